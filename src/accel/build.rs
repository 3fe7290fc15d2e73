//! Binned-SAH builder shared by the binary [`super::Bvh`] and the wide
//! [`super::wide::WideBvh`].
//!
//! * Primitive references are 32 bytes (`lo`, `hi` as SIMD `Vec4`s, the index in
//!   the spare lane), binned on all three axes in one pass over 32 bins (16 or 8 for small
//!   nodes, where the sweeps would dominate).
//! * The cost model counts *blocks* of [`BLOCK`] triangles, as the wide BVH's
//!   leaves store triangles eight to a SIMD block: a leaf of 1–8 triangles costs
//!   one block test (so nodes of up to eight triangles become leaves at once),
//!   while a sphere (or any other primitive) costs a test of its own, so their
//!   leaves stay small (each reference carries its kind; bins count the two
//!   kinds in the halves of a `u64`). Leaves stop at [`MAX_LEAF`] primitives; a
//!   node becomes a leaf when that is cheaper than its best split.
//! * Subtrees above `PAR_MIN` (2048) references are built with `rayon::join`, and the
//!   binning of nodes above `PAR_BIN_MIN` (65,536) is split across threads too.
//! * Below depth [`SAH_DEPTH_LIMIT`] splits are object medians, so depth stays
//!   bounded; coincident centroids are split in halves.

use crate::geometry::Aabb;
use crate::math::Vec4;

/// Leaves hold at most this many primitives.
pub const MAX_LEAF: usize = 8;
/// Primitives per SIMD block in the leaf-cost model.
pub const BLOCK: usize = 8;
const BINS: usize = 32;
/// Below this depth SAH decides; deeper, object-median splits.
pub const SAH_DEPTH_LIMIT: usize = 48;
/// Cost of one node visit relative to one block test.
const COST_TRAVERSE: f32 = 1.0;
const COST_BLOCK: f32 = 1.0;
/// Cost of testing one primitive that is not a triangle (a sphere), in block tests.
const COST_OTHER: f32 = 1.0;
const PAR_MIN: usize = 2048;
const PAR_BIN_MIN: usize = 1 << 16;

/// A primitive reference: its box, the index in `lo.w`'s bits (with [`INDEX_TAG`]
/// set), and in `hi.w` 0 for a triangle (tested eight to a block) or 1 for anything
/// else (tested on its own).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PrimRef {
    lo: Vec4,
    hi: Vec4,
}

/// Set in the bits of `lo.w` above the index, so that the lane holds a normal float
/// (between 2 and 2^64): the SIMD arithmetic on boxes and centroids computes the w lane
/// too, and with the bare index there (a subnormal for every index below 2^23) each such
/// operation took a microcode assist, which made the build twice as slow.
const INDEX_TAG: u32 = 0x4000_0000;
/// References index at most this many primitives (the tagged lane stays finite).
pub(crate) const MAX_REFS: usize = 1 << 29;

impl PrimRef {
    /// A reference to primitive `index` with box `b` (finite, non-empty), a triangle or not.
    #[inline]
    pub(crate) fn new(b: Aabb, index: u32, triangle: bool) -> PrimRef {
        PrimRef {
            lo: b.min.extend(f32::from_bits(index | INDEX_TAG)),
            hi: b.max.extend(if triangle { 0.0 } else { 1.0 }),
        }
    }
    #[inline]
    pub(crate) fn bounds(&self) -> Aabb {
        Aabb::new(self.lo.truncate(), self.hi.truncate())
    }
    #[inline]
    pub(crate) fn is_triangle(&self) -> bool {
        self.hi.w == 0.0
    }
    #[inline]
    pub(crate) fn index(&self) -> u32 {
        self.lo.w.to_bits() & !INDEX_TAG
    }
    /// This reference in a [`Count`]: triangles in the low half, others in the high.
    #[inline]
    fn unit(&self) -> u64 {
        1 + (self.hi.w != 0.0) as u64 * 0xFFFF_FFFF
    }
    #[inline]
    fn c2(&self) -> Vec4 {
        self.lo + self.hi
    }
}

