//! Mitsuba 0.6's `phong` (Mitsuba 3 dropped it): Lafortune and Willems' normalised
//! modified Phong lobe ρs·(n + 2)/(2π)·cos^n α, α the angle between `wi` and the mirror
//! direction of `wo`, over a Lambertian ρd/π; one-sided. Sampled as 0.6 samples it: a
//! lobe chosen by the reflectances' weights, then the cosine or cos^n α about the
//! mirror direction ([`crate::sampling::power_cosine`]). Local frame as in [`super::bsdf`].

use super::sample::BsdfSample;
use crate::math::{Frame, Vec2, Vec3, INV_PI};
use crate::sampling::{cosine_hemisphere, power_cosine};

const INV_2PI: f32 = 0.5 * INV_PI;

#[derive(Clone, Copy, Debug)]
pub struct Phong {
    /// `diffuse_reflectance` at the point.
    pub diffuse: Vec3,
    /// `specular_reflectance` at the point.
    pub specular: Vec3,
    /// `exponent` n.
    pub exponent: f32,
    /// The share of samples for the Phong lobe: s̄/(d̄ + s̄) of the reflectances'
    /// mean luminances (0.6's `m_specularSamplingWeight`).
    pub specular_sampling_weight: f32,
}

impl Phong {
    /// cos α of `i` about the mirror direction of `o` (0 when beyond 90°).
    fn cos_alpha(o: Vec3, i: Vec3) -> f32 {
        Vec3::new(-o.x, -o.y, o.z).dot(i).max(0.0)
    }

    pub fn eval(&self, o: Vec3, i: Vec3) -> Vec3 {
        if o.z <= 0.0 || i.z <= 0.0 {
            return Vec3::ZERO;
        }
        let n = self.exponent;
        let lobe = (n + 2.0) * INV_2PI * Self::cos_alpha(o, i).powf(n);
        self.diffuse * INV_PI + self.specular * lobe
    }

    pub fn pdf(&self, o: Vec3, i: Vec3) -> f32 {
        if o.z <= 0.0 || i.z <= 0.0 {
            return 0.0;
        }
        let n = self.exponent;
        let w = self.specular_sampling_weight;
        let lobe = (n + 1.0) * INV_2PI * Self::cos_alpha(o, i).powf(n);
        w * lobe + (1.0 - w) * i.z * INV_PI
    }

    pub fn sample(&self, o: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        if o.z <= 0.0 {
            return None;
        }
        let i = if uc < self.specular_sampling_weight {
            Frame::from_normal(Vec3::new(-o.x, -o.y, o.z)).to_world(power_cosine(u, self.exponent))
        } else {
            cosine_hemisphere(u)
        };
        if i.z <= 0.0 {
            return None;
        }
        BsdfSample::glossy(i, self.eval(o, i), self.pdf(o, i))
    }
}
