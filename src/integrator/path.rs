//! Unidirectional path tracer (the `path` integrator).
//!
//! `max_depth` counts path segments as in Mitsuba (1: emitters seen directly,
//! 2: direct light, …). Profiles: `MIS` (default) combines light sampling and
//! BSDF sampling with the power heuristic; `NEE` uses light sampling only (BSDF
//! sampling just continues the path); `RW` is a random walk with BSDF sampling
//! only (point lights, which no ray can hit, then contribute nothing). Emission
//! seen directly or through delta (specular) bounces counts once, unweighted.
//! Russian roulette as in Mitsuba: from the 5th segment on, a path survives with
//! probability min(0.95, max throughput·η²), where η² undoes the radiance scaling
//! of refraction; survivors are reweighted, so the estimate stays unbiased.

use super::pass::CameraBlock;
use super::{spawn_ray, RayCounts};
use crate::accel::wide::{PacketHits, PACKET};
use crate::geometry::{Ray, RayDifferential};
use crate::light::environment::EnvironmentLight;
use crate::light::{Light, LightSample, LightSampling};
use crate::material::bsdf::Bsdf;
use crate::math::{Vec2, Vec3};
use crate::sampler::PixelSampler;
use crate::sampling::{power_heuristic, RowDraw};
use crate::scene::{Hit, Interaction, Scene};
use std::mem::MaybeUninit;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PathProfile {
    RandomWalk,
    NextEvent,
    #[default]
    Mis,
}

/// Segment from which Russian roulette may end paths.
const RR_DEPTH: u32 = 5;

/// Weight of emission found by BSDF sampling, given the light-sampling density.
#[inline]
fn emitter_weight(profile: PathProfile, after_delta: bool, bsdf_pdf: f32, light_pdf: impl FnOnce() -> f32) -> f32 {
    match profile {
        _ if after_delta => 1.0,
        PathProfile::RandomWalk => 1.0,
        PathProfile::NextEvent => 0.0,
        PathProfile::Mis => power_heuristic(bsdf_pdf, light_pdf()),
    }
}

/// Parameters (JSON `integrator` keys, besides `type` and `spp`):
/// * `max_depth` (int ≥ 1, 12) — path segments, the camera ray being the first;
/// * `profile` (`"MIS"` | `"NEE"` | `"RW"`, `"MIS"`; also the long names
///   `MultipleImportanceSampling`, `NextEventEstimation`, `RandomWalk`);
/// * `rr_threshold` (number, 0.1) — read and kept; roulette follows Mitsuba's rule
///   (see the module docs), so the converged image does not depend on it.
///
/// ```json
/// {"type": "path", "spp": 64, "max_depth": 12, "profile": "MIS"}
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathTracer {
    pub max_depth: u32,
    pub profile: PathProfile,
    pub rr_threshold: f32,
}

impl PathTracer {
    pub fn li(&self, scene: &Scene, ray: Ray, diff: Option<RayDifferential>, sampler: &mut PixelSampler, counts: &mut RayCounts) -> Vec3 {
        self.finish(scene, PathState::new(ray), 1, diff.as_ref(), sampler, counts)
    }

    /// Traces `path` from segment `segment` (its ray) to its end; its radiance.
    #[inline(always)]
    fn finish(
        &self,
        scene: &Scene,
        mut path: PathState,
        mut segment: u32,
        diff: Option<&RayDifferential>,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
    ) -> Vec3 {
        loop {
            counts.rays += 1;
            let hit = scene.intersect(&path.ray);
            let (shadow, goes_on) = path.advance(self, scene, Found { hit, segment, diff }, sampler, counts);
            if let Some(s) = shadow {
                path.add_unoccluded(&s, scene.transmittance(&s.ray));
            }
            if !goes_on {
                return path.l;
            }
            segment += 1;
        }
    }

    /// [`PathTracer::li`] of a pixel block's camera samples, each radiance exactly
    /// as `li` computes it: the camera rays, and then the shadow rays of their
    /// hits, are traced as one packet each (a packet query gives the single-ray
    /// answer; without masks a shadow ray's transmittance is 1 or 0); each path
    /// then goes on alone, as later segments' rays scatter and trace faster one at
    /// a time (README, "Speed"). Under a sky the block's second segments are still
    /// taken in step (their rays, one at a time, then each path's step), so that the
    /// sky's lookups overlap; stepping every segment so was slower elsewhere. Each
    /// path draws its numbers in `li`'s order and sums its terms in the same order.
    pub fn li_block(&self, scene: &Scene, block: &mut CameraBlock, out: &mut [Vec3]) {
        scene.bvh.isa().run(
            #[inline(always)]
            || self.li_block_body(scene, block, out),
        )
    }

