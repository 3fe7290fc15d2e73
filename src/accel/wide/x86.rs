//! The x86 kernels: AVX2+FMA and AVX-512 (F+VL) entry points of the traversal,
//! their node tests and the 8-lane triangle block test.
//!
//! The instruction set ([`super::Isa`]) is picked at run time with
//! `is_x86_feature_detected!`: AVX-512 (the node test's hit mask straight from a
//! mask compare), AVX2+FMA, or portable Rust (scalar kernel per lane); the portable
//! one runs everywhere and can be forced with [`super::WideBvh::set_isa`] (the tests
//! run every variant the machine has).
//!
//! The block test is the watertight kernel [`intersect_watertight`] evaluated on
//! eight lanes with the same operations in the same order (no FMA contraction), so
//! its hits, distances and barycentrics are bit-identical to the scalar kernel;
//! lanes with an edge function exactly zero go through the scalar kernel (which
//! decides them in f64).

use super::node::{TriBlock, WideNode, LANES, WIDTH};
use super::traverse::{any, closest, BlockHits, Kernel, Leaves, RayData, FAR_SCALE};
use super::WideBvh;
use crate::geometry::prim::Hit;
use crate::geometry::triangle::intersect_watertight;
use crate::geometry::Ray;
use crate::math::gamma;
use std::arch::x86_64::*;

// The entry points: the generic traversal instantiated with an AVX kernel
// inside a function that enables its instruction set, so the kernel inlines
// into code compiled for it. Callers must have detected the features at run
// time (`super::Isa::available`).

#[target_feature(enable = "avx2,fma")]
pub(super) fn closest_avx2<L: Leaves + ?Sized, const S: usize>(bvh: &WideBvh, prims: &L, ray: &Ray) -> Option<Hit> {
    closest::<Avx2, L, S>(bvh, prims, ray)
}
#[target_feature(enable = "avx2,fma")]
pub(super) fn any_avx2<L: Leaves + ?Sized, const S: usize>(bvh: &WideBvh, prims: &L, ray: &Ray) -> bool {
    any::<Avx2, L, S>(bvh, prims, ray)
}
#[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
pub(super) fn closest_avx512<L: Leaves + ?Sized, const S: usize>(bvh: &WideBvh, prims: &L, ray: &Ray) -> Option<Hit> {
    closest::<Avx512, L, S>(bvh, prims, ray)
}
#[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
pub(super) fn any_avx512<L: Leaves + ?Sized, const S: usize>(bvh: &WideBvh, prims: &L, ray: &Ray) -> bool {
    any::<Avx512, L, S>(bvh, prims, ray)
}

/// The AVX2+FMA kernels. Private to this module and named only in
/// `closest_avx2` and `any_avx2`: its safe methods call `#[target_feature]`
/// code, so it must never be reachable from anywhere else.
struct Avx2;

impl Kernel for Avx2 {
    #[inline(always)]
    fn node(n: &WideNode, r: &RayData, t_max: f32) -> (u32, [f32; WIDTH]) {
        // SAFETY: `Avx2` is only instantiated inside `closest_avx2`/`any_avx2`,
        // which enable avx2,fma and are only called once the CPU is known to
        // have them (runtime detection, `Isa::available`).
        unsafe { node_avx2(n, r, t_max) }
    }

    #[inline(always)]
    fn block(b: &TriBlock, r: &RayData, t_max: f32) -> BlockHits {
        // SAFETY: as in `node`.
        unsafe { block_avx(b, r, t_max) }
    }
}

/// The AVX-512 (F+VL) kernels: the AVX2 block test and a node test taking its
/// hit mask straight from a mask compare. Private to this module and named
/// only in `closest_avx512` and `any_avx512`, as [`Avx2`].
struct Avx512;

impl Kernel for Avx512 {
    #[inline(always)]
    fn node(n: &WideNode, r: &RayData, t_max: f32) -> (u32, [f32; WIDTH]) {
        // SAFETY: `Avx512` is only instantiated inside `closest_avx512`/
        // `any_avx512`, which enable avx2,fma,avx512f,avx512vl and are only
        // called once the CPU is known to have them (runtime detection,
        // `Isa::available`).
        unsafe { node_avx512(n, r, t_max) }
    }

