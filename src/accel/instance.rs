//! Two-level acceleration: instances of shared bottom-level trees.
//!
//! A [`Group`] is a bottom level: primitives in their own frame and the wide BVH
//! over them, built once. An [`Instance`] places a group with an affine transform.
//! The top level is an ordinary [`WideBvh`] over [`Prim::Instance`] entries (the
//! instance's world box, beside any other primitives); its generic leaves are
//! tested by [`TwoLevel`], which carries the ray into the instance's frame
//! (world → object, same `t`: the direction is transformed, not renormalised) and
//! traverses the group's tree with the same kernels. Memory grows with the number
//! of instances (one [`Instance`] and one top-level entry each), not with the
//! triangles they show.
//!
//! Hits inside an instance come back as a [`Hit`] whose `prim` is the top-level
//! [`Prim::Instance`] and whose `sub` is the group's primitive. Surface points
//! are made in the object frame and carried to the world by [`Instance::point_to_world`],
//! [`Instance::vector_to_world`] (tangents) and [`Instance::normal_to_world`]
//! (normals, by the inverse transpose).

use super::wide::{Leaves, WideBvh};
use crate::geometry::prim::{Hit, Prim};
use crate::geometry::{Aabb, Ray};
use crate::math::{Mat4, Vec3};
use glam::{Affine3A, Mat3A, Vec3A};

/// A bottom level shared by its instances: primitives in the group's frame and their BVH.
#[derive(Clone, Debug, Default)]
pub struct Group {
    pub prims: Vec<Prim>,
    pub bvh: WideBvh,
}

impl Group {
    /// Builds the group's tree. Instances inside a group are not supported (the
    /// caller refuses them); their entries would never be hit.
    pub fn new(prims: Vec<Prim>) -> Group {
        let bvh = WideBvh::build(&prims);
        Group { prims, bvh }
    }

    /// Bytes of primitives and tree.
    pub fn memory_bytes(&self) -> usize {
        self.prims.len() * std::mem::size_of::<Prim>() + self.bvh.memory_bytes()
    }
}

/// A placed group: its transform both ways and which group it shows.
#[derive(Clone, Copy, Debug)]
pub struct Instance {
    /// World → object (rays).
    pub to_object: Affine3A,
    /// Object → world (points and tangents).
    pub to_world: Affine3A,
    pub group: u32,
}

impl Instance {
    /// An instance of `group` placed by `to_world`; `None` when the matrix is not
    /// affine, not finite or singular.
    pub fn new(to_world: &Mat4, group: u32) -> Option<Instance> {
        let r = to_world.row(3);
        if r != glam::Vec4::new(0.0, 0.0, 0.0, 1.0) || !to_world.is_finite() {
            return None;
        }
        let a = Affine3A::from_mat4(*to_world);
        let det = a.matrix3.determinant();
        if !(det.is_finite() && det != 0.0) {
            return None;
        }
        let inv = a.inverse();
        inv.is_finite().then_some(Instance {
            to_object: inv,
            to_world: a,
            group,
        })
    }

    /// The ray in the object frame, with the same parameter range (`t` means the same
    /// point on both).
    #[inline]
    pub fn ray_to_object(&self, ray: &Ray) -> Ray {
        Ray {
            o: self.to_object.transform_point3(ray.o),
            d: self.to_object.transform_vector3(ray.d),
            t_min: ray.t_min,
            t_max: ray.t_max,
        }
    }

    #[inline]
    pub fn point_to_world(&self, p: Vec3) -> Vec3 {
        self.to_world.transform_point3(p)
    }

    #[inline]
    pub fn vector_to_world(&self, v: Vec3) -> Vec3 {
        self.to_world.transform_vector3(v)
    }

    /// A unit normal carried to the world by the inverse transpose, renormalised.
    #[inline]
    pub fn normal_to_world(&self, n: Vec3) -> Vec3 {
        let m: Mat3A = self.to_object.matrix3.transpose();
        let w = Vec3::from(m * Vec3A::from(n));
        let l = w.length();
        if l > 0.0 && l.is_finite() {
            w / l
        } else {
            n
        }
    }

    /// World box of the group's `bounds` (its eight corners carried over), padded by
    /// a relative margin for the rounding of the ray's transform.
    pub fn world_bounds(&self, bounds: Aabb) -> Aabb {
        if bounds.is_empty() {
            return bounds;
        }
        let mut b = Aabb::EMPTY;
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { bounds.min.x } else { bounds.max.x },
                if i & 2 == 0 { bounds.min.y } else { bounds.max.y },
                if i & 4 == 0 { bounds.min.z } else { bounds.max.z },
            );
            b = b.union(Aabb::new(self.point_to_world(c), self.point_to_world(c)));
        }
        let pad = (b.max - b.min).max_element() * 1e-6 + b.min.abs().max(b.max.abs()).max_element() * 1e-6;
        Aabb::new(b.min - Vec3::splat(pad), b.max + Vec3::splat(pad))
    }
}

