//! Phase functions: a closed family (Mitsuba's `isotropic` and `hg`). Directions
//! follow the BSDFs' convention: `wo` points back along the path (towards the
//! camera side), `wi` towards where light comes from; light that goes on undeflected
//! has `wi = -wo`, and a forward-scattering `hg` (g > 0) favours it.

use crate::math::{Frame, Vec2, Vec3, PI};

/// A phase function. Its value is its own density (a phase function integrates to 1
/// over the sphere), so a sample's weight is exactly 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PhaseFunction {
    /// `isotropic`: 1/(4π).
    Isotropic,
    /// `hg` (Henyey–Greenstein): mean cosine `g` in (−1, 1), 0.8 by default as Mitsuba's.
    HenyeyGreenstein { g: f32 },
}

/// Below this |g| the Henyey–Greenstein inversion loses precision; it is isotropic.
const HG_ISOTROPIC_BELOW: f32 = 1e-3;

/// Henyey–Greenstein's density of the cosine `cos` between the light's
/// travel direction before and after scattering.
#[inline]
fn henyey_greenstein(cos: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos;
    (1.0 - g * g) / (4.0 * PI * denom * denom.max(1e-12).sqrt())
}

impl PhaseFunction {
    /// The value (and density) for the pair `wo`, `wi`.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        match *self {
            PhaseFunction::Isotropic => 0.25 / PI,
            // light arrives along −wi and leaves along wo
            PhaseFunction::HenyeyGreenstein { g } => henyey_greenstein(-wo.dot(wi), g),
        }
    }

    /// Solid-angle density of [`PhaseFunction::sample`] (equal to the value).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.eval(wo, wi)
    }

    /// A direction `wi` drawn with density [`PhaseFunction::pdf`], and that density.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> (Vec3, f32) {
        let cos = match *self {
            PhaseFunction::HenyeyGreenstein { g } if g.abs() >= HG_ISOTROPIC_BELOW => {
                // inverse of the cosine's distribution function
                let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u.x);
                ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
            }
            _ => 1.0 - 2.0 * u.x,
        };
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        // the light's travel direction before scattering, −wi, at angle acos(cos) from wo
        let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
        let wi = -Frame::from_normal(wo).to_world(local);
        (wi, self.pdf(wo, wi))
    }

    /// The asymmetry `g` checked: a one-line reason when it is outside (−1, 1).
    pub fn henyey_greenstein(g: f32) -> Result<PhaseFunction, String> {
        if !(g > -1.0 && g < 1.0) {
            return Err(format!("g must lie in (-1, 1), found {g}"));
        }
        Ok(PhaseFunction::HenyeyGreenstein { g })
    }
}
