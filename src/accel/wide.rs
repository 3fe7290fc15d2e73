//! The renderer's acceleration structure: an 8-wide BVH collapsed from the binned
//! SAH tree of [`super::build`], with triangles stored eight to a SIMD block.
//!
//! * **Collapse**: which binary subtrees become the children of each wide node
//!   is chosen by SAH cost, not greedily: the builder fills, bottom-up, each
//!   node's least cost as at most 1…8 children (`build::share_slots`, the
//!   dynamic programme of Ylitie et al. 2017), and the collapse follows the
//!   cheapest choice. Nodes come out fuller (6.0 children on average for the
//!   bunny, against 3.7 when the largest child was opened first) and rays visit
//!   5–8 % fewer of them. A node's inner children get consecutive indices. The
//!   root's subtrees are collapsed in parallel and moved to exactly the indices
//!   the sequential collapse gives, so the tree is the same for any number of
//!   threads (and so are hit ties, which go by child index).
//! * **Nodes** ([`WideNode`], 224 bytes) hold the boxes of up to eight children as
//!   six rows of eight floats (`lo x, hi x, lo y, hi y, lo z, hi z`), so one ray
//!   tests all eight with a handful of 8-wide operations: per ray the near and far
//!   planes of each axis are picked once by the sign of the direction. The slab
//!   test is the scalar [`crate::geometry::Aabb::intersect`] lane by lane
//!   (`(plane − o)·(1/d)`, far distances widened by 2γ(3)), on padded boxes, so
//!   it is exactly as conservative.
//! * **Triangles** ([`TriBlock`]) are stored as structure-of-arrays blocks of
//!   eight (vertex, axis, lane) with their primitive indices; short blocks repeat
//!   their last triangle. A leaf is one block: on AVX2 an 8-lane test costs what a
//!   4-lane one does, and the builder's cost model knows it, so leaves fill up
//!   (7.3 triangles on average for the bunny) and a ray tests about a third fewer
//!   blocks than with 4-lane blocks. The block test is the watertight kernel
//!   [`crate::geometry::triangle::intersect_watertight`] evaluated on eight lanes
//!   with the same operations in the same order (no FMA contraction), so its
//!   hits, distances and barycentrics are bit-identical to the scalar kernel;
//!   lanes with an edge function exactly zero go through the scalar kernel (which
//!   decides them in f64).
//! * **Traversal** is front to back: children hit are visited nearest first and
//!   stack entries farther than the current closest hit are skipped; any-hit
//!   queries stop at the first hit and do not sort. Children pushed for later
//!   are prefetched (their latency overlaps the nearer child's work when the
//!   tree outgrows the cache), and the fixed-size stacks are not zeroed per ray.
//! * **Instruction sets** ([`Isa`]): AVX-512 (F+VL: the node test's hit mask
//!   straight from a mask compare), AVX2+FMA, or portable Rust (scalar kernel per
//!   lane), picked at run time with `is_x86_feature_detected!`; the portable one
//!   runs everywhere and can be forced with [`WideBvh::set_isa`] (the tests run
//!   every variant the machine has).
//!
//! Spheres (and any primitive that is not a triangle) sit in separate leaves of
//! primitive indices tested with their own kernel.

use super::build::{self, PrimRef, TmpKind, TmpNode};
use crate::geometry::triangle::intersect_watertight;
use crate::geometry::{Aabb, Ray};
use crate::math::{gamma, Vec3};
use crate::scene::{Hit, Prim};
use std::mem::MaybeUninit;

pub const WIDTH: usize = 8;
/// Triangles per SIMD block.
pub const LANES: usize = 8;
/// Child reference: a leaf (else the index of a node).
const LEAF: u32 = 1 << 31;
/// Leaf of non-triangle primitives (indices in `generic`), else of triangle blocks.
const GENERIC: u32 = 1 << 30;
/// An unused child slot (its box is empty, so no ray reaches it).
const EMPTY: u32 = u32::MAX;
const INDEX_BITS: u32 = 26;
/// Stack sizes: the small one serves every tree whose worst path needs it.
const STACK_SMALL: usize = 128;
const STACK_LARGE: usize = 1024;

/// Far distances are widened by this, as in the scalar slab test.
const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct WideNode {
    /// `lo x, hi x, lo y, hi y, lo z, hi z` of each child (padded boxes).
    pub planes: [[f32; WIDTH]; 6],
    pub child: [u32; WIDTH],
}

impl WideNode {
    const EMPTY: WideNode = WideNode {
        planes: [
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [EMPTY; WIDTH],
    };

    /// Box of child `i` (empty for an unused slot).
    pub fn child_bounds(&self, i: usize) -> Aabb {
        let p = &self.planes;
        Aabb::new(Vec3::new(p[0][i], p[2][i], p[4][i]), Vec3::new(p[1][i], p[3][i], p[5][i]))
    }
}

/// Four triangles, structure of arrays: `v[vertex][axis][lane]`.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct TriBlock {
    pub v: [[[f32; LANES]; 3]; 3],
    /// Primitive index of each lane (a short block repeats its last triangle).
    pub prim: [u32; LANES],
}

impl TriBlock {
    pub fn triangle(&self, lane: usize) -> [Vec3; 3] {
        [0, 1, 2].map(|k| Vec3::new(self.v[k][0][lane], self.v[k][1][lane], self.v[k][2][lane]))
    }
}

/// Instruction set of the traversal kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    Portable,
    Avx2,
    Avx512,
}

impl Isa {
    /// The best the CPU has.
    pub fn detect() -> Isa {
        [Isa::Avx512, Isa::Avx2]
            .into_iter()
            .find(|i| i.available())
            .unwrap_or(Isa::Portable)
    }

