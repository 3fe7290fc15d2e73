//! Mitsuba 3's `sunsky` emitter in RGB: the Hošek–Wilkie sky (2012) and sun (2013).
//!
//! The tables (`data/sunsky/hosek_wilkie_rgb.bin`, made by `scripts/make_sunsky_tables.py`
//! from Mitsuba 3's copy of the Hošek–Wilkie data, BSD-3) hold, per turbidity 1…10 and
//! ground albedo 0/1, the sky's nine parameters and mean radiance at six Bézier control
//! points over the sun's elevation, and the sun's radiance as a polynomial in elevation
//! (45 segments) and in cos ψ (limb darkening, baked into the RGB fit).
//! Directions are in the sky's frame: +z is up (the zenith), as in Mitsuba.

use crate::math::{luminance, Frame, Vec2, Vec3, PI};
use glam::Mat3;

const TABLES: &[u8] = include_bytes!("../../data/sunsky/hosek_wilkie_rgb.bin");
const MAGIC: &[u8] = b"RDRSKY01";
const TURBIDITIES: usize = 10;
const CONTROL_POINTS: usize = 6;
const SKY_PARAMS: usize = 9;
const SUN_SEGMENTS: usize = 45;
const SUN_DEGREE: usize = 4;
const LIMB_POWERS: usize = 6;
const SKY_PARAMS_LEN: usize = TURBIDITIES * 2 * CONTROL_POINTS * 3 * SKY_PARAMS;
const SKY_RADIANCE_LEN: usize = TURBIDITIES * 2 * CONTROL_POINTS * 3;
/// One turbidity's sun table: [segment][channel][degree][limb power].
const SUN_LEN: usize = SUN_SEGMENTS * 3 * SUN_DEGREE * LIMB_POWERS;

/// Mitsuba's RGB radiance is the model's spectral radiance integrated against CIE ȳ
/// and divided by ∫ȳ (its `MI_CIE_Y_NORMALIZATION`).
const CIE_Y_NORMALIZATION: f32 = 1.0 / 106.750_26;
/// Mitsuba's factor from the RGB sun fit to its spectral units.
const SUN_RGB_CONVERSION: f32 = 467.069_28;
/// The sun's true half aperture (0.5358° across), in radians.
pub const SUN_HALF_APERTURE: f32 = 0.5 * 0.5358 * PI / 180.0;

fn table(i: usize) -> f32 {
    let at = MAGIC.len() + 4 * i;
    f32::from_le_bytes([TABLES[at], TABLES[at + 1], TABLES[at + 2], TABLES[at + 3]])
}

/// `1 − cos θ` without cancellation (θ as small as the sun's half aperture).
pub fn one_minus_cos(theta: f32) -> f32 {
    let s = (0.5 * theta).sin();
    2.0 * s * s
}

/// Turbidity `t` ∈ [1, 10] as the two table rows and the weight of the second.
fn turbidity_rows(t: f32) -> (usize, usize, f32) {
    let x = (t - 1.0).clamp(0.0, (TURBIDITIES - 1) as f32);
    let lo = (x.floor() as usize).min(TURBIDITIES - 1);
    (lo, (lo + 1).min(TURBIDITIES - 1), x - lo as f32)
}

/// What fixes the sky: Mitsuba's parameters, the sun given in the sky's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunSkyParams {
    pub turbidity: f32,
    /// Ground albedo per channel, in [0, 1].
    pub albedo: Vec3,
    /// Unit direction towards the sun, +z up.
    pub sun: Vec3,
    pub sky_scale: f32,
    pub sun_scale: f32,
    /// Half the sun's aperture, radians.
    pub sun_half_aperture: f32,
    pub complex_sun: bool,
}

impl SunSkyParams {
    /// The sun's elevation above the horizon, radians.
    pub fn sun_elevation(&self) -> f32 {
        0.5 * PI - self.sun.z.clamp(-1.0, 1.0).acos()
    }
}

/// The sky's radiance for one sun (Hošek–Wilkie's nine-parameter formula per channel).
#[derive(Clone, Debug)]
pub struct SkyModel {
    params: [[f32; SKY_PARAMS]; 3],
    radiance: Vec3,
    sun: Vec3,
}

