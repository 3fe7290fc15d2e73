//! Scenes in two layers: [`desc`] (the JSON as plain values that remember where
//! they came from, a [`Source`]) and [`Scene`] (render-ready: loaded meshes, resolved
//! names, BVH), built by [`build`](mod@build). Both layers share one definition of
//! each variant family, generic over what is still unresolved in the description:
//! [`Material`], [`Texture`], [`Shape`], [`Filter`], [`crate::camera::CameraParams`]
//! and [`crate::texture::UvMapping`].

pub mod build;
pub mod desc;
pub mod json;
pub mod source;

use crate::accel::WideBvh;
use crate::camera::Camera;
use crate::film::Filter;
use crate::geometry::mesh::Mesh;
use crate::geometry::sphere::Sphere;
use crate::geometry::{Ray, RayDifferential};
use crate::light::Light;
use crate::material::Material;
use crate::math::{normalize_div, Vec2, Vec3};
use crate::texture::{TexCoord, Texture, TextureConvention};
pub use build::{build, BuildOptions};
pub use desc::SceneDesc;
pub use source::{Located, Source};

/// An object's geometry, chosen by `objects[i].type`. The mesh is `M`: a file to
/// read in the scene description ([`desc::MeshFile`]: `path`, `transform`,
/// `translate`), the loaded [`Mesh`] (the default) once the scene is built.
#[derive(Clone, Debug)]
pub enum Shape<M = Mesh> {
    /// `mesh`: `path` (OBJ, required), `transform` (16 numbers row-major, identity),
    /// `translate` ((0,0,0), added after `transform`); see [`desc::MeshFile`].
    Mesh(M),
    /// `sphere`: `center` (vec3, (0,0,0)), `radius` (> 0, 1).
    Sphere(Sphere),
}

/// One entry of the scene's `objects` list, resolved.
#[derive(Clone, Debug)]
pub struct Object {
    pub shape: Shape,
    pub material: Option<u32>,
    /// Index into `Scene::lights` of the area light on this object.
    pub light: Option<u32>,
}

/// A primitive as the BVH's leaves hold it.
#[derive(Clone, Copy, Debug)]
pub enum Prim {
    Triangle { p: [Vec3; 3], object: u32, index: u32 },
    Sphere { sphere: Sphere, object: u32 },
}

impl Prim {
    /// Position in the scene's object/triangle order (ties in `--compat`).
    pub fn order_key(&self) -> (u32, u32) {
        match *self {
            Prim::Triangle { object, index, .. } => (object, index),
            Prim::Sphere { object, .. } => (object, 0),
        }
    }
}

#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    /// Barycentrics for triangles (unused for spheres).
    pub b: [f32; 3],
}

/// A surface point with everything shading needs.
#[derive(Clone, Copy, Debug)]
pub struct Interaction {
    pub p: Vec3,
    /// Geometric normal (triangle winding; spheres: outward).
    pub ng: Vec3,
    /// Shading normal (interpolated vertex normals, else `ng`).
    pub ns: Vec3,
    pub uv: Vec2,
    /// `∂p/∂u`, `∂p/∂v` of the uv parameterisation (spec §14.2; an arbitrary frame
    /// around `ng` where it is degenerate).
    pub dpdu: Vec3,
    pub dpdv: Vec3,
    /// Screen-space derivatives of `uv` per pixel; zero unless
    /// [`Interaction::compute_uv_derivatives`] was given the ray's differentials.
    pub duvdx: Vec2,
    pub duvdy: Vec2,
    /// Direction back along the incoming ray.
    pub wo: Vec3,
    pub object: u32,
}

