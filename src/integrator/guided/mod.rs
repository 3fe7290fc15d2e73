//! Path guiding (the `guided` integrator): Müller, Gross and Novák, "Practical
//! Path Guiding for Efficient Light-Transport Simulation" (2017), on top of the
//! `path` integrator's estimator (light selection, NEE, MIS, roulette).
//!
//! An SD-tree ([`sdtree`]: a binary tree over a cube around the scene whose
//! leaves hold directional quadtrees, [`quadtree`]) learns the radiance arriving
//! at surfaces. Rendering goes in iterations of 1, 2, 4, … samples per pixel;
//! each training iteration samples from the tree the previous one recorded and
//! records what its paths find (radiance from light samples and from BSDF- or
//! guide-sampled hits, MIS-weighted, divided by the sampling density). At its
//! end spatial leaves that recorded more than `c·√spp` vertices are split, the
//! recording becomes the sampling distribution, and the next recording tree is
//! refined where a cell holds more than ρ = 1 % of its leaf's energy.
//!
//! At non-specular vertices directions come from a mixture: the BSDF with
//! probability `bsdf_fraction`, the learned distribution otherwise; MIS against
//! light sampling uses the mixture's density, so every iteration is unbiased.
//! Specular vertices sample their BSDF. The image combines the iterations with
//! one weight per iteration, the inverse of its estimated variance (mean over
//! pixels of the relative variance of the pixel mean, the `rdr compare` metric's
//! weighting), or shows the last iteration alone (`combine: "last"`).
//!
//! Schedule: with an spp budget, iterations double while the rest still holds
//! at least one more doubling, and the last takes what remains (64 spp: 1, 2, 4,
//! 8, 16, then 33). Under `--time-limit` training stops when the predicted
//! variance of the final image, (V_k·T_k) / (budget left at the start of
//! iteration k), rises from one iteration to the next (the paper's balancing),
//! or when the next iteration could not end within the limit; the last iteration
//! then renders until the render loop stops it.
//!
//! Deterministic: records are kept per tile and deposited in tile order after
//! each pass, so the trees, and with them the image, do not depend on the
//! thread count (timing matters only under `--time-limit`).

pub mod path;
pub mod quadtree;
pub mod sdtree;

pub use path::{Guiding, Mixture, Record, Scratch};
pub use quadtree::{sphere_to_square, square_to_sphere, DTree};
pub use sdtree::{SdTree, TreeStats};

use super::pass::{differential_scale, tile_grid};
use super::{PassContext, PassResult, RayCounts};
use crate::film::{Film, FilmTile};
use crate::math::{Vec2, Vec3};
use crate::sampler::{hash_combine, PixelSampler};
use crate::scene::Scene;
use rayon::prelude::*;
use std::time::Instant;

/// Energy share above which a directional cell is split (the paper's ρ).
pub const RHO: f32 = 0.01;

/// How the iterations' images make the final one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Combine {
    /// One weight per iteration, 1 / its estimated variance.
    #[default]
    InverseVariance,
    /// The last iteration alone.
    Last,
}

/// Parameters (JSON `integrator` keys, besides `type`):
/// * `spp` (int ≥ 1, 64) — the whole budget, training included;
/// * `max_depth` (int ≥ 1, 12) and `rr_threshold` (number, 0.1) — as `path`
///   (roulette follows `path`'s rule; the threshold is read and kept);
/// * `bsdf_fraction` (number in (0, 1], 0.5) — probability of BSDF sampling at a
///   guided vertex (1: never guided);
/// * `training_iterations` (int ≥ 0, absent: chosen by the budget, see the
///   module docs) — doubling iterations before the final one;
/// * `combine` (`"inverse_variance"` | `"last"`, `"inverse_variance"`);
/// * `spatial_threshold` (number > 0, 2000) — the paper's c: a spatial leaf is
///   split when an iteration of n spp records more than c·√n vertices in it (the
///   paper's 12000 suits longer renders than the minute's tens of spp here: leaves
///   that span several walls send guided samples below the surface);
/// * `learn_direct` (bool, false) — `true`: the tree learns all radiance arriving
///   at a vertex, direct light included (the paper, whose path tracer had no light
///   sampling); `false`: only what arrives by way of other surfaces or specular
///   chains (light sampled at later vertices included), leaving the direct light
///   to light sampling, which handles it better (cbox, 33 spp: relMSE 1.2e-2 with
///   direct light learned, 7.0e-3 without, `path` 5.5e-3).
///
/// ```json
/// {"type": "guided", "spp": 256, "bsdf_fraction": 0.5, "combine": "inverse_variance"}
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Guided {
    pub max_depth: u32,
    pub rr_threshold: f32,
    pub bsdf_fraction: f32,
    pub training_iterations: Option<u32>,
    pub combine: Combine,
    pub spatial_threshold: f32,
    pub learn_direct: bool,
}

