//! A point kd-tree for photon maps (and any other point set): k nearest
//! neighbours and all points within a radius, in `D` dimensions (3 for photons,
//! 2 for tests). It knows nothing of scenes: it stores coordinates and, per
//! point, the index it had in the input, so callers keep their payload beside it
//! (permuted into tree order with [`KdTree::permute`] for locality).
//!
//! Layout: the points are reordered in place into an implicit balanced tree —
//! the node of range `[lo, hi)` is its median `m = lo + (hi − lo)/2`, with the
//! left subtree in `[lo, m)` and the right one in `(m, hi)`; each node splits
//! along the axis of largest extent of its range. No child pointers: 4·D bytes
//! per point for the coordinates, 4 for the input index and 1 for the split axis.
//!
//! The build splits ranges with `select_nth_unstable` (linear time, O(n log n)
//! overall) and recurses into both halves with `rayon::join` above 4096 points.
//! The halves are disjoint and each is processed by a fixed sequence of
//! operations, so the tree is identical for any thread count.
//!
//! Why a kd-tree and not a hashed grid: `examples/photon_map_bench.rs` measures
//! both (`docs/dev/integrators/photon.md`, "The photon map"). A grid whose cells equal the query radius wins
//! fixed-radius queries with many hits (16,384 points, r = 0.1: 2.5 µs against
//! 9.3 µs) but loses with few (10⁶ points, r = 0.01: 3.8 µs against 2.3 µs), needs
//! one radius for all queries, and has no k-NN; the photon integrators need k-NN
//! (`photon`) and a different, shrinking radius per pixel (`sppm`), so the tree.

use rayon::join;

const PARALLEL_MIN: usize = 4096;

#[derive(Clone, Debug, Default)]
pub struct KdTree<const D: usize> {
    points: Vec<[f32; D]>,
    /// Input index of each point in tree order.
    order: Vec<u32>,
    axis: Vec<u8>,
}

/// Squared distance, summed in axis order (the brute-force order too).
#[inline]
pub fn dist2<const D: usize>(a: &[f32; D], b: &[f32; D]) -> f32 {
    let mut s = 0.0;
    for i in 0..D {
        let d = a[i] - b[i];
        s += d * d;
    }
    s
}

