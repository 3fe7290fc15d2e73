use crate::math::{gamma, Vec3};

/// `1/d` per component, with zero components replaced by ±1e-30 first so the
/// result stays finite: no `0·∞` can meet the slab test, and `1e30 · distance`
/// stays below f32::MAX for any distance under 3e8.
#[inline]
pub fn safe_inverse(d: Vec3) -> Vec3 {
    let fix = |x: f32| if x == 0.0 { 1e-30f32.copysign(x) } else { x };
    Vec3::ONE / Vec3::new(fix(d.x), fix(d.y), fix(d.z))
}

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
    /// The box grown by an ulp and 1e-20 on every side, so no axis has zero
    /// thickness: with [`safe_inverse`] a ray lying in the plane of a flat box
    /// then sees a slab of ±1e10 instead of [0, 0]. The BVH stores padded boxes.
    pub fn padded(&self) -> Aabb {
        if self.is_empty() {
            return *self;
        }
        let down = |v: Vec3| Vec3::new(v.x.next_down() - 1e-20, v.y.next_down() - 1e-20, v.z.next_down() - 1e-20);
        let up = |v: Vec3| Vec3::new(v.x.next_up() + 1e-20, v.y.next_up() + 1e-20, v.z.next_up() + 1e-20);
        Aabb {
            min: down(self.min),
            max: up(self.max),
        }
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
    /// hit. `inv_d` should come from [`safe_inverse`]: finite, so no `0·∞` NaN
    /// arises. A ray lying exactly in a boundary plane may miss an unpadded box;
    /// [`Aabb::padded`] boxes (what the BVH stores) contain such rays. The
    /// exit is widened by 2γ(3) against rounding (pbrt-v4). Not meant for the
    /// empty box (a BVH never stores one).
    #[inline]
    pub fn intersect(&self, o: Vec3, inv_d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let a = (self.min - o) * inv_d;
        let b = (self.max - o) * inv_d;
        let near = a.min(b);
        let far = a.max(b) * (1.0 + 2.0 * gamma(3));
        let t0 = near.x.max(near.y).max(near.z).max(t_min);
        let t1 = far.x.min(far.y).min(far.z).min(t_max);
        (t0 <= t1).then_some(t0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn inv(d: Vec3) -> Vec3 {
        safe_inverse(d)
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
        let wall = Aabb::new(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0)).padded();
        assert!((wall.intersect(Vec3::new(0.2, 3.0, 0.1), inv(-Vec3::Y), 0.0, 10.0).unwrap() - 3.0).abs() < 1e-6);
        // ray lying exactly in the plane of the flat box
        assert!(wall.intersect(Vec3::new(-5.0, 0.0, 0.0), inv(Vec3::X), 0.0, 10.0).is_some());
        // parallel ray just outside
        assert!(wall.intersect(Vec3::new(-5.0, 1e-3, 0.0), inv(Vec3::X), 0.0, 10.0).is_none());
        // origin on the boundary plane of a thick box, moving along it
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE).padded();
        assert!(b.intersect(Vec3::new(0.0, 0.5, -1.0), inv(Vec3::Z), 0.0, 10.0).is_some());
        assert!(b.intersect(Vec3::new(1.0, 0.5, -1.0), inv(-(-Vec3::Z)), 0.0, 10.0).is_some());
    }
}