impl Default for Guided {
    fn default() -> Self {
        Guided {
            max_depth: 12,
            rr_threshold: 0.1,
            bsdf_fraction: 0.5,
            training_iterations: None,
            combine: Combine::InverseVariance,
            spatial_threshold: 2000.0,
            learn_direct: false,
        }
    }
}

/// One finished (or running) iteration, for the summary.
#[derive(Clone, Copy, Debug, Default)]
pub struct IterationInfo {
    pub spp: u32,
    /// Rendering and recording.
    pub seconds: f64,
    /// Refining and rebuilding the tree at its end.
    pub build_seconds: f64,
    /// Estimated relative variance of its image.
    pub variance: f64,
    pub last: bool,
    /// The tree it sampled from.
    pub tree: TreeStats,
}

/// What the integrator keeps in the film between passes.
pub struct State {
    pub tree: SdTree,
    pub history: Vec<IterationInfo>,
    /// The schedule, in words.
    pub schedule: String,
    started: Instant,
    /// Elapsed seconds when the current iteration began.
    iteration_start: f64,
    length: u32,
    last: bool,
    passes: u32,
    passes_total: u32,
    /// Predicted final variance after the previous training iteration.
    predicted: Option<f64>,
    stop_training: bool,
    /// The current iteration's image (film rows, y up) and per-pixel moments of
    /// the samples' mean over channels: Σy, Σy², n.
    sum: Vec<[f64; 3]>,
    weight: Vec<f64>,
    moments: Vec<[f64; 3]>,
    /// Finished iterations: Σ image/variance and Σ 1/variance (for `last`: the
    /// previous image, weight 1).
    done: Vec<[f64; 3]>,
    done_weight: f64,
}

struct TileOut {
    tile: FilmTile,
    records: Vec<Record>,
    /// Moments of the tile's own pixels, row by row.
    moments: Vec<[f64; 3]>,
    rect: (i32, i32, i32, i32),
    counts: RayCounts,
}

impl Guided {
    /// Doubling iterations the spp budget gives when `training_iterations` is absent:
    /// the most K with 2^(K+1) − 1 ≤ spp (the final one keeps at least 2^K).
    pub fn auto_training_iterations(spp: u32) -> u32 {
        let mut k = 0u32;
        while k < 30 && (1u64 << (k + 2)) - 1 <= spp as u64 {
            k += 1;
        }
        k
    }

    fn new_state(&self, ctx: &PassContext) -> State {
        let n = (ctx.film.width * ctx.film.height) as usize;
        let schedule = match (ctx.time_limit, self.training_iterations) {
            (_, Some(k)) => format!("{k} training iterations (given)"),
            (Some(t), None) => format!("time budget of {t} s (training stops when the predicted final variance rises)"),
            (None, None) => format!("spp budget: {} training iterations", Self::auto_training_iterations(ctx.spp)),
        };
        let mut s = State {
            tree: SdTree::new(ctx.scene.center, ctx.scene.radius, DTree::initial(RHO)),
            history: Vec::new(),
            schedule,
            started: Instant::now(),
            iteration_start: 0.0,
            length: 0,
            last: false,
            passes: 0,
            passes_total: 0,
            predicted: None,
            stop_training: false,
            sum: vec![[0.0; 3]; n],
            weight: vec![0.0; n],
            moments: vec![[0.0; 3]; n],
            done: vec![[0.0; 3]; n],
            done_weight: 0.0,
        };
        self.begin_iteration(&mut s, ctx);
        s
    }