    pub fn available(self) -> bool {
        match self {
            Isa::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => Isa::Avx2.available() && is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512vl"),
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// Every variant this CPU can run.
    pub fn all_available() -> Vec<Isa> {
        [Isa::Portable, Isa::Avx2, Isa::Avx512]
            .into_iter()
            .filter(|i| i.available())
            .collect()
    }

    pub fn name(self) -> &'static str {
        match self {
            Isa::Portable => "portable",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }
}

#[derive(Clone, Debug)]
pub struct WideBvh {
    /// Node 0 is the root (no nodes: nothing to hit).
    pub nodes: Vec<WideNode>,
    pub blocks: Vec<TriBlock>,
    /// Primitive indices of the generic leaves.
    pub generic: Vec<u32>,
    /// Bounds of everything (unpadded).
    root_bounds: Aabb,
    /// Primitives in the tree.
    pub prim_count: usize,
    isa: Isa,
    /// Deepest traversal stack any ray can need.
    stack_need: usize,
    /// Use the large stack even where the small one would do (tests).
    large_stack: bool,
}

impl Default for WideBvh {
    fn default() -> Self {
        WideBvh {
            nodes: Vec::new(),
            blocks: Vec::new(),
            generic: Vec::new(),
            root_bounds: Aabb::EMPTY,
            prim_count: 0,
            isa: Isa::detect(),
            stack_need: 1,
            large_stack: false,
        }
    }
}

/// One candidate child while a wide node is formed.
enum Cand<'a> {
    Node(&'a TmpNode),
    /// Primitive indices (all triangles, or all not).
    Leaf(Aabb, std::borrow::Cow<'a, [u32]>),
    /// A leaf mixing triangles and other primitives: becomes a node of two leaves.
    Mixed(Aabb, Vec<u32>, Vec<u32>),
}

impl Cand<'_> {
    fn bounds(&self) -> Aabb {
        match self {
            Cand::Node(n) => n.bounds,
            Cand::Leaf(b, _) | Cand::Mixed(b, _, _) => *b,
        }
    }
}

struct Collapser<'a> {
    prims: &'a [Prim],
    /// Position in the builder's reference order → primitive index.
    order: &'a [u32],
    out: WideBvh,
}

impl<'a> Collapser<'a> {
    fn is_tri(&self, i: u32) -> bool {
        matches!(self.prims[i as usize], Prim::Triangle { .. })
    }

