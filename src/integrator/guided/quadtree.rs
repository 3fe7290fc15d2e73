//! The directional part of the SD-tree: a quadtree over the unit square, which
//! the cylindrical equal-area map ([`sphere_to_square`]) spreads over the sphere
//! of directions, so a cell's area is its share of the 4π steradians.
//!
//! A node holds the energy of its four children (child `c` is the quadrant
//! `x ≥ ½` for bit 0, `y ≥ ½` for bit 1) and their indices (0: a leaf), 32
//! bytes in one flat array. While a tree records, the energies are the leaf
//! cells' sums; [`DTree::finish_recording`] turns them into density factors,
//! `4·share` of each child within its node, so the density of a point on the
//! square is the product of the factors along its path (no division, no sum per
//! level), and sampling descends by them.
//!
//! With the variance-aware target ([`Target::Variance`]) the recorded sums are
//! second moments, and a leaf cell's energy becomes the square root of its mean
//! second moment times its area.

use crate::math::{atan2_poly, prefetch, Vec2, Vec3, PI};

/// Deepest level a cell may reach (2⁻²⁰ of the square's side).
pub const MAX_DEPTH: u32 = 20;

/// Direction ↔ square: `x = (cos θ + 1)/2`, `y = φ/2π` about world `z`. Area
/// preserving: a region of area A on the square covers 4π·A steradians. The
/// azimuth comes from [`azimuth`], a polynomial within 2e-7 rad of `atan2`
/// (about f32 rounding of φ, `math::atan2_poly`): libm's `atan2f` was 4–8 % of a guided render.
#[inline]
pub fn sphere_to_square(d: Vec3) -> Vec2 {
    let x = ((d.z.clamp(-1.0, 1.0) + 1.0) * 0.5).min(ONE_BELOW);
    let y = (azimuth(d.x, d.y) * (0.5 / PI)).clamp(0.0, ONE_BELOW);
    Vec2::new(x, y)
}

/// The angle of `(x, y)` in [0, 2π) (0 for the origin and for non-finite
/// coordinates): [`atan2_poly`] taken into one turn.
#[inline]
pub fn azimuth(x: f32, y: f32) -> f32 {
    if (x == 0.0 && y == 0.0) || !(x.is_finite() && y.is_finite()) {
        return 0.0;
    }
    let a = atan2_poly(y, x);
    let a = if a < 0.0 { a + 2.0 * PI } else { a };
    if a >= 2.0 * PI {
        0.0
    } else {
        a
    }
}

/// The inverse of [`sphere_to_square`].
#[inline]
pub fn square_to_sphere(p: Vec2) -> Vec3 {
    let cos = 2.0 * p.x - 1.0;
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * p.y).sin_cos();
    Vec3::new(sin * c, sin * s, cos)
}

/// Nodes [`DTree::prefetch_top`] fetches: three full levels (1 + 4 + 16).
const PREFETCHED_NODES: usize = 21;

/// Largest f32 below 1.
const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// What a guide's density is learned to follow (Rath et al. 2020, "Variance-aware
/// path guiding").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Target {
    /// The incident radiance (Müller et al. 2017), or the flux photons bring.
    #[default]
    Radiance,
    /// √E[(f·|cos|·L̂_i)²]: the square root of the second moment of the vertex's
    /// estimate, BSDF included, over the leaf's vertices; a cell's value is its area
    /// times the root of its mean second moment.
    Variance,
}

/// Aligned to its size, so that a cache line holds two whole nodes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(align(32))]
struct Node {
    /// Recorded energies; after [`DTree::finish_recording`] the factors
    /// `4·e_c / Σe` (all 0 in a node without energy).
    energy: [f32; 4],
    child: [u32; 4],
}

/// A directional quadtree: energies (recorded, or learned from recordings) and
/// the density they define.
#[derive(Clone, Debug, PartialEq)]
pub struct DTree {
    nodes: Vec<Node>,
    /// Sum of the root's energies (0: nothing learned, the tree cannot sample).
    total: f32,
    /// Whether the recorded sums are second moments ([`DTree::deposit_moment`]); once
    /// the tree is finished, its leaf cells' energies are their roots.
    moments: bool,
}

impl Default for DTree {
    fn default() -> Self {
        DTree {
            nodes: vec![Node::default()],
            total: 0.0,
            moments: false,
        }
    }
}

impl DTree {
    /// A tree of `levels` full levels (4^levels leaves), energy 0.
    pub fn uniform(levels: u32) -> DTree {
        let mut t = DTree::default();
        fn grow(t: &mut DTree, node: usize, levels: u32) {
            if levels <= 1 {
                return;
            }
            for c in 0..4 {
                let i = t.nodes.len();
                t.nodes.push(Node::default());
                t.nodes[node].child[c] = i as u32;
                grow(t, i, levels - 1);
            }
        }
        grow(&mut t, 0, levels.clamp(1, MAX_DEPTH));
        t
    }

