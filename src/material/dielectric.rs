//! Mitsuba's `thindielectric` and `roughdielectric` in the local frame (z is the
//! shading normal; `o` points to the viewer, `i` to the light, both away from the
//! surface). Index `eta` = η_inside / η_outside, the inside being below the frame.

use super::fresnel;
use super::microfacet::Microfacet;
use super::sample::{BsdfSample, TransportMode};
use crate::math::Vec3;

/// A thin slab: mirror reflection with probability 2R/(1+R) (see
/// [`fresnel::thin_dielectric`]), otherwise straight through (no bending, so no
/// η² scaling in either transport mode). Both faces alike.
#[derive(Clone, Copy, Debug)]
pub struct ThinDielectric {
    /// `specular_reflectance`, `specular_transmittance`.
    pub r: Vec3,
    pub t: Vec3,
    pub eta: f32,
}

impl ThinDielectric {
    pub fn sample(&self, o: Vec3, uc: f32) -> Option<BsdfSample> {
        if o.z == 0.0 {
            return None;
        }
        let r = fresnel::thin_dielectric(o.z, self.eta);
        Some(if uc < r {
            BsdfSample {
                wi: Vec3::new(-o.x, -o.y, o.z),
                weight: self.r,
                pdf: r,
                delta: true,
                eta: 1.0,
            }
        } else {
            BsdfSample {
                wi: -o,
                weight: self.t,
                pdf: 1.0 - r,
                delta: true,
                eta: 1.0,
            }
        })
    }
}

/// Rough dielectric interface (Walter et al. 2007), Mitsuba's `roughdielectric`:
/// reflection F·D·G/(4|cos θo cos θi|) and transmission
/// (1−F)·D·G·η²|o·m||i·m| / (|cos θo cos θi| (o·m + η i·m)²), η the relative index
/// seen from `o`'s side; in radiance mode the transmission is scaled by 1/η² (the
/// adjoint, importance, is not). Visible normals are sampled from `o` (flipped to the
/// upper side), then reflection with probability F.
#[derive(Clone, Copy, Debug)]
pub struct RoughDielectric {
    pub r: Vec3,
    pub t: Vec3,
    pub eta: f32,
    pub mf: Microfacet,
}

/// The microfacet normal joining `o` and `i` (upper hemisphere), the relative index
/// seen from `o` and whether it is a reflection; `None` where no facet joins them
/// consistently (each direction must see the facet from its own side).
fn half_vector(o: Vec3, i: Vec3, eta: f32) -> Option<(Vec3, f32, bool)> {
    if o.z == 0.0 || i.z == 0.0 {
        return None;
    }
    let reflect = o.z * i.z > 0.0;
    let eta_rel = if o.z > 0.0 { eta } else { 1.0 / eta };
    let h = if reflect { o + i } else { o + i * eta_rel };
    let len = h.length();
    if len == 0.0 || !len.is_finite() {
        return None;
    }
    let m = h / len;
    let m = if m.z < 0.0 { -m } else { m };
    if o.dot(m) * o.z <= 0.0 || i.dot(m) * i.z <= 0.0 {
        return None;
    }
    Some((m, eta_rel, reflect))
}

impl RoughDielectric {
    pub fn eval(&self, o: Vec3, i: Vec3, mode: TransportMode) -> Vec3 {
        let Some((m, eta_rel, reflect)) = half_vector(o, i, self.eta) else {
            return Vec3::ZERO;
        };
        let d = self.mf.d(m);
        if d == 0.0 {
            return Vec3::ZERO;
        }
        let f = fresnel::dielectric(o.dot(m), self.eta).0;
        let g = self.mf.g(o, i, m);
        if reflect {
            self.r * (f * d * g / (4.0 * o.z * i.z).abs())
        } else {
            let (om, im) = (o.dot(m), i.dot(m));
            let denom = om + eta_rel * im;
            let scale = match mode {
                TransportMode::Radiance => 1.0 / (eta_rel * eta_rel),
                TransportMode::Importance => 1.0,
            };
            let v = scale * (1.0 - f) * d * g * eta_rel * eta_rel * om * im / (o.z * i.z * denom * denom);
            self.t * v.abs()
        }
    }

    pub fn pdf(&self, o: Vec3, i: Vec3) -> f32 {
        let Some((m, eta_rel, reflect)) = half_vector(o, i, self.eta) else {
            return 0.0;
        };
        let o_up = if o.z < 0.0 { -o } else { o };
        let f = fresnel::dielectric(o.dot(m), self.eta).0;
        let pm = self.mf.pdf_visible(o_up, m);
        // the Jacobian from microfacet normals to directions
        let (p_lobe, dm_di) = if reflect {
            (f, 1.0 / (4.0 * i.dot(m).abs()))
        } else {
            let denom = o.dot(m) + eta_rel * i.dot(m);
            (1.0 - f, eta_rel * eta_rel * i.dot(m).abs() / (denom * denom))
        };
        let p = pm * p_lobe * dm_di;
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }

    pub fn sample(&self, o: Vec3, u: crate::math::Vec2, uc: f32, mode: TransportMode) -> Option<BsdfSample> {
        if o.z == 0.0 {
            return None;
        }
        let o_up = if o.z < 0.0 { -o } else { o };
        let m = self.mf.sample_visible(o_up, u);
        let om = o.dot(m);
        if om * o.z <= 0.0 {
            return None;
        }
        let (f, cos_t, eta_ti) = fresnel::dielectric(om, self.eta);
        let (i, weight, eta) = if uc < f {
            let i = 2.0 * om * m - o;
            if i.z * o.z <= 0.0 {
                return None;
            }
            (i, self.r * self.mf.g1(i, m), 1.0)
        } else {
            let i = (m * (om * eta_ti + cos_t) - o * eta_ti).normalize();
            if i.z * o.z >= 0.0 {
                return None;
            }
            // radiance is compressed into the smaller solid angle: (η_o/η_i)²
            let scale = match mode {
                TransportMode::Radiance => eta_ti * eta_ti,
                TransportMode::Importance => 1.0,
            };
            (i, self.t * (self.mf.g1(i, m) * scale), 1.0 / eta_ti)
        };
        let pdf = self.pdf(o, i);
        if pdf.is_nan() || pdf <= 0.0 || weight == Vec3::ZERO {
            return None;
        }
        Some(BsdfSample {
            wi: i,
            weight,
            pdf,
            delta: false,
            eta,
        })
    }
}
