//! Microfacet distributions (Beckmann, GGX) with anisotropic roughness, Smith
//! masking, and sampling of visible normals (Heitz & d'Eon 2014 for Beckmann as
//! Mitsuba 3 does it; Heitz 2018 for GGX). Vectors are in the local frame (z up).

use crate::math::{sin_cos_poly, Vec2, Vec3, PI};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    Beckmann,
    Ggx,
}

#[derive(Clone, Copy, Debug)]
pub struct Microfacet {
    pub kind: Distribution,
    pub alpha_x: f32,
    pub alpha_y: f32,
}

impl Microfacet {
    pub fn new(kind: Distribution, alpha_x: f32, alpha_y: f32) -> Self {
        // a perfectly smooth limit is numerically unusable; keep a tiny roughness
        Microfacet {
            kind,
            alpha_x: alpha_x.max(1e-4),
            alpha_y: alpha_y.max(1e-4),
        }
    }

    /// Normal distribution D(m).
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        let c2 = m.z * m.z;
        match self.kind {
            Distribution::Beckmann => {
                let e = (m.x * m.x / (ax * ax) + m.y * m.y / (ay * ay)) / c2;
                exp_neg(e) / (PI * ax * ay * c2 * c2)
            }
            Distribution::Ggx => {
                let t = m.x * m.x / (ax * ax) + m.y * m.y / (ay * ay) + c2;
                1.0 / (PI * ax * ay * t * t)
            }
        }
    }

    /// Smith masking G1(v, m); 0 when `v` sees the back of `m`.
    pub fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        self.g1_unmasked(v)
    }

    /// G1 of `v` on the side of every facet that faces it: the part of [`Self::g1`]
    /// that does not depend on the facet normal.
    #[inline]
    pub fn g1_unmasked(&self, v: Vec3) -> f32 {
        let xy = (self.alpha_x * v.x).powi(2) + (self.alpha_y * v.y).powi(2);
        if xy == 0.0 {
            return 1.0;
        }
        let tan2 = xy / (v.z * v.z);
        match self.kind {
            Distribution::Beckmann => {
                // Walter et al.'s rational approximation of Λ
                let a = 1.0 / tan2.sqrt();
                if a >= 1.6 {
                    1.0
                } else {
                    (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
                }
            }
            Distribution::Ggx => 2.0 / (1.0 + (1.0 + tan2).sqrt()),
        }
    }

    /// Separable masking–shadowing G1(wi)·G1(wo), as Mitsuba.
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.g1(wi, m) * self.g1(wo, m)
    }

    /// Density of visible normal `m` seen from `wi`: G1(wi)·max(0, wi·m)·D(m)/cosθi.
    pub fn pdf_visible(&self, wi: Vec3, m: Vec3) -> f32 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        self.g1(wi, m) * wi.dot(m).max(0.0) * self.d(m) / wi.z
    }

    /// A microfacet normal visible from `wi` (wi.z > 0).
    pub fn sample_visible(&self, wi: Vec3, u: Vec2) -> Vec3 {
        match self.kind {
            Distribution::Ggx => {
                // Heitz 2018: stretch, sample the projected hemisphere, unstretch
                let vh = Vec3::new(self.alpha_x * wi.x, self.alpha_y * wi.y, wi.z).normalize();
                let len2 = vh.x * vh.x + vh.y * vh.y;
                let t1 = if len2 > 0.0 {
                    Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
                } else {
                    Vec3::X
                };
                let t2 = vh.cross(t1);
                let r = u.x.sqrt();
                let (sin_phi, cos_phi) = sin_cos_poly(2.0 * PI * u.y);
                let p1 = r * cos_phi;
                let s = 0.5 * (1.0 + vh.z);
                let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sin_phi;
                let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
                Vec3::new(self.alpha_x * nh.x, self.alpha_y * nh.y, nh.z.max(1e-6)).normalize()
            }
            Distribution::Beckmann => {
                let wip = Vec3::new(self.alpha_x * wi.x, self.alpha_y * wi.y, wi.z).normalize();
                let sin_t = (1.0 - wip.z * wip.z).max(0.0).sqrt();
                let (cos_phi, sin_phi) = if sin_t > 1e-7 { (wip.x / sin_t, wip.y / sin_t) } else { (1.0, 0.0) };
                let slope = beckmann_visible_slope(wip.z, u);
                let s = Vec2::new(cos_phi * slope.x - sin_phi * slope.y, sin_phi * slope.x + cos_phi * slope.y);
                Vec3::new(-s.x * self.alpha_x, -s.y * self.alpha_y, 1.0).normalize()
            }
        }
    }
}