    /// Whether the tree holds energy to sample from.
    pub fn can_sample(&self) -> bool {
        self.total > 0.0 && self.total.is_finite()
    }

    pub fn total(&self) -> f32 {
        self.total
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Leaf cells (4 per node, minus the ones that are nodes themselves).
    pub fn leaf_count(&self) -> usize {
        3 * self.nodes.len() + 1
    }

    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
    }

    /// Depth of the deepest leaf cell (1: the root's four quadrants).
    pub fn depth(&self) -> u32 {
        fn d(t: &DTree, n: usize) -> u32 {
            1 + t.nodes[n]
                .child
                .iter()
                .filter(|c| **c != 0)
                .map(|c| d(t, *c as usize))
                .max()
                .unwrap_or(0)
        }
        d(self, 0)
    }

    /// The leaf cell holding point `p` of the square, as `node·4 + child`.
    #[inline]
    pub fn cell_of(&self, p: Vec2) -> u32 {
        let mut at = (0, p.x, p.y);
        loop {
            match self.descend(at) {
                Ok(cell) => return cell,
                Err(next) => at = next,
            }
        }
    }

    /// One step of [`DTree::cell_of`] from node `n` at the point (x, y) of its
    /// square: the cell when the child there is a leaf, else the child and the
    /// point in its square (a step at a time, so that a batch of descents can go
    /// in lockstep, [`super::SdTree::record_cells`]).
    #[inline(always)]
    pub fn descend(&self, (n, x, y): (usize, f32, f32)) -> Result<u32, (usize, f32, f32)> {
        let (bx, by) = (x >= 0.5, y >= 0.5);
        let c = bx as usize | ((by as usize) << 1);
        match self.nodes[n].child[c] {
            0 => Ok((n * 4 + c) as u32),
            next => Err((next as usize, 2.0 * x - bx as u32 as f32, 2.0 * y - by as u32 as f32)),
        }
    }

    /// Adds recorded energy to a leaf cell from [`DTree::cell_of`].
    #[inline]
    pub fn deposit(&mut self, cell: u32, energy: f32) {
        self.nodes[(cell / 4) as usize].energy[(cell % 4) as usize] += energy;
    }

    /// Adds a recorded second moment (the variance-aware target's record) to a leaf
    /// cell from [`DTree::cell_of`]; a tree records energies or second moments, not both.
    #[inline]
    pub fn deposit_moment(&mut self, cell: u32, moment: f32) {
        self.moments = true;
        self.deposit(cell, moment);
    }

    /// Makes the recorded leaf energies a distribution: second moments become
    /// √(sum × area) per leaf cell (the root of the cell's mean second moment, times
    /// its area, up to one factor for the tree); inner energies become the sums of
    /// their subtrees (in a fixed order), the total is set, and every node's energies
    /// become its density factors `4·e_c / Σe`.
    pub fn finish_recording(&mut self) {
        fn sum(t: &mut DTree, n: usize) -> f32 {
            let mut s = 0.0f32;
            for c in 0..4 {
                let ch = t.nodes[n].child[c];
                if ch != 0 {
                    t.nodes[n].energy[c] = sum(t, ch as usize);
                }
                s += t.nodes[n].energy[c];
            }
            s
        }
        fn roots(t: &mut DTree, n: usize, area: f32) {
            for c in 0..4 {
                match t.nodes[n].child[c] {
                    0 => t.nodes[n].energy[c] = (t.nodes[n].energy[c].max(0.0) * area).sqrt(),
                    ch => roots(t, ch as usize, area * 0.25),
                }
            }
        }
        if self.moments {
            roots(self, 0, 0.25);
        }
        let total = sum(self, 0);
        self.total = if total.is_finite() { total } else { 0.0 };
        for n in &mut self.nodes {
            let s: f32 = n.energy.iter().sum();
            let k = if s > 0.0 && s.is_finite() { 4.0 / s } else { 0.0 };
            for e in &mut n.energy {
                *e *= k;
            }
        }
        self.order_breadth_first();
    }

    /// Renumbers the nodes level by level (siblings stay side by side): the top levels
    /// every descent starts with then lie in the first cache lines, which
    /// [`DTree::prefetch_top`] fetches. Cells (`node·4 + child`) change with it, so a
    /// finished tree records nothing.
    fn order_breadth_first(&mut self) {
        let mut order = Vec::with_capacity(self.nodes.len());
        let mut renumbered = vec![0u32; self.nodes.len()];
        order.push(0usize);
        let mut i = 0;
        while i < order.len() {
            for &ch in &self.nodes[order[i]].child {
                if ch != 0 {
                    renumbered[ch as usize] = order.len() as u32;
                    order.push(ch as usize);
                }
            }
            i += 1;
        }
        self.nodes = order
            .iter()
            .map(|&old| {
                let mut n = self.nodes[old];
                for ch in &mut n.child {
                    *ch = renumbered[*ch as usize];
                }
                n
            })
            .collect();
    }

