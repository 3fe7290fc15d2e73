//! Property tests of the two triangle kernels (watertight and f64 Möller–Trumbore)
//! against an f64 reference: agreement away from edges, degenerate triangles,
//! rays parallel to the plane, self-hits, and no leaks through shared edges and
//! vertices on an exact lattice (see `common::lattice`).
//!
//! A splitmix64 generator with fixed seeds (`common::Rng`) drives many random
//! cases per test, so every run checks the same cases.

mod common;

use common::*;
use rdr::geometry::triangle::{intersect_moller_trumbore_f64, intersect_watertight};
use rdr::math::Vec3;

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
