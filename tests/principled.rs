//! `principled` (Mitsuba's Disney BSDF) and `blendbsdf`: values against Mitsuba 3's
//! own plugin at random direction pairs (`tests/refs/principled/points.json`, made by
//! `scripts/make_principled_points.py`), sampling against the pdf (χ²) at several
//! incident angles and parameter sets, sample weights against eval·cos/pdf, energy
//! (white furnace) and reciprocity where they hold, and each test's deliberate errors
//! (a lobe left out, a wrong sheen weight, a wrong lobe probability in the pdf), which
//! must make it fail. The renders against Mitsuba's images are at the end.

mod common;
use common::chi2::{bin_in_cap, chi2_test, N_COS, N_PHI};
use common::*;
use rdr::desc::{SceneDesc, TextureRef};
use rdr::material::principled::Principled;
use rdr::material::{Bsdf, Material, PrincipledParams, TransportMode};
use rdr::math::{Frame, Vec2, Vec3, PI};
use rdr::Profile;
use serde_json::{json, Value};
use std::path::Path;

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
    fn dir(&mut self) -> Vec3 {
        rdr::sampling::uniform_sphere(self.next2())
    }
}

fn dir(theta: f32, phi: f32) -> Vec3 {
    Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
}

/// The materials of a JSON `materials` section (textures: a constant "grey").
fn materials(m: Value) -> rdr::error::Result<SceneDesc> {
    let v = json!({
        "camera": {}, "film": {"resolution": [4, 4]}, "integrator": {"type": "path", "lights": []},
        "textures": {"grey": {"type": "constant", "color": [0.4, 0.4, 0.4]}},
        "materials": m,
    });
    SceneDesc::from_value(&v, Path::new("m.json"), Path::new("."))
}

/// A described material with its constants as textures 0, 1, …: the material and
/// the colours those stand for.
fn built(m: &Material<TextureRef>) -> (Material, Vec<Vec3>) {
    let mut colours = Vec::new();
    let m = m
        .try_map_textures(|t| -> Result<u32, ()> {
            colours.push(match t {
                TextureRef::Color(c) => *c,
                TextureRef::Named(_) => Vec3::splat(0.4),
            });
            Ok(colours.len() as u32 - 1)
        })
        .unwrap();
    (m, colours)
}

/// `principled` from Mitsuba-style parameters (the JSON keys are the same).
fn principled_json(params: &Value) -> Material<TextureRef> {
    let mut p = params.clone();
    p["type"] = json!("principled");
    let d = materials(json!({ "m": p })).unwrap_or_else(|e| panic!("{e}"));
    d.materials[0].material.clone()
}

/// The BSDF of a material at a surface facing +z seen from `wo`.
fn bsdf_of(m: &Material<TextureRef>, wo: Vec3) -> Bsdf {
    let (m, colours) = built(m);
    m.bsdf(Vec3::Z, wo, |t| colours[t as usize])
}

/// The per-point principled BSDF (local frame = world frame here).
fn lobes_of(m: &Material<TextureRef>) -> Principled {
    let (m, colours) = built(m);
    let Material::Principled(p) = m else { panic!("not principled") };
    let p: &PrincipledParams<u32> = &p;
    p.at(&|t| colours[t as usize])
}

// ---- against Mitsuba's own values --------------------------------------------------

fn points() -> Value {
    let f = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/principled/points.json");
    serde_json::from_str(&std::fs::read_to_string(f).unwrap()).unwrap()
}

fn v3(v: &Value) -> Vec3 {
    Vec3::new(
        v[0].as_f64().unwrap() as f32,
        v[1].as_f64().unwrap() as f32,
        v[2].as_f64().unwrap() as f32,
    )
}