    /// Asks for the cache lines of the tree's top levels (the root, its children and
    /// grandchildren), where every descent starts: called where a vertex's tree becomes
    /// known, their loads overlap the work before its lookups (the trees of a scene
    /// together are larger than the caches nearest the core).
    #[inline]
    pub fn prefetch_top(&self) {
        for i in (0..self.nodes.len().min(PREFETCHED_NODES)).step_by(2) {
            prefetch(&self.nodes, i);
        }
    }

    /// Density on the unit square at `p` (integrates to 1 over it; 0 when the
    /// tree cannot sample).
    #[inline]
    pub fn pdf_square(&self, p: Vec2) -> f32 {
        if !self.can_sample() {
            return 0.0;
        }
        let (mut x, mut y) = (p.x, p.y);
        let mut n = 0usize;
        let mut pdf = 1.0f32;
        loop {
            let node = &self.nodes[n];
            let (bx, by) = (x >= 0.5, y >= 0.5);
            let c = bx as usize | ((by as usize) << 1);
            pdf *= node.energy[c];
            let next = node.child[c];
            if next == 0 {
                return pdf;
            }
            x = 2.0 * x - bx as u32 as f32;
            y = 2.0 * y - by as u32 as f32;
            n = next as usize;
        }
    }

    /// [`DTree::pdf_square`] and the area of the cell holding `p`.
    pub fn pdf_square_and_area(&self, p: Vec2) -> (f32, f32) {
        if !self.can_sample() {
            return (0.0, 1.0);
        }
        let (mut x, mut y) = (p.x, p.y);
        let (mut n, mut pdf, mut area) = (0usize, 1.0f32, 1.0f32);
        loop {
            let node = &self.nodes[n];
            let (bx, by) = (x >= 0.5, y >= 0.5);
            let c = bx as usize | ((by as usize) << 1);
            pdf *= node.energy[c];
            area *= 0.25;
            let next = node.child[c];
            if next == 0 {
                return (pdf, area);
            }
            x = 2.0 * x - bx as u32 as f32;
            y = 2.0 * y - by as u32 as f32;
            n = next as usize;
        }
    }

    /// The density on the square at `p` of the tree learned without one record there
    /// that deposited `deposit` (energy, or a second moment where the tree learned
    /// from those): a vertex's own record left out of the guide it is judged by.
    pub fn pdf_square_without(&self, p: Vec2, deposit: f32) -> f64 {
        let (pdf, area) = self.pdf_square_and_area(p);
        let (pdf, area, total) = (pdf as f64, area as f64, self.total as f64);
        let e = if deposit > 0.0 && deposit.is_finite() {
            deposit as f64
        } else {
            0.0
        };
        let cell = pdf * area * total;
        // what the record added to the cell's energy: with second moments the energy
        // is the root √(S·area), which is √((S − e)·area) without the record
        let added = if self.moments {
            cell - (cell * cell - e * area).max(0.0).sqrt()
        } else {
            e
        };
        if total - added > 0.0 {
            (cell - added).max(0.0) / ((total - added) * area)
        } else {
            0.0
        }
    }

