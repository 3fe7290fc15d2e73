//! Sampling routines: piecewise-constant distributions and warps from the unit
//! square. Each has a matching pdf; `tests/sampling_chi2.rs` checks them.

use crate::math::{sin_cos_poly, sin_cos_quarter, Vec2, Vec3, PI};
use crate::pages::HugeBuf;

/// One bucket of a guide table: `i`, the last interval whose cdf is ≤ k/n, and that
/// interval's bounds and density, so that a `u` inside `[lo, hi)` (most draws) is
/// sampled from this one entry, with one memory access instead of a dependent chain
/// guide → cdf → density (each of them a cache miss on a large map's rows).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(16))]
struct Guide {
    lo: f32,
    hi: f32,
    func: f32,
    i: u32,
}

/// Builds the tables of one piecewise-constant distribution: `func` (densities: the
/// clamped weights over their mean),
/// `cdf` (n + 1 entries) and `guide` (n entries) are appended; returns the integral.
fn build_tables(weights: &[f32], func: &mut Vec<f32>, cdf: &mut Vec<f32>, guide: &mut Vec<Guide>) -> f32 {
    let n = weights.len().max(1);
    let (f0, c0) = (func.len(), cdf.len());
    if weights.is_empty() {
        func.push(0.0);
    } else {
        func.extend(weights.iter().map(|w| if w.is_finite() { w.max(0.0) } else { 0.0 }));
    }
    let weights = &func[f0..];
    cdf.resize(c0 + n + 1, 0.0);
    let cdf = &mut cdf[c0..];
    let mut acc = 0.0f64;
    for i in 0..n {
        acc += weights[i] as f64 / n as f64;
        cdf[i + 1] = acc as f32;
    }
    let integral = acc as f32;
    // from here on `func` holds densities, `func[i] / integral` (1 when all are zero),
    // what sampling and `pdf` return, so they need no division
    let func = &mut func[f0..];
    for f in func.iter_mut() {
        *f = if integral > 0.0 { *f / integral } else { 1.0 };
    }
    let func = &*func;
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
    guide.reserve(n);
    let mut i = 0;
    for k in 0..n {
        let lo = k as f32 / n as f32;
        while i + 1 < n && cdf[i + 1] <= lo {
            i += 1;
        }
        guide.push(Guide {
            lo: cdf[i],
            hi: cdf[i + 1],
            func: func[i],
            i: i as u32,
        });
    }
    integral
}

/// Distributions of at most this many buckets (a scene's lights, a light's
/// triangles) are searched by counting.
const SMALL: usize = 16;

/// A borrowed view of one distribution's tables (a [`Distribution1D`] or a row of a
/// [`Distribution2D`]).
#[derive(Clone, Copy)]
struct Tables<'a> {
    func: &'a [f32],
    cdf: &'a [f32],
    guide: &'a [Guide],
}

