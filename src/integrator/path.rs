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

use super::{spawn_ray, RayCounts};
use crate::geometry::{Ray, RayDifferential};
use crate::light::Light;
use crate::math::{Vec2, Vec3};
use crate::sampler::PixelSampler;
use crate::sampling::power_heuristic;
use crate::scene::Scene;

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
        li(scene, ray, diff, sampler, counts, self.profile, self.max_depth)
    }
}

fn li(
    scene: &Scene,
    mut ray: Ray,
    diff: Option<RayDifferential>,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
    profile: PathProfile,
    max_depth: u32,
) -> Vec3 {
    let mode = scene.light_sampling;
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let mut eta_scale = 1.0f32;
    let (mut after_delta, mut bsdf_pdf, mut prev_p) = (true, 0.0f32, ray.o);
    let mut segment = 1u32;
    loop {
        counts.rays += 1;
        let Some(hit) = scene.intersect(&ray) else {
            if let Some((env, sky)) = scene.environment_light() {
                // the direction's texture coordinates once, for radiance and pdf
                let uv = sky.direction_to_uv(ray.d);
                if profile == PathProfile::Mis && !after_delta {
                    // the pdf's weight loads while the texels do
                    sky.prefetch_pdf(uv);
                }
                let le = sky.radiance_at(uv);
                if le != Vec3::ZERO {
                    let w = emitter_weight(profile, after_delta, bsdf_pdf, || {
                        scene.light_sampler.pmf(env as usize) * sky.pdf_at(uv, mode)
                    });
                    l += beta * le * w;
                }
            }
            break;
        };
        let mut it = scene.interaction(&ray, &hit);
        if let (1, Some(d)) = (segment, &diff) {
            it.compute_uv_derivatives(d);
        }
        if let Some((index, area)) = scene.area_light_of(&it) {
            let le = area.emitted(it.ng, it.wo, it.uv);
            if le != Vec3::ZERO {
                let w = emitter_weight(profile, after_delta, bsdf_pdf, || {
                    scene.light_sampler.pmf(index as usize) * scene.lights[index as usize].pdf(prev_p, ray.d, Some((it.p, it.ng)), mode)
                });
                l += beta * le * w;
            }
        }
        if segment >= max_depth {
            break;
        }
        // an emitter without a material does not reflect (Mitsuba gives it a black BSDF)
        let Some(material) = scene.material_of(&it) else { break };
        let bsdf = material.bsdf_at(&it, &scene.textures);

        // the BSDF's numbers follow the light's (the same order as drawn one after the
        // other), drawn before the light sample is taken, while its tables load
        let (uc, u_bsdf);
        if profile != PathProfile::RandomWalk && !bsdf.is_delta() && !scene.lights.is_empty() {
            let (index, pmf, _) = scene.light_sampler.sample(sampler.next_1d());
            let light: &Light = &scene.lights[index];
            let u_light = Vec2::from(sampler.next_2d());
            light.prefetch_sample(u_light, mode);
            uc = sampler.next_1d();
            u_bsdf = Vec2::from(sampler.next_2d());
            // the environment's radiance only for directions the BSDF reflects
            if let Some(mut ls) = light.sample_unlit(it.p, u_light, mode) {
                let f = bsdf.eval(it.wo, ls.wi);
                let cos = it.ns.dot(ls.wi).abs();
                if f != Vec3::ZERO && ls.pdf > 0.0 && pmf > 0.0 && {
                    ls.radiance = light.radiance_of(&ls);
                    ls.radiance != Vec3::ZERO
                } {
                    counts.rays += 1;
                    let tr = scene.transmittance(&super::shadow_ray(&it, &ls));
                    if tr > 0.0 {
                        let light_pdf = pmf * ls.pdf;
                        let w = if ls.delta || profile == PathProfile::NextEvent {
                            1.0
                        } else {
                            power_heuristic(light_pdf, bsdf.pdf(it.wo, ls.wi))
                        };
                        l += beta * f * ls.radiance * (cos * w / light_pdf) * tr;
                    }
                }
            }
        } else {
            uc = sampler.next_1d();
            u_bsdf = Vec2::from(sampler.next_2d());
        }

        let Some(bs) = bsdf.sample(it.wo, u_bsdf, uc) else {
            break;
        };
        beta *= bs.weight;
        // refraction scales radiance by 1/η²; roulette judges the path without it
        eta_scale *= bs.eta * bs.eta;
        if beta == Vec3::ZERO || !beta.is_finite() {
            break;
        }
        after_delta = bs.delta;
        bsdf_pdf = bs.pdf;
        prev_p = it.p;
        if segment >= RR_DEPTH {
            let q = (beta.max_element() * eta_scale).min(0.95);
            if sampler.next_1d() >= q {
                break;
            }
            beta /= q;
        }
        ray = spawn_ray(&it, bs.wi);
        if let Some((_, sky)) = scene.environment_light() {
            // should the ray escape, its texels load during the traversal
            sky.prefetch_direction(ray.d);
        }
        segment += 1;
    }
    l
}
