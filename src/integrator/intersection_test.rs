//! The `intersection_test` integrator, physically based (spec §13 with the refs
//! README's conventions): follow perfect refraction up to `max_depth` path
//! segments, adding emission seen on the way (area lights, the environment for
//! rays that escape); at the first diffuse surface add the direct light of every
//! light: point lights with one shadow ray each (`ρ/π · cosθ · (Φ/4π) / d²`),
//! area lights and the environment with `light_samples` light samples (drawn by
//! the light's own importance, or uniformly for comparisons) and as many BSDF
//! samples each, combined by MIS.

use super::{shadow_ray, spawn_ray, RayCounts};
use crate::geometry::{Ray, RayDifferential};
use crate::material::Material;
use crate::math::{reflect, refract, Frame, Vec2, Vec3, INV_PI};
use crate::sampler::PixelSampler;
use crate::sampling::{cosine_hemisphere, power_heuristic};
use crate::scene::{Interaction, Scene};

/// Parameters (JSON `integrator` keys, besides `type` and `spp`):
/// * `max_depth` (int ≥ 1, 16) — path segments, the camera ray being the first;
/// * `light_samples` (int ≥ 1, 1) — samples per area light and environment at each
///   shading point, per pixel sample (and as many BSDF samples); point lights need
///   one shadow ray each.
///
/// ```json
/// {"type": "intersection_test", "spp": 32, "max_depth": 16, "light_samples": 4}
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntersectionTest {
    pub max_depth: u32,
    pub light_samples: u32,
}

impl IntersectionTest {
    /// Radiance arriving along a camera ray. `diff` (the camera ray's differentials)
    /// sets the texture footprint of the first hit only: rays after a refraction carry
    /// none (pbrt would refract the differentials too, which needs normal derivatives),
    /// so textures seen through a refractor are looked up on their finest MIP level.
    pub fn li(&self, scene: &Scene, ray: Ray, diff: Option<RayDifferential>, sampler: &mut PixelSampler, counts: &mut RayCounts) -> Vec3 {
        li(scene, self, ray, diff, sampler, counts)
    }
}

fn li(
    scene: &Scene,
    params: &IntersectionTest,
    mut ray: Ray,
    diff: Option<RayDifferential>,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
) -> Vec3 {
    let max_depth = params.max_depth;
    let mut total = Vec3::ZERO;
    // `segment` is the number of path segments so far, the camera ray being the first.
    for segment in 1..=max_depth {
        counts.rays += 1;
        let Some(hit) = scene.intersect(&ray) else {
            return total + scene.environment_radiance(ray.d);
        };
        let mut it = scene.interaction(&ray, &hit);
        if let (1, Some(d)) = (segment, &diff) {
            it.compute_uv_derivatives(d);
        }
        if let Some((_, light)) = scene.area_light_of(&it) {
            total += light.emitted(it.ng, it.wo, it.uv);
        }
        match scene.material_of(&it) {
            Some(Material::Refraction { eta }) => ray = spawn_ray(&it, perfect_refraction(it.wo, it.ns, *eta)),
            Some(Material::Diffuse { texture, twosided }) => {
                // The light segment must fit into max_depth too (Mitsuba's counting).
                if segment >= max_depth {
                    return total;
                }
                let albedo = scene.textures[*texture as usize].eval(it.tex_coord());
                return total + direct_diffuse(scene, &it, albedo, *twosided, params.light_samples, sampler, counts);
            }
            // no material (a light without a BSDF), glass, rough conductor: not this integrator's
            _ => return total,
        }
    }
    total
}

/// Perfect refraction with vacuum outside: a ray entering (from the side `ns`
/// points to) bends toward the normal with ratio 1/η; total internal reflection
/// mirrors.
pub fn perfect_refraction(wo: Vec3, ns: Vec3, eta: f32) -> Vec3 {
    let entering = ns.dot(wo) > 0.0;
    let (n, ratio) = if entering { (ns, 1.0 / eta) } else { (-ns, eta) };
    refract(wo, n, ratio).unwrap_or_else(|| reflect(wo, n))
}

/// Direct light at a diffuse point. Point lights: one shadow ray each. Area
/// lights and the environment: `light_samples` light samples and as many
/// cosine-weighted BSDF samples, combined by multiple importance sampling (power
/// heuristic), so neither a small bright source nor a broad sky that is mostly
/// behind the surface makes the estimate noisy.
fn direct_diffuse(
    scene: &Scene,
    it: &Interaction,
    albedo: Vec3,
    twosided: bool,
    light_samples: u32,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
) -> Vec3 {
    let n = if twosided && it.ns.dot(it.wo) < 0.0 { -it.ns } else { it.ns };
    if n.dot(it.wo) <= 0.0 {
        return Vec3::ZERO; // the back of a one-sided surface is black
    }
    let mut total = Vec3::ZERO;
    for (index, light) in scene.lights.iter().enumerate() {
        if light.is_delta() {
            if let Some(ls) = light.sample(it.p, Vec2::ZERO, scene.light_sampling) {
                let cos = n.dot(ls.wi);
                if cos > 0.0 {
                    counts.rays += 1;
                    let tr = scene.transmittance(&shadow_ray(it, &ls));
                    if tr > 0.0 {
                        total += ls.radiance * cos * tr;
                    }
                }
            }
            continue;
        }
        // only area lights and the environment need the frame (for BSDF sampling)
        let frame = Frame::from_normal(n);
        let mut sum = Vec3::ZERO;
        for _ in 0..light_samples {
            // light sampling
            if let Some(ls) = light.sample(it.p, Vec2::from(sampler.next_2d()), scene.light_sampling) {
                let cos = n.dot(ls.wi);
                if cos > 0.0 && ls.pdf > 0.0 && ls.radiance != Vec3::ZERO {
                    counts.rays += 1;
                    let tr = scene.transmittance(&shadow_ray(it, &ls));
                    if tr > 0.0 {
                        let w = power_heuristic(ls.pdf, cos * INV_PI);
                        sum += ls.radiance * (cos * w / ls.pdf) * tr;
                    }
                }
            }
            // BSDF sampling: the estimate f·L·cos/pdf is ρ·L for cosine sampling (ρ applied below, with π)
            let wi = frame.to_world(cosine_hemisphere(Vec2::from(sampler.next_2d())));
            let cos = n.dot(wi);
            if cos <= 0.0 {
                continue;
            }
            let bsdf_pdf = cos * INV_PI;
            counts.rays += 1;
            let ray = spawn_ray(it, wi);
            let (radiance, light_pdf) = match scene.intersect(&ray) {
                Some(hit) => {
                    let lit = scene.interaction(&ray, &hit);
                    match scene.area_light_of(&lit) {
                        Some((i, area)) if i as usize == index => (
                            area.emitted(lit.ng, lit.wo, lit.uv),
                            light.pdf(it.p, wi, Some((lit.p, lit.ng)), scene.light_sampling),
                        ),
                        _ => continue,
                    }
                }
                None if scene.environment == Some(index as u32) => {
                    (scene.environment_radiance(wi), light.pdf(it.p, wi, None, scene.light_sampling))
                }
                None => continue,
            };
            if radiance != Vec3::ZERO {
                sum += radiance * (cos * power_heuristic(bsdf_pdf, light_pdf) / bsdf_pdf);
            }
        }
        total += sum / light_samples as f32;
    }
    albedo * INV_PI * total
}
