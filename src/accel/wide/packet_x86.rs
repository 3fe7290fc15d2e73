//! The x86 lanes of the packet traversal ([`super::packet`]): 8 rays in one AVX2
//! register, 16 in two, or 16 in one AVX-512 register; and the
//! `#[target_feature]` entry points that instantiate the traversal with them.
//!
//! The lane types are private here and named only inside the entry points: their
//! safe methods run AVX2 / AVX-512 instructions, so they must never be reachable
//! from code that has not checked the CPU (the same rule as `x86`'s kernels).
//! `min`/`max` are the instructions' `a < b ? a : b`, as in the single-ray kernels.

use super::packet::{any_packet, closest_packet, ray_rows_by_lane, PacketHits, Simd};
use super::traverse::Leaves;
use super::WideBvh;
use crate::geometry::Ray;
use std::arch::x86_64::*;

/// Entry points: `$closest`/`$any` run the traversal with lanes `$v` of width `$n`
/// in code compiled for `$feat`. Callers must have detected the features at run time
/// (`super::Isa::available`).
macro_rules! entry {
    ($feat:literal, $v:ty, $n:literal, $closest:ident, $any:ident) => {
        #[target_feature(enable = $feat)]
        pub(super) fn $closest<L: Leaves + ?Sized, const S: usize>(
            bvh: &WideBvh,
            prims: &L,
            rays: &[Ray],
            active: u32,
            out: &mut PacketHits,
            start: usize,
        ) -> u32 {
            closest_packet::<$v, L, $n, S>(bvh, prims, rays, active, out, start)
        }
        #[target_feature(enable = $feat)]
        pub(super) fn $any<L: Leaves + ?Sized, const S: usize>(bvh: &WideBvh, prims: &L, rays: &[Ray], active: u32) -> u32 {
            any_packet::<$v, L, $n, S>(bvh, prims, rays, active)
        }
    };
}

entry!("avx2,fma", Y8, 8, closest_avx2_8, any_avx2_8);
entry!("avx2,fma", Y16, 16, closest_avx2_16, any_avx2_16);
entry!("avx2,fma,avx512f,avx512vl", Y8, 8, closest_avx512_8, any_avx512_8);
entry!("avx2,fma,avx512f,avx512vl", Z16, 16, closest_avx512_16, any_avx512_16);

/// Eight lanes in an AVX2 register; masks are all-ones lanes.
#[derive(Clone, Copy)]
struct Y8(__m256);

/// Sixteen lanes in two AVX2 registers.
#[derive(Clone, Copy)]
struct Y16([__m256; 2]);

/// Sixteen lanes in an AVX-512 register; masks are mask registers.
#[derive(Clone, Copy)]
struct Z16(__m512);

// SAFETY (every `unsafe` block in the impls below): the lane types are only
// instantiated inside the entry points above, which enable the instructions
// used (AVX for Y8/Y16, AVX-512F for Z16) and are only called once the CPU is
// known to have them; loads and stores go through references to arrays of
// exactly the lanes' size (unaligned forms).

/// Comparisons of a lane type whose intrinsic `$cmp::<PREDICATE>` gives mask `$m`.
macro_rules! lane_cmp {
    ($m:ty, $cmp:ident; $($name:ident => $pred:ident),*) => {$(
        #[inline(always)]
        fn $name(self, o: Self) -> $m {
            // SAFETY: see above.
            unsafe { $cmp::<$pred>(self.0, o.0) }
        }
    )*};
}

/// Lane-wise binary operations of the lane type `$lanes` (a one-register wrapper).
macro_rules! lane_op {
    ($lanes:ident; $($name:ident => $f:ident),*) => {$(
        #[inline(always)]
        fn $name(self, o: Self) -> Self {
            // SAFETY: see above.
            $lanes(unsafe { $f(self.0, o.0) })
        }
    )*};
}

