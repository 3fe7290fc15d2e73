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

    /// Area of the image plane at distance 1 from the eye (the whole film).
    pub fn image_plane_area(&self) -> f32 {
        4.0 * self.right.length() * self.up.length() / self.forward.length_squared()
    }

    /// The continuous film position a world point projects to and cos θ of its
    /// direction to the optical axis; `None` behind the eye or outside the film.
    /// The inverse of [`Camera::direction`].
    pub fn project(&self, p: Vec3) -> Option<(crate::math::Vec2, f32)> {
        let v = p - self.position;
        let z = v.dot(self.forward) / self.forward.length_squared();
        if z <= 0.0 || !z.is_finite() {
            return None;
        }
        let sx = v.dot(self.right) / self.right.length_squared() / z;
        let sy = v.dot(self.up) / self.up.length_squared() / z;
        let (x, y) = ((sx + 1.0) * 0.5 * self.width, (sy + 1.0) * 0.5 * self.height);
        if !(x >= 0.0 && x < self.width && y >= 0.0 && y < self.height) {
            return None;
        }
        let cos = v.dot(self.forward) / (v.length() * self.forward.length());
        Some((crate::math::Vec2::new(x, y), cos))
    }

    /// Solid-angle density of camera rays in direction `w` (unit) for film positions
    /// drawn uniformly over the whole film: 1/(A·cos³θ), 0 outside the view.
    pub fn pdf_dir(&self, w: Vec3) -> f32 {
        match self.project(self.position + w) {
            Some((_, cos)) => 1.0 / (self.image_plane_area() * cos * cos * cos),
            None => 0.0,
        }
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
    fn projection_inverts_directions_and_densities_integrate_to_one() {
        let d = CameraParams {
            position: Vec3::new(0.5, 1.0, 3.0),
            look_at: Vec3::new(0.0, 0.8, 0.0),
            ref_up: Vec3::Y,
            fov: 50.0,
            focal_length: 1.0,
        };
        let c = Camera::new(&d, 64, 48);
        for (x, y) in [(0.5f32, 0.5f32), (10.25, 40.0), (63.9, 0.1), (32.0, 24.0)] {
            let (pos, _) = c.project(c.position + c.direction(x, y) * 2.7).unwrap();
            assert!((pos.x - x).abs() < 1e-3 && (pos.y - y).abs() < 1e-3, "({x},{y}) -> {pos}");
        }
        assert!(c.project(c.position - c.direction(32.0, 24.0)).is_none(), "behind the eye");
        // ∫ pdf_dir dω over the view = 1 (film sampled uniformly): E[1/pdf] over the film = Ω
        let n = 200;
        let mut omega = 0.0f64;
        let mut expect = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let (x, y) = ((i as f32 + 0.5) / n as f32 * 64.0, (j as f32 + 0.5) / n as f32 * 48.0);
                let w = c.direction(x, y);
                omega += 1.0 / c.pdf_dir(w) as f64 / (n * n) as f64;
                let cos = w.dot((d.look_at - d.position).normalize()) as f64;
                expect += c.image_plane_area() as f64 * cos * cos * cos / (n * n) as f64;
            }
        }
        assert!((omega - expect).abs() < 1e-4 * expect, "{omega} vs {expect}");
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
