//! The render loop: an integrator's passes over the film, with Ctrl-C (the stop
//! token), `--time-limit`, NaN counting and progress. Passes are deterministic and
//! merged in a fixed order, so the image depends only on the scene, the job
//! (sample count, seed) and never on the thread count or timing.

pub mod job;

pub use job::{load, load_with_defines, Loaded, RenderJob};

use crate::film::Film;
use crate::integrator::{PassContext, StopToken};
use crate::math::Vec3;
use crate::scene::Scene;
use std::sync::Arc;
use std::time::Instant;

/// How a caller watches a render: progress callback (samples finished since the
/// last call) and the stop token (Ctrl-C).
#[derive(Clone, Default)]
pub struct RenderControl {
    pub progress: Option<Arc<dyn Fn(u64) + Send + Sync>>,
    pub stop: Arc<StopToken>,
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
    /// What the integrator reports besides the image (photon counts, memory, radii).
    pub summary: Option<String>,
    /// Rays with a NaN or infinite origin or direction, treated as misses (counted
    /// process-wide: renders running at the same time add to each other's figure).
    pub invalid_rays: u64,
}

/// Renders `scene` as `job` says. When the stop token is set the current pass is
/// abandoned (integrators check it per tile) and the finished passes are returned.
pub fn render(scene: &Scene, job: &RenderJob, control: &RenderControl) -> RenderOutput {
    let start = Instant::now();
    let invalid_rays_before = crate::accel::wide::invalid_rays();
    let report = |n: u64| {
        if let Some(p) = &control.progress {
            p(n)
        }
    };
    let f = &job.film;
    let mut film = Film::new(f.width, f.height, f.filter);
    let ctx = PassContext {
        scene,
        camera: &job.camera,
        film: &job.film,
        spp: job.spp,
        seed: job.seed,
        stop: &control.stop,
        progress: &report,
    };
    let (mut passes_done, mut rays, mut invalid) = (0u32, 0u64, 0u64);
    let (mut interrupted, mut time_limited) = (false, false);
    let passes = job.integrator.pass_count(job.spp);
    let mut last_pass = 0.0f64;
    for pass in 0..passes {
        if control.stop.is_stopped() {
            interrupted = true;
            break;
        }
        if let Some(limit) = job.time_limit {
            // start a pass only if it should end within the limit (the first always runs)
            if pass > 0 && start.elapsed().as_secs_f64() + last_pass > limit {
                time_limited = true;
                break;
            }
        }
        let pass_start = Instant::now();
        let r = job.integrator.render_pass(&ctx, pass, &mut film);
        rays += r.counts.rays;
        invalid += r.counts.invalid;
        if !r.complete {
            interrupted = true;
            break;
        }
        passes_done = pass + 1;
        last_pass = pass_start.elapsed().as_secs_f64();
    }
    let spp_done = job.integrator.spp_done(job.spp, passes_done);
    RenderOutput {
        width: f.width,
        height: f.height,
        pixels: film.to_rgb_rows(1.0 / spp_done.max(1) as f64),
        spp_done,
        samples: (f.width as u64 * f.height as u64).saturating_mul(spp_done as u64),
        rays,
        seconds: start.elapsed().as_secs_f64(),
        interrupted,
        invalid_samples: invalid,
        time_limited,
        summary: job.integrator.summary(&film),
        invalid_rays: crate::accel::wide::invalid_rays() - invalid_rays_before,
    }
}
