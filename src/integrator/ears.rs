//! Efficiency-aware Russian roulette and splitting (Rath, Grittmann, Herholz, Weier
//! and Slusallek 2022, "EARS"): `path` with `rr: "ears"`. At a vertex reached with
//! throughput β the estimator continues q sub-paths in expectation
//! ([`crate::integrator::estimator::Branches`]: roulette below 1, splitting above, at
//! most 8), where
//!
//!   q = β / √(I² + 0.01) · √(M / C) · √(C_img / V_img),
//!
//! the factor that minimises the image's relative variance × cost: I is the pixel's
//! estimate (blurred over 3×3 pixels; 0.01 is the relative MSE's own floor), C the rays
//! one continuation from the vertex costs, V_img and C_img the relative variance and ray
//! cost of a pixel sample, and M what a continuation's estimate X of the radiance the
//! vertex reflects adds to the variance: for roulette (q < 1) its second moment E[X²]
//! (the paper's), for splitting only its variance V[X] (averaging n sub-paths divides
//! V[X], not E[X]², by n; with E[X²], env_sphere's easy paths were split 8 ways and
//! the image had 8× `path`'s relMSE at equal time). X and C are learned per cell of a
//! grid over the scene. Easy regions
//! (little light coming back, or cheaply) end paths early, hard ones (a caustic seen
//! through glass) split them. Cost is counted in rays, never in seconds.
//!
//! The statistics are learned over passes that double: the first two passes play
//! Mitsuba's roulette, and the statistics of passes [2^k, 2^(k+1)) give the factors of
//! the next ones (a cell with fewer than [`MIN_RECORDS`] records keeps what it had,
//! or Mitsuba's rule). Every pass's samples are unbiased and all of them make the
//! image. Records are kept per tile and summed in tile order, so the image depends
//! on the scene, the seed and the spp only, not on the thread count.
//!
//! Media: vertices in a medium keep Mitsuba's roulette, and surface vertices play the
//! learned roulette without splitting (the media loop traces one path at a time).

use super::estimator::{trace, Branches, PathProfile, PathState, Policy, MAX_SPLIT, RR_DEPTH};
use super::pass::camera_pass_with;
use super::{PassContext, PassResult, PathTracer};
use crate::film::Film;
use crate::material::bsdf::Bsdf;
use crate::math::Vec3;
use crate::sampler::PixelSampler;
use crate::scene::{Interaction, Scene};

/// Cells of the statistics' grid per axis, over the scene's bounding cube.
const GRID: usize = 32;

/// Records a cell needs in an iteration before its factor is learned anew.
pub const MIN_RECORDS: u64 = 16;

/// Lowest survival probability (the paper's lower bound on the factor).
const MIN_SURVIVAL: f32 = 0.05;

/// What `path` with EARS keeps between passes (in the render loop's
/// [`crate::integrator::PassState`]).
pub struct State {
    lo: Vec3,
    cells_per_unit: f32,
    /// Each cell's √(E[X²] / C) and √(V[X] / C) (negative: not learned yet).
    cell_factors: Vec<[f32; 2]>,
    /// Each pixel's β-to-factor scale, 1/√(I² + 0.01) · √(C_img / V_img) (empty before
    /// the first iteration ends).
    pixel_factors: Vec<f32>,
    /// This iteration's records per cell: Σx, Σx², Σrays, count.
    cells: Vec<[f64; 4]>,
    /// This iteration's samples per pixel: Σy, Σy², count (y: mean over channels);
    /// and all iterations' Σy, count, for the pixels' estimates.
    pixels: Vec<[f64; 3]>,
    means: Vec<[f64; 2]>,
    /// This iteration's rays and samples.
    rays: u64,
    samples: u64,
    passes: u32,
    /// Iterations finished, and cells learned at the last one.
    pub iterations: u32,
    pub cells_learned: usize,
    pub image_factor: f32,
}

/// What a tile collects: the sub-paths' stack, and the records of its samples.
#[derive(Default)]
pub struct Scratch {
    pub branches: Branches,
    /// Cell, x (one continuation's estimate), rays.
    records: Vec<(u32, f32, u64)>,
    /// Pixel, y, rays.
    samples: Vec<(u32, f32, u64)>,
}

impl Scratch {
    /// Keeps the records of a camera sample of pixel `pixel` (of `pixels`) whose
    /// sub-paths, in [`Scratch::branches`], gave the estimate `l` with `rays` rays.
    pub fn keep_sample(&mut self, pixel: usize, pixels: usize, l: Vec3, rays: u64) {
        if l.is_finite() && pixel < pixels {
            let records = &mut self.records;
            self.branches.records(|cell, x, r| records.push((cell, x, r)));
            self.samples.push((pixel as u32, (l.x + l.y + l.z) / 3.0, rays));
        }
    }
}

