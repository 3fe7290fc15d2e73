//! Rays leaving lights, for integrators that trace from the lights (light
//! tracing, bidirectional path tracing, photon mapping): a position and a
//! direction with their densities kept apart (area measure and solid angle), as
//! bidirectional MIS needs them.
//!
//! | light | position (`pdf_pos`) | direction (`pdf_dir`) | `le` |
//! |---|---|---|---|
//! | point | its position (delta: 1) | uniform over the sphere (1/4π) | intensity Φ/4π |
//! | mesh area light | uniform by area over all triangles (1/A) | cosine about the normal (cos/π) | radiance (a texture's at the point's uv) |
//! | sphere area light | uniform over the sphere (1/4πr²) | cosine about the outward normal | radiance |
//! | environment | uniform on a disk of the scene's radius facing the direction (1/πR²) | the environment's own importance sampling | radiance |
//! | spot | its position (delta: 1) | uniform in the cone out to the cutoff (1/2π(1 − cos θc)) | intensity × falloff (Mitsuba's `spot`) |
//! | textured spot | its position (delta: 1) | uniform in the cone out to the cutoff | intensity × texture × falloff |
//! | projector | its position (delta: 1) | the image point by a table of its luminance, as a solid angle (pdf_uv / (A cos³θ)) | π·scale·E(uv)/cos³θ |
//! | directional | uniform on a disk of the scene's radius, perpendicular to the direction, on the side the light comes from (1/πR²) | its direction (delta: 1) | irradiance |
//!
//! Emission sampling always uses the lights' own importance (by area for meshes,
//! never the uniform-triangle comparison mode of [`super::LightSampling`]).

use super::{AreaLight, Light, LightSampling};
use crate::math::{Frame, Vec2, Vec3, INV_4PI, INV_PI, PI};
use crate::sampling::{concentric_disk, cosine_hemisphere, uniform_cone, uniform_cone_pdf, uniform_sphere, uniform_triangle};

/// A ray leaving a light.
#[derive(Clone, Copy, Debug)]
pub struct EmissionSample {
    /// Origin: on the light's surface, the point light's position, or on the disk
    /// outside the scene (environment).
    pub p: Vec3,
    /// Surface normal at `p` (area lights; the travel direction for the environment's
    /// disk), `None` for point lights.
    pub n: Option<Vec3>,
    /// Texture coordinates of `p` on an area light (zero elsewhere).
    pub uv: Vec2,
    /// Unit direction of travel, away from the light.
    pub dir: Vec3,
    /// Radiance (intensity for point lights) carried along `dir`.
    pub le: Vec3,
    /// Density of `p`: area measure (1 for a point light's delta position).
    pub pdf_pos: f32,
    /// Density of `dir`: solid angle.
    pub pdf_dir: f32,
}

/// The scene's bounding sphere, which the environment's disk must cover.
#[derive(Clone, Copy, Debug)]
pub struct SceneBounds {
    pub center: Vec3,
    pub radius: f32,
}

impl Light {
    /// Whether emission starts at a single point (a delta position: point and spot).
    pub fn is_delta_position(&self) -> bool {
        matches!(
            self,
            Light::Point { .. } | Light::Spot { .. } | Light::TexturedSpot(_) | Light::Projector(_)
        )
    }

    /// Whether the light lies at infinity (its vertices have no position).
    pub fn is_infinite(&self) -> bool {
        matches!(self, Light::Environment(_) | Light::Directional { .. })
    }

