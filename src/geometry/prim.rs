//! Primitives as the acceleration structures hold them: their kinds, bounds and
//! intersection, and the hit record the queries return.

use super::cylinder::Cylinder;
use super::sdfgrid::SdfVoxel;
use super::sphere::Sphere;
use super::triangle::intersect_watertight;
use super::{Aabb, Ray};
use crate::math::Vec3;

/// A primitive as the BVH's leaves hold it.
#[derive(Clone, Copy, Debug)]
pub enum Prim {
    Triangle {
        p: [Vec3; 3],
        object: u32,
        index: u32,
    },
    Sphere {
        sphere: Sphere,
        object: u32,
    },
    /// An open cylinder ([`Cylinder`]), tested analytically in a generic leaf.
    Cylinder {
        cylinder: Cylinder,
        object: u32,
    },
    /// A voxel of an `sdfgrid` with the surface in it ([`SdfVoxel`]), in its grid's
    /// index space: only inside the grid's own bottom level, which an instance places.
    SdfVoxel {
        voxel: SdfVoxel,
        object: u32,
    },
    /// An entry of a two-level structure's top level: instance `instance` with its
    /// world box. Its test needs the instance and its group
    /// ([`crate::accel::instance::TwoLevel`]); [`Prim::intersect`] misses it.
    Instance {
        bounds: Aabb,
        instance: u32,
    },
}

impl Prim {
    /// Position in the scene's object/triangle order (ties in `--compat`).
    pub fn order_key(&self) -> (u32, u32) {
        match *self {
            Prim::Triangle { object, index, .. } => (object, index),
            Prim::Sphere { object, .. } | Prim::Cylinder { object, .. } | Prim::SdfVoxel { object, .. } => (object, 0),
            Prim::Instance { instance, .. } => (u32::MAX, instance),
        }
    }

    /// Whether this is a triangle (the wide BVH stores triangles in SIMD blocks,
    /// every other kind in leaves of primitive indices).
    #[inline]
    pub fn is_triangle(&self) -> bool {
        match self {
            Prim::Triangle { .. } => true,
            Prim::Sphere { .. } | Prim::Cylinder { .. } | Prim::SdfVoxel { .. } | Prim::Instance { .. } => false,
        }
    }

    /// Conservative bounds (spheres padded by a relative and an absolute margin).
    pub fn bounds(&self) -> Aabb {
        match self {
            Prim::Triangle { p, .. } => Aabb::from_points(p),
            Prim::Sphere { sphere, .. } => {
                let r = Vec3::splat(sphere.radius * (1.0 + 1e-6) + 1e-6);
                Aabb::new(sphere.center - r, sphere.center + r)
            }
            Prim::Cylinder { cylinder, .. } => cylinder.bounds(),
            Prim::SdfVoxel { voxel, .. } => voxel.bounds(),
            Prim::Instance { bounds, .. } => *bounds,
        }
    }

    /// Nearest hit in `[ray.t_min, t_max]`: its distance and barycentrics (zero
    /// for spheres). Triangles go through the watertight kernel
    /// ([`intersect_watertight`]), spheres through [`Sphere::intersect`].
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<(f32, [f32; 3])> {
        match self {
            Prim::Triangle { p, .. } => intersect_watertight(ray.o, ray.d, ray.t_min, t_max, p).map(|h| (h.t, h.b)),
            Prim::Sphere { sphere, .. } => sphere.intersect(ray.o, ray.d, ray.t_min, t_max).map(|t| (t, [0.0; 3])),
            Prim::Cylinder { cylinder, .. } => cylinder.intersect(ray.o, ray.d, ray.t_min, t_max).map(|t| (t, [0.0; 3])),
            Prim::SdfVoxel { voxel, .. } => voxel.intersect(ray.o, ray.d, ray.t_min, t_max).map(|t| (t, [0.0; 3])),
            Prim::Instance { .. } => None,
        }
    }
}

/// [`Prim::bounds`] as a function (for `map`).
pub fn prim_bounds(p: &Prim) -> Aabb {
    p.bounds()
}

#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    /// Barycentrics for triangles (unused for spheres and cylinders).
    pub b: [f32; 3],
    /// When `prim` is a [`Prim::Instance`]: the primitive hit inside the instance's
    /// group (an index into the group's primitives); 0 otherwise.
    pub sub: u32,
}
