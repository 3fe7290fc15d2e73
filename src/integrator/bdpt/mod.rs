//! Bidirectional path tracing (the `bdpt` integrator; Veach 1997, ch. 10) and
//! the light tracer it contains (`ptracer`, [`super::ptracer`]).
//!
//! Per camera sample, a camera subpath (the pinhole, then up to `max_depth` surface
//! vertices, or the environment when a ray escapes) and a light subpath (a point on
//! a light chosen by power, then up to `max_depth − 1` surface vertices) are traced
//! with the same pixel sampler, and every prefix pair (s light vertices, t camera
//! vertices) is connected, when the path's s + t − 1 segments are at most
//! `max_depth` (Mitsuba's convention, as `path`):
//! * s = 0: the camera subpath's last vertex is an emitter (or the environment);
//! * s = 1: a light sampled from the camera vertex (next-event estimation);
//! * t = 1: a light-subpath vertex connected to the pinhole, splatted to the film
//!   position it projects to (the film scales splats by 1/spp and by the filter);
//! * s, t ≥ 2: a shadow ray between the two subpaths' ends.
//!
//! Paths of one segment come from s = 0 alone (emitters seen directly); s = 1,
//! t = 1 is the light tracer's alone. Strategies are weighted by the power (or
//! balance) heuristic over area-measure densities ([`mis`]); specular vertices
//! (glass, refraction) and delta lights take part with Dirac densities, i.e.
//! strategies that would have to connect at them are left out of the sum: no
//! camera subpath reaches a point or spot light (a delta position) or a
//! directional light (a delta direction), so s = 0 is impossible for them, and the
//! camera cannot see them either (no s = 1, t = 1). As in pbrt-v4, a directional
//! light's subpath starts on a disk covering the scene, and the density of its
//! first surface vertex is the disk's 1/πR² times the cosine there.
//!
//! Light subpaths carry importance: their BSDFs are adjoint — `glass` refraction
//! without the radiance's (η_o/η_i)², `refraction` with it — and corrected for
//! shading normals (Veach §5.3). Russian roulette as in `path`: from the 5th
//! segment on, a subpath continues with probability min(0.95, throughput) (the
//! light subpath's throughput relative to its start), survivors reweighted.

pub mod mis;
pub mod strategies;
pub mod vertex;

use super::{CameraSample, RayCounts};
use crate::geometry::ray::RAY_T_MAX;
use crate::geometry::{Ray, RayDifferential};
use crate::light::SceneBounds;
use crate::material::TransportMode;
use crate::math::{offset_ray_origin, Vec2, Vec3};
use crate::sampler::PixelSampler;
pub use mis::{Heuristic, PathDensities};
use vertex::{shading_correction, Ctx, Kind, Vertex};

/// Segment from which Russian roulette may end subpaths (as `path`).
const RR_DEPTH: usize = 5;

/// Default of `connection_roulette`: measured on `caustic_cbox` (32 spp, three
/// seeds, instructions by callgrind), 0.3 costs 12 % fewer instructions per sample
/// for 1.7 % more error (1.0: 16 % and 11 %).
pub const CONNECTION_ROULETTE: f32 = 0.3;

/// Parameters (JSON `integrator` keys, besides `type` and `spp`):
/// * `max_depth` (int ≥ 1, 12) — path segments, the camera ray being the first,
///   as `path` (so both converge to the same image);
/// * `rr_threshold` (number, 0.1), `profile` (as `path`'s) — read and kept; roulette
///   follows `path`'s rule, so the converged image depends on neither;
/// * `mis` (`"power"` | `"balance"`, `"power"`) — the MIS heuristic;
/// * `strategy` ([s, t], none) — debugging view: render only the paths of strategy
///   (s, t) (s + t − 1 segments), unweighted (each strategy alone converges to the
///   same image as the other strategies of its length), or with
///   `strategy_weighted` (bool, false) its MIS-weighted share of the full image
///   (the shares of all strategies add up to the `bdpt` image);
/// * `visualize_strategies` (bool, false) — pbrt-v4's view: one render writes, beside
///   the `bdpt` image `OUT.exr`, every strategy's MIS-weighted share to
///   `OUT.s{s}_t{t}.exr` (s + t − 1 ≤ `max_depth`; see [`strategies`]); not with `strategy`;
/// * `connection_roulette` (number ≥ 0, 0.3) — a connection (s ≥ 1, t ≥ 2) whose
///   unweighted contribution is below this share of what the sample's earlier
///   strategies found is traced (weighted and tested for visibility) only with
///   probability contribution/threshold, and divided by it: unbiased, and most of a
///   diffuse room's long connections carry little. 0 traces every connection;
///   `strategy` renders never roulette (so they add up to the image only with 0).
///
/// ```json
/// {"type": "bdpt", "spp": 64, "max_depth": 12, "strategy": [2, 2]}
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bdpt {
    pub max_depth: u32,
    pub rr_threshold: f32,
    pub heuristic: Heuristic,
    pub strategy: Option<(u32, u32)>,
    pub strategy_weighted: bool,
    pub visualize_strategies: bool,
    pub connection_roulette: f32,
}

