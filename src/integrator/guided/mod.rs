//! Path guiding (the `guided` integrator): Müller, Gross and Novák, "Practical
//! Path Guiding for Efficient Light-Transport Simulation" (2017), on top of the
//! `path` integrator's estimator (light selection, NEE, MIS, roulette).
//!
//! An SD-tree ([`sdtree`]: a binary tree over a cube around the scene whose
//! leaves hold directional quadtrees, [`quadtree`]) learns the light arriving
//! at surfaces. Rendering goes in iterations of 1, 1, 2, 4, … samples per pixel;
//! each training iteration samples from the tree the previous one recorded and
//! records into the next: by default the flux of photons shot from the lights into
//! the cell of the direction they arrive from, so a leaf's density follows L_i·cos,
//! sharp where light is focused (Vorba et al. 2014 train their guiding from photons
//! too). Photons do not depend on the guide, so every training photon is kept and
//! deposited again into each later recording tree ([`photons`]): a recording pass
//! shoots a quarter of a photon per pixel, or more where the kept ones fall short of
//! one per pixel and recording pass of the iteration (at most 2²⁰ a pass); or, as in the paper
//! (`learn_from: "paths"`), what the camera paths find (radiance from light
//! samples and from BSDF- or guide-sampled hits, MIS-weighted, divided by the
//! sampling density), or with `target: "variance"` the second moments of their
//! estimates (Rath et al. 2020, [`Target::Variance`]). At its end spatial leaves that recorded more than `c·√spp`
//! vertices and photons are split, the recording becomes the sampling
//! distribution, and the next recording tree is refined where a cell holds more
//! than ρ = 1 % of its leaf's energy.
//!
//! At non-specular vertices directions come from a mixture: the BSDF with
//! probability `bsdf_fraction`, the learned distribution otherwise; MIS against
//! light sampling uses the mixture's density, so every iteration is unbiased.
//! Specular vertices sample their BSDF. Russian roulette is `path`'s until a
//! path takes a guided sample; from then on it judges the path by its throughput
//! as if the guided vertices had sampled their BSDFs, against `rr_threshold` (see
//! [`path::Guiding`]): judged by the throughput alone, as `path` does, the paths
//! guiding sends towards the light are the ones ended.
//!
//! All iterations draw from each pixel's one sample sequence, continuing where
//! the last stopped as `path`'s passes do; iteration k ≥ 1 takes the indices
//! [2^(k−1), 2^k), a stratified block on its own. The image weighs every sample
//! alike (`combine: "samples"`, `path`'s one film), or shows the last
//! iteration alone (`"last"`). Where no leaf guides, a sample is `path`'s number
//! for number, so the image is `path`'s.
//!
//! Schedule: iterations double while the rest of the spp budget still holds at
//! least as many samples as training took, at most [`MAX_TRAINING_ITERATIONS`] of
//! them, and the last takes what remains (64 spp: 1, 1, 2, 4, 8, 16, then 32). Under
//! `--time-limit` the budget is the spp cap and the render loop stops the
//! schedule where the time runs out. Every decision depends on sample counts
//! only, never on the clock. The leaves choose their BSDF fractions after every
//! iteration, from the vertices of its first [`CHOICE_PASSES`] recording passes (at
//! most [`CHOICE_SAMPLES_PER_PASS`] of each; a leaf with too few vertices takes its
//! nearest ancestor's choice);
//! there is no global switch on an estimate. What guiding costs is weighed by
//! measurement ([`State::guide`]): a training iteration's first pass samples the
//! other way than its other passes, and in an iteration of two passes or more the
//! first two, one sample per pixel each way, measure the variance per sample with and
//! without the guide, against the iteration's other samples and the finished
//! iterations' ([`difference_variances`]: medians over blocks of pixels, so that a few
//! pixels' fireflies cannot decide). One measurement that finds the variance with the
//! guide, times [`GUIDED_PASS_COST`], below that without takes the guide up. While it is
//! not used, or every leaf chooses BSDF sampling alone, a training iteration records
//! (and shoots photons) in its first pass only and renders its other passes with
//! `path`'s own code, as does such a final iteration (its packets, without
//! inverse-variance weights to estimate): the guide keeps learning at the cost of one
//! pass per iteration. Where two measurements in a row find the guide does not pay, or
//! one finds a guided sample no less noisy than an unguided one, or no leaf guides at
//! all (the two passes then sample alike), a guide in use is left and training stops
//! ([`DECLINES_TO_STOP_TRAINING`]): the rest of the budget is then the final
//! iteration, `path`'s passes, and the tree is not rebuilt.
//!
//! Media: the estimator tracks them as for `path`; guiding acts at surface
//! vertices only (a medium vertex samples its phase function).
//!
//! Deterministic: records are kept per tile and deposited in tile order after
//! each pass, so the trees, and with them the image, do not depend on the
//! thread count (timing matters only under `--time-limit`).