/// How many of Mitsuba's eval and pdf values `f` (eval with the cosine, pdf) misses,
/// over every parameter set, printing the first few.
fn mismatches_with_mitsuba(name: &str, f: impl Fn(&Principled, bool, Vec3, Vec3) -> (Vec3, f32)) -> usize {
    let pts = points();
    let mut bad = 0;
    for (set, data) in pts["sets"].as_object().unwrap() {
        let m = principled_json(&data["params"]);
        let p = lobes_of(&m);
        let transmits = m.transmits();
        for pair in data["pairs"].as_array().unwrap() {
            let (wi, wo) = (v3(&pair["wi"]), v3(&pair["wo"]));
            let (e, pdf) = (v3(&pair["eval"]), pair["pdf"].as_f64().unwrap() as f32);
            let (ge, gp) = f(&p, transmits, wi, wo);
            let close = |a: f32, b: f32| (a - b).abs() <= 2e-3 * a.abs().max(b.abs()) + 1e-6;
            let eval_ok = (0..3).all(|c| close(ge[c], e[c]));
            // rdr's documented difference: from inside an opaque one, pdf 0 (Mitsuba's
            // reports its reflection lobe there, with a value of 0)
            let pdf_ok = if wi.z < 0.0 && !transmits { gp == 0.0 } else { close(gp, pdf) };
            if !(eval_ok && pdf_ok) {
                bad += 1;
                if bad <= 3 {
                    eprintln!("{name} [{set}] wi {wi} wo {wo}: eval {ge} vs Mitsuba {e}, pdf {gp} vs {pdf}");
                }
            }
        }
    }
    eprintln!("{name}: {bad} of Mitsuba's values missed");
    bad
}

fn rdr_values(p: &Principled, _: bool, wi: Vec3, wo: Vec3) -> (Vec3, f32) {
    (p.eval(wi, wo, TransportMode::Radiance) * wo.z.abs(), p.pdf(wi, wo))
}

#[test]
fn values_match_mitsubas_principled() {
    assert_eq!(mismatches_with_mitsuba("rdr", rdr_values), 0);
    // deliberate errors: each must miss some of Mitsuba's values
    let off = |lobe: usize| {
        move |p: &Principled, _: bool, wi: Vec3, wo: Vec3| {
            let mut on = [true; 5];
            on[lobe] = false;
            (p.eval_lobes(wi, wo, TransportMode::Radiance, on) * wo.z.abs(), p.pdf(wi, wo))
        }
    };
    assert!(mismatches_with_mitsuba("clearcoat left out", off(2)) > 0);
    assert!(mismatches_with_mitsuba("sheen left out", off(4)) > 0);
    assert!(mismatches_with_mitsuba("transmission left out", off(1)) > 0);
    let double_sheen = |p: &Principled, t: bool, wi: Vec3, wo: Vec3| {
        rdr_values(
            &Principled {
                sheen: 2.0 * p.sheen,
                ..*p
            },
            t,
            wi,
            wo,
        )
    };
    assert!(mismatches_with_mitsuba("sheen weight doubled", double_sheen) > 0);
    let even_lobes = |p: &Principled, _: bool, wi: Vec3, wo: Vec3| {
        let change = |q: [f32; 4]| {
            q.map(|x| if x > 0.0 { 1.0 } else { 0.0 })
                .map(|x| x / q.iter().filter(|x| **x > 0.0).count() as f32)
        };
        (
            p.eval(wi, wo, TransportMode::Radiance) * wo.z.abs(),
            p.pdf_with(wi, wo, Some(&change)),
        )
    };
    assert!(mismatches_with_mitsuba("lobe probabilities even", even_lobes) > 0);
}

// ---- sampling against the pdf ------------------------------------------------------

/// χ² of `sample`'s directions against `pdf` (bins over the whole sphere, masses by a
/// 16×16 midpoint rule per bin), as `Err` when they disagree.
fn chi2_of(name: &str, n: usize, mut sample: impl FnMut(Vec2, f32) -> Option<Vec3>, pdf: impl Fn(Vec3) -> f32) -> Result<f64, String> {
    let frame = Frame::from_normal(Vec3::Z);
    let mut rng = Rng::new(0x1234_5678 ^ name.len() as u64);
    let mut observed = vec![0.0f64; N_COS * N_PHI + 1];
    for _ in 0..n {
        if let Some(w) = sample(rng.next2(), rng.next()) {
            observed[bin_in_cap(&frame, w, -1.0).unwrap_or(N_COS * N_PHI)] += 1.0;
        }
    }
    let k = 16;
    let d_area = (2.0 / N_COS as f64) * (2.0 * std::f64::consts::PI / N_PHI as f64) / (k * k) as f64;
    let mut mass = vec![0.0f64; N_COS * N_PHI + 1];
    for c in 0..N_COS {
        for p in 0..N_PHI {
            let mut acc = 0.0f64;
            for i in 0..k {
                for j in 0..k {
                    let cos = -1.0 + 2.0 * (c as f64 + (i as f64 + 0.5) / k as f64) / N_COS as f64;
                    let phi = 2.0 * std::f64::consts::PI * (p as f64 + (j as f64 + 0.5) / k as f64) / N_PHI as f64;
                    let s = (1.0 - cos * cos).max(0.0).sqrt();
                    let w = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, cos as f32);
                    acc += pdf(w) as f64 * d_area;
                }
            }
            mass[c * N_PHI + p] = acc;
        }
    }
    chi2_test(name, n, &observed, &mass)
}

