//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod brute;
pub mod chi2;
pub mod gen;
pub mod lattice;
pub mod rng;
pub mod transport;

// each test file uses some of these
#[allow(unused_imports)]
pub use brute::*;
#[allow(unused_imports)]
pub use gen::*;
#[allow(unused_imports)]
pub use lattice::*;
#[allow(unused_imports)]
pub use rng::Rng;

use rdr::metrics::Image;
use rdr::{Loaded, Profile, RenderControl};
use std::path::{Path, PathBuf};

/// `../shared` beside the project (or the folder `RDR_SHARED` names), or `None` (with
/// a printed reason, see `skip`) when absent. With `CI` set, a missing `../shared` is
/// a failure, not a skip.
pub fn shared() -> Option<PathBuf> {
    let p = std::env::var_os("RDR_SHARED")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared"));
    if p.join("refs").is_dir() && p.join("scenes").is_dir() {
        return Some(p);
    }
    if std::env::var_os("CI").is_some() {
        panic!(
            "{} is missing but CI is set: tests that need the shared data cannot be skipped in CI",
            p.display()
        );
    }
    skip(&format!(
        "{} not found (reference images and course scenes live there)",
        p.display()
    ));
    None
}

/// Records that the running test skips for `reason`, which libtest would report as
/// passed: prints `SKIPPED: binary::test: reason` (shown with `--nocapture`) and, when
/// `RDR_SKIPPED_LOG` names a file, appends that line to it; `.ci/run` counts them.
pub fn skip(reason: &str) {
    use std::io::Write;
    let binary = std::env::current_exe()
        .ok()
        .and_then(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .map(|s| s.rsplit_once('-').map_or(s.clone(), |(name, _hash)| name.to_string()))
        .unwrap_or_default();
    let test = std::thread::current().name().unwrap_or("?").to_string();
    let line = format!("SKIPPED: {binary}::{test}: {}\n", reason.replace('\n', " "));
    eprint!("{line}");
    // once per test, however often it asks
    static SKIPPED: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());
    let mut seen = SKIPPED.lock().unwrap_or_else(|e| e.into_inner());
    if seen.contains(&test) {
        return;
    }
    seen.push(test);
    if let Some(log) = std::env::var_os("RDR_SKIPPED_LOG") {
        // one write of one line in append mode: lines of parallel tests do not mix
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log)
            .unwrap_or_else(|e| panic!("RDR_SKIPPED_LOG {}: {e}", Path::new(&log).display()));
        f.write_all(line.as_bytes()).unwrap();
    }
}

/// The scene and the job of a scene file, for `profile`.
pub fn load_scene(path: &Path, overrides: &[&str], profile: Profile) -> Loaded {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    rdr::load(path, &o, profile).unwrap_or_else(|e| panic!("{e}"))
}

/// Renders a loaded scene's job with `spp` samples per pixel and `seed`, as if the
/// scene declared that spp (the texture footprint follows it, see `target_spp`).
pub fn render(loaded: &Loaded, spp: u32, seed: u32) -> Image {
    let job = rdr::RenderJob {
        spp,
        target_spp: spp,
        seed,
        ..loaded.job.clone()
    };
    let out = rdr::render(&loaded.scene, &job, &RenderControl::default());
    Image::new(out.width as usize, out.height as usize, out.pixels)
}

/// Mean relative variance of the mean of two independent renders `a`, `b` of one scene
/// (from their difference): over pixels and channels, (x − y)²/4 / (m² + 0.01), m their mean.
pub fn relative_variance_of_mean(a: &Image, b: &Image) -> f64 {
    let mut acc = 0.0f64;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            let (x, y) = (p[c] as f64, q[c] as f64);
            let m = 0.5 * (x + y);
            acc += 0.25 * (x - y) * (x - y) / (m * m + 0.01);
        }
    }
    acc / (3 * a.pixels.len()) as f64
}

/// Whether two renders of `file` (with `overrides`, `spp` each, seeds 1 and 2) converge
/// to the reference `refs/<reference>.exr` (with its `.var.exr`) under the noise-aware
/// relative MSE: |corrected| below 5σ + 2e-4.
pub fn converges_to_ref(refs: &Path, file: &Path, reference: &str, overrides: &[&str], spp: u32) -> bool {
    converges_to_ref_within(refs, file, reference, overrides, spp, 2e-4)
}

