//! `rdr bench MESH` end to end: it builds, checks every kernel variant against
//! the reference and prints the whole table; its options are checked.

mod common;

use std::fmt::Write as _;
use std::process::Command;

/// A UV sphere of `2·n·n` triangles as an OBJ file in a fresh temporary folder
/// (removed when the returned guard drops).
fn sphere_obj(name: &str, n: usize) -> (tempfile::TempDir, std::path::PathBuf) {
    let tmp = common::temp_dir(&format!("rdr-bench-cli-{name}"));
    let dir = tmp.path();
    let mut obj = String::new();
    for i in 0..=n {
        let theta = std::f64::consts::PI * i as f64 / n as f64;
        for j in 0..=n {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / n as f64;
            let (x, y, z) = (theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            writeln!(obj, "v {x} {y} {z}").unwrap();
        }
    }
    let v = |i: usize, j: usize| i * (n + 1) + j + 1;
    for i in 0..n {
        for j in 0..n {
            writeln!(obj, "f {} {} {}", v(i, j), v(i + 1, j), v(i + 1, j + 1)).unwrap();
            writeln!(obj, "f {} {} {}", v(i, j), v(i + 1, j + 1), v(i, j + 1)).unwrap();
        }
    }
    let path = dir.join("sphere.obj");
    std::fs::write(&path, obj).unwrap();
    (tmp, path)
}

fn bench(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_rdr"))
        .arg("bench")
        .args(args)
        .output()
        .expect("cannot run rdr");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn mesh_benchmark_checks_every_kernel_and_prints_the_table() {
    let (_tmp, mesh) = sphere_obj("full", 40);
    let (ok, out, err) = bench(&[mesh.to_str().unwrap(), "--repeat", "1", "--threads", "2"]);
    assert!(ok, "rdr bench failed: {err}");
    assert!(out.contains("triangles, loaded in"), "{out}");
    assert!(out.contains("(1 thread)") && out.contains("(2 threads)"), "{out}");
    let checks = out.lines().filter(|l| l.starts_with("check")).count();
    let agree = out
        .lines()
        .filter(|l| l.contains("closest and any hit agree with the reference"))
        .count();
    assert!(checks >= 1 && checks == agree, "{out}");
    assert!(out.contains("portable: closest and any hit agree"), "{out}");
    assert!(!out.contains("DISAGREE") && !out.contains("MISMATCH"), "{out}");
    for set in ["primary", "incoherent", "bounce"] {
        let row = out
            .lines()
            .find(|l| l.starts_with(set))
            .unwrap_or_else(|| panic!("no {set} row in\n{out}"));
        // four positive Mrays/s figures and a hit percentage
        let figures: Vec<f64> = row
            .split(|c: char| c == '|' || c.is_whitespace())
            .filter_map(|w| w.parse().ok())
            .collect();
        assert_eq!(figures.len(), 5, "{row}");
        assert!(figures[..4].iter().all(|&f| f > 0.0), "{row}");
    }
}

#[test]
fn mesh_benchmark_options() {
    let (_tmp, mesh) = sphere_obj("options", 10);
    let path = mesh.to_str().unwrap();
    // one ray set, no repeated builds or check
    let (ok, out, err) = bench(&[path, "--repeat", "1", "--threads", "1", "--rays", "bounce", "--trace-only"]);
    assert!(ok, "{err}");
    assert!(out.lines().any(|l| l.starts_with("bounce")), "{out}");
    assert!(!out.lines().any(|l| l.starts_with("primary") || l.starts_with("check")), "{out}");
    // the portable kernels can always be timed
    let (ok, out, err) = bench(&[path, "--repeat", "1", "--threads", "1", "--isa", "portable", "--rays", "primary"]);
    assert!(ok && out.contains("kernels       portable"), "{out}{err}");
    // bad values are errors that say what was wrong
    let (ok, _, err) = bench(&[path, "--rays", "sideways"]);
    assert!(!ok && err.contains("--rays") && err.contains("sideways"), "{err}");
    let (ok, _, err) = bench(&[path, "--isa", "sse9"]);
    assert!(!ok && err.contains("--isa") && err.contains("sse9"), "{err}");
}