/// Every sample's weight is f·|cos|/pdf of its direction and its pdf the pdf.
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
            "{name}: weight {} vs f·cos/pdf {expect}",
            s.weight
        );
        assert!((s.pdf - pdf).abs() <= 1e-3 * pdf, "{name}: pdf {} vs {pdf}", s.pdf);
    }
}

/// The parameter sets the statistical tests use (roughness ≥ 0.3 and a clearcoat
/// gloss of 0, so that the 16×16 quadrature of each bin resolves the lobes).
fn sampling_sets() -> Vec<(&'static str, Value)> {
    vec![
        ("defaults", json!({})),
        (
            "everything",
            json!({"base_color": [0.8, 0.3, 0.1], "roughness": 0.4, "metallic": 0.2, "clearcoat": 0.8, "clearcoat_gloss": 0.0,
                   "sheen": 0.6, "sheen_tint": 0.4, "spec_tint": 0.3, "spec_trans": 0.4, "flatness": 0.3}),
        ),
        (
            "anisotropic metal",
            json!({"base_color": [0.9, 0.6, 0.2], "metallic": 1.0, "roughness": 0.5, "anisotropic": 0.8}),
        ),
        (
            "glass",
            json!({"base_color": [0.9, 0.9, 1.0], "spec_trans": 1.0, "eta": 1.33, "roughness": 0.4}),
        ),
        (
            "clearcoat and rates",
            json!({"base_color": [0.1, 0.1, 0.6], "roughness": 0.6, "clearcoat": 1.0, "main_specular_sampling_rate": 0.5,
                   "clearcoat_sampling_rate": 2.0, "diffuse_reflectance_sampling_rate": 0.7}),
        ),
    ]
}

#[test]
fn principled_sampling_matches_its_pdf() {
    for (set, params) in sampling_sets() {
        let m = principled_json(&params);
        let mut thetas = vec![0.25f32, 0.9, 1.35];
        if m.transmits() {
            thetas.extend([PI - 0.3, PI - 1.1]);
        }
        for theta in thetas {
            let wo = dir(theta, 0.6);
            let b = bsdf_of(&m, wo);
            let name = format!("principled [{set}] θo={theta:.2}");
            check_weights(&name, &b, wo, TransportMode::Radiance);
            check_weights(&name, &b, wo, TransportMode::Importance);
            let r = chi2_of(&name, 150_000, |u, uc| b.sample(wo, u, uc).map(|s| s.wi), |w| b.pdf(wo, w));
            assert!(r.is_ok(), "{}", r.unwrap_err());
        }
    }
}

#[test]
fn a_wrong_lobe_probability_in_the_pdf_fails_the_chi2_test() {
    let m = principled_json(&sampling_sets()[4].1);
    let wo = dir(0.9, 0.6);
    let p = lobes_of(&m);
    // the clearcoat's share (0.29 here) reported too small (half), the rest renormalised
    let wrong = |q: [f32; 4]| {
        let mut q = q;
        q[1] *= 0.5;
        let t: f32 = q.iter().sum();
        q.map(|x| x / t)
    };
    let r = chi2_of(
        "clearcoat share halved in the pdf",
        150_000,
        |u, uc| p.sample(wo, u, uc, TransportMode::Radiance).map(|s| s.wi),
        |w| p.pdf_with(wo, w, Some(&wrong)),
    );
    eprintln!("{r:?}");
    assert!(r.is_err(), "a wrong clearcoat probability passed: {r:?}");
    // and sampling the lobes with Mitsuba's probabilities but reporting even shares
    let even = |q: [f32; 4]| {
        let n = q.iter().filter(|x| **x > 0.0).count() as f32;
        q.map(|x| if x > 0.0 { 1.0 / n } else { 0.0 })
    };
    let r = chi2_of(
        "even lobe shares in the pdf",
        150_000,
        |u, uc| p.sample(wo, u, uc, TransportMode::Radiance).map(|s| s.wi),
        |w| p.pdf_with(wo, w, Some(&even)),
    );
    eprintln!("{r:?}");
    assert!(r.is_err(), "even lobe shares passed: {r:?}");
}

