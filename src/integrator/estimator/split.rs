//! Roulette and splitting in one step, for policies that learn where paths are worth
//! continuing ([`Policy::SPLITS`], `path`'s `rr: "ears"`): a vertex's expected number of
//! sub-paths q ([`Policy::split_factor`]) becomes n = ⌊q + u⌋ sub-paths, each with its
//! own BSDF sample from the vertex. Below 1 it is roulette: a survivor weighs 1/q. From
//! 1 on the n sub-paths are averaged, each weighing 1/n (n may then be capped, at
//! [`MAX_SPLIT`] and by the camera sample's budget: averaging stays unbiased for any
//! n ≥ 1 chosen before the sub-paths are drawn). The sub-paths beyond the first wait on
//! an explicit stack ([`Branches`]) and are traced, one after another, when the path
//! before them ends. Each sub-path is a node of a tree whose sums (the estimate's
//! terms, the rays traced) are what the policy learns from ([`Branches::records`]).

use super::*;

/// Most sub-paths a vertex splits into (the paper's cap).
pub const MAX_SPLIT: u32 = 8;

/// Most sub-paths one camera sample starts in all: splitting factors learned wrongly
/// cost at most this many paths' work.
const BUDGET: u32 = 64;

/// The cell of a node that belongs to no vertex (the camera's path).
pub(super) const NO_CELL: u32 = u32::MAX;

/// A sub-path of a camera sample: where it left from and what it found.
#[derive(Clone, Copy, Debug)]
struct Node {
    /// The statistics' cell of the vertex it left ([`NO_CELL`]: the camera's path).
    cell: u32,
    parent: u32,
    /// Turns the sub-path's estimate (mean over channels) into one unsplit
    /// continuation's estimate of the radiance its vertex reflects: q (or n) over
    /// the mean throughput arriving at the vertex.
    norm: f32,
    /// The estimate's terms the sub-path added itself, then (after
    /// [`Branches::records`]) with those of the sub-paths it split into.
    sum: f32,
    rays: u64,
}

/// The sub-paths of one camera sample: those waiting to be traced and the tree of
/// all of them. Kept per thread and reused ([`Branches::begin`] per sample).
#[derive(Default)]
pub struct Branches {
    /// Waiting sub-paths: the path, the segment number of its ray, its node.
    waiting: Vec<(PathState, u32, u32)>,
    nodes: Vec<Node>,
    current: u32,
    /// The current path's estimate and the ray count where its node's share began.
    l_mark: f32,
    rays_mark: u64,
    /// The estimates of the sub-paths that ended.
    total: Vec3,
    budget: u32,
}

#[inline]
fn mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z) * (1.0 / 3.0)
}

impl Branches {
    /// Starts a camera sample (the ray count so far `rays`).
    pub fn begin(&mut self, rays: u64) {
        self.waiting.clear();
        self.nodes.clear();
        self.nodes.push(Node {
            cell: NO_CELL,
            parent: 0,
            norm: 0.0,
            sum: 0.0,
            rays: 0,
        });
        (self.current, self.l_mark, self.rays_mark) = (0, 0.0, rays);
        self.total = Vec3::ZERO;
        self.budget = BUDGET;
    }

    /// Gives the current node what its path added since its mark (estimate `l`).
    fn settle(&mut self, l: Vec3, rays: u64) {
        let node = &mut self.nodes[self.current as usize];
        node.sum += mean(l) - self.l_mark;
        node.rays += rays - self.rays_mark;
        (self.l_mark, self.rays_mark) = (mean(l), rays);
    }

    /// A path of estimate `l` ended: the next waiting sub-path (its state and its
    /// ray's segment number), or `None` when all have ended ([`Branches::total`]).
    pub fn end_path(&mut self, l: Vec3, rays: u64) -> Option<(PathState, u32)> {
        self.settle(l, rays);
        self.total += l;
        let (path, segment, node) = self.waiting.pop()?;
        (self.current, self.l_mark) = (node, 0.0);
        Some((path, segment))
    }

