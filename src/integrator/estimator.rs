//! The light-transport estimator of camera paths, written once for `path`, `guided`,
//! and `photon`'s and `sppm`'s camera paths to their visible points: emission found
//! along the path (weighted by MIS against light sampling), next-event estimation
//! (light selection, the light sample, its shadow ray, MIS against the path's own
//! sampling), the environment, and the path's throughput. What differs between integrators is a [`Policy`]: how the
//! next direction is sampled and with what density (the BSDF; or `guided`'s
//! mixture of the BSDF and the learned distribution), Russian roulette, and what
//! the path records on the way (`guided`'s training). `path`'s policy is the
//! BSDF with Mitsuba's roulette (`photon`'s: light sampling alone, no roulette, the
//! path handed over at its visible point); `path`'s packet code drives the same steps
//! ([`PathState::begin`], [`Vertex::light_sample`], [`PathState::end`]) lane by lane.
//!
//! In a scene with media ([`Scene::has_media`]) the same steps run inside
//! [`trace_media`]: each segment's ray is first tracked through the medium it is in
//! (delta tracking with hero-channel MIS, [`crate::medium::tracking`]); a real
//! scattering event makes a medium vertex (light sample with MIS against the phase
//! function, the phase function's sample); an emissive medium's light is gathered at
//! the tracking's collisions; `null` surfaces are crossed without a
//! vertex; shadow rays carry the media's transmittance (ratio tracking). `max_depth`
//! counts real events, surface and medium alike, as Mitsuba's `volpath` does.
//!
//! A policy may also split paths ([`Policy::SPLITS`], `path`'s `rr: "ears"`): its
//! roulette and splitting step is in [`split`], the sub-paths it makes are traced one
//! after another from an explicit stack.
//!
//! The light-sampling pieces ([`choose_light`], [`sample_light`],
//! [`light_sample_weight`]) serve the other integrators' direct light too.

use super::{shadow_ray_from_point, spawn_ray, RayCounts};
use crate::geometry::ray::RAY_T_MAX;
use crate::geometry::{Ray, RayDifferential};
use crate::light::{Light, LightSample};
use crate::material::bsdf::{Bsdf, BsdfSample};
use crate::math::{Vec2, Vec3};
use crate::medium::{delta_tracking_emitting, HeroWeights, PhaseFunction, Tracked};
use crate::sampler::PixelSampler;
use crate::sampling::{power_heuristic, RowDraw};
use crate::scene::{Hit, Interaction, Scene};
use std::mem::MaybeUninit;

mod media;
mod split;
use media::trace_media;
pub use split::{Branches, MAX_SPLIT};

/// Which strategies find light: light sampling and BSDF sampling combined by MIS,
/// light sampling alone (`NextEvent`), or BSDF sampling alone (`RandomWalk`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PathProfile {
    RandomWalk,
    NextEvent,
    #[default]
    Mis,
}

/// Segment from which Russian roulette may end paths.
pub const RR_DEPTH: u32 = 5;

/// Weight of emission found by sampling the next direction (density `bsdf_pdf`),
/// given the light-sampling density.
#[inline]
pub fn emitter_weight(profile: PathProfile, after_delta: bool, bsdf_pdf: f32, light_pdf: impl FnOnce() -> f32) -> f32 {
    match profile {
        _ if after_delta => 1.0,
        PathProfile::RandomWalk => 1.0,
        PathProfile::NextEvent => 0.0,
        PathProfile::Mis => power_heuristic(bsdf_pdf, light_pdf()),
    }
}