impl Simd<8> for Y8 {
    type M = __m256;
    #[inline(always)]
    fn ray_rows(rays: &[Ray]) -> [Self; 8] {
        match rays.first_chunk::<8>() {
            Some(r) => Y8::ray_rows8(r).map(Y8),
            None => ray_rows_by_lane(rays),
        }
    }
    lane_op!(Y8; add => _mm256_add_ps, sub => _mm256_sub_ps, mul => _mm256_mul_ps, div => _mm256_div_ps,
           min => _mm256_min_ps, max => _mm256_max_ps);
    lane_cmp!(__m256, _mm256_cmp_ps; lt => _CMP_LT_OQ, le => _CMP_LE_OQ, gt => _CMP_GT_OQ, ge => _CMP_GE_OQ, eq => _CMP_EQ_OQ,
            not_lt => _CMP_NLT_UQ);
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: see above.
        Y8(unsafe { _mm256_set1_ps(x) })
    }
    #[inline(always)]
    fn load(a: &[f32; 8]) -> Self {
        // SAFETY: see above.
        Y8(unsafe { _mm256_loadu_ps(a.as_ptr()) })
    }
    #[inline(always)]
    fn store(self, a: &mut [f32; 8]) {
        // SAFETY: see above.
        unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        // SAFETY: see above.
        Y8(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
    }
    #[inline(always)]
    fn neg(self) -> Self {
        // SAFETY: see above.
        Y8(unsafe { _mm256_xor_ps(_mm256_set1_ps(-0.0), self.0) })
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        // SAFETY: see above.
        Y8(unsafe {
            let s = _mm256_set1_ps(-0.0);
            _mm256_or_ps(_mm256_andnot_ps(s, self.0), _mm256_and_ps(s, sign.0))
        })
    }
    #[inline(always)]
    fn select(m: __m256, a: Self, b: Self) -> Self {
        // SAFETY: see above.
        Y8(unsafe { _mm256_blendv_ps(b.0, a.0, m) })
    }
    #[inline(always)]
    fn and(a: __m256, b: __m256) -> __m256 {
        // SAFETY: see above.
        unsafe { _mm256_and_ps(a, b) }
    }
    #[inline(always)]
    fn or(a: __m256, b: __m256) -> __m256 {
        // SAFETY: see above.
        unsafe { _mm256_or_ps(a, b) }
    }
    #[inline(always)]
    fn andnot(a: __m256, b: __m256) -> __m256 {
        // SAFETY: see above.
        unsafe { _mm256_andnot_ps(a, b) }
    }
    #[inline(always)]
    fn bits(m: __m256) -> u32 {
        // SAFETY: see above.
        unsafe { _mm256_movemask_ps(m) as u32 }
    }
    #[inline(always)]
    fn from_bits(b: u32) -> __m256 {
        // SAFETY: see above.
        unsafe {
            let lane = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let m = _mm256_and_si256(_mm256_set1_epi32(b as i32), lane);
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(m, lane))
        }
    }
}

