//! Mitsuba 3's `principled` plugin: Burley's Disney BSDF (2012, and the 2015
//! extension to transmission) as Mitsuba defines it, evaluated in the local frame
//! (z the shading normal; `o` towards the viewer — Mitsuba's `si.wi` —, `i` towards
//! the light — Mitsuba's `wo`).
//!
//! Lobes, with brdf = (1 − metallic)(1 − spec_trans) and bsdf = (1 − metallic)·spec_trans:
//! * main specular reflection: GGX (α = max(0.001, roughness²), stretched by
//!   anisotropic as √(1 − 0.9·anisotropic)) with the principled Fresnel term (the true
//!   dielectric Fresnel of `eta`, mixed with Schlick terms for `metallic` and
//!   `spec_tint`), F·D·G / (4|cos θo cos θi|); seen from inside only bsdf·F;
//! * main specular transmission (Walter et al.), weighted by bsdf·√base_color;
//! * clearcoat: 0.25·clearcoat·F_schlick(0.04)·D_GTR1·G(α = 0.25), on the front side,
//!   *without* the 1/(4 cos θo cos θi) of a microfacet BRDF (as Mitsuba writes it);
//!   the GTR1 α runs from 0.1 to 0.001 as clearcoat_gloss goes from 0 to 1;
//! * diffuse with retro-reflection (and the fake subsurface term blended by
//!   `flatness`), brdf·base_color/π·(…), and sheen (1 − metallic)·sheen·F_schlick(cos θd)
//!   tinted by `sheen_tint`; both on the front side and only where brdf > 0 (the
//!   scalar variants' evaluation, which rdr follows: sheen rides on the diffuse lobe).
//!
//! Sampling as Mitsuba's: one visible GGX normal m from `o`; the lobe is chosen with
//! probabilities ∝ (diffuse: brdf·r_d, clearcoat: 0.25·clearcoat·r_c, specular
//! reflection: r_s(1 − bsdf(1 − F(m))), specular transmission: r_s·bsdf(1 − F(m))) on
//! the front side (r_* the sampling rates), F(m) and 1 − F(m) from inside. The two
//! specular shares add up to r_s whatever F is, so the diffuse and clearcoat shares do
//! not depend on m, and the split between the specular lobes is made at the normal the
//! direction comes from: the mixture [`Principled::pdf`] is the density of
//! [`Principled::sample`] exactly. One difference from Mitsuba: where nothing can be
//! sampled (from inside with bsdf = 0) the pdf is 0; Mitsuba's reports the reflection
//! lobe's there, for a BSDF value of 0.

use super::fresnel;
use super::microfacet::{Distribution, Microfacet};
use super::sample::{BsdfSample, TransportMode};
use crate::math::{Vec2, Vec3, INV_PI, PI};
use crate::sampling::cosine_hemisphere;

/// Mitsuba's luminance of a linear sRGB colour (its `luminance()` in RGB modes).
pub fn luminance(c: Vec3) -> f32 {
    0.212_671 * c.x + 0.715_160 * c.y + 0.072_169 * c.z
}

/// A float parameter read from a colour texture: the value itself when the three
/// channels agree (every constant given as a number), else the luminance (Mitsuba's
/// `eval_1` of an RGB bitmap).
pub fn scalar(c: Vec3) -> f32 {
    if c.x == c.y && c.y == c.z {
        c.x
    } else {
        luminance(c)
    }
}

/// η from Mitsuba's `specular`: 2/(1 − √(0.08·specular)) − 1 (0.5 gives 1.5).
pub fn eta_from_specular(specular: f32) -> f32 {
    2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
}

/// The parameters of `principled` (and, with `diff_trans` unused, shared by the
/// description and render layers): each texture `T` (a reference by name or an inline
/// constant in a description, a texture index once built) is evaluated at the shading
/// point; float parameters read a colour texture through [`scalar`].
#[derive(Clone, Debug, PartialEq)]
pub struct PrincipledParams<T> {
    pub base_color: T,
    pub roughness: T,
    pub metallic: T,
    pub spec_tint: T,
    pub anisotropic: T,
    pub sheen: T,
    pub sheen_tint: T,
    pub clearcoat: T,
    pub clearcoat_gloss: T,
    pub spec_trans: T,
    pub flatness: T,
    /// The index ratio inside/outside in use (from `eta`, or from `specular`).
    pub eta: f32,
    /// `specular` as given (then `eta` was derived from it); `None` when `eta` was.
    pub specular: Option<f32>,
    /// `main_specular_sampling_rate`, `clearcoat_sampling_rate`,
    /// `diffuse_reflectance_sampling_rate` (1 each).
    pub spec_srate: f32,
    pub clearcoat_srate: f32,
    pub diffuse_srate: f32,
    /// Derived when read: `spec_trans` is given and not the constant 0 (Mitsuba's
    /// flag: then light may pass, `twosided` may not wrap it, and `eta` = 1 became 1.001).
    pub has_spec_trans: bool,
}

