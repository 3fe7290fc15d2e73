//! Binary BVH built with a binned surface-area heuristic, flattened depth-first
//! into one array (left child next to its parent, right child by index).
//!
//! The tree knows only boxes; primitive tests are the caller's closure, so the same
//! tree serves closest-hit, any-hit and the `--compat` tie-breaking query.

use crate::geometry::{Aabb, Ray};
use crate::math::Vec3;

const BINS: usize = 16;
/// Leaves hold at most this many primitives unless they cannot be split.
pub const MAX_LEAF: usize = 8;
/// Below this depth SAH decides; deeper, splits are by median so depth stays bounded.
const SAH_DEPTH_LIMIT: usize = 48;
const STACK: usize = 128;
/// SAH costs relative to one primitive test.
const COST_TRAVERSE: f32 = 1.0;
const COST_INTERSECT: f32 = 1.0;

#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct Node {
    pub bounds: Aabb,
    /// Leaf: first primitive in `order`. Interior: index of the right child.
    pub offset: u32,
    /// Number of primitives; 0 for interior nodes.
    pub count: u32,
}

#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: Vec<Node>,
    /// Leaf ranges index this array; it holds the caller's primitive indices.
    pub order: Vec<u32>,
}

struct Item {
    bounds: Aabb,
    centroid: Vec3,
    index: u32,
}