    #[inline(always)]
    fn li_block_body(&self, scene: &Scene, block: &mut CameraBlock, out: &mut [Vec3]) {
        let n = block.rays.len().min(PACKET);
        let mut hits = PacketHits::default();
        scene.intersect_packet_lanes(&block.rays[..n], (1 << n) - 1, &mut hits);
        block.counts.rays += n as u64;
        // a constant copied, then each lane's ray set in place: `array::from_fn` built each
        // path on the stack with narrow stores and copied it with wide loads, which stalled
        let mut paths = [PathState::IDLE; PACKET];
        for (path, ray) in paths.iter_mut().zip(&block.rays[..n]) {
            path.start(ray);
        }
        let diffs = block.diffs;
        let found = |i: usize| Found {
            hit: hits.get(i),
            segment: 1,
            diff: diffs[i].as_ref(),
        };
        let mut steps = [(None, false); PACKET];
        let environment = scene.environment_light();
        if let Some((env, sky)) = environment {
            // the sky's coordinates of the camera rays that miss, all lanes together
            let missed = !hits.found & ((1 << n) - 1);
            if missed != 0 {
                let (uv, sin_theta) = sky.direction_coords_lanes(&directions(&paths));
                for i in (0..n).filter(|&i| missed >> i & 1 != 0) {
                    paths[i].sky_coords = Some((Vec2::new(uv[0][i], uv[1][i]), sin_theta[i]));
                }
            }
            // `advance` a step at a time over the block, so that the sky's table and
            // texel loads overlap across paths (elsewhere the split costs more)
            // uninitialised lanes and a mark of those written, rather than an array of
            // `Option`s: a `None` template would be copied into every lane first, and each
            // `Option` returned by `begin` was copied whole, `None`s too (300 bytes each)
            let mut lanes = [const { MaybeUninit::<Vertex>::uninit() }; PACKET];
            let mut live = [false; PACKET];
            for i in 0..n {
                live[i] = paths[i].begin(self, scene, found(i), &mut block.samplers[i], &mut lanes[i]);
            }
            // light samples; the sky's own (by importance) in two steps, their
            // trigonometry for all lanes at once
            let mut samples = [None; PACKET];
            let (mut sky_uv, mut sky_pdf, mut sky_lanes) = ([[0.0f32; PACKET]; 2], [0.0f32; PACKET], 0u32);
            let importance = scene.light_sampling == LightSampling::Importance;
            for i in 0..n {
                if live[i] {
                    // SAFETY: live lanes were written above (and are dropped only below)
                    let v = unsafe { lanes[i].assume_init_ref() };
                    match v.light {
                        Some((index, _, u)) if importance && index == env as usize => {
                            let (uv, pdf) = sky.sample_uv(u, v.sky_row);
                            (sky_uv[0][i], sky_uv[1][i], sky_pdf[i]) = (uv.x, uv.y, pdf);
                            sky_lanes |= 1 << i;
                        }
                        // no closure here: it would be compiled apart from the kernel set's code
                        _ => samples[i] = v.light_sample(scene),
                    }
                }
            }
            // and the sky's directions and their coordinates, for their radiance (by axis:
            // each lane's sample is made where it is used, not stored in an array of
            // `Option`s, whose narrow stores then stalled the wide loads that copied them)
            let (mut wi, mut sin_theta, mut wi_uv) = ([[0.0f32; PACKET]; 3], [0.0f32; PACKET], [[0.0f32; PACKET]; 2]);
            if sky_lanes != 0 {
                (wi, sin_theta) = sky.uv_to_direction_lanes(&sky_uv);
                (wi_uv, _) = sky.direction_coords_lanes(&wi);
            }
            for i in 0..n {
                if live[i] {
                    let (sample, radiance_uv) = if sky_lanes >> i & 1 != 0 {
                        let w = Vec3::new(wi[0][i], wi[1][i], wi[2][i]);
                        let sample =
                            EnvironmentLight::direction_sample(w, sin_theta[i], sky_pdf[i]).map(|(w, pdf)| LightSample::unlit_sky(w, pdf));
                        (sample, Some(Vec2::new(wi_uv[0][i], wi_uv[1][i])))
                    } else {
                        (samples[i], None)
                    };
                    // SAFETY: as above
                    let v = unsafe { lanes[i].assume_init_ref() };
                    steps[i] = paths[i].end(self, scene, v, sample, radiance_uv, 1, &mut block.samplers[i], block.counts);
                }
            }
            // the sky's coordinates of the next rays, all lanes together (as `advance`
            // takes them for one), and their texels and pdf weights prefetched
            let (uv, sin_theta) = sky.direction_coords_lanes(&directions(&paths));
            for i in (0..n).filter(|&i| steps[i].1) {
                let uv = Vec2::new(uv[0][i], uv[1][i]);
                sky.prefetch_coords(uv);
                paths[i].sky_coords = Some((uv, sin_theta[i]));
            }
            for i in 0..n {
                if live[i] {
                    // SAFETY: a live lane, dropped this once and not used again (a panic
                    // before here leaks the lanes)
                    unsafe { lanes[i].assume_init_drop() };
                }
            }
        } else {
            for i in 0..n {
                steps[i] = paths[i].advance(self, scene, found(i), &mut block.samplers[i], block.counts);
            }
        }
        // the shadow rays, as one packet where the scene traces packets
        let mut rays = [Ray::IDLE; PACKET];
        let mut waiting = 0u32;
        for (i, (shadow, _)) in steps.iter().enumerate().take(n) {
            if let Some(s) = shadow {
                rays[i] = s.ray;
                waiting |= 1 << i;
            }
        }
        let lit = if scene.packets() {
            waiting & !scene.occluded_packet(&rays[..n], waiting)
        } else {
            0
        };
        for (i, (shadow, _)) in steps.iter().enumerate().take(n) {
            if let Some(s) = shadow {
                let tr = if scene.packets() {
                    (lit >> i & 1) as f32
                } else {
                    scene.transmittance(&s.ray)
                };
                paths[i].add_unoccluded(s, tr);
            }
        }
        let mut going = (0..n).filter(|&i| steps[i].1).fold(0u32, |m, i| m | 1 << i);
        let mut segment = 1;
        if environment.is_some() {
            // the second segment's rays one after another, then each path's step (the
            // first turn of `finish`'s loop): independent traversals and the sky's lookups
            // of the rays that escape overlap across paths
            let mut hits = PacketHits::default();
            if scene.bvh.nodes.len() == 1 {
                // a tree of one node: one box test of the root for all the scattered rays
                // pays (env_sphere, the bundled showcase: 3–5 %); from 7 nodes on
                // scattered packets were slower than single rays
                let rays: [Ray; PACKET] = std::array::from_fn(|i| paths[i].ray);
                scene.intersect_packet_lanes(&rays[..n], going, &mut hits);
            } else {
                for i in (0..n).filter(|&i| going >> i & 1 != 0) {
                    hits.set(i, scene.intersect(&paths[i].ray));
                }
            }
            block.counts.rays += going.count_ones() as u64;
            let traced = going;
            for i in (0..n).filter(|&i| traced >> i & 1 != 0) {
                let found = Found {
                    hit: hits.get(i),
                    segment: 2,
                    diff: None,
                };
                let (shadow, goes_on) = paths[i].advance(self, scene, found, &mut block.samplers[i], block.counts);
                if let Some(s) = shadow {
                    paths[i].add_unoccluded(&s, scene.transmittance(&s.ray));
                }
                if !goes_on {
                    going &= !(1 << i);
                }
            }
            segment = 2;
        }
        for i in 0..n {
            out[i] = if going >> i & 1 != 0 {
                self.finish(scene, paths[i], segment + 1, None, &mut block.samplers[i], block.counts)
            } else {
                paths[i].l
            };
        }
    }
}