    fn leaf_cand(&self, n: &'a TmpNode, start: u32, count: u32) -> Cand<'a> {
        let items = &self.order[start as usize..(start + count) as usize];
        let first = self.is_tri(items[0]);
        if items.iter().all(|&i| self.is_tri(i) == first) {
            return Cand::Leaf(n.bounds, items.into());
        }
        let (tris, other): (Vec<u32>, Vec<u32>) = items.iter().partition(|&&i| self.is_tri(i));
        Cand::Mixed(n.bounds, tris, other)
    }

    /// The children of a wide node over `l` and `r` with `slots` slots: the
    /// roots the collapse's cost tables choose (`build::share_slots`).
    fn share(&self, l: &'a TmpNode, r: &'a TmpNode, slots: usize, out: &mut Vec<Cand<'a>>) {
        let (k, _) = build::share_slots(l, r, slots);
        self.roots(l, k, out);
        self.roots(r, slots - k, out);
    }

    /// The roots standing for `n` with at most `slots` slots.
    fn roots(&self, n: &'a TmpNode, slots: usize, out: &mut Vec<Cand<'a>>) {
        let TmpKind::Inner(c) = &n.kind else {
            out.push(self.cand(n));
            return;
        };
        let mut slots = slots;
        // fewer slots when they do as well
        while slots > 1 && n.cost[slots - 1] >= n.cost[slots - 2] {
            slots -= 1;
        }
        if slots == 1 {
            out.push(self.cand(n));
        } else {
            self.share(&c[0], &c[1], slots, out);
        }
    }

    fn cand(&self, n: &'a TmpNode) -> Cand<'a> {
        match n.kind {
            TmpKind::Leaf { start, count } => self.leaf_cand(n, start, count),
            TmpKind::Inner(_) => Cand::Node(n),
        }
    }

    fn bounds_of(&self, items: &[u32]) -> Aabb {
        items
            .iter()
            .map(|&i| crate::scene::build::prim_bounds(&self.prims[i as usize]))
            .fold(Aabb::EMPTY, Aabb::union)
    }

    /// Emits a leaf; returns its child reference.
    fn leaf(&mut self, items: &[u32]) -> u32 {
        debug_assert!(!items.is_empty() && items.len() <= 16);
        if self.is_tri(items[0]) {
            let first = self.out.blocks.len() as u32;
            for chunk in items.chunks(LANES) {
                let mut b = TriBlock {
                    v: [[[0.0; LANES]; 3]; 3],
                    prim: [0; LANES],
                };
                for lane in 0..LANES {
                    let i = chunk[lane.min(chunk.len() - 1)];
                    let Prim::Triangle { p, .. } = &self.prims[i as usize] else {
                        unreachable!("mixed leaf")
                    };
                    for (k, v) in p.iter().enumerate() {
                        for a in 0..3 {
                            b.v[k][a][lane] = v[a];
                        }
                    }
                    b.prim[lane] = i;
                }
                self.out.blocks.push(b);
            }
            let n = self.out.blocks.len() as u32 - first;
            assert!(first < 1 << INDEX_BITS, "too many triangles for the wide BVH");
            LEAF | (first << 4) | (n - 1)
        } else {
            let first = self.out.generic.len() as u32;
            self.out.generic.extend_from_slice(items);
            assert!(first < 1 << INDEX_BITS, "too many primitives for the wide BVH");
            LEAF | GENERIC | (first << 4) | (items.len() as u32 - 1)
        }
    }

    /// Emits the node at `index` (already pushed) for `cands`; returns the stack
    /// depth below it. Its inner children get consecutive indices, so siblings
    /// share cache lines and pages.
    fn node_at(&mut self, index: usize, cands: Vec<Cand<'a>>) -> usize {
        let mut node = WideNode::EMPTY;
        let mut deepest = 0;
        let k = cands.len();
        let inner = cands.iter().filter(|c| !matches!(c, Cand::Leaf(..))).count();
        let mut next = self.out.nodes.len();
        self.out.nodes.resize(next + inner, WideNode::EMPTY);
        for (slot, c) in cands.into_iter().enumerate() {
            let b = c.bounds().padded();
            let (lo, hi) = (b.min, b.max);
            for a in 0..3 {
                node.planes[2 * a][slot] = lo[a];
                node.planes[2 * a + 1][slot] = hi[a];
            }
            node.child[slot] = match c {
                Cand::Leaf(_, items) => self.leaf(&items),
                Cand::Mixed(_, tris, other) => {
                    let (tb, ob) = (self.bounds_of(&tris), self.bounds_of(&other));
                    let d = self.node_at(next, vec![Cand::Leaf(tb, tris.into()), Cand::Leaf(ob, other.into())]);
                    deepest = deepest.max(d);
                    next += 1;
                    next as u32 - 1
                }
                Cand::Node(n) => {
                    let d = self.open_at(next, n);
                    deepest = deepest.max(d);
                    next += 1;
                    next as u32 - 1
                }
            };
        }
        self.out.nodes[index] = node;
        deepest + k.saturating_sub(1)
    }

    /// [`Collapser::open_at`] on a new node; returns its index and stack depth.
    fn open(&mut self, n: &'a TmpNode) -> (u32, usize) {
        let index = self.out.nodes.len();
        self.out.nodes.push(WideNode::EMPTY);
        (index as u32, self.open_at(index, n))
    }

    /// The wide node at `index` from binary node `n`: its children are the
    /// subtrees the cost tables choose, mixed leaves split in two while there
    /// is room. Returns the stack depth below it.
    fn open_at(&mut self, index: usize, n: &'a TmpNode) -> usize {
        let cands = self.wide_children(n);
        self.node_at(index, cands)
    }

    /// The children of the wide node standing for binary node `n`.
    fn wide_children(&self, n: &'a TmpNode) -> Vec<Cand<'a>> {
        let mut cands: Vec<Cand<'a>> = Vec::with_capacity(WIDTH);
        match &n.kind {
            TmpKind::Inner(c) => self.share(&c[0], &c[1], WIDTH, &mut cands),
            TmpKind::Leaf { start, count } => cands.push(self.leaf_cand(n, *start, *count)),
        }
        while cands.len() < WIDTH {
            let Some(i) = cands.iter().position(|c| matches!(c, Cand::Mixed(..))) else {
                break;
            };
            let Cand::Mixed(_, tris, other) = cands.swap_remove(i) else {
                unreachable!()
            };
            let (tb, ob) = (self.bounds_of(&tris), self.bounds_of(&other));
            cands.push(Cand::Leaf(tb, tris.into()));
            cands.push(Cand::Leaf(ob, other.into()));
        }
        cands
    }
}

impl<'a> Collapser<'a> {
    /// [`Collapser::open`] for the root, its inner children collapsed in
    /// parallel and moved into place so that the result is exactly what the
    /// sequential collapse gives (the same nodes at the same indices, the same
    /// blocks), whatever the number of threads.
    fn open_parallel(&mut self, t: &'a TmpNode) -> (u32, usize) {
        use rayon::prelude::*;
        if !matches!(t.kind, TmpKind::Inner(_)) {
            return self.open(t);
        }
        let cands = self.wide_children(t);
        let (prims, order) = (self.prims, self.order);
        let parts: Vec<Option<(WideBvh, usize)>> = cands
            .par_iter()
            .map(|c| match c {
                Cand::Node(n) => {
                    let mut sub = Collapser {
                        prims,
                        order,
                        out: WideBvh::default(),
                    };
                    let count = ref_count(n);
                    sub.out.nodes.reserve(count / 4 + 1);
                    sub.out.blocks.reserve(count / 2 + 1);
                    let (_, need) = sub.open(n);
                    Some((sub.out, need))
                }
                _ => None,
            })
            .collect();
        let root = self.out.nodes.len();
        self.out.nodes.push(WideNode::EMPTY);
        // as in `node_at`: the inner children right after the root, in slot order
        let inner = cands.iter().filter(|c| !matches!(c, Cand::Leaf(..))).count();
        let mut next = self.out.nodes.len();
        self.out.nodes.resize(next + inner, WideNode::EMPTY);
        let mut node = WideNode::EMPTY;
        let mut deepest = 0;
        let k = cands.len();
        for (slot, (c, part)) in cands.into_iter().zip(parts).enumerate() {
            let b = c.bounds().padded();
            for a in 0..3 {
                node.planes[2 * a][slot] = b.min[a];
                node.planes[2 * a + 1][slot] = b.max[a];
            }
            node.child[slot] = match (c, part) {
                (_, Some((sub, need))) => {
                    deepest = deepest.max(need);
                    let at = next as u32;
                    next += 1;
                    // the subtree's root goes to its reserved slot, the rest after
                    // everything so far, as the sequential collapse would place them
                    let (base, b0, g0) = (
                        self.out.nodes.len() as u32,
                        self.out.blocks.len() as u32,
                        self.out.generic.len() as u32,
                    );
                    assert!(
                        (b0 as usize + sub.blocks.len()) < 1 << INDEX_BITS && (g0 as usize + sub.generic.len()) < 1 << INDEX_BITS,
                        "too many primitives for the wide BVH"
                    );
                    let moved = |r: u32| match r {
                        EMPTY => EMPTY,
                        0 => at,
                        r if r & LEAF == 0 => base + r - 1,
                        r if r & GENERIC != 0 => r + (g0 << 4),
                        r => r + (b0 << 4),
                    };
                    let mut placed = sub.nodes.iter().map(|n| WideNode {
                        planes: n.planes,
                        child: n.child.map(moved),
                    });
                    self.out.nodes[at as usize] = placed.next().expect("a subtree has its root");
                    self.out.nodes.extend(placed);
                    self.out.blocks.extend_from_slice(&sub.blocks);
                    self.out.generic.extend_from_slice(&sub.generic);
                    at
                }
                (Cand::Leaf(_, items), None) => self.leaf(&items),
                (Cand::Mixed(_, tris, other), None) => {
                    let (tb, ob) = (self.bounds_of(&tris), self.bounds_of(&other));
                    let at = next;
                    next += 1;
                    deepest = deepest.max(self.node_at(at, vec![Cand::Leaf(tb, tris.into()), Cand::Leaf(ob, other.into())]));
                    at as u32
                }
                (Cand::Node(_), None) => unreachable!("inner children are collapsed in parallel"),
            };
        }
        self.out.nodes[root] = node;
        (root as u32, deepest + k.saturating_sub(1))
    }
}

/// References below `n` (leaves cover contiguous ranges, in order).
fn ref_count(n: &TmpNode) -> usize {
    let (mut lo, mut hi) = (n, n);
    while let TmpKind::Inner(c) = &lo.kind {
        lo = &c[0];
    }
    while let TmpKind::Inner(c) = &hi.kind {
        hi = &c[1];
    }
    match (&lo.kind, &hi.kind) {
        (TmpKind::Leaf { start, .. }, TmpKind::Leaf { start: s, count }) => (s + count - start) as usize,
        _ => unreachable!("descended to leaves"),
    }
}

/// Calls a traversal for the tree's instruction set and stack size: the
/// portable body `$portable::<PORTABLE, S>` or the x86 entry points
/// `x86::$avx2::<S>` / `x86::$avx512::<S>`, with `S` the small stack where it
/// is enough.
macro_rules! dispatch {
    ($bvh:expr, $portable:ident, $avx2:ident, $avx512:ident, ($($arg:expr),*)) => {{
        let small = $bvh.stack_need <= STACK_SMALL && !$bvh.large_stack;
        match $bvh.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `isa` is only ever set to an instruction set the CPU has (`set_isa`, `Isa::detect`).
            Isa::Avx512 => unsafe {
                if small {
                    x86::$avx512::<STACK_SMALL>($($arg),*)
                } else {
                    x86::$avx512::<STACK_LARGE>($($arg),*)
                }
            },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            Isa::Avx2 => unsafe {
                if small {
                    x86::$avx2::<STACK_SMALL>($($arg),*)
                } else {
                    x86::$avx2::<STACK_LARGE>($($arg),*)
                }
            },
            _ => {
                if small {
                    $portable::<PORTABLE, STACK_SMALL>($($arg),*)
                } else {
                    $portable::<PORTABLE, STACK_LARGE>($($arg),*)
                }
            }
        }
    }};
}

impl WideBvh {
    /// Builds over `prims` (indices refer to this slice); primitives with
    /// unusable bounds (empty, NaN, infinite) are left out.
    pub fn build(prims: &[Prim]) -> WideBvh {
        let mut refs = build::make_refs_with(prims.len(), |i| {
            let p = &prims[i];
            (crate::scene::build::prim_bounds(p), matches!(p, Prim::Triangle { .. }))
        });
        let tree = build::build_tree(&mut refs);
        let order: Vec<u32> = refs.iter().map(PrimRef::index).collect();
        drop(refs);
        Self::from_tree(tree.as_ref(), &order, prims)
    }

    fn from_tree(tree: Option<&TmpNode>, order: &[u32], prims: &[Prim]) -> WideBvh {
        let mut c = Collapser {
            prims,
            order,
            out: WideBvh::default(),
        };
        if let Some(t) = tree {
            // generous reservations: pages never written cost nothing, regrowth copies
            let (_, need) = if order.len() >= 1 << 15 && rayon::current_num_threads() > 1 {
                c.open_parallel(t)
            } else {
                c.out.nodes.reserve(order.len() / 4 + 1);
                c.out.blocks.reserve(order.len() / 2 + 1);
                c.open(t)
            };
            c.out.stack_need = need + 1;
            c.out.root_bounds = t.bounds;
        }
        c.out.prim_count = order.len();
        c.out
    }

    /// Bounds of all primitives in the tree (empty for an empty tree).
    pub fn bounds(&self) -> Aabb {
        self.root_bounds
    }

    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// Forces an instruction set; `false` (and no change) if the CPU lacks it.
    pub fn set_isa(&mut self, isa: Isa) -> bool {
        if isa.available() {
            self.isa = isa;
        }
        self.isa == isa
    }

    /// Bytes of nodes, triangle blocks and generic leaves.
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<WideNode>() + self.blocks.len() * std::mem::size_of::<TriBlock>() + self.generic.len() * 4
    }

    /// Forces the traversal variants with the large stack (which deep trees
    /// use) so tests reach them on small trees too.
    #[doc(hidden)]
    pub fn set_large_stack(&mut self, on: bool) {
        self.large_stack = on;
    }

    /// Deepest stack a traversal can need.
    pub fn stack_need(&self) -> usize {
        self.stack_need
    }

    /// Closest hit in `[ray.t_min, ray.t_max]`; `prims` is the slice the tree was built over.
    pub fn intersect(&self, prims: &[Prim], ray: &Ray) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        dispatch!(self, closest, closest_avx2, closest_avx512, (self, prims, ray))
    }

