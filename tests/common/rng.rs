//! Deterministic random numbers for the property tests.

use super::lattice::I3;
use rdr::geometry::aabb::Aabb;
use rdr::math::Vec3;

/// Test generator: splitmix64 with helpers for ranges.
pub struct Rng(pub rdr::sampling::SplitMix64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(rdr::sampling::SplitMix64(
            seed.wrapping_mul(0xD1B5_4A32_D192_ED03) ^ 0x9E37_79B9_7F4A_7C15,
        ))
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        self.0.unit_f64()
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    pub fn rangef(&mut self, lo: f32, hi: f32) -> f32 {
        self.range(lo as f64, hi as f64) as f32
    }
    /// Log-uniform in [lo, hi).
    pub fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        self.range(lo.ln(), hi.ln()).exp()
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    /// Uniform integer in [lo, hi].
    pub fn int(&mut self, lo: i64, hi: i64) -> i64 {
        lo + (self.next_u64() % (hi - lo + 1) as u64) as i64
    }
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    pub fn sign(&mut self) -> f32 {
        if self.chance(0.5) {
            1.0
        } else {
            -1.0
        }
    }
    pub fn in_cube(&mut self, r: f32) -> Vec3 {
        Vec3::new(self.rangef(-r, r), self.rangef(-r, r), self.rangef(-r, r))
    }
    pub fn in_box(&mut self, b: &Aabb) -> Vec3 {
        let mut p = Vec3::ZERO;
        for a in 0..3 {
            p[a] = self.rangef(b.min[a], b.max[a]).clamp(b.min[a], b.max[a]);
        }
        p
    }
    /// Uniform unit vector.
    pub fn dir(&mut self) -> Vec3 {
        loop {
            let v = self.in_cube(1.0);
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
    /// Barycentric coordinates uniform over the triangle.
    pub fn bary(&mut self) -> [f32; 3] {
        let (mut u, mut v) = (self.unit() as f32, self.unit() as f32);
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        [1.0 - u - v, u, v]
    }
    pub fn int3(&mut self, lo: i64, hi: i64) -> I3 {
        [self.int(lo, hi), self.int(lo, hi), self.int(lo, hi)]
    }
}
