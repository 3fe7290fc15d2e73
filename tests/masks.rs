//! Cut-outs (issue 17): a leaf-shaped `mask` casts a leaf-shaped shadow and fractional
//! masks graded ones (against Mitsuba's `volpath`, whose shadow rays pass through masked
//! surfaces as rdr's do; references in `tests/refs/bump/`, made by
//! `scripts/make_bump_refs.py`), every integrator passes rays through masks and weights
//! shadow rays through fractional ones, and `--compat rdr171` refuses them.

mod common;
use common::*;
use rdr::math::Vec3;
use rdr::Profile;
use std::path::{Path, PathBuf};

fn refs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/bump")
}

#[test]
fn a_masked_leaf_casts_a_leaf_shaped_shadow() {
    assert!(
        converges_to_ref_beside("bump", "mask.xml", &[], 128),
        "the masked leaf and its shadow differ from Mitsuba's volpath"
    );
}

const QUAD_OBJ: &str = "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";

/// A floor, a small spherical light above it and, unless `occluder` is `None`, a quad
/// between them whose material is a `mask` of that opacity around a red diffuse.
fn mask_scene(dir: &Path, integrator: &str, occluder: Option<f32>) -> PathBuf {
    let mut objects = vec![
        r#"{"type": "mesh", "path": "quad.obj", "material_name": "floor",
            "transform": [6,0,0,0, 0,6,0,0, 0,0,6,0, 0,0,0,1]}"#
            .to_string(),
        r#"{"type": "sphere", "center": [0, 0, 3], "radius": 0.3, "light": {"type": "area", "radiance": [60, 60, 60]}}"#.to_string(),
    ];
    if occluder.is_some() {
        objects.push(
            r#"{"type": "mesh", "path": "quad.obj", "material_name": "occ",
                "transform": [1.5,0,0,0.3, 0,1.3,-0.75,0, 0,0.75,1.3,1, 0,0,0,1]}"#
                .to_string(),
        );
    }
    let scene = format!(
        r#"{{
  "integrator": {integrator},
  "film": {{"resolution": [24, 24]}},
  "camera": {{"position": [0, -4, 4], "look_at": [0, 0, 0.5], "ref_up": [0, 0, 1], "fov": 45, "focal_length": 1}},
  "textures": {{"white": {{"type": "constant", "color": [0.8, 0.8, 0.8]}}, "red": {{"type": "constant", "color": [0.8, 0.1, 0.1]}}}},
  "materials": {{
    "floor": {{"type": "diffuse", "texture_name": "white"}},
    "red": {{"type": "diffuse", "texture_name": "red", "twosided": true}},
    "occ": {{"type": "mask", "material_name": "red", "opacity": {}}}
  }},
  "objects": [{}]
}}"#,
        occluder.unwrap_or(1.0),
        objects.join(",\n")
    );
    let file = dir.join(format!("scene_{}.json", occluder.map_or("none".into(), |o| o.to_string())));
    std::fs::write(dir.join("quad.obj"), QUAD_OBJ).unwrap();
    std::fs::write(&file, scene).unwrap();
    file
}

fn mean_abs_diff(a: &rdr::metrics::Image, b: &rdr::metrics::Image) -> f64 {
    let n = a.pixels.len() as f64;
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(x, y)| (*x - *y).abs().element_sum() as f64)
        .sum::<f64>()
        / n
}

