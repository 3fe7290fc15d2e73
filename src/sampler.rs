//! Sample generation.
//!
//! [`PixelSampler`]: the default. Owen-scrambled, index-shuffled 2D Sobol points
//! (Burley 2020, "Practical Hash-based Owen Scrambling"), padded per dimension
//! pair. Every pixel gets its own scramble from a hash of (pixel, seed), so a
//! sample depends only on (pixel, sample index, dimension, seed): renders are
//! identical for any thread count or tile order, and any power-of-two prefix of
//! a pixel's samples is a stratified (0,2)-net.

use crate::accel::wide::Isa;

/// 32-bit integer hash (lowbias32, Chris Wellons).
#[inline]
pub const fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

#[inline]
pub fn hash_combine(a: u32, b: u32) -> u32 {
    hash_u32(a ^ hash_u32(b).wrapping_add(0x9e37_79b9).wrapping_add(a << 6).wrapping_add(a >> 2))
}

/// The part of [`hash_combine`]`(a, b)` that depends on `a` alone (wrapping additions
/// commute): `hash_combine(a, b) == hash_u32(a ^ hash_u32(b).wrapping_add(combine_key(a)))`.
#[inline]
const fn combine_key(a: u32) -> u32 {
    0x9e37_79b9u32.wrapping_add(a << 6).wrapping_add(a >> 2)
}

#[inline]
fn laine_karras_permutation(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Owen scrambling of a 32-bit fixed-point value.
#[inline]
pub fn nested_uniform_scramble(x: u32, seed: u32) -> u32 {
    laine_karras_permutation(x.reverse_bits(), seed).reverse_bits()
}

/// Sobol's second dimension (generator matrix columns v_k = v_{k−1} ⊕ (v_{k−1} ≫ 1),
/// v_0 = 2³¹) with its bits reversed (what the Owen scramble works on), without a table:
/// column `k` of the generator matrix has bit `31 − j` set where the binomial
/// coefficient C(k, j) is odd, which by Lucas's theorem is where `j`'s bits are a
/// subset of `k`'s. So bit `j` of the reversed point is the parity of the index bits
/// at the positions that contain `j`'s bits: a sum over supersets, one step per bit
/// of the position (five shifts, masks and XORs, which vectorize).
#[inline]
fn sobol_dim1_reversed(i: u32) -> u32 {
    let mut x = i;
    x ^= (x >> 1) & 0x5555_5555;
    x ^= (x >> 2) & 0x3333_3333;
    x ^= (x >> 4) & 0x0f0f_0f0f;
    x ^= (x >> 8) & 0x00ff_00ff;
    x ^= (x >> 16) & 0x0000_ffff;
    x
}

#[inline]
fn to_unit(x: u32) -> f32 {
    // top 24 bits: exactly representable, strictly below 1
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Dimension pairs a [`PixelSampler`] computes together when it has none left: one
/// pass over arrays that the compiler vectorizes (eight lanes of AVX2) costs about
/// what two pairs cost one at a time, and a path draws a few dozen.
const BATCH: usize = 8;

/// Samples for one pixel and one sample index.
///
/// Dimension pair `d` is `(x, y)` with `s = hash_combine(pixel_seed, d)`,
/// `i = nested_uniform_scramble(index, s)` (the shuffled index),
/// `x = nested_uniform_scramble(i.reverse_bits(), hash_u32(s ^ 0x5851_f42d))` (Sobol's
/// first dimension is the bit reversal) and
/// `y = nested_uniform_scramble(sobol_dim1(i), hash_u32(s ^ 0x1405_7b7e))`. The code
/// computes exactly that with fewer bit reversals (the scramble is
/// `reverse(laine_karras(reverse(·)))`, so the reversals of adjacent steps cancel, and
/// the index's is taken once) and the pixel's half of `hash_combine` kept. Pairs are
/// computed [`BATCH`] at a time, ahead of their use; a pair's value does not depend on
/// when it is computed.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    pixel_seed: u32,
    /// `combine_key(pixel_seed)`.
    seed_key: u32,
    index: u32,
    /// `index.reverse_bits()`.
    index_reversed: u32,
    /// The next dimension pair to hand out.
    dim: u32,
    /// `batch[k]` is dimension pair `batch_dim + k`, for `k < batch_len` (0 or [`BATCH`]).
    batch_dim: u32,
    batch_len: u32,
    batch: [(f32, f32); BATCH],
}

impl PixelSampler {
    pub fn new(x: u32, y: u32, sample_index: u32, seed: u32) -> Self {
        PixelSampler::at(hash_combine(hash_combine(x, y), seed), sample_index, 0)
    }

    /// The sampler of the pixel with seed `pixel_seed`, at sample `index`, its next
    /// dimension pair `dim`.
    #[inline(always)]
    fn at(pixel_seed: u32, index: u32, dim: u32) -> Self {
        let mut s = PixelSampler {
            pixel_seed: 0,
            seed_key: 0,
            index: 0,
            index_reversed: 0,
            dim: 0,
            batch_dim: 0,
            batch_len: 0,
            batch: [(0.0, 0.0); BATCH],
        };
        s.restart(pixel_seed, index, dim);
        s
    }

    /// Makes this the sampler [`Self::at`] gives, writing only what that reads (the
    /// batch's contents are left, unread until refilled).
    #[inline(always)]
    fn restart(&mut self, pixel_seed: u32, index: u32, dim: u32) {
        (self.pixel_seed, self.seed_key, self.index) = (pixel_seed, combine_key(pixel_seed), index);
        (self.index_reversed, self.dim, self.batch_len) = (index.reverse_bits(), dim, 0);
    }

    /// The next dimension pair's point, from the batch (computing the next
    /// [`BATCH`] pairs first when it has run out).
    #[inline(always)]
    fn next_pair(&mut self) -> (f32, f32) {
        let d = self.dim;
        self.dim += 1;
        let k = d.wrapping_sub(self.batch_dim);
        if k >= self.batch_len {
            self.refill(d);
            return self.batch[0];
        }
        self.batch[k as usize]
    }

    /// Computes pairs `d..d + BATCH` into the batch.
    #[inline(never)]
    fn refill(&mut self, d: u32) {
        let (seed, key, index_reversed) = (self.pixel_seed, self.seed_key, self.index_reversed);
        // the integer lanes vectorize best with AVX2's 32-bit multiplies; the values
        // are the same on every instruction set
        let isa = if Isa::Avx2.available() { Isa::Avx2 } else { Isa::Portable };
        self.batch = isa.run(
            #[inline(always)]
            || pairs_lanes(seed, key, index_reversed, d),
        );
        (self.batch_dim, self.batch_len) = (d, BATCH as u32);
    }

    /// The next 2D point; each call uses a new, independently scrambled dimension pair.
    #[inline]
    pub fn next_2d(&mut self) -> (f32, f32) {
        self.next_pair()
    }

    /// A uniform number keyed by `tag` alone (not a dimension of the sequence): the
    /// same for this pixel sample whatever else was drawn before it.
    #[inline]
    pub fn keyed_1d(&self, tag: u32) -> f32 {
        let h = hash_combine(hash_combine(self.pixel_seed ^ 0x9e37_79b9, self.index), tag);
        to_unit(hash_u32(h))
    }

    /// The first coordinate of [`next_2d`](Self::next_2d) (the pair's second is not used).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        self.next_pair().0
    }
}

