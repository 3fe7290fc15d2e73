//! Small numeric helpers shared by the whole renderer.
//!
//! Vectors are glam's `Vec3` (f32). Where the RDR171 profile needs a particular
//! f32 evaluation order the helper here spells it out (glam's `normalize`
//! multiplies by a reciprocal, the original divides).

pub use glam::{DVec3, Mat4, Vec2, Vec3, Vec4};

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const INV_4PI: f32 = 1.0 / (4.0 * std::f32::consts::PI);

/// `v / |v|` as three divisions (the original's order; bit-exact for `--compat`).
#[inline]
pub fn normalize_div(v: Vec3) -> Vec3 {
    let len = v.dot(v).sqrt();
    Vec3::new(v.x / len, v.y / len, v.z / len)
}

/// pbrt's γ(n): a bound on the relative rounding error of n f32 operations.
#[inline]
pub const fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5;
    (n as f32 * e) / (1.0 - n as f32 * e)
}

/// Row-major 16 numbers (JSON order) to a glam column-major matrix.
pub fn mat4_from_row_major(m: &[f32; 16]) -> Mat4 {
    Mat4::from_cols_array(m).transpose()
}

/// `M · (v, 1)` accumulated column by column, then divided by w (spec §0, §10.1).
#[inline]
pub fn transform_point(m: &Mat4, v: Vec3) -> Vec3 {
    let h = ((m.x_axis * v.x + m.y_axis * v.y) + m.z_axis * v.z) + m.w_axis;
    Vec3::new(h.x / h.w, h.y / h.w, h.z / h.w)
}

/// `M · (v, 0)`, xyz.
#[inline]
pub fn transform_vector(m: &Mat4, v: Vec3) -> Vec3 {
    let h = (m.x_axis * v.x + m.y_axis * v.y) + m.z_axis * v.z;
    h.truncate()
}

/// An orthonormal basis around `n` (Duff et al. 2017, branchless).
#[inline]
pub fn coordinate_system(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Local shading frame with `z` as the normal axis.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let (s, t) = coordinate_system(n);
        Frame { s, t, n }
    }
    /// The frame around `n` whose first tangent is `tangent` made orthogonal to it
    /// (Gram–Schmidt), as Mitsuba builds a shading frame from `∂p/∂u`; `t = n × s`.
    /// [`Frame::from_normal`] where `tangent` is parallel to `n`.
    pub fn with_tangent(n: Vec3, tangent: Vec3) -> Self {
        let s = tangent - n * n.dot(tangent);
        let l2 = s.length_squared();
        if !(l2 > 0.0 && l2.is_finite()) {
            return Frame::from_normal(n);
        }
        let s = s / l2.sqrt();
        Frame { s, t: n.cross(s), n }
    }
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Reflect `wo` about `n` (both pointing away from the surface).
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    -wo + 2.0 * wo.dot(n) * n
}

/// Refract `wi` (pointing away from the surface, on `n`'s side) with the ratio
/// `eta = sinθt / sinθi`. `None` on total internal reflection. Spec §14.6.
#[inline]
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let c = n.dot(wi);
    let s2 = (1.0 - c * c).max(0.0);
    let s2t = eta * eta * s2;
    if s2t >= 1.0 {
        return None;
    }
    let ct = (1.0 - s2t).sqrt();
    Some(normalize_div(eta * -wi + (eta * c - ct) * n))
}

/// Move a point off a surface along `n` (Wächter & Binder, Ray Tracing Gems ch. 6):
/// integer ULP steps away from the origin, a fixed float step near it. On x86-64 the
/// three axes go through SSE2 lanes without branches (every bounce and shadow ray makes
/// one to three of these, and the branches on signs and magnitudes go either way at
/// random); the result is [`offset_ray_origin_scalar`]'s bit for bit.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: SSE2 is part of the x86-64 baseline, so every x86-64 CPU has it
        // (`tests::offset_ray_origin_lanes_match_the_scalar_formula_bit_for_bit`).
        unsafe { offset_ray_origin_sse2(p, n) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        offset_ray_origin_scalar(p, n)
    }
}

const OFFSET_ORIGIN: f32 = 1.0 / 32.0;
const OFFSET_FLOAT_SCALE: f32 = 1.0 / 65536.0;
const OFFSET_INT_SCALE: f32 = 256.0;