/// The top level's generic leaves: top-level primitives, with [`Prim::Instance`]
/// entries resolved through `instances` and `groups`.
#[derive(Clone, Copy)]
pub struct TwoLevel<'a> {
    pub prims: &'a [Prim],
    pub instances: &'a [Instance],
    pub groups: &'a [Group],
}

impl TwoLevel<'_> {
    /// Closest hit in `[ray.t_min, ray.t_max]` of the top level `bvh` (built over `prims`).
    #[inline]
    pub fn intersect(&self, bvh: &WideBvh, ray: &Ray) -> Option<Hit> {
        bvh.intersect_with(self, ray)
    }

    /// Whether anything lies on the ray within `[ray.t_min, ray.t_max]`.
    #[inline]
    pub fn occluded(&self, bvh: &WideBvh, ray: &Ray) -> bool {
        bvh.occluded_with(self, ray)
    }
}

impl Leaves for TwoLevel<'_> {
    #[inline]
    fn closest(&self, p: u32, ray: &Ray, t_max: f32) -> Option<Hit> {
        match &self.prims[p as usize] {
            Prim::Instance { instance, .. } => {
                let inst = &self.instances[*instance as usize];
                let g = &self.groups[inst.group as usize];
                let mut local = inst.ray_to_object(ray);
                local.t_max = t_max;
                g.bvh.intersect(&g.prims, &local).map(|h| Hit {
                    t: h.t,
                    prim: p,
                    b: h.b,
                    sub: h.prim,
                })
            }
            prim => prim.intersect(ray, t_max).map(|(t, b)| Hit { t, prim: p, b, sub: 0 }),
        }
    }

    #[inline]
    fn any(&self, p: u32, ray: &Ray, t_max: f32) -> bool {
        match &self.prims[p as usize] {
            Prim::Instance { instance, .. } => {
                let inst = &self.instances[*instance as usize];
                let g = &self.groups[inst.group as usize];
                let mut local = inst.ray_to_object(ray);
                local.t_max = t_max;
                g.bvh.occluded(&g.prims, &local)
            }
            prim => prim.intersect(ray, t_max).is_some(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(x: f32, index: u32) -> Prim {
        Prim::Triangle {
            p: [Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0), Vec3::new(x, 1.0, 0.0)],
            object: 0,
            index,
        }
    }

    /// Two instances of one group: the nearer is hit, `sub` names the group's
    /// triangle, `t` is the world distance, and shadow rays see both.
    #[test]
    fn instances_are_hit_in_world_distance() {
        let group = Group::new((0..20).map(|i| tri(i as f32 * 2.0, i)).collect());
        let place = |z: f32, s: f32| {
            Instance::new(
                &(Mat4::from_translation(Vec3::new(0.0, 0.0, z)) * Mat4::from_scale(Vec3::splat(s))),
                0,
            )
            .unwrap()
        };
        let instances = [place(-3.0, 2.0), place(-5.0, 0.5)];
        let prims: Vec<Prim> = instances
            .iter()
            .enumerate()
            .map(|(i, inst)| Prim::Instance {
                bounds: inst.world_bounds(group.bvh.bounds()),
                instance: i as u32,
            })
            .collect();
        let top = WideBvh::build(&prims);
        let groups = [group];
        let tl = TwoLevel {
            prims: &prims,
            instances: &instances,
            groups: &groups,
        };
        // x = 8.5 hits the first instance's triangle 2 (x in [4, 5]·2 = [8, 10]) at z = −3
        let ray = Ray::new(Vec3::new(8.5, 0.2, 0.0), -Vec3::Z);
        let h = tl.intersect(&top, &ray).unwrap();
        assert_eq!((h.prim, h.sub), (0, 2));
        assert!((h.t - 3.0).abs() < 1e-5, "{}", h.t);
        // between the first instance's triangles (x in [0, 2], [4, 6]), on the second's
        // triangle 2 (scale 0.5: x in [2, 2.5]) at z = −5
        let ray = Ray::new(Vec3::new(2.1, 0.1, 0.0), -Vec3::Z);
        let h = tl.intersect(&top, &ray).unwrap();
        assert_eq!((h.prim, h.sub), (1, 2));
        assert!((h.t - 5.0).abs() < 1e-5, "{}", h.t);
        assert!(tl.occluded(&top, &ray));
        assert!(!tl.occluded(&top, &Ray::with_range(ray.o, ray.d, 0.0, 4.9)));
        let n = instances[0].normal_to_world(Vec3::Z);
        assert!((n - Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn singular_and_projective_transforms_are_refused() {
        assert!(Instance::new(&Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)), 0).is_none());
        let mut m = Mat4::IDENTITY;
        m.x_axis.w = 0.5;
        assert!(Instance::new(&m, 0).is_none());
        assert!(Instance::new(&Mat4::IDENTITY, 0).is_some());
    }
}