impl Bdpt {
    pub fn new(max_depth: u32) -> Bdpt {
        Bdpt {
            max_depth,
            rr_threshold: 0.1,
            heuristic: Heuristic::Power,
            strategy: None,
            strategy_weighted: false,
            visualize_strategies: false,
            connection_roulette: CONNECTION_ROULETTE,
        }
    }

    /// One camera sample: its radiance; light-tracing contributions go to `s.splats`.
    pub fn li(&self, scene: &crate::scene::Scene, camera: &crate::camera::Camera, s: &mut CameraSample) -> Vec3 {
        let e = Engine {
            ctx: ctx(scene, camera),
            max_depth: self.max_depth as usize,
            heuristic: self.heuristic,
            select: match self.strategy {
                Some((s, t)) => Select::Only(s as usize, t as usize, self.strategy_weighted),
                None => Select::All,
            },
            roulette: self.connection_roulette,
        };
        e.sample(s)
    }
}

/// The light tracer's sample (`ptracer`): see [`super::ptracer`].
pub(crate) fn light_tracing_sample(
    max_depth: u32,
    scene: &crate::scene::Scene,
    camera: &crate::camera::Camera,
    s: &mut CameraSample,
) -> Vec3 {
    let e = Engine {
        ctx: ctx(scene, camera),
        max_depth: max_depth as usize,
        heuristic: Heuristic::Power,
        select: Select::LightTracing,
        roulette: 0.0,
    };
    e.sample(s)
}

