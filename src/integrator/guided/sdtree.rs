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
    /// Estimated second moments ∫F²/p_α of the local estimator for each of the
    /// candidate fractions [`FRACTIONS`], from this iteration's vertices.
    pub moments: [f64; FRACTIONS.len()],
}

/// Candidate BSDF-sampling probabilities a leaf chooses from.
pub const FRACTIONS: [f32; 5] = [0.1, 0.25, 0.5, 0.75, 1.0];

/// Vertices a leaf needs to choose its fraction (fewer keep the default).
const MIN_CHOICE_VERTICES: f64 = 64.0;

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
                moments: [0.0; FRACTIONS.len()],
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
    /// With `learn_fraction`, each leaf that recorded at least 64 vertices (and
    /// could guide) takes the candidate fraction whose estimated second moment is
    /// smallest (1, which skips the guide's lookups, unless another is 5 % better);
    /// the others keep `default_fraction`. The moments come from the tree the
    /// iteration sampled, not the new one (a conservative choice: the new tree is
    /// the better trained).
    pub fn end_iteration(&mut self, threshold: f64, rho: f32, refine: bool, learn_fraction: bool, default_fraction: f32) {
        for leaf in &mut self.leaves {
            let m = leaf.moments;
            leaf.bsdf_fraction = default_fraction;
            if learn_fraction && leaf.sampling.can_sample() && leaf.count as f64 >= MIN_CHOICE_VERTICES && m.iter().all(|x| x.is_finite()) {
                let last = FRACTIONS.len() - 1;
                let mut best = last;
                for (i, x) in m.iter().enumerate() {
                    if *x < m[best] && (best != last || *x < 0.95 * m[last]) {
                        best = i;
                    }
                }
                if m[last] > 0.0 {
                    leaf.bsdf_fraction = FRACTIONS[best];
                }
            }
            leaf.moments = [0.0; FRACTIONS.len()];
            leaf.building.finish_recording();
            leaf.sampling = std::mem::take(&mut leaf.building);
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
