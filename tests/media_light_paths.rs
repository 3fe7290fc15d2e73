//! Media in the integrators that trace light paths, `ptracer` and `bdpt`: both converge
//! to `path` on a slab of chromatic fog (an opaque sphere in it, a light above it and
//! one inside it), `bdpt` also when the fog glows (an emissive medium, which `ptracer`
//! refuses), and `bdpt`'s MIS self-check holds on paths with medium vertices.
//! (fog_cbox against Mitsuba's reference is in `tests/media.rs`.)

mod common;
use common::*;
use rdr::math::Vec3;
use rdr::metrics::{compare, Image};
use rdr::Profile;
use std::path::Path;

/// A slab y ∈ [0, 0.6] of chromatic, forward-scattering fog behind `null` boundaries
/// on a diffuse floor, an opaque sphere half in it; a spherical light above it and a
/// small one inside it (a light subpath starting in the fog). `glow`: the fog is a
/// heterogeneous one (a 4³ grid, σt from 0.4 to 2 under a majorant of 3, so delta
/// tracking makes null collisions) that emits radiance (4, 2, 1) (σa·Le per unit length).
fn fog_slab(dir: &Path, integrator: &str, glow: bool) -> rdr::Loaded {
    let cube = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/media/box.obj");
    let medium = if glow {
        let values = (0..64).map(|i| 0.2 + (i % 5) as f32 * 0.2).collect();
        let bbox = rdr::geometry::Aabb::new(Vec3::ZERO, Vec3::ONE);
        let grid = rdr::volume::GridData::new([4, 4, 4], 1, bbox, values).unwrap();
        std::fs::write(dir.join("glow.vol"), rdr::volume::vol_file::encode(&grid)).unwrap();
        r#"{"type": "heterogeneous", "scale": 2, "albedo": [0.9, 0.7, 0.4], "radiance": [4, 2, 1],
    "sigma_t": {"type": "gridvolume", "filename": "glow.vol", "max_value": 1.5,
      "to_world": [3, 0, 0, -1.5, 0, 0.6, 0, 0, 0, 0, 3, -1.5, 0, 0, 0, 1]},
    "phase": {"type": "hg", "g": 0.5}}"#
    } else {
        r#"{"type": "homogeneous", "sigma_t": [0.6, 1.5, 3], "albedo": [0.9, 0.7, 0.4],
    "phase": {"type": "hg", "g": 0.5}}"#
    };
    let json = format!(
        r#"{{
  "integrator": {{"type": "{integrator}", "max_depth": 8}},
  "film": {{"resolution": [24, 24], "filter": {{"type": "box", "radius": 0.5}}}},
  "camera": {{"position": [0, 1.6, 3.5], "look_at": [0, 0.3, 0], "fov": 45}},
  "textures": {{"grey": {{"type": "constant", "color": [0.6, 0.6, 0.6]}}}},
  "materials": {{"grey": {{"type": "diffuse", "texture_name": "grey"}}}},
  "media": {{"fog": {medium}}},
  "objects": [
    {{"type": "sphere", "center": [0, -100, 0], "radius": 100, "material_name": "grey"}},
    {{"type": "sphere", "center": [0.3, 0.35, 0], "radius": 0.35, "material_name": "grey"}},
    {{"type": "sphere", "center": [0.6, 2.2, 0.6], "radius": 0.3, "light": {{"type": "area", "radiance": [12, 12, 12]}}}},
    {{"type": "sphere", "center": [-0.7, 0.25, 0.4], "radius": 0.08, "light": {{"type": "area", "radiance": [20, 20, 20]}}}},
    {{"type": "mesh", "path": "{}", "null_bsdf": true, "interior": "fog",
     "transform": [1.5, 0, 0, 0, 0, 0.3, 0, 0.3, 0, 0, 1.5, 0, 0, 0, 0, 1]}}
  ]
}}"#,
        cube.display()
    );
    let path = dir.join(format!("slab_{integrator}_{glow}.json"));
    std::fs::write(&path, json).unwrap();
    load_scene(&path, &[], Profile::Physical)
}

/// The mean and the variance of the mean per pixel of `n` renders (seeds 11…).
fn reference(loaded: &rdr::Loaded, spp: u32, n: u32) -> (Image, Image) {
    let renders: Vec<Image> = (0..n).map(|i| render(loaded, spp, 11 + i)).collect();
    let mut mean = renders[0].clone();
    let mut var = renders[0].clone();
    for p in 0..mean.pixels.len() {
        let m = renders.iter().map(|r| r.pixels[p]).sum::<Vec3>() / n as f32;
        let v = renders.iter().map(|r| (r.pixels[p] - m) * (r.pixels[p] - m)).sum::<Vec3>() / (n - 1) as f32;
        (mean.pixels[p], var.pixels[p]) = (m, v / n as f32);
    }
    (mean, var)
}