impl Y8 {
    /// The rows of eight rays (a transpose of their eight numbers each, in registers).
    #[inline(always)]
    fn ray_rows8(rays: &[Ray; 8]) -> [__m256; 8] {
        // SAFETY: `Ray` is `repr(C)`: glam's `Vec3` (`repr(C)`, three `f32`) twice,
        // then two `f32`, 32 bytes without padding (checked below), which is
        // `ray_row`'s order; the unaligned load reads exactly one live `Ray`.
        const _: () = assert!(std::mem::size_of::<Ray>() == 32);
        let r: [__m256; 8] = std::array::from_fn(|i| unsafe { _mm256_loadu_ps((&rays[i] as *const Ray).cast::<f32>()) });
        // SAFETY: see above.
        unsafe {
            let (t0, t1) = (_mm256_unpacklo_ps(r[0], r[1]), _mm256_unpackhi_ps(r[0], r[1]));
            let (t2, t3) = (_mm256_unpacklo_ps(r[2], r[3]), _mm256_unpackhi_ps(r[2], r[3]));
            let (t4, t5) = (_mm256_unpacklo_ps(r[4], r[5]), _mm256_unpackhi_ps(r[4], r[5]));
            let (t6, t7) = (_mm256_unpacklo_ps(r[6], r[7]), _mm256_unpackhi_ps(r[6], r[7]));
            // numbers k and k + 4 of rays 0–3 (s0–s3) and of rays 4–7 (s4–s7)
            let (s0, s1) = (_mm256_shuffle_ps::<0x44>(t0, t2), _mm256_shuffle_ps::<0xee>(t0, t2));
            let (s2, s3) = (_mm256_shuffle_ps::<0x44>(t1, t3), _mm256_shuffle_ps::<0xee>(t1, t3));
            let (s4, s5) = (_mm256_shuffle_ps::<0x44>(t4, t6), _mm256_shuffle_ps::<0xee>(t4, t6));
            let (s6, s7) = (_mm256_shuffle_ps::<0x44>(t5, t7), _mm256_shuffle_ps::<0xee>(t5, t7));
            [
                _mm256_permute2f128_ps::<0x20>(s0, s4),
                _mm256_permute2f128_ps::<0x20>(s1, s5),
                _mm256_permute2f128_ps::<0x20>(s2, s6),
                _mm256_permute2f128_ps::<0x20>(s3, s7),
                _mm256_permute2f128_ps::<0x31>(s0, s4),
                _mm256_permute2f128_ps::<0x31>(s1, s5),
                _mm256_permute2f128_ps::<0x31>(s2, s6),
                _mm256_permute2f128_ps::<0x31>(s3, s7),
            ]
        }
    }
}

/// Both halves of a [`Y16`] through [`Y8`].
macro_rules! y16_op {
    ($($name:ident),*) => {$(
        #[inline(always)]
        fn $name(self, o: Self) -> Self {
            Y16([Y8(self.0[0]).$name(Y8(o.0[0])).0, Y8(self.0[1]).$name(Y8(o.0[1])).0])
        }
    )*};
}
macro_rules! y16_cmp {
    ($($name:ident),*) => {$(
        #[inline(always)]
        fn $name(self, o: Self) -> [__m256; 2] {
            [Y8(self.0[0]).$name(Y8(o.0[0])), Y8(self.0[1]).$name(Y8(o.0[1]))]
        }
    )*};
}
macro_rules! y16_mask {
    ($($name:ident),*) => {$(
        #[inline(always)]
        fn $name(a: [__m256; 2], b: [__m256; 2]) -> [__m256; 2] {
            [Y8::$name(a[0], b[0]), Y8::$name(a[1], b[1])]
        }
    )*};
}

