//! Textured emitters (issue 17, item 5): Mitsuba's `spot` with a `texture`, the
//! `projector`, and `area` lights whose `radiance` is a texture. rdr's `path` (from the
//! XML and from its JSON twin) converges to Mitsuba 3's image of the same scene
//! (`tests/refs/emitters/`, made by `scripts/make_emitter_refs.py`) under the
//! noise-aware relative MSE of the other reference tests; the integrators that trace from
//! the lights (`bdpt`, `ptracer`, `photon`, `sppm`) converge to the same images, so their
//! emission sampling is right; `guided` and `intersection_test` take them; bad input
//! fails with the key named; `rdr convert` carries them both ways; `--compat rdr171` refuses them in one line.

mod common;
use common::*;
use rdr::Profile;
use std::path::{Path, PathBuf};

fn refs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/emitters")
}

fn converges_with(file: &Path, reference: &str, overrides: &[&str], spp: u32) -> bool {
    converges_to_ref(&refs(), file, reference, overrides, spp)
}

const NAMES: [&str; 3] = ["spot_texture", "projector", "area_texture"];

#[test]
fn path_converges_to_mitsubas_images() {
    let mut failed = Vec::new();
    for name in NAMES {
        for ext in ["xml", "json"] {
            let file = refs().join(format!("{name}.{ext}"));
            if !converges_with(&file, name, &[], 256) {
                failed.push(format!("{name}.{ext}"));
            }
        }
    }
    assert!(failed.is_empty(), "not converging to Mitsuba: {failed:?}");
}

