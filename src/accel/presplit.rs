//! Triangle pre-splitting (Karras and Aila 2013, "Fast parallel construction of
//! high-quality bounding volume hierarchies", section 4): before the SAH build, large
//! triangles whose boxes are mostly empty (walls, floors, long thin rails) are split
//! into several references, each with the box of one piece of the triangle, so that
//! the tree's boxes stop overlapping where such triangles cross it. Every reference
//! still names the whole triangle: traversal tests it with the same watertight kernel
//! on the same vertices, so a ray hits exactly what it hit before, only from a
//! smaller box.
//!
//! * Priority: a triangle's wasted box area `w` (its box's half area minus the half
//!   area its pieces would cover if split without end, the sum of its projections on
//!   the three axis planes), taken as `w^(1/3)` (the paper's exponent). Splits per
//!   triangle: `⌊β·N·p / Σp⌋` for a budget `β` of extra references per triangle, so
//!   a mesh of even triangles (a scanned model) gets none, and the total stays within
//!   `β·N`.
//! * Planes: the piece's longest axis, at the coarsest plane of the power-of-two grid
//!   over the scene's box that cuts the piece, so neighbouring triangles are cut in
//!   the same places; the remaining splits go to the two sides by their box areas.
//! * Pieces: the triangle clipped to the piece's box in `f64`; the clipped box is
//!   widened by an `f32` ulp beyond the outward rounding and kept within the parent's,
//!   so it always holds its piece (a ray that hits the triangle there enters it).
//!
//! The result depends on the triangles only (sums are sequential), not on threads.

use super::build::PrimRef;
use crate::geometry::Aabb;
use crate::math::{DVec3, Vec3};

/// The paper's budget of extra references per triangle (β = 0.3).
pub const PAPER_BUDGET: f32 = 0.3;
/// Most splits one triangle gets.
const MAX_SPLITS: usize = 255;
/// Finest level of the split grid searched for a plane.
const MAX_LEVEL: i32 = 24;

/// Half area of a box (0 for an empty one).
fn half_area(b: &Aabb) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    let e = (b.max - b.min).as_dvec3();
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// Wasted box area of triangle `p` with box `b`.
fn waste(p: &[Vec3; 3], b: &Aabb) -> f64 {
    let [a, q, r] = p.map(|v| v.as_dvec3());
    let c = (q - a).cross(r - a);
    (half_area(b) - 0.5 * (c.x.abs() + c.y.abs() + c.z.abs())).max(0.0)
}

/// `refs` with the triangles pre-split within a budget of `budget` extra references
/// per triangle; `triangle(i)` gives primitive `i`'s vertices (`None` for other kinds).
/// References of one triangle stay together, in the order of `refs`.
pub(crate) fn presplit(refs: Vec<PrimRef>, budget: f32, triangle: impl Fn(u32) -> Option<[Vec3; 3]> + Sync) -> Vec<PrimRef> {
    use rayon::prelude::*;
    if budget <= 0.0 || refs.is_empty() {
        return refs;
    }
    let scene = refs.iter().fold(Aabb::EMPTY, |b, r| b.union(r.bounds()));
    let priority: Vec<f64> = refs
        .par_iter()
        .with_min_len(8192)
        .map(|r| match triangle(r.index()).filter(|_| r.is_triangle()) {
            Some(p) => waste(&p, &r.bounds()).cbrt(),
            None => 0.0,
        })
        .collect();
    // sequential: the same sum for any number of threads
    let total: f64 = priority.iter().sum();
    if total <= 0.0 || !total.is_finite() {
        return refs;
    }
    let scale = budget as f64 * refs.len() as f64 / total;
    let splits: Vec<usize> = priority.iter().map(|p| ((p * scale) as usize).min(MAX_SPLITS)).collect();
    if splits.iter().all(|&s| s == 0) {
        return refs;
    }
    let pieces: Vec<Vec<PrimRef>> = refs
        .par_iter()
        .zip(splits.par_iter())
        .with_min_len(1024)
        .map(|(r, &s)| {
            let mut out = Vec::new();
            match triangle(r.index()) {
                Some(p) if s > 0 => {
                    let poly: Vec<DVec3> = p.iter().map(|v| v.as_dvec3()).collect();
                    split(&poly, r.bounds(), s, &scene, &mut |b| out.push(PrimRef::new(b, r.index(), true)));
                }
                _ => out.push(*r),
            }
            out
        })
        .collect();
    pieces.concat()
}