    #[inline(always)]
    fn block(b: &TriBlock, r: &RayData, t_max: f32) -> BlockHits {
        // SAFETY: as in `node`; the features include avx2,fma, which
        // `block_avx` needs.
        unsafe { block_avx(b, r, t_max) }
    }
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
    // RN(min(f0, f1, f2)·s) = min(RN(f0·s), RN(f1·s), RN(f2·s)) for s > 0 (rounding is
    // monotonic), so scaling each axis first gives the scalar test's value bit for bit
    // with a dependency chain two operations shorter
    let s = _mm256_set1_ps(FAR_SCALE);
    let far = |a: usize| _mm256_mul_ps(far(a), s);
    let t1 = _mm256_min_ps(_mm256_min_ps(far(0), far(1)), _mm256_min_ps(far(2), _mm256_set1_ps(t_max)));
    (t0, t1)
}

#[target_feature(enable = "avx2,fma")]
#[inline]
fn node_avx2(n: &WideNode, r: &RayData, t_max: f32) -> (u32, [f32; WIDTH]) {
    let (t0, t1) = slabs(n, r, t_max);
    let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32;
    let mut d = [0.0f32; WIDTH];
    // SAFETY: `d` is 8 writable f32s; the store is unaligned.
    unsafe { _mm256_storeu_ps(d.as_mut_ptr(), t0) };
    (mask, d)
}

