//! `guided`'s iterations: their schedule, the state kept between passes, the
//! end of a training iteration (the tree rebuilt, the leaves' fractions chosen)
//! and the summary.

use super::combine::{combine, current_image, pixel_variances, relative_variances, Part};
use super::sdtree::{self, SdTree, TreeStats};
use super::{Combine, DTree, Guided, LearnFrom, RHO};
use crate::film::Film;
use crate::integrator::PassContext;
use crate::math::Vec3;
use std::time::Instant;

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

/// What the integrator keeps between passes (in the render loop's
/// [`crate::integrator::PassState`]).
pub struct State {
    pub tree: SdTree,
    pub history: Vec<IterationInfo>,
    /// The schedule, in words.
    pub schedule: String,
    started: Instant,
    /// Elapsed seconds when the current iteration began.
    iteration_start: f64,
    pub(super) length: u32,
    pub(super) last: bool,
    pub(super) passes: u32,
    pub(super) passes_total: u32,
    stop_training: bool,
    /// Why training stopped early, for the summary.
    stop_reason: Option<String>,
    /// The current iteration's samples, and per-pixel moments of the samples'
    /// mean over channels: Σy, Σy², n.
    pub(super) film: Film,
    pub(super) moments: Vec<[f64; 3]>,
    /// Finished iterations, weighted anew whenever the image is made (`last`:
    /// the previous one only).
    finished: Vec<Finished>,
    /// The current iteration's first-pass vertices, for the leaves' fractions.
    pub(super) choice: Vec<sdtree::ChoiceSample>,
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

    pub(super) fn new_state(&self, ctx: &PassContext) -> State {
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
            film: Film::new(ctx.film.width, ctx.film.height, ctx.film.filter),
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

    /// Whether training stops after `iterations_done` iterations whose last one's
    /// fraction choice is estimated to gain `gain` (see `min_gain`).
    fn stops_unprofitable(&self, iterations_done: usize, gain: f64) -> bool {
        self.learn_fraction && self.training_iterations.is_none() && iterations_done >= 3 && gain < self.min_gain as f64
    }

    /// Keeps the finished training iteration's image, rebuilds the tree and
    /// starts the next iteration.
    pub(super) fn end_iteration(&self, s: &mut State, ctx: &PassContext) {
        let build_start = Instant::now();
        let finished = Finished {
            image: current_image(s.film.sums()),
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
        s.film.take_sums(true);
        s.moments.iter_mut().for_each(|x| *x = [0.0; 3]);
        self.begin_iteration(s, ctx);
    }

    /// The image so far (film rows, y up): the iterations, finished and current,
    /// each weighted by the inverse of its estimated variance (or the last alone).
    pub fn image(&self, s: &State, width: usize) -> Vec<Vec3> {
        let current = (s.passes > 0).then(|| (current_image(s.film.sums()), pixel_variances(&s.moments, width)));
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
        combine(&parts, s.moments.len())
    }

    /// Schedule, iterations and tree sizes, for the render summary.
    pub fn summary(&self, s: &State) -> String {
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
        format!(
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
        )
    }
}