pub mod combine;
pub mod iteration;
pub mod path;
pub mod photons;
pub mod quadtree;
pub mod sdtree;

pub use combine::{
    combine, combine_weighted, difference_variances, iteration_weights, pixel_variances, relative_variances, relative_variances_within,
    Part,
};
pub use iteration::{IterationInfo, State};
pub use path::{Guiding, Mixture, Record, Scratch};
pub use quadtree::{sphere_to_square, square_to_sphere, DTree, Target};
pub use sdtree::{SdTree, TreeStats};

use super::pass::{camera_pass_blocks_with, camera_pass_with, tile_of};
use super::{ears, PassContext, PassResult, PathProfile, PathTracer, RayCounts, Roulette};
use crate::accel::wide::PACKET;
use crate::math::Vec3;
use crate::sampler::hash_combine;
use iteration::ChoiceStride;
use std::cell::RefCell;
use std::sync::Mutex;
use std::time::Instant;

/// The training photons' seed offset (their own sequence, apart from the camera's).
const PHOTON_SEED: u32 = 0x5eed_0000;

/// Most photons a training pass of one photon per pixel shoots (see [`photons`]):
/// their deposits, a few per photon, are held until the pass ends.
pub const MAX_PHOTONS_PER_PASS: u32 = 1 << 20;

/// Most training iterations the spp budget gives (1 + 1 + 2 + 4 + 8 + 16 = 32 spp):
/// a recording pass costs about two `path` passes (its photons, records and the
/// guide's lookups; cbox_path: 2.4 for the first, 1.6–1.9 for the next ones), and
/// every pass of a training iteration records while the guide is used, so training
/// stops where a minute's render still has most of its samples ahead (caustic_cbox at 256 spp with 31 of
/// training: relMSE 2.9e-3, `path` 1.3e-2). More did not pay: at 256 spp, 7 and 8
/// iterations gave relMSE × CPU s 0.146 and 0.167 against 6's 0.142 (caustic_cbox).
pub const MAX_TRAINING_ITERATIONS: u32 = 6;

/// Passes of a training iteration whose vertices choose the leaves' BSDF fractions
/// (those of them that record: the first, or every pass while the guide is used; see
/// [`sdtree::SdTree::end_iteration`]). The caustic light a leaf's choice hinges on
/// reaches few of one pass's vertices, so one pass's estimate of the second moment
/// misses it in most leaves; more passes hold more vertices in memory until the
/// iteration ends (a few per pixel and pass).
pub const CHOICE_PASSES: u32 = 4;

/// Most vertices a pass keeps for the leaves' choice of fractions (see [`CHOICE_PASSES`]):
/// where a pass has more, it keeps this many spread evenly over the deposit order (tile
/// order, then pixel order: fixed), so the choice depends on sample counts only. A
/// [`sdtree::ChoiceSample`] takes 28 bytes, so an iteration holds at most
/// 4 × 800,000 × 28 B = 90 MB; 1080p records about 3 million per pass (350 MB for four
/// passes before this cap), 256² about 100,000 (under the cap: nothing changes there).
pub const CHOICE_SAMPLES_PER_PASS: usize = 800_000;

/// What a pass that samples the guide costs against `path`'s pass (its packets),
/// the price the guide must pay for: the leaves guide only while the variance per
/// sample with the guide, times this, is below that without (see [`State::guide`]).
/// Measured: cbox_path and caustic_cbox at 33 spp, one training iteration, then
/// every leaf at fraction 0.5: 2.50 and 2.61 CPU s against `path`'s 2.08 and 2.03
/// (AMD EPYC family 25 model 17, Zen 4, AVX-512, loaded), 1.20 and 1.29 since guided
/// passes trace packets; deeper trees cost more. Kept above the measured cost as a
/// margin against one measurement's noise: at 1.25, cbox_path's first ratios
/// (0.74–0.98) would take up a guide that does not pay.
pub const GUIDED_PASS_COST: f64 = 1.5;

