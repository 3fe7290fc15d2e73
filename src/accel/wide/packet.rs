//! Packet traversal: up to [`PACKET`] coherent rays (camera rays of a pixel
//! block, their shadow rays) through the wide BVH together. Each node's child
//! boxes are tested against all active rays at once (SIMD across rays) and a
//! child is visited if any ray hits it; each ray keeps its own range and only
//! tests what its own box tests admitted. A triangle block is tested triangle by
//! triangle against all rays of one watertight axis permutation.
//!
//! Results are exactly the single-ray kernels' (same hit, `t` bits, primitive,
//! barycentrics). Any hit: a ray's leaves are those its own box tests admit
//! with its fixed `t_max`, as in single-ray traversal, so the answer is the same.
//! Closest hit: the visiting order differs, and a hit test against a shrunken
//! range can differ from the single-ray one only when two candidates lie within
//! a few ulps of each other (ties, hits at a shared edge) or when the culling
//! distance is that close to a candidate. So each ray keeps its range open by a
//! relative [`GROW`] beyond its best hit and is flagged when a new hit lands
//! within [`SHRINK`] of it; flagged rays leave the packet and are traced again by
//! the single-ray kernel ([`super::WideBvh::intersect_packet_with`]). Every
//! other ray's result is the unique nearest candidate, which any order finds.
//!
//! The arithmetic is [`Simd`]: the portable lanes here, AVX2 and AVX-512
//! vectors in `packet_x86` (with the single-ray kernels' operations and operand
//! order, so NaN and signed-zero cases round alike too).

// lanes and axes are indexed in step across several arrays
#![allow(clippy::needless_range_loop)]

use super::node::{leaf_range, TriBlock, WideNode, EMPTY, GENERIC, LANES, LEAF, WIDTH};
use super::traverse::{prefetch, Leaves, FAR_SCALE};
use super::WideBvh;
use crate::geometry::prim::Hit;
use crate::geometry::triangle::intersect_watertight;
use crate::geometry::Ray;
use crate::math::gamma;
use std::mem::MaybeUninit;

/// Closest hits of up to [`PACKET`] rays by lane, in structure-of-arrays form (what
/// a packet traversal finds, stored with a few vector stores; an `Option<Hit>` per
/// ray took some 40 instructions a ray). Lane `i`'s fields hold [`Hit`]'s values
/// where bit `i` of `found` is set; elsewhere they mean nothing.
#[derive(Clone, Copy, Debug)]
pub struct PacketHits {
    pub found: u32,
    pub t: [f32; PACKET],
    pub prim: [u32; PACKET],
    pub sub: [u32; PACKET],
    /// Barycentrics by coordinate (`b[k][lane]`).
    pub b: [[f32; PACKET]; 3],
}

impl Default for PacketHits {
    fn default() -> Self {
        PacketHits {
            found: 0,
            t: [0.0; PACKET],
            prim: [0; PACKET],
            sub: [0; PACKET],
            b: [[0.0; PACKET]; 3],
        }
    }
}

impl PacketHits {
    /// Lane `i`'s hit.
    #[inline]
    pub fn get(&self, i: usize) -> Option<Hit> {
        (self.found >> i & 1 != 0).then(|| self.hit(i))
    }

    /// Lane `i`'s fields as a [`Hit`] (meaningful where `found` says so).
    #[inline]
    pub fn hit(&self, i: usize) -> Hit {
        Hit {
            t: self.t[i],
            prim: self.prim[i],
            b: self.barycentrics(i),
            sub: self.sub[i],
        }
    }

    /// Lane `i`'s barycentrics.
    #[inline]
    pub fn barycentrics(&self, i: usize) -> [f32; 3] {
        [self.b[0][i], self.b[1][i], self.b[2][i]]
    }

    /// Sets lane `i` to `hit`.
    #[inline]
    pub fn set(&mut self, i: usize, hit: Option<Hit>) {
        self.found &= !(1 << i);
        if let Some(h) = hit {
            self.found |= 1 << i;
            (self.t[i], self.prim[i], self.sub[i]) = (h.t, h.prim, h.sub);
            for k in 0..3 {
                self.b[k][i] = h.b[k];
            }
        }
    }
}

/// The primitives of a generic leaf; none in the traversals' copy for trees without
/// generic leaves, which thus compiles no test for them.
#[inline(always)]
fn generic_leaf<const GENERIC_LEAVES: bool>(bvh: &WideBvh, first: usize, count: usize) -> &[u32] {
    if GENERIC_LEAVES {
        &bvh.generic[first..first + count]
    } else {
        &[]
    }
}

/// Lanes `start..start + N` of a packet's array, as an array.
#[inline(always)]
fn lanes<T, const N: usize>(a: &mut [T; PACKET], start: usize) -> &mut [T; N] {
    (&mut a[start..start + N]).try_into().expect("a packet's lanes lie within PACKET")
}