impl Simd<16> for Y16 {
    type M = [__m256; 2];
    #[inline(always)]
    fn ray_rows(rays: &[Ray]) -> [Self; 8] {
        match rays.first_chunk::<16>() {
            Some(r) => {
                let (lo, hi) = (Y8::ray_rows8(r[..8].try_into().unwrap()), Y8::ray_rows8(r[8..].try_into().unwrap()));
                std::array::from_fn(|k| Y16([lo[k], hi[k]]))
            }
            None => ray_rows_by_lane(rays),
        }
    }
    y16_op!(add, sub, mul, div, min, max);
    y16_cmp!(lt, le, gt, ge, eq, not_lt);
    y16_mask!(and, or, andnot);
    #[inline(always)]
    fn splat(x: f32) -> Self {
        let h = Y8::splat(x).0;
        Y16([h, h])
    }
    #[inline(always)]
    fn load(a: &[f32; 16]) -> Self {
        let (lo, hi) = a.split_at(8);
        Y16([Y8::load(lo.try_into().unwrap()).0, Y8::load(hi.try_into().unwrap()).0])
    }
    #[inline(always)]
    fn store(self, a: &mut [f32; 16]) {
        let (lo, hi) = a.split_at_mut(8);
        Y8(self.0[0]).store(lo.try_into().unwrap());
        Y8(self.0[1]).store(hi.try_into().unwrap());
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Y16([Y8(self.0[0]).abs().0, Y8(self.0[1]).abs().0])
    }
    #[inline(always)]
    fn neg(self) -> Self {
        Y16([Y8(self.0[0]).neg().0, Y8(self.0[1]).neg().0])
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        Y16([Y8(self.0[0]).copysign(Y8(sign.0[0])).0, Y8(self.0[1]).copysign(Y8(sign.0[1])).0])
    }
    #[inline(always)]
    fn select(m: [__m256; 2], a: Self, b: Self) -> Self {
        Y16([
            Y8::select(m[0], Y8(a.0[0]), Y8(b.0[0])).0,
            Y8::select(m[1], Y8(a.0[1]), Y8(b.0[1])).0,
        ])
    }
    #[inline(always)]
    fn bits(m: [__m256; 2]) -> u32 {
        Y8::bits(m[0]) | Y8::bits(m[1]) << 8
    }
    #[inline(always)]
    fn from_bits(b: u32) -> [__m256; 2] {
        [Y8::from_bits(b & 0xff), Y8::from_bits(b >> 8 & 0xff)]
    }
}

impl Simd<16> for Z16 {
    type M = __mmask16;
    lane_op!(Z16; add => _mm512_add_ps, sub => _mm512_sub_ps, mul => _mm512_mul_ps, div => _mm512_div_ps,
            min => _mm512_min_ps, max => _mm512_max_ps);
    lane_cmp!(__mmask16, _mm512_cmp_ps_mask; lt => _CMP_LT_OQ, le => _CMP_LE_OQ, gt => _CMP_GT_OQ, ge => _CMP_GE_OQ, eq => _CMP_EQ_OQ,
             not_lt => _CMP_NLT_UQ);
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: see above.
        Z16(unsafe { _mm512_set1_ps(x) })
    }
    #[inline(always)]
    fn load(a: &[f32; 16]) -> Self {
        // SAFETY: see above.
        Z16(unsafe { _mm512_loadu_ps(a.as_ptr()) })
    }
    #[inline(always)]
    fn store(self, a: &mut [f32; 16]) {
        // SAFETY: see above.
        unsafe { _mm512_storeu_ps(a.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        // SAFETY: see above.
        Z16(unsafe { _mm512_abs_ps(self.0) })
    }
    #[inline(always)]
    fn neg(self) -> Self {
        // SAFETY: see above (integer forms: float xor is AVX-512DQ).
        Z16(unsafe { _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(self.0), _mm512_set1_epi32(i32::MIN))) })
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        // SAFETY: as in `neg`.
        Z16(unsafe {
            let (m, s) = (_mm512_castps_si512(self.0), _mm512_castps_si512(sign.0));
            let bit = _mm512_set1_epi32(i32::MIN);
            _mm512_castsi512_ps(_mm512_or_si512(_mm512_andnot_si512(bit, m), _mm512_and_si512(bit, s)))
        })
    }
    #[inline(always)]
    fn select(m: __mmask16, a: Self, b: Self) -> Self {
        // SAFETY: see above.
        Z16(unsafe { _mm512_mask_blend_ps(m, b.0, a.0) })
    }
    #[inline(always)]
    fn and(a: __mmask16, b: __mmask16) -> __mmask16 {
        a & b
    }
    #[inline(always)]
    fn or(a: __mmask16, b: __mmask16) -> __mmask16 {
        a | b
    }
    #[inline(always)]
    fn andnot(a: __mmask16, b: __mmask16) -> __mmask16 {
        !a & b
    }
    #[inline(always)]
    fn bits(m: __mmask16) -> u32 {
        m as u32
    }
    #[inline(always)]
    fn from_bits(b: u32) -> __mmask16 {
        b as __mmask16
    }
}
