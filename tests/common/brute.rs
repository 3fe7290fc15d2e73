//! Brute-force references for ray queries, and the checks of a traversal
//! (closest hit, any hit, visits; the wide tree's structure) against them.

use rdr::accel::bvh::MAX_LEAF;
use rdr::accel::wide::{ChildRef, Isa, WideBvh, LANES};
use rdr::geometry::aabb::Aabb;
use rdr::geometry::triangle::intersect_watertight;
use rdr::geometry::Ray;
use rdr::scene::Prim;

pub fn prim_intersect(p: &Prim, ray: &Ray, t_max: f32) -> Option<f32> {
    match p {
        Prim::Triangle { p, .. } => intersect_watertight(ray.o, ray.d, ray.t_min, t_max, p).map(|h| h.t),
        Prim::Sphere { sphere, .. } => sphere.intersect(ray.o, ray.d, ray.t_min, t_max),
        Prim::Cylinder { cylinder, .. } => cylinder.intersect(ray.o, ray.d, ray.t_min, t_max),
        Prim::SdfVoxel { voxel, .. } => voxel.intersect(ray.o, ray.d, ray.t_min, t_max),
        Prim::Instance { .. } => panic!("brute force over instances: flatten them first"),
    }
}

/// Closest hit over all primitives by brute force (first index wins ties).
pub fn brute_closest(prims: &[Prim], ray: &Ray) -> Option<(u32, f32)> {
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

/// A traversal under test: closest hit, any hit and a visit of every primitive
/// the boxes admit.
pub type Visit<'a> = &'a dyn Fn(&Ray, &mut dyn FnMut(u32));

pub struct Queries<'a> {
    pub closest: &'a dyn Fn(&Ray) -> Option<(u32, f32)>,
    pub any: &'a dyn Fn(&Ray) -> bool,
    pub visit: Visit<'a>,
    /// Primitives may sit in several leaves (pre-split triangles), so a visit may
    /// meet one more than once.
    pub repeats: bool,
}

/// Whether some primitive of the wide tree sits in more than one leaf (pre-split).
pub fn has_split_refs(bvh: &WideBvh) -> bool {
    bvh.children().map(|(_, _, c)| bvh.leaf_prims(c).len()).sum::<usize>() > bvh.prim_count
}

pub fn check_with(label: &str, q: &Queries, prims: &[Prim], rays: &[Ray]) -> usize {
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
                if !q.repeats {
                    assert_ne!(seen[i as usize], k as u32, "{}: primitive {i} visited twice", ctx());
                }
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

/// The wide BVH with every instruction set this CPU has (the portable one
/// always), and its closure traversal.
pub fn check_wide_queries(label: &str, bvh: &WideBvh, prims: &[Prim], rays: &[Ray]) -> usize {
    let mut hits = 0;
    // the traversals with the large stack (deep trees) on every other check
    let large = rays.len() % 2 == 1;
    let repeats = has_split_refs(bvh);
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
            repeats,
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

/// Checks the wide tree's structure: every usable primitive in exactly one leaf
/// (padding lanes repeat their block's last triangle), leaves of one kind and
/// at most `MAX_LEAF` primitives, children inside their parents' slots, every
/// node reached once; returns the depth. In a pre-split tree a triangle may sit in
/// several leaves (once in each), each of which then holds a piece of it (the
/// queries check that the pieces cover it); one in a single leaf lies inside it.
pub fn check_wide_structure(bvh: &WideBvh, bounds: &[Aabb]) -> usize {
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
    // (primitive, its leaf's box, the node holding the leaf)
    let mut placed = Vec::new();
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
                    for (k, &p) in items.iter().enumerate() {
                        assert!(!items[..k].contains(&p), "primitive {p} twice in a leaf of node {i}");
                        seen[p as usize] += 1;
                        placed.push((p, cb, i));
                    }
                }
            }
        }
    }
    for (p, cb, i) in placed {
        if seen[p as usize] == 1 {
            assert!(inside(&bounds[p as usize], &cb), "primitive {p} outside its leaf box in node {i}");
        }
    }
    let split = has_split_refs(bvh);
    for (i, &n) in seen.iter().enumerate() {
        let usable = valid.binary_search(&(i as u32)).is_ok();
        if split && usable {
            assert!(n >= 1, "primitive {i} in no leaf");
        } else {
            assert_eq!(n, usable as u32, "primitive {i} in {n} leaves");
        }
    }
    assert!(reached.iter().all(|&r| r), "unreachable nodes");
    assert!(bvh.stack_need() >= 1 && bvh.stack_need() <= 7 * max_depth + 1);
    max_depth
}