    /// Whether anything lies on the ray within `[ray.t_min, ray.t_max]`.
    pub fn occluded(&self, prims: &[Prim], ray: &Ray) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        dispatch!(self, any, any_avx2, any_avx512, (self, prims, ray))
    }

    /// Visits the primitives of the leaves the ray's box tests admit, nearest
    /// child first, each primitive at most once per leaf. `visit` gets a
    /// primitive index and the current `t_max`, which it may shrink; returning
    /// `true` stops the traversal. Portable code (used by `--compat`).
    pub fn traverse(&self, ray: &Ray, mut visit: impl FnMut(u32, &mut f32) -> bool) {
        if self.nodes.is_empty() {
            return;
        }
        let r = RayData::new(ray);
        let mut t_max = ray.t_max;
        let mut stack: Vec<(u32, f32)> = Vec::with_capacity(64);
        let mut cur = 0u32;
        loop {
            if cur & LEAF == 0 {
                let node = &self.nodes[cur as usize];
                let (mut mask, d) = node_portable(node, &r, t_max);
                let base = stack.len();
                while mask != 0 {
                    let i = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    stack.push((node.child[i], d[i]));
                }
                stack[base..].sort_by(|a, b| b.1.total_cmp(&a.1));
            } else if cur != EMPTY {
                let (first, count) = (((cur & !(LEAF | GENERIC)) >> 4) as usize, (cur & 15) as usize + 1);
                if cur & GENERIC != 0 {
                    for &p in &self.generic[first..first + count] {
                        if visit(p, &mut t_max) {
                            return;
                        }
                    }
                } else {
                    for b in &self.blocks[first..first + count] {
                        for lane in 0..LANES {
                            if lane > 0 && b.prim[lane] == b.prim[lane - 1] {
                                continue;
                            }
                            if visit(b.prim[lane], &mut t_max) {
                                return;
                            }
                        }
                    }
                }
            }
            loop {
                let Some((c, d)) = stack.pop() else { return };
                if d <= t_max {
                    cur = c;
                    break;
                }
            }
        }
    }