/// Emits the boxes of `s` splits of the polygon `poly` (a triangle clipped to `b`, its box).
fn split(poly: &[DVec3], b: Aabb, s: usize, scene: &Aabb, emit: &mut impl FnMut(Aabb)) {
    if s == 0 {
        emit(b);
        return;
    }
    let axis = b.largest_axis();
    let Some(plane) = grid_plane(b.min[axis], b.max[axis], scene.min[axis], scene.max[axis]) else {
        emit(b);
        return;
    };
    let (left, right) = clip(poly, axis, plane as f64);
    let mut lb = conservative_box(&left, &b);
    lb.max[axis] = lb.max[axis].min(plane);
    let mut rb = conservative_box(&right, &b);
    rb.min[axis] = rb.min[axis].max(plane);
    match (left.is_empty() || lb.is_empty(), right.is_empty() || rb.is_empty()) {
        (false, false) => {
            let (al, ar) = (half_area(&lb), half_area(&rb));
            let sl = (((s - 1) as f64) * al / (al + ar).max(f64::MIN_POSITIVE)).round() as usize;
            split(&left, lb, sl.min(s - 1), scene, emit);
            split(&right, rb, s - 1 - sl.min(s - 1), scene, emit);
        }
        (false, true) => split(&left, lb, s - 1, scene, emit),
        (true, false) => split(&right, rb, s - 1, scene, emit),
        // a degenerate sliver: keep the piece whole
        (true, true) => emit(b),
    }
}

/// The coarsest plane of the power-of-two grid over `[s0, s1]` strictly inside `(lo, hi)`.
fn grid_plane(lo: f32, hi: f32, s0: f32, s1: f32) -> Option<f32> {
    let ext = s1 as f64 - s0 as f64;
    // (NaN fails both)
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) || ext.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    for level in 0..=MAX_LEVEL {
        let cells = (1u64 << level) as f64;
        let k = ((lo as f64 - s0 as f64) / ext * cells).floor() + 1.0;
        let x = (s0 as f64 + ext * k / cells) as f32;
        if x > lo && x < hi {
            return Some(x);
        }
    }
    None
}

/// The parts of the convex polygon `poly` on each side of the plane `x[axis] = at`.
fn clip(poly: &[DVec3], axis: usize, at: f64) -> (Vec<DVec3>, Vec<DVec3>) {
    let (mut l, mut r) = (Vec::with_capacity(poly.len() + 1), Vec::with_capacity(poly.len() + 1));
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let (da, db) = (a[axis] - at, b[axis] - at);
        if da <= 0.0 {
            l.push(a);
        }
        if da >= 0.0 {
            r.push(a);
        }
        if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
            let mut x = a + (b - a) * (da / (da - db));
            x[axis] = at;
            l.push(x);
            r.push(x);
        }
    }
    (l, r)
}

/// The `f32` box around `poly`'s points (rounded outward, then one ulp more), within `parent`.
fn conservative_box(poly: &[DVec3], parent: &Aabb) -> Aabb {
    let mut b = Aabb::EMPTY;
    for p in poly {
        let lo = Vec3::new(down(p.x), down(p.y), down(p.z));
        let hi = Vec3::new(up(p.x), up(p.y), up(p.z));
        b = b.union(Aabb::new(lo, hi));
    }
    Aabb::new(b.min.max(parent.min), b.max.min(parent.max))
}

/// The `f32` one ulp below the largest `f32` not above `x`.
fn down(x: f64) -> f32 {
    let f = x as f32;
    (if f as f64 > x { f.next_down() } else { f }).next_down()
}

/// The `f32` one ulp above the smallest `f32` not below `x`.
fn up(x: f64) -> f32 {
    let f = x as f32;
    (if (f as f64) < x { f.next_up() } else { f }).next_up()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each piece's box holds the triangle's points on its side of every plane: points
    /// sampled over a long thin triangle each lie in some piece's box.
    #[test]
    fn pieces_cover_the_triangle() {
        let p = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(10.0, 0.3, 1.0), Vec3::new(0.2, 7.0, -3.0)];
        let tri = Aabb::from_points(&p);
        let mut boxes = Vec::new();
        let poly: Vec<DVec3> = p.iter().map(|v| v.as_dvec3()).collect();
        split(&poly, tri, 40, &tri, &mut |b| boxes.push(b));
        assert!(boxes.len() > 20, "{} pieces", boxes.len());
        // the pieces' boxes waste less than half the whole box's empty area
        let area: f64 = boxes.iter().map(half_area).sum();
        let (whole, ideal) = (half_area(&tri), half_area(&tri) - waste(&p, &tri));
        assert!(
            area - ideal < 0.5 * (whole - ideal),
            "pieces' area {area}, whole {whole}, ideal {ideal}"
        );
        for i in 0..=200 {
            for j in 0..=200 - i {
                let (u, v) = (i as f64 / 200.0, j as f64 / 200.0);
                let x = poly[0] + (poly[1] - poly[0]) * u + (poly[2] - poly[0]) * v;
                let inside = |b: &Aabb| (0..3).all(|a| b.min[a] as f64 <= x[a] && x[a] <= b.max[a] as f64);
                assert!(boxes.iter().any(inside), "point {x} (u {u}, v {v}) in no piece");
            }
        }
    }
}
