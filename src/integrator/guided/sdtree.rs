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
}

/// A vertex of the iteration, for its leaf's choice of BSDF fraction: F/q (F =
/// f·|cos|·L_i, q its sampling density), q, the BSDF's density, the direction's
/// point on the square, and what it deposited there (energy, or a second moment).
#[derive(Clone, Copy, Debug)]
pub struct ChoiceSample {
    pub leaf: u32,
    pub fq: f32,
    pub q: f32,
    pub pb: f32,
    pub p: Vec2,
    pub value: f32,
}

/// Smallest BSDF-sampling probability a leaf may choose: directions the guide
/// never learned stay reachable.
pub const MIN_FRACTION: f32 = 0.1;

/// The candidate fractions a leaf's second moment is evaluated at: a grid of
/// step 0.025 from [`MIN_FRACTION`] to 1, refined by a parabola through the
/// least value and its neighbours (the moment is convex in the fraction).
const GRID: usize = 37;

fn grid_fraction(i: usize) -> f64 {
    MIN_FRACTION as f64 + (1.0 - MIN_FRACTION as f64) * i as f64 / (GRID - 1) as f64
}

/// Bins of the leaves' fractions in the summary: lower bounds, the last one
/// being BSDF sampling alone (fraction 1).
pub const FRACTION_BINS: [f32; 5] = [0.1, 0.25, 0.5, 0.75, 1.0];

/// Records (camera vertices and photons) a leaf needs for its own directional
/// distribution, and vertices it needs to choose its own fraction: with fewer a
/// leaf keeps the distribution it had (its parent's, when it was just split)
/// and takes the fraction of its nearest ancestor that has enough.
pub const MIN_LEAF_SAMPLES: u64 = 128;

/// How much smaller than BSDF sampling's a guided fraction's second moment must
/// be to be chosen: a guided vertex costs more (the guide's lookups), and the
/// smallest of many noisy estimates is lower than its truth (with 0.95, cbox
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
    /// The vertices that took part (in leaves with a guide to choose against).
    pub vertices: u64,
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

/// Bits per axis of a [`SdTree::quantized_point`]: the deepest leaf's halvings per axis.
pub const UNIT_BITS: u32 = MAX_SPATIAL_DEPTH / 3;

/// A coordinate in [0, 1) as the index of its interval of 2^−[`UNIT_BITS`] (its first
/// [`UNIT_BITS`] binary digits; a tree's descent reads no more).
#[inline]
pub fn quantize_unit(x: f32) -> u16 {
    ((x * (1u32 << UNIT_BITS) as f32) as u32).min((1 << UNIT_BITS) - 1) as u16
}

/// The middle of [`quantize_unit`]'s interval `i`: its digits are `i`'s (exact in f32).
#[inline]
pub fn dequantize_unit(i: u16) -> f32 {
    (i as f32 + 0.5) / (1u32 << UNIT_BITS) as f32
}

/// The levels [`SdTree::leaf_of`] skips: its descent starts at the node of depth
/// 3·`JUMP_BITS` (or the leaf above it) that holds the point's cell of a grid of
/// 2^`JUMP_BITS` cells per axis, from a table of 4096 nodes (16 KB: in the first-level
/// cache beside the nodes; caustic_cbox spent 27 % less time in the descent than with
/// 512 nodes, and 36 % less with 32768, 128 KB in the second level).
const JUMP_BITS: u32 = 4;
const JUMP_SIDE: usize = 1 << JUMP_BITS;

/// A jump table entry's flag: no leaf under the node samples its guide (each has
/// fraction 1 or a tree that cannot sample), so a vertex there that records nothing
/// needs no leaf ([`SdTree::guiding_leaf_of`]; caustic_cbox: 1,202 of its 1,561 leaves).
const UNGUIDED: u32 = 1 << 30;