    /// The camera sample's estimate: the sum of its sub-paths'.
    pub fn total(&self) -> Vec3 {
        self.total
    }

    /// Each sub-path that left a vertex, once the sample has ended: its vertex's cell,
    /// its estimate as one unsplit continuation's (see [`Node::norm`]) and the rays
    /// it and the sub-paths it split into traced.
    pub fn records(&mut self, mut record: impl FnMut(u32, f32, u64)) {
        // children come after their parents
        for i in (1..self.nodes.len()).rev() {
            let n = self.nodes[i];
            let parent = &mut self.nodes[n.parent as usize];
            parent.sum += n.sum;
            parent.rays += n.rays;
            if n.cell != NO_CELL && n.norm.is_finite() {
                record(n.cell, n.sum.max(0.0) * n.norm, n.rays);
            }
        }
    }
}

impl PathState {
    /// The roulette-and-splitting step of [`PathState::end`] for a [`Policy::SPLITS`]
    /// policy: this path becomes the first sub-path, the others wait in the policy's
    /// [`Branches`]. Returns whether the path goes on.
    pub(super) fn split<P: Policy>(
        &mut self,
        policy: &mut P,
        v: &Vertex<P::Plan>,
        segment: u32,
        sampler: &mut PixelSampler,
        counts: &RayCounts,
    ) -> bool {
        let (q, cell) = policy.split_factor(&v.it, self.beta, self.eta_scale, segment);
        let u = sampler.next_1d();
        let room = policy.branches().map_or(0, |b| b.budget);
        let n = if q < 1.0 {
            (u < q) as u32
        } else {
            ((q + u) as u32).clamp(1, MAX_SPLIT.min(room + 1))
        };
        if n == 0 {
            return false;
        }
        // a survivor of roulette weighs 1/q; split sub-paths are averaged
        let scale = if q < 1.0 { 1.0 / q } else { 1.0 / n as f32 };
        let (it, bsdf, beta) = (&v.it, &v.bsdf, self.beta);
        let norm = 1.0 / (scale * mean(beta));
        let parent = match policy.branches() {
            Some(b) => {
                b.settle(self.l, counts.rays);
                b.budget -= n - 1;
                b.current
            }
            None => 0,
        };
        let mut first = None;
        for k in 0..n {
            let (uc, u) = if k == 0 {
                (v.uc, v.u_bsdf)
            } else {
                (sampler.next_1d(), Vec2::from(sampler.next_2d()))
            };
            let Some(bs) = policy.sample(&v.plan, bsdf, it.wo, u, uc) else {
                continue;
            };
            let child_beta = beta * bs.weight * scale;
            if child_beta == Vec3::ZERO || !child_beta.is_finite() {
                continue;
            }
            policy.scattered(&v.plan, &bs, child_beta, self.l);
            let child = PathState {
                ray: spawn_ray(it, bs.wi),
                l: Vec3::ZERO,
                beta: child_beta,
                eta_scale: self.eta_scale * bs.eta * bs.eta,
                after_delta: bs.delta,
                bsdf_pdf: bs.pdf,
                prev_p: it.p,
                sky_coords: None,
            };
            let node = policy.branches().map_or(0, |b| {
                b.nodes.push(Node {
                    cell,
                    parent,
                    norm,
                    sum: 0.0,
                    rays: 0,
                });
                b.nodes.len() as u32 - 1
            });
            if first.is_none() {
                first = Some((child, node));
            } else if let Some(b) = policy.branches() {
                b.waiting.push((child, segment + 1, node));
            }
        }
        let Some((child, node)) = first else {
            return false;
        };
        *self = PathState { l: self.l, ..child };
        if let Some(b) = policy.branches() {
            b.current = node;
        }
        true
    }
}
