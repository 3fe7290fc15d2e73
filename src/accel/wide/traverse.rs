//! Traversal: closest-hit and any-hit queries, generic over the kernels
//! ([`Kernel`]: a node test and a block test per instruction set), and the
//! portable kernels.
//!
//! Traversal is front to back: children hit are visited nearest first and stack
//! entries farther than the current closest hit are skipped; any-hit queries stop
//! at the first hit and do not sort. Children pushed for later are prefetched
//! (their latency overlaps the nearer child's work when the tree outgrows the
//! cache), and the fixed-size stacks are not zeroed per ray.
//!
//! Triangle blocks go through the block kernel; generic leaves through each
//! primitive's own test ([`Prim::intersect`]).

use super::node::{leaf_range, TriBlock, WideNode, EMPTY, GENERIC, LANES, LEAF, WIDTH};
use super::WideBvh;
use crate::geometry::aabb::safe_inverse;
use crate::geometry::prim::{Hit, Prim};
use crate::geometry::sphere::Sphere;
use crate::geometry::triangle::{intersect_watertight, watertight_axes};
use crate::geometry::Ray;
use crate::math::{gamma, Vec3};
use std::mem::MaybeUninit;

/// The tests of the primitives in generic leaves (those that are not triangles):
/// the slice the tree was built over for a one-level tree; a top level's
/// instances for a two-level one ([`crate::accel::instance`]).
pub trait Leaves {
    /// Nearest hit of primitive `p` in `[ray.t_min, t_max]`.
    fn closest(&self, p: u32, ray: &Ray, t_max: f32) -> Option<Hit>;
    /// Whether primitive `p` is hit in `[ray.t_min, t_max]`.
    fn any(&self, p: u32, ray: &Ray, t_max: f32) -> bool;
    /// Primitive `p` if it is a sphere (hit `prim: p`, `b` and `sub` zero), which the
    /// packet kernels test against all their rays at once.
    #[inline(always)]
    fn sphere(&self, _p: u32) -> Option<&Sphere> {
        None
    }
}

impl Leaves for [Prim] {
    #[inline(always)]
    fn closest(&self, p: u32, ray: &Ray, t_max: f32) -> Option<Hit> {
        self[p as usize].intersect(ray, t_max).map(|(t, b)| Hit { t, prim: p, b, sub: 0 })
    }
    #[inline(always)]
    fn any(&self, p: u32, ray: &Ray, t_max: f32) -> bool {
        self[p as usize].intersect(ray, t_max).is_some()
    }
    #[inline(always)]
    fn sphere(&self, p: u32) -> Option<&Sphere> {
        match &self[p as usize] {
            Prim::Sphere { sphere, .. } => Some(sphere),
            _ => None,
        }
    }
}

/// Far distances are widened by this, as in the scalar slab test.
pub(super) const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(3);

impl WideBvh {
    /// Visits the primitives of the leaves the ray's box tests admit, nearest
    /// child first, each primitive at most once per leaf. `visit` gets a
    /// primitive index and the current `t_max`, which it may shrink; returning
    /// `true` stops the traversal. Portable code (used by `--compat`).
    pub fn traverse(&self, ray: &Ray, visit: impl FnMut(u32, &mut f32) -> bool) {
        self.traverse_counted(ray, visit, &mut 0);
    }

