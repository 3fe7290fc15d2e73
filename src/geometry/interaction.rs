//! Surface interactions: the point a ray hit with its normals, texture
//! coordinates and shading frame, and their screen-space derivatives.

use super::cylinder::Cylinder;
use super::mesh::{Mesh, ATTRIBUTE_SLOTS};
use super::prim::{Hit, Prim};
use super::sphere::Sphere;
use super::{Ray, RayDifferential};
use crate::math::{normalize_div, Vec2, Vec3};

/// A surface point with everything shading needs.
#[derive(Clone, Copy, Debug)]
pub struct Interaction {
    pub p: Vec3,
    /// Geometric normal (triangle winding; spheres: outward).
    pub ng: Vec3,
    /// Shading normal (interpolated vertex normals, else `ng`).
    pub ns: Vec3,
    /// Texture coordinates: zero on triangles and spheres when made without them
    /// (`uv` false in [`Interaction::of_hit`], a scene that reads none).
    pub uv: Vec2,
    /// `∂p/∂u`, `∂p/∂v` of the uv parameterisation (spec §14.2; an arbitrary frame
    /// around `ng` where it is degenerate); zero, like `uv`, when made without them.
    pub dpdu: Vec3,
    pub dpdv: Vec3,
    /// Screen-space derivatives of `uv` per pixel; zero unless
    /// [`Interaction::compute_uv_derivatives`] was given the ray's differentials.
    pub duvdx: Vec2,
    pub duvdy: Vec2,
    /// Direction back along the incoming ray.
    pub wo: Vec3,
    pub object: u32,
    /// The mesh attributes the scene's textures read, by slot ([`Mesh::slots`]): a
    /// vertex attribute interpolated with the barycentrics, a face attribute as it is
    /// (zero where the mesh has none, on spheres and cylinders, and without `uv`).
    pub attributes: [Vec3; ATTRIBUTE_SLOTS],
}

/// Order of a sphere's texture coordinates (which one is the azimuth).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SphereUv {
    /// `uv = (φ/2π, θ/π)` as [`Sphere::uv`] gives it (pbrt, Mitsuba, Blender).
    PhiTheta,
    /// `uv = (θ/π, φ/2π)`, the derivatives in the same order.
    ThetaPhi,
}

