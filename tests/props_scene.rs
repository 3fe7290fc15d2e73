//! Property tests of the full `Scene` queries against brute force (meshes from
//! OBJ files, transforms, spheres), and of the wide BVH on an exact lattice grid.
//!
//! A splitmix64 generator with fixed seeds (`common::Rng`) drives many random
//! cases per test, so every run checks the same cases.

mod common;

use common::*;
use rdr::accel::wide::Isa;
use rdr::desc::build::{build_bvh, prim_bounds};
use rdr::geometry::aabb::Aabb;
use rdr::geometry::triangle::intersect_watertight;
use rdr::geometry::Ray;
use rdr::math::Vec3;
use rdr::scene::Prim;
use std::path::Path;

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
    let dir = common::temp_dir("rdr-props-scene");
    let mut rng = Rng::new(13);
    let mut soup = random_soup(&mut rng, 400, 1.0, (0.01, 0.3));
    soup.push([Vec3::ZERO, Vec3::X, Vec3::X * 2.0]); // degenerate: dropped with a warning
    write_obj(&dir.path().join("soup.obj"), &soup);
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
    write_obj(&dir.path().join("grid.obj"), &grid);
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
    let desc = rdr::desc::SceneDesc::from_value(&value, Path::new("t.json"), dir.path()).unwrap();
    let scene = rdr::desc::build(&desc, rdr::desc::BuildOptions::default()).unwrap();
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
