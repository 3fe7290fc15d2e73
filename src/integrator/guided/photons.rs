//! `guided`'s training photons (`learn_from: "photons"`): shot from the lights in
//! the recording passes and deposited with their flux into the recording tree's cell
//! of the direction they arrive from. Photons do not depend on the guide (their
//! numbers depend on the render's seed and the pass only), so a photon of an earlier
//! training pass is as good a sample of the incident light as a new one: each is
//! kept (its deposits, up to [`MAX_KEPT_DEPOSITS`]) and deposited again into every
//! later iteration's recording tree. A recording pass then shoots only
//! [`NEW_PHOTON_SHARE`] of a photon per pixel, or more where the kept ones fall short:
//! after its r-th recording pass an iteration's tree has seen at least r photons per
//! pixel (at most [`super::MAX_PHOTONS_PER_PASS`] per pass), as many as when every pass shot
//! one per pixel. Where the guide is off a training iteration records in one pass,
//! and its photons cost a quarter; where it guides, every pass records and the
//! doubling iterations take about half a photon per pixel and pass.

use super::path::mean;
use super::sdtree::{dequantize_unit, quantize_unit, SdTree};
use super::sphere_to_square;
use crate::integrator::photon::{shoot_into, Shooting, CHUNK};
use crate::integrator::{PassContext, RayCounts};
use crate::math::Vec2;
use rayon::prelude::*;

/// Photons' roulette threshold (the photon integrators' default).
const PHOTON_RR_THRESHOLD: f32 = 0.1;

/// Photons per pixel a recording pass shoots at least (of one photon per pixel, at most
/// [`super::MAX_PHOTONS_PER_PASS`]); the kept photons make up the rest.
pub const NEW_PHOTON_SHARE: f64 = 0.25;

/// Most photon deposits kept for later trees, [`PhotonDeposit`]s of 16 bytes: 64 MiB.
/// At 256² a pass's deposits are a few hundred thousand; at 1080p (2²⁰ photons per
/// pass) the store fills after one or two passes, and the passes after it shoot as many
/// photons as the trees need ([`TrainingPhotons::pass_count`]).
pub const MAX_KEPT_DEPOSITS: usize = 1 << 22;

/// A photon's deposit as the training trees take it: its point in the SD-tree's cube
/// ([`SdTree::quantized_point`]: the leaf is exact at any depth), its direction's point
/// on the square in as many bits per coordinate (directional cells to depth 16 exact,
/// deeper ones see the rounded point), and its flux (mean over channels).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonDeposit {
    at: [u16; 3],
    dir: [u16; 2],
    pub value: f32,
}

impl PhotonDeposit {
    /// The spatial leaf and the point on the square the deposit records at in `tree`.
    #[inline]
    fn query(&self, tree: &SdTree) -> (u32, Vec2) {
        let [x, y] = self.dir.map(dequantize_unit);
        (tree.leaf_of_quantized(self.at), Vec2::new(x, y))
    }
}

/// A chunk of a pass's photons (of [`CHUNK`]): their deposits in photon order, and
/// where they record in the current tree (leaf, cell).
#[derive(Default)]
pub struct PhotonChunk {
    deposits: Vec<PhotonDeposit>,
    photons: u32,
    leaves: Vec<u32>,
    cells: Vec<u32>,
}

/// The photons of the training passes so far (see the module docs), kept between passes.
#[derive(Debug, Default)]
pub struct TrainingPhotons {
    /// Deposits of whole chunks of photons, in the order they were shot.
    kept: Vec<PhotonDeposit>,
    /// How many photons those are.
    kept_photons: u64,
    /// `kept[..earlier]` are the finished iterations' deposits, of `earlier_photons`.
    earlier: usize,
    earlier_photons: u64,
    /// Photons the current iteration shot (kept or not).
    shot: u64,
    /// The current iteration's photon deposits per spatial leaf (for its count).
    tally: Vec<u32>,
    /// A chunk did not fit: no more are kept.
    full: bool,
}

impl TrainingPhotons {
    /// Sum of the kept deposits' values (the energy every later tree receives from them).
    pub fn kept_energy(&self) -> f64 {
        self.kept.iter().map(|d| d.value as f64).sum()
    }

    /// Photons kept, and their deposits.
    pub fn kept(&self) -> (u64, usize) {
        (self.kept_photons, self.kept.len())
    }

    /// Photons the iteration's `r`-th recording pass shoots, when a pass of one photon per
    /// pixel holds `n`: [`NEW_PHOTON_SHARE`] of `n`, or what brings the photons its tree
    /// sees (kept ones of earlier iterations, and its own) to `r·n`.
    pub fn pass_count(&self, n: u64, r: u32) -> u32 {
        let share = (n as f64 * NEW_PHOTON_SHARE).ceil() as u64;
        let short = (r as u64 * n).saturating_sub(self.earlier_photons + self.shot);
        share.max(short).clamp(1, n.max(1)) as u32
    }

