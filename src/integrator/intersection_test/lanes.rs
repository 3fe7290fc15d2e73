//! `intersection_test`'s lane-wise code for pixel blocks: the diffuse first
//! hits of a packet of camera rays in structure-of-arrays form (shading points,
//! the plain triangles' hits), the point lights' terms and shadow rays per lane,
//! and the paths' ends.

use crate::accel::wide::PACKET;
use crate::geometry::mesh::Mesh;
use crate::geometry::Ray;
use crate::material::Material;
use crate::math::{is_finite_lane, offset_coordinates, Vec3, INV_4PI, INV_PI};
use crate::scene::{Interaction, Prim, Scene, Shape};
use crate::texture::Texture;

/// Lights a block's shadow rays are deferred for (more: ray by ray).
pub(super) const MAX_DEFERRED: usize = 4;

/// Lane `i`'s dot product of two vectors stored by axis, as glam's `Vec3::dot` orders it.
#[inline(always)]
fn lane_dot(u: &[[f32; PACKET]; 3], w: &[[f32; PACKET]; 3], i: usize) -> f32 {
    (u[0][i] * w[0][i]) + (u[1][i] * w[1][i]) + (u[2][i] * w[2][i])
}

/// The lanes whose flag is set, as bits.
#[inline(always)]
fn lane_mask(flags: &[bool; PACKET]) -> u32 {
    flags.iter().enumerate().fold(0, |m, (i, &f)| m | (f as u32) << i)
}

/// The path totals and albedos of a block's diffuse first hits by lane, in
/// structure-of-arrays form, and the last step of their radiance.
#[derive(Default)]
pub(super) struct PathEnds {
    pub(super) total: [[f32; PACKET]; 3],
    pub(super) albedo: [[f32; PACKET]; 3],
}

/// Lane `i` of vectors stored by axis set to `v`.
#[inline(always)]
pub(super) fn set_lane(lanes: &mut [[f32; PACKET]; 3], i: usize, v: Vec3) {
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
    pub(super) fn finish(&self, terms: &[[[f32; PACKET]; 3]], lit: &[u32], wait: u32, out: &mut [Vec3]) {
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
pub(super) struct ShadingPoints {
    p: [[f32; PACKET]; 3],
    ng: [[f32; PACKET]; 3],
    nf: [[f32; PACKET]; 3],
}

// lanes are indexed in step across several arrays
#[allow(clippy::needless_range_loop)]
impl ShadingPoints {
    pub(super) fn set(&mut self, i: usize, it: &Interaction, n: Vec3) {
        for a in 0..3 {
            (self.p[a][i], self.ng[a][i], self.nf[a][i]) = (it.p[a], it.ng[a], n[a]);
        }
    }

    /// `direct_diffuse`'s light term `L·cosθ` of a point light for the lanes in `mask`: the terms (into `c`),
    /// and the mask of the lanes it reaches with their shadow rays, lane by lane with
    /// `Light::sample`'s and `shadow_ray`'s operations in their order; the arrays
    /// let the compiler do the square roots and divisions four lanes at a time.
    #[inline(always)]
    pub(super) fn point_terms(&self, position: Vec3, flux: Vec3, mask: u32, c: &mut [[f32; PACKET]; 3]) -> (u32, [Ray; PACKET]) {
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
        let reached = lane_mask(&reach);
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
/// has no differentials, so its point is `Interaction::on_triangle` without uv). Its
/// vertices, vertex normals (if the mesh has them), albedo and two-sidedness.
#[inline(always)]
pub(super) fn plain_diffuse_triangle(scene: &Scene, prim: u32) -> Option<PlainTriangle<'_>> {
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
pub(super) struct PlainTriangle<'a> {
    p: &'a [Vec3; 3],
    normals: Option<[u32; 3]>,
    mesh: &'a Mesh,
    pub(super) albedo: Vec3,
    twosided: bool,
}

/// A block's plain diffuse triangle hits by lane, in structure-of-arrays form: the
/// vertices and vertex normals (`[vertex][axis][lane]`), barycentrics and the
/// direction towards the camera.
#[derive(Default)]
pub(super) struct PlainHits {
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
    pub(super) fn set(&mut self, i: usize, t: &PlainTriangle, b: [f32; 3], d: Vec3) {
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

    /// `Interaction::on_triangle` without uv and `facing_normal` of the lanes in `mask`,
    /// lane by lane with their operations in their order (`triangle_point`, glam's
    /// `cross`, `dot` and `length`), so the compiler can do the square roots and
    /// divisions of several lanes at once: the point, geometric and facing normal go
    /// into `at`; returns the lanes that have a facing normal.
    #[inline(always)]
    pub(super) fn shade(&self, mask: u32, at: &mut ShadingPoints) -> u32 {
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
        lane_mask(&take)
    }
}

#[cfg(test)]
mod tests {
    use super::super::facing_normal;
    use super::*;
    use crate::geometry::obj::ObjTriangle;
    use crate::sampler::hash_u32;

    /// `PlainHits::shade` against `Interaction::on_triangle` without uv and `facing_normal`,
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
                let it = Interaction::on_triangle(&p, b, &mesh, 0, 0, -d, false);
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
