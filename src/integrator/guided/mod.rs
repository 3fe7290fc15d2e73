//! Path guiding (the `guided` integrator): Müller, Gross and Novák, "Practical
//! Path Guiding for Efficient Light-Transport Simulation" (2017), on top of the
//! `path` integrator's estimator (light selection, NEE, MIS, roulette).
//!
//! An SD-tree ([`sdtree`]: a binary tree over a cube around the scene whose
//! leaves hold directional quadtrees, [`quadtree`]) learns the light arriving
//! at surfaces. Rendering goes in iterations of 1, 2, 4, … samples per pixel;
//! each training iteration samples from the tree the previous one recorded and
//! records into the next: by default the flux of photons shot from the lights
//! (one per pixel and pass, at most 2²⁰) into the cell of the direction they arrive from, so
//! a leaf's density follows L_i·cos, sharp where light is focused (Vorba et
//! al. 2014 train their guiding from photons too); or, as in the paper
//! (`learn_from: "paths"`), what the camera paths find (radiance from light
//! samples and from BSDF- or guide-sampled hits, MIS-weighted, divided by the
//! sampling density). At its end spatial leaves that recorded more than `c·√spp`
//! vertices and photons are split, the recording becomes the sampling
//! distribution, and the next recording tree is refined where a cell holds more
//! than ρ = 1 % of its leaf's energy.
//!
//! At non-specular vertices directions come from a mixture: the BSDF with
//! probability `bsdf_fraction`, the learned distribution otherwise; MIS against
//! light sampling uses the mixture's density, so every iteration is unbiased.
//! Specular vertices sample their BSDF. Russian roulette judges a path by its
//! throughput as if the guided vertices had sampled their BSDFs, against
//! `rr_threshold` (see [`path::Guiding`]): judged by the throughput alone, as
//! `path` does, the paths guiding sends towards the light are the ones ended.
//! The image combines the iterations with
//! one weight per iteration, the inverse of its estimated variance (mean over
//! pixels of the relative variance of the pixel mean, the `rdr compare` metric's
//! weighting), or shows the last iteration alone (`combine: "last"`).
//!
//! Schedule: with an spp budget, iterations double while the rest still holds
//! at least one more doubling, and the last takes what remains (64 spp: 1, 2, 4,
//! 8, 16, then 33). Under `--time-limit` a training iteration starts only if it
//! is predicted to end within `training_share` of the limit (the paper's
//! variance-times-time balancing trained too long for a minute's render); the
//! last iteration then renders until the render loop stops it. Either way
//! training also stops early, with the guide turned off, once the leaves' chosen
//! fractions are estimated to gain less than `min_gain` over BSDF sampling; a
//! final iteration that guides nowhere runs `path`'s own code.
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
use super::photon::{shoot_deposits, Shooting};
use super::{PassContext, PassResult, PathProfile, PathTracer, RayCounts};
use crate::film::{Film, FilmTile};
use crate::math::{Vec2, Vec3};
use crate::sampler::{hash_combine, PixelSampler};
use crate::scene::Scene;
use rayon::prelude::*;
use std::time::Instant;

/// Photons' roulette threshold when the tree learns from them (the photon
/// integrators' default).
const PHOTON_RR_THRESHOLD: f32 = 0.1;

/// Most photons a training pass shoots (one per pixel below it): their deposits,
/// a few per photon, are held until the pass ends.
pub const MAX_PHOTONS_PER_PASS: u32 = 1 << 20;

/// Energy share above which a directional cell is split (the paper's ρ).
pub const RHO: f32 = 0.01;

