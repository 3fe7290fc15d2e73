//! `guided`'s iterations: their schedule, the state kept between passes, the
//! end of a training iteration (the tree rebuilt, the leaves' fractions chosen)
//! and the summary.

use super::combine::{combine, combine_weighted, current_image, difference_variances, pixel_variances, relative_variances, Part};
use super::sdtree::{self, SdTree, TreeStats};
use super::{Combine, DTree, Guided, LearnFrom, Target, DECLINES_TO_STOP_TRAINING, GUIDED_PASS_COST, MAX_TRAINING_ITERATIONS, RHO};
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
    /// The vertices that chose the leaves' fractions at its end.
    pub choice_vertices: u64,
    /// The vertices held for that choice (at most [`State::choice_budget`] per pass).
    pub choice_samples: u64,
    /// Measured relative variance per sample with the guide over that without
    /// (see [`State::guide`]; `None` where not measured).
    pub variance_ratio: Option<f64>,
    /// Whether its passes sampled the guide.
    pub guided: bool,
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
    pub(super) length: u32,
    pub(super) last: bool,
    pub(super) passes: u32,
    pub(super) passes_total: u32,
    /// The current iteration's passes that recorded (the first, or all where a leaf guides).
    pub(super) recorded: u32,
    /// The current iteration's samples, and per-pixel moments of the samples'
    /// mean over channels: Σy, Σy², n.
    pub(super) film: Film,
    pub(super) moments: Vec<[f64; 3]>,
    /// Finished iterations, weighted anew whenever the image is made (`last`:
    /// the previous one only).
    finished: Vec<Finished>,
    /// The vertices of the current iteration's first [`super::CHOICE_PASSES`] passes that
    /// record, for the leaves' fractions.
    pub(super) choice: Vec<sdtree::ChoiceSample>,
    /// Most vertices a pass keeps in `choice`: [`super::CHOICE_SAMPLES_PER_PASS`] (tests
    /// lower it).
    pub choice_budget: usize,
    /// Whether the leaves sample their guides at their learned fractions (with
    /// `learn_fraction` and photons to learn from; else always): while the relative
    /// variance per sample with the guide, times [`GUIDED_PASS_COST`], is at least
    /// that without, every leaf samples its BSDF alone and the passes are `path`'s
    /// (its packets): a few leaves guiding for a few per cent cost every pass the
    /// guided code. A training iteration's first pass samples the other way than its
    /// rest; it and the second pass, one sample per pixel each, against the other
    /// samples measure both (roulette's part included; see
    /// `Guided::probe_variance_ratio`), so that sample counts decide, never the clock.
    /// One measurement that finds the guide pays takes it up; it is left, and training
    /// stops, after [`DECLINES_TO_STOP_TRAINING`] in a row that find it does not, or one
    /// that finds a guided sample no less noisy than an unguided one.
    pub guide: bool,
    /// Measurements in a row that found the guide does not pay.
    pub(super) declined: u32,
    /// Whether training stopped where the guide does not pay (see
    /// [`DECLINES_TO_STOP_TRAINING`]): the rest of the render is the final iteration.
    pub training_stopped: bool,
    /// The film's sums after the current training iteration's first and second passes.
    pub(super) probe: Vec<(Vec<[f64; 3]>, Vec<f64>)>,
    /// EARS's statistics (`rr: "ears"`), from the passes that played it.
    pub(super) ears: Option<Box<crate::integrator::ears::State>>,
    /// The training photons kept for later trees (`learn_from: "photons"`).
    pub photons: super::photons::TrainingPhotons,
}

impl State {
    /// Room in `choice` for `kept` more vertices: where a pass reaches its budget, for
    /// the iteration's other choosing passes too, so that `choice` grows once to its
    /// most (doubling its capacity, it would hold up to twice its length).
    pub(super) fn reserve_choice(&mut self, kept: usize) {
        let more = if kept >= self.choice_budget {
            self.choice_budget * super::CHOICE_PASSES.saturating_sub(self.passes) as usize
        } else {
            kept
        };
        if self.choice.capacity() - self.choice.len() < kept {
            self.choice.reserve_exact(more);
        }
    }

    /// Keeps the film's sums after a training iteration's first and second passes.
    pub(super) fn keep_probe(&mut self) {
        if self.passes <= 2 {
            let sums = self.film.sums();
            self.probe.push((sums.sum.clone(), sums.weight.clone()));
        }
    }
}

