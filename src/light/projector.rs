//! Mitsuba's `projector`: a pinhole at `position` that projects its `irradiance`
//! image into the scene, as a perspective camera looking along the frame's `n` would
//! see it (the reciprocal of the `perspective` sensor, same pixel-to-direction map).
//!
//! The image lies on the plane z = 1 in front of the pinhole, `2·tan_x` wide and
//! `2·tan_y` tall (`tan_x = tan(fov_x/2)`, `tan_y = tan_x · height/width` from the
//! texture's resolution). A local direction `(x, y, z)` reads Mitsuba's
//! `(½ − ½·x/(z·tan_x), ½ − ½·y/(z·tan_y))` (its `x` is the camera's left, `v = 0`
//! the top row); rdr looks up `(u, 1 − v)`, the same texel in its orientation.
//! Nothing leaves outside the image or behind the pinhole.
//!
//! Normalisation (Mitsuba's): the radiant intensity towards a direction at θ to the
//! axis is `I = π · scale · E(uv) / cos³θ`, so that the irradiance on the plane z = 1
//! facing the projector is `π · scale · E(uv)` (I·cosθ/r² with r = 1/cosθ): the image
//! is irradiance up to Mitsuba's factor π, and the total power is
//! `π · scale · A · ∫E du dv` over the image of area `A = 4·tan_x·tan_y`.
//!
//! Emission sampling picks the image point in proportion to a tabulated version of
//! the image's luminance (the largest of nine lookups per cell, plus a floor, so the
//! density is positive wherever the filtered image is), as Mitsuba samples its pixels.

use crate::math::{luminance, Frame, Vec2, Vec3, PI};
use crate::sampling::Distribution2D;
use crate::texture::Texture;

/// Which extent of the image the `fov` spans (Mitsuba's `fov_axis`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    X,
    Y,
    Diagonal,
    Smaller,
    Larger,
}

impl FovAxis {
    pub fn parse(s: &str) -> Option<FovAxis> {
        Some(match s {
            "x" => FovAxis::X,
            "y" => FovAxis::Y,
            "diagonal" => FovAxis::Diagonal,
            "smaller" => FovAxis::Smaller,
            "larger" => FovAxis::Larger,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            FovAxis::X => "x",
            FovAxis::Y => "y",
            FovAxis::Diagonal => "diagonal",
            FovAxis::Smaller => "smaller",
            FovAxis::Larger => "larger",
        }
    }

    /// Half-extents `(tan_x, tan_y)` of the image plane at z = 1 for a field of view
    /// `fov` (radians, full angle) along this axis of a `w × h` image.
    pub fn half_tangents(self, fov: f32, w: f32, h: f32) -> (f32, f32) {
        let t = (0.5 * fov).tan();
        let axis = match self {
            FovAxis::Smaller if w <= h => FovAxis::X,
            FovAxis::Smaller => FovAxis::Y,
            FovAxis::Larger if w >= h => FovAxis::X,
            FovAxis::Larger => FovAxis::Y,
            a => a,
        };
        match axis {
            FovAxis::X => (t, t * h / w),
            FovAxis::Y => (t * w / h, t),
            _ => {
                let d = w.hypot(h);
                (t * w / d, t * h / d)
            }
        }
    }
}

#[derive(Clone, Debug)]
pub struct Projector {
    pub position: Vec3,
    /// `s`, `t`: the camera's left and up (Mitsuba's `to_world` x, y); `n`: its view axis.
    pub frame: Frame,
    /// Mitsuba's `scale`.
    pub scale: f32,
    /// The field of view (radians) and the axis it spans; with the texture's
    /// resolution they give `tan_x`, `tan_y` ([`Projector::with_texture`]).
    pub fov: f32,
    pub fov_axis: FovAxis,
    pub tan_x: f32,
    pub tan_y: f32,
    pub irradiance: Texture,
    /// Over rdr's uv of the image, for emission sampling.
    distribution: Distribution2D,
}

/// Cells of the sampling table along each axis, at most.
const MAX_TABLE: usize = 256;

impl Projector {
    /// A projector showing a constant irradiance of 1 (a placeholder until
    /// [`Projector::with_texture`] gives it its image).
    pub fn new(position: Vec3, frame: Frame, scale: f32, fov: f32, fov_axis: FovAxis) -> Projector {
        let (tan_x, tan_y) = fov_axis.half_tangents(fov, 1.0, 1.0);
        Projector {
            position,
            frame,
            scale,
            fov,
            fov_axis,
            tan_x,
            tan_y,
            irradiance: Texture::Constant(Vec3::ONE),
            distribution: Distribution2D::new(&[1.0], 1, 1),
        }
    }