/// The integrators that start paths at the lights sample emission from each textured
/// emitter (the cone of the spot, the projector's image by its table, the quad by area
/// with cosine directions): each converges to Mitsuba's image.
#[test]
fn light_tracing_integrators_converge() {
    let mut failed = Vec::new();
    for name in NAMES {
        let file = refs().join(format!("{name}.json"));
        for (integrator, spp) in [
            (r#"{"integrator": {"type": "bdpt"}}"#, 64),
            (r#"{"integrator": {"type": "ptracer"}}"#, 512),
            (r#"{"integrator": {"type": "photon", "n_photons": 100000, "n_iterations": 4}}"#, 16),
            (r#"{"integrator": {"type": "sppm", "photons_per_iteration": 5000}}"#, 64),
        ] {
            if !converges_with(&file, name, &[integrator], spp) {
                failed.push(format!("{name}: {integrator}"));
            }
        }
    }
    assert!(failed.is_empty(), "not converging to Mitsuba: {failed:?}");
}

/// bdpt's MIS weights over paths from the textured emitters sum to 1, and the densities
/// its connections assemble equal those recomputed from the vertices (the projector's
/// tabulated direction density included).
#[test]
fn bdpt_mis_weights_sum_to_one() {
    for name in NAMES {
        assert_bdpt_mis_sums_to_one(&refs().join(format!("{name}.json")));
    }
}

/// `guided` and `intersection_test` (and `direct` from the XML) take them.
#[test]
fn other_integrators_take_them() {
    for name in NAMES {
        let file = refs().join(format!("{name}.json"));
        for ty in ["guided", "intersection_test"] {
            let o = format!("{{\"integrator\": {{\"type\": \"{ty}\", \"spp\": 2}}}}");
            let s = load_scene(&file, &[&o], Profile::Physical);
            let mean = render(&s, 2, 1).mean();
            assert!(mean.min_element() > 0.005 && mean.is_finite(), "{name} under {ty}: mean {mean}");
        }
    }
}

/// A scene of textured area lights on each shape rdr has (a mesh with uv, a sphere, a
/// cylinder) with a checkerboard radiance, written to `dir`.
fn write_area_shapes(dir: &Path) -> PathBuf {
    std::fs::write(dir.join("quad.obj"), std::fs::read(refs().join("quad.obj")).unwrap()).unwrap();
    let scene = r#"{
  "integrator": {"type": "path", "spp": 1, "lights": []},
  "film": {"resolution": [8, 8]},
  "camera": {"position": [0, 0, -6], "look_at": [0, 0, 0], "ref_up": [0, 1, 0], "fov": 40},
  "textures": {"checks": {"type": "checkerboard", "color0": [1, 2, 3], "color1": [0.2, 0.1, 0.05],
                          "tex_coordinate_generator": {"type": "uvmapping2d", "scale": [5, 3]}}},
  "objects": [
    {"type": "mesh", "path": "quad.obj", "light": {"type": "area", "radiance": "checks"}},
    {"type": "sphere", "center": [3, 0, 0], "radius": 0.7, "light": {"radiance": "checks"}},
    {"type": "sphere", "center": [0, 2.2, 1], "radius": 0.6, "uv_frame": [1, 0, 0, 0, 0, -1, 0, 1, 0],
     "light": {"radiance": "checks"}},
    {"type": "cylinder", "p0": [-3, -1, 0], "p1": [-3, 1, 0.5], "radius": 0.6, "light": {"radiance": "checks"}}
  ]
}"#;
    let file = dir.join("shapes.json");
    std::fs::write(&file, scene).unwrap();
    file
}

/// Light sampling and emission sampling look the texture up at the uv a ray hitting the
/// same point sees (meshes, spheres — also in their cone sampling, and with a `uv_frame` — and cylinders), and
/// the emitted power E[L·cos/(pdf_pos·pdf_dir)] is π ∫ L dA, for the area lights and
/// (against their closed forms) for a textured spot and a projector of constant images.
#[test]
fn textured_area_lights_use_the_hit_uv_and_carry_their_power() {
    use rdr::geometry::Ray;
    use rdr::light::{Light, SceneBounds};
    use rdr::math::{Vec2, Vec3};
    let dir = temp_dir("rdr-textured-area");
    let loaded = load_scene(&write_area_shapes(dir.path()), &[], Profile::Physical);
    let scene = &loaded.scene;
    let mut rng = Rng::new(3);
    let mut checked = 0;
    for (li, light) in scene.lights.iter().enumerate() {
        let Light::Area(area) = light else { continue };
        for _ in 0..400 {
            // from points around the scene, also inside the sphere's cone
            let p = Vec3::new(rng.rangef(-5.0, 5.0), rng.rangef(-3.0, 3.0), rng.rangef(-4.0, -1.5));
            let u = Vec2::new(rng.rangef(0.0, 1.0), rng.rangef(0.0, 1.0));
            let Some(ls) = light.sample(p, u, scene.light_sampling) else {
                continue;
            };
            let rdr::light::ShadowTarget::Point { p: q, .. } = ls.target else {
                panic!()
            };
            let d = (q - p).length();
            let Some(hit) = scene.intersect(&Ray::with_range(p, ls.wi, 0.0, d * 1.001)) else {
                continue;
            };
            if (hit.t - d).abs() > 1e-3 * d {
                continue; // another light in front
            }
            let ray = Ray::with_range(p, ls.wi, 0.0, d * 1.001);
            let it = scene.interaction(&ray, &hit);
            assert_eq!(scene.area_light_of(&it).map(|(i, _)| i as usize), Some(li));
            let seen = area.emitted(it.ng, it.wo, it.uv);
            assert!(
                (seen - ls.radiance).abs().max_element() < 1e-4,
                "light {li}: sampled {} vs hit {seen} at {q}",
                ls.radiance
            );
            checked += 1;
        }
        // power: π ∫ L dA from emission samples, against the texture's own integral by area
        let bounds = SceneBounds {
            center: Vec3::ZERO,
            radius: 5.0,
        };
        let (mut est, mut by_area, n) = (Vec3::ZERO, Vec3::ZERO, 100_000);
        for _ in 0..n {
            let u1 = Vec2::new(rng.rangef(0.0, 1.0), rng.rangef(0.0, 1.0));
            let u2 = Vec2::new(rng.rangef(0.0, 1.0), rng.rangef(0.0, 1.0));
            let Some(s) = light.sample_emission(u1, u2, bounds) else { continue };
            est += s.le * s.n.unwrap().dot(s.dir).abs() / (s.pdf_pos * s.pdf_dir);
            by_area += area.radiance_at(s.uv) * (std::f32::consts::PI / s.pdf_pos);
        }
        let (est, by_area) = (est / n as f32, by_area / n as f32);
        assert!(
            (est - by_area).abs().max_element() < 0.03 * by_area.max_element(),
            "light {li}: {est} vs {by_area}"
        );
    }
    assert!(checked > 600, "only {checked} samples checked");

    // a textured spot and a projector with constant images: closed-form powers
    let bounds = SceneBounds {
        center: Vec3::ZERO,
        radius: 5.0,
    };
    let power = |l: &Light| {
        let mut rng = Rng::new(5);
        let mut sum = Vec3::ZERO;
        let n = 200_000;
        for _ in 0..n {
            let u1 = Vec2::new(rng.rangef(0.0, 1.0), rng.rangef(0.0, 1.0));
            let u2 = Vec2::new(rng.rangef(0.0, 1.0), rng.rangef(0.0, 1.0));
            if let Some(s) = l.sample_emission(u1, u2, bounds) {
                sum += s.le / s.pdf_dir;
                let (_, pd) = l.pdf_emission(Vec3::ZERO, s.dir, bounds);
                assert!((pd - s.pdf_dir).abs() <= 1e-3 * s.pdf_dir, "{pd} vs {}", s.pdf_dir);
            }
        }
        sum / n as f32
    };
    let frame = rdr::desc::light_frame(Vec3::new(0.2, -1.0, 0.3), Vec3::Y).unwrap();
    let tex = rdr::texture::Texture::Constant(Vec3::new(0.5, 1.0, 2.0));
    let Light::Projector(pr) = rdr::desc::projector_light(Vec3::ONE, frame, 3.0, 50.0, rdr::light::projector::FovAxis::X).unwrap() else {
        panic!()
    };
    let pr = pr.with_texture(tex.clone());
    let (tx, ty) = (25f32.to_radians().tan(), 25f32.to_radians().tan());
    let expected = Vec3::new(0.5, 1.0, 2.0) * (std::f32::consts::PI * 3.0 * 4.0 * tx * ty);
    let p = power(&Light::Projector(pr));
    assert!(
        (p - expected).abs().max_element() < 0.01 * expected.max_element(),
        "projector: {p} vs {expected}"
    );
    let Light::TexturedSpot(mut sp) = rdr::desc::textured_spot(Vec3::ONE, frame, Vec3::splat(3.0), 25.0, Some(10.0)).unwrap() else {
        panic!()
    };
    sp.texture = tex;
    let (tb, tc) = (10f32.to_radians(), 25f32.to_radians());
    let cone = 2.0 * std::f32::consts::PI * 3.0 * ((1.0 - tb.cos()) + ((tc - tb) * tb.cos() + tb.sin() - tc.sin()) / (tc - tb));
    let expected = Vec3::new(0.5, 1.0, 2.0) * cone;
    let p = power(&Light::TexturedSpot(sp));
    assert!(
        (p - expected).abs().max_element() < 0.01 * expected.max_element(),
        "textured spot: {p} vs {expected}"
    );
}

/// JSON bad input: each fails to load with one line naming the file and the key.
#[test]
fn bad_json_names_the_key() {
    let dir = temp_dir("rdr-textured-bad-json");
    let d = dir.path();
    let base: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(refs().join("spot_texture.json")).unwrap()).unwrap();
    let spot = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut v = base.clone();
        edit(&mut v["integrator"]["lights"][0]);
        v
    };
    let projector = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut v = base.clone();
        v["integrator"]["lights"][0] = serde_json::json!({"type": "projector", "position": [0, 3, 0], "look_at": [0, 0, 0],
            "ref_up": [0, 0, 1], "irradiance": "image", "fov": 40});
        edit(&mut v["integrator"]["lights"][0]);
        v
    };
    let area = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut v = base.clone();
        v["integrator"]["lights"] = serde_json::json!([]);
        v["objects"][1]["light"] = serde_json::json!({"type": "area", "radiance": "image"});
        edit(&mut v["objects"][1]["light"]);
        v
    };
    use serde_json::json;
    // (case, scene, words the one-line error must hold)
    let cases: Vec<(&str, serde_json::Value, Vec<&str>)> = vec![
        (
            "spot texture unknown",
            spot(&|l| l["texture"] = json!("nope")),
            vec!["integrator.lights[0].texture", "no texture named 'nope'"],
        ),
        (
            "spot texture a number",
            spot(&|l| l["texture"] = json!(3)),
            vec!["integrator.lights[0].texture", "expected a string"],
        ),
        (
            "spot texture wide cutoff",
            spot(&|l| l["cutoff_angle"] = json!(95)),
            vec!["integrator.lights[0].cutoff_angle", "below 90"],
        ),
        (
            "spot up along the axis",
            spot(&|l| l["ref_up"] = json!([0, 1, 0.05])),
            vec!["integrator.lights[0].ref_up", "parallel"],
        ),
        (
            "spot up a string",
            spot(&|l| l["ref_up"] = json!("up")),
            vec!["integrator.lights[0].ref_up"],
        ),
        (
            "projector irradiance missing",
            projector(&|l| {
                l.as_object_mut().unwrap().remove("irradiance");
            }),
            vec!["integrator.lights[0].irradiance", "required"],
        ),
        (
            "projector irradiance a bool",
            projector(&|l| l["irradiance"] = json!(true)),
            vec!["integrator.lights[0].irradiance", "expected a number, [r, g, b] or a texture name"],
        ),
        (
            "projector irradiance unknown",
            projector(&|l| l["irradiance"] = json!("nope")),
            vec!["integrator.lights[0]", "no texture named 'nope'"],
        ),
        (
            "projector fov 180",
            projector(&|l| l["fov"] = json!(180)),
            vec!["integrator.lights[0].fov", "between 0 and 180"],
        ),
        (
            "projector fov a string",
            projector(&|l| l["fov"] = json!("wide")),
            vec!["integrator.lights[0].fov"],
        ),
        (
            "projector fov_axis unknown",
            projector(&|l| l["fov_axis"] = json!("z")),
            vec!["integrator.lights[0].fov_axis", "unknown axis 'z'"],
        ),
        (
            "projector negative scale",
            projector(&|l| l["scale"] = json!(-1)),
            vec!["integrator.lights[0].scale", "must not be negative"],
        ),
        (
            "projector position missing",
            projector(&|l| {
                l.as_object_mut().unwrap().remove("position");
            }),
            vec!["integrator.lights[0].position", "required"],
        ),
        ("projector unknown key", projector(&|l| l["irradiance_scale"] = json!(2)), vec![]),
        (
            "area radiance unknown texture",
            area(&|l| l["radiance"] = json!("nope")),
            vec!["objects[1].light.radiance", "no texture named 'nope'"],
        ),
        (
            "area radiance a bool",
            area(&|l| l["radiance"] = json!(false)),
            vec!["objects[1].light.radiance", "expected a number, [r, g, b] or a texture name"],
        ),
        (
            "texture file missing",
            area(&|_| {}),
            vec!["textures.image.path", "missing_tex.exr"],
        ),
    ];
    let mut failures = Vec::new();
    for (name, mut scene, words) in cases {
        if name == "texture file missing" {
            scene["textures"]["image"]["path"] = json!("missing_tex.exr");
        }
        let file = d.join(format!("{}.json", name.replace(' ', "_")));
        std::fs::write(&file, serde_json::to_string_pretty(&scene).unwrap()).unwrap();
        std::fs::copy(refs().join("spot_texture_tex.exr"), d.join("spot_texture_tex.exr")).unwrap();
        let r = rdr::load(&file, &[], Profile::Physical);
        if words.is_empty() {
            // an unknown key is a warning, not an error
            match r {
                Ok(l) => {
                    let w = l.scene.warnings.join("\n");
                    if !w.contains("irradiance_scale") {
                        failures.push(format!("{name}: no warning about the unknown key ({w})"));
                    }
                }
                Err(e) => failures.push(format!("{name}: rejected: {e}")),
            }
            continue;
        }
        let msg = match r {
            Ok(_) => {
                failures.push(format!("{name}: accepted"));
                continue;
            }
            Err(e) => e.to_string(),
        };
        eprintln!("{name:>30}: {msg}");
        if msg.contains('\n')
            || !msg.contains(&file.file_name().unwrap().to_string_lossy().to_string())
            || !words.iter().all(|w| msg.contains(w))
        {
            failures.push(format!("{name}: expected {words:?}, got: {msg}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// XML bad input: one line with the file, line and column and the property.
#[test]
fn bad_xml_names_line_and_property() {
    let dir = temp_dir("rdr-textured-bad-xml");
    let d = dir.path();
    std::fs::copy(refs().join("spot_texture_tex.exr"), d.join("t.exr")).unwrap();
    // the body on line 6, after a sensor
    let scene = |body: &str| {
        format!(
            "<scene version=\"3.0.0\">\n  <sensor type=\"perspective\">\n    <float name=\"fov\" value=\"40\"/>\n    <film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/><integer name=\"height\" value=\"8\"/></film>\n  </sensor>\n{body}\n</scene>\n"
        )
    };
    let bitmap = |name: &str| format!(r#"<texture type="bitmap" name="{name}"><string name="filename" value="t.exr"/></texture>"#);
    let cases: Vec<(&str, String, &str, &str)> = vec![
        (
            "spot texture constant",
            scene(r#"  <emitter type="spot"><rgb name="texture" value="1"/></emitter>"#),
            "line 6, column 24",
            "must be a texture",
        ),
        (
            "spot texture wide cutoff",
            scene(&format!(
                r#"  <emitter type="spot"><float name="cutoff_angle" value="100"/>{}</emitter>"#,
                bitmap("texture")
            )),
            "line 6, column 24",
            "below 90",
        ),
        (
            "spot texture file missing",
            scene(
                r#"  <emitter type="spot"><texture type="bitmap" name="texture"><string name="filename" value="none.exr"/></texture></emitter>"#,
            ),
            "line 6",
            "none.exr",
        ),
        (
            "projector without irradiance",
            scene(r#"  <emitter type="projector"><float name="fov" value="40"/></emitter>"#),
            "line 6, column 3",
            "\"irradiance\" (a texture or a colour) is required",
        ),
        (
            "projector fov as a string",
            scene(&format!(
                r#"  <emitter type="projector"><string name="fov" value="wide"/>{}</emitter>"#,
                bitmap("irradiance")
            )),
            "line 6, column 29",
            "expected a float, found a string",
        ),
        (
            "projector fov 0",
            scene(&format!(
                r#"  <emitter type="projector"><float name="fov" value="0"/>{}</emitter>"#,
                bitmap("irradiance")
            )),
            "line 6, column 29",
            "between 0 and 180",
        ),
        (
            "projector fov_axis unknown",
            scene(&format!(
                r#"  <emitter type="projector"><string name="fov_axis" value="z"/><float name="fov" value="40"/>{}</emitter>"#,
                bitmap("irradiance")
            )),
            "line 6, column 29",
            "unknown axis \"z\"",
        ),
        (
            "projector bad focal_length",
            scene(&format!(
                r#"  <emitter type="projector"><string name="focal_length" value="long"/>{}</emitter>"#,
                bitmap("irradiance")
            )),
            "line 6, column 29",
            "expected a length",
        ),
        (
            "projector scale as a string",
            scene(&format!(
                r#"  <emitter type="projector"><string name="scale" value="2"/>{}</emitter>"#,
                bitmap("irradiance")
            )),
            "line 6, column 29",
            "expected a float, found a string",
        ),
        (
            "projector negative scale",
            scene(&format!(
                r#"  <emitter type="projector"><float name="scale" value="-2"/>{}</emitter>"#,
                bitmap("irradiance")
            )),
            "line 6, column 29",
            "must not be negative",
        ),
        (
            "projector irradiance file missing",
            scene(
                r#"  <emitter type="projector"><texture type="bitmap" name="irradiance"><string name="filename" value="none.exr"/></texture></emitter>"#,
            ),
            "line 6",
            "none.exr",
        ),
        (
            "area radiance as a string",
            scene(r#"  <shape type="sphere"><emitter type="area"><string name="radiance" value="bright"/></emitter></shape>"#),
            "line 6, column 45",
            "expected a colour",
        ),
        (
            "area radiance negative",
            scene(r#"  <shape type="sphere"><emitter type="area"><rgb name="radiance" value="-1"/></emitter></shape>"#),
            "line 6, column 45",
            "must not be negative",
        ),
        (
            "area radiance file missing",
            scene(
                r#"  <shape type="sphere"><emitter type="area"><texture type="bitmap" name="radiance"><string name="filename" value="none.exr"/></texture></emitter></shape>"#,
            ),
            "line 6",
            "none.exr",
        ),
    ];
    let mut failures = Vec::new();
    for (name, text, at, words) in &cases {
        let file = d.join(format!("{}.xml", name.replace(' ', "_")));
        std::fs::write(&file, text).unwrap();
        let msg = match rdr::load(&file, &[], Profile::Physical) {
            Ok(_) => {
                failures.push(format!("{name}: accepted"));
                continue;
            }
            Err(e) => e.to_string(),
        };
        eprintln!("{name:>34}: {msg}");
        if msg.contains('\n') || !msg.contains(&format!(".xml: {at}")) || !msg.contains(words) {
            failures.push(format!("{name}: expected '{at}' and '{words}', got: {msg}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// `rdr convert` carries each textured emitter (the spot's texture, the projector's
/// irradiance, the area light's radiance) both ways, with the image's path relative to the
/// converted file: XML → JSON → XML and JSON → XML → JSON, each converted scene converges to
/// Mitsuba's image of the original.
#[test]
fn convert_carries_textured_emitters_both_ways() {
    let dir = temp_dir("rdr-textured-convert");
    let convert = |from: &Path, to: &Path| {
        let run = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
            .args(["convert", "-q"])
            .arg(from)
            .arg("-o")
            .arg(to)
            .output()
            .unwrap();
        assert!(
            run.status.success(),
            "{} → {}: {}",
            from.display(),
            to.display(),
            String::from_utf8_lossy(&run.stderr)
        );
    };
    let mut failed = Vec::new();
    for name in NAMES {
        for (from, to) in [("xml", "json"), ("json", "xml")] {
            let there = dir.path().join(format!("{name}.from-{from}.{to}"));
            let back = dir.path().join(format!("{name}.from-{from}.back.{from}"));
            convert(&refs().join(format!("{name}.{from}")), &there);
            convert(&there, &back);
            for out in [&there, &back] {
                let text = std::fs::read_to_string(out).unwrap();
                let image = format!("{name}_tex.exr");
                assert!(
                    text.contains(&image) && !text.contains(&format!("\"{}\"", refs().join(&image).display())),
                    "{}: the image's path is not written relative: {text}",
                    out.display()
                );
                if !converges_with(out, name, &[], 256) {
                    failed.push(out.file_name().unwrap().to_string_lossy().into_owned());
                }
            }
        }
    }
    assert!(failed.is_empty(), "converted scenes off Mitsuba's image: {failed:?}");
}

/// `--compat rdr171` refuses all three textured emitters in one line (the course renderer had none).
#[test]
fn compat_refuses_them() {
    for name in NAMES {
        let o = vec![r#"{"integrator": {"type": "intersection_test"}}"#.to_string()];
        let e = rdr::load(&refs().join(format!("{name}.json")), &o, Profile::Rdr171)
            .err()
            .expect("compat accepted it")
            .to_string();
        assert!(!e.contains('\n') && e.contains("--compat rdr171 does not support"), "{e}");
    }
}