impl Interaction {
    /// The surface point of `hit` on `prim` (the primitive `hit.prim` names).
    /// `mesh` gives the mesh of a triangle's object (its vertex normals and uvs);
    /// `sphere_uv` the order of a sphere's uv; `uv` whether to compute the texture
    /// coordinates, their tangents and the mesh attributes (false: zero on triangles
    /// and spheres, for scenes whose materials read none of them).
    #[inline]
    pub fn of_hit<'m>(prim: &Prim, ray: &Ray, hit: &Hit, mesh: impl FnOnce(u32) -> &'m Mesh, sphere_uv: SphereUv, uv: bool) -> Interaction {
        let wo = -ray.d;
        match prim {
            Prim::Triangle { p, object, index } => Interaction::on_triangle(p, hit.b, mesh(*object), *index, *object, wo, uv),
            Prim::Sphere { sphere, object } => Interaction::on_sphere(sphere, ray.at(hit.t), uv.then_some(sphere_uv), *object, wo),
            Prim::Cylinder { cylinder, object } => Interaction::on_cylinder(cylinder, ray.at(hit.t), *object, wo),
            // an sdfgrid's voxel (in its grid's frame): no uv, as Mitsuba's; the scene sets the shading normal
            Prim::SdfVoxel { voxel, object } => {
                let (p, n) = (ray.at(hit.t), voxel.normal(ray.at(hit.t)));
                Interaction::plain(p, n, n, *object, wo)
            }
            Prim::Instance { .. } => unreachable!("an instance's hit is resolved in its group (Scene::interaction)"),
        }
    }

    /// The point with barycentrics `b` on triangle `index` of `mesh` (vertices `p`):
    /// `(b0·p0 + b1·p1) + b2·p2` (spec §14.2, more accurate than `o + t·d`). With `uv`
    /// its texture coordinates, tangents and the mesh's colours; without, zero.
    #[inline]
    pub fn on_triangle(p: &[Vec3; 3], b: [f32; 3], mesh: &Mesh, index: u32, object: u32, wo: Vec3, uv: bool) -> Interaction {
        let (pos, ng, ns) = triangle_point(p, b, mesh, index);
        let plain = Interaction::plain(pos, ng, ns, object, wo);
        if uv {
            plain.with_triangle_uv(p, b, mesh, index)
        } else {
            plain
        }
    }

    /// The triangle point `self` (barycentrics `b`) with its texture coordinates,
    /// tangents and the mesh's colours (out of line: the common point needs none).
    fn with_triangle_uv(self, p: &[Vec3; 3], b: [f32; 3], mesh: &Mesh, index: u32) -> Interaction {
        let tri = &mesh.triangles[index as usize];
        let uvs = match tri.uv {
            Some(t) => t.map(|i| mesh.uvs[i as usize]),
            None => [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0)],
        };
        let (dpdu, dpdv) = triangle_dpduv(p, &uvs).unwrap_or_else(|| fallback_dpduv(self.ng));
        let mut attributes = [Vec3::ZERO; ATTRIBUTE_SLOTS];
        for (value, slot) in attributes.iter_mut().zip(mesh.slots) {
            let Some(a) = slot.map(|a| &mesh.attributes[a as usize]) else {
                continue;
            };
            *value = if a.per_face() {
                a.values[index as usize]
            } else {
                let c = tri.p.map(|i| a.values[i as usize]);
                (c[0] * b[0] + c[1] * b[1]) + c[2] * b[2]
            };
        }
        Interaction {
            uv: uvs[0] * b[0] + uvs[1] * b[1] + uvs[2] * b[2],
            dpdu,
            dpdv,
            attributes,
            ..self
        }
    }

    /// The point of `sphere` nearest `hit_point` (the ray at the hit distance). With
    /// `uv` (their order) its texture coordinates and tangents; without, zero.
    #[inline]
    pub fn on_sphere(sphere: &Sphere, hit_point: Vec3, uv: Option<SphereUv>, object: u32, wo: Vec3) -> Interaction {
        let (pos, n) = sphere.project(hit_point);
        let plain = Interaction::plain(pos, n, n, object, wo);
        let Some(order) = uv else {
            return plain;
        };
        let (mut uv, (mut dpdu, mut dpdv)) = sphere.uv_and_derivatives(n);
        if order == SphereUv::ThetaPhi {
            uv = Vec2::new(uv.y, uv.x);
            std::mem::swap(&mut dpdu, &mut dpdv);
        }
        let c = dpdu.cross(dpdv);
        if !(c.length_squared() > 0.0 && c.is_finite()) {
            (dpdu, dpdv) = fallback_dpduv(n);
        }
        Interaction { uv, dpdu, dpdv, ..plain }
    }

    /// The point of `cylinder` nearest `hit_point`; the normal points outwards (the
    /// scene flips it for `flip_normals`). Texture coordinates are Mitsuba's
    /// `(φ/2π, h)` ([`Cylinder::surface`]) in rdr's orientation, `(φ/2π, 1 − h)`: rdr's
    /// `v` runs the other way from Mitsuba's (an OBJ's coordinates are used as they
    /// are where Mitsuba flips them, and the XML reader rewrites `to_uv` for that), so
    /// a texture shows on the cylinder as Mitsuba shows it. Always with them (cheap).
    pub fn on_cylinder(cylinder: &Cylinder, hit_point: Vec3, object: u32, wo: Vec3) -> Interaction {
        let (p, n, uv, dpdu, dpdv) = cylinder.surface(hit_point);
        Interaction {
            uv: Vec2::new(uv.x, 1.0 - uv.y),
            dpdu,
            dpdv: -dpdv,
            ..Interaction::plain(p, n, n, object, wo)
        }
    }

    /// A point without texture coordinates, tangents and mesh attributes (zero): what
    /// every shape's constructor starts from.
    #[inline(always)]
    fn plain(p: Vec3, ng: Vec3, ns: Vec3, object: u32, wo: Vec3) -> Interaction {
        Interaction {
            p,
            ng,
            ns,
            uv: Vec2::ZERO,
            dpdu: Vec3::ZERO,
            dpdv: Vec3::ZERO,
            duvdx: Vec2::ZERO,
            duvdy: Vec2::ZERO,
            wo,
            object,
            attributes: [Vec3::ZERO; ATTRIBUTE_SLOTS],
        }
    }

    /// Sets `duvdx`, `duvdy` from the ray differentials of the ray that hit this point
    /// (pbrt-v4's `SurfaceInteraction::ComputeDifferentials`): the auxiliary rays are
    /// intersected with the tangent plane (`ng` through `p`), giving `∂p/∂x`, `∂p/∂y`,
    /// and `∂p/∂x = ∂p/∂u·∂u/∂x + ∂p/∂v·∂v/∂x` is solved in the least-squares sense.
    /// Auxiliary rays parallel to the plane, or a singular system, give zero
    /// derivatives (no filtering); the results are clamped to ±1e8.
    pub fn compute_uv_derivatives(&mut self, diff: &RayDifferential) {
        let n = self.ng;
        let hit_plane = |o: Vec3, d: Vec3| -> Option<Vec3> {
            let t = n.dot(self.p - o) / n.dot(d);
            t.is_finite().then(|| o + d * t)
        };
        let (Some(px), Some(py)) = (hit_plane(diff.rx_o, diff.rx_d), hit_plane(diff.ry_o, diff.ry_d)) else {
            self.duvdx = Vec2::ZERO;
            self.duvdy = Vec2::ZERO;
            return;
        };
        let (dpdx, dpdy) = (px - self.p, py - self.p);
        let (a00, a01, a11) = (self.dpdu.dot(self.dpdu), self.dpdu.dot(self.dpdv), self.dpdv.dot(self.dpdv));
        let det = a00 * a11 - a01 * a01;
        let inv = 1.0 / det;
        let solve = |b: Vec3| -> Vec2 {
            let (b0, b1) = (self.dpdu.dot(b), self.dpdv.dot(b));
            let r = Vec2::new(a11 * b0 - a01 * b1, a00 * b1 - a01 * b0) * inv;
            if r.is_finite() {
                r.clamp(Vec2::splat(-1e8), Vec2::splat(1e8))
            } else {
                Vec2::ZERO
            }
        };
        if det == 0.0 || !inv.is_finite() {
            self.duvdx = Vec2::ZERO;
            self.duvdy = Vec2::ZERO;
        } else {
            self.duvdx = solve(dpdx);
            self.duvdy = solve(dpdy);
        }
    }
}