impl<T> PrincipledParams<T> {
    /// Whether light can pass (see `has_spec_trans`).
    pub fn transmits(&self) -> bool {
        self.has_spec_trans
    }

    /// The same parameters with every texture replaced by `f(texture)`, in declaration order.
    pub fn try_map<U, E>(&self, f: &mut impl FnMut(&T) -> Result<U, E>) -> Result<PrincipledParams<U>, E> {
        Ok(PrincipledParams {
            base_color: f(&self.base_color)?,
            roughness: f(&self.roughness)?,
            metallic: f(&self.metallic)?,
            spec_tint: f(&self.spec_tint)?,
            anisotropic: f(&self.anisotropic)?,
            sheen: f(&self.sheen)?,
            sheen_tint: f(&self.sheen_tint)?,
            clearcoat: f(&self.clearcoat)?,
            clearcoat_gloss: f(&self.clearcoat_gloss)?,
            spec_trans: f(&self.spec_trans)?,
            flatness: f(&self.flatness)?,
            eta: self.eta,
            specular: self.specular,
            spec_srate: self.spec_srate,
            clearcoat_srate: self.clearcoat_srate,
            diffuse_srate: self.diffuse_srate,
            has_spec_trans: self.has_spec_trans,
        })
    }
}

impl PrincipledParams<u32> {
    /// The BSDF at a point where `tex` evaluates the textures.
    pub fn at(&self, tex: &impl Fn(u32) -> Vec3) -> Principled {
        let s = |t: u32| scalar(tex(t));
        Principled::new(
            tex(self.base_color),
            [
                s(self.roughness),
                s(self.metallic),
                s(self.spec_tint),
                s(self.anisotropic),
                s(self.sheen),
                s(self.sheen_tint),
                s(self.clearcoat),
                s(self.clearcoat_gloss),
                s(self.spec_trans),
                s(self.flatness),
            ],
            self.eta,
            [self.spec_srate, self.clearcoat_srate, self.diffuse_srate],
        )
    }
}

/// Clearcoat's GTR1 distribution (Burley 2012), isotropic, sampled by its D·cos θ.
#[derive(Clone, Copy, Debug)]
struct Gtr1 {
    alpha: f32,
}

impl Gtr1 {
    fn d(&self, m: Vec3) -> f32 {
        let a2 = self.alpha * self.alpha;
        let c2 = m.z * m.z;
        let r = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * c2));
        if r * m.z > 1e-20 {
            r
        } else {
            0.0
        }
    }

    fn pdf(&self, m: Vec3) -> f32 {
        if m.z < 0.0 {
            0.0
        } else {
            m.z * self.d(m)
        }
    }

    fn sample(&self, u: Vec2) -> Vec3 {
        let phi = 2.0 * PI * u.x;
        let a2 = self.alpha * self.alpha;
        let c2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
        let (s, c) = ((1.0 - c2).max(0.0).sqrt(), c2.max(0.0).sqrt());
        Vec3::new(phi.cos() * s, phi.sin() * s, c)
    }
}

/// Smith's GGX masking for an isotropic α (the clearcoat's, α = 0.25).
fn smith_ggx1(v: Vec3, m: Vec3, alpha: f32) -> f32 {
    if v.dot(m) * v.z <= 0.0 {
        return 0.0;
    }
    if v.z == 1.0 {
        return 1.0;
    }
    let c2 = v.z * v.z;
    let t2 = (1.0 - c2) / c2;
    2.0 / (1.0 + (1.0 + alpha * alpha * t2).sqrt())
}

