//! Cameras (spec §6): the pinhole with a vertical field of view, a thin lens
//! (depth of field) and the orthographic projection.

use crate::geometry::ray::RAY_T_MAX;
use crate::geometry::{Ray, RayDifferential};
use crate::math::{normalize_div, Vec2, Vec3, PI};
use crate::sampling::concentric_disk;

/// Where a camera is and how it looks: `camera` in a scene, every key optional:
/// * `type` (`"perspective"` (the pinhole; RDR171's only camera) | `"thinlens"` |
///   `"orthographic"`, `"perspective"`);
/// * `position` (vec3, (0,0,1)), `look_at` (vec3, (0,0,0)) — must differ;
/// * `ref_up` (vec3, (0,1,0)) — not zero nor parallel to the viewing direction;
/// * `fov` (vertical degrees, strictly between 0 and 180, 45; not `orthographic`);
/// * `focal_length` (> 0, 1; cancels out of the rays);
/// * `thinlens`: `aperture_radius` (≥ 0, world units, required) and
///   `focus_distance` (> 0, along the view axis, required): rays leave a disk of
///   that radius around `position` and meet at the plane in focus (Mitsuba's
///   `thinlens`);
/// * `orthographic`: `height` (> 0, world units, 2): the film sees a `height` tall
///   window perpendicular to the view direction, with parallel rays;
/// * `near_clip` (≥ 0, 0), `far_clip` (> `near_clip`, unbounded): camera rays see
///   only what lies between these distances along the view axis;
/// * `mirrored` (false): the image is mirrored left to right (Mitsuba's sensor with a
///   negative scale in its `to_world`).
///
/// ```json
/// "camera": {"type": "thinlens", "position": [0, 1, 6.8], "look_at": [0, 1, 0], "fov": 19.5,
///            "aperture_radius": 0.05, "focus_distance": 6.8}
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraParams {
    pub position: Vec3,
    pub look_at: Vec3,
    pub ref_up: Vec3,
    pub fov: f32,
    pub focal_length: f32,
    pub projection: Projection,
    pub near_clip: f32,
    pub far_clip: f32,
    pub mirrored: bool,
}

impl Default for CameraParams {
    fn default() -> Self {
        CameraParams {
            position: Vec3::new(0.0, 0.0, 1.0),
            look_at: Vec3::ZERO,
            ref_up: Vec3::Y,
            fov: 45.0,
            focal_length: 1.0,
            projection: Projection::Pinhole,
            near_clip: 0.0,
            far_clip: f32::INFINITY,
            mirrored: false,
        }
    }
}

/// How film positions become rays.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Projection {
    /// All rays leave `position` (JSON `perspective`).
    #[default]
    Pinhole,
    /// Rays leave a disk of `aperture_radius` around `position`, perpendicular to
    /// the view axis, and meet on the plane `focus_distance` ahead.
    ThinLens { aperture_radius: f32, focus_distance: f32 },
    /// Parallel rays along the view axis from a window `height` tall.
    Orthographic { height: f32 },
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
    pub projection: Projection,
    /// Unit view axis, right and up (the lens and the orthographic window).
    axis: Vec3,
    unit_right: Vec3,
    unit_up: Vec3,
    /// Orthographic half extents (world units).
    half_w: f32,
    half_h: f32,
    near_clip: f32,
    far_clip: f32,
    /// The film's corner within the view, in pixels of the whole view (not zero
    /// when cropped, [`Camera::crop`]), and the film's size.
    film_origin: Vec2,
    film_size: Vec2,
}

