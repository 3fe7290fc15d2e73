//! Mitsuba 3's `sdfgrid`: a signed distance function sampled on a grid of `res`
//! samples per axis spanning the unit cube (sample `(i, j, k)` at `(i, j, k)/(res − 1)`),
//! placed by `to_world`. Between samples the function is the trilinear interpolant,
//! and the surface is its zero set (Hansson-Söderlund, Evans and Akenine-Möller 2022,
//! "Ray Tracing of Signed Distance Function Grids", JCGT 11(3)).
//!
//! Every voxel whose corners have both signs is one primitive ([`SdfVoxel`]) bounded
//! by its tight box (the box of the corners on the surface and the surface's edge
//! crossings, which bounds the trilinear zero set: each coordinate is monotone along
//! the zero curves of the bilinear faces). The voxels live in index space (a voxel
//! is a unit cube at its lower sample's index); the scene places them as an
//! instance of their own bottom-level tree with [`SdfGrid::index_to_world`]. A ray
//! meets a voxel where the cubic that the interpolant is along it changes sign;
//! the first root is bracketed between the roots of the cubic's derivative and
//! found by safeguarded Newton steps.
//!
//! Normals as Mitsuba's: the geometric normal is the interpolant's gradient; the
//! shading normal (`normals`) the same (`analytic`) or the paper's `smooth` blend of
//! the eight voxel gradients around the nearest sample. No uv (zero), no area, no
//! sampling: Mitsuba's sdfgrid cannot emit.

use super::Aabb;
use crate::math::{Mat4, Vec3};

/// How the shading normal is made (Mitsuba's `normals`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdfNormals {
    /// The paper's blend of the gradients of the voxels around the nearest sample:
    /// continuous across voxels (Mitsuba's default).
    Smooth,
    /// The interpolant's gradient, as the geometric normal.
    Analytic,
}

impl SdfNormals {
    pub fn name(self) -> &'static str {
        match self {
            SdfNormals::Smooth => "smooth",
            SdfNormals::Analytic => "analytic",
        }
    }

    pub fn from_name(name: &str) -> Result<SdfNormals, String> {
        match name {
            "smooth" => Ok(SdfNormals::Smooth),
            "analytic" => Ok(SdfNormals::Analytic),
            other => Err(format!("\"{other}\" is not a normals mode (analytic or smooth)")),
        }
    }
}

/// Samples per axis at most: voxel coordinates are held in 16 bits.
pub const MAX_RES: usize = 1 << 16;

/// A grid, render-ready.
#[derive(Clone, Debug)]
pub struct SdfGrid {
    /// Samples per axis, each at least 2.
    pub res: [usize; 3],
    /// The samples, x fastest, then y, then z; all finite.
    pub values: Vec<f32>,
    /// The unit cube to the world.
    pub to_world: Mat4,
    pub normals: SdfNormals,
}

