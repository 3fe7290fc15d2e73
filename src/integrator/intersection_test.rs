//! The `intersection_test` integrator, physically based (spec §13 with the refs
//! README's conventions): follow perfect refraction up to `max_depth` path
//! segments, adding emission seen on the way (area lights, the environment for
//! rays that escape); at the first diffuse surface add the direct light of every
//! light: point lights with one shadow ray each (`ρ/π · cosθ · (Φ/4π) / d²`),
//! area lights and the environment with `light_samples` light samples (drawn by
//! the light's own importance, or uniformly for comparisons) and as many BSDF
//! samples each, combined by MIS.

use super::pass::CameraBlock;
use super::{shadow_ray, spawn_ray, RayCounts};
use crate::accel::wide::{PacketHits, PACKET};
use crate::geometry::mesh::Mesh;
use crate::geometry::{Ray, RayDifferential};
use crate::light::Light;
use crate::material::Material;
use crate::math::{is_finite_lane, offset_coordinates, reflect, refract, Frame, Vec2, Vec3, INV_4PI, INV_PI};
use crate::sampler::PixelSampler;
use crate::sampling::{cosine_hemisphere, power_heuristic};
use crate::scene::{Hit, Interaction, Prim, Scene, Shape};
use crate::texture::Texture;

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

/// Lights a block's shadow rays are deferred for (more: ray by ray).
const MAX_DEFERRED: usize = 4;

/// Lane `i`'s dot product of two vectors stored by axis, as glam's `Vec3::dot` orders it.
#[inline(always)]
fn lane_dot(u: &[[f32; PACKET]; 3], w: &[[f32; PACKET]; 3], i: usize) -> f32 {
    (u[0][i] * w[0][i]) + (u[1][i] * w[1][i]) + (u[2][i] * w[2][i])
}

/// The path totals and albedos of a block's diffuse first hits by lane, in
/// structure-of-arrays form, and the last step of their radiance.
#[derive(Default)]
struct PathEnds {
    total: [[f32; PACKET]; 3],
    albedo: [[f32; PACKET]; 3],
}

/// Lane `i` of vectors stored by axis set to `v`.
#[inline(always)]
fn set_lane(lanes: &mut [[f32; PACKET]; 3], i: usize, v: Vec3) {
    for (a, axis) in lanes.iter_mut().enumerate() {
        axis[i] = v[a];
    }
}

// lanes are indexed in step across several arrays
#[allow(clippy::needless_range_loop)]
impl PathEnds {
    /// The radiance of the lanes in `wait`: `direct_diffuse`'s sum of the lights'
    /// terms, in light order, over the lights that reach a lane unoccluded
    /// (transmittance 1), then `total + ρ/π · direct`, as glam orders it.
    #[inline(always)]
    fn finish(&self, terms: &[[[f32; PACKET]; 3]], lit: &[u32], wait: u32, out: &mut [Vec3]) {
        const L: usize = PACKET;
        let mut direct = [[0.0f32; L]; 3];
        for (term, &lit) in terms.iter().zip(lit) {
            for a in 0..3 {
                for i in 0..L {
                    let add = direct[a][i] + term[a][i] * 1.0;
                    direct[a][i] = if lit >> i & 1 != 0 { add } else { direct[a][i] };
                }
            }
        }
        let mut radiance = [[0.0f32; L]; 3];
        for a in 0..3 {
            for i in 0..L {
                radiance[a][i] = self.total[a][i] + self.albedo[a][i] * INV_PI * direct[a][i];
            }
        }
        // interleaved into x, y, z by lane with vector stores first: a lane's radiance
        // stored as three floats was read back by the film as two and one, a load the
        // stores could not forward (a stall per sample)
        let mut xyz = [0.0f32; 3 * L];
        for i in 0..L {
            for a in 0..3 {
                xyz[3 * i + a] = radiance[a][i];
            }
        }
        for i in (0..L.min(out.len())).filter(|&i| wait >> i & 1 != 0) {
            out[i] = Vec3::from_slice(&xyz[3 * i..3 * i + 3]);
        }
    }
}

/// A block's diffuse shading points by lane, in structure-of-arrays form: position,
/// geometric normal and the shading normal facing the ray.
#[derive(Default)]
struct ShadingPoints {
    p: [[f32; PACKET]; 3],
    ng: [[f32; PACKET]; 3],
    nf: [[f32; PACKET]; 3],
}

// lanes are indexed in step across several arrays
#[allow(clippy::needless_range_loop)]
impl ShadingPoints {
    fn set(&mut self, i: usize, it: &Interaction, n: Vec3) {
        for a in 0..3 {
            (self.p[a][i], self.ng[a][i], self.nf[a][i]) = (it.p[a], it.ng[a], n[a]);
        }
    }