/// The watertight kernel's axis order `(kx, ky, kz)` for `kz` = 0, 1, 2.
const PERMUTATIONS: [[usize; 3]; 3] = [[1, 2, 0], [2, 0, 1], [0, 1, 2]];

/// Most rays a packet call takes.
pub const PACKET: usize = 16;

/// A ray's range stays open this much (relative) beyond its best hit, so near
/// ties are seen in any visiting order.
const GROW: f32 = 1.0 + 1.0 / (1 << 15) as f32;
/// A hit not below the best by this factor is a near tie: the ray is flagged.
const SHRINK: f32 = 1.0 - 1.0 / (1 << 16) as f32;

/// `N` lanes of `f32` and a lane mask `M`. Comparisons are ordered (false on
/// NaN) except `not_lt`; `min`/`max` are the instruction set's own (x86:
/// `a < b ? a : b`; portable: `f32::min`), used where the single-ray kernels use them.
pub(super) trait Simd<const N: usize>: Copy {
    type M: Copy;
    fn splat(x: f32) -> Self;
    fn load(a: &[f32; N]) -> Self;
    fn store(self, a: &mut [f32; N]);
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    fn min(self, o: Self) -> Self;
    fn max(self, o: Self) -> Self;
    fn abs(self) -> Self;
    /// `-self` (the sign bit flipped).
    fn neg(self) -> Self;
    /// `self`'s magnitude with `sign`'s sign bit.
    fn copysign(self, sign: Self) -> Self;
    fn lt(self, o: Self) -> Self::M;
    fn le(self, o: Self) -> Self::M;
    fn gt(self, o: Self) -> Self::M;
    fn ge(self, o: Self) -> Self::M;
    fn eq(self, o: Self) -> Self::M;
    /// `!(self < o)`: true for NaN.
    fn not_lt(self, o: Self) -> Self::M;
    /// `m ? a : b` lane by lane.
    fn select(m: Self::M, a: Self, b: Self) -> Self;
    fn and(a: Self::M, b: Self::M) -> Self::M;
    fn or(a: Self::M, b: Self::M) -> Self::M;
    /// `!a & b`.
    fn andnot(a: Self::M, b: Self::M) -> Self::M;
    /// Lane `i` in bit `i`.
    fn bits(m: Self::M) -> u32;
    fn from_bits(b: u32) -> Self::M;
    /// The rays' rows: origin x, y, z, direction x, y, z, `t_min`, `t_max`, lane `i`
    /// from `rays[i]` (lanes past the rays zero).
    #[inline(always)]
    fn ray_rows(rays: &[Ray]) -> [Self; 8] {
        ray_rows_by_lane(rays)
    }
}

/// [`Simd::ray_rows`] lane by lane.
#[inline(always)]
pub(super) fn ray_rows_by_lane<V: Simd<N>, const N: usize>(rays: &[Ray]) -> [V; 8] {
    let mut a = [[0.0f32; N]; 8];
    for (i, r) in rays.iter().enumerate().take(N) {
        for (k, v) in ray_row(r).into_iter().enumerate() {
            a[k][i] = v;
        }
    }
    std::array::from_fn(|k| V::load(&a[k]))
}

/// A ray's eight numbers in the order of [`Simd::ray_rows`].
#[inline(always)]
pub(super) fn ray_row(r: &Ray) -> [f32; 8] {
    [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.t_min, r.t_max]
}

/// Portable lanes: plain arrays, the scalar kernel's operations lane by lane.
#[derive(Clone, Copy)]
pub(super) struct Lanes<const N: usize>([f32; N]);

impl<const N: usize> Lanes<N> {
    #[inline(always)]
    fn map2(self, o: Self, f: impl Fn(f32, f32) -> f32) -> Self {
        Lanes(std::array::from_fn(|i| f(self.0[i], o.0[i])))
    }
    #[inline(always)]
    fn cmp(self, o: Self, f: impl Fn(f32, f32) -> bool) -> u32 {
        let mut m = 0;
        for i in 0..N {
            m |= (f(self.0[i], o.0[i]) as u32) << i;
        }
        m
    }
}

