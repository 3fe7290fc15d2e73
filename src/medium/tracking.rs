//! Distance sampling and transmittance through a medium, written over a ray's
//! majorant segments ([`MajorantSegment`]): a homogeneous medium is one segment,
//! a grid medium the cells of its majorant grid along the ray.
//!
//! Distances are sampled by delta tracking in one channel, the path's hero
//! channel, and every channel is weighted by one-sample MIS over the channels
//! (Miller, Georgiev and Jarosz 2019, pbrt-v4's `r_u`): a path sampled with the
//! densities of channel h weighs f/mean_c(p_c), which [`HeroWeights`] keeps as the
//! ratios p_c/p_h. A chromatic extinction is then neither biased nor fireflied.
//! Shadow rays use ratio tracking at the largest channel's majorant, exact (no
//! collisions) where a segment's majorant is the extinction itself.

use super::{Medium, MediumPoint};
use crate::geometry::Ray;
use crate::math::Vec3;

/// A stretch `[t0, t1]` of a ray where `sigma_maj` bounds the extinction of every
/// channel; `exact`: the extinction equals the majorant throughout.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MajorantSegment {
    pub t0: f32,
    pub t1: f32,
    pub sigma_maj: Vec3,
    pub exact: bool,
}

/// What delta tracking found before the ray's end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tracked {
    /// A real scattering event at `t`.
    Scattered { t: f32, point: MediumPoint },
    /// The path was absorbed.
    Absorbed,
    /// The ray reached its end.
    Passed,
}

/// The channel-MIS state of a path: its hero channel and the ratios p_c/p_h of
/// the densities with which its medium events were sampled, scaled to mean 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeroWeights {
    pub hero: usize,
    pub ratios: Vec3,
}

impl HeroWeights {
    /// The hero channel from a uniform number.
    pub fn new(u: f32) -> HeroWeights {
        HeroWeights {
            hero: ((u * 3.0) as usize).min(2),
            ratios: Vec3::ONE,
        }
    }

    /// Applies a tracking factor `f` (∝ f_c/p_h per channel, any positive scale) to
    /// the ratios and to the throughput `beta`, which stays f/mean_c(p_c).
    #[inline]
    pub fn apply(&mut self, f: Vec3, beta: &mut Vec3) {
        let r = self.ratios * f;
        let m = (r.x + r.y + r.z) / 3.0;
        if !(m > 0.0 && m.is_finite()) {
            *beta = Vec3::ZERO;
            return;
        }
        self.ratios = r / m;
        *beta *= f / m;
    }
}

/// exp(−(σc − σh)·d) per channel, scaled so the largest is 1 (the tracking factor
/// T_c/T_h up to a common scale, without overflow).
#[inline]
fn transmittance_ratio(sigma: Vec3, d: f32, hero: usize) -> Vec3 {
    let e = -(sigma - Vec3::splat(sigma[hero])) * d;
    let top = e.max_element();
    Vec3::new((e.x - top).exp(), (e.y - top).exp(), (e.z - top).exp())
}

/// Scales a positive factor so its largest channel is 1 (0 stays 0).
#[inline]
fn rescaled(f: Vec3) -> Vec3 {
    let top = f.max_element();
    if top > 0.0 && top.is_finite() {
        f / top
    } else {
        f
    }
}

/// Delta tracking along `ray` over `[ray.t_min, t_end]` (`t_end` finite) in channel
/// `hero`: the event found, and the factor to apply through [`HeroWeights::apply`].
/// `u` gives uniform numbers in [0, 1).
pub fn delta_tracking(medium: &Medium, ray: &Ray, t_end: f32, hero: usize, u: impl FnMut() -> f32) -> (Tracked, Vec3) {
    let (found, f, _) = track(medium, ray, t_end, hero, None, u);
    (found, f)
}

