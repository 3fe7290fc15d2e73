//! Rays through media and their boundaries: the transmittance of a shadow ray that
//! crosses `null` surfaces (Mitsuba's `volpath` shadow rays), estimated by ratio
//! tracking in each medium it passes ([`crate::medium::tracking`]).

use super::{Hit, Interaction, Scene};
use crate::geometry::Ray;
use crate::math::{offset_ray_origin, Vec3};
use crate::medium::ratio_tracking;

/// Null surfaces one ray crosses at most (a deeper stack counts as opaque).
pub const MAX_NULL_CROSSINGS: u32 = 256;

impl Scene {
    /// The medium a ray in direction `d` is in after crossing or leaving the surface
    /// point `it` (`current` when its object declares no media).
    #[inline]
    pub fn medium_after(&self, it: &Interaction, d: Vec3, current: Option<u32>) -> Option<u32> {
        match self.objects[it.object as usize].media {
            Some(mi) => mi.along(d, it.ng),
            None => current,
        }
    }

    /// Whether the surface of `it` is a `null` boundary, which rays cross unchanged.
    #[inline]
    pub fn is_null(&self, it: &Interaction) -> bool {
        self.objects[it.object as usize].null_bsdf
    }

    /// `ray` continued from the far side of the surface point `it` it reached
    /// (unchanged direction; `t_max` shortened by the distance travelled).
    #[inline]
    pub fn ray_beyond(ray: &Ray, it: &Interaction) -> Ray {
        let side = if ray.d.dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
        let o = offset_ray_origin(it.p, side);
        let advanced = (o - ray.o).dot(ray.d) / ray.d.length_squared();
        Ray::with_range(o, ray.d, 0.0, ray.t_max - advanced)
    }

    /// The fraction of light of each channel that passes along `ray` (which starts in
    /// `medium`) over `[t_min, t_max]`: 0 at a surface that is not `null`, the media's
    /// transmittance (ratio tracking, numbers from `u`) across `null` boundaries.
    pub fn transmittance_through_media(&self, ray: &Ray, mut medium: Option<u32>, mut u: impl FnMut() -> f32) -> Vec3 {
        let (mut r, mut tr) = (*ray, Vec3::ONE);
        for _ in 0..MAX_NULL_CROSSINGS {
            let hit: Option<Hit> = self.intersect(&r);
            if let Some(m) = medium {
                let t_end = hit.map_or(r.t_max, |h| h.t);
                tr *= ratio_tracking(&self.media[m as usize], &r, t_end, &mut u);
                if tr.max_element() <= 0.0 {
                    return Vec3::ZERO;
                }
            }
            let Some(h) = hit else {
                return tr;
            };
            let it = self.interaction(&r, &h);
            if !self.is_null(&it) {
                return Vec3::ZERO;
            }
            medium = self.medium_after(&it, r.d, medium);
            r = Scene::ray_beyond(&r, &it);
            if r.t_max <= 0.0 {
                return tr;
            }
        }
        Vec3::ZERO
    }
}
