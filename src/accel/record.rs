//! Recording the closest-hit rays a render traces (`rdr bench SCENE --record-rays`), so
//! another tracer (Embree) can be timed on exactly the same rays.

use crate::geometry::Ray;
use std::sync::Mutex;

/// Rays recorded, up to a cap; shared by the render's threads (their order in the log
/// follows the scheduling: record with one thread for a reproducible file).
#[derive(Debug)]
pub struct RayLog {
    rays: Mutex<Vec<[f32; 6]>>,
    cap: usize,
}

impl RayLog {
    pub fn new(cap: usize) -> RayLog {
        RayLog {
            rays: Mutex::new(Vec::new()),
            cap,
        }
    }

    /// Keeps `ray` (while fewer than the cap are kept) as it would be traced from t = 0:
    /// the origin moved to `t_min`, the direction made unit length; unusable rays and
    /// rays without a direction are left out.
    pub fn push(&self, ray: &Ray) {
        let len = ray.d.length();
        if !(len > 0.0 && len.is_finite() && ray.t_min.is_finite() && ray.o.is_finite()) {
            return;
        }
        let o = ray.o + ray.d * ray.t_min.max(0.0);
        let d = ray.d / len;
        let mut rays = self.rays.lock().unwrap_or_else(|e| e.into_inner());
        if rays.len() < self.cap {
            rays.push([o.x, o.y, o.z, d.x, d.y, d.z]);
        }
    }

    /// The rays kept so far.
    pub fn take(&self) -> Vec<[f32; 6]> {
        std::mem::take(&mut *self.rays.lock().unwrap_or_else(|e| e.into_inner()))
    }
}