impl SdfGrid {
    /// A checked grid: at least 2 and at most [`MAX_RES`] samples per axis, as many
    /// values as they ask, all finite, and some voxel with the surface in it
    /// (Mitsuba refuses a grid without one too). The error names what is wrong (the
    /// caller names the file and the key).
    pub fn new(res: [usize; 3], values: Vec<f32>, to_world: Mat4, normals: SdfNormals) -> Result<SdfGrid, String> {
        if res.iter().any(|&n| !(2..=MAX_RES).contains(&n)) {
            return Err(format!(
                "a {}×{}×{} grid (an sdfgrid needs 2 to {MAX_RES} samples per axis)",
                res[0], res[1], res[2]
            ));
        }
        if res.iter().product::<usize>() != values.len() {
            return Err(format!("{} values for a {}×{}×{} grid", values.len(), res[0], res[1], res[2]));
        }
        if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
            let (x, y, z) = (bad % res[0], (bad / res[0]) % res[1], bad / (res[0] * res[1]));
            return Err(format!("sample ({x}, {y}, {z}) holds {} (distances must be finite)", values[bad]));
        }
        let g = SdfGrid {
            res,
            values,
            to_world,
            normals,
        };
        if g.voxels().next().is_none() {
            return Err("no voxel has the surface in it (no sign change between neighbouring samples)".into());
        }
        Ok(g)
    }

    #[inline]
    fn sample(&self, x: usize, y: usize, z: usize) -> f32 {
        self.values[(z * self.res[1] + y) * self.res[0] + x]
    }

    /// The sample at `q`, each coordinate clamped into the grid.
    #[inline]
    fn sample_clamped(&self, q: [i64; 3]) -> f32 {
        let c = |a: usize| q[a].clamp(0, self.res[a] as i64 - 1) as usize;
        self.sample(c(0), c(1), c(2))
    }

    /// The voxels with the surface in them (corners of both signs, or zero).
    pub fn voxels(&self) -> impl Iterator<Item = SdfVoxel> + '_ {
        let [nx, ny, nz] = self.res;
        (0..nz - 1).flat_map(move |z| {
            (0..ny - 1).flat_map(move |y| {
                (0..nx - 1).filter_map(move |x| {
                    let corners = std::array::from_fn(|i| self.sample(x + (i & 1), y + (i >> 1 & 1), z + (i >> 2)));
                    let voxel = SdfVoxel {
                        corners,
                        at: [x as u16, y as u16, z as u16],
                    };
                    voxel.occupied().then_some(voxel)
                })
            })
        })
    }

    /// Index space (sample `(i, j, k)` at `(i, j, k)`) to the world.
    pub fn index_to_world(&self) -> Mat4 {
        let scale = Vec3::new(
            1.0 / (self.res[0] - 1) as f32,
            1.0 / (self.res[1] - 1) as f32,
            1.0 / (self.res[2] - 1) as f32,
        );
        self.to_world * Mat4::from_scale(scale)
    }

    /// The shading normal at `p` (index space) where the geometric normal is `ng`, as
    /// an index-space normal (carried to the world like `ng`, by the inverse transpose
    /// of [`SdfGrid::index_to_world`]).
    pub fn shading_normal(&self, p: Vec3, ng: Vec3) -> Vec3 {
        match self.normals {
            SdfNormals::Analytic => ng,
            SdfNormals::Smooth => {
                // blended in the unit cube's frame, as Mitsuba's; an index-space normal
                // n/r is that frame's n after the scale
                let n = self.smooth_normal(p) / self.steps();
                let l = n.length();
                if l > 0.0 && l.is_finite() {
                    n / l
                } else {
                    ng
                }
            }
        }
    }

    /// `res − 1` per axis.
    fn steps(&self) -> Vec3 {
        Vec3::new((self.res[0] - 1) as f32, (self.res[1] - 1) as f32, (self.res[2] - 1) as f32)
    }

    /// The paper's smooth normal at `p` (index space), in the unit cube's frame (not
    /// normalised): the eight voxels around the sample nearest `p` each give their
    /// gradient, normalised, and these are blended trilinearly by `p`'s position
    /// between the voxels' centres. A voxel's gradient along an axis is the
    /// difference of the interpolant across the voxel along that axis, taken at
    /// `p`'s position along the other two (within the voxel holding `p`); samples
    /// beyond the grid are clamped, and voxels below index 0 take no weight.
    fn smooth_normal(&self, p: Vec3) -> Vec3 {
        let r = self.steps();
        let q = p.to_array();
        let near: [i64; 3] = std::array::from_fn(|a| q[a].round_ties_even() as i64 - 1);
        let cell: [i64; 3] = std::array::from_fn(|a| (q[a].floor() as i64).clamp(0, self.res[a] as i64 - 2));
        let w: [f32; 3] = std::array::from_fn(|a| q[a] - cell[a] as f32);
        // the interpolant on the sample plane `k` across axis `a`, at p along the others
        let plane = |a: usize, k: i64| -> f32 {
            let (b, c) = ((a + 1) % 3, (a + 2) % 3);
            let mut f = [0.0f32; 4];
            for (i, v) in f.iter_mut().enumerate() {
                let mut s = [0i64; 3];
                s[a] = k;
                s[b] = cell[b] + (i & 1) as i64;
                s[c] = cell[c] + (i >> 1) as i64;
                *v = self.sample_clamped(s);
            }
            lerp(lerp(f[0], f[1], w[b]), lerp(f[2], f[3], w[b]), w[c])
        };
        // per axis, the differences of the lower voxel (`low`) and the upper one (`high`)
        let (mut low, mut high) = ([0.0f32; 3], [0.0f32; 3]);
        for a in 0..3 {
            let (g0, g1) = (plane(a, cell[a]), plane(a, cell[a] + 1));
            let across = (g1 - g0) * r[a];
            if cell[a] != near[a] {
                // p's voxel is the upper one; the lower is the one before it
                low[a] = (g0 - plane(a, cell[a] - 1)) * r[a];
                high[a] = across;
            } else {
                low[a] = across;
                high[a] = (plane(a, cell[a] + 2) - g1) * r[a];
            }
        }
        let inside: [bool; 3] = std::array::from_fn(|a| near[a] >= 0);
        let t: [f32; 3] = std::array::from_fn(|a| if inside[a] { q[a] - near[a] as f32 - 0.5 } else { 1.0 });
        let n: [Vec3; 8] = std::array::from_fn(|i| {
            let hi = [i & 1 != 0, i & 2 != 0, i & 4 != 0];
            if (0..3).all(|a| hi[a] || inside[a]) {
                let g = Vec3::from_array(std::array::from_fn(|a| if hi[a] { high[a] } else { low[a] }));
                let l = g.length();
                if l > 0.0 {
                    g / l
                } else {
                    Vec3::ZERO
                }
            } else {
                Vec3::ZERO
            }
        });
        let x = |a: Vec3, b: Vec3| a + (b - a) * t[0];
        let y = |a: Vec3, b: Vec3| a + (b - a) * t[1];
        let z0 = y(x(n[0], n[1]), x(n[2], n[3]));
        let z1 = y(x(n[4], n[5]), x(n[6], n[7]));
        z0 + (z1 - z0) * t[2]
    }
}

