//! Reconstruction filters (spec §5): their weights, evaluated per axis, and the
//! sampler that draws offsets in proportion to them.

use crate::math::{exp_poly, select, Vec2};

/// The pixel reconstruction filter, `film.filter` in a scene: `type` (`"box"` |
/// `"gaussian"` | `"mitchell"`, `"box"`), `radius` (> 0, 0.5), `alpha` (gaussian, 2),
/// `B`, `C` (mitchell, 1/3 each). Without a `filter` object the film uses a box of
/// radius 0.5.
///
/// ```json
/// "filter": {"type": "gaussian", "radius": 1.5, "alpha": 2}
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    Box {
        radius: f32,
    },
    /// `exp(−α·d²) − tail` per axis, clamped at 0; build it with [`Filter::gaussian`],
    /// which derives `tail = exp(−α·radius²)` so the weight vanishes at the radius.
    Gaussian {
        radius: f32,
        alpha: f32,
        tail: f32,
    },
    Mitchell {
        radius: f32,
        b: f32,
        c: f32,
    },
    /// `(1 − |dx|/r)·(1 − |dy|/r)`: Mitsuba's tent.
    Tent {
        radius: f32,
    },
}

impl Filter {
    /// A gaussian of falloff `alpha` cut off (and shifted to 0) at `radius`.
    pub fn gaussian(radius: f32, alpha: f32) -> Filter {
        Filter::Gaussian {
            radius,
            alpha,
            tail: (-alpha * radius * radius).exp(),
        }
    }

    pub fn radius(&self) -> f32 {
        match *self {
            Filter::Box { radius } | Filter::Gaussian { radius, .. } | Filter::Mitchell { radius, .. } | Filter::Tent { radius } => radius,
        }
    }

    /// A box of radius ≤ ½: each sample counts once, with weight 1, in its own pixel only.
    pub fn is_own_pixel_box(&self) -> bool {
        matches!(*self, Filter::Box { radius } if radius <= 0.5)
    }

    /// How many pixels a sample reaches on each side of its own: ceil(r − ½).
    pub fn reach(&self) -> i32 {
        (self.radius() - 0.5).ceil().max(0.0) as i32
    }

    /// Weight of a sample at offset `(dx, dy)` from a pixel centre: every filter is
    /// separable, the product of its [`Filter::axis`] factors.
    pub fn eval(&self, dx: f32, dy: f32) -> f32 {
        self.axis(dx) * self.axis(dy)
    }

    /// The factor of one axis at offset `d` (0 beyond the radius).
    #[inline]
    pub fn axis(&self, d: f32) -> f32 {
        let r = self.radius();
        if d.abs() > r {
            return 0.0;
        }
        match *self {
            Filter::Box { .. } => 1.0,
            Filter::Tent { radius } => 1.0 - d.abs() / radius,
            Filter::Gaussian { alpha, tail, .. } => ((-alpha * d * d).exp() - tail).max(0.0),
            Filter::Mitchell { radius, b, c } => {
                let x = (2.0 * (d / radius)).abs();
                if x > 1.0 {
                    ((-b - 6.0 * c) * x * x * x + (6.0 * b + 30.0 * c) * x * x + (-12.0 * b - 48.0 * c) * x + (8.0 * b + 24.0 * c)) / 6.0
                } else {
                    ((12.0 - 9.0 * b - 6.0 * c) * x * x * x + (-18.0 + 12.0 * b + 6.0 * c) * x * x + (6.0 - 2.0 * b)) / 6.0
                }
            }
        }
    }
}

impl Filter {
    /// [`Filter::axis`] at the centres of pixels `a, a + 1, …` (the first `n` of `out`,
    /// n ≤ 16; the rest is left undefined) for a sample at film coordinate `pos`; a
    /// gaussian's exponentials by [`exp_poly`], eight lanes at a time (within 2.4·10⁻⁷
    /// relative of `exp`: the library's `exp`, pixel by pixel, was 6 % of a Veach MIS
    /// render, the film 15 %).
    #[inline(always)]
    pub fn axis_weights(&self, pos: f32, a: i32, out: &mut [f32; 16], n: usize) {
        match *self {
            Filter::Gaussian { radius, alpha, tail } => {
                // all eight lanes computed: vector code without a scalar tail or a copy
                for (c, lanes) in out.chunks_exact_mut(8).take(n.div_ceil(8)).enumerate() {
                    for (i, w) in lanes.iter_mut().enumerate() {
                        let d = pos - ((a + (8 * c + i) as i32) as f32 + 0.5);
                        let g = (exp_poly(-alpha * d * d) - tail).max(0.0);
                        *w = select(d.abs() > radius, 0.0, g);
                    }
                }
            }
            _ => self.axis_weights_exact(pos, a, out, n),
        }
    }

