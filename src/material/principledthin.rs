//! Mitsuba 3's `principledthin` plugin: the thin-surface variant of Burley's Disney
//! BSDF (a sheet with no inside: both faces alike, light passing straight through).
//! Local frame as in [`super::principled`] (`o` towards the viewer, `i` towards the
//! light); both are first turned to the front side (the model is symmetric).
//!
//! Lobes, with st = spec_trans and dt = diff_trans/2 (the key runs from 0 to 2):
//! * specular reflection: st·F_thin·D·G/(4 cos θo cos θi), F_thin the dielectric
//!   Fresnel of `eta` blended towards a tinted Schlick term by `spec_tint`;
//! * specular transmission: the reflection at a GGX normal mirrored to the other
//!   side, st·base_color·(1 − F)·D'·G'/(4 cos θo |cos θi|), D' of a roughness scaled
//!   by 0.65·η − 0.35 (Burley 2015);
//! * diffuse reflection (with retro-reflection, `flatness` and sheen as `principled`),
//!   weighted (1 − st)(1 − dt); diffuse transmission (1 − st)·dt·base_color/π.
//!
//! Sampling as Mitsuba's, the lobe chosen with probabilities ∝ st·r_sr/2, st·r_st/2,
//! (1 − st)(1 − dt)·r_dr, (1 − st)·dt·r_dt (the sampling rates r), none depending on
//! the direction, so [`PrincipledThin::pdf`] is the density of its sampling.

use super::fresnel;
use super::microfacet::{Distribution, Microfacet};
use super::principled::{luminance, scalar, schlick_weight};
use super::sample::BsdfSample;
use crate::math::{Vec2, Vec3, INV_PI};
use crate::sampling::cosine_hemisphere;

/// The parameters of `principledthin`, shared by the description and render layers
/// (textures `T` as in [`super::PrincipledParams`]); `eta` is a texture here, as in
/// Mitsuba.
#[derive(Clone, Debug, PartialEq)]
pub struct PrincipledThinParams<T> {
    pub base_color: T,
    pub roughness: T,
    pub anisotropic: T,
    pub spec_trans: T,
    pub eta: T,
    pub spec_tint: T,
    pub sheen: T,
    pub sheen_tint: T,
    pub flatness: T,
    pub diff_trans: T,
    /// `specular_reflectance_sampling_rate`, `specular_transmittance_sampling_rate`,
    /// `diffuse_reflectance_sampling_rate`, `diffuse_transmittance_sampling_rate` (1 each).
    pub rates: [f32; 4],
}

impl<T> PrincipledThinParams<T> {
    /// The textures in declaration order.
    pub fn textures(&self) -> [&T; 10] {
        [
            &self.base_color,
            &self.roughness,
            &self.anisotropic,
            &self.spec_trans,
            &self.eta,
            &self.spec_tint,
            &self.sheen,
            &self.sheen_tint,
            &self.flatness,
            &self.diff_trans,
        ]
    }

    /// The same parameters with every texture replaced by `f(texture)`, in declaration order.
    pub fn try_map<U, E>(&self, f: &mut impl FnMut(&T) -> Result<U, E>) -> Result<PrincipledThinParams<U>, E> {
        Ok(PrincipledThinParams {
            base_color: f(&self.base_color)?,
            roughness: f(&self.roughness)?,
            anisotropic: f(&self.anisotropic)?,
            spec_trans: f(&self.spec_trans)?,
            eta: f(&self.eta)?,
            spec_tint: f(&self.spec_tint)?,
            sheen: f(&self.sheen)?,
            sheen_tint: f(&self.sheen_tint)?,
            flatness: f(&self.flatness)?,
            diff_trans: f(&self.diff_trans)?,
            rates: self.rates,
        })
    }
}

impl PrincipledThinParams<u32> {
    /// The BSDF at a point where `tex` evaluates the textures.
    pub fn at(&self, tex: &impl Fn(u32) -> Vec3) -> PrincipledThin {
        let s = |t: u32| scalar(tex(t));
        PrincipledThin::new(
            tex(self.base_color),
            [
                s(self.roughness),
                s(self.anisotropic),
                s(self.spec_trans),
                s(self.eta),
                s(self.spec_tint),
                s(self.sheen),
                s(self.sheen_tint),
                s(self.flatness),
                s(self.diff_trans),
            ],
            self.rates,
        )
    }
}