/// The directions of the paths' rays by axis (`[axis][lane]`).
#[inline(always)]
fn directions(paths: &[PathState; PACKET]) -> [[f32; PACKET]; 3] {
    std::array::from_fn(|a| std::array::from_fn(|i| paths[i].ray.d[a]))
}

/// A light sample's term, waiting for its shadow ray.
#[derive(Clone, Copy)]
struct Shadow {
    ray: Ray,
    /// The term if the light is unoccluded (transmittance 1).
    term: Vec3,
}

/// What a segment's ray found: its hit (if any), the segment's number (1: the
/// camera ray) and, for the camera ray, its differentials.
struct Found<'a> {
    hit: Option<Hit>,
    segment: u32,
    diff: Option<&'a RayDifferential>,
}

/// A path's vertex with its numbers drawn, before its light sample is taken.
struct Vertex {
    it: Interaction,
    bsdf: Bsdf,
    /// The light chosen for next-event estimation: its index, probability and
    /// sample numbers (`None`: no light sample here).
    light: Option<(usize, f32, Vec2)>,
    /// The environment's row drawn for the light sample, if the light is the sky
    /// sampled by importance ([`Light::prefetch_sample`]).
    sky_row: Option<RowDraw>,
    uc: f32,
    u_bsdf: Vec2,
}

