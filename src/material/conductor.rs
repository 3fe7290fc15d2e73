//! Smooth conductor (Mitsuba's `conductor`): a mirror whose reflectance is the
//! conductor Fresnel term of the complex index η + ik, times a tint. One-sided.

use super::fresnel;
use super::sample::BsdfSample;
use crate::math::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct SmoothConductor {
    /// Mitsuba's `specular_reflectance`.
    pub tint: Vec3,
    /// Real part of the relative index (Mitsuba's `eta`).
    pub eta: Vec3,
    /// Imaginary part (Mitsuba's `k`).
    pub k: Vec3,
}

impl SmoothConductor {
    /// The mirror direction in the local frame, weighted by F(cos θ)·tint; nothing from below.
    pub fn sample(&self, o: Vec3) -> Option<BsdfSample> {
        if o.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi: Vec3::new(-o.x, -o.y, o.z),
            weight: self.tint * fresnel::conductor(o.z, self.eta, self.k),
            pdf: 1.0,
            delta: true,
            eta: 1.0,
        })
    }
}
