//! Property tests of the BVH against brute force: the binary and the wide tree
//! (closest hit, any hit, visits, structure) on random soups, spheres and
//! degenerate inputs, with every instruction set this CPU has.
//!
//! A splitmix64 generator with fixed seeds (`common::Rng`) drives many random
//! cases per test, so every run checks the same cases.

mod common;

use common::*;
use rdr::accel::bvh::{Bvh, MAX_LEAF};
use rdr::accel::wide::{ChildRef, Isa, WideBvh};
use rdr::desc::build::{build_bvh, prim_bounds};
use rdr::geometry::aabb::Aabb;
use rdr::geometry::Ray;
use rdr::math::Vec3;
use rdr::scene::Prim;

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
        repeats: false,
    };
    check_with(label, &q, prims, rays)
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
        _ => unreachable!("triangles and spheres only"),
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

/// `n` spheres centred in the unit cube, radii log-uniform in `radii`, objects 1…n.
fn random_spheres(rng: &mut Rng, n: u32, radii: (f64, f64)) -> Vec<Prim> {
    (1..=n)
        .map(|object| Prim::Sphere {
            sphere: rdr::geometry::sphere::Sphere {
                center: rng.in_cube(1.0),
                radius: rng.log_range(radii.0, radii.1) as f32,
                uv_frame: None,
            },
            object,
        })
        .collect()
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
            uv_frame: None,
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
        uv_frame: None,
    };
    prims.push(Prim::Sphere { sphere: big, object: 400 });
    let far = rdr::geometry::sphere::Sphere {
        center: Vec3::splat(50.0),
        radius: 2.0,
        uv_frame: None,
    };
    prims.push(Prim::Sphere { sphere: far, object: 401 });
    let n = prims.len();
    for _ in 0..n {
        let (i, j) = (rng.below(n), rng.below(n));
        prims.swap(i, j);
    }
    let (_, hits) = check_prims("spheres and triangles", &mut rng, prims, 6000);
    assert!(hits > 1000);
    // and a tree of spheres alone (its traversal compiled without triangle blocks)
    let spheres = random_spheres(&mut rng, 500, (1e-3, 0.3));
    let (_, hits) = check_prims("spheres only", &mut rng, spheres, 3000);
    assert!(hits > 500);
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

/// Rooms: large walls and floors, long thin rails and small clutter, the geometry
/// pre-splitting is for (`rdr::accel::presplit`).
fn room(rng: &mut Rng) -> Vec<[Vec3; 3]> {
    let v = Vec3::new;
    let mut tris = vec![
        // floor and two walls of a 4 x 3 x 4 room, two triangles each
        [v(-2.0, 0.0, -2.0), v(2.0, 0.0, -2.0), v(2.0, 0.0, 2.0)],
        [v(-2.0, 0.0, -2.0), v(2.0, 0.0, 2.0), v(-2.0, 0.0, 2.0)],
        [v(-2.0, 0.0, -2.0), v(-2.0, 3.0, -2.0), v(2.0, 3.0, -2.0)],
        [v(-2.0, 0.0, -2.0), v(2.0, 3.0, -2.0), v(2.0, 0.0, -2.0)],
        [v(-2.0, 0.0, -2.0), v(-2.0, 3.0, 2.0), v(-2.0, 3.0, -2.0)],
        [v(-2.0, 0.0, -2.0), v(-2.0, 0.0, 2.0), v(-2.0, 3.0, 2.0)],
    ];
    // rails: long thin diagonal triangles across the room
    for _ in 0..40 {
        let a = rng.in_cube(2.0) + Vec3::new(0.0, 1.5, 0.0);
        let b = rng.in_cube(2.0) + Vec3::new(0.0, 1.5, 0.0);
        let w = rng.in_cube(0.02);
        tris.push([a, b, a + w]);
        tris.push([b, b + w, a + w]);
    }
    // clutter: many small triangles, so the budget goes to the large ones
    tris.extend(
        random_soup(rng, 3000, 1.5, (0.005, 0.05))
            .into_iter()
            .map(|t| t.map(|p| p + Vec3::new(0.0, 1.5, 0.0))),
    );
    tris
}

/// Pre-split trees (walls, floors and rails split into pieces) against brute force,
/// with every instruction set, single rays and packets; and every hit exactly the
/// unsplit tree's (primitive, distance and barycentric bits), on the same rays.
#[test]
fn bvh_presplit_matches_brute_force_and_the_unsplit_tree() {
    use common::brute::has_split_refs;
    let mut rng = Rng::new(21);
    for budget in [rdr::accel::presplit::PAPER_BUDGET, 1.0] {
        let prims = as_prims(room(&mut rng));
        let bounds: Vec<Aabb> = prims.iter().map(prim_bounds).collect();
        let split = WideBvh::build_split(&prims, budget);
        let plain = WideBvh::build_split(&prims, 0.0);
        assert!(has_split_refs(&split), "budget {budget}: nothing was split");
        assert!(!has_split_refs(&plain));
        let label = format!("room, budget {budget}");
        check_wide_structure(&split, &bounds);
        let rays = scene_rays(&mut rng, &prims, 3000);
        let hits = check_wide_queries(&label, &split, &prims, &rays);
        assert!(hits > 1000, "{label}: {hits} hits");
        let key = |h: Option<rdr::scene::Hit>| h.map(|h| (h.prim, h.t.to_bits(), h.b.map(f32::to_bits)));
        let mut out = vec![None; 16];
        for (k, chunk) in rays.chunks(16).enumerate() {
            split.intersect_packet(&prims, chunk, u32::MAX, &mut out);
            for (i, r) in chunk.iter().enumerate() {
                let (a, b) = (split.intersect(&prims, r), plain.intersect(&prims, r));
                assert_eq!(key(a), key(b), "{label}: ray {} hits differently in the split tree", 16 * k + i);
                assert_eq!(key(out[i]), key(a), "{label}: ray {}: the packet's hit differs", 16 * k + i);
                assert_eq!(split.occluded(&prims, r), b.is_some(), "{label}: ray {}: any hit", 16 * k + i);
            }
        }
    }
}

/// A pre-split tree, like any other, does not depend on the number of threads.
#[test]
fn bvh_presplit_is_the_same_for_any_thread_count() {
    let mut rng = Rng::new(22);
    let prims = as_prims(room(&mut rng));
    let build = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| WideBvh::build_split(&prims, 1.0))
    };
    let one = build(1);
    assert!(common::brute::has_split_refs(&one));
    for threads in [2, 3] {
        assert_same_tree(&one, &build(threads));
    }
}