fn ctx<'a>(scene: &'a crate::scene::Scene, camera: &'a crate::camera::Camera) -> Ctx<'a> {
    Ctx {
        scene,
        camera,
        bounds: SceneBounds {
            center: scene.center,
            radius: scene.radius,
        },
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Select {
    All,
    /// One strategy (s, t), MIS-weighted or not.
    Only(usize, usize, bool),
    /// Light tracing: every t = 1 strategy unweighted, and the environment seen directly.
    LightTracing,
    /// Every strategy MIS-weighted, each to its own image ([`strategies`]).
    Each,
}

thread_local! {
    /// Per-thread camera and light subpaths, reused across samples.
    static BUFFERS: std::cell::Cell<(Vec<Vertex>, Vec<Vertex>)> = const { std::cell::Cell::new((Vec::new(), Vec::new())) };
}

struct Engine<'a> {
    ctx: Ctx<'a>,
    max_depth: usize,
    heuristic: Heuristic,
    select: Select,
    /// `connection_roulette` (0: off; never for one strategy alone).
    roulette: f32,
}

impl Engine<'_> {
    fn sample(&self, cs: &mut CameraSample) -> Vec3 {
        let mut l = Vec3::ZERO;
        let splats = &mut *cs.splats;
        self.sample_each(cs.ray, cs.diff, cs.sampler, cs.counts, |_, _, c, pos| match pos {
            Some(pos) => splats.add(pos, c),
            None => l += c,
        });
        l
    }

    /// One camera sample, each strategy's (weighted, as `select` says) contribution
    /// handed to `sink` as (s, t, value, film position of a t = 1 splat).
    fn sample_each(
        &self,
        ray: Ray,
        diff: Option<RayDifferential>,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
        sink: impl FnMut(usize, usize, Vec3, Option<Vec2>),
    ) {
        // the subpaths reuse this thread's buffers (taken, so a
        // nested sample would only start with empty ones)
        let (mut cam, mut light) = BUFFERS.take();
        cam.clear();
        light.clear();
        self.sample_with(ray, diff, sampler, counts, &mut cam, &mut light, sink);
        BUFFERS.set((cam, light));
    }

    #[allow(clippy::too_many_arguments)]
    fn sample_with(
        &self,
        ray: Ray,
        diff: Option<RayDifferential>,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
        cam: &mut Vec<Vertex>,
        light: &mut Vec<Vertex>,
        mut sink: impl FnMut(usize, usize, Vec3, Option<Vec2>),
    ) {
        let ctx = &self.ctx;
        let light_tracing = self.select == Select::LightTracing;
        // the pinhole, or the lens point the camera ray leaves
        let mut camera_vertex = Vertex::new(Kind::Camera, ray.o, Vec3::ZERO, Vec3::ONE);
        camera_vertex.pdf_fwd = 1.0;
        cam.push(camera_vertex);
        // the light tracer only looks for the environment behind its first segment
        let cam_max = if light_tracing { 2 } else { self.max_depth + 1 };
        let pdf_dir = ctx.camera.pdf_dir_from(ray.o, ray.d);
        self.walk(
            ray,
            diff,
            Vec3::ONE,
            pdf_dir,
            TransportMode::Radiance,
            cam_max,
            cam,
            sampler,
            counts,
        );
        self.light_subpath(light, sampler, counts);

        let mut acc = 0.0f32;
        for t in 1..=cam.len() {
            for s in 0..=light.len() {
                let segments = s + t - 1;
                if segments == 0 || segments > self.max_depth {
                    continue;
                }
                let weighted = match self.select {
                    Select::All | Select::Each => true,
                    Select::Only(s0, t0, w) if (s0, t0) == (s, t) => w,
                    Select::Only(..) => continue,
                    Select::LightTracing => {
                        let env_seen = s == 0 && t == 2 && cam[1].infinite;
                        if t != 1 && !env_seen {
                            continue;
                        }
                        false
                    }
                };
                // one-segment paths: s = 0 (the light tracer: s = 1 for surfaces)
                if (s, t) == (1, 1) && weighted {
                    continue;
                }
                let rr = (self.roulette > 0.0 && matches!(self.select, Select::All | Select::Each) && t > 1).then_some(self.roulette * acc);
                let Some((c, pos)) = self.connect(light, cam, s, t, sampler, counts, weighted, rr) else {
                    continue;
                };
                if pos.is_none() {
                    acc += crate::math::luminance(c);
                }
                sink(s, t, c, pos);
            }
        }
    }

    /// Traces a subpath from `ray` and appends its vertices to `path` (which holds
    /// the vertex the ray leaves), at most `max_vertices` in all.
    #[allow(clippy::too_many_arguments)]
    fn walk(
        &self,
        mut ray: Ray,
        diff: Option<RayDifferential>,
        mut beta: Vec3,
        mut pdf_dir: f32,
        mode: TransportMode,
        max_vertices: usize,
        path: &mut Vec<Vertex>,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
    ) {
        let scene = self.ctx.scene;
        // roulette judges the throughput relative to the start, without refraction's η²
        let rr_norm = 1.0 / beta.max_element();
        let mut eta_scale = 1.0f32;
        while path.len() < max_vertices {
            counts.rays += 1;
            let Some(hit) = scene.intersect(&ray) else {
                if let (TransportMode::Radiance, Some(env)) = (mode, scene.environment) {
                    let mut v = Vertex::new(Kind::Light(env), ray.o, ray.d, beta);
                    v.infinite = true;
                    v.pdf_fwd = pdf_dir;
                    path.push(v);
                }
                break;
            };
            let mut it = scene.interaction(&ray, &hit);
            if let (1, Some(d)) = (path.len(), &diff) {
                it.compute_uv_derivatives(d);
            }
            let mut v = Vertex::new(Kind::Surface, it.p, it.ng, beta);
            v.ns = it.ns;
            v.wo = it.wo;
            v.emitter = scene.area_light_of(&it).map(|(i, _)| i);
            v.uv = it.uv;
            v.pdf_fwd = self.ctx.convert(pdf_dir, &path[path.len() - 1], &v);
            v.bsdf = scene.material_of(&it).map(|m| m.bsdf_at(&it, &scene.textures));
            let bsdf = v.bsdf.clone();
            path.push(v);
            let Some(bsdf) = bsdf else { break };
            if path.len() >= max_vertices {
                break;
            }
            let uc = sampler.next_1d();
            let Some(bs) = bsdf.sample_mode(it.wo, Vec2::from(sampler.next_2d()), uc, mode) else {
                break;
            };
            let mut weight = bs.weight;
            if mode == TransportMode::Importance {
                weight *= shading_correction(it.wo, bs.wi, it.ns, it.ng);
            }
            beta *= weight;
            let (pdf_fwd, pdf_rev) = if bs.delta { (0.0, 0.0) } else { (bs.pdf, bsdf.pdf(bs.wi, it.wo)) };
            let n = path.len();
            path[n - 1].delta = bs.delta;
            path[n - 2].pdf_rev = self.ctx.convert(pdf_rev, &path[n - 1], &path[n - 2]);
            if beta == Vec3::ZERO || !beta.is_finite() {
                break;
            }
            if mode == TransportMode::Radiance {
                eta_scale *= bs.eta * bs.eta;
            }
            let segments = n - 1; // so far, the camera ray or the light's ray first
            if segments >= RR_DEPTH {
                let q = (beta.max_element() * rr_norm * eta_scale).min(0.95);
                if sampler.next_1d() >= q {
                    break;
                }
                beta /= q;
            }
            let n_off = if bs.wi.dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
            ray = Ray::with_range(offset_ray_origin(it.p, n_off), bs.wi, 0.0, RAY_T_MAX);
            pdf_dir = pdf_fwd;
        }
    }

    /// A light subpath: a light chosen by power, a ray leaving it, its walk.
    fn light_subpath(&self, path: &mut Vec<Vertex>, sampler: &mut PixelSampler, counts: &mut RayCounts) {
        let ctx = &self.ctx;
        let scene = ctx.scene;
        if scene.lights.is_empty() || self.max_depth == 0 {
            return;
        }
        let (index, pmf, _) = scene.light_sampler.sample(sampler.next_1d());
        let (u_pos, u_dir) = (Vec2::from(sampler.next_2d()), Vec2::from(sampler.next_2d()));
        let light = &scene.lights[index];
        let Some(es) = light.sample_emission(u_pos, u_dir, ctx.bounds) else {
            return;
        };
        if pmf <= 0.0 || es.pdf_pos <= 0.0 || es.pdf_dir <= 0.0 || es.le == Vec3::ZERO {
            return;
        }
        let mut v = Vertex::new(
            Kind::Light(index as u32),
            es.p,
            es.n.unwrap_or(Vec3::ZERO),
            Vec3::splat(1.0 / (pmf * es.pdf_pos)),
        );
        v.uv = es.uv;
        if light.is_infinite() {
            v.infinite = true;
            v.ng = -es.dir;
        }
        v.pdf_fwd = ctx.pdf_light_origin(&v);
        path.push(v);
        let cos = es.n.map_or(1.0, |n| n.dot(es.dir).abs());
        let beta = es.le * (cos / (pmf * es.pdf_pos * es.pdf_dir));
        let o = match es.n {
            Some(n) if !light.is_infinite() => offset_ray_origin(es.p, n),
            _ => es.p,
        };
        let ray = Ray::with_range(o, es.dir, 0.0, RAY_T_MAX);
        self.walk(
            ray,
            None,
            beta,
            es.pdf_dir,
            TransportMode::Importance,
            self.max_depth,
            path,
            sampler,
            counts,
        );
        if path.len() > 1 {
            path[1].pdf_fwd = ctx.pdf_light(&path[0], &path[1]);
        }
    }

    /// Strategy (s, t): its contribution (MIS-weighted when `weighted`) and, for
    /// t = 1, the film position to splat it to.
    #[allow(clippy::too_many_arguments)]
    fn connect(
        &self,
        light: &[Vertex],
        cam: &[Vertex],
        s: usize,
        t: usize,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
        weighted: bool,
        rr: Option<f32>,
    ) -> Option<(Vec3, Option<Vec2>)> {
        let ctx = &self.ctx;
        let scene = ctx.scene;
        let mut sampled = None;
        let mut pos = None;
        let mut l;
        if s == 0 {
            let pt = &cam[t - 1];
            pt.light()?;
            l = pt.beta * ctx.emitted(pt, pt.dir_to(&cam[t - 2]));
            if l == Vec3::ZERO {
                return None;
            }
        } else if t == 1 {
            let qs = &light[s - 1];
            if !qs.connectible() || qs.infinite || (s == 1 && scene.lights[qs.light()? as usize].is_delta_position()) {
                return None;
            }
            // a thin lens: a point on it, drawn uniformly (its area density cancels
            // against the lens area in the importance)
            let lens = if ctx.camera.has_lens() {
                let mut c = Vertex::new(
                    Kind::Camera,
                    ctx.camera.lens_point(Vec2::from(sampler.next_2d())),
                    Vec3::ZERO,
                    Vec3::ONE,
                );
                c.pdf_fwd = 1.0 / ctx.camera.lens_area();
                c
            } else {
                cam[0].clone()
            };
            let (p, cos_cam) = ctx.camera.project_from(lens.p, qs.p)?;
            let v = lens.p - qs.p;
            let d2 = v.length_squared();
            let w = v / d2.sqrt();
            // We·cos_cam = 1/(A cos³θ): the pinhole's importance (1/(A cos⁴θ)) times its
            // cosine; a lens's 1/(A·lens_area·cos⁴θ) times cos over its density 1/lens_area
            let we = 1.0 / (ctx.camera.image_plane_area() * cos_cam * cos_cam * cos_cam);
            let f = if s == 1 {
                ctx.emitted(qs, w)
            } else {
                qs.f(w, TransportMode::Importance)
            };
            l = qs.beta * f * (qs.cos(w) * we / d2);
            if l == Vec3::ZERO {
                return None;
            }
            l = self.through(l, qs, &lens, counts)?;
            sampled = Some(lens);
            pos = Some(p);
        } else if s == 1 {
            let pt = &cam[t - 1];
            if !pt.connectible() || scene.lights.is_empty() {
                return None;
            }
            let (index, pmf, _) = scene.light_sampler.sample(sampler.next_1d());
            let ls = scene.lights[index].sample(pt.p, Vec2::from(sampler.next_2d()), scene.light_sampling)?;
            if ls.pdf <= 0.0 || pmf <= 0.0 {
                return None;
            }
            let mut q = match ls.target {
                crate::light::ShadowTarget::Infinity => {
                    let mut q = Vertex::new(Kind::Light(index as u32), pt.p, ls.wi, Vec3::ONE);
                    q.infinite = true;
                    q
                }
                crate::light::ShadowTarget::Point { p, n } => Vertex::new(Kind::Light(index as u32), p, n.unwrap_or(Vec3::ZERO), Vec3::ONE),
            };
            q.pdf_fwd = ctx.pdf_light_origin(&q);
            l = pt.beta * pt.f(ls.wi, TransportMode::Radiance) * ls.radiance * (pt.cos(ls.wi) / (pmf * ls.pdf));
            if l == Vec3::ZERO {
                return None;
            }
            if let Some(tau) = rr {
                l = self.roulette(l, tau, sampler, s, t)?;
            }
            l = self.through(l, pt, &q, counts)?;
            sampled = Some(q);
        } else {
            let (qs, pt) = (&light[s - 1], &cam[t - 1]);
            if !qs.connectible() || !pt.connectible() {
                return None;
            }
            let v = pt.p - qs.p;
            let d2 = v.length_squared();
            if d2 == 0.0 {
                return None;
            }
            let w = v / d2.sqrt();
            l = qs.beta * qs.f(w, TransportMode::Importance) * pt.f(-w, TransportMode::Radiance) * pt.beta * (qs.cos(w) * pt.cos(w) / d2);
            if l == Vec3::ZERO {
                return None;
            }
            if let Some(tau) = rr {
                l = self.roulette(l, tau, sampler, s, t)?;
            }
            l = self.through(l, qs, pt, counts)?;
        }
        if !weighted {
            return Some((l, pos));
        }
        let w = self.connection(light, cam, s, t, sampled.as_ref()).weight(self.heuristic);
        Some((l * w, pos))
    }

    /// `connection_roulette`: a contribution below `tau` survives with probability
    /// (its luminance)/`tau` and is divided by it; the number is keyed by (s, t), so
    /// it does not depend on what other strategies drew.
    fn roulette(&self, c: Vec3, tau: f32, sampler: &PixelSampler, s: usize, t: usize) -> Option<Vec3> {
        let y = crate::math::luminance(c);
        // (NaN and non-positive luminance pass untouched)
        if y.is_nan() || y >= tau || y <= 0.0 {
            return Some(c);
        }
        let q = y / tau;
        (sampler.keyed_1d((s as u32) << 16 | t as u32) < q).then(|| c / q)
    }

    /// The contribution `l` of a connection between two vertices times the
    /// fraction of light passing between them ([`crate::scene::Scene::transmittance`]: 1 or 0
    /// unless masks lie between); `None` when nothing passes.
    fn through(&self, l: Vec3, a: &Vertex, b: &Vertex, counts: &mut RayCounts) -> Option<Vec3> {
        let tr = self.transmittance(a, b, counts);
        (tr > 0.0).then(|| l * tr)
    }

    /// The fraction of light passing between two vertices (either may be at infinity).
    fn transmittance(&self, a: &Vertex, b: &Vertex, counts: &mut RayCounts) -> f32 {
        counts.rays += 1;
        let (a, b) = if a.infinite { (b, a) } else { (a, b) };
        let ray = if b.infinite {
            Ray::with_range(a.origin_towards(b.ng), b.ng, 0.0, RAY_T_MAX)
        } else {
            let (oa, ob) = (a.origin_towards(b.p - a.p), b.origin_towards(a.p - b.p));
            let v = ob - oa;
            let dist = v.length();
            if dist == 0.0 {
                return 0.0;
            }
            Ray::with_range(oa, v / dist, 0.0, dist * (1.0 - 1e-5))
        };
        self.ctx.scene.transmittance(&ray)
    }

    /// The densities of the path strategy (s, t) made, from the subpaths' cached
    /// densities and the four the connection changes (pbrt-v4's `MISWeight` scheme),
    /// read in place by [`Connection::weight`].
    fn connection<'v>(&self, light: &'v [Vertex], cam: &'v [Vertex], s: usize, t: usize, sampled: Option<&'v Vertex>) -> Connection<'v> {
        let ctx = &self.ctx;
        let mut c = Connection {
            light,
            cam,
            s,
            t,
            sampled,
            light_s: 0.0,
            light_s1: 0.0,
            cam_s1: 0.0,
            cam_s2: 0.0,
            delta_light: false,
        };
        let pt = c.cv(t - 1);
        let pt_minus = (t > 1).then(|| c.cv(t - 2));
        let qs = (s > 0).then(|| c.lv(s - 1));
        let qs_minus = (s > 1).then(|| c.lv(s - 2));
        // the four densities the connection changes, two at each connection vertex
        match (qs, qs_minus) {
            (Some(q), Some(qm)) => (c.light_s, c.cam_s2) = ctx.pdf_pair(q, qm, pt),
            (Some(q), None) => c.light_s = ctx.pdf(q, None, pt),
            (None, _) => c.light_s = ctx.pdf_light_origin(pt),
        }
        match (qs, pt_minus) {
            (Some(q), Some(pm)) => (c.cam_s1, c.light_s1) = ctx.pdf_pair(pt, pm, q),
            (Some(q), None) => c.cam_s1 = ctx.pdf(pt, None, q),
            (None, Some(pm)) => c.light_s1 = ctx.pdf_light(pt, pm),
            (None, None) => {}
        }
        let x0 = if s > 0 { c.lv(0) } else { pt };
        c.delta_light = x0.light().is_some_and(|i| ctx.scene.lights[i as usize].is_delta());
        c
    }

    /// [`Engine::connection`]'s densities collected (for checking them).
    fn densities(&self, light: &[Vertex], cam: &[Vertex], s: usize, t: usize, sampled: Option<&Vertex>, d: &mut PathDensities) {
        let c = self.connection(light, cam, s, t, sampled);
        d.clear();
        for i in 0..s + t {
            let (pl, pe, delta) = c.at(i);
            d.push(pl, pe, delta);
        }
        d.delta_light = c.delta_light;
    }
}

