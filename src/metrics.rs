//! Image comparison with the reference's and our own noise taken out
//! (`shared/refs/README.md`, "How to compare").
//!
//! For each pixel and channel, E[(X − R)²] = bias² + V_X + V_R. With X the mean of
//! two independent renders X1, X2 (V_X ≈ (X1 − X2)²/4) and V_R the reference's
//! variance file, `relMSE_corrected = mean(((X − R)² − V_X − V_R) / (R² + 0.01))`
//! estimates the systematic error only: ≈ 0 for a correct renderer.

use crate::math::Vec3;

/// Linear RGB, row 0 = top: the images `imageio` reads.
pub use crate::imageio::RgbImage as Image;

impl Image {
    pub fn new(width: usize, height: usize, pixels: Vec<Vec3>) -> Self {
        assert_eq!(pixels.len(), width * height);
        Image { width, height, pixels }
    }

    pub fn mean(&self) -> Vec3 {
        let s: glam::DVec3 = self.pixels.iter().map(|p| p.as_dvec3()).sum();
        (s / self.pixels.len() as f64).as_vec3()
    }

    /// Averages k×k blocks (dropping a partial last row/column of blocks).
    /// With `variance` the block values are variances of means: Σv / k⁴.
    pub fn block_average(&self, k: usize, variance: bool) -> Image {
        let (w, h) = (self.width / k, self.height / k);
        let norm = if variance { (k * k * k * k) as f32 } else { (k * k) as f32 };
        let mut out = vec![Vec3::ZERO; w * h];
        for by in 0..h {
            for bx in 0..w {
                let mut s = Vec3::ZERO;
                for y in by * k..(by + 1) * k {
                    for x in bx * k..(bx + 1) * k {
                        s += self.pixels[y * self.width + x];
                    }
                }
                out[by * w + bx] = s / norm;
            }
        }
        Image::new(w, h, out)
    }

    /// Keeps rows outside `[r0, r1)` (for masking a band).
    pub fn without_rows(&self, r0: usize, r1: usize) -> Image {
        let mut px = Vec::new();
        let mut h = 0;
        for y in 0..self.height {
            if y < r0 || y >= r1 {
                px.extend_from_slice(&self.pixels[y * self.width..(y + 1) * self.width]);
                h += 1;
            }
        }
        Image::new(self.width, h, px)
    }
}

/// Relative MSE of one image against a reference, mean((x − r)² / (r² + 0.01))
/// over pixels and channels, and the part of it the reference's own variance
/// `vr` accounts for, mean(V_R / (r² + 0.01)) (0 without `vr`).
pub fn rel_mse(x: &Image, r: &Image, vr: Option<&Image>) -> (f64, f64) {
    assert_eq!(x.pixels.len(), r.pixels.len(), "image sizes differ");
    let (mut rel, mut noise) = (0.0f64, 0.0f64);
    for i in 0..x.pixels.len() {
        for c in 0..3 {
            let (a, b) = (x.pixels[i][c] as f64, r.pixels[i][c] as f64);
            let d = 1.0 / (b * b + 0.01);
            rel += (a - b) * (a - b) * d;
            if let Some(v) = vr {
                noise += v.pixels[i][c].max(0.0) as f64 * d;
            }
        }
    }
    let n = (3 * x.pixels.len()) as f64;
    (rel / n, noise / n)
}

/// Result of a noise-aware comparison.
#[derive(Clone, Copy, Debug)]
pub struct Comparison {
    /// Bias estimate: mean of ((X − R)² − V_X − V_R) / (R² + 0.01).
    pub rel_mse_corrected: f64,
    /// Mean of (X − R)² / (R² + 0.01), noise included.
    pub rel_mse_raw: f64,
    /// Expected noise part of `rel_mse_raw`: mean of (V_X + V_R)/(R² + 0.01).
    pub rel_mse_noise: f64,
    /// Standard error of `rel_mse_corrected` under the noise model.
    pub std_error: f64,
    /// Mean of z² = (X − R)²/(V_X + V_R) over pixel-channels with variance > 0.
    pub mean_z2: f64,
    /// The renders' own variance: mean of V_X/(R² + 0.01). Compares estimators.
    pub rel_var_x: f64,
}

