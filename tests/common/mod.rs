//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod brute;
pub mod gen;
pub mod lattice;
pub mod rng;

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

/// `../shared` beside the project, or `None` (with a printed reason) when absent.
/// With `CI` set, a missing `../shared` is a failure, not a skip.
pub fn shared() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared");
    if p.join("refs").is_dir() && p.join("scenes").is_dir() {
        return Some(p);
    }
    if std::env::var_os("CI").is_some() {
        panic!(
            "{} is missing but CI is set: tests that need the shared data cannot be skipped in CI",
            p.display()
        );
    }
    eprintln!(
        "skipping: {} not found (reference images and course scenes live there)",
        p.display()
    );
    None
}

/// The scene and the job of a scene file, for `profile`.
pub fn load_scene(path: &Path, overrides: &[&str], profile: Profile) -> Loaded {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    rdr::load(path, &o, profile).unwrap_or_else(|e| panic!("{e}"))
}

/// Renders a loaded scene's job with `spp` samples per pixel and `seed`.
pub fn render(loaded: &Loaded, spp: u32, seed: u32) -> Image {
    let job = rdr::RenderJob {
        spp,
        seed,
        ..loaded.job.clone()
    };
    let out = rdr::render(&loaded.scene, &job, &RenderControl::default());
    Image::new(out.width as usize, out.height as usize, out.pixels)
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
