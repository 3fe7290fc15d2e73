use crate::math::Vec3;

/// Default parametric range of camera rays (spec §14.1).
pub const RAY_T_MIN: f32 = 1e-4;
pub const RAY_T_MAX: f32 = 1e7;

/// A ray `o + t·d`, `t ∈ [t_min, t_max]`. `d` is unit length for rays made by the
/// camera and the integrators; the kernels do not rely on it.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray {
            o,
            d,
            t_min: RAY_T_MIN,
            t_max: RAY_T_MAX,
        }
    }
    pub fn with_range(o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Self {
        Ray { o, d, t_min, t_max }
    }
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}
