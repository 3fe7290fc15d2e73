//! Property tests of the geometric queries against brute force: the two triangle
//! kernels, the slab test, the BVH (closest hit, any hit, structure) and the full
//! `Scene` queries.
//!
//! No extra dependencies: a splitmix64 generator with fixed seeds drives many
//! random cases per test, so every run checks the same cases. Where a property
//! only holds for exact geometry (shared edges, rays lying in a plane, collinear
//! vertices) the cases are built on a dyadic integer lattice, where every
//! coordinate, difference and `o = p − m·d` is exact in f32, and the geometric
//! predicates are decided exactly in i128.

use rdr::accel::bvh::{Bvh, MAX_LEAF};
use rdr::accel::wide::{ChildRef, Isa, WideBvh, LANES};
use rdr::geometry::aabb::{safe_inverse, Aabb};
use rdr::geometry::triangle::{intersect_moller_trumbore_f64, intersect_watertight};
use rdr::geometry::Ray;
use rdr::math::Vec3;
use rdr::scene::build::{build_bvh, prim_bounds};
use rdr::scene::Prim;
use std::path::Path;

// ---------------------------------------------------------------------------
// Deterministic random numbers
// ---------------------------------------------------------------------------

/// Test generator: splitmix64 with helpers for ranges.
struct Rng(rdr::sampling::SplitMix64);

impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(rdr::sampling::SplitMix64(
            seed.wrapping_mul(0xD1B5_4A32_D192_ED03) ^ 0x9E37_79B9_7F4A_7C15,
        ))
    }
    fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        self.0.unit_f64()
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn rangef(&mut self, lo: f32, hi: f32) -> f32 {
        self.range(lo as f64, hi as f64) as f32
    }
    /// Log-uniform in [lo, hi).
    fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        self.range(lo.ln(), hi.ln()).exp()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    /// Uniform integer in [lo, hi].
    fn int(&mut self, lo: i64, hi: i64) -> i64 {
        lo + (self.next_u64() % (hi - lo + 1) as u64) as i64
    }
    fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    fn sign(&mut self) -> f32 {
        if self.chance(0.5) {
            1.0
        } else {
            -1.0
        }
    }
    fn in_cube(&mut self, r: f32) -> Vec3 {
        Vec3::new(self.rangef(-r, r), self.rangef(-r, r), self.rangef(-r, r))
    }
    fn in_box(&mut self, b: &Aabb) -> Vec3 {
        let mut p = Vec3::ZERO;
        for a in 0..3 {
            p[a] = self.rangef(b.min[a], b.max[a]).clamp(b.min[a], b.max[a]);
        }
        p
    }
    /// Uniform unit vector.
    fn dir(&mut self) -> Vec3 {
        loop {
            let v = self.in_cube(1.0);
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
    /// Barycentric coordinates uniform over the triangle.
    fn bary(&mut self) -> [f32; 3] {
        let (mut u, mut v) = (self.unit() as f32, self.unit() as f32);
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        [1.0 - u - v, u, v]
    }
    fn int3(&mut self, lo: i64, hi: i64) -> I3 {
        [self.int(lo, hi), self.int(lo, hi), self.int(lo, hi)]
    }
}

// ---------------------------------------------------------------------------
// Exact lattice helpers
// ---------------------------------------------------------------------------

type I3 = [i64; 3];

/// 2^k as f32, exactly.
fn pow2(k: i32) -> f32 {
    assert!((-126..=127).contains(&k));
    f32::from_bits(((127 + k) as u32) << 23)
}

/// Lattice point to f32; exact while every |component| < 2^24 and `unit` is a power of two.
fn lat(v: I3, unit: f32) -> Vec3 {
    assert!(v.iter().all(|c| c.abs() < 1 << 24), "lattice point {v:?} not exact in f32");
    Vec3::new(v[0] as f32 * unit, v[1] as f32 * unit, v[2] as f32 * unit)
}

fn isub(a: I3, b: I3) -> I3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn iadd(a: I3, b: I3) -> I3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn iscale(a: I3, k: i64) -> I3 {
    [a[0] * k, a[1] * k, a[2] * k]
}
fn icross(a: I3, b: I3) -> [i128; 3] {
    let (a, b) = (a.map(|x| x as i128), b.map(|x| x as i128));
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
/// a · (b × c), exactly.
fn idet(a: I3, b: I3, c: I3) -> i128 {
    let n = icross(b, c);
    a[0] as i128 * n[0] + a[1] as i128 * n[1] + a[2] as i128 * n[2]
}

// ---------------------------------------------------------------------------
// References
// ---------------------------------------------------------------------------

/// The ray's plane crossing in f64 with unclipped barycentrics (None when the ray
/// is parallel to the plane or the triangle is degenerate).
fn ref_triangle(o: Vec3, d: Vec3, p: &[Vec3; 3]) -> Option<(f64, [f64; 3])> {
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let [p0, p1, p2] = p.map(|v| v.as_dvec3());
    let (e1, e2) = (p1 - p0, p2 - p0);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det.abs() <= 1e-9 * d.length() * e1.length() * e2.length() {
        return None;
    }
    let s = o - p0;
    let u = s.dot(pv) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    Some((t, [1.0 - u - v, u, v]))
}

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

fn prim_intersect(p: &Prim, ray: &Ray, t_max: f32) -> Option<f32> {
    match p {
        Prim::Triangle { p, .. } => intersect_watertight(ray.o, ray.d, ray.t_min, t_max, p).map(|h| h.t),
        Prim::Sphere { sphere, .. } => sphere.intersect(ray.o, ray.d, ray.t_min, t_max),
    }
}

/// Closest hit over all primitives by brute force (first index wins ties).
fn brute_closest(prims: &[Prim], ray: &Ray) -> Option<(u32, f32)> {
    let mut best: Option<(u32, f32)> = None;
    for (i, p) in prims.iter().enumerate() {
        if let Some(t) = prim_intersect(p, ray, ray.t_max) {
            if best.is_none_or(|(_, bt)| t < bt) {
                best = Some((i as u32, t));
            }
        }
    }
    best
}

fn bvh_closest(bvh: &Bvh, prims: &[Prim], ray: &Ray) -> Option<(u32, f32)> {
    let mut best = None;
    bvh.traverse(ray, |i, t_max| {
        if let Some(t) = prim_intersect(&prims[i as usize], ray, *t_max) {
            *t_max = t;
            best = Some((i, t));
        }
        false
    });
    best
}

fn bvh_any(bvh: &Bvh, prims: &[Prim], ray: &Ray) -> bool {
    let mut hit = false;
    bvh.traverse(ray, |i, t_max| {
        hit = prim_intersect(&prims[i as usize], ray, *t_max).is_some();
        hit
    });
    hit
}

fn tri(p: [Vec3; 3], index: u32) -> Prim {
    Prim::Triangle { p, object: 0, index }
}

// ---------------------------------------------------------------------------
// 1. Triangle kernels
// ---------------------------------------------------------------------------

/// A random well-shaped triangle of size ~`scale` somewhere up to 100·scale from the origin.
fn random_triangle(rng: &mut Rng) -> ([Vec3; 3], f32) {
    loop {
        let scale = rng.log_range(1e-2, 1e3) as f32;
        let center = rng.in_cube(1.0) * scale * rng.rangef(0.0, 100.0);
        let p = [0; 3].map(|_| center + rng.in_cube(scale));
        let area2 = (p[1] - p[0]).cross(p[2] - p[0]).length();
        let longest = (p[1] - p[0]).length().max((p[2] - p[1]).length()).max((p[0] - p[2]).length());
        if area2 > 0.05 * longest * longest {
            return (p, scale);
        }
    }
}

fn unit_normal(p: &[Vec3; 3]) -> Vec3 {
    (p[1] - p[0]).cross(p[2] - p[0]).normalize()
}

#[test]
fn triangle_kernels_agree_away_from_edges() {
    let mut rng = Rng::new(1);
    let (mut inside, mut outside) = (0, 0);
    for case in 0..1_000_000 {
        let (p, scale) = random_triangle(&mut rng);
        let n = unit_normal(&p);
        let [b0, b1, b2] = if rng.chance(0.5) {
            rng.bary()
        } else {
            let (b1, b2) = (rng.rangef(-0.3, 1.3), rng.rangef(-0.3, 1.3));
            [1.0 - b1 - b2, b1, b2]
        };
        let target = p[0] * b0 + p[1] * b1 + p[2] * b2;
        let dir = loop {
            let d = rng.dir();
            if d.dot(n).abs() > 0.1 {
                break d;
            }
        };
        let dist = rng.log_range(0.5, 20.0) as f32 * scale;
        // now and then the triangle lies behind the origin
        let o = if rng.chance(0.1) {
            target + dir * dist
        } else {
            target - dir * dist
        };
        let d = dir * rng.log_range(0.1, 10.0) as f32;
        let t_min = if rng.chance(0.5) { 0.0 } else { 1e-4 };
        let t_expected = dist / d.length();
        let t_max = match rng.below(4) {
            0 => f32::INFINITY,
            1 => 1e7,
            2 => t_expected * rng.rangef(0.5, 0.99),
            _ => t_expected * rng.rangef(1.01, 2.0),
        };
        let Some((t, b)) = ref_triangle(o, d, &p) else {
            panic!("case {case}: reference found no plane crossing")
        };
        let w = intersect_watertight(o, d, t_min, t_max, &p);
        let m = intersect_moller_trumbore_f64(o, d, t_min as f64, t_max as f64, &p);
        let bmin = b[0].min(b[1]).min(b[2]);
        let margin = 1e-4 * t.abs();
        let t_inside = t > t_min as f64 + margin && t < t_max as f64 - margin;
        let t_outside = t < t_min as f64 - margin || t > t_max as f64 + margin;
        let ctx = || format!("case {case}: p={p:?} o={o} d={d} range=[{t_min}, {t_max}] ref t={t} b={b:?} -> wt={w:?} mt={m:?}");
        if bmin > 1e-3 && t_inside {
            inside += 1;
            let (Some(w), Some(m)) = (w, m) else {
                panic!("both kernels should hit: {}", ctx())
            };
            assert!((w.t as f64 - t).abs() <= 1e-4 * t, "watertight t off: {}", ctx());
            assert!((m.t - t).abs() <= 1e-4 * t, "Möller–Trumbore t off: {}", ctx());
            assert!((w.t as f64 - m.t).abs() <= 1e-4 * m.t, "kernels disagree on t: {}", ctx());
            let mb = [1.0 - m.u - m.v, m.u, m.v];
            for k in 0..3 {
                assert!((w.b[k] as f64 - b[k]).abs() < 1e-3, "watertight barycentrics off: {}", ctx());
                assert!((mb[k] - b[k]).abs() < 1e-6, "Möller–Trumbore barycentrics off: {}", ctx());
            }
            let wsum = w.b[0] + w.b[1] + w.b[2];
            assert!((wsum - 1.0).abs() < 1e-5, "watertight barycentrics do not sum to 1: {}", ctx());
        } else if bmin < -1e-3 || t_outside {
            outside += 1;
            assert!(w.is_none(), "watertight should miss: {}", ctx());
            assert!(m.is_none(), "Möller–Trumbore should miss: {}", ctx());
        }
    }
    assert!(
        inside > 200_000 && outside > 200_000,
        "too few decisive cases: {inside} inside, {outside} outside"
    );
}

#[test]
fn degenerate_triangles_never_hit() {
    let mut rng = Rng::new(2);
    let mut mt_checked = 0;
    for case in 0..200_000 {
        let kind = rng.below(3);
        let mut p = match kind {
            // two equal vertices
            0 => {
                let s = rng.log_range(1e-3, 1e3) as f32;
                let a = rng.in_cube(s);
                let b = a + rng.in_cube(s);
                [a, a, b]
            }
            // all three equal
            1 => {
                let s = rng.log_range(1e-3, 1e3) as f32;
                let a = rng.in_cube(s);
                [a, a, a]
            }
            // three distinct collinear lattice points a + k·s, exact in f32
            _ => {
                let unit = pow2(rng.int(-12, 6) as i32);
                let a = rng.int3(-1000, 1000);
                let s = loop {
                    let s = rng.int3(-20, 20);
                    if s != [0, 0, 0] {
                        break s;
                    }
                };
                let mut ks = [0i64; 3];
                loop {
                    ks = ks.map(|_| rng.int(-30, 30));
                    if ks[0] != ks[1] && ks[1] != ks[2] && ks[0] != ks[2] {
                        break;
                    }
                }
                ks.map(|k| lat(iadd(a, iscale(s, k)), unit))
            }
        };
        // random vertex order
        p.swap(0, rng.below(3));
        p.swap(1, 1 + rng.below(2));
        let lo = p[0].min(p[1]).min(p[2]);
        let hi = p[0].max(p[1]).max(p[2]);
        let size = (hi - lo).max_element().max(lo.abs().max_element() * 1e-3).max(1e-6);
        for _ in 0..8 {
            // aim at a point of the degenerate "triangle": a vertex or (up to
            // rounding) a point of its segment
            let (i, j) = (rng.below(3), rng.below(3));
            let target = if rng.chance(0.3) {
                p[i]
            } else {
                p[i].lerp(p[j], rng.unit() as f32)
            };
            let dir = if rng.chance(0.2) {
                [Vec3::X, Vec3::Y, Vec3::Z][rng.below(3)] * rng.sign()
            } else {
                rng.dir()
            };
            let o = target - dir * size * rng.log_range(0.01, 100.0) as f32;
            let d = dir * rng.log_range(0.1, 10.0) as f32;
            let w = intersect_watertight(o, d, 0.0, f32::INFINITY, &p);
            assert!(
                w.is_none(),
                "case {case}: watertight hit degenerate (kind {kind}) triangle {p:?}: o={o} d={d} -> {w:?}"
            );
            // The f64 Möller–Trumbore kernel rejects |det| ≤ 1e-12 as the RDR171 spec
            // prescribes, an absolute bound: for a degenerate triangle det is pure f64
            // rounding noise, ≲ 1e-15·|d|·|e1|·|e2|, below 1e-12 only for small
            // inputs. Above it u, v and t are noise ratios (e.g. t = −0 with u = 1
            // for a ray through the doubled vertex), so only small inputs count.
            let e1 = (p[1] - p[0]).as_dvec3().length();
            let e2 = (p[2] - p[0]).as_dvec3().length();
            if 1e-14 * d.as_dvec3().length() * e1 * e2 < 1e-12 {
                mt_checked += 1;
                let m = intersect_moller_trumbore_f64(o, d, 0.0, f64::INFINITY, &p);
                assert!(
                    m.is_none(),
                    "case {case}: Möller–Trumbore hit degenerate (kind {kind}) triangle {p:?}: o={o} d={d} -> {m:?}"
                );
            }
        }
    }
    assert!(mt_checked > 500_000, "only {mt_checked} Möller–Trumbore checks");
}

#[test]
fn rays_parallel_to_the_triangle_plane_do_not_hit() {
    let mut rng = Rng::new(3);
    let (mut in_plane, mut off_plane) = (0, 0);
    for case in 0..200_000 {
        // vertices on the lattice `unit`; in-plane origins on the finer lattice unit/16
        let unit = pow2(rng.int(-14, 4) as i32);
        let pi = [0; 3].map(|_| rng.int3(-1000, 1000));
        let e1 = isub(pi[1], pi[0]);
        let e2 = isub(pi[2], pi[0]);
        if icross(e1, e2) == [0, 0, 0] {
            continue;
        }
        let p = pi.map(|v| lat(v, unit));
        let (al, be) = loop {
            let (a, b) = (rng.int(-3, 3), rng.int(-3, 3));
            if (a, b) != (0, 0) {
                break (a, b);
            }
        };
        // d = α·e1 + β·e2: exactly in the plane's direction space
        let d = lat(iadd(iscale(e1, al), iscale(e2, be)), unit * pow2(rng.int(-10, 10) as i32));
        // an exact point p0 + (g·e1 + h·e2)/16 of the plane: inside the triangle, on
        // its edges, or outside
        let (g, h) = if rng.chance(0.7) {
            let g = rng.int(0, 16);
            (g, rng.int(0, 16 - g))
        } else {
            (rng.int(-32, 48), rng.int(-32, 48))
        };
        let q = lat(iadd(iscale(pi[0], 16), iadd(iscale(e1, g), iscale(e2, h))), unit / 16.0);
        let size = (p[1] - p[0]).length().max((p[2] - p[0]).length());
        let o = if rng.chance(0.5) {
            in_plane += 1;
            q
        } else {
            off_plane += 1;
            q + unit_normal(&p) * size * rng.log_range(1e-3, 1.0) as f32 * rng.sign()
        };
        for (t_min, t_max) in [(0.0, f32::INFINITY), (1e-4, 1e7)] {
            let w = intersect_watertight(o, d, t_min, t_max, &p);
            assert!(
                w.is_none(),
                "case {case}: watertight hit with a ray parallel to {p:?}: o={o} d={d} -> {w:?}"
            );
            let m = intersect_moller_trumbore_f64(o, d, t_min as f64, t_max as f64, &p);
            assert!(
                m.is_none(),
                "case {case}: Möller–Trumbore hit with a ray parallel to {p:?}: o={o} d={d} -> {m:?}"
            );
        }
    }
    assert!(in_plane > 50_000 && off_plane > 50_000);
}

#[test]
fn rays_leaving_the_surface_do_not_hit_it_again() {
    let mut rng = Rng::new(4);
    for case in 0..500_000 {
        let (p, _) = random_triangle(&mut rng);
        let n = unit_normal(&p);
        let b = loop {
            let b = rng.bary();
            if b.iter().all(|&x| x > 0.05) {
                break b;
            }
        };
        let o = p[0] * b[0] + p[1] * b[1] + p[2] * b[2];
        let d = loop {
            let d = rng.dir();
            if d.dot(n).abs() > 0.1 {
                break d;
            }
        };
        let longest = (p[1] - p[0]).length().max((p[2] - p[1]).length()).max((p[0] - p[2]).length());
        let scale = longest.max(p.iter().map(|v| v.abs().max_element()).fold(0.0, f32::max));
        let tiny = 1e-4 * scale;
        let ctx = |what: &str| format!("case {case}: {what}: p={p:?} o={o} d={d}");
        if let Some(h) = intersect_watertight(o, d, 0.0, f32::INFINITY, &p) {
            assert!(h.t <= tiny, "{} t={}", ctx("watertight self-hit far away"), h.t);
        }
        if let Some(h) = intersect_moller_trumbore_f64(o, d, 0.0, f64::INFINITY, &p) {
            assert!(h.t <= tiny as f64, "{} t={}", ctx("Möller–Trumbore self-hit far away"), h.t);
        }
        assert!(
            intersect_watertight(o, d, tiny, f32::INFINITY, &p).is_none(),
            "{}",
            ctx("watertight self-hit past t_min")
        );
        assert!(
            intersect_moller_trumbore_f64(o, d, tiny as f64, f64::INFINITY, &p).is_none(),
            "{}",
            ctx("Möller–Trumbore self-hit past t_min")
        );
    }
}

/// Ray through an exact lattice point `q` (lattice `unit`) from roughly `dist`
/// lattice steps away: origin `q − m·d` with a small integer `d` and a power of
/// two `m`, all exact. The direction's length is an unrelated power of two.
fn exact_ray_through(rng: &mut Rng, q: I3, unit: f32, dist: f64) -> Option<(Vec3, Vec3, I3)> {
    let d = rng.int3(-16, 16);
    if d == [0, 0, 0] {
        return None;
    }
    let len = (d.iter().map(|&c| (c * c) as f64).sum::<f64>()).sqrt();
    let m = 1i64 << (dist / len).log2().floor().max(0.0) as i64;
    let o = isub(q, iscale(d, m));
    Some((lat(o, unit), lat(d, unit * pow2(rng.int(-8, 16) as i32)), d))
}

#[test]
fn watertight_shared_edges_and_vertices_do_not_leak() {
    let mut rng = Rng::new(5);
    let mut edge_rays = 0;
    for case in 0..200_000 {
        let unit = pow2(rng.int(-30, 10) as i32);
        // a, b: the shared edge; c, e: the third vertices. Lattice step 1/1024.
        let [a, b, c, e] = [0; 4].map(|_| iscale(rng.int3(-1024, 1024), 1024));
        let tri_a = [a, b, c];
        let tri_b = [b, a, e];
        if icross(isub(b, a), isub(c, a)) == [0, 0, 0] || icross(isub(b, a), isub(e, a)) == [0, 0, 0] {
            continue;
        }
        // random rotation of each triangle's vertex list (the winding stays)
        let rot = |t: [I3; 3], r: usize| [t[r % 3], t[(r + 1) % 3], t[(r + 2) % 3]];
        let ta = rot(tri_a, rng.below(3)).map(|v| lat(v, unit / 1024.0));
        let tb = rot(tri_b, rng.below(3)).map(|v| lat(v, unit / 1024.0));
        for _ in 0..4 {
            let k = rng.int(1, 1023);
            let q = iadd(a, [0, 1, 2].map(|i| (b[i] - a[i]) / 1024 * k)); // exact: b − a is a multiple of 1024
                                                                          // The conservative `t > δt` test rejects hits much closer than the
                                                                          // triangle's size (δt grows with the triangle's extent along the ray),
                                                                          // so start at least 10% of the triangles' size away.
            let size = [b, c, e]
                .iter()
                .map(|&v| isub(v, a).iter().map(|&x| (x * x) as f64).sum::<f64>().sqrt())
                .fold(0.0, f64::max);
            let dist = size * rng.range(0.1, 2.0);
            let Some((o, d, d_lat)) = exact_ray_through(&mut rng, q, unit / 1024.0, dist) else {
                continue;
            };
            // Watertightness promises a hit only where the two triangles meet from
            // opposite sides as seen along the ray (not at a silhouette). And the
            // conservative `t > δt` test rejects hits on a triangle seen almost
            // edge-on (δt/t grows like 1/cos as the projected area shrinks; ~1e-3/cos
            // here), so skip rays within ~1° of either plane.
            let sc = idet(d_lat, isub(b, a), isub(c, a));
            let se = idet(d_lat, isub(b, a), isub(e, a));
            if sc == 0 || se == 0 || sc.signum() == se.signum() {
                continue;
            }
            if [&ta, &tb].iter().any(|t| unit_normal(t).dot(d.normalize()).abs() < 0.02) {
                continue;
            }
            edge_rays += 1;
            let ha = intersect_watertight(o, d, 0.0, f32::INFINITY, &ta);
            let hb = intersect_watertight(o, d, 0.0, f32::INFINITY, &tb);
            let t = (lat(q, unit / 1024.0) - o).length() / d.length();
            assert!(
                ha.is_some() || hb.is_some(),
                "case {case}: ray through the shared edge leaks: {ta:?} {tb:?} o={o} d={d}"
            );
            // f32 t is accurate relative to the triangle's depth range along the ray,
            // and less so for grazing rays
            let depth = ta.iter().chain(&tb).map(|&p| (p - o).length()).fold(0.0, f32::max) / d.length();
            for (h, tri) in [(ha, &ta), (hb, &tb)] {
                let Some(h) = h else { continue };
                let cos = unit_normal(tri).dot(d.normalize()).abs();
                let tol = 1e-5 * (t + depth) / cos;
                assert!(
                    (h.t - t).abs() <= tol,
                    "case {case}: edge hit at t={} instead of {t}: {tri:?} o={o:?} d={d:?}",
                    h.t
                );
            }
        }
    }
    assert!(edge_rays > 100_000, "only {edge_rays} edge rays");

    // A closed fan around a vertex, star-shaped as seen along the ray: a ray
    // through the exact centre vertex must hit one of the fan's triangles.
    let mut vertex_rays = 0;
    for case in 0..50_000 {
        let unit = pow2(rng.int(-20, 10) as i32);
        let v = rng.int3(-4096, 4096);
        let k = rng.int(3, 9) as usize;
        let phase = rng.range(0.0, 1.0);
        let ring: Vec<I3> = (0..k)
            .map(|i| {
                let ang = (i as f64 + phase + rng.range(-0.3, 0.3)) / k as f64 * std::f64::consts::TAU;
                let r = rng.range(50.0, 2000.0);
                iadd(v, [(r * ang.cos()) as i64, (r * ang.sin()) as i64, rng.int(-1500, 1500)])
            })
            .collect();
        let fan: Vec<[I3; 3]> = (0..k).map(|i| [v, ring[i], ring[(i + 1) % k]]).collect();
        let fan_f: Vec<[Vec3; 3]> = fan.iter().map(|t| t.map(|p| lat(p, unit))).collect();
        for _ in 0..4 {
            let dist = rng.range(200.0, 8000.0);
            let Some((o, d, d_lat)) = exact_ray_through(&mut rng, v, unit, dist) else {
                continue;
            };
            let signs: Vec<i128> = fan
                .iter()
                .map(|t| idet(d_lat, isub(t[1], t[0]), isub(t[2], t[0])).signum())
                .collect();
            if signs.iter().any(|&s| s == 0 || s != signs[0]) {
                continue;
            }
            vertex_rays += 1;
            let hit = fan_f.iter().any(|t| intersect_watertight(o, d, 0.0, f32::INFINITY, t).is_some());
            assert!(hit, "case {case}: ray through the fan's centre vertex leaks: {fan_f:?} o={o} d={d}");
        }
    }
    assert!(vertex_rays > 20_000, "only {vertex_rays} vertex rays");
}

// ---------------------------------------------------------------------------
// 2. Slab test
// ---------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------
// 3. BVH
// ---------------------------------------------------------------------------

/// Checks the tree's structure; returns its depth.
fn check_structure(bvh: &Bvh, bounds: &[Aabb]) -> usize {
    let valid: Vec<u32> = (0..bounds.len() as u32)
        .filter(|&i| {
            let b = &bounds[i as usize];
            !b.is_empty() && b.min.is_finite() && b.max.is_finite()
        })
        .collect();
    let mut order = bvh.order.clone();
    order.sort_unstable();
    assert_eq!(order, valid, "order is not a permutation of the valid primitives");
    if valid.is_empty() {
        assert!(bvh.nodes.is_empty(), "empty input should give an empty tree");
        assert_eq!(bvh.depth(), 0);
        return 0;
    }
    let inside = |inner: &Aabb, outer: &Aabb| inner.min.cmpge(outer.min).all() && inner.max.cmple(outer.max).all();
    let mut covered = vec![false; bvh.order.len()];
    let mut reached = vec![false; bvh.nodes.len()];
    let mut max_depth = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, depth)) = stack.pop() {
        assert!(!reached[i], "node {i} reached twice");
        reached[i] = true;
        max_depth = max_depth.max(depth);
        let node = &bvh.nodes[i];
        if node.count == 0 {
            let (l, r) = (i + 1, node.offset as usize);
            assert!(r > l && r < bvh.nodes.len(), "node {i}: bad right child {r}");
            for c in [l, r] {
                assert!(inside(&bvh.nodes[c].bounds, &node.bounds), "node {c} sticks out of its parent {i}");
            }
            stack.push((l, depth + 1));
            stack.push((r, depth + 1));
        } else {
            let range = node.offset as usize..(node.offset + node.count) as usize;
            assert!(range.end <= bvh.order.len(), "leaf {i} range out of bounds");
            let c0 = bounds[bvh.order[range.start] as usize].centroid();
            if node.count as usize > MAX_LEAF {
                assert!(
                    range.clone().all(|k| bounds[bvh.order[k] as usize].centroid() == c0),
                    "leaf {i} holds {} primitives with distinct centroids",
                    node.count
                );
            }
            for k in range {
                assert!(!covered[k], "order slot {k} in two leaves");
                covered[k] = true;
                assert!(
                    inside(&bounds[bvh.order[k] as usize], &node.bounds),
                    "primitive outside its leaf {i}"
                );
            }
        }
    }
    assert!(covered.iter().all(|&c| c), "some primitives are in no leaf");
    assert!(reached.iter().all(|&r| r), "unreachable nodes");
    assert_eq!(bvh.depth(), max_depth);
    max_depth
}