/// Measurements in a row that find the guide does not pay its cost (see
/// [`State::guide`]) after which a guide in use is left and training stops (as after
/// one that finds a guided sample no less noisy than an unguided one, or where no leaf
/// guides): the rest of the spp budget is the final iteration, `path`'s passes, without
/// photons, records or tree builds. A recording pass costs about two `path` passes (its
/// photons, the camera paths and records, the tree's rebuild); one "no" was not
/// enough: caustic_cbox (seeds 3 and 5, 64 spp) measured 0.79 and 0.73 first (the
/// guide pays below 1/1.5) and 0.38 and 0.39 next.
pub const DECLINES_TO_STOP_TRAINING: u32 = 2;

/// Blocks of pixels (dealt out in turn) over which the switch's measurement takes its
/// medians ([`difference_variances`]): fewer than 8 pixels' fireflies move none, and a tail
/// of one bright sample in a few thousand pixels still lands in most blocks (4,369
/// pixels each at 256²).
pub const PROBE_BLOCKS: usize = 15;

/// Energy share above which a directional cell is split (the paper's ρ).
pub const RHO: f32 = 0.01;

/// Where training iterations learn the incident light from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LearnFrom {
    /// The camera paths' vertices (the paper): radiance arriving along sampled
    /// directions divided by their density.
    Paths,
    /// Photons shot from the lights, deposited with their flux where they land, each
    /// into its own iteration's recording tree and every later one ([`photons`]): at
    /// least as many as one per pixel and recording pass of the iteration (at most 2²⁰ a
    /// pass), of which a recording pass shoots a quarter per pixel or more (the camera
    /// paths still count vertices for the spatial splits and choose the leaves' BSDF
    /// fractions).
    #[default]
    Photons,
}

/// How the iterations' images make the final one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Combine {
    /// The last iteration alone.
    Last,
    /// Weights by spp: every sample alike, as `path`'s one film.
    #[default]
    Samples,
}