    /// A ray leaving the light; `None` when the sample carries no light.
    pub fn sample_emission(&self, u_pos: Vec2, u_dir: Vec2, bounds: SceneBounds) -> Option<EmissionSample> {
        match self {
            Light::Point { position, flux } => Some(EmissionSample {
                p: *position,
                n: None,
                uv: Vec2::ZERO,
                dir: uniform_sphere(u_dir),
                le: *flux * INV_4PI,
                pdf_pos: 1.0,
                pdf_dir: INV_4PI,
            }),
            Light::Spot {
                position,
                axis,
                intensity,
                cutoff,
                beam_width,
            } => {
                let cos_max = cutoff.cos();
                let local = uniform_cone(u_dir, cos_max);
                let falloff = super::spot_falloff(local.z, *cutoff, *beam_width);
                (falloff > 0.0).then(|| EmissionSample {
                    p: *position,
                    n: None,
                    uv: Vec2::ZERO,
                    dir: Frame::from_normal(*axis).to_world(local),
                    le: *intensity * falloff,
                    pdf_pos: 1.0,
                    pdf_dir: uniform_cone_pdf(cos_max),
                })
            }
            Light::TexturedSpot(s) => {
                let cos_max = s.cutoff.cos();
                let local = uniform_cone(u_dir, cos_max);
                let le = s.intensity_local(local);
                (le != Vec3::ZERO).then(|| EmissionSample {
                    p: s.position,
                    n: None,
                    uv: Vec2::ZERO,
                    dir: s.frame.to_world(local),
                    le,
                    pdf_pos: 1.0,
                    pdf_dir: uniform_cone_pdf(cos_max),
                })
            }
            Light::Projector(pr) => {
                let (dir, le, pdf_dir) = pr.sample_direction(u_dir)?;
                (le != Vec3::ZERO && pdf_dir > 0.0).then_some(EmissionSample {
                    p: pr.position,
                    n: None,
                    uv: Vec2::ZERO,
                    dir,
                    le,
                    pdf_pos: 1.0,
                    pdf_dir,
                })
            }
            Light::Directional { direction, irradiance } => {
                // the disk through the bounding sphere's centre, moved out to its
                // surface on the side the light comes from
                let d = concentric_disk(u_pos) * bounds.radius;
                let frame = Frame::from_normal(*direction);
                let p = bounds.center - *direction * bounds.radius + frame.s * d.x + frame.t * d.y;
                Some(EmissionSample {
                    p,
                    n: Some(*direction),
                    uv: Vec2::ZERO,
                    dir: *direction,
                    le: *irradiance,
                    pdf_pos: 1.0 / (PI * bounds.radius * bounds.radius),
                    pdf_dir: 1.0,
                })
            }
            Light::Area(a) => {
                let (p, n, pdf_pos, uv) = a.sample_point(u_pos)?;
                let local = cosine_hemisphere(u_dir);
                let dir = Frame::from_normal(n).to_world(local);
                let pdf_dir = local.z * INV_PI;
                (pdf_dir > 0.0).then_some(EmissionSample {
                    p,
                    n: Some(n),
                    uv,
                    dir,
                    le: a.radiance_at(uv),
                    pdf_pos,
                    pdf_dir,
                })
            }
            Light::Environment(e) => {
                // wi points to the sky; light travels along −wi
                let ls = e.sample(u_dir, LightSampling::Importance)?;
                if ls.pdf <= 0.0 {
                    return None;
                }
                let dir = -ls.wi;
                let d = concentric_disk(u_pos) * bounds.radius;
                let frame = Frame::from_normal(dir);
                let p = bounds.center + ls.wi * bounds.radius + frame.s * d.x + frame.t * d.y;
                Some(EmissionSample {
                    p,
                    n: Some(dir),
                    uv: Vec2::ZERO,
                    dir,
                    le: ls.radiance,
                    pdf_pos: 1.0 / (PI * bounds.radius * bounds.radius),
                    pdf_dir: ls.pdf,
                })
            }
        }
    }

