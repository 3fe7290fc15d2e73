use crate::math::Vec3;

/// Default parametric range of camera rays (spec §14.1).
pub const RAY_T_MIN: f32 = 1e-4;
pub const RAY_T_MAX: f32 = 1e7;

/// A ray `o + t·d`, `t ∈ [t_min, t_max]`. `d` is unit length for rays made by the
/// camera and the integrators; the kernels do not rely on it. Laid out as eight
/// `f32` in field order (the packet kernels load a ray as one vector).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    /// A stand-in for the unused lanes of a ray array: from the origin along +z. A
    /// constant, so arrays of it are copied from read-only data (a template built on
    /// the stack with narrow stores and copied with wide loads stalled).
    pub const IDLE: Ray = Ray::new(Vec3::ZERO, Vec3::Z);

    pub const fn new(o: Vec3, d: Vec3) -> Self {
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

/// The two auxiliary rays of a camera ray (pbrt's ray differentials): the rays
/// through the film positions one pixel to the right (`x + 1`) and one pixel up
/// (`y + 1`) of the main ray's (spec §6). They give the screen-space footprint of a
/// hit ([`crate::geometry::interaction::Interaction::compute_uv_derivatives`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayDifferential {
    pub rx_o: Vec3,
    pub rx_d: Vec3,
    pub ry_o: Vec3,
    pub ry_d: Vec3,
}

impl RayDifferential {
    /// Moves the auxiliary rays towards `main` by `s` (pbrt's `ScaleDifferentials`):
    /// `s < 1` describes a footprint smaller than a pixel.
    pub fn scaled(&self, main: &Ray, s: f32) -> RayDifferential {
        RayDifferential {
            rx_o: main.o + (self.rx_o - main.o) * s,
            rx_d: main.d + (self.rx_d - main.d) * s,
            ry_o: main.o + (self.ry_o - main.o) * s,
            ry_d: main.d + (self.ry_d - main.d) * s,
        }
    }
}