/// [`offset_ray_origin`] axis by axis, as written in the chapter.
#[inline]
pub fn offset_ray_origin_scalar(p: Vec3, n: Vec3) -> Vec3 {
    Vec3::new(
        offset_coordinate(p.x, n.x),
        offset_coordinate(p.y, n.y),
        offset_coordinate(p.z, n.z),
    )
}

/// One coordinate of [`offset_ray_origin_scalar`]: `p` pushed along the normal's
/// coordinate `n`.
#[inline(always)]
pub fn offset_coordinate(p: f32, n: f32) -> f32 {
    let of = (OFFSET_INT_SCALE * n) as i32;
    let stepped = f32::from_bits((p.to_bits() as i32).wrapping_add(if p < 0.0 { of.wrapping_neg() } else { of }) as u32);
    if p.abs() < OFFSET_ORIGIN {
        p + OFFSET_FLOAT_SCALE * n
    } else {
        stepped
    }
}

/// [`offset_ray_origin_scalar`] in the lanes of one SSE2 register.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse2")]
#[inline]
fn offset_ray_origin_sse2(p: Vec3, n: Vec3) -> Vec3 {
    use std::arch::x86_64::*;
    let r = offset_lanes_sse2(_mm_setr_ps(p.x, p.y, p.z, 0.0), _mm_setr_ps(n.x, n.y, n.z, 0.0));
    let mut out = [0.0f32; 4];
    // SAFETY: `out` is four writable f32s; the store is unaligned.
    unsafe { _mm_storeu_ps(out.as_mut_ptr(), r) };
    Vec3::new(out[0], out[1], out[2])
}

/// [`offset_coordinate`] of four lanes: `as i32`'s saturation and NaN → 0 made
/// explicit around `cvttps2dq` (which gives `i32::MIN` for both).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse2")]
#[inline]
fn offset_lanes_sse2(pv: std::arch::x86_64::__m128, nv: std::arch::x86_64::__m128) -> std::arch::x86_64::__m128 {
    use std::arch::x86_64::*;
    let scaled = _mm_mul_ps(nv, _mm_set1_ps(OFFSET_INT_SCALE));
    let of = _mm_cvttps_epi32(scaled);
    // ≥ 2³¹: i32::MAX (MIN xor all ones); NaN: 0
    let of = _mm_xor_si128(of, _mm_castps_si128(_mm_cmpge_ps(scaled, _mm_set1_ps(2_147_483_648.0))));
    let of = _mm_and_si128(of, _mm_castps_si128(_mm_cmpord_ps(scaled, scaled)));
    // −of where p < 0 (not for −0.0): (of xor −1) − (−1)
    let neg = _mm_castps_si128(_mm_cmplt_ps(pv, _mm_setzero_ps()));
    let step = _mm_sub_epi32(_mm_xor_si128(of, neg), neg);
    let stepped = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(pv), step));
    let abs = _mm_and_ps(pv, _mm_castsi128_ps(_mm_set1_epi32(0x7fff_ffff)));
    let small = _mm_cmplt_ps(abs, _mm_set1_ps(OFFSET_ORIGIN));
    let nudged = _mm_add_ps(pv, _mm_mul_ps(_mm_set1_ps(OFFSET_FLOAT_SCALE), nv));
    _mm_or_ps(_mm_and_ps(small, nudged), _mm_andnot_ps(small, stepped))
}