/// Parameters (JSON `integrator` keys, besides `type`):
/// * `spp` (int ≥ 1, 64) — the whole budget, training included;
/// * `max_depth` (int ≥ 1, 12) — as `path`;
/// * `rr_threshold` (number in [0, 1], 0.3) — from the 5th segment on a path
///   survives roulette with probability min(1, β'/`rr_threshold`), β' its
///   throughput as if every guided vertex had sampled its BSDF (0: no roulette);
///   `path`'s rule, min(β, 0.95), ends the very paths guiding finds the light by
///   (caustic_cbox's ceiling: per-sample relative variance 60 with it, 8 with this);
///   caustic_cbox at 256 spp, relMSE × CPU s against 0.1's in the same run: 0.3 0.95
///   over seeds 1–6 (0.87–1.02: about 7 % less CPU, 2 % more error); seeds 1–3: 0.05
///   1.03, 0.2 0.95, 0.4 0.93, 0.6 1.03, 1 1.26;
/// * `learn_from` (`"photons"` | `"paths"`, `"photons"`) — what training
///   iterations learn from: photons shot from the lights, deposited with their flux
///   into the recording tree and kept for every later one (a recording pass shoots a
///   quarter of a photon per pixel, or more while the tree has seen fewer than one per
///   pixel and recording pass, at most 2²⁰ a pass; see [`photons`]; segments ≥ 2 unless
///   `learn_direct`; the camera
///   paths still count vertices for the splits and choose the BSDF fractions), or
///   the camera paths' vertices as in the paper. Photons find light that arrives
///   through glass where camera paths rarely do (caustic_cbox, 256 spp with 31 of
///   training: relMSE 2.9e-3 from photons, 5.0e-3 from paths, `path` 1.3e-2);
/// * `bsdf_fraction` (number in (0, 1], 0.5) — probability of BSDF sampling at a
///   guided vertex (1: never guided) when `learn_fraction` is false;
/// * `learn_fraction` (bool, true) — each spatial leaf learns its BSDF fraction
///   after every iteration, a continuous value in [0.1, 1]: the one whose
///   estimated second moment of the vertex estimator, ∫F²/p, is smallest (1, BSDF
///   sampling without guide lookups, unless another's is below 0.6 of its),
///   estimated on the vertices of the iteration's first [`CHOICE_PASSES`] passes
///   that record (the first alone while the guide is off; at most
///   [`CHOICE_SAMPLES_PER_PASS`] of a pass's, spread evenly) with the new tree
///   (leave-one-out); a leaf with fewer than 128 vertices there takes the fraction
///   its nearest ancestor's vertices choose together;
/// * `training_iterations` (int ≥ 0, absent: chosen by the spp budget, see the
///   module docs) — doubling iterations before the final one;
/// * `combine` (`"samples"` | `"last"`, `"samples"`) — how the
///   iterations make the image (see the module docs);
/// * `spatial_threshold` (number > 0, 2000) — the paper's c: a spatial leaf is
///   split when an iteration's n recording passes record more than c·√n vertices in it (the
///   paper's 12000 suits longer renders than the minute's tens of spp here: leaves
///   that span several walls send guided samples below the surface);
/// * `learn_direct` (bool, false) — `true`: the tree learns all radiance arriving
///   at a vertex, direct light included (the paper, whose path tracer had no light
///   sampling); `false`: only what arrives by way of other surfaces or specular
///   chains (light sampled at later vertices included), leaving the direct light
///   to light sampling, which handles it better (cbox, 33 spp: relMSE 1.2e-2 with
///   direct light learned, 7.0e-3 without, `path` 5.5e-3);
/// * `target` (`"radiance"` | `"variance"`, `"radiance"`) — what a leaf's density
///   follows: the incident radiance (from photons, their flux), or (Rath et al. 2020,
///   their `distribution: "simple"`, [`Target::Variance`]) √E[(f·|cos|·L̂_i)²], the
///   root of the second moment of the vertices' estimates, their BSDFs and the
///   estimates' noise included, which the camera paths record: `learn_from` then
///   defaults to, and must be, `"paths"` (beside photons, each giving half of a leaf's
///   density, it measured worse than photons alone at 64 spp; path records alone under
///   the photons' cost gate never took the guide up). Against radiance learned from the
///   paths, relMSE at 60 s: caustic_cbox 0.67–0.86×, cbox 0.78–0.99×, veach-mis 1.0×;
///   with `learn_direct` (the glossy plates' light is direct light) 0.78–0.84×,
///   0.88–0.94×, 0.88–0.92×;
/// * `rr` (`"mitsuba"` | `"ears"`, `"mitsuba"`) — `"ears"`: the final iteration's
///   passes (which record nothing for the guide) play EARS's learned roulette and
///   splitting ([`super::ears`]) instead of the roulette above, learning its statistics
///   from those passes (the first two play Mitsuba's);
/// ```json
/// {"type": "guided", "spp": 256, "bsdf_fraction": 0.5, "combine": "samples"}
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
    pub learn_fraction: bool,
    pub learn_from: LearnFrom,
    pub target: Target,
    pub rr: Roulette,
}

impl Default for Guided {
    fn default() -> Self {
        Guided {
            max_depth: 12,
            rr_threshold: 0.3,
            bsdf_fraction: 0.5,
            training_iterations: None,
            combine: Combine::Samples,
            spatial_threshold: 2000.0,
            learn_direct: false,
            learn_fraction: true,
            learn_from: LearnFrom::Photons,
            target: Target::Radiance,
            rr: Roulette::Mitsuba,
        }
    }
}

