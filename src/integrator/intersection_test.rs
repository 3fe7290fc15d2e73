//! The `intersection_test` integrator, physically based (spec §13 with the refs
//! README's conventions): follow perfect refraction up to `max_depth` path
//! segments; at the first diffuse surface sum the direct light of every point
//! light, `ρ/π · cosθ · (Φ/4π) / d²`, with a shadow ray each.

use super::{spawn_ray, spawn_ray_to};
use crate::geometry::Ray;
use crate::light::Light;
use crate::material::Material;
use crate::math::{reflect, refract, Vec3, INV_PI};
use crate::scene::{Interaction, Scene};

/// Counters a render thread keeps for the benchmark figures.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayCounts {
    pub rays: u64,
}

/// Radiance arriving along a camera ray.
pub fn li(scene: &Scene, mut ray: Ray, counts: &mut RayCounts) -> Vec3 {
    // `segment` is the number of path segments so far, the camera ray being the first.
    for segment in 1..=scene.max_depth {
        counts.rays += 1;
        let Some(hit) = scene.intersect(&ray) else { return Vec3::ZERO };
        let it = scene.interaction(&ray, &hit);
        match scene.material_of(&it) {
            Some(Material::Refraction { eta }) => ray = spawn_ray(&it, perfect_refraction(it.wo, it.ns, *eta)),
            Some(Material::Diffuse { texture, twosided }) => {
                // The light segment must fit into max_depth too (Mitsuba's counting).
                if segment >= scene.max_depth {
                    return Vec3::ZERO;
                }
                let albedo = scene.textures[*texture as usize].eval(it.uv);
                return direct_diffuse(scene, &it, albedo, *twosided, counts);
            }
            // no material (a light without a BSDF), glass, rough conductor: not this integrator's
            _ => return Vec3::ZERO,
        }
    }
    Vec3::ZERO
}

/// Perfect refraction with vacuum outside: a ray entering (from the side `ns`
/// points to) bends toward the normal with ratio 1/η; total internal reflection
/// mirrors.
pub fn perfect_refraction(wo: Vec3, ns: Vec3, eta: f32) -> Vec3 {
    let entering = ns.dot(wo) > 0.0;
    let (n, ratio) = if entering { (ns, 1.0 / eta) } else { (-ns, eta) };
    refract(wo, n, ratio).unwrap_or_else(|| reflect(wo, n))
}

fn direct_diffuse(scene: &Scene, it: &Interaction, albedo: Vec3, twosided: bool, counts: &mut RayCounts) -> Vec3 {
    let n = if twosided && it.ns.dot(it.wo) < 0.0 { -it.ns } else { it.ns };
    if n.dot(it.wo) <= 0.0 {
        return Vec3::ZERO; // the back of a one-sided surface is black
    }
    let f = albedo * INV_PI;
    let mut total = Vec3::ZERO;
    for light in &scene.lights {
        match light {
            Light::Point { position, .. } => {
                let v = *position - it.p;
                let d2 = v.length_squared();
                let l = v / d2.sqrt();
                let cos = n.dot(l);
                if cos <= 0.0 || d2 == 0.0 {
                    continue;
                }
                counts.rays += 1;
                if scene.occluded(&spawn_ray_to(it, *position)) {
                    continue;
                }
                total += f * light.intensity() * (cos / d2);
            }
        }
    }
    total
}
