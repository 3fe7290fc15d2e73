//! Materials (spec §9): a closed family. The `intersection_test` integrator uses
//! `diffuse` (Lambertian ρ/π) and `refraction` (a perfect refractor); `glass` and
//! `roughconductor` are parsed and kept for the path tracer.

pub mod bsdf;
pub mod fresnel;
pub mod microfacet;

pub use bsdf::{Bsdf, BsdfKind, BsdfSample, TransportMode};
pub use microfacet::Distribution;

use crate::math::{Frame, Vec3};

/// A material, `materials.<name>` in a scene: `type` (`"diffuse"`) and the keys of
/// each variant below. Textures are `T`: references by name (or inline colours) in the
/// scene description, indices into the scene's textures (the default) once it is built.
///
/// ```json
/// "materials": {
///   "white": {"type": "diffuse", "texture_name": "white"},
///   "metal": {"type": "roughconductor", "texture_name": "white", "etaT": [0.2, 0.9, 1.1],
///             "k": [3.9, 2.4, 2.2], "alpha_x": 0.2, "alpha_y": 0.2, "distribution": "ggx"}
/// }
/// ```
#[derive(Clone, Debug)]
pub enum Material<T = u32> {
    /// `diffuse`: Lambertian, albedo from a texture; one-sided unless `twosided`.
    /// `texture_name` (required; legacy scenes may give an inline `color` instead,
    /// accepted with a warning), `twosided` (false).
    Diffuse { texture: T, twosided: bool },
    /// `refraction`: perfect refraction with index `eta` (> 0, 1.5) inside, vacuum
    /// outside; weight 1.
    Refraction { eta: f32 },
    /// `glass`: a smooth dielectric; `R` (reflectance, vec3, (1,1,1)), `T`
    /// (transmittance, vec3, (1,1,1)), `eta` (> 0, 1.5).
    Glass { reflect: Vec3, transmit: Vec3, eta: f32 },
    /// `roughconductor`: `texture_name` (required, a tint; legacy scenes may give an
    /// inline `R` instead, accepted with a warning), `etaI`, `etaT`, `k` (vec3, (1,1,1)
    /// each), `alpha_x`, `alpha_y` (≥ 0, 0.1 each), `distribution` (`"beckmann"` |
    /// `"ggx"`, `"beckmann"`).
    RoughConductor {
        texture: T,
        eta_i: Vec3,
        eta_t: Vec3,
        k: Vec3,
        alpha_x: f32,
        alpha_y: f32,
        distribution: Distribution,
    },
}

impl<T> Material<T> {
    /// Specular materials have a Dirac-delta BSDF.
    pub fn is_delta(&self) -> bool {
        matches!(self, Material::Refraction { .. } | Material::Glass { .. })
    }

    /// The same material with every texture replaced by `f(texture)` (in declaration
    /// order): how a description's texture references become indices.
    pub fn try_map_textures<U, E>(&self, mut f: impl FnMut(&T) -> Result<U, E>) -> Result<Material<U>, E> {
        Ok(match self {
            Material::Diffuse { texture, twosided } => Material::Diffuse {
                texture: f(texture)?,
                twosided: *twosided,
            },
            Material::Refraction { eta } => Material::Refraction { eta: *eta },
            Material::Glass { reflect, transmit, eta } => Material::Glass {
                reflect: *reflect,
                transmit: *transmit,
                eta: *eta,
            },
            Material::RoughConductor {
                texture,
                eta_i,
                eta_t,
                k,
                alpha_x,
                alpha_y,
                distribution,
            } => Material::RoughConductor {
                texture: f(texture)?,
                eta_i: *eta_i,
                eta_t: *eta_t,
                k: *k,
                alpha_x: *alpha_x,
                alpha_y: *alpha_y,
                distribution: *distribution,
            },
        })
    }
}

impl Material {
    /// The BSDF at a point with shading normal `ns`, seen from `wo`; `tint`
    /// evaluates a texture there. One-sided materials keep `ns`; two-sided ones
    /// (`twosided` diffuse, conductors — Mitsuba wraps them — and dielectrics)
    /// face the viewer.
    pub fn bsdf(&self, ns: Vec3, wo: Vec3, tint: impl Fn(u32) -> Vec3) -> Bsdf {
        let facing = if ns.dot(wo) < 0.0 { -ns } else { ns };
        let (n, kind) = match *self {
            Material::Diffuse { texture, twosided } => (if twosided { facing } else { ns }, BsdfKind::Diffuse { albedo: tint(texture) }),
            Material::Refraction { eta } => (ns, BsdfKind::PerfectRefraction { eta }),
            Material::Glass { reflect, transmit, eta } => (
                ns,
                BsdfKind::Dielectric {
                    r: reflect,
                    t: transmit,
                    eta,
                },
            ),
            Material::RoughConductor {
                texture,
                eta_i,
                eta_t,
                k,
                alpha_x,
                alpha_y,
                distribution,
            } => (
                facing,
                BsdfKind::Conductor {
                    tint: tint(texture),
                    eta: eta_t / eta_i,
                    k: k / eta_i,
                    mf: microfacet::Microfacet::new(distribution, alpha_x, alpha_y),
                },
            ),
        };
        Bsdf {
            frame: Frame::from_normal(n),
            kind,
        }
    }
}
