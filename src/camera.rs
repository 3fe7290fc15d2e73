//! Pinhole camera with a vertical field of view (spec §6).

use crate::geometry::{Ray, RayDifferential};
use crate::math::{normalize_div, Vec3, PI};

/// Where a pinhole camera is and how it looks: `camera` in a scene, every key
/// optional:
/// * `position` (vec3, (0,0,1)), `look_at` (vec3, (0,0,0)) — must differ;
/// * `ref_up` (vec3, (0,1,0)) — not zero nor parallel to the viewing direction;
/// * `fov` (vertical degrees, strictly between 0 and 180, 45);
/// * `focal_length` (> 0, 1; cancels out of the rays).
///
/// ```json
/// "camera": {"position": [0, 1, 6.8], "look_at": [0, 1, 0], "ref_up": [0, 1, 0], "fov": 19.5}
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraParams {
    pub position: Vec3,
    pub look_at: Vec3,
    pub ref_up: Vec3,
    pub fov: f32,
    pub focal_length: f32,
}

#[derive(Clone, Debug)]
pub struct Camera {
    pub position: Vec3,
    /// Forward, right and up vectors scaled to the image plane's half extents.
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    width: f32,
    height: f32,
}

impl Camera {
    /// Set-up in the original's f32 order, so `--compat` rays are bit-exact.
    pub fn new(d: &CameraParams, width: u32, height: u32) -> Camera {
        let f = normalize_div(d.look_at - d.position);
        let r = normalize_div(f.cross(d.ref_up));
        let u = r.cross(f);
        let hy = (((d.fov / 2.0) * PI) / 180.0).tan() * d.focal_length;
        let hx = hy * (width as f32 / height as f32);
        Camera {
            position: d.position,
            forward: f * d.focal_length,
            right: r * hx,
            up: u * hy,
            width: width as f32,
            height: height as f32,
        }
    }

    /// Whether the basis and the rays through the film's corners and centre are
    /// finite and non-zero (scenes are checked with this before rendering).
    pub fn is_finite(&self) -> bool {
        let ok = |v: Vec3| v.is_finite() && v.length_squared() > 0.0 && v.length_squared().is_finite();
        let (w, h) = (self.width, self.height);
        self.position.is_finite()
            && ok(self.forward)
            && ok(self.right)
            && ok(self.up)
            && [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h), (0.5 * w, 0.5 * h)]
                .iter()
                .all(|&(x, y)| ok(self.direction(x, y)))
    }

    /// Direction through the continuous film position `(x, y)`; film `y` grows
    /// upwards, `(0, 0)` is the bottom-left corner of the view.
    #[inline]
    pub fn direction(&self, x: f32, y: f32) -> Vec3 {
        let sx = (x / self.width) * 2.0 - 1.0;
        let sy = (y / self.height) * 2.0 - 1.0;
        normalize_div((sx * self.right + sy * self.up) + self.forward)
    }

    /// Angle (radians, small-angle) one pixel spans at the centre of the view:
    /// a pixel's footprint at distance d is about `d · pixel_spread()`.
    pub fn pixel_spread(&self) -> f32 {
        2.0 * self.up.length() / (self.height * self.forward.length())
    }

    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        Ray::new(self.position, self.direction(x, y))
    }

    /// The ray through `(x, y)` (identical to [`Camera::ray`]) and its differentials:
    /// the rays through `(x + 1, y)` and `(x, y + 1)`, from the same eye point (spec §6).
    #[inline]
    pub fn ray_differential(&self, x: f32, y: f32) -> (Ray, RayDifferential) {
        let diff = RayDifferential {
            rx_o: self.position,
            rx_d: self.direction(x + 1.0, y),
            ry_o: self.position,
            ry_d: self.direction(x, y + 1.0),
        };
        (self.ray(x, y), diff)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_left_is_world_minus_x_and_fov_is_vertical() {
        let d = CameraParams {
            position: Vec3::new(0.0, 1.0, 6.8),
            look_at: Vec3::new(0.0, 1.0, 0.0),
            ref_up: Vec3::Y,
            fov: 90.0,
            focal_length: 1.0,
        };
        let c = Camera::new(&d, 200, 100);
        assert!(c.direction(0.0, 50.0).x < 0.0, "left edge looks towards -x");
        assert!(c.direction(100.0, 100.0).y > 0.0, "film y = H is the top");
        // vertical half angle 45°, horizontal extent doubled by the 2:1 aspect
        let top = c.direction(100.0, 100.0);
        assert!((top.y / -top.z - 1.0).abs() < 1e-6);
        let right = c.direction(200.0, 50.0);
        assert!((right.x / -right.z - 2.0).abs() < 1e-6);
    }

    #[test]
    fn differentials_are_the_rays_one_pixel_right_and_up() {
        let d = CameraParams {
            position: Vec3::new(1.0, 2.0, 3.0),
            look_at: Vec3::ZERO,
            ref_up: Vec3::Y,
            fov: 40.0,
            focal_length: 1.0,
        };
        let c = Camera::new(&d, 64, 48);
        let (r, diff) = c.ray_differential(10.25, 7.5);
        assert_eq!(r.d, c.ray(10.25, 7.5).d);
        assert_eq!((diff.rx_o, diff.ry_o), (r.o, r.o));
        assert_eq!(diff.rx_d, c.direction(11.25, 7.5));
        assert_eq!(diff.ry_d, c.direction(10.25, 8.5));
        let half = diff.scaled(&r, 0.5);
        assert!((half.rx_d - (r.d + diff.rx_d) * 0.5).length() < 1e-7);
    }
}