// ---- energy and reciprocity --------------------------------------------------------

/// Mean sample weight (red channel) and its standard error.
fn sampled_albedo(b: &Bsdf, wo: Vec3, mode: TransportMode, n: usize) -> (f64, f64) {
    let mut rng = Rng::new(3);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        if let Some(s) = b.sample_mode(wo, rng.next2(), rng.next(), mode) {
            let w = s.weight.x as f64;
            sum += w;
            sum2 += w * w;
        }
    }
    let mean = sum / n as f64;
    (mean, ((sum2 / n as f64 - mean * mean) / n as f64).sqrt())
}

/// ∫ f(wo, ω)|cos θ| dω over the sphere by a midpoint rule in (cos θ, φ).
fn eval_albedo(b: &Bsdf, wo: Vec3, mode: TransportMode) -> f64 {
    let (nc, np) = (600, 300);
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

/// White-furnace albedos: ≤ 1 for the sets where Mitsuba's model conserves energy (a
/// white metal, isotropic or not, and white glass), and sampling agrees with ∫ f cos
/// for every set. (Mitsuba's principled, like Burley's, is not energy-conserving with
/// a diffuse base: the dielectric specular lobe is added on top of the diffuse one
/// without taking its share away — a white base of roughness 0.3 reflects 1.035 at
/// θo = 0.3 —, and so are the retro-reflection, the sheen and the clearcoat; the test
/// prints those albedos.)
#[test]
fn white_furnace_and_sampling_agree_with_eval() {
    let white = |extra: Value| {
        let mut v = json!({"base_color": 1.0});
        for (k, x) in extra.as_object().unwrap() {
            v[k] = x.clone();
        }
        v
    };
    let cases = [
        ("white metal", white(json!({"metallic": 1.0, "roughness": 0.5})), true),
        (
            "white anisotropic metal",
            white(json!({"metallic": 1.0, "roughness": 0.4, "anisotropic": 0.9})),
            true,
        ),
        ("white glass", white(json!({"spec_trans": 1.0, "roughness": 0.4})), true),
        ("white base r=0.3", white(json!({"roughness": 0.3})), false),
        (
            "white everything",
            white(json!({"roughness": 0.8, "sheen": 1.0, "clearcoat": 1.0, "spec_trans": 0.3})),
            false,
        ),
    ];
    for (name, params, conserves) in &cases {
        let m = principled_json(params);
        for theta in [0.3f32, 1.0, 1.4, PI - 0.4, PI - 1.2] {
            let wo = dir(theta, 0.2);
            if wo.z < 0.0 && !m.transmits() {
                continue;
            }
            let b = bsdf_of(&m, wo);
            let (albedo, se) = sampled_albedo(&b, wo, TransportMode::Importance, 100_000);
            eprintln!("{name} θo={theta}: albedo {albedo:.4} ± {se:.4}");
            if *conserves {
                assert!(
                    albedo <= 1.0 + 4.0 * se + 1e-3,
                    "{name} θo={theta}: albedo {albedo} ± {se} exceeds 1"
                );
            }
            for mode in [TransportMode::Importance, TransportMode::Radiance] {
                let (s, se) = if mode == TransportMode::Importance {
                    (albedo, se)
                } else {
                    sampled_albedo(&b, wo, mode, 100_000)
                };
                let q = eval_albedo(&b, wo, mode);
                assert!(
                    (s - q).abs() < 4.0 * se + 5e-3 * q.max(0.1),
                    "{name} θo={theta} {mode:?}: sampling gives {s:.4} ± {se:.4}, ∫ f cos = {q:.4}"
                );
            }
        }
    }
}

/// f(o, i) = f(i, o) for reflection on the front side, with every reflecting lobe on;
/// the transmission is not reciprocal in Mitsuba's model (√base_color and the Fresnel
/// factor are taken on the viewer's side only), so pairs through the surface are not
/// compared.
#[test]
fn reflection_is_reciprocal() {
    let mut rng = Rng::new(17);
    for (set, params) in sampling_sets() {
        let m = principled_json(&params);
        for _ in 0..300 {
            let (mut o, mut i) = (rng.dir(), rng.dir());
            o.z = o.z.abs();
            i.z = i.z.abs();
            let a = bsdf_of(&m, o).eval(o, i);
            let b = bsdf_of(&m, i).eval(i, o);
            assert!(
                (a - b).abs().max_element() <= 1e-4 * a.max_element().max(1e-3),
                "[{set}] f({o}, {i}) = {a} vs {b}"
            );
        }
    }
}

// ---- blendbsdf ---------------------------------------------------------------------

fn blend_desc() -> SceneDesc {
    materials(json!({
        "plastic": {"type": "roughplastic", "alpha": 0.3, "distribution": "ggx", "texture_name": "grey"},
        "metal": {"type": "principled", "base_color": [0.9, 0.7, 0.3], "metallic": 1, "roughness": 0.4},
        "mirror": {"type": "conductor"},
        "glass": {"type": "principled", "spec_trans": 1, "roughness": 0.5},
        "a": {"type": "blendbsdf", "weight": 0.3, "material_names": ["plastic", "metal"]},
        "b": {"type": "blendbsdf", "weight": 0.6, "material_names": ["mirror", "glass"]},
        "c": {"type": "blendbsdf", "weight": "grey", "material_names": ["a", "b"]},
    }))
    .unwrap_or_else(|e| panic!("{e}"))
}

fn material<'a>(d: &'a SceneDesc, name: &str) -> &'a Material<TextureRef> {
    &d.materials.iter().find(|m| m.name == name).unwrap().material
}

