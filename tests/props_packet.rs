//! Packet traversal against single-ray traversal: for every instruction set this
//! CPU has, both packet widths and both stack sizes, `intersect_packet` and
//! `occluded_packet` must give each ray exactly what `intersect` and `occluded`
//! give it (hit or miss, `t` and barycentric bits, primitive), on coherent
//! packets (a camera's pixel blocks, shadow rays of their hits towards one
//! point), incoherent ones, partially active masks, misses, short ranges, rays
//! through shared edges and vertices, duplicated triangles (exact ties) and
//! spheres (generic leaves).

mod common;

use common::*;
use rdr::accel::wide::{packet_retraced, Isa, WideBvh, PACKET};
use rdr::geometry::prim::Hit;
use rdr::geometry::Ray;
use rdr::math::Vec3;
use rdr::scene::Prim;

/// A closed room of `n`×`n` quads a wall (shared edges everywhere, walls meeting
/// at right angles as in a Cornell box) with two boxes inside.
fn room(n: usize) -> Vec<[Vec3; 3]> {
    let mut t = Vec::new();
    let mut quad = |o: Vec3, u: Vec3, v: Vec3, n: usize| {
        for i in 0..n {
            for j in 0..n {
                let p = |a: usize, b: usize| o + u * (a as f32 / n as f32) + v * (b as f32 / n as f32);
                t.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
                t.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
            }
        }
    };
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0);
    let o = Vec3::splat(-1.0);
    quad(o, x, z, n); // floor
    quad(o + y, x, z, n); // ceiling
    quad(o, x, y, n); // back
    quad(o + z, x, y, n); // front
    quad(o, y, z, n); // left
    quad(o + x, y, z, n); // right
    for (c, s) in [(Vec3::new(-0.4, -0.6, -0.3), 0.35f32), (Vec3::new(0.4, -0.3, 0.3), 0.3)] {
        let o = c - Vec3::splat(s);
        let (x, y, z) = (Vec3::X * 2.0 * s, Vec3::Y * 2.0 * s, Vec3::Z * 2.0 * s);
        for (o, u, v) in [(o, x, z), (o + y, x, z), (o, x, y), (o + z, x, y), (o, y, z), (o + x, y, z)] {
            quad(o, u, v, 2);
        }
    }
    t
}

/// The meshes: the room, a random soup, the room with every 7th triangle
/// doubled (exact ties between primitives), the room with spheres.
fn meshes(rng: &mut Rng) -> Vec<(&'static str, Vec<Prim>)> {
    let mut out = vec![("room", as_prims(room(6)))];
    out.push(("soup", as_prims(random_soup(rng, 3000, 1.0, (0.01, 0.2)))));
    let mut dup = room(4);
    let extra: Vec<[Vec3; 3]> = dup.iter().step_by(7).copied().collect();
    dup.extend(extra);
    out.push(("room+duplicates", as_prims(dup)));
    let mut spheres = as_prims(room(3));
    for i in 0..40u32 {
        spheres.push(Prim::Sphere {
            sphere: rdr::geometry::sphere::Sphere {
                center: rng.in_cube(0.8),
                radius: rng.log_range(0.01, 0.2) as f32,
                uv_frame: None,
            },
            object: 1 + i,
        });
    }
    out.push(("room+spheres", spheres));
    if let Some(s) = shared() {
        let path = s.join("meshes/bunny.obj");
        if let Ok(bunny) = rdr::bench::load_mesh(&path) {
            out.push(("bunny", bunny));
        }
    }
    out
}

/// Packets of up to 16 rays of one kind; `None` lanes are inactive.
fn packets(rng: &mut Rng, bvh: &WideBvh, prims: &[Prim], count: usize) -> Vec<Vec<Option<Ray>>> {
    let b = bvh.bounds();
    let (c, r) = (b.centroid(), b.extent().max_element() * 0.5);
    let mut out = Vec::new();
    for k in 0..count {
        let n = if rng.chance(0.8) { PACKET } else { 1 + rng.below(PACKET) };
        let kind = k % 6;
        // a pinhole camera: eye, forward, right, up, pixel size
        let eye = if rng.chance(0.5) {
            c + rng.dir() * r * rng.rangef(1.5, 4.0)
        } else {
            c + rng.in_cube(r * 0.6) // inside (the room)
        };
        let fwd = (c + rng.in_cube(r * 0.5) - eye).normalize();
        let right = fwd.cross(Vec3::Y).normalize();
        let up = right.cross(fwd);
        let px = rng.log_range(1e-4, 0.05) as f32;
        let (u0, v0) = (rng.rangef(-0.5, 0.5), rng.rangef(-0.5, 0.5));
        let camera = |i: usize, rng: &mut Rng| {
            let (u, v) = ((i % 4) as f32 + rng.rangef(0.0, 1.0), (i / 4) as f32 + rng.rangef(0.0, 1.0));
            let d = fwd + right * (u0 + u * px) + up * (v0 + v * px);
            Ray::new(eye, d.normalize())
        };
        let mut p: Vec<Option<Ray>> = match kind {
            // camera rays of a pixel block
            0 | 1 => (0..n).map(|i| Some(camera(i, rng))).collect(),
            // shadow rays of a block's hits towards one point
            2 => {
                let light = c + rng.in_cube(r * 0.9);
                (0..n)
                    .map(|i| {
                        let ray = camera(i, rng);
                        let hit = bvh.intersect(prims, &ray)?;
                        let o = ray.at(hit.t * 0.9999);
                        let to = light - o;
                        let d = to.length();
                        Some(Ray::with_range(o, to / d, 1e-4, d * 0.9999))
                    })
                    .collect()
            }
            // incoherent
            3 => (0..n)
                .map(|_| {
                    let o = c + rng.in_cube(r * 1.5);
                    Some(Ray::new(o, (c + rng.in_cube(r) - o).normalize()))
                })
                .collect(),
            // through vertices and edges of the primitives (ties, shared edges)
            4 => (0..n)
                .map(|_| {
                    let Prim::Triangle { p, .. } = prims[rng.below(prims.len())] else {
                        return Some(camera(0, rng));
                    };
                    let target = match rng.below(3) {
                        0 => p[rng.below(3)],
                        1 => (p[0] + p[1]) * 0.5,
                        _ => p[0] + (p[2] - p[0]) * rng.rangef(0.0, 1.0),
                    };
                    Some(Ray::new(eye, (target - eye).normalize()))
                })
                .collect(),
            // random ranges, some away from everything (misses), some bad
            _ => (0..n)
                .map(|i| {
                    let mut ray = camera(i, rng);
                    if rng.chance(0.2) {
                        ray.d = -ray.d;
                    }
                    ray.t_min = if rng.chance(0.5) { 0.0 } else { rng.rangef(0.0, r) };
                    ray.t_max = ray.t_min + rng.log_range(1e-3, 10.0 * r as f64) as f32;
                    if rng.chance(0.03) {
                        ray.o.x = f32::NAN;
                    }
                    Some(ray)
                })
                .collect(),
        };
        // partially active
        if k % 3 == 1 {
            for l in p.iter_mut() {
                if rng.chance(0.3) {
                    *l = None;
                }
            }
        }
        out.push(p);
    }
    out
}

