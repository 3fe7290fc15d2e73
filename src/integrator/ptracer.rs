//! Particle tracer (the `ptracer` integrator, as Mitsuba's): light paths only,
//! every vertex connected to the pinhole and splatted to the film position it
//! projects to — bidirectional path tracing's t = 1 strategies alone, unweighted
//! (the machinery is [`super::bdpt`]'s). Area lights seen directly come from their
//! emission points connected to the camera (s = 1); the environment, which no
//! light path can connect to a pinhole, from camera rays that escape; point, spot
//! and directional lights stay invisible, as in `path`. In media, light paths scatter
//! and connect to the camera through the media as `bdpt`'s subpaths do; a scene with
//! an emissive medium is refused, as no light path starts inside a medium's volume.

use super::CameraSample;
use crate::camera::Camera;
use crate::math::Vec3;
use crate::scene::Scene;

/// Parameters (JSON `integrator` keys, besides `type` and `spp`): `max_depth`
/// (int ≥ 1, 12; path segments as `path`), `rr_threshold` (number, 0.1; read and
/// kept: roulette follows `path`'s rule).
///
/// ```json
/// {"type": "ptracer", "spp": 64, "max_depth": 12}
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ptracer {
    pub max_depth: u32,
    pub rr_threshold: f32,
}

impl Ptracer {
    /// One light path per camera sample; returns what the camera ray itself sees
    /// (the environment), the rest goes to `s.splats`.
    pub fn li(&self, scene: &Scene, camera: &Camera, s: &mut CameraSample) -> Vec3 {
        super::bdpt::light_tracing_sample(self.max_depth, scene, camera, s)
    }
}