#[test]
fn blendbsdf_is_the_mixture_and_samples_by_weight() {
    let d = blend_desc();
    let mut rng = Rng::new(5);
    // the value and pdf are the weighted sums of the nested ones
    for _ in 0..200 {
        let (o, i) = (rng.dir(), rng.dir());
        let (a, p, m) = (
            bsdf_of(material(&d, "a"), o),
            bsdf_of(material(&d, "plastic"), o),
            bsdf_of(material(&d, "metal"), o),
        );
        let f = p.eval(o, i) * 0.7 + m.eval(o, i) * 0.3;
        assert!((a.eval(o, i) - f).abs().max_element() <= 1e-5 * (1.0 + f.max_element()));
        let q = p.pdf(o, i) * 0.7 + m.pdf(o, i) * 0.3;
        assert!((a.pdf(o, i) - q).abs() <= 1e-5 * (1.0 + q));
    }
    for (name, thetas) in [("a", vec![0.3f32, 1.2]), ("c", vec![0.5, 1.3, PI - 0.5])] {
        for theta in thetas {
            let wo = dir(theta, 0.4);
            let b = bsdf_of(material(&d, name), wo);
            let label = format!("blendbsdf {name} θo={theta}");
            check_weights(&label, &b, wo, TransportMode::Radiance);
            // delta samples (the mirror of "c") fall out: the pdf's missing mass covers them
            let r = chi2_of(
                &label,
                150_000,
                |u, uc| b.sample(wo, u, uc).filter(|s| !s.delta).map(|s| s.wi),
                |w| b.pdf(wo, w),
            );
            assert!(r.is_ok(), "{}", r.unwrap_err());
        }
    }
    // "c" = 0.6·a + 0.4·b, b = 0.4·mirror + 0.6·glass: the mirror is drawn 0.16 of the time
    let wo = dir(0.7, 0.1);
    let b = bsdf_of(material(&d, "c"), wo);
    let n = 100_000;
    let mut mirrored = 0;
    for _ in 0..n {
        if let Some(s) = b.sample(wo, rng.next2(), rng.next()) {
            if s.delta {
                mirrored += 1;
                assert!((s.pdf - 0.16).abs() < 1e-5, "delta pdf {}", s.pdf);
                assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-5);
            }
        }
    }
    let share = mirrored as f64 / n as f64;
    assert!(
        (share - 0.16).abs() < 5.0 * (0.16f64 * 0.84 / n as f64).sqrt(),
        "mirror share {share}"
    );
    // a deliberate error: the pdf with the weights swapped fails χ²
    let a = bsdf_of(material(&d, "a"), dir(0.5, 0.4));
    let (p, m) = (
        bsdf_of(material(&d, "plastic"), dir(0.5, 0.4)),
        bsdf_of(material(&d, "metal"), dir(0.5, 0.4)),
    );
    let wo = dir(0.5, 0.4);
    let r = chi2_of(
        "blendbsdf with swapped weights in the pdf",
        150_000,
        |u, uc| a.sample(wo, u, uc).map(|s| s.wi),
        |w| p.pdf(wo, w) * 0.3 + m.pdf(wo, w) * 0.7,
    );
    eprintln!("{r:?}");
    assert!(r.is_err(), "swapped weights passed: {r:?}");
}

