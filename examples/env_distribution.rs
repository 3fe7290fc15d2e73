//! Times building the environment map's sampling distribution: the 1k sky from
//! `../shared` (if present) and a synthetic 2048×1024 map.
//! `cargo run --release --example env_distribution`

use rdr::light::environment::{EnvImage, EnvironmentLight};
use rdr::math::{Mat4, Vec2, Vec3};
use rdr::texture::UvMapping;
use std::time::Instant;

fn time(name: &str, width: usize, height: usize, texels: Vec<Vec3>) {
    let mapping = UvMapping {
        scale: Vec2::ONE,
        delta: Vec2::ZERO,
    };
    let t = Instant::now();
    let light = EnvironmentLight::new(
        EnvImage::Image {
            width,
            height,
            texels,
            mapping,
        },
        1.0,
        &Mat4::IDENTITY,
    );
    println!(
        "{name:<40} {width}x{height}: distribution built in {:.1} ms (mean luminance {:.3})",
        t.elapsed().as_secs_f64() * 1e3,
        light.mean_luminance()
    );
}

fn main() {
    let sky = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/envmaps/industrial_sunset_puresky_1k.hdr");
    if let Ok(img) = rdr::imageio::read_texture_image(&sky) {
        time("industrial_sunset_puresky_1k.hdr", img.width, img.height, img.pixels);
    }
    let (w, h) = (2048, 1024);
    let texels = (0..w * h)
        .map(|k| Vec3::splat(1.0 + ((k % w) as f32 * 0.01).sin() * ((k / w) as f32 * 0.02).cos()))
        .collect();
    time("synthetic", w, h, texels);
}