    /// Densities `(pdf_pos, pdf_dir)` with which [`Light::sample_emission`] would
    /// leave point `p` (normal `n`; ignored by point lights and the environment) in
    /// direction `dir`. A delta part (the position of point and spot lights, the
    /// direction of a directional light) is 0 here, as in pbrt-v4's `PDF_Le`.
    pub fn pdf_emission(&self, n: Vec3, dir: Vec3, bounds: SceneBounds) -> (f32, f32) {
        match self {
            Light::Point { .. } => (0.0, INV_4PI),
            Light::Spot { axis, cutoff, .. } => {
                let cos_max = cutoff.cos();
                // (a hair of slack: a sampled direction at the cone's edge, rounded)
                (
                    0.0,
                    if dir.dot(*axis) >= cos_max - 1e-6 {
                        uniform_cone_pdf(cos_max)
                    } else {
                        0.0
                    },
                )
            }
            Light::TexturedSpot(s) => {
                let cos_max = s.cutoff.cos();
                (
                    0.0,
                    if dir.dot(s.frame.n) >= cos_max - 1e-6 {
                        uniform_cone_pdf(cos_max)
                    } else {
                        0.0
                    },
                )
            }
            Light::Projector(p) => (0.0, p.pdf_direction(dir)),
            Light::Directional { .. } => (1.0 / (PI * bounds.radius * bounds.radius), 0.0),
            Light::Area(a) => (1.0 / a.area(), n.dot(dir).max(0.0) * INV_PI),
            Light::Environment(e) => (1.0 / (PI * bounds.radius * bounds.radius), e.pdf(-dir, LightSampling::Importance)),
        }
    }
}

