//! BSDFs at a surface point: evaluate, sample and pdf, in a local frame whose z
//! is the shading normal. `eval` returns f (without the cosine); directions are
//! world-space unit vectors pointing away from the surface.

use super::conductor::SmoothConductor;
use super::dielectric::{RoughDielectric, ThinDielectric};
use super::fresnel;
use super::microfacet::Microfacet;
use super::phong::Phong;
use super::plastic::{Plastic, RoughPlastic};
pub use super::sample::{BsdfSample, TransportMode};
use super::{principled::Principled, principledthin::PrincipledThin};
use crate::math::{Frame, Vec2, Vec3, INV_PI};
use crate::sampling::cosine_hemisphere;

#[derive(Clone, Debug)]
pub enum BsdfKind {
    /// Lambertian ρ/π on the frame's front side.
    Diffuse { albedo: Vec3 },
    /// Perfect refraction, weight 1 (vacuum outside, index `eta` inside).
    PerfectRefraction { eta: f32 },
    /// Smooth dielectric: Fresnel-weighted mirror reflection (tint `r`) and
    /// refraction (tint `t`, radiance scaled by 1/η² when entering).
    Dielectric { r: Vec3, t: Vec3, eta: f32 },
    /// Rough conductor: D·G·F·tint / (4 cosθi cosθo), separable Smith G.
    Conductor { tint: Vec3, eta: Vec3, k: Vec3, mf: Microfacet },
    /// Mirror with conductor Fresnel (Mitsuba `conductor`), front side only.
    SmoothConductor(SmoothConductor),
    /// Thin slab, delta reflection and straight transmission (Mitsuba `thindielectric`).
    ThinDielectric(ThinDielectric),
    /// Rough dielectric interface (Mitsuba `roughdielectric`).
    RoughDielectric(RoughDielectric),
    /// Coated diffuse, smooth coating (Mitsuba `plastic`): a delta lobe and a diffuse one.
    Plastic(Plastic),
    /// Coated diffuse, rough coating (Mitsuba `roughplastic`).
    RoughPlastic(RoughPlastic),
    /// Lambertian plus a modified Phong lobe (Mitsuba 0.6 `phong`).
    Phong(Phong),
    /// Burley's Disney BSDF as Mitsuba's `principled`.
    Principled(Principled),
    /// Its thin-sheet variant, Mitsuba's `principledthin`.
    PrincipledThin(PrincipledThin),
    /// Mitsuba's `blendbsdf` of two BSDFs with their own frames (boxed: it nests).
    Blend(Box<BlendBsdf>),
}

#[derive(Clone, Debug)]
pub struct Bsdf {
    pub frame: Frame,
    pub kind: BsdfKind,
    /// Set by `bumpmap` and `normalmap` ([`super::bump`]): `frame` is then the perturbed
    /// frame and this holds the surface's own shading normal, for Mitsuba's side test,
    /// its shadow-terminator factor and the change of cosine (integrators weight by the
    /// cosine to the interaction's shading normal).
    pub perturbed: Option<super::bump::Perturbation>,
}

impl BsdfKind {
    /// Whether a lobe depends on the azimuth about the normal (a microfacet
    /// distribution with α_x ≠ α_y): the frame's tangent must then be the surface's
    /// `∂p/∂u`, as Mitsuba's shading frame is.
    pub fn is_anisotropic(&self) -> bool {
        let aniso = |m: &super::microfacet::Microfacet| m.alpha_x != m.alpha_y;
        match self {
            BsdfKind::Conductor { mf, .. } => aniso(mf),
            BsdfKind::RoughDielectric(b) => aniso(&b.mf),
            BsdfKind::Principled(b) => aniso(&b.mf),
            BsdfKind::PrincipledThin(b) => aniso(&b.mf_reflect) || aniso(&b.mf_transmit),
            _ => false,
        }
    }
}

impl Bsdf {
    /// Whether every lobe is a Dirac delta (nothing for light sampling to find).
    /// `plastic` is not: its mirror lobe is, its diffuse lobe is not, so its samples
    /// say per sample ([`BsdfSample::delta`]) and `eval`/`pdf` cover the diffuse lobe.
    #[inline]
    pub fn is_delta(&self) -> bool {
        if let BsdfKind::Blend(b) = &self.kind {
            return b.is_delta();
        }
        matches!(
            self.kind,
            BsdfKind::PerfectRefraction { .. } | BsdfKind::Dielectric { .. } | BsdfKind::SmoothConductor(_) | BsdfKind::ThinDielectric(_)
        )
    }