/// Rays for a scene: aimed at random primitives, random, axis-parallel, with
/// assorted `[t_min, t_max]`.
fn scene_rays(rng: &mut Rng, prims: &[Prim], count: usize) -> Vec<Ray> {
    let usable = |p: &&Prim| {
        let b = prim_bounds(p);
        !b.is_empty() && b.min.is_finite() && b.max.is_finite()
    };
    let prims: Vec<Prim> = prims.iter().filter(usable).copied().collect();
    let bounds = prims.iter().map(prim_bounds).fold(Aabb::EMPTY, Aabb::union);
    let (c, r) = if prims.is_empty() {
        (Vec3::ZERO, 1.0)
    } else {
        (bounds.centroid(), (bounds.extent().max_element() * 0.5).max(1e-3))
    };
    let wide = Aabb::new(c - Vec3::splat(r * 1.5), c + Vec3::splat(r * 1.5));
    let mut rays = Vec::with_capacity(count);
    while rays.len() < count {
        let target = if prims.is_empty() {
            rng.in_box(&wide)
        } else {
            match prims[rng.below(prims.len())] {
                Prim::Triangle { p, .. } => {
                    let b = rng.bary();
                    p[0] * b[0] + p[1] * b[1] + p[2] * b[2]
                }
                Prim::Sphere { sphere, .. } => sphere.center + rng.dir() * sphere.radius * rng.rangef(0.0, 1.0),
            }
        };
        let (o, d) = match rng.below(5) {
            // from outside the scene towards a primitive
            0 | 1 => {
                let o = c + rng.dir() * r * rng.rangef(1.2, 3.0);
                (o, target - o)
            }
            // from inside the scene towards a primitive
            2 => {
                let o = rng.in_box(&wide);
                (o, target - o)
            }
            // random
            3 => (rng.in_box(&wide), rng.dir()),
            // axis-parallel through a primitive's point: zero direction components
            _ => {
                let axis = rng.below(3);
                let mut o = target;
                o[axis] = c[axis] + rng.rangef(-3.0, 3.0) * r;
                let mut d = Vec3::ZERO;
                d[axis] = if target[axis] >= o[axis] { 1.0 } else { -1.0 };
                (o, d)
            }
        };
        if d.length().is_nan() || d.length() <= 1e-6 * r {
            continue;
        }
        let d = if rng.chance(0.7) { d.normalize() } else { d };
        let t_min = if rng.chance(0.5) { 0.0 } else { 1e-4 * r / d.length() };
        let t_max = match rng.below(3) {
            0 => f32::INFINITY,
            1 => 1e7,
            _ => rng.rangef(0.0, 4.0 * r / d.length()),
        };
        rays.push(Ray::with_range(o, d, t_min, t_max));
    }
    rays
}