    /// `direct_diffuse`'s light term `L·cosθ` of a point light for the lanes in `mask`: the terms (into `c`),
    /// and the mask of the lanes it reaches with their shadow rays, lane by lane with
    /// `Light::sample`'s and `shadow_ray`'s operations in their order; the arrays
    /// let the compiler do the square roots and divisions four lanes at a time.
    #[inline(always)]
    fn point_terms(&self, position: Vec3, flux: Vec3, mask: u32, c: &mut [[f32; PACKET]; 3]) -> (u32, [Ray; PACKET]) {
        const L: usize = PACKET;
        let (p, ng, nf) = (&self.p, &self.ng, &self.nf);
        let mut v = [[0.0f32; L]; 3];
        for a in 0..3 {
            for i in 0..L {
                v[a][i] = position[a] - p[a][i];
            }
        }
        let mut d2 = [0.0f32; L];
        let mut root = [0.0f32; L];
        for i in 0..L {
            d2[i] = lane_dot(&v, &v, i);
            root[i] = d2[i].sqrt();
        }
        // wi = v / √d2; cos θ = n·wi
        let mut wi = [[0.0f32; L]; 3];
        for a in 0..3 {
            for i in 0..L {
                wi[a][i] = v[a][i] / root[i];
            }
        }
        let scaled = flux * INV_4PI;
        let mut reach = [false; L];
        for i in 0..L {
            let cos = lane_dot(nf, &wi, i);
            reach[i] = (mask >> i & 1 != 0) & (d2[i] != 0.0) & (cos > 0.0);
            // `Vec3::new(scaled / d2) * cos`, by component
            for a in 0..3 {
                c[a][i] = (scaled[a] / d2[i]) * cos;
            }
        }
        // the shadow ray: from the point pushed off its surface (on the light's side)
        // towards the light; `offset_ray_origin` by coordinate, so the lanes vectorize
        let mut front = [false; L];
        for i in 0..L {
            front[i] = lane_dot(&v, ng, i) >= 0.0;
        }
        let (mut side, mut pushed) = ([[0.0f32; L]; 3], [[0.0f32; L]; 3]);
        for a in 0..3 {
            for i in 0..L {
                side[a][i] = if front[i] { ng[a][i] } else { -ng[a][i] };
            }
            offset_coordinates(&p[a], &side[a], &mut pushed[a]);
        }
        let (mut o, mut to) = ([[0.0f32; L]; 3], [[0.0f32; L]; 3]);
        for a in 0..3 {
            for i in 0..L {
                // unused lanes start at the light: anything harmless
                o[a][i] = if reach[i] { pushed[a][i] } else { position[a] };
                to[a][i] = position[a] - o[a][i];
            }
        }
        let mut dist = [0.0f32; L];
        for i in 0..L {
            dist[i] = lane_dot(&to, &to, i).sqrt();
        }
        let mut d = [[0.0f32; L]; 3];
        for a in 0..3 {
            for i in 0..L {
                d[a][i] = to[a][i] / dist[i];
            }
        }
        let mut reached = 0u32;
        for (i, &r) in reach.iter().enumerate() {
            reached |= (r as u32) << i;
        }
        // made in place (an array filled with a template first cost a copy per lane)
        let rays = std::array::from_fn(|i| Ray {
            o: Vec3::new(o[0][i], o[1][i], o[2][i]),
            d: Vec3::new(d[0][i], d[1][i], d[2][i]),
            t_min: 0.0,
            t_max: dist[i] * (1.0 - 1e-5),
        });
        (reached, rays)
    }
}

/// Lane `hit`'s surface when `surface` would find a diffuse triangle with nothing else
/// to it: a mesh triangle without an area light, its material diffuse with a constant
/// texture (the caller checks that the scene reads no texture coordinates and the ray
/// has no differentials, so its point is `Interaction::on_triangle_plain`). Its
/// vertices, vertex normals (if the mesh has them), albedo and two-sidedness.
#[inline(always)]
fn plain_diffuse_triangle(scene: &Scene, prim: u32) -> Option<PlainTriangle<'_>> {
    let Prim::Triangle { p, object, index } = &scene.prims[prim as usize] else {
        return None;
    };
    let obj = &scene.objects[*object as usize];
    let Shape::Mesh(mesh) = &obj.shape else {
        return None;
    };
    if obj.light.is_some() {
        return None;
    }
    let Some(Material::Diffuse { texture, twosided }) = scene.material_of_object(*object) else {
        return None;
    };
    let Texture::Constant(albedo) = scene.textures[*texture as usize] else {
        return None;
    };
    Some(PlainTriangle {
        p,
        normals: mesh.triangles[*index as usize].n,
        mesh,
        albedo,
        twosided: *twosided,
    })
}