/// The path of strategy (s, t): the subpaths' prefixes, the vertex the connection
/// sampled (s = 1: a light; t = 1: the pinhole), and the densities it changes.
struct Connection<'v> {
    light: &'v [Vertex],
    cam: &'v [Vertex],
    s: usize,
    t: usize,
    sampled: Option<&'v Vertex>,
    /// p_L of x_s and x_{s+1}; p_E of x_{s−1} and x_{s−2}.
    light_s: f32,
    light_s1: f32,
    cam_s1: f32,
    cam_s2: f32,
    delta_light: bool,
}

impl<'v> Connection<'v> {
    #[inline(always)]
    fn lv(&self, i: usize) -> &'v Vertex {
        match self.sampled {
            Some(v) if self.s == 1 && i == 0 => v,
            _ => &self.light[i],
        }
    }

    #[inline(always)]
    fn cv(&self, j: usize) -> &'v Vertex {
        match self.sampled {
            Some(v) if self.t == 1 && j == 0 => v,
            _ => &self.cam[j],
        }
    }

    /// Path vertex `i` (0 at the light): (p_L, p_E, specular).
    #[inline(always)]
    fn at(&self, i: usize) -> (f32, f32, bool) {
        let s = self.s;
        if i < s {
            let v = self.lv(i);
            match s - i {
                1 => (v.pdf_fwd, self.cam_s1, false),
                2 => (v.pdf_fwd, self.cam_s2, v.delta),
                _ => (v.pdf_fwd, v.pdf_rev, v.delta),
            }
        } else {
            let v = self.cv(s + self.t - 1 - i);
            match i - s {
                0 => (self.light_s, v.pdf_fwd, false),
                1 => (self.light_s1, v.pdf_fwd, v.delta),
                _ => (v.pdf_rev, v.pdf_fwd, v.delta),
            }
        }
    }

    fn weight(&self, heuristic: Heuristic) -> f32 {
        mis::weight_of(self.s + self.t, self.s, self.delta_light, heuristic, |i| self.at(i))
    }
}