/// A traversal under test: closest hit, any hit and a visit of every primitive
/// the boxes admit.
type Visit<'a> = &'a dyn Fn(&Ray, &mut dyn FnMut(u32));

struct Queries<'a> {
    closest: &'a dyn Fn(&Ray) -> Option<(u32, f32)>,
    any: &'a dyn Fn(&Ray) -> bool,
    visit: Visit<'a>,
}

/// Closest hit, any hit and "visits everything it must" against brute force.
/// `prims` must be in the order `bvh.order` indexes.
fn check_queries(label: &str, bvh: &Bvh, prims: &[Prim], rays: &[Ray]) -> usize {
    let q = Queries {
        closest: &|r| bvh_closest(bvh, prims, r),
        any: &|r| bvh_any(bvh, prims, r),
        visit: &|r, f| {
            bvh.traverse(r, |i, _| {
                f(i);
                false
            })
        },
    };
    check_with(label, &q, prims, rays)
}

/// The wide BVH with every instruction set this CPU has (the portable one
/// always), and its closure traversal.
fn check_wide_queries(label: &str, bvh: &WideBvh, prims: &[Prim], rays: &[Ray]) -> usize {
    let mut hits = 0;
    // the traversals with the large stack (deep trees) on every other check
    let large = rays.len() % 2 == 1;
    for isa in Isa::all_available() {
        let mut b = bvh.clone();
        assert!(b.set_isa(isa));
        b.set_large_stack(large);
        let label = format!("{label} [wide, {}{}]", isa.name(), if large { ", large stack" } else { "" });
        let q = Queries {
            closest: &|r| b.intersect(prims, r).map(|h| (h.prim, h.t)),
            any: &|r| b.occluded(prims, r),
            visit: &|r, f| {
                b.traverse(r, |i, _| {
                    f(i);
                    false
                })
            },
        };
        hits = check_with(&label, &q, prims, rays);
        // the renderer's hits carry the scalar kernel's exact barycentrics
        for ray in rays.iter().step_by(3) {
            if let Some(h) = b.intersect(prims, ray) {
                if let Prim::Triangle { p, .. } = prims[h.prim as usize] {
                    let w = intersect_watertight(ray.o, ray.d, ray.t_min, ray.t_max, &p);
                    assert_eq!(w.map(|w| (w.t, w.b)), Some((h.t, h.b)), "{label}: ray {ray:?}: hit {h:?}");
                }
            }
        }
    }
    hits
}