#[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
#[inline]
fn node_avx512(n: &WideNode, r: &RayData, t_max: f32) -> (u32, [f32; WIDTH]) {
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
///
/// Inlined (not a `#[target_feature]` function, which the compiler left as a call:
/// the call spilled every ray constant around each block test) into the entry
/// points, whose features its intrinsics then inline under. The body uses macros,
/// not closures: a closure is a function of its own without the target features,
/// so the intrinsics inside it would stay calls (2.5× slower traversal).
///
/// # Safety
///
/// The CPU must have AVX2 and FMA (the callers, `Avx2` and `Avx512`, only run
/// inside entry points called after run-time detection).
#[inline(always)]
unsafe fn block_avx(blk: &TriBlock, r: &RayData, t_max: f32) -> BlockHits {
    let [kx, ky, kz] = r.k;
    macro_rules! set {
        ($x:expr) => {
            _mm256_set1_ps($x)
        };
    }
    macro_rules! abs {
        ($v:expr) => {
            _mm256_andnot_ps(_mm256_set1_ps(-0.0), $v)
        };
    }
    // SAFETY (every use): each row is 8 f32s, 32-byte aligned (TriBlock is
    // `repr(align(32))` and every row is 32 bytes).
    macro_rules! ld {
        ($a:expr) => {
            _mm256_load_ps(($a).as_ptr())
        };
    }
    macro_rules! cmp {
        ($op:ident, $a:expr, $b:expr) => {
            _mm256_cmp_ps::<$op>($a, $b)
        };
    }
    macro_rules! or {
        ($a:expr, $b:expr) => {
            _mm256_or_ps($a, $b)
        };
    }
    macro_rules! max3 {
        ($a:expr, $b:expr, $c:expr) => {
            _mm256_max_ps(_mm256_max_ps(abs!($a), abs!($b)), abs!($c))
        };
    }
    let zero = _mm256_setzero_ps();
    // vertices relative to the origin, permuted, sheared
    macro_rules! vert {
        ($k:expr) => {{
            // SAFETY: k < 3 and kx, ky, kz < 3 (a permutation of the axes).
            let v = blk.v.get_unchecked($k);
            let (x, y, z) = (v.get_unchecked(kx), v.get_unchecked(ky), v.get_unchecked(kz));
            let x = _mm256_sub_ps(ld!(x), set!(r.op[0]));
            let y = _mm256_sub_ps(ld!(y), set!(r.op[1]));
            let z = _mm256_sub_ps(ld!(z), set!(r.op[2]));
            let x = _mm256_add_ps(x, _mm256_mul_ps(set!(r.s[0]), z));
            let y = _mm256_add_ps(y, _mm256_mul_ps(set!(r.s[1]), z));
            (x, y, z)
        }};
    }
    let (p0x, p0y, p0z) = vert!(0);
    let (p1x, p1y, p1z) = vert!(1);
    let (p2x, p2y, p2z) = vert!(2);
    let e0 = _mm256_sub_ps(_mm256_mul_ps(p1x, p2y), _mm256_mul_ps(p1y, p2x));
    let e1 = _mm256_sub_ps(_mm256_mul_ps(p2x, p0y), _mm256_mul_ps(p2y, p0x));
    let e2 = _mm256_sub_ps(_mm256_mul_ps(p0x, p1y), _mm256_mul_ps(p0y, p1x));
    // lanes with an edge function exactly zero: the scalar kernel (f64) decides
    let on_edge = _mm256_movemask_ps(or!(
        or!(cmp!(_CMP_EQ_OQ, e0, zero), cmp!(_CMP_EQ_OQ, e1, zero)),
        cmp!(_CMP_EQ_OQ, e2, zero)
    )) as u32;
    let neg = or!(
        or!(cmp!(_CMP_LT_OS, e0, zero), cmp!(_CMP_LT_OS, e1, zero)),
        cmp!(_CMP_LT_OS, e2, zero)
    );
    let pos = or!(
        or!(cmp!(_CMP_GT_OS, e0, zero), cmp!(_CMP_GT_OS, e1, zero)),
        cmp!(_CMP_GT_OS, e2, zero)
    );
    let mut reject = _mm256_and_ps(neg, pos);
    let det = _mm256_add_ps(_mm256_add_ps(e0, e1), e2);
    // det == 0 or not finite (NaN: "not less than" is true when unordered)
    reject = or!(reject, cmp!(_CMP_EQ_OQ, det, zero));
    reject = or!(reject, cmp!(_CMP_NLT_US, abs!(det), set!(f32::INFINITY)));
    let sz = set!(r.s[2]);
    let (p0z, p1z, p2z) = (_mm256_mul_ps(p0z, sz), _mm256_mul_ps(p1z, sz), _mm256_mul_ps(p2z, sz));
    let ts = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(e0, p0z), _mm256_mul_ps(e1, p1z)),
        _mm256_mul_ps(e2, p2z),
    );
    let tmd = _mm256_mul_ps(set!(t_max), det);
    let det_neg = cmp!(_CMP_LT_OS, det, zero);
    let det_pos = cmp!(_CMP_GT_OS, det, zero);
    reject = or!(
        reject,
        _mm256_and_ps(det_neg, or!(cmp!(_CMP_GE_OS, ts, zero), cmp!(_CMP_LT_OS, ts, tmd)))
    );
    reject = or!(
        reject,
        _mm256_and_ps(det_pos, or!(cmp!(_CMP_LE_OS, ts, zero), cmp!(_CMP_GT_OS, ts, tmd)))
    );
    let mut mask = !(_mm256_movemask_ps(reject) as u32) & 0xff & !on_edge;
    let mut h = BlockHits {
        mask: 0,
        t: [0.0; LANES],
        b: [[0.0; LANES]; 3],
    };
    if mask != 0 {
        let inv_det = _mm256_div_ps(set!(1.0), det);
        let t = _mm256_mul_ps(ts, inv_det);
        let mut rej = or!(cmp!(_CMP_LT_OS, t, set!(r.t_min)), cmp!(_CMP_GT_OS, t, set!(t_max)));
        // the conservative bound on t
        let max_zt = max3!(p0z, p1z, p2z);
        let delta_z = _mm256_mul_ps(set!(gamma(3)), max_zt);
        let max_xt = max3!(p0x, p1x, p2x);
        let max_yt = max3!(p0y, p1y, p2y);
        let max_z = _mm256_mul_ps(max_zt, set!(r.dz_abs));
        let delta_x = _mm256_mul_ps(set!(gamma(5)), _mm256_add_ps(max_xt, max_z));
        let delta_y = _mm256_mul_ps(set!(gamma(5)), _mm256_add_ps(max_yt, max_z));
        let delta_e = _mm256_mul_ps(
            set!(2.0),
            _mm256_add_ps(
                _mm256_add_ps(
                    _mm256_mul_ps(_mm256_mul_ps(set!(gamma(2)), max_xt), max_yt),
                    _mm256_mul_ps(delta_y, max_xt),
                ),
                _mm256_mul_ps(delta_x, max_yt),
            ),
        );
        let max_e = max3!(e0, e1, e2);
        let sum = _mm256_add_ps(
            _mm256_add_ps(
                _mm256_mul_ps(_mm256_mul_ps(set!(gamma(3)), max_e), max_zt),
                _mm256_mul_ps(delta_e, max_zt),
            ),
            _mm256_mul_ps(delta_z, max_e),
        );
        let delta_t = _mm256_mul_ps(_mm256_mul_ps(set!(3.0), sum), abs!(inv_det));
        rej = or!(rej, cmp!(_CMP_LE_OS, t, delta_t));
        mask &= !(_mm256_movemask_ps(rej) as u32);
        if mask != 0 {
            h.mask = mask;
            // SAFETY: each destination is 8 writable f32s; the stores are unaligned.
            _mm256_storeu_ps(h.t.as_mut_ptr(), t);
            _mm256_storeu_ps(h.b[0].as_mut_ptr(), _mm256_mul_ps(e0, inv_det));
            _mm256_storeu_ps(h.b[1].as_mut_ptr(), _mm256_mul_ps(e1, inv_det));
            _mm256_storeu_ps(h.b[2].as_mut_ptr(), _mm256_mul_ps(e2, inv_det));
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