/// A triangle's point with barycentrics `b`, its geometric normal and shading normal
/// (interpolated vertex normals where the mesh has them).
#[inline(always)]
fn triangle_point(p: &[Vec3; 3], b: [f32; 3], mesh: &Mesh, index: u32) -> (Vec3, Vec3, Vec3) {
    let pos = (p[0] * b[0] + p[1] * b[1]) + p[2] * b[2];
    let ng = normalize_div((p[1] - p[0]).cross(p[2] - p[0]));
    let ns = match mesh.triangles[index as usize].n {
        Some(n) => {
            let v = mesh.normals[n[0] as usize] * b[0] + mesh.normals[n[1] as usize] * b[1] + mesh.normals[n[2] as usize] * b[2];
            let l = v.length();
            if l > 0.0 && l.is_finite() {
                v / l
            } else {
                ng
            }
        }
        None => ng,
    };
    (pos, ng, ns)
}

/// `∂p/∂u`, `∂p/∂v` from three points and their uv (pbrt); `None` when the uv
/// triangle is degenerate (|det| < 1e-8) or the two vectors are parallel.
fn triangle_dpduv(p: &[Vec3; 3], uv: &[Vec2; 3]) -> Option<(Vec3, Vec3)> {
    let (duv02, duv12) = (uv[0] - uv[2], uv[1] - uv[2]);
    let (dp02, dp12) = (p[0] - p[2], p[1] - p[2]);
    let det = duv02.x * duv12.y - duv02.y * duv12.x;
    if det.abs() < 1e-8 {
        return None;
    }
    let inv = 1.0 / det;
    let dpdu = (dp02 * duv12.y - dp12 * duv02.y) * inv;
    let dpdv = (dp12 * duv02.x - dp02 * duv12.x) * inv;
    let c = dpdu.cross(dpdv);
    (c.length_squared() > 0.0 && c.is_finite()).then_some((dpdu, dpdv))
}

/// An arbitrary tangent frame around `n` when the uv parameterisation has none.
fn fallback_dpduv(n: Vec3) -> (Vec3, Vec3) {
    crate::math::coordinate_system(n)
}
