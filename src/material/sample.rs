//! What every BSDF's sampling returns and the quantity a path carries: the leaf
//! the BSDF variants' files share, so that they need not import `bsdf.rs` (which
//! imports them).

use crate::math::Vec3;

/// Which quantity a path carries: radiance (camera subpaths) or importance
/// (light subpaths, the adjoint BSDF). They differ only at specular refraction:
/// `glass` scales radiance by (η_o/η_i)² and importance not at all; `refraction`
/// (radiance weight 1) has the adjoint weight (η_o/η_i)², η_o being the index on
/// the side of `wo`; `roughdielectric` likewise scales radiance by (η_o/η_i)² in
/// `eval` and `sample`, importance not. Integrators reach importance transport through
/// [`super::adjoint`], which adds the shading-normal correction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TransportMode {
    #[default]
    Radiance,
    Importance,
}

#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// f·|cos θi| / pdf (for delta lobes: the lobe's weight).
    pub weight: Vec3,
    pub pdf: f32,
    pub delta: bool,
    /// Relative index crossed where the radiance weight carries its 1/η² (η_t/η_i for
    /// the refractions of `glass`, `roughdielectric`, `principled`; 1 otherwise,
    /// `refraction` included, whose radiance weight is 1): for roulette on the throughput without it.
    pub eta: f32,
}

impl BsdfSample {
    /// A sample of the non-delta direction `wi` (local, z the normal) where the BSDF
    /// is `f` and the density `pdf`: weight f·cos θi/pdf; `None` for a zero or NaN density.
    pub fn glossy(wi: Vec3, f: Vec3, pdf: f32) -> Option<BsdfSample> {
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: f * (wi.z / pdf),
            pdf,
            delta: false,
            eta: 1.0,
        })
    }
}