/// (1 − cos)⁵, clamped.
pub fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick's Fresnel R0 + (1 − R0)·w, w from the cosine on the denser side (the
/// refracted one when light arrives from the denser medium), as Mitsuba's `calc_schlick`.
fn schlick(r0: Vec3, cos: f32, eta: f32) -> Vec3 {
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

fn r0_of(eta: f32) -> f32 {
    ((eta - 1.0) / (eta + 1.0)).powi(2)
}

/// Mitsuba's macro/micro-surface agreement: both directions on the sides of `m` that
/// a reflection (or a refraction) at `m` connects, seen from `o`'s side.
fn compatible(m: Vec3, o: Vec3, i: Vec3, reflection: bool) -> bool {
    let m = if o.z < 0.0 { -m } else { m };
    o.dot(m) > 0.0 && if reflection { i.dot(m) > 0.0 } else { i.dot(-m) > 0.0 }
}

/// The principled BSDF at one point: its parameters evaluated there.
#[derive(Clone, Copy, Debug)]
pub struct Principled {
    pub base_color: Vec3,
    pub roughness: f32,
    pub metallic: f32,
    pub spec_tint: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub clearcoat: f32,
    pub clearcoat_gloss: f32,
    pub spec_trans: f32,
    pub flatness: f32,
    pub eta: f32,
    pub spec_srate: f32,
    pub clearcoat_srate: f32,
    pub diffuse_srate: f32,
    /// The main lobes' GGX distribution (from roughness and anisotropic).
    pub mf: Microfacet,
}

/// Which lobe a sample came from (for tests that count them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    Diffuse,
    Clearcoat,
    SpecularTransmission,
    SpecularReflection,
}

impl Principled {
    /// `values` = roughness, metallic, spec_tint, anisotropic, sheen, sheen_tint,
    /// clearcoat, clearcoat_gloss, spec_trans, flatness; `rates` = the main specular,
    /// clearcoat and diffuse sampling rates.
    pub fn new(base_color: Vec3, values: [f32; 10], eta: f32, rates: [f32; 3]) -> Principled {
        let [roughness, metallic, spec_tint, anisotropic, sheen, sheen_tint, clearcoat, clearcoat_gloss, spec_trans, flatness] = values;
        let r2 = roughness * roughness;
        let aspect = (1.0 - 0.9 * anisotropic).sqrt();
        let (ax, ay) = ((r2 / aspect).max(0.001), (r2 * aspect).max(0.001));
        Principled {
            base_color,
            roughness,
            metallic,
            spec_tint,
            sheen,
            sheen_tint,
            clearcoat,
            clearcoat_gloss,
            spec_trans,
            flatness,
            eta,
            spec_srate: rates[0],
            clearcoat_srate: rates[1],
            diffuse_srate: rates[2],
            mf: Microfacet::new(Distribution::Ggx, ax, ay),
        }
    }

    /// brdf and bsdf, the weights of the reflecting base and of the transmitting lobe.
    fn weights(&self) -> (f32, f32) {
        let m = 1.0 - self.metallic;
        (m * (1.0 - self.spec_trans), m * self.spec_trans)
    }

    fn clearcoat_distribution(&self) -> Gtr1 {
        Gtr1 {
            alpha: 0.1 + (0.001 - 0.1) * self.clearcoat_gloss,
        }
    }

    /// Normalised lobe probabilities (diffuse, clearcoat, transmission, reflection)
    /// for the dielectric Fresnel term `f` at the specular normal; `None` when no lobe
    /// can be sampled.
    fn probabilities(&self, front: bool, f: f32) -> Option<[f32; 4]> {
        let (brdf, bsdf) = self.weights();
        let p = if front {
            [
                brdf * self.diffuse_srate,
                0.25 * self.clearcoat * self.clearcoat_srate,
                self.spec_srate * bsdf * (1.0 - f),
                self.spec_srate * (1.0 - bsdf * (1.0 - f)),
            ]
        } else {
            if bsdf <= 0.0 {
                return None;
            }
            [0.0, 0.0, 1.0 - f, f]
        };
        let total: f32 = p.iter().sum();
        (total > 0.0 && total.is_finite()).then(|| p.map(|x| x / total))
    }

    /// The principled Fresnel term at the microfacet with cos `c` = o·m.
    fn fresnel(&self, f_dielectric: f32, c: f32, front: bool) -> Vec3 {
        let (_, bsdf) = self.weights();
        if !front {
            return Vec3::splat(bsdf * f_dielectric);
        }
        let lum = luminance(self.base_color);
        let eta_it = if c >= 0.0 { self.eta } else { 1.0 / self.eta };
        let mut fs = self.metallic * schlick(self.base_color, c, self.eta);
        if self.spec_tint != 0.0 {
            let tint = if lum > 0.0 { self.base_color / lum } else { Vec3::ONE };
            fs += (1.0 - self.metallic) * self.spec_tint * schlick(tint * r0_of(eta_it), c, self.eta);
        }
        Vec3::splat((1.0 - self.metallic) * (1.0 - self.spec_tint) * f_dielectric) + fs
    }