/// Dimension pairs `first..first + BATCH` of the pixel sample with seed `pixel_seed`
/// (`seed_key` = `combine_key(pixel_seed)`) and reversed index `index_reversed`, by
/// the definition of [`PixelSampler`]: each loop one step over all lanes, as in
/// [`first_2d_lanes`].
#[inline(always)]
fn pairs_lanes(pixel_seed: u32, seed_key: u32, index_reversed: u32, first: u32) -> [(f32, f32); BATCH] {
    const B: usize = BATCH;
    let (mut s, mut i) = ([0u32; B], [0u32; B]);
    for k in 0..B {
        (s[k], i[k]) = pair_hash_index(pixel_seed, seed_key, index_reversed, first.wrapping_add(k as u32));
    }
    std::array::from_fn(|k| pair_point(s[k], i[k]))
}

/// Dimension pair `d`'s hash `s = hash_combine(pixel_seed, d)` (its pixel half
/// `seed_key` = `combine_key(pixel_seed)` given) and the shuffled index
/// `nested_uniform_scramble(index, s)` (from `index_reversed`).
#[inline(always)]
fn pair_hash_index(pixel_seed: u32, seed_key: u32, index_reversed: u32, d: u32) -> (u32, u32) {
    let s = hash_u32(pixel_seed ^ hash_u32(d).wrapping_add(seed_key));
    (s, laine_karras_permutation(index_reversed, s).reverse_bits())
}

/// The point of the dimension pair whose hash is `s`, at shuffled index `i`: Sobol's
/// first dimension (the bit reversal) and second, each Owen-scrambled by its own
/// hash of `s`.
#[inline(always)]
fn pair_point(s: u32, i: u32) -> (f32, f32) {
    let x = laine_karras_permutation(i, hash_u32(s ^ 0x5851_f42d)).reverse_bits();
    let y = laine_karras_permutation(sobol_dim1_reversed(i), hash_u32(s ^ 0x1405_7b7e)).reverse_bits();
    (to_unit(x), to_unit(y))
}