/// [`converges_to_ref`] with the relative MSE allowed beyond 5 standard errors `floor`
/// (2·10⁻⁴ there, for small differences of models; less where rdr's model is Mitsuba's).
pub fn converges_to_ref_within(refs: &Path, file: &Path, reference: &str, overrides: &[&str], spp: u32, floor: f64) -> bool {
    let s = load_scene(file, overrides, Profile::Physical);
    let (a, b) = (render(&s, spp, 1), render(&s, spp, 2));
    let r = read(&refs.join(format!("{reference}.exr")));
    let vr = read(&refs.join(format!("{reference}.var.exr")));
    let c = rdr::metrics::compare(&a, &b, &r, &vr);
    eprintln!(
        "{:>18} {:>8}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
        file.file_name().unwrap().to_string_lossy(),
        s.job.integrator.name(),
        c.rel_mse_corrected,
        c.std_error,
        c.rel_mse_raw,
        c.rel_mse_noise
    );
    c.rel_mse_corrected.abs() < 5.0 * c.std_error + floor
}

/// [`converges_to_ref`] of `tests/refs/<dir>/<file>` against the reference beside it
/// named after the file (`mask.xml`: `mask.exr`, `mask.var.exr`).
pub fn converges_to_ref_beside(dir: &str, file: &str, overrides: &[&str], spp: u32) -> bool {
    let refs = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs").join(dir);
    let name = file.split('.').next().unwrap();
    converges_to_ref(&refs, &refs.join(file), name, overrides, spp)
}

/// bdpt's MIS self-check on `file`: over 3000 paths the weights of the strategies that
/// could make each path sum to 1 and the densities the connections assemble equal those
/// recomputed from the vertices.
pub fn assert_bdpt_mis_sums_to_one(file: &Path) {
    let s = load_scene(file, &[r#"{"integrator": {"type": "bdpt"}}"#], Profile::Physical);
    let f = &s.job.film;
    let c = rdr::integrator::bdpt::mis_self_check(&s.scene, &s.job.camera, f.width, f.height, 6, 3000);
    let name = file.display();
    eprintln!("{name}: {c:?}");
    assert!(
        c.paths > 1000 && c.max_sum_error < 1e-3 && c.samples_off * 100 < 3000,
        "{name}: {c:?}"
    );
}

pub fn read(path: &Path) -> Image {
    rdr::imageio::read_exr(path).unwrap_or_else(|e| panic!("{e:#}"))
}

pub fn scaled(img: &Image, s: f32) -> Image {
    Image::new(img.width, img.height, img.pixels.iter().map(|p| *p * s).collect())
}

/// A fresh, uniquely named folder under the system temp dir (`prefix-XXXXXX`),
/// removed when the returned guard drops, also when the test panics.
pub fn temp_dir(prefix: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("{prefix}-"))
        .tempdir()
        .unwrap_or_else(|e| panic!("cannot create a temp folder for {prefix}: {e}"))
}

/// Renders `scene` through the binary with `--threads` 1, 2 and 3 (at `spp`, with the
/// `--override` JSON `overrides`) and asserts that the three EXR files are byte-identical.
pub fn assert_same_image_for_1_2_3_threads(scene: &Path, spp: u32, overrides: &str, what: &str) {
    let dir = temp_dir("rdr-threads");
    let render = |threads: u32| {
        let out = dir.path().join(format!("t{threads}.exr"));
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
            .arg("render")
            .arg(scene)
            .args([
                "--spp",
                &spp.to_string(),
                "-q",
                "--threads",
                &threads.to_string(),
                "--override",
                overrides,
                "-o",
            ])
            .arg(&out)
            .stdout(std::process::Stdio::null())
            .status()
            .unwrap();
        assert!(status.success(), "{what}: render with {threads} threads failed");
        std::fs::read(out).unwrap()
    };
    let one = render(1);
    assert!(one == render(2), "{what}: 2 threads give another image than 1");
    assert!(one == render(3), "{what}: 3 threads give another image than 1");
}

/// `rdr convert` of the scene `xml` into `<dir>/<stem>.json`: its path and its text.
pub fn converted_to_json(xml: &Path, dir: &Path) -> (PathBuf, String) {
    let json = dir.join(xml.with_extension("json").file_name().unwrap());
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["convert", "-q", xml.to_str().unwrap(), "-o", json.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&json).unwrap();
    (json, text)
}