/// What an integrator decides along a camera path; the estimator does the rest.
/// Every hook is inlined into the estimator's steps (`path`'s policy costs nothing).
pub trait Policy {
    /// What the policy decided at a vertex, kept with it (`path`: nothing).
    type Plan: Copy;
    /// Which strategies find light.
    fn profile(&self) -> PathProfile;
    /// Longest path, in segments (the camera ray being the first).
    fn max_depth(&self) -> u32;
    /// Whether emission the camera ray finds is left out (Mitsuba's `hide_emitters`).
    fn hide_emitters(&self) -> bool {
        false
    }
    /// The plan at a non-emitting vertex with a BSDF, after its light numbers are
    /// drawn and before the direction's (`guided` draws its strategy choice here).
    fn plan(&mut self, it: &Interaction, bsdf: &Bsdf, sampler: &mut PixelSampler) -> Self::Plan;
    /// Solid-angle density of sampling `wi` as [`Policy::sample`] does (light
    /// samples' MIS weights); the BSDF's unless the policy samples otherwise.
    #[inline(always)]
    fn pdf(&self, plan: &Self::Plan, bsdf: &Bsdf, wo: Vec3, wi: Vec3) -> f32 {
        let _ = plan;
        bsdf.pdf(wo, wi)
    }
    /// The next direction, its weight f·|cos|/pdf and its density (the BSDF's sample
    /// unless the policy samples otherwise).
    #[inline(always)]
    fn sample(&mut self, plan: &Self::Plan, bsdf: &Bsdf, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        let _ = plan;
        bsdf.sample(wo, u, uc)
    }
    /// Whether paths play Russian roulette from [`RR_DEPTH`] on (without it no number is drawn for it).
    const ROULETTE: bool = true;
    /// Whether roulette is the policy's learned roulette and splitting instead (at every
    /// surface vertex: [`Policy::split_factor`], sub-paths kept in [`Policy::branches`]).
    const SPLITS: bool = false;
    /// With [`Policy::SPLITS`]: the expected number of sub-paths to continue from `it`
    /// (throughput `beta` arriving there, before its BSDF sample; below 1: roulette) and
    /// the statistics' cell the vertex belongs to, for the sub-paths' records.
    #[inline(always)]
    fn split_factor(&self, it: &Interaction, beta: Vec3, eta_scale: f32, segment: u32) -> (f32, u32) {
        let _ = (it, beta, eta_scale, segment);
        (1.0, split::NO_CELL)
    }
    /// With [`Policy::SPLITS`]: where the sub-paths wait (`None`: nowhere, no splitting).
    #[inline(always)]
    fn branches(&mut self) -> Option<&mut Branches> {
        None
    }
    /// Probability of surviving roulette from [`RR_DEPTH`] on, given the throughput
    /// and the product of η² of the refractions so far (1: always).
    #[inline(always)]
    fn survival(&self, beta: Vec3, eta_scale: f32) -> f32 {
        let _ = (beta, eta_scale);
        1.0
    }
    /// Whether the path ends at this vertex (reached by segment `segment`, throughput `beta`)
    /// once its light sample is taken, the vertex being the policy's (`photon`'s and `sppm`'s
    /// visible point, where photons take over).
    #[inline(always)]
    fn stops_at(&mut self, it: &Interaction, bsdf: &Bsdf, beta: Vec3, segment: u32) -> bool {
        let _ = (it, bsdf, beta, segment);
        false
    }
    /// Adds emission `c` found along the direction the last vertex sampled
    /// (`after_delta`: a specular one) to the estimate `l`.
    #[inline(always)]
    fn add_emission(&mut self, l: &mut Vec3, c: Vec3, after_delta: bool) {
        let _ = after_delta;
        *l += c;
    }
    /// A light sample whose term waits for its shadow ray (BSDF times cosine `f_cos`,
    /// MIS weight `w`, density `light_pdf`).
    #[inline(always)]
    fn light_sampled(&mut self, plan: &Self::Plan, ls: &LightSample, f_cos: Vec3, w: f32, light_pdf: f32) {
        let _ = (plan, ls, f_cos, w, light_pdf);
    }
    /// The waiting light sample's shadow ray let `tr > 0` through: `c` was added
    /// to the estimate.
    #[inline(always)]
    fn light_arrived(&mut self, c: Vec3, tr: f32) {
        let _ = (c, tr);
    }
    /// The path scattered into `bs` at a vertex; `beta` is the throughput with it,
    /// `l` the estimate so far.
    #[inline(always)]
    fn scattered(&mut self, plan: &Self::Plan, bs: &BsdfSample, beta: Vec3, l: Vec3) {
        let _ = (plan, bs, beta, l);
    }
}