    /// Length and kind of the next iteration.
    fn begin_iteration(&self, s: &mut State, ctx: &PassContext) {
        let k = s.history.len() as u32;
        let remaining = ctx.spp.saturating_sub(s.passes_total).max(1);
        let length = 1u32 << k.min(31);
        let training = match self.training_iterations {
            Some(n) => k < n,
            None if ctx.time_limit.is_some() => !s.stop_training,
            None => k < Self::auto_training_iterations(ctx.spp),
        };
        s.last = !training || length >= remaining;
        s.length = if s.last { remaining } else { length };
        s.passes = 0;
        s.iteration_start = s.started.elapsed().as_secs_f64();
        s.history.push(IterationInfo {
            last: s.last,
            tree: s.tree.stats(),
            ..IterationInfo::default()
        });
    }

    pub fn render_pass(&self, ctx: &PassContext, pass: u32, film: &mut Film) -> PassResult {
        let mut state = film.take_aux::<State>().unwrap_or_else(|| Box::new(self.new_state(ctx)));
        let pass_start = Instant::now();
        let guiding = Guiding {
            tree: &state.tree,
            bsdf_fraction: self.bsdf_fraction,
            record: !state.last,
            max_depth: self.max_depth,
            record_direct: self.learn_direct,
        };
        // each iteration draws from its own scrambling of the sampler, starting at
        // sample 0: its samples are then independent of the ones the tree it samples
        // from was learned from (the same pixel's Sobol points are correlated, and an
        // adaptive density that depends on them would be biased)
        let iteration = state.history.len() as u32 - 1;
        let seed = hash_combine(ctx.seed, 0x5eed_0000 + iteration);
        let tiles = render_tiles(ctx, state.passes, seed, &guiding);
        let _ = pass;
        let mut result = PassResult {
            complete: tiles.iter().all(Option::is_some),
            counts: RayCounts::default(),
        };
        for t in tiles.iter().flatten() {
            result.counts += t.counts;
        }
        if !result.complete {
            film.set_aux(state);
            return result;
        }
        let s = &mut *state;
        let w = ctx.film.width as i32;
        for t in tiles.iter().flatten() {
            merge_tile(&mut s.sum, &mut s.weight, w, &t.tile);
            let (x0, y0, x1, _) = t.rect;
            let tw = (x1 - x0) as usize;
            for (i, m) in t.moments.iter().enumerate() {
                let (x, y) = (x0 as usize + i % tw, y0 as usize + i / tw);
                let d = &mut s.moments[y * w as usize + x];
                for c in 0..3 {
                    d[c] += m[c];
                }
            }
            for r in &t.records {
                let leaf = &mut s.tree.leaves[r.leaf as usize];
                if r.counted {
                    leaf.count += 1;
                }
                if r.value > 0.0 && r.value.is_finite() {
                    leaf.building.deposit(r.cell, r.value);
                }
            }
        }
        drop(tiles);
        s.passes += 1;
        s.passes_total += 1;
        let info = s.history.last_mut().expect("an iteration is running");
        info.spp = s.passes;
        info.seconds += pass_start.elapsed().as_secs_f64();
        if s.passes >= s.length && !s.last {
            self.end_iteration(s, ctx);
        }
        film.set_estimate(self.estimate(s, ctx.film.width as usize));
        film.set_aux(state);
        result
    }

