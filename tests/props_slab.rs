//! Property tests of the slab test (`Aabb::intersect`) against an f64 reference,
//! including rays through exact boundary points on a dyadic lattice.
//!
//! A splitmix64 generator with fixed seeds (`common::Rng`) drives many random
//! cases per test, so every run checks the same cases.

mod common;

use common::*;
use rdr::geometry::aabb::{safe_inverse, Aabb};
use rdr::math::Vec3;

/// Slab test in f64. Returns `None` when an axis with a zero direction component
/// has the origin outside its slab (an exact miss), else the clipped interval
/// `(t0, t1)` (a miss when `t0 > t1`).
fn ref_slab(b: &Aabb, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (t_min as f64, t_max as f64);
    for a in 0..3 {
        let (lo, hi, o, d) = (b.min[a] as f64, b.max[a] as f64, o[a] as f64, d[a] as f64);
        if d == 0.0 {
            if o < lo || o > hi {
                return None;
            }
            continue;
        }
        let (n, f) = ((lo - o) / d, (hi - o) / d);
        t0 = t0.max(n.min(f));
        t1 = t1.min(n.max(f));
    }
    Some((t0, t1))
}

// `Aabb::intersect` takes `inv_d` from `safe_inverse` (zero components become
// ±1e30, never ±∞), and the BVH stores `padded()` boxes, which have no zero
// thickness. So: a padded box must be hit by every ray that touches the closed
// unpadded box, flat boxes and rays lying in a face included; a plain box only
// where no zero direction component has its origin exactly on that slab's
// boundary (there the slab degenerates to [0, 0] or [−∞, 0]).

/// Whether some axis with a zero direction component has the origin exactly on
/// the box's boundary plane.
fn on_parallel_face(b: &Aabb, o: Vec3, d: Vec3) -> bool {
    (0..3).any(|a| d[a] == 0.0 && (o[a] == b.min[a] || o[a] == b.max[a]))
}

#[test]
fn slab_test_matches_f64_reference() {
    let mut rng = Rng::new(6);
    let (mut hits, mut misses, mut face_rays) = (0, 0, 0);
    for case in 0..2_000_000 {
        let scale = rng.log_range(1e-3, 1e3) as f32;
        let min = rng.in_cube(10.0 * scale);
        let mut ext = Vec3::ZERO;
        for a in 0..3 {
            if !rng.chance(0.25) {
                ext[a] = rng.log_range(1e-3, 10.0) as f32 * scale;
            }
        }
        let raw = Aabb::new(min, min + ext);
        let padded = raw.padded();
        let mut o = match rng.below(4) {
            0 => rng.in_cube(30.0 * scale),
            _ => rng.in_box(&raw),
        };
        // put the origin on faces, edges or corners now and then
        for a in 0..3 {
            if rng.chance(0.25) {
                o[a] = if rng.chance(0.5) { raw.min[a] } else { raw.max[a] };
            }
        }
        let mut d = if rng.chance(0.5) {
            rng.dir()
        } else {
            let t = rng.in_box(&raw) + rng.in_cube(0.1 * scale);
            let v = t - o;
            if v.length() > 1e-3 * scale {
                v.normalize()
            } else {
                rng.dir()
            }
        };
        for a in 0..3 {
            if rng.chance(0.2) {
                d[a] = 0.0 * rng.sign(); // ±0
            }
        }
        if d == Vec3::ZERO {
            continue;
        }
        let d = d * rng.log_range(0.1, 10.0) as f32;
        let t_min = if rng.chance(0.6) { 0.0 } else { rng.rangef(0.0, 5.0 * scale) };
        let t_max = match rng.below(3) {
            0 => f32::INFINITY,
            1 => 1e7,
            _ => t_min + rng.rangef(0.0, 40.0 * scale),
        };
        let inv = safe_inverse(d);
        let on_face = on_parallel_face(&raw, o, d);
        face_rays += on_face as usize;
        for (bx, reference_box) in [(padded, raw), (raw, raw)] {
            let is_raw = bx == raw && padded != raw;
            let got = bx.intersect(o, inv, t_min, t_max);
            let ctx = || {
                format!(
                    "case {case}: box {bx:?} (padded: {}) o={o} d={d} range=[{t_min}, {t_max}] -> {got:?}",
                    !is_raw
                )
            };
            // hits: judged on the unpadded box
            if let Some((t0, t1)) = ref_slab(&reference_box, o, d, t_min, t_max) {
                let margin = 1e-5 * (t0.abs() + if t1.is_finite() { t1.abs() } else { 0.0 }) + 1e-30;
                if t1 - t0 > margin && !(is_raw && on_face) {
                    hits += 1;
                    let Some(te) = got else {
                        panic!("reference hits on [{t0}, {t1}]: {}", ctx())
                    };
                    assert!(te as f64 <= t0 + margin, "entry {te} after the reference's {t0}: {}", ctx());
                    assert!(te >= t_min, "entry before t_min: {}", ctx());
                }
            }
            // misses: judged on the box actually tested
            match ref_slab(&bx, o, d, t_min, t_max) {
                None => {
                    misses += 1;
                    assert!(got.is_none(), "a ray parallel to a slab and outside it should miss: {}", ctx());
                }
                Some((t0, t1)) => {
                    let margin = 1e-5 * (t0.abs() + if t1.is_finite() { t1.abs() } else { 0.0 }) + 1e-30;
                    if t0 - t1 > margin {
                        misses += 1;
                        assert!(got.is_none(), "reference misses by [{t0}, {t1}]: {}", ctx());
                    }
                }
            }
        }
    }
    assert!(
        hits > 500_000 && misses > 500_000 && face_rays > 50_000,
        "{hits} hits, {misses} misses, {face_rays} on faces"
    );
}

