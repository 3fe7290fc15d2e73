//! Integrators: a closed family. The render loop lives in [`crate::render`].

pub mod intersection_test;

use crate::geometry::ray::RAY_T_MAX;
use crate::geometry::Ray;
use crate::math::{offset_ray_origin, Vec3};
use crate::scene::Interaction;

/// A ray leaving a surface in direction `d`, its origin pushed off the surface
/// to the side `d` goes (robust offset, so `t_min` can be 0).
#[inline]
pub fn spawn_ray(it: &Interaction, d: Vec3) -> Ray {
    let n = if d.dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
    Ray::with_range(offset_ray_origin(it.p, n), d, 0.0, RAY_T_MAX)
}

/// A shadow ray from a surface towards point `target`, stopping just short of it.
/// Returns the ray and the distance from the surface point to the target.
#[inline]
pub fn spawn_ray_to(it: &Interaction, target: Vec3) -> Ray {
    let side = if (target - it.p).dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
    let o = offset_ray_origin(it.p, side);
    let v = target - o;
    let dist = v.length();
    Ray::with_range(o, v / dist, 0.0, dist * (1.0 - 1e-5))
}