impl SkyModel {
    /// The sky under `p` (the sun above the horizon), `sky_scale` included.
    pub fn new(p: &SunSkyParams) -> Self {
        // quintic Bézier over (elevation / (π/2))^⅓, as the model's fit
        let x = (p.sun_elevation().max(0.0) * 2.0 / PI).cbrt().min(1.0 - 1e-6);
        const BINOMIAL: [f32; CONTROL_POINTS] = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];
        let bezier: [f32; CONTROL_POINTS] =
            std::array::from_fn(|i| BINOMIAL[i] * x.powi(i as i32) * (1.0 - x).powi((CONTROL_POINTS - 1 - i) as i32));
        let (t0, t1, ft) = turbidity_rows(p.turbidity);
        // value at (turbidity row, albedo row, control point, channel, parameter) of a table
        // of `n` parameters starting at `base`
        let at = |base: usize, n: usize, t: usize, a: usize, k: usize, c: usize, j: usize| {
            table(base + (((t * 2 + a) * CONTROL_POINTS + k) * 3 + c) * n + j)
        };
        let blend = |base: usize, n: usize, c: usize, j: usize| -> f32 {
            let albedo = p.albedo[c];
            (0..CONTROL_POINTS)
                .map(|k| {
                    let by_albedo = |t| at(base, n, t, 0, k, c, j) * (1.0 - albedo) + at(base, n, t, 1, k, c, j) * albedo;
                    bezier[k] * (by_albedo(t0) * (1.0 - ft) + by_albedo(t1) * ft)
                })
                .sum()
        };
        let params = std::array::from_fn(|c| std::array::from_fn(|j| blend(0, SKY_PARAMS, c, j)));
        let radiance = Vec3::new(
            blend(SKY_PARAMS_LEN, 1, 0, 0),
            blend(SKY_PARAMS_LEN, 1, 1, 0),
            blend(SKY_PARAMS_LEN, 1, 2, 0),
        );
        SkyModel {
            params,
            radiance: radiance * (p.sky_scale * CIE_Y_NORMALIZATION),
            sun: p.sun.normalize(),
        }
    }

    /// Radiance from unit direction `l` (+z up); none from below the horizon.
    pub fn radiance(&self, l: Vec3) -> Vec3 {
        let cos_theta = l.z;
        if cos_theta.is_nan() || cos_theta < 0.0 || self.radiance == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let cos_gamma = l.dot(self.sun).clamp(-1.0, 1.0);
        let gamma = cos_gamma.acos();
        let channel = |c: usize| {
            let [a, b, cc, d, e, f, g, h, i] = self.params[c];
            let zenith = 1.0 + a * (b / (cos_theta + 0.01)).exp();
            let mie = (1.0 + cos_gamma * cos_gamma) / (1.0 + i * i - 2.0 * i * cos_gamma).powf(1.5);
            let glow = cc + d * (e * gamma).exp() + f * cos_gamma * cos_gamma + g * mie + h * cos_theta.sqrt();
            zenith * glow
        };
        Vec3::new(channel(0), channel(1), channel(2)) * self.radiance
    }
}

/// The sun's disc: radiance within the half aperture of its direction, either flat
/// (Mitsuba's default: the disc's mean) or limb-darkened (`complex_sun`).
#[derive(Clone, Debug)]
pub struct SunModel {
    /// Unit direction to the sun's centre, +z up.
    pub dir: Vec3,
    pub half_aperture: f32,
    sin2_half: f32,
    /// The turbidity's table (limb-darkened sun), scaled to radiance; `None`: flat.
    limb: Option<Box<[f32]>>,
    /// The disc's mean radiance.
    pub mean: Vec3,
}

impl SunModel {
    /// The sun of `p` (above the horizon), `sun_scale` included. Its power does not
    /// depend on the aperture (Mitsuba scales the radiance by the true disc's solid
    /// angle over the one given).
    pub fn new(p: &SunSkyParams) -> Self {
        let (t0, t1, ft) = turbidity_rows(p.turbidity);
        let base = SKY_PARAMS_LEN + SKY_RADIANCE_LEN;
        let scale =
            p.sun_scale * SUN_RGB_CONVERSION * CIE_Y_NORMALIZATION * one_minus_cos(SUN_HALF_APERTURE) / one_minus_cos(p.sun_half_aperture);
        let limb: Box<[f32]> = (0..SUN_LEN)
            .map(|i| (table(base + t0 * SUN_LEN + i) * (1.0 - ft) + table(base + t1 * SUN_LEN + i) * ft) * scale)
            .collect();
        let s = p.sun_half_aperture.sin();
        let mut sun = SunModel {
            dir: p.sun.normalize(),
            half_aperture: p.sun_half_aperture,
            sin2_half: s * s,
            limb: Some(limb),
            mean: Vec3::ZERO,
        };
        sun.mean = sun.disc_mean();
        if !p.complex_sun {
            sun.limb = None;
        }
        sun
    }

    /// Solid angle of the disc.
    pub fn solid_angle(&self) -> f32 {
        2.0 * PI * one_minus_cos(self.half_aperture)
    }

    /// sin² of the angle between unit `l` and the sun's centre when `l` is on the disc.
    #[inline]
    pub fn on_disc(&self, l: Vec3) -> Option<f32> {
        let sin2 = l.cross(self.dir).length_squared();
        (l.dot(self.dir) > 0.0 && sin2 <= self.sin2_half).then_some(sin2)
    }

