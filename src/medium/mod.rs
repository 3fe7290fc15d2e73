//! Participating media: a closed family (Mitsuba's `homogeneous` and `heterogeneous`,
//! the latter over grid volumes, [`crate::volume`]), their phase functions
//! ([`phase`]) and the tracking that samples distances and estimates
//! transmittance through them ([`tracking`]).
//!
//! Which medium a ray is in follows Mitsuba 3's rule ([`MediumInterface`]): a shape
//! that declares media changes the ray's medium where the ray crosses it, shapes
//! without media change nothing, and the camera's medium is the one the sensor names.
//! Coefficients are per unit length in scene units, one value per RGB channel.
//!
//! A medium may emit (`radiance` Le, pbrt-v4's convention): it adds σa·Le per unit
//! length, so a thick absorbing medium glows with radiance Le, and an albedo-1 one not
//! at all.

pub mod heterogeneous;
pub mod homogeneous;
pub mod phase;
pub mod tracking;

pub use heterogeneous::Heterogeneous;
pub use homogeneous::Homogeneous;
pub use phase::PhaseFunction;
pub use tracking::{delta_tracking, delta_tracking_emitting, ratio_tracking, HeroWeights, MajorantSegment, Tracked};

use crate::geometry::Ray;
use crate::math::Vec3;

/// A participating medium.
#[derive(Clone, Debug)]
pub enum Medium {
    /// Constant coefficients everywhere (inside the shapes that bound it).
    Homogeneous(Homogeneous),
    /// Coefficients from volumes, inside the extinction volume's box only.
    Heterogeneous(Box<Heterogeneous>),
}

/// The coefficients at a point of a medium.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MediumPoint {
    pub sigma_a: Vec3,
    pub sigma_s: Vec3,
}

impl Medium {
    /// The medium's phase function.
    #[inline]
    pub fn phase(&self) -> PhaseFunction {
        match self {
            Medium::Homogeneous(h) => h.phase,
            Medium::Heterogeneous(h) => h.phase,
        }
    }

    /// Whether the medium emits anywhere.
    #[inline]
    pub fn is_emissive(&self) -> bool {
        match self {
            Medium::Homogeneous(h) => h.radiance != Vec3::ZERO,
            Medium::Heterogeneous(h) => h.radiance.is_some(),
        }
    }

    /// The emitted radiance Le at `p` (the medium adds σa·Le per unit length).
    #[inline]
    pub fn radiance(&self, p: Vec3) -> Vec3 {
        match self {
            Medium::Homogeneous(h) => h.radiance,
            Medium::Heterogeneous(h) => h.radiance(p),
        }
    }

    /// The coefficients at `p`.
    #[inline]
    pub fn at(&self, p: Vec3) -> MediumPoint {
        match self {
            Medium::Homogeneous(h) => MediumPoint {
                sigma_a: h.sigma_a,
                sigma_s: h.sigma_s,
            },
            Medium::Heterogeneous(h) => h.at(p),
        }
    }

    /// The majorant segments of `ray` over `[ray.t_min, t_end]`, in order, passed
    /// to `each` until it returns false. A homogeneous medium is one segment whose
    /// majorant is its extinction; a heterogeneous one the cells of its majorant grid.
    #[inline]
    pub fn segments(&self, ray: &Ray, t_end: f32, mut each: impl FnMut(MajorantSegment) -> bool) {
        match self {
            Medium::Heterogeneous(h) => h.segments(ray, t_end, each),
            Medium::Homogeneous(h) => {
                if t_end > ray.t_min {
                    each(MajorantSegment {
                        t0: ray.t_min,
                        t1: t_end,
                        sigma_maj: h.sigma_t(),
                        exact: true,
                    });
                }
            }
        }
    }
}

/// The media on the two sides of a shape (`None`: vacuum), Mitsuba's
/// `interior`/`exterior`. The side is judged by the shape's geometric normal:
/// a ray with `d·n < 0` is entering and takes the interior medium.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MediumInterface {
    pub interior: Option<u32>,
    pub exterior: Option<u32>,
}

impl MediumInterface {
    /// The medium of a ray leaving (or crossing) the surface of normal `ng` in direction `d`.
    #[inline]
    pub fn along(&self, d: Vec3, ng: Vec3) -> Option<u32> {
        if d.dot(ng) < 0.0 {
            self.interior
        } else {
            self.exterior
        }
    }
}