    /// The BSDF value f(wo, wi) (without the cosine) for radiance transport (see
    /// [`Bsdf::eval_mode`]).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_mode(wo, wi, TransportMode::Radiance)
    }

    /// f(wo, wi) for radiance or importance transport: they differ only where light
    /// is refracted (`roughdielectric`).
    #[inline]
    pub fn eval_mode(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        // the common case without the calls and matches of the general one
        if let (None, BsdfKind::Diffuse { albedo }) = (&self.perturbed, &self.kind) {
            return diffuse_eval(self.frame.n, *albedo, wo, wi);
        }
        self.eval_general(wo, wi, mode)
    }

    fn eval_general(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        match self.perturbed {
            None => self.eval_frame(wo, wi, mode),
            Some(p) => match p.eval_factor(self.frame.n, wi) {
                Some(k) => self.eval_frame(wo, wi, mode) * k,
                None => Vec3::ZERO,
            },
        }
    }

    /// f(wo, wi) in this BSDF's own frame (the perturbed one of a bump or normal map).
    fn eval_frame(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        match &self.kind {
            BsdfKind::Principled(b) => b.eval(self.frame.to_local(wo), self.frame.to_local(wi), mode),
            BsdfKind::PrincipledThin(b) => b.eval(self.frame.to_local(wo), self.frame.to_local(wi)),
            BsdfKind::Blend(b) => b.eval(wo, wi, mode),
            _ => self.eval_plain(wo, wi, mode),
        }
    }

    fn eval_plain(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        match self.kind {
            BsdfKind::RoughDielectric(b) => b.eval(self.frame.to_local(wo), self.frame.to_local(wi), mode),
            BsdfKind::Plastic(b) => b.eval(self.frame.to_local(wo), self.frame.to_local(wi)),
            BsdfKind::RoughPlastic(b) => b.eval(self.frame.to_local(wo), self.frame.to_local(wi)),
            BsdfKind::Phong(b) => b.eval(self.frame.to_local(wo), self.frame.to_local(wi)),
            BsdfKind::SmoothConductor(_) | BsdfKind::ThinDielectric(_) => Vec3::ZERO,
            // only the cosines: the hot case skips the full change of frame
            BsdfKind::Diffuse { albedo } => diffuse_eval(self.frame.n, albedo, wo, wi),
            BsdfKind::Conductor { tint, eta, k, mf } => {
                let (o, i) = (self.frame.to_local(wo), self.frame.to_local(wi));
                if o.z <= 0.0 || i.z <= 0.0 {
                    return Vec3::ZERO;
                }
                let m = (o + i).normalize();
                let d = mf.d(m);
                if d == 0.0 {
                    return Vec3::ZERO;
                }
                let g = mf.g(o, i, m);
                fresnel::conductor(o.dot(m), eta, k) * tint * (d * g / (4.0 * o.z * i.z))
            }
            BsdfKind::PerfectRefraction { .. } | BsdfKind::Dielectric { .. } => Vec3::ZERO,
            BsdfKind::Principled(_) | BsdfKind::PrincipledThin(_) | BsdfKind::Blend(_) => unreachable!("evaluated in eval_mode"),
        }
    }

    /// The solid-angle density with which [`Bsdf::sample`] from `wo` returns `wi`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if let (None, BsdfKind::Diffuse { .. }) = (&self.perturbed, &self.kind) {
            return diffuse_pdf(self.frame.n, wo, wi);
        }
        self.pdf_general(wo, wi)
    }

    fn pdf_general(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self.perturbed {
            None => self.pdf_frame(wo, wi),
            Some(p) if p.same_side(self.frame.n, wi) => self.pdf_frame(wo, wi),
            Some(_) => 0.0,
        }
    }

    fn pdf_frame(&self, wo: Vec3, wi: Vec3) -> f32 {
        match &self.kind {
            BsdfKind::Principled(b) => b.pdf(self.frame.to_local(wo), self.frame.to_local(wi)),
            BsdfKind::PrincipledThin(b) => b.pdf(self.frame.to_local(wo), self.frame.to_local(wi)),
            BsdfKind::Blend(b) => b.pdf(wo, wi),
            _ => self.pdf_plain(wo, wi),
        }
    }

    fn pdf_plain(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self.kind {
            BsdfKind::Diffuse { .. } => diffuse_pdf(self.frame.n, wo, wi),
            BsdfKind::RoughDielectric(b) => b.pdf(self.frame.to_local(wo), self.frame.to_local(wi)),
            BsdfKind::Plastic(b) => b.pdf(self.frame.to_local(wo), self.frame.to_local(wi)),
            BsdfKind::RoughPlastic(b) => b.pdf(self.frame.to_local(wo), self.frame.to_local(wi)),
            BsdfKind::Phong(b) => b.pdf(self.frame.to_local(wo), self.frame.to_local(wi)),
            BsdfKind::SmoothConductor(_) | BsdfKind::ThinDielectric(_) => 0.0,
            BsdfKind::Conductor { mf, .. } => {
                let (o, i) = (self.frame.to_local(wo), self.frame.to_local(wi));
                if o.z <= 0.0 || i.z <= 0.0 {
                    return 0.0;
                }
                let m = (o + i).normalize();
                let om = o.dot(m);
                if om <= 0.0 {
                    return 0.0;
                }
                mf.pdf_visible(o, m) / (4.0 * om)
            }
            BsdfKind::PerfectRefraction { .. } | BsdfKind::Dielectric { .. } => 0.0,
            BsdfKind::Principled(_) | BsdfKind::PrincipledThin(_) | BsdfKind::Blend(_) => unreachable!("in pdf"),
        }
    }

    /// `(pdf(a, b), pdf(b, a))`, sharing the change of frame (bit-identical to two calls).
    pub fn pdf_pair(&self, a: Vec3, b: Vec3) -> (f32, f32) {
        match self.kind {
            BsdfKind::Diffuse { .. } if self.perturbed.is_none() => {
                let (za, zb) = (a.dot(self.frame.n), b.dot(self.frame.n));
                if za > 0.0 && zb > 0.0 {
                    (zb * INV_PI, za * INV_PI)
                } else {
                    (0.0, 0.0)
                }
            }
            _ => (self.pdf(a, b), self.pdf(b, a)),
        }
    }

    /// `u` drives the direction, `uc` the choice between lobes.
    pub fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        self.sample_mode(wo, u, uc, TransportMode::Radiance)
    }

    /// [`Bsdf::sample`] for radiance or importance transport (see [`TransportMode`]).
    pub fn sample_mode(&self, wo: Vec3, u: Vec2, uc: f32, mode: TransportMode) -> Option<BsdfSample> {
        let s = self.sample_frame(wo, u, uc, mode)?;
        match self.perturbed {
            None => Some(s),
            Some(p) => p
                .sample_weight(self.frame.n, s.wi)
                .map(|k| BsdfSample { weight: s.weight * k, ..s }),
        }
    }

    fn sample_frame(&self, wo: Vec3, u: Vec2, uc: f32, mode: TransportMode) -> Option<BsdfSample> {
        if let BsdfKind::Diffuse { albedo } = self.kind {
            // the cosine is all the change of frame it needs
            return self.sample_diffuse(wo.dot(self.frame.n), albedo, u);
        }
        let radiance = mode == TransportMode::Radiance;
        let o = self.frame.to_local(wo);
        let world = |l: Vec3| self.frame.to_world(l);
        let local = match &self.kind {
            BsdfKind::Blend(b) => return b.sample(wo, u, uc, mode, self.frame.n),
            BsdfKind::Principled(b) => b.sample(o, u, uc, mode),
            BsdfKind::PrincipledThin(b) => b.sample(o, u, uc),
            BsdfKind::SmoothConductor(b) => b.sample(o),
            BsdfKind::ThinDielectric(b) => b.sample(o, uc),
            BsdfKind::RoughDielectric(b) => b.sample(o, u, uc, mode),
            BsdfKind::Plastic(b) => b.sample(o, u, uc),
            BsdfKind::RoughPlastic(b) => b.sample(o, u, uc),
            BsdfKind::Phong(b) => b.sample(o, u, uc),
            _ => return self.sample_legacy(o, u, uc, radiance),
        };
        local.map(|s| BsdfSample { wi: world(s.wi), ..s })
    }

    /// Cosine-weighted sampling of the front hemisphere; `cos_o` is `wo`'s cosine.
    #[inline]
    fn sample_diffuse(&self, cos_o: f32, albedo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if cos_o <= 0.0 {
            return None;
        }
        let i = cosine_hemisphere(u);
        if i.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi: self.frame.to_world(i),
            weight: albedo,
            pdf: i.z * INV_PI,
            delta: false,
            eta: 1.0,
        })
    }

    /// The materials of the RDR171 format, sampled as before.
    fn sample_legacy(&self, o: Vec3, u: Vec2, uc: f32, radiance: bool) -> Option<BsdfSample> {
        let world = |l: Vec3| self.frame.to_world(l);
        match self.kind {
            BsdfKind::Diffuse { albedo } => self.sample_diffuse(o.z, albedo, u),
            BsdfKind::PerfectRefraction { eta } => {
                let (n, ratio) = if o.z > 0.0 { (Vec3::Z, 1.0 / eta) } else { (-Vec3::Z, eta) };
                let refracted = crate::math::refract(o, n, ratio);
                let i = refracted.unwrap_or_else(|| crate::math::reflect(o, n));
                // the adjoint of a weight-1 refraction carries (η_o/η_i)² = ratio²
                let w = if radiance || refracted.is_none() { 1.0 } else { ratio * ratio };
                Some(BsdfSample {
                    wi: world(i),
                    weight: Vec3::splat(w),
                    pdf: 1.0,
                    delta: true,
                    eta: 1.0,
                })
            }
            BsdfKind::Dielectric { r, t, eta } => {
                let (f, cos_t, eta_ti) = fresnel::dielectric(o.z, eta);
                if uc < f {
                    let i = Vec3::new(-o.x, -o.y, o.z);
                    Some(BsdfSample {
                        wi: world(i),
                        weight: r,
                        pdf: f,
                        delta: true,
                        eta: 1.0,
                    })
                } else {
                    let i = Vec3::new(-eta_ti * o.x, -eta_ti * o.y, cos_t).normalize();
                    Some(BsdfSample {
                        wi: world(i),
                        // radiance is scaled by (η_o/η_i)², importance is not
                        weight: if radiance { t * (eta_ti * eta_ti) } else { t },
                        pdf: 1.0 - f,
                        delta: true,
                        eta: 1.0 / eta_ti,
                    })
                }
            }
            BsdfKind::Conductor { tint, eta, k, mf } => {
                if o.z <= 0.0 {
                    return None;
                }
                let m = mf.sample_visible(o, u);
                let om = o.dot(m);
                if om <= 0.0 {
                    return None;
                }
                let i = 2.0 * om * m - o;
                if i.z <= 0.0 {
                    return None;
                }
                let pdf = mf.pdf_visible(o, m) / (4.0 * om);
                if pdf <= 0.0 || !pdf.is_finite() {
                    return None;
                }
                let weight = fresnel::conductor(om, eta, k) * tint * mf.g1(i, m);
                Some(BsdfSample {
                    wi: world(i),
                    weight,
                    pdf,
                    delta: false,
                    eta: 1.0,
                })
            }
            _ => unreachable!("sampled by its own module"),
        }
    }
}