    /// Every child reference: `(node, slot, child)` for checks and statistics.
    pub fn children(&self) -> impl Iterator<Item = (usize, usize, ChildRef)> + '_ {
        self.nodes.iter().enumerate().flat_map(|(i, n)| {
            n.child
                .iter()
                .enumerate()
                .filter(|(_, &c)| c != EMPTY)
                .map(move |(s, &c)| (i, s, decode(c)))
        })
    }

    /// Primitive indices of a leaf reference (padding lanes left out).
    pub fn leaf_prims(&self, c: ChildRef) -> Vec<u32> {
        match c {
            ChildRef::Node(_) => Vec::new(),
            ChildRef::Generic { first, count } => self.generic[first..first + count].to_vec(),
            ChildRef::Triangles { first, count } => {
                let mut v = Vec::new();
                for b in &self.blocks[first..first + count] {
                    for lane in 0..LANES {
                        if lane == 0 || b.prim[lane] != b.prim[lane - 1] {
                            v.push(b.prim[lane]);
                        }
                    }
                }
                v
            }
        }
    }
}

/// A decoded child reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChildRef {
    Node(usize),
    /// `count` triangle blocks from `first`.
    Triangles {
        first: usize,
        count: usize,
    },
    /// `count` primitive indices from `first` in `generic`.
    Generic {
        first: usize,
        count: usize,
    },
}

fn decode(c: u32) -> ChildRef {
    let (first, count) = (((c & !(LEAF | GENERIC)) >> 4) as usize, (c & 15) as usize + 1);
    if c & LEAF == 0 {
        ChildRef::Node(c as usize)
    } else if c & GENERIC != 0 {
        ChildRef::Generic { first, count }
    } else {
        ChildRef::Triangles { first, count }
    }
}

/// Everything the kernels need about a ray, computed once.
#[derive(Clone, Copy)]
struct RayData {
    o: Vec3,
    d: Vec3,
    t_min: f32,
    inv: [f32; 3],
    /// Rows of the near and far planes per axis.
    near: [usize; 3],
    far: [usize; 3],
    /// Watertight kernel: axis permutation, permuted origin, shear.
    k: [usize; 3],
    op: [f32; 3],
    s: [f32; 3],
    dz_abs: f32,
    /// `false` when the direction is zero: no triangle can be hit.
    tri_ok: bool,
}

impl RayData {
    #[inline(always)]
    fn new(ray: &Ray) -> RayData {
        let inv = crate::geometry::aabb::safe_inverse(ray.d);
        let inv = [inv.x, inv.y, inv.z];
        let near = [0, 1, 2].map(|a| 2 * a + (inv[a] < 0.0) as usize);
        let far = [0, 1, 2].map(|a| 2 * a + (inv[a] >= 0.0) as usize);
        // the watertight kernel's permutation and shear, exactly as it computes them
        let d = ray.d;
        let (kx, ky, kz) = crate::geometry::triangle::watertight_axes(d);
        let dz = d[kz];
        RayData {
            o: ray.o,
            d: ray.d,
            t_min: ray.t_min,
            inv,
            near,
            far,
            k: [kx, ky, kz],
            op: [ray.o[kx], ray.o[ky], ray.o[kz]],
            s: [-d[kx] / dz, -d[ky] / dz, 1.0 / dz],
            dz_abs: dz.abs(),
            tri_ok: dz != 0.0,
        }
    }
}

/// Portable node test: hit mask and entry distances.
#[inline(always)]
fn node_portable(n: &WideNode, r: &RayData, t_max: f32) -> (u32, [f32; WIDTH]) {
    let mut mask = 0;
    let mut t0 = [0.0f32; WIDTH];
    for (i, t0) in t0.iter_mut().enumerate() {
        let near = |a: usize| (n.planes[r.near[a]][i] - r.o[a]) * r.inv[a];
        let far = |a: usize| (n.planes[r.far[a]][i] - r.o[a]) * r.inv[a];
        let t_in = near(0).max(near(1)).max(near(2)).max(r.t_min);
        let t_out = (far(0).min(far(1)).min(far(2)) * FAR_SCALE).min(t_max);
        *t0 = t_in;
        mask |= ((t_in <= t_out) as u32) << i;
    }
    (mask, t0)
}

/// Hits of one block: lane mask, distances and barycentrics per lane.
#[derive(Clone, Copy)]
struct BlockHits {
    mask: u32,
    t: [f32; LANES],
    b: [[f32; LANES]; 3],
}

/// Portable block test: the scalar kernel on each lane.
#[inline(always)]
fn block_portable(blk: &TriBlock, r: &RayData, t_max: f32) -> BlockHits {
    let mut h = BlockHits {
        mask: 0,
        t: [0.0; LANES],
        b: [[0.0; LANES]; 3],
    };
    for lane in 0..LANES {
        if let Some(x) = intersect_watertight(r.o, r.d, r.t_min, t_max, &blk.triangle(lane)) {
            h.mask |= 1 << lane;
            h.t[lane] = x.t;
            for k in 0..3 {
                h.b[k][lane] = x.b[k];
            }
        }
    }
    h
}

const PORTABLE: u8 = 0;
#[cfg(target_arch = "x86_64")]
const AVX2: u8 = 1;
#[cfg(target_arch = "x86_64")]
const AVX512: u8 = 2;

