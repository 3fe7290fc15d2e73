use crate::math::{gamma, Vec3};

/// Axis-aligned box. The empty box has `min = +∞`, `max = −∞`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }
    pub fn from_points(pts: &[Vec3]) -> Self {
        pts.iter().fold(Self::EMPTY, |b, &p| b.grow(p))
    }
    #[inline]
    pub fn grow(self, p: Vec3) -> Self {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }
    #[inline]
    pub fn union(self, o: Aabb) -> Self {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }
    pub fn centroid(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }
    /// Surface area; 0 for the empty box.
    #[inline]
    pub fn area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
    pub fn largest_axis(&self) -> usize {
        let e = self.extent();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    /// Slab test against `[t_min, t_max]`; returns the entry distance.
    ///
    /// Inclusive at both ends, so boxes of zero thickness (a wall, a floor) are
    /// hit. `inv_d` is `1/d` with ±∞ for zero components; the near/far pick is by
    /// the sign of `inv_d` and `f32::max/min` ignore the NaN of `0·∞`, which makes a
    /// ray lying in a slab's boundary plane count as inside that slab. The exit is
    /// widened by 2γ(3) against rounding (pbrt-v4).
    #[inline]
    pub fn intersect(&self, o: Vec3, inv_d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let mut t0 = t_min;
        let mut t1 = t_max;
        for a in 0..3 {
            let (lo, hi) = if inv_d[a] >= 0.0 {
                (self.min[a], self.max[a])
            } else {
                (self.max[a], self.min[a])
            };
            let near = (lo - o[a]) * inv_d[a];
            let far = (hi - o[a]) * inv_d[a] * (1.0 + 2.0 * gamma(3));
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        (t0 <= t1).then_some(t0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inv(d: Vec3) -> Vec3 {
        Vec3::ONE / d
    }

    #[test]
    fn unit_box_entry_and_exit_match_the_course_tests() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        for (o, d) in [
            (Vec3::new(-2.0, 0.0, 0.0), Vec3::X),
            (Vec3::new(2.0, 0.0, 0.0), -Vec3::X),
            (Vec3::new(0.0, -2.0, 0.0), Vec3::Y),
            (Vec3::new(0.0, 0.0, 2.0), -Vec3::Z),
        ] {
            assert_eq!(b.intersect(o, inv(d), 0.0, f32::INFINITY), Some(1.0));
            assert!(b.intersect(o, inv(d), 0.0, 0.99).is_none(), "culled by t_max");
        }
    }

    #[test]
    fn flat_boxes_and_axis_parallel_rays() {
        let wall = Aabb::new(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0));
        assert_eq!(wall.intersect(Vec3::new(0.2, 3.0, 0.1), inv(-Vec3::Y), 0.0, 10.0), Some(3.0));
        // ray lying exactly in the plane of the flat box
        assert!(wall.intersect(Vec3::new(-5.0, 0.0, 0.0), inv(Vec3::X), 0.0, 10.0).is_some());
        // parallel ray just outside
        assert!(wall.intersect(Vec3::new(-5.0, 1e-3, 0.0), inv(Vec3::X), 0.0, 10.0).is_none());
        // origin on the boundary plane of a thick box, moving along it
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert!(b.intersect(Vec3::new(0.0, 0.5, -1.0), inv(Vec3::Z), 0.0, 10.0).is_some());
        assert!(b.intersect(Vec3::new(1.0, 0.5, -1.0), inv(-(-Vec3::Z)), 0.0, 10.0).is_some());
        assert!(Aabb::EMPTY.intersect(Vec3::ZERO, inv(Vec3::X), 0.0, 10.0).is_none());
    }
}
