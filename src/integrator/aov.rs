//! Feature buffers (`rdr render --aov albedo,normal,depth,position`), what denoisers
//! such as Open Image Denoise take besides the noisy image.
//!
//! Every camera sample of [`super::camera_pass`] also traces its camera ray here:
//! `depth` (distance from the camera) and `position` (world space) of the first
//! surface hit; `albedo` and `normal` of the first non-specular one, following smooth
//! mirrors, glass and conductors as OIDN expects (the albedo is then the product of the
//! specular weights and that surface's albedo). A surface's albedo is one BSDF sample's
//! weight `f·cos/pdf`, whose mean is the directional albedo (a diffuse surface's
//! reflectance exactly, per sample). Choices here (glass: reflect or refract) take
//! a sampler of their own, so the image itself is the same with and without `--aov`.
//! Values are averaged over the same samples as the image, with a box filter (each
//! sample to its own pixel): albedo and normal over all samples (a miss adds zero),
//! depth and position over the samples that hit something (zero where none did):
//! [`crate::film::aov`] writes them out.

use super::spawn_ray;
use crate::film::AovSample;
use crate::geometry::Ray;
use crate::math::{Vec2, Vec3};
use crate::sampler::PixelSampler;
use crate::scene::Scene;

/// Most smooth specular bounces followed to find a non-specular surface.
const MAX_SPECULAR_BOUNCES: u32 = 16;

/// Seed offset of the features' own sampler, so they never consume the image's samples.
const AOV_SEED: u32 = 0xa0f5_3c1d;

/// The sampler of the features of sample `pass` of pixel (`x`, `y`).
pub fn aov_sampler(x: u32, y: u32, pass: u32, seed: u32) -> PixelSampler {
    PixelSampler::new(x, y, pass, seed ^ AOV_SEED)
}

/// The features seen along the camera ray `ray`.
pub fn features(scene: &Scene, ray: &Ray, sampler: &mut PixelSampler) -> AovSample {
    let mut out = AovSample::default();
    let mut ray = *ray;
    let mut weight = Vec3::ONE;
    for bounce in 0..=MAX_SPECULAR_BOUNCES {
        let Some(hit) = scene.intersect(&ray) else { break };
        let it = scene.interaction(&ray, &hit);
        if bounce == 0 {
            out.depth = Some(hit.t * ray.d.length());
            out.position = it.p;
        }
        let Some(material) = scene.material_of(&it) else {
            // an emitter without a material: its normal, no albedo
            out.normal = it.ns;
            break;
        };
        let bsdf = material.bsdf_at(&it, &scene.textures);
        let uc = sampler.next_1d();
        let bs = bsdf.sample(it.wo, Vec2::from(sampler.next_2d()), uc);
        if !bsdf.is_delta() {
            out.normal = it.ns;
            if let Some(bs) = bs.filter(|b| b.weight.is_finite()) {
                out.albedo = weight * bs.weight;
            }
            break;
        }
        let Some(bs) = bs else { break };
        // the weight of a refraction carries radiance's 1/η², which albedo does not
        weight *= bs.weight * (bs.eta * bs.eta);
        if weight == Vec3::ZERO || !weight.is_finite() {
            break;
        }
        ray = spawn_ray(&it, bs.wi);
    }
    out
}
