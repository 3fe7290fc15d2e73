//! Environment map (infinite area light, spec §12) with importance sampling.
//!
//! Direction ω (from the scene towards the sky) → `ℓ = normalize(T⁻¹ω)` with
//! `T = transform · C`, `C(x, y, z) = (y, z, −x)`; `u = atan2(ℓy, ℓx)/2π`,
//! `v = acos(ℓz)/π`. With the identity transform +y is v = 0 (the top row) and
//! −z is u = 0, as in Mitsuba. Texels are looked up as Mitsuba does (refs README,
//! convention 10): `x = u·W − ½` wrapping, `y = v·(H − 1)`, bilinear.

use super::sunsky::{SkyModel, SunModel, WorldSun};
/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 0.999_999_94;
use super::{LightSample, LightSampling, ShadowTarget};
use crate::math::{atan2_poly, floor_f32, luminance, prefetch, select, sin_cos_poly, Mat4, Vec2, Vec3, INV_PI, PI};
use crate::pages::HugeBuf;
use crate::sampling::{uniform_sphere, Distribution2D, RowDraw};
use crate::texture::UvMapping;
use glam::Mat3;

/// The picture of the sky: an image with its `uvmapping2d`, or one colour. The light
/// keeps its texels on huge pages ([`HugeBuf`]).
#[derive(Clone, Debug)]
pub enum EnvImage<T = Vec<Vec3>> {
    Constant(Vec3),
    Image {
        width: usize,
        height: usize,
        texels: T,
        mapping: UvMapping,
    },
    /// Mitsuba's `sunsky` sky ([`SkyModel`]), evaluated per direction; the pole of
    /// the light's frame is the sky's zenith (see [`EnvironmentLight::sunsky`]).
    Sky(Box<SkyModel>),
}

#[derive(Clone, Debug)]
pub struct EnvironmentLight {
    image: EnvImage<HugeBuf<Vec3>>,
    scale: f32,
    to_world: Mat3,
    to_local: Mat3,
    distribution: Distribution2D,
    mean_luminance: f32,
    /// `sunsky`'s sun: its disc's radiance is added to the image's, and importance
    /// sampling draws it with probability `choose` (else the image's table).
    sun: Option<Box<WorldSun>>,
}

/// Resolution of the sampling grid for a constant environment (only sinθ varies).
const CONSTANT_GRID: (usize, usize) = (8, 64);
/// Resolution of the sampling grid for `sunsky`'s sky (cells of 1.4°: the glow
/// around the sun spans several).
const SKY_GRID: (usize, usize) = (256, 128);

/// How many texels of an environment map are NaN or infinite, and how many negative
/// (in some channel): `EnvironmentLight::new` takes them as zero, and the scene
/// builder says so.
pub fn unusable_texels(texels: &[Vec3]) -> (usize, usize) {
    let not_finite = texels.iter().filter(|t| !t.is_finite()).count();
    let negative = texels.iter().filter(|t| t.is_finite() && t.min_element() < 0.0).count();
    (not_finite, negative)
}