impl<const D: usize> KdTree<D> {
    /// Builds the tree over `points` (any number, duplicates allowed).
    pub fn build(points: Vec<[f32; D]>) -> Self {
        assert!(points.len() < u32::MAX as usize, "too many points for a kd-tree");
        let n = points.len();
        let mut items: Vec<([f32; D], u32)> = points.into_iter().zip(0u32..).collect();
        let mut axis = vec![0u8; n];
        build_range(&mut items, &mut axis);
        let (points, order) = items.into_iter().unzip();
        KdTree { points, order, axis }
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Coordinates of tree slot `slot`.
    #[inline]
    pub fn point(&self, slot: usize) -> &[f32; D] {
        &self.points[slot]
    }

    /// Input index of tree slot `slot`.
    #[inline]
    pub fn original(&self, slot: usize) -> usize {
        self.order[slot] as usize
    }

    /// Reorders `items` (given in input order) into tree order.
    pub fn permute<T: Clone>(&self, items: &[T]) -> Vec<T> {
        self.order.iter().map(|&i| items[i as usize].clone()).collect()
    }

    /// Bytes the tree holds per point.
    pub const BYTES_PER_POINT: usize = 4 * D + 4 + 1;

    /// The nearest point: `(slot, squared distance)`; `None` when empty. Ties go to
    /// the point found first.
    pub fn nearest(&self, q: &[f32; D]) -> Option<(usize, f32)> {
        let mut best = (usize::MAX, f32::INFINITY);
        self.nearest_in(0, self.points.len(), q, &mut best);
        (best.0 != usize::MAX).then_some(best)
    }

    fn nearest_in(&self, lo: usize, hi: usize, q: &[f32; D], best: &mut (usize, f32)) {
        if lo >= hi {
            return;
        }
        let m = lo + (hi - lo) / 2;
        let d2 = dist2(&self.points[m], q);
        if d2 < best.1 {
            *best = (m, d2);
        }
        let a = self.axis[m] as usize;
        let diff = q[a] - self.points[m][a];
        let (near, far) = if diff < 0.0 {
            ((lo, m), (m + 1, hi))
        } else {
            ((m + 1, hi), (lo, m))
        };
        self.nearest_in(near.0, near.1, q, best);
        if diff * diff <= best.1 {
            self.nearest_in(far.0, far.1, q, best);
        }
    }

    /// Calls `f(slot, squared distance)` for every point strictly closer than `r`.
    pub fn within(&self, q: &[f32; D], r: f32, mut f: impl FnMut(usize, f32)) {
        self.within_in(0, self.points.len(), q, r * r, &mut f);
    }

    fn within_in(&self, lo: usize, hi: usize, q: &[f32; D], r2: f32, f: &mut impl FnMut(usize, f32)) {
        if lo >= hi {
            return;
        }
        let m = lo + (hi - lo) / 2;
        let d2 = dist2(&self.points[m], q);
        if d2 < r2 {
            f(m, d2);
        }
        let a = self.axis[m] as usize;
        let diff = q[a] - self.points[m][a];
        // a point in the far half is at least |diff| away
        if diff < 0.0 || diff * diff < r2 {
            self.within_in(lo, m, q, r2, f);
        }
        if diff >= 0.0 || diff * diff < r2 {
            self.within_in(m + 1, hi, q, r2, f);
        }
    }

    /// The `k` nearest points (fewer when the tree holds fewer), as `(squared
    /// distance, slot)` sorted nearest first, into `out` (cleared first). Only
    /// points closer than `max_r2` (squared) count; pass `f32::INFINITY` for no cap.
    pub fn knn(&self, q: &[f32; D], k: usize, max_r2: f32, out: &mut Vec<(f32, u32)>) {
        out.clear();
        if k == 0 {
            return;
        }
        let mut heap = KnnHeap {
            items: out,
            k,
            bound: max_r2,
        };
        self.knn_in(0, self.points.len(), q, &mut heap);
        out.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    }

    fn knn_in(&self, lo: usize, hi: usize, q: &[f32; D], heap: &mut KnnHeap) {
        if lo >= hi {
            return;
        }
        let m = lo + (hi - lo) / 2;
        let d2 = dist2(&self.points[m], q);
        if d2 < heap.bound {
            heap.push(d2, m as u32);
        }
        let a = self.axis[m] as usize;
        let diff = q[a] - self.points[m][a];
        let (near, far) = if diff < 0.0 {
            ((lo, m), (m + 1, hi))
        } else {
            ((m + 1, hi), (lo, m))
        };
        self.knn_in(near.0, near.1, q, heap);
        if diff * diff < heap.bound {
            self.knn_in(far.0, far.1, q, heap);
        }
    }
}

/// A max-heap of the k best candidates (by squared distance); `bound` is the
/// distance a new point has to beat: the cap until the heap is full, then its top.
struct KnnHeap<'a> {
    items: &'a mut Vec<(f32, u32)>,
    k: usize,
    bound: f32,
}

impl KnnHeap<'_> {
    fn push(&mut self, d2: f32, slot: u32) {
        let h = &mut *self.items;
        if h.len() < self.k {
            h.push((d2, slot));
            let mut i = h.len() - 1;
            while i > 0 {
                let p = (i - 1) / 2;
                if h[p].0 >= h[i].0 {
                    break;
                }
                h.swap(p, i);
                i = p;
            }
        } else {
            h[0] = (d2, slot);
            let n = h.len();
            let mut i = 0;
            loop {
                let (l, r) = (2 * i + 1, 2 * i + 2);
                let mut big = i;
                if l < n && h[l].0 > h[big].0 {
                    big = l;
                }
                if r < n && h[r].0 > h[big].0 {
                    big = r;
                }
                if big == i {
                    break;
                }
                h.swap(i, big);
                i = big;
            }
        }
        if h.len() == self.k {
            self.bound = h[0].0;
        }
    }
}

fn build_range<const D: usize>(items: &mut [([f32; D], u32)], axis: &mut [u8]) {
    let n = items.len();
    if n <= 1 {
        return;
    }
    let mut lo = [f32::INFINITY; D];
    let mut hi = [f32::NEG_INFINITY; D];
    for (p, _) in items.iter() {
        for a in 0..D {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let mut a = 0;
    for i in 1..D {
        if hi[i] - lo[i] > hi[a] - lo[a] {
            a = i;
        }
    }
    let m = n / 2;
    items.select_nth_unstable_by(m, |x, y| x.0[a].total_cmp(&y.0[a]).then(x.1.cmp(&y.1)));
    axis[m] = a as u8;
    let (left, rest) = items.split_at_mut(m);
    let right = &mut rest[1..];
    let (al, arest) = axis.split_at_mut(m);
    let ar = &mut arest[1..];
    if n > PARALLEL_MIN {
        join(|| build_range(left, al), || build_range(right, ar));
    } else {
        build_range(left, al);
        build_range(right, ar);
    }
}
