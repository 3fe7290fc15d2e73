//! Ray–triangle kernels. Both are two-sided and reject degenerate triangles.
//!
//! * [`intersect_watertight`]: f32, Woop–Benthin–Wald watertight test with pbrt-v4's
//!   conservative `t > 0` bound — the default. Rays through a shared edge or vertex
//!   hit at least one of the triangles.
//! * [`intersect_moller_trumbore_f64`]: Möller–Trumbore in f64 exactly as the RDR171
//!   contract describes it (spec §14.2); used by `--compat rdr171`.

use crate::math::{gamma, Vec3};

/// Barycentric hit: `p = b0·p0 + b1·p1 + b2·p2`, distance `t` along the ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriHit {
    pub t: f32,
    pub b: [f32; 3],
}

#[inline]
fn permute(v: Vec3, x: usize, y: usize, z: usize) -> Vec3 {
    Vec3::new(v[x], v[y], v[z])
}

/// The watertight test's axis permutation `(kx, ky, kz)`: `kz` is the direction's
/// largest component. The SIMD block test in `accel/wide.rs` uses it too, so both
/// kernels give bit-identical hits.
#[inline(always)]
pub fn watertight_axes(d: Vec3) -> (usize, usize, usize) {
    let ad = d.abs();
    // kz = 0 if x is the largest, else 1 if y beats z, else 2 (NaN: 2); computed
    // without branches, which incoherent rays mispredict about half the time
    let x_max = (ad.x > ad.y) & (ad.x > ad.z);
    let y_over_z = ad.y > ad.z;
    let kz = (!x_max) as usize * (1 + (!y_over_z) as usize);
    // kx = kz + 1 and ky = kx + 1, modulo 3: two-bit fields of a constant (a table
    // indexed by kz was built on the stack for every ray)
    (0b00_10_01 >> (2 * kz) & 3, 0b01_00_10 >> (2 * kz) & 3, kz)
}

/// Watertight ray–triangle test (f32) for `t ∈ [t_min, t_max]`.
#[inline]
pub fn intersect_watertight(o: Vec3, d: Vec3, t_min: f32, t_max: f32, p: &[Vec3; 3]) -> Option<TriHit> {
    let (kx, ky, kz) = watertight_axes(d);
    let dp = permute(d, kx, ky, kz);
    if dp.z == 0.0 {
        return None; // zero direction
    }
    let mut p0 = permute(p[0] - o, kx, ky, kz);
    let mut p1 = permute(p[1] - o, kx, ky, kz);
    let mut p2 = permute(p[2] - o, kx, ky, kz);
    let sx = -dp.x / dp.z;
    let sy = -dp.y / dp.z;
    let sz = 1.0 / dp.z;
    p0.x += sx * p0.z;
    p0.y += sy * p0.z;
    p1.x += sx * p1.z;
    p1.y += sy * p1.z;
    p2.x += sx * p2.z;
    p2.y += sy * p2.z;

    let mut e0 = p1.x * p2.y - p1.y * p2.x;
    let mut e1 = p2.x * p0.y - p2.y * p0.x;
    let mut e2 = p0.x * p1.y - p0.y * p1.x;
    if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
        // Exactly on an edge in f32: decide in f64 so shared edges are not missed twice.
        let f = |a: f32, b: f32, c: f32, d: f32| (a as f64 * b as f64 - c as f64 * d as f64) as f32;
        e0 = f(p1.x, p2.y, p1.y, p2.x);
        e1 = f(p2.x, p0.y, p2.y, p0.x);
        e2 = f(p0.x, p1.y, p0.y, p1.x);
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    p0.z *= sz;
    p1.z *= sz;
    p2.z *= sz;
    let t_scaled = e0 * p0.z + e1 * p1.z + e2 * p2.z;
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max * det) {
        return None;
    }
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    if t < t_min || t > t_max {
        return None;
    }
    // Conservative bound: reject t that rounding could have pushed above zero.
    let max_zt = p0.z.abs().max(p1.z.abs()).max(p2.z.abs());
    let delta_z = gamma(3) * max_zt;
    let max_xt = p0.x.abs().max(p1.x.abs()).max(p2.x.abs());
    let max_yt = p0.y.abs().max(p1.y.abs()).max(p2.y.abs());
    // The shear errors δx, δy are in world units: use |z| before the 1/d_z scaling
    // (pbrt-v4 uses the scaled z here, which makes the bound grow with 1/|d|).
    let max_z = max_zt * dp.z.abs();
    let delta_x = gamma(5) * (max_xt + max_z);
    let delta_y = gamma(5) * (max_yt + max_z);
    let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let delta_t = 3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
    if t <= delta_t {
        return None;
    }
    Some(TriHit {
        t,
        b: [e0 * inv_det, e1 * inv_det, e2 * inv_det],
    })
}

/// f64 Möller–Trumbore hit with the unrounded distance (spec §14.2).
#[derive(Clone, Copy, Debug)]
pub struct TriHit64 {
    pub t: f64,
    pub u: f64,
    pub v: f64,
}

