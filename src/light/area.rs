//! Area lights: radiance emitted one-sided along the geometric normal (triangle
//! winding; spheres: outward), on a triangle mesh, a sphere or a cylinder. The
//! radiance is a constant or a texture looked up at the emitting point's uv (the same
//! uv a material there sees: Mitsuba's `area` with a `bitmap` `radiance`). Points are
//! sampled by area (Mitsuba samples the shape, not the texture) or, for spheres seen
//! from outside, in the cone they subtend; the texture only weighs the samples.

use super::{LightSample, LightSampling, ShadowTarget};
use crate::geometry::interaction::{Interaction, SphereUv};
use crate::geometry::sphere::Sphere;
use crate::math::{Frame, Vec2, Vec3, PI};
use crate::sampling::{uniform_sphere, uniform_triangle, Distribution1D};
use crate::texture::Texture;

#[derive(Clone, Debug)]
pub enum Emitter {
    /// Triangles with a distribution in proportion to their areas; each triangle's
    /// area and unit normal kept (as `tri_area` and `tri_normal` give them).
    Mesh {
        triangles: Vec<[Vec3; 3]>,
        areas: Vec<f32>,
        normals: Vec<Vec3>,
        by_area: Distribution1D,
        total_area: f32,
        /// Per triangle the uv of its corners (empty unless the radiance is a texture).
        uvs: Vec<[Vec2; 3]>,
    },
    Sphere {
        center: Vec3,
        radius: f32,
        /// The sphere's uv parameterisation ([`Sphere::uv_frame`]), for textured radiance.
        uv_frame: Option<[f32; 4]>,
    },
    /// An open cylinder, sampled uniformly by area; `flip`: it emits inwards.
    Cylinder {
        cylinder: crate::geometry::cylinder::Cylinder,
        flip: bool,
    },
}

#[derive(Clone, Debug)]
pub struct AreaLight {
    /// The constant radiance, or with a `texture` its mean (for choosing lights by power).
    pub radiance: Vec3,
    /// A radiance texture, looked up at the emitting point's uv.
    pub texture: Option<Texture>,
    pub object: u32,
    pub emitter: Emitter,
}

impl AreaLight {
    pub fn mesh(object: u32, radiance: Vec3, triangles: Vec<[Vec3; 3]>) -> Self {
        let areas: Vec<f32> = triangles.iter().map(tri_area).collect();
        let total_area = areas.iter().sum();
        AreaLight {
            radiance,
            texture: None,
            object,
            emitter: Emitter::Mesh {
                by_area: Distribution1D::new(&areas),
                normals: triangles.iter().map(tri_normal).collect(),
                areas,
                triangles,
                total_area,
                uvs: Vec::new(),
            },
        }
    }

    pub fn sphere(object: u32, radiance: Vec3, center: Vec3, radius: f32) -> Self {
        AreaLight {
            radiance,
            texture: None,
            object,
            emitter: Emitter::Sphere {
                center,
                radius,
                uv_frame: None,
            },
        }
    }

    /// A sphere light whose uv follows `uv_frame` (the shape's [`Sphere::uv_frame`]).
    pub fn with_sphere_uv_frame(mut self, frame: Option<[f32; 4]>) -> Self {
        if let Emitter::Sphere { uv_frame, .. } = &mut self.emitter {
            *uv_frame = frame;
        }
        self
    }

    pub fn cylinder(object: u32, radiance: Vec3, cylinder: crate::geometry::cylinder::Cylinder, flip: bool) -> Self {
        AreaLight {
            radiance,
            texture: None,
            object,
            emitter: Emitter::Cylinder { cylinder, flip },
        }
    }

    /// The light with its radiance given by `texture` (at the emitting point's uv);
    /// `uvs`: a mesh's per-triangle corner uvs, in the order of its triangles.
    pub fn with_texture(mut self, texture: Texture, uvs: Vec<[Vec2; 3]>) -> Self {
        self.radiance = texture.mean();
        self.texture = Some(texture);
        if let Emitter::Mesh { uvs: u, triangles, .. } = &mut self.emitter {
            debug_assert_eq!(uvs.len(), triangles.len());
            *u = uvs;
        }
        self
    }

    /// The radiance at a point of uv `uv`.
    #[inline]
    pub fn radiance_at(&self, uv: Vec2) -> Vec3 {
        match &self.texture {
            None => self.radiance,
            Some(t) => t.eval(uv),
        }
    }