/// GGX α from roughness and anisotropy (Mitsuba's `calc_dist_params`).
fn distribution(roughness: f32, anisotropic: f32) -> Microfacet {
    let r2 = roughness * roughness;
    let aspect = (1.0 - 0.9 * anisotropic).sqrt();
    Microfacet::new(Distribution::Ggx, (r2 / aspect).max(0.001), (r2 * aspect).max(0.001))
}

/// The thin principled BSDF at one point.
#[derive(Clone, Copy, Debug)]
pub struct PrincipledThin {
    pub base_color: Vec3,
    pub roughness: f32,
    pub spec_trans: f32,
    pub eta: f32,
    pub spec_tint: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub flatness: f32,
    /// diff_trans/2, in [0, 1].
    pub diff_trans: f32,
    pub rates: [f32; 4],
    /// Reflection's GGX, and transmission's (roughness scaled by 0.65·η − 0.35).
    pub mf_reflect: Microfacet,
    pub mf_transmit: Microfacet,
}

impl PrincipledThin {
    /// `values` = roughness, anisotropic, spec_trans, eta, spec_tint, sheen, sheen_tint,
    /// flatness, diff_trans (0 to 2).
    pub fn new(base_color: Vec3, values: [f32; 9], rates: [f32; 4]) -> PrincipledThin {
        let [roughness, anisotropic, spec_trans, eta, spec_tint, sheen, sheen_tint, flatness, diff_trans] = values;
        PrincipledThin {
            base_color,
            roughness,
            spec_trans,
            eta,
            spec_tint,
            sheen,
            sheen_tint,
            flatness,
            diff_trans: diff_trans / 2.0,
            rates,
            mf_reflect: distribution(roughness, anisotropic),
            mf_transmit: distribution((0.65 * eta - 0.35) * roughness, anisotropic),
        }
    }

    /// Normalised lobe probabilities: specular reflection, specular transmission,
    /// diffuse reflection, diffuse transmission.
    fn probabilities(&self) -> Option<[f32; 4]> {
        let (st, dt) = (self.spec_trans, self.diff_trans);
        let r = self.rates;
        let p = [
            st * r[0] / 2.0,
            st * r[1] / 2.0,
            r[2] * (1.0 - st) * (1.0 - dt),
            r[3] * (1.0 - st) * dt,
        ];
        let total: f32 = p.iter().sum();
        (total > 0.0 && total.is_finite()).then(|| p.map(|x| x / total))
    }

    /// Both directions turned so that `o` is on the front side; `None` at grazing `o`.
    fn front(o: Vec3, i: Vec3) -> Option<(Vec3, Vec3)> {
        if o.z == 0.0 {
            return None;
        }
        Some(if o.z < 0.0 { (-o, -i) } else { (o, i) })
    }

    /// The half vector of `o` and `i` mirrored to `o`'s side.
    fn half(o: Vec3, i: Vec3) -> Vec3 {
        (o + Vec3::new(i.x, i.y, i.z.abs())).normalize()
    }

    fn compatible(m: Vec3, o: Vec3, i: Vec3, reflection: bool) -> bool {
        o.dot(m) > 0.0 && if reflection { i.dot(m) > 0.0 } else { i.dot(-m) > 0.0 }
    }

