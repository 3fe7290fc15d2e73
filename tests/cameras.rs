//! Thin-lens and orthographic cameras against Mitsuba 3 references of the shared
//! Cornell box (tests/refs/cameras, made by scripts/make_camera_refs.py), for the
//! integrators that can use them; wrong variants must fail; bad camera keys are
//! one-line errors.

mod common;
use common::*;
use rdr::metrics::{compare, Comparison, Image};
use rdr::Profile;
use std::path::{Path, PathBuf};

const THIN_LENS: &str =
    r#"{"camera": {"type": "thinlens", "aperture_radius": 0.1, "focus_distance": 6.0}, "film": {"resolution": [64, 64]}}"#;
const ORTHO: &str = r#"{"camera": {"type": "orthographic", "height": 2.2}, "film": {"resolution": [64, 64]}}"#;

fn refs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/cameras")
}

fn cbox(shared: &Path, overrides: &[&str]) -> rdr::Loaded {
    load_scene(&shared.join("refs/scenes/cbox_path.json"), overrides, Profile::Physical)
}

fn check(name: &str, scene: &rdr::Loaded, spp: u32, reference: &str) -> Comparison {
    let (r, vr) = (
        read(&refs().join(format!("{reference}.exr"))),
        read(&refs().join(format!("{reference}.var.exr"))),
    );
    let (a, b): (Image, Image) = (render(scene, spp, 1), render(scene, spp, 2));
    let c = compare(&a, &b, &r, &vr);
    eprintln!(
        "{name:>34}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
        c.rel_mse_corrected, c.std_error, c.rel_mse_raw, c.rel_mse_noise
    );
    c
}

fn converges(c: &Comparison) -> bool {
    c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4
}

/// The bias estimate is far outside its own noise and above what the right camera
/// shows (the wrong cameras here are off by about 1e-3 in relMSE, not more).
fn fails(bad: &Comparison, good: &Comparison) -> bool {
    bad.rel_mse_corrected > 10.0 * bad.std_error + 5e-4 && bad.rel_mse_corrected > good.rel_mse_corrected + 3.0 * good.std_error
}