impl Vertex {
    /// The next-event light sample, its radiance left to [`PathState::end`].
    #[inline(always)]
    fn light_sample(&self, scene: &Scene) -> Option<LightSample> {
        let (index, _, u_light) = self.light?;
        scene.lights[index].sample_unlit(self.it.p, u_light, scene.light_sampling, self.sky_row)
    }
}

/// A path between segments: its next ray and what it carries to the next vertex.
#[derive(Clone, Copy)]
struct PathState {
    ray: Ray,
    l: Vec3,
    beta: Vec3,
    eta_scale: f32,
    after_delta: bool,
    bsdf_pdf: f32,
    prev_p: Vec3,
    /// The sky's texture coordinates and sinθ of `ray`'s direction, where they were
    /// computed when the ray was spawned (to prefetch its texels should it escape).
    sky_coords: Option<(Vec2, f32)>,
}

impl PathState {
    /// [`PathState::new`] of [`Ray::IDLE`].
    const IDLE: PathState = PathState::new(Ray::IDLE);

    const fn new(ray: Ray) -> PathState {
        PathState {
            ray,
            l: Vec3::ZERO,
            beta: Vec3::ONE,
            eta_scale: 1.0,
            after_delta: true,
            bsdf_pdf: 0.0,
            prev_p: ray.o,
            sky_coords: None,
        }
    }

    /// Makes this [`PathState::new`]`(*ray)`, field by field.
    #[inline(always)]
    fn start(&mut self, ray: &Ray) {
        self.ray.o = ray.o;
        self.ray.d = ray.d;
        (self.ray.t_min, self.ray.t_max) = (ray.t_min, ray.t_max);
        self.prev_p = ray.o;
    }

    /// A light term times the transmittance of its shadow ray.
    #[inline]
    fn add_unoccluded(&mut self, s: &Shadow, tr: f32) {
        if tr > 0.0 {
            self.l += s.term * tr;
        }
    }

    /// Ends the segment (`self.ray`, which found `found.hit`): adds the emission it
    /// finds, takes the next-event light sample (returned with its shadow ray, for
    /// the caller to trace) and samples the next segment into `self.ray`. Returns
    /// whether the path goes on. The three steps of [`PathState::begin`],
    /// [`Vertex::light_sample`] and [`PathState::end`].
    #[inline(always)]
    fn advance(
        &mut self,
        tracer: &PathTracer,
        scene: &Scene,
        found: Found,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
    ) -> (Option<Shadow>, bool) {
        let segment = found.segment;
        let mut vertex = MaybeUninit::uninit();
        if !self.begin(tracer, scene, found, sampler, &mut vertex) {
            return (None, false);
        }
        // SAFETY: `begin` wrote the vertex (it returned true); it is dropped below, once
        let v = unsafe { vertex.assume_init_ref() };
        let ls = v.light_sample(scene);
        let step = self.end(tracer, scene, v, ls, None, segment, sampler, counts);
        // SAFETY: as above; `v` is not used again (a panic before here leaks the vertex)
        unsafe { vertex.assume_init_drop() };
        if let (true, Some((_, sky))) = (step.1, scene.environment_light()) {
            // should the ray escape, its texels and pdf weight load during the traversal
            let coords = sky.direction_coords(self.ray.d);
            sky.prefetch_coords(coords.0);
            self.sky_coords = Some(coords);
        }
        step
    }

