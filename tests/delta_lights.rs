//! Mitsuba's delta lights, `spot` and `directional`: rdr's `path` (from the JSON twin and
//! from the XML) converges to Mitsuba 3's image of the same scene (`tests/refs/lights/`,
//! made by `scripts/make_light_refs.py`) under the noise-aware relative MSE of the path
//! tests; `guided` and `intersection_test` take them, the integrators that trace from the
//! lights (`bdpt`, `ptracer`, `photon`, `sppm`) converge to the same images, and
//! `--compat rdr171` refuses them in one line; `rdr convert` carries them both ways.

mod common;
use common::*;
use rdr::Profile;
use std::path::{Path, PathBuf};

fn refs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/lights")
}

fn converges(file: &Path, reference: &str) -> bool {
    converges_with(file, reference, &[], 256)
}

fn converges_with(file: &Path, reference: &str, overrides: &[&str], spp: u32) -> bool {
    converges_to_ref(&refs(), file, reference, overrides, spp)
}

#[test]
fn spot_and_directional_converge_to_mitsubas_images() {
    let mut failed = Vec::new();
    for name in ["spot", "directional"] {
        for ext in ["json", "xml"] {
            let file = refs().join(format!("{name}.{ext}"));
            if !converges(&file, name) {
                failed.push(format!("{name}.{ext}"));
            }
        }
    }
    assert!(failed.is_empty(), "not converging to Mitsuba: {failed:?}");
}

/// The integrators that trace from the lights (`bdpt`, `ptracer`, `photon`, `sppm`) start
/// light subpaths at spot lights (a point, directions in the cone) and directional ones
/// (a disk covering the scene): each converges to Mitsuba's image. The directional
/// light's scene has the small floor (`directional_small`): under the large one's
/// bounding sphere (radius 100) few light paths would land in view.
#[test]
fn light_tracing_integrators_converge_with_delta_lights() {
    let mut failed = Vec::new();
    for name in ["spot", "directional_small"] {
        let file = refs().join(format!("{name}.json"));
        for (integrator, spp) in [
            (r#"{"integrator": {"type": "bdpt"}}"#, 64),
            (r#"{"integrator": {"type": "ptracer"}}"#, 1024),
            // (fewer photons: a density-estimation bias of 5e-4 on directional_small)
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

/// bdpt's MIS over paths from spot and directional lights: the weights of the
/// strategies that could make each path sum to 1 (s = 0 is impossible at a delta light,
/// s = 1 and the light-subpath strategies are not), and the densities the connections
/// assemble equal those recomputed from the vertices.
#[test]
fn bdpt_mis_weights_sum_to_one_with_delta_lights() {
    for name in ["spot", "directional_small"] {
        assert_bdpt_mis_sums_to_one(&refs().join(format!("{name}.json")));
    }
}

#[test]
fn integrators_take_or_refuse_delta_lights() {
    for name in ["spot", "directional"] {
        let file = refs().join(format!("{name}.json"));
        for ty in ["guided", "intersection_test"] {
            let o = format!("{{\"integrator\": {{\"type\": \"{ty}\", \"spp\": 2}}}}");
            let s = load_scene(&file, &[&o], Profile::Physical);
            let img = render(&s, 2, 1);
            let mean = img.mean();
            assert!(mean.min_element() > 0.01 && mean.is_finite(), "{name} under {ty}: mean {mean}");
        }
        let o = vec!["{\"integrator\": {\"type\": \"intersection_test\"}}".to_string()];
        let e = rdr::load(&file, &o, Profile::Rdr171).err().expect("compat accepted it").to_string();
        assert!(
            !e.contains('\n') && e.contains("integrator.lights[0]") && e.contains("--compat rdr171 does not support"),
            "{e}"
        );
    }
}

/// The numbers of a description's spot and directional lights, in order.
fn light_numbers(d: &rdr::desc::SceneDesc) -> (String, Vec<f64>) {
    let text = format!("{:?}", d.integrator.delta_lights.iter().map(|l| &l.light).collect::<Vec<_>>());
    let words: String = text.chars().filter(|c| c.is_alphabetic()).collect();
    let numbers = text
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e'))
        .filter_map(|t| t.parse::<f64>().ok())
        .collect();
    (words, numbers)
}

fn convert(input: &Path, output: &Path) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["convert", "-q"])
        .arg(input)
        .arg("-o")
        .arg(output)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn convert_carries_spot_and_directional_both_ways() {
    let dir = temp_dir("rdr-convert-lights");
    let d = dir.path();
    for name in ["spot", "directional"] {
        for (from, mid, back) in [("json", "xml", "json"), ("xml", "json", "xml")] {
            let original = refs().join(format!("{name}.{from}"));
            let (m, b) = (d.join(format!("{name}_{from}.{mid}")), d.join(format!("{name}_{from}_back.{back}")));
            convert(&original, &m);
            convert(&m, &b);
            let load = |p: &Path| rdr::desc::SceneDesc::load(p, &[]).unwrap_or_else(|e| panic!("{e}"));
            let (w0, n0) = light_numbers(&load(&original));
            for p in [&m, &b] {
                let (w, n) = light_numbers(&load(p));
                assert_eq!(w, w0, "{}", p.display());
                assert!(
                    n.len() == n0.len() && n.iter().zip(&n0).all(|(x, y)| (x - y).abs() <= 1e-4 * (1.0 + y.abs())),
                    "{}: {n:?} vs {n0:?}",
                    p.display()
                );
            }
        }
    }
}
