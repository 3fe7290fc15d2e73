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
//! The estimator is [`super::estimator`]'s; this file holds `path`'s policy and
//! its packet code.

use super::estimator::{trace, Found, PathProfile, PathState, Policy, Vertex};
use super::pass::{camera_pass_blocks, CameraBlock, PassContext, PassResult};
use super::RayCounts;
use crate::accel::wide::{PacketHits, PACKET};
use crate::film::Film;
use crate::geometry::{Ray, RayDifferential};
use crate::light::environment::EnvironmentLight;
use crate::light::{LightSample, LightSampling};
use crate::material::bsdf::Bsdf;
use crate::math::{Vec2, Vec3};
use crate::sampler::PixelSampler;
use crate::scene::{Interaction, Scene};
use std::mem::MaybeUninit;

/// Parameters (JSON `integrator` keys, besides `type` and `spp`):
/// * `max_depth` (int ≥ 1, 12) — path segments, the camera ray being the first;
/// * `profile` (`"MIS"` | `"NEE"` | `"RW"`, `"MIS"`; also the long names
///   `MultipleImportanceSampling`, `NextEventEstimation`, `RandomWalk`);
/// * `rr_threshold` (number, 0.1) — read and kept; roulette follows Mitsuba's rule
///   (see the module docs), so the converged image does not depend on it;
/// * `rr` (`"mitsuba"` | `"ears"`, `"mitsuba"`) — Russian roulette: Mitsuba's rule, or
///   EARS (Rath et al. 2022, efficiency-aware Russian roulette and splitting): at every
///   vertex a path is ended or split into up to 8 by factors learned over passes
///   ([`super::ears`]); unbiased either way, but the passes then depend on the ones
///   before (no `--resume` or `--shard`).
///
/// ```json
/// {"type": "path", "spp": 64, "max_depth": 12, "profile": "MIS"}
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathTracer {
    pub max_depth: u32,
    pub profile: PathProfile,
    pub rr_threshold: f32,
    /// Emitters and the environment seen directly by the camera are black (Mitsuba's
    /// `hide_emitters`); the light they cast is not hidden.
    pub hide_emitters: bool,
    pub rr: Roulette,
}

/// How `path` plays Russian roulette (its `rr` key).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Roulette {
    /// Mitsuba's rule (see the module docs).
    #[default]
    Mitsuba,
    /// Learned roulette and splitting ([`super::ears`]).
    Ears,
}