impl Guided {
    /// A pass of the current iteration, onto the iteration's own film in `state`;
    /// the render's image is [`Guided::image`] of the state.
    pub fn render_pass(&self, ctx: &PassContext, state: &mut Option<Box<State>>) -> PassResult {
        let state = state.get_or_insert_with(|| Box::new(self.new_state(ctx)));
        let pass_start = Instant::now();
        // every iteration continues the pixels' one sample sequence where the last
        // stopped, as `path`'s passes do, and iteration k ≥ 1 takes indices
        // [2^(k−1), 2^k): each iteration is a stratified block of the sequence on its
        // own and together they are `path`'s (own scramblings per iteration lost that:
        // env_sphere at equal spp 1.67× `path`'s relMSE). The tree an iteration samples
        // from depends on a pixel's earlier samples only through the records of all
        // pixels together (its share ~ 1/pixels), the photons' not at all.
        let iteration = state.history.len() as u32 - 1;
        let sample_index = state.passes_total;
        let photon_seed = hash_combine(ctx.seed, PHOTON_SEED + iteration);
        let mut counts = RayCounts::default();
        // where no leaf guides, a sample is `path`'s: a training iteration then records
        // (and shoots photons) in its first pass only and renders the rest as `path`,
        // at `path`'s cost (a recording pass costs about two `path` passes, which trace
        // packets: cbox_path), and so does a final iteration
        // a training iteration's first pass samples the other way than the rest (the
        // guide where they do not, and back), for the choice of `State::guide`
        let probe = !state.last && state.passes == 0;
        let guides = if self.learn_fraction {
            state.guide != probe && state.tree.any_guides()
        } else {
            self.bsdf_fraction < 1.0
        };
        let record = !state.last && (state.passes == 0 || guides);
        if !record {
            drop(SPARE_TILES.take());
        }
        // the pass's photons before the camera samples, which are merged as the pass
        // ends: a pass stopped on the way leaves the state as it was
        let photon_chunks = if record && self.learns_from_photons() {
            let count = state.photons.pass_count(photons_per_pass(ctx), state.recorded + 1);
            let shooting = (count, self.max_depth, self.learn_direct);
            match photons::shoot(ctx, &state.tree, shooting, (state.passes_total, photon_seed), &mut counts) {
                Some(d) => d,
                None => return PassResult { complete: false, counts },
            }
        } else {
            Vec::new()
        };
        // EARS plays in the final iteration, which records nothing (see `Guiding::li_ears`);
        // not in the training iterations' unguided passes, against which `State::guide`
        // weighs the guide at a guided pass's cost
        let ears_pass = self.rr == Roulette::Ears && state.last;
        if ears_pass && state.ears.is_none() {
            state.ears = Some(Box::new(ears::State::new(ctx)));
        }
        let State {
            film, tree, ears: learned, ..
        } = &mut **state;
        let learned = learned.as_deref().filter(|_| ears_pass);
        let record_radiance = self.learn_from == LearnFrom::Paths;
        // while the guide does not pay (see `State::guide`), BSDF sampling alone, except
        // where the paths that learn sample from it
        let off = self.learn_fraction && !guides && !(record && record_radiance);
        let guiding = Guiding {
            tree,
            bsdf_fraction: if off { 1.0 } else { self.bsdf_fraction },
            record,
            record_radiance,
            max_depth: self.max_depth,
            rr_threshold: self.rr_threshold,
            record_direct: self.learn_direct,
            learn_fraction: self.learn_fraction && !off,
            target: self.target,
        };
        let path = (!guides && !record).then_some(PathTracer {
            max_depth: self.max_depth,
            profile: PathProfile::Mis,
            rr_threshold: self.rr_threshold,
            hide_emitters: false,
            rr: Roulette::Mitsuba,
        });
        let scene = ctx.scene;
        if let (Some(p), true) = (&path, scene.packets() && !scene.has_media && !ears_pass) {
            // `path`'s packet pass, the same samples as its `li` (no per-pixel moments:
            // the summary's variance estimate is the recording passes')
            let mut result = p.render_pass_blocks(ctx, sample_index, film);
            result.counts += counts;
            if result.complete {
                self.pass_done(state, ctx, pass_start);
            }
            return result;
        }
        let width = ctx.film.width as usize;
        let pixels = (ctx.film.width * ctx.film.height) as usize;
        // each tile's records and the samples' means (pixel, value) for the moments (and
        // EARS's sub-paths and records)
        let (mut result, tiles) = if path.is_none() && learned.is_none() && scene.packets() && !scene.has_media {
            // `path`'s packets for the camera rays and their shadow rays, each lane then
            // walking on alone with the thread's buffers; its records kept apart, each
            // pixel's span noted for the deposits in the pixels' order below, in the last
            // recording pass's tiles (see `SPARE_TILES`)
            let spare = Mutex::new(SPARE_TILES.take());
            let new_tile = || spare.lock().ok().and_then(|mut s| s.pop()).unwrap_or_default();
            camera_pass_blocks_with(ctx, sample_index, film, new_tile, |b, out, t| {
                LANES.with_borrow_mut(|lanes| {
                    guiding.li_block(scene, b, out, lanes);
                    t.add_block(ctx, b.pixels, out, lanes, width);
                })
            })
        } else {
            let new_tile = || (Scratch::default(), Vec::<(usize, f64)>::new(), ears::Scratch::default());
            let (result, tiles) = camera_pass_with(ctx, sample_index, film, new_tile, |s, (scratch, means, split)| {
                let mark = scratch.records.len();
                let pixel = s.pixel.1 as usize * width + s.pixel.0 as usize;
                let rays = s.counts.rays;
                let l = match (&path, learned) {
                    (Some(p), Some(e)) => ears::li(p, e, scene, s, pixel, &mut split.branches),
                    (Some(p), None) => p.li(scene, s.ray, s.diff, s.sampler, s.counts),
                    (None, Some(e)) => {
                        let learned = (e, e.pixel_factor(pixel));
                        guiding.li_ears(scene, s, scratch, learned, &mut split.branches)
                    }
                    (None, None) => guiding.li(scene, s.ray, s.diff, s.sampler, s.counts, scratch),
                };
                if learned.is_some() {
                    split.keep_sample(pixel, pixels, l, s.counts.rays - rays);
                }
                if l.is_finite() {
                    means.push((pixel, sample_mean(l)));
                } else {
                    scratch.records.truncate(mark);
                }
                l
            });
            (
                result,
                tiles
                    .into_iter()
                    .map(|(scratch, means, split)| TileRecords {
                        records: scratch.records,
                        means,
                        split,
                        ..TileRecords::default()
                    })
                    .collect::<Vec<_>>(),
            )
        };
        result.counts += counts;
        if !result.complete {
            return result;
        }
        let s = &mut **state;
        s.recorded += record as u32;
        // the first passes' vertices choose the leaves' fractions, at most a budget of them
        let chooses = |r: &Record| r.counted && r.fq > 0.0;
        let candidates = if self.learn_fraction && s.passes < CHOICE_PASSES {
            tiles.iter().map(|t| t.records.iter().filter(|r| chooses(r)).count()).sum()
        } else {
            0
        };
        let mut choice = ChoiceStride::new(candidates, s.choice_budget);
        s.reserve_choice(choice.kept());
        if let (true, Some(e)) = (ears_pass, s.ears.as_mut()) {
            e.add_pass(tiles.iter().map(|t| &t.split), width);
        }
        for tile in &tiles {
            for &(pixel, y) in &tile.means {
                let m = &mut s.moments[pixel];
                m[0] += y;
                m[1] += y * y;
                m[2] += 1.0;
            }
            tile.for_each_in_pixel_order(|r| {
                let leaf = &mut s.tree.leaves[r.leaf as usize];
                if r.counted {
                    leaf.count += 1;
                }
                if r.value > 0.0 && r.value.is_finite() {
                    match self.target {
                        Target::Radiance => leaf.building.deposit(r.cell, r.value),
                        Target::Variance => leaf.building.deposit_moment(r.cell, r.value),
                    }
                }
                if candidates > 0 && chooses(r) && choice.keep() {
                    s.choice.push(sdtree::ChoiceSample {
                        leaf: r.leaf,
                        fq: r.fq,
                        q: r.q,
                        pb: r.pb,
                        p: r.p,
                        value: r.value,
                    });
                }
            });
        }
        if record {
            SPARE_TILES.set(tiles.into_iter().map(TileRecords::emptied).collect());
        }
        s.photons.deposit(&mut s.tree, photon_chunks);
        self.pass_done(s, ctx, pass_start);
        result
    }