impl<const N: usize> Simd<N> for Lanes<N> {
    type M = u32;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Lanes([x; N])
    }
    #[inline(always)]
    fn load(a: &[f32; N]) -> Self {
        Lanes(*a)
    }
    #[inline(always)]
    fn store(self, a: &mut [f32; N]) {
        *a = self.0;
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        self.map2(o, |a, b| a + b)
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        self.map2(o, |a, b| a - b)
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        self.map2(o, |a, b| a * b)
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        self.map2(o, |a, b| a / b)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        self.map2(o, f32::min)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.map2(o, f32::max)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Lanes(self.0.map(f32::abs))
    }
    #[inline(always)]
    fn neg(self) -> Self {
        Lanes(self.0.map(|x| -x))
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        self.map2(sign, f32::copysign)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> u32 {
        self.cmp(o, |a, b| a < b)
    }
    #[inline(always)]
    fn le(self, o: Self) -> u32 {
        self.cmp(o, |a, b| a <= b)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> u32 {
        self.cmp(o, |a, b| a > b)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> u32 {
        self.cmp(o, |a, b| a >= b)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> u32 {
        self.cmp(o, |a, b| a == b)
    }
    #[inline(always)]
    fn not_lt(self, o: Self) -> u32 {
        self.cmp(o, |a, b| a.partial_cmp(&b) != Some(std::cmp::Ordering::Less))
    }
    #[inline(always)]
    fn select(m: u32, a: Self, b: Self) -> Self {
        Lanes(std::array::from_fn(|i| if m >> i & 1 != 0 { a.0[i] } else { b.0[i] }))
    }
    #[inline(always)]
    fn and(a: u32, b: u32) -> u32 {
        a & b
    }
    #[inline(always)]
    fn or(a: u32, b: u32) -> u32 {
        a | b
    }
    #[inline(always)]
    fn andnot(a: u32, b: u32) -> u32 {
        !a & b
    }
    #[inline(always)]
    fn bits(m: u32) -> u32 {
        m & full::<N>()
    }
    #[inline(always)]
    fn from_bits(b: u32) -> u32 {
        b
    }
}

#[inline(always)]
const fn full<const N: usize>() -> u32 {
    if N >= 32 {
        u32::MAX
    } else {
        (1u32 << N) - 1
    }
}

/// Bits of `m`, lowest first.
#[inline(always)]
fn each_bit(mut m: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (m != 0).then(|| {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            i
        })
    })
}

/// The packet's rays in structure-of-arrays form, what the kernels need of each
/// computed once (as [`RayData`] does for one ray).
pub(super) struct Packet<'r, V: Simd<N>, const N: usize> {
    rays: &'r [Ray],
    o: [V; 3],
    d: [V; 3],
    inv: [V; 3],
    /// Lanes whose direction is negative on each axis: they enter a box at its high plane.
    neg: [V::M; 3],
    t_min: V,
    t_max: V,
    /// Watertight kernel per ray: permuted origin, shear, |d_z|.
    op: [V; 3],
    s: [V; 3],
    dz_abs: V,
    /// The rays of each watertight axis permutation (`PERMUTATIONS[g]`: `kz` = `g`),
    /// as lane masks: a block is tested once per non-empty group. (Masks alone: an
    /// array of permutations and masks built here was copied into the packet by
    /// wide loads of its narrow stores, which stalled every packet.)
    groups: [u32; 3],
    /// Usable rays (finite, a range that is not NaN, in `active`).
    valid: u32,
    /// Rays that can hit a triangle (non-zero direction).
    tri_ok: u32,
}

impl<'r, V: Simd<N>, const N: usize> Packet<'r, V, N> {
    /// The ray data of [`RayData::new`] and the test of `super::usable`, lane by
    /// lane with the same operations.
    #[inline(always)]
    fn new(rays: &'r [Ray], active: u32) -> Self {
        let [ox, oy, oz, dx, dy, dz, t_min, t_max] = V::ray_rows(rays);
        let (o, d) = ([ox, oy, oz], [dx, dy, dz]);
        let zero = V::splat(0.0);
        let inf = V::splat(f32::INFINITY);
        let active = active & full::<N>() & ((1u64 << rays.len().min(N)) - 1) as u32;
        // `usable`: the sum of the coordinates is finite, the range not NaN
        let sum = o[0].add(o[1]).add(o[2].add(d[0])).add(d[1].add(d[2]));
        let ok = V::bits(V::and(sum.abs().lt(inf), t_max.ge(t_min)));
        let mut valid = active & ok;
        for i in each_bit(active & !ok) {
            // the rare rest (counts bad rays; an empty range is a plain miss)
            if super::usable(&rays[i]) {
                valid |= 1 << i;
            }
        }
        // `safe_inverse`: a zero component becomes ±1e-30
        let inv = [safe_inv(d[0]), safe_inv(d[1]), safe_inv(d[2])];
        // `watertight_axes`: kz the largest |d| component (x before y before z on ties
        // as there), then kx, ky cyclically after it
        let ad = [d[0].abs(), d[1].abs(), d[2].abs()];
        let m0 = V::and(ad[0].gt(ad[1]), ad[0].gt(ad[2]));
        let m1 = V::andnot(m0, ad[1].gt(ad[2]));
        // (no closures in the kernels: they would not inline into the entry points' instruction set)
        let (dkx, dky, dkz) = (pick3(m0, m1, &d, 0), pick3(m0, m1, &d, 1), pick3(m0, m1, &d, 2));
        let op = [pick3(m0, m1, &o, 0), pick3(m0, m1, &o, 1), pick3(m0, m1, &o, 2)];
        let tri_ok = valid & !V::bits(dkz.eq(zero));
        let (b0, b1) = (V::bits(m0), V::bits(m1));
        let groups = [b0 & tri_ok, b1 & !b0 & tri_ok, !(b0 | b1) & tri_ok];
        Packet {
            rays,
            o,
            d,
            inv,
            neg: [inv[0].lt(zero), inv[1].lt(zero), inv[2].lt(zero)],
            t_min,
            t_max,
            op,
            s: [dkx.neg().div(dkz), dky.neg().div(dkz), V::splat(1.0).div(dkz)],
            dz_abs: dkz.abs(),
            groups,
            valid,
            tri_ok,
        }
    }
}

