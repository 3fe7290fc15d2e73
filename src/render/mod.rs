//! The render loop: an integrator's passes over the film, with Ctrl-C (the stop
//! token), `--time-limit`, NaN counting and progress. Passes are deterministic and
//! merged in a fixed order, so the image depends only on the scene, the job
//! (sample count, seed) and never on the thread count or timing.

pub mod blocks;
pub mod denoise;
pub mod identity;
pub mod job;
pub mod params;
pub mod session;
pub mod statefile;
pub mod tev;

pub use blocks::{FilmState, Piece, BLOCK_PASSES};
pub use job::{load, load_with_defines, Loaded, RenderJob};

use crate::film::Film;
use crate::integrator::{PassContext, PassState, StopToken};
use crate::math::Vec3;
use crate::scene::Scene;
use std::sync::Arc;
use std::time::Instant;

/// How a caller watches a render: progress callback (samples finished since the
/// last call), the stop token (Ctrl-C), and callbacks that get the image and the film
/// state every so often (checkpoints, previews, a viewer).
#[derive(Clone, Default)]
pub struct RenderControl {
    pub progress: Option<Arc<dyn Fn(u64) + Send + Sync>>,
    pub stop: Arc<StopToken>,
    pub periodic: Vec<Periodic>,
}

/// A callback run after a finished pass when `every` seconds have passed since it
/// last ran (or since the start).
#[derive(Clone)]
pub struct Periodic {
    pub every: f64,
    pub call: Arc<dyn Fn(&Snapshot) + Send + Sync>,
}

/// The render so far: its image and the film state it came from.
pub struct Snapshot<'a> {
    pub width: u32,
    pub height: u32,
    /// Linear RGB, row 0 = top.
    pub pixels: &'a [Vec3],
    pub state: &'a FilmState,
    pub spp_done: u32,
}

#[derive(Clone, Debug)]
pub struct RenderOutput {
    pub width: u32,
    pub height: u32,
    /// Linear RGB, row 0 = top.
    pub pixels: Vec<Vec3>,
    /// Samples per pixel the image holds (fewer than asked when interrupted; with a
    /// resumed state, its passes count too).
    pub spp_done: u32,
    /// Samples taken by this run.
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
    /// The film state the image is made of (the pieces of [`blocks`]), to be saved for
    /// a resume or a merge.
    pub state: FilmState,
    /// Feature-buffer sums, when asked for ([`render_with_aov`]).
    pub aov: Option<crate::film::AovSums>,
    /// Images besides the main one, named ([`crate::integrator::Integrator::extra_images`]).
    pub extra_images: Vec<(String, Vec<Vec3>)>,
}

/// Renders `scene` as `job` says. When the stop token is set the current pass is
/// abandoned (integrators check it per tile) and the finished passes are returned.
pub fn render(scene: &Scene, job: &RenderJob, control: &RenderControl) -> RenderOutput {
    render_from(scene, job, control, FilmState::default())
}

/// [`render`] continuing from `start`, the state of an earlier render of the same job
/// whose pieces end where this one's passes ([`RenderJob::passes`]) begin: the result
/// is the same, bit for bit, as one render of all the passes.
pub fn render_from(scene: &Scene, job: &RenderJob, control: &RenderControl, start: FilmState) -> RenderOutput {
    render_with_aov(scene, job, control, start, false)
}