fn check_with(label: &str, q: &Queries, prims: &[Prim], rays: &[Ray]) -> usize {
    let mut hits = 0;
    let mut seen = vec![u32::MAX; prims.len()];
    for (k, ray) in rays.iter().enumerate() {
        let ctx = || format!("{label}: ray {k} {ray:?}");
        let brute = brute_closest(prims, ray);
        let fast = (q.closest)(ray);
        match (brute, fast) {
            (None, None) => {}
            (Some((bi, bt)), Some((fi, ft))) => {
                hits += 1;
                if bi == fi {
                    assert_eq!(bt, ft, "{}: same primitive, different t", ctx());
                } else {
                    // a tie: both are (within rounding of the shrinking t_max test) closest
                    let full = prim_intersect(&prims[fi as usize], ray, ray.t_max);
                    assert_eq!(full, Some(ft), "{}: BVH hit {fi} is not a hit over the full range", ctx());
                    assert!(
                        (ft - bt).abs() <= 1e-6 * bt.abs(),
                        "{}: BVH closest {fi} at {ft}, brute force {bi} at {bt}",
                        ctx()
                    );
                }
            }
            _ => panic!("{}: brute force {brute:?}, BVH {fast:?}", ctx()),
        }
        assert_eq!((q.any)(ray), brute.is_some(), "{}: any-hit disagrees", ctx());
        // every primitive the ray hits is visited, and nothing is visited twice
        if k % 4 == 0 {
            (q.visit)(ray, &mut |i| {
                assert_ne!(seen[i as usize], k as u32, "{}: primitive {i} visited twice", ctx());
                seen[i as usize] = k as u32;
            });
            for (i, p) in prims.iter().enumerate() {
                if seen[i] != k as u32 && prim_intersect(p, ray, ray.t_max).is_some() {
                    panic!("{}: primitive {i} is hit but never visited", ctx());
                }
            }
        }
    }
    hits
}

/// Checks the wide tree's structure: every usable primitive in exactly one leaf
/// (padding lanes repeat their block's last triangle), leaves of one kind and
/// at most `MAX_LEAF` primitives, children inside their parents' slots, every
/// node reached once; returns the depth.
fn check_wide_structure(bvh: &WideBvh, bounds: &[Aabb]) -> usize {
    let valid: Vec<u32> = (0..bounds.len() as u32)
        .filter(|&i| {
            let b = &bounds[i as usize];
            !b.is_empty() && b.min.is_finite() && b.max.is_finite()
        })
        .collect();
    assert_eq!(bvh.prim_count, valid.len());
    if valid.is_empty() {
        assert!(bvh.nodes.is_empty(), "empty input should give an empty tree");
        return 0;
    }
    let inside = |inner: &Aabb, outer: &Aabb| inner.min.cmpge(outer.min).all() && inner.max.cmple(outer.max).all();
    let mut seen = vec![0u32; bounds.len()];
    let mut reached = vec![false; bvh.nodes.len()];
    let mut max_depth = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, depth)) = stack.pop() {
        assert!(!reached[i], "node {i} reached twice");
        reached[i] = true;
        max_depth = max_depth.max(depth);
        let node = &bvh.nodes[i];
        for slot in 0..8 {
            let cb = node.child_bounds(slot);
            let Some((_, _, c)) = bvh.children().find(|&(n, s, _)| n == i && s == slot) else {
                assert!(cb.is_empty(), "unused slot {slot} of node {i} has a box");
                continue;
            };
            match c {
                ChildRef::Node(j) => {
                    assert!(j > i && j < bvh.nodes.len(), "node {i}: bad child {j}");
                    let n = &bvh.nodes[j];
                    for s in 0..8 {
                        let b = n.child_bounds(s);
                        if !b.is_empty() {
                            assert!(inside(&b, &cb), "child {s} of node {j} sticks out of its slot in node {i}");
                        }
                    }
                    stack.push((j, depth + 1));
                }
                leaf => {
                    let items = bvh.leaf_prims(leaf);
                    assert!(!items.is_empty() && items.len() <= MAX_LEAF, "leaf of {} primitives", items.len());
                    if let ChildRef::Triangles { first, count } = leaf {
                        assert_eq!(count, items.len().div_ceil(LANES), "blocks of a leaf not packed");
                        for b in &bvh.blocks[first..first + count] {
                            for lane in 1..LANES {
                                if b.prim[lane] == b.prim[lane - 1] {
                                    assert_eq!(b.triangle(lane), b.triangle(lane - 1), "padding lane differs");
                                }
                            }
                            for lane in 0..LANES {
                                let tb = Aabb::from_points(&b.triangle(lane));
                                assert_eq!(tb, bounds[b.prim[lane] as usize], "block lane holds another triangle");
                            }
                        }
                    }
                    for &p in &items {
                        seen[p as usize] += 1;
                        assert!(inside(&bounds[p as usize], &cb), "primitive {p} outside its leaf box in node {i}");
                    }
                }
            }
        }
    }
    for (i, &n) in seen.iter().enumerate() {
        let usable = valid.binary_search(&(i as u32)).is_ok();
        assert_eq!(n, usable as u32, "primitive {i} in {n} leaves");
    }
    assert!(reached.iter().all(|&r| r), "unreachable nodes");
    assert!(bvh.stack_need() >= 1 && bvh.stack_need() <= 7 * max_depth + 1);
    max_depth
}