/// A packet's rays as arrays: origins and directions by axis, `t_min`, `t_max`.
struct Rows<const N: usize> {
    o: [[f32; N]; 3],
    d: [[f32; N]; 3],
    t_min: [f32; N],
    t_max: [f32; N],
}

impl<V: Simd<N>, const N: usize> Packet<'_, V, N> {
    /// The rays as arrays (for [`Sphere::intersect_lanes`](crate::geometry::sphere::Sphere::intersect_lanes)).
    #[inline(always)]
    fn rows(&self) -> Rows<N> {
        let mut r = Rows {
            o: [[0.0; N]; 3],
            d: [[0.0; N]; 3],
            t_min: [0.0; N],
            t_max: [0.0; N],
        };
        for a in 0..3 {
            self.o[a].store(&mut r.o[a]);
            self.d[a].store(&mut r.d[a]);
        }
        self.t_min.store(&mut r.t_min);
        self.t_max.store(&mut r.t_max);
        r
    }
}

/// `1 / safe_inverse`'s fixed component: a zero becomes ±1e-30.
#[inline(always)]
fn safe_inv<V: Simd<N>, const N: usize>(c: V) -> V {
    let fixed = V::select(c.eq(V::splat(0.0)), V::splat(1e-30).copysign(c), c);
    V::splat(1.0).div(fixed)
}

/// Component `a` of `v` in each lane's watertight order `(kx, ky, kz)`: with
/// `kz` = 0 (`m0`) that is `(y, z, x)`, with `kz` = 1 (`m1`) `(z, x, y)`, else `(x, y, z)`.
#[inline(always)]
fn pick3<V: Simd<N>, const N: usize>(m0: V::M, m1: V::M, v: &[V; 3], a: usize) -> V {
    V::select(m0, v[(a + 1) % 3], V::select(m1, v[(a + 2) % 3], v[a]))
}

/// Entry and exit distances of child `i` for every lane, as the single-ray
/// node test computes them (`x86::slabs`: same operations, same order).
#[inline(always)]
fn child_slabs<V: Simd<N>, const N: usize>(n: &WideNode, i: usize, p: &Packet<V, N>, lim: V) -> (V, V) {
    // no closures here: they would not inline into the entry points' instruction set
    let (n0, f0) = axis_slab(n, i, p, 0);
    let (n1, f1) = axis_slab(n, i, p, 1);
    let (n2, f2) = axis_slab(n, i, p, 2);
    let t0 = n0.max(n1).max(n2.max(p.t_min));
    let t1 = f0.min(f1).min(f2);
    let t1 = t1.mul(V::splat(FAR_SCALE)).min(lim);
    (t0, t1)
}

/// Near and far distance of child `i`'s slab on axis `a`.
#[inline(always)]
fn axis_slab<V: Simd<N>, const N: usize>(n: &WideNode, i: usize, p: &Packet<V, N>, a: usize) -> (V, V) {
    let lo = V::splat(n.planes[2 * a][i]).sub(p.o[a]).mul(p.inv[a]);
    let hi = V::splat(n.planes[2 * a + 1][i]).sub(p.o[a]).mul(p.inv[a]);
    (V::select(p.neg[a], hi, lo), V::select(p.neg[a], lo, hi))
}

/// Vertex `v` of triangle `j` relative to each ray's origin, permuted by `k`, sheared.
#[inline(always)]
fn vertex<V: Simd<N>, const N: usize>(blk: &TriBlock, v: usize, j: usize, k: [usize; 3], p: &Packet<V, N>) -> (V, V, V) {
    let x = V::splat(blk.v[v][k[0]][j]).sub(p.op[0]);
    let y = V::splat(blk.v[v][k[1]][j]).sub(p.op[1]);
    let z = V::splat(blk.v[v][k[2]][j]).sub(p.op[2]);
    (x.add(p.s[0].mul(z)), y.add(p.s[1].mul(z)), z)
}

#[inline(always)]
fn max3<V: Simd<N>, const N: usize>(a: V, b: V, c: V) -> V {
    a.abs().max(b.abs()).max(c.abs())
}

/// The best hit of each lane in one block (lowest `t`, the first lane on ties,
/// as the single-ray block test picks it).
struct BlockBest<V: Simd<N>, const N: usize> {
    has: u32,
    t: V,
    b: [V; 3],
    /// The block lane of the best hit, per ray, as the bits of an `f32` (selects
    /// copy bits; reading it back needs no float-to-integer conversion).
    lane: V,
}