    /// Radiance from unit direction `l` (+z up): zero off the disc.
    pub fn radiance(&self, l: Vec3) -> Vec3 {
        match self.on_disc(l) {
            None => Vec3::ZERO,
            Some(sin2) => match &self.limb {
                None => self.mean,
                Some(t) => Self::limb_radiance(t, l.z, sin2 / self.sin2_half),
            },
        }
    }

    /// The limb-darkened radiance at cos θ (of the viewing direction) and sin²γ/sin²(half
    /// aperture): a cubic in the elevation above its segment's start, a quintic in cos ψ.
    fn limb_radiance(t: &[f32], cos_theta: f32, rel_sin2: f32) -> Vec3 {
        let elevation = 0.5 * PI - cos_theta.clamp(-1.0, 1.0).acos();
        let segment = ((elevation.max(0.0) * 2.0 / PI).cbrt() * SUN_SEGMENTS as f32) as usize;
        let segment = segment.min(SUN_SEGMENTS - 1);
        let x = elevation - 0.5 * PI * (segment as f32 / SUN_SEGMENTS as f32).powi(3);
        let cos_psi = (1.0 - rel_sin2).max(0.0).sqrt();
        let mut out = [0.0f32; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let mut x_k = 1.0;
            for k in 0..SUN_DEGREE {
                let row = &t[((segment * 3 + c) * SUN_DEGREE + k) * LIMB_POWERS..][..LIMB_POWERS];
                // Horner in cos ψ
                let limb = row.iter().rev().fold(0.0, |acc, &a| acc * cos_psi + a);
                *o += x_k * limb;
                x_k *= x;
            }
        }
        Vec3::from_array(out)
    }

    /// The limb-darkened radiance averaged over the disc (uniform in solid angle: rings of
    /// equal area, each at several azimuths, since the elevation varies across the disc).
    fn disc_mean(&self) -> Vec3 {
        let Some(t) = &self.limb else { return self.mean };
        let frame = crate::math::Frame::from_normal(self.dir);
        let h_max = one_minus_cos(self.half_aperture);
        let (rings, spokes) = (64, 16);
        let mut sum = Vec3::ZERO;
        for i in 0..rings {
            let h = (i as f32 + 0.5) / rings as f32 * h_max;
            let sin_t = (h * (2.0 - h)).sqrt();
            for k in 0..spokes {
                let phi = 2.0 * PI * (k as f32 + 0.5) / spokes as f32;
                let l = (frame.to_world(Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), 1.0 - h))).normalize();
                sum += Self::limb_radiance(t, l.z, sin_t * sin_t / self.sin2_half);
            }
        }
        sum / (rings * spokes) as f32
    }
}

/// The sun as the environment light carries it: its disc in world directions (`to_world`
/// a rotation), sampled uniformly over the cone of its aperture.
#[derive(Clone, Debug)]
pub struct WorldSun {
    model: SunModel,
    to_sky: Mat3,
    frame: Frame,
    /// Probability that the environment's importance sampling draws the sun.
    pub choose: f32,
}

impl WorldSun {
    pub fn new(model: SunModel, to_world: Mat3) -> Self {
        let dir = (to_world * model.dir).normalize();
        WorldSun {
            to_sky: to_world.inverse(),
            frame: Frame::from_normal(dir),
            model,
            choose: 1.0,
        }
    }

    /// Luminance of the sun's irradiance on a surface facing it (its share of the power).
    pub fn irradiance_luminance(&self) -> f32 {
        luminance(self.model.mean) * self.model.solid_angle()
    }

    fn local(&self, w: Vec3) -> Vec3 {
        (self.to_sky * w).normalize()
    }

    /// Radiance arriving from world direction `w` (unit): zero off the disc.
    #[inline]
    pub fn radiance(&self, w: Vec3) -> Vec3 {
        self.model.radiance(self.local(w))
    }

    /// A direction uniform over the disc's cone (1 − cos θ uniform, without cancellation).
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let h = u.x * one_minus_cos(self.model.half_aperture);
        let sin_theta = (h * (2.0 - h)).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        self.frame
            .to_world(Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), 1.0 - h))
            .normalize()
    }

    /// Solid-angle density of [`Self::sample`] at `w` (where the disc is, as [`Self::radiance`] sees it).
    pub fn pdf(&self, w: Vec3) -> f32 {
        match self.model.on_disc(self.local(w)) {
            Some(_) => 1.0 / self.model.solid_angle(),
            None => 0.0,
        }
    }
}

