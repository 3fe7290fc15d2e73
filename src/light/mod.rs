//! Lights: a closed family. Each can be sampled from a shading point (radiance,
//! direction, solid-angle pdf) and asked for the pdf of a direction, so
//! integrators can combine light and BSDF sampling with MIS.

pub mod area;
pub mod emission;
pub mod environment;
pub mod projector;
pub mod sunsky;
pub mod textured_spot;

pub use area::AreaLight;
pub use emission::{EmissionSample, SceneBounds};
pub use environment::EnvironmentLight;
pub use projector::Projector;
pub use textured_spot::TexturedSpot;

use crate::math::{luminance, Vec2, Vec3, INV_4PI, PI};
use crate::sampling::{Distribution1D, RowDraw};

#[derive(Clone, Debug)]
pub enum Light {
    /// Isotropic point light of total power `flux` Φ; intensity Φ/4π.
    Point {
        position: Vec3,
        flux: Vec3,
    },
    Area(AreaLight),
    Environment(EnvironmentLight),
    /// Mitsuba's `spot`: a point at `position` shining along the unit `axis`, radiant
    /// intensity `intensity` within `beam_width` of it, falling linearly in angle to 0
    /// at `cutoff` (both half-angles in radians, 0 < beam_width ≤ cutoff < π/2 … π).
    Spot {
        position: Vec3,
        axis: Vec3,
        intensity: Vec3,
        cutoff: f32,
        beam_width: f32,
    },
    /// Mitsuba's `directional`: light from infinitely far, travelling along the unit
    /// `direction`, `irradiance` on a surface facing it.
    Directional {
        direction: Vec3,
        irradiance: Vec3,
    },
    /// Mitsuba's `spot` with a `texture` projected over its cone ([`textured_spot`]).
    TexturedSpot(TexturedSpot),
    /// Mitsuba's `projector`: an image projected through a pinhole ([`projector`]).
    Projector(Projector),
}

/// A spot light's intensity factor for a direction at `cos_theta` to its axis:
/// 1 inside the beam, linear in the angle down to 0 at the cutoff (Mitsuba's curve).
pub fn spot_falloff(cos_theta: f32, cutoff: f32, beam_width: f32) -> f32 {
    if cos_theta <= cutoff.cos() {
        return 0.0;
    }
    if cos_theta >= beam_width.cos() || cutoff <= beam_width {
        return 1.0;
    }
    ((cutoff - cos_theta.clamp(-1.0, 1.0).acos()) / (cutoff - beam_width)).clamp(0.0, 1.0)
}

/// Where a shadow ray for a light sample has to go.
#[derive(Clone, Copy, Debug)]
pub enum ShadowTarget {
    /// A point (on a surface with normal `n`, if any).
    Point { p: Vec3, n: Option<Vec3> },
    /// Infinitely far in direction `wi`.
    Infinity,
}

#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Radiance arriving at the shading point (intensity/d² for point lights).
    pub radiance: Vec3,
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Solid-angle density; 1 for delta lights.
    pub pdf: f32,
    pub delta: bool,
    pub target: ShadowTarget,
}

impl LightSample {
    /// A sample of the environment towards `wi` with solid-angle density `pdf`, its
    /// radiance left zero ([`Light::sample_unlit`]).
    #[inline(always)]
    pub fn unlit_sky(wi: Vec3, pdf: f32) -> LightSample {
        LightSample {
            radiance: Vec3::ZERO,
            wi,
            pdf,
            delta: false,
            target: ShadowTarget::Infinity,
        }
    }
}

/// How lights draw their samples: the light's own importance (area ∝, the
/// cone of a sphere, the environment's luminance) or uniformly (uniform area
/// over all triangles alike, over the whole sphere, uniform directions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LightSampling {
    #[default]
    Importance,
    Uniform,
}