/// Tests the block's triangles against the rays in `mask` (a subset of
/// `p.tri_ok`) with ranges `[t_min, lim]`. `CLOSEST`: the best hit per ray;
/// otherwise only `has` (rays with any hit) is meaningful.
#[inline(always)]
fn block<V: Simd<N>, const N: usize, const CLOSEST: bool>(blk: &TriBlock, p: &Packet<V, N>, lim: V, mask: u32) -> BlockBest<V, N> {
    let zero = V::splat(0.0);
    let inf = V::splat(f32::INFINITY);
    let mut best = BlockBest {
        has: 0,
        t: zero,
        b: [zero; 3],
        lane: zero,
    };
    let mut has_m = V::from_bits(0);
    for (&g, &k) in p.groups.iter().zip(&PERMUTATIONS) {
        let mut gm = g & mask;
        if gm == 0 {
            continue;
        }
        let mut gm_m = V::from_bits(gm);
        for j in 0..LANES {
            // a short block repeats its last triangle: same hits, never picked over the first
            if j > 0 && blk.prim[j] == blk.prim[j - 1] {
                continue;
            }
            if !CLOSEST && gm & best.has != 0 {
                gm &= !best.has;
                if gm == 0 {
                    break;
                }
                gm_m = V::from_bits(gm);
            }
            let (p0x, p0y, p0z) = vertex(blk, 0, j, k, p);
            let (p1x, p1y, p1z) = vertex(blk, 1, j, k, p);
            let (p2x, p2y, p2z) = vertex(blk, 2, j, k, p);
            let e0 = p1x.mul(p2y).sub(p1y.mul(p2x));
            let e1 = p2x.mul(p0y).sub(p2y.mul(p0x));
            let e2 = p0x.mul(p1y).sub(p0y.mul(p1x));
            let or = V::or;
            let on_edge = V::bits(or(or(e0.eq(zero), e1.eq(zero)), e2.eq(zero))) & gm;
            // edge functions of both signs: outside (by min and max, fewer operations
            // than six compares; a NaN lane may decide otherwise here, but its det
            // is NaN and rejects it below)
            let neg = e0.min(e1).min(e2).lt(zero);
            let pos = e0.max(e1).max(e2).gt(zero);
            let mut reject = V::and(neg, pos);
            // most rays miss most triangles here: skip the rest when all do
            if V::bits(V::andnot(reject, gm_m)) & !on_edge == 0 && on_edge == 0 {
                continue;
            }
            let det = e0.add(e1).add(e2);
            reject = or(reject, det.eq(zero));
            reject = or(reject, det.abs().not_lt(inf));
            let sz = p.s[2];
            let (p0z, p1z, p2z) = (p0z.mul(sz), p1z.mul(sz), p2z.mul(sz));
            let ts = e0.mul(p0z).add(e1.mul(p1z)).add(e2.mul(p2z));
            let tmd = lim.mul(det);
            let det_neg = det.lt(zero);
            let det_pos = det.gt(zero);
            reject = or(reject, V::and(det_neg, or(ts.ge(zero), ts.lt(tmd))));
            reject = or(reject, V::and(det_pos, or(ts.le(zero), ts.gt(tmd))));
            let mut acc = V::andnot(reject, gm_m);
            let mut hits = V::bits(acc) & !on_edge;
            if hits == 0 && on_edge == 0 {
                continue;
            }
            let inv_det = V::splat(1.0).div(det);
            let mut t = ts.mul(inv_det);
            let mut b = [zero; 3];
            if hits != 0 {
                let mut rej = or(t.lt(p.t_min), t.gt(lim));
                // the conservative bound on t
                let max_zt = max3(p0z, p1z, p2z);
                let delta_z = V::splat(gamma(3)).mul(max_zt);
                let max_xt = max3(p0x, p1x, p2x);
                let max_yt = max3(p0y, p1y, p2y);
                let max_z = max_zt.mul(p.dz_abs);
                let delta_x = V::splat(gamma(5)).mul(max_xt.add(max_z));
                let delta_y = V::splat(gamma(5)).mul(max_yt.add(max_z));
                let delta_e = V::splat(2.0).mul(
                    V::splat(gamma(2))
                        .mul(max_xt)
                        .mul(max_yt)
                        .add(delta_y.mul(max_xt))
                        .add(delta_x.mul(max_yt)),
                );
                let max_e = max3(e0, e1, e2);
                let sum = V::splat(gamma(3))
                    .mul(max_e)
                    .mul(max_zt)
                    .add(delta_e.mul(max_zt))
                    .add(delta_z.mul(max_e));
                let delta_t = V::splat(3.0).mul(sum).mul(inv_det.abs());
                rej = or(rej, t.le(delta_t));
                hits &= !V::bits(rej);
                if CLOSEST {
                    b = [e0.mul(inv_det), e1.mul(inv_det), e2.mul(inv_det)];
                }
            }
            if on_edge != 0 {
                edge_rays(blk, j, p, lim, on_edge, &mut hits, &mut t, &mut b);
            }
            if hits == 0 {
                continue;
            }
            acc = V::from_bits(hits);
            if CLOSEST {
                // first hit of a ray, or strictly nearer than its best so far
                let upd = V::andnot(V::andnot(t.lt(best.t), has_m), acc);
                best.t = V::select(upd, t, best.t);
                for a in 0..3 {
                    best.b[a] = V::select(upd, b[a], best.b[a]);
                }
                best.lane = V::select(upd, V::splat(f32::from_bits(j as u32)), best.lane);
                has_m = V::or(has_m, acc);
            }
            best.has |= hits;
        }
    }
    best
}