#[test]
fn slab_test_hits_through_exact_boundary_points() {
    // Boxes flat on 0–3 axes; rays through an exact point of the closed box — on a
    // flat plane, an edge, a corner — must hit. Everything on a lattice, so the ray
    // passes through that point exactly.
    let mut rng = Rng::new(7);
    let mut raw_checked = 0;
    for case in 0..1_000_000 {
        let unit = pow2(rng.int(-20, 10) as i32);
        let min = rng.int3(-2000, 2000);
        let mut max = min;
        let flat = rng.below(4); // number of flat axes
        let mut axes = [0usize, 1, 2];
        axes.swap(0, rng.below(3));
        for &a in &axes[flat..] {
            max[a] += rng.int(1, 2000);
        }
        // a point of the closed box: each coordinate at min, at max, or in between
        let mut q = [0i64; 3];
        for a in 0..3 {
            q[a] = match rng.below(3) {
                0 => min[a],
                1 => max[a],
                _ => rng.int(min[a], max[a]),
            };
        }
        let dist = rng.log_range(1.0, 1e5);
        let Some((o, d, _)) = exact_ray_through(&mut rng, q, unit, dist) else {
            continue;
        };
        let raw = Aabb::new(lat(min, unit), lat(max, unit));
        let t = (lat(q, unit) - o).length() / d.length();
        let t_max = if rng.chance(0.5) { f32::INFINITY } else { t * 1.001 };
        let inv = safe_inverse(d);
        let mut boxes = vec![raw.padded()];
        if !on_parallel_face(&raw, o, d) {
            boxes.push(raw);
            raw_checked += 1;
        }
        for bx in boxes {
            let got = bx.intersect(o, inv, 0.0, t_max);
            assert!(got.is_some(), "case {case}: ray through {q:?} of box {bx:?} misses: o={o} d={d}");
            assert!(got.unwrap() <= t * 1.000_01, "case {case}: entry {got:?} after the point at {t}");
        }
    }
    assert!(raw_checked > 500_000);
}
