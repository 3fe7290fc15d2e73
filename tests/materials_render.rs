//! The Mitsuba materials rendered by rdr's `path` against Mitsuba 3's own images of
//! the same scenes (`tests/refs/materials/`, made by `scripts/make_material_refs.py`:
//! a unit sphere of each material on a diffuse floor under a small spherical light
//! and a constant sky, and two `twosided` quads seen from the front and the back),
//! with the noise-aware relative MSE of the path tests; and two of the scenes read
//! from their Mitsuba XML (a named conductor, `material="Cu"`, whose reference Mitsuba
//! rendered from its own spectral table, and the plastic with Mitsuba's parameter names).

mod common;
use common::*;
use rdr::metrics::compare;
use rdr::Profile;
use std::path::Path;

fn refs() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/materials")
}

/// The names of `files` that do not converge to their reference `<name>.exr`.
fn not_converging(files: &[&str]) -> Vec<String> {
    let mut failed = Vec::new();
    for file in files {
        let dir = refs();
        let name = file.split('.').next().unwrap();
        let s = load_scene(&dir.join(file), &[], Profile::Physical);
        let (a, b) = (render(&s, 512, 1), render(&s, 512, 2));
        let r = read(&dir.join(format!("{name}.exr")));
        let vr = read(&dir.join(format!("{name}.var.exr")));
        let c = compare(&a, &b, &r, &vr);
        eprintln!(
            "{file:>20}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
            c.rel_mse_corrected, c.std_error, c.rel_mse_raw, c.rel_mse_noise
        );
        if c.rel_mse_corrected.abs() >= 5.0 * c.std_error + 2e-4 {
            failed.push(file.to_string());
        }
    }
    failed
}

#[test]
fn every_material_converges_to_mitsubas_image() {
    let failed = not_converging(&[
        "conductor.json",
        "thindielectric.json",
        "roughdielectric.json",
        "plastic.json",
        "roughplastic.json",
        "twosided.json",
    ]);
    assert!(failed.is_empty(), "not converging to Mitsuba: {failed:?}");
}

#[test]
fn mitsuba_xml_materials_converge_to_mitsubas_image() {
    let failed = not_converging(&["conductor_cu.xml", "plastic.xml", "roughdielectric.xml"]);
    assert!(failed.is_empty(), "not converging to Mitsuba: {failed:?}");
}