impl Camera {
    /// Set-up in the original's f32 order, so `--compat` rays are bit-exact.
    pub fn new(d: &CameraParams, width: u32, height: u32) -> Camera {
        let f = normalize_div(d.look_at - d.position);
        let r = normalize_div(f.cross(d.ref_up));
        let u = r.cross(f);
        // a mirrored camera's film x runs the other way (its up stays)
        let r = if d.mirrored { -r } else { r };
        let hy = (((d.fov / 2.0) * PI) / 180.0).tan() * d.focal_length;
        let hx = hy * (width as f32 / height as f32);
        let (half_h, half_w) = match d.projection {
            Projection::Orthographic { height: h } => (0.5 * h, 0.5 * h * (width as f32 / height as f32)),
            _ => (0.0, 0.0),
        };
        Camera {
            position: d.position,
            forward: f * d.focal_length,
            right: r * hx,
            up: u * hy,
            width: width as f32,
            height: height as f32,
            projection: d.projection,
            axis: f,
            unit_right: r,
            unit_up: u,
            half_w,
            half_h,
            near_clip: d.near_clip,
            far_clip: d.far_clip,
            film_origin: Vec2::ZERO,
            film_size: Vec2::new(width as f32, height as f32),
        }
    }

    /// The camera of a film that is the `w`×`h` region at `(x0, y0)` (film
    /// coordinates, `y` upwards) of the whole view: film positions are offset by
    /// the corner, so each pixel sees what it sees in the whole image.
    pub fn crop(&mut self, x0: u32, y0: u32, w: u32, h: u32) {
        self.film_origin = Vec2::new(x0 as f32, y0 as f32);
        self.film_size = Vec2::new(w as f32, h as f32);
    }

    /// Whether rays need a lens sample ([`Camera::sample_ray`]'s `u_lens`).
    pub fn has_lens(&self) -> bool {
        matches!(self.projection, Projection::ThinLens { aperture_radius, .. } if aperture_radius > 0.0)
    }

    /// Whether every ray leaves one point (light paths can be joined to it).
    pub fn is_pinhole(&self) -> bool {
        self.projection == Projection::Pinhole
    }

    /// The point of the lens that `u` (in [0,1)²) picks.
    pub fn lens_point(&self, u: Vec2) -> Vec3 {
        match self.projection {
            Projection::ThinLens { aperture_radius, .. } => {
                let d = concentric_disk(u) * aperture_radius;
                self.position + self.unit_right * d.x + self.unit_up * d.y
            }
            _ => self.position,
        }
    }

    /// Area of the lens (1 for a pinhole, whose position density is a Dirac delta).
    pub fn lens_area(&self) -> f32 {
        match self.projection {
            Projection::ThinLens { aperture_radius, .. } if aperture_radius > 0.0 => PI * aperture_radius * aperture_radius,
            _ => 1.0,
        }
    }

    /// The camera ray through film position `(x, y)`, leaving the lens point
    /// `u_lens` picks (ignored without a lens). A pinhole without clipping gives
    /// exactly [`Camera::ray`].
    pub fn sample_ray(&self, x: f32, y: f32, u_lens: Vec2) -> Ray {
        let (o, d) = self.origin_direction(x, y, u_lens);
        self.clipped(o, d)
    }

    /// A pinhole camera without clipping planes ([`Camera::pinhole_rays`]).
    pub fn is_plain_pinhole(&self) -> bool {
        matches!(self.projection, Projection::Pinhole) && self.near_clip == 0.0 && self.far_clip == f32::INFINITY
    }

    /// [`Camera::sample_ray`] of a pinhole camera without clipping planes for
    /// film positions `(x[i], y[i])`, `i < n`: the same rays, bit for bit, computed
    /// a step at a time over all positions (which the compiler vectorizes). `false`
    /// (nothing written) for other cameras.
    pub fn pinhole_rays<const N: usize>(&self, x: &[f32; N], y: &[f32; N], n: usize, out: &mut [Ray; N]) -> bool {
        if !self.is_plain_pinhole() {
            return false;
        }
        // `direction`'s operations in its order: the film position's offsets, the
        // unnormalized direction, then `normalize_div`
        let (mut dx, mut dy, mut dz) = ([0.0f32; N], [0.0f32; N], [0.0f32; N]);
        for i in 0..N {
            let sx = ((x[i] + self.film_origin.x) / self.width) * 2.0 - 1.0;
            let sy = ((y[i] + self.film_origin.y) / self.height) * 2.0 - 1.0;
            dx[i] = (sx * self.right.x + sy * self.up.x) + self.forward.x;
            dy[i] = (sx * self.right.y + sy * self.up.y) + self.forward.y;
            dz[i] = (sx * self.right.z + sy * self.up.z) + self.forward.z;
            let len = (dx[i] * dx[i] + dy[i] * dy[i] + dz[i] * dz[i]).sqrt();
            (dx[i], dy[i], dz[i]) = (dx[i] / len, dy[i] / len, dz[i] / len);
        }
        for i in 0..n.min(N) {
            out[i] = Ray::new(self.position, Vec3::new(dx[i], dy[i], dz[i]));
        }
        true
    }