impl Bvh {
    /// Builds over the given boxes; empty boxes (and boxes with NaN) are left out.
    pub fn build(bounds: &[Aabb]) -> Bvh {
        let mut items: Vec<Item> = bounds
            .iter()
            .enumerate()
            .filter(|(_, b)| !b.is_empty() && b.min.is_finite() && b.max.is_finite())
            .map(|(i, b)| Item {
                bounds: *b,
                centroid: b.centroid(),
                index: i as u32,
            })
            .collect();
        let mut bvh = Bvh {
            nodes: Vec::with_capacity(2 * items.len() / MAX_LEAF.max(1) + 1),
            order: Vec::new(),
        };
        if !items.is_empty() {
            let n = items.len();
            bvh.build_node(&mut items[..], 0, 0, n);
        }
        bvh.order = items.iter().map(|it| it.index).collect();
        bvh
    }

    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds)
    }

    pub fn depth(&self) -> usize {
        fn rec(b: &Bvh, i: usize) -> usize {
            let n = &b.nodes[i];
            if n.count > 0 {
                1
            } else {
                1 + rec(b, i + 1).max(rec(b, n.offset as usize))
            }
        }
        if self.nodes.is_empty() {
            0
        } else {
            rec(self, 0)
        }
    }

    fn build_node(&mut self, items: &mut [Item], first: usize, depth: usize, total: usize) -> usize {
        let node_index = self.nodes.len();
        let bounds = items.iter().fold(Aabb::EMPTY, |b, it| b.union(it.bounds));
        self.nodes.push(Node {
            bounds: bounds.padded(),
            offset: first as u32,
            count: items.len() as u32,
        });
        let n = items.len();
        if n == 1 {
            return node_index;
        }
        let cb = items.iter().fold(Aabb::EMPTY, |b, it| b.grow(it.centroid));
        let axis = cb.largest_axis();
        let extent = cb.extent()[axis];

        let mid = if extent <= 0.0 || !extent.is_finite() {
            // all centroids coincide: SAH cannot separate them
            if n <= MAX_LEAF {
                return node_index;
            }
            n / 2
        } else if depth >= SAH_DEPTH_LIMIT {
            items.select_nth_unstable_by(n / 2, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
            n / 2
        } else {
            match sah_split(items, &cb, bounds.area()) {
                Some((split_axis, bin, cost)) => {
                    if n <= MAX_LEAF && cost >= n as f32 * COST_INTERSECT {
                        return node_index;
                    }
                    let lo = cb.min[split_axis];
                    let scale = BINS as f32 / cb.extent()[split_axis];
                    let m = partition(items, |it| bin_of(it.centroid[split_axis], lo, scale) <= bin);
                    if m == 0 || m == n {
                        n / 2
                    } else {
                        m
                    }
                }
                None => n / 2,
            }
        };
        let _ = total;
        let (left, right) = items.split_at_mut(mid);
        self.build_node(left, first, depth + 1, total);
        let right_index = self.build_node(right, first + mid, depth + 1, total);
        self.nodes[node_index].offset = right_index as u32;
        self.nodes[node_index].count = 0;
        node_index
    }

    /// Visits the leaves the ray's box test admits, near child first. `visit` gets
    /// a primitive index and the current `t_max`, which it may shrink; returning
    /// `true` stops the traversal (any-hit).
    #[inline]
    pub fn traverse(&self, ray: &Ray, mut visit: impl FnMut(u32, &mut f32) -> bool) {
        if self.nodes.is_empty() {
            return;
        }
        let inv_d = crate::geometry::aabb::safe_inverse(ray.d);
        let mut t_max = ray.t_max;
        if self.nodes[0].bounds.intersect(ray.o, inv_d, ray.t_min, t_max).is_none() {
            return;
        }
        let mut stack = [0u32; STACK];
        let mut sp = 0;
        let mut index = 0usize;
        loop {
            let node = &self.nodes[index];
            if node.count > 0 {
                let start = node.offset as usize;
                for &p in &self.order[start..start + node.count as usize] {
                    if visit(p, &mut t_max) {
                        return;
                    }
                }
            } else {
                let (l, r) = (index + 1, node.offset as usize);
                let tl = self.nodes[l].bounds.intersect(ray.o, inv_d, ray.t_min, t_max);
                let tr = self.nodes[r].bounds.intersect(ray.o, inv_d, ray.t_min, t_max);
                match (tl, tr) {
                    (Some(a), Some(b)) => {
                        let (near, far) = if a <= b { (l, r) } else { (r, l) };
                        stack[sp] = far as u32;
                        sp += 1;
                        index = near;
                        continue;
                    }
                    (Some(_), None) => {
                        index = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        index = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            if sp == 0 {
                return;
            }
            sp -= 1;
            index = stack[sp] as usize;
        }
    }
}

#[inline]
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    (((c - lo) * scale) as usize).min(BINS - 1)
}

/// Best (axis, last bin of the left side, SAH cost) over all three axes.
fn sah_split(items: &[Item], cb: &Aabb, parent_area: f32) -> Option<(usize, usize, f32)> {
    let mut best: Option<(usize, usize, f32)> = None;
    for axis in 0..3 {
        let ext = cb.extent()[axis];
        if ext <= 0.0 {
            continue;
        }
        let lo = cb.min[axis];
        let scale = BINS as f32 / ext;
        let mut bin_bounds = [Aabb::EMPTY; BINS];
        let mut bin_count = [0usize; BINS];
        for it in items {
            let b = bin_of(it.centroid[axis], lo, scale);
            bin_bounds[b] = bin_bounds[b].union(it.bounds);
            bin_count[b] += 1;
        }
        // sweep from the right to get right-side areas and counts
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0usize; BINS];
        let mut acc = Aabb::EMPTY;
        let mut cnt = 0;
        for i in (1..BINS).rev() {
            acc = acc.union(bin_bounds[i]);
            cnt += bin_count[i];
            right_area[i] = acc.area();
            right_count[i] = cnt;
        }
        let mut acc = Aabb::EMPTY;
        let mut cnt = 0;
        for i in 0..BINS - 1 {
            acc = acc.union(bin_bounds[i]);
            cnt += bin_count[i];
            if cnt == 0 || right_count[i + 1] == 0 {
                continue;
            }
            let cost = COST_TRAVERSE
                + COST_INTERSECT * (acc.area() * cnt as f32 + right_area[i + 1] * right_count[i + 1] as f32)
                    / parent_area.max(f32::MIN_POSITIVE);
            if best.is_none_or(|(_, _, c)| cost < c) {
                best = Some((axis, i, cost));
            }
        }
    }
    best
}

fn partition(items: &mut [Item], pred: impl Fn(&Item) -> bool) -> usize {
    let mut i = 0;
    for j in 0..items.len() {
        if pred(&items[j]) {
            items.swap(i, j);
            i += 1;
        }
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_tree_visits_nothing() {
        let bvh = Bvh::build(&[]);
        let mut called = false;
        bvh.traverse(&Ray::new(Vec3::ZERO, Vec3::X), |_, _| {
            called = true;
            false
        });
        assert!(!called);
    }

    #[test]
    fn course_bvh_tests() {
        let cube = |c: Vec3| Aabb::new(c - 0.5, c + 0.5);
        let boxes = [
            cube(Vec3::ZERO),
            cube(Vec3::new(2.0, 0.0, 0.0)),
            cube(Vec3::new(0.0, 2.0, 0.0)),
            cube(Vec3::new(0.0, 0.0, 2.0)),
        ];
        let bvh = Bvh::build(&boxes);
        assert_eq!(bvh.order.len(), 4);
        let ray = Ray::new(Vec3::new(-1.0, 0.0, 0.0), Vec3::X);
        let inv = crate::geometry::aabb::safe_inverse(ray.d);
        let mut seen = vec![];
        bvh.traverse(&ray, |p, _| {
            seen.push(p);
            false
        });
        assert!(seen.contains(&0) && seen.contains(&1));
        for p in seen {
            assert!(boxes[p as usize].intersect(ray.o, inv, 0.0, f32::INFINITY).is_some());
        }
    }

    #[test]
    fn identical_boxes_still_make_bounded_leaves() {
        let boxes = vec![Aabb::new(Vec3::ZERO, Vec3::ONE); 1000];
        let bvh = Bvh::build(&boxes);
        assert!(bvh.nodes.iter().all(|n| n.count as usize <= MAX_LEAF));
        assert!(bvh.depth() < 20);
        let mut n = 0;
        bvh.traverse(&Ray::new(Vec3::new(0.5, 0.5, -1.0), Vec3::Z), |_, _| {
            n += 1;
            false
        });
        assert_eq!(n, 1000);
    }
}
