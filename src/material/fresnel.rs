//! Fresnel reflectance (unpolarised light).

use crate::math::Vec3;

/// Dielectric Fresnel for a ray arriving with `cos_i` (positive on the side the
/// normal points to) at an interface with relative index `eta` (inside/outside).
/// Returns `(F, cos_t, eta_ti)`: reflectance, the signed cosine of the refracted
/// direction (0 on total internal reflection) and the ratio incident/transmitted
/// index, as Mitsuba's `fresnel()`.
pub fn dielectric(cos_i: f32, eta: f32) -> (f32, f32, f32) {
    let outside = cos_i >= 0.0;
    let (eta_it, eta_ti) = if outside { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    let cos_t2 = 1.0 - eta_ti * eta_ti * (1.0 - cos_i * cos_i);
    let ci = cos_i.abs();
    let ct = cos_t2.max(0.0).sqrt();
    let f = if eta == 1.0 {
        0.0
    } else if ci == 0.0 {
        1.0
    } else {
        let a_s = (eta_it * ct - ci) / (eta_it * ct + ci);
        let a_p = (eta_it * ci - ct) / (eta_it * ci + ct);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    let cos_t = if cos_t2 <= 0.0 { 0.0 } else { -cos_i.signum() * ct };
    (if cos_t2 <= 0.0 { 1.0 } else { f }, cos_t, eta_ti)
}

/// Conductor Fresnel with complex index `eta + i·k` (relative to the outside),
/// per channel (pbrt-v3 `FrConductor`, the same formula as Mitsuba).
pub fn conductor(cos_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let c = cos_i.clamp(-1.0, 1.0);
    let one = |eta: f32, k: f32| {
        let cos2 = c * c;
        let sin2 = 1.0 - cos2;
        let (eta2, k2) = (eta * eta, k * k);
        let t0 = eta2 - k2 - sin2;
        let a2b2 = (t0 * t0 + 4.0 * eta2 * k2).max(0.0).sqrt();
        let t1 = a2b2 + cos2;
        let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
        let t2 = 2.0 * c * a;
        let rs = (t1 - t2) / (t1 + t2);
        let t3 = cos2 * a2b2 + sin2 * sin2;
        let t4 = t2 * sin2;
        let rp = rs * (t3 - t4) / (t3 + t4);
        0.5 * (rp + rs)
    };
    Vec3::new(one(eta.x, k.x), one(eta.y, k.y), one(eta.z, k.z))
}

/// Hemispherical average of the dielectric Fresnel reflectance for relative index
/// `eta` (light arriving from the side of index 1), the `fdr` of Mitsuba's `plastic`:
/// Egan & Hilgeman's fit for `eta` < 1, d'Eon & Irving's polynomial in 1/η otherwise
/// (the same choice of fits as Mitsuba's `fresnel_diffuse_reflectance`).
pub fn diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        // Horner in 1/η, highest power first
        let c = [-1.36881, 4.98554, -7.80989, 6.75335, -3.4793, 0.919317];
        c.iter().fold(0.0f32, |acc, &k| acc * inv + k)
    }
}

/// Reflectance of a thin dielectric slab with both faces at relative index `eta`
/// (Mitsuba's `thindielectric`): one interface reflects `R`, and light bouncing
/// inside adds `R(1−R)²/(1−R²)`, so the slab reflects 2R/(1+R) and transmits the rest.
pub fn thin_dielectric(cos_i: f32, eta: f32) -> f32 {
    let r = dielectric(cos_i.abs(), eta).0;
    if r < 1.0 {
        2.0 * r / (1.0 + r)
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_limits() {
        let (f, ct, _) = dielectric(1.0, 1.5);
        assert!(
            (f - 0.04).abs() < 1e-6 && (ct + 1.0).abs() < 1e-6,
            "normal incidence: ((1.5−1)/(1.5+1))²"
        );
        assert!(dielectric(0.1, 1.5).0 < 1.0);
        let (f, ct, _) = dielectric(-0.2, 1.5); // from inside at a grazing angle: TIR
        assert_eq!((f, ct), (1.0, 0.0));
        assert_eq!(dielectric(0.5, 1.0).0, 0.0);
    }

    #[test]
    fn conductor_matches_dielectric_without_absorption_and_goes_to_one_at_grazing() {
        for c in [0.1f32, 0.5, 0.9] {
            let fc = conductor(c, Vec3::splat(1.5), Vec3::ZERO).x;
            assert!((fc - dielectric(c, 1.5).0).abs() < 1e-5);
        }
        assert!(conductor(1e-4, Vec3::splat(0.2), Vec3::splat(3.9)).x > 0.99);
    }
}