/// Builds with `build_bvh` and checks everything:
/// the binary tree and the wide one, with every instruction set.
fn check_prims(label: &str, rng: &mut Rng, prims: Vec<Prim>, rays: usize) -> (WideBvh, usize) {
    let bounds: Vec<Aabb> = prims.iter().map(prim_bounds).collect();
    // the tree over the boxes directly
    let raw = Bvh::build(&bounds);
    check_structure(&raw, &bounds);
    // build_bvh: the primitives back unchanged, a tree over the usable ones
    let key = |p: &Prim| match *p {
        Prim::Triangle { p, object, index } => (object, index, p.map(|v| v.to_array().map(f32::to_bits))),
        Prim::Sphere { sphere, object } => (
            object,
            u32::MAX,
            [
                [sphere.center.x, sphere.center.y, sphere.center.z].map(f32::to_bits),
                [sphere.radius.to_bits(); 3],
                [0; 3],
            ],
        ),
    };
    let ray_list = scene_rays(rng, &prims, rays);
    let (returned, bvh) = build_bvh(prims.clone());
    assert!(
        returned.iter().map(key).eq(prims.iter().map(key)),
        "{label}: build_bvh changed the primitives"
    );
    check_wide_structure(&bvh, &bounds);
    check_queries(label, &raw, &prims, &ray_list);
    let hits = check_wide_queries(label, &bvh, &prims, &ray_list);
    (bvh, hits)
}

/// Random triangles in a cube of half-size `extent`, sizes log-uniform in `sizes`.
fn random_soup(rng: &mut Rng, n: usize, extent: f32, sizes: (f64, f64)) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = rng.in_cube(extent);
            let s = rng.log_range(sizes.0, sizes.1) as f32;
            [c + rng.in_cube(s), c + rng.in_cube(s), c + rng.in_cube(s)]
        })
        .collect()
}

/// `n` spheres centred in the unit cube, radii log-uniform in `radii`, objects 1…n.
fn random_spheres(rng: &mut Rng, n: u32, radii: (f64, f64)) -> Vec<Prim> {
    (1..=n)
        .map(|object| Prim::Sphere {
            sphere: rdr::geometry::sphere::Sphere {
                center: rng.in_cube(1.0),
                radius: rng.log_range(radii.0, radii.1) as f32,
            },
            object,
        })
        .collect()
}

fn as_prims(tris: Vec<[Vec3; 3]>) -> Vec<Prim> {
    tris.into_iter().enumerate().map(|(i, p)| tri(p, i as u32)).collect()
}

#[test]
fn bvh_empty_and_single_primitive() {
    let mut rng = Rng::new(8);
    let rays = scene_rays(&mut rng, &[], 200);
    // no primitives, or only unusable boxes: no node, no visit
    let unusable = [
        Aabb::EMPTY,
        Aabb::new(Vec3::splat(f32::NAN), Vec3::ONE),
        Aabb::new(Vec3::ZERO, Vec3::splat(f32::INFINITY)),
    ];
    for bounds in [&[][..], &unusable[..]] {
        let bvh = Bvh::build(bounds);
        check_structure(&bvh, bounds);
        for ray in &rays {
            bvh.traverse(ray, |i, _| panic!("visited {i} in an empty tree"));
        }
    }
    let (ordered, bvh) = build_bvh(Vec::new());
    assert!(ordered.is_empty() && bvh.nodes.is_empty());
    for isa in Isa::all_available() {
        let mut b = bvh.clone();
        b.set_isa(isa);
        for ray in &rays {
            b.traverse(ray, |i, _| panic!("visited {i} in an empty tree"));
            assert!(b.intersect(&[], ray).is_none() && !b.occluded(&[], ray));
        }
    }
    // one triangle, one sphere
    for seed in 0..20 {
        let mut rng = Rng::new(100 + seed);
        let (p, _) = random_triangle(&mut rng);
        let (bvh, hits) = check_prims("single triangle", &mut rng, vec![tri(p, 0)], 500);
        assert_eq!(bvh.nodes.len(), 1);
        assert!(hits > 100, "single triangle: only {hits} hits");
        let s = rdr::geometry::sphere::Sphere {
            center: rng.in_cube(10.0),
            radius: rng.log_range(0.01, 10.0) as f32,
        };
        let (_, hits) = check_prims("single sphere", &mut rng, vec![Prim::Sphere { sphere: s, object: 0 }], 500);
        assert!(hits > 100, "single sphere: only {hits} hits");
    }
}

#[test]
fn bvh_matches_brute_force_on_random_soups() {
    let mut rng = Rng::new(9);
    let configs = [
        ("small triangles", 1000, 1.0, (0.005, 0.05)),
        ("mixed sizes", 1000, 1.0, (1e-4, 2.0)),
        ("large overlapping", 800, 1.0, (0.3, 1.5)),
        ("far from the origin", 1000, 1.0, (0.001, 0.1)),
        ("tiny scale", 1000, 1e-3, (1e-6, 1e-4)),
    ];
    for (label, n, extent, sizes) in configs {
        let mut tris = random_soup(&mut rng, n, extent, sizes);
        if label == "far from the origin" {
            for t in &mut tris {
                *t = t.map(|v| v + Vec3::new(1000.0, -2000.0, 500.0));
            }
        }
        let (_, hits) = check_prims(label, &mut rng, as_prims(tris), 6000);
        assert!(hits > 1000, "{label}: only {hits} hits");
    }
}