/// The densities of a whole path x₀ (light) … x_{n−1} (camera) recomputed from its
/// geometry alone, for checking the cached ones.
fn recomputed(ctx: &Ctx, x: &[&Vertex]) -> PathDensities {
    let n = x.len();
    let mut d = PathDensities::default();
    for i in 0..n {
        let pl = match i {
            0 => ctx.pdf_light_origin(x[0]),
            1 => ctx.pdf_light(x[0], x[1]),
            _ => ctx.pdf(x[i - 1], Some(x[i - 2]), x[i]),
        };
        let pe = if i == n - 1 {
            1.0
        } else {
            ctx.pdf(x[i + 1], (i + 2 < n).then(|| x[i + 2]), x[i])
        };
        d.push(pl, pe, x[i].delta && i > 0 && i < n - 1);
    }
    d.delta_light = x[0].light().is_some_and(|i| ctx.scene.lights[i as usize].is_delta());
    d
}

/// What [`mis_self_check`] found.
#[derive(Clone, Copy, Debug, Default)]
pub struct MisCheck {
    /// Connections (paths) checked.
    pub paths: usize,
    /// Largest |Σ_s w_s − 1| over the strategies that could make each path.
    pub max_sum_error: f32,
    /// Largest relative difference between the cached densities a connection
    /// assembles and those recomputed from the path's geometry.
    pub max_density_error: f32,
    /// Camera samples with a path whose density is off by more than 1 % (relative).
    /// Vertices close to each other at grazing angles (in corners) differ by
    /// 0.1–10 %: the sampled direction is the ray's, the recomputed one joins the
    /// (rounded) hit points.
    pub samples_off: usize,
}