/// Rays with an exactly-zero edge function for triangle `j`: the scalar kernel
/// decides (in f64), as in the single-ray block tests.
#[cold]
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn edge_rays<V: Simd<N>, const N: usize>(
    blk: &TriBlock,
    j: usize,
    p: &Packet<V, N>,
    lim: V,
    rays: u32,
    hits: &mut u32,
    t: &mut V,
    b: &mut [V; 3],
) {
    let (mut ta, mut ba, mut la) = ([0.0f32; N], [[0.0f32; N]; 3], [0.0f32; N]);
    t.store(&mut ta);
    for a in 0..3 {
        b[a].store(&mut ba[a]);
    }
    lim.store(&mut la);
    let tri = blk.triangle(j);
    for r in each_bit(rays) {
        let ray = &p.rays[r];
        *hits &= !(1 << r);
        if let Some(x) = intersect_watertight(ray.o, ray.d, ray.t_min, la[r], &tri) {
            *hits |= 1 << r;
            ta[r] = x.t;
            for a in 0..3 {
                ba[a][r] = x.b[a];
            }
        }
    }
    *t = V::load(&ta);
    for a in 0..3 {
        b[a] = V::load(&ba[a]);
    }
}

/// A ray's best hit so far, the packet's closest-hit state.
struct Best<V: Simd<N>, const N: usize> {
    found: u32,
    /// Near ties seen: these rays are traced again alone.
    flagged: u32,
    t: V,
    b: [V; 3],
    prim: [u32; N],
    sub: [u32; N],
    /// Culling and test distance per ray: `t_max`, then [`GROW`] × the best hit.
    lim: V,
    t_max: V,
}

impl<V: Simd<N>, const N: usize> Best<V, N> {
    /// Takes candidate hits `t` (rays `has`): a ray's first, or one nearer than its
    /// best by more than [`SHRINK`], is kept; any other flags the ray, as does a
    /// non-finite `t`.
    #[inline(always)]
    fn offer(&mut self, has: u32, t: V, b: &[V; 3]) -> u32 {
        let has_m = V::from_bits(has);
        let found_m = V::from_bits(self.found);
        let bad = t.not_lt(V::splat(f32::INFINITY));
        let near = V::and(found_m, t.not_lt(self.t.mul(V::splat(SHRINK))));
        let flag = V::and(has_m, V::or(bad, near));
        let acc = V::andnot(flag, has_m);
        self.t = V::select(acc, t, self.t);
        for a in 0..3 {
            self.b[a] = V::select(acc, b[a], self.b[a]);
        }
        self.lim = V::select(acc, self.t_max.min(t.mul(V::splat(GROW))), self.lim);
        let acc = V::bits(acc);
        self.found |= acc;
        self.flagged |= V::bits(flag);
        acc
    }
}

/// Closest hits of the packet's valid rays, into lanes `start..start + N` of `out`
/// (`found` set for the rays with one); returns the flagged rays, whose lanes are
/// left for the caller (not found).
#[inline(always)]
pub(super) fn closest_packet<V: Simd<N>, L: Leaves + ?Sized, const N: usize, const S: usize>(
    bvh: &WideBvh,
    prims: &L,
    rays: &[Ray],
    active: u32,
    out: &mut PacketHits,
    start: usize,
) -> u32 {
    // a tree without generic leaves gets its own copy: the spheres' set-up of the rays
    // (directions normalised in f64, divisions and square roots) depends on the rays
    // alone, so the compiler moves it to the entry, where every packet paid for it
    if bvh.generic.is_empty() {
        closest_in::<V, L, N, S, false>(bvh, prims, rays, active, out, start)
    } else {
        closest_in::<V, L, N, S, true>(bvh, prims, rays, active, out, start)
    }
}

