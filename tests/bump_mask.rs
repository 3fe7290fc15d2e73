//! Surface detail and cut-outs (issue 17): `bumpmap` and `normalmap` scenes read from
//! Mitsuba XML converge to Mitsuba 3's images of them (`tests/refs/bump/`, made by
//! `scripts/make_bump_refs.py` with textures it computes), a leaf-shaped `mask` casts
//! a leaf-shaped shadow (against Mitsuba's `volpath`, whose shadow rays pass through
//! masked surfaces as rdr's do), every integrator passes rays through masks, and the
//! JSON and XML forms of the three materials agree.

mod common;
use common::*;
use rdr::math::Vec3;
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
    assert!(
        converges("mask.xml", &[], 128),
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

/// `mesh_attribute` on a PLY quad with a colour per vertex (uchar) and per face: the
/// image seen straight on is the barycentric interpolation of the vertex colours, and
/// the face colours come back per triangle; the same scene from Mitsuba XML agrees.
#[test]
fn mesh_attribute_interpolates_ply_vertex_colours() {
    let dir = temp_dir("rdr-mesh-attribute");
    // a quad [-1, 1]² at z = 0 facing +z; vertex colours red, green, blue, white
    let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 2\nproperty list uchar int vertex_indices\n\
property float r\nproperty float g\nproperty float b\nend_header\n\
-1 -1 0 255 0 0\n1 -1 0 0 255 0\n1 1 0 0 0 255\n-1 1 0 255 255 255\n3 0 1 2 0.25 0.5 0.75\n3 0 2 3 1 0 0.5\n";
    std::fs::write(dir.path().join("quad.ply"), ply).unwrap();
    let corners = [
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::ONE,
    ];
    let pos = [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    // the expected colour at (x, y) on the quad: barycentrics in triangle (0 1 2) or (0 2 3)
    let expect = |x: f32, y: f32, face: bool| -> Vec3 {
        let tri = if y <= x { [0usize, 1, 2] } else { [0, 2, 3] };
        if face {
            return if tri[1] == 1 {
                Vec3::new(0.25, 0.5, 0.75)
            } else {
                Vec3::new(1.0, 0.0, 0.5)
            };
        }
        let p = |i: usize| glam::Vec2::new(pos[tri[i]].0, pos[tri[i]].1);
        let (a, b, c, q) = (p(0), p(1), p(2), glam::Vec2::new(x, y));
        let area = (b - a).perp_dot(c - a);
        let (l1, l2) = ((q - a).perp_dot(c - a) / area, (b - a).perp_dot(q - a) / area);
        corners[tri[0]] * (1.0 - l1 - l2) + corners[tri[1]] * l1 + corners[tri[2]] * l2
    };
    for (face, name) in [(false, "vertex_color"), (true, "face_color")] {
        // an orthographic-like view: a narrow field of view from far away, white sky, no light:
        // a diffuse of albedo = the attribute under a uniform sky of 1 reflects the albedo
        let xml = format!(
            r#"<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="2"/></integrator>
  <sensor type="perspective"><float name="fov" value="2.29"/>
    <transform name="to_world"><lookat origin="0, 0, 50" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
  </sensor>
  <shape type="ply"><string name="filename" value="quad.ply"/>
    <bsdf type="diffuse"><texture name="reflectance" type="mesh_attribute"><string name="name" value="{name}"/></texture></bsdf>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
</scene>"#
        );
        let f = dir.path().join(format!("{name}.xml"));
        std::fs::write(&f, xml).unwrap();
        let s = load_scene(&f, &[], Profile::Physical);
        let img = render(&s, 64, 1);
        let mut worst = 0.0f32;
        for py in 0..16 {
            for px in 0..16 {
                // pixel centres: the view spans [-1, 1]² (2.29° at 50 units ≈ 2 units)
                let (x, y) = ((px as f32 + 0.5) / 8.0 - 1.0, 1.0 - (py as f32 + 0.5) / 8.0);
                if (x - y).abs() < 0.2 || x.abs() > 0.85 || y.abs() > 0.85 {
                    continue; // pixels straddling the diagonal or the border
                }
                let got = img.pixels[py * 16 + px];
                worst = worst.max((got - expect(x, y, face)).abs().max_element());
            }
        }
        eprintln!("{name}: largest difference from the interpolated colours {worst:.3}");
        assert!(worst < 0.06, "{name}: the quad's colours are not the {name} ones (off by {worst})");
    }
}

/// Two fractional masks (opacity 0.5, and a grey ramp from 0 to 1) cast a half and a
/// graded shadow: the scene converges to Mitsuba's `volpath` image, whose shadow rays
/// carry 1 − α through each masked surface.
#[test]
fn fractional_masks_cast_graded_shadows_as_mitsubas_volpath() {
    assert!(
        converges("mask_half.xml", &[], 128),
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
