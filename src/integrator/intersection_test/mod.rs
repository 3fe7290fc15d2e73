//! The `intersection_test` integrator, physically based (spec §13 with the refs
//! README's conventions): follow perfect refraction up to `max_depth` path
//! segments, adding emission seen on the way (area lights, the environment for
//! rays that escape); at the first diffuse surface add the direct light of every
//! light: point lights with one shadow ray each (`ρ/π · cosθ · (Φ/4π) / d²`),
//! area lights and the environment with `light_samples` light samples (drawn by
//! the light's own importance, or uniformly for comparisons) and as many BSDF
//! samples each, combined by MIS.

mod lanes;

use super::estimator::{emitter_weight, light_sample_weight, PathProfile};
use super::pass::CameraBlock;
use super::{shadow_ray, spawn_ray, RayCounts};
use crate::accel::wide::{PacketHits, PACKET};
use crate::geometry::{Ray, RayDifferential};
use crate::light::Light;
use crate::material::Material;
use crate::math::{reflect, refract, Frame, Vec2, Vec3, INV_PI};
use crate::sampler::PixelSampler;
use crate::sampling::cosine_hemisphere;
use crate::scene::{Hit, Interaction, Scene};
use lanes::{plain_diffuse_triangle, set_lane, PathEnds, PlainHits, ShadingPoints, MAX_DEFERRED};

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
        counts.rays += 1;
        let hit = scene.intersect(&ray);
        li_from(scene, self, ray, hit, diff, sampler, counts)
    }

    /// [`IntersectionTest::li`] of a pixel block's camera samples, each radiance
    /// exactly as `li` computes it: the camera rays are traced as a packet, and
    /// where every light is a point light (one shadow ray each, no sampler), the
    /// shadow rays of the diffuse first hits are made and traced as one packet per
    /// light.
    pub fn li_block(&self, scene: &Scene, block: &mut CameraBlock, out: &mut [Vec3]) {
        // the lane loops below compiled for the render's kernel set
        scene.bvh.isa().run(
            #[inline(always)]
            || self.li_block_body(scene, block, out),
        )
    }

    #[inline(always)]
    // lanes are indexed in step across the block's arrays and the hits' lanes
    #[allow(clippy::needless_range_loop)]
    fn li_block_body(&self, scene: &Scene, block: &mut CameraBlock, out: &mut [Vec3]) {
        let n = block.rays.len().min(PACKET);
        let mut hits = PacketHits::default();
        scene.intersect_packet_lanes(&block.rays[..n], (1 << n) - 1, &mut hits);
        block.counts.rays += n as u64;
        let lights = &scene.lights;
        // shadow rays are 0 or 1 without masks (`Scene::transmittance`)
        let point = |l: &Light| matches!(l, Light::Point { .. });
        let deferred = self.max_depth > 1 && !scene.has_masks && lights.len() <= MAX_DEFERRED && lights.iter().all(point);
        // diffuse first hits waiting for their shadow rays: the path's total and the
        // albedo by lane (plain triangles have no emission: total 0), the point and its normals
        let mut wait = 0u32;
        let mut ends = PathEnds::default();
        let mut at = ShadingPoints::default();
        // plain diffuse triangles: their points made together below
        let mut plain = PlainHits::default();
        let mut plain_lanes = 0u32;
        // the last lane's triangle and what `plain_diffuse_triangle` found for it
        let (mut last_prim, mut last) = (u32::MAX, None);
        for i in 0..n {
            if !deferred {
                let (ray, diff) = (block.rays[i], block.diffs[i]);
                out[i] = li_from(scene, self, ray, hits.get(i), diff, &mut block.samplers[i], block.counts);
                continue;
            }
            // by reference: a lane's ray and differentials are read, not copied
            let (ray, diff) = (&block.rays[i], &block.diffs[i]);
            if hits.found >> i & 1 == 0 {
                out[i] = scene.environment_radiance(ray.d);
                continue;
            }
            let prim = hits.prim[i];
            if diff.is_none() && !scene.texture_coords {
                // neighbouring pixels mostly hit the same triangle: its lookup is kept
                if prim != last_prim {
                    (last_prim, last) = (prim, plain_diffuse_triangle(scene, prim));
                }
                if let Some(t) = &last {
                    plain.set(i, t, hits.barycentrics(i), ray.d);
                    plain_lanes |= 1 << i;
                    set_lane(&mut ends.albedo, i, t.albedo);
                    continue;
                }
            }
            let hit = hits.hit(i);
            let mut total = Vec3::ZERO;
            match surface(scene, ray, &hit, diff.as_ref(), &mut total) {
                Surface::Diffuse(it, texture, twosided) => {
                    // max_depth > 1: the light segment fits
                    let albedo = scene.textures[texture as usize].eval(it.tex_coord());
                    let Some(nrm) = facing_normal(&it, twosided) else {
                        out[i] = total + Vec3::ZERO; // what `direct_diffuse` returns there
                        continue;
                    };
                    set_lane(&mut ends.albedo, i, albedo);
                    set_lane(&mut ends.total, i, total);
                    at.set(i, &it, nrm);
                    wait |= 1 << i;
                }
                Surface::Refracted(next) => out[i] = li_path(scene, self, next, 2, total, &mut block.samplers[i], block.counts),
                Surface::Done => out[i] = total,
            }
        }
        if plain_lanes != 0 {
            let facing = plain.shade(plain_lanes, &mut at);
            let unlit = plain_lanes & !facing;
            for i in (0..n).filter(|&i| unlit >> i & 1 != 0) {
                out[i] = Vec3::ZERO; // what `direct_diffuse` returns there (no emission)
            }
            wait |= facing;
        }
        if wait == 0 {
            return;
        }
        // per light: the unoccluded terms (`L·cosθ`) of the points it reaches
        let mut terms = [[[0.0f32; PACKET]; 3]; MAX_DEFERRED];
        let mut lit = [0u32; MAX_DEFERRED];
        for (l, light) in lights.iter().enumerate() {
            let Light::Point { position, flux } = *light else {
                unreachable!("deferred only with point lights")
            };
            let (active, rays) = at.point_terms(position, flux, wait, &mut terms[l]);
            block.counts.rays += active.count_ones() as u64;
            lit[l] = active & !scene.occluded_packet(&rays[..n], active);
        }
        ends.finish(&terms[..lights.len()], &lit[..lights.len()], wait, out);
    }

    /// Whether [`IntersectionTest::li_block`] traces packets in `scene` (else the
    /// pass goes ray by ray).
    pub fn packets(&self, scene: &Scene) -> bool {
        scene.packets()
    }
}

