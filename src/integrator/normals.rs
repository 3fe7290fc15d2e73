//! The `normals` debug integrator: the shading normal at the first hit as a
//! colour, `(n + 1) / 2` per component (so +x is red, +y green, +z blue), black
//! where camera rays escape. No keys besides `type` and `spp`.
//!
//! ```json
//! {"type": "normals", "spp": 4}
//! ```

use super::RayCounts;
use crate::geometry::Ray;
use crate::math::Vec3;
use crate::scene::Scene;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Normals;

impl Normals {
    pub fn li(&self, scene: &Scene, ray: Ray, counts: &mut RayCounts) -> Vec3 {
        counts.rays += 1;
        match scene.intersect(&ray) {
            Some(hit) => (scene.interaction(&ray, &hit).ns + Vec3::ONE) * 0.5,
            None => Vec3::ZERO,
        }
    }
}