/// The light chosen for next-event estimation: its index, its selection
/// probability and the numbers for its sample (drawn in this order).
#[inline(always)]
pub fn choose_light(scene: &Scene, sampler: &mut PixelSampler) -> (usize, f32, Vec2) {
    let (index, pmf, _) = scene.light_sampler.sample(sampler.next_1d());
    (index, pmf, Vec2::from(sampler.next_2d()))
}

/// A light chosen by [`choose_light`] and sampled from `p`: its index, selection
/// probability and sample.
#[inline]
pub fn sample_light(scene: &Scene, p: Vec3, sampler: &mut PixelSampler) -> Option<(usize, f32, LightSample)> {
    let (index, pmf, u) = choose_light(scene, sampler);
    scene.lights[index].sample(p, u, scene.light_sampling).map(|ls| (index, pmf, ls))
}

/// MIS weight (power heuristic) of a light sample of density `light_pdf`
/// (selection included) against the path's own sampling of its direction
/// (`scatter_pdf`); a delta light, which no scattered ray can find, weighs 1.
#[inline(always)]
pub fn light_sample_weight(ls: &LightSample, light_pdf: f32, scatter_pdf: impl FnOnce() -> f32) -> f32 {
    if ls.delta {
        1.0
    } else {
        power_heuristic(light_pdf, scatter_pdf())
    }
}

/// Traces `path` from segment `segment` (its ray) to its end under `policy`; its radiance.
#[inline(always)]
pub fn trace<P: Policy>(
    policy: &mut P,
    scene: &Scene,
    mut path: PathState,
    mut segment: u32,
    diff: Option<&RayDifferential>,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
) -> Vec3 {
    if scene.has_media {
        return trace_media(policy, scene, path, segment, diff, sampler, counts);
    }
    loop {
        counts.rays += 1;
        let hit = scene.intersect(&path.ray);
        let (shadow, goes_on) = path.advance(policy, scene, Found { hit, segment, diff }, sampler, counts);
        if let Some(s) = shadow {
            path.add_unoccluded(policy, &s, scene.transmittance(&s.ray));
        }
        if !goes_on {
            // a splitting policy's sub-paths waiting at earlier vertices, one after another
            match policy.branches() {
                Some(b) if P::SPLITS => match b.end_path(path.l, counts.rays) {
                    Some((next, s)) => (path, segment) = (next, s),
                    None => return b.total(),
                },
                _ => return path.l,
            }
            continue;
        }
        segment += 1;
    }
}

/// A light sample's term, waiting for its shadow ray.
#[derive(Clone, Copy)]
pub struct Shadow {
    pub ray: Ray,
    /// The term if the light is unoccluded (transmittance 1).
    pub term: Vec3,
}

/// What a segment's ray found: its hit (if any), the segment's number (1: the
/// camera ray) and, for the camera ray, its differentials.
pub struct Found<'a> {
    pub hit: Option<Hit>,
    pub segment: u32,
    pub diff: Option<&'a RayDifferential>,
}

/// A path's vertex with its numbers drawn, before its light sample is taken
/// (`P`: the policy's plan there).
pub struct Vertex<P = ()> {
    it: Interaction,
    bsdf: Bsdf,
    /// The light chosen for next-event estimation: its index, probability and
    /// sample numbers (`None`: no light sample here).
    pub light: Option<(usize, f32, Vec2)>,
    /// The environment's row drawn for the light sample, if the light is the sky
    /// sampled by importance ([`Light::prefetch_sample`]).
    pub sky_row: Option<RowDraw>,
    uc: f32,
    u_bsdf: Vec2,
    plan: P,
}