    /// The first step of [`PathState::advance`]: the emission the segment finds, and
    /// the vertex it reaches with its BSDF and all its numbers but roulette's (the
    /// light's tables are prefetched), written into `out`; returns false (and writes
    /// nothing) where the path ends. An out-parameter, because a returned vertex was
    /// built on the stack with narrow stores and then copied with wide loads, which
    /// stalled.
    #[inline(always)]
    fn begin(
        &mut self,
        tracer: &PathTracer,
        scene: &Scene,
        found: Found,
        sampler: &mut PixelSampler,
        out: &mut MaybeUninit<Vertex>,
    ) -> bool {
        let (profile, mode, ray) = (tracer.profile, scene.light_sampling, self.ray);
        let Found { hit, segment, diff } = found;
        let Some(hit) = hit else {
            if let Some((env, sky)) = scene.environment_light() {
                // the direction's texture coordinates once, for radiance and pdf
                // (a bounce ray's coordinates, and their prefetches, come from its spawn)
                let (uv, sin_theta) = self.sky_coords.unwrap_or_else(|| sky.direction_coords(ray.d));
                let le = sky.radiance_at(uv);
                if le != Vec3::ZERO {
                    let w = emitter_weight(profile, self.after_delta, self.bsdf_pdf, || {
                        scene.light_sampler.pmf(env as usize) * sky.pdf_at(uv, sin_theta, mode)
                    });
                    self.l += self.beta * le * w;
                }
            }
            return false;
        };
        let mut it = scene.interaction(&ray, &hit);
        if let (1, Some(d)) = (segment, diff) {
            it.compute_uv_derivatives(d);
        }
        if let Some((index, area)) = scene.area_light_of(&it) {
            let le = area.emitted(it.ng, it.wo, it.uv);
            if le != Vec3::ZERO {
                let w = emitter_weight(profile, self.after_delta, self.bsdf_pdf, || {
                    scene.light_sampler.pmf(index as usize)
                        * scene.lights[index as usize].pdf(self.prev_p, ray.d, Some((it.p, it.ng)), mode)
                });
                self.l += self.beta * le * w;
            }
        }
        if segment >= tracer.max_depth {
            return false;
        }
        // an emitter without a material does not reflect (Mitsuba gives it a black BSDF)
        let Some(material) = scene.material_of(&it) else {
            return false;
        };
        let bsdf = material.bsdf_at(&it, &scene.textures);

        // the BSDF's numbers follow the light's (the same order as drawn one after the
        // other), drawn before the light sample is taken, while its tables load
        let (mut light, mut sky_row) = (None, None);
        if profile != PathProfile::RandomWalk && !bsdf.is_delta() && !scene.lights.is_empty() {
            let (index, pmf, _) = scene.light_sampler.sample(sampler.next_1d());
            let u_light = Vec2::from(sampler.next_2d());
            sky_row = scene.lights[index].prefetch_sample(u_light, mode);
            light = Some((index, pmf, u_light));
        }
        let uc = sampler.next_1d();
        let u_bsdf = Vec2::from(sampler.next_2d());
        out.write(Vertex {
            it,
            bsdf,
            light,
            sky_row,
            uc,
            u_bsdf,
        });
        true
    }

    /// The last step of [`PathState::advance`]: the light sample's term and shadow
    /// ray, the BSDF sample, roulette, the next segment's ray (its coordinates in the
    /// sky are the caller's to take). A sample of the sky may come with the texture
    /// coordinates of its direction (`sky_uv`, for its radiance).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn end(
        &mut self,
        tracer: &PathTracer,
        scene: &Scene,
        v: &Vertex,
        ls: Option<LightSample>,
        sky_uv: Option<Vec2>,
        segment: u32,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
    ) -> (Option<Shadow>, bool) {
        let (profile, it, bsdf) = (tracer.profile, &v.it, &v.bsdf);
        let (uc, u_bsdf) = (v.uc, v.u_bsdf);
        let mut shadow = None;
        // the environment's radiance only for directions the BSDF reflects
        if let (Some((index, pmf, _)), Some(mut ls)) = (v.light, ls) {
            let light: &Light = &scene.lights[index];
            let f = bsdf.eval(it.wo, ls.wi);
            let cos = it.ns.dot(ls.wi).abs();
            if f != Vec3::ZERO && ls.pdf > 0.0 && pmf > 0.0 && {
                ls.radiance = match (sky_uv, light) {
                    (Some(uv), Light::Environment(sky)) => sky.radiance_at(uv),
                    _ => light.radiance_of(&ls),
                };
                ls.radiance != Vec3::ZERO
            } {
                counts.rays += 1;
                let light_pdf = pmf * ls.pdf;
                let w = if ls.delta || profile == PathProfile::NextEvent {
                    1.0
                } else {
                    power_heuristic(light_pdf, bsdf.pdf(it.wo, ls.wi))
                };
                shadow = Some(Shadow {
                    ray: super::shadow_ray(it, &ls),
                    term: self.beta * f * ls.radiance * (cos * w / light_pdf),
                });
            }
        }

        let Some(bs) = bsdf.sample(it.wo, u_bsdf, uc) else {
            return (shadow, false);
        };
        self.beta *= bs.weight;
        // refraction scales radiance by 1/η²; roulette judges the path without it
        self.eta_scale *= bs.eta * bs.eta;
        if self.beta == Vec3::ZERO || !self.beta.is_finite() {
            return (shadow, false);
        }
        self.after_delta = bs.delta;
        self.bsdf_pdf = bs.pdf;
        self.prev_p = it.p;
        if segment >= RR_DEPTH {
            let q = (self.beta.max_element() * self.eta_scale).min(0.95);
            if sampler.next_1d() >= q {
                return (shadow, false);
            }
            self.beta /= q;
        }
        self.ray = spawn_ray(it, bs.wi);
        (shadow, true)
    }
}