/// Where training iterations learn the incident light from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LearnFrom {
    /// The camera paths' vertices (the paper): radiance arriving along sampled
    /// directions divided by their density.
    Paths,
    /// Photons shot from the lights, one per pixel and pass (at most 2²⁰), deposited with their
    /// flux where they land (the camera paths still count vertices for the
    /// spatial splits and choose the leaves' BSDF fractions).
    #[default]
    Photons,
}

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
/// * `max_depth` (int ≥ 1, 12) — as `path`;
/// * `rr_threshold` (number in [0, 1], 0.1) — from the 5th segment on a path
///   survives roulette with probability min(1, β'/`rr_threshold`), β' its
///   throughput as if every guided vertex had sampled its BSDF (0: no roulette);
///   `path`'s rule, min(β, 0.95), ends the very paths guiding finds the light by
///   (caustic_cbox's ceiling: per-sample relative variance 60 with it, 8 with this);
/// * `learn_from` (`"photons"` | `"paths"`, `"photons"`) — what training
///   iterations learn from: photons shot from the lights, one per pixel and pass
///   (at most 2²⁰),
///   deposited with their flux (segments ≥ 2 unless `learn_direct`; the camera
///   paths still count vertices for the splits and choose the BSDF fractions), or
///   the camera paths' vertices as in the paper. Photons find light that arrives
///   through glass where camera paths rarely do (caustic_cbox, 256 spp with 31 of
///   training: relMSE 2.9e-3 from photons, 5.0e-3 from paths, `path` 1.3e-2);
/// * `bsdf_fraction` (number in (0, 1], 0.5) — probability of BSDF sampling at a
///   guided vertex (1: never guided) when `learn_fraction` is false;
/// * `learn_fraction` (bool, true) — training iterations sample with
///   `bsdf_fraction`; for the final one each spatial leaf chooses its BSDF fraction
///   from 0.1, 0.25, 0.5, 0.75, 1 after every training iteration: the one whose
///   estimated second moment of the vertex estimator, ∫F²/p, is smallest (1,
///   BSDF sampling without guide lookups, unless another's is below 0.6 of its),
///   estimated on the first pass of the last training iteration with the new
///   tree (leave-one-out); leaves with fewer than 128 vertices there sample the
///   BSDF alone;
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
///   direct light learned, 7.0e-3 without, `path` 5.5e-3);
/// * `training_share` (number in (0, 1], 0.12) — under `--time-limit`, the share of
///   the time budget training may take: a training iteration starts only when it
///   is predicted (twice the previous one) to end within it.
/// * `min_gain` (number in [0, 1), 0.15) — with `learn_fraction` and no
///   `training_iterations`, training stops after the third iteration (1 + 2 + 4
///   spp) or any later one when the leaves' chosen fractions are estimated to
///   reduce the vertex estimator's second moment, summed over the iteration's
///   vertices, by less than this share against BSDF sampling alone: guiding does
///   not pay there, and the rest of the budget goes to one final iteration, whose
///   single stratified sequence is worth more than further training, with the
///   guide off everywhere (0: train by the schedule alone). The estimate sees one
///   vertex, not what guiding gains along a whole path: after the third
///   iteration, photon-trained, it gave 4.6–9.5 % on cbox, 0 on env_sphere, 7.2 %
///   on veach, where guiding does not pay, and 21–51 % on caustic_cbox, where the
///   image's error falls by half and more at equal time (0.25, the value before
///   photons, stopped one of two caustic_cbox runs at 21.2 %).
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
    pub training_share: f32,
    pub learn_fraction: bool,
    pub min_gain: f32,
    pub learn_from: LearnFrom,
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
            training_share: 0.12,
            learn_fraction: true,
            min_gain: 0.15,
            learn_from: LearnFrom::Photons,
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
    /// What the leaves' fractions chosen at its end are estimated to gain
    /// ([`sdtree::ChoiceMoments::gain`]; `None` without a choice).
    pub gain: Option<f64>,
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
    stop_training: bool,
    /// Why training stopped early, for the summary.
    stop_reason: Option<String>,
    /// Whether passes ended since the film's image was made.
    image_stale: bool,
    /// The current iteration's image (film rows, y up) and per-pixel moments of
    /// the samples' mean over channels: Σy, Σy², n.
    sum: Vec<[f64; 3]>,
    weight: Vec<f64>,
    moments: Vec<[f64; 3]>,
    /// Finished iterations, weighted anew whenever the image is made (`last`:
    /// the previous one only).
    finished: Vec<Finished>,
    /// The current iteration's first-pass vertices, for the leaves' fractions.
    choice: Vec<sdtree::ChoiceSample>,
}

