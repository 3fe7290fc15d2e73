//! How `guided`'s iterations make one image: each iteration's estimated
//! variance (from the spread of its samples within pixels, or from the
//! differences between iterations' images) and their inverse-variance weighted
//! combination.

use super::PROBE_BLOCKS;
use crate::film::Sums;
use crate::math::Vec3;

/// The mean of a film's samples per pixel (film rows, `y` up; black without weight).
pub fn current_image(sums: &Sums) -> Vec<Vec3> {
    sums.sum
        .iter()
        .zip(&sums.weight)
        .map(|(s, w)| {
            if *w != 0.0 {
                let wf = *w as f32;
                Vec3::new(s[0] as f32 / wf, s[1] as f32 / wf, s[2] as f32 / wf)
            } else {
                Vec3::ZERO
            }
        })
        .collect()
}

/// One iteration's image, the variance of each of its pixel means (NaN: no
/// estimate) and its samples per pixel.
#[derive(Clone, Copy, Debug)]
pub struct Part<'a> {
    pub image: &'a [Vec3],
    pub pixel_variance: &'a [f32],
    pub spp: u32,
}

/// Var(pixel mean) of the mean over channels per pixel, from the moments Σy,
/// Σy², n. With one sample per pixel it comes from horizontal pairs of pixels,
/// (y_a − y_b)²/2 (an overestimate where the image has gradients).
pub fn pixel_variances(moments: &[[f64; 3]], width: usize) -> Vec<f32> {
    moments
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let count = m[2];
            if count <= 0.0 {
                return f32::NAN;
            }
            let mean = m[0] / count;
            if count >= 2.0 {
                return (((m[1] - m[0] * mean) / (count - 1.0)).max(0.0) / count) as f32;
            }
            let x = i % width;
            let even = x.is_multiple_of(2);
            if even && x + 1 >= width {
                return f32::NAN;
            }
            let j = if even { i + 1 } else { i - 1 };
            if j >= moments.len() || moments[j][2] <= 0.0 {
                return f32::NAN;
            }
            let other = moments[j][0] / moments[j][2];
            (0.5 * (mean - other) * (mean - other)) as f32
        })
        .collect()
}

/// Each iteration's estimated relative variance: the mean over pixels of
/// Var(pixel mean) / (r² + 0.01), the `rdr compare` metric's weighting, with one
/// denominator r per pixel for all iterations: the mean of all their samples.
/// (Each iteration's own pixel mean there would shrink the variance exactly where
/// a rare bright sample raised it, and overweight the short early iterations.)
///
/// With three or more iterations the variances come from the differences of
/// their images instead: iterations are independent and unbiased, so the mean
/// D_ab of (I_a − I_b)² / (r² + 0.01) estimates V_a + V_b, and the least-squares
/// solution of those K(K−1)/2 equations is V_a = (R_a − S)/(K − 2), R_a = Σ_b D_ab,
/// S = ΣD / (K − 1). Unlike the samples' spread within a pixel, this sees what the
/// stratified sampler gains in a long iteration over a short one (an iteration of
/// 30 spp has less than 1/30 of the per-sample variance of one of 1 or 2 spp; on
/// `env_sphere` weights by the spread within pixels gave 1.39× the error of one
/// uninterrupted sequence of 45 spp). When a solution is not positive, the
/// spread within pixels is used.
pub fn relative_variances(parts: &[Part]) -> Vec<f64> {
    let within = relative_variances_within(parts);
    let k = parts.len();
    if k < 3 {
        return within;
    }
    let n = parts[0].image.len();
    let total_spp: f64 = parts.iter().map(|p| p.spp as f64).sum::<f64>().max(1.0);
    let mut d = vec![0.0f64; k * k];
    let mut y = vec![0.0f64; k];
    for i in 0..n {
        let mut r = 0.0f64;
        for (yk, p) in y.iter_mut().zip(parts) {
            let c = p.image[i];
            *yk = ((c.x + c.y + c.z) / 3.0) as f64;
            r += p.spp as f64 * *yk;
        }
        r /= total_spp;
        let norm = 1.0 / (r * r + 0.01);
        for a in 0..k {
            for b in a + 1..k {
                let e = y[a] - y[b];
                d[a * k + b] += e * e * norm;
            }
        }
    }
    let mut row = vec![0.0f64; k];
    let mut total = 0.0f64;
    for a in 0..k {
        for b in a + 1..k {
            let x = d[a * k + b] / n.max(1) as f64;
            row[a] += x;
            row[b] += x;
            total += x;
        }
    }
    let s = total / (k - 1) as f64;
    let v: Vec<f64> = row.iter().map(|r| (r - s) / (k - 2) as f64).collect();
    if v.iter().all(|x| *x > 0.0 && x.is_finite()) {
        v
    } else {
        within
    }
}