    /// [`Filter::axis_weights`] by [`Filter::axis`] pixel by pixel (the library's `exp`).
    #[inline]
    pub fn axis_weights_exact(&self, pos: f32, a: i32, out: &mut [f32; 16], n: usize) {
        for (i, w) in out.iter_mut().take(n).enumerate() {
            *w = self.axis(pos - ((a + i as i32) as f32 + 0.5));
        }
    }
}

/// Bins of [`FilterSampler`]'s table over `[-radius, radius]`.
const SAMPLER_BINS: usize = 128;

/// Draws offsets in proportion to |filter| on each axis: every filter here is a product
/// of one function of `dx` and the same function of `dy`, so the two axes are drawn
/// apart from the same table (piecewise constant, the filter at each bin's centre).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterSampler {
    radius: f32,
    /// `cdf[i]`: the share of |filter| in bins `[0, i)`; `cdf[BINS] = 1`.
    cdf: [f32; SAMPLER_BINS + 1],
    /// Bit `i` set: the filter is negative in bin `i`.
    negative: u128,
}

impl FilterSampler {
    pub fn new(filter: &Filter) -> FilterSampler {
        let radius = filter.radius();
        let width = 2.0 * radius / SAMPLER_BINS as f32;
        let mut cdf = [0.0f32; SAMPLER_BINS + 1];
        let mut negative = 0u128;
        let mut total = 0.0f64;
        for i in 0..SAMPLER_BINS {
            let g = filter.eval(-radius + (i as f32 + 0.5) * width, 0.0);
            if g < 0.0 {
                negative |= 1 << i;
            }
            total += g.abs() as f64;
            cdf[i + 1] = total as f32;
        }
        for c in cdf.iter_mut() {
            *c = if total > 0.0 { (*c as f64 / total) as f32 } else { 0.0 };
        }
        cdf[SAMPLER_BINS] = 1.0;
        FilterSampler { radius, cdf, negative }
    }

    /// One axis: the offset for `u` in [0, 1) and whether the filter is negative there.
    fn axis(&self, u: f32) -> (f32, bool) {
        // the last bin whose start is at most u (bins of zero share are never chosen)
        let i = self.cdf[1..SAMPLER_BINS].partition_point(|&c| c <= u);
        let (a, b) = (self.cdf[i], self.cdf[i + 1]);
        let t = if b > a { ((u - a) / (b - a)).clamp(0.0, 1.0) } else { 0.5 };
        let width = 2.0 * self.radius / SAMPLER_BINS as f32;
        (-self.radius + (i as f32 + t) * width, self.negative & (1 << i) != 0)
    }

    /// The offset from the pixel's centre for the sample `(u, v)` and its weight (±1).
    pub fn sample(&self, u: f32, v: f32) -> (Vec2, f32) {
        let ((dx, nx), (dy, ny)) = (self.axis(u), self.axis(v));
        (Vec2::new(dx, dy), if nx != ny { -1.0 } else { 1.0 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A gaussian's weights by `exp_poly` are `axis`'s (the library's `exp`) within
    /// 3·10⁻⁷ (its peak is 1); other filters' are `axis`'s bit for bit.
    #[test]
    fn axis_weights_are_the_filters_factors() {
        let mut filters: Vec<Filter> = [(2.0, 2.0), (1.5, 0.5), (0.2, 50.0)].map(|(r, a)| Filter::gaussian(r, a)).into();
        filters.extend([
            Filter::Tent { radius: 1.5 },
            Filter::Mitchell {
                radius: 2.0,
                b: 0.5,
                c: 0.25,
            },
        ]);
        for f in filters {
            let mut worst = 0.0f32;
            for k in 0..4000 {
                let pos = -20.0 + k as f32 * 0.01237;
                let a = pos.floor() as i32 - f.reach();
                let n = (2 * f.reach() + 1) as usize + 3;
                let mut w = [f32::NAN; 16];
                f.axis_weights(pos, a, &mut w, n);
                for (i, &w) in w[..n].iter().enumerate() {
                    let exact = f.axis(pos - ((a + i as i32) as f32 + 0.5));
                    worst = worst.max((w - exact).abs());
                }
            }
            println!("{f:?}: worst difference {worst:e}");
            match f {
                Filter::Gaussian { .. } => assert!(worst < 3e-7, "{f:?}: {worst:e}"),
                _ => assert_eq!(worst, 0.0, "{f:?}"),
            }
        }
    }
}