#[test]
fn json_keys_defaults_and_errors() {
    let m = principled_json(&json!({}));
    let Material::Principled(p) = &m else { panic!() };
    assert!((p.eta - 1.5).abs() < 1e-6 && p.specular == Some(0.5) && !p.has_spec_trans);
    assert!(matches!(p.base_color, TextureRef::Color(c) if c == Vec3::splat(0.5)));
    assert!(matches!(p.roughness, TextureRef::Color(c) if c == Vec3::splat(0.5)));
    let m = principled_json(&json!({"eta": 1.0, "spec_trans": 0.5, "roughness": "grey", "base_color": [0.1, 0.2, 0.3]}));
    let Material::Principled(p) = &m else { panic!() };
    assert!(p.eta == 1.001 && p.specular.is_none() && p.has_spec_trans && m.transmits());
    assert!(matches!(&p.roughness, TextureRef::Named(n) if n.value == "grey"));
    let d = blend_desc();
    assert!(matches!(material(&d, "c"), Material::BlendBsdf { first, second, .. }
        if matches!(**first, Material::BlendBsdf { .. }) && matches!(**second, Material::BlendBsdf { .. })));
    let d = materials(json!({"p": {"type": "principled", "shininess": 3}})).unwrap();
    assert!(
        d.warnings
            .iter()
            .any(|w| w.contains("materials.p") && w.contains("unknown key 'shininess'")),
        "{:?}",
        d.warnings
    );
    for (m, expect) in [
        (
            json!({"a": {"type": "principled", "eta": 1.4, "specular": 0.5}}),
            "materials.a.specular: give either eta or specular",
        ),
        (
            json!({"a": {"type": "principled", "roughness": [0.1, 0.2, 0.3]}}),
            "materials.a.roughness: expected a number or a texture name",
        ),
        (
            json!({"a": {"type": "principled", "base_color": true}}),
            "materials.a.base_color: expected a number, [r, g, b] or a texture name",
        ),
        (
            json!({"a": {"type": "principled", "metallic": -0.5}}),
            "materials.a.metallic: must not be negative",
        ),
        (
            json!({"a": {"type": "principled", "eta": "glass"}}),
            "materials.a.eta: expected a number",
        ),
        (
            json!({"a": {"type": "principled", "clearcoat_sampling_rate": -1}}),
            "materials.a.clearcoat_sampling_rate",
        ),
        (
            json!({"a": {"type": "blendbsdf", "material_names": ["b", "b"]}, "b": {"type": "conductor"}}),
            "materials.a.weight: required key is missing",
        ),
        (
            json!({"a": {"type": "blendbsdf", "weight": 0.5}}),
            "materials.a.material_names: required key is missing",
        ),
        (
            json!({"a": {"type": "blendbsdf", "weight": 0.5, "material_names": ["b"]}, "b": {"type": "conductor"}}),
            "expected an array of two material names",
        ),
        (
            json!({"a": {"type": "blendbsdf", "weight": 0.5, "material_names": ["b", "x"]}, "b": {"type": "conductor"}}),
            "no material named 'x'",
        ),
        (
            json!({"a": {"type": "blendbsdf", "weight": 0.5, "material_names": ["a", "a"]}}),
            "materials.a.material_names: materials that wrap each other form a cycle",
        ),
        (
            json!({"a": {"type": "twosided", "material_name": "g"}, "g": {"type": "principled", "spec_trans": 1}}),
            "'g' transmits light",
        ),
    ] {
        let e = materials(m).unwrap_err().to_string();
        assert!(e.contains(expect) && e.starts_with("m.json: "), "{e}\n  should say: {expect}");
    }
}