impl<P> Vertex<P> {
    /// The next-event light sample, its radiance left to [`PathState::end`].
    #[inline(always)]
    pub fn light_sample(&self, scene: &Scene) -> Option<LightSample> {
        let (index, _, u_light) = self.light?;
        scene.lights[index].sample_unlit(self.it.p, u_light, scene.light_sampling, self.sky_row)
    }
}

/// A path between segments: its next ray and what it carries to the next vertex.
#[derive(Clone, Copy)]
pub struct PathState {
    pub ray: Ray,
    pub l: Vec3,
    beta: Vec3,
    eta_scale: f32,
    after_delta: bool,
    bsdf_pdf: f32,
    prev_p: Vec3,
    /// The sky's texture coordinates and sinθ of `ray`'s direction, where they were
    /// computed when the ray was spawned (to prefetch its texels should it escape).
    pub sky_coords: Option<(Vec2, f32)>,
}

impl PathState {
    /// [`PathState::new`] of [`Ray::IDLE`].
    pub const IDLE: PathState = PathState::new(Ray::IDLE);

    pub const fn new(ray: Ray) -> PathState {
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
    pub fn start(&mut self, ray: &Ray) {
        self.ray.o = ray.o;
        self.ray.d = ray.d;
        (self.ray.t_min, self.ray.t_max) = (ray.t_min, ray.t_max);
        self.prev_p = ray.o;
    }

    /// A light term times the transmittance of its shadow ray.
    #[inline]
    pub fn add_unoccluded<P: Policy>(&mut self, policy: &mut P, s: &Shadow, tr: f32) {
        self.add_transmitted(policy, s, Vec3::splat(tr), tr);
    }

    /// [`PathState::add_unoccluded`] with a transmittance per channel (through media);
    /// `tr_mean` is the scalar the policy's records take.
    #[inline(always)]
    pub fn add_transmitted<P: Policy>(&mut self, policy: &mut P, s: &Shadow, tr: Vec3, tr_mean: f32) {
        if tr.cmpgt(Vec3::ZERO).any() {
            let c = s.term * tr;
            self.l += c;
            policy.light_arrived(c, tr_mean);
        }
    }

    /// Ends the segment (`self.ray`, which found `found.hit`): adds the emission it
    /// finds, takes the next-event light sample (returned with its shadow ray, for
    /// the caller to trace) and samples the next segment into `self.ray`. Returns
    /// whether the path goes on. The three steps of [`PathState::begin`],
    /// [`Vertex::light_sample`] and [`PathState::end`].
    #[inline(always)]
    pub fn advance<P: Policy>(
        &mut self,
        policy: &mut P,
        scene: &Scene,
        found: Found,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
    ) -> (Option<Shadow>, bool) {
        let segment = found.segment;
        let mut vertex = MaybeUninit::uninit();
        if !self.begin(policy, scene, found, sampler, &mut vertex) {
            return (None, false);
        }
        // SAFETY: `begin` wrote the vertex (it returned true); it is dropped below, once
        let v = unsafe { vertex.assume_init_ref() };
        let ls = v.light_sample(scene);
        let step = self.end(policy, scene, v, ls, None, segment, sampler, counts);
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
    pub fn begin<P: Policy>(
        &mut self,
        policy: &mut P,
        scene: &Scene,
        found: Found,
        sampler: &mut PixelSampler,
        out: &mut MaybeUninit<Vertex<P::Plan>>,
    ) -> bool {
        let (profile, mode, ray) = (policy.profile(), scene.light_sampling, self.ray);
        let Found { hit, segment, diff } = found;
        // emission the camera ray itself finds, where the policy hides emitters
        let hidden = segment == 1 && policy.hide_emitters();
        let Some(hit) = hit else {
            if let (Some((env, sky)), false) = (scene.environment_light(), hidden) {
                // the direction's texture coordinates once, for radiance and pdf
                // (a bounce ray's coordinates, and their prefetches, come from its spawn)
                let (uv, sin_theta) = self.sky_coords.unwrap_or_else(|| sky.direction_coords(ray.d));
                let le = sky.radiance_at(uv);
                if le != Vec3::ZERO {
                    let w = emitter_weight(profile, self.after_delta, self.bsdf_pdf, || {
                        scene.light_sampler.pmf(env as usize) * sky.pdf_at(uv, sin_theta, mode)
                    });
                    policy.add_emission(&mut self.l, self.beta * le * w, self.after_delta);
                }
            }
            return false;
        };
        let mut it = scene.interaction(&ray, &hit);
        if let (1, Some(d)) = (segment, diff) {
            it.compute_uv_derivatives(d);
        }
        if let (Some((index, area)), false) = (scene.area_light_of(&it), hidden) {
            let le = area.emitted(it.ng, it.wo, it.uv);
            if le != Vec3::ZERO {
                let w = emitter_weight(profile, self.after_delta, self.bsdf_pdf, || {
                    scene.light_sampler.pmf(index as usize)
                        * scene.lights[index as usize].pdf(self.prev_p, ray.d, Some((it.p, it.ng)), mode)
                });
                policy.add_emission(&mut self.l, self.beta * le * w, self.after_delta);
            }
        }
        if segment >= policy.max_depth() {
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
            let (index, pmf, u_light) = choose_light(scene, sampler);
            sky_row = scene.lights[index].prefetch_sample(u_light, mode);
            light = Some((index, pmf, u_light));
        }
        let plan = policy.plan(&it, &bsdf, sampler);
        let uc = sampler.next_1d();
        let u_bsdf = Vec2::from(sampler.next_2d());
        out.write(Vertex {
            it,
            bsdf,
            light,
            sky_row,
            uc,
            u_bsdf,
            plan,
        });
        true
    }

    /// The last step of [`PathState::advance`]: the light sample's term and shadow
    /// ray, the BSDF sample, roulette, the next segment's ray (its coordinates in the
    /// sky are the caller's to take). A sample of the sky may come with the texture
    /// coordinates of its direction (`sky_uv`, for its radiance).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn end<P: Policy>(
        &mut self,
        policy: &mut P,
        scene: &Scene,
        v: &Vertex<P::Plan>,
        ls: Option<LightSample>,
        sky_uv: Option<Vec2>,
        segment: u32,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
    ) -> (Option<Shadow>, bool) {
        let (profile, it, bsdf) = (policy.profile(), &v.it, &v.bsdf);
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
                let w = if profile == PathProfile::NextEvent {
                    1.0
                } else {
                    light_sample_weight(&ls, light_pdf, || policy.pdf(&v.plan, bsdf, it.wo, ls.wi))
                };
                policy.light_sampled(&v.plan, &ls, f * cos, w, light_pdf);
                shadow = Some(Shadow {
                    ray: super::shadow_ray(it, &ls),
                    term: self.beta * f * ls.radiance * (cos * w / light_pdf),
                });
            }
        }

        if policy.stops_at(it, bsdf, self.beta, segment) {
            return (shadow, false);
        }
        if P::SPLITS {
            return (shadow, self.split(policy, v, segment, sampler, counts));
        }
        let Some(bs) = policy.sample(&v.plan, bsdf, it.wo, u_bsdf, uc) else {
            return (shadow, false);
        };
        self.beta *= bs.weight;
        // refraction scales radiance by 1/η²; roulette judges the path without it
        self.eta_scale *= bs.eta * bs.eta;
        if self.beta == Vec3::ZERO || !self.beta.is_finite() {
            return (shadow, false);
        }
        policy.scattered(&v.plan, &bs, self.beta, self.l);
        self.after_delta = bs.delta;
        self.bsdf_pdf = bs.pdf;
        self.prev_p = it.p;
        if P::ROULETTE && segment >= RR_DEPTH {
            let q = policy.survival(self.beta, self.eta_scale);
            if sampler.next_1d() >= q {
                return (shadow, false);
            }
            self.beta /= q;
        }
        self.ray = spawn_ray(it, bs.wi);
        (shadow, true)
    }
}