/// Box as two `Vec4`s (the w lanes are ignored).
#[derive(Clone, Copy, Debug)]
struct B4 {
    lo: Vec4,
    hi: Vec4,
}

impl B4 {
    const EMPTY: B4 = B4 {
        lo: Vec4::splat(f32::INFINITY),
        hi: Vec4::splat(f32::NEG_INFINITY),
    };
    #[inline]
    fn grow_box(&mut self, lo: Vec4, hi: Vec4) {
        self.lo = self.lo.min(lo);
        self.hi = self.hi.max(hi);
    }
    #[inline]
    fn grow_point(&mut self, p: Vec4) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }
    #[inline]
    fn union(self, o: B4) -> B4 {
        B4 {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }
    #[inline]
    fn half_area(&self) -> f32 {
        let e = self.hi - self.lo;
        if e.x < 0.0 {
            return 0.0;
        }
        e.x * e.y + e.y * e.z + e.z * e.x
    }
    /// Half area of a non-empty box.
    #[inline]
    fn half_area_nonempty(&self) -> f32 {
        let e = self.hi - self.lo;
        e.x * e.y + e.y * e.z + e.z * e.x
    }
    fn aabb(&self) -> Aabb {
        Aabb::new(self.lo.truncate(), self.hi.truncate())
    }
}

/// A node of the temporary binary tree. Leaves index the reordered references.
pub(crate) struct TmpNode {
    /// Exact (unpadded) bounds of the primitives below.
    pub bounds: Aabb,
    pub kind: TmpKind,
    /// `cost[i]`: least SAH cost of this subtree as at most `i + 1` children of
    /// an 8-wide node (the wide collapse's dynamic programme, filled bottom-up).
    pub cost: [f32; WIDE],
}

/// Children of a wide node.
pub(crate) const WIDE: usize = 8;

/// Best way to share `j` (≥ 2) child slots between subtrees `l` and `r`: the
/// slots given to `l` and the cost.
#[inline]
pub(crate) fn share_slots(l: &TmpNode, r: &TmpNode, j: usize) -> (usize, f32) {
    let mut best = (1, f32::INFINITY);
    for k in 1..j {
        let c = l.cost[k - 1] + r.cost[j - k - 1];
        if c < best.1 {
            best = (k, c);
        }
    }
    best
}

pub(crate) enum TmpKind {
    Leaf { start: u32, count: u32 },
    Inner(Box<[TmpNode; 2]>),
}

/// Usable references (finite, non-empty boxes) of `bounds`, all counted as triangles.
pub(crate) fn make_refs(bounds: &[Aabb]) -> Vec<PrimRef> {
    make_refs_with(bounds.len(), |i| (bounds[i], true))
}

/// Usable references of the boxes `prim(0..n)` (box, whether a triangle),
/// computed in parallel.
pub(crate) fn make_refs_with(n: usize, prim: impl Fn(usize) -> (Aabb, bool) + Sync) -> Vec<PrimRef> {
    use rayon::prelude::*;
    assert!(n <= MAX_REFS, "too many primitives for the BVH builder ({n})");
    (0..n)
        .into_par_iter()
        .with_min_len(8192)
        .filter_map(|i| {
            let (b, triangle) = prim(i);
            (!b.is_empty() && b.min.is_finite() && b.max.is_finite()).then(|| PrimRef::new(b, i as u32, triangle))
        })
        .collect()
}

/// Builds over `refs` (reordered in place so leaves are contiguous ranges) with
/// leaves of at most `max_leaf` (≤ [`MAX_LEAF`]) primitives. `None` for no references.
pub(crate) fn build_tree(refs: &mut [PrimRef], max_leaf: usize) -> Option<TmpNode> {
    if refs.is_empty() {
        return None;
    }
    let (geom, cent) = bounds_of(refs);
    Some(build_rec(refs, 0, geom, cent, 0, max_leaf.clamp(1, MAX_LEAF)))
}