impl Roulette {
    /// The names the `rr` key takes.
    pub const NAMES: [&'static str; 2] = ["mitsuba", "ears"];

    pub fn from_name(name: &str) -> Option<Roulette> {
        match name {
            "mitsuba" => Some(Roulette::Mitsuba),
            "ears" => Some(Roulette::Ears),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }
}

impl PathTracer {
    /// Mitsuba's roulette: survive with probability min(0.95, max throughput·η²)
    /// (`guided` keeps it for paths that have not taken a guided sample).
    #[inline(always)]
    pub fn throughput_survival(beta: Vec3, eta_scale: f32) -> f32 {
        (beta.max_element() * eta_scale).min(0.95)
    }

    pub fn li(&self, scene: &Scene, ray: Ray, diff: Option<RayDifferential>, sampler: &mut PixelSampler, counts: &mut RayCounts) -> Vec3 {
        trace(&mut { *self }, scene, PathState::new(ray), 1, diff.as_ref(), sampler, counts)
    }

    /// [`PathTracer::li`] of a pixel block's camera samples, each radiance exactly
    /// as `li` computes it: the camera rays, and then the shadow rays of their
    /// hits, are traced as one packet each (a packet query gives the single-ray
    /// answer; without masks a shadow ray's transmittance is 1 or 0); each path
    /// then goes on alone, as later segments' rays scatter and trace faster one at
    /// a time. Under a sky the block's second segments are still
    /// taken in step (their rays, one at a time, then each path's step), so that the
    /// sky's lookups overlap; stepping every segment so was slower elsewhere. Each
    /// path draws its numbers in `li`'s order and sums its terms in the same order.
    pub fn li_block(&self, scene: &Scene, block: &mut CameraBlock, out: &mut [Vec3]) {
        trace_block(scene, block, out, &mut [*self; PACKET]);
    }

    /// A pass of packets ([`PathTracer::li_block`]) into `film`: `path`'s, and `guided`'s
    /// where it does not guide, through this one compiled copy (each caller's own copy of
    /// the pass made `guided`'s unguided passes slower than `path`'s).
    #[inline(never)]
    pub fn render_pass_blocks(&self, ctx: &PassContext, pass: u32, film: &mut Film) -> PassResult {
        camera_pass_blocks(ctx, pass, film, |b, out| self.li_block(ctx.scene, b, out))
    }
}

/// [`PathTracer::li_block`] under any policy, one per lane (`policies[i]` walks lane `i`'s
/// path, as [`trace`] would alone: `guided`'s walks, each with its records).
pub fn trace_block<P: Policy>(scene: &Scene, block: &mut CameraBlock, out: &mut [Vec3], policies: &mut [P]) {
    scene.bvh.isa().run(
        #[inline(always)]
        || trace_block_body(scene, block, out, policies),
    )
}

#[inline(always)]
fn trace_block_body<P: Policy>(scene: &Scene, block: &mut CameraBlock, out: &mut [Vec3], policies: &mut [P]) {
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
        let mut vertices = [const { MaybeUninit::<Vertex<P::Plan>>::uninit() }; PACKET];
        let mut live = [false; PACKET];
        for i in 0..n {
            live[i] = paths[i].begin(&mut policies[i], scene, found(i), &mut block.samplers[i], &mut vertices[i]);
        }
        // light samples; the sky's own (by importance) in two steps, their
        // trigonometry for all lanes at once
        let mut samples = [None; PACKET];
        let (mut sky_uv, mut sky_pdf, mut sky_lanes) = ([[0.0f32; PACKET]; 2], [0.0f32; PACKET], 0u32);
        let importance = scene.light_sampling == LightSampling::Importance;
        for i in 0..n {
            if live[i] {
                // SAFETY: live lanes were written above (and are dropped only below)
                let v = unsafe { vertices[i].assume_init_ref() };
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
                let v = unsafe { vertices[i].assume_init_ref() };
                steps[i] = paths[i].end(
                    &mut policies[i],
                    scene,
                    v,
                    sample,
                    radiance_uv,
                    1,
                    &mut block.samplers[i],
                    block.counts,
                );
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
                unsafe { vertices[i].assume_init_drop() };
            }
        }
    } else {
        for i in 0..n {
            steps[i] = paths[i].advance(&mut policies[i], scene, found(i), &mut block.samplers[i], block.counts);
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
            paths[i].add_unoccluded(&mut policies[i], s, tr);
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
            let (shadow, goes_on) = paths[i].advance(&mut policies[i], scene, found, &mut block.samplers[i], block.counts);
            if let Some(s) = shadow {
                paths[i].add_unoccluded(&mut policies[i], &s, scene.transmittance(&s.ray));
            }
            if !goes_on {
                going &= !(1 << i);
            }
        }
        segment = 2;
    }
    for i in 0..n {
        out[i] = if going >> i & 1 != 0 {
            trace(
                &mut policies[i],
                scene,
                paths[i],
                segment + 1,
                None,
                &mut block.samplers[i],
                block.counts,
            )
        } else {
            paths[i].l
        };
    }
}

/// The directions of the paths' rays by axis (`[axis][lane]`).
#[inline(always)]
fn directions(paths: &[PathState; PACKET]) -> [[f32; PACKET]; 3] {
    std::array::from_fn(|a| std::array::from_fn(|i| paths[i].ray.d[a]))
}

/// `path`'s policy: the BSDF samples the next direction, roulette as in Mitsuba.
impl Policy for PathTracer {
    type Plan = ();

    #[inline(always)]
    fn profile(&self) -> PathProfile {
        self.profile
    }

    #[inline(always)]
    fn max_depth(&self) -> u32 {
        self.max_depth
    }

    #[inline(always)]
    fn hide_emitters(&self) -> bool {
        self.hide_emitters
    }

    #[inline(always)]
    fn plan(&mut self, _: &Interaction, _: &Bsdf, _: &mut PixelSampler) {}

    /// Survive with probability min(0.95, max throughput·η²): η² undoes the
    /// radiance scaling of refraction.
    #[inline(always)]
    fn survival(&self, beta: Vec3, eta_scale: f32) -> f32 {
        Self::throughput_survival(beta, eta_scale)
    }
}