    /// f(o, i) without the cosine (the same for radiance and importance: nothing bends).
    pub fn eval(&self, o: Vec3, i: Vec3) -> Vec3 {
        let Some((o, i)) = Self::front(o, i) else { return Vec3::ZERO };
        if i.z == 0.0 {
            return Vec3::ZERO;
        }
        let (st, dt) = (self.spec_trans, self.diff_trans);
        let reflect = i.z > 0.0;
        let h = Self::half(o, i);
        if !h.is_finite() {
            return Vec3::ZERO;
        }
        let (co, ci) = (o.z, i.z.abs());
        let mut value = Vec3::ZERO;
        if st > 0.0 {
            let f = fresnel::dielectric(o.dot(h), self.eta).0;
            if reflect && Self::compatible(h, o, i, true) {
                let mut f_thin = Vec3::splat(f);
                if self.spec_tint != 0.0 {
                    let lum = luminance(self.base_color);
                    let tint = if lum > 0.0 { self.base_color / lum } else { Vec3::ONE };
                    let r0 = tint * ((self.eta - 1.0) / (self.eta + 1.0)).powi(2);
                    let schlick = schlick_thin(r0, o.dot(h), self.eta);
                    f_thin += (schlick - f_thin) * self.spec_tint;
                }
                let (d, g) = (self.mf_reflect.d(h), self.mf_reflect.g(o, i, h));
                value += f_thin * (st * d * g / (4.0 * co * ci));
            }
            if !reflect && Self::compatible(h, o, i, false) {
                let (d, g) = (self.mf_transmit.d(h), self.mf_transmit.g(o, i, h));
                value += self.base_color * (st * (1.0 - f) * d * g / (4.0 * co * ci));
            }
        }
        if reflect && st < 1.0 && dt < 1.0 {
            let (fo, fi) = (schlick_weight(ci), schlick_weight(co));
            let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
            let cos_d = h.dot(i);
            let rr = 2.0 * self.roughness * cos_d * cos_d;
            let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
            let mut shape = f_diff + f_retro;
            if self.flatness != 0.0 {
                let fss90 = rr / 2.0;
                let fss = (1.0 + (fss90 - 1.0) * fo) * (1.0 + (fss90 - 1.0) * fi);
                let f_ss = 1.25 * (fss * (1.0 / (co + ci) - 0.5) + 0.5);
                shape += (f_ss - shape) * self.flatness;
            }
            value += self.base_color * ((1.0 - st) * INV_PI * (1.0 - dt) * shape);
            if self.sheen > 0.0 {
                let fd = schlick_weight(cos_d.abs());
                let lum = luminance(self.base_color);
                let tint = if lum > 0.0 { self.base_color / lum } else { Vec3::ONE };
                let c_sheen = Vec3::ONE + (tint - Vec3::ONE) * self.sheen_tint;
                value += c_sheen * (self.sheen * (1.0 - st) * fd * (1.0 - dt));
            }
        }
        if !reflect && st < 1.0 && dt > 0.0 {
            value += self.base_color * ((1.0 - st) * dt * INV_PI);
        }
        value
    }

    pub fn pdf(&self, o: Vec3, i: Vec3) -> f32 {
        let Some((o, i)) = Self::front(o, i) else { return 0.0 };
        if i.z == 0.0 {
            return 0.0;
        }
        let Some([p_sr, p_st, p_dr, p_dt]) = self.probabilities() else {
            return 0.0;
        };
        let reflect = i.z > 0.0;
        let mut pdf = 0.0;
        if self.spec_trans > 0.0 {
            let h = Self::half(o, i);
            let i_r = Vec3::new(i.x, i.y, i.z.abs());
            let dh_di = (1.0 / (4.0 * i_r.dot(h))).abs();
            if reflect && Self::compatible(h, o, i, true) {
                pdf += p_sr * self.mf_reflect.pdf_visible(o, h) * dh_di;
            }
            if !reflect && Self::compatible(h, o, i, false) {
                pdf += p_st * self.mf_transmit.pdf_visible(o, h) * dh_di;
            }
        }
        pdf += (if reflect { p_dr } else { p_dt }) * i.z.abs() * INV_PI;
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    pub fn sample(&self, o: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        let sign = if o.z < 0.0 { -1.0 } else { 1.0 };
        let (of, _) = Self::front(o, o)?;
        let [p_sr, p_st, p_dr, _] = self.probabilities()?;
        let i = if uc < p_sr {
            let m = self.mf_reflect.sample_visible(of, u);
            let i = 2.0 * of.dot(m) * m - of;
            if i.z <= 0.0 || !Self::compatible(m, of, i, true) {
                return None;
            }
            i
        } else if uc < p_sr + p_st {
            let m = self.mf_transmit.sample_visible(of, u);
            let r = 2.0 * of.dot(m) * m - of;
            let i = Vec3::new(r.x, r.y, -r.z);
            if i.z >= 0.0 || !Self::compatible(m, of, i, false) {
                return None;
            }
            i
        } else if uc < p_sr + p_st + p_dr {
            cosine_hemisphere(u)
        } else {
            -cosine_hemisphere(u)
        };
        let i = i * sign;
        let pdf = self.pdf(o, i);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(BsdfSample {
            wi: i,
            weight: self.eval(o, i) * (i.z.abs() / pdf),
            pdf,
            delta: false,
            eta: 1.0,
        })
    }
}

/// Mitsuba's `calc_schlick` for the thin sheet's index.
fn schlick_thin(r0: Vec3, cos: f32, eta: f32) -> Vec3 {
    let eta_it = if cos >= 0.0 { eta } else { 1.0 / eta };
    let eta_ti = 1.0 / eta_it;
    let ct2 = 1.0 - (1.0 - cos * cos) * eta_ti * eta_ti;
    let w = if eta_it > 1.0 {
        schlick_weight(cos.abs())
    } else {
        schlick_weight(ct2.max(0.0).sqrt())
    };
    r0 + (Vec3::ONE - r0) * w
}