/// Checks the MIS of `bdpt` on random paths of a scene: for `samples` camera
/// samples (random film positions), every connection (s, t) that carries light is
/// taken as a path; the weights of all strategies that could have made it must sum
/// to 1, and the densities the connection assembled must equal those recomputed
/// from the vertices alone (specular vertices excepted: density 0 either way).
pub fn mis_self_check(
    scene: &crate::scene::Scene,
    camera: &crate::camera::Camera,
    width: u32,
    height: u32,
    max_depth: u32,
    samples: u32,
) -> MisCheck {
    let e = Engine {
        ctx: ctx(scene, camera),
        max_depth: max_depth as usize,
        heuristic: Heuristic::Power,
        select: Select::All,
        roulette: 0.0,
    };
    let mut out = MisCheck::default();
    let mut counts = RayCounts::default();
    let mut d = PathDensities::default();
    for i in 0..samples {
        let mut sampler = PixelSampler::new(i % width, (i / width) % height, i, 77);
        let (u, v) = sampler.next_2d();
        let ray = camera.ray(u * width as f32, v * height as f32);
        let mut cam = vec![Vertex::new(Kind::Camera, camera.position, Vec3::ZERO, Vec3::ONE)];
        cam[0].pdf_fwd = 1.0;
        e.walk(
            ray,
            None,
            Vec3::ONE,
            camera.pdf_dir(ray.d),
            TransportMode::Radiance,
            e.max_depth + 1,
            &mut cam,
            &mut sampler,
            &mut counts,
        );
        let mut light = Vec::new();
        e.light_subpath(&mut light, &mut sampler, &mut counts);
        let mut sample_off = false;
        for t in 1..=cam.len() {
            for s in 0..=light.len() {
                let n = s + t;
                if n < 3 || n - 1 > e.max_depth {
                    continue;
                }
                let mut probe = sampler;
                let Some((c, _)) = e.connect(&light, &cam, s, t, &mut probe, &mut counts, false, None) else {
                    continue;
                };
                if c == Vec3::ZERO {
                    continue;
                }
                // the vertex a connection samples (s = 1: a light; t = 1: the pinhole)
                let mut sampled = None;
                if s == 1 && t > 1 {
                    let mut probe = sampler;
                    let (index, _, _) = scene.light_sampler.sample(probe.next_1d());
                    let Some(ls) = scene.lights[index].sample(cam[t - 1].p, Vec2::from(probe.next_2d()), scene.light_sampling) else {
                        continue;
                    };
                    let mut q = match ls.target {
                        crate::light::ShadowTarget::Infinity => {
                            let mut q = Vertex::new(Kind::Light(index as u32), cam[t - 1].p, ls.wi, Vec3::ONE);
                            q.infinite = true;
                            q
                        }
                        crate::light::ShadowTarget::Point { p, n } => {
                            Vertex::new(Kind::Light(index as u32), p, n.unwrap_or(Vec3::ZERO), Vec3::ONE)
                        }
                    };
                    q.pdf_fwd = e.ctx.pdf_light_origin(&q);
                    sampled = Some(q);
                } else if t == 1 {
                    sampled = Some(cam[0].clone());
                }
                e.densities(&light, &cam, s, t, sampled.as_ref(), &mut d);
                let mut x: Vec<&Vertex> = Vec::with_capacity(n);
                for i in 0..s {
                    x.push(if s == 1 { sampled.as_ref().unwrap_or(&light[0]) } else { &light[i] });
                }
                for j in (0..t).rev() {
                    x.push(if t == 1 { sampled.as_ref().unwrap_or(&cam[0]) } else { &cam[j] });
                }
                let fresh = recomputed(&e.ctx, &x);
                let mut off = false;
                for i in 0..n {
                    if fresh.delta[i] || (i > 0 && fresh.delta[i - 1]) || (i + 1 < n && fresh.delta[i + 1]) {
                        continue; // densities next to specular vertices are conventions
                    }
                    for (a, b) in [(d.light[i], fresh.light[i]), (d.camera[i], fresh.camera[i])] {
                        let err = (a - b).abs() / a.abs().max(b.abs()).max(1e-20);
                        out.max_density_error = out.max_density_error.max(err);
                        off |= err > 1e-2;
                    }
                }
                let sum: f32 = (0..n).filter(|&k| d.possible(k)).map(|k| d.weight(k, Heuristic::Power)).sum();
                out.max_sum_error = out.max_sum_error.max((sum - 1.0).abs());
                out.paths += 1;
                sample_off |= off;
            }
        }
        out.samples_off += sample_off as usize;
    }
    out
}
