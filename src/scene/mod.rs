//! Scenes in two layers: [`desc`] (the JSON as plain structs that remember their
//! JSON paths) and [`Scene`] (render-ready: loaded meshes, resolved names, BVH),
//! built by [`build`].

pub mod build;
pub mod desc;
pub mod json;

use crate::accel::Bvh;
use crate::camera::Camera;
use crate::film::Filter;
use crate::geometry::mesh::Mesh;
use crate::geometry::sphere::Sphere;
use crate::geometry::triangle::intersect_watertight;
use crate::geometry::Ray;
use crate::light::Light;
use crate::material::Material;
use crate::math::{normalize_div, Vec2, Vec3};
use crate::texture::Texture;
pub use build::{build, BuildOptions};
pub use desc::SceneDesc;

#[derive(Clone, Debug)]
pub enum Shape {
    Mesh(Mesh),
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
    /// Direction back along the incoming ray.
    pub wo: Vec3,
    pub object: u32,
}

pub struct Scene {
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    pub block_size: u32,
    pub filter: Filter,
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
    /// Primitives in BVH leaf order (`bvh.order` is the identity).
    pub prims: Vec<Prim>,
    pub bvh: Bvh,
    pub warnings: Vec<String>,
    /// Seconds spent building the BVH.
    pub bvh_seconds: f64,
}

impl Scene {
    /// Closest hit in `[ray.t_min, ray.t_max]`.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        self.bvh.traverse(ray, |i, t_max| {
            match &self.prims[i as usize] {
                Prim::Triangle { p, .. } => {
                    if let Some(h) = intersect_watertight(ray.o, ray.d, ray.t_min, *t_max, p) {
                        *t_max = h.t;
                        best = Some(Hit { t: h.t, prim: i, b: h.b });
                    }
                }
                Prim::Sphere { sphere, .. } => {
                    if let Some(t) = sphere.intersect(ray.o, ray.d, ray.t_min, *t_max) {
                        *t_max = t;
                        best = Some(Hit { t, prim: i, b: [0.0; 3] });
                    }
                }
            }
            false
        });
        best
    }

    /// Whether anything lies on the ray within `[t_min, t_max]`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut hit = false;
        self.bvh.traverse(ray, |i, t_max| {
            hit = match &self.prims[i as usize] {
                Prim::Triangle { p, .. } => intersect_watertight(ray.o, ray.d, ray.t_min, *t_max, p).is_some(),
                Prim::Sphere { sphere, .. } => sphere.intersect(ray.o, ray.d, ray.t_min, *t_max).is_some(),
            };
            hit
        });
        hit
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
                let uv = match tri.uv {
                    Some(t) => mesh.uvs[t[0] as usize] * b[0] + mesh.uvs[t[1] as usize] * b[1] + mesh.uvs[t[2] as usize] * b[2],
                    None => Vec2::new(0.0, 0.0) * b[0] + Vec2::new(1.0, 0.0) * b[1] + Vec2::new(1.0, 1.0) * b[2],
                };
                Interaction {
                    p: pos,
                    ng,
                    ns,
                    uv,
                    wo,
                    object: *object,
                }
            }
            Prim::Sphere { sphere, object } => {
                let (pos, n) = sphere.project(ray.at(hit.t));
                Interaction {
                    p: pos,
                    ng: n,
                    ns: n,
                    uv: sphere.uv(n),
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