    /// The uv of the point `q` (normal `n`) of the emitter: triangle `tri` at barycentrics
    /// `b`, the sphere's (φ/2π, θ/π), the cylinder's sample `u`. Only what the texture needs.
    pub(super) fn uv_of(&self, tri: usize, b: [f32; 3], n: Vec3, u: Vec2) -> Vec2 {
        if self.texture.is_none() {
            return Vec2::ZERO;
        }
        match &self.emitter {
            Emitter::Mesh { uvs, .. } => uvs.get(tri).map_or(Vec2::ZERO, |t| t[0] * b[0] + t[1] * b[1] + t[2] * b[2]),
            // as the surface points a ray finds (their uv orientation included)
            Emitter::Sphere { center, radius, uv_frame } => {
                let s = Sphere {
                    center: *center,
                    radius: *radius,
                    uv_frame: *uv_frame,
                };
                Interaction::on_sphere(&s, *center + n * *radius, Some(SphereUv::PhiTheta), 0, n).uv
            }
            Emitter::Cylinder { cylinder, .. } => Interaction::on_cylinder(cylinder, cylinder.at(u).0, 0, n).uv,
        }
    }

    /// A uniform point on a cylinder emitter and its emitting normal.
    pub(super) fn cylinder_point(cylinder: &crate::geometry::cylinder::Cylinder, flip: bool, u: Vec2) -> (Vec3, Vec3) {
        let (q, n) = cylinder.at(u);
        (q, if flip { -n } else { n })
    }

    pub fn area(&self) -> f32 {
        match &self.emitter {
            Emitter::Mesh { total_area, .. } => *total_area,
            Emitter::Sphere { radius, .. } => 4.0 * PI * radius * radius,
            Emitter::Cylinder { cylinder, .. } => cylinder.area(),
        }
    }

    /// Emitted radiance leaving a point with geometric normal `n` and texture
    /// coordinates `uv` in direction `w`.
    #[inline]
    pub fn emitted(&self, n: Vec3, w: Vec3, uv: Vec2) -> Vec3 {
        if n.dot(w) > 0.0 {
            self.radiance_at(uv)
        } else {
            Vec3::ZERO
        }
    }

    /// Turns a point sampled by area (density `pdf_area`) into a light sample.
    fn light_sample_from_area_point(&self, p: Vec3, q: Vec3, n: Vec3, uv: Vec2, pdf_area: f32) -> Option<LightSample> {
        let v = q - p;
        let d2 = v.length_squared();
        if d2 == 0.0 || pdf_area <= 0.0 {
            return None;
        }
        let wi = v / d2.sqrt();
        let cos_light = n.dot(-wi);
        if cos_light <= 0.0 {
            return None; // the back of a one-sided emitter
        }
        Some(LightSample {
            radiance: self.radiance_at(uv),
            wi,
            pdf: pdf_area * d2 / cos_light,
            delta: false,
            target: ShadowTarget::Point { p: q, n: Some(n) },
        })
    }