/// Lanes of [`first_2d_lanes`]: a 4×4 pixel block.
pub const LANES: usize = 16;

/// `PixelSampler::new(x[i], y[i], index, seed)` followed by its `next_2d`, for
/// [`LANES`] pixels at once: the samplers (their first dimension pair drawn, written
/// into `samplers`) and the points returned, bit for bit as one pixel at a time. The integer hashing runs lane by lane in
/// arrays, which the compiler turns into vector instructions for the instruction set
/// `isa` names (the render's kernel set: `--isa avx2` holds both to AVX2); a fifth of a
/// direct-lighting sample went on this one pixel at a time.
pub fn first_2d_lanes(
    isa: Isa,
    x: &[u32; LANES],
    y: &[u32; LANES],
    index: u32,
    seed: u32,
    samplers: &mut [PixelSampler; LANES],
) -> [(f32, f32); LANES] {
    // every loop runs over all lanes with one operation of `new` and `next_2d`, inlined
    // into the instruction set's copy
    isa.run(
        #[inline(always)]
        || {
            const L: usize = LANES;
            let index_reversed = index.reverse_bits();
            let (mut pixel_seed, mut s, mut i) = ([0u32; L], [0u32; L], [0u32; L]);
            for k in 0..L {
                pixel_seed[k] = hash_combine(hash_combine(x[k], y[k]), seed);
                (s[k], i[k]) = pair_hash_index(pixel_seed[k], combine_key(pixel_seed[k]), index_reversed, 0);
            }
            for (sampler, &pixel_seed) in samplers.iter_mut().zip(&pixel_seed) {
                sampler.restart(pixel_seed, index, 1);
            }
            std::array::from_fn(|k| pair_point(s[k], i[k]))
        },
    )
}

/// The RDR171 sampler (spec §7): `std::mt19937` with its default seed and
/// libstdc++'s `uniform_real_distribution<float>(0, 1 − 2⁻²³)`.
pub struct Mt19937Sampler {
    mt: rand_mt::Mt,
}

impl Default for Mt19937Sampler {
    fn default() -> Self {
        Mt19937Sampler {
            mt: rand_mt::Mt::new(5489),
        }
    }
}

impl Mt19937Sampler {
    pub fn get_1d(&mut self) -> f32 {
        const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON;
        let mut c = self.mt.next_u32() as f32 / 4_294_967_296.0;
        if c >= 1.0 {
            c = 1.0f32.next_down();
        }
        (c * ONE_MINUS_EPS).clamp(0.0, ONE_MINUS_EPS)
    }