impl State {
    pub fn new(ctx: &PassContext) -> State {
        let (w, h) = (ctx.film.width as usize, ctx.film.height as usize);
        let r = ctx.scene.radius.max(1e-6);
        State {
            lo: ctx.scene.center - Vec3::splat(r),
            cells_per_unit: GRID as f32 / (2.0 * r),
            cell_factors: vec![[-1.0; 2]; GRID * GRID * GRID],
            pixel_factors: Vec::new(),
            cells: vec![[0.0; 4]; GRID * GRID * GRID],
            pixels: vec![[0.0; 3]; w * h],
            means: vec![[0.0; 2]; w * h],
            rays: 0,
            samples: 0,
            passes: 0,
            iterations: 0,
            cells_learned: 0,
            image_factor: 0.0,
        }
    }

    /// The grid cell of point `p` (points outside the cube go to its border cells).
    #[inline]
    fn cell(&self, p: Vec3) -> u32 {
        let c = (p - self.lo) * self.cells_per_unit;
        let axis = |v: f32| (v as i64).clamp(0, GRID as i64 - 1) as usize;
        ((axis(c.z) * GRID + axis(c.y)) * GRID + axis(c.x)) as u32
    }

    /// Adds a finished pass's tiles; ends the iteration when the pass count reaches a
    /// power of two (2, 4, 8, …).
    pub fn add_pass<'a>(&mut self, tiles: impl IntoIterator<Item = &'a Scratch>, width: usize) {
        for t in tiles {
            for &(cell, x, rays) in &t.records {
                let c = &mut self.cells[cell as usize];
                c[0] += x as f64;
                c[1] += x as f64 * x as f64;
                c[2] += rays as f64;
                c[3] += 1.0;
            }
            for &(pixel, y, rays) in &t.samples {
                let (p, m) = (&mut self.pixels[pixel as usize], &mut self.means[pixel as usize]);
                p[0] += y as f64;
                p[1] += y as f64 * y as f64;
                p[2] += 1.0;
                m[0] += y as f64;
                m[1] += 1.0;
                self.rays += rays;
                self.samples += 1;
            }
        }
        self.passes += 1;
        if self.passes >= 2 && self.passes.is_power_of_two() {
            self.learn(width);
        }
    }

    /// The end of an iteration: the cells' factors from its records, the pixels'
    /// from its samples; then a fresh iteration.
    fn learn(&mut self, width: usize) {
        let mut learned = 0;
        for (f, c) in self.cell_factors.iter_mut().zip(&self.cells) {
            let [s, s2, rays, n] = *c;
            if n >= MIN_RECORDS as f64 {
                // a continuation costs its own ray at least
                let cost = (rays / n).max(1.0);
                let variance = ((s2 - s * s / n) / (n - 1.0)).max(0.0);
                *f = [((s2 / n) / cost).sqrt() as f32, (variance / cost).sqrt() as f32];
                learned += 1;
            }
        }
        // the pixels' estimates, blurred over 3×3 pixels against their noise
        let height = self.means.len() / width.max(1);
        let estimate = |x: usize, y: usize| {
            let (mut s, mut n) = (0.0, 0.0);
            for yy in y.saturating_sub(1)..(y + 2).min(height) {
                for xx in x.saturating_sub(1)..(x + 2).min(width) {
                    let m = self.means[yy * width + xx];
                    (s, n) = (s + m[0], n + m[1]);
                }
            }
            if n > 0.0 {
                s / n
            } else {
                0.0
            }
        };
        let mut relative = vec![0.0f64; self.means.len()];
        let mut variance = 0.0;
        for y in 0..height {
            for x in 0..width {
                let i = y * width + x;
                let i2 = estimate(x, y).powi(2) + 0.01;
                relative[i] = 1.0 / i2.sqrt();
                let [s, s2, n] = self.pixels[i];
                if n >= 2.0 {
                    variance += ((s2 - s * s / n) / (n - 1.0)).max(0.0) / i2;
                }
            }
        }
        variance /= self.means.len().max(1) as f64;
        let cost = self.rays as f64 / self.samples.max(1) as f64;
        if variance > 0.0 && variance.is_finite() && cost > 0.0 {
            let image = (cost / variance).sqrt();
            self.pixel_factors = relative.iter().map(|r| (r * image) as f32).collect();
            self.image_factor = image as f32;
        }
        self.cells_learned = learned;
        self.iterations += 1;
        self.cells.iter_mut().for_each(|c| *c = [0.0; 4]);
        self.pixels.iter_mut().for_each(|p| *p = [0.0; 3]);
        (self.rays, self.samples) = (0, 0);
    }

    /// The factor of the pixel `pixel`'s samples (`None` before anything is learned).
    pub fn pixel_factor(&self, pixel: usize) -> Option<f32> {
        self.pixel_factors.get(pixel).copied()
    }

    /// The EARS factor at `p` for throughput `beta` (see the module docs) and the cell of
    /// `p`, or `None` (with the cell) where the cell or the pixel has learned nothing yet.
    pub fn factor(&self, pixel_factor: Option<f32>, p: Vec3, beta: Vec3) -> (Option<f32>, u32) {
        let cell = self.cell(p);
        let [rr, split] = self.cell_factors[cell as usize];
        let Some(pixel) = pixel_factor.filter(|_| rr >= 0.0) else {
            return (None, cell);
        };
        let w = (beta.x + beta.y + beta.z) * (1.0 / 3.0) * pixel;
        let q = if w * rr < 1.0 {
            (w * rr).max(MIN_SURVIVAL)
        } else {
            (w * split).clamp(1.0, MAX_SPLIT as f32)
        };
        (Some(q), cell)
    }

    /// The expected number of sub-paths from a surface vertex at `p` reached with
    /// throughput `beta` by segment `segment` (see the module docs), at most 1 without
    /// `split`, and the vertex's cell: the learned factor where the cell and the pixel
    /// (`pixel_factor`) have been learned, Mitsuba's roulette elsewhere.
    pub fn split_factor(&self, pixel_factor: Option<f32>, split: bool, p: Vec3, beta: Vec3, eta_scale: f32, segment: u32) -> (f32, u32) {
        let (learned, cell) = self.factor(pixel_factor, p, beta);
        let q = match learned {
            Some(q) => q,
            None if segment >= RR_DEPTH => PathTracer::throughput_survival(beta, eta_scale),
            None => 1.0,
        };
        (if split { q } else { q.min(1.0) }, cell)
    }

    /// A line for the render summary.
    pub fn summary(&self) -> String {
        format!(
            "ears: {} iterations, {} of {} cells learned, image factor {:.3}",
            self.iterations,
            self.cells_learned,
            self.cell_factors.len(),
            self.image_factor
        )
    }
}

