//! Photon-map data structures compared on the acceptance tests' queries:
//! the kd-tree of `rdr::accel::photon_map` and a hashed uniform grid (cells of
//! the query radius, points sorted by cell, 3×3×3 cells per query).
//!
//!     cargo run --release --example photon_map_bench

use rdr::accel::photon_map::{dist2, KdTree};
use rdr::sampling::SplitMix64;
use std::time::Instant;

struct Grid {
    cell: f32,
    size: usize,
    start: Vec<u32>,
    points: Vec<[f32; 3]>,
}

fn hash(c: [i32; 3], size: usize) -> usize {
    ((c[0] as u32).wrapping_mul(73_856_093) ^ (c[1] as u32).wrapping_mul(19_349_663) ^ (c[2] as u32).wrapping_mul(83_492_791)) as usize
        % size
}

impl Grid {
    fn build(pts: &[[f32; 3]], cell: f32) -> Grid {
        let size = pts.len().next_power_of_two();
        let key = |p: &[f32; 3]| hash(p.map(|x| (x / cell).floor() as i32), size);
        let mut count = vec![0u32; size + 1];
        for p in pts {
            count[key(p) + 1] += 1;
        }
        for i in 0..size {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut points = vec![[0.0; 3]; pts.len()];
        for p in pts {
            let k = key(p);
            points[fill[k] as usize] = *p;
            fill[k] += 1;
        }
        Grid {
            cell,
            size,
            start: count,
            points,
        }
    }

    fn within(&self, q: &[f32; 3], r: f32, mut f: impl FnMut(&[f32; 3])) {
        let c = q.map(|x| (x / self.cell).floor() as i32);
        let mut seen = [usize::MAX; 27];
        let mut n = 0;
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let h = hash([c[0] + dx, c[1] + dy, c[2] + dz], self.size);
                    if seen[..n].contains(&h) {
                        continue;
                    }
                    seen[n] = h;
                    n += 1;
                    for p in &self.points[self.start[h] as usize..self.start[h + 1] as usize] {
                        if dist2(p, q) < r * r {
                            f(p);
                        }
                    }
                }
            }
        }
    }
}

fn main() {
    for (n, r) in [(16_384usize, 0.1f32), (1_000_000, 0.01)] {
        let mut rng = SplitMix64(1);
        let pts: Vec<[f32; 3]> = (0..n).map(|_| std::array::from_fn(|_| rng.unit_f32())).collect();
        let queries: Vec<[f32; 3]> = (0..200_000).map(|_| std::array::from_fn(|_| rng.unit_f32())).collect();
        let t = Instant::now();
        let tree = KdTree::build(pts.clone());
        let kd_build = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let grid = Grid::build(&pts, r);
        let grid_build = t.elapsed().as_secs_f64();
        let (mut a, mut b) = (0usize, 0usize);
        let t = Instant::now();
        for q in &queries {
            tree.within(q, r, |_, _| a += 1);
        }
        let kd_radius = t.elapsed().as_secs_f64();
        let t = Instant::now();
        for q in &queries {
            grid.within(q, r, |_| b += 1);
        }
        let grid_radius = t.elapsed().as_secs_f64();
        assert_eq!(a, b);
        let mut out = Vec::new();
        let t = Instant::now();
        for q in &queries {
            tree.knn(q, 64, f32::INFINITY, &mut out);
        }
        let kd_knn = t.elapsed().as_secs_f64();
        let per = |s: f64| s / queries.len() as f64 * 1e9;
        println!(
            "{n} points, r = {r} ({:.1} found per query): build kd {:.1} ms / grid {:.1} ms; radius query kd {:.0} ns / grid {:.0} ns; kd k-NN (k = 64) {:.0} ns",
            a as f64 / queries.len() as f64,
            kd_build * 1e3,
            grid_build * 1e3,
            per(kd_radius),
            per(grid_radius),
            per(kd_knn)
        );
    }
}
