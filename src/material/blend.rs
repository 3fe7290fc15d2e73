//! Mitsuba's `blendbsdf`: (1 − w)·f₀ + w·f₁ of two nested BSDFs, `w` the weight
//! (clamped to [0, 1]) at the point. Sampling picks the second with probability `w`
//! (the first otherwise, the lobe choice `uc` rescaled for the nested one), as
//! Mitsuba does; rdr then reports the mixture density (1 − w)·p₀ + w·p₁ and weight
//! f·|cos|/p of the mixture for a non-delta direction (Mitsuba keeps the chosen one's
//! own pdf and weight: the same expectation), and for a delta lobe the nested
//! sample's weight with its probability scaled by the choice. Each nested BSDF keeps
//! its own frame (a nested `twosided` flips its own), so all of this is in world space.

use super::bsdf::Bsdf;
use super::sample::{BsdfSample, TransportMode};
use crate::math::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct BlendBsdf {
    /// The second BSDF's share, in [0, 1].
    pub weight: f32,
    pub first: Bsdf,
    pub second: Bsdf,
}

impl BlendBsdf {
    pub fn new(weight: f32, first: Bsdf, second: Bsdf) -> BlendBsdf {
        BlendBsdf {
            weight: if weight.is_nan() { 0.0 } else { weight.clamp(0.0, 1.0) },
            first,
            second,
        }
    }

    pub fn is_delta(&self) -> bool {
        self.first.is_delta() && self.second.is_delta()
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        let w = self.weight;
        let mut f = Vec3::ZERO;
        if w < 1.0 {
            f += self.first.eval_mode(wo, wi, mode) * (1.0 - w);
        }
        if w > 0.0 {
            f += self.second.eval_mode(wo, wi, mode) * w;
        }
        f
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let w = self.weight;
        let mut p = 0.0;
        if w < 1.0 {
            p += self.first.pdf(wo, wi) * (1.0 - w);
        }
        if w > 0.0 {
            p += self.second.pdf(wo, wi) * w;
        }
        p
    }

    /// `n` is the outer frame's normal, for the cosine of the mixture's weight.
    pub fn sample(&self, wo: Vec3, u: Vec2, uc: f32, mode: TransportMode, n: Vec3) -> Option<BsdfSample> {
        let w = self.weight;
        let (chosen, p_choice, uc) = if w > 0.0 && (uc < w || w >= 1.0) {
            (&self.second, w, (uc / w).min(1.0 - f32::EPSILON / 2.0))
        } else {
            (&self.first, 1.0 - w, ((uc - w) / (1.0 - w)).clamp(0.0, 1.0 - f32::EPSILON / 2.0))
        };
        let s = chosen.sample_mode(wo, u, uc, mode)?;
        if s.delta {
            return Some(BsdfSample {
                pdf: s.pdf * p_choice,
                ..s
            });
        }
        let pdf = self.pdf(wo, s.wi);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(BsdfSample {
            weight: self.eval(wo, s.wi, mode) * (n.dot(s.wi).abs() / pdf),
            pdf,
            ..s
        })
    }
}