#[derive(Clone, Debug, PartialEq)]
pub struct SdTree {
    origin: Vec3,
    size: f32,
    nodes: Vec<SNode>,
    pub leaves: Vec<Leaf>,
    /// Per leaf, the probability of BSDF sampling at vertices there (learned, see
    /// [`SdTree::end_iteration`]; 1: the guide is not used). Beside the leaves, not in
    /// them: every vertex reads its leaf's, 4 bytes of a small array, where reading it
    /// from the leaf (80 bytes each) missed the cache (caustic_cbox: 40 % of `plan`'s time).
    fractions: Vec<f32>,
    /// For each cell of the grid (x fastest), the node [`SdTree::leaf_of`] goes on from,
    /// with [`UNGUIDED`] set where no leaf in the cell's box uses the guide.
    jump: Vec<u32>,
}

/// Sizes for the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TreeStats {
    pub spatial_leaves: usize,
    pub directional_nodes: usize,
    pub max_directional_depth: u32,
    pub bytes: usize,
    /// Leaves per bin of [`FRACTION_BINS`] (a fraction counts in the last bin
    /// whose bound it reaches).
    pub fractions: [usize; FRACTION_BINS.len()],
}

impl SdTree {
    /// One leaf covering the cube of side `2·radius` about `center`, recording
    /// into `initial`.
    pub fn new(center: Vec3, radius: f32, initial: DTree, bsdf_fraction: f32) -> SdTree {
        let r = if radius.is_finite() && radius > 0.0 { radius } else { 1.0 };
        let mut t = SdTree {
            origin: center - Vec3::splat(r),
            size: 2.0 * r,
            nodes: vec![LEAF],
            leaves: vec![Leaf {
                sampling: DTree::default(),
                building: initial,
                count: 0,
                depth: 0,
            }],
            fractions: vec![bsdf_fraction],
            jump: Vec::new(),
        };
        t.build_jump();
        t
    }

    /// Fills [`SdTree::jump`]: the first 3·[`JUMP_BITS`] steps of a descent depend only on
    /// the point's grid cell, the step along an axis taking that coordinate's next bit.
    fn build_jump(&mut self) {
        let mut jump = vec![0u32; JUMP_SIDE * JUMP_SIDE * JUMP_SIDE];
        for (i, j) in jump.iter_mut().enumerate() {
            let cell = [i % JUMP_SIDE, i / JUMP_SIDE % JUMP_SIDE, i / (JUMP_SIDE * JUMP_SIDE)];
            let mut n = 0usize;
            for level in 0..3 * JUMP_BITS as usize {
                let node = self.nodes[n];
                if node & LEAF != 0 {
                    break;
                }
                let bit = cell[level % 3] >> (JUMP_BITS as usize - 1 - level / 3) & 1;
                n = node as usize + bit;
            }
            // node indices stay far below the flag's bit: 2^30 nodes would be half as
            // many leaves, each with two directional trees
            debug_assert!(n < UNGUIDED as usize, "spatial node {n} reaches the jump table's flag");
            *j = n as u32 | if self.guides_below(n) { 0 } else { UNGUIDED };
        }
        self.jump = jump;
    }

    /// Whether a leaf of node `n`'s subtree samples its guide.
    fn guides_below(&self, n: usize) -> bool {
        let node = self.nodes[n];
        if node & LEAF != 0 {
            let leaf = (node & !LEAF) as usize;
            return self.fractions[leaf] < 1.0 && self.leaves[leaf].sampling.can_sample();
        }
        self.guides_below(node as usize) || self.guides_below(node as usize + 1)
    }

    /// The probability of BSDF sampling at vertices in `leaf`.
    #[inline]
    pub fn bsdf_fraction(&self, leaf: u32) -> f32 {
        self.fractions[leaf as usize]
    }

    /// Sets each leaf's fraction to `f` of it (tests force guiding so).
    pub fn map_fractions(&mut self, f: impl Fn(f32) -> f32) {
        self.fractions.iter_mut().for_each(|x| *x = f(*x));
        self.build_jump();
    }

    /// Whether some leaf samples the guide.
    pub fn any_guides(&self) -> bool {
        self.fractions.iter().any(|&f| f < 1.0)
    }

    /// Index of the leaf whose box holds `p` (points outside go to the nearest).
    #[inline]
    pub fn leaf_of(&self, p: Vec3) -> u32 {
        self.leaf_at_unit(self.unit_point(p))
    }