impl Light {
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } | Light::TexturedSpot(_) | Light::Projector(_)
        )
    }

    /// The radiant intensity a light at a delta position (point, spot, textured spot,
    /// projector) sends along the unit direction `dir` (away from it); zero for others.
    pub fn intensity_towards(&self, dir: Vec3) -> Vec3 {
        match self {
            Light::Point { flux, .. } => *flux * INV_4PI,
            Light::Spot {
                axis,
                intensity,
                cutoff,
                beam_width,
                ..
            } => *intensity * spot_falloff(dir.dot(*axis), *cutoff, *beam_width),
            Light::TexturedSpot(s) => s.intensity_towards(dir),
            Light::Projector(p) => p.intensity_towards(dir),
            _ => Vec3::ZERO,
        }
    }

    /// A sample of the light as seen from `p`. `None` when the light cannot
    /// reach `p` this time (back of a one-sided emitter, zero pdf).
    pub fn sample(&self, p: Vec3, u: Vec2, mode: LightSampling) -> Option<LightSample> {
        match self {
            Light::Point { position, flux } => {
                let v = *position - p;
                let d2 = v.length_squared();
                if d2 == 0.0 {
                    return None;
                }
                Some(LightSample {
                    radiance: *flux * INV_4PI / d2,
                    wi: v / d2.sqrt(),
                    pdf: 1.0,
                    delta: true,
                    target: ShadowTarget::Point { p: *position, n: None },
                })
            }
            Light::Spot {
                position,
                axis,
                intensity,
                cutoff,
                beam_width,
            } => {
                let v = *position - p;
                let d2 = v.length_squared();
                if d2 == 0.0 {
                    return None;
                }
                let wi = v / d2.sqrt();
                let f = spot_falloff(-wi.dot(*axis), *cutoff, *beam_width);
                (f > 0.0).then_some(LightSample {
                    radiance: *intensity * f / d2,
                    wi,
                    pdf: 1.0,
                    delta: true,
                    target: ShadowTarget::Point { p: *position, n: None },
                })
            }
            Light::Directional { direction, irradiance } => Some(LightSample {
                radiance: *irradiance,
                wi: -*direction,
                pdf: 1.0,
                delta: true,
                target: ShadowTarget::Infinity,
            }),
            Light::TexturedSpot(TexturedSpot { position, .. }) | Light::Projector(Projector { position, .. }) => {
                let v = *position - p;
                let d2 = v.length_squared();
                if d2 == 0.0 {
                    return None;
                }
                let wi = v / d2.sqrt();
                let i = self.intensity_towards(-wi);
                (i != Vec3::ZERO).then_some(LightSample {
                    radiance: i / d2,
                    wi,
                    pdf: 1.0,
                    delta: true,
                    target: ShadowTarget::Point { p: *position, n: None },
                })
            }
            Light::Area(a) => a.sample(p, u, mode),
            Light::Environment(e) => e.sample(u, mode),
        }
    }

    /// [`Self::sample`], except that an environment's radiance is left zero for
    /// [`Self::radiance_of`] to give: a caller that may drop the sample first (a
    /// direction the BSDF does not reflect) saves the environment lookup.
    /// `draw`: the environment's row drawn for `u` by [`Self::prefetch_sample`], if it was.
    #[inline]
    pub fn sample_unlit(&self, p: Vec3, u: Vec2, mode: LightSampling, draw: Option<RowDraw>) -> Option<LightSample> {
        match self {
            Light::Environment(e) => e.sample_direction(u, mode, draw).map(|(wi, pdf)| LightSample::unlit_sky(wi, pdf)),
            _ => self.sample(p, u, mode),
        }
    }

    /// Prefetches what [`Self::sample`] with `u` will read first (a hint, for the
    /// environment's tables), so that other work overlaps the loads; an environment
    /// sampled by importance returns the row it drew, for [`Self::sample_unlit`].
    #[inline]
    pub fn prefetch_sample(&self, u: Vec2, mode: LightSampling) -> Option<RowDraw> {
        match self {
            Light::Environment(e) => e.prefetch_sample(u, mode),
            _ => None,
        }
    }

    /// The radiance of a sample from [`Self::sample_unlit`]: what [`Self::sample`]
    /// would have given.
    #[inline]
    pub fn radiance_of(&self, ls: &LightSample) -> Vec3 {
        match self {
            Light::Environment(e) => e.radiance(ls.wi),
            _ => ls.radiance,
        }
    }

    /// Solid-angle density with which `sample(p, ..)` would produce direction `wi`
    /// that reaches the light at `hit` (point and geometric normal on the light;
    /// `None` for the environment).
    pub fn pdf(&self, p: Vec3, wi: Vec3, hit: Option<(Vec3, Vec3)>, mode: LightSampling) -> f32 {
        match self {
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } | Light::TexturedSpot(_) | Light::Projector(_) => 0.0,
            Light::Area(a) => hit.map_or(0.0, |(q, n)| a.pdf(p, wi, q, n, mode)),
            Light::Environment(e) => e.pdf(wi, mode),
        }
    }

    /// Total emitted power (luminance), for choosing lights in proportion to it.
    pub fn power(&self, scene_radius: f32) -> f32 {
        match self {
            Light::Point { flux, .. } => luminance(*flux),
            Light::Area(a) => PI * a.area() * luminance(a.radiance),
            Light::Environment(e) => PI * scene_radius * scene_radius * 4.0 * PI * e.mean_luminance(),
            // the cone's power with the full intensity out to the cutoff (a choice weight only)
            Light::Spot { intensity, cutoff, .. } => 2.0 * PI * (1.0 - cutoff.cos()) * luminance(*intensity),
            Light::Directional { irradiance, .. } => PI * scene_radius * scene_radius * luminance(*irradiance),
            Light::TexturedSpot(s) => {
                2.0 * PI * (1.0 - s.cutoff.cos()) * luminance(s.intensity) * crate::texture::luminance(s.texture.mean()).max(0.0)
            }
            Light::Projector(p) => p.power(),
        }
    }
}