    /// Solid-angle density of direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        self.pdf_square(sphere_to_square(d)) * (0.25 / PI)
    }

    /// A point of the square drawn from the tree's density by `u`, with that
    /// density (`None` when the tree cannot sample).
    pub fn sample_square(&self, u: Vec2) -> Option<(Vec2, f32)> {
        if !self.can_sample() {
            return None;
        }
        let (mut ux, mut uy) = (u.x, u.y);
        let (mut origin, mut size) = (Vec2::ZERO, 1.0f32);
        let mut n = 0usize;
        let mut pdf = 1.0f32;
        loop {
            let node = &self.nodes[n];
            let f = node.energy;
            if f[0] + f[1] + f[2] + f[3] <= 0.0 {
                return None;
            }
            // left or right half by the columns' factors, then bottom or top within it
            // the children's lines load while the divisions below choose one (siblings
            // are side by side: up to 4 nodes from the first, on 2 or 3 lines)
            let first = node.child.iter().fold(u32::MAX, |m, &c| if c != 0 { m.min(c) } else { m }) as usize;
            for k in [0, 1, 3] {
                prefetch(&self.nodes, first.wrapping_add(k));
            }
            let p_left = (f[0] + f[2]) * 0.25;
            let bx = pick(&mut ux, p_left);
            let (lo, hi) = if bx { (f[1], f[3]) } else { (f[0], f[2]) };
            let by = pick(&mut uy, lo / (lo + hi));
            let c = bx as usize | ((by as usize) << 1);
            if f[c] <= 0.0 {
                return None; // only by rounding at a share's edge
            }
            pdf *= f[c];
            size *= 0.5;
            origin += Vec2::new(bx as u32 as f32, by as u32 as f32) * size;
            if node.child[c] == 0 {
                // inside the cell also after rounding (its density is the one returned)
                let below = |x: f32| f32::from_bits(x.to_bits() - 1);
                let p = origin + Vec2::new(ux, uy) * size;
                let p = Vec2::new(p.x.min(below(origin.x + size)), p.y.min(below(origin.y + size)));
                return Some((p, pdf));
            }
            n = node.child[c] as usize;
        }
    }

    /// A direction drawn from the tree, with its solid-angle density.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let (p, pdf) = self.sample_square(u)?;
        Some((square_to_sphere(p), pdf * (0.25 / PI)))
    }

    /// The structure the next iteration records into, energies 0: a cell is split
    /// while its share of this tree's energy exceeds `rho` (a leaf's energy spread
    /// evenly over its quadrants), and subtrees whose share is at most `rho` are
    /// merged into one cell. A tree without energy keeps its structure.
    pub fn refined(&self, rho: f32) -> DTree {
        let mut out = DTree::default();
        if !self.can_sample() {
            out.nodes = self.nodes.clone();
            for n in &mut out.nodes {
                n.energy = [0.0; 4];
            }
            return out;
        }
        // (node in out, node in self or None, the share of its cell, depth)
        let mut stack = vec![(0usize, Some(0usize), 1.0f32, 1u32)];
        while let Some((dst, src, share, depth)) = stack.pop() {
            for c in 0..4 {
                let (child_share, child_src) = match src {
                    Some(s) => {
                        let ch = self.nodes[s].child[c];
                        (share * 0.25 * self.nodes[s].energy[c], (ch != 0).then_some(ch as usize))
                    }
                    None => (share * 0.25, None),
                };
                if depth < MAX_DEPTH && child_share > rho {
                    let i = out.nodes.len();
                    out.nodes.push(Node::default());
                    out.nodes[dst].child[c] = i as u32;
                    stack.push((i, child_src, child_share, depth + 1));
                }
            }
        }
        out
    }

    /// [`DTree::refined`] of an even distribution: the first structure.
    pub fn initial(rho: f32) -> DTree {
        let mut t = DTree::uniform(1);
        t.nodes[0].energy = [1.0; 4];
        t.finish_recording();
        t.refined(rho)
    }
}

/// Chooses the lower part (false) with probability `p` and rescales `u` to [0, 1).
/// Both rescalings are computed and one is selected, without a branch: the choice is a
/// coin flip at every level of a descent, which a branch mispredicts about half the time
/// (caustic_cbox at 64 spp, callgrind's branch simulation: 11 million of guided's 233
/// million mispredictions were here).
#[inline]
fn pick(u: &mut f32, p: f32) -> bool {
    let lower = *u < p;
    let lower_u = (*u / p).min(ONE_BELOW);
    let upper_u = ((*u - p) / (1.0 - p)).clamp(0.0, ONE_BELOW);
    *u = std::hint::select_unpredictable(lower, lower_u, upper_u);
    !lower
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_round_trips() {
        for i in 0..50 {
            for j in 0..50 {
                let p = Vec2::new((i as f32 + 0.5) / 50.0, (j as f32 + 0.5) / 50.0);
                let q = sphere_to_square(square_to_sphere(p));
                assert!((p - q).abs().max_element() < 1e-5, "{p} {q}");
            }
        }
    }

    #[test]
    fn refinement_splits_by_share() {
        let t = DTree::initial(0.01);
        // 1/4^3 = 0.0156 > 0.01 is split once more, 1/4^4 is not: 4 full levels
        assert_eq!(t.depth(), 4);
        assert_eq!(t.leaf_count(), 256);
        let mut t = t;
        let cell = t.cell_of(Vec2::new(0.01, 0.01));
        t.deposit(cell, 1.0);
        t.finish_recording();
        let r = t.refined(0.01);
        // all energy in one level-4 cell: the chain down to it (4 nodes), then the cell's
        // energy spread evenly, shares 1, 1/4, 1/16, 1/64 split (1 + 4 + 16 + 64 nodes)
        assert_eq!(r.depth(), 8);
        assert_eq!(r.node_count(), 4 + 1 + 4 + 16 + 64);
    }
}