    /// [`SdTree::leaf_of`] where a leaf that samples its guide may hold `p`; `None`
    /// where none does (the point's grid cell is [`UNGUIDED`]).
    #[inline]
    pub fn guiding_leaf_of(&self, p: Vec3) -> Option<u32> {
        let q = self.unit_point(p);
        let (n, x, y, z) = self.jump_at(q);
        (n & UNGUIDED == 0).then(|| self.descend_from(n as usize, x, y, z))
    }

    /// `p` in the cube's own coordinates, [0, 1)³ (points outside clamped to the
    /// nearest, non-finite ones at 0); the cube does not change as the tree grows.
    #[inline]
    pub fn unit_point(&self, p: Vec3) -> Vec3 {
        let q = ((p - self.origin) / self.size).clamp(Vec3::ZERO, Vec3::splat(1.0 - f32::EPSILON));
        if q.is_finite() {
            q
        } else {
            Vec3::ZERO
        }
    }

    /// [`SdTree::unit_point`] in [`UNIT_BITS`] bits per axis: a leaf's box is at least
    /// 2^−[`UNIT_BITS`] of the cube's side per axis, so the point's leaf is exact (the
    /// training photons keep their positions so, [`super::photons`]).
    #[inline]
    pub fn quantized_point(&self, p: Vec3) -> [u16; 3] {
        self.unit_point(p).to_array().map(quantize_unit)
    }

    /// The leaf of a point from [`SdTree::quantized_point`].
    #[inline]
    pub fn leaf_of_quantized(&self, q: [u16; 3]) -> u32 {
        self.leaf_at_unit(Vec3::from_array(q.map(dequantize_unit)))
    }

    /// The leaf holding the point `q` of [0, 1)³ ([`SdTree::unit_point`]).
    #[inline]
    fn leaf_at_unit(&self, q: Vec3) -> u32 {
        let (n, x, y, z) = self.jump_at(q);
        self.descend_from((n & !UNGUIDED) as usize, x, y, z)
    }

    /// The jump table's entry for the point `q` of [0, 1)³ and the point in its box:
    /// each step of the descent doubles a coordinate and drops its integer part,
    /// exactly, so this is the point those 3·JUMP_BITS steps leave (2^JUMP_BITS·q and
    /// its fraction are exact too).
    #[inline(always)]
    fn jump_at(&self, q: Vec3) -> (u32, f32, f32, f32) {
        let side = JUMP_SIDE as f32;
        let g = [(q.x * side) as usize, (q.y * side) as usize, (q.z * side) as usize];
        let (x, y, z) = (q.x * side - g[0] as f32, q.y * side - g[1] as f32, q.z * side - g[2] as f32);
        (self.jump[(g[2] * JUMP_SIDE + g[1]) * JUMP_SIDE + g[0]], x, y, z)
    }

    /// The leaf holding the point (x, y, z) of node `n`'s box, from `n` down.
    #[inline(always)]
    fn descend_from(&self, mut n: usize, mut x: f32, mut y: f32, mut z: f32) -> u32 {
        // the axes in turn from x (3·JUMP_BITS levels down), unrolled: each coordinate
        // stays in a register (indexed by the axis, the point went through memory and
        // every level waited on a store)
        loop {
            for c in [&mut x, &mut y, &mut z] {
                let node = self.nodes[n];
                if node & LEAF != 0 {
                    return node & !LEAF;
                }
                let upper = *c >= 0.5;
                *c = 2.0 * *c - upper as u32 as f32;
                n = node as usize + upper as usize;
            }
        }
    }

    /// The directional cell of the recording tree of `leaf` for direction `d`.
    #[inline]
    pub fn record_cell(&self, leaf: u32, d: Vec3) -> u32 {
        self.leaves[leaf as usize].building.cell_of(sphere_to_square(d))
    }