/// Which of a pass's `n` candidate vertices (in deposit order) the choice keeps: all
/// of them within the budget, else exactly `budget`, the i-th where ⌊i·budget/n⌋ steps
/// up (evenly spread over the order, which is fixed: the tiles', then the pixels').
pub(super) struct ChoiceStride {
    n: u64,
    budget: u64,
    seen: u64,
}

impl ChoiceStride {
    pub(super) fn new(n: usize, budget: usize) -> ChoiceStride {
        ChoiceStride {
            n: n as u64,
            budget: budget as u64,
            seen: 0,
        }
    }

    /// The vertices kept of the `n`.
    pub(super) fn kept(&self) -> usize {
        self.n.min(self.budget) as usize
    }

    /// Whether the next candidate is kept.
    pub(super) fn keep(&mut self) -> bool {
        let i = self.seen;
        self.seen += 1;
        self.n <= self.budget || (i + 1) * self.budget / self.n != i * self.budget / self.n
    }
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
    /// the most K whose training (2^(K−1) spp, see [`Guided::iteration_length`]) the
    /// final iteration at least matches, 2^K ≤ spp, at most [`MAX_TRAINING_ITERATIONS`].
    pub fn auto_training_iterations(spp: u32) -> u32 {
        let mut k = 0u32;
        while k < MAX_TRAINING_ITERATIONS && (1u64 << (k + 1)) <= spp as u64 {
            k += 1;
        }
        k
    }

    /// Passes of training iteration `k`: 1, then 2^(k−1) (1, 1, 2, 4, …), so iteration
    /// k ≥ 1 holds the sample indices [2^(k−1), 2^k), an aligned block of the pixels'
    /// sequence (stratified on its own), and training ends at a power of two.
    pub fn iteration_length(k: u32) -> u32 {
        1u32 << k.saturating_sub(1).min(31)
    }

    /// Training iterations of a render of `spp` samples per pixel (under
    /// `--time-limit`, the most it may reach): a function of sample counts only.
    pub fn training_iterations_for(&self, spp: u32) -> u32 {
        self.training_iterations.unwrap_or_else(|| Self::auto_training_iterations(spp))
    }

    /// Fraction of the leaves before any choice: with `learn_fraction`, 1 (BSDF
    /// sampling until a leaf's vertices show the guide would help: a tree learned
    /// from a few samples per pixel, sampled at half the vertices, gave
    /// `veach_path` ten times `path`'s error), else `bsdf_fraction`.
    fn initial_fraction(&self) -> f32 {
        if self.learn_fraction {
            1.0
        } else {
            self.bsdf_fraction
        }
    }

    pub(super) fn new_state(&self, ctx: &PassContext) -> State {
        let n = (ctx.film.width * ctx.film.height) as usize;
        let k = self.training_iterations_for(ctx.spp);
        let schedule = match self.training_iterations {
            Some(_) => format!("{k} training iterations (given)"),
            None => format!("{k} training iterations for {} spp", ctx.spp),
        };
        let mut s = State {
            tree: SdTree::new(ctx.scene.center, ctx.scene.radius, DTree::initial(RHO), self.initial_fraction()),
            history: Vec::new(),
            schedule,
            length: 0,
            last: false,
            passes: 0,
            passes_total: 0,
            recorded: 0,
            film: Film::new(ctx.film.width, ctx.film.height, ctx.film.filter),
            moments: vec![[0.0; 3]; n],
            finished: Vec::new(),
            choice: Vec::new(),
            choice_budget: super::CHOICE_SAMPLES_PER_PASS,
            guide: !self.learn_fraction || self.learn_from == LearnFrom::Paths,
            probe: Vec::new(),
            declined: 0,
            training_stopped: false,
            ears: None,
            photons: Default::default(),
        };
        self.begin_iteration(&mut s, ctx);
        s
    }

    /// Length and kind of the next iteration: iteration k takes
    /// [`Guided::iteration_length`] passes and
    /// trains while k is below the training iterations; the last takes what
    /// remains of the spp budget. Sample counts decide, never the clock: the same
    /// seed and spp give the same image on a busy machine and a quiet one.
    fn begin_iteration(&self, s: &mut State, ctx: &PassContext) {
        let k = s.history.len() as u32;
        let remaining = ctx.spp.saturating_sub(s.passes_total).max(1);
        let length = Self::iteration_length(k);
        let training = k < self.training_iterations_for(ctx.spp) && !s.training_stopped;
        s.last = !training || length >= remaining;
        s.length = if s.last { remaining } else { length };
        s.passes = 0;
        s.recorded = 0;
        s.probe.clear();
        s.history.push(IterationInfo {
            last: s.last,
            guided: s.guide,
            tree: s.tree.stats(),
            ..IterationInfo::default()
        });
    }