fn bounds_of(refs: &[PrimRef]) -> (B4, B4) {
    let seq = |rs: &[PrimRef]| {
        let (mut g, mut c) = (B4::EMPTY, B4::EMPTY);
        for r in rs {
            g.grow_box(r.lo, r.hi);
            c.grow_point(r.c2());
        }
        (g, c)
    };
    if refs.len() >= PAR_BIN_MIN {
        use rayon::prelude::*;
        refs.par_chunks(PAR_BIN_MIN / 2)
            .map(seq)
            .reduce(|| (B4::EMPTY, B4::EMPTY), |a, b| (a.0.union(b.0), a.1.union(b.1)))
    } else {
        seq(refs)
    }
}

/// Primitives of a node: triangles in the low 32 bits, others in the high.
type Count = u64;

/// Cost of testing a leaf of `n` primitives, in block tests: triangles eight
/// to a block, anything else one test each.
#[inline]
fn leaf_tests(n: Count) -> f32 {
    (n as u32).div_ceil(BLOCK as u32) as f32 + (n >> 32) as f32 * COST_OTHER
}

fn count(refs: &[PrimRef]) -> Count {
    refs.iter().map(PrimRef::unit).sum()
}

/// Per-axis bins: bounds and counts.
#[derive(Clone)]
struct Bins<const N: usize> {
    b: [[B4; N]; 3],
    n: [[Count; N]; 3],
}

impl<const N: usize> Bins<N> {
    fn new() -> Self {
        Bins {
            b: [[B4::EMPTY; N]; 3],
            n: [[0; N]; 3],
        }
    }
    #[inline(always)]
    fn add(&mut self, k: [usize; 3], r: &PrimRef) {
        let unit = r.unit();
        for (a, &k) in k.iter().enumerate() {
            self.b[a][k].grow_box(r.lo, r.hi);
            self.n[a][k] += unit;
        }
    }
    fn merge(mut self, o: &Self) -> Self {
        for a in 0..3 {
            for k in 0..N {
                self.b[a][k] = self.b[a][k].union(o.b[a][k]);
                self.n[a][k] += o.n[a][k];
            }
        }
        self
    }
}

/// Maps doubled centroids to bins.
#[derive(Clone, Copy)]
struct Binner {
    lo: Vec4,
    scale: Vec4,
    /// Bins in use: fewer for small nodes, where the sweeps would dominate.
    nb: usize,
}

impl Binner {
    fn new(cent: &B4, nb: usize) -> Binner {
        let ext = cent.hi - cent.lo;
        let s = |e: f32| if e > 0.0 { nb as f32 * 0.99999 / e } else { 0.0 };
        Binner {
            lo: cent.lo,
            scale: Vec4::new(s(ext.x), s(ext.y), s(ext.z), 0.0),
            nb,
        }
    }
    #[inline]
    fn bins(&self, r: &PrimRef) -> [usize; 3] {
        let f = ((r.c2() - self.lo) * self.scale)
            .max(Vec4::ZERO)
            .min(Vec4::splat((self.nb - 1) as f32));
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_cvttps_epi32, _mm_storeu_si128};
            let mut i = [0i32; 4];
            // SAFETY: SSE2 is part of x86_64; `i` is 16 writable bytes (unaligned store).
            // `f` is clamped to [0, nb − 1], so the truncation is exact and in range.
            unsafe { _mm_storeu_si128(i.as_mut_ptr().cast(), _mm_cvttps_epi32(f.into())) };
            [i[0] as usize, i[1] as usize, i[2] as usize]
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let i = f.as_ivec4();
            [i.x as usize, i.y as usize, i.z as usize]
        }
    }
    /// Bins `refs`; two sets of bins take alternate references, so neighbours
    /// (often in the same bin) do not wait on each other's updates.
    fn fill<const N: usize>(&self, refs: &[PrimRef]) -> Bins<N> {
        let mut bins = Bins::new();
        if refs.len() < 256 {
            for r in refs {
                bins.add(self.bins(r), r);
            }
            return bins;
        }
        let mut odd = Bins::new();
        let mut pairs = refs.chunks_exact(2);
        for p in &mut pairs {
            let (r, s) = (&p[0], &p[1]);
            bins.add(self.bins(r), r);
            odd.add(self.bins(s), s);
        }
        for r in pairs.remainder() {
            bins.add(self.bins(r), r);
        }
        bins.merge(&odd)
    }
}

