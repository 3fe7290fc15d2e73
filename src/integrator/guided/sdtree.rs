//! The spatial part of the SD-tree: a binary tree over a cube around the scene,
//! each node halving its box along x, y, z in turn. Every leaf holds two
//! directional quadtrees: the one paths sample from during an iteration (learned
//! from the previous one) and the one they record into.

use super::quadtree::{sphere_to_square, DTree};
use crate::math::{Vec2, Vec3};

/// A spatial node in 4 bytes: `LEAF | leaf index`, or the index of the first of
/// its two children (lower and upper half along `depth % 3`), which are stored
/// side by side, so the descent picks one by adding the half's bit.
type SNode = u32;
const LEAF: u32 = 1 << 31;

/// What a spatial leaf holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Leaf {
    pub sampling: DTree,
    pub building: DTree,
    /// Path vertices recorded here in the current iteration.
    pub count: u64,
    depth: u32,
    /// Probability of BSDF sampling at vertices here (learned, see
    /// [`SdTree::end_iteration`]; 1: the guide is not used).
    pub bsdf_fraction: f32,
}

/// A vertex of the iteration, for its leaf's choice of BSDF fraction: F/q (F =
/// f·|cos|·L_i, q its sampling density), q, the BSDF's density, the direction's
/// point on the square, and the energy it deposited there.
#[derive(Clone, Copy, Debug)]
pub struct ChoiceSample {
    pub leaf: u32,
    pub fq: f32,
    pub q: f32,
    pub pb: f32,
    pub p: Vec2,
    pub value: f32,
}

/// Candidate BSDF-sampling probabilities a leaf chooses from.
pub const FRACTIONS: [f32; 5] = [0.1, 0.25, 0.5, 0.75, 1.0];

/// Vertices a leaf needs to choose its fraction (fewer keep the default).
const MIN_CHOICE_VERTICES: f64 = 128.0;

/// How much smaller than BSDF sampling's a guided fraction's second moment must
/// be to be chosen: a guided vertex costs more (the guide's lookups), and the
/// smallest of five noisy estimates is lower than its truth (with 0.95, cbox
/// chose guiding in 124 of 366 leaves and rendered 57 spp in a minute against 94
/// of `path`, at a higher error per sample).
const GUIDE_MARGIN: f64 = 0.6;

/// The second moments, summed over the vertices of an iteration that chose the
/// leaves' fractions, of the vertex estimator with each leaf's chosen fraction and
/// with BSDF sampling alone: 1 − chosen/bsdf estimates what guiding gains.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChoiceMoments {
    pub chosen: f64,
    pub bsdf: f64,
}

impl ChoiceMoments {
    /// Estimated relative reduction of the vertex estimator's second moment by
    /// guiding (0 without data).
    pub fn gain(&self) -> f64 {
        if self.bsdf > 0.0 && self.bsdf.is_finite() {
            (1.0 - self.chosen / self.bsdf).max(0.0)
        } else {
            0.0
        }
    }
}

/// Deepest spatial level (a box of 2⁻¹⁶ of the cube's side per axis).
const MAX_SPATIAL_DEPTH: u32 = 48;

#[derive(Clone, Debug, PartialEq)]
pub struct SdTree {
    origin: Vec3,
    size: f32,
    nodes: Vec<SNode>,
    pub leaves: Vec<Leaf>,
}

/// Sizes for the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TreeStats {
    pub spatial_leaves: usize,
    pub directional_nodes: usize,
    pub max_directional_depth: u32,
    pub bytes: usize,
    /// Leaves sampling with each of the [`FRACTIONS`] (others: the default).
    pub fractions: [usize; FRACTIONS.len()],
}

impl SdTree {
    /// One leaf covering the cube of side `2·radius` about `center`, recording
    /// into `initial`.
    pub fn new(center: Vec3, radius: f32, initial: DTree, bsdf_fraction: f32) -> SdTree {
        let r = if radius.is_finite() && radius > 0.0 { radius } else { 1.0 };
        SdTree {
            origin: center - Vec3::splat(r),
            size: 2.0 * r,
            nodes: vec![LEAF],
            leaves: vec![Leaf {
                sampling: DTree::default(),
                building: initial,
                count: 0,
                depth: 0,
                bsdf_fraction,
            }],
        }
    }

    /// Index of the leaf whose box holds `p` (points outside go to the nearest).
    #[inline]
    pub fn leaf_of(&self, p: Vec3) -> u32 {
        let mut q = ((p - self.origin) / self.size).clamp(Vec3::ZERO, Vec3::splat(1.0 - f32::EPSILON));
        if !q.is_finite() {
            q = Vec3::ZERO;
        }
        let mut n = 0usize;
        let mut axis = 0usize;
        loop {
            let node = self.nodes[n];
            if node & LEAF != 0 {
                return node & !LEAF;
            }
            let upper = q[axis] >= 0.5;
            q[axis] = 2.0 * q[axis] - upper as u32 as f32;
            n = node as usize + upper as usize;
            axis = if axis == 2 { 0 } else { axis + 1 };
        }
    }

    /// The directional cell of the recording tree of `leaf` for direction `d`.
    #[inline]
    pub fn record_cell(&self, leaf: u32, d: Vec3) -> u32 {
        self.leaves[leaf as usize].building.cell_of(sphere_to_square(d))
    }

    /// [`SdTree::record_cell`] for the point `p` of the square.
    #[inline]
    pub fn record_cell_at(&self, leaf: u32, p: Vec2) -> u32 {
        self.leaves[leaf as usize].building.cell_of(p)
    }