    /// [`WideBvh::traverse`] that adds the number of inner nodes it visits to `nodes`
    /// (the benchmark's nodes per ray).
    pub fn traverse_counted(&self, ray: &Ray, mut visit: impl FnMut(u32, &mut f32) -> bool, nodes: &mut usize) {
        if self.nodes.is_empty() {
            return;
        }
        if !super::usable(ray) {
            return;
        }
        let r = RayData::new(ray);
        let mut t_max = ray.t_max;
        let mut stack: Vec<(u32, f32)> = Vec::with_capacity(64);
        let mut cur = 0u32;
        loop {
            if cur & LEAF == 0 {
                *nodes += 1;
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
}

/// Everything the kernels need about a ray, computed once.
#[derive(Clone, Copy)]
pub(super) struct RayData {
    pub(super) o: Vec3,
    pub(super) d: Vec3,
    pub(super) t_min: f32,
    pub(super) inv: [f32; 3],
    /// Rows of the near and far planes per axis.
    pub(super) near: [usize; 3],
    pub(super) far: [usize; 3],
    /// Watertight kernel: axis permutation, permuted origin, shear.
    pub(super) k: [usize; 3],
    pub(super) op: [f32; 3],
    pub(super) s: [f32; 3],
    pub(super) dz_abs: f32,
    /// `false` when the direction is zero: no triangle can be hit.
    pub(super) tri_ok: bool,
}

impl RayData {
    #[inline(always)]
    pub(super) fn new(ray: &Ray) -> RayData {
        Self::for_tree::<true>(ray)
    }

    /// The ray's data for a tree with triangle blocks (`TRIANGLES`) or without them,
    /// whose rays need no watertight set-up (`tri_ok` false).
    #[inline(always)]
    pub(super) fn for_tree<const TRIANGLES: bool>(ray: &Ray) -> RayData {
        let inv = safe_inverse(ray.d);
        let inv = [inv.x, inv.y, inv.z];
        let neg = inv.map(|c| (c < 0.0) as usize);
        // built once, field by field (a copy of a boxes-only `RayData` updated with
        // the watertight fields was stored twice)
        let (d, o) = (ray.d.to_array(), ray.o.to_array());
        let (k, op, s, dz_abs, tri_ok) = if TRIANGLES {
            // the watertight kernel's permutation and shear, exactly as it computes them
            let (kx, ky, kz) = watertight_axes(ray.d);
            let dz = d[kz];
            (
                [kx, ky, kz],
                [o[kx], o[ky], o[kz]],
                [-d[kx] / dz, -d[ky] / dz, 1.0 / dz],
                dz.abs(),
                dz != 0.0,
            )
        } else {
            ([0, 1, 2], [0.0; 3], [0.0; 3], 0.0, false)
        };
        RayData {
            o: ray.o,
            d: ray.d,
            t_min: ray.t_min,
            inv,
            near: [neg[0], 2 + neg[1], 4 + neg[2]],
            far: [1 - neg[0], 3 - neg[1], 5 - neg[2]],
            k,
            op,
            s,
            dz_abs,
            tri_ok,
        }
    }
}

/// Portable node test: hit mask and entry distances.
#[inline(always)]
pub(super) fn node_portable(n: &WideNode, r: &RayData, t_max: f32) -> (u32, [f32; WIDTH]) {
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
pub(super) struct BlockHits {
    pub(super) mask: u32,
    pub(super) t: [f32; LANES],
    pub(super) b: [[f32; LANES]; 3],
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

/// One instruction set's node and block tests: what the generic traversal
/// ([`closest`], [`any`]) is instantiated with. Both must give the portable
/// kernels' results bit for bit.
///
/// The portable kernel, [`Portable`], is here; the AVX2 and AVX-512 ones are
/// private to `x86`, which instantiates the traversal with them only inside
/// its `#[target_feature]` entry points.
pub(super) trait Kernel {
    /// Hit mask and entry distances of the node's children.
    fn node(n: &WideNode, r: &RayData, t_max: f32) -> (u32, [f32; WIDTH]);
    /// Hits of the block's lanes.
    fn block(b: &TriBlock, r: &RayData, t_max: f32) -> BlockHits;
}

/// The portable kernels: Rust that runs on every CPU.
pub(super) struct Portable;

impl Kernel for Portable {
    #[inline(always)]
    fn node(n: &WideNode, r: &RayData, t_max: f32) -> (u32, [f32; WIDTH]) {
        node_portable(n, r, t_max)
    }

    #[inline(always)]
    fn block(b: &TriBlock, r: &RayData, t_max: f32) -> BlockHits {
        block_portable(b, r, t_max)
    }
}

/// Starts loading a child that will be visited later (if no nearer hit culls
/// it), so its memory latency overlaps the work on the nearer ones.
#[inline(always)]
pub(super) fn prefetch(bvh: &WideBvh, c: u32) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // straight-line prefetches (no loop over the size): a node's 224 bytes lie
        // in the four lines from its start, a block's 320 in five
        let pf = |p: *const i8| {
            // SAFETY: a prefetch is a hint that never faults, whatever the address;
            // SSE is part of x86_64.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p) }
        };
        const _: () = assert!(std::mem::size_of::<WideNode>() <= 4 * 64 && std::mem::size_of::<TriBlock>() <= 5 * 64);
        if c & LEAF == 0 {
            let p = bvh.nodes.as_ptr().wrapping_add(c as usize).cast::<i8>();
            pf(p);
            pf(p.wrapping_add(64));
            pf(p.wrapping_add(128));
            pf(p.wrapping_add(192));
        } else if c & GENERIC == 0 {
            let p = bvh.blocks.as_ptr().wrapping_add(leaf_range(c).0).cast::<i8>();
            pf(p);
            pf(p.wrapping_add(64));
            pf(p.wrapping_add(128));
            pf(p.wrapping_add(192));
            pf(p.wrapping_add(256));
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
pub(super) fn closest<K: Kernel, L: Leaves + ?Sized, const S: usize>(bvh: &WideBvh, prims: &L, ray: &Ray) -> Option<Hit> {
    // a tree without triangle blocks (spheres only, a top level of instances): its
    // own copy, without the watertight set-up and the block test
    if bvh.blocks.is_empty() {
        closest_in::<K, L, S, false>(bvh, prims, ray)
    } else {
        closest_in::<K, L, S, true>(bvh, prims, ray)
    }
}

/// [`closest`] in a tree with triangle blocks (`TRIANGLES`) or without.
#[inline(always)]
fn closest_in<K: Kernel, L: Leaves + ?Sized, const S: usize, const TRIANGLES: bool>(bvh: &WideBvh, prims: &L, ray: &Ray) -> Option<Hit> {
    let r_data = RayData::for_tree::<TRIANGLES>(ray);
    let mut t_max = ray.t_max;
    let mut best: Option<Hit> = None;
    // stack entries: entry distance's bits above, child reference below (for
    // distances ≥ 0 the integer order is the distance order)
    // not zeroed for every ray; entries `..sp` are initialised
    let mut st = [MaybeUninit::<u64>::uninit(); S];
    let mut sp = 0usize;
    let mut cur = 0u32;
    loop {
        // read from memory where the kernels use it: the compiler otherwise broadcast
        // every field into a vector register before the loop and spilled them all to
        // the stack, a copy per ray that cost more than it saved (cbox_path: 3 %)
        let r = std::hint::black_box(&r_data);
        if cur & LEAF == 0 {
            let node = &bvh.nodes[cur as usize];
            let (mask, d) = K::node(node, r, t_max);
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
        } else if cur != EMPTY {
            // an empty slot is never admitted by a box test of a finite ray; the
            // check keeps a bad one (huge but finite coordinates) from indexing garbage
            let (first, count) = leaf_range(cur);
            if cur & GENERIC != 0 {
                for &p in &bvh.generic[first..first + count] {
                    if let Some(h) = prims.closest(p, ray, t_max) {
                        t_max = h.t;
                        best = Some(h);
                    }
                }
            } else if r.tri_ok {
                for blk in &bvh.blocks[first..first + count] {
                    let h = K::block(blk, r, t_max);
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
                            sub: 0,
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
pub(super) fn any<K: Kernel, L: Leaves + ?Sized, const S: usize>(bvh: &WideBvh, prims: &L, ray: &Ray) -> bool {
    // as in `closest`
    if bvh.blocks.is_empty() {
        any_in::<K, L, S, false>(bvh, prims, ray)
    } else {
        any_in::<K, L, S, true>(bvh, prims, ray)
    }
}

/// [`any`] in a tree with triangle blocks (`TRIANGLES`) or without.
#[inline(always)]
fn any_in<K: Kernel, L: Leaves + ?Sized, const S: usize, const TRIANGLES: bool>(bvh: &WideBvh, prims: &L, ray: &Ray) -> bool {
    let r_data = RayData::for_tree::<TRIANGLES>(ray);
    let t_max = ray.t_max;
    // not zeroed for every ray; entries `..sp` are initialised
    let mut st = [MaybeUninit::<u32>::uninit(); S];
    let mut sp = 0usize;
    let mut cur = 0u32;
    loop {
        // as in `closest_in`
        let r = std::hint::black_box(&r_data);
        if cur & LEAF == 0 {
            let node = &bvh.nodes[cur as usize];
            let (mask, _) = K::node(node, r, t_max);
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
        } else if cur != EMPTY {
            // an empty slot is never admitted by a box test of a finite ray; the
            // check keeps a bad one (huge but finite coordinates) from indexing garbage
            let (first, count) = leaf_range(cur);
            if cur & GENERIC != 0 {
                for &p in &bvh.generic[first..first + count] {
                    if prims.any(p, ray, t_max) {
                        return true;
                    }
                }
            } else if r.tri_ok {
                for blk in &bvh.blocks[first..first + count] {
                    if K::block(blk, r, t_max).mask != 0 {
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