/// Best split: (cost relative to a block test, axis, last bin on the left).
fn best_split<const N: usize>(bins: &Bins<N>, cent: &B4, parent_half_area: f32) -> Option<(f32, usize, usize)> {
    let nb = N;
    let ext = cent.hi - cent.lo;
    let mut best: Option<(f32, usize, usize)> = None;
    for a in 0..3 {
        if ext[a] <= 0.0 {
            continue;
        }
        let mut right_cost = [0.0f32; N];
        let mut acc = B4::EMPTY;
        let mut cnt: Count = 0;
        for k in (1..nb).rev() {
            acc = acc.union(bins.b[a][k]);
            cnt += bins.n[a][k];
            // NaN while empty (the area of the empty box times 0 blocks)
            right_cost[k] = acc.half_area_nonempty() * leaf_tests(cnt);
        }
        let mut acc = B4::EMPTY;
        let mut cnt: Count = 0;
        for k in 0..nb - 1 {
            acc = acc.union(bins.b[a][k]);
            cnt += bins.n[a][k];
            let rc = right_cost[k + 1];
            if cnt == 0 || rc.is_nan() {
                continue;
            }
            let cost = acc.half_area_nonempty() * leaf_tests(cnt) + rc;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, a, k));
            }
        }
    }
    best.map(|(c, a, k)| (COST_TRAVERSE + COST_BLOCK * c / parent_half_area.max(f32::MIN_POSITIVE), a, k))
}

/// Bins `refs` into `N` bins per axis and finds the best split.
fn find_split<const N: usize>(refs: &[PrimRef], cent: &B4, geom: &B4) -> (Binner, Option<(f32, usize, usize)>) {
    let binner = Binner::new(cent, N);
    let bins: Bins<N> = if refs.len() >= PAR_BIN_MIN {
        use rayon::prelude::*;
        refs.par_chunks(PAR_BIN_MIN / 2)
            .map(|c| binner.fill::<N>(c))
            .reduce(Bins::new, |a, b| a.merge(&b))
    } else {
        binner.fill::<N>(refs)
    };
    (binner, best_split(&bins, cent, geom.half_area()))
}

/// A leaf of `refs`, which count `counted` ([`count`]).
fn leaf(refs: &[PrimRef], first: usize, geom: &B4, counted: Count) -> TmpNode {
    TmpNode {
        bounds: geom.aabb(),
        kind: TmpKind::Leaf {
            start: first as u32,
            count: refs.len() as u32,
        },
        cost: [geom.half_area() * COST_BLOCK * leaf_tests(counted); WIDE],
    }
}