    #[inline(always)]
    pub fn sample(&self, p: Vec3, u: Vec2, mode: LightSampling) -> Option<LightSample> {
        match &self.emitter {
            Emitter::Mesh {
                triangles,
                areas,
                normals,
                by_area,
                ..
            } => {
                let (i, pdf_tri, ux) = match mode {
                    LightSampling::Importance => {
                        let (i, pmf, rest) = by_area.sample_discrete(u.x);
                        let area = areas[i];
                        (i, if area > 0.0 { pmf / area } else { 0.0 }, rest)
                    }
                    LightSampling::Uniform => {
                        let n = triangles.len();
                        let x = u.x * n as f32;
                        let i = (x as usize).min(n - 1);
                        (i, 1.0 / (n as f32 * areas[i]), (x - i as f32).min(1.0 - f32::EPSILON))
                    }
                };
                let t = &triangles[i];
                let b = uniform_triangle(Vec2::new(ux, u.y));
                let q = t[0] * b[0] + t[1] * b[1] + t[2] * b[2];
                let n = normals[i];
                self.light_sample_from_area_point(p, q, n, self.uv_of(i, b, n, u), pdf_tri)
            }
            Emitter::Cylinder { cylinder, flip } => {
                let (q, n) = Self::cylinder_point(cylinder, *flip, u);
                self.light_sample_from_area_point(p, q, n, self.uv_of(0, [0.0; 3], n, u), 1.0 / self.area())
            }
            Emitter::Sphere { center, radius, .. } => {
                let dc2 = (*center - p).length_squared();
                if mode == LightSampling::Uniform || dc2 <= radius * radius {
                    let n = uniform_sphere(u);
                    let uv = self.uv_of(0, [0.0; 3], n, u);
                    return self.light_sample_from_area_point(p, *center + n * *radius, n, uv, 1.0 / self.area());
                }
                // the cone of directions the sphere subtends (pbrt-v4)
                let dc = dc2.sqrt();
                let sin2_max = radius * radius / dc2;
                let sin_max = sin2_max.sqrt();
                let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
                let mut one_minus_cos_max = 1.0 - cos_max;
                let mut cos_theta = (cos_max - 1.0) * u.x + 1.0;
                let mut sin2_theta = 1.0 - cos_theta * cos_theta;
                if sin2_max < 0.000_685_23 {
                    // small cone: Taylor expansion keeps precision
                    sin2_theta = sin2_max * u.x;
                    cos_theta = (1.0 - sin2_theta).sqrt();
                    one_minus_cos_max = sin2_max / 2.0;
                }
                let cos_alpha = sin2_theta / sin_max + cos_theta * (1.0 - sin2_theta / sin2_max).max(0.0).sqrt();
                let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
                let phi = u.y * 2.0 * PI;
                let w = Vec3::new(sin_alpha * phi.cos(), sin_alpha * phi.sin(), cos_alpha);
                let frame = Frame::from_normal((*center - p) / dc);
                let n = frame.to_world(-w);
                let q = *center + n * *radius;
                let v = q - p;
                let wi = v.normalize();
                Some(LightSample {
                    radiance: self.radiance_at(self.uv_of(0, [0.0; 3], n, u)),
                    wi,
                    pdf: 1.0 / (2.0 * PI * one_minus_cos_max),
                    delta: false,
                    target: ShadowTarget::Point { p: q, n: Some(n) },
                })
            }
        }
    }

    /// Density of direction `wi` from `p`, which meets the light at `q` with normal `n`.
    pub fn pdf(&self, p: Vec3, wi: Vec3, q: Vec3, n: Vec3, mode: LightSampling) -> f32 {
        let area_to_solid = |pdf_area: f32| {
            let cos = n.dot(-wi);
            if cos <= 0.0 {
                0.0
            } else {
                pdf_area * (q - p).length_squared() / cos
            }
        };
        match &self.emitter {
            Emitter::Mesh { triangles, total_area, .. } => match mode {
                LightSampling::Importance => area_to_solid(1.0 / total_area),
                LightSampling::Uniform => {
                    // the triangle holding q: the one whose plane q lies in and contains it
                    let tri = triangles.iter().find(|t| point_in_triangle(q, t)).map(tri_area);
                    tri.map_or(0.0, |a| area_to_solid(1.0 / (triangles.len() as f32 * a)))
                }
            },
            Emitter::Cylinder { .. } => area_to_solid(1.0 / self.area()),
            Emitter::Sphere { center, radius, .. } => {
                let dc2 = (*center - p).length_squared();
                if mode == LightSampling::Uniform || dc2 <= radius * radius {
                    return area_to_solid(1.0 / self.area());
                }
                let sin2_max = radius * radius / dc2;
                let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
                let one_minus = if sin2_max < 0.000_685_23 { sin2_max / 2.0 } else { 1.0 - cos_max };
                1.0 / (2.0 * PI * one_minus)
            }
        }
    }
}

fn tri_area(t: &[Vec3; 3]) -> f32 {
    0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length()
}

/// A triangle's unit normal (winding order).
pub(super) fn tri_normal(t: &[Vec3; 3]) -> Vec3 {
    (t[1] - t[0]).cross(t[2] - t[0]).normalize()
}

fn point_in_triangle(q: Vec3, t: &[Vec3; 3]) -> bool {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let scale = n.length();
    if scale == 0.0 || (q - t[0]).dot(n).abs() > 1e-4 * scale.sqrt() * (1.0 + q.abs().max_element()) {
        return false;
    }
    let e = |a: Vec3, b: Vec3| (b - a).cross(q - a).dot(n) >= -1e-6 * scale * scale;
    e(t[0], t[1]) && e(t[1], t[2]) && e(t[2], t[0])
}
