//! The Mitsuba materials (`conductor`, `thindielectric`, `roughdielectric`, `plastic`,
//! `roughplastic`, `twosided`): sampling against their own pdf (χ²), sample weights
//! against eval·cos/pdf, energy (white furnace on the sphere of directions) and
//! reciprocity, and values against Mitsuba's formulas written out here from
//! scratch (Fresnel with complex arithmetic, the microfacet D and G, the coating's
//! transmittance by quadrature over microfacet normals).

mod common;
use common::chi2::chi2;
use rdr::material::{fresnel, Bsdf, Distribution, Material, TransportMode};
use rdr::math::{Frame, Vec2, Vec3, PI};
use std::path::Path;

/// Uniform numbers for the tests.
struct Rng(rdr::sampling::SplitMix64);
impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(rdr::sampling::SplitMix64(seed))
    }
    fn next(&mut self) -> f32 {
        self.0.unit_f32()
    }
    fn next2(&mut self) -> Vec2 {
        Vec2::new(self.next(), self.next())
    }
    /// Uniform on the sphere.
    fn dir(&mut self) -> Vec3 {
        rdr::sampling::uniform_sphere(self.next2())
    }
}

const GREY: Vec3 = Vec3::new(0.5, 0.5, 0.5);

/// `m` (with its derived parts prepared for a constant texture `albedo`) at a surface facing +z.
fn bsdf(m: &Material, wo: Vec3, albedo: Vec3) -> Bsdf {
    let mut m = m.clone();
    m.prepare(&|_| albedo);
    m.bsdf(Vec3::Z, wo, |_| albedo)
}

fn dir(theta: f32, phi: f32) -> Vec3 {
    Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

fn rough_dielectric(distribution: Distribution, ax: f32, ay: f32, eta: f32) -> Material {
    Material::RoughDielectric {
        reflect: Vec3::ONE,
        transmit: Vec3::ONE,
        eta,
        alpha_x: ax,
        alpha_y: ay,
        alpha_textures: None,
        distribution,
    }
}

fn rough_plastic(distribution: Distribution, alpha: f32, eta: f32, nonlinear: bool) -> Material {
    Material::RoughPlastic {
        texture: 0,
        specular: Vec3::ONE,
        eta,
        nonlinear,
        alpha,
        distribution,
        specular_sampling_weight: None,
        tables: None,
    }
}

fn plastic(eta: f32) -> Material {
    Material::Plastic {
        texture: 0,
        specular: Vec3::ONE,
        eta,
        nonlinear: false,
        specular_sampling_weight: None,
    }
}

/// Every non-delta sample's weight is f·|cos|/pdf of its own direction, and its pdf the pdf.
fn check_weights(name: &str, b: &Bsdf, wo: Vec3, mode: TransportMode) {
    let mut rng = Rng::new(99);
    for _ in 0..2000 {
        let Some(s) = b.sample_mode(wo, rng.next2(), rng.next(), mode) else {
            continue;
        };
        if s.delta {
            continue;
        }
        let pdf = b.pdf(wo, s.wi);
        let expect = b.eval_mode(wo, s.wi, mode) * s.wi.z.abs() / pdf;
        assert!(
            (s.weight - expect).abs().max_element() <= 2e-3 * expect.max_element().max(1e-2),
            "{name}: weight {} vs f·cos/pdf {}",
            s.weight,
            expect
        );
        assert!((s.pdf - pdf).abs() <= 1e-3 * pdf, "{name}: pdf {} vs {pdf}", s.pdf);
    }
}

/// χ² of the sampled directions against the pdf; delta samples (plastic's mirror
/// lobe) count as failures, which the pdf's missing mass accounts for.
fn chi2_bsdf(name: &str, n: usize, b: &Bsdf, wo: Vec3) {
    let mut rng = Rng::new(0x5eed ^ name.len() as u64);
    chi2(
        name,
        n,
        Frame::from_normal(Vec3::Z),
        |u| b.sample(wo, u, rng.next()).filter(|s| !s.delta).map(|s| s.wi),
        |w| b.pdf(wo, w),
    );
}

#[test]
fn rough_dielectric_sampling_matches_its_pdf() {
    use Distribution::{Beckmann, Ggx};
    for kind in [Beckmann, Ggx] {
        for (ax, ay) in [(0.3, 0.3), (0.2, 0.5)] {
            // from outside, and from inside (total internal reflection at the last one)
            for theta in [0.3f32, 1.2, PI - 0.4, PI - 1.0] {
                let wo = dir(theta, 0.7);
                let b = bsdf(&rough_dielectric(kind, ax, ay, 1.5), wo, Vec3::ONE);
                let name = format!("roughdielectric {kind:?} α=({ax},{ay}) θo={theta:.2}");
                check_weights(&name, &b, wo, TransportMode::Radiance);
                check_weights(&name, &b, wo, TransportMode::Importance);
                chi2_bsdf(&name, 150_000, &b, wo);
            }
        }
    }
}

#[test]
fn rough_plastic_sampling_matches_its_pdf() {
    use Distribution::{Beckmann, Ggx};
    for (kind, alpha) in [(Beckmann, 0.2f32), (Ggx, 0.5)] {
        {
            for theta in [0.2f32, 0.9, 1.4] {
                let wo = dir(theta, 0.3);
                let b = bsdf(&rough_plastic(kind, alpha, 1.5, false), wo, GREY);
                let name = format!("roughplastic {kind:?} α={alpha} θo={theta}");
                check_weights(&name, &b, wo, TransportMode::Radiance);
                chi2_bsdf(&name, 150_000, &b, wo);
            }
        }
    }
}

#[test]
fn plastic_samples_its_mirror_lobe_with_mitsubas_probability() {
    for (theta, albedo) in [(0.3f32, GREY), (1.3, Vec3::new(0.9, 0.2, 0.1))] {
        let wo = dir(theta, 1.0);
        let b = bsdf(&plastic(1.49), wo, albedo);
        let name = format!("plastic θo={theta}");
        check_weights(&name, &b, wo, TransportMode::Radiance);
        chi2_bsdf(&name, 200_000, &b, wo);
        // Mitsuba: p_spec = F·w / (F·w + (1−F)(1−w)), w = s̄/(d̄+s̄), weight F/p_spec
        let f = fresnel_dielectric(wo.z as f64, 1.49) as f32;
        let w = 1.0 / (albedo.element_sum() / 3.0 + 1.0);
        let p_spec = f * w / (f * w + (1.0 - f) * (1.0 - w));
        let mut rng = Rng::new(7);
        let n = 100_000;
        let mut mirrored = 0;
        for _ in 0..n {
            let s = b.sample(wo, rng.next2(), rng.next()).unwrap();
            if s.delta {
                mirrored += 1;
                assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-5);
                assert!((s.weight - Vec3::splat(f / p_spec)).abs().max_element() < 1e-4 * f / p_spec);
                assert!((s.pdf - p_spec).abs() < 1e-5);
            }
        }
        let p = mirrored as f64 / n as f64;
        let sigma = (p_spec as f64 * (1.0 - p_spec as f64) / n as f64).sqrt();
        assert!((p - p_spec as f64).abs() < 5.0 * sigma, "{name}: mirror share {p} vs {p_spec}");
    }
}

