//! Writes the assets of `scenes/showcase.json` into `scenes/showcase/`, all
//! procedural: a 128×128 tile texture (PNG), a 128×64 equirectangular sky with
//! a sun (Radiance HDR), and the two OBJ quads (floor, area light).
//! `cargo run --release --example make_showcase_assets`
//!
//! The output is deterministic: running it again rewrites the same files.

use image::codecs::hdr::HdrEncoder;
use image::{Rgb, RgbImage};
use std::f32::consts::PI;
use std::path::Path;

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn mix(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * t)
}

/// A small integer hash in [0, 1), for per-tile colour variation.
fn hash(x: u32, y: u32) -> f32 {
    let mut h = x.wrapping_mul(0x9E37_79B1) ^ y.wrapping_mul(0x85EB_CA77);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h & 0xFFFF) as f32 / 65536.0
}

/// 2×2 glazed tiles (terracotta and cream, checkered) with grout lines and a
/// small diamond inlay at every corner; it repeats seamlessly.
fn tiles(size: u32) -> RgbImage {
    let tile = size / 2;
    RgbImage::from_fn(size, size, |x, y| {
        let (tx, ty) = (x / tile, y / tile);
        let (fx, fy) = ((x % tile) as f32 + 0.5, (y % tile) as f32 + 0.5);
        let t = tile as f32;
        let edge = fx.min(fy).min(t - fx).min(t - fy); // distance to the grout line
        let base = if (tx + ty) % 2 == 0 {
            [0.70, 0.30, 0.16]
        } else {
            [0.86, 0.80, 0.66]
        };
        let v = 0.9 + 0.2 * hash(tx, ty);
        let mut c = base.map(|c| c * v);
        // a faint glaze gradient across each tile
        c = mix(c, c.map(|c| c * 0.82), (fx + fy) / (2.0 * t));
        // corner inlay: a dark teal diamond centred on the tile corners
        let (cx, cy) = ((fx - t * 0.5).abs(), (fy - t * 0.5).abs());
        let corner = (t * 0.5 - cx) + (t * 0.5 - cy);
        if corner < t * 0.22 {
            c = [0.08, 0.30, 0.32];
        }
        let grout = [0.22, 0.21, 0.20];
        c = mix(grout, c, smoothstep(1.0, 2.5, edge));
        Rgb(c.map(|v| (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0 + 0.5) as u8))
    })
}

/// Equirectangular sky, row 0 at the zenith: a blue gradient above a warm
/// horizon, dark ground below, and a sun disc with a glow. Same convention as
/// rdr's environment light: u = 0 is −z, u = ¼ is +x.
fn sky(width: usize, height: usize, sun: [f32; 3]) -> Vec<Rgb<f32>> {
    let n = (sun[0] * sun[0] + sun[1] * sun[1] + sun[2] * sun[2]).sqrt();
    let sun = sun.map(|c| c / n);
    let mut px = Vec::with_capacity(width * height);
    for j in 0..height {
        let theta = (j as f32 + 0.5) / height as f32 * PI;
        for i in 0..width {
            let phi = (i as f32 + 0.5) / width as f32 * 2.0 * PI;
            // u = atan2(x, −z)/2π, y up
            let d = [theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos()];
            let up = d[1];
            let c = if up >= 0.0 {
                let zenith = [0.10, 0.24, 0.66];
                let horizon = [0.80, 0.74, 0.64];
                mix(horizon, zenith, up.powf(0.3))
            } else {
                mix([0.45, 0.40, 0.34], [0.12, 0.11, 0.10], (-up).powf(0.5))
            };
            let cos = d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2];
            let angle = cos.clamp(-1.0, 1.0).acos();
            let disc = if angle < 0.1 { 40.0 } else { 0.0 };
            let glow = 2.0 * (-angle / 0.15).exp();
            let sun_col = [1.0, 0.92, 0.78];
            px.push(Rgb([0, 1, 2].map(|k| c[k] + (disc + glow) * sun_col[k])));
        }
    }
    px
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/showcase");
    std::fs::create_dir_all(&dir)?;

    tiles(128).save(dir.join("tiles.png"))?;

    let (w, h) = (128, 64);
    // the sun: behind the objects and to the left, 30° up
    let sky = sky(w, h, [-0.55, 0.58, -0.6]);
    HdrEncoder::new(std::io::BufWriter::new(std::fs::File::create(dir.join("sky.hdr"))?)).encode(&sky, w, h)?;

    // the floor: 24 × 24 around the origin, facing up, uv 0…1 (the scene repeats the texture)
    std::fs::write(
        dir.join("floor.obj"),
        "# showcase floor (make_showcase_assets)\n\
         v -12 0 12\nv 12 0 12\nv 12 0 -12\nv -12 0 -12\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         f 1/1 2/2 3/3 4/4\n",
    )?;
    // the area light: 1.2 × 1.2 at y = 3.2, emitting downwards
    std::fs::write(
        dir.join("light.obj"),
        "# showcase area light (make_showcase_assets); emits towards -y\n\
         v -0.6 3.2 -0.6\nv 0.6 3.2 -0.6\nv 0.6 3.2 0.6\nv -0.6 3.2 0.6\n\
         f 1 2 3 4\n",
    )?;
    for f in ["tiles.png", "sky.hdr", "floor.obj", "light.obj"] {
        println!("{} ({} bytes)", dir.join(f).display(), std::fs::metadata(dir.join(f))?.len());
    }
    Ok(())
}