/// Compares two independent renders `x1`, `x2` against reference `r` with
/// variance `vr` (all the same size).
pub fn compare(x1: &Image, x2: &Image, r: &Image, vr: &Image) -> Comparison {
    let n = r.pixels.len();
    assert!(
        x1.pixels.len() == n && x2.pixels.len() == n && vr.pixels.len() == n,
        "image sizes differ"
    );
    let (mut corr, mut raw, mut noise, mut var_acc, mut z2, mut zn, mut var_x) = (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0f64, 0usize, 0.0f64);
    for i in 0..n {
        for c in 0..3 {
            let (a, b, rv, v) = (
                x1.pixels[i][c] as f64,
                x2.pixels[i][c] as f64,
                r.pixels[i][c] as f64,
                vr.pixels[i][c] as f64,
            );
            let x = 0.5 * (a + b);
            let vx = 0.25 * (a - b) * (a - b);
            let d = 1.0 / (rv * rv + 0.01);
            let e2 = (x - rv) * (x - rv);
            corr += (e2 - vx - v.max(0.0)) * d;
            raw += e2 * d;
            noise += (vx + v.max(0.0)) * d;
            var_x += vx * d;
            // Var of (e² − V̂_X − V_R) ≈ 2(V_X + V_R)² + 2V_X² (χ² terms), scaled by d²
            let vt = vx + v.max(0.0);
            var_acc += (2.0 * vt * vt + 2.0 * vx * vx) * d * d;
            if vt > 0.0 {
                z2 += e2 / vt;
                zn += 1;
            }
        }
    }
    let m = (3 * n) as f64;
    Comparison {
        rel_mse_corrected: corr / m,
        rel_mse_raw: raw / m,
        rel_mse_noise: noise / m,
        std_error: var_acc.sqrt() / m,
        mean_z2: if zn > 0 { z2 / zn as f64 } else { 0.0 },
        rel_var_x: var_x / m,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::hash_u32;

    fn noisy(base: &[f32], sigma: f32, seed: u32) -> Image {
        // sum of 12 uniforms - 6 ≈ N(0,1)
        let px = base
            .iter()
            .enumerate()
            .map(|(i, &b)| {
                let g = |c: u32| {
                    (0..12)
                        .map(|k| hash_u32(seed ^ hash_u32(i as u32 * 3 + c) ^ (k * 0x9e37_79b9)) as f32 / 4_294_967_296.0)
                        .sum::<f32>()
                        - 6.0
                };
                Vec3::new(b + sigma * g(0), b + sigma * g(1), b + sigma * g(2))
            })
            .collect();
        Image::new(base.len(), 1, px)
    }

    #[test]
    fn unbiased_noise_is_corrected_away_and_bias_is_not() {
        let base: Vec<f32> = (0..20000).map(|i| 0.2 + 0.6 * ((i % 97) as f32 / 97.0)).collect();
        let r = noisy(&base, 0.01, 1);
        let vr = Image::new(base.len(), 1, vec![Vec3::splat(0.01 * 0.01); base.len()]);
        let (x1, x2) = (noisy(&base, 0.05, 2), noisy(&base, 0.05, 3));
        let c = compare(&x1, &x2, &r, &vr);
        assert!(c.rel_mse_corrected.abs() < 4.0 * c.std_error, "{c:?}");
        assert!(c.rel_mse_raw > 10.0 * c.std_error, "the raw error is mostly noise");
        let biased: Vec<f32> = base.iter().map(|b| b * 1.05).collect();
        let c = compare(&noisy(&biased, 0.05, 2), &noisy(&biased, 0.05, 3), &r, &vr);
        assert!(c.rel_mse_corrected > 10.0 * c.std_error, "{c:?}");
    }
}