    /// [`SdTree::record_cell`] of each (leaf, direction) in `queries`, in order. The
    /// descents of a batch go in lockstep, a level of each in turn: the photons'
    /// directions land in scattered leaves' trees, and one descent at a time waits
    /// for each of its loads (caustic_cbox: half of `record_cell`'s time on one load).
    /// The directions are given as points on the square ([`sphere_to_square`]).
    pub fn record_cells(&self, queries: &[(u32, Vec2)]) -> Vec<u32> {
        const LANES: usize = 8;
        let mut cells = vec![0u32; queries.len()];
        for (batch, out) in queries.chunks(LANES).zip(cells.chunks_mut(LANES)) {
            let mut at = [(0usize, 0.0f32, 0.0f32); LANES];
            for (a, &(_, p)) in at.iter_mut().zip(batch) {
                *a = (0, p.x, p.y);
            }
            let mut running = (1u32 << batch.len()) - 1;
            while running != 0 {
                for (i, &(leaf, _)) in batch.iter().enumerate() {
                    if running & (1 << i) == 0 {
                        continue;
                    }
                    match self.leaves[leaf as usize].building.descend(at[i]) {
                        Ok(cell) => {
                            out[i] = cell;
                            running &= !(1 << i);
                        }
                        Err(next) => at[i] = next,
                    }
                }
            }
        }
        cells
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

    /// Ends an iteration: what was recorded becomes the sampling distribution of
    /// each leaf with at least [`MIN_LEAF_SAMPLES`] records (the others keep theirs:
    /// a distribution learned from a handful of records is noise); leaves that
    /// recorded more than `threshold` vertices are split (their children copy the
    /// trees and share the count) until none exceeds it; the recording trees are
    /// refined from the new distributions by energy share `rho`, emptied, and the
    /// counts reset.
    ///
    /// With `choice` (some of the iteration's vertices), each leaf with at least
    /// [`MIN_LEAF_SAMPLES`] of them takes the fraction α in [[`MIN_FRACTION`], 1]
    /// whose estimated second moment of the vertex estimator,
    /// Σ (F/q)²·q / (α·p_bsdf + (1−α)·p_guide), is smallest (1, which skips the
    /// guide's lookups, unless another is below 0.6 of its), the guide's density
    /// being the new tree's with the vertex's own deposit left out
    /// ([`DTree::pdf_square_without`], leave-one-out:
    /// the tree was learned from these vertices, and without it every vertex would
    /// find the guide at its own direction); a leaf with fewer takes the fraction
    /// its nearest ancestor's vertices choose together, and keeps its own when no
    /// ancestor has enough. Returns the second moments the choice leads to
    /// ([`ChoiceMoments`]; zero without `choice`).
    pub fn end_iteration(&mut self, threshold: f64, rho: f32, refine: bool, choice: Option<&[ChoiceSample]>) -> ChoiceMoments {
        let mut totals = ChoiceMoments::default();
        for leaf in &mut self.leaves {
            leaf.building.finish_recording();
            if leaf.count >= MIN_LEAF_SAMPLES || !leaf.sampling.can_sample() {
                leaf.sampling = std::mem::take(&mut leaf.building);
            }
        }
        if let Some(samples) = choice {
            totals = self.choose_fractions(samples);
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
                        self.fractions.push(self.fractions[l as usize]);
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
        self.build_jump();
        totals
    }

    /// The leaves' fractions from the iteration's vertices (see [`SdTree::end_iteration`]).
    fn choose_fractions(&mut self, samples: &[ChoiceSample]) -> ChoiceMoments {
        // per leaf: the second moment at each grid fraction, and the vertices
        let mut moments = vec![([0.0f64; GRID], 0u64); self.leaves.len()];
        for c in samples {
            let Some(leaf) = self.leaves.get(c.leaf as usize) else { continue };
            let t = &leaf.sampling;
            let usable = c.fq > 0.0 && c.fq.is_finite() && c.q > 0.0;
            if !usable || !t.can_sample() {
                continue;
            }
            let pg = t.pdf_square_without(c.p, c.value) / (4.0 * std::f64::consts::PI);
            let x = c.fq as f64 * c.fq as f64 * c.q as f64;
            let m = &mut moments[c.leaf as usize];
            m.1 += 1;
            for (i, mi) in m.0.iter_mut().enumerate() {
                let a = grid_fraction(i);
                let p = a * c.pb as f64 + (1.0 - a) * pg;
                *mi += if p > 0.0 { x / p } else { f64::INFINITY };
            }
        }
        // the same summed over each spatial node's subtree (children follow their
        // parents in `nodes`, so a reverse sweep sums whole subtrees)
        let mut subtree = vec![([0.0f64; GRID], 0u64); self.nodes.len()];
        let mut parent = vec![usize::MAX; self.nodes.len()];
        for (n, &node) in self.nodes.iter().enumerate() {
            if node & LEAF != 0 {
                subtree[n] = moments[(node & !LEAF) as usize];
            } else {
                parent[node as usize] = n;
                parent[node as usize + 1] = n;
            }
        }
        for n in (1..self.nodes.len()).rev() {
            let (m, count) = subtree[n];
            let p = &mut subtree[parent[n]];
            p.1 += count;
            p.0.iter_mut().zip(m).for_each(|(a, b)| *a += b);
        }
        let mut totals = ChoiceMoments {
            vertices: moments.iter().map(|m| m.1).sum(),
            ..ChoiceMoments::default()
        };
        for n in 0..self.nodes.len() {
            let node = self.nodes[n];
            if node & LEAF == 0 {
                continue;
            }
            let leaf = (node & !LEAF) as usize;
            let own = &moments[leaf].0;
            let last = GRID - 1;
            // the nearest node, the leaf itself first, whose subtree has enough vertices
            let mut a = n;
            while subtree[a].1 < MIN_LEAF_SAMPLES && parent[a] != usize::MAX {
                a = parent[a];
            }
            if subtree[a].1 < MIN_LEAF_SAMPLES {
                if own[last] > 0.0 && own[last].is_finite() {
                    totals.bsdf += own[last];
                    totals.chosen += own[last];
                }
                continue;
            }
            let (fraction, best) = least_moment(&subtree[a].0);
            self.fractions[leaf] = fraction;
            if own[last] > 0.0 && own[last].is_finite() {
                totals.bsdf += own[last];
                totals.chosen += own[best];
            }
        }
        totals
    }

    pub fn stats(&self) -> TreeStats {
        let mut s = TreeStats {
            spatial_leaves: self.leaves.len(),
            bytes: self.nodes.len() * std::mem::size_of::<SNode>()
                + self.leaves.len() * (std::mem::size_of::<Leaf>() + std::mem::size_of::<f32>()),
            ..TreeStats::default()
        };
        for (l, &fraction) in self.leaves.iter().zip(&self.fractions) {
            s.directional_nodes += l.sampling.node_count() + l.building.node_count();
            s.bytes += l.sampling.bytes() + l.building.bytes();
            s.max_directional_depth = s.max_directional_depth.max(l.sampling.depth());
            if let Some(i) = FRACTION_BINS.iter().rposition(|f| fraction >= *f) {
                s.fractions[i] += 1;
            }
        }
        s
    }
}

/// The fraction with the least estimated second moment `m` (at the grid's
/// fractions) and the grid point nearest to it: 1 unless another's is below
/// [`GUIDE_MARGIN`] of its; else the grid's least, moved to the vertex of the
/// parabola through it and its neighbours.
fn least_moment(m: &[f64; GRID]) -> (f32, usize) {
    let last = GRID - 1;
    if !(m[last] > 0.0 && m[last].is_finite()) {
        return (1.0, last);
    }
    let mut best = last;
    for (i, x) in m.iter().enumerate() {
        if *x < m[best] && (best != last || *x < GUIDE_MARGIN * m[last]) {
            best = i;
        }
    }
    if best == last {
        return (1.0, last);
    }
    let a = grid_fraction(best);
    if best == 0 {
        return (a as f32, best);
    }
    let (l, c, r) = (m[best - 1], m[best], m[best + 1]);
    let curvature = l - 2.0 * c + r;
    let step = grid_fraction(1) - grid_fraction(0);
    let shift = if curvature > 0.0 {
        (0.5 * (l - r) / curvature).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    ((a + shift * step).clamp(MIN_FRACTION as f64, 1.0) as f32, best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::xorshift32;

    /// The descent from the root, one level at a time (what the grid's table skips).
    fn leaf_by_descent(t: &SdTree, p: Vec3) -> u32 {
        let mut q = ((p - t.origin) / t.size).clamp(Vec3::ZERO, Vec3::splat(1.0 - f32::EPSILON));
        if !q.is_finite() {
            q = Vec3::ZERO;
        }
        let (mut n, mut axis) = (0usize, 0usize);
        loop {
            let node = t.nodes[n];
            if node & LEAF != 0 {
                return node & !LEAF;
            }
            let upper = q[axis] >= 0.5;
            q[axis] = 2.0 * q[axis] - upper as u32 as f32;
            n = node as usize + upper as usize;
            axis = (axis + 1) % 3;
        }
    }

    /// A tree split unevenly to depths 0 to 30 (most leaves split a few times, some not
    /// at all, some 10 times), and around `deep` (unit coordinates) to the deepest level.
    fn uneven_tree(state: &mut u32, deep: Vec3) -> SdTree {
        let mut t = SdTree::new(Vec3::new(0.5, -1.0, 2.0), 3.0, DTree::default(), 1.0);
        for _ in 0..3 {
            for leaf in &mut t.leaves {
                leaf.count = match xorshift32(state) % 8 {
                    0 => 0,
                    1 => 1000 << 10,
                    _ => (xorshift32(state) % 8000) as u64,
                };
            }
            t.end_iteration(1000.0, 0.01, true, None);
        }
        for _ in 0..MAX_SPATIAL_DEPTH {
            t.leaves.iter_mut().for_each(|l| l.count = 0);
            let l = t.leaf_of(t.origin + deep * t.size);
            t.leaves[l as usize].count = 2000;
            t.end_iteration(1000.0, 0.01, true, None);
        }
        t
    }

    /// Random points, points on the grid's planes and the halves' planes below them,
    /// random points about `deep`, and points outside the box or not finite.
    fn test_points(t: &SdTree, state: &mut u32, deep: Vec3) -> Vec<Vec3> {
        let mut points = Vec::new();
        let mut u = || (xorshift32(state) >> 8) as f32 / (1 << 24) as f32;
        for _ in 0..20000 {
            points.push(t.origin + Vec3::new(u(), u(), u()) * t.size);
        }
        for _ in 0..20000 {
            let d = Vec3::new(u(), u(), u()) - Vec3::splat(0.5);
            points.push(t.origin + (deep + d * 2f32.powi(-13)) * t.size);
        }
        for k in 0..=64 {
            // planes of the grid (k = 8·i) and of finer halves, and the box's faces
            let f = k as f32 / 64.0;
            points.push(t.origin + Vec3::new(f, 0.3, 0.7) * t.size);
            points.push(t.origin + Vec3::new(0.6, f, f) * t.size);
            points.push(t.origin + Vec3::new(f, f, f) * t.size);
        }
        points.extend([
            Vec3::splat(-100.0),
            Vec3::splat(100.0),
            Vec3::splat(f32::NAN),
            Vec3::new(f32::INFINITY, 0.0, 0.0),
        ]);
        points
    }

    /// Where [`uneven_tree`] splits to the deepest level: an arbitrary point off the grid's
    /// planes (its digits happen to begin those of 1/π and 1/√2).
    #[allow(clippy::approx_constant)]
    const DEEP: Vec3 = Vec3::new(0.3183, 0.7071, 0.5772);

    /// `leaf_of` through the grid's table finds the leaf the level-by-level descent does,
    /// in a tree split unevenly to depths 0 to 48 (leaves above and below the table's
    /// depth), for the points of [`test_points`].
    #[test]
    fn leaf_lookup_through_the_grid_is_the_descent() {
        let mut state = 0x1234_5678u32;
        let t = uneven_tree(&mut state, DEEP);
        let depths: Vec<u32> = t.leaves.iter().map(|l| l.depth).collect();
        let (shallow, deep) = (depths.iter().filter(|&&d| d < 9).count(), depths.iter().filter(|&&d| d > 9).count());
        assert!(shallow > 0 && deep > 0, "{shallow} leaves above and {deep} below the table's depth");
        let points = test_points(&t, &mut state, DEEP);
        let wrong = points.iter().filter(|&&p| t.leaf_of(p) != leaf_by_descent(&t, p)).count();
        assert_eq!(
            wrong,
            0,
            "{wrong} of {} points in another leaf ({} leaves)",
            points.len(),
            t.leaves.len()
        );
    }

    /// `guiding_leaf_of` gives `leaf_of`'s leaf wherever that leaf samples its guide, and
    /// says "none" only where it does not, in the uneven tree with a random tenth of its
    /// leaves guiding (fraction below 1 and a tree to sample), others at a fraction below
    /// 1 without a tree, and one deep leaf guiding, for the points of [`test_points`].
    /// Both answers occur (15,121 and 25,078 points). Fails when the flag looks at a
    /// node's first child alone (696 of the 40,199 points answered "none" in a guiding leaf).
    #[test]
    fn the_grid_skips_only_regions_without_a_guiding_leaf() {
        let mut state = 0x1234_5678u32;
        let mut t = uneven_tree(&mut state, DEEP);
        let mut learned = DTree::uniform(1);
        learned.deposit(0, 1.0);
        learned.finish_recording();
        for l in 0..t.leaves.len() {
            match xorshift32(&mut state) % 10 {
                0 => {
                    t.leaves[l].sampling = learned.clone();
                    t.fractions[l] = 0.5;
                }
                1 => t.fractions[l] = 0.3,
                _ => {}
            }
        }
        let deep_leaf = t.leaf_of(t.origin + DEEP * t.size) as usize;
        t.leaves[deep_leaf].sampling = learned;
        t.fractions[deep_leaf] = 0.2;
        t.build_jump();
        let guides = |l: u32| t.fractions[l as usize] < 1.0 && t.leaves[l as usize].sampling.can_sample();
        let points = test_points(&t, &mut state, DEEP);
        let (mut skipped, mut found, mut wrong) = (0, 0, 0);
        for &p in &points {
            let leaf = t.leaf_of(p);
            match t.guiding_leaf_of(p) {
                Some(l) => {
                    found += 1;
                    wrong += (l != leaf) as usize;
                }
                None => {
                    skipped += 1;
                    wrong += guides(leaf) as usize;
                }
            }
        }
        eprintln!("{skipped} points skipped, {found} looked up, {wrong} wrong of {}", points.len());
        assert_eq!(wrong, 0, "{wrong} of {} points given the wrong answer", points.len());
        assert!(
            skipped > 0 && found > 0,
            "{skipped} skipped, {found} looked up: one answer never occurs"
        );
    }

    /// A point kept in [`UNIT_BITS`] bits per axis (the training photons') finds the leaf
    /// of the point itself, in a tree with leaves at the deepest level, for the points of
    /// [`test_points`], half of them about the deep leaves. Fails with 15 bits (307 of
    /// 40,199 points in another leaf) and with round-to-nearest instead of the interval's
    /// index (5,659).
    #[test]
    fn quantized_points_find_the_leaf_of_the_point() {
        let mut state = 0x1234_5678u32;
        let t = uneven_tree(&mut state, DEEP);
        let deepest = t.leaves.iter().map(|l| l.depth).max().unwrap_or(0);
        assert_eq!(deepest, MAX_SPATIAL_DEPTH, "the tree is not split to the deepest level");
        let points = test_points(&t, &mut state, DEEP);
        let wrong = points
            .iter()
            .filter(|&&p| t.leaf_of_quantized(t.quantized_point(p)) != t.leaf_of(p))
            .count();
        eprintln!("{wrong} of {} points in another leaf (depth up to {deepest})", points.len());
        assert_eq!(wrong, 0, "{wrong} of {} points in another leaf", points.len());
    }
}
