//! Open cylinder (Mitsuba 3's `cylinder`): the points at distance `radius` from the
//! segment `p0`–`p1`, no caps. Intersected in f64 in the world frame; texture
//! coordinates as Mitsuba's: `u = φ/2π` around the axis (from the frame's `x`
//! towards `axis × x`), `v` = height along the axis from `p0` (0) to `p1` (1).

use crate::math::{Vec2, Vec3, PI};

/// The cylinder as the BVH holds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    /// Centre of the `v = 0` rim.
    pub p0: Vec3,
    /// `p1 − p0`: the axis, its length the height.
    pub axis: Vec3,
    /// Unit vector perpendicular to the axis where `u = 0`.
    pub x: Vec3,
    pub radius: f32,
}

/// A cylinder object: the shape and whether its normals point inwards (`flip_normals`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CylinderShape {
    pub cylinder: Cylinder,
    pub flip_normals: bool,
}

/// Mitsuba's frame around a unit normal (Duff et al. 2017): `(s, t)` with `s × t = n`.
pub fn mitsuba_frame(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

impl Cylinder {
    /// Mitsuba's cylinder from `p0` to `p1` of `radius` before any `to_world`: the
    /// `u = 0` direction is the first vector of [`mitsuba_frame`] of the axis.
    /// `None` when `p0 = p1` or the radius is not positive.
    pub fn new(p0: Vec3, p1: Vec3, radius: f32) -> Option<Cylinder> {
        let axis = p1 - p0;
        let l = axis.length();
        if !(l > 0.0 && l.is_finite() && radius > 0.0 && radius.is_finite()) {
            return None;
        }
        let (x, _) = mitsuba_frame(axis / l);
        Some(Cylinder { p0, axis, x, radius })
    }

    /// The unit axis and the `u = 1/4` direction (`axis × x`).
    #[inline]
    pub fn frame(&self) -> (Vec3, Vec3) {
        let a = self.axis.normalize();
        (a, a.cross(self.x))
    }

    /// Distance to the nearest hit in `[t_min, t_max]` (of the ray's own
    /// parameter, `d` need not be unit); rays parallel to the axis and tangent
    /// rays miss.
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let len = self.axis.as_dvec3().length();
        let a = self.axis.as_dvec3() / len;
        let oc = (o - self.p0).as_dvec3();
        let dd = d.as_dvec3();
        let d_perp = dd - a * dd.dot(a);
        let o_perp = oc - a * oc.dot(a);
        let qa = d_perp.dot(d_perp);
        if qa <= 0.0 {
            return None;
        }
        let r = self.radius as f64;
        let qb = 2.0 * o_perp.dot(d_perp);
        let qc = o_perp.dot(o_perp) - r * r;
        let disc = qb * qb - 4.0 * qa * qc;
        if disc <= 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        let q = if qb >= 0.0 { -0.5 * (qb + sq) } else { -0.5 * (qb - sq) };
        let (mut t1, mut t2) = (q / qa, qc / q);
        if t1 > t2 {
            std::mem::swap(&mut t1, &mut t2);
        }
        let (lo, hi) = (t_min as f64, t_max as f64);
        for t in [t1, t2] {
            if t >= lo && t <= hi {
                let z = (oc + dd * t).dot(a);
                if (0.0..=len).contains(&z) {
                    return Some(t as f32);
                }
            }
        }
        None
    }

    /// The surface point nearest `p` (re-projected onto the radius), its outward
    /// normal, uv and `∂p/∂u`, `∂p/∂v`.
    pub fn surface(&self, p: Vec3) -> (Vec3, Vec3, Vec2, Vec3, Vec3) {
        let (a, y) = self.frame();
        let rel = p - self.p0;
        let z = rel.dot(a);
        let (cx, cy) = (rel.dot(self.x), rel.dot(y));
        let mut phi = cy.atan2(cx);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let (s, c) = phi.sin_cos();
        let n = self.x * c + y * s;
        let pos = self.p0 + a * z + n * self.radius;
        let len = self.axis.length();
        let uv = Vec2::new(phi / (2.0 * PI), z / len);
        let dpdu = (y * c - self.x * s) * (2.0 * PI * self.radius);
        (pos, n, uv, dpdu, self.axis)
    }

    /// The point at `uv` and its outward normal (inverse of [`Cylinder::surface`]).
    pub fn at(&self, uv: Vec2) -> (Vec3, Vec3) {
        let (a, y) = self.frame();
        let (s, c) = (uv.x * 2.0 * PI).sin_cos();
        let n = self.x * c + y * s;
        (self.p0 + a * (uv.y * self.axis.length()) + n * self.radius, n)
    }

    pub fn area(&self) -> f32 {
        2.0 * PI * self.radius * self.axis.length()
    }

    /// Conservative bounds: the two rims' boxes, padded.
    pub fn bounds(&self) -> super::Aabb {
        let a = self.axis.normalize();
        // a rim's extent along each world axis is r·sqrt(1 − a_i²)
        let e = Vec3::new(
            (1.0 - a.x * a.x).max(0.0).sqrt(),
            (1.0 - a.y * a.y).max(0.0).sqrt(),
            (1.0 - a.z * a.z).max(0.0).sqrt(),
        ) * self.radius;
        let p1 = self.p0 + self.axis;
        let pad = Vec3::splat((self.radius + self.axis.length()) * 1e-6 + 1e-6) + e * 1e-6;
        super::Aabb::new(self.p0.min(p1) - e - pad, self.p0.max(p1) + e + pad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_outside_inside_and_open_ends() {
        let c = Cylinder::new(Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0), 1.0).unwrap();
        // from outside, towards the axis: the near wall
        let t = c.intersect(Vec3::new(-3.0, 0.0, 1.0), Vec3::X, 0.0, 1e9).unwrap();
        assert!((t - 2.0).abs() < 1e-6);
        // from inside: the far wall
        let t = c.intersect(Vec3::new(0.0, 0.0, 1.0), Vec3::X, 0.0, 1e9).unwrap();
        assert!((t - 1.0).abs() < 1e-6);
        // along the axis and beyond the ends: misses
        assert!(c.intersect(Vec3::new(0.0, 0.0, -1.0), Vec3::Z, 0.0, 1e9).is_none());
        assert!(c.intersect(Vec3::new(-3.0, 0.0, 2.5), Vec3::X, 0.0, 1e9).is_none());
        // through an open end, hitting the inside of the far wall
        let d = Vec3::new(1.0, 0.0, -1.0).normalize();
        let t = c.intersect(Vec3::new(0.0, 0.0, 2.5), d, 0.0, 1e9).unwrap();
        let p = Vec3::new(0.0, 0.0, 2.5) + d * t;
        assert!((p.x - 1.0).abs() < 1e-5 && (p.z - 1.5).abs() < 1e-5, "{p}");
        // unnormalised direction: t in the ray's units
        let t = c.intersect(Vec3::new(-3.0, 0.0, 1.0), Vec3::X * 2.0, 0.0, 1e9).unwrap();
        assert!((t - 1.0).abs() < 1e-6);
    }

    #[test]
    fn uv_round_trip_and_derivatives() {
        let c = Cylinder::new(Vec3::new(1.0, 2.0, 3.0), Vec3::new(2.0, 0.5, 4.0), 0.7).unwrap();
        for (u, v) in [(0.1f32, 0.2f32), (0.6, 0.9), (0.95, 0.5)] {
            let (p, n) = c.at(Vec2::new(u, v));
            let (q, m, uv, dpdu, dpdv) = c.surface(p);
            assert!((q - p).length() < 1e-5 && (m - n).length() < 1e-5);
            assert!((uv - Vec2::new(u, v)).length() < 1e-5, "{uv}");
            let h = 1e-3;
            let fu = (c.at(Vec2::new(u + h, v)).0 - c.at(Vec2::new(u - h, v)).0) / (2.0 * h);
            let fv = (c.at(Vec2::new(u, v + h)).0 - c.at(Vec2::new(u, v - h)).0) / (2.0 * h);
            assert!((dpdu - fu).length() < 1e-2 * fu.length(), "{dpdu} {fu}");
            assert!((dpdv - fv).length() < 1e-2 * fv.length(), "{dpdv} {fv}");
            // outward, and (dpdu × dpdv) along it as in Mitsuba
            assert!(dpdu.cross(dpdv).dot(n) > 0.0);
        }
        let b = c.bounds();
        for i in 0..100 {
            let (p, _) = c.at(Vec2::new(i as f32 / 100.0, (i % 7) as f32 / 6.0));
            assert!(p.cmpge(b.min).all() && p.cmple(b.max).all(), "{p}");
        }
    }
}