/// A finished iteration's image and the variance of each of its pixel means.
struct Finished {
    image: Vec<Vec3>,
    pixel_variance: Vec<f32>,
    spp: u32,
}

impl Finished {
    fn part(&self) -> Part<'_> {
        Part {
            image: &self.image,
            pixel_variance: &self.pixel_variance,
            spp: self.spp,
        }
    }
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

    /// Fraction of the leaves that have not chosen one: with `learn_fraction`, 1
    /// (the guide is off where a leaf's vertices did not show it would help: a
    /// tree learned from a few samples per pixel, sampled at half the vertices in
    /// the final iteration, gave `veach_path` ten times `path`'s error), else
    /// `bsdf_fraction`.
    fn default_fraction(&self) -> f32 {
        if self.learn_fraction {
            1.0
        } else {
            self.bsdf_fraction
        }
    }

    fn new_state(&self, ctx: &PassContext) -> State {
        let n = (ctx.film.width * ctx.film.height) as usize;
        let schedule = match (ctx.time_limit, self.training_iterations) {
            (_, Some(k)) => format!("{k} training iterations (given)"),
            (Some(t), None) => format!("time budget of {t} s (training within {:.0} % of it)", 100.0 * self.training_share),
            (None, None) => format!("spp budget: {} training iterations", Self::auto_training_iterations(ctx.spp)),
        };
        let mut s = State {
            tree: SdTree::new(ctx.scene.center, ctx.scene.radius, DTree::initial(RHO), self.default_fraction()),
            history: Vec::new(),
            schedule,
            started: Instant::now(),
            iteration_start: 0.0,
            length: 0,
            last: false,
            passes: 0,
            passes_total: 0,
            stop_training: false,
            stop_reason: None,
            image_stale: false,
            sum: vec![[0.0; 3]; n],
            weight: vec![0.0; n],
            moments: vec![[0.0; 3]; n],
            finished: Vec::new(),
            choice: Vec::new(),
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
            None => !s.stop_training && k < Self::auto_training_iterations(ctx.spp),
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
            record_radiance: self.learn_from == LearnFrom::Paths,
            max_depth: self.max_depth,
            rr_threshold: self.rr_threshold,
            record_direct: self.learn_direct,
            learn_fraction: self.learn_fraction,
        };
        // each iteration draws from its own scrambling of the sampler, starting at
        // sample 0: its samples are then independent of the ones the tree it samples
        // from was learned from (the same pixel's Sobol points are correlated, and an
        // adaptive density that depends on them would be biased)
        let iteration = state.history.len() as u32 - 1;
        let seed = hash_combine(ctx.seed, 0x5eed_0000 + iteration);
        // a final iteration that guides nowhere is `path`'s estimator: `path`'s own
        // code renders it, at `path`'s cost (the guided one's bookkeeping made such
        // a sample 7 % dearer, 15 % with the tree's lookups)
        let unguided = state.last
            && if self.learn_fraction {
                state.tree.leaves.iter().all(|l| l.bsdf_fraction >= 1.0)
            } else {
                self.bsdf_fraction >= 1.0
            };
        let path = unguided.then_some(PathTracer {
            max_depth: self.max_depth,
            profile: PathProfile::Mis,
            rr_threshold: self.rr_threshold,
        });
        let tiles = render_tiles(ctx, state.passes, seed, &guiding, path.as_ref());
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
        // the pass's photons before anything is merged: a pass stopped while shooting
        // them leaves the state as it was
        let photon_deposits = if !state.last && self.learn_from == LearnFrom::Photons {
            match self.training_photons(ctx, &state.tree, state.passes_total, seed, &mut result.counts) {
                Some(d) => d,
                None => {
                    film.set_aux(state);
                    result.complete = false;
                    return result;
                }
            }
        } else {
            Vec::new()
        };
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
                // the first pass's vertices choose the leaves' fractions
                if self.learn_fraction && s.passes == 0 && r.counted && r.fq > 0.0 {
                    s.choice.push(sdtree::ChoiceSample {
                        leaf: r.leaf,
                        fq: r.fq,
                        q: r.q,
                        pb: r.pb,
                        p: r.p,
                        value: r.value,
                    });
                }
            }
        }
        drop(tiles);
        for &(leaf, cell, value) in &photon_deposits {
            let leaf = &mut s.tree.leaves[leaf as usize];
            leaf.count += 1;
            leaf.building.deposit(cell, value);
        }
        s.passes += 1;
        s.passes_total += 1;
        let info = s.history.last_mut().expect("an iteration is running");
        info.spp = s.passes;
        info.seconds += pass_start.elapsed().as_secs_f64();
        if s.passes >= s.length && !s.last {
            self.end_iteration(s, ctx);
        }
        // the image is made when it is read ([`Guided::prepare_image`]): combining
        // the iterations after every pass took 5 % of a minute's render
        s.image_stale = true;
        film.set_aux(state);
        result
    }

    /// A training pass's photons (one per pixel, at most [`MAX_PHOTONS_PER_PASS`]) as
    /// deposits (leaf, recording cell, flux); `None` when the stop token was set.
    fn training_photons(
        &self,
        ctx: &PassContext,
        tree: &SdTree,
        pass: u32,
        seed: u32,
        counts: &mut RayCounts,
    ) -> Option<Vec<(u32, u32, f32)>> {
        // a vertex after the camera's first segment receives paths of at most
        // max_depth − 1 segments; its direct light only when that is learned
        let shooting = Shooting {
            count: (ctx.film.width * ctx.film.height).min(MAX_PHOTONS_PER_PASS),
            max_segments: self.max_depth.saturating_sub(1),
            rr_threshold: PHOTON_RR_THRESHOLD,
            min_segments: if self.learn_direct { 1 } else { 2 },
        };
        let (points, photons, rays) = shoot_deposits(ctx.scene, shooting, pass, seed, ctx.stop)?;
        counts.rays += rays;
        let deposits = points
            .iter()
            .zip(&photons)
            .filter_map(|(p, photon)| {
                let value = path::mean(photon.power);
                let leaf = tree.leaf_of(Vec3::from_array(*p));
                (value > 0.0 && value.is_finite()).then(|| (leaf, tree.record_cell(leaf, photon.wi), value))
            })
            .collect();
        Some(deposits)
    }

    /// Makes the film's image from the iterations so far, if passes were rendered
    /// since it was last made.
    pub fn prepare_image(&self, film: &mut Film) {
        let Some(mut state) = film.take_aux::<State>() else { return };
        if state.image_stale {
            film.set_estimate(self.estimate(&state, film.width as usize));
            state.image_stale = false;
        }
        film.set_aux(state);
    }

    /// Whether training stops after `iterations_done` iterations whose last one's
    /// fraction choice is estimated to gain `gain` (see `min_gain`).
    fn stops_unprofitable(&self, iterations_done: usize, gain: f64) -> bool {
        self.learn_fraction && self.training_iterations.is_none() && iterations_done >= 3 && gain < self.min_gain as f64
    }

    /// Keeps the finished training iteration's image, rebuilds the tree and
    /// starts the next iteration.
    fn end_iteration(&self, s: &mut State, ctx: &PassContext) {
        let build_start = Instant::now();
        let finished = Finished {
            image: current_image(&s.sum, &s.weight),
            pixel_variance: pixel_variances(&s.moments, ctx.film.width as usize),
            spp: s.passes,
        };
        match self.combine {
            Combine::InverseVariance => s.finished.push(finished),
            Combine::Last => s.finished = vec![finished],
        }
        let threshold = self.spatial_threshold as f64 * (s.length as f64).sqrt();
        let choice = std::mem::take(&mut s.choice);
        let moments = s.tree.end_iteration(
            threshold,
            RHO,
            true,
            self.learn_fraction.then_some(&choice[..]),
            self.default_fraction(),
        );
        let build = build_start.elapsed().as_secs_f64();
        let variance = {
            let parts: Vec<Part> = s.finished.iter().map(Finished::part).collect();
            relative_variances(&parts).last().copied().unwrap_or(0.0)
        };
        let iterations_done = s.history.len();
        let info = s.history.last_mut().expect("an iteration is running");
        info.build_seconds = build;
        info.variance = variance;
        info.gain = self.learn_fraction.then(|| moments.gain());
        let spent = info.seconds + build;
        if self.stops_unprofitable(iterations_done, moments.gain()) {
            // the few leaves that chose to guide would slow the final iteration
            // (cbox: 28 of 366 leaves, 25 % more time per sample) for a gain
            // estimated too small to pay
            s.tree.leaves.iter_mut().for_each(|l| l.bsdf_fraction = 1.0);
            s.stop_training = true;
            s.stop_reason = Some(format!(
                "training stopped after {iterations_done} iterations: estimated gain {:.1} % < min_gain {:.1} %",
                100.0 * moments.gain(),
                100.0 * self.min_gain
            ));
        }
        if let Some(limit) = ctx.time_limit {
            // the next iteration, twice as long, must end within the training share
            let now = s.started.elapsed().as_secs_f64();
            if now + 2.0 * spent > self.training_share as f64 * limit {
                s.stop_training = true;
            }
        }
        for x in s.sum.iter_mut() {
            *x = [0.0; 3];
        }
        s.weight.iter_mut().for_each(|x| *x = 0.0);
        s.moments.iter_mut().for_each(|x| *x = [0.0; 3]);
        self.begin_iteration(s, ctx);
    }

    /// The image so far (film rows, y up): the iterations, finished and current,
    /// each weighted by the inverse of its estimated variance (or the last alone).
    fn estimate(&self, s: &State, width: usize) -> Vec<Vec3> {
        let current = (s.passes > 0).then(|| (current_image(&s.sum, &s.weight), pixel_variances(&s.moments, width)));
        let mut parts: Vec<Part> = match self.combine {
            Combine::Last if current.is_some() => Vec::new(),
            _ => s.finished.iter().map(Finished::part).collect(),
        };
        if let Some((image, var)) = &current {
            parts.push(Part {
                image,
                pixel_variance: var,
                spp: s.passes,
            });
        }
        combine(&parts, s.sum.len())
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
                    "{}{} spp {:.2} s (tree {} leaves, {:.1} MB; build {:.1} ms{}{})",
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
                    },
                    i.gain.map_or_else(String::new, |g| format!(", gain {:.1} %", 100.0 * g))
                )
            })
            .collect();
        Some(format!(
            "guided: schedule {}{}; learned from {}; combine {}; iterations: {}; SD-tree {} spatial leaves, {} directional nodes (depth ≤ {}), {:.1} MB; leaves per BSDF fraction {}",
            s.schedule,
            s.stop_reason.as_ref().map_or_else(String::new, |r| format!(" ({r})")),
            match self.learn_from {
                LearnFrom::Photons => "photons (one per pixel and training pass)",
                LearnFrom::Paths => "camera paths",
            },
            match self.combine {
                Combine::InverseVariance => "inverse variance",
                Combine::Last => "last iteration",
            },
            iterations.join(", "),
            stats.spatial_leaves,
            stats.directional_nodes,
            stats.max_directional_depth,
            stats.bytes as f64 / 1e6,
            sdtree::FRACTIONS
                .iter()
                .zip(stats.fractions)
                .map(|(f, n)| format!("{f}: {n}"))
                .collect::<Vec<_>>()
                .join(", ")
        ))
    }
}