impl Interaction {
    /// The texture coordinates and their footprint, for [`crate::texture::Texture::eval`].
    #[inline]
    pub fn tex_coord(&self) -> TexCoord {
        TexCoord {
            uv: self.uv,
            duvdx: self.duvdx,
            duvdy: self.duvdy,
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

pub struct Scene {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub block_size: u32,
    pub filter: Filter,
    pub integrator: crate::integrator::Integrator,
    /// Some texture filters by footprint (an image texture): camera rays carry differentials.
    pub uses_footprints: bool,
    pub spp: u32,
    pub max_depth: u32,
    pub textures: Vec<Texture>,
    pub materials: Vec<Material>,
    pub objects: Vec<Object>,
    pub lights: Vec<Light>,
    /// Index of the environment light in `lights`.
    pub environment: Option<u32>,
    pub light_sampler: crate::light::LightSampler,
    pub light_sampling: crate::light::LightSampling,
    pub light_samples: u32,
    /// Bounding sphere of the geometry.
    pub center: Vec3,
    pub radius: f32,
    /// Primitives in BVH leaf order; the BVH's primitive indices index this.
    pub prims: Vec<Prim>,
    pub bvh: WideBvh,
    pub warnings: Vec<String>,
    /// Seconds spent building the BVH.
    pub bvh_seconds: f64,
    /// Sphere uv order (and image orientation, baked into the textures).
    pub texture_convention: TextureConvention,
}

impl Scene {
    /// Closest hit in `[ray.t_min, ray.t_max]`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.bvh.intersect(&self.prims, ray)
    }

    /// Whether anything lies on the ray within `[t_min, t_max]`.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.bvh.occluded(&self.prims, ray)
    }

    /// The surface point of a hit. Triangle points are the barycentric
    /// interpolation `(b0·p0 + b1·p1) + b2·p2` (spec §14.2), which is more
    /// accurate than `o + t·d`.
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> Interaction {
        let wo = -ray.d;
        match &self.prims[hit.prim as usize] {
            Prim::Triangle { p, object, index } => {
                let b = hit.b;
                let pos = (p[0] * b[0] + p[1] * b[1]) + p[2] * b[2];
                let ng = normalize_div((p[1] - p[0]).cross(p[2] - p[0]));
                let Shape::Mesh(mesh) = &self.objects[*object as usize].shape else {
                    unreachable!("triangle of a non-mesh")
                };
                let tri = &mesh.triangles[*index as usize];
                let ns = match tri.n {
                    Some(n) => {
                        let v =
                            mesh.normals[n[0] as usize] * b[0] + mesh.normals[n[1] as usize] * b[1] + mesh.normals[n[2] as usize] * b[2];
                        let l = v.length();
                        if l > 0.0 && l.is_finite() {
                            v / l
                        } else {
                            ng
                        }
                    }
                    None => ng,
                };
                let uvs = match tri.uv {
                    Some(t) => t.map(|i| mesh.uvs[i as usize]),
                    None => [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0)],
                };
                let uv = uvs[0] * b[0] + uvs[1] * b[1] + uvs[2] * b[2];
                let (dpdu, dpdv) = triangle_dpduv(p, &uvs).unwrap_or_else(|| fallback_dpduv(ng));
                Interaction {
                    p: pos,
                    ng,
                    ns,
                    uv,
                    dpdu,
                    dpdv,
                    duvdx: Vec2::ZERO,
                    duvdy: Vec2::ZERO,
                    wo,
                    object: *object,
                }
            }
            Prim::Sphere { sphere, object } => {
                let (pos, n) = sphere.project(ray.at(hit.t));
                let (mut uv, (mut dpdu, mut dpdv)) = (sphere.uv(n), sphere.uv_derivatives(n));
                if self.texture_convention == TextureConvention::Rdr171 {
                    // the original stores (θ/π, φ/2π), derivatives in the same order (§10.2)
                    uv = Vec2::new(uv.y, uv.x);
                    std::mem::swap(&mut dpdu, &mut dpdv);
                }
                let c = dpdu.cross(dpdv);
                if !(c.length_squared() > 0.0 && c.is_finite()) {
                    (dpdu, dpdv) = fallback_dpduv(n);
                }
                Interaction {
                    p: pos,
                    ng: n,
                    ns: n,
                    uv,
                    dpdu,
                    dpdv,
                    duvdx: Vec2::ZERO,
                    duvdy: Vec2::ZERO,
                    wo,
                    object: *object,
                }
            }
        }
    }

    /// The area light on the surface of `it`, if any.
    pub fn area_light_of(&self, it: &Interaction) -> Option<(u32, &crate::light::AreaLight)> {
        let i = self.objects[it.object as usize].light?;
        match &self.lights[i as usize] {
            Light::Area(a) => Some((i, a)),
            _ => None,
        }
    }

    /// Radiance arriving from the environment along direction `w` (0 without one).
    pub fn environment_radiance(&self, w: Vec3) -> Vec3 {
        match self.environment.map(|i| &self.lights[i as usize]) {
            Some(Light::Environment(e)) => e.radiance(w),
            _ => Vec3::ZERO,
        }
    }

    pub fn material_of(&self, it: &Interaction) -> Option<&Material> {
        self.objects[it.object as usize].material.map(|m| &self.materials[m as usize])
    }

    pub fn triangle_count(&self) -> usize {
        self.prims.iter().filter(|p| matches!(p, Prim::Triangle { .. })).count()
    }
}