/// Mitsuba's `sunsky` location and time (its defaults: Tokyo, 10 July 2010, 15:00).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunPosition {
    pub latitude: f32,
    pub longitude: f32,
    pub timezone: f32,
    pub year: i32,
    pub month: i32,
    pub day: i32,
    pub hour: f32,
    pub minute: f32,
    pub second: f32,
}

impl Default for SunPosition {
    fn default() -> Self {
        SunPosition {
            latitude: 35.6894,
            longitude: 139.6917,
            timezone: 9.0,
            year: 2010,
            month: 7,
            day: 10,
            hour: 15.0,
            minute: 0.0,
            second: 0.0,
        }
    }
}

impl SunPosition {
    /// The unit direction to the sun in the sky's frame (+z up, azimuth as Mitsuba's),
    /// by Blanco-Muriel et al., "Computing the solar vector" (Solar Energy 70(5), 2001).
    pub fn direction(&self) -> Vec3 {
        let hours = self.hour as f64 - self.timezone as f64 + (self.minute as f64 + self.second as f64 / 60.0) / 60.0;
        // Julian day (integer divisions truncate, as the algorithm's)
        let (y, m, d) = (self.year as i64, self.month as i64, self.day as i64);
        let a1 = (m - 14) / 12;
        let a2 = (1461 * (y + 4800 + a1)) / 4 + (367 * (m - 2 - 12 * a1)) / 12 - (3 * ((y + 4900 + a1) / 100)) / 4 + d - 32075;
        let n = a2 as f64 - 0.5 + hours / 24.0 - 2_451_545.0;
        // ecliptic coordinates
        let omega = 2.1429 - 0.001_039_459_4 * n;
        let mean_longitude = 4.895_063 + 0.017_202_791_698 * n;
        let anomaly = 6.240_06 + 0.017_201_969_9 * n;
        let longitude =
            mean_longitude + 0.033_416_07 * anomaly.sin() + 0.000_348_94 * (2.0 * anomaly).sin() - 0.000_113_4 - 0.000_020_3 * omega.sin();
        let obliquity = 0.409_092_8 - 6.214e-9 * n + 0.000_039_6 * omega.cos();
        // celestial coordinates
        let mut right_ascension = (obliquity.cos() * longitude.sin()).atan2(longitude.cos());
        if right_ascension < 0.0 {
            right_ascension += 2.0 * std::f64::consts::PI;
        }
        let declination = (obliquity.sin() * longitude.sin()).asin();
        // local coordinates
        let sidereal = (6.697_424_324_2 + 0.065_709_828_3 * n + hours) * 15.0 + self.longitude as f64;
        let hour_angle = sidereal.to_radians() - right_ascension;
        let lat = (self.latitude as f64).to_radians();
        let mut zenith = (lat.cos() * hour_angle.cos() * declination.cos() + declination.sin() * lat.sin()).acos();
        let mut azimuth = (-hour_angle.sin()).atan2(declination.tan() * lat.cos() - lat.sin() * hour_angle.cos());
        if azimuth < 0.0 {
            azimuth += 2.0 * std::f64::consts::PI;
        }
        // parallax (Earth's mean radius over the astronomical unit, km)
        zenith += 6371.01 / 149_597_890.0 * zenith.sin();
        let phi = azimuth - std::f64::consts::PI;
        Vec3::new(
            (zenith.sin() * phi.cos()) as f32,
            (zenith.sin() * phi.sin()) as f32,
            zenith.cos() as f32,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_have_the_expected_size() {
        assert_eq!(&TABLES[..MAGIC.len()], MAGIC);
        assert_eq!(
            TABLES.len(),
            MAGIC.len() + 4 * (SKY_PARAMS_LEN + SKY_RADIANCE_LEN + TURBIDITIES * SUN_LEN)
        );
    }

    /// The flat sun carries the limb-darkened one's power, and both the aperture's.
    #[test]
    fn sun_power_does_not_depend_on_the_model_or_aperture() {
        let p = SunSkyParams {
            turbidity: 3.0,
            albedo: Vec3::splat(0.3),
            sun: Vec3::new(0.3, 0.2, 0.8).normalize(),
            sky_scale: 1.0,
            sun_scale: 1.0,
            sun_half_aperture: SUN_HALF_APERTURE,
            complex_sun: true,
        };
        let power = |p: &SunSkyParams| {
            let s = SunModel::new(p);
            s.disc_mean() * s.solid_angle()
        };
        let base = power(&p);
        let wide = power(&SunSkyParams {
            sun_half_aperture: 4.0 * SUN_HALF_APERTURE,
            ..p
        });
        assert!(((wide - base) / base).abs().max_element() < 0.02, "{base} vs {wide}");
        let flat = SunModel::new(&SunSkyParams { complex_sun: false, ..p });
        assert_eq!(flat.radiance(p.sun), flat.mean);
        assert!(flat.radiance(Vec3::Z).max_element() == 0.0);
    }
}