#[test]
fn bvh_degenerate_inputs() {
    let mut rng = Rng::new(10);
    // many identical triangles: all centroids coincide
    let p = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.5)];
    let (bvh, hits) = check_prims("identical", &mut rng, as_prims(vec![p; 1000]), 1000);
    assert!(bvh.stack_need() < 7 * 20);
    let raw = Bvh::build(&vec![Aabb::from_points(&p); 1000]);
    assert!(raw.nodes.iter().all(|n| n.count as usize <= MAX_LEAF));
    assert!(raw.depth() < 20);
    assert!(hits > 300);

    // distinct triangles sharing one bounding box (diagonal cuts of one cube)
    let cube: Vec<[Vec3; 3]> = (0..600)
        .map(|i| {
            let c = |k: usize| Vec3::new((k & 1) as f32, ((k >> 1) & 1) as f32, ((k >> 2) & 1) as f32);
            let a = i % 8;
            [c(a), c(7 - a), c((a + 1 + i / 8 % 6) % 8)]
        })
        .collect();
    let (_, hits) = check_prims("same box", &mut rng, as_prims(cube), 1000);
    assert!(hits > 300);

    // all in one plane (zero-thickness scene bounds), axis-aligned and not
    for axis in 0..3 {
        let tris: Vec<[Vec3; 3]> = random_soup(&mut rng, 1000, 1.0, (0.01, 0.2))
            .into_iter()
            .map(|t| {
                t.map(|mut v| {
                    v[axis] = 0.25;
                    v
                })
            })
            .collect();
        let bounds = tris.iter().map(|t| Aabb::from_points(t)).fold(Aabb::EMPTY, Aabb::union);
        assert_eq!(bounds.extent()[axis], 0.0);
        let (_, hits) = check_prims("flat", &mut rng, as_prims(tris), 2000);
        assert!(hits > 500, "flat {axis}: only {hits} hits");
    }
    // coplanar grid: triangles sharing edges, hit through edges and vertices
    let mut grid = Vec::new();
    for i in 0..30 {
        for j in 0..30 {
            let v = |a: i32, b: i32| Vec3::new(a as f32 * 0.125, b as f32 * 0.125, 0.0);
            grid.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            grid.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    let (_, hits) = check_prims("grid", &mut rng, as_prims(grid), 2000);
    assert!(hits > 500);

    // a mix with degenerate triangles (collinear, repeated vertices, points) and
    // unusable ones (NaN, infinite): the BVH drops the unusable ones
    let mut tris = random_soup(&mut rng, 600, 1.0, (0.01, 0.3));
    for _ in 0..300 {
        let a = rng.in_cube(1.0);
        let b = a + rng.in_cube(0.2);
        tris.push(match rng.below(3) {
            0 => [a, b, a],
            1 => [a, a, a],
            _ => [a, b, a + (b - a) * 2.0],
        });
    }
    tris.push([Vec3::new(f32::NAN, 0.0, 0.0), Vec3::ONE, Vec3::ZERO]);
    tris.push([Vec3::new(f32::INFINITY, 0.0, 0.0), Vec3::ONE, Vec3::ZERO]);
    let n = tris.len();
    for _ in 0..n {
        let (i, j) = (rng.below(n), rng.below(n));
        tris.swap(i, j);
    }
    // (a NaN coordinate does not always make the box unusable: glam's min/max may
    // drop the NaN, depending on the vertex order)
    let usable = tris.iter().filter(|t| {
        let b = Aabb::from_points(&t[..]);
        b.min.is_finite() && b.max.is_finite()
    });
    let usable = usable.count();
    assert!(usable < n);
    let (bvh, hits) = check_prims("with degenerate", &mut rng, as_prims(tris), 2000);
    assert_eq!(bvh.prim_count, usable);
    assert!(hits > 500);
}

#[test]
fn bvh_with_spheres_via_build_bvh() {
    let mut rng = Rng::new(11);
    let mut prims = as_prims(random_soup(&mut rng, 700, 1.0, (0.01, 0.3)));
    prims.extend(random_spheres(&mut rng, 300, (1e-3, 0.3)));
    // a sphere enclosing much of the scene and one far away
    let big = rdr::geometry::sphere::Sphere {
        center: Vec3::ZERO,
        radius: 0.8,
    };
    prims.push(Prim::Sphere { sphere: big, object: 400 });
    let far = rdr::geometry::sphere::Sphere {
        center: Vec3::splat(50.0),
        radius: 2.0,
    };
    prims.push(Prim::Sphere { sphere: far, object: 401 });
    let n = prims.len();
    for _ in 0..n {
        let (i, j) = (rng.below(n), rng.below(n));
        prims.swap(i, j);
    }
    let (_, hits) = check_prims("spheres and triangles", &mut rng, prims, 6000);
    assert!(hits > 1000);
}

/// Spheres are tested one at a time, so the builder must not pack them eight
/// to a leaf as it does triangles (a cost model that counts them as triangles
/// gives leaves of about eight and fails this).
#[test]
fn bvh_keeps_sphere_leaves_small() {
    let mut rng = Rng::new(13);
    let prims = random_spheres(&mut rng, 5000, (1e-3, 0.02));
    let (prims, bvh) = build_bvh(prims);
    let (mut leaves, mut spheres) = (0, 0);
    for (_, _, c) in bvh.children() {
        if let ChildRef::Generic { count, .. } = c {
            leaves += 1;
            spheres += count;
        }
    }
    assert_eq!(spheres, prims.len());
    let per_leaf = spheres as f64 / leaves as f64;
    assert!(per_leaf < 3.0, "{per_leaf:.2} spheres a leaf");
}

#[test]
fn bvh_100k_triangles() {
    let mut rng = Rng::new(12);
    let mut tris = random_soup(&mut rng, 90_000, 1.0, (0.002, 0.02));
    // a dense cluster and a thin layer, to give the SAH something uneven
    tris.extend(random_soup(&mut rng, 5_000, 0.01, (1e-4, 1e-3)));
    tris.extend(
        random_soup(&mut rng, 5_000, 1.0, (0.01, 0.05))
            .into_iter()
            .map(|t| t.map(|v| Vec3::new(v.x, 0.5, v.z))),
    );
    let bounds: Vec<Aabb> = tris.iter().map(|t| Aabb::from_points(t)).collect();
    let depth = Bvh::build(&bounds).depth();
    assert!(depth < 64, "depth {depth}");
    let (bvh, hits) = check_prims("100k", &mut rng, as_prims(tris), 500);
    assert!(bvh.stack_need() <= 7 * depth + 1);
    assert!(hits > 100);
    // the SAH collapse fills the wide nodes (opening the largest child first gave
    // 3.7 children a node on the bunny, the cost tables 6.0); a collapse that
    // stops at two or three children fails this
    let children = bvh.children().count() as f64 / bvh.nodes.len() as f64;
    assert!(children > 5.0, "{children:.2} children a node");
}

/// Same tree, bit for bit: nodes at the same indices, the same blocks.
fn assert_same_tree(a: &WideBvh, b: &WideBvh) {
    assert_eq!(a.nodes.len(), b.nodes.len(), "node count");
    for (i, (x, y)) in a.nodes.iter().zip(&b.nodes).enumerate() {
        assert_eq!(x.child, y.child, "children of node {i}");
        assert_eq!(
            x.planes.map(|r| r.map(f32::to_bits)),
            y.planes.map(|r| r.map(f32::to_bits)),
            "boxes of node {i}"
        );
    }
    assert_eq!(a.blocks.len(), b.blocks.len(), "block count");
    for (i, (x, y)) in a.blocks.iter().zip(&b.blocks).enumerate() {
        assert_eq!(x.prim, y.prim, "primitives of block {i}");
        assert_eq!(
            x.v.map(|v| v.map(|r| r.map(f32::to_bits))),
            y.v.map(|v| v.map(|r| r.map(f32::to_bits))),
            "block {i}"
        );
    }
    assert_eq!(a.generic, b.generic);
    assert_eq!(a.stack_need(), b.stack_need());
}

/// The tree does not depend on the number of threads that build it (the
/// parallel collapse places every node where the sequential one does), so
/// neither do hit ties nor images. Large enough for every parallel path.
#[test]
fn bvh_is_the_same_for_any_thread_count() {
    let mut rng = Rng::new(14);
    let mut prims = as_prims(random_soup(&mut rng, 60_000, 1.0, (0.002, 0.03)));
    prims.extend(random_spheres(&mut rng, 3000, (1e-3, 0.05)));
    let build = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| WideBvh::build(&prims))
    };
    let one = build(1);
    for threads in [2, 3] {
        assert_same_tree(&one, &build(threads));
    }
}