/// What [`plain_diffuse_triangle`] finds, by reference: the vertices, the indices
/// of the vertex normals in the mesh (if it has them), albedo and two-sidedness.
#[derive(Clone, Copy)]
struct PlainTriangle<'a> {
    p: &'a [Vec3; 3],
    normals: Option<[u32; 3]>,
    mesh: &'a Mesh,
    albedo: Vec3,
    twosided: bool,
}

/// A block's plain diffuse triangle hits by lane, in structure-of-arrays form: the
/// vertices and vertex normals (`[vertex][axis][lane]`), barycentrics and the
/// direction towards the camera.
#[derive(Default)]
struct PlainHits {
    v: [[[f32; PACKET]; 3]; 3],
    n: [[[f32; PACKET]; 3]; 3],
    b: [[f32; PACKET]; 3],
    wo: [[f32; PACKET]; 3],
    /// Lanes whose mesh has vertex normals (by lane, not as bits: the lane loops
    /// vectorize without a shift per lane).
    normals: [bool; PACKET],
    twosided: [bool; PACKET],
}

// lanes are indexed in step across several arrays
#[allow(clippy::needless_range_loop)]
impl PlainHits {
    #[inline(always)]
    fn set(&mut self, i: usize, t: &PlainTriangle, b: [f32; 3], d: Vec3) {
        for k in 0..3 {
            for a in 0..3 {
                self.v[k][a][i] = t.p[k][a];
            }
            self.b[k][i] = b[k];
            self.wo[k][i] = -d[k];
        }
        // without vertex normals the lane's `n` stays as `default` left it (unread:
        // `shade` takes the geometric normal there); each block starts a new `PlainHits`
        if let Some(n) = t.normals {
            for k in 0..3 {
                let n = t.mesh.normals[n[k] as usize];
                for a in 0..3 {
                    self.n[k][a][i] = n[a];
                }
            }
            self.normals[i] = true;
        }
        self.twosided[i] = t.twosided;
    }

