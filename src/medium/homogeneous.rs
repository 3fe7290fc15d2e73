//! `homogeneous` (Mitsuba 3's): constant extinction and albedo, and (pbrt-v4's) a
//! constant emitted radiance.

use super::PhaseFunction;
use crate::math::Vec3;

/// Constant absorption and scattering coefficients and a phase function.
#[derive(Clone, Debug, PartialEq)]
pub struct Homogeneous {
    pub sigma_a: Vec3,
    pub sigma_s: Vec3,
    pub phase: PhaseFunction,
    /// Emitted radiance Le: the medium adds σa·Le per unit length (zero: not emissive).
    pub radiance: Vec3,
}

impl Homogeneous {
    /// From Mitsuba's parameters: extinction `sigma_t` times `scale`, and single-scattering
    /// `albedo` σs/σt. A one-line reason (naming the key) when a value is out of range.
    pub fn new(sigma_t: Vec3, albedo: Vec3, scale: f32, phase: PhaseFunction) -> Result<Homogeneous, (&'static str, String)> {
        if !sigma_t.is_finite() || sigma_t.min_element() < 0.0 {
            return Err(("sigma_t", format!("must be finite and non-negative, found {sigma_t}")));
        }
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(("scale", format!("must be finite and non-negative, found {scale}")));
        }
        if !albedo.is_finite() || albedo.min_element() < 0.0 || albedo.max_element() > 1.0 {
            return Err(("albedo", format!("must lie in [0, 1], found {albedo}")));
        }
        if !(sigma_t * scale).is_finite() {
            return Err(("scale", format!("times sigma_t overflows ({scale} × {})", sigma_t.max_element())));
        }
        let sigma_t = sigma_t * scale;
        let sigma_s = sigma_t * albedo;
        Ok(Homogeneous {
            sigma_a: sigma_t - sigma_s,
            sigma_s,
            phase,
            radiance: Vec3::ZERO,
        })
    }

    /// The medium emitting radiance `le` (σa·Le per unit length); a one-line reason when
    /// `le` is negative or not finite.
    pub fn with_radiance(self, le: Vec3) -> Result<Homogeneous, (&'static str, String)> {
        check_radiance(le.min_element(), le.max_element())?;
        Ok(Homogeneous { radiance: le, ..self })
    }

    /// The extinction σa + σs.
    #[inline]
    pub fn sigma_t(&self) -> Vec3 {
        self.sigma_a + self.sigma_s
    }

    /// The single-scattering albedo σs/σt (0 where σt is 0).
    pub fn albedo(&self) -> Vec3 {
        let t = self.sigma_t();
        Vec3::new(
            if t.x > 0.0 { self.sigma_s.x / t.x } else { 0.0 },
            if t.y > 0.0 { self.sigma_s.y / t.y } else { 0.0 },
            if t.z > 0.0 { self.sigma_s.z / t.z } else { 0.0 },
        )
    }
}

/// `Ok` when a medium's emitted radiance, of smallest value `min` and largest `max`,
/// is finite and not negative.
pub(super) fn check_radiance(min: f32, max: f32) -> Result<(), (&'static str, String)> {
    if min >= 0.0 && max.is_finite() {
        Ok(())
    } else {
        Err((
            "radiance",
            format!("must be finite and non-negative, found values from {min} to {max}"),
        ))
    }
}