impl Tables<'_> {
    /// The largest `i < n` with `cdf[i] <= u` (0 when there is none), with `cdf[i]`,
    /// `cdf[i + 1]` and `func[i]`.
    #[inline(always)]
    fn find(&self, u: f32) -> (usize, f32, f32, f32) {
        let n = self.func.len();
        // a single entry (a scene's only light) needs no search
        if n <= 1 || u.is_nan() {
            return (0, self.cdf[0], self.cdf[1], self.func[0]);
        }
        if n <= SMALL {
            // the cdf rising (cdf[0] = 0), the answer counts the bounds ≤ u: compares
            // without the branches of a walk, which go either way at random
            let i = self.cdf[1..n].iter().filter(|&&c| c <= u).count();
            return (i, self.cdf[i], self.cdf[i + 1], self.func[i]);
        }
        // `as` saturates: negative u gives 0
        let k = ((u * n as f32) as usize).min(n - 1);
        let g = self.guide[k];
        // the search below would stop at once where it starts
        if g.lo <= u && u < g.hi {
            return (g.i as usize, g.lo, g.hi, g.func);
        }
        // or where the next bucket's entry starts (the bucket holds one cdf value: u is
        // past it, in the interval that reaches into the next bucket), whose entry is
        // beside this one: the search would pass the intervals between the two
        // (the cdf does not decrease) and stop there
        if let Some(g) = self.guide.get(k + 1) {
            if g.lo <= u && u < g.hi {
                return (g.i as usize, g.lo, g.hi, g.func);
            }
        }
        let mut i = g.i as usize;
        // the guide is a start; rounding of u·n may put it one bucket off either way
        while i > 0 && self.cdf[i] > u {
            i -= 1;
        }
        while i + 1 < n && self.cdf[i + 1] <= u {
            i += 1;
        }
        (i, self.cdf[i], self.cdf[i + 1], self.func[i])
    }

    #[inline(always)]
    fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        let (i, lo, hi, _) = self.find(u);
        let width = hi - lo;
        let rest = if width > 0.0 {
            ((u - lo) / width).clamp(0.0, 1.0 - f32::EPSILON)
        } else {
            0.0
        };
        (i, width, rest)
    }

    #[inline(always)]
    fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        self.continuous_in(u, self.find(u))
    }

    /// [`Tables::sample_continuous`] of `u` with its bucket already found (`find(u)`).
    #[inline(always)]
    fn continuous_in(&self, u: f32, (i, lo, hi, func): (usize, f32, f32, f32)) -> (f32, f32, usize) {
        let width = hi - lo;
        let du = if width > 0.0 { (u - lo) / width } else { 0.0 };
        let n = self.func.len() as f32;
        // `func` holds densities (see `build_tables`)
        let pdf = func;
        (((i as f32 + du) / n).min(1.0 - f32::EPSILON), pdf, i)
    }

    #[inline]
    fn pdf(&self, x: f32) -> f32 {
        let n = self.func.len();
        let i = ((x * n as f32) as usize).min(n - 1);
        self.func[i]
    }
}

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
    guide: Vec<Guide>,
}

impl Distribution1D {
    pub fn new(weights: &[f32]) -> Self {
        let (mut func, mut cdf, mut guide) = (Vec::new(), Vec::new(), Vec::new());
        let integral = build_tables(weights, &mut func, &mut cdf, &mut guide);
        Distribution1D {
            func,
            cdf,
            integral,
            guide,
        }
    }

    #[inline]
    fn tables(&self) -> Tables<'_> {
        Tables {
            func: &self.func,
            cdf: &self.cdf,
            guide: &self.guide,
        }
    }

    /// Mean of the weights.
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// The largest `i < n` with `cdf[i] <= u` (0 when there is none).
    #[cfg(test)]
    fn find(&self, u: f32) -> usize {
        self.tables().find(u).0
    }

    /// Index `i` with probability `w_i / Σw`, that probability, and `u` re-used:
    /// its position inside the chosen bucket, in [0, 1).
    #[inline(always)]
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        self.tables().sample_discrete(u)
    }

    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// A continuous sample in [0, 1), its density, and the bucket.
    #[inline(always)]
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        self.tables().sample_continuous(u)
    }

    /// Density at `x` in [0, 1).
    #[inline]
    pub fn pdf(&self, x: f32) -> f32 {
        self.tables().pdf(x)
    }
}

/// The marginal's bucket of a [`Distribution2D`] sample, found once by
/// [`Distribution2D::prefetch_sample`] for [`Distribution2D::sample_in`] (the search
/// was made twice, and its loads miss the cache once the map's rows have evicted it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowDraw {
    /// The `u.y` it was found for.
    v: f32,
    bucket: (usize, f32, f32, f32),
}

/// Piecewise-constant 2D distribution over `[0, 1)²` (rows are `v`, columns `u`).
/// The rows' conditional distributions live in flat arrays (row `r`'s weights at
/// `r·nu…`, its cdf at `r·(nu + 1)…`), so a sample touches no per-row header.
#[derive(Clone, Debug)]
pub struct Distribution2D {
    nu: usize,
    func: HugeBuf<f32>,
    cdf: HugeBuf<f32>,
    guide: HugeBuf<Guide>,
    /// The rows' integrals (the marginal's weights).
    integrals: Vec<f32>,
    marginal: Distribution1D,
}