/// [`relative_variances`] from the spread of each iteration's samples within its
/// pixels.
pub fn relative_variances_within(parts: &[Part]) -> Vec<f64> {
    let Some(first) = parts.first() else { return Vec::new() };
    let n = first.image.len();
    let total_spp: f64 = parts.iter().map(|p| p.spp as f64).sum::<f64>().max(1.0);
    let mut acc = vec![(0.0f64, 0usize); parts.len()];
    for i in 0..n {
        let r: f64 = parts
            .iter()
            .map(|p| {
                let c = p.image[i];
                p.spp as f64 * ((c.x + c.y + c.z) / 3.0) as f64
            })
            .sum::<f64>()
            / total_spp;
        let norm = 1.0 / (r * r + 0.01);
        for (a, p) in acc.iter_mut().zip(parts) {
            let v = p.pixel_variance[i];
            if v.is_finite() {
                a.0 += v as f64 * norm;
                a.1 += 1;
            }
        }
    }
    acc.iter().map(|&(s, c)| if c == 0 { 0.0 } else { s / c as f64 }).collect()
}

/// The iterations' images combined with weights 1 / their relative variance
/// (an iteration without a variance estimate weighs as much as its spp
/// suggest, relative to the others).
pub fn combine(parts: &[Part], pixels: usize) -> Vec<Vec3> {
    match parts {
        [] => return vec![Vec3::ZERO; pixels],
        [only] => return only.image.to_vec(),
        _ => {}
    }
    combine_weighted(parts, &iteration_weights(&relative_variances(parts), parts), pixels)
}

/// The iterations' images with the given weights (by spp: every sample alike, the
/// image of one film holding them all).
pub fn combine_weighted(parts: &[Part], weights: &[f64], pixels: usize) -> Vec<Vec3> {
    if parts.is_empty() {
        return vec![Vec3::ZERO; pixels];
    }
    let total: f64 = weights.iter().sum();
    (0..pixels)
        .map(|i| {
            let mut acc = [0.0f64; 3];
            for (p, w) in parts.iter().zip(weights) {
                let c = p.image[i];
                acc[0] += c.x as f64 * w;
                acc[1] += c.y as f64 * w;
                acc[2] += c.z as f64 * w;
            }
            Vec3::new((acc[0] / total) as f32, (acc[1] / total) as f32, (acc[2] / total) as f32)
        })
        .collect()
}

/// Normalised weights 1/v_k; iterations whose variance is 0 or unknown (a black
/// image) fall back to weights by spp.
pub fn iteration_weights(variances: &[f64], parts: &[Part]) -> Vec<f64> {
    let w: Vec<f64> = variances
        .iter()
        .map(|&v| if v > 0.0 && v.is_finite() { 1.0 / v } else { 0.0 })
        .collect();
    if w.contains(&0.0) || w.iter().sum::<f64>() <= 0.0 {
        return parts.iter().map(|p| p.spp as f64).collect();
    }
    let total: f64 = w.iter().sum();
    w.iter().map(|x| x / total).collect()
}

/// The variances of two independent unbiased images X and Y from each pixel's weighted
/// squared differences [(X − Y)², (X − Z)², (Y − Z)²] with each other and with a third
/// image Z independent of both, whose expectations are v_X + v_Y, v_X + v_Z and v_Y + v_Z:
/// each of [`PROBE_BLOCKS`] blocks of pixels (dealt out in turn) solved alone, and the
/// median over the blocks of each variance. A firefly lands in one block and moves no
/// median while fewer than half the blocks hold one: a handful of pixels cannot decide
/// (the plain means over all pixels measured veach_path's guide at 0.02, 81.6 and 0.39
/// of its BSDF sampling in turn). A tail that the render sees, a bright sample in one
/// pixel of a few thousand, lands in most blocks and counts; with many more blocks, each
/// of a few hundred pixels, most would hold none of it (caustic_cbox, whose unguided
/// variance is such a tail: the guide measured 1.3–1.5× as noisy with 255 blocks,
/// 0.29–0.79× with 15). `None` unless both are positive.
pub fn difference_variances(terms: &[[f64; 3]]) -> Option<(f64, f64)> {
    let blocks = PROBE_BLOCKS.min(terms.len());
    if blocks == 0 {
        return None;
    }
    let mut sums = vec![[0.0f64; 4]; blocks];
    for (i, t) in terms.iter().enumerate() {
        let b = &mut sums[i % blocks];
        for c in 0..3 {
            b[c] += t[c];
        }
        b[3] += 1.0;
    }
    let (mut x, mut y): (Vec<f64>, Vec<f64>) = sums
        .iter()
        .map(|b| (0.5 * (b[0] + b[1] - b[2]) / b[3], 0.5 * (b[0] + b[2] - b[1]) / b[3]))
        .unzip();
    let (x, y) = (median(&mut x), median(&mut y));
    (x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite()).then_some((x, y))
}

/// The median of `v` (the upper one of an even count), reordering it.
fn median(v: &mut [f64]) -> f64 {
    let mid = v.len() / 2;
    *v.select_nth_unstable_by(mid, f64::total_cmp).1
}