    /// The projector with its image: the aspect ratio follows the texture's
    /// resolution (a constant is 1 × 1, as in Mitsuba).
    pub fn with_texture(mut self, irradiance: Texture) -> Projector {
        let (w, h) = match &irradiance {
            Texture::Image(img) => {
                let l = &img.mipmap.levels()[0];
                (l.width, l.height)
            }
            _ => (1, 1),
        };
        (self.tan_x, self.tan_y) = self.fov_axis.half_tangents(self.fov, w as f32, h as f32);
        let (nu, nv) = (w.clamp(1, MAX_TABLE), h.clamp(1, MAX_TABLE));
        let mut weights = vec![0.0f32; nu * nv];
        for j in 0..nv {
            for i in 0..nu {
                let mut m = 0.0f32;
                for (a, b) in [
                    (0.0, 0.0),
                    (0.5, 0.0),
                    (1.0, 0.0),
                    (0.0, 0.5),
                    (0.5, 0.5),
                    (1.0, 0.5),
                    (0.0, 1.0),
                    (0.5, 1.0),
                    (1.0, 1.0),
                ] {
                    let uv = Vec2::new((i as f32 + a) / nu as f32, (j as f32 + b) / nv as f32);
                    m = m.max(luminance(irradiance.eval(uv)).abs());
                }
                weights[j * nu + i] = m;
            }
        }
        let top = weights.iter().copied().fold(0.0f32, f32::max);
        let floor = if top > 0.0 { 1e-3 * top } else { 1.0 };
        for w in &mut weights {
            *w += floor;
        }
        self.distribution = Distribution2D::new(&weights, nu, nv);
        self.irradiance = irradiance;
        self
    }

    /// Area of the image at z = 1.
    pub fn image_area(&self) -> f32 {
        4.0 * self.tan_x * self.tan_y
    }

    /// rdr's uv of a local direction (or point) with `local.z > 0`; `None` outside the image.
    #[inline]
    pub fn uv(&self, local: Vec3) -> Option<Vec2> {
        if local.z <= 0.0 {
            return None;
        }
        let u = 0.5 - 0.5 * local.x / (local.z * self.tan_x);
        let v = 0.5 - 0.5 * local.y / (local.z * self.tan_y);
        ((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v)).then_some(Vec2::new(u, 1.0 - v))
    }

    /// The unit local direction through rdr's `uv` of the image.
    fn local_dir(&self, uv: Vec2) -> Vec3 {
        let x = (1.0 - 2.0 * uv.x) * self.tan_x;
        let y = (2.0 * uv.y - 1.0) * self.tan_y;
        Vec3::new(x, y, 1.0).normalize()
    }

    /// Radiant intensity towards the unit world direction `dir`.
    pub fn intensity_towards(&self, dir: Vec3) -> Vec3 {
        let local = self.frame.to_local(dir);
        match self.uv(local) {
            Some(uv) => self.irradiance.eval(uv) * (PI * self.scale / (local.z * local.z * local.z)),
            None => Vec3::ZERO,
        }
    }

    /// A direction of emission (world), its intensity and its solid-angle density.
    pub fn sample_direction(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        let (uv, pdf_uv) = self.distribution.sample(u);
        if pdf_uv <= 0.0 {
            return None;
        }
        let local = self.local_dir(uv);
        let cos3 = local.z * local.z * local.z;
        let le = self.irradiance.eval(uv) * (PI * self.scale / cos3);
        Some((self.frame.to_world(local), le, pdf_uv / (self.image_area() * cos3)))
    }

    /// Solid-angle density of [`Projector::sample_direction`] producing `dir`.
    pub fn pdf_direction(&self, dir: Vec3) -> f32 {
        let local = self.frame.to_local(dir);
        match self.uv(local) {
            Some(uv) => self.distribution.pdf(uv) / (self.image_area() * local.z * local.z * local.z),
            None => 0.0,
        }
    }

    /// Total power (luminance): π · scale · A · mean(E).
    pub fn power(&self) -> f32 {
        PI * self.scale * self.image_area() * luminance(self.irradiance.mean())
    }
}
