//! The render loop: passes over tiles on all cores, merged in a fixed order, so
//! the image depends only on the scene, the sample count and the seed.

use crate::compat::{self, Profile};
use crate::film::{Film, FilmTile};
use crate::integrator::intersection_test::{self, RayCounts};
use crate::integrator::{path, Integrator};
use crate::math::{Vec2, Vec3};
use crate::sampler::PixelSampler;
use crate::scene::Scene;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

#[derive(Clone)]
pub struct RenderSettings {
    pub spp: u32,
    pub seed: u32,
    pub profile: Profile,
    /// Called with the number of samples finished since the last call.
    pub progress: Option<std::sync::Arc<dyn Fn(u64) + Send + Sync>>,
    /// Wall-clock budget in seconds: no pass starts that would end after it.
    pub time_limit: Option<f64>,
}

#[derive(Clone, Debug)]
pub struct RenderOutput {
    pub width: u32,
    pub height: u32,
    /// Linear RGB, row 0 = top.
    pub pixels: Vec<Vec3>,
    /// Samples per pixel actually taken (fewer than asked when interrupted).
    pub spp_done: u32,
    pub samples: u64,
    pub rays: u64,
    pub seconds: f64,
    pub interrupted: bool,
    /// Samples that came out NaN or infinite and were left out of the image.
    pub invalid_samples: u64,
    /// The render stopped early to stay within `time_limit`.
    pub time_limited: bool,
}

/// Renders `scene`. When `stop` becomes true the render ends at the next pass
/// boundary (a column in `--compat rdr171`) and returns what is finished.
pub fn render(scene: &Scene, settings: &RenderSettings, stop: &AtomicBool) -> RenderOutput {
    let start = Instant::now();
    let report = |n: u64| {
        if let Some(p) = &settings.progress {
            p(n)
        }
    };
    let mut film = Film::new(scene.width, scene.height, scene.filter);
    let (mut spp_done, mut rays) = (0u32, 0u64);
    let mut interrupted = false;
    let mut time_limited = false;
    let mut invalid = 0u64;
    match settings.profile {
        Profile::Rdr171 => {
            let column_samples = scene.height as u64 * settings.spp as u64;
            let tiles = compat::rdr171::render_columns(scene, settings.spp, &|| stop.load(Ordering::Relaxed), &|| report(column_samples));
            interrupted = tiles.iter().any(Option::is_none);
            for t in tiles.iter().flatten() {
                film.merge(t);
            }
            spp_done = if interrupted { 0 } else { settings.spp };
        }
        Profile::Physical => {
            // one sample per pixel per pass: fine steps for --time-limit and
            // Ctrl-C; merging a pass costs far less than rendering it
            let passes = settings.spp;
            let mut last_pass = 0.0f64;
            let ray_count = AtomicU64::new(0);
            let invalid_count = AtomicU64::new(0);
            let diff_scale = differential_scale(settings.spp);
            let tiles = tile_grid(scene);
            for pass in 0..passes {
                if stop.load(Ordering::Relaxed) {
                    interrupted = true;
                    break;
                }
                if let Some(limit) = settings.time_limit {
                    // start a pass only if it should end within the limit (the first always runs)
                    if pass > 0 && start.elapsed().as_secs_f64() + last_pass > limit {
                        time_limited = true;
                        break;
                    }
                }
                let pass_start = Instant::now();
                let s0 = settings.spp * pass / passes;
                let s1 = settings.spp * (pass + 1) / passes;
                let done: Vec<FilmTile> = tiles
                    .par_iter()
                    .map(|&(x0, y0, x1, y1)| {
                        let t = render_tile(
                            scene,
                            (x0, y0, x1, y1),
                            s0..s1,
                            settings.seed,
                            diff_scale,
                            &ray_count,
                            &invalid_count,
                        );
                        report(((x1 - x0) * (y1 - y0)) as u64 * (s1 - s0) as u64);
                        t
                    })
                    .collect();
                for t in &done {
                    film.merge(t);
                }
                spp_done = s1;
                last_pass = pass_start.elapsed().as_secs_f64();
            }
            rays = ray_count.load(Ordering::Relaxed);
            invalid = invalid_count.load(Ordering::Relaxed);
        }
    }
    RenderOutput {
        width: scene.width,
        height: scene.height,
        pixels: film.to_rgb_rows(),
        spp_done,
        samples: scene.width as u64 * scene.height as u64 * spp_done as u64,
        rays,
        seconds: start.elapsed().as_secs_f64(),
        interrupted,
        invalid_samples: invalid,
        time_limited,
    }
}

/// Camera-ray differentials span one pixel; with `spp` samples per pixel each sample
/// stands for a smaller footprint, so they are scaled by `max(1/8, 1/√spp)` (pbrt-v4).
/// Textures are then filtered over about one sample's share of the pixel: a 1-spp
/// image is antialiased by the MIP pyramid, and many samples converge to the
/// supersampled (not the over-blurred) picture.
pub fn differential_scale(spp: u32) -> f32 {
    (1.0 / (spp.max(1) as f32).sqrt()).max(0.125)
}

fn tile_grid(scene: &Scene) -> Vec<(i32, i32, i32, i32)> {
    let b = scene.block_size.max(1) as i32;
    let (w, h) = (scene.width as i32, scene.height as i32);
    let mut tiles = Vec::new();
    for y0 in (0..h).step_by(b as usize) {
        for x0 in (0..w).step_by(b as usize) {
            tiles.push((x0, y0, (x0 + b).min(w), (y0 + b).min(h)));
        }
    }
    tiles
}

fn render_tile(
    scene: &Scene,
    (x0, y0, x1, y1): (i32, i32, i32, i32),
    samples: std::ops::Range<u32>,
    seed: u32,
    diff_scale: f32,
    ray_count: &AtomicU64,
    invalid_count: &AtomicU64,
) -> FilmTile {
    let (w, h) = (scene.width as i32, scene.height as i32);
    let mut tile = FilmTile::new(x0, y0, x1, y1, scene.filter.reach(), w, h);
    let mut counts = RayCounts::default();
    for y in y0..y1 {
        for x in x0..x1 {
            for s in samples.clone() {
                let mut sampler = PixelSampler::new(x as u32, y as u32, s, seed);
                let (u, v) = sampler.next_2d();
                let pos = Vec2::new(x as f32 + u, y as f32 + v);
                // differentials only matter to image textures: skip them otherwise
                let (ray, diff) = if scene.uses_footprints {
                    let (ray, diff) = scene.camera.ray_differential(pos.x, pos.y);
                    (ray, Some(diff.scaled(&ray, diff_scale)))
                } else {
                    (scene.camera.ray(pos.x, pos.y), None)
                };
                let l = match scene.integrator {
                    Integrator::IntersectionTest => intersection_test::li(scene, ray, diff, &mut sampler, &mut counts),
                    Integrator::Path { profile, .. } => path::li(scene, ray, diff, &mut sampler, &mut counts, profile),
                };
                if l.is_finite() {
                    tile.add(pos, l, &scene.filter, w, h);
                } else {
                    counts.invalid += 1; // dropped, reported at the end
                }
            }
        }
    }
    ray_count.fetch_add(counts.rays, Ordering::Relaxed);
    invalid_count.fetch_add(counts.invalid, Ordering::Relaxed);
    tile
}
