//! Sphere shape (spec §10.2): f64 stable quadratic, hit point re-projected.

use crate::math::{Vec2, Vec3, PI};

#[derive(Clone, Copy, Debug)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    /// Mitsuba's parameterisation (XML spheres, JSON `uv_frame`): the rotation (a unit
    /// quaternion, x y z w) from the sphere's object frame, whose z is the pole, to the
    /// world; uv is then `(φ/2π, 1 − θ/π)` in that frame, Mitsuba's `(φ/2π, θ/π)` in
    /// rdr's v orientation (as a mesh's), so textures show as in Mitsuba. `None`:
    /// RDR171's `(φ/2π, θ/π)` about the world's z ([`Sphere::uv`]).
    pub uv_frame: Option<[f32; 4]>,
}

impl Sphere {
    /// A sphere with RDR171's parameterisation.
    pub fn new(center: Vec3, radius: f32) -> Sphere {
        Sphere {
            center,
            radius,
            uv_frame: None,
        }
    }

    /// Texture coordinates and `∂p/∂u`, `∂p/∂v` at the point with outward normal `n`,
    /// in the sphere's own parameterisation ([`Sphere::uv_frame`]).
    pub fn uv_and_derivatives(&self, n: Vec3) -> (Vec2, (Vec3, Vec3)) {
        match self.uv_frame {
            None => (self.uv(n), self.uv_derivatives(n)),
            Some(q) => {
                let q = glam::Quat::from_array(q);
                let local = q.inverse() * n;
                let (uv, (dpdu, dpdv)) = (self.uv(local), self.uv_derivatives(local));
                (Vec2::new(uv.x, 1.0 - uv.y), (q * dpdu, -(q * dpdv)))
            }
        }
    }

    /// Distance to the nearest hit in `[t_min, t_max]`; tangent rays miss.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let quadratic = self.quadratic(o, d);
        // one ray alone stops here when it misses (most of a scene's spheres)
        if quadratic.disc <= 0.0 {
            return None;
        }
        let t = quadratic.hit_distance(t_min, t_max);
        (!t.is_nan()).then_some(t)
    }

    /// [`Sphere::intersect`] of `L` rays given by axis (`o[axis][lane]`), NaN where
    /// a ray misses: each lane's bits as one call gives them (a loop without
    /// branches, which vectorizes).
    #[inline(always)]
    pub fn intersect_lanes<const L: usize>(&self, o: &[[f32; L]; 3], d: &[[f32; L]; 3], t_min: &[f32; L], t_max: &[f32; L]) -> [f32; L] {
        let mut t = [0.0; L];
        for i in 0..L {
            let at = |v: &[[f32; L]; 3]| Vec3::new(v[0][i], v[1][i], v[2][i]);
            t[i] = self.quadratic(at(o), at(d)).hit_distance(t_min[i], t_max[i]);
        }
        t
    }

    /// The ray's quadratic along its normalised direction (f64).
    #[inline(always)]
    fn quadratic(&self, o: Vec3, d: Vec3) -> Quadratic {
        let dd = d.as_dvec3();
        // the length once for both uses (the same value `dd.length()` gives twice)
        let len = dd.length();
        let dd = dd / len;
        let oc = (o - self.center).as_dvec3();
        let r = self.radius as f64;
        let b = 2.0 * dd.dot(oc);
        let c = oc.dot(oc) - r * r;
        Quadratic {
            len,
            b,
            c,
            disc: b * b - 4.0 * c,
        }
    }

    /// Point on the surface nearest to `p`, and the outward normal there.
    pub fn project(&self, p: Vec3) -> (Vec3, Vec3) {
        let mut v = p - self.center;
        if v.x == 0.0 && v.z == 0.0 {
            v.x = 1e-8 * self.radius; // at the poles keep the parameterisation defined
        }
        let n = v / v.length();
        (self.center + n * self.radius, n)
    }

    /// Texture coordinates: `u = φ/2π`, `v = θ/π` with the local z as the polar axis.
    pub fn uv(&self, n: Vec3) -> Vec2 {
        let mut phi = n.y.atan2(n.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let theta = n.z.clamp(-1.0, 1.0).acos();
        Vec2::new(phi / (2.0 * PI), theta / PI)
    }

    /// `∂p/∂u`, `∂p/∂v` of [`Sphere::uv`] at the point with outward normal `n`:
    /// `2π·(−y, x, 0)` and `π·(z·x/ρ, z·y/ρ, −ρ)` with `(x, y, z) = r·n`, `ρ = √(x² + y²)`.
    /// At the poles (`ρ = 0`) `∂p/∂v` is zero and so is `∂p/∂u`; callers fall back to
    /// an arbitrary frame.
    pub fn uv_derivatives(&self, n: Vec3) -> (Vec3, Vec3) {
        let p = n * self.radius;
        let rho = (p.x * p.x + p.y * p.y).sqrt();
        let dpdu = Vec3::new(-p.y, p.x, 0.0) * (2.0 * PI);
        let dpdv = if rho > 0.0 {
            Vec3::new(p.z * p.x / rho, p.z * p.y / rho, -rho) * PI
        } else {
            Vec3::ZERO
        };
        (dpdu, dpdv)
    }

    pub fn area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }
}