    /// The half vector of `o` and `i` (upper hemisphere), whether it is a reflection,
    /// and the relative index seen from `o`.
    fn half(&self, o: Vec3, i: Vec3) -> Option<(Vec3, bool, f32)> {
        let reflect = o.z * i.z > 0.0;
        let eta_path = if o.z > 0.0 { self.eta } else { 1.0 / self.eta };
        let h = (o + i * if reflect { 1.0 } else { eta_path }).normalize();
        if !h.is_finite() {
            return None;
        }
        Some((if h.z < 0.0 { -h } else { h }, reflect, eta_path))
    }

    /// f(o, i) without the cosine; only `lobes` switched on (all for rendering: the
    /// deliberate-error tests switch one off).
    pub fn eval(&self, o: Vec3, i: Vec3, mode: TransportMode) -> Vec3 {
        self.eval_lobes(o, i, mode, [true; 5])
    }

    /// [`Principled::eval`] with lobes (reflection, transmission, clearcoat, diffuse,
    /// sheen) switched on or off.
    pub fn eval_lobes(&self, o: Vec3, i: Vec3, mode: TransportMode, on: [bool; 5]) -> Vec3 {
        if o.z == 0.0 || i.z == 0.0 {
            return Vec3::ZERO;
        }
        let Some((h, reflect, eta_path)) = self.half(o, i) else {
            return Vec3::ZERO;
        };
        let (brdf, bsdf) = self.weights();
        let front = o.z > 0.0;
        let refract = !reflect;
        let f = fresnel::dielectric(o.dot(h), self.eta).0;
        let refl_ok = compatible(h, o, i, true);
        let refr_ok = compatible(h, o, i, false);
        let (d, g) = (self.mf.d(h), self.mf.g(o, i, h));
        let (co, ci) = (o.z.abs(), i.z.abs());
        let mut value = Vec3::ZERO;
        if on[0] && reflect && refl_ok && f > 0.0 {
            value += self.fresnel(f, o.dot(h), front) * (d * g / (4.0 * co * ci));
        }
        if on[1] && bsdf > 0.0 && refract && refr_ok && f < 1.0 {
            let scale = match mode {
                TransportMode::Radiance => 1.0 / (eta_path * eta_path),
                TransportMode::Importance => 1.0,
            };
            let (oh, ih) = (o.dot(h), i.dot(h));
            let denom = oh + eta_path * ih;
            let t = scale * (1.0 - f) * d * g * eta_path * eta_path * oh * ih / (o.z * denom * denom);
            value += self.base_color.max(Vec3::ZERO).powf(0.5) * (bsdf * t.abs() / ci);
        }
        if on[2] && self.clearcoat > 0.0 && reflect && refl_ok && front {
            let fcc = schlick(Vec3::splat(0.04), o.dot(h), self.eta).x;
            let dcc = self.clearcoat_distribution().d(h);
            let gcc = smith_ggx1(o, h, 0.25) * smith_ggx1(i, h, 0.25);
            value += Vec3::splat(0.25 * self.clearcoat * fcc * dcc * gcc);
        }
        if brdf > 0.0 && reflect && front {
            let (fo, fi) = (schlick_weight(ci), schlick_weight(co));
            let cos_d = h.dot(i);
            if on[3] {
                let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
                let rr = 2.0 * self.roughness * cos_d * cos_d;
                let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
                let mut shape = f_diff + f_retro;
                if self.flatness != 0.0 {
                    let fss90 = rr / 2.0;
                    let fss = (1.0 + (fss90 - 1.0) * fo) * (1.0 + (fss90 - 1.0) * fi);
                    let f_ss = 1.25 * (fss * (1.0 / (co + ci) - 0.5) + 0.5);
                    shape += (f_ss - shape) * self.flatness;
                }
                value += self.base_color * (brdf * INV_PI * shape);
            }
            if on[4] && self.sheen > 0.0 && 1.0 - self.metallic > 0.0 {
                let fd = schlick_weight(cos_d.abs());
                let lum = luminance(self.base_color);
                let tint = if lum > 0.0 { self.base_color / lum } else { Vec3::ONE };
                let c_sheen = Vec3::ONE + (tint - Vec3::ONE) * self.sheen_tint;
                value += c_sheen * (self.sheen * (1.0 - self.metallic) * fd);
            }
        }
        value
    }

    /// The solid-angle density of [`Principled::sample`] from `o` at `i`.
    pub fn pdf(&self, o: Vec3, i: Vec3) -> f32 {
        self.pdf_with(o, i, None)
    }

