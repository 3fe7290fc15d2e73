//! Sample generation.
//!
//! [`PixelSampler`]: the default. Owen-scrambled, index-shuffled 2D Sobol points
//! (Burley 2020, "Practical Hash-based Owen Scrambling"), padded per dimension
//! pair. Every pixel gets its own scramble from a hash of (pixel, seed), so a
//! sample depends only on (pixel, sample index, dimension, seed): renders are
//! identical for any thread count or tile order, and any power-of-two prefix of
//! a pixel's samples is a stratified (0,2)-net.

/// 32-bit integer hash (lowbias32, Chris Wellons).
#[inline]
pub fn hash_u32(mut x: u32) -> u32 {
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

/// The same, one table lookup per index byte (the map is linear over XOR).
static SOBOL_DIM1_BYTES: [[u32; 256]; 4] = {
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut v = 0;
        while v < 256 {
            t[b][v] = sobol_dim1_slow((v as u32) << (8 * b));
            v += 1;
        }
        b += 1;
    }
    t
};

#[inline]
fn sobol_dim1(i: u32) -> u32 {
    let t = &SOBOL_DIM1_BYTES;
    t[0][(i & 0xff) as usize] ^ t[1][((i >> 8) & 0xff) as usize] ^ t[2][((i >> 16) & 0xff) as usize] ^ t[3][(i >> 24) as usize]
}

#[inline]
fn to_unit(x: u32) -> f32 {
    // top 24 bits: exactly representable, strictly below 1
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Samples for one pixel and one sample index.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    pixel_seed: u32,
    index: u32,
    dim: u32,
}

impl PixelSampler {
    pub fn new(x: u32, y: u32, sample_index: u32, seed: u32) -> Self {
        PixelSampler {
            pixel_seed: hash_combine(hash_combine(x, y), seed),
            index: sample_index,
            dim: 0,
        }
    }

    /// The next 2D point; each call uses a new, independently scrambled dimension pair.
    #[inline]
    pub fn next_2d(&mut self) -> (f32, f32) {
        let s = hash_combine(self.pixel_seed, self.dim);
        self.dim += 1;
        let i = nested_uniform_scramble(self.index, s);
        let x = nested_uniform_scramble(i.reverse_bits(), hash_u32(s ^ 0x5851_f42d));
        let y = nested_uniform_scramble(sobol_dim1(i), hash_u32(s ^ 0x1405_7b7e));
        (to_unit(x), to_unit(y))
    }

    /// A uniform number keyed by `tag` alone (not a dimension of the sequence): the
    /// same for this pixel sample whatever else was drawn before it.
    #[inline]
    pub fn keyed_1d(&self, tag: u32) -> f32 {
        let h = hash_combine(hash_combine(self.pixel_seed ^ 0x9e37_79b9, self.index), tag);
        to_unit(hash_u32(h))
    }

    /// The first coordinate of [`next_2d`](Self::next_2d), without computing the second.
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let s = hash_combine(self.pixel_seed, self.dim);
        self.dim += 1;
        let i = nested_uniform_scramble(self.index, s);
        to_unit(nested_uniform_scramble(i.reverse_bits(), hash_u32(s ^ 0x5851_f42d)))
    }
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
    fn sobol_tables_match_the_bitwise_definition() {
        for k in 0..100_000u32 {
            let i = hash_u32(k);
            assert_eq!(sobol_dim1(i), sobol_dim1_slow(i));
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