/// [`closest_packet`] in a tree with generic leaves (`GENERIC_LEAVES`) or without.
#[inline(always)]
fn closest_in<V: Simd<N>, L: Leaves + ?Sized, const N: usize, const S: usize, const GENERIC_LEAVES: bool>(
    bvh: &WideBvh,
    prims: &L,
    rays: &[Ray],
    active: u32,
    out: &mut PacketHits,
    start: usize,
) -> u32 {
    let p = Packet::<V, N>::new(rays, active);
    let t_max = p.t_max;
    let zero = V::splat(0.0);
    let mut best = Best {
        found: 0,
        flagged: 0,
        t: zero,
        b: [zero; 3],
        prim: [0; N],
        sub: [0; N],
        lim: t_max,
        t_max,
    };
    // stack: child reference, its ray mask and each ray's entry distance
    let mut st_c = [MaybeUninit::<(u32, u32)>::uninit(); S];
    let mut st_t = [MaybeUninit::<[f32; N]>::uninit(); S];
    let mut sp = 0usize;
    let mut cur = 0u32;
    let mut cur_mask = p.valid;
    'walk: loop {
        let alive = p.valid & !best.flagged;
        cur_mask &= alive;
        if cur & LEAF == 0 && cur_mask != 0 {
            let node = &bvh.nodes[cur as usize];
            // children hit by some ray: (order key, child, ray mask), entry distances
            let mut hit: [(f32, u32, u32); WIDTH] = [(0.0, 0, 0); WIDTH];
            let mut t_in = [[0.0f32; N]; WIDTH];
            let mut n = 0;
            // order by the first ray's entry distance (coherent rays mostly agree)
            let rep = cur_mask.trailing_zeros() as usize;
            for i in 0..WIDTH {
                if node.child[i] == EMPTY {
                    continue; // never admitted by a finite ray's box test
                }
                let (t0, t1) = child_slabs(node, i, &p, best.lim);
                let m = V::bits(t0.le(t1)) & cur_mask;
                if m != 0 {
                    t0.store(&mut t_in[n]);
                    hit[n] = (t_in[n][rep], node.child[i], m);
                    n += 1;
                }
            }
            if n == 1 {
                (_, cur, cur_mask) = hit[0];
                continue;
            }
            if n >= 2 {
                // push all but the nearest, farthest deepest
                let mut order: [u8; WIDTH] = std::array::from_fn(|i| i as u8);
                let ord = &mut order[..n];
                ord.sort_unstable_by(|&a, &b| hit[b as usize].0.total_cmp(&hit[a as usize].0));
                for &i in &ord[..n - 1] {
                    let (_, c, m) = hit[i as usize];
                    prefetch(bvh, c);
                    st_c[sp].write((c, m)); // the bounds check: overflow panics here
                    st_t[sp].write(t_in[i as usize]);
                    sp += 1;
                }
                (_, cur, cur_mask) = hit[ord[n - 1] as usize];
                continue;
            }
        } else if cur != EMPTY && cur & LEAF != 0 && cur_mask != 0 {
            let (first, count) = leaf_range(cur);
            if cur & GENERIC != 0 {
                for &pi in generic_leaf::<GENERIC_LEAVES>(bvh, first, count) {
                    // each ray tests the primitive alone; their hits are offered together
                    // (`offer` is lane by lane, and a ray's own limit is read before it
                    // changes)
                    let mut lim = [0.0f32; N];
                    best.lim.store(&mut lim);
                    let (mut has, mut tv, mut bv) = (0u32, [0.0f32; N], [[0.0f32; N]; 3]);
                    let (mut prim, mut sub) = ([0u32; N], [0u32; N]);
                    let live = cur_mask & !best.flagged;
                    if let Some(sphere) = prims.sphere(pi) {
                        // all rays at once (NaN: a miss); a sphere's `b` and `sub` are zero
                        let r = p.rows();
                        let t = sphere.intersect_lanes(&r.o, &r.d, &r.t_min, &lim);
                        for r in each_bit(live).filter(|&r| !t[r].is_nan()) {
                            has |= 1 << r;
                            (tv[r], prim[r]) = (t[r], pi);
                        }
                    } else {
                        for r in each_bit(live) {
                            if let Some(h) = prims.closest(pi, &rays[r], lim[r]) {
                                has |= 1 << r;
                                tv[r] = h.t;
                                for a in 0..3 {
                                    bv[a][r] = h.b[a];
                                }
                                (prim[r], sub[r]) = (h.prim, h.sub);
                            }
                        }
                    }
                    if has != 0 {
                        let b = [V::load(&bv[0]), V::load(&bv[1]), V::load(&bv[2])];
                        let acc = best.offer(has, V::load(&tv), &b);
                        for r in each_bit(acc) {
                            (best.prim[r], best.sub[r]) = (prim[r], sub[r]);
                        }
                    }
                }
            } else {
                for blk in &bvh.blocks[first..first + count] {
                    let m = cur_mask & p.tri_ok & !best.flagged;
                    if m == 0 {
                        break;
                    }
                    let h = block::<V, N, true>(blk, &p, best.lim, m);
                    if h.has != 0 {
                        let acc = best.offer(h.has, h.t, &h.b);
                        let mut lane = [0.0f32; N];
                        h.lane.store(&mut lane);
                        for r in each_bit(acc) {
                            best.prim[r] = blk.prim[lane[r].to_bits() as usize % LANES];
                            best.sub[r] = 0;
                        }
                    }
                }
            }
        }
        // next entry that some live ray still needs (its entry distance within range)
        loop {
            if sp == 0 {
                break 'walk;
            }
            sp -= 1;
            // SAFETY: entries below the old `sp` were written when pushed.
            let (c, m) = unsafe { st_c[sp].assume_init() };
            let m = m & p.valid & !best.flagged;
            if m == 0 {
                continue;
            }
            // SAFETY: as above.
            let t = V::load(unsafe { st_t[sp].assume_init_ref() });
            let m = m & V::bits(t.le(best.lim));
            if m != 0 {
                cur = c;
                cur_mask = m;
                break;
            }
        }
    }
    best.t.store(lanes(&mut out.t, start));
    for a in 0..3 {
        best.b[a].store(lanes(&mut out.b[a], start));
    }
    *lanes(&mut out.prim, start) = best.prim;
    *lanes(&mut out.sub, start) = best.sub;
    // found: valid, unflagged rays with a hit (not the invalid ones, not the flagged)
    let found = best.found & p.valid & !best.flagged;
    out.found = (out.found & !(full::<N>() << start)) | found << start;
    best.flagged
}