    /// Counts a finished pass (begun at `start`) and ends its iteration when that is full.
    fn pass_done(&self, s: &mut State, ctx: &PassContext, start: Instant) {
        if s.last {
            // no tree is rebuilt from the training photons again
            s.photons.release();
        }
        s.passes += 1;
        s.passes_total += 1;
        let info = s.history.last_mut().expect("an iteration is running");
        info.spp = s.passes;
        info.seconds += start.elapsed().as_secs_f64();
        if !s.last {
            s.keep_probe();
        }
        if s.passes >= s.length && !s.last {
            self.end_iteration(s, ctx);
        }
    }

    /// Whether the recording trees learn from training photons ([`photons`]).
    fn learns_from_photons(&self) -> bool {
        self.learn_from == LearnFrom::Photons && self.target == Target::Radiance
    }
}

/// Photons of a training pass of one photon per pixel (at most [`MAX_PHOTONS_PER_PASS`]).
fn photons_per_pass(ctx: &PassContext) -> u64 {
    (ctx.film.width * ctx.film.height).min(MAX_PHOTONS_PER_PASS) as u64
}

/// A sample's radiance as the per-pixel moments take it (the mean over channels).
fn sample_mean(l: Vec3) -> f64 {
    ((l.x + l.y + l.z) / 3.0) as f64
}