/// Asserts that each of `integrators` converges to `path` on the fog slab (`glow`: the
/// glowing one): noise-aware relative MSE (24×24, path 4 × 256 spp, the others 2 × 256)
/// below 5 standard errors + 2e-4; the share of that bound each used is printed.
fn assert_converge_to_path(integrators: &[&str], glow: bool) {
    let dir = temp_dir("rdr-media-light-paths");
    let (r, vr) = reference(&fog_slab(dir.path(), "path", glow), 256, 4);
    for integrator in integrators {
        let s = fog_slab(dir.path(), integrator, glow);
        let (a, b) = (render(&s, 256, 1), render(&s, 256, 2));
        let c = compare(&a, &b, &r, &vr);
        let diff = (a.mean() + b.mean()) * 0.5 - r.mean();
        let bound = 5.0 * c.std_error + 2e-4;
        eprintln!(
            "{integrator:>8} (glow {glow}): relMSE corrected {:+.2e} ± {:.1e} ({:.2} of the bound; raw {:.2e}, noise {:.2e}); mean − path's {diff:.4} (path {:.4})",
            c.rel_mse_corrected,
            c.std_error,
            c.rel_mse_corrected.abs() / bound,
            c.rel_mse_raw,
            c.rel_mse_noise,
            r.mean()
        );
        assert!(
            c.rel_mse_corrected.abs() < bound,
            "{integrator} does not converge to path in the fog slab (glow {glow}): {c:?}"
        );
    }
}

/// `ptracer` and `bdpt` against `path` on the fog slab. Measured: see the report in
/// the commit; a deliberate error must give more than 3× the margin.
#[test]
fn ptracer_and_bdpt_converge_to_path_in_a_chromatic_fog_slab() {
    assert_converge_to_path(&["ptracer", "bdpt"], false);
}

/// `bdpt` against `path` on the glowing fog slab: the medium's light, found by the
/// camera subpaths alone (weight 1), as `path` finds it. Deliberate errors (emission
/// only at real collisions; not divided by the collision's density): see the commit.
#[test]
fn bdpt_converges_to_path_in_a_glowing_fog_slab() {
    assert_converge_to_path(&["bdpt"], true);
}

/// The MIS self-check on paths through media: weights sum to 1 and the densities the
/// subpaths cache (medium vertices' without a cosine) are those of the path's geometry.
#[test]
fn mis_weights_sum_to_one_on_paths_with_medium_vertices() {
    let dir = temp_dir("rdr-media-mis");
    let s = fog_slab(dir.path(), "bdpt", false);
    let f = &s.job.film;
    let c = rdr::integrator::bdpt::mis_self_check(&s.scene, &s.job.camera, f.width, f.height, 6, 3000);
    eprintln!("fog slab: {c:?}");
    assert!(c.medium_paths > 1000, "{c:?}");
    assert!(c.max_sum_error < 1e-4, "{c:?}");
    assert!(c.samples_off <= 60, "{c:?}");
}

/// Light emitted by media is found by camera paths only: `ptracer` (a light tracer)
/// refuses an emissive medium in one line instead of rendering it dark; `bdpt` and
/// `path` render it.
#[test]
fn ptracer_refuses_emissive_media() {
    let dir = tempfile::tempdir().unwrap();
    let cube = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/media/box.obj");
    for integrator in ["ptracer", "bdpt", "path"] {
        let json = format!(
            r#"{{"integrator": {{"type": "{integrator}"}}, "film": {{"resolution": [8, 8]}},
  "camera": {{"position": [0, 0, 3], "look_at": [0, 0, 0], "fov": 45}},
  "media": {{"glow": {{"type": "homogeneous", "sigma_t": 1, "albedo": 0.5, "radiance": [1, 1, 1]}}}},
  "objects": [{{"type": "mesh", "path": "{}", "null_bsdf": true, "interior": "glow"}}]}}"#,
            cube.display()
        );
        let path = dir.path().join(format!("glow_{integrator}.json"));
        std::fs::write(&path, json).unwrap();
        let desc = rdr::desc::SceneDesc::load(&path, &[]).unwrap_or_else(|e| panic!("{e}"));
        match rdr::Loaded::build(&desc, Profile::Physical) {
            Ok(_) => assert_ne!(integrator, "ptracer", "ptracer accepted an emissive medium"),
            Err(e) => {
                assert_eq!(integrator, "ptracer", "{integrator} refused an emissive medium: {e}");
                assert!(e.to_string().contains("does not render emissive media"), "{integrator}: {e}");
            }
        }
    }
}