/// Any hit of each active ray: the mask of rays with one.
#[inline(always)]
pub(super) fn any_packet<V: Simd<N>, L: Leaves + ?Sized, const N: usize, const S: usize>(
    bvh: &WideBvh,
    prims: &L,
    rays: &[Ray],
    active: u32,
) -> u32 {
    // as in `closest_packet`
    if bvh.generic.is_empty() {
        any_in::<V, L, N, S, false>(bvh, prims, rays, active)
    } else {
        any_in::<V, L, N, S, true>(bvh, prims, rays, active)
    }
}

/// [`any_packet`] in a tree with generic leaves (`GENERIC_LEAVES`) or without.
#[inline(always)]
fn any_in<V: Simd<N>, L: Leaves + ?Sized, const N: usize, const S: usize, const GENERIC_LEAVES: bool>(
    bvh: &WideBvh,
    prims: &L,
    rays: &[Ray],
    active: u32,
) -> u32 {
    let p = Packet::<V, N>::new(rays, active);
    let t_max = p.t_max;
    let mut st = [MaybeUninit::<(u32, u32)>::uninit(); S];
    let mut sp = 0usize;
    let mut cur = 0u32;
    let mut cur_mask = p.valid;
    let mut occluded = 0u32;
    loop {
        cur_mask &= !occluded;
        if cur & LEAF == 0 && cur_mask != 0 {
            let node = &bvh.nodes[cur as usize];
            let mut first = None;
            for i in 0..WIDTH {
                let c = node.child[i];
                if c == EMPTY {
                    continue;
                }
                let (t0, t1) = child_slabs(node, i, &p, t_max);
                let m = V::bits(t0.le(t1)) & cur_mask;
                if m != 0 {
                    if first.is_none() {
                        first = Some((c, m));
                    } else {
                        prefetch(bvh, c);
                        st[sp].write((c, m));
                        sp += 1;
                    }
                }
            }
            if let Some((c, m)) = first {
                (cur, cur_mask) = (c, m);
                continue;
            }
        } else if cur != EMPTY && cur & LEAF != 0 && cur_mask != 0 {
            let (first, count) = leaf_range(cur);
            if cur & GENERIC != 0 {
                for &pi in generic_leaf::<GENERIC_LEAVES>(bvh, first, count) {
                    if let Some(sphere) = prims.sphere(pi) {
                        // all rays at once (NaN: a miss)
                        let r = p.rows();
                        let t = sphere.intersect_lanes(&r.o, &r.d, &r.t_min, &r.t_max);
                        for r in each_bit(cur_mask & !occluded).filter(|&r| !t[r].is_nan()) {
                            occluded |= 1 << r;
                        }
                    } else {
                        for r in each_bit(cur_mask & !occluded) {
                            if prims.any(pi, &rays[r], rays[r].t_max) {
                                occluded |= 1 << r;
                            }
                        }
                    }
                }
            } else {
                for blk in &bvh.blocks[first..first + count] {
                    let m = cur_mask & p.tri_ok & !occluded;
                    if m == 0 {
                        break;
                    }
                    occluded |= block::<V, N, false>(blk, &p, t_max, m).has;
                }
            }
            if occluded == p.valid {
                return occluded;
            }
        }
        loop {
            if sp == 0 {
                return occluded;
            }
            sp -= 1;
            // SAFETY: entries below the old `sp` were written when pushed.
            let (c, m) = unsafe { st[sp].assume_init() };
            let m = m & !occluded;
            if m != 0 {
                (cur, cur_mask) = (c, m);
                break;
            }
        }
    }
}