// ---- principledthin ----------------------------------------------------------------

fn thin_json(params: &Value) -> Material<TextureRef> {
    let mut p = params.clone();
    p["type"] = json!("principledthin");
    let d = materials(json!({ "m": p })).unwrap_or_else(|e| panic!("{e}"));
    d.materials[0].material.clone()
}

fn thin_lobes_of(m: &Material<TextureRef>) -> rdr::material::principledthin::PrincipledThin {
    let (m, colours) = built(m);
    let Material::PrincipledThin(p) = m else {
        panic!("not principledthin")
    };
    p.at(&|t| colours[t as usize])
}

/// How many of Mitsuba's principledthin values `eval`/`pdf` miss.
fn thin_mismatches(name: &str, scale_diff_trans: f32) -> usize {
    let pts = points();
    let mut bad = 0;
    for (set, data) in pts["thin_sets"].as_object().unwrap() {
        let mut p = thin_lobes_of(&thin_json(&data["params"]));
        p.diff_trans *= scale_diff_trans;
        for pair in data["pairs"].as_array().unwrap() {
            let (wi, wo) = (v3(&pair["wi"]), v3(&pair["wo"]));
            let (e, pdf) = (v3(&pair["eval"]), pair["pdf"].as_f64().unwrap() as f32);
            let (ge, gp) = (p.eval(wi, wo) * wo.z.abs(), p.pdf(wi, wo));
            let close = |a: f32, b: f32| (a - b).abs() <= 2e-3 * a.abs().max(b.abs()) + 1e-6;
            if !((0..3).all(|c| close(ge[c], e[c])) && close(gp, pdf)) {
                bad += 1;
                if bad <= 3 {
                    eprintln!("{name} [{set}] wi {wi} wo {wo}: eval {ge} vs Mitsuba {e}, pdf {gp} vs {pdf}");
                }
            }
        }
    }
    eprintln!("{name}: {bad} of Mitsuba's values missed");
    bad
}

#[test]
fn principledthin_matches_mitsuba_and_samples_its_pdf() {
    assert_eq!(thin_mismatches("principledthin", 1.0), 0);
    // a deliberate error: diff_trans not halved (its 0–2 range taken as 0–1)
    assert!(thin_mismatches("diff_trans not halved", 2.0) > 0);
    let pts = points();
    for (set, data) in pts["thin_sets"].as_object().unwrap() {
        let m = thin_json(&data["params"]);
        for theta in [0.3f32, 1.2, PI - 0.6] {
            let wo = dir(theta, 0.8);
            let b = bsdf_of(&m, wo);
            let name = format!("principledthin [{set}] θo={theta:.2}");
            check_weights(&name, &b, wo, TransportMode::Radiance);
            let r = chi2_of(&name, 150_000, |u, uc| b.sample(wo, u, uc).map(|s| s.wi), |w| b.pdf(wo, w));
            assert!(r.is_ok(), "{}", r.unwrap_err());
            // sampling agrees with ∫ f cos (and prints the albedo)
            let (s, se) = sampled_albedo(&b, wo, TransportMode::Radiance, 100_000);
            let q = eval_albedo(&b, wo, TransportMode::Radiance);
            eprintln!("{name}: albedo {s:.4} ± {se:.4}, ∫ f cos = {q:.4}");
            assert!(s <= 1.0 + 4.0 * se + 1e-3, "{name}: albedo {s} exceeds 1");
            assert!(
                (s - q).abs() < 4.0 * se + 5e-3 * q.max(0.1),
                "{name}: sampling {s} ± {se} vs ∫ f cos {q}"
            );
        }
    }
    // a white specular sheet keeps at most what arrives (a white diffuse one does not
    // quite: Burley's retro-reflection gives 1.003 at θo = 0.2 for roughness 0.5)
    for params in [json!({"base_color": 1, "spec_trans": 1, "roughness": 0.3})] {
        let m = thin_json(&params);
        for theta in [0.2f32, 1.0, 1.4] {
            let wo = dir(theta, 0.3);
            let (s, se) = sampled_albedo(&bsdf_of(&m, wo), wo, TransportMode::Radiance, 100_000);
            eprintln!("principledthin white {params} θo={theta}: albedo {s:.4} ± {se:.4}");
            assert!(
                s <= 1.0 + 4.0 * se + 1e-3,
                "white principledthin {params} θo={theta}: albedo {s} exceeds 1"
            );
        }
    }
    // a thin sheet is the same from both sides
    let m = thin_json(&pts["thin_sets"]["everything"]["params"]);
    let mut rng = Rng::new(41);
    for _ in 0..200 {
        let (o, i) = (rng.dir(), rng.dir());
        let flip = |w: Vec3| Vec3::new(w.x, w.y, -w.z);
        let (a, b) = (bsdf_of(&m, o).eval(o, i), bsdf_of(&m, flip(o)).eval(flip(o), flip(i)));
        assert!((a - b).abs().max_element() <= 1e-5 * (1.0 + a.max_element()), "{o} {i}: {a} vs {b}");
    }
}