impl TriHit64 {
    /// Barycentrics as the original stores them: `1 − u − v` in f64, then cast.
    pub fn bary(&self) -> [f32; 3] {
        [(1.0 - self.u - self.v) as f32, self.u as f32, self.v as f32]
    }
}

#[inline]
fn dot64(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]
}
#[inline]
fn cross64(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
#[inline]
fn sub64(a: Vec3, b: Vec3) -> [f64; 3] {
    [a.x as f64 - b.x as f64, a.y as f64 - b.y as f64, a.z as f64 - b.z as f64]
}

/// Möller–Trumbore in f64, accepting `t_min ≤ t ≤ t_max`; |det| ≤ 1e-12 misses.
#[inline]
pub fn intersect_moller_trumbore_f64(o: Vec3, d: Vec3, t_min: f64, t_max: f64, p: &[Vec3; 3]) -> Option<TriHit64> {
    let d64 = [d.x as f64, d.y as f64, d.z as f64];
    let e1 = sub64(p[1], p[0]);
    let e2 = sub64(p[2], p[0]);
    let pv = cross64(d64, e2);
    let det = dot64(pv, e1);
    if det.abs() <= 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub64(o, p[0]);
    let u = dot64(s, pv) * inv;
    if u < 0.0 {
        return None;
    }
    let q = cross64(s, e1);
    let v = dot64(d64, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = dot64(q, e2) * inv;
    (t >= t_min && t <= t_max).then_some(TriHit64 { t, u, v })
}

/// Twice the area's vector: `(p1 − p0) × (p2 − p0)`.
#[inline]
pub fn cross_edges(p: &[Vec3; 3]) -> Vec3 {
    (p[1] - p[0]).cross(p[2] - p[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRI: [Vec3; 3] = [Vec3::ZERO, Vec3::X, Vec3::Y];

    fn both(o: Vec3, d: Vec3, t0: f32, t1: f32, p: &[Vec3; 3]) -> (Option<TriHit>, Option<TriHit64>) {
        (
            intersect_watertight(o, d, t0, t1, p),
            intersect_moller_trumbore_f64(o, d, t0 as f64, t1 as f64, p),
        )
    }

    #[test]
    fn course_unit_tests() {
        // hit from either side at (0.2, 0.3, 0)
        for (o, d) in [(Vec3::new(0.2, 0.3, -1.0), Vec3::Z), (Vec3::new(0.2, 0.3, 1.0), -Vec3::Z)] {
            let (w, m) = both(o, d, 1e-4, 1e7, &TRI);
            let w = w.unwrap();
            let m = m.unwrap();
            assert!((w.t - 1.0).abs() < 1e-6 && (m.t - 1.0).abs() < 1e-12);
            let pw = TRI[0] * w.b[0] + TRI[1] * w.b[1] + TRI[2] * w.b[2];
            assert!((pw - Vec3::new(0.2, 0.3, 0.0)).length() < 1e-4);
            let b = m.bary();
            let pm = TRI[0] * b[0] + TRI[1] * b[1] + TRI[2] * b[2];
            assert!((pm - Vec3::new(0.2, 0.3, 0.0)).length() < 1e-4);
        }
        // outside, parallel, out of range
        let miss = |o, d, t0, t1| {
            let (w, m) = both(o, d, t0, t1, &TRI);
            assert!(w.is_none() && m.is_none(), "{o} {d}");
        };
        miss(Vec3::new(2.0, 2.0, -1.0), Vec3::Z, 1e-4, 1e7);
        miss(Vec3::new(-1.0, 0.3, 0.0), Vec3::X, 1e-4, 1e7);
        miss(Vec3::new(0.2, 0.3, -1.0), Vec3::Z, 1.1, 2.0);
        // collinear triangle never hits
        let line = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        for d in [Vec3::Z, Vec3::Y, Vec3::new(0.1, 0.2, 0.9).normalize()] {
            let (w, m) = both(Vec3::new(0.5, -0.1, -1.0), d, 0.0, 1e7, &line);
            assert!(w.is_none() && m.is_none());
        }
        // a triangle in the xz plane hit from below
        let xz = [Vec3::ZERO, Vec3::Z, Vec3::X];
        let (w, _) = both(Vec3::new(0.2, -1.0, 0.3), Vec3::Y, 1e-4, 1e7, &xz);
        assert!((w.unwrap().t - 1.0).abs() < 1e-6);
    }

    #[test]
    fn watertight_shared_edge_is_hit_by_one_of_the_two_triangles() {
        let a = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let b = [Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        // points exactly on the diagonal x + y = 1
        for i in 1..100 {
            let x = i as f32 / 100.0;
            let d = Vec3::new(0.013, -0.007, 1.0).normalize();
            let o = Vec3::new(x, 1.0 - x, 0.0) - d;
            let ha = intersect_watertight(o, d, 0.0, 10.0, &a);
            let hb = intersect_watertight(o, d, 0.0, 10.0, &b);
            assert!(ha.is_some() || hb.is_some(), "ray {i} leaks between triangles");
        }
    }
}
