//! Binary BVH built with the binned surface-area heuristic of [`super::build`], flattened depth-first
//! into one array (left child next to its parent, right child by index).
//!
//! The tree knows only boxes; primitive tests are the caller's closure, so the same
//! tree serves closest-hit, any-hit and the `--compat` tie-breaking query.

use super::build::{TmpKind, TmpNode};
use crate::geometry::{Aabb, Ray};

pub use super::build::MAX_LEAF;
const STACK: usize = 128;

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

impl Bvh {
    /// Builds over the given boxes; empty boxes (and boxes with NaN) are left out.
    pub fn build(bounds: &[Aabb]) -> Bvh {
        let mut refs = super::build::make_refs(bounds);
        let tree = super::build::build_tree(&mut refs, MAX_LEAF);
        let mut bvh = Bvh {
            nodes: Vec::with_capacity(2 * refs.len() / 2 + 1),
            order: refs.iter().map(|r| r.index()).collect(),
        };
        if let Some(t) = tree {
            bvh.flatten(&t);
        }
        bvh
    }

    fn flatten(&mut self, t: &TmpNode) -> usize {
        let index = self.nodes.len();
        self.nodes.push(Node {
            bounds: t.bounds.padded(),
            offset: 0,
            count: 0,
        });
        match &t.kind {
            TmpKind::Leaf { start, count } => {
                self.nodes[index].offset = *start;
                self.nodes[index].count = *count;
            }
            TmpKind::Inner(c) => {
                self.flatten(&c[0]);
                let r = self.flatten(&c[1]);
                self.nodes[index].offset = r as u32;
            }
        }
        index
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

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
        let mut seen = vec![];
        bvh.traverse(&ray, |p, _| {
            seen.push(p);
            false
        });
        // (four boxes make one leaf: all are visited, the two hit among them)
        assert!(seen.contains(&0) && seen.contains(&1));
        // a 4×4×4 lattice of cubes: the ray along one row visits that row and
        // not all 64
        let boxes: Vec<Aabb> = (0..64)
            .map(|i| cube(Vec3::new((i % 4) as f32, (i / 4 % 4) as f32, (i / 16) as f32) * 2.0))
            .collect();
        let bvh = Bvh::build(&boxes);
        let ray = Ray::new(Vec3::new(-1.0, 0.0, 0.0), Vec3::X);
        let inv = crate::geometry::aabb::safe_inverse(ray.d);
        let mut seen = vec![];
        bvh.traverse(&ray, |p, _| {
            seen.push(p);
            false
        });
        for (i, b) in boxes.iter().enumerate() {
            if b.intersect(ray.o, inv, 0.0, f32::INFINITY).is_some() {
                assert!(seen.contains(&(i as u32)), "box {i} is hit but not visited");
            }
        }
        assert!(seen.len() < 32, "visited {} of 64", seen.len());
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
