//! Lights: a closed family. Point lights for now (area lights and the
//! environment map are parsed and kept on their objects).

use crate::math::{Vec3, INV_4PI};

#[derive(Clone, Debug)]
pub enum Light {
    /// Isotropic point light of total power `flux` Φ; intensity Φ/4π.
    Point { position: Vec3, flux: Vec3 },
}

impl Light {
    pub fn intensity(&self) -> Vec3 {
        match self {
            Light::Point { flux, .. } => *flux * INV_4PI,
        }
    }
}