    /// Keeps the finished training iteration's image, rebuilds the tree and
    /// starts the next iteration.
    pub(super) fn end_iteration(&self, s: &mut State, ctx: &PassContext) {
        let build_start = Instant::now();
        let variance_ratio = self.probe_variance_ratio(s);
        // a guided sample no less noisy than an unguided one cannot pay for its cost
        let mut hopeless = false;
        if let Some(r) = variance_ratio {
            let pays = r * GUIDED_PASS_COST < 1.0;
            hopeless = r >= 1.0;
            s.declined = if pays { 0 } else { s.declined + 1 };
            s.guide = pays || (s.guide && s.declined < DECLINES_TO_STOP_TRAINING && !hopeless);
        }
        // training stops where the guide is off and cannot pay (see
        // `DECLINES_TO_STOP_TRAINING`): the tree is not used again, so not rebuilt either
        s.training_stopped = !s.guide && (s.declined >= DECLINES_TO_STOP_TRAINING || hopeless);
        let finished = Finished {
            image: current_image(s.film.sums()),
            pixel_variance: pixel_variances(&s.moments, ctx.film.width as usize),
            spp: s.passes,
        };
        match self.combine {
            Combine::Samples => s.finished.push(finished),
            Combine::Last => s.finished = vec![finished],
        }
        if !s.training_stopped && self.learns_from_photons() {
            // the earlier iterations' photons go into the recording trees too (not where
            // training stops: the tree is not rebuilt, and the final passes free them)
            s.photons.end_iteration(&mut s.tree, s.recorded, super::photons_per_pass(ctx));
        }
        let threshold = self.spatial_threshold as f64 * (s.recorded.max(1) as f64).sqrt();
        let choice = std::mem::take(&mut s.choice);
        let moments = if s.training_stopped {
            sdtree::ChoiceMoments::default()
        } else {
            s.tree
                .end_iteration(threshold, RHO, true, self.learn_fraction.then_some(&choice[..]))
        };
        let build = build_start.elapsed().as_secs_f64();
        let variance = {
            let parts: Vec<Part> = s.finished.iter().map(Finished::part).collect();
            relative_variances(&parts).last().copied().unwrap_or(0.0)
        };
        let info = s.history.last_mut().expect("an iteration is running");
        info.build_seconds = build;
        info.variance = variance;
        info.gain = (self.learn_fraction && !s.training_stopped).then(|| moments.gain());
        info.choice_vertices = moments.vertices;
        info.choice_samples = choice.len() as u64;
        info.variance_ratio = variance_ratio;
        s.film.take_sums(true);
        s.moments.iter_mut().for_each(|x| *x = [0.0; 3]);
        if s.training_stopped {
            s.schedule += &format!(", training stopped after {} spp (the guide did not pay)", s.passes_total);
        }
        self.begin_iteration(s, ctx);
    }

    /// The relative variance per sample of the current training iteration's passes
    /// that sampled the guide over that of those that did not; `None` without two
    /// passes or a finished iteration, or where the gate does not apply (see
    /// [`State::guide`]). The first two passes, one sampled each way, give two images of
    /// one sample per pixel (f, s), the finished iterations and the later passes a third
    /// (m), all independent; their squared differences with relMSE's weights (m standing
    /// in for the reference) are per pixel a + b, a + M and b + M, solved for the
    /// variances per sample of the first pass (a) and of the second (b) by
    /// [`difference_variances`], which a handful of pixels' fireflies cannot swing. One
    /// sample against one, so that its medians treat both alike: against the mean of all
    /// the later passes, whose tails average out, the one-sample probe's tail was cut more,
    /// and veach_path's guide measured 0.34, 0.59 and 0.49 in three of 18 iterations, as if it
    /// paid (one against one 0.94, 0.74, 0.84). Where no leaf guides, the two passes
    /// sampled alike: the ratio is 1.
    fn probe_variance_ratio(&self, s: &State) -> Option<f64> {
        if !self.learn_fraction || self.learn_from == LearnFrom::Paths || s.passes < 2 {
            return None;
        }
        if !s.tree.any_guides() {
            return Some(1.0);
        }
        let (first, second) = difference_variances(&probe_terms(s)?)?;
        let (with, without) = if s.guide { (second, first) } else { (first, second) };
        Some(with / without)
    }