// ---- Mitsuba's formulas, written out independently (f64) ----

/// Unpolarised dielectric Fresnel reflectance from Snell's law, light arriving at
/// `cos_i` > 0 from the side of index 1 onto index `eta`.
fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin_t2 >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t2).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

#[derive(Clone, Copy)]
struct C(f64, f64);
impl C {
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn div(self, o: C) -> C {
        let d = o.0 * o.0 + o.1 * o.1;
        C((self.0 * o.0 + self.1 * o.1) / d, (self.1 * o.0 - self.0 * o.1) / d)
    }
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn sub(self, o: C) -> C {
        C(self.0 - o.0, self.1 - o.1)
    }
    fn sqrt(self) -> C {
        let r = (self.0 * self.0 + self.1 * self.1).sqrt();
        C(((r + self.0) / 2.0).sqrt(), ((r - self.0) / 2.0).sqrt().copysign(self.1))
    }
    fn norm2(self) -> f64 {
        self.0 * self.0 + self.1 * self.1
    }
}

/// Conductor Fresnel from the complex Snell law: n = η + ik, n cos θt = √(n² − sin²θi).
fn fresnel_conductor(cos_i: f64, eta: f64, k: f64) -> f64 {
    let n = C(eta, k);
    let n2 = n.mul(n);
    let c = C(cos_i, 0.0);
    let nct = n2.sub(C(1.0 - cos_i * cos_i, 0.0)).sqrt();
    let rs = c.sub(nct).div(c.add(nct));
    let rp = n2.mul(c).sub(nct).div(n2.mul(c).add(nct));
    0.5 * (rs.norm2() + rp.norm2())
}

/// Microfacet D and Smith G1 (isotropic α), Walter et al. 2007 / Mitsuba.
type Dir = [f64; 3];