/// The learned SD-tree of a render's film (for tests and inspection).
pub fn learned_tree(film: &Film) -> Option<&SdTree> {
    film.aux::<State>().map(|s| &s.tree)
}

/// Renders sample `sample` (of the sampler seeded by `seed`) of every pixel, tiles in parallel, each with its
/// records and moments; `None` for tiles skipped after a stop.
fn render_tiles(ctx: &PassContext, sample: u32, seed: u32, guiding: &Guiding, path: Option<&PathTracer>) -> Vec<Option<TileOut>> {
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
                    let l = match path {
                        Some(p) => p.li(scene, ray, diff, &mut sampler, &mut counts),
                        None => guiding.li(scene, ray, diff, &mut sampler, &mut counts, &mut scratch),
                    };
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

/// One iteration's image, the variance of each of its pixel means (NaN: no
/// estimate) and its samples per pixel.
#[derive(Clone, Copy, Debug)]
pub struct Part<'a> {
    pub image: &'a [Vec3],
    pub pixel_variance: &'a [f32],
    pub spp: u32,
}

/// Var(pixel mean) of the mean over channels per pixel, from the moments Σy,
/// Σy², n. With one sample per pixel it comes from horizontal pairs of pixels,
/// (y_a − y_b)²/2 (an overestimate where the image has gradients).
pub fn pixel_variances(moments: &[[f64; 3]], width: usize) -> Vec<f32> {
    moments
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let count = m[2];
            if count <= 0.0 {
                return f32::NAN;
            }
            let mean = m[0] / count;
            if count >= 2.0 {
                return (((m[1] - m[0] * mean) / (count - 1.0)).max(0.0) / count) as f32;
            }
            let x = i % width;
            let even = x.is_multiple_of(2);
            if even && x + 1 >= width {
                return f32::NAN;
            }
            let j = if even { i + 1 } else { i - 1 };
            if j >= moments.len() || moments[j][2] <= 0.0 {
                return f32::NAN;
            }
            let other = moments[j][0] / moments[j][2];
            (0.5 * (mean - other) * (mean - other)) as f32
        })
        .collect()
}