    /// [`Camera::sample_ray`] and its differentials (the rays through `(x + 1, y)`
    /// and `(x, y + 1)` from the same lens point).
    pub fn sample_ray_differential(&self, x: f32, y: f32, u_lens: Vec2) -> (Ray, RayDifferential) {
        let (o, d) = self.origin_direction(x, y, u_lens);
        let (rx_o, rx_d) = self.origin_direction(x + 1.0, y, u_lens);
        let (ry_o, ry_d) = self.origin_direction(x, y + 1.0, u_lens);
        (self.clipped(o, d), RayDifferential { rx_o, rx_d, ry_o, ry_d })
    }

    fn origin_direction(&self, x: f32, y: f32, u_lens: Vec2) -> (Vec3, Vec3) {
        match self.projection {
            Projection::Pinhole => (self.position, self.direction(x, y)),
            Projection::ThinLens { focus_distance, .. } => {
                let d = self.direction(x, y);
                let focus = self.position + d * (focus_distance / d.dot(self.axis));
                let o = self.lens_point(u_lens);
                (o, normalize_div(focus - o))
            }
            Projection::Orthographic { .. } => {
                let sx = ((x + self.film_origin.x) / self.width) * 2.0 - 1.0;
                let sy = ((y + self.film_origin.y) / self.height) * 2.0 - 1.0;
                (
                    self.position + self.unit_right * (sx * self.half_w) + self.unit_up * (sy * self.half_h),
                    self.axis,
                )
            }
        }
    }

    /// The ray from `o` along `d`, limited to the clip distances (along the axis).
    fn clipped(&self, o: Vec3, d: Vec3) -> Ray {
        if self.near_clip == 0.0 && self.far_clip == f32::INFINITY {
            return Ray::new(o, d);
        }
        let cos = d.dot(self.axis);
        Ray::with_range(o, d, self.near_clip / cos, (self.far_clip / cos).min(RAY_T_MAX))
    }

    /// For a ray leaving lens point `o` towards world point `p`: the film position
    /// it arrives at and cos θ of its direction to the view axis; `None` behind
    /// the lens or outside the film. A pinhole's `o` is its position ([`Camera::project`]).
    pub fn project_from(&self, o: Vec3, p: Vec3) -> Option<(Vec2, f32)> {
        match self.projection {
            Projection::ThinLens { focus_distance, .. } => {
                let w = normalize_div(p - o);
                let cos = w.dot(self.axis);
                if cos <= 0.0 || !cos.is_finite() {
                    return None;
                }
                // the pinhole ray through the point in focus has the same film position
                let (pos, _) = self.project(o + w * (focus_distance / cos))?;
                Some((pos, cos))
            }
            _ => self.project(p),
        }
    }