    /// `Interaction::on_triangle_plain` and `facing_normal` of the lanes in `mask`,
    /// lane by lane with their operations in their order (`triangle_point`, glam's
    /// `cross`, `dot` and `length`), so the compiler can do the square roots and
    /// divisions of several lanes at once: the point, geometric and facing normal go
    /// into `at`; returns the lanes that have a facing normal.
    #[inline(always)]
    fn shade(&self, mask: u32, at: &mut ShadingPoints) -> u32 {
        const L: usize = PACKET;
        let (v, n, b, wo) = (&self.v, &self.n, &self.b, &self.wo);
        // (b0·p0 + b1·p1) + b2·p2, and the same of the vertex normals
        let (mut pos, mut sv) = ([[0.0f32; L]; 3], [[0.0f32; L]; 3]);
        for a in 0..3 {
            for i in 0..L {
                pos[a][i] = (v[0][a][i] * b[0][i] + v[1][a][i] * b[1][i]) + v[2][a][i] * b[2][i];
                sv[a][i] = (n[0][a][i] * b[0][i] + n[1][a][i] * b[1][i]) + n[2][a][i] * b[2][i];
            }
        }
        // ng = normalize_div((p1 − p0) × (p2 − p0))
        let (mut e1, mut e2) = ([[0.0f32; L]; 3], [[0.0f32; L]; 3]);
        for a in 0..3 {
            for i in 0..L {
                e1[a][i] = v[1][a][i] - v[0][a][i];
                e2[a][i] = v[2][a][i] - v[0][a][i];
            }
        }
        let mut c = [[0.0f32; L]; 3];
        for i in 0..L {
            c[0][i] = e1[1][i] * e2[2][i] - e2[1][i] * e1[2][i];
            c[1][i] = e1[2][i] * e2[0][i] - e2[2][i] * e1[0][i];
            c[2][i] = e1[0][i] * e2[1][i] - e2[0][i] * e1[1][i];
        }
        let (mut len, mut slen) = ([0.0f32; L], [0.0f32; L]);
        for i in 0..L {
            len[i] = lane_dot(&c, &c, i).sqrt();
            slen[i] = lane_dot(&sv, &sv, i).sqrt();
        }
        // interpolated vertex normals where the mesh has them and they do not vanish
        // (`&`, not `&&`: no branches, so the lanes vectorize)
        let mut smooth = [false; L];
        for i in 0..L {
            smooth[i] = self.normals[i] & (slen[i] > 0.0) & is_finite_lane(slen[i]);
        }
        let (mut ng, mut unit) = ([[0.0f32; L]; 3], [[0.0f32; L]; 3]);
        for a in 0..3 {
            for i in 0..L {
                ng[a][i] = c[a][i] / len[i];
                unit[a][i] = sv[a][i] / slen[i];
            }
        }
        // divided in every lane, then selected: a division under the condition was
        // compiled to a branch and a scalar division per lane
        let mut ns = [[0.0f32; L]; 3];
        for a in 0..3 {
            for i in 0..L {
                ns[a][i] = if smooth[i] { unit[a][i] } else { ng[a][i] };
            }
        }
        let mut nf = [[0.0f32; L]; 3];
        let mut take = [false; L];
        for i in 0..L {
            let flip = self.twosided[i] & (lane_dot(&ns, wo, i) < 0.0);
            for a in 0..3 {
                nf[a][i] = if flip { -ns[a][i] } else { ns[a][i] };
            }
            take[i] = (mask >> i & 1 != 0) & (lane_dot(&nf, wo, i) > 0.0);
        }
        // merged by selects, which vectorize (a loop over the set bits does not)
        for a in 0..3 {
            for i in 0..L {
                at.p[a][i] = if take[i] { pos[a][i] } else { at.p[a][i] };
                at.ng[a][i] = if take[i] { ng[a][i] } else { at.ng[a][i] };
                at.nf[a][i] = if take[i] { nf[a][i] } else { at.nf[a][i] };
            }
        }
        let mut facing = 0u32;
        for (i, &t) in take.iter().enumerate() {
            facing |= (t as u32) << i;
        }
        facing
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::obj::ObjTriangle;
    use crate::sampler::hash_u32;

    /// `PlainHits::shade` against `Interaction::on_triangle_plain` and `facing_normal`,
    /// bit for bit, on random triangles seen from both sides: one- and two-sided,
    /// with and without vertex normals (some of them vanishing, some too long for a
    /// float), lanes left out.
    #[test]
    fn plain_hits_shade_as_one_hit_at_a_time() {
        let mut k = 0u32;
        let unit = |k: &mut u32| {
            *k += 1;
            hash_u32(*k) as f32 / 4_294_967_296.0
        };
        let v = |k: &mut u32| Vec3::new(unit(k) * 4.0 - 2.0, unit(k) * 4.0 - 2.0, unit(k) * 4.0 - 2.0);
        for round in 0..200 {
            let mut plain = PlainHits::default();
            let mut expected = Vec::new();
            let mut mask = 0u32;
            for i in 0..PACKET {
                let p = [v(&mut k), v(&mut k), v(&mut k)];
                let normals = match i % 4 {
                    0 => None,
                    1 => Some([v(&mut k), v(&mut k), v(&mut k)]),
                    2 => Some([Vec3::ZERO; 3]),                          // vanishing: the geometric normal
                    _ => Some([v(&mut k) * 1e30, v(&mut k), v(&mut k)]), // infinite length: the same
                };
                let mesh = Mesh {
                    positions: p.to_vec(),
                    normals: normals.map_or(Vec::new(), |n| n.to_vec()),
                    triangles: vec![ObjTriangle {
                        p: [0, 1, 2],
                        n: normals.map(|_| [0, 1, 2]),
                        uv: None,
                        line: 1,
                    }],
                    ..Mesh::default()
                };
                let (u, w) = (unit(&mut k), unit(&mut k));
                let b = if u + w < 1.0 {
                    [1.0 - u - w, u, w]
                } else {
                    [u + w - 1.0, 1.0 - w, 1.0 - u]
                };
                let d = v(&mut k).normalize();
                let twosided = (round + i) % 2 == 0;
                let it = Interaction::on_triangle_plain(&p, b, &mesh, 0, 0, -d);
                let t = PlainTriangle {
                    p: &p,
                    normals: normals.map(|_| [0, 1, 2]),
                    mesh: &mesh,
                    albedo: Vec3::ONE,
                    twosided,
                };
                plain.set(i, &t, b, d);
                // every fifth lane is set but not asked for
                if i % 5 != 4 {
                    mask |= 1 << i;
                    expected.push((i, it.p, it.ng, facing_normal(&it, twosided)));
                }
            }
            let mut at = ShadingPoints::default();
            let facing = plain.shade(mask, &mut at);
            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
            for (i, p, ng, nf) in expected {
                assert_eq!(facing >> i & 1 != 0, nf.is_some(), "round {round} lane {i}");
                if let Some(nf) = nf {
                    let lane = |a: &[[f32; PACKET]; 3]| Vec3::new(a[0][i], a[1][i], a[2][i]);
                    assert_eq!(bits(lane(&at.p)), bits(p), "round {round} lane {i}");
                    assert_eq!(bits(lane(&at.ng)), bits(ng), "round {round} lane {i}");
                    assert_eq!(bits(lane(&at.nf)), bits(nf), "round {round} lane {i}");
                }
            }
            assert_eq!(facing & !mask, 0, "lanes left out stay out");
        }
    }
}
