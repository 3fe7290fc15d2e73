//! Sampling routines: piecewise-constant distributions and warps from the unit
//! square. Each has a matching pdf; `tests/sampling_chi2.rs` checks them.

use crate::math::{Vec2, Vec3, PI};

/// Piecewise-constant 1D distribution over `[0, 1)` (pbrt's `Distribution1D`).
/// All-zero weights give the uniform distribution.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    func: Vec<f32>,
    cdf: Vec<f32>,
    integral: f32,
    /// `guide[k]`: the last bucket whose cdf is ≤ k/n, where the search for a
    /// `u` in [k/n, (k+1)/n) starts (a guide table: a step or two instead of a
    /// binary search whose dependent loads miss the cache on large maps).
    guide: Vec<u32>,
}

impl Distribution1D {
    pub fn new(weights: &[f32]) -> Self {
        let n = weights.len().max(1);
        let func: Vec<f32> = if weights.is_empty() {
            vec![0.0]
        } else {
            weights.iter().map(|w| if w.is_finite() { w.max(0.0) } else { 0.0 }).collect()
        };
        let mut cdf = vec![0.0f32; n + 1];
        let mut acc = 0.0f64;
        for i in 0..n {
            acc += func[i] as f64 / n as f64;
            cdf[i + 1] = acc as f32;
        }
        let integral = acc as f32;
        if integral == 0.0 {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f32 / n as f32;
            }
        } else {
            for c in cdf.iter_mut() {
                *c /= integral;
            }
        }
        cdf[n] = 1.0;
        let mut guide = Vec::with_capacity(n);
        let mut i = 0;
        for k in 0..n {
            let lo = k as f32 / n as f32;
            while i + 1 < n && cdf[i + 1] <= lo {
                i += 1;
            }
            guide.push(i as u32);
        }
        Distribution1D {
            func,
            cdf,
            integral,
            guide,
        }
    }

    /// Mean of the weights.
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// The largest `i < n` with `cdf[i] <= u` (0 when there is none).
    #[inline]
    fn find(&self, u: f32) -> usize {
        let n = self.func.len();
        // a single entry (a scene's only light) needs no search
        if n <= 1 || u.is_nan() {
            return 0;
        }
        // `as` saturates: negative u gives 0
        let mut i = self.guide[((u * n as f32) as usize).min(n - 1)] as usize;
        // the guide is a start; rounding of u·n may put it one bucket off either way
        while i > 0 && self.cdf[i] > u {
            i -= 1;
        }
        while i + 1 < n && self.cdf[i + 1] <= u {
            i += 1;
        }
        i
    }

    /// Index `i` with probability `w_i / Σw`, that probability, and `u` re-used:
    /// its position inside the chosen bucket, in [0, 1).
    #[inline]
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        let i = self.find(u);
        let width = self.cdf[i + 1] - self.cdf[i];
        let rest = if width > 0.0 {
            ((u - self.cdf[i]) / width).clamp(0.0, 1.0 - f32::EPSILON)
        } else {
            0.0
        };
        (i, self.pmf(i), rest)
    }

    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// A continuous sample in [0, 1), its density, and the bucket.
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        let i = self.find(u);
        let width = self.cdf[i + 1] - self.cdf[i];
        let du = if width > 0.0 { (u - self.cdf[i]) / width } else { 0.0 };
        let n = self.func.len() as f32;
        let pdf = if self.integral > 0.0 { self.func[i] / self.integral } else { 1.0 };
        (((i as f32 + du) / n).min(1.0 - f32::EPSILON), pdf, i)
    }

    /// Density at `x` in [0, 1).
    pub fn pdf(&self, x: f32) -> f32 {
        let n = self.func.len();
        let i = ((x * n as f32) as usize).min(n - 1);
        if self.integral > 0.0 {
            self.func[i] / self.integral
        } else {
            1.0
        }
    }
}

/// Piecewise-constant 2D distribution over `[0, 1)²` (rows are `v`, columns `u`).
#[derive(Clone, Debug)]
pub struct Distribution2D {
    conditional: Vec<Distribution1D>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// `weights[v * nu + u]`.
    pub fn new(weights: &[f32], nu: usize, nv: usize) -> Self {
        let conditional: Vec<Distribution1D> = (0..nv).map(|v| Distribution1D::new(&weights[v * nu..(v + 1) * nu])).collect();
        let marginal = Distribution1D::new(&conditional.iter().map(|c| c.integral()).collect::<Vec<_>>());
        Distribution2D { conditional, marginal }
    }

