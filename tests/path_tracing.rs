//! The path tracer against Mitsuba 3's references, the white furnace, and
//! deliberately broken variants that must fail.
//!
//! Renders are made at half resolution and compared with the reference averaged
//! over 2×2 blocks: with a box filter a half-resolution pixel integrates exactly
//! the footprint of those four pixels, so the comparison is exact in expectation
//! and four times cheaper.

mod common;
use common::*;
use rdr::metrics::{compare, Comparison, Image};
use rdr::Profile;
use std::path::Path;

struct Reference {
    r: Image,
    vr: Image,
}

fn reference(shared: &Path, name: &str, mask_rows: Option<(usize, usize)>) -> Reference {
    let mut r = read(&shared.join(format!("refs/{name}.exr")));
    let mut vr = read(&shared.join(format!("refs/{name}.var.exr")));
    if let Some((a, b)) = mask_rows {
        r = r.without_rows(a, b);
        vr = vr.without_rows(a, b);
    }
    Reference {
        r: r.block_average(2, false),
        vr: vr.block_average(2, true),
    }
}

/// Renders `scene.json` at half resolution (two independent halves of `spp`).
fn half_res(shared: &Path, scene: &str, spp: u32, extra: &[&str]) -> (Image, Image, rdr::Loaded) {
    let path = shared.join(format!("refs/scenes/{scene}.json"));
    let full: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let (w, h) = (
        full["film"]["resolution"][0].as_u64().unwrap(),
        full["film"]["resolution"][1].as_u64().unwrap(),
    );
    let res = format!(r#"{{"film": {{"resolution": [{}, {}]}}}}"#, w / 2, h / 2);
    let mut o = vec![res.as_str()];
    o.extend_from_slice(extra);
    let s = load_scene(&path, &o, Profile::Physical);
    let (a, b) = (render(&s, spp, 1), render(&s, spp, 2));
    (a, b, s)
}

fn masked(img: &Image, mask_rows: Option<(usize, usize)>) -> Image {
    match mask_rows {
        // rows of the half-resolution image
        Some((a, b)) => img.without_rows(a / 2, b.div_ceil(2)),
        None => img.clone(),
    }
}

fn check(name: &str, x: (&Image, &Image), reference: &Reference, mask_rows: Option<(usize, usize)>) -> Comparison {
    let c = compare(&masked(x.0, mask_rows), &masked(x.1, mask_rows), &reference.r, &reference.vr);
    eprintln!(
        "{name:>28}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
        c.rel_mse_corrected, c.std_error, c.rel_mse_raw, c.rel_mse_noise
    );
    c
}

fn converges(c: &Comparison) -> bool {
    c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4
}

fn fails(bad: &Comparison, good: &Comparison) -> bool {
    bad.rel_mse_corrected > 10.0 * (bad.std_error + good.std_error) + 1e-3
}

#[test]
fn white_furnace_is_one_for_every_profile() {
    let Some(shared) = shared() else { return };
    for profile in ["MIS", "NEE", "RW"] {
        let o = format!(r#"{{"integrator": {{"profile": "{profile}"}}, "film": {{"resolution": [40, 40]}}}}"#);
        let s = load_scene(&shared.join("refs/scenes/sphere_furnace.json"), &[&o], Profile::Physical);
        let img = render(&s, 64, 3);
        let m = img.mean();
        eprintln!("furnace {profile}: mean {m}");
        assert!((m - rdr::math::Vec3::ONE).abs().max_element() < 3e-3, "{profile}: {m}");
        let worst = img.pixels.iter().map(|p| (p.x - 1.0).abs()).fold(0.0f32, f32::max);
        assert!(worst < 0.35, "{profile}: every pixel is 1 within noise, worst {worst}");
    }
}

#[test]
fn cbox_converges_and_double_counted_emission_fails() {
    let Some(shared) = shared() else { return };
    let reference = reference(&shared, "cbox", None);
    let (a, b, _) = half_res(&shared, "cbox_path", 32, &[]);
    let good = check("cbox MIS", (&a, &b), &reference, None);
    assert!(converges(&good), "{good:?}");
    let (na, nb, _) = half_res(&shared, "cbox_path", 32, &[r#"{"integrator": {"profile": "NEE"}}"#]);
    let nee = check("cbox NEE", (&na, &nb), &reference, None);
    assert!(converges(&nee), "{nee:?}");
    // MIS weights that sum to two instead of one: every light path counted by both
    // strategies = NEE + random walk − what both see directly (max_depth 1)
    let (ra, rb, _) = half_res(&shared, "cbox_path", 32, &[r#"{"integrator": {"profile": "RW"}}"#]);
    let (da, db, _) = half_res(&shared, "cbox_path", 4, &[r#"{"integrator": {"max_depth": 1}}"#]);
    let combine = |n: &Image, r: &Image, d: &Image| {
        Image::new(
            n.width,
            n.height,
            (0..n.pixels.len()).map(|i| n.pixels[i] + r.pixels[i] - d.pixels[i]).collect(),
        )
    };
    let bad = check(
        "cbox weights sum to 2",
        (&combine(&na, &ra, &da), &combine(&nb, &rb, &db)),
        &reference,
        None,
    );
    assert!(fails(&bad, &good), "{bad:?}");
}

#[test]
fn two_spheres_converges() {
    let Some(shared) = shared() else { return };
    let reference = reference(&shared, "two_spheres", None);
    let (a, b, _) = half_res(&shared, "two_spheres_path", 16, &[]);
    let good = check("two_spheres", (&a, &b), &reference, None);
    assert!(converges(&good), "{good:?}");
    let m = (a.mean() + b.mean()) * 0.5;
    assert!(
        (m.x - 0.27658).abs() < 2e-3,
        "the RDR171 integration test's mean 0.27657896 ± 2e-3: {m}"
    );
}

#[test]
fn veach_converges_outside_the_glossy_band() {
    let Some(shared) = shared() else { return };
    let mask = Some((194, 222)); // rows 195–220, widened to whole 2×2 blocks
    let reference = reference(&shared, "veach", mask);
    let (a, b, _) = half_res(&shared, "veach_path", 16, &[]);
    let good = check("veach", (&a, &b), &reference, mask);
    // veach's variance file is a lower bound (heavy tails): a looser bias bound
    assert!(good.rel_mse_corrected.abs() < 5.0 * good.std_error + 3e-3, "{good:?}");
    // the wrong microfacet distribution (GGX instead of Beckmann) must fail
    let (ga, gb, _) = half_res(
        &shared,
        "veach_path",
        16,
        &[
            r#"{"materials": {"glossy": {"distribution": "ggx"}, "rough": {"distribution": "ggx"}, "superrough": {"distribution": "ggx"}, "smooth": {"distribution": "ggx"}}}"#,
        ],
    );
    let ggx = check("veach with GGX", (&ga, &gb), &reference, mask);
    assert!(
        ggx.rel_mse_corrected > good.rel_mse_corrected.abs() + 5.0 * (ggx.std_error + good.std_error),
        "{ggx:?}"
    );
}

#[test]
fn glass_sphere_converges_and_ignoring_fresnel_fails() {
    let Some(shared) = shared() else { return };
    let reference = reference(&shared, "glass_sphere", None);
    let (a, b, _) = half_res(&shared, "glass_sphere", 32, &[]);
    let good = check("glass_sphere", (&a, &b), &reference, None);
    assert!(converges(&good), "{good:?}");
    // a renderer that ignores Fresnel: all light refracts (the perfect refractor)
    let (fa, fb, _) = half_res(
        &shared,
        "glass_sphere",
        32,
        &[r#"{"materials": {"glass": {"type": "refraction", "eta": 1.8}}}"#],
    );
    let bad = check("glass without Fresnel", (&fa, &fb), &reference, None);
    assert!(fails(&bad, &good), "{bad:?}");
}

#[test]
fn env_sphere_path_traced_converges() {
    let Some(shared) = shared() else { return };
    let reference = reference(&shared, "env_sphere", None);
    let (a, b, _) = half_res(&shared, "env_sphere", 16, &[]);
    let good = check("env_sphere", (&a, &b), &reference, None);
    assert!(converges(&good), "{good:?}");
}

#[test]
fn every_course_scene_renders_or_names_its_missing_asset() {
    let Some(shared) = shared() else { return };
    let mut scenes: Vec<_> = std::fs::read_dir(shared.join("scenes/rdr171/data"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 15);
    let tmp = common::temp_dir("rdr-course");
    let out = tmp.path().join("out.exr");
    for scene in scenes {
        let r = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
            .args([
                "render",
                "-q",
                // the course's files carry keys its spec ignores (an object's `path`), which
                // rdr's JSON refuses unless --lenient
                "--lenient",
                "--override",
                r#"{"film": {"resolution": [12, 8]}, "integrator": {"spp": 2}}"#,
                "-o",
            ])
            .arg(&out)
            .arg(&scene)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        let name = scene.file_name().unwrap().to_string_lossy().to_string();
        if r.status.success() {
            continue;
        }
        assert_eq!(r.status.code(), Some(1), "{name}: {err}");
        assert_eq!(err.lines().count(), 1, "{name}: one line: {err}");
        assert!(
            err.contains(&name) && err.contains("No such file"),
            "{name}: the error names a missing asset: {err}"
        );
    }
}