    /// [`Principled::pdf`], optionally with the lobe probabilities replaced (the
    /// deliberate-error tests).
    pub fn pdf_with(&self, o: Vec3, i: Vec3, probs: Option<&dyn Fn([f32; 4]) -> [f32; 4]>) -> f32 {
        if o.z == 0.0 || i.z == 0.0 {
            return 0.0;
        }
        let Some((h, reflect, eta_path)) = self.half(o, i) else {
            return 0.0;
        };
        let front = o.z > 0.0;
        let f = fresnel::dielectric(o.dot(h), self.eta).0;
        let Some(mut p) = self.probabilities(front, f) else {
            return 0.0;
        };
        if let Some(change) = probs {
            p = change(p);
        }
        let [p_diffuse, p_clearcoat, p_trans, p_reflect] = p;
        let (oh, ih) = (o.dot(h), i.dot(h));
        let dh_di = if reflect {
            (1.0 / (4.0 * ih)).abs()
        } else {
            let denom = oh + eta_path * ih;
            (eta_path * eta_path * ih / (denom * denom)).abs()
        };
        let o_up = if front { o } else { -o };
        let mut pdf = 0.0;
        if reflect {
            if compatible(h, o, i, true) {
                pdf += p_reflect * self.mf.pdf_visible(o_up, h) * dh_di;
                if p_clearcoat > 0.0 {
                    pdf += p_clearcoat * self.clearcoat_distribution().pdf(h) * dh_di;
                }
            }
            pdf += p_diffuse * i.z.abs() * INV_PI;
        } else if p_trans > 0.0 && compatible(h, o, i, false) {
            pdf += p_trans * self.mf.pdf_visible(o_up, h) * dh_di;
        }
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    /// A direction from `o` (`u` for the direction, `uc` for the lobe), as Mitsuba
    /// samples it, with its lobe.
    pub fn sample_lobe(&self, o: Vec3, u: Vec2, uc: f32, mode: TransportMode) -> Option<(BsdfSample, Lobe)> {
        if o.z == 0.0 {
            return None;
        }
        let front = o.z > 0.0;
        let o_up = if front { o } else { -o };
        let m = self.mf.sample_visible(o_up, u);
        let om = o.dot(m);
        let (f, cos_t, eta_ti) = fresnel::dielectric(om, self.eta);
        let [p_diffuse, p_clearcoat, p_trans, _] = self.probabilities(front, f)?;
        let (i, lobe) = if uc < p_diffuse {
            (cosine_hemisphere(u), Lobe::Diffuse)
        } else if uc < p_diffuse + p_clearcoat {
            let mc = self.clearcoat_distribution().sample(u);
            let i = 2.0 * o.dot(mc) * mc - o;
            if !compatible(mc, o, i, true) {
                return None;
            }
            (i, Lobe::Clearcoat)
        } else if uc < p_diffuse + p_clearcoat + p_trans {
            if f >= 1.0 {
                return None;
            }
            let i = m * (om * eta_ti + cos_t) - o * eta_ti;
            if o.z * i.z >= 0.0 || !compatible(m, o, i, false) {
                return None;
            }
            (i, Lobe::SpecularTransmission)
        } else {
            let i = 2.0 * om * m - o;
            if !compatible(m, o, i, true) {
                return None;
            }
            (i, Lobe::SpecularReflection)
        };
        if o.z * i.z == 0.0 || (lobe != Lobe::SpecularTransmission && o.z * i.z < 0.0) {
            return None;
        }
        let pdf = self.pdf(o, i);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        let weight = self.eval(o, i, mode) * (i.z.abs() / pdf);
        let eta = if lobe == Lobe::SpecularTransmission { 1.0 / eta_ti } else { 1.0 };
        Some((
            BsdfSample {
                wi: i,
                weight,
                pdf,
                delta: false,
                eta,
            },
            lobe,
        ))
    }

    pub fn sample(&self, o: Vec3, u: Vec2, uc: f32, mode: TransportMode) -> Option<BsdfSample> {
        self.sample_lobe(o, u, uc, mode).map(|(s, _)| s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specular_maps_to_eta_and_gtr1_is_normalised() {
        assert!((eta_from_specular(0.5) - 1.5).abs() < 1e-6);
        // ∫ D(m) cos θm dω = 1
        for alpha in [0.1f32, 0.03] {
            let g = Gtr1 { alpha };
            let n = 20_000;
            let mut acc = 0.0f64;
            for k in 0..n {
                let c = (k as f32 + 0.5) / n as f32;
                acc += (g.d(Vec3::new((1.0 - c * c).sqrt(), 0.0, c)) * c) as f64 * 2.0 * std::f64::consts::PI / n as f64;
            }
            assert!((acc - 1.0).abs() < 0.01, "α {alpha}: {acc}");
        }
    }
}
