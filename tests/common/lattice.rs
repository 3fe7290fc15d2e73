//! Exact lattice helpers: on a dyadic integer lattice every coordinate,
//! difference and `o = p − m·d` is exact in f32, and the geometric predicates
//! can be decided exactly in i128.

use super::rng::Rng;
use rdr::math::Vec3;

pub type I3 = [i64; 3];

/// 2^k as f32, exactly.
pub fn pow2(k: i32) -> f32 {
    assert!((-126..=127).contains(&k));
    f32::from_bits(((127 + k) as u32) << 23)
}

/// Lattice point to f32; exact while every |component| < 2^24 and `unit` is a power of two.
pub fn lat(v: I3, unit: f32) -> Vec3 {
    assert!(v.iter().all(|c| c.abs() < 1 << 24), "lattice point {v:?} not exact in f32");
    Vec3::new(v[0] as f32 * unit, v[1] as f32 * unit, v[2] as f32 * unit)
}

pub fn isub(a: I3, b: I3) -> I3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn iadd(a: I3, b: I3) -> I3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub fn iscale(a: I3, k: i64) -> I3 {
    [a[0] * k, a[1] * k, a[2] * k]
}

pub fn icross(a: I3, b: I3) -> [i128; 3] {
    let (a, b) = (a.map(|x| x as i128), b.map(|x| x as i128));
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// a · (b × c), exactly.
pub fn idet(a: I3, b: I3, c: I3) -> i128 {
    let n = icross(b, c);
    a[0] as i128 * n[0] + a[1] as i128 * n[1] + a[2] as i128 * n[2]
}

/// Ray through an exact lattice point `q` (lattice `unit`) from roughly `dist`
/// lattice steps away: origin `q − m·d` with a small integer `d` and a power of
/// two `m`, all exact. The direction's length is an unrelated power of two.
pub fn exact_ray_through(rng: &mut Rng, q: I3, unit: f32, dist: f64) -> Option<(Vec3, Vec3, I3)> {
    let d = rng.int3(-16, 16);
    if d == [0, 0, 0] {
        return None;
    }
    let len = (d.iter().map(|&c| (c * c) as f64).sum::<f64>()).sqrt();
    let m = 1i64 << (dist / len).log2().floor().max(0.0) as i64;
    let o = isub(q, iscale(d, m));
    Some((lat(o, unit), lat(d, unit * pow2(rng.int(-8, 16) as i32)), d))
}