    /// Folds the finished training iteration into the image, rebuilds the tree and
    /// starts the next iteration.
    fn end_iteration(&self, s: &mut State, ctx: &PassContext) {
        let build_start = Instant::now();
        let v = variance(&s.moments, ctx.film.width as usize).max(1e-30);
        let image = current_image(&s.sum, &s.weight);
        match self.combine {
            Combine::InverseVariance => {
                for (d, p) in s.done.iter_mut().zip(&image) {
                    for c in 0..3 {
                        d[c] += p[c] as f64 / v;
                    }
                }
                s.done_weight += 1.0 / v;
            }
            Combine::Last => {
                for (d, p) in s.done.iter_mut().zip(&image) {
                    *d = [p.x as f64, p.y as f64, p.z as f64];
                }
                s.done_weight = 1.0;
            }
        }
        let threshold = self.spatial_threshold as f64 * (s.length as f64).sqrt();
        s.tree.end_iteration(threshold, RHO, true);
        let build = build_start.elapsed().as_secs_f64();
        let info = s.history.last_mut().expect("an iteration is running");
        info.variance = v;
        info.build_seconds = build;
        if let Some(limit) = ctx.time_limit {
            // the paper's balancing: V_k·T_k spread over the budget left at the
            // iteration's start predicts the final image's variance
            let spent = info.seconds + build;
            let predicted = v * spent / (limit - s.iteration_start).max(1e-9);
            let now = s.started.elapsed().as_secs_f64();
            if s.predicted.is_some_and(|p| predicted > p) || now + 2.0 * spent > limit {
                s.stop_training = true;
            }
            s.predicted = Some(predicted);
        }
        for x in s.sum.iter_mut() {
            *x = [0.0; 3];
        }
        s.weight.iter_mut().for_each(|x| *x = 0.0);
        s.moments.iter_mut().for_each(|x| *x = [0.0; 3]);
        self.begin_iteration(s, ctx);
    }

    /// The image so far (film rows, y up).
    fn estimate(&self, s: &State, width: usize) -> Vec<Vec3> {
        let current = current_image(&s.sum, &s.weight);
        let to_vec = |d: &[f64; 3], w: f64| Vec3::new((d[0] / w) as f32, (d[1] / w) as f32, (d[2] / w) as f32);
        if s.passes == 0 {
            return s.done.iter().map(|d| to_vec(d, s.done_weight.max(1e-300))).collect();
        }
        match self.combine {
            Combine::Last => current,
            Combine::InverseVariance => {
                let wc = 1.0 / variance(&s.moments, width).max(1e-30);
                let total = s.done_weight + wc;
                s.done
                    .iter()
                    .zip(&current)
                    .map(|(d, c)| {
                        let mix = [d[0] + c.x as f64 * wc, d[1] + c.y as f64 * wc, d[2] + c.z as f64 * wc];
                        to_vec(&mix, total)
                    })
                    .collect()
            }
        }
    }

    /// Schedule, iterations and tree sizes, for the render summary.
    pub fn summary(&self, film: &Film) -> Option<String> {
        let s = film.aux::<State>()?;
        let stats = s.tree.stats();
        let iterations: Vec<String> = s
            .history
            .iter()
            .filter(|i| i.spp > 0)
            .map(|i| {
                format!(
                    "{}{} spp {:.2} s (tree {} leaves, {:.1} MB; build {:.1} ms{})",
                    if i.last { "final " } else { "" },
                    i.spp,
                    i.seconds,
                    i.tree.spatial_leaves,
                    i.tree.bytes as f64 / 1e6,
                    i.build_seconds * 1e3,
                    if i.variance > 0.0 {
                        format!(", variance {:.2e}", i.variance)
                    } else {
                        String::new()
                    }
                )
            })
            .collect();
        Some(format!(
            "guided: schedule {}; combine {}; iterations: {}; SD-tree {} spatial leaves, {} directional nodes (depth ≤ {}), {:.1} MB",
            s.schedule,
            match self.combine {
                Combine::InverseVariance => "inverse variance",
                Combine::Last => "last iteration",
            },
            iterations.join(", "),
            stats.spatial_leaves,
            stats.directional_nodes,
            stats.max_directional_depth,
            stats.bytes as f64 / 1e6
        ))
    }
}

/// The learned SD-tree of a render's film (for tests and inspection).
pub fn learned_tree(film: &Film) -> Option<&SdTree> {
    film.aux::<State>().map(|s| &s.tree)
}