impl EnvironmentLight {
    /// Negative texels are clamped to zero (lossy EXR compression leaves some), and
    /// NaN or infinite ones are zero (see `unusable_texels`).
    pub fn new(image: EnvImage, scale: f32, transform: &Mat4) -> Self {
        let image = match image {
            EnvImage::Constant(c) => EnvImage::Constant(c),
            EnvImage::Sky(sky) => EnvImage::Sky(sky),
            EnvImage::Image {
                width,
                height,
                mut texels,
                mapping,
            } => {
                for t in texels.iter_mut() {
                    *t = t.max(Vec3::ZERO);
                    if !t.is_finite() {
                        *t = Vec3::ZERO;
                    }
                }
                // on huge pages: lookups land all over the image
                EnvImage::Image {
                    width,
                    height,
                    texels: HugeBuf::from_slice(&texels),
                    mapping,
                }
            }
        };
        let c = Mat3::from_cols(Vec3::new(0.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        let to_world = Mat3::from_mat4(*transform) * c;
        let to_local = to_world.inverse();
        let mut light = EnvironmentLight {
            image,
            scale,
            to_world,
            to_local,
            distribution: Distribution2D::new(&[1.0], 1, 1),
            mean_luminance: 0.0,
            sun: None,
        };
        if let EnvImage::Image {
            width,
            height,
            texels,
            mapping,
        } = &light.image
        {
            if mapping.scale == Vec2::ONE && mapping.delta == Vec2::ZERO {
                let (weights, mean) = fast_weights(*width, *height, texels);
                light.mean_luminance = mean;
                light.distribution = Distribution2D::new(&weights, *width, *height);
                return light;
            }
        }
        let (nu, nv) = match &light.image {
            EnvImage::Constant(_) => CONSTANT_GRID,
            EnvImage::Sky(_) => SKY_GRID,
            EnvImage::Image { width, height, .. } => (*width, *height),
        };
        // Each cell's weight bounds the bilinear radiance over it (max of corners and
        // centre), times sinθ, so the pdf is positive wherever the radiance is.
        let mut weights = vec![0.0f32; nu * nv];
        let mut lum_sum = 0.0f64;
        let mut solid_angle = 0.0f64;
        for j in 0..nv {
            let (v0, v1) = (j as f32 / nv as f32, (j + 1) as f32 / nv as f32);
            let sin_theta = (PI * (j as f32 + 0.5) / nv as f32).sin();
            for i in 0..nu {
                let (u0, u1) = (i as f32 / nu as f32, (i + 1) as f32 / nu as f32);
                let pts = [(u0, v0), (u1, v0), (u0, v1), (u1, v1), ((u0 + u1) / 2.0, (v0 + v1) / 2.0)];
                let lum = pts
                    .iter()
                    .map(|&(u, v)| luminance(light.lookup(Vec2::new(u, v))))
                    .fold(0.0f32, f32::max);
                weights[j * nu + i] = lum * sin_theta;
                lum_sum += (luminance(light.lookup(Vec2::new((u0 + u1) / 2.0, (v0 + v1) / 2.0))) * sin_theta) as f64;
                solid_angle += sin_theta as f64;
            }
        }
        light.mean_luminance = (lum_sum / solid_angle.max(1e-30)) as f32;
        light.distribution = Distribution2D::new(&weights, nu, nv);
        light
    }

    /// Mitsuba's `sunsky`: the sky (`None` with `sky_scale` 0) and the sun (`None` with
    /// `sun_scale` 0) in the frame `to_world` (a rotation) takes to the world, +z up.
    /// The light's own frame puts its pole at the zenith: sky coordinates (x, y, z) are
    /// the light's local (ℓy, ℓx, ℓz), and the horizon is v = ½, a row of the grid.
    pub fn sunsky(sky: Option<SkyModel>, sun: Option<SunModel>, to_world: &Mat4) -> Self {
        let image = sky.map_or(EnvImage::Constant(Vec3::ZERO), |s| EnvImage::Sky(Box::new(s)));
        let mut light = Self::new(image, 1.0, &(*to_world * Mat4::from_rotation_x(0.5 * PI)));
        if let Some(sun) = sun {
            let mut sun = WorldSun::new(sun, Mat3::from_mat4(*to_world));
            // the sun drawn in proportion to its share of the power
            let (sun_power, sky_power) = (sun.irradiance_luminance(), 4.0 * PI * light.mean_luminance);
            sun.choose = if sky_power > 0.0 {
                sun_power / (sun_power + sky_power)
            } else {
                1.0
            };
            light.mean_luminance += sun_power / (4.0 * PI);
            light.sun = Some(Box::new(sun));
        }
        light
    }

    pub fn mean_luminance(&self) -> f32 {
        self.mean_luminance
    }

    /// Texture coordinates of world direction `w` (towards the sky).
    pub fn direction_to_uv(&self, w: Vec3) -> Vec2 {
        self.direction_coords(w).0
    }

    /// Texture coordinates of world direction `w`, and sinθ there (for [`Self::pdf_at`]):
    /// `φ = atan2(ℓy, ℓx)`, `θ = atan2(√(ℓx² + ℓy²), ℓz)` (accurate at the poles too,
    /// where `acos` is not), by the inlined polynomials of `math`.
    #[inline(always)]
    pub fn direction_coords(&self, w: Vec3) -> (Vec2, f32) {
        let l = self.to_local * w;
        let rho = (l.x * l.x + l.y * l.y).sqrt();
        let phi = atan2_poly(l.y, l.x);
        let phi = select(phi < 0.0, phi + 2.0 * PI, phi);
        let theta = atan2_poly(rho, l.z);
        (Vec2::new(phi * (0.5 * INV_PI), theta * INV_PI), rho / l.length())
    }

    /// [`Self::direction_coords`] of `L` directions given by axis (`d[axis][lane]`):
    /// texture coordinates by axis and sinθ, each lane's bits as one call gives them
    /// (the same operations, in a loop without branches, which vectorizes).
    #[inline(always)]
    pub fn direction_coords_lanes<const L: usize>(&self, d: &[[f32; L]; 3]) -> ([[f32; L]; 2], [f32; L]) {
        let (mut uv, mut sin_theta) = ([[0.0; L]; 2], [0.0; L]);
        for i in 0..L {
            let (c, s) = self.direction_coords(Vec3::new(d[0][i], d[1][i], d[2][i]));
            (uv[0][i], uv[1][i], sin_theta[i]) = (c.x, c.y, s);
        }
        (uv, sin_theta)
    }

    /// World direction of `uv`, and sinθ there.
    #[inline(always)]
    pub fn uv_to_direction(&self, uv: Vec2) -> (Vec3, f32) {
        let (theta, phi) = (uv.y * PI, uv.x * 2.0 * PI);
        let (st, ct) = sin_cos_poly(theta);
        let (sp, cp) = sin_cos_poly(phi);
        let l = Vec3::new(st * cp, st * sp, ct);
        ((self.to_world * l).normalize(), st)
    }

    /// [`Self::uv_to_direction`] of `L` texture coordinates given by axis
    /// (`uv[axis][lane]`): directions by axis and sinθ, each lane's bits as one call
    /// gives them (a loop without branches, which vectorizes).
    #[inline(always)]
    pub fn uv_to_direction_lanes<const L: usize>(&self, uv: &[[f32; L]; 2]) -> ([[f32; L]; 3], [f32; L]) {
        let (mut d, mut sin_theta) = ([[0.0; L]; 3], [0.0; L]);
        for i in 0..L {
            let (w, s) = self.uv_to_direction(Vec2::new(uv[0][i], uv[1][i]));
            (d[0][i], d[1][i], d[2][i], sin_theta[i]) = (w.x, w.y, w.z, s);
        }
        (d, sin_theta)
    }

    /// Unscaled radiance at texture coordinates `uv`.
    #[inline(always)]
    fn lookup(&self, uv: Vec2) -> Vec3 {
        match &self.image {
            EnvImage::Constant(c) => *c,
            EnvImage::Sky(sky) => {
                let (st, ct) = sin_cos_poly(uv.y * PI);
                let (sp, cp) = sin_cos_poly(uv.x * 2.0 * PI);
                sky.radiance(Vec3::new(st * sp, st * cp, ct))
            }
            EnvImage::Image {
                width,
                height,
                texels,
                mapping,
            } => {
                let st = mapping.map(uv);
                let (w, h) = (*width as i64, *height as i64);
                let x = st.x * w as f32 - 0.5;
                let y = (st.y * (h - 1) as f32).clamp(0.0, (h - 1) as f32);
                let (x0, y0) = (floor_f32(x), floor_f32(y));
                let (fx, fy) = (x - x0, y - y0);
                let (x0, y0) = (x0 as i64, y0 as i64);
                // columns wrap around (no division inside the image), rows clamp
                let (c0, c1) = if x0 >= 0 && x0 + 1 < w {
                    (x0 as usize, x0 as usize + 1)
                } else {
                    (x0.rem_euclid(w) as usize, (x0 + 1).rem_euclid(w) as usize)
                };
                let (r0, r1) = (y0.clamp(0, h - 1) as usize, (y0 + 1).clamp(0, h - 1) as usize);
                let (row0, row1) = (&texels[r0 * *width..][..*width], &texels[r1 * *width..][..*width]);
                let top = row0[c0] * (1.0 - fx) + row0[c1] * fx;
                let bottom = row1[c0] * (1.0 - fx) + row1[c1] * fx;
                top * (1.0 - fy) + bottom * fy
            }
        }
    }

    /// Prefetches the texels [`Self::lookup`] reads at `uv` (a hint: the lines of the
    /// nearest texel and the one below it).
    #[inline]
    fn prefetch_texels(&self, uv: Vec2) {
        if let EnvImage::Image {
            width,
            height,
            texels,
            mapping,
        } = &self.image
        {
            let st = mapping.map(uv);
            // `as` saturates (and takes NaN to 0); `prefetch` ignores indices past the end
            let x = ((st.x * *width as f32) as usize).min(width - 1);
            let y = (st.y * (*height - 1) as f32) as usize;
            // the texels left and right of the nearest (the pair a lookup blends is one
            // of theirs), in this row and the next
            let (a, b) = (x.saturating_sub(1), (x + 1).min(width - 1));
            for r in [y * width, (y + 1) * width] {
                prefetch(texels, r + a);
                prefetch(texels, r + b);
            }
        }
    }

    /// Prefetches what [`Self::sample_direction`] will read first for `u` (a hint);
    /// for importance sampling, the row drawn, which [`Self::sample_uv`] takes.
    #[inline]
    pub fn prefetch_sample(&self, u: Vec2, mode: LightSampling) -> Option<RowDraw> {
        (mode == LightSampling::Importance && self.sun.is_none()).then(|| self.distribution.prefetch_sample(u))
    }

    /// Prefetches the texels and the pdf's weight at `uv` (a hint for a ray that may miss
    /// everything, its coordinates from [`Self::direction_coords`]).
    #[inline]
    pub fn prefetch_coords(&self, uv: Vec2) {
        self.prefetch_texels(uv);
        self.distribution.prefetch(uv);
    }

    /// Radiance arriving from direction `w` (towards the sky).
    pub fn radiance(&self, w: Vec3) -> Vec3 {
        let sun = self.sun.as_ref().map_or(Vec3::ZERO, |s| s.radiance(w));
        self.lookup(self.direction_to_uv(w)) * self.scale + sun
    }

    /// Radiance at texture coordinates `uv` ([`Self::direction_to_uv`]): with
    /// [`Self::pdf_at`], one direction's mapping serves both.
    #[inline]
    pub fn radiance_at(&self, uv: Vec2) -> Vec3 {
        let sun = self.sun.as_ref().map_or(Vec3::ZERO, |s| s.radiance(self.uv_to_direction(uv).0));
        self.lookup(uv) * self.scale + sun
    }

    pub fn sample(&self, u: Vec2, mode: LightSampling) -> Option<LightSample> {
        let (wi, pdf) = self.sample_direction(u, mode, None)?;
        Some(LightSample {
            radiance: self.radiance(wi),
            wi,
            pdf,
            delta: false,
            target: ShadowTarget::Infinity,
        })
    }

    /// The direction and solid-angle pdf of [`Self::sample`], without its radiance
    /// ([`Self::radiance`] of the direction).
    /// `draw`: the row [`Self::prefetch_sample`] drew for `u`, if it was.
    #[inline(always)]
    pub fn sample_direction(&self, u: Vec2, mode: LightSampling, draw: Option<RowDraw>) -> Option<(Vec3, f32)> {
        match mode {
            LightSampling::Uniform => Some((uniform_sphere(u), 1.0 / (4.0 * PI))),
            LightSampling::Importance => match &self.sun {
                None => {
                    let (uv, pdf_uv) = self.sample_uv(u, draw);
                    let (wi, sin_theta) = self.uv_to_direction(uv);
                    Self::direction_sample(wi, sin_theta, pdf_uv)
                }
                Some(sun) => {
                    let wi = self.sample_with_sun(sun, u)?;
                    let pdf = self.pdf(wi, mode);
                    (pdf > 0.0).then_some((wi, pdf))
                }
            },
        }
    }

    /// A direction from the sun (probability `choose`) or from the image's table.
    fn sample_with_sun(&self, sun: &WorldSun, u: Vec2) -> Option<Vec3> {
        if u.x < sun.choose {
            // a direction on the disc's very edge that rounding (here, or through the
            // coordinates the packet path takes it by) puts off the disc is dropped: its
            // pdf would lack the sun's term while its radiance had it
            let w = sun.sample(Vec2::new(u.x / sun.choose, u.y));
            let through_uv = self.uv_to_direction(self.direction_coords(w).0).0;
            return (sun.pdf(w) > 0.0 && sun.pdf(through_uv) > 0.0).then_some(w);
        }
        let u = Vec2::new(((u.x - sun.choose) / (1.0 - sun.choose)).min(ONE_MINUS_EPSILON), u.y);
        let (wi, sin_theta) = self.uv_to_direction(self.distribution.sample(u).0);
        (sin_theta > 0.0).then_some(wi)
    }

    /// The solid-angle density of importance sampling at `w` (coordinates `uv`, sinθ
    /// `sin_theta`): the table's, and with a sun the mixture.
    #[inline]
    fn importance_pdf(&self, w: Vec3, uv: Vec2, sin_theta: f32) -> f32 {
        let table = || {
            if sin_theta.is_nan() || sin_theta <= 0.0 {
                0.0
            } else {
                self.distribution.pdf(uv) / (2.0 * PI * PI * sin_theta)
            }
        };
        match &self.sun {
            None => table(),
            Some(sun) if sun.choose >= 1.0 => sun.pdf(w),
            Some(sun) => (1.0 - sun.choose) * table() + sun.choose * sun.pdf(w),
        }
    }

    /// The first step of an importance sample ([`Self::sample_direction`]): the
    /// texture coordinates drawn for `u` and their density over `[0, 1)²`.
    /// `draw`: the row [`Self::prefetch_sample`] drew for `u`, if it was.
    #[inline(always)]
    pub fn sample_uv(&self, u: Vec2, draw: Option<RowDraw>) -> (Vec2, f32) {
        if let Some(sun) = &self.sun {
            // the mixture's direction as coordinates, its density in their measure
            let Some(w) = self.sample_with_sun(sun, u) else {
                return (Vec2::ZERO, 0.0);
            };
            // the density where the caller goes: the direction of the coordinates
            let uv = self.direction_coords(w).0;
            let (w, sin_theta) = self.uv_to_direction(uv);
            return (uv, self.importance_pdf(w, uv, sin_theta) * 2.0 * PI * PI * sin_theta);
        }
        let (uv, pdf_uv) = match draw {
            Some(d) => self.distribution.sample_in(u, d),
            None => self.distribution.sample(u),
        };
        // the radiance will be looked up at (about) `uv`, after the trigonometry
        self.prefetch_texels(uv);
        (uv, pdf_uv)
    }

    /// The last step: direction `wi` of the drawn coordinates ([`Self::uv_to_direction`],
    /// with sinθ there) and its solid-angle density; `None` where that has none.
    #[inline(always)]
    pub fn direction_sample(wi: Vec3, sin_theta: f32, pdf_uv: f32) -> Option<(Vec3, f32)> {
        if sin_theta <= 0.0 || pdf_uv <= 0.0 {
            return None;
        }
        Some((wi, pdf_uv / (2.0 * PI * PI * sin_theta)))
    }

    pub fn pdf(&self, wi: Vec3, mode: LightSampling) -> f32 {
        match mode {
            LightSampling::Uniform => 1.0 / (4.0 * PI),
            LightSampling::Importance => {
                let (uv, sin_theta) = self.direction_coords(wi);
                self.importance_pdf(wi, uv, sin_theta)
            }
        }
    }

    /// [`Self::pdf`] of the direction with texture coordinates `uv` and sinθ
    /// `sin_theta` ([`Self::direction_coords`]).
    #[inline]
    pub fn pdf_at(&self, uv: Vec2, sin_theta: f32, mode: LightSampling) -> f32 {
        match mode {
            LightSampling::Uniform => 1.0 / (4.0 * PI),
            LightSampling::Importance => {
                let w = if self.sun.is_some() {
                    self.uv_to_direction(uv).0
                } else {
                    Vec3::ZERO
                };
                self.importance_pdf(w, uv, sin_theta)
            }
        }
    }
}

/// Sampling weights for an image under the identity mapping: cell (i, j) covers
/// `x ∈ [i − ½, i + ½]`, `y ∈ [j(H−1)/H, (j+1)(H−1)/H]` in texel units, so only
/// texels i−1…i+1, j−1…j+1 shape its bilinear radiance; luminance being linear,
/// their maximum bounds it. A separable 3×3 max filter, rows in parallel.
fn fast_weights(w: usize, h: usize, texels: &[Vec3]) -> (Vec<f32>, f32) {
    use rayon::prelude::*;
    let lum: Vec<f32> = texels.par_iter().map(|t| luminance(*t)).collect();
    let row_max: Vec<f32> = (0..h)
        .into_par_iter()
        .flat_map_iter(|j| {
            let row = &lum[j * w..(j + 1) * w];
            (0..w).map(move |i| row[(i + w - 1) % w].max(row[i]).max(row[(i + 1) % w]))
        })
        .collect();
    let weights: Vec<f32> = (0..h)
        .into_par_iter()
        .flat_map_iter(|j| {
            let (a, b) = (j.saturating_sub(1), (j + 1).min(h - 1));
            let sin_theta = (PI * (j as f32 + 0.5) / h as f32).sin();
            let rm = &row_max;
            (0..w).map(move |i| rm[a * w + i].max(rm[j * w + i]).max(rm[b * w + i]) * sin_theta)
        })
        .collect();
    // mean over the sphere: Σ L sinθ / Σ sinθ at texel rows v = j/(H−1)
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for j in 0..h {
        let s = (PI * j as f32 / (h - 1).max(1) as f32).sin() as f64;
        num += s * lum[j * w..(j + 1) * w].iter().map(|&l| l as f64).sum::<f64>();
        den += s * w as f64;
    }
    (
        weights,
        if den > 0.0 {
            (num / den) as f32
        } else {
            lum.iter().sum::<f32>() / lum.len() as f32
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identity_mapping_matches_the_spec_examples() {
        let e = EnvironmentLight::new(EnvImage::Constant(Vec3::ONE), 1.0, &Mat4::IDENTITY);
        let uv = |w: Vec3| e.direction_to_uv(w);
        assert!(uv(Vec3::Y).y.abs() < 1e-6, "+y is the top row");
        assert!((uv(-Vec3::Y).y - 1.0).abs() < 1e-6);
        for (w, u) in [(-Vec3::Z, 0.0), (Vec3::X, 0.25), (Vec3::Z, 0.5), (-Vec3::X, 0.75)] {
            let got = uv(w).x;
            assert!(
                (got - u).abs() < 1e-6 || (u == 0.0 && (got - 1.0).abs() < 1e-6),
                "{w}: u = {got}, want {u}"
            );
        }
        for k in 0..50 {
            let w = uniform_sphere(Vec2::new((k as f32 + 0.3) / 50.0, (k as f32 * 0.618).fract()));
            let (back, _) = e.uv_to_direction(e.direction_to_uv(w));
            assert!((back - w).length() < 1e-4, "{w} -> {back}");
        }
    }

    /// The lanes functions give each lane the bits of one call, compiled (as the
    /// renderer runs them) for the widest kernel set: coordinates of directions of
    /// every octant, the axes, zero and NaN, under a rotated sky, and the directions
    /// of those coordinates.
    #[test]
    fn lanes_match_one_call_bit_for_bit() {
        let rotation = Mat4::from_rotation_y(0.7) * Mat4::from_rotation_x(-0.3);
        let e = EnvironmentLight::new(EnvImage::Constant(Vec3::ONE), 1.0, &rotation);
        let mut dirs: Vec<Vec3> = vec![
            Vec3::X,
            -Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::ZERO,
            Vec3::NAN,
            Vec3::new(1e-30, 0.0, -0.0),
        ];
        let mut state = 0x9e37_79b9u32;
        while dirs.len() < 16 * 64 {
            let mut next = || crate::math::xorshift32(&mut state) as f32 / u32::MAX as f32;
            dirs.push(uniform_sphere(Vec2::new(next(), next())));
        }
        let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        for chunk in dirs.chunks(16) {
            let d: [[f32; 16]; 3] = std::array::from_fn(|a| std::array::from_fn(|i| chunk[i][a]));
            let (uv, sin_theta) = crate::accel::wide::Isa::detect().run(
                #[inline(always)]
                || e.direction_coords_lanes(&d),
            );
            let (back, back_sin) = crate::accel::wide::Isa::detect().run(
                #[inline(always)]
                || e.uv_to_direction_lanes(&uv),
            );
            for (i, &w) in chunk.iter().enumerate() {
                let (c, s) = e.direction_coords(w);
                assert!(same(uv[0][i], c.x) && same(uv[1][i], c.y) && same(sin_theta[i], s), "{w}");
                let (b, s) = e.uv_to_direction(c);
                assert!((0..3).all(|a| same(back[a][i], b[a])) && same(back_sin[i], s), "{c}");
            }
        }
    }

    #[test]
    fn texel_rows_sit_at_v_equals_j_over_h_minus_1() {
        // a 4×3 ramp: G = row index; at v = j/(H−1) the lookup returns exactly row j
        let texels = (0..12).map(|k| Vec3::new((k % 4) as f32, (k / 4) as f32, 0.0)).collect();
        let e = EnvironmentLight::new(
            EnvImage::Image {
                width: 4,
                height: 3,
                texels,
                mapping: UvMapping {
                    scale: Vec2::ONE,
                    delta: Vec2::ZERO,
                },
            },
            1.0,
            &Mat4::IDENTITY,
        );
        for j in 0..3 {
            assert!((e.lookup(Vec2::new(0.375, j as f32 / 2.0)).y - j as f32).abs() < 1e-6);
        }
        // texel i is centred at u = (i + ½)/W
        assert!((e.lookup(Vec2::new(0.375, 0.0)).x - 1.0).abs() < 1e-6);
        // wrapping across u = 0 blends the last and first columns
        assert!((e.lookup(Vec2::new(0.0, 0.0)).x - 1.5).abs() < 1e-6);
    }
}