#[inline(always)]
fn node_test<const ISA: u8>(n: &WideNode, r: &RayData, t_max: f32) -> (u32, [f32; WIDTH]) {
    match ISA {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: ISA ≠ PORTABLE is only instantiated inside the `x86` entry points,
        // which carry (and are only called with) the matching target features.
        AVX512 => unsafe { x86::node_avx512(n, r, t_max) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        AVX2 => unsafe { x86::node_avx2(n, r, t_max) },
        _ => node_portable(n, r, t_max),
    }
}

#[inline(always)]
fn block_test<const ISA: u8>(b: &TriBlock, r: &RayData, t_max: f32) -> BlockHits {
    match ISA {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as in `node_test`: both instruction sets include AVX2.
        AVX2 | AVX512 => unsafe { x86::block_avx(b, r, t_max) },
        _ => block_portable(b, r, t_max),
    }
}

#[inline(always)]
fn leaf_range(c: u32) -> (usize, usize) {
    (((c & !(LEAF | GENERIC)) >> 4) as usize, (c & 15) as usize + 1)
}

/// Starts loading a child that will be visited later (if no nearer hit culls
/// it), so its memory latency overlaps the work on the nearer ones.
#[inline(always)]
fn prefetch(bvh: &WideBvh, c: u32) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let (p, bytes) = if c & LEAF == 0 {
            (
                bvh.nodes.as_ptr().wrapping_add(c as usize).cast::<i8>(),
                std::mem::size_of::<WideNode>(),
            )
        } else if c & GENERIC == 0 {
            (
                bvh.blocks.as_ptr().wrapping_add(leaf_range(c).0).cast::<i8>(),
                std::mem::size_of::<TriBlock>(),
            )
        } else {
            return;
        };
        for off in (0..bytes).step_by(64) {
            // SAFETY: a prefetch is a hint that never faults, whatever the address;
            // SSE is part of x86_64.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(off)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (bvh, c);
}

#[inline(always)]
fn key(d: f32, child: u32) -> u64 {
    ((d.to_bits() as u64) << 32) | child as u64
}

/// Closest hit; the generic body of every instruction set's entry point.
#[inline(always)]
fn closest<const ISA: u8, const S: usize>(bvh: &WideBvh, prims: &[Prim], ray: &Ray) -> Option<Hit> {
    let r = RayData::new(ray);
    let mut t_max = ray.t_max;
    let mut best: Option<Hit> = None;
    // stack entries: entry distance's bits above, child reference below (for
    // distances ≥ 0 the integer order is the distance order)
    // not zeroed for every ray; entries `..sp` are initialised
    let mut st = [MaybeUninit::<u64>::uninit(); S];
    let mut sp = 0usize;
    let mut cur = 0u32;
    loop {
        if cur & LEAF == 0 {
            let node = &bvh.nodes[cur as usize];
            let (mask, d) = node_test::<ISA>(node, &r, t_max);
            if mask != 0 {
                let a = mask.trailing_zeros() as usize;
                let rest = mask & (mask - 1);
                if rest == 0 {
                    cur = node.child[a];
                    continue;
                }
                let b = rest.trailing_zeros() as usize;
                if rest & (rest - 1) == 0 {
                    let (near, far) = if d[a] <= d[b] { (a, b) } else { (b, a) };
                    prefetch(bvh, node.child[far]);
                    st[sp].write(key(d[far], node.child[far]));
                    sp += 1;
                    cur = node.child[near];
                    continue;
                }
                // three or more: push all, sort farthest first, continue with the nearest
                let base = sp;
                let mut m = mask;
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    m &= m - 1;
                    prefetch(bvh, node.child[i]);
                    let k = key(d[i], node.child[i]);
                    st[sp].write(k); // the bounds check: overflow panics here
                    let mut j = sp;
                    // SAFETY: base ≤ j − 1 < sp: written entries
                    while j > base && unsafe { st[j - 1].assume_init() } < k {
                        st[j] = st[j - 1];
                        j -= 1;
                    }
                    st[j].write(k);
                    sp += 1;
                }
                sp -= 1;
                // SAFETY: at least three entries were just written
                cur = unsafe { st[sp].assume_init() } as u32;
                continue;
            }
        } else {
            let (first, count) = leaf_range(cur);
            if cur & GENERIC != 0 {
                for &p in &bvh.generic[first..first + count] {
                    if let Prim::Sphere { sphere, .. } = &prims[p as usize] {
                        if let Some(t) = sphere.intersect(ray.o, ray.d, ray.t_min, t_max) {
                            t_max = t;
                            best = Some(Hit { t, prim: p, b: [0.0; 3] });
                        }
                    }
                }
            } else if r.tri_ok {
                for blk in &bvh.blocks[first..first + count] {
                    let h = block_test::<ISA>(blk, &r, t_max);
                    if h.mask != 0 {
                        let mut lane = h.mask.trailing_zeros() as usize;
                        let mut m = h.mask & (h.mask - 1);
                        while m != 0 {
                            let l = m.trailing_zeros() as usize;
                            m &= m - 1;
                            if h.t[l] < h.t[lane] {
                                lane = l;
                            }
                        }
                        t_max = h.t[lane];
                        best = Some(Hit {
                            t: t_max,
                            prim: blk.prim[lane],
                            b: [h.b[0][lane], h.b[1][lane], h.b[2][lane]],
                        });
                    }
                }
            }
        }
        loop {
            if sp == 0 {
                return best;
            }
            sp -= 1;
            // SAFETY: entries below the old `sp` were written above.
            let e = unsafe { st[sp].assume_init() };
            if f32::from_bits((e >> 32) as u32) <= t_max {
                cur = e as u32;
                break;
            }
        }
    }
}

