//! Integrators: a closed family. The render loop lives in [`crate::render`](mod@crate::render).

pub mod intersection_test;
pub mod path;

pub use path::PathProfile;

/// The integrator a scene asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integrator {
    IntersectionTest,
    Path { profile: PathProfile, rr_threshold: f32 },
}

use crate::geometry::ray::RAY_T_MAX;
use crate::geometry::Ray;
use crate::light::{LightSample, ShadowTarget};
use crate::math::{offset_ray_origin, Vec3};
use crate::scene::Interaction;

/// A ray leaving a surface in direction `d`, its origin pushed off the surface
/// to the side `d` goes (robust offset, so `t_min` can be 0).
#[inline]
pub fn spawn_ray(it: &Interaction, d: Vec3) -> Ray {
    let n = if d.dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
    Ray::with_range(offset_ray_origin(it.p, n), d, 0.0, RAY_T_MAX)
}

/// A shadow ray from a surface towards a light sample, stopping just short of
/// the light: both ends are pushed off their surfaces.
#[inline]
pub fn shadow_ray(it: &Interaction, ls: &LightSample) -> Ray {
    match ls.target {
        ShadowTarget::Infinity => spawn_ray(it, ls.wi),
        ShadowTarget::Point { p, n } => {
            let side = if (p - it.p).dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
            let o = offset_ray_origin(it.p, side);
            let target = match n {
                Some(n) => offset_ray_origin(p, if (it.p - p).dot(n) >= 0.0 { n } else { -n }),
                None => p,
            };
            let v = target - o;
            let dist = v.length();
            Ray::with_range(o, v / dist, 0.0, dist * (1.0 - 1e-5))
        }
    }
}
