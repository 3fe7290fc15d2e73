//! The Mitsuba materials rendered by rdr's `path` against Mitsuba 3's own images of
//! the same scenes (`tests/refs/materials/`, made by `scripts/make_material_refs.py`:
//! a unit sphere of each material on a diffuse floor under a small spherical light
//! and a constant sky, and two `twosided` quads seen from the front and the back),
//! with the noise-aware relative MSE of the path tests.

mod common;
use common::*;
use rdr::metrics::compare;
use rdr::Profile;
use std::path::Path;

fn refs() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/materials")
}

#[test]
fn every_material_converges_to_mitsubas_image() {
    let mut failed = Vec::new();
    for name in [
        "conductor",
        "thindielectric",
        "roughdielectric",
        "plastic",
        "roughplastic",
        "twosided",
    ] {
        let dir = refs();
        let s = load_scene(&dir.join(format!("{name}.json")), &[], Profile::Physical);
        let (a, b) = (render(&s, 512, 1), render(&s, 512, 2));
        let r = read(&dir.join(format!("{name}.exr")));
        let vr = read(&dir.join(format!("{name}.var.exr")));
        let c = compare(&a, &b, &r, &vr);
        eprintln!(
            "{name:>16}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
            c.rel_mse_corrected, c.std_error, c.rel_mse_raw, c.rel_mse_noise
        );
        if c.rel_mse_corrected.abs() >= 5.0 * c.std_error + 2e-4 {
            failed.push(name);
        }
    }
    assert!(failed.is_empty(), "not converging to Mitsuba: {failed:?}");
}