    /// The image so far (film rows, y up): the iterations, finished and current,
    /// every sample alike (or the last alone).
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
        match self.combine {
            Combine::Samples => combine_weighted(&parts, &parts.iter().map(|p| p.spp as f64).collect::<Vec<_>>(), s.moments.len()),
            _ => combine(&parts, s.moments.len()),
        }
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
                    "{}{}{} spp {:.2} s (tree {} leaves, {:.1} MB; build {:.1} ms{}{}{})",
                    if i.last { "final " } else { "" },
                    if i.guided { "guided " } else { "" },
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
                    i.gain.map_or_else(String::new, |g| format!(", gain {:.1} %", 100.0 * g)),
                    i.variance_ratio
                        .map_or_else(String::new, |r| format!(", image variance ratio {r:.2}"))
                )
            })
            .collect();
        let ears = s.ears.as_ref().map_or_else(String::new, |e| format!("; {}", e.summary()));
        format!(
            "guided: schedule {}; learned from {}; combine {}; iterations: {}; SD-tree {} spatial leaves, {} directional nodes (depth ≤ {}), {:.1} MB; leaves per BSDF fraction {}",
            s.schedule,
            match (self.learn_from, self.target) {
                (LearnFrom::Photons, Target::Radiance) => "photons (kept for every later tree; new ones a quarter per pixel and recording pass, or more)",
                (LearnFrom::Paths, Target::Radiance) => "camera paths",
                (_, Target::Variance) => "the camera paths' second moments",
            },
            match self.combine {
                Combine::Last => "last iteration",
                Combine::Samples => "all samples alike",
            },
            iterations.join(", "),
            stats.spatial_leaves,
            stats.directional_nodes,
            stats.max_directional_depth,
            stats.bytes as f64 / 1e6,
            sdtree::FRACTION_BINS
                .iter()
                .zip(stats.fractions)
                .map(|(f, n)| if *f >= 1.0 { format!("1: {n}") } else { format!("≥ {f}: {n}") })
                .collect::<Vec<_>>()
                .join(", "),
        ) + &ears
    }
}

/// Each pixel's weighted squared differences of the current training iteration's first
/// pass (f), its second (s) and the other samples (m: the finished iterations and the later
/// passes): [(f − s)², (f − m)², (s − m)²] / (m² + 0.01); `None` before the second pass or
/// without a finished iteration.
fn probe_terms(s: &State) -> Option<Vec<[f64; 3]>> {
    let [(sum1, weight1), (sum2, weight2)] = &s.probe[..] else {
        return None;
    };
    let parts: Vec<Part> = s.finished.iter().map(Finished::part).collect();
    let weights: Vec<f64> = parts.iter().map(|p| p.spp as f64).collect();
    let finished_spp: f64 = weights.iter().sum();
    if finished_spp == 0.0 {
        return None;
    }
    let finished = combine_weighted(&parts, &weights, s.moments.len());
    let sums = s.film.sums();
    let later_spp = s.passes.saturating_sub(2) as f64;
    let luminance = |x: [f64; 3]| (x[0] + x[1] + x[2]) / 3.0;
    let mean_between = |a: &[f64; 3], b: &[f64; 3], w: f64| luminance(std::array::from_fn(|c| a[c] - b[c])) / w;
    let mut terms = Vec::with_capacity(finished.len());
    for (i, m) in finished.iter().enumerate() {
        let (w1, w2, w) = (weight1[i], weight2[i] - weight1[i], sums.weight[i] - weight2[i]);
        if w1 <= 0.0 || w2 <= 0.0 {
            continue;
        }
        let f = luminance(sum1[i]) / w1;
        let second = mean_between(&sum2[i], &sum1[i], w2);
        let mut m = (m.x + m.y + m.z) as f64 / 3.0;
        if w > 0.0 {
            m = (m * finished_spp + mean_between(&sums.sum[i], &sum2[i], w) * later_spp) / (finished_spp + later_spp);
        }
        let weight = 1.0 / (m * m + 0.01);
        terms.push([
            weight * (f - second).powi(2),
            weight * (f - m).powi(2),
            weight * (second - m).powi(2),
        ]);
    }
    Some(terms)
}