fn build_rec(refs: &mut [PrimRef], first: usize, geom: B4, cent: B4, depth: usize, max_leaf: usize) -> TmpNode {
    let n = refs.len();
    // counted once, where the node may still become a leaf
    let counted = (n <= max_leaf).then(|| count(refs));
    if let Some(c) = counted {
        // up to a block of triangles costs one test whatever the split: a leaf
        if n == 1 || (n <= BLOCK && c >> 32 == 0) {
            return leaf(refs, first, &geom, c);
        }
    }
    let ext = cent.hi - cent.lo;
    let mid = if !(ext.x > 0.0 || ext.y > 0.0 || ext.z > 0.0) {
        // all centroids coincide: SAH cannot separate them
        if let Some(c) = counted {
            return leaf(refs, first, &geom, c);
        }
        n / 2
    } else if depth >= SAH_DEPTH_LIMIT {
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        refs.select_nth_unstable_by(n / 2, |a, b| a.c2()[axis].total_cmp(&b.c2()[axis]));
        n / 2
    } else {
        // fewer bins for small nodes, where the sweeps would dominate
        let (binner, best) = if n <= 16 {
            find_split::<8>(refs, &cent, &geom)
        } else if n <= 128 {
            find_split::<16>(refs, &cent, &geom)
        } else {
            find_split::<BINS>(refs, &cent, &geom)
        };
        match best {
            Some((cost, axis, split)) => {
                if let Some(c) = counted.filter(|&c| COST_BLOCK * leaf_tests(c) <= cost) {
                    return leaf(refs, first, &geom, c);
                }
                // left of the plane between bins `split` and `split + 1` (doubled
                // centroids); a comparison instead of a bin index per reference
                let pos = Vec4::splat(binner.lo[axis] + (split + 1) as f32 / binner.scale[axis]);
                let bit = 1u32 << axis;
                let (m, lb, rb) = partition(refs, |r| r.c2().cmplt(pos).bitmask() & bit != 0);
                if m > 0 && m < n {
                    return split_at(refs, first, m, geom, depth, Some((lb, rb)), max_leaf);
                }
                n / 2
            }
            None => n / 2,
        }
    };
    split_at(refs, first, mid, geom, depth, None, max_leaf)
}

/// Builds the two children of `refs` split at `mid` (with their bounds if known).
fn split_at(
    refs: &mut [PrimRef],
    first: usize,
    mid: usize,
    geom: B4,
    depth: usize,
    bounds: Option<((B4, B4), (B4, B4))>,
    max_leaf: usize,
) -> TmpNode {
    let n = refs.len();
    let (left, right) = refs.split_at_mut(mid);
    let (lb, rb) = match bounds {
        Some(b) => b,
        None if n >= PAR_BIN_MIN => rayon::join(|| bounds_of(left), || bounds_of(right)),
        None => (bounds_of(left), bounds_of(right)),
    };
    let (l, r) = if n >= PAR_MIN {
        rayon::join(
            || build_rec(left, first, lb.0, lb.1, depth + 1, max_leaf),
            || build_rec(right, first + mid, rb.0, rb.1, depth + 1, max_leaf),
        )
    } else {
        (
            build_rec(left, first, lb.0, lb.1, depth + 1, max_leaf),
            build_rec(right, first + mid, rb.0, rb.1, depth + 1, max_leaf),
        )
    };
    // as one wide node, or its slots shared among the roots below
    let mut cost = [0.0; WIDE];
    cost[0] = geom.half_area() * COST_TRAVERSE + share_slots(&l, &r, WIDE).1;
    for i in 1..WIDE {
        cost[i] = cost[i - 1].min(share_slots(&l, &r, i + 1).1);
    }
    TmpNode {
        bounds: geom.aabb(),
        kind: TmpKind::Inner(Box::new([l, r])),
        cost,
    }
}

/// Moves the references `left` accepts to the front; returns their number and
/// the (geometry, centroid) bounds of both sides.
fn partition(refs: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> (usize, (B4, B4), (B4, B4)) {
    let (mut lg, mut lc, mut rg, mut rc) = (B4::EMPTY, B4::EMPTY, B4::EMPTY, B4::EMPTY);
    let (mut i, mut j) = (0, refs.len());
    loop {
        while i < j && left(&refs[i]) {
            lg.grow_box(refs[i].lo, refs[i].hi);
            lc.grow_point(refs[i].c2());
            i += 1;
        }
        while i < j && !left(&refs[j - 1]) {
            rg.grow_box(refs[j - 1].lo, refs[j - 1].hi);
            rc.grow_point(refs[j - 1].c2());
            j -= 1;
        }
        if i >= j {
            return (i, (lg, lc), (rg, rc));
        }
        refs.swap(i, j - 1);
    }
}