    /// Solid-angle density of camera rays leaving lens point `o` in direction `w`
    /// (film positions uniform): 1/(A·cos³θ) inside the view, as for the pinhole.
    pub fn pdf_dir_from(&self, o: Vec3, w: Vec3) -> f32 {
        match self.projection {
            Projection::ThinLens { .. } => match self.project_from(o, o + w) {
                Some((_, cos)) => 1.0 / (self.image_plane_area() * cos * cos * cos),
                None => 0.0,
            },
            _ => self.pdf_dir(w),
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
        let sx = ((x + self.film_origin.x) / self.width) * 2.0 - 1.0;
        let sy = ((y + self.film_origin.y) / self.height) * 2.0 - 1.0;
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
        let (x, y) = (
            (sx + 1.0) * 0.5 * self.width - self.film_origin.x,
            (sy + 1.0) * 0.5 * self.height - self.film_origin.y,
        );
        if !(x >= 0.0 && x < self.film_size.x && y >= 0.0 && y < self.film_size.y) {
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

/// Checks a camera's clipping range: `Err((key, message))` naming the key at fault.
pub fn check_clip_range(near_clip: f32, far_clip: f32) -> Result<(), (&'static str, String)> {
    if !(near_clip >= 0.0 && near_clip.is_finite()) {
        return Err(("near_clip", format!("must be a finite distance of at least 0, found {near_clip}")));
    }
    if far_clip.is_nan() || far_clip <= near_clip {
        return Err((
            "far_clip",
            format!("must be greater than near_clip ({near_clip}), found {far_clip}"),
        ));
    }
    Ok(())
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
            ..Default::default()
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

    /// `pinhole_rays` is `sample_ray` bit for bit, over odd cameras and positions
    /// on and off the film (a lane-by-lane rewrite must keep the operation order).
    #[test]
    fn pinhole_rays_are_sample_ray_bit_for_bit() {
        let mut state = 0x2545_f491u32;
        let mut next = move || crate::math::xorshift32(&mut state) as f32 / u32::MAX as f32;
        for (fov, w, h, pos, look) in [
            (19.5, 512, 512, Vec3::new(0.0, 1.0, 6.8), Vec3::new(0.0, 1.0, 0.0)),
            (90.0, 37, 29, Vec3::new(-3.1, 0.2, 1e3), Vec3::new(0.3, -7.0, 2.0)),
            (1.0, 1920, 1080, Vec3::new(1e-3, 5e4, -2.0), Vec3::new(0.0, 0.0, 0.0)),
        ] {
            let d = CameraParams {
                position: pos,
                look_at: look,
                ref_up: Vec3::Y,
                fov,
                focal_length: 1.3,
                ..Default::default()
            };
            let c = Camera::new(&d, w, h);
            for _ in 0..200 {
                let (mut x, mut y) = ([0.0f32; 16], [0.0f32; 16]);
                for i in 0..16 {
                    x[i] = (next() * 1.2 - 0.1) * w as f32;
                    y[i] = (next() * 1.2 - 0.1) * h as f32;
                }
                let mut out = [Ray::IDLE; 16];
                assert!(c.pinhole_rays(&x, &y, 16, &mut out));
                for i in 0..16 {
                    let r = c.sample_ray(x[i], y[i], Vec2::ZERO);
                    assert_eq!(out[i].o.to_array().map(f32::to_bits), r.o.to_array().map(f32::to_bits));
                    assert_eq!(
                        out[i].d.to_array().map(f32::to_bits),
                        r.d.to_array().map(f32::to_bits),
                        "({}, {})",
                        x[i],
                        y[i]
                    );
                    assert_eq!((out[i].t_min, out[i].t_max), (r.t_min, r.t_max));
                }
            }
        }
    }

    #[test]
    fn projection_inverts_directions_and_densities_integrate_to_one() {
        let d = CameraParams {
            position: Vec3::new(0.5, 1.0, 3.0),
            look_at: Vec3::new(0.0, 0.8, 0.0),
            ref_up: Vec3::Y,
            fov: 50.0,
            focal_length: 1.0,
            ..Default::default()
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
            ..Default::default()
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

    fn lens_camera(projection: Projection) -> Camera {
        let d = CameraParams {
            position: Vec3::new(0.5, 1.0, 3.0),
            look_at: Vec3::new(0.0, 0.8, 0.0),
            fov: 50.0,
            projection,
            ..Default::default()
        };
        Camera::new(&d, 64, 48)
    }

    #[test]
    fn thin_lens_rays_of_one_film_point_meet_on_the_plane_in_focus() {
        let c = lens_camera(Projection::ThinLens {
            aperture_radius: 0.2,
            focus_distance: 2.5,
        });
        let axis = c.axis;
        for (x, y) in [(0.5f32, 0.5f32), (10.25, 40.0), (63.9, 0.1), (32.0, 24.0)] {
            let pinhole = c.ray(x, y);
            let focus = pinhole.o + pinhole.d * (2.5 / pinhole.d.dot(axis));
            for u in [(0.1f32, 0.2f32), (0.9, 0.5), (0.5, 0.5), (0.3, 0.99)] {
                let r = c.sample_ray(x, y, Vec2::new(u.0, u.1));
                // the origin lies on the lens disk, the ray passes through the point in focus
                let off = r.o - c.position;
                assert!(off.dot(axis).abs() < 1e-5 && off.length() <= 0.2 + 1e-5, "{off}");
                let t = (focus - r.o).dot(r.d);
                assert!((r.o + r.d * t - focus).length() < 1e-4, "({x},{y}) {u:?}");
                // and it projects back to the film point it came from
                let (pos, cos) = c.project_from(r.o, r.o + r.d * 7.0).unwrap();
                assert!((pos.x - x).abs() < 2e-3 && (pos.y - y).abs() < 2e-3, "({x},{y}) -> {pos}");
                assert!((cos - r.d.dot(axis)).abs() < 1e-6);
            }
        }
        // from any lens point the density of ray directions integrates to 1 (a
        // direction grid over the cone ahead that holds the view: cos θ in [0.7, 1])
        let (right, up) = (c.unit_right, c.unit_up);
        for u in [Vec2::new(0.8, 0.3), Vec2::new(0.5, 0.5)] {
            let o = c.lens_point(u);
            let n = 600;
            let mut total = 0.0f64;
            let d_cos = 0.3 / n as f64;
            let d_phi = 2.0 * std::f64::consts::PI / n as f64;
            for i in 0..n {
                let cos = 0.7 + (i as f64 + 0.5) * d_cos;
                let sin = (1.0 - cos * cos).sqrt();
                for j in 0..n {
                    let phi = (j as f64 + 0.5) * d_phi;
                    let w = (right * (sin * phi.cos()) as f32 + up * (sin * phi.sin()) as f32 + axis * cos as f32).normalize();
                    total += c.pdf_dir_from(o, w) as f64 * d_cos * d_phi;
                }
            }
            assert!((total - 1.0).abs() < 0.01, "{u}: {total}");
        }
    }

    #[test]
    fn orthographic_rays_are_parallel_from_a_window_of_the_given_height() {
        let c = lens_camera(Projection::Orthographic { height: 3.0 });
        let bottom_left = c.sample_ray(0.0, 0.0, Vec2::ZERO);
        let top_right = c.sample_ray(64.0, 48.0, Vec2::ZERO);
        assert_eq!(bottom_left.d, top_right.d);
        let span = top_right.o - bottom_left.o;
        assert!((span.dot(c.unit_up) - 3.0).abs() < 1e-5, "{span}");
        assert!((span.dot(c.unit_right) - 4.0).abs() < 1e-5, "4:3 film");
        assert!(span.dot(c.axis).abs() < 1e-6);
        // the left of the picture is on the left of the view, its top up
        let centre = c.sample_ray(32.0, 24.0, Vec2::ZERO);
        assert!((centre.o - c.position).length() < 1e-5);
        assert!(!c.has_lens() && !c.is_pinhole());
    }

    #[test]
    fn clipping_limits_rays_along_the_view_axis() {
        let d = CameraParams {
            position: Vec3::ZERO,
            look_at: Vec3::new(0.0, 0.0, -1.0),
            near_clip: 1.0,
            far_clip: 4.0,
            ..Default::default()
        };
        let c = Camera::new(&d, 32, 32);
        let r = c.sample_ray(0.0, 16.0, Vec2::ZERO);
        assert!(((r.o + r.d * r.t_min).z + 1.0).abs() < 1e-5, "near plane at z = -1");
        assert!(((r.o + r.d * r.t_max).z + 4.0).abs() < 1e-4, "far plane at z = -4");
        // without clipping, exactly the pinhole ray
        let plain = Camera::new(
            &CameraParams {
                look_at: d.look_at,
                position: d.position,
                ..Default::default()
            },
            32,
            32,
        );
        let (a, b) = (plain.sample_ray(3.5, 7.25, Vec2::new(0.3, 0.6)), plain.ray(3.5, 7.25));
        assert_eq!((a.o, a.d, a.t_min, a.t_max), (b.o, b.d, b.t_min, b.t_max));
    }
}