    pub fn get_2d(&mut self) -> (f32, f32) {
        let x = self.get_1d();
        (x, self.get_1d())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Second Sobol dimension, bit by bit: generator matrix columns
    /// v_k = v_{k−1} ⊕ (v_{k−1} ≫ 1), v_0 = 2³¹.
    const fn sobol_dim1_slow(mut i: u32) -> u32 {
        let mut v = 1u32 << 31;
        let mut x = 0;
        while i != 0 {
            if i & 1 != 0 {
                x ^= v;
            }
            i >>= 1;
            v ^= v >> 1;
        }
        x
    }

    #[test]
    fn mt19937_default_seed_matches_the_standard() {
        // The C++ standard requires the 10000th output of default-seeded mt19937.
        let mut mt = rand_mt::Mt::new(5489);
        for _ in 0..9999 {
            mt.next_u32();
        }
        assert_eq!(mt.next_u32(), 4_123_659_995);
        let mut s = Mt19937Sampler::default();
        let first = s.get_1d();
        // 3499211612 / 2^32 = 0.8147236..., times (1 - 2^-23)
        assert_eq!(first, (3_499_211_612u32 as f32 / 4_294_967_296.0) * (1.0 - f32::EPSILON));
    }

    #[test]
    fn next_1d_is_the_first_coordinate_of_next_2d() {
        for k in 0..1000 {
            let (mut a, mut b) = (PixelSampler::new(k, 7 * k, k / 3, 11), PixelSampler::new(k, 7 * k, k / 3, 11));
            for _ in 0..4 {
                assert_eq!(a.next_1d(), b.next_2d().0);
            }
        }
    }

    #[test]
    fn sobol_dim1_matches_the_bitwise_definition() {
        for k in 0..100_000u32 {
            let i = hash_u32(k);
            assert_eq!(sobol_dim1_reversed(i), sobol_dim1_slow(i).reverse_bits());
        }
    }

    /// The definition the sampler's documentation gives, spelt out step by step.
    fn reference_2d(pixel_seed: u32, index: u32, dim: u32) -> (f32, f32) {
        let s = hash_combine(pixel_seed, dim);
        let i = nested_uniform_scramble(index, s);
        let x = nested_uniform_scramble(i.reverse_bits(), hash_u32(s ^ 0x5851_f42d));
        let y = nested_uniform_scramble(sobol_dim1_slow(i), hash_u32(s ^ 0x1405_7b7e));
        (to_unit(x), to_unit(y))
    }

    #[test]
    fn samples_follow_the_definition_bit_for_bit() {
        // across several batches, the last one partly used
        for k in 0..3000u32 {
            let (x, y, index, seed) = (k % 37, k / 37, hash_u32(k) % 1024, k % 5);
            let mut a = PixelSampler::new(x, y, index, seed);
            let mut b = a;
            let pixel_seed = hash_combine(hash_combine(x, y), seed);
            for dim in 0..(5 * BATCH as u32 + 3) {
                let (rx, ry) = reference_2d(pixel_seed, index, dim);
                let (px, py) = a.next_2d();
                assert_eq!(
                    (px.to_bits(), py.to_bits()),
                    (rx.to_bits(), ry.to_bits()),
                    "pixel ({x}, {y}) index {index} dim {dim}"
                );
                assert_eq!(b.next_1d().to_bits(), rx.to_bits());
            }
        }
    }

    /// The block version against one pixel at a time, bit for bit, with every
    /// instruction set this CPU runs: the points and the samplers' next dimensions.
    #[test]
    fn first_2d_lanes_is_new_and_next_2d() {
        for isa in Isa::all_available() {
            for k in 0..400u32 {
                let x: [u32; LANES] = std::array::from_fn(|i| hash_u32(k * 31 + i as u32) % 5000);
                let y: [u32; LANES] = std::array::from_fn(|i| hash_u32(k * 17 + i as u32 + 99) % 3000);
                let (index, seed) = (if k % 3 == 0 { k } else { hash_u32(k) }, k % 7);
                // samplers that have drawn before: restarting must forget their batches
                let mut samplers: [PixelSampler; LANES] = std::array::from_fn(|i| {
                    let mut s = PixelSampler::new(i as u32, 1, 2, 3);
                    (0..i).for_each(|_| _ = s.next_1d());
                    s
                });
                let points = first_2d_lanes(isa, &x, &y, index, seed, &mut samplers);
                for i in 0..LANES {
                    let mut one = PixelSampler::new(x[i], y[i], index, seed);
                    let (a, b) = one.next_2d();
                    let (c, d) = points[i];
                    let what = format!("{isa:?}, pixel ({}, {}), index {index}", x[i], y[i]);
                    assert_eq!((a.to_bits(), b.to_bits()), (c.to_bits(), d.to_bits()), "{what}");
                    for _ in 0..2 * BATCH {
                        assert_eq!(one.next_2d(), samplers[i].next_2d(), "{what}");
                    }
                    assert_eq!(one.keyed_1d(5), samplers[i].keyed_1d(5), "{what}");
                }
            }
        }
    }

    #[test]
    fn power_of_two_prefixes_are_stratified() {
        // 16 samples of one pixel: exactly one in each 4x4 cell, and in each 16x1 and 1x16 strip.
        for seed in 0..20 {
            let pts: Vec<(f32, f32)> = (0..16).map(|i| PixelSampler::new(3, 7, i, seed).next_2d()).collect();
            for (nx, ny) in [(4, 4), (16, 1), (1, 16), (2, 8), (8, 2)] {
                let mut cells = vec![0; nx * ny];
                for &(x, y) in &pts {
                    cells[(x * nx as f32) as usize * ny + (y * ny as f32) as usize] += 1;
                }
                assert!(cells.iter().all(|&c| c == 1), "seed {seed}, {nx}x{ny}: {cells:?}");
            }
        }
    }

    #[test]
    fn dimensions_and_pixels_are_decorrelated() {
        // The mean of u·v over many pixels and dimension pairs stays near 1/4.
        let mut acc = 0.0f64;
        let n = 20000;
        for k in 0..n {
            let mut s = PixelSampler::new(k % 100, k / 100, 5, 1);
            let a = s.next_1d();
            let b = s.next_1d();
            acc += (a * b) as f64;
        }
        assert!((acc / n as f64 - 0.25).abs() < 0.01);
    }
}