thread_local! {
    /// Each lane's buffers of a packet pass (one per lane of a packet), kept by the thread
    /// from tile to tile and pass to pass: made anew for every tile, their growth was a
    /// tenth of what recording adds to a pass (cbox_path).
    static LANES: RefCell<[Scratch; PACKET]> = RefCell::new(std::array::from_fn(|_| Scratch::default()));
}

thread_local! {
    /// The tiles of the last recording pass run by this thread, emptied, for the next
    /// to fill: each pass's records made anew (megabytes) were pages faulted in and
    /// given back every pass (cbox_path: 4 % of a pass). Left empty by a pass that does
    /// not record, so that a render's training holds them no longer.
    static SPARE_TILES: RefCell<Vec<TileRecords>> = const { RefCell::new(Vec::new()) };
}

/// What a tile of a pass collects for the deposits: the records of its samples, the
/// samples' means (pixel, value) and EARS's sub-paths. A ray-by-ray pass leaves the
/// records in its pixels' order; a packet pass in its blocks' order, with each pixel's
/// span there (`spans`, by the pixels' order in the tile, from pixel `origin` on, rows
/// of `width`).
#[derive(Default)]
struct TileRecords {
    records: Vec<Record>,
    spans: Vec<(u32, u32)>,
    origin: (i32, i32),
    width: usize,
    means: Vec<(usize, f64)>,
    split: ears::Scratch,
}

impl TileRecords {
    /// Takes a packet's samples (pixels `pixels` of a block, radiance `out`) and each
    /// lane's records from `lanes`; a sample that is not finite records nothing.
    #[inline]
    fn add_block(&mut self, ctx: &PassContext, pixels: &[(i32, i32)], out: &[Vec3], lanes: &mut [Scratch; PACKET], width: usize) {
        if self.spans.is_empty() {
            let (x0, y0, x1, y1) = tile_of(ctx.film, pixels[0]);
            let area = ((x1 - x0) * (y1 - y0)) as usize;
            (self.origin, self.width) = ((x0, y0), (x1 - x0) as usize);
            self.spans.resize(area, (0, 0));
            self.means.reserve(area);
        }
        for (i, &(x, y)) in pixels.iter().enumerate() {
            let lane = &mut lanes[i].records;
            if out[i].is_finite() {
                self.means.push((y as usize * width + x as usize, sample_mean(out[i])));
                let start = self.records.len() as u32;
                self.records.append(lane);
                let local = (y - self.origin.1) as usize * self.width + (x - self.origin.0) as usize;
                self.spans[local] = (start, self.records.len() as u32);
            } else {
                lane.clear();
            }
        }
    }

    /// The tile without its samples, its buffers kept.
    fn emptied(mut self) -> TileRecords {
        self.records.clear();
        self.spans.clear();
        self.means.clear();
        self.split = ears::Scratch::default();
        self
    }

    /// Calls `f` with the records by pixel, rows in order, each sample's in its walk's
    /// order, as a ray-by-ray pass leaves them, so that the trees do not depend on how
    /// the pass traced.
    #[inline]
    fn for_each_in_pixel_order(&self, mut f: impl FnMut(&Record)) {
        if self.spans.is_empty() {
            self.records.iter().for_each(f);
            return;
        }
        for &(start, end) in &self.spans {
            self.records[start as usize..end as usize].iter().for_each(&mut f);
        }
    }
}