/// Each iteration's estimated relative variance: the mean over pixels of
/// Var(pixel mean) / (r² + 0.01), the `rdr compare` metric's weighting, with one
/// denominator r per pixel for all iterations: the mean of all their samples.
/// (Each iteration's own pixel mean there would shrink the variance exactly where
/// a rare bright sample raised it, and overweight the short early iterations.)
///
/// With three or more iterations the variances come from the differences of
/// their images instead: iterations are independent and unbiased, so the mean
/// D_ab of (I_a − I_b)² / (r² + 0.01) estimates V_a + V_b, and the least-squares
/// solution of those K(K−1)/2 equations is V_a = (R_a − S)/(K − 2), R_a = Σ_b D_ab,
/// S = ΣD / (K − 1). Unlike the samples' spread within a pixel, this sees what the
/// stratified sampler gains in a long iteration over a short one (an iteration of
/// 30 spp has less than 1/30 of the per-sample variance of one of 1 or 2 spp; on
/// `env_sphere` weights by the spread within pixels gave 1.39× the error of one
/// uninterrupted sequence of 45 spp). When a solution is not positive, the
/// spread within pixels is used.
pub fn relative_variances(parts: &[Part]) -> Vec<f64> {
    let within = relative_variances_within(parts);
    let k = parts.len();
    if k < 3 {
        return within;
    }
    let n = parts[0].image.len();
    let total_spp: f64 = parts.iter().map(|p| p.spp as f64).sum::<f64>().max(1.0);
    let mut d = vec![0.0f64; k * k];
    let mut y = vec![0.0f64; k];
    for i in 0..n {
        let mut r = 0.0f64;
        for (yk, p) in y.iter_mut().zip(parts) {
            let c = p.image[i];
            *yk = ((c.x + c.y + c.z) / 3.0) as f64;
            r += p.spp as f64 * *yk;
        }
        r /= total_spp;
        let norm = 1.0 / (r * r + 0.01);
        for a in 0..k {
            for b in a + 1..k {
                let e = y[a] - y[b];
                d[a * k + b] += e * e * norm;
            }
        }
    }
    let mut row = vec![0.0f64; k];
    let mut total = 0.0f64;
    for a in 0..k {
        for b in a + 1..k {
            let x = d[a * k + b] / n.max(1) as f64;
            row[a] += x;
            row[b] += x;
            total += x;
        }
    }
    let s = total / (k - 1) as f64;
    let v: Vec<f64> = row.iter().map(|r| (r - s) / (k - 2) as f64).collect();
    if v.iter().all(|x| *x > 0.0 && x.is_finite()) {
        v
    } else {
        within
    }
}

