//! Materials (spec §9): a closed family. The `intersection_test` integrator uses
//! `diffuse` (Lambertian ρ/π) and `refraction` (a perfect refractor); `glass` and
//! `roughconductor` are parsed and kept for the path tracer.

use crate::math::Vec3;

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
    },
}

impl Material {
    /// Specular materials have a Dirac-delta BSDF.
    pub fn is_delta(&self) -> bool {
        matches!(self, Material::Refraction { .. } | Material::Glass { .. })
    }
}
