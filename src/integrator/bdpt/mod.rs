//! Bidirectional path tracing (the `bdpt` integrator; Veach 1997, ch. 10) and
//! the light tracer it contains (`ptracer`, [`super::ptracer`]).
//!
//! Per camera sample, a camera subpath (the pinhole, then up to `max_depth` surface
//! vertices, or the environment when a ray escapes) and a light subpath (a point on
//! a light chosen as `path` chooses it, then up to `max_depth − 1` surface vertices) are traced
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
//!
//! In media, scattering points are vertices of either subpath and connections carry
//! the media's transmittance (the `media` module). Light emitted by a medium is found by
//! the camera subpath alone (an s = 0 strategy of weight 1: no light subpath starts in
//! a medium's volume); the light tracer (`ptracer`) cannot see it.

mod check;
mod connect;
mod media;
pub mod mis;
pub mod strategies;
pub mod vertex;

use super::{spawn_ray, CameraSample, RayCounts};
use crate::camera::Camera;
use crate::geometry::ray::RAY_T_MAX;
use crate::geometry::{Ray, RayDifferential};
use crate::light::SceneBounds;
use crate::material::{Normals, TransportMode};
use crate::math::{offset_ray_origin, Vec2, Vec3};
use crate::sampler::PixelSampler;
use crate::scene::Scene;
pub use check::{mis_self_check, MisCheck};
pub use mis::{Heuristic, PathDensities};
use vertex::{Ctx, Kind, Vertex};

/// Segment from which Russian roulette may end subpaths (as `path`).
const RR_DEPTH: usize = 5;

/// Default of `connection_roulette`: measured on `caustic_cbox` (32 spp, three
/// seeds, instructions by callgrind), 0.3 costs 12 % fewer instructions per sample
/// for 1.7 % more error (1.0: 16 % and 11 %).
pub const CONNECTION_ROULETTE: f32 = 0.3;

/// Parameters (JSON `integrator` keys, besides `type` and `spp`):
/// * `max_depth` (int ≥ 1, 12) — path segments, the camera ray being the first,
///   as `path` (so both converge to the same image);
/// * `rr_threshold` (number, 0.1; kept) and `profile` (as `path`'s; checked) — read;
///   roulette follows `path`'s rule, so the converged image depends on neither;
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
    pub fn li(&self, scene: &Scene, camera: &Camera, s: &mut CameraSample) -> Vec3 {
        let select = match self.strategy {
            Some((s, t)) => Select::Only(s as usize, t as usize, self.strategy_weighted),
            None => Select::All,
        };
        Engine::new(scene, camera, self.max_depth, self.heuristic, select, self.connection_roulette).sample(s)
    }
}

/// The light tracer's sample (`ptracer`): see [`super::ptracer`].
pub(crate) fn light_tracing_sample(max_depth: u32, scene: &Scene, camera: &Camera, s: &mut CameraSample) -> Vec3 {
    Engine::new(scene, camera, max_depth, Heuristic::Power, Select::LightTracing, 0.0).sample(s)
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

/// A sample's camera and light subpaths, and the light its camera subpath found
/// emitted by media, as (t, radiance): t − 1 the segment along which it was emitted.
type Buffers = (Vec<Vertex>, Vec<Vertex>, Vec<(usize, Vec3)>);

thread_local! {
    /// Per-thread camera and light subpaths, reused across samples.
    static BUFFERS: std::cell::Cell<Buffers> = const { std::cell::Cell::new((Vec::new(), Vec::new(), Vec::new())) };
}

struct Engine<'a> {
    ctx: Ctx<'a>,
    max_depth: usize,
    heuristic: Heuristic,
    select: Select,
    /// `connection_roulette` (0: off; never for one strategy alone).
    roulette: f32,
}

