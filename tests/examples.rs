//! The bundled example scenes render through the binary: a broken example (a
//! missing asset, a key the parser warns about, a black image) fails CI.

mod common;

use std::path::Path;
use std::process::Command;

/// Renders `scenes/<name>.json` at 48×32 and 2 spp to a PNG; returns the
/// decoded pixels (8-bit RGB) after checking the run was clean.
fn render_example(name: &str) -> Vec<u8> {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(format!("{name}.json"));
    let tmp = common::temp_dir(&format!("rdr-example-{name}"));
    let out = tmp.path().join(format!("{name}.png"));
    let r = Command::new(env!("CARGO_BIN_EXE_rdr"))
        .arg("render")
        .arg(&scene)
        .args(["--override", r#"{"film":{"resolution":[48,32]}}"#, "--spp", "2", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{name}: exit status {:?}: {stderr}", r.status.code());
    assert!(!stderr.to_lowercase().contains("warning"), "{name}: warnings on stderr: {stderr}");
    let img = image::open(&out)
        .unwrap_or_else(|e| panic!("{name}: {}: {e}", out.display()))
        .to_rgb8();
    assert_eq!(img.dimensions(), (48, 32), "{name}");
    img.into_raw()
}

#[test]
fn showcase_renders_cleanly_and_is_not_black() {
    let px = render_example("showcase");
    let lit = px.chunks(3).filter(|p| p.iter().any(|&c| c > 16)).count();
    assert!(lit > px.len() / 3 / 2, "only {lit} of {} pixels are lit", px.len() / 3);
    let mean = px.iter().map(|&c| c as f64).sum::<f64>() / px.len() as f64;
    assert!(mean > 40.0, "mean 8-bit value {mean:.1}: too dark");
}

#[test]
fn cornell_renders_cleanly_and_is_not_black() {
    let px = render_example("cornell");
    assert!(px.iter().any(|&c| c > 16), "black image");
}