// ---------------------------------------------------------------------------
// 4. Through the full Scene
// ---------------------------------------------------------------------------

struct TempDir(std::path::PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn write_obj(path: &Path, tris: &[[Vec3; 3]]) {
    let mut s = String::new();
    for t in tris {
        for v in t {
            s += &format!("v {:?} {:?} {:?}\n", v.x, v.y, v.z);
        }
    }
    // one face as a quad, to go through the triangulation too
    s += "v 0 -1 0\nv 1 -1 0\nv 1 -1 1\nv 0 -1 1\nf -4 -3 -2 -1\n";
    for i in 0..tris.len() {
        s += &format!("f {} {} {}\n", 3 * i + 1, 3 * i + 2, 3 * i + 3);
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn scene_queries_match_brute_force() {
    let dir = TempDir(std::env::temp_dir().join(format!("rdr-intersection-props-{}", std::process::id())));
    std::fs::create_dir_all(&dir.0).unwrap();
    let mut rng = Rng::new(13);
    let mut soup = random_soup(&mut rng, 400, 1.0, (0.01, 0.3));
    soup.push([Vec3::ZERO, Vec3::X, Vec3::X * 2.0]); // degenerate: dropped with a warning
    write_obj(&dir.0.join("soup.obj"), &soup);
    let grid: Vec<[Vec3; 3]> = (0..100)
        .flat_map(|k| {
            let (i, j) = ((k % 10) as f32 * 0.2 - 1.0, (k / 10) as f32 * 0.2 - 1.0);
            let v = |a: f32, b: f32| Vec3::new(a, b, 0.0);
            [
                [v(i, j), v(i + 0.2, j), v(i + 0.2, j + 0.2)],
                [v(i, j), v(i + 0.2, j + 0.2), v(i, j + 0.2)],
            ]
        })
        .collect();
    write_obj(&dir.0.join("grid.obj"), &grid);
    let mut objects = vec![
        serde_json::json!({"type": "mesh", "path": "soup.obj", "material_name": "white"}),
        serde_json::json!({
            "type": "mesh", "path": "grid.obj", "material_name": "white",
            "transform": [0.8, 0.0, 0.6, 0.0,  0.0, 1.0, 0.0, 0.0,  -0.6, 0.0, 0.8, 0.0,  0.0, 0.0, 0.0, 1.0],
            "translate": [0.1, 0.2, -0.3]
        }),
    ];
    for _ in 0..40 {
        let c = rng.in_cube(1.2);
        objects.push(serde_json::json!({
            "type": "sphere", "center": [c.x, c.y, c.z], "radius": rng.log_range(0.01, 0.4), "material_name": "white"
        }));
    }
    // a large sphere overlapping part of the scene
    objects.push(serde_json::json!({"type": "sphere", "center": [0.0, 1.5, 0.0], "radius": 0.9, "material_name": "white"}));
    let value = serde_json::json!({
        "integrator": {"type": "intersection_test"},
        "film": {"resolution": [8, 8]},
        "camera": {"position": [0.0, 0.0, 5.0], "look_at": [0.0, 0.0, 0.0]},
        "textures": {"w": {"type": "constant", "color": [0.8, 0.8, 0.8]}},
        "materials": {"white": {"type": "diffuse", "texture_name": "w"}},
        "objects": objects
    });
    let desc = rdr::scene::SceneDesc::from_value(&value, Path::new("t.json"), &dir.0).unwrap();
    let scene = rdr::scene::build(&desc, rdr::scene::BuildOptions::default()).unwrap();
    let expected_tris = (soup.len() - 1) + grid.len() + 2 * 2;
    assert_eq!(scene.triangle_count(), expected_tris);
    assert_eq!(scene.prims.len(), expected_tris + 41);
    assert!(scene.warnings.iter().any(|w| w.contains("degenerate")), "{:?}", scene.warnings);
    let bounds: Vec<Aabb> = scene.prims.iter().map(prim_bounds).collect();
    check_wide_structure(&scene.bvh, &bounds);

    let rays = scene_rays(&mut rng, &scene.prims, 4000);
    let mut hits = 0;
    for (k, ray) in rays.iter().enumerate() {
        let brute = brute_closest(&scene.prims, ray);
        let got = scene.intersect(ray);
        match (brute, got) {
            (None, None) => {}
            (Some((bi, bt)), Some(h)) => {
                hits += 1;
                if bi == h.prim {
                    assert_eq!(bt, h.t, "ray {k} {ray:?}");
                } else {
                    assert!(
                        (h.t - bt).abs() <= 1e-6 * bt.abs(),
                        "ray {k} {ray:?}: scene {h:?}, brute force {bi} at {bt}"
                    );
                }
                if let Prim::Triangle { p, .. } = scene.prims[h.prim as usize] {
                    let w = intersect_watertight(ray.o, ray.d, ray.t_min, ray.t_max, &p).unwrap();
                    assert_eq!(w.b, h.b, "ray {k}: barycentrics");
                }
            }
            _ => panic!("ray {k} {ray:?}: brute force {brute:?}, scene {got:?}"),
        }
        assert_eq!(scene.occluded(ray), brute.is_some(), "ray {k} {ray:?}: occluded disagrees");
    }
    assert!(hits > 2000, "only {hits} hits");
}

#[test]
fn wide_bvh_does_not_leak_through_lattice_edges_and_vertices() {
    // a 16×16 grid of squares split into triangles (alternating diagonals), on a
    // dyadic lattice: rays aimed exactly at vertices, edge points and diagonals
    // have edge functions exactly 0 in some SIMD lanes (the scalar fallback)
    let v = |a: i32, b: i32| Vec3::new(a as f32 * 0.125, b as f32 * 0.125, 0.5);
    let mut tris = Vec::new();
    for i in 0..16 {
        for j in 0..16 {
            if (i + j) % 2 == 0 {
                tris.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
                tris.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
            } else {
                tris.push([v(i, j), v(i + 1, j), v(i, j + 1)]);
                tris.push([v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
    }
    let (prims, bvh) = build_bvh(as_prims(tris));
    let mut rng = Rng::new(14);
    let mut rays = Vec::new();
    for a in 1..64 {
        for b in 1..64 {
            // the point (a/32, b/32) lies on a vertex, an edge or inside a triangle
            let p = Vec3::new(a as f32 / 32.0, b as f32 / 32.0, 0.5);
            let d = match rng.below(3) {
                0 => -Vec3::Z,
                1 => Vec3::new(pow2(-3) * rng.int(-4, 4) as f32, pow2(-3) * rng.int(-4, 4) as f32, -1.0),
                _ => Vec3::new(pow2(-5) * rng.int(-8, 8) as f32, pow2(-4) * rng.int(-8, 8) as f32, 1.0),
            };
            // p − d is exact on this lattice, so the ray passes exactly through p
            rays.push(Ray::with_range(p - d, d, 0.0, f32::INFINITY));
        }
    }
    for isa in Isa::all_available() {
        let mut b = bvh.clone();
        assert!(b.set_isa(isa));
        for ray in &rays {
            let h = b.intersect(&prims, ray);
            assert!(h.is_some(), "[{}] ray {ray:?} leaks through the grid", isa.name());
            assert!(b.occluded(&prims, ray), "[{}] ray {ray:?}: occluded misses", isa.name());
            let h = h.unwrap();
            assert!((h.t - 1.0).abs() < 1e-6, "[{}] ray {ray:?}: t = {}", isa.name(), h.t);
        }
    }
    check_wide_queries("lattice grid", &bvh, &prims, &rays);
}