impl<'a> Engine<'a> {
    fn new(scene: &'a Scene, camera: &'a Camera, max_depth: u32, heuristic: Heuristic, select: Select, roulette: f32) -> Self {
        let bounds = SceneBounds {
            center: scene.center,
            radius: scene.radius,
        };
        Engine {
            ctx: Ctx { scene, camera, bounds },
            max_depth: max_depth as usize,
            heuristic,
            select,
            roulette,
        }
    }

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
        mut sink: impl FnMut(usize, usize, Vec3, Option<Vec2>),
    ) {
        // the subpaths reuse this thread's buffers (taken, so a
        // nested sample would only start with empty ones)
        let (mut cam, mut light, mut glow) = BUFFERS.take();
        cam.clear();
        light.clear();
        glow.clear();
        // the light tracer only looks for the environment behind its first segment
        let cam_max = if self.select == Select::LightTracing {
            2
        } else {
            self.max_depth + 1
        };
        self.camera_subpath(ray, diff, cam_max, &mut cam, &mut glow, sampler, counts);
        self.light_subpath(&mut light, sampler, counts);

        let mut acc = 0.0f32;
        // medium emission: only s = 0 makes it, weight 1 (weighted or not)
        for &(t, le) in &glow {
            if self.select != Select::LightTracing && self.selected(0, t, &cam).is_some() {
                acc += crate::math::luminance(le);
                sink(0, t, le, None);
            }
        }
        for t in 1..=cam.len() {
            for s in 0..=light.len() {
                let Some(weighted) = self.selected(s, t, &cam) else { continue };
                let rr = (self.roulette > 0.0 && matches!(self.select, Select::All | Select::Each) && t > 1).then_some(self.roulette * acc);
                let Some((c, pos)) = self.connect(&light, &cam, s, t, sampler, counts, weighted, rr) else {
                    continue;
                };
                if pos.is_none() {
                    acc += crate::math::luminance(c);
                }
                sink(s, t, c, pos);
            }
        }
        BUFFERS.set((cam, light, glow));
    }

    /// Whether the sample evaluates strategy (s, t), and MIS-weighted or not
    /// (`cam`: the camera subpath, for the light tracer's view of the environment).
    fn selected(&self, s: usize, t: usize, cam: &[Vertex]) -> Option<bool> {
        let segments = s + t - 1;
        if segments == 0 || segments > self.max_depth {
            return None;
        }
        let weighted = match self.select {
            Select::All | Select::Each => true,
            Select::Only(s0, t0, w) if (s0, t0) == (s, t) => w,
            Select::Only(..) => return None,
            Select::LightTracing => {
                let env_seen = s == 0 && t == 2 && cam[1].infinite;
                if t != 1 && !env_seen {
                    return None;
                }
                false
            }
        };
        // one-segment paths: s = 0 (the light tracer: s = 1 for surfaces)
        (!((s, t) == (1, 1) && weighted)).then_some(weighted)
    }

    /// A camera subpath of at most `max_vertices`: the pinhole (or the lens point the
    /// camera ray leaves), then the walk of `ray`; the light media emit along it to `glow`.
    #[allow(clippy::too_many_arguments)]
    fn camera_subpath(
        &self,
        ray: Ray,
        diff: Option<RayDifferential>,
        max_vertices: usize,
        cam: &mut Vec<Vertex>,
        glow: &mut Vec<(usize, Vec3)>,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
    ) {
        let (camera, medium) = (self.ctx.camera, self.ctx.scene.camera_medium);
        let mut v = Vertex::new(Kind::Camera, ray.o, Vec3::ZERO, Vec3::ONE);
        v.pdf_fwd = 1.0;
        v.set_media([medium; 2]);
        cam.push(v);
        let pdf_dir = camera.pdf_dir_from(ray.o, ray.d);
        self.walk(
            ray,
            diff,
            Vec3::ONE,
            pdf_dir,
            TransportMode::Radiance,
            max_vertices,
            medium,
            cam,
            Some(glow),
            sampler,
            counts,
        );
    }

    /// Traces a subpath from `ray` (starting in `medium`) and appends its vertices to
    /// `path` (which holds the vertex the ray leaves), at most `max_vertices` in all;
    /// with `glow`, the light emitted by media along it, as (t, radiance).
    #[allow(clippy::too_many_arguments)]
    fn walk(
        &self,
        ray: Ray,
        diff: Option<RayDifferential>,
        beta: Vec3,
        pdf_dir: f32,
        mode: TransportMode,
        max_vertices: usize,
        medium: Option<u32>,
        path: &mut Vec<Vertex>,
        glow: Option<&mut Vec<(usize, Vec3)>>,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
    ) {
        // one walk per kind of scene: a surface-only one carries no media code
        let walk = match self.ctx.scene.has_media {
            true => Self::walk_in::<true>,
            false => Self::walk_in::<false>,
        };
        walk(
            self,
            ray,
            diff,
            beta,
            pdf_dir,
            mode,
            max_vertices,
            medium,
            path,
            glow,
            sampler,
            counts,
        );
    }

    /// [`Engine::walk`] in a scene with media (`MEDIA`) or without.
    #[allow(clippy::too_many_arguments)]
    fn walk_in<const MEDIA: bool>(
        &self,
        mut ray: Ray,
        diff: Option<RayDifferential>,
        mut beta: Vec3,
        mut pdf_dir: f32,
        mode: TransportMode,
        max_vertices: usize,
        mut medium: Option<u32>,
        path: &mut Vec<Vertex>,
        mut glow: Option<&mut Vec<(usize, Vec3)>>,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
    ) {
        let scene = self.ctx.scene;
        // roulette judges the throughput relative to the start, without refraction's η²
        let rr_norm = 1.0 / beta.max_element();
        let mut eta_scale = 1.0f32;
        let mut hero = None;
        while path.len() < max_vertices {
            // the segment traced now ends at vertex path.len(): its emission is strategy (0, path.len() + 1)
            let mut le = Vec3::ZERO;
            let found = media::next_event::<MEDIA>(
                scene,
                &mut ray,
                &mut medium,
                &mut hero,
                &mut beta,
                glow.is_some().then_some(&mut le),
                sampler,
                counts,
            );
            if let (true, Some(g)) = (le != Vec3::ZERO, glow.as_deref_mut()) {
                g.push((path.len() + 1, le));
            }
            let hit = match found {
                media::Event::Absorbed => break,
                media::Event::Scattered { p, medium: m } => {
                    let phase = scene.media[m as usize].phase();
                    let mut v = Vertex::new(Kind::Medium(phase), p, Vec3::ZERO, beta);
                    v.wo = -ray.d;
                    v.set_media([Some(m); 2]);
                    v.pdf_fwd = self.ctx.convert(pdf_dir, &path[path.len() - 1], &v);
                    let wo = v.wo;
                    path.push(v);
                    if path.len() >= max_vertices {
                        break;
                    }
                    // the phase function's sample weighs 1; its density is the same both ways
                    let (wi, pdf) = phase.sample(wo, Vec2::from(sampler.next_2d()));
                    let n = path.len();
                    path[n - 2].pdf_rev = self.ctx.convert(pdf, &path[n - 1], &path[n - 2]);
                    if !self.survives(n - 1, &mut beta, (rr_norm, eta_scale), sampler) {
                        break;
                    }
                    (ray, pdf_dir) = (Ray::with_range(p, wi, 0.0, RAY_T_MAX), pdf);
                    continue;
                }
                media::Event::Surface(hit) => hit,
            };
            let Some(hit) = hit else {
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
            if MEDIA {
                v.set_media([scene.medium_after(&it, it.ng, medium), scene.medium_after(&it, -it.ng, medium)]);
            }
            let bsdf = v.bsdf.clone();
            path.push(v);
            let Some(bsdf) = bsdf else { break };
            if path.len() >= max_vertices {
                break;
            }
            let uc = sampler.next_1d();
            let u = Vec2::from(sampler.next_2d());
            let sampled = match mode {
                TransportMode::Radiance => bsdf.sample(it.wo, u, uc),
                TransportMode::Importance => bsdf.sample_adjoint(it.wo, u, uc, Normals { ns: it.ns, ng: it.ng }),
            };
            let Some(bs) = sampled else { break };
            beta *= bs.weight;
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
            // segments so far, the camera ray or the light's ray first
            if !self.survives(n - 1, &mut beta, (rr_norm, eta_scale), sampler) {
                break;
            }
            ray = spawn_ray(&it, bs.wi);
            medium = path[n - 1].medium_towards(bs.wi);
            pdf_dir = pdf_fwd;
        }
    }

    /// Russian roulette after `segments` segments: survival probability
    /// min(0.95, throughput × `norm.0` × `norm.1`), survivors reweighted.
    #[inline]
    fn survives(&self, segments: usize, beta: &mut Vec3, norm: (f32, f32), sampler: &mut PixelSampler) -> bool {
        if segments >= RR_DEPTH {
            let q = (beta.max_element() * norm.0 * norm.1).min(0.95);
            if sampler.next_1d() >= q {
                return false;
            }
            *beta /= q;
        }
        true
    }

    /// A light subpath: a light chosen as for next-event estimation, a ray leaving it, its walk.
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
        let cos = es.n.map_or(1.0, |n| n.dot(es.dir).abs());
        let beta = es.le * (cos / (pmf * es.pdf_pos * es.pdf_dir));
        let o = match es.n {
            Some(n) if !light.is_infinite() => offset_ray_origin(es.p, n),
            _ => es.p,
        };
        let ray = Ray::with_range(o, es.dir, 0.0, RAY_T_MAX);
        v.set_media(media::light_media(scene, index, es.n, &ray));
        let medium = v.medium_towards(es.dir);
        path.push(v);
        self.walk(
            ray,
            None,
            beta,
            es.pdf_dir,
            TransportMode::Importance,
            self.max_depth,
            medium,
            path,
            None,
            sampler,
            counts,
        );
        if path.len() > 1 {
            path[1].pdf_fwd = ctx.pdf_light(&path[0], &path[1]);
        }
    }
}