fn bits(h: &Option<Hit>) -> Option<(u32, u32, [u32; 3], u32)> {
    h.map(|h| (h.t.to_bits(), h.prim, h.b.map(f32::to_bits), h.sub))
}

/// Checks every packet; returns (closest-hit rays, of them hits, retraced).
fn check(label: &str, bvh: &WideBvh, prims: &[Prim], packets: &[Vec<Option<Ray>>]) -> (u64, u64, u64) {
    let (mut rays, mut hits) = (0u64, 0u64);
    let before = packet_retraced();
    for (k, p) in packets.iter().enumerate() {
        let list: Vec<Ray> = p.iter().map(|r| r.unwrap_or(Ray::new(Vec3::ZERO, Vec3::X))).collect();
        let active = p.iter().enumerate().filter(|(_, r)| r.is_some()).fold(0u32, |m, (i, _)| m | 1 << i);
        let sentinel = Some(Hit {
            t: -1.0,
            prim: u32::MAX,
            b: [0.0; 3],
            sub: 7,
        });
        let mut out = vec![sentinel; list.len()];
        bvh.intersect_packet(prims, &list, active, &mut out);
        let occ = bvh.occluded_packet(prims, &list, active);
        for (i, ray) in list.iter().enumerate() {
            if active >> i & 1 == 0 {
                assert_eq!(bits(&out[i]), bits(&sentinel), "{label}: packet {k} inactive lane {i} was written");
                assert_eq!(occ >> i & 1, 0, "{label}: packet {k} inactive lane {i} occluded");
                continue;
            }
            let want = bvh.intersect(prims, ray);
            rays += 1;
            hits += want.is_some() as u64;
            assert_eq!(
                bits(&out[i]),
                bits(&want),
                "{label}: packet {k} ray {i} {ray:?}: closest {:?}, single-ray {:?}",
                out[i],
                want
            );
            assert_eq!(
                occ >> i & 1 != 0,
                bvh.occluded(prims, ray),
                "{label}: packet {k} ray {i} {ray:?}: any hit differs"
            );
        }
    }
    (rays, hits, packet_retraced() - before)
}

/// The property, on every kernel variant. The retraced count is global (other
/// tests in this file would disturb it), so this is the file's only test that
/// traces packets.
#[test]
fn packets_match_single_rays() {
    let mut rng = Rng::new(13);
    for (name, prims) in meshes(&mut rng) {
        let mut bvh = WideBvh::build(&prims);
        let set = packets(&mut rng, &bvh, &prims, 600);
        for isa in Isa::all_available() {
            assert!(bvh.set_isa(isa));
            for width in [8, 16] {
                assert!(bvh.set_packet_width(width));
                for large in [false, true] {
                    bvh.set_large_stack(large);
                    let label = format!("{name} {} x{width}{}", isa.name(), if large { " large stack" } else { "" });
                    let (rays, hits, retraced) = check(&label, &bvh, &prims, &set);
                    eprintln!("{label}: {rays} rays, {hits} hits, {retraced} traced again");
                    assert!(hits * 5 > rays, "{label}: too few hits ({hits} of {rays}) to test much");
                    // the fallback must stay rare, or the packet kernels are barely tested
                    // (a sixth of the rays aim at vertices and edges, where ties are common)
                    assert!(retraced * 20 < rays, "{label}: {retraced} of {rays} rays traced again");
                }
            }
        }
        bvh.set_large_stack(false);
        // width 0: packet calls go ray by ray
        assert!(bvh.set_packet_width(0));
        check(&format!("{name} no packets"), &bvh, &prims, &set[..50]);
    }
}