#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// One voxel with the surface in it, as the BVH holds it: its corner samples
/// (indexed `x + 2y + 4z` from the lower corner) and its lower sample's index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SdfVoxel {
    pub corners: [f32; 8],
    pub at: [u16; 3],
}

impl SdfVoxel {
    /// Whether the surface passes through it: some corner not negative and some not
    /// positive.
    pub fn occupied(&self) -> bool {
        self.corners.iter().any(|&f| f >= 0.0) && self.corners.iter().any(|&f| f <= 0.0)
    }

    fn origin(&self) -> Vec3 {
        Vec3::new(self.at[0] as f32, self.at[1] as f32, self.at[2] as f32)
    }

    /// The trilinear interpolant at `w` in the voxel's unit cube.
    fn value(&self, w: [f64; 3]) -> f64 {
        let c = self.corners.map(f64::from);
        let l = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let y0 = l(l(c[0], c[1], w[0]), l(c[2], c[3], w[0]), w[1]);
        let y1 = l(l(c[4], c[5], w[0]), l(c[6], c[7], w[0]), w[1]);
        l(y0, y1, w[2])
    }

    /// The interpolant's gradient at `w` in the voxel's unit cube (index space).
    pub fn gradient(&self, w: Vec3) -> Vec3 {
        let c = &self.corners;
        let bl = |f: [f32; 4], u: f32, v: f32| lerp(lerp(f[0], f[1], u), lerp(f[2], f[3], u), v);
        Vec3::new(
            bl([c[1] - c[0], c[3] - c[2], c[5] - c[4], c[7] - c[6]], w.y, w.z),
            bl([c[2] - c[0], c[3] - c[1], c[6] - c[4], c[7] - c[5]], w.x, w.z),
            bl([c[4] - c[0], c[5] - c[1], c[6] - c[2], c[7] - c[3]], w.x, w.y),
        )
    }

    /// The unit geometric normal at `p` (index space, clamped into the voxel): the
    /// gradient's direction, towards positive distances.
    pub fn normal(&self, p: Vec3) -> Vec3 {
        let g = self.gradient((p - self.origin()).clamp(Vec3::ZERO, Vec3::ONE));
        let l = g.length();
        if l > 0.0 && l.is_finite() {
            g / l
        } else {
            Vec3::Z
        }
    }

