//! `heterogeneous` (Mitsuba 3's): extinction and albedo from volumes, the medium
//! existing only inside its `sigma_t` volume's world box. Distances are tracked against
//! a coarse majorant grid of `sigma_t` walked by a DDA ([`crate::volume::MajorantGrid`]).

use super::{MajorantSegment, MediumPoint, PhaseFunction};
use crate::geometry::Ray;
use crate::math::Vec3;
use crate::volume::{majorant, MajorantGrid, Volume};

/// The largest optical depth (σ_maj × length) of a majorant cell: delta tracking's
/// expected steps across it. Above it a medium is opaque at any visible scale, while
/// null collisions in its thin parts would take that many steps each crossing.
pub const MAX_CELL_OPTICAL_DEPTH: f64 = 1e5;

/// Extinction `sigma_t` × `scale` and single-scattering `albedo`, each a volume.
#[derive(Clone, Debug)]
pub struct Heterogeneous {
    pub sigma_t: Volume,
    pub albedo: Volume,
    pub scale: f32,
    pub phase: PhaseFunction,
    /// Emitted radiance Le (`None`: not emissive).
    pub radiance: Option<Volume>,
    majorants: MajorantGrid,
}

impl Heterogeneous {
    /// A one-line reason (naming the key) when a value is out of range.
    pub fn new(sigma_t: Volume, albedo: Volume, scale: f32, phase: PhaseFunction) -> Result<Heterogeneous, (&'static str, String)> {
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(("scale", format!("must be finite and non-negative, found {scale}")));
        }
        if !(sigma_t.max() * scale).is_finite() {
            return Err(("scale", format!("times sigma_t overflows ({scale} × {})", sigma_t.max())));
        }
        if albedo.max() > 1.0 {
            return Err(("albedo", format!("must lie in [0, 1], its largest value is {}", albedo.max())));
        }
        let majorants = MajorantGrid::new(&sigma_t, majorant::DEFAULT_RES);
        // delta tracking takes about this many steps to cross the densest cell, null
        // collisions included where thin values share a cell with it
        let (peak, reach) = (majorants.max() * scale, majorants.cell_reach());
        if f64::from(peak) * f64::from(reach) > MAX_CELL_OPTICAL_DEPTH {
            return Err((
                "sigma_t",
                format!(
                    "values up to {peak:e} (× scale) over majorant cells {reach:e} across reach an optical depth above \
                     {MAX_CELL_OPTICAL_DEPTH:e} per cell, which delta tracking cannot cross in time: lower the peaks or scale"
                ),
            ));
        }
        Ok(Heterogeneous {
            sigma_t,
            albedo,
            scale,
            phase,
            radiance: None,
            majorants,
        })
    }

    /// The medium emitting radiance `le` (a volume; σa·Le per unit length); a one-line
    /// reason when its values are negative or not finite.
    pub fn with_radiance(self, le: Volume) -> Result<Heterogeneous, (&'static str, String)> {
        // a grid holds no negative value (GridData::new refuses them)
        let min = match &le {
            Volume::Constant(c) => c.value.min_element(),
            Volume::Grid(_) => 0.0,
        };
        super::homogeneous::check_radiance(min, le.max())?;
        let radiance = (le.max() > 0.0).then_some(le);
        Ok(Heterogeneous { radiance, ..self })
    }

    /// The emitted radiance at world point `p`.
    #[inline]
    pub fn radiance(&self, p: Vec3) -> Vec3 {
        self.radiance.as_ref().map_or(Vec3::ZERO, |v| Vec3::from_array(v.eval(p)))
    }

    /// The coefficients at world point `p`.
    #[inline]
    pub fn at(&self, p: Vec3) -> MediumPoint {
        let sigma_t = Vec3::from_array(self.sigma_t.eval(p)) * self.scale;
        let sigma_s = sigma_t * Vec3::from_array(self.albedo.eval(p)).clamp(Vec3::ZERO, Vec3::ONE);
        MediumPoint {
            sigma_a: sigma_t - sigma_s,
            sigma_s,
        }
    }

    /// The majorant grid's segments of `ray` over `[ray.t_min, t_end]` inside the
    /// volume's box.
    #[inline]
    pub fn segments(&self, ray: &Ray, t_end: f32, mut each: impl FnMut(MajorantSegment) -> bool) {
        for s in self.majorants.iter(ray.o, ray.d, ray.t_min, t_end) {
            let go_on = each(MajorantSegment {
                t0: s.t0,
                t1: s.t1,
                sigma_maj: Vec3::splat(s.scale * self.scale),
                exact: false,
            });
            if !go_on {
                return;
            }
        }
    }
}