/// Renders sample `sample` (of the sampler seeded by `seed`) of every pixel, tiles in parallel, each with its
/// records and moments; `None` for tiles skipped after a stop.
fn render_tiles(ctx: &PassContext, sample: u32, seed: u32, guiding: &Guiding) -> Vec<Option<TileOut>> {
    let scene: &Scene = ctx.scene;
    let diff_scale = differential_scale(ctx.spp);
    let (w, h) = (ctx.film.width as i32, ctx.film.height as i32);
    let filter = &ctx.film.filter;
    tile_grid(ctx.film)
        .par_iter()
        .map(|&(x0, y0, x1, y1)| {
            if ctx.stop.is_stopped() {
                return None;
            }
            let mut tile = FilmTile::new(x0, y0, x1, y1, filter.reach(), w, h);
            let mut counts = RayCounts::default();
            let mut scratch = Scratch::default();
            let mut moments = vec![[0.0f64; 3]; ((x1 - x0) * (y1 - y0)) as usize];
            for y in y0..y1 {
                for x in x0..x1 {
                    let mut sampler = PixelSampler::new(x as u32, y as u32, sample, seed);
                    let (u, v) = sampler.next_2d();
                    let pos = Vec2::new(x as f32 + u, y as f32 + v);
                    let u_lens = crate::integrator::lens_sample(ctx.camera, &mut sampler);
                    let (ray, diff) = if scene.uses_footprints {
                        let (ray, diff) = ctx.camera.sample_ray_differential(pos.x, pos.y, u_lens);
                        (ray, Some(diff.scaled(&ray, diff_scale)))
                    } else {
                        (ctx.camera.sample_ray(pos.x, pos.y, u_lens), None)
                    };
                    let mark = scratch.records.len();
                    let l = guiding.li(scene, ray, diff, &mut sampler, &mut counts, &mut scratch);
                    if l.is_finite() {
                        tile.add(pos, l, filter, w, h);
                        let yv = ((l.x + l.y + l.z) / 3.0) as f64;
                        let m = &mut moments[((y - y0) * (x1 - x0) + (x - x0)) as usize];
                        m[0] += yv;
                        m[1] += yv * yv;
                        m[2] += 1.0;
                    } else {
                        counts.invalid += 1;
                        scratch.records.truncate(mark);
                    }
                }
            }
            (ctx.progress)(((x1 - x0) * (y1 - y0)) as u64);
            Some(TileOut {
                tile,
                records: scratch.records,
                moments,
                rect: (x0, y0, x1, y1),
                counts,
            })
        })
        .collect()
}

fn merge_tile(sum: &mut [[f64; 3]], weight: &mut [f64], width: i32, t: &FilmTile) {
    for ly in 0..t.h {
        for lx in 0..t.w {
            let i = (ly * t.w + lx) as usize;
            let j = ((t.y0 + ly) * width + t.x0 + lx) as usize;
            for (s, v) in sum[j].iter_mut().zip(t.sum[i]) {
                *s += v as f64;
            }
            weight[j] += t.weight[i];
        }
    }
}

fn current_image(sum: &[[f64; 3]], weight: &[f64]) -> Vec<Vec3> {
    sum.iter()
        .zip(weight)
        .map(|(s, w)| {
            if *w != 0.0 {
                let wf = *w as f32;
                Vec3::new(s[0] as f32 / wf, s[1] as f32 / wf, s[2] as f32 / wf)
            } else {
                Vec3::ZERO
            }
        })
        .collect()
}

/// Mean over pixels of Var(pixel mean) / (mean² + 0.01), from the per-pixel
/// moments. With one sample per pixel the variance comes from horizontal pairs
/// of pixels, (y_a − y_b)²/2 (an overestimate where the image has gradients).
pub fn variance(moments: &[[f64; 3]], width: usize) -> f64 {
    let (mut acc, mut n) = (0.0f64, 0usize);
    for (i, m) in moments.iter().enumerate() {
        let count = m[2];
        if count <= 0.0 {
            continue;
        }
        let mean = m[0] / count;
        let var = if count >= 2.0 {
            ((m[1] - m[0] * mean) / (count - 1.0)).max(0.0) / count
        } else {
            let x = i % width;
            let even = x.is_multiple_of(2);
            let j = if even { i + 1 } else { i - 1 };
            if (even && x + 1 >= width) || j >= moments.len() || moments[j][2] <= 0.0 {
                continue;
            }
            let other = moments[j][0] / moments[j][2];
            0.5 * (mean - other) * (mean - other)
        };
        acc += var / (mean * mean + 0.01);
        n += 1;
    }
    if n == 0 {
        0.0
    } else {
        acc / n as f64
    }
}
