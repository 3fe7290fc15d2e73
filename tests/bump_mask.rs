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
