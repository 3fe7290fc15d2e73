//! The Mitsuba materials rendered by rdr's `path` against Mitsuba 3's own images of
//! the same scenes (`tests/refs/materials/`, made by `scripts/make_material_refs.py`:
//! a unit sphere of each material on a diffuse floor under a small spherical light
//! and a constant sky, and two `twosided` quads seen from the front and the back),
//! with the noise-aware relative MSE of the path tests; and two of the scenes read
//! from their Mitsuba XML (a named conductor, `material="Cu"`, whose reference Mitsuba
//! rendered from its own spectral table, and the plastic with Mitsuba's parameter names);
//! and roughness given as textures (XML only).

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
    not_converging_at(files, 512)
}

/// [`not_converging`] at `spp` samples per pixel (two seeds).
fn not_converging_at(files: &[&str], spp: u32) -> Vec<String> {
    let mut failed = Vec::new();
    for file in files {
        let dir = refs();
        let name = file.split('.').next().unwrap();
        let s = load_scene(&dir.join(file), &[], Profile::Physical);
        let (a, b) = (render(&s, spp, 1), render(&s, spp, 2));
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

/// Roughness given as textures, read as floats at the point (Mitsuba's `eval_1`): an
/// anisotropic roughconductor (`alpha_u` a checkerboard, `alpha_v` a bitmap ramp) and an
/// isotropic roughdielectric (`alpha` a checkerboard), 64×64.
#[test]
fn textured_roughness_converges_to_mitsubas_image() {
    let failed = not_converging_at(&["rough_textured_conductor.xml", "rough_textured_dielectric.xml"], 128);
    assert!(failed.is_empty(), "not converging to Mitsuba: {failed:?}");
}

/// The textured roughnesses through `rdr convert` to JSON (texture names in `alpha_x`,
/// `alpha_y`): read back as textures, the same image as Mitsuba's.
#[test]
fn textured_roughness_survives_conversion_to_json() {
    let dir = temp_dir("rdr-rough-json");
    let json = dir.path().join("rough.json");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["convert", "-q"])
        .arg(refs().join("rough_textured_conductor.xml"))
        .arg("-o")
        .arg(&json)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let desc = rdr::desc::SceneDesc::load(&json, &[]).unwrap_or_else(|e| panic!("{e}"));
    let textured = desc.materials.iter().any(|m| {
        matches!(
            m.material,
            rdr::material::Material::RoughConductor {
                alpha_textures: Some(_),
                ..
            }
        )
    });
    assert!(textured, "{:?}", desc.materials);
    let s = load_scene(&json, &[], Profile::Physical);
    let (a, b) = (render(&s, 128, 1), render(&s, 128, 2));
    let dir = refs();
    let c = compare(
        &a,
        &b,
        &read(&dir.join("rough_textured_conductor.exr")),
        &read(&dir.join("rough_textured_conductor.var.exr")),
    );
    eprintln!("JSON: relMSE corrected {:+.2e} ± {:.1e}", c.rel_mse_corrected, c.std_error);
    assert!(
        c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4,
        "the JSON twin differs from Mitsuba's image"
    );
}
