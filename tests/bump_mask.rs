//! Surface detail and cut-outs (issue 17): `bumpmap` and `normalmap` scenes read from
//! Mitsuba XML converge to Mitsuba 3's images of them (`tests/refs/bump/`, made by
//! `scripts/make_bump_refs.py` with textures it computes), a leaf-shaped `mask` casts
//! a leaf-shaped shadow (against Mitsuba's `volpath`, whose shadow rays pass through
//! masked surfaces as rdr's do), every integrator passes rays through masks, and the
//! JSON and XML forms of the three materials agree.

mod common;
use common::*;
use rdr::metrics::compare;
use rdr::Profile;
use std::path::{Path, PathBuf};

fn refs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/bump")
}

/// Whether `file` (in tests/refs/bump) rendered at `spp` converges to `<name>.exr`;
/// prints the comparison.
fn converges(file: &str, overrides: &[&str], spp: u32) -> bool {
    let dir = refs();
    let name = file.split('.').next().unwrap();
    let s = load_scene(&dir.join(file), overrides, Profile::Physical);
    let (a, b) = (render(&s, spp, 1), render(&s, spp, 2));
    let r = read(&dir.join(format!("{name}.exr")));
    let vr = read(&dir.join(format!("{name}.var.exr")));
    let c = compare(&a, &b, &r, &vr);
    eprintln!(
        "{file:>14} {overrides:?}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
        c.rel_mse_corrected, c.std_error, c.rel_mse_raw, c.rel_mse_noise
    );
    c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4
}

#[test]
fn bump_and_normal_maps_converge_to_mitsubas_images() {
    let failed: Vec<&str> = ["bumpmap.xml", "normalmap.xml"]
        .into_iter()
        .filter(|f| !converges(f, &[], 128))
        .collect();
    assert!(failed.is_empty(), "not converging to Mitsuba: {failed:?}");
}

#[test]
fn a_masked_leaf_casts_a_leaf_shaped_shadow() {
    assert!(converges("mask.xml", &[], 128), "the masked leaf and its shadow differ from Mitsuba's volpath");
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
    a.pixels.iter().zip(&b.pixels).map(|(x, y)| (*x - *y).abs().element_sum() as f64).sum::<f64>() / n
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
            let text = std::fs::read_to_string(&f).unwrap().replace(r#""material_name": "occ""#, r#""material_name": "red""#);
            std::fs::write(&f, text).unwrap();
            render(&load_scene(&f, &[], Profile::Physical), 8, 1)
        });
        let (d_clear, d_quad, d_opaque) = (mean_abs_diff(&clear, &none), mean_abs_diff(&solid, &none), mean_abs_diff(&opaque, &solid));
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