/// Every integrator passes rays through a fully transparent mask (the image is that
/// of the scene without the quad) and stops at an opaque one (the image with it).
#[test]
fn every_integrator_passes_rays_through_masks() {
    let dir = temp_dir("rdr-mask");
    let integrators = [
        r#"{"type": "path", "lights": [], "max_depth": 6}"#,
        r#"{"type": "guided", "lights": [], "max_depth": 6}"#,
        r#"{"type": "bdpt", "lights": [], "max_depth": 6}"#,
        r#"{"type": "ptracer", "lights": [], "max_depth": 6}"#,
        r#"{"type": "photon", "lights": [], "n_photons": 5000, "n_iterations": 1}"#,
        r#"{"type": "sppm", "lights": [], "photons_per_iteration": 5000}"#,
        r#"{"type": "intersection_test", "lights": [], "max_depth": 4}"#,
        r#"{"type": "normals", "lights": []}"#,
    ];
    let mut failed = Vec::new();
    for integrator in integrators {
        let ty = integrator.split('"').nth(3).unwrap();
        let img = |o: Option<f32>| {
            let s = load_scene(&mask_scene(dir.path(), integrator, o), &[], Profile::Physical);
            render(&s, 8, 1)
        };
        let (none, clear, opaque, solid) = (img(None), img(Some(0.0)), img(Some(1.0)), {
            // the same quad with its red diffuse unmasked
            let f = mask_scene(dir.path(), integrator, Some(1.0));
            let text = std::fs::read_to_string(&f)
                .unwrap()
                .replace(r#""material_name": "occ""#, r#""material_name": "red""#);
            std::fs::write(&f, text).unwrap();
            render(&load_scene(&f, &[], Profile::Physical), 8, 1)
        });
        let (d_clear, d_quad, d_opaque) = (
            mean_abs_diff(&clear, &none),
            mean_abs_diff(&solid, &none),
            mean_abs_diff(&opaque, &solid),
        );
        eprintln!("{ty:>18}: |clear − none| {d_clear:.2e}, |opaque − unmasked| {d_opaque:.2e}, |unmasked − none| {d_quad:.2e}");
        if !(d_clear < 0.02 * d_quad && d_opaque < 0.02 * d_quad) {
            failed.push(ty);
        }
    }
    assert!(failed.is_empty(), "masks not honoured by {failed:?}");
}

/// `--compat rdr171` (the course renderer's own intersection) refuses masks, naming the material.
#[test]
fn compat_rdr171_refuses_masks() {
    let dir = temp_dir("rdr-mask-compat");
    let f = mask_scene(dir.path(), r#"{"type": "intersection_test", "lights": []}"#, Some(0.5));
    let e = rdr::load(&f, &[], Profile::Rdr171).err().expect("refused").to_string();
    assert!(e.contains("materials.occ") && e.contains("mask"), "{e}");
}

/// Two fractional masks (opacity 0.5, and a grey ramp from 0 to 1) cast a half and a
/// graded shadow: the scene converges to Mitsuba's `volpath` image, whose shadow rays
/// carry 1 − α through each masked surface.
#[test]
fn fractional_masks_cast_graded_shadows_as_mitsubas_volpath() {
    assert!(
        converges_to_ref_beside("bump", "mask_half.xml", &[], 128),
        "the fractional masks' shadows differ from Mitsuba's volpath"
    );
}

/// `Scene::transmittance` along shadow rays from the floor of `mask_half.xml` to its
/// light: 1 − 0.5 through the half-opaque quad, 1 − ramp(u) through the graded one,
/// their product through both, 1 beside them and 0 into the floor — weights, not a
/// random 0 or 1.
#[test]
fn shadow_rays_through_fractional_masks_are_weighted() {
    let s = load_scene(&refs().join("mask_half.xml"), &[], Profile::Physical);
    let light = Vec3::new(0.0, 3.5, 0.0); // below the light sphere
    let tr = |from: Vec3, to: Vec3| {
        let d = to - from;
        let ray = rdr::geometry::Ray::with_range(from, d.normalize(), 1e-4, d.length() * (1.0 - 1e-4));
        s.scene.transmittance(&ray)
    };
    let up = |x: f32, z: f32| tr(Vec3::new(x, 1e-3, z), Vec3::new(x, 2.0, z));
    let mut bad = Vec::new();
    let mut check = |what: String, got: f32, want: f32, tol: f32| {
        eprintln!("{what:>40}: transmittance {got:.4} (expected {want:.4})");
        if (got - want).abs() > tol {
            bad.push(what);
        }
    };
    check(
        "half quad, towards the light".into(),
        tr(Vec3::new(-0.65, 1e-3, 0.2), light),
        0.5,
        1e-6,
    );
    for x in [-1.0f32, -0.8, -0.3] {
        check(format!("half quad, straight up at x = {x}"), up(x, 0.3), 0.5, 1e-6);
    }
    // the ramp's opacity is its u: x from 0.15 to 1.15 (texel centres, bilinear)
    for x in [0.3f32, 0.55, 0.8, 1.05] {
        let u = (x - 0.15) / 1.0;
        check(format!("ramp quad, straight up at x = {x}"), up(x, 0.3), 1.0 - u, 0.02);
    }
    check("beside the quads".into(), up(0.0, 1.5), 1.0, 0.0);
    check(
        "into the floor".into(),
        tr(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, -1.0, 0.0)),
        0.0,
        0.0,
    );
    assert!(bad.is_empty(), "wrong transmittance: {bad:?}");
}

/// A floor lit through a quad whose mask wraps a black diffuse, the quad out of the
/// camera's view: every path crosses the quad at most once, so the image at opacity
/// 0.5 is the mean of the images at 0 and 1. With the same seed that holds sample by
/// sample where shadow rays and connections are weighted by 1 − α (a random 0 or 1
/// per shadow ray leaves the difference at about half the 0-to-1 difference), in
/// every integrator. The light tracer's light paths reach the floor without crossing
/// (they pass masks at random, as Mitsuba's do); for it the quad stands between the
/// camera and the floor instead, where its connections to the camera cross it.
#[test]
fn every_integrator_weights_shadow_rays_through_fractional_masks() {
    let dir = temp_dir("rdr-mask-half");
    std::fs::write(dir.path().join("quad.obj"), QUAD_OBJ).unwrap();
    let scene = |integrator: &str, opacity: f32| {
        // above the floor, under the light; or (ptracer) upright between camera and floor
        let quad = if integrator.contains("ptracer") {
            "[3,0,0,0, 0,0,-1,-2.5, 0,2,0,1, 0,0,0,1]"
        } else {
            "[1.2,0,0,0.2, 0,1.2,0,0, 0,0,1,2, 0,0,0,1]"
        };
        let text = format!(
            r#"{{
  "integrator": {integrator},
  "film": {{"resolution": [24, 24]}},
  "camera": {{"position": [0, -3, 1], "look_at": [0, 0, 0], "ref_up": [0, 0, 1], "fov": 45}},
  "textures": {{"white": {{"type": "constant", "color": [0.8, 0.8, 0.8]}}, "black": {{"type": "constant", "color": [0, 0, 0]}}}},
  "materials": {{
    "floor": {{"type": "diffuse", "texture_name": "white"}},
    "black": {{"type": "diffuse", "texture_name": "black", "twosided": true}},
    "occ": {{"type": "mask", "material_name": "black", "opacity": {opacity}}}
  }},
  "objects": [
    {{"type": "mesh", "path": "quad.obj", "material_name": "floor", "transform": [6,0,0,0, 0,6,0,0, 0,0,6,0, 0,0,0,1]}},
    {{"type": "sphere", "center": [0, 0, 3], "radius": 0.3, "light": {{"type": "area", "radiance": [60, 60, 60]}}}},
    {{"type": "mesh", "path": "quad.obj", "material_name": "occ", "transform": {quad}}}
  ]
}}"#
        );
        let f = dir.path().join(format!("half_{opacity}.json"));
        std::fs::write(&f, text).unwrap();
        render(&load_scene(&f, &[], Profile::Physical), 8, 1)
    };
    let integrators = [
        r#"{"type": "path", "lights": [], "max_depth": 4, "profile": "NEE"}"#,
        r#"{"type": "path", "lights": [], "max_depth": 4}"#,
        r#"{"type": "guided", "lights": [], "max_depth": 4}"#,
        r#"{"type": "bdpt", "lights": [], "max_depth": 4}"#,
        r#"{"type": "ptracer", "lights": [], "max_depth": 4}"#,
        r#"{"type": "photon", "lights": [], "n_photons": 5000, "n_iterations": 1}"#,
        r#"{"type": "sppm", "lights": [], "photons_per_iteration": 5000}"#,
        r#"{"type": "intersection_test", "lights": [], "max_depth": 4}"#,
    ];
    let mut failed = Vec::new();
    for integrator in integrators {
        let ty = integrator.split('"').nth(3).unwrap();
        let (clear, half, opaque) = (scene(integrator, 0.0), scene(integrator, 0.5), scene(integrator, 1.0));
        let mut mean = clear.clone();
        for (m, o) in mean.pixels.iter_mut().zip(&opaque.pixels) {
            *m = (*m + *o) * 0.5;
        }
        let (d_half, d_full) = (mean_abs_diff(&half, &mean), mean_abs_diff(&clear, &opaque));
        eprintln!(
            "{ty:>18}: |half − mean(clear, opaque)| {d_half:.2e}, |clear − opaque| {d_full:.2e}, ratio {:.3}",
            d_half / d_full
        );
        if !(d_full > 0.0 && d_half < 0.08 * d_full) {
            failed.push(ty);
        }
    }
    assert!(failed.is_empty(), "shadow rays through fractional masks not weighted by {failed:?}");
}