/// [`render_from`], also summing feature buffers when `aov` (for integrators with
/// [`crate::integrator::Integrator::supports_aov`]; the image is the same either way).
pub fn render_with_aov(scene: &Scene, job: &RenderJob, control: &RenderControl, start: FilmState, aov: bool) -> RenderOutput {
    let t0 = Instant::now();
    let invalid_rays_before = crate::accel::wide::invalid_rays();
    let report = |n: u64| {
        if let Some(p) = &control.progress {
            p(n)
        }
    };
    let f = &job.film;
    let mut film = Film::new(f.width, f.height, f.filter);
    if aov {
        film.enable_aov();
    }
    let ctx = PassContext {
        scene,
        camera: &job.camera,
        film: &job.film,
        spp: job.spp,
        target_spp: job.target_spp,
        seed: job.seed,
        time_limit: job.time_limit,
        stop: &control.stop,
        progress: &report,
    };
    let total = job.integrator.pass_count(job.spp);
    let range = job.passes.clone().unwrap_or(0..total);
    let mut state = start;
    let mut next = state.pieces.last().map_or(range.start, |p| p.passes.end).max(range.start);
    // an unfinished block goes on in the film
    let mut block_start = next;
    if state.pieces.last().is_some_and(|p| p.passes.end % BLOCK_PASSES != 0) {
        let last = state.pieces.pop().expect("a last piece");
        block_start = last.passes.start;
        film.set_sums(last.sums);
    }
    // the pieces and, if the film holds an unfinished block, its sums as one more piece
    let partial = |mut s: FilmState, film: &Film, block_start: u32, end: u32| {
        if end > block_start {
            s.pieces.push(Piece {
                passes: block_start..end,
                sums: film.sums().clone(),
            });
        }
        s
    };
    let spp_of = |state: &FilmState| job.integrator.spp_done(job.spp, state.passes_done());
    // the integrator's state between passes: the loop owns it, each pass gets it
    let mut integrator_state = PassState::default();
    let image_of = |state: &FilmState, film: &Film, estimate: Option<&[Vec3]>| {
        let sums = state.total().unwrap_or_else(|| film.sums().clone());
        crate::film::rgb_rows(f.width, f.height, &sums, estimate, 1.0 / spp_of(state).max(1) as f64)
    };
    let (mut rays, mut invalid, mut rendered) = (0u64, 0u64, 0u64);
    let (mut interrupted, mut time_limited) = (false, false);
    let mut last_pass = 0.0f64;
    let mut last_call = vec![t0; control.periodic.len()];
    let first = next;
    while next < range.end {
        if control.stop.is_stopped() {
            interrupted = true;
            break;
        }
        if let Some(limit) = job.time_limit {
            // start a pass only if it should end within the limit (the first always runs)
            if next > first && t0.elapsed().as_secs_f64() + last_pass > limit {
                time_limited = true;
                break;
            }
        }
        let pass_start = Instant::now();
        let r = job.integrator.render_pass(&ctx, next, &mut film, &mut integrator_state);
        rays += r.counts.rays;
        invalid += r.counts.invalid;
        if !r.complete {
            interrupted = true;
            break;
        }
        next += 1;
        rendered += 1;
        last_pass = pass_start.elapsed().as_secs_f64();
        if next.is_multiple_of(BLOCK_PASSES) {
            state.push(Piece {
                passes: block_start..next,
                sums: film.take_sums(next < range.end),
            });
            block_start = next;
        }
        let due: Vec<usize> = (0..control.periodic.len())
            .filter(|&i| last_call[i].elapsed().as_secs_f64() >= control.periodic[i].every)
            .collect();
        if !due.is_empty() && next < range.end {
            let estimate = job.integrator.estimate(&integrator_state, f.width as usize);
            let snap_state = partial(state.clone(), &film, block_start, next);
            let pixels = image_of(&snap_state, &film, estimate.as_deref());
            let snap = Snapshot {
                width: f.width,
                height: f.height,
                pixels: &pixels,
                state: &snap_state,
                spp_done: spp_of(&snap_state),
            };
            for i in due {
                (control.periodic[i].call)(&snap);
                last_call[i] = Instant::now();
            }
        }
    }
    // the image: with no finished block the film alone (also a compat render's
    // finished columns of an interrupted pass), else the pieces and the film's block
    let estimate = job.integrator.estimate(&integrator_state, f.width as usize);
    let finished_blocks = !state.pieces.is_empty();
    // the state moves into the output (a copy of its pieces was megabytes of fresh memory)
    let image_state = partial(state, &film, block_start, next);
    let pixels = if !finished_blocks {
        crate::film::rgb_rows(
            f.width,
            f.height,
            film.sums(),
            estimate.as_deref(),
            1.0 / spp_of(&image_state).max(1) as f64,
        )
    } else {
        image_of(&image_state, &film, estimate.as_deref())
    };
    let spp_done = spp_of(&image_state);
    let run_spp = job.integrator.spp_done(job.spp, rendered as u32);
    let weights = || image_state.total().map_or_else(|| film.sums().weight.clone(), |s| s.weight);
    let extra_images = job
        .integrator
        .extra_images(&integrator_state, weights, 1.0 / spp_done.max(1) as f64);
    RenderOutput {
        width: f.width,
        height: f.height,
        pixels,
        spp_done,
        samples: (f.width as u64 * f.height as u64).saturating_mul(run_spp as u64),
        rays,
        seconds: t0.elapsed().as_secs_f64(),
        interrupted,
        invalid_samples: invalid,
        time_limited,
        summary: job.integrator.summary(&integrator_state),
        extra_images,
        invalid_rays: crate::accel::wide::invalid_rays() - invalid_rays_before,
        state: image_state,
        aov: film.aov().cloned(),
    }
}