/// `t² + b·t + c = 0` of a ray and a sphere, `t` along the ray's normalised direction
/// (its length `len`), and the discriminant.
struct Quadratic {
    len: f64,
    b: f64,
    c: f64,
    disc: f64,
}

impl Quadratic {
    /// The nearest root in `[t_min, t_max]` on the ray's own scale, NaN for none: the
    /// stable form, without branches (every case computed, then selected).
    #[inline(always)]
    fn hit_distance(&self, t_min: f32, t_max: f32) -> f32 {
        let Quadratic { len, b, c, disc } = *self;
        let sq = disc.sqrt();
        let q = if b >= 0.0 { -b - sq } else { sq - b };
        let (near, far) = (q / 2.0, 2.0 * c / q);
        let (t1, t2) = if near > far { (far, near) } else { (near, far) };
        // distances are along the normalised direction; rescale to the ray's own
        let scale = 1.0 / len;
        let (t1, t2) = (t1 * scale, t2 * scale);
        let (lo, hi) = (t_min as f64, t_max as f64);
        let (first, second) = (t1 >= lo && t1 <= hi, t2 >= lo && t2 <= hi);
        let t = if first { t1 } else { t2 } as f32;
        // tangent rays (and a NaN discriminant, whose distances are NaN) miss
        if disc > 0.0 && (first || second) {
            t
        } else {
            f32::NAN
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_from_outside_and_inside() {
        let s = Sphere::new(Vec3::new(0.0, 0.0, -5.0), 1.0);
        assert!((s.intersect(Vec3::ZERO, -Vec3::Z, 1e-4, 1e7).unwrap() - 4.0).abs() < 1e-5);
        assert!((s.intersect(Vec3::new(0.0, 0.0, -5.0), Vec3::X, 1e-4, 1e7).unwrap() - 1.0).abs() < 1e-6);
        assert!(s.intersect(Vec3::ZERO, Vec3::Z, 1e-4, 1e7).is_none());
        assert!(s.intersect(Vec3::new(1.0, 0.0, 0.0), -Vec3::Z, 1e-4, 1e7).is_none(), "tangent");
        // unnormalised direction: t is in the ray's own units
        assert!((s.intersect(Vec3::ZERO, -Vec3::Z * 2.0, 1e-4, 1e7).unwrap() - 2.0).abs() < 1e-5);
    }

    #[test]
    fn uv_derivatives_match_finite_differences() {
        let s = Sphere::new(Vec3::new(1.0, -2.0, 0.5), 2.0);
        // p(u, v) on the sphere, inverse of `uv`
        let at = |u: f32, v: f32| {
            let (phi, theta) = (u * 2.0 * PI, v * PI);
            Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
        };
        for (u, v) in [(0.1, 0.3), (0.6, 0.7), (0.9, 0.45)] {
            let n = at(u, v);
            let uv = s.uv(n);
            assert!((uv - Vec2::new(u, v)).length() < 1e-5);
            let (dpdu, dpdv) = s.uv_derivatives(n);
            let h = 1e-3;
            let fu = (at(u + h, v) - at(u - h, v)) * (s.radius / (2.0 * h));
            let fv = (at(u, v + h) - at(u, v - h)) * (s.radius / (2.0 * h));
            assert!((dpdu - fu).length() < 1e-2 * fu.length(), "{dpdu} {fu}");
            assert!((dpdv - fv).length() < 1e-2 * fv.length(), "{dpdv} {fv}");
        }
    }
}
