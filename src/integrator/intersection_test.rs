//! The `intersection_test` integrator, physically based (spec §13 with the refs
//! README's conventions): follow perfect refraction up to `max_depth` path
//! segments, adding emission seen on the way (area lights, the environment for
//! rays that escape); at the first diffuse surface add the direct light of every
//! light: point lights with one shadow ray each (`ρ/π · cosθ · (Φ/4π) / d²`),
//! area lights and the environment with `light_samples` samples each, drawn by
//! the light's own importance (or uniformly, for comparisons).

use super::{shadow_ray, spawn_ray};
use crate::geometry::Ray;
use crate::material::Material;
use crate::math::{reflect, refract, Vec2, Vec3, INV_PI};
use crate::sampler::PixelSampler;
use crate::scene::{Interaction, Scene};

/// Counters a render thread keeps for the benchmark figures.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayCounts {
    pub rays: u64,
}

/// Radiance arriving along a camera ray.
pub fn li(scene: &Scene, mut ray: Ray, sampler: &mut PixelSampler, counts: &mut RayCounts) -> Vec3 {
    let mut total = Vec3::ZERO;
    // `segment` is the number of path segments so far, the camera ray being the first.
    for segment in 1..=scene.max_depth {
        counts.rays += 1;
        let Some(hit) = scene.intersect(&ray) else {
            return total + scene.environment_radiance(ray.d);
        };
        let it = scene.interaction(&ray, &hit);
        if let Some((_, light)) = scene.area_light_of(&it) {
            total += light.emitted(it.ng, it.wo);
        }
        match scene.material_of(&it) {
            Some(Material::Refraction { eta }) => ray = spawn_ray(&it, perfect_refraction(it.wo, it.ns, *eta)),
            Some(Material::Diffuse { texture, twosided }) => {
                // The light segment must fit into max_depth too (Mitsuba's counting).
                if segment >= scene.max_depth {
                    return total;
                }
                let albedo = scene.textures[*texture as usize].eval(it.uv);
                return total + direct_diffuse(scene, &it, albedo, *twosided, sampler, counts);
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

fn direct_diffuse(
    scene: &Scene,
    it: &Interaction,
    albedo: Vec3,
    twosided: bool,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
) -> Vec3 {
    let n = if twosided && it.ns.dot(it.wo) < 0.0 { -it.ns } else { it.ns };
    if n.dot(it.wo) <= 0.0 {
        return Vec3::ZERO; // the back of a one-sided surface is black
    }
    let f = albedo * INV_PI;
    let mut total = Vec3::ZERO;
    for light in &scene.lights {
        let samples = if light.is_delta() { 1 } else { scene.light_samples };
        let mut sum = Vec3::ZERO;
        for _ in 0..samples {
            let u = if light.is_delta() {
                Vec2::ZERO
            } else {
                Vec2::from(sampler.next_2d())
            };
            let Some(ls) = light.sample(it.p, u, scene.light_sampling) else {
                continue;
            };
            let cos = n.dot(ls.wi);
            if cos <= 0.0 || ls.pdf <= 0.0 || ls.radiance == Vec3::ZERO {
                continue;
            }
            counts.rays += 1;
            if scene.occluded(&shadow_ray(it, &ls)) {
                continue;
            }
            sum += ls.radiance * (cos / ls.pdf);
        }
        total += sum / samples as f32;
    }
    f * total
}
