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
use rdr::{Profile, RenderSettings};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

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

pub fn load_scene(path: &Path, overrides: &[&str], profile: Profile) -> rdr::Scene {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    rdr::scene::build::load(path, &o, profile.build_options()).unwrap_or_else(|e| panic!("{e}"))
}

pub fn render(scene: &rdr::Scene, spp: u32, seed: u32, profile: Profile) -> Image {
    let out = rdr::render(
        scene,
        &RenderSettings {
            spp,
            seed,
            profile,
            progress: None,
            time_limit: None,
        },
        &AtomicBool::new(false),
    );
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