fn d_g1(kind: Distribution, alpha: f64) -> (impl Fn(Dir) -> f64, impl Fn(Dir, Dir) -> f64) {
    let d = move |m: [f64; 3]| {
        if m[2] <= 0.0 {
            return 0.0;
        }
        let c2 = m[2] * m[2];
        let tan2 = (1.0 - c2) / c2;
        match kind {
            Distribution::Beckmann => (-tan2 / (alpha * alpha)).exp() / (PI as f64 * alpha * alpha * c2 * c2),
            Distribution::Ggx => alpha * alpha / (PI as f64 * c2 * c2 * (alpha * alpha + tan2).powi(2)),
        }
    };
    let g1 = move |v: [f64; 3], m: [f64; 3]| {
        let vm = v[0] * m[0] + v[1] * m[1] + v[2] * m[2];
        if vm * v[2] <= 0.0 {
            return 0.0;
        }
        let tan = (1.0 - v[2] * v[2]).max(0.0).sqrt() / v[2].abs();
        if tan == 0.0 {
            return 1.0;
        }
        match kind {
            Distribution::Beckmann => {
                let a = 1.0 / (alpha * tan);
                if a >= 1.6 {
                    1.0
                } else {
                    (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
                }
            }
            Distribution::Ggx => 2.0 / (1.0 + (1.0 + alpha * alpha * tan * tan).sqrt()),
        }
    };
    (d, g1)
}

fn v64(v: Vec3) -> [f64; 3] {
    [v.x as f64, v.y as f64, v.z as f64]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn unit(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

fn close(name: &str, got: f32, expect: f64, rel: f64) {
    assert!(
        (got as f64 - expect).abs() <= rel * expect.abs() + 1e-7,
        "{name}: {got} vs Mitsuba's formula {expect} (relative error {:.2e})",
        (got as f64 - expect).abs() / expect.abs()
    );
}

#[test]
fn conductor_reflects_the_conductor_fresnel_term() {
    // gold and aluminium (RGB η, k as Mitsuba tabulates them, roughly)
    for (eta, k) in [
        (Vec3::new(0.143, 0.374, 1.442), Vec3::new(3.983, 2.385, 1.603)),
        (Vec3::new(1.657, 0.880, 0.521), Vec3::new(9.224, 6.270, 4.837)),
    ] {
        let m = Material::Conductor {
            texture: 0,
            eta,
            k,
            eta_k_textures: None,
        };
        // at normal incidence ((n−1)² + k²)/((n+1)² + k²)
        let s = bsdf(&m, Vec3::Z, Vec3::ONE).sample(Vec3::Z, Vec2::ZERO, 0.0).unwrap();
        for c in 0..3 {
            let (n, k) = (eta[c] as f64, k[c] as f64);
            close(
                "normal incidence",
                s.weight[c],
                ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k),
                1e-5,
            );
        }
        for theta in [0.5f32, 1.0, 1.4] {
            let wo = dir(theta, 2.0);
            let s = bsdf(&m, wo, Vec3::ONE).sample(wo, Vec2::ZERO, 0.0).unwrap();
            assert!(s.delta && (s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
            for c in 0..3 {
                close(
                    &format!("conductor θ={theta}"),
                    s.weight[c],
                    fresnel_conductor(wo.z as f64, eta[c] as f64, k[c] as f64),
                    1e-4,
                );
            }
        }
        // one-sided, as Mitsuba's
        assert!(bsdf(&m, -Vec3::Z, Vec3::ONE).sample(-Vec3::Z, Vec2::ZERO, 0.0).is_none());
    }
    // the defaults are Mitsuba's `material="none"`: a perfect mirror
    let mirror = Material::Conductor {
        texture: 0,
        eta: Vec3::ZERO,
        k: Vec3::ONE,
        eta_k_textures: None,
    };
    let wo = dir(0.8, 0.0);
    let s = bsdf(&mirror, wo, Vec3::ONE).sample(wo, Vec2::ZERO, 0.0).unwrap();
    assert!((s.weight - Vec3::ONE).abs().max_element() < 1e-6);
}

#[test]
fn thin_dielectric_reflects_2r_over_1_plus_r_and_passes_the_rest_straight() {
    for eta in [1.33f32, 1.5] {
        for theta in [0.1f32, 0.8, 1.3, PI - 0.6] {
            let wo = dir(theta, 0.4);
            let m = Material::ThinDielectric {
                reflect: Vec3::ONE,
                transmit: Vec3::ONE,
                eta,
            };
            let b = bsdf(&m, wo, Vec3::ONE);
            let r = fresnel_dielectric(wo.z.abs() as f64, eta as f64);
            let expect = 2.0 * r / (1.0 + r);
            let mut rng = Rng::new(11);
            let n = 100_000;
            let mut reflected = 0;
            for _ in 0..n {
                let s = b.sample_mode(wo, rng.next2(), rng.next(), TransportMode::Radiance).unwrap();
                assert!(
                    s.delta && s.weight == Vec3::ONE && s.eta == 1.0,
                    "no η² scaling: the pane does not bend light"
                );
                if s.wi.z * wo.z > 0.0 {
                    reflected += 1;
                    close("reflection probability", s.pdf, expect, 1e-4);
                    assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
                } else {
                    assert!((s.wi + wo).length() < 1e-6, "straight through");
                }
            }
            let p = reflected as f64 / n as f64;
            assert!(
                (p - expect).abs() < 5.0 * (expect * (1.0 - expect) / n as f64).sqrt() + 1e-4,
                "{p} vs {expect}"
            );
        }
    }
}

#[test]
fn rough_dielectric_matches_walters_formulas() {
    for kind in [Distribution::Beckmann, Distribution::Ggx] {
        let alpha = 0.3f64;
        let eta = 1.5f64;
        let m = rough_dielectric(kind, alpha as f32, alpha as f32, eta as f32);
        let (d, g1) = d_g1(kind, alpha);
        let mut rng = Rng::new(5);
        let mut checked = [0usize; 2];
        for _ in 0..1500 {
            let (wo, wi) = (rng.dir(), rng.dir());
            let b = bsdf(&m, wo, Vec3::ONE);
            let (o, i) = (v64(wo), v64(wi));
            let reflect = o[2] * i[2] > 0.0;
            // η on the side of o, and on the side of i
            let (eta_o, eta_i) = if o[2] > 0.0 { (1.0, eta) } else { (eta, 1.0) };
            // the half vector: h ∝ −(η_o o + η_i i) for refraction, o + i for reflection
            let h = if reflect {
                unit([o[0] + i[0], o[1] + i[1], o[2] + i[2]])
            } else {
                unit([
                    -(eta_o * o[0] + eta_i * i[0]),
                    -(eta_o * o[1] + eta_i * i[1]),
                    -(eta_o * o[2] + eta_i * i[2]),
                ])
            };
            let h = if h[2] < 0.0 { [-h[0], -h[1], -h[2]] } else { h };
            let (oh, ih) = (dot(o, h), dot(i, h));
            let g = g1(o, h) * g1(i, h);
            // F with the incident side's cosine and index ratio
            let f = if oh > 0.0 {
                fresnel_dielectric(oh, eta)
            } else {
                fresnel_dielectric(-oh, 1.0 / eta)
            };
            let (radiance, importance) = if reflect {
                let v = f * d(h) * g / (4.0 * (o[2] * i[2]).abs());
                (v, v)
            } else {
                // Walter (21) for light from i out towards o, the radiance BSDF (η_o² above);
                // its adjoint, importance, has η_i² there instead
                let v = (oh * ih / (o[2] * i[2])).abs() * eta_o * eta_o * (1.0 - f) * d(h) * g / (eta_i * ih + eta_o * oh).powi(2);
                (v, v * (eta_i * eta_i) / (eta_o * eta_o))
            };
            let got_r = b.eval_mode(wo, wi, TransportMode::Radiance).x;
            let got_i = b.eval_mode(wo, wi, TransportMode::Importance).x;
            if radiance == 0.0 || g == 0.0 {
                assert!(
                    got_r == 0.0 || radiance < 1e-6,
                    "{kind:?}: {got_r} where the formula gives {radiance}"
                );
                continue;
            }
            checked[reflect as usize] += 1;
            close(&format!("{kind:?} radiance {wo} {wi}"), got_r, radiance, 2e-3);
            close(&format!("{kind:?} importance {wo} {wi}"), got_i, importance, 2e-3);
        }
        assert!(checked[0] > 100 && checked[1] > 100, "{checked:?}");
    }
}

/// ∫ g(m) over normals visible from `o` (D_o(m) = G1(o, m) max(0, o·m) D(m) / cos θo),
/// by a midpoint rule in (cos θm, φm), f64.
fn visible_normal_integral(kind: Distribution, alpha: f64, o: [f64; 3], g: impl Fn([f64; 3]) -> f64) -> f64 {
    let (d, g1) = d_g1(kind, alpha);
    let (nc, np) = (300, 300);
    let mut acc = 0.0;
    for a in 0..nc {
        // cos θm concentrated near 1, where D lives: cos = 1 − t²
        let t = (a as f64 + 0.5) / nc as f64;
        let c = 1.0 - t * t;
        let jac = 2.0 * t / nc as f64;
        let s = (1.0 - c * c).max(0.0).sqrt();
        for b in 0..np {
            let phi = 2.0 * std::f64::consts::PI * (b as f64 + 0.5) / np as f64;
            let m = [s * phi.cos(), s * phi.sin(), c];
            let om = dot(o, m);
            if om <= 0.0 {
                continue;
            }
            let dv = g1(o, m) * om * d(m) / o[2];
            if dv > 0.0 {
                acc += dv * g(m) * jac * 2.0 * std::f64::consts::PI / np as f64;
            }
        }
    }
    acc
}

#[test]
fn rough_plastic_matches_mitsubas_definition() {
    let eta = 1.5f64;
    for (kind, alpha) in [(Distribution::Ggx, 0.3f64), (Distribution::Beckmann, 0.2)] {
        let (d, g1) = d_g1(kind, alpha);
        let mu_dir = |mu: f64| [(1.0 - mu * mu).sqrt(), 0.0, mu];
        // the coating's transmittance from outside: E_m[(1 − F(o·m)) G1(t, m)], t refracted
        let transmittance = |mu: f64| {
            let o = mu_dir(mu);
            visible_normal_integral(kind, alpha, o, |m| {
                let om = dot(o, m);
                let f = fresnel_dielectric(om, eta);
                // refraction about m: t = (om/η − cos θt) m − o/η
                let cos_t = (1.0 - (1.0 - om * om) / (eta * eta)).max(0.0).sqrt();
                let t = [
                    (om / eta - cos_t) * m[0] - o[0] / eta,
                    (om / eta - cos_t) * m[1] - o[1] / eta,
                    (om / eta - cos_t) * m[2] - o[2] / eta,
                ];
                (1.0 - f) * g1(t, m)
            })
        };
        // inside: 2·mean over μⱼ = j/63 of μⱼ·E_m[F(o·m, 1/η) G1(r, m)], r reflected
        let internal: f64 = (0..64)
            .map(|j| {
                let mu = (j as f64 / 63.0).max(1e-6);
                let o = mu_dir(mu);
                let r = visible_normal_integral(kind, alpha, o, |m| {
                    let om = dot(o, m);
                    let r = [2.0 * om * m[0] - o[0], 2.0 * om * m[1] - o[1], 2.0 * om * m[2] - o[2]];
                    if r[2] <= 0.0 {
                        return 0.0;
                    }
                    fresnel_dielectric(om, 1.0 / eta) * g1(r, m)
                });
                r * mu
            })
            .sum::<f64>()
            * 2.0
            / 64.0;
        let albedo = Vec3::new(0.8, 0.4, 0.2);
        let m = rough_plastic(kind, alpha as f32, eta as f32, false);
        for (to, ti) in [(0.2f32, 0.5f32), (0.7, 1.1), (1.2, 0.3), (0.5, 0.5)] {
            let (wo, wi) = (dir(to, 0.0), dir(ti, 2.5));
            let b = bsdf(&m, wo, albedo);
            let (o, i) = (v64(wo), v64(wi));
            let h = unit([o[0] + i[0], o[1] + i[1], o[2] + i[2]]);
            let spec = fresnel_dielectric(dot(o, h), eta) * d(h) * g1(o, h) * g1(i, h) / (4.0 * o[2] * i[2]);
            let (t_o, t_i) = (transmittance(o[2]), transmittance(i[2]));
            for c in 0..3 {
                let rho = albedo[c] as f64;
                let diffuse = rho / (1.0 - internal) / std::f64::consts::PI / (eta * eta) * t_o * t_i;
                close(
                    &format!("roughplastic {kind:?} θo={to} θi={ti}"),
                    b.eval(wo, wi)[c],
                    spec + diffuse,
                    4e-3,
                );
            }
        }
        // `nonlinear`: ρ/(1 − ρ·R_int) instead of ρ/(1 − R_int)
        let (wo, wi) = (dir(0.4, 0.0), dir(0.9, 1.0));
        let nl = bsdf(&rough_plastic(kind, alpha as f32, eta as f32, true), wo, albedo).eval(wo, wi);
        let lin = bsdf(&m, wo, albedo).eval(wo, wi);
        let spec = bsdf(&m, wo, Vec3::ZERO).eval(wo, wi);
        for c in 0..3 {
            let rho = albedo[c] as f64;
            let ratio = (nl[c] - spec[c]) as f64 / (lin[c] - spec[c]) as f64;
            close("nonlinear", ratio as f32, (1.0 - internal) / (1.0 - rho * internal), 1e-3);
        }
    }
}

#[test]
fn plastic_matches_mitsubas_definition() {
    for eta in [1.49f64, 1.8] {
        // the internal diffuse reflectance fdr = ∫ F(μ; 1/η) 2μ dμ, here by quadrature;
        // Mitsuba uses a fit within 1% of it
        let n = 20_000;
        let fdr: f64 = (0..n)
            .map(|j| {
                let mu = (j as f64 + 0.5) / n as f64;
                fresnel_dielectric(mu, 1.0 / eta) * 2.0 * mu / n as f64
            })
            .sum();
        let albedo = Vec3::new(0.7, 0.3, 0.05);
        let m = Material::Plastic {
            texture: 0,
            specular: Vec3::ONE,
            eta: eta as f32,
            nonlinear: false,
            specular_sampling_weight: None,
        };
        for (to, ti) in [(0.1f32, 0.5f32), (0.8, 1.2), (1.4, 0.2)] {
            let (wo, wi) = (dir(to, 0.5), dir(ti, 3.0));
            let got = bsdf(&m, wo, albedo).eval(wo, wi);
            let (fo, fi) = (fresnel_dielectric(wo.z as f64, eta), fresnel_dielectric(wi.z as f64, eta));
            for c in 0..3 {
                let expect = albedo[c] as f64 / (1.0 - fdr) / (std::f64::consts::PI * eta * eta) * (1.0 - fo) * (1.0 - fi);
                close(&format!("plastic η={eta} θo={to} θi={ti}"), got[c], expect, 1e-2);
            }
        }
        let fit = fresnel::diffuse_reflectance(1.0 / eta as f32) as f64;
        assert!((fit - fdr).abs() < 0.01 * fdr, "fit {fit} vs quadrature {fdr}");
    }
}

/// ∫ f(wo, ω)|cos θ| dω over the sphere (midpoint rule, dense near the poles'
/// specular peaks via cos-uniform bins), for the lobes `eval` covers.
fn eval_albedo(b: &Bsdf, wo: Vec3, mode: TransportMode) -> f64 {
    let (nc, np) = (400, 200);
    let mut acc = 0.0f64;
    for a in 0..nc {
        let c = -1.0 + 2.0 * (a as f64 + 0.5) / nc as f64;
        let s = (1.0 - c * c).sqrt();
        for p in 0..np {
            let phi = 2.0 * std::f64::consts::PI * (p as f64 + 0.5) / np as f64;
            let wi = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, c as f32);
            acc += b.eval_mode(wo, wi, mode).x as f64 * c.abs();
        }
    }
    acc * 4.0 * std::f64::consts::PI / (nc * np) as f64
}

/// Mean sample weight (the albedo by sampling) and its standard error.
fn sampled_albedo(b: &Bsdf, wo: Vec3, mode: TransportMode, n: usize) -> (f64, f64, f64) {
    let mut rng = Rng::new(3);
    let (mut sum, mut sum2, mut delta) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..n {
        if let Some(s) = b.sample_mode(wo, rng.next2(), rng.next(), mode) {
            let w = s.weight.x as f64;
            sum += w;
            sum2 += w * w;
            if s.delta {
                delta += w;
            }
        }
    }
    let mean = sum / n as f64;
    (mean, ((sum2 / n as f64 - mean * mean) / n as f64).sqrt(), delta / n as f64)
}

#[test]
fn white_furnace_energy_is_at_most_one_and_sampling_agrees_with_eval() {
    let mut cases: Vec<(String, Material)> = Vec::new();
    for (kind, alpha) in [(Distribution::Beckmann, 0.3f32), (Distribution::Ggx, 0.7)] {
        {
            cases.push((
                format!("roughdielectric {kind:?} α={alpha}"),
                rough_dielectric(kind, alpha, alpha, 1.5),
            ));
            cases.push((format!("roughplastic {kind:?} α={alpha}"), rough_plastic(kind, alpha, 1.5, false)));
        }
    }
    cases.push(("plastic".into(), plastic(1.5)));
    cases.push((
        "thindielectric".into(),
        Material::ThinDielectric {
            reflect: Vec3::ONE,
            transmit: Vec3::ONE,
            eta: 1.5,
        },
    ));
    for (name, m) in &cases {
        for theta in [0.3f32, 1.1, 1.45, PI - 0.5, PI - 1.2] {
            let wo = dir(theta, 0.2);
            let b = bsdf(m, wo, Vec3::ONE);
            if !m.transmits() && wo.z < 0.0 {
                continue;
            }
            // energy: the adjoint (importance) carries what is physically conserved
            let (albedo, se, delta) = sampled_albedo(&b, wo, TransportMode::Importance, 100_000);
            eprintln!("{name} θo={theta}: albedo {albedo:.4} ± {se:.4}");
            assert!(
                albedo <= 1.0 + 4.0 * se + 1e-4,
                "{name} θo={theta}: albedo {albedo} ± {se} exceeds 1"
            );
            if b.is_delta() {
                assert!((albedo - 1.0).abs() < 1e-5, "{name}: a lossless delta BSDF keeps all energy");
                continue;
            }
            for mode in [TransportMode::Importance, TransportMode::Radiance] {
                let (s, se, delta) = if mode == TransportMode::Importance {
                    (albedo, se, delta)
                } else {
                    sampled_albedo(&b, wo, mode, 100_000)
                };
                let q = eval_albedo(&b, wo, mode);
                assert!(
                    (s - delta - q).abs() < 4.0 * se + 4e-3 * q.max(0.1),
                    "{name} θo={theta} {mode:?}: sampling gives {:.4} ± {se:.4}, ∫ f cos = {q:.4}",
                    s - delta
                );
            }
        }
    }
}

#[test]
fn reciprocity() {
    let mut rng = Rng::new(17);
    let reflective = [
        ("plastic", plastic(1.49)),
        ("roughplastic ggx", rough_plastic(Distribution::Ggx, 0.3, 1.49, false)),
        ("roughplastic beckmann", rough_plastic(Distribution::Beckmann, 0.2, 1.6, true)),
    ];
    for (name, m) in &reflective {
        for _ in 0..300 {
            let (mut o, mut i) = (rng.dir(), rng.dir());
            o.z = o.z.abs();
            i.z = i.z.abs();
            let a = bsdf(m, o, GREY).eval(o, i);
            let b = bsdf(m, i, GREY).eval(i, o);
            assert!(
                (a - b).abs().max_element() <= 1e-4 * a.max_element().max(1e-3),
                "{name}: f({o},{i}) = {a} vs {b}"
            );
        }
    }
    let eta = 1.5f32;
    let m = rough_dielectric(Distribution::Ggx, 0.3, 0.3, eta);
    let mut transmissions = 0;
    for _ in 0..600 {
        let (o, i) = (rng.dir(), rng.dir());
        let fo = bsdf(&m, o, Vec3::ONE);
        let fi = bsdf(&m, i, Vec3::ONE);
        let a = fo.eval_mode(o, i, TransportMode::Radiance).x;
        let b = fi.eval_mode(i, o, TransportMode::Radiance).x;
        let index = |w: Vec3| if w.z > 0.0 { 1.0 } else { eta };
        // f(o, i)/η_o² = f(i, o)/η_i², η on each direction's side
        let (x, y) = (a / index(o).powi(2), b / index(i).powi(2));
        assert!((x - y).abs() <= 1e-3 * x.max(y).max(1e-3), "roughdielectric {o} {i}: {x} vs {y}");
        // the adjoint is the transpose
        let adj = fo.eval_mode(o, i, TransportMode::Importance).x;
        assert!((adj - b).abs() <= 1e-3 * b.max(1e-3), "adjoint {adj} vs f(i, o) {b}");
        if o.z * i.z < 0.0 && a > 0.0 {
            transmissions += 1;
        }
    }
    assert!(transmissions > 30, "{transmissions}");
}

#[test]
fn twosided_uses_the_back_material_with_its_frame_flipped() {
    let front = plastic(1.49);
    let back = Material::Diffuse {
        texture: 0,
        twosided: false,
    };
    let one = Material::TwoSided {
        front: Box::new(front.clone()),
        back: None,
    };
    let two = Material::TwoSided {
        front: Box::new(front.clone()),
        back: Some(Box::new(back.clone())),
    };
    let flip = |w: Vec3| Vec3::new(w.x, w.y, -w.z);
    let mut rng = Rng::new(23);
    for _ in 0..200 {
        let (mut o, mut i) = (rng.dir(), rng.dir());
        o.z = o.z.abs();
        i.z = i.z.abs();
        let f = bsdf(&front, o, GREY).eval(o, i);
        assert_eq!(bsdf(&one, o, GREY).eval(o, i), f, "front side: the material itself");
        let fb = bsdf(&one, flip(o), GREY).eval(flip(o), flip(i));
        assert!((fb - f).abs().max_element() < 1e-5, "back side: the same material mirrored");
        let pb = bsdf(&one, flip(o), GREY).pdf(flip(o), flip(i));
        assert!((pb - bsdf(&front, o, GREY).pdf(o, i)).abs() < 1e-4);
        let db = bsdf(&two, flip(o), GREY).eval(flip(o), flip(i));
        assert!((db - GREY / PI).abs().max_element() < 1e-5, "back side: the back material");
        assert_eq!(bsdf(&two, flip(o), GREY).eval(flip(o), i), Vec3::ZERO, "no light through");
        let s = bsdf(&one, flip(o), GREY).sample(flip(o), rng.next2(), rng.next()).unwrap();
        assert!(s.wi.z < 0.0, "samples stay on the viewer's side");
    }
}

fn desc_of(materials: serde_json::Value) -> rdr::error::Result<rdr::desc::SceneDesc> {
    let v = serde_json::json!({
        "camera": {}, "film": {"resolution": [4, 4]}, "integrator": {"type": "path"},
        "textures": {"red": {"type": "constant", "color": [0.8, 0.1, 0.1]}},
        "materials": materials,
    });
    rdr::desc::SceneDesc::from_value(&v, Path::new("m.json"), Path::new("."))
}

#[test]
fn json_keys_defaults_and_errors() {
    let d = desc_of(serde_json::json!({
        "gold": {"type": "conductor", "eta": [0.14, 0.37, 1.44], "k": [3.98, 2.38, 1.60], "texture_name": "red"},
        "mirror": {"type": "conductor"},
        "pane": {"type": "thindielectric", "eta": 1.33, "colour": 1},
        "frost": {"type": "roughdielectric", "alpha_x": 0.3, "alpha_y": 0.2, "distribution": "ggx"},
        "shiny": {"type": "plastic", "texture_name": "red", "nonlinear": true},
        "matte": {"type": "roughplastic", "alpha": 0.25, "specular_reflectance": [0.5, 0.5, 0.5]},
        "leaf": {"type": "twosided", "material_name": "shiny", "back_material_name": "matte"},
    }))
    .unwrap();
    let get = |n: &str| &d.materials.iter().find(|m| m.name == n).unwrap().material;
    assert!(matches!(get("mirror"), Material::Conductor { eta, k, .. } if *eta == Vec3::ZERO && *k == Vec3::ONE));
    assert!(matches!(get("pane"), Material::ThinDielectric { eta, reflect, .. } if *eta == 1.33 && *reflect == Vec3::ONE));
    assert!(
        matches!(get("frost"), Material::RoughDielectric { eta, alpha_x, alpha_y, distribution: Distribution::Ggx, .. }
        if *eta == 1.5 && *alpha_x == 0.3 && *alpha_y == 0.2)
    );
    assert!(matches!(get("shiny"), Material::Plastic { eta, nonlinear: true, .. } if *eta == 1.49));
    assert!(
        matches!(get("matte"), Material::RoughPlastic { alpha, distribution: Distribution::Beckmann, nonlinear: false, .. } if *alpha == 0.25)
    );
    assert!(matches!(get("leaf"), Material::TwoSided { front, back: Some(b) }
        if matches!(**front, Material::Plastic { .. }) && matches!(**b, Material::RoughPlastic { .. })));
    assert!(
        d.warnings
            .iter()
            .any(|w| w.contains("materials.pane") && w.contains("unknown key 'colour'")),
        "{:?}",
        d.warnings
    );
    for (m, expect) in [
        (
            serde_json::json!({"a": {"type": "twosided"}}),
            "materials.a.material_name: required key is missing",
        ),
        (
            serde_json::json!({"a": {"type": "twosided", "material_name": "b"}}),
            "materials.a.material_name: no material named 'b'",
        ),
        (
            serde_json::json!({"a": {"type": "twosided", "material_name": "g"}, "g": {"type": "glass"}}),
            "'g' transmits light",
        ),
        (
            serde_json::json!({"a": {"type": "twosided", "material_name": "b"}, "b": {"type": "twosided", "material_name": "c"}, "c": {"type": "conductor"}}),
            "twosided cannot nest",
        ),
        (
            serde_json::json!({"a": {"type": "plastic", "eta": 1}}),
            "materials.a.eta: a coating needs an index other than 1",
        ),
        (
            serde_json::json!({"a": {"type": "roughplastic", "distribution": "phong"}}),
            "unknown microfacet distribution 'phong'",
        ),
        (
            serde_json::json!({"a": {"type": "roughdielectric", "alpha_x": -1}}),
            "materials.a.alpha_x: must not be negative",
        ),
        (
            serde_json::json!({"a": {"type": "conductor", "k": [1, -1, 1]}}),
            "materials.a.k: must not be negative",
        ),
        (
            serde_json::json!({"a": {"type": "velvet"}}),
            "available: diffuse, refraction, glass, roughconductor, conductor",
        ),
    ] {
        let e = desc_of(m).unwrap_err().to_string();
        assert!(e.contains(expect) && e.starts_with("m.json: "), "{e}\n  should say: {expect}");
    }
}