/// [`relative_variances`] from the spread of each iteration's samples within its
/// pixels.
pub fn relative_variances_within(parts: &[Part]) -> Vec<f64> {
    let Some(first) = parts.first() else { return Vec::new() };
    let n = first.image.len();
    let total_spp: f64 = parts.iter().map(|p| p.spp as f64).sum::<f64>().max(1.0);
    let mut acc = vec![(0.0f64, 0usize); parts.len()];
    for i in 0..n {
        let r: f64 = parts
            .iter()
            .map(|p| {
                let c = p.image[i];
                p.spp as f64 * ((c.x + c.y + c.z) / 3.0) as f64
            })
            .sum::<f64>()
            / total_spp;
        let norm = 1.0 / (r * r + 0.01);
        for (a, p) in acc.iter_mut().zip(parts) {
            let v = p.pixel_variance[i];
            if v.is_finite() {
                a.0 += v as f64 * norm;
                a.1 += 1;
            }
        }
    }
    acc.iter().map(|&(s, c)| if c == 0 { 0.0 } else { s / c as f64 }).collect()
}

/// The iterations' images combined with weights 1 / their relative variance
/// (an iteration without a variance estimate weighs as much as its spp
/// suggest, relative to the others).
pub fn combine(parts: &[Part], pixels: usize) -> Vec<Vec3> {
    match parts {
        [] => return vec![Vec3::ZERO; pixels],
        [only] => return only.image.to_vec(),
        _ => {}
    }
    let weights = iteration_weights(&relative_variances(parts), parts);
    let total: f64 = weights.iter().sum();
    (0..pixels)
        .map(|i| {
            let mut acc = [0.0f64; 3];
            for (p, w) in parts.iter().zip(&weights) {
                let c = p.image[i];
                acc[0] += c.x as f64 * w;
                acc[1] += c.y as f64 * w;
                acc[2] += c.z as f64 * w;
            }
            Vec3::new((acc[0] / total) as f32, (acc[1] / total) as f32, (acc[2] / total) as f32)
        })
        .collect()
}

/// Normalised weights 1/v_k; iterations whose variance is 0 or unknown (a black
/// image) fall back to weights by spp.
pub fn iteration_weights(variances: &[f64], parts: &[Part]) -> Vec<f64> {
    let w: Vec<f64> = variances
        .iter()
        .map(|&v| if v > 0.0 && v.is_finite() { 1.0 / v } else { 0.0 })
        .collect();
    if w.contains(&0.0) || w.iter().sum::<f64>() <= 0.0 {
        return parts.iter().map(|p| p.spp as f64).collect();
    }
    let total: f64 = w.iter().sum();
    w.iter().map(|x| x / total).collect()
}