    /// The tight box (index space) of the surface in the voxel: the corners on it and
    /// the points where it crosses an edge, padded for the rounding of the ray's
    /// transform and box tests.
    pub fn bounds(&self) -> Aabb {
        let c = &self.corners;
        let corner = |i: usize| Vec3::new((i & 1) as f32, (i >> 1 & 1) as f32, (i >> 2) as f32);
        let mut b = Aabb::EMPTY;
        for i in 0..8 {
            if c[i] == 0.0 {
                b = b.union(Aabb::new(corner(i), corner(i)));
            }
            for axis in 0..3 {
                let j = i | 1 << axis;
                if i & 1 << axis != 0 || !(c[i] * c[j] <= 0.0 && c[i] != c[j]) {
                    continue;
                }
                let mut p = corner(i);
                p[axis] = (c[i] / (c[i] - c[j])).clamp(0.0, 1.0);
                b = b.union(Aabb::new(p, p));
            }
        }
        let o = self.origin();
        let pad = Vec3::splat(1e-3 + o.max_element() * 4.0 * f32::EPSILON);
        Aabb::new(o + b.min - pad, o + b.max + pad)
    }

    /// The first `t` in `[t_min, t_max]` where the ray (index space, `d` not
    /// necessarily unit) meets the surface in this voxel: the trilinear interpolant
    /// along the ray is a cubic in `t` whose first sign change is found.
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let o = (o - self.origin()).as_dvec3().to_array();
        let d = d.as_dvec3().to_array();
        // the part of the ray in the voxel, and the faces it enters and leaves by
        let (mut t0, mut t1) = (t_min as f64, t_max as f64);
        let (mut enter, mut leave) = (None, None);
        for a in 0..3 {
            if d[a] == 0.0 {
                if !(0.0..=1.0).contains(&o[a]) {
                    return None;
                }
                continue;
            }
            let (mut near, mut far) = (-o[a] / d[a], (1.0 - o[a]) / d[a]);
            if near > far {
                std::mem::swap(&mut near, &mut far);
            }
            if near > t0 {
                (t0, enter) = (near, Some(a));
            }
            if far < t1 {
                (t1, leave) = (far, Some(a));
            }
        }
        if t0.is_nan() || t1.is_nan() || t0 > t1 {
            return None;
        }
        // the distances where it enters and leaves, on a crossed face with that
        // face's coordinate exact, so that two neighbours agree on their shared face
        let point = |t: f64, face: Option<usize>, entering: bool| -> [f64; 3] {
            let mut p: [f64; 3] = std::array::from_fn(|a| (o[a] + d[a] * t).clamp(0.0, 1.0));
            if let Some(a) = face {
                p[a] = if (d[a] > 0.0) == entering { 0.0 } else { 1.0 };
            }
            p
        };
        let start = point(t0, enter, true);
        let (f_start, f_end) = (self.value(start), self.value(point(t1, leave, false)));
        let cubic = self.cubic(start, d);
        let s = first_root(&cubic, t1 - t0, f_start, f_end)?;
        let t = (t0 + s) as f32;
        (t >= t_min && t <= t_max).then_some(t)
    }

    /// The interpolant along `p + s·d` as `c0 + c1 s + c2 s² + c3 s³`.
    fn cubic(&self, p: [f64; 3], d: [f64; 3]) -> [f64; 4] {
        let c = self.corners.map(f64::from);
        // f = k0 + kx x + ky y + kz z + kxy xy + kxz xz + kyz yz + kxyz xyz
        let kx = c[1] - c[0];
        let ky = c[2] - c[0];
        let kz = c[4] - c[0];
        let kxy = c[3] - c[2] - kx;
        let kxz = c[5] - c[4] - kx;
        let kyz = c[6] - c[4] - ky;
        let kxyz = (c[7] - c[6]) - (c[5] - c[4]) - kxy;
        let [x, y, z] = p;
        let [dx, dy, dz] = d;
        let c0 = self.value(p);
        let c1 = dx * (kx + kxy * y + kxz * z + kxyz * y * z)
            + dy * (ky + kxy * x + kyz * z + kxyz * x * z)
            + dz * (kz + kxz * x + kyz * y + kxyz * x * y);
        let c2 = kxy * dx * dy + kxz * dx * dz + kyz * dy * dz + kxyz * (dx * dy * z + dx * y * dz + x * dy * dz);
        let c3 = kxyz * dx * dy * dz;
        [c0, c1, c2, c3]
    }
}