// ---- renders against Mitsuba -------------------------------------------------------

fn refs() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/materials")
}

/// `file` rendered by rdr's `path` at `spp` (two seeds) against Mitsuba's image
/// of the same scene, by the noise-aware relative MSE of the material tests.
fn converges(file: &str, spp: u32) -> bool {
    let dir = refs();
    let name = file.split('.').next().unwrap();
    let s = load_scene(&dir.join(file), &[], Profile::Physical);
    let (a, b) = (render(&s, spp, 1), render(&s, spp, 2));
    let c = rdr::metrics::compare(
        &a,
        &b,
        &read(&dir.join(format!("{name}.exr"))),
        &read(&dir.join(format!("{name}.var.exr"))),
    );
    eprintln!(
        "{file:>22}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
        c.rel_mse_corrected, c.std_error, c.rel_mse_raw, c.rel_mse_noise
    );
    c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4
}

#[test]
fn principled_and_blendbsdf_converge_to_mitsubas_images() {
    let failed: Vec<&str> = [
        "principled_coat.json",
        "principled_sheen_coat.json",
        "principled_glass.xml",
        "principledthin.json",
        "blendbsdf.xml",
    ]
    .into_iter()
    .filter(|f| !converges(f, 256))
    .collect();
    assert!(failed.is_empty(), "not converging to Mitsuba: {failed:?}");
}

/// Anisotropic lobes (principled and roughconductor) stretched along the surface's
/// ∂p/∂u, as Mitsuba's shading frame has it: a rectangle turned about its normal and
/// an analytic sphere (`tests/refs/bump/aniso_*.xml`, made by `scripts/make_bump_refs.py`).
#[test]
fn anisotropic_lobes_follow_the_uv_tangent_as_in_mitsuba() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/bump");
    let failed: Vec<&str> = ["aniso_rect", "aniso_sphere"]
        .into_iter()
        .filter(|name| {
            let s = load_scene(&dir.join(format!("{name}.xml")), &[], Profile::Physical);
            let (a, b) = (render(&s, 128, 1), render(&s, 128, 2));
            let c = rdr::metrics::compare(
                &a,
                &b,
                &read(&dir.join(format!("{name}.exr"))),
                &read(&dir.join(format!("{name}.var.exr"))),
            );
            eprintln!(
                "{name:>22}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
                c.rel_mse_corrected, c.std_error, c.rel_mse_raw, c.rel_mse_noise
            );
            c.rel_mse_corrected.abs() >= 5.0 * c.std_error + 2e-4
        })
        .collect();
    assert!(failed.is_empty(), "anisotropic lobes not along Mitsuba's tangent: {failed:?}");
}