impl Distribution2D {
    /// `weights[v * nu + u]`.
    pub fn new(weights: &[f32], nu: usize, nv: usize) -> Self {
        let cells = nu.max(1) * nv;
        let (mut func, mut cdf, mut guide) = (Vec::with_capacity(cells), Vec::with_capacity(cells + nv), Vec::with_capacity(cells));
        let integrals: Vec<f32> = (0..nv)
            .map(|v| build_tables(&weights[v * nu..(v + 1) * nu], &mut func, &mut cdf, &mut guide))
            .collect();
        let marginal = Distribution1D::new(&integrals);
        // a row of no weights is one zero weight (as `Distribution1D::new(&[])`)
        let nu = nu.max(1);
        // on huge pages: samples read them all over
        Distribution2D {
            nu,
            func: HugeBuf::from_slice(&func),
            cdf: HugeBuf::from_slice(&cdf),
            guide: HugeBuf::from_slice(&guide),
            integrals,
            marginal,
        }
    }

    #[inline]
    fn row(&self, r: usize) -> Tables<'_> {
        let nu = self.nu;
        Tables {
            func: &self.func[r * nu..(r + 1) * nu],
            cdf: &self.cdf[r * (nu + 1)..(r + 1) * (nu + 1)],
            guide: &self.guide[r * nu..(r + 1) * nu],
        }
    }

    /// A point `(u, v)` and its density with respect to area in `[0, 1)²`.
    #[inline(always)]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        self.sample_in(u, self.row_draw(u))
    }

    /// [`Self::sample`] of `u` with the marginal's bucket `draw` found for it before
    /// ([`Self::prefetch_sample`] of the same `u`).
    #[inline(always)]
    pub fn sample_in(&self, u: Vec2, draw: RowDraw) -> (Vec2, f32) {
        debug_assert!(draw.v.to_bits() == u.y.to_bits(), "a row drawn for another sample");
        let (v, pdf_v, row) = self.marginal.tables().continuous_in(u.y, draw.bucket);
        let (x, pdf_u, _) = self.row(row).sample_continuous(u.x);
        (Vec2::new(x, v), pdf_u * pdf_v)
    }

    /// The marginal's bucket for `u`.
    #[inline(always)]
    fn row_draw(&self, u: Vec2) -> RowDraw {
        RowDraw {
            v: u.y,
            bucket: self.marginal.tables().find(u.y),
        }
    }

    /// Prefetches the guide entry [`Self::sample`] will read in its row for `u` (a
    /// hint), and returns the row's bucket for [`Self::sample_in`].
    #[inline]
    pub fn prefetch_sample(&self, u: Vec2) -> RowDraw {
        let draw = self.row_draw(u);
        let col = ((u.x * self.nu as f32) as usize).min(self.nu - 1);
        crate::math::prefetch(&self.guide, draw.bucket.0 * self.nu + col);
        draw
    }

    /// Prefetches the weight [`Self::pdf`] reads at `p` (a hint).
    #[inline]
    pub fn prefetch(&self, p: Vec2) {
        let nv = self.integrals.len();
        let row = ((p.y * nv as f32) as usize).min(nv.saturating_sub(1));
        let col = ((p.x * self.nu as f32) as usize).min(self.nu - 1);
        crate::math::prefetch(&self.func, row * self.nu + col);
    }

    #[inline]
    pub fn pdf(&self, p: Vec2) -> f32 {
        let nv = self.integrals.len();
        let row = ((p.y * nv as f32) as usize).min(nv - 1);
        self.marginal.pdf(p.y) * self.row(row).pdf(p.x)
    }
}

/// Cosine-weighted direction about +z; pdf cosθ/π.
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.x * d.x - d.y * d.y).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Direction about +z with density (n + 1)/(2π)·cos^n θ over the sphere's upper half
/// (Lafortune and Willems' Phong lobe: cos θ = u.y^(1/(n+1)), φ = 2π u.x).
pub fn power_cosine(u: Vec2, n: f32) -> Vec3 {
    let cos = u.y.powf(1.0 / (n + 1.0));
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.x;
    Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
}

/// Shirley–Chiu concentric map to the unit disk.
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // the angle from the nearer axis lies within ±π/4: no range reduction
    if o.x.abs() > o.y.abs() {
        let (sin, cos) = sin_cos_quarter(PI / 4.0 * (o.y / o.x));
        o.x * Vec2::new(cos, sin)
    } else {
        // θ = π/2 − a, so (cos θ, sin θ) = (sin a, cos a)
        let (sin, cos) = sin_cos_quarter(PI / 4.0 * (o.x / o.y));
        o.y * Vec2::new(sin, cos)
    }
}

