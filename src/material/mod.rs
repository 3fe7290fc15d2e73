//! Materials (spec §9): a closed family. The `intersection_test` integrator uses
//! `diffuse` (Lambertian ρ/π) and `refraction` (a perfect refractor); `glass` and
//! `roughconductor` are parsed and kept for the path tracer.

pub mod bsdf;
pub mod fresnel;
pub mod microfacet;

pub use bsdf::{Bsdf, BsdfKind, BsdfSample, TransportMode};
pub use microfacet::Distribution;

use crate::math::{Frame, Vec3};

#[derive(Clone, Debug)]
pub enum Material {
    /// Lambertian, albedo from a texture; one-sided unless `twosided`.
    Diffuse {
        texture: u32,
        twosided: bool,
    },
    /// Perfect refraction with index `eta` inside, vacuum outside; weight 1.
    Refraction {
        eta: f32,
    },
    Glass {
        reflect: Vec3,
        transmit: Vec3,
        eta: f32,
    },
    RoughConductor {
        texture: u32,
        eta_i: Vec3,
        eta_t: Vec3,
        k: Vec3,
        alpha_x: f32,
        alpha_y: f32,
        distribution: Distribution,
    },
}

impl Material {
    /// Specular materials have a Dirac-delta BSDF.
    pub fn is_delta(&self) -> bool {
        matches!(self, Material::Refraction { .. } | Material::Glass { .. })
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