/// `e^−e`: 0 from e = 104 on, where libm's `expf` gives 0 too but through its slow
/// underflow path (1 % of a Veach MIS render); the same value bit for bit everywhere.
#[inline]
fn exp_neg(e: f32) -> f32 {
    if e >= 104.0 {
        0.0
    } else {
        (-e).exp()
    }
}

/// Slopes of visible Beckmann normals for unit roughness (Heitz & d'Eon 2014, as
/// Mitsuba's `sample_visible_11`).
fn beckmann_visible_slope(cos_theta_i: f32, u: Vec2) -> Vec2 {
    const INV_SQRT_PI: f32 = 0.564_189_6;
    let mut ux = u.x.clamp(1e-6, 1.0 - 1e-6);
    let uy = u.y.clamp(1e-6, 1.0 - 1e-6);
    if cos_theta_i > 0.999_999 {
        // normal incidence: the plain Beckmann slope distribution
        let r = (-ux.ln()).sqrt();
        let phi = 2.0 * PI * uy;
        return Vec2::new(r * phi.cos(), r * phi.sin());
    }
    let tan_t = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt() / cos_theta_i;
    let cot_t = 1.0 / tan_t;
    let maxval = erf(cot_t);
    let mut x = maxval - (maxval + 1.0) * erf((-ux.ln()).sqrt());
    ux *= 1.0 + maxval + INV_SQRT_PI * tan_t * exp_neg(cot_t * cot_t);
    for _ in 0..3 {
        let slope = erfinv(x);
        let value = 1.0 + x + INV_SQRT_PI * tan_t * exp_neg(slope * slope) - ux;
        let derivative = 1.0 - slope * tan_t;
        x -= value / derivative;
    }
    Vec2::new(erfinv(x), erfinv(2.0 * uy - 1.0))
}

/// Error function (Abramowitz & Stegun 7.1.26 refined; |error| < 1.2e-7 in f64).
pub fn erf(x: f32) -> f32 {
    let x = x as f64;
    let t = 1.0 / (1.0 + 0.5 * x.abs());
    let y = 1.0
        - t * (-x * x - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07 + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    (if x >= 0.0 { y } else { -y }) as f32
}

/// Inverse error function: Giles 2010's single-precision polynomials (as Mitsuba's
/// `erfinv`), within a few 1e-7 of the exact value, without Newton steps: the only
/// caller, [`beckmann_visible_slope`], refines its own root (Newton steps of f64 `erf`
/// here were 9 % of a Veach MIS render).
pub fn erfinv(x: f32) -> f32 {
    let x = x.clamp(-1.0 + 1e-7, 1.0 - 1e-7);
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_4e-08f32;
        for c in [
            3.432_739_4e-07,
            -3.523_387_7e-06,
            -4.391_506_5e-06,
            0.000_218_580_87,
            -0.001_253_725,
            -0.004_177_681_6,
            0.246_640_73,
            1.501_409_4,
        ] {
            p = c + p * w;
        }
        p
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_26f32;
        for c in [
            0.000_100_950_56,
            0.001_349_343_2,
            -0.003_673_428_4,
            0.005_739_507_7,
            -0.007_622_461_3,
            0.009_438_870_5,
            1.001_674,
            2.832_976_8,
        ] {
            p = c + p * w;
        }
        p
    };
    p * x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erf_and_its_inverse() {
        for (x, e) in [
            (0.0f32, 0.0f32),
            (0.5, 0.520_499_9),
            (1.0, 0.842_700_8),
            (2.0, 0.995_322_3),
            (-1.0, -0.842_700_8),
        ] {
            assert!((erf(x) - e).abs() < 1e-6, "erf({x})");
        }
        for k in -99..100 {
            let y = k as f32 / 100.0;
            assert!((erf(erfinv(y)) - y).abs() < 2e-6, "erfinv({y})");
        }
    }

    #[test]
    fn distributions_are_normalised_projected_areas() {
        // ∫ D(m) cos θm dω = 1, by a midpoint rule over the hemisphere
        for kind in [Distribution::Beckmann, Distribution::Ggx] {
            for (ax, ay) in [(0.3, 0.3), (0.1, 0.4), (0.8, 0.6)] {
                let m = Microfacet::new(kind, ax, ay);
                let n = 600;
                let mut acc = 0.0f64;
                for i in 0..n {
                    for j in 0..2 * n {
                        let ct = (i as f32 + 0.5) / n as f32;
                        let phi = PI * (j as f32 + 0.5) / n as f32;
                        let st = (1.0 - ct * ct).sqrt();
                        let w = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
                        acc += (m.d(w) * ct) as f64 * (1.0 / n as f64) * (PI as f64 / n as f64);
                    }
                }
                assert!((acc - 1.0).abs() < 0.01, "{kind:?} {ax} {ay}: {acc}");
            }
        }
    }
}
