//! The adjoint BSDF: scattering for paths that start at the lights and carry
//! importance or flux (BDPT's light subpaths, `ptracer`, the photons of `photon` and
//! `sppm`). Written once here, so that no light tracer patches radiance weights.
//!
//! Directions follow the light: `wo` points back towards where the path came from
//! (the light side), `wi` to where it goes next. Two things differ from radiance:
//! * refraction: the BSDF is sampled and evaluated in [`TransportMode::Importance`]
//!   (`glass` and `roughdielectric` without the radiance's (η_o/η_i)², `refraction`
//!   with it, see [`TransportMode`]);
//! * shading normals: Veach's correction (thesis §5.3, pbrt-v3's
//!   `CorrectShadingNormal`) |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|), `ns` the normal
//!   whose cosine the integrator weights by, `ng` the geometric one (1 where they agree).

use super::bsdf::Bsdf;
use super::sample::{BsdfSample, TransportMode};
use crate::math::{Vec2, Vec3};

/// The normals at a surface point that the adjoint needs besides the BSDF's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Normals {
    /// The shading normal the integrator takes cosines to.
    pub ns: Vec3,
    /// The geometric normal.
    pub ng: Vec3,
}

/// Veach's correction of the adjoint BSDF for shading normals (see the module docs);
/// 0 where a direction is tangent to the geometric surface or `wi` to the shading one.
#[inline]
pub fn shading_correction(wo: Vec3, wi: Vec3, n: Normals) -> f32 {
    let den = wo.dot(n.ng).abs() * wi.dot(n.ns).abs();
    if den == 0.0 {
        0.0
    } else {
        wo.dot(n.ns).abs() * wi.dot(n.ng).abs() / den
    }
}

impl Bsdf {
    /// A direction for a path from the lights leaving along `wo` reversed: weight
    /// f*(wo, wi)·|wi·ns| / pdf, the adjoint of [`Bsdf::sample`].
    #[inline]
    pub fn sample_adjoint(&self, wo: Vec3, u: Vec2, uc: f32, n: Normals) -> Option<BsdfSample> {
        let s = self.sample_mode(wo, u, uc, TransportMode::Importance)?;
        Some(BsdfSample {
            weight: s.weight * shading_correction(wo, s.wi, n),
            ..s
        })
    }

    /// The adjoint BSDF f*(wo, wi) (without the cosine), for connections that end a
    /// light path here.
    #[inline]
    pub fn eval_adjoint(&self, wo: Vec3, wi: Vec3, n: Normals) -> Vec3 {
        self.eval_mode(wo, wi, TransportMode::Importance) * shading_correction(wo, wi, n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Frame;

    /// The adjoint obeys reciprocity against the radiance BSDF with shading normals
    /// (Veach eq. 5.18 with the cosines of §5.3): f*(wo, wi)·|wi·ns|/|wi·ng| equals
    /// f(wi, wo)·|wo·ns|/|wo·ng| (the radiance BSDF of the reverse direction, in
    /// the geometric measure). Fails with the correction inverted (off by its
    /// square, here 0.47² ≈ 0.22) or dropped (0.47).
    #[test]
    fn adjoint_with_shading_normals_is_reciprocal_in_the_geometric_measure() {
        let ns = Vec3::new(0.3, 0.0, 1.0).normalize();
        let n = Normals { ns, ng: Vec3::Z };
        let bsdf = Bsdf {
            frame: Frame::from_normal(ns),
            kind: crate::material::BsdfKind::Diffuse { albedo: Vec3::splat(0.7) },
            perturbed: None,
        };
        let wo = Vec3::new(-0.6, 0.1, 0.5).normalize();
        let wi = Vec3::new(0.5, -0.2, 0.4).normalize();
        let adjoint = bsdf.eval_adjoint(wo, wi, n).x * wi.dot(ns).abs() / wi.dot(Vec3::Z).abs();
        let radiance = bsdf.eval(wi, wo).x * wo.dot(ns).abs() / wo.dot(Vec3::Z).abs();
        assert!((adjoint / radiance - 1.0).abs() < 1e-5, "{adjoint} vs {radiance}");
        let ratio = shading_correction(wo, wi, n);
        assert!((ratio - 1.0).abs() > 0.2, "the test needs shading normals that matter: {ratio}");
    }
}