/// The first root of the cubic `c` on `[0, len]` (its values there `f0`, `f1`): the
/// interval is cut at the derivative's roots into monotone pieces, the first piece
/// whose ends differ in sign (or touch zero) holds it, and safeguarded Newton steps
/// (bisection when a step leaves the bracket) find it.
fn first_root(c: &[f64; 4], len: f64, f0: f64, f1: f64) -> Option<f64> {
    let eval = |s: f64| ((c[3] * s + c[2]) * s + c[1]) * s + c[0];
    let slope = |s: f64| (3.0 * c[3] * s + 2.0 * c[2]) * s + c[1];
    // NaN (no root) fails the filter below
    let cuts = derivative_roots(c);
    let (mut a, mut fa) = (0.0, f0);
    let mut bracket = None;
    for s in cuts.into_iter().filter(|&s| s > 0.0 && s < len).chain([len]) {
        let fs = if s == len { f1 } else { eval(s) };
        if fa * fs <= 0.0 {
            bracket = Some((s, fs));
            break;
        }
        (a, fa) = (s, fs);
    }
    let (mut b, fb) = bracket?;
    if fa == 0.0 {
        return Some(a);
    }
    if fb == 0.0 && b == len {
        return Some(b);
    }
    let mut s = a + (b - a) * (fa / (fa - fb));
    if !(s >= a && s <= b) {
        s = 0.5 * (a + b);
    }
    for _ in 0..64 {
        let fs = eval(s);
        if fs == 0.0 {
            return Some(s);
        }
        if (fs > 0.0) == (fa > 0.0) {
            a = s;
        } else {
            b = s;
        }
        let mut next = s - fs / slope(s);
        if !(next > a && next < b) {
            next = 0.5 * (a + b);
        }
        let step = (next - s).abs();
        s = next;
        if step <= 1e-12 * (1.0 + s.abs()) || b - a <= 1e-12 * (1.0 + s.abs()) {
            break;
        }
    }
    Some(s)
}