/// [`offset_coordinate`] of every lane: `out[i]` is `p[i]` pushed along `n[i]`.
/// Four lanes at a time through SSE2 on x86-64 (Rust's saturating `as i32` does
/// not vectorize), bit for bit the scalar formula.
#[inline(always)]
pub fn offset_coordinates<const L: usize>(p: &[f32; L], n: &[f32; L], out: &mut [f32; L]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        let (pc, nc, oc) = (p.chunks_exact(4), n.chunks_exact(4), out.chunks_exact_mut(4));
        for ((p4, n4), o4) in pc.zip(nc).zip(oc) {
            // SAFETY: each chunk is four f32s (`chunks_exact`); loads and store are
            // unaligned; SSE2 is part of the x86-64 baseline
            // (`tests::offset_ray_origin_lanes_match_the_scalar_formula_bit_for_bit`).
            unsafe {
                let r = offset_lanes_sse2(_mm_loadu_ps(p4.as_ptr()), _mm_loadu_ps(n4.as_ptr()));
                _mm_storeu_ps(o4.as_mut_ptr(), r);
            }
        }
        for i in L / 4 * 4..L {
            out[i] = offset_coordinate(p[i], n[i]);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    for i in 0..L {
        out[i] = offset_coordinate(p[i], n[i]);
    }
}

/// `x.is_finite()` as `x − x = 0` (NaN for ±∞ and NaN), for loops over lanes: it
/// compiles to vector compares, where `is_finite` became scalar bit tests per lane.
#[allow(clippy::eq_op)]
#[inline(always)]
pub fn is_finite_lane(x: f32) -> bool {
    x - x == 0.0
}

/// Luminance of linear sRGB/Rec.709 primaries.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// `x.floor()`, bit for bit (signed zeros, NaN, infinities included), without a
/// call: the baseline x86-64 target has no rounding instruction, so `f32::floor`
/// is a library call. Below 2²³ in magnitude a float truncates exactly through
/// `i32`; from there on every float is an integer. Without branches (a select), so
/// that loops over lanes vectorize.
#[inline(always)]
pub fn floor_f32(x: f32) -> f32 {
    // `as` saturates: a truncation that is unused when |x| ≥ 2²³ (or NaN)
    let t = x as i32 as f32;
    // truncation rounds towards zero: one down for negative non-integers, and
    // otherwise the sign of a zero kept (−0.0 and −0.3 truncate to +0.0 and −1 …)
    let below = select(t > x, t - 1.0, t.copysign(x));
    select(x.abs() < 8_388_608.0, below, x)
}

/// `atan2(y, x)` in radians, within 2·10⁻⁷ of the exact angle, inlined without a
/// library call (the polynomial of [`atan_unit`] after folding the angle into the
/// first octant). NaN in, NaN out; two infinities give NaN (libm: a multiple of π/4).
/// Without branches (every case computed, then selected), so that loops over lanes
/// vectorize: the sky's coordinates of a block's rays are taken together.
#[inline(always)]
pub fn atan2_poly(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    // both zero: the angle 0, as libm gives for atan2(±0, +0)
    let s = select(hi > 0.0, lo / hi, lo);
    let a = atan_unit(s);
    // the octant's angle ± a; the constants in two parts (f32 value + rounding error)
    const HALF: (f32, f32) = (std::f32::consts::FRAC_PI_2, -4.371_139e-8);
    const FULL: (f32, f32) = (PI, -8.742_278e-8);
    let (steep, left) = (ay > ax, x.is_sign_negative());
    let steep_angle = select(left, (HALF.1 + a) + HALF.0, (HALF.1 - a) + HALF.0);
    let flat_angle = select(left, (FULL.1 - a) + FULL.0, a);
    let a = select(steep, steep_angle, flat_angle).copysign(y);
    // min and max above drop a NaN
    select(x.is_nan() || y.is_nan(), f32::NAN, a)
}

/// `e^x` within 2 ulp (relative 2.4·10⁻⁷) for x in [−87, 88], clamped to that range
/// (below it, e^−87 ≈ 1.6·10⁻³⁸ rather than 0), inlined without a library call: `x = k·ln 2 + r` with
/// |r| ≤ ln 2 / 2 (Cody and Waite: `k·HI` is exact), `e^r` by its degree-7 Taylor
/// polynomial (truncation 5·10⁻⁹), scaled by 2^k through the exponent bits. Float and
/// integer lane operations only (no branch, no saturating conversion), so that loops
/// over lanes vectorize (a film filter's weights).
#[inline(always)]
pub fn exp_poly(x: f32) -> f32 {
    const HI: f32 = 0.693_359_4; // 355/512 exactly, so k·HI is exact
    const LO: f32 = -2.121_944_4e-4;
    // 1.5·2²³: adding it rounds to the nearest integer, which lands in the low bits
    const ROUND: f32 = 12_582_912.0;
    let x = x.clamp(-87.0, 88.0);
    let shifted = x * std::f32::consts::LOG2_E + ROUND;
    let k = shifted - ROUND;
    let r = (x - k * HI) - k * LO;
    let mut p = 1.0 / 5040.0;
    for c in [1.0 / 720.0, 1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0] {
        p = p * r + c;
    }
    let k = shifted.to_bits().wrapping_sub(ROUND.to_bits());
    p * f32::from_bits(k.wrapping_add(127) << 23)
}

/// `if c { a } else { b }` for values already computed: a select, not a branch.
#[inline(always)]
pub fn select(c: bool, a: f32, b: f32) -> f32 {
    let m = (c as u32).wrapping_neg();
    f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}

/// `atan(s)` for `s` in [0, 1]: `s + s·t·P(t)` with `t = s²`, `P` a degree-7 fit
/// (Lawson's minimax iteration in f64, `scripts/fit_poly.py`) of absolute error
/// 7·10⁻⁹ before f32 rounding.
#[inline]
fn atan_unit(s: f32) -> f32 {
    const P: [f32; 8] = [
        -0.333_329_86,
        0.199_903_96,
        -0.141_859_75,
        0.105_739_32,
        -0.073_667_05,
        0.041_121_85,
        -0.015_132_529,
        0.002_622_242_8,
    ];
    let t = s * s;
    let mut u = P[7];
    for c in P[..7].iter().rev() {
        u = u * t + c;
    }
    s + s * (t * u)
}

/// `(sin x, cos x)` within 2·10⁻⁷ for |x| up to 10⁴ (angles of a few turns in the
/// renderer), inlined without a library call: `x` reduced by the nearest multiple of
/// π/2 in two steps (Cody and Waite; the first constant's low bits are zero, so
/// `k·HI` is exact), then degree-7 and degree-8 polynomials on [−π/4, π/4] (fits as
/// for [`atan_unit`]). NaN and infinities give NaN. Without branches (the quadrant's
/// swap and signs are selects), so that loops over lanes vectorize.
#[inline(always)]
pub fn sin_cos_poly(x: f32) -> (f32, f32) {
    const HI: f32 = 1.570_312_5;
    const LO: f32 = 4.838_268e-4;
    let k = floor_f32(x * std::f32::consts::FRAC_2_PI + 0.5);
    let r = (x - k * HI) - k * LO;
    let (sin, cos) = sin_cos_quarter(r);
    // quadrant q: (sin, cos), (cos, −sin), (−sin, −cos), (−cos, sin)
    let q = (k as i32) & 3;
    let (s, c) = (select(q & 1 != 0, cos, sin), select(q & 1 != 0, sin, cos));
    let s = select(q >= 2, -s, s);
    let c = select(q == 1 || q == 2, -c, c);
    let bad = x.is_nan() || x.abs() > 1e4;
    (select(bad, f32::NAN, s), select(bad, f32::NAN, c))
}

/// `(sin r, cos r)` for |r| ≤ π/4 (the polynomials of [`sin_cos_poly`] without its
/// range reduction), within 2·10⁻⁷.
#[inline]
pub fn sin_cos_quarter(r: f32) -> (f32, f32) {
    const S: [f32; 4] = [-0.166_666_67, 0.008_333_328, -0.000_198_390_44, 2.716_014e-6];
    const C: [f32; 4] = [0.041_666_668, -0.001_388_888_3, 2.479_952e-5, -2.721_023_7e-7];
    let t = r * r;
    let sin = r + r * (t * (S[0] + t * (S[1] + t * (S[2] + t * S[3]))));
    let cos = (1.0 - 0.5 * t) + (t * t) * (C[0] + t * (C[1] + t * (C[2] + t * C[3])));
    (sin, cos)
}

/// Asks the CPU to bring `s[i]`'s cache line closer (a hint only; nothing when `i`
/// is out of range or on other architectures), so that a load expected later
/// overlaps the work before it.
#[inline]
pub fn prefetch<T>(s: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(p) = s.get(i) {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: prefetching has no architectural effect (it cannot fault), and SSE
        // is part of the x86-64 baseline; the address is that of a live element.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((p as *const T).cast::<i8>()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (s, i);
}

/// The next state of Marsaglia's xorshift32 (tests' random numbers: any bit
/// pattern but 0).
#[cfg(test)]
pub(crate) fn xorshift32(state: &mut u32) -> u32 {
    *state ^= *state << 13;
    *state ^= *state >> 17;
    *state ^= *state << 5;
    *state
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_f32_is_floor_bit_for_bit() {
        let mut xs = vec![
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            1.5,
            -1.5,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            -8_388_609.0,
            1e30,
            -1e30,
        ];
        xs.extend([
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
            f32::MAX,
            f32::MIN,
        ]);
        for k in -300_000..300_000 {
            let x = k as f32 / 64.0;
            xs.extend([x, x.next_up(), x.next_down()]);
        }
        // every 97th bit pattern over the whole range
        xs.extend((0..u32::MAX / 97).map(|k| f32::from_bits(k * 97)));
        for x in xs {
            let (a, b) = (floor_f32(x), x.floor());
            assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()), "{x:e}: {a:e} != {b:e}");
        }
    }

    #[test]
    fn exp_poly_is_within_2_4e7_of_exp() {
        // relative to f64's exp, over the whole range it promises and some steps past it
        let mut worst = 0.0f64;
        for k in -870_000..=880_000 {
            let x = k as f32 / 10_000.0;
            let exact = (x as f64).exp();
            worst = worst.max(((exp_poly(x) as f64 - exact) / exact).abs());
        }
        println!("exp_poly: worst relative error {worst:e}");
        assert!(worst < 2.4e-7, "relative error {worst:e}");
        // clamped below: e^−87, not 0, NaN or a wrapped exponent
        assert_eq!(exp_poly(-1000.0), exp_poly(-87.0));
        assert!(exp_poly(-87.0) > 1e-38 && exp_poly(-87.0) < 2e-38);
        assert_eq!(exp_poly(0.0), 1.0);
    }

    #[test]
    fn prefetch_accepts_any_index() {
        let v = [1u8, 2, 3];
        prefetch(&v, 0);
        prefetch(&v, 3);
        prefetch(&v, usize::MAX);
        prefetch::<u32>(&[], 0);
    }

    #[test]
    fn coordinate_system_is_orthonormal() {
        for n in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::Z, Vec3::new(0.3, -0.5, 0.8).normalize()] {
            let (s, t) = coordinate_system(n);
            assert!(s.dot(t).abs() < 1e-6 && s.dot(n).abs() < 1e-6 && t.dot(n).abs() < 1e-6);
            assert!((s.length() - 1.0).abs() < 1e-6 && (t.length() - 1.0).abs() < 1e-6);
            assert!((s.cross(t) - n).length() < 1e-5, "right-handed");
        }
    }

    #[test]
    fn refraction_bends_toward_normal_when_entering_denser_medium() {
        let n = Vec3::Z;
        let wi = Vec3::new(0.6, 0.0, 0.8); // sinθi = 0.6
        let wt = refract(wi, n, 1.0 / 1.5).unwrap();
        assert!(wt.z < 0.0);
        assert!((wt.x.abs() - 0.4).abs() < 1e-6, "sinθt = sinθi/1.5");
        // leaving a dense medium at a steep angle: total internal reflection
        assert!(refract(Vec3::new(0.8, 0.0, 0.6), n, 1.5).is_none());
    }

    #[test]
    fn atan2_poly_is_within_2e7_of_atan2_everywhere() {
        let mut worst = 0.0f64;
        let n = 2000;
        for i in 0..n {
            // every direction of the circle, on several radii, and the axes exactly
            let a = (i as f64 / n as f64) * std::f64::consts::TAU;
            for r in [1e-30f64, 1e-3, 1.0, 7.5, 1e20] {
                let (y, x) = ((a.sin() * r) as f32, (a.cos() * r) as f32);
                let exact = (y as f64).atan2(x as f64);
                let got = atan2_poly(y, x) as f64;
                worst = worst.max((got - exact).abs());
            }
        }
        for (y, x) in [
            (0.0f32, 1.0f32),
            (1.0, 0.0),
            (0.0, -1.0),
            (-1.0, 0.0),
            (-0.0, -1.0),
            (1.0, 1.0),
            (-3.0, -3.0),
        ] {
            let exact = (y as f64).atan2(x as f64);
            worst = worst.max((atan2_poly(y, x) as f64 - exact).abs());
        }
        assert!(worst < 2e-7, "worst error {worst}");
        assert_eq!(atan2_poly(0.0, 0.0), 0.0);
        assert!(atan2_poly(f32::NAN, 1.0).is_nan() && atan2_poly(1.0, f32::NAN).is_nan());
        // the sign of y decides the half plane on the negative x axis, as in libm
        assert!(atan2_poly(-0.0, -1.0) < 0.0 && atan2_poly(0.0, -1.0) > 0.0);
    }

    #[test]
    fn sin_cos_poly_is_within_2e7_of_sin_and_cos() {
        let mut worst = 0.0f64;
        let n = 200_000;
        for i in 0..=n {
            let x = -20.0f32 + 40.0 * i as f32 / n as f32;
            let (s, c) = sin_cos_poly(x);
            worst = worst
                .max((s as f64 - (x as f64).sin()).abs())
                .max((c as f64 - (x as f64).cos()).abs());
        }
        for x in [0.0f32, PI, 2.0 * PI, std::f32::consts::FRAC_PI_2, 1e4, -1e4] {
            let (s, c) = sin_cos_poly(x);
            worst = worst
                .max((s as f64 - (x as f64).sin()).abs())
                .max((c as f64 - (x as f64).cos()).abs());
        }
        assert!(worst < 2e-7, "worst error {worst}");
        assert!(sin_cos_poly(f32::NAN).0.is_nan() && sin_cos_poly(f32::INFINITY).1.is_nan());
    }

    #[test]
    fn offset_ray_origin_lanes_match_the_scalar_formula_bit_for_bit() {
        let specials = [
            0.0f32,
            -0.0,
            1.0 / 32.0,
            -1.0 / 32.0,
            0.031_249_998,
            -0.031_249_998,
            1e-30,
            -1e-30,
            f32::MIN_POSITIVE,
            1e30,
            -1e30,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1e7,
            -3.5,
        ];
        let normals = [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            0.577,
            -0.707,
            1e-3,
            1e10,
            -1e10,
            f32::NAN,
            f32::INFINITY,
            0.001_953_125,
        ];
        let mut state = 0x9e37_79b9u32;
        // any bit pattern: NaNs, infinities and subnormals included
        let mut next = || f32::from_bits(xorshift32(&mut state));
        let mut cases: Vec<(Vec3, Vec3)> = Vec::new();
        for &a in &specials {
            for &b in &normals {
                cases.push((Vec3::new(a, -a, 0.5), Vec3::new(b, 0.3, -b)));
            }
        }
        for _ in 0..200_000 {
            let p = Vec3::new(next(), next() * 1e-3, next());
            let n = Vec3::new(next() * 1e-38, next(), (next() * 1e-37).clamp(-1.0, 1.0));
            cases.push((p, n));
            let u = Vec3::new(next(), next(), next());
            cases.push((u, u));
        }
        for &(p, n) in &cases {
            let (a, b) = (offset_ray_origin(p, n), offset_ray_origin_scalar(p, n));
            for k in 0..3 {
                assert_eq!(a[k].to_bits(), b[k].to_bits(), "axis {k} of p {p:?}, n {n:?}: {a:?} vs {b:?}");
            }
        }
        // the same coordinates through `offset_coordinates`: 18 lanes, so four-lane
        // chunks and a remainder of two
        let (ps, ns): (Vec<f32>, Vec<f32>) = cases.iter().flat_map(|(p, n)| (0..3).map(move |k| (p[k], n[k]))).unzip();
        for (p, n) in ps.chunks_exact(18).zip(ns.chunks_exact(18)) {
            let (p, n): (&[f32; 18], &[f32; 18]) = (p.try_into().unwrap(), n.try_into().unwrap());
            let mut out = [0.0f32; 18];
            offset_coordinates(p, n, &mut out);
            for i in 0..18 {
                let want = offset_coordinate(p[i], n[i]);
                assert_eq!(out[i].to_bits(), want.to_bits(), "lane {i}: p {}, n {}", p[i], n[i]);
            }
        }
    }

    #[test]
    fn offset_moves_point_to_the_normal_side() {
        for p in [Vec3::new(1.0, -2.0, 3.0), Vec3::new(0.001, 0.0, -0.01), Vec3::splat(-1e5)] {
            for n in [Vec3::X, -Vec3::Y, Vec3::new(0.6, 0.0, -0.8)] {
                let q = offset_ray_origin(p, n);
                assert!((q - p).dot(n) > 0.0, "{p} {n} -> {q}");
            }
        }
    }

    #[test]
    fn row_major_matrix_has_translation_in_elements_3_7_11() {
        let mut m = [0.0f32; 16];
        m[0] = 1.0;
        m[5] = 1.0;
        m[10] = 1.0;
        m[15] = 1.0;
        m[3] = 2.0;
        m[7] = 3.0;
        m[11] = 4.0;
        let p = transform_point(&mat4_from_row_major(&m), Vec3::ZERO);
        assert_eq!(p, Vec3::new(2.0, 3.0, 4.0));
    }
}
