//! `--denoise` (Intel Open Image Denoise through the `denoise` feature's run-time
//! loading): on `cbox_path.json` at 4 spp the denoised image's relative MSE against
//! `cbox.exr` is at least 5× lower than the noisy one's. This runs the FFI code of
//! `src/render/denoise.rs`. It needs a binary built with `--features denoise` and the
//! library (`RDR_OIDN_LIB`, which `.ci/run` sets from a `pip install pyoidn` venv);
//! otherwise it prints why and skips (with `CI` and `RDR_OIDN_LIB` set it must run).

mod common;

use std::process::Command;

fn rdr() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rdr"))
}

#[test]
fn denoised_cbox_at_4spp_is_at_least_5x_closer_to_the_reference() {
    let Some(shared) = common::shared() else { return };
    let scene = shared.join("refs/scenes/cbox_path.json");
    let reference = shared.join("refs/cbox.exr");
    let dir = tempfile::tempdir().unwrap();
    let (noisy, clean) = (dir.path().join("noisy.exr"), dir.path().join("clean.exr"));
    let o = rdr()
        .arg("render")
        .arg(&scene)
        .args(["--spp", "4", "--denoise", "-q", "-o"])
        .arg(&clean)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    if !o.status.success() {
        // a clear one-line refusal in any case
        assert!(err.starts_with("error: --denoise: ") && err.trim().lines().count() == 1, "{err}");
        let must_run = std::env::var_os("CI").is_some() && std::env::var_os("RDR_OIDN_LIB").is_some();
        assert!(!must_run, "CI set RDR_OIDN_LIB but --denoise failed: {err}");
        common::skip(err.trim());
        return;
    }
    let o = rdr()
        .arg("render")
        .arg(&scene)
        .args(["--spp", "4", "-q", "-o"])
        .arg(&noisy)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = common::read(&reference);
    let rel = |path: &std::path::Path| rdr::metrics::rel_mse(&common::read(path), &r, None).0;
    let (e_noisy, e_clean) = (rel(&noisy), rel(&clean));
    eprintln!(
        "relMSE noisy {e_noisy:.4e}, denoised {e_clean:.4e} ({:.1}x lower)",
        e_noisy / e_clean
    );
    assert!(
        e_clean * 5.0 <= e_noisy,
        "denoised relMSE {e_clean:.4e} is not 5x below the noisy {e_noisy:.4e}"
    );
    // the noisy image stays in the state file beside the denoised one: the image its passes make
    let state = rdr::render::statefile::state_path(&clean);
    assert_eq!(
        common::read(&state).pixels,
        common::read(&noisy).pixels,
        "the state file's image is not the noisy one"
    );
}

#[test]
fn denoise_without_the_library_is_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.json");
    let o = rdr()
        .arg("render")
        .arg(&scene)
        .args(["--spp", "1", "--denoise", "-q", "-o"])
        .arg(dir.path().join("x.exr"))
        .env("RDR_OIDN_LIB", dir.path().join("no-such-libOpenImageDenoise.so"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.trim().lines().count() == 1, "{err}");
    assert!(
        err.contains("pip install pyoidn") || err.contains("--features denoise"),
        "the error says how to get it: {err}"
    );
    assert!(!dir.path().join("x.exr").exists(), "nothing written");
}