/// What the path meets at a hit (its emission added to `total`).
enum Surface {
    /// A diffuse surface: texture, two-sided.
    Diffuse(Interaction, u32, bool),
    /// Through a refractor: the next segment.
    Refracted(Ray),
    /// Nothing more to follow (no material, or one this integrator does not handle).
    Done,
}

/// The surface a segment's ray hit: its emission into `total`, and what follows.
/// `diff` sets the texture footprint (camera rays only).
#[inline(always)]
fn surface(scene: &Scene, ray: &Ray, hit: &Hit, diff: Option<&RayDifferential>, total: &mut Vec3) -> Surface {
    let mut it = scene.interaction(ray, hit);
    if let Some(d) = diff {
        it.compute_uv_derivatives(d);
    }
    if let Some((_, light)) = scene.area_light_of(&it) {
        *total += light.emitted(it.ng, it.wo, it.uv);
    }
    match scene.material_of(&it) {
        Some(Material::Refraction { eta }) => Surface::Refracted(spawn_ray(&it, perfect_refraction(it.wo, it.ns, *eta))),
        Some(Material::Diffuse { texture, twosided }) => Surface::Diffuse(it, *texture, *twosided),
        // no material (a light without a BSDF), glass, rough conductor: not this integrator's
        _ => Surface::Done,
    }
}

/// The path from its camera ray, whose closest hit `hit` is traced already.
#[inline(always)]
fn li_from(
    scene: &Scene,
    params: &IntersectionTest,
    ray: Ray,
    hit: Option<Hit>,
    diff: Option<RayDifferential>,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
) -> Vec3 {
    let Some(hit) = hit else {
        return scene.environment_radiance(ray.d);
    };
    let mut total = Vec3::ZERO;
    match surface(scene, &ray, &hit, diff.as_ref(), &mut total) {
        Surface::Diffuse(it, texture, twosided) => diffuse_end(scene, params, &it, texture, twosided, 1, total, sampler, counts),
        Surface::Refracted(next) => li_path(scene, params, next, 2, total, sampler, counts),
        Surface::Done => total,
    }
}

/// The path on from path segment `first` (the camera ray being the first), with
/// `total` gathered so far.
fn li_path(
    scene: &Scene,
    params: &IntersectionTest,
    mut ray: Ray,
    first: u32,
    mut total: Vec3,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
) -> Vec3 {
    for segment in first..=params.max_depth {
        counts.rays += 1;
        let Some(hit) = scene.intersect(&ray) else {
            return total + scene.environment_radiance(ray.d);
        };
        match surface(scene, &ray, &hit, None, &mut total) {
            Surface::Diffuse(it, texture, twosided) => {
                return diffuse_end(scene, params, &it, texture, twosided, segment, total, sampler, counts)
            }
            Surface::Refracted(next) => ray = next,
            Surface::Done => return total,
        }
    }
    total
}

/// The end of a path at a diffuse surface reached by segment `segment`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn diffuse_end(
    scene: &Scene,
    params: &IntersectionTest,
    it: &Interaction,
    texture: u32,
    twosided: bool,
    segment: u32,
    total: Vec3,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
) -> Vec3 {
    // The light segment must fit into max_depth too (Mitsuba's counting).
    if segment >= params.max_depth {
        return total;
    }
    let albedo = scene.textures[texture as usize].eval(it.tex_coord());
    total + direct_diffuse(scene, it, albedo, twosided, params.light_samples, sampler, counts)
}

/// The normal on the side the ray came from, or `None` at the back of a one-sided
/// surface (which is black): `direct_diffuse`'s test.
fn facing_normal(it: &Interaction, twosided: bool) -> Option<Vec3> {
    let n = if twosided && it.ns.dot(it.wo) < 0.0 { -it.ns } else { it.ns };
    (n.dot(it.wo) > 0.0).then_some(n)
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
#[inline(always)]
fn direct_diffuse(
    scene: &Scene,
    it: &Interaction,
    albedo: Vec3,
    twosided: bool,
    light_samples: u32,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
) -> Vec3 {
    let Some(n) = facing_normal(it, twosided) else {
        return Vec3::ZERO; // the back of a one-sided surface is black
    };
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
                        let w = light_sample_weight(&ls, ls.pdf, || cos * INV_PI);
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
                sum += radiance * (cos * emitter_weight(PathProfile::Mis, false, bsdf_pdf, || light_pdf) / bsdf_pdf);
            }
        }
        total += sum / light_samples as f32;
    }
    albedo * INV_PI * total
}