/// The real roots of the cubic's derivative `3c3 s² + 2c2 s + c1`, ascending, NaN
/// where there is none (none, one or two; an array, as this runs per voxel hit test).
fn derivative_roots(c: &[f64; 4]) -> [f64; 2] {
    let (qa, qb, qc) = (3.0 * c[3], 2.0 * c[2], c[1]);
    if qa == 0.0 {
        return [if qb != 0.0 { -qc / qb } else { f64::NAN }, f64::NAN];
    }
    let disc = qb * qb - 4.0 * qa * qc;
    if disc < 0.0 {
        return [f64::NAN; 2];
    }
    let q = -0.5 * (qb + disc.sqrt().copysign(qb));
    if q == 0.0 {
        return [0.0, f64::NAN];
    }
    let (r0, r1) = (q / qa, qc / q);
    if r0 <= r1 {
        [r0, r1]
    } else {
        [r1, r0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere_grid(n: usize, r: f32) -> SdfGrid {
        let mut v = Vec::with_capacity(n * n * n);
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let p = Vec3::new(x as f32, y as f32, z as f32) / (n - 1) as f32 - Vec3::splat(0.5);
                    v.push(p.length() - r);
                }
            }
        }
        SdfGrid::new([n, n, n], v, Mat4::IDENTITY, SdfNormals::Smooth).unwrap()
    }

    #[test]
    fn a_ray_through_the_centre_meets_the_sphere_at_its_radius() {
        let g = sphere_grid(17, 0.3);
        // index space: the sphere's centre at 8, radius 0.3·16 = 4.8
        let o = Vec3::new(8.0, 8.0, -3.0);
        let hits: Vec<f32> = g.voxels().filter_map(|v| v.intersect(o, Vec3::Z, 0.0, 1e9)).collect();
        let first = hits.iter().copied().fold(f32::INFINITY, f32::min);
        assert!((first - (3.0 + 8.0 - 4.8)).abs() < 1e-3, "{first}");
        let v = g.voxels().find(|v| v.intersect(o, Vec3::Z, 0.0, 1e9) == Some(first)).unwrap();
        // on a voxel edge: the gradient of one of the four voxels, the blend symmetric
        let n = v.normal(o + Vec3::Z * first);
        assert!(n.dot(-Vec3::Z) > 0.97, "{n}");
        let s = g.shading_normal(o + Vec3::Z * first, n);
        assert!((s - -Vec3::Z).length() < 1e-3, "{s}");
    }

    /// The voxel with lower sample `at`, made from the grid's samples.
    fn voxel_at(g: &SdfGrid, at: [usize; 3]) -> SdfVoxel {
        SdfVoxel {
            corners: std::array::from_fn(|i| g.sample(at[0] + (i & 1), at[1] + (i >> 1 & 1), at[2] + (i >> 2))),
            at: at.map(|c| c as u16),
        }
    }

    /// The paper's smooth normal is continuous across voxel faces (the gradient, the
    /// analytic normal, jumps there): on either side of every inner face of the
    /// voxels with the surface, a bumpy grid with a different count per axis.
    #[test]
    fn smooth_normals_are_continuous_across_voxel_faces() {
        let res = [7usize, 5, 6];
        let mut v = Vec::new();
        for z in 0..res[2] {
            for y in 0..res[1] {
                for x in 0..res[0] {
                    let p = Vec3::new(x as f32 / 6.0, y as f32 / 4.0, z as f32 / 5.0);
                    v.push((p - Vec3::splat(0.5)).length() - 0.3 + 0.05 * (9.0 * p.x).sin() * (7.0 * p.y).cos());
                }
            }
        }
        let g = SdfGrid::new(res, v, Mat4::from_scale(Vec3::new(1.0, 2.0, 0.5)), SdfNormals::Smooth).unwrap();
        let (mut smooth, mut analytic, mut faces) = (0.0f32, 0.0f32, 0);
        for low in g.voxels() {
            for a in 0..3 {
                let at = low.at.map(usize::from);
                if at[a] + 2 >= res[a] {
                    continue;
                }
                let mut next = at;
                next[a] += 1;
                let high = voxel_at(&g, next);
                let mut p = low.origin() + Vec3::new(0.3, 0.6, 0.45);
                p[a] = (at[a] + 1) as f32;
                let e = Vec3::from_array(std::array::from_fn(|i| if i == a { 1e-4 } else { 0.0 }));
                let (below, above) = (low.normal(p - e), high.normal(p + e));
                analytic = analytic.max((below - above).length());
                let (sb, sa) = (g.shading_normal(p - e, below), g.shading_normal(p + e, above));
                smooth = smooth.max((sb - sa).length());
                faces += 1;
            }
        }
        println!("{faces} faces: smooth normals jump by {smooth:.1e} at most, analytic ones by {analytic:.2}");
        assert!(faces > 20 && analytic > 0.05, "the grid must make the gradient jump");
        assert!(smooth < 2e-3, "smooth normals jump by {smooth} across a face");
    }

    #[test]
    fn bad_grids_are_refused() {
        assert!(SdfGrid::new([1, 2, 2], vec![1.0; 4], Mat4::IDENTITY, SdfNormals::Smooth).is_err());
        assert!(SdfGrid::new([2, 2, 2], vec![1.0; 8], Mat4::IDENTITY, SdfNormals::Smooth).is_err());
        let mut v = vec![1.0; 8];
        v[0] = -1.0;
        assert!(SdfGrid::new([2, 2, 2], v.clone(), Mat4::IDENTITY, SdfNormals::Smooth).is_ok());
        v[3] = f32::NAN;
        let e = SdfGrid::new([2, 2, 2], v, Mat4::IDENTITY, SdfNormals::Smooth).unwrap_err();
        assert!(e.contains("(1, 1, 0)"), "{e}");
    }
}
