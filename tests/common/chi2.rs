//! χ² goodness-of-fit of direction samplers against their pdf (the Mitsuba
//! approach: bins of equal solid angle in (cos θ, φ), expected counts by
//! integrating the pdf over each bin). Shared by the sampling and material tests.

use rdr::math::{Frame, Vec2, Vec3, PI};

pub const N_COS: usize = 40;
pub const N_PHI: usize = 80;

/// Bin of `w` when the (cos θ) bins cover only `[cos_min, 1]`.
pub fn bin_in_cap(frame: &Frame, w: Vec3, cos_min: f32) -> Option<usize> {
    let l = frame.to_local(w);
    let t = (l.z.clamp(-1.0, 1.0) - cos_min) / (1.0 - cos_min);
    if t < 0.0 {
        return None;
    }
    let c = (t * N_COS as f32).min(N_COS as f32 - 1.0) as usize;
    let mut phi = l.y.atan2(l.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let p = (phi / (2.0 * PI) * N_PHI as f32).min(N_PHI as f32 - 1.0) as usize;
    Some(c * N_PHI + p)
}

/// χ² test of `n` samples against bin probabilities `mass[b]` (which may sum to
/// less than 1 when sampling can fail); panics when it fails.
pub fn chi2_bins(name: &str, n: usize, observed: &[f64], mass: &[f64]) {
    if let Err(e) = chi2_test(name, n, observed, mass) {
        panic!("{e}");
    }
}

/// The χ² statistic of `observed` counts against bin probabilities `mass` (bins
/// expecting fewer than 5 pooled) as a z-score (Wilson–Hilferty); `Err` when the
/// samples do not follow the masses (p ≈ 1e-4 one-sided: a correct sampler fails
/// about once in 10,000 runs) or the masses do not sum to what was drawn.
pub fn chi2_test(name: &str, n: usize, observed: &[f64], mass: &[f64]) -> Result<f64, String> {
    let (mut stat, mut dof, mut pool_o, mut pool_e) = (0.0f64, 0usize, 0.0f64, 0.0f64);
    for (o, m) in observed.iter().zip(mass) {
        let e = m * n as f64;
        if e < 5.0 {
            pool_o += o;
            pool_e += e;
        } else {
            stat += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        dof += 1;
    } else if pool_o > 1e-4 * n as f64 {
        // bins the quadrature saw no support in; only a sliver along an edge may fall there
        return Err(format!("{name}: {pool_o} samples where the pdf is zero"));
    }
    let total: f64 = mass.iter().sum::<f64>() * n as f64;
    let drawn: f64 = observed.iter().sum();
    if (total - drawn).abs() > 5.0 * total.sqrt() + 0.002 * n as f64 {
        return Err(format!("{name}: the pdf integrates to {total:.0} of the {drawn} samples drawn"));
    }
    let k = (dof - 1) as f64;
    let z = ((stat / k).cbrt() - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt();
    eprintln!("{name}: χ² = {stat:.1} with {} dof, z = {z:.2}", dof - 1);
    if z < 3.72 {
        Ok(z)
    } else {
        Err(format!(
            "{name}: samples do not follow the pdf (χ² = {stat:.1}, dof {}, z = {z:.2})",
            dof - 1
        ))
    }
}

/// Directions binned by (cos θ, φ) about `frame.n`; bin masses by a 16×16
/// midpoint rule of the pdf.
pub fn chi2(name: &str, n: usize, frame: Frame, sample: impl FnMut(Vec2) -> Option<Vec3>, pdf: impl Fn(Vec3) -> f32) {
    chi2_cap(name, n, frame, -1.0, sample, pdf)
}

/// As [`chi2`] with the bins covering only the cap `cos θ ≥ cos_min` (a sample
/// outside it counts in an extra bin of zero expectation).
pub fn chi2_cap(name: &str, n: usize, frame: Frame, cos_min: f32, mut sample: impl FnMut(Vec2) -> Option<Vec3>, pdf: impl Fn(Vec3) -> f32) {
    let mut rng = rdr::sampling::SplitMix64(0x1234_5678 ^ name.len() as u64);
    let mut observed = vec![0.0f64; N_COS * N_PHI + 1];
    for _ in 0..n {
        if let Some(w) = sample(Vec2::new(rng.unit_f32(), rng.unit_f32())) {
            observed[bin_in_cap(&frame, w, cos_min).unwrap_or(N_COS * N_PHI)] += 1.0;
        }
    }
    let k = 16;
    let span = 1.0 - cos_min as f64;
    let d_area = (span / N_COS as f64) * (2.0 * std::f64::consts::PI / N_PHI as f64) / (k * k) as f64;
    let mut mass = vec![0.0f64; N_COS * N_PHI + 1];
    for c in 0..N_COS {
        for p in 0..N_PHI {
            let mut acc = 0.0f64;
            for i in 0..k {
                for j in 0..k {
                    let cos = cos_min as f64 + span * (c as f64 + (i as f64 + 0.5) / k as f64) / N_COS as f64;
                    let phi = 2.0 * std::f64::consts::PI * (p as f64 + (j as f64 + 0.5) / k as f64) / N_PHI as f64;
                    let s = (1.0 - cos * cos).max(0.0).sqrt();
                    let local = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, cos as f32);
                    acc += pdf(frame.to_world(local)) as f64 * d_area;
                }
            }
            mass[c * N_PHI + p] = acc;
        }
    }
    chi2_bins(name, n, &observed, &mass);
}