/// Uniform direction on the unit sphere; pdf 1/4π.
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin, cos) = sin_cos_poly(2.0 * PI * u.y);
    Vec3::new(r * cos, r * sin, z)
}

/// Uniform direction in the cone of half-angle arccos(`cos_max`) about +z; pdf
/// [`uniform_cone_pdf`].
pub fn uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin, cos) = sin_cos_poly(2.0 * PI * u.y);
    Vec3::new(r * cos, r * sin, z)
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
        for n in [2usize, 3, 15, 16, 17, 256, 1000] {
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

    /// The flat rows of a 2D distribution sample and evaluate exactly as one
    /// `Distribution1D` per row would, bit for bit, including all-zero rows.
    #[test]
    fn flat_rows_match_one_distribution_per_row() {
        let mut rng = SplitMix64(11);
        for (nu, nv) in [(1usize, 1usize), (5, 3), (64, 32), (300, 7)] {
            let w: Vec<f32> = (0..nu * nv)
                .map(|k| {
                    // every third row all zero, a fifth of the other weights zero
                    if (k / nu) % 3 == 1 || rng.next_u64().is_multiple_of(5) {
                        0.0
                    } else {
                        rng.unit_f32() * 10.0
                    }
                })
                .collect();
            let d = Distribution2D::new(&w, nu, nv);
            let rows: Vec<Distribution1D> = (0..nv).map(|v| Distribution1D::new(&w[v * nu..(v + 1) * nu])).collect();
            let marginal = Distribution1D::new(&rows.iter().map(|r| r.integral()).collect::<Vec<_>>());
            for _ in 0..5000 {
                let u = Vec2::new(rng.unit_f32(), rng.unit_f32());
                let (v, pv, row) = marginal.sample_continuous(u.y);
                let (x, pu, _) = rows[row].sample_continuous(u.x);
                let (p, pdf) = d.sample(u);
                assert_eq!(
                    (p.x.to_bits(), p.y.to_bits(), pdf.to_bits()),
                    (x.to_bits(), v.to_bits(), (pu * pv).to_bits())
                );
                // with the row drawn by the prefetch: the same sample
                let (p, pdf) = d.sample_in(u, d.prefetch_sample(u));
                assert_eq!(
                    (p.x.to_bits(), p.y.to_bits(), pdf.to_bits()),
                    (x.to_bits(), v.to_bits(), (pu * pv).to_bits())
                );
                let q = Vec2::new(rng.unit_f32(), rng.unit_f32());
                let r = ((q.y * nv as f32) as usize).min(nv - 1);
                assert_eq!(d.pdf(q).to_bits(), (marginal.pdf(q.y) * rows[r].pdf(q.x)).to_bits());
            }
        }
    }

    #[test]
    fn concentric_disk_matches_shirley_chiu_in_f64() {
        let n = 400;
        for i in 0..=n {
            for j in 0..=n {
                let u = Vec2::new(i as f32 / n as f32, j as f32 / n as f32);
                let (x, y) = (2.0 * u.x as f64 - 1.0, 2.0 * u.y as f64 - 1.0);
                let want = if x == 0.0 && y == 0.0 {
                    (0.0, 0.0)
                } else if x.abs() > y.abs() {
                    let t = std::f64::consts::FRAC_PI_4 * (y / x);
                    (x * t.cos(), x * t.sin())
                } else {
                    let t = std::f64::consts::FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (x / y);
                    (y * t.cos(), y * t.sin())
                };
                let got = concentric_disk(u);
                let err = (got.x as f64 - want.0).abs().max((got.y as f64 - want.1).abs());
                assert!(err < 4e-7, "{u}: {got} vs {want:?}");
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

/// SplitMix64's output function: a bijection of `u64` that scatters nearby inputs.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        mix64(self.0)
    }

    /// A stream for one of many keys (a photon's seed, iteration and index): its start is
    /// [`mix64`] of the key, so different keys start far apart in SplitMix64's one sequence.
    /// (Starting at `key·γ` would put key + 1's stream one draw behind key's: the two
    /// would share all but one number.)
    pub fn for_key(key: u64) -> SplitMix64 {
        SplitMix64(mix64(key))
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