    /// A point `(u, v)` and its density with respect to area in `[0, 1)²`.
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (v, pdf_v, row) = self.marginal.sample_continuous(u.y);
        let (x, pdf_u, _) = self.conditional[row].sample_continuous(u.x);
        (Vec2::new(x, v), pdf_u * pdf_v)
    }

    pub fn pdf(&self, p: Vec2) -> f32 {
        let nv = self.conditional.len();
        let row = ((p.y * nv as f32) as usize).min(nv - 1);
        self.marginal.pdf(p.y) * self.conditional[row].pdf(p.x)
    }
}

/// Cosine-weighted direction about +z; pdf cosθ/π.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.x * d.x - d.y * d.y).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Shirley–Chiu concentric map to the unit disk.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, PI / 4.0 * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - PI / 4.0 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Uniform direction on the unit sphere; pdf 1/4π.
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction in the cone of half-angle arccos(`cos_max`) about +z; pdf
/// [`uniform_cone_pdf`].
pub fn uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Solid-angle density of [`uniform_cone`]: 1/(2π(1 − cos_max)).
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform barycentrics on a triangle: `(1 − √u₁, u₂√u₁, rest)`.
pub fn uniform_triangle(u: Vec2) -> [f32; 3] {
    let s = u.x.sqrt();
    let b0 = 1.0 - s;
    let b1 = u.y * s;
    [b0, b1, (1.0 - b0 - b1).max(0.0)]
}

/// Power heuristic (β = 2) weight of a strategy with density `a` against `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    if a.is_infinite() {
        return 1.0;
    }
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 == 0.0 {
        0.0
    } else {
        a2 / (a2 + b2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discrete_pmf_matches_weights() {
        let w = [1.0, 0.0, 3.0, 4.0];
        let d = Distribution1D::new(&w);
        for (i, &wi) in w.iter().enumerate() {
            assert!((d.pmf(i) - wi / 8.0).abs() < 1e-6);
        }
        let mut counts = [0usize; 4];
        let n = 100_000;
        for k in 0..n {
            let (i, p, rest) = d.sample_discrete((k as f32 + 0.5) / n as f32);
            assert!((0.0..1.0).contains(&rest));
            assert_eq!(p, d.pmf(i));
            counts[i] += 1;
        }
        for i in 0..4 {
            assert!((counts[i] as f32 / n as f32 - w[i] / 8.0).abs() < 1e-3);
        }
        let z = Distribution1D::new(&[0.0, 0.0]);
        assert_eq!(z.sample_discrete(0.7).0, 1);
        assert_eq!(z.pdf(0.2), 1.0);
    }

    /// The guided search finds what a binary search over the cdf finds, on
    /// weights with zero runs, spikes and a single bucket, for `u` on and
    /// around every cdf value and outside [0, 1).
    #[test]
    fn guided_search_matches_binary_search() {
        let mut rng = SplitMix64(7);
        let mut cases: Vec<Vec<f32>> = vec![vec![1.0], vec![0.0, 0.0, 0.0], vec![0.0, 5.0, 0.0, 0.0, 1.0, 0.0]];
        for n in [2usize, 3, 17, 256, 1000] {
            cases.push(
                (0..n)
                    .map(|_| match rng.next_u64() % 4 {
                        0 => 0.0,
                        1 => 1e6,
                        _ => rng.unit_f32(),
                    })
                    .collect(),
            );
        }
        for w in &cases {
            let d = Distribution1D::new(w);
            let binary = |u: f32| d.cdf.partition_point(|&c| c <= u).saturating_sub(1).min(d.func.len() - 1);
            let mut us: Vec<f32> = vec![-1.0, -0.0, 1.0, 2.0, f32::NAN, 1.0 - f32::EPSILON / 2.0];
            for &c in &d.cdf {
                us.extend([c, c.next_down(), c.next_up()]);
            }
            us.extend((0..2000).map(|_| rng.unit_f32()));
            for u in us {
                assert_eq!(d.find(u), binary(u), "u = {u} with {} weights", w.len());
            }
        }
    }

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (0.3, 0.0), (5.0, 5.0)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
        }
    }
}

/// splitmix64 (Steele, Lea & Flood 2014): a small, fast, seedable generator for
/// ray sets in benchmarks and randomized tests (not used for rendering, which
/// uses the per-pixel Sobol sampler).
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl From<u64> for SplitMix64 {
    fn from(seed: u64) -> Self {
        SplitMix64(seed)
    }
}

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) with 24 bits.
    pub fn unit_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in [0, 1) with 53 bits.
    pub fn unit_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `0..n` (`n` ≥ 1; slightly biased for huge `n`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }
}