/// Any hit; the generic body of every instruction set's entry point.
#[inline(always)]
fn any<const ISA: u8, const S: usize>(bvh: &WideBvh, prims: &[Prim], ray: &Ray) -> bool {
    let r = RayData::new(ray);
    let t_max = ray.t_max;
    // not zeroed for every ray; entries `..sp` are initialised
    let mut st = [MaybeUninit::<u32>::uninit(); S];
    let mut sp = 0usize;
    let mut cur = 0u32;
    loop {
        if cur & LEAF == 0 {
            let node = &bvh.nodes[cur as usize];
            let (mask, _) = node_test::<ISA>(node, &r, t_max);
            if mask != 0 {
                let mut m = mask & (mask - 1);
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    m &= m - 1;
                    prefetch(bvh, node.child[i]);
                    st[sp].write(node.child[i]);
                    sp += 1;
                }
                cur = node.child[mask.trailing_zeros() as usize];
                continue;
            }
        } else {
            let (first, count) = leaf_range(cur);
            if cur & GENERIC != 0 {
                for &p in &bvh.generic[first..first + count] {
                    if let Prim::Sphere { sphere, .. } = &prims[p as usize] {
                        if sphere.intersect(ray.o, ray.d, ray.t_min, t_max).is_some() {
                            return true;
                        }
                    }
                }
            } else if r.tri_ok {
                for blk in &bvh.blocks[first..first + count] {
                    if block_test::<ISA>(blk, &r, t_max).mask != 0 {
                        return true;
                    }
                }
            }
        }
        if sp == 0 {
            return false;
        }
        sp -= 1;
        // SAFETY: entries below the old `sp` were written just above.
        cur = unsafe { st[sp].assume_init() };
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    #[target_feature(enable = "avx2,fma")]
    pub(super) fn closest_avx2<const S: usize>(bvh: &WideBvh, prims: &[Prim], ray: &Ray) -> Option<Hit> {
        closest::<AVX2, S>(bvh, prims, ray)
    }
    #[target_feature(enable = "avx2,fma")]
    pub(super) fn any_avx2<const S: usize>(bvh: &WideBvh, prims: &[Prim], ray: &Ray) -> bool {
        any::<AVX2, S>(bvh, prims, ray)
    }
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
    pub(super) fn closest_avx512<const S: usize>(bvh: &WideBvh, prims: &[Prim], ray: &Ray) -> Option<Hit> {
        closest::<AVX512, S>(bvh, prims, ray)
    }
    #[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
    pub(super) fn any_avx512<const S: usize>(bvh: &WideBvh, prims: &[Prim], ray: &Ray) -> bool {
        any::<AVX512, S>(bvh, prims, ray)
    }

    /// Row `row` of the node's planes.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn row(n: &WideNode, row: usize) -> __m256 {
        // SAFETY: `row` < 6 (RayData's near/far rows are 2·axis + 0 or 1) and
        // every row is 8 f32s, 32-byte aligned by WideNode's `repr(align(32))`.
        unsafe { _mm256_load_ps(n.planes.get_unchecked(row).as_ptr()) }
    }

    /// Entry and exit distances of the eight children.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    fn slabs(n: &WideNode, r: &RayData, t_max: f32) -> (__m256, __m256) {
        let o = [_mm256_set1_ps(r.o.x), _mm256_set1_ps(r.o.y), _mm256_set1_ps(r.o.z)];
        let inv = [_mm256_set1_ps(r.inv[0]), _mm256_set1_ps(r.inv[1]), _mm256_set1_ps(r.inv[2])];
        let near = |a: usize| _mm256_mul_ps(_mm256_sub_ps(row(n, r.near[a]), o[a]), inv[a]);
        let far = |a: usize| _mm256_mul_ps(_mm256_sub_ps(row(n, r.far[a]), o[a]), inv[a]);
        let t0 = _mm256_max_ps(_mm256_max_ps(near(0), near(1)), _mm256_max_ps(near(2), _mm256_set1_ps(r.t_min)));
        let t1 = _mm256_min_ps(_mm256_min_ps(far(0), far(1)), far(2));
        let t1 = _mm256_min_ps(_mm256_mul_ps(t1, _mm256_set1_ps(FAR_SCALE)), _mm256_set1_ps(t_max));
        (t0, t1)
    }

    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(super) fn node_avx2(n: &WideNode, r: &RayData, t_max: f32) -> (u32, [f32; WIDTH]) {
        let (t0, t1) = slabs(n, r, t_max);
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32;
        let mut d = [0.0f32; WIDTH];
        // SAFETY: `d` is 8 writable f32s; the store is unaligned.
        unsafe { _mm256_storeu_ps(d.as_mut_ptr(), t0) };
        (mask, d)
    }

    #[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
    #[inline]
    pub(super) fn node_avx512(n: &WideNode, r: &RayData, t_max: f32) -> (u32, [f32; WIDTH]) {
        let (t0, t1) = slabs(n, r, t_max);
        let mask = _mm256_cmp_ps_mask::<_CMP_LE_OQ>(t0, t1) as u32;
        let mut d = [0.0f32; WIDTH];
        // SAFETY: `d` is 8 writable f32s; the store is unaligned.
        unsafe { _mm256_storeu_ps(d.as_mut_ptr(), t0) };
        (mask, d)
    }

    /// The watertight kernel on eight triangles, operation for operation as the
    /// scalar [`intersect_watertight`] (AVX arithmetic rounds alike and nothing
    /// is fused), so every lane's result is bit-identical to it.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub(super) fn block_avx(blk: &TriBlock, r: &RayData, t_max: f32) -> BlockHits {
        let [kx, ky, kz] = r.k;
        let set = |x: f32| _mm256_set1_ps(x);
        let zero = _mm256_setzero_ps();
        let abs = |v: __m256| _mm256_andnot_ps(_mm256_set1_ps(-0.0), v);
        // SAFETY: each row is 8 f32s, 32-byte aligned (TriBlock is `repr(align(32))`
        // and every row is 32 bytes).
        let ld = |a: &[f32; LANES]| unsafe { _mm256_load_ps(a.as_ptr()) };
        // vertices relative to the origin, permuted, sheared
        let vert = |k: usize| {
            // SAFETY: k < 3 and kx, ky, kz < 3 (a permutation of the axes).
            let v = unsafe { blk.v.get_unchecked(k) };
            // SAFETY: as above.
            let (x, y, z) = unsafe { (v.get_unchecked(kx), v.get_unchecked(ky), v.get_unchecked(kz)) };
            let x = _mm256_sub_ps(ld(x), set(r.op[0]));
            let y = _mm256_sub_ps(ld(y), set(r.op[1]));
            let z = _mm256_sub_ps(ld(z), set(r.op[2]));
            let x = _mm256_add_ps(x, _mm256_mul_ps(set(r.s[0]), z));
            let y = _mm256_add_ps(y, _mm256_mul_ps(set(r.s[1]), z));
            (x, y, z)
        };
        let (p0x, p0y, p0z) = vert(0);
        let (p1x, p1y, p1z) = vert(1);
        let (p2x, p2y, p2z) = vert(2);
        let e0 = _mm256_sub_ps(_mm256_mul_ps(p1x, p2y), _mm256_mul_ps(p1y, p2x));
        let e1 = _mm256_sub_ps(_mm256_mul_ps(p2x, p0y), _mm256_mul_ps(p2y, p0x));
        let e2 = _mm256_sub_ps(_mm256_mul_ps(p0x, p1y), _mm256_mul_ps(p0y, p1x));
        let cmp_eq = |a, b| _mm256_cmp_ps::<_CMP_EQ_OQ>(a, b);
        let cmp_lt = |a, b| _mm256_cmp_ps::<_CMP_LT_OS>(a, b);
        let cmp_le = |a, b| _mm256_cmp_ps::<_CMP_LE_OS>(a, b);
        let cmp_gt = |a, b| _mm256_cmp_ps::<_CMP_GT_OS>(a, b);
        let cmp_ge = |a, b| _mm256_cmp_ps::<_CMP_GE_OS>(a, b);
        let or = |a, b| _mm256_or_ps(a, b);
        // lanes with an edge function exactly zero: the scalar kernel (f64) decides
        let on_edge = _mm256_movemask_ps(or(or(cmp_eq(e0, zero), cmp_eq(e1, zero)), cmp_eq(e2, zero))) as u32;
        let neg = or(or(cmp_lt(e0, zero), cmp_lt(e1, zero)), cmp_lt(e2, zero));
        let pos = or(or(cmp_gt(e0, zero), cmp_gt(e1, zero)), cmp_gt(e2, zero));
        let mut reject = _mm256_and_ps(neg, pos);
        let det = _mm256_add_ps(_mm256_add_ps(e0, e1), e2);
        // det == 0 or not finite (NaN: "not less than" is true when unordered)
        reject = or(reject, cmp_eq(det, zero));
        reject = or(reject, _mm256_cmp_ps::<_CMP_NLT_US>(abs(det), set(f32::INFINITY)));
        let sz = set(r.s[2]);
        let (p0z, p1z, p2z) = (_mm256_mul_ps(p0z, sz), _mm256_mul_ps(p1z, sz), _mm256_mul_ps(p2z, sz));
        let ts = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(e0, p0z), _mm256_mul_ps(e1, p1z)),
            _mm256_mul_ps(e2, p2z),
        );
        let tmd = _mm256_mul_ps(set(t_max), det);
        let det_neg = cmp_lt(det, zero);
        let det_pos = cmp_gt(det, zero);
        reject = or(reject, _mm256_and_ps(det_neg, or(cmp_ge(ts, zero), cmp_lt(ts, tmd))));
        reject = or(reject, _mm256_and_ps(det_pos, or(cmp_le(ts, zero), cmp_gt(ts, tmd))));
        let mut mask = !(_mm256_movemask_ps(reject) as u32) & 0xff & !on_edge;
        let mut h = BlockHits {
            mask: 0,
            t: [0.0; LANES],
            b: [[0.0; LANES]; 3],
        };
        if mask != 0 {
            let inv_det = _mm256_div_ps(set(1.0), det);
            let t = _mm256_mul_ps(ts, inv_det);
            let mut rej = or(cmp_lt(t, set(r.t_min)), cmp_gt(t, set(t_max)));
            // the conservative bound on t
            let max3 = |a, b, c| _mm256_max_ps(_mm256_max_ps(abs(a), abs(b)), abs(c));
            let max_zt = max3(p0z, p1z, p2z);
            let delta_z = _mm256_mul_ps(set(gamma(3)), max_zt);
            let max_xt = max3(p0x, p1x, p2x);
            let max_yt = max3(p0y, p1y, p2y);
            let max_z = _mm256_mul_ps(max_zt, set(r.dz_abs));
            let delta_x = _mm256_mul_ps(set(gamma(5)), _mm256_add_ps(max_xt, max_z));
            let delta_y = _mm256_mul_ps(set(gamma(5)), _mm256_add_ps(max_yt, max_z));
            let delta_e = _mm256_mul_ps(
                set(2.0),
                _mm256_add_ps(
                    _mm256_add_ps(
                        _mm256_mul_ps(_mm256_mul_ps(set(gamma(2)), max_xt), max_yt),
                        _mm256_mul_ps(delta_y, max_xt),
                    ),
                    _mm256_mul_ps(delta_x, max_yt),
                ),
            );
            let max_e = max3(e0, e1, e2);
            let sum = _mm256_add_ps(
                _mm256_add_ps(
                    _mm256_mul_ps(_mm256_mul_ps(set(gamma(3)), max_e), max_zt),
                    _mm256_mul_ps(delta_e, max_zt),
                ),
                _mm256_mul_ps(delta_z, max_e),
            );
            let delta_t = _mm256_mul_ps(_mm256_mul_ps(set(3.0), sum), abs(inv_det));
            rej = or(rej, cmp_le(t, delta_t));
            mask &= !(_mm256_movemask_ps(rej) as u32);
            if mask != 0 {
                h.mask = mask;
                let st = |dst: &mut [f32; LANES], v: __m256| {
                    // SAFETY: `dst` is 8 writable f32s; the store is unaligned.
                    unsafe { _mm256_storeu_ps(dst.as_mut_ptr(), v) }
                };
                st(&mut h.t, t);
                st(&mut h.b[0], _mm256_mul_ps(e0, inv_det));
                st(&mut h.b[1], _mm256_mul_ps(e1, inv_det));
                st(&mut h.b[2], _mm256_mul_ps(e2, inv_det));
            }
        }
        if on_edge != 0 {
            edge_lanes(blk, r, t_max, on_edge, &mut h);
        }
        h
    }

    /// Lanes with an exactly-zero edge function, through the scalar kernel.
    #[cold]
    #[inline(never)]
    fn edge_lanes(blk: &TriBlock, r: &RayData, t_max: f32, lanes: u32, h: &mut BlockHits) {
        for lane in 0..LANES {
            if lanes & (1 << lane) == 0 {
                continue;
            }
            if let Some(x) = intersect_watertight(r.o, r.d, r.t_min, t_max, &blk.triangle(lane)) {
                h.mask |= 1 << lane;
                h.t[lane] = x.t;
                for k in 0..3 {
                    h.b[k][lane] = x.b[k];
                }
            }
        }
    }
}