/// [`delta_tracking`] for a path with channel-MIS state `weights`, which also gathers an
/// emissive medium's light: the third value, to be multiplied by the path's throughput
/// before the factor is applied. As pbrt-v4's volumetric path tracer does, the emission
/// σa·Le is collected at every collision, real or null, weighted by the collision's
/// density mean_c(p_c·σmaj_c·T_maj,c); the same numbers are drawn as without emission.
pub fn delta_tracking_emitting(
    medium: &Medium,
    ray: &Ray,
    t_end: f32,
    weights: &HeroWeights,
    u: impl FnMut() -> f32,
) -> (Tracked, Vec3, Vec3) {
    let emission = medium.is_emissive().then_some(weights.ratios);
    track(medium, ray, t_end, weights.hero, emission, u)
}

/// Delta tracking; with `emission` (the path's density ratios) it sums the emission at
/// every collision.
#[inline]
fn track(medium: &Medium, ray: &Ray, t_end: f32, hero: usize, emission: Option<Vec3>, mut u: impl FnMut() -> f32) -> (Tracked, Vec3, Vec3) {
    let mut f = Vec3::ONE;
    let mut emitted = Vec3::ZERO;
    let mut found = Tracked::Passed;
    medium.segments(ray, t_end, |s| {
        let sigma_h = s.sigma_maj[hero];
        // in f64: steps far below the ray's f32 resolution still advance
        let mut t = f64::from(s.t0);
        loop {
            let dt = if sigma_h > 0.0 {
                -(1.0 - u()).ln() / sigma_h
            } else {
                f32::INFINITY
            };
            let left = (f64::from(s.t1) - t) as f32;
            if dt >= left {
                f = rescaled(f * transmittance_ratio(s.sigma_maj, left, hero));
                return true;
            }
            t += f64::from(dt);
            let tm = transmittance_ratio(s.sigma_maj, dt, hero);
            let x = ray.at(t as f32);
            let point = medium.at(x);
            if let Some(ratios) = emission {
                // f·tm is each channel's density of reaching t up to a common scale,
                // which cancels between the emission and its density
                let reach = f * tm;
                let q = ratios * reach * s.sigma_maj;
                let mean = (q.x + q.y + q.z) / 3.0;
                if mean > 0.0 {
                    emitted += reach * point.sigma_a * medium.radiance(x) / mean;
                }
            }
            let sigma_n = (s.sigma_maj - point.sigma_a - point.sigma_s).max(Vec3::ZERO);
            let (p_absorb, p_scatter) = (point.sigma_a[hero] / sigma_h, point.sigma_s[hero] / sigma_h);
            let xi = u();
            if xi < p_absorb {
                found = Tracked::Absorbed;
                return false;
            }
            if xi < p_absorb + p_scatter || sigma_n[hero] <= 0.0 {
                if point.sigma_s[hero] <= 0.0 {
                    found = Tracked::Absorbed;
                    return false;
                }
                f = rescaled(f * tm * point.sigma_s / point.sigma_s[hero]);
                found = Tracked::Scattered { t: t as f32, point };
                return false;
            }
            // a null collision: the ray goes on
            f = rescaled(f * tm * sigma_n / sigma_n[hero]);
        }
    });
    (found, f, emitted)
}

/// Transmittance of every channel along `ray` over `[ray.t_min, t_end]` (`t_end`
/// finite), estimated by ratio tracking at the largest channel's majorant; exact on
/// segments whose majorant is the extinction.
pub fn ratio_tracking(medium: &Medium, ray: &Ray, t_end: f32, mut u: impl FnMut() -> f32) -> Vec3 {
    let mut tr = Vec3::ONE;
    medium.segments(ray, t_end, |s| {
        if s.exact {
            let d = -s.sigma_maj * (s.t1 - s.t0);
            tr *= Vec3::new(d.x.exp(), d.y.exp(), d.z.exp());
            return tr.max_element() > 0.0;
        }
        let mu = s.sigma_maj.max_element();
        if mu <= 0.0 {
            return true;
        }
        let mut t = f64::from(s.t0);
        loop {
            t -= f64::from((1.0 - u()).ln() / mu);
            if t >= f64::from(s.t1) {
                return true;
            }
            let point = medium.at(ray.at(t as f32));
            tr *= (Vec3::ONE - (point.sigma_a + point.sigma_s) / mu).max(Vec3::ZERO);
            if tr.max_element() <= 0.0 {
                return false;
            }
        }
    });
    tr
}