/// Share of next-event light choices made uniformly, the rest in proportion to power:
/// a defensive mixture (Hesterberg 1995). Power alone starves lights of little power
/// that matter where they are seen or reflected (the Veach MIS scene's four small
/// spheres: 0.5 % of the samples each, against 98 % for the large one), uniform
/// choice alone wastes samples on weak lights; the mixture is within 2x of either
/// strategy's probability for every light. Measured on the real scenes (relMSE of two
/// seeds, 64 spp): see the commit that introduced it.
pub const UNIFORM_SHARE: f32 = 0.5;

/// Picks one light: for next-event estimation (and bdpt's light subpaths, which
/// connect to the same choice) by [`UNIFORM_SHARE`]'s mixture of power and uniform
/// choice, or uniformly; for photons leaving the lights, in proportion to power (so
/// photons carry alike), or uniformly.
#[derive(Clone, Debug)]
pub struct LightSampler {
    distribution: Distribution1D,
    emission: Distribution1D,
}

impl LightSampler {
    pub fn new(lights: &[Light], scene_radius: f32, mode: LightSampling) -> Self {
        match mode {
            LightSampling::Importance => Self::with_uniform_share(lights, scene_radius, UNIFORM_SHARE),
            LightSampling::Uniform => {
                let uniform = Self::mixture(lights, scene_radius, 1.0);
                LightSampler {
                    distribution: uniform.clone(),
                    emission: uniform,
                }
            }
        }
    }

    /// A sampler choosing lights with probability (1 − `uniform_share`)·Φᵢ/ΣΦ +
    /// `uniform_share`/n for next-event estimation (0: by power, the strategy before
    /// [`UNIFORM_SHARE`]; for comparisons), and by power for photons.
    pub fn with_uniform_share(lights: &[Light], scene_radius: f32, uniform_share: f32) -> Self {
        LightSampler {
            distribution: Self::mixture(lights, scene_radius, uniform_share),
            emission: Self::mixture(lights, scene_radius, 0.0),
        }
    }

    /// The mixture's distribution; weights scaled by n, so that uniform choice weighs
    /// each light exactly 1. Lights of no power at all are chosen uniformly.
    fn mixture(lights: &[Light], scene_radius: f32, uniform_share: f32) -> Distribution1D {
        let n = lights.len() as f32;
        let power: Vec<f32> = lights.iter().map(|l| l.power(scene_radius).max(0.0)).collect();
        let total: f32 = power.iter().sum();
        let weights: Vec<f32> = if uniform_share >= 1.0 || !(total > 0.0 && total.is_finite()) {
            vec![1.0; lights.len()]
        } else if uniform_share <= 0.0 {
            power
        } else {
            power
                .iter()
                .map(|p| (1.0 - uniform_share) * n * p / total + uniform_share)
                .collect()
        };
        Distribution1D::new(&weights)
    }

    /// A light index, its probability, and `u` re-used.
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        self.distribution.sample_discrete(u)
    }

    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.distribution.pmf(i)
    }

    /// A light for a photon to leave (in proportion to power), its probability, and `u` re-used.
    #[inline]
    pub fn sample_emission(&self, u: f32) -> (usize, f32, f32) {
        self.emission.sample_discrete(u)
    }
}