    /// The sampling tree of `leaf`, if it learned anything.
    #[inline]
    pub fn guide(&self, leaf: u32) -> Option<&DTree> {
        let t = &self.leaves[leaf as usize].sampling;
        t.can_sample().then_some(t)
    }

    /// The learned density at point `p` (for tests and inspection).
    pub fn sampling_tree_at(&self, p: Vec3) -> &DTree {
        &self.leaves[self.leaf_of(p) as usize].sampling
    }

    /// Ends an iteration: what was recorded becomes the sampling distribution;
    /// leaves that recorded more than `threshold` vertices are split (their
    /// children copy the trees and share the count) until none exceeds it; the
    /// recording trees are refined from the new distributions by energy share
    /// `rho`, emptied, and the counts reset.
    ///
    /// With `choice` (some of the iteration's vertices), each leaf with at least
    /// 128 of them takes the candidate fraction α whose estimated second moment of
    /// the vertex estimator, Σ (F/q)²·q / (α·p_bsdf + (1−α)·p_guide), is smallest
    /// (1, which skips the guide's lookups, unless another is below 0.6 of its), the
    /// guide's density being the new tree's with the vertex's own deposit left out
    /// (leave-one-out: the tree was learned from these vertices, and without it
    /// every vertex would find the guide at its own direction); the others take
    /// `default_fraction`. Returns the second moments the choice leads to
    /// ([`ChoiceMoments`]; zero without `choice`).
    pub fn end_iteration(
        &mut self,
        threshold: f64,
        rho: f32,
        refine: bool,
        choice: Option<&[ChoiceSample]>,
        default_fraction: f32,
    ) -> ChoiceMoments {
        let mut totals = ChoiceMoments::default();
        for leaf in &mut self.leaves {
            leaf.building.finish_recording();
            leaf.sampling = std::mem::take(&mut leaf.building);
            leaf.bsdf_fraction = default_fraction;
        }
        if let Some(samples) = choice {
            let mut moments = vec![([0.0f64; FRACTIONS.len()], 0u32); self.leaves.len()];
            for c in samples {
                let Some(leaf) = self.leaves.get(c.leaf as usize) else { continue };
                let t = &leaf.sampling;
                let usable = c.fq > 0.0 && c.fq.is_finite() && c.q > 0.0;
                if !usable || !t.can_sample() {
                    continue;
                }
                let (pdf, area) = t.pdf_square_and_area(c.p);
                let total = t.total() as f64;
                let e = if c.value > 0.0 && c.value.is_finite() {
                    c.value as f64
                } else {
                    0.0
                };
                let pg = if total - e > 0.0 {
                    ((pdf as f64 * area as f64 * total - e).max(0.0) / ((total - e) * area as f64)) / (4.0 * std::f64::consts::PI)
                } else {
                    0.0
                };
                let x = c.fq as f64 * c.fq as f64 * c.q as f64;
                let m = &mut moments[c.leaf as usize];
                m.1 += 1;
                for (mi, a) in m.0.iter_mut().zip(FRACTIONS) {
                    let p = a as f64 * c.pb as f64 + (1.0 - a as f64) * pg;
                    *mi += if p > 0.0 { x / p } else { f64::INFINITY };
                }
            }
            for (leaf, (m, n)) in self.leaves.iter_mut().zip(moments) {
                let last = FRACTIONS.len() - 1;
                if !(m[last] > 0.0 && m[last].is_finite()) {
                    continue;
                }
                totals.bsdf += m[last];
                if (n as f64) < MIN_CHOICE_VERTICES {
                    totals.chosen += m[last];
                    continue;
                }
                let mut best = last;
                for (i, x) in m.iter().enumerate() {
                    if *x < m[best] && (best != last || *x < GUIDE_MARGIN * m[last]) {
                        best = i;
                    }
                }
                leaf.bsdf_fraction = FRACTIONS[best];
                totals.chosen += m[best];
            }
        }
        if refine {
            let mut n = 0;
            while n < self.nodes.len() {
                if self.nodes[n] & LEAF != 0 {
                    let l = self.nodes[n] & !LEAF;
                    let leaf = &self.leaves[l as usize];
                    if leaf.count as f64 > threshold && leaf.depth < MAX_SPATIAL_DEPTH {
                        let mut child = leaf.clone();
                        child.count /= 2;
                        child.depth += 1;
                        let upper = self.leaves.len() as u32;
                        self.leaves[l as usize] = child.clone();
                        self.leaves.push(child);
                        let a = self.nodes.len() as u32;
                        self.nodes.push(LEAF | l);
                        self.nodes.push(LEAF | upper);
                        self.nodes[n] = a;
                        // the new leaves are visited later in this loop, and split again if needed
                    }
                }
                n += 1;
            }
        }
        for leaf in &mut self.leaves {
            leaf.building = leaf.sampling.refined(rho);
            leaf.count = 0;
        }
        totals
    }

    pub fn stats(&self) -> TreeStats {
        let mut s = TreeStats {
            spatial_leaves: self.leaves.len(),
            bytes: self.nodes.len() * std::mem::size_of::<SNode>() + self.leaves.len() * std::mem::size_of::<Leaf>(),
            ..TreeStats::default()
        };
        for l in &self.leaves {
            s.directional_nodes += l.sampling.node_count() + l.building.node_count();
            s.bytes += l.sampling.bytes() + l.building.bytes();
            s.max_directional_depth = s.max_directional_depth.max(l.sampling.depth());
            if let Some(i) = FRACTIONS.iter().position(|f| *f == l.bsdf_fraction) {
                s.fractions[i] += 1;
            }
        }
        s
    }
}
