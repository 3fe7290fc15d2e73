//! The spatial part of the SD-tree: a binary tree over a cube around the scene,
//! each node halving its box along x, y, z in turn. Every leaf holds two
//! directional quadtrees: the one paths sample from during an iteration (learned
//! from the previous one) and the one they record into.

use super::quadtree::{sphere_to_square, DTree};
use crate::math::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
enum SNode {
    /// Children for the lower and upper half along `depth % 3`.
    Inner([u32; 2]),
    Leaf(u32),
}

/// What a spatial leaf holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Leaf {
    pub sampling: DTree,
    pub building: DTree,
    /// Path vertices recorded here in the current iteration.
    pub count: u64,
    depth: u32,
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
}

impl SdTree {
    /// One leaf covering the cube of side `2·radius` about `center`, recording
    /// into `initial`.
    pub fn new(center: Vec3, radius: f32, initial: DTree) -> SdTree {
        let r = if radius.is_finite() && radius > 0.0 { radius } else { 1.0 };
        SdTree {
            origin: center - Vec3::splat(r),
            size: 2.0 * r,
            nodes: vec![SNode::Leaf(0)],
            leaves: vec![Leaf {
                sampling: DTree::default(),
                building: initial,
                count: 0,
                depth: 0,
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
            match self.nodes[n] {
                SNode::Leaf(l) => return l,
                SNode::Inner(ch) => {
                    let upper = q[axis] >= 0.5;
                    q[axis] = 2.0 * q[axis] - upper as u32 as f32;
                    n = ch[upper as usize] as usize;
                    axis = (axis + 1) % 3;
                }
            }
        }
    }

    /// The directional cell of the recording tree of `leaf` for direction `d`.
    #[inline]
    pub fn record_cell(&self, leaf: u32, d: Vec3) -> u32 {
        self.leaves[leaf as usize].building.cell_of(sphere_to_square(d))
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
    pub fn end_iteration(&mut self, threshold: f64, rho: f32, refine: bool) {
        for leaf in &mut self.leaves {
            leaf.building.finish_recording();
            leaf.sampling = std::mem::take(&mut leaf.building);
        }
        if refine {
            let mut n = 0;
            while n < self.nodes.len() {
                if let SNode::Leaf(l) = self.nodes[n] {
                    let leaf = &self.leaves[l as usize];
                    if leaf.count as f64 > threshold && leaf.depth < MAX_SPATIAL_DEPTH {
                        let mut child = leaf.clone();
                        child.count /= 2;
                        child.depth += 1;
                        let upper = self.leaves.len() as u32;
                        self.leaves[l as usize] = child.clone();
                        self.leaves.push(child);
                        let a = self.nodes.len() as u32;
                        self.nodes.push(SNode::Leaf(l));
                        self.nodes.push(SNode::Leaf(upper));
                        self.nodes[n] = SNode::Inner([a, a + 1]);
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
        }
        s
    }
}