#[test]
fn thin_lens_converges_for_path_bdpt_and_ptracer_and_a_pinhole_does_not() {
    let Some(shared) = shared() else { return };
    let path = check("thinlens path", &cbox(&shared, &[THIN_LENS]), 128, "cbox_thinlens");
    assert!(converges(&path), "{path:?}");
    let bdpt = check(
        "thinlens bdpt",
        &cbox(&shared, &[THIN_LENS, r#"{"integrator": {"type": "bdpt"}}"#]),
        48,
        "cbox_thinlens",
    );
    assert!(converges(&bdpt), "{bdpt:?}");
    // the light tracer reaches the film only through the lens (the t = 1 strategy)
    let pt = check(
        "thinlens ptracer",
        &cbox(&shared, &[THIN_LENS, r#"{"integrator": {"type": "ptracer"}}"#]),
        96,
        "cbox_thinlens",
    );
    assert!(converges(&pt), "{pt:?}");
    // the same camera without its lens is sharp where the reference is not
    let pinhole = r#"{"camera": {"aperture_radius": 0}}"#;
    let sharp = check("aperture 0 (pinhole)", &cbox(&shared, &[THIN_LENS, pinhole]), 128, "cbox_thinlens");
    assert!(fails(&sharp, &path), "{sharp:?}");
    let defocused = r#"{"camera": {"focus_distance": 4.0}}"#;
    let wrong = check(
        "focus 4 instead of 6",
        &cbox(&shared, &[THIN_LENS, defocused]),
        128,
        "cbox_thinlens",
    );
    assert!(fails(&wrong, &path), "{wrong:?}");
}

#[test]
fn orthographic_converges_and_a_wrong_window_fails() {
    let Some(shared) = shared() else { return };
    let good = check("orthographic path", &cbox(&shared, &[ORTHO]), 128, "cbox_ortho");
    assert!(converges(&good), "{good:?}");
    let bad = check(
        "height 2.0 instead of 2.2",
        &cbox(&shared, &[ORTHO, r#"{"camera": {"height": 2.0}}"#]),
        128,
        "cbox_ortho",
    );
    assert!(fails(&bad, &good), "{bad:?}");
}

#[test]
fn lens_renders_do_not_depend_on_the_thread_count() {
    let Some(shared) = shared() else { return };
    let scene = shared.join("refs/scenes/cbox_path.json");
    let o = r#"{"camera": {"type": "thinlens", "aperture_radius": 0.1, "focus_distance": 6.0}, "film": {"resolution": [24, 24]}, "integrator": {"type": "bdpt"}}"#;
    assert_same_image_for_1_2_3_threads(&scene, 2, o, "thin-lens bdpt");
}

#[test]
fn bad_camera_keys_are_one_line_errors() {
    let dir = temp_dir("camera-errors");
    let cases: &[(&str, &str)] = &[
        (
            r#"{"type": "fisheye"}"#,
            "camera.type: unknown camera type 'fisheye' (available: perspective, thinlens, orthographic)",
        ),
        (
            r#"{"type": "thinlens", "aperture_radius": 0.1}"#,
            "camera.focus_distance: is required for a 'thinlens' camera",
        ),
        (
            r#"{"type": "thinlens", "focus_distance": 3}"#,
            "camera.aperture_radius: is required for a 'thinlens' camera",
        ),
        (
            r#"{"type": "thinlens", "aperture_radius": -1, "focus_distance": 3}"#,
            "camera.aperture_radius: must be at least 0",
        ),
        (
            r#"{"type": "thinlens", "aperture_radius": 0.1, "focus_distance": 0}"#,
            "camera.focus_distance: must be positive",
        ),
        (r#"{"type": "orthographic", "height": -2}"#, "camera.height: must be positive"),
        (
            r#"{"near_clip": 2, "far_clip": 1}"#,
            "camera.far_clip: must be greater than near_clip",
        ),
        (r#"{"near_clip": -1}"#, "camera.near_clip: must be a finite distance of at least 0"),
    ];
    for (i, (camera, expect)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("c{i}.json"));
        std::fs::write(
            &path,
            format!(r#"{{"camera": {camera}, "integrator": {{}}, "film": {{}}, "objects": []}}"#),
        )
        .unwrap();
        let err = rdr::load(&path, &[], Profile::Physical)
            .err()
            .unwrap_or_else(|| panic!("{camera}: loaded"))
            .to_string();
        assert!(err.contains(expect) && !err.contains('\n'), "{camera}: {err}");
    }
    // what an integrator or the compatibility mode cannot do is refused when the job is made
    let path = dir.path().join("ortho.json");
    std::fs::write(
        &path,
        r#"{"camera": {"type": "orthographic"}, "integrator": {"type": "bdpt"}, "film": {}, "objects": []}"#,
    )
    .unwrap();
    let err = rdr::load(&path, &[], Profile::Physical).err().unwrap().to_string();
    assert!(
        err.contains("camera.type: bdpt: light paths cannot be joined to an orthographic camera"),
        "{err}"
    );
    let path = dir.path().join("lens.json");
    std::fs::write(&path, r#"{"camera": {"type": "thinlens", "aperture_radius": 0.1, "focus_distance": 2}, "integrator": {"type": "intersection_test"}, "film": {}, "objects": []}"#).unwrap();
    let err = rdr::load(&path, &[], Profile::Rdr171).err().unwrap().to_string();
    assert!(
        err.contains("--compat rdr171 has the course renderer's pinhole camera only"),
        "{err}"
    );
}

/// Mitsuba's `thinlens` and `orthographic` sensors through the XML reader: the
/// references' own scenes (tests/refs/cameras/*.xml) build the cameras of their JSON
/// twins (the orthographic window from the to_world scale: 2·1.1 tall) and converge
/// to the references; `rdr convert` carries both cameras to JSON and back.
#[test]
fn mitsuba_thinlens_and_orthographic_sensors_read_and_converge() {
    use rdr::camera::Projection;
    let Some(_shared) = shared() else { return };
    let dir = temp_dir("camera-convert");
    for (name, want) in [
        (
            "cbox_thinlens",
            Projection::ThinLens {
                aperture_radius: 0.1,
                focus_distance: 6.0,
            },
        ),
        ("cbox_ortho", Projection::Orthographic { height: 2.2 }),
    ] {
        let xml = refs().join(format!("{name}.xml"));
        let desc = rdr::desc::SceneDesc::load(&xml, &[]).unwrap_or_else(|e| panic!("{e}"));
        let close = |a: Projection| match (a, want) {
            (
                Projection::ThinLens {
                    aperture_radius: r,
                    focus_distance: f,
                },
                Projection::ThinLens {
                    aperture_radius: r0,
                    focus_distance: f0,
                },
            ) => (r - r0).abs() < 1e-5 && (f - f0).abs() < 1e-4,
            (Projection::Orthographic { height: h }, Projection::Orthographic { height: h0 }) => (h - h0).abs() < 1e-5,
            _ => false,
        };
        assert!(close(desc.camera.projection), "{name}: {:?}", desc.camera.projection);
        for (from, to) in [
            (xml.clone(), dir.path().join(format!("{name}.json"))),
            (dir.path().join(format!("{name}.json")), dir.path().join(format!("{name}_back.xml"))),
        ] {
            let out = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
                .args(["convert", "-q"])
                .arg(&from)
                .arg("-o")
                .arg(&to)
                .output()
                .unwrap();
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            let d = rdr::desc::SceneDesc::load(&to, &[]).unwrap_or_else(|e| panic!("{}: {e}", to.display()));
            assert!(close(d.camera.projection), "{}: {:?}", to.display(), d.camera.projection);
        }
        let c = check(&format!("{name}.xml path"), &load_scene(&xml, &[], Profile::Physical), 128, name);
        assert!(converges(&c), "{name}: {c:?}");
    }
}