    /// Deposits a pass's photons into `tree`'s recording trees, and keeps them.
    pub fn deposit(&mut self, tree: &mut SdTree, chunks: Vec<PhotonChunk>) {
        self.tally.resize(tree.leaves.len(), 0);
        for c in chunks {
            for ((&leaf, &cell), d) in c.leaves.iter().zip(&c.cells).zip(&c.deposits) {
                tree.leaves[leaf as usize].building.deposit(cell, d.value);
                self.tally[leaf as usize] += 1;
            }
            self.shot += c.photons as u64;
            if !self.full && self.kept.len() + c.deposits.len() <= MAX_KEPT_DEPOSITS {
                self.kept.extend(c.deposits);
                self.kept_photons += c.photons as u64;
            } else {
                self.full = true;
            }
        }
    }

    /// Before a training iteration ends: deposits the kept photons of the earlier
    /// iterations into `tree`'s recording trees, and adds the iteration's photons to the
    /// leaves' counts as `recorded` passes of `n` photons each (the spatial splits'
    /// threshold grows with the passes, not with the photons, so the splits stay those of
    /// one photon per pixel and pass).
    pub fn end_iteration(&mut self, tree: &mut SdTree, recorded: u32, n: u64) {
        self.tally.resize(tree.leaves.len(), 0);
        let earlier = &self.kept[..self.earlier];
        // the lookups in parallel, the deposits in order (the sums do not depend on threads)
        let at: Vec<Vec<(u32, u32)>> = earlier
            .par_chunks(CHUNK)
            .map(|c| {
                let queries: Vec<(u32, Vec2)> = c.iter().map(|d| d.query(tree)).collect();
                let cells = tree.record_cells(&queries);
                queries.iter().zip(cells).map(|(q, cell)| (q.0, cell)).collect()
            })
            .collect();
        for (&(leaf, cell), d) in at.iter().flatten().zip(earlier) {
            tree.leaves[leaf as usize].building.deposit(cell, d.value);
            self.tally[leaf as usize] += 1;
        }
        let seen = (self.earlier_photons + self.shot).max(1) as f64;
        let scale = (recorded as f64 * n as f64 / seen).min(1.0);
        for (leaf, t) in tree.leaves.iter_mut().zip(&self.tally) {
            leaf.count += (*t as f64 * scale).round() as u64;
        }
        self.tally.clear();
        self.earlier = self.kept.len();
        self.earlier_photons = self.kept_photons;
        self.shot = 0;
    }

    /// Frees the store (training is over).
    pub fn release(&mut self) {
        *self = TrainingPhotons::default();
    }
}

/// Photons `count` of a training pass (`pass`, `seed`) as `tree` records them, in
/// chunks of [`CHUNK`]; `None` when the stop token was set. A vertex after the camera's
/// first segment receives paths of at most `max_depth − 1` segments; its direct light
/// (the photons' first segment) only with `learn_direct`.
pub fn shoot(
    ctx: &PassContext,
    tree: &SdTree,
    (count, max_depth, learn_direct): (u32, u32, bool),
    (pass, seed): (u32, u32),
    counts: &mut RayCounts,
) -> Option<Vec<PhotonChunk>> {
    let shooting = Shooting {
        count,
        max_segments: max_depth.saturating_sub(1),
        rr_threshold: PHOTON_RR_THRESHOLD,
        min_segments: if learn_direct { 1 } else { 2 },
    };
    let (mut chunks, rays) = shoot_into(
        ctx.scene,
        shooting,
        0..count as usize,
        (pass, seed),
        ctx.stop,
        PhotonChunk::default,
        |c, p, photon| {
            let value = mean(photon.power);
            if value > 0.0 && value.is_finite() {
                let s = sphere_to_square(photon.wi);
                c.deposits.push(PhotonDeposit {
                    at: tree.quantized_point(p),
                    dir: [quantize_unit(s.x), quantize_unit(s.y)],
                    value,
                });
            }
        },
    )?;
    counts.rays += rays;
    let count = count as usize;
    chunks.par_iter_mut().enumerate().for_each(|(i, c)| {
        c.photons = (count - i * CHUNK).min(CHUNK) as u32;
        let queries: Vec<(u32, Vec2)> = c.deposits.iter().map(|d| d.query(tree)).collect();
        c.cells = tree.record_cells(&queries);
        c.leaves = queries.into_iter().map(|q| q.0).collect();
    });
    Some(chunks)
}