impl AreaLight {
    /// A point uniformly by area over the whole emitter, its geometric normal, its
    /// area density 1/A and its uv (zero unless the radiance is a texture).
    pub fn sample_point(&self, u: Vec2) -> Option<(Vec3, Vec3, f32, Vec2)> {
        let area = self.area();
        if area.is_nan() || area <= 0.0 {
            return None;
        }
        match &self.emitter {
            super::area::Emitter::Mesh {
                triangles,
                normals,
                by_area,
                ..
            } => {
                let (i, _, ux) = by_area.sample_discrete(u.x);
                let t = &triangles[i];
                let b = uniform_triangle(Vec2::new(ux, u.y));
                let q = t[0] * b[0] + t[1] * b[1] + t[2] * b[2];
                let n = normals[i];
                Some((q, n, 1.0 / area, self.uv_of(i, b, n, u)))
            }
            super::area::Emitter::Sphere { center, radius, .. } => {
                let n = uniform_sphere(u);
                Some((*center + n * *radius, n, 1.0 / area, self.uv_of(0, [0.0; 3], n, u)))
            }
            super::area::Emitter::Cylinder { cylinder, flip } => {
                let (q, n) = AreaLight::cylinder_point(cylinder, *flip, u);
                Some((q, n, 1.0 / area, self.uv_of(0, [0.0; 3], n, u)))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::SplitMix64;

    /// Power estimated from emission samples: E[le·|cos|/(pdf_pos·pdf_dir)] = Φ for
    /// surfaces (cos at the light), E[le/pdf_dir] = Φ for a point light, and for the
    /// environment the power through the disk.
    fn estimated_power(light: &Light, bounds: SceneBounds) -> Vec3 {
        let mut rng = SplitMix64(7);
        let n = 200_000;
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            let u1 = Vec2::new(rng.unit_f32(), rng.unit_f32());
            let u2 = Vec2::new(rng.unit_f32(), rng.unit_f32());
            if let Some(s) = light.sample_emission(u1, u2, bounds) {
                let cos = s.n.map_or(1.0, |n| n.dot(s.dir).abs());
                sum += s.le * cos / (s.pdf_pos * s.pdf_dir);
                // the stand-alone densities agree with the sample's
                let (pp, pd) = light.pdf_emission(s.n.unwrap_or(Vec3::Z), s.dir, bounds);
                if !light.is_delta_position() {
                    assert!((pp - s.pdf_pos).abs() <= 1e-4 * s.pdf_pos, "{pp} vs {}", s.pdf_pos);
                }
                // (the environment's uv round trip can land in the neighbouring row;
                // a directional light's direction is a delta, 0 there)
                if !matches!(light, Light::Directional { .. }) {
                    assert!((pd - s.pdf_dir).abs() <= 1e-2 * s.pdf_dir, "{pd} vs {}", s.pdf_dir);
                }
            }
        }
        sum / n as f32
    }

    #[test]
    fn emission_samples_carry_the_lights_power() {
        let bounds = SceneBounds {
            center: Vec3::ZERO,
            radius: 2.0,
        };
        let point = Light::Point {
            position: Vec3::ONE,
            flux: Vec3::new(4.0, 2.0, 1.0),
        };
        let p = estimated_power(&point, bounds);
        assert!((p - Vec3::new(4.0, 2.0, 1.0)).abs().max_element() < 1e-3, "point: {p}");

        // a unit square (two triangles) of radiance 2: Φ = π·A·L = 2π
        let quad = Light::Area(AreaLight::mesh(
            0,
            Vec3::splat(2.0),
            vec![
                [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)],
                [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            ],
        ));
        let p = estimated_power(&quad, bounds);
        assert!((p.x - 2.0 * PI).abs() < 0.02 * 2.0 * PI, "quad: {p}");

        // a sphere of radius 0.5 and radiance 1: Φ = π·4πr²·L = π²
        let sphere = Light::Area(AreaLight::sphere(0, Vec3::ONE, Vec3::ZERO, 0.5));
        let p = estimated_power(&sphere, bounds);
        assert!((p.x - PI * PI).abs() < 0.02 * PI * PI, "sphere: {p}");

        // a constant sky of radiance 0.5 through a disk of radius R: 4π · πR² · L
        let sky = Light::Environment(crate::light::EnvironmentLight::new(
            crate::light::environment::EnvImage::Constant(Vec3::splat(0.5)),
            1.0,
            &crate::math::Mat4::IDENTITY,
        ));
        let p = estimated_power(&sky, bounds);
        let expected = 4.0 * PI * PI * 4.0 * 0.5;
        assert!((p.x - expected).abs() < 0.02 * expected, "sky: {p} vs {expected}");

        // a spot of intensity 3, beam 10°, cutoff 25°: 2πI [(1 − cos θb) +
        // ((θc − θb) cos θb + sin θb − sin θc)/(θc − θb)] (the linear falloff integrated)
        let (tb, tc) = (10f32.to_radians(), 25f32.to_radians());
        let spot = Light::Spot {
            position: Vec3::ONE,
            axis: Vec3::new(1.0, -2.0, 0.5).normalize(),
            intensity: Vec3::splat(3.0),
            cutoff: tc,
            beam_width: tb,
        };
        let p = estimated_power(&spot, bounds);
        let expected = 2.0 * PI * 3.0 * ((1.0 - tb.cos()) + ((tc - tb) * tb.cos() + tb.sin() - tc.sin()) / (tc - tb));
        assert!((p.x - expected).abs() < 0.01 * expected, "spot: {p} vs {expected}");

        // a directional light of irradiance 2 through the disk of radius R: 2πR²
        let sun = Light::Directional {
            direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
            irradiance: Vec3::splat(2.0),
        };
        let p = estimated_power(&sun, bounds);
        let expected = 2.0 * PI * 4.0;
        assert!((p.x - expected).abs() < 1e-3 * expected, "directional: {p} vs {expected}");
        // its rays start outside the bounding sphere, on the side the light comes from
        let es = sun.sample_emission(Vec2::new(0.3, 0.8), Vec2::splat(0.5), bounds).unwrap();
        let along = (es.p - bounds.center).dot(es.dir);
        assert!((along + bounds.radius).abs() < 1e-4 && (es.p - bounds.center).length() <= 2f32.sqrt() * bounds.radius * 1.0001);
    }
}