/// Lambertian f: ρ/π when both directions are on the front of normal `n`.
#[inline]
fn diffuse_eval(n: Vec3, albedo: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.dot(n) > 0.0 && wi.dot(n) > 0.0 {
        albedo * INV_PI
    } else {
        Vec3::ZERO
    }
}

/// The cosine-weighted density of `wi`, zero unless both directions are in front of `n`.
#[inline]
fn diffuse_pdf(n: Vec3, wo: Vec3, wi: Vec3) -> f32 {
    let (zo, zi) = (wo.dot(n), wi.dot(n));
    if zo > 0.0 && zi > 0.0 {
        zi * INV_PI
    } else {
        0.0
    }
}

// ---- blendbsdf (here, not in a file of its own: it nests `Bsdf`s and `Bsdf` holds it) ----

/// Mitsuba's `blendbsdf`: (1 − w)·f₀ + w·f₁ of two nested BSDFs, `w` the weight
/// (clamped to [0, 1]) at the point. Sampling picks the second with probability `w`
/// (the first otherwise, the lobe choice `uc` rescaled for the nested one), as
/// Mitsuba does; rdr then reports the mixture density (1 − w)·p₀ + w·p₁ and weight
/// f·|cos|/p of the mixture for a non-delta direction (Mitsuba keeps the chosen one's
/// own pdf and weight: the same expectation), and for a delta lobe the nested
/// sample's weight with its probability scaled by the choice. Each nested BSDF keeps
/// its own frame (a nested `twosided` flips its own), so all of this is in world space.
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
