//! The benchmark's three ray sets (see the [module docs](super)).

use crate::geometry::prim::{Hit, Prim};
use crate::geometry::{Aabb, Ray};
use crate::math::Vec3;

/// Fixed-seed generator for the ray sets.
type Rng = crate::sampling::SplitMix64;

/// The three ray sets.
pub struct RaySets {
    pub primary: Vec<Ray>,
    pub incoherent: Vec<Ray>,
    pub bounce: Vec<Ray>,
}

/// The benchmark camera's `res`×`res` primary rays (the camera of
/// `shared/tools/embree_rays.py`: looking along −(0.35, 0.25, 1), 40° field of
/// view, all eight box corners in view with a 5 % margin).
pub fn primary_rays(b: &Aabb, res: usize) -> Vec<Ray> {
    let c = b.centroid();
    let w = Vec3::new(0.35, 0.25, 1.0).normalize(); // from the centre towards the camera
    let right = Vec3::Y.cross(w).normalize();
    let up = w.cross(right);
    let tan_half = (20.0f32).to_radians().tan();
    let mut dist = 0.0f32;
    for k in 0..8 {
        let corner = Vec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        );
        let q = corner - c;
        dist = dist.max(q.dot(w) + q.dot(right).abs().max(q.dot(up).abs()) * 1.05 / tan_half);
    }
    let eye = c + w * dist.max(1e-6);
    let mut rays = Vec::with_capacity(res * res);
    for y in 0..res {
        for x in 0..res {
            let sx = (2.0 * (x as f32 + 0.5) / res as f32 - 1.0) * tan_half;
            let sy = (1.0 - 2.0 * (y as f32 + 0.5) / res as f32) * tan_half;
            let d = (-w + right * sx + up * sy).normalize();
            rays.push(Ray::with_range(eye, d, 0.0, f32::INFINITY));
        }
    }
    rays
}

fn uniform_sphere(rng: &mut Rng) -> Vec3 {
    let z = 1.0 - 2.0 * rng.unit_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * rng.unit_f32();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub fn incoherent_rays(b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::from(seed);
    let c = b.centroid();
    let r = b.extent().length() * 0.5;
    (0..n)
        .map(|_| {
            let o = c + uniform_sphere(&mut rng) * r;
            let t = b.min + b.extent() * Vec3::new(rng.unit_f32(), rng.unit_f32(), rng.unit_f32());
            Ray::with_range(o, (t - o).normalize(), 0.0, f32::INFINITY)
        })
        .collect()
}

/// Cosine-distributed rays from the primary hits (`hits[i]` belongs to `primary[i]`).
pub fn bounce_rays(prims: &[Prim], primary: &[Ray], hits: &[Option<Hit>], n: usize, eps: f32, seed: u64) -> Vec<Ray> {
    let points: Vec<(Vec3, Vec3)> = primary
        .iter()
        .zip(hits)
        .filter_map(|(ray, h)| {
            let h = h.as_ref()?;
            let p = match &prims[h.prim as usize] {
                Prim::Triangle { p, .. } => p,
                // the benchmark loads meshes only
                _ => return None,
            };
            let mut ng = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
            if ng.dot(ray.d) > 0.0 {
                ng = -ng;
            }
            let pos = (p[0] * h.b[0] + p[1] * h.b[1]) + p[2] * h.b[2];
            Some((pos + ng * eps, ng))
        })
        .collect();
    if points.is_empty() {
        return Vec::new();
    }
    let mut rng = Rng::from(seed);
    (0..n)
        .map(|i| {
            let (o, ng) = points[i % points.len()];
            let (t, bt) = crate::math::coordinate_system(ng);
            let r = rng.unit_f32().sqrt();
            let phi = 2.0 * std::f32::consts::PI * rng.unit_f32();
            let z = (1.0 - r * r).max(0.0).sqrt();
            let d = (t * (r * phi.cos()) + bt * (r * phi.sin()) + ng * z).normalize();
            Ray::with_range(o, d, 0.0, f32::INFINITY)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_sets_are_as_described() {
        let b = Aabb::new(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(1.0, 3.0, 2.5));
        let primary = primary_rays(&b, 16);
        assert_eq!(primary.len(), 256);
        // the camera sits outside the box along (0.35, 0.25, 1) from its centre and
        // sees every corner inside the 40° image, with a margin
        let eye = primary[0].o;
        let w = Vec3::new(0.35, 0.25, 1.0).normalize();
        assert!((eye - b.centroid()).normalize().dot(w) > 1.0 - 1e-6);
        let tan_half = 20f32.to_radians().tan();
        for k in 0..8 {
            let corner = Vec3::new(
                if k & 1 == 0 { b.min.x } else { b.max.x },
                if k & 2 == 0 { b.min.y } else { b.max.y },
                if k & 4 == 0 { b.min.z } else { b.max.z },
            );
            let q = corner - eye;
            let depth = -q.dot(w);
            let right = Vec3::Y.cross(w).normalize();
            let up = w.cross(right);
            assert!(depth > 0.0);
            assert!(q.dot(right).abs() / depth < tan_half / 1.04, "corner {k}");
            assert!(q.dot(up).abs() / depth < tan_half / 1.04, "corner {k}");
        }
        let inc = incoherent_rays(&b, 1000, 1);
        let r = b.extent().length() * 0.5;
        for ray in &inc {
            assert!(((ray.o - b.centroid()).length() - r).abs() < 1e-4 * r);
            assert!((ray.d.length() - 1.0).abs() < 1e-5);
        }
    }
}