/// `path`'s policy with the learned roulette and splitting.
struct Ears<'a> {
    path: &'a PathTracer,
    state: &'a State,
    /// The sample's pixel's factor (`None`: nothing learned yet).
    pixel_factor: Option<f32>,
    split: bool,
    branches: &'a mut Branches,
}

impl Policy for Ears<'_> {
    type Plan = ();

    #[inline]
    fn profile(&self) -> PathProfile {
        self.path.profile
    }

    #[inline]
    fn max_depth(&self) -> u32 {
        self.path.max_depth
    }

    #[inline]
    fn hide_emitters(&self) -> bool {
        self.path.hide_emitters
    }

    #[inline]
    fn plan(&mut self, _: &Interaction, _: &Bsdf, _: &mut PixelSampler) {}

    const SPLITS: bool = true;

    /// The EARS factor (see the module docs) where the cell and the pixel have been
    /// learned; Mitsuba's roulette elsewhere.
    fn split_factor(&self, it: &Interaction, beta: Vec3, eta_scale: f32, segment: u32) -> (f32, u32) {
        self.state
            .split_factor(self.pixel_factor, self.split, it.p, beta, eta_scale, segment)
    }

    fn branches(&mut self) -> Option<&mut Branches> {
        Some(self.branches)
    }

    /// Medium vertices: Mitsuba's roulette.
    fn survival(&self, beta: Vec3, eta_scale: f32) -> f32 {
        PathTracer::throughput_survival(beta, eta_scale)
    }
}

/// A pass of `path` with `rr: "ears"` into `film`, learning in `state`.
pub fn render_pass(path: &PathTracer, ctx: &PassContext, pass: u32, film: &mut Film, state: &mut Option<Box<State>>) -> PassResult {
    let state = state.get_or_insert_with(|| Box::new(State::new(ctx)));
    let (scene, width, pixels) = (ctx.scene, ctx.film.width as usize, state.means.len());
    let learned: &State = state;
    let (result, tiles) = camera_pass_with(ctx, pass, film, Scratch::default, |s, scratch| {
        let pixel = s.pixel.1 as usize * width + s.pixel.0 as usize;
        let rays = s.counts.rays;
        let l = li(path, learned, scene, s, pixel, &mut scratch.branches);
        scratch.keep_sample(pixel, pixels, l, s.counts.rays - rays);
        l
    });
    if result.complete {
        state.add_pass(&tiles, width);
    }
    result
}

/// One camera sample's radiance (pixel index `pixel`).
pub fn li(path: &PathTracer, state: &State, scene: &Scene, s: &mut super::CameraSample, pixel: usize, branches: &mut Branches) -> Vec3 {
    branches.begin(s.counts.rays);
    let mut policy = Ears {
        path,
        state,
        pixel_factor: state.pixel_factor(pixel),
        split: !scene.has_media,
        branches,
    };
    let l = trace(&mut policy, scene, PathState::new(s.ray), 1, s.diff.as_ref(), s.sampler, s.counts);
    if scene.has_media {
        // the media loop ends its one path itself
        policy.branches.end_path(l, s.counts.rays);
    }
    l
}
