//! Surface detail without geometry: Mitsuba 3's `bumpmap` and `normalmap` adapters,
//! which hand the material they wrap a perturbed shading frame.
//!
//! Both follow Mitsuba 3.9 (`src/bsdfs/bumpmap.cpp`, `normalmap.cpp` and their shared
//! `perturbed_bsdf.h`):
//!
//! * **The perturbed normal**, relative to the surface's own shading frame: a normal
//!   map's texel `c` decoded as `2c − 1` (tangent space: x along the frame's first
//!   tangent, z the shading normal); a bump map's from the uv gradient `(h_u, h_v)` of
//!   its height texture times `scale`: `∂p/∂u' = ∂p/∂u + n (h_u − n·∂p/∂u)` (and the same
//!   for v), normal `∂p/∂u' × ∂p/∂v'`, turned to the geometric normal's side. The
//!   texture-space derivative of the base normal is ignored, so a constant offset of
//!   the heights changes nothing. `∂p/∂u`, `∂p/∂v` come from the mesh's uv per triangle
//!   ([`crate::geometry::interaction::Interaction`]), analytic on spheres.
//! * **Black fringes** (`flip_invalid_normals`, default true): where the viewer lies
//!   below the perturbed normal but above the shading normal, the perturbed normal's
//!   tangential part is mirrored (`(−x, −y, z)`, Schüssler et al. 2017's flip), so the
//!   viewer always sees the front of the frame and no black pixels appear there.
//! * **Light leaks**: a direction counts only when it lies on the same side of the
//!   shading normal and of the perturbed one (in eval, pdf and sample alike), so light
//!   from below the surface never leaks through a strongly tilted normal.
//! * **The bump terminator** (`use_shadowing_function`, default true): every value is
//!   scaled by Estevez et al. 2019's shadowing `2 / (1 + √(1 + α² tan²θ))`, θ the
//!   direction's angle to the shading normal and `α² = min(tan²θₚ / 8, 1)` from the
//!   perturbed normal's tilt θₚ, which softens the hard shadow line of tilted normals.
//!
//! The wrapped material is evaluated in the perturbed frame and, as in Mitsuba, its
//! cosine is the one to the perturbed normal; rdr's integrators weight by the cosine
//! to the interaction's shading normal, so [`Perturbation`] folds in the ratio of the
//! two (a sample's weight needs no change). The frame's first tangent follows
//! Mitsuba's Gram–Schmidt from the base frame's; anisotropic materials inside a bump
//! map therefore turn with rdr's base tangent, which is not Mitsuba's.

use crate::math::{Frame, Vec3};

/// What a bump or normal map leaves on the BSDF it built: the surface's own shading
/// normal `base` (world space) and the shadow-terminator strength `alpha2` (0: off).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perturbation {
    pub base: Vec3,
    pub alpha2: f32,
}

impl Perturbation {
    /// Whether `w` lies on the same side of the base normal and the perturbed normal `np`.
    #[inline]
    pub fn same_side(&self, np: Vec3, w: Vec3) -> bool {
        self.base.dot(w) * np.dot(w) > 0.0
    }

    /// Estevez et al.'s shadowing for a direction whose cosine to the base normal is `c`.
    #[inline]
    fn terminator(&self, c: f32) -> f32 {
        if self.alpha2 == 0.0 {
            return 1.0;
        }
        let c2 = c * c;
        let tan2 = ((1.0 - c2) / c2).max(0.0);
        2.0 / (1.0 + (1.0 + self.alpha2 * tan2).sqrt())
    }

    /// The factor on the wrapped material's f(wo, wi): `None` when `wi` is on different
    /// sides of the two normals; otherwise the cosine ratio |np·wi| / |base·wi| and the
    /// terminator.
    #[inline]
    pub fn eval_factor(&self, np: Vec3, wi: Vec3) -> Option<f32> {
        if !self.same_side(np, wi) {
            return None;
        }
        let cb = self.base.dot(wi);
        Some(np.dot(wi).abs() / cb.abs() * self.terminator(cb))
    }

    /// The factor on a sample's weight (`None`: the sample is dropped).
    #[inline]
    pub fn sample_weight(&self, np: Vec3, wi: Vec3) -> Option<f32> {
        self.same_side(np, wi).then(|| self.terminator(self.base.dot(wi)))
    }
}

/// The options both adapters take (Mitsuba's names).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerturbOptions {
    /// `flip_invalid_normals` (true).
    pub flip_invalid_normals: bool,
    /// `use_shadowing_function` (true).
    pub use_shadowing_function: bool,
}

impl Default for PerturbOptions {
    fn default() -> Self {
        PerturbOptions {
            flip_invalid_normals: true,
            use_shadowing_function: true,
        }
    }
}

/// The surface a BSDF is built at: shading and geometric normals, uv tangents and
/// the direction towards the viewer (all world space).
#[derive(Clone, Copy, Debug)]
pub struct ShadingGeometry {
    pub ns: Vec3,
    pub ng: Vec3,
    pub dpdu: Vec3,
    pub dpdv: Vec3,
    pub wo: Vec3,
}

/// What a bump or normal map perturbs the shading normal with.
#[derive(Clone, Copy, Debug)]
pub enum Detail {
    /// A bump map's height gradient in uv (already times `scale`).
    Heights(glam::Vec2),
    /// A normal map's texel (tangent space, `2c − 1` decoded).
    Normal(Vec3),
}

/// The perturbed frame the wrapped material is evaluated in at `g`, and the
/// [`Perturbation`] that goes with it: the perturbed normal relative to Mitsuba's
/// shading frame at `g` ([`Frame::with_tangent`] of `ns` and `∂p/∂u`), flipped
/// towards the viewer where `opts` asks for it (module docs).
pub fn perturb(g: &ShadingGeometry, detail: Detail, opts: PerturbOptions) -> (Frame, Perturbation) {
    let base = Frame::with_tangent(g.ns, g.dpdu);
    let n = match detail {
        Detail::Heights(grad) => bump_normal(g, &base, grad),
        Detail::Normal(rgb) => decode_normal(rgb),
    };
    perturbed_frame(n, &base, base.to_local(g.wo), opts)
}

/// A bump map's perturbed normal (unnormalised, in `base`'s local coordinates) for the
/// height gradient `grad` (already times `scale`).
fn bump_normal(g: &ShadingGeometry, base: &Frame, grad: glam::Vec2) -> Vec3 {
    let n = g.ns;
    let dpdu = g.dpdu + n * (grad.x - n.dot(g.dpdu));
    let dpdv = g.dpdv + n * (grad.y - n.dot(g.dpdv));
    let mut c = dpdu.cross(dpdv);
    if g.ng.dot(c) < 0.0 {
        c = -c;
    }
    base.to_local(c)
}

/// A normal map's perturbed normal from its texel `rgb`: `2·rgb − 1`.
#[inline]
fn decode_normal(rgb: Vec3) -> Vec3 {
    rgb * 2.0 - Vec3::ONE
}

/// The perturbed frame in world space from the perturbed normal `n` (local to `base`,
/// unnormalised) as seen from `wo_local` (local to `base`), and the
/// [`Perturbation`] that goes with it.
fn perturbed_frame(n: Vec3, base: &Frame, wo_local: Vec3, opts: PerturbOptions) -> (Frame, Perturbation) {
    let mut n = n;
    if opts.flip_invalid_normals && wo_local.z * wo_local.dot(n) <= 0.0 {
        n = Vec3::new(-n.x, -n.y, n.z);
    }
    let len2 = n.length_squared();
    let n = if len2 > 0.0 && len2.is_finite() { n / len2.sqrt() } else { Vec3::Z };
    let s = Vec3::X - n * n.x;
    let sl = s.length_squared();
    let s = if sl > 0.0 && sl.is_finite() { s / sl.sqrt() } else { Vec3::Y };
    let t = n.cross(s);
    let frame = Frame {
        s: base.to_world(s),
        t: base.to_world(t),
        n: base.to_world(n),
    };
    let alpha2 = if opts.use_shadowing_function {
        let c2 = n.z * n.z;
        let tan2 = if c2 > 0.0 { ((1.0 - c2) / c2).max(0.0) } else { f32::INFINITY };
        (0.125 * tan2).min(1.0)
    } else {
        0.0
    };
    (frame, Perturbation { base: base.n, alpha2 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_normal_map_changes_nothing() {
        let base = Frame::from_normal(Vec3::new(0.3, 0.4, 0.866).normalize());
        let wo = Vec3::new(0.1, 0.2, 0.97).normalize();
        let (f, p) = perturbed_frame(decode_normal(Vec3::new(0.5, 0.5, 1.0)), &base, wo, PerturbOptions::default());
        assert!((f.n - base.n).length() < 1e-6);
        assert_eq!(p.alpha2, 0.0);
        let wi = base.to_world(Vec3::new(0.5, 0.1, 0.8).normalize());
        assert!((p.eval_factor(f.n, wi).unwrap() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn tilted_normal_is_flipped_towards_the_viewer() {
        let base = Frame::from_normal(Vec3::Z);
        // tilted towards +x, viewer grazing from −x: below the tilted normal
        let n = Vec3::new(0.9, 0.0, 0.3);
        let wo = Vec3::new(-0.95, 0.0, 0.1).normalize();
        let (f, _) = perturbed_frame(n, &base, wo, PerturbOptions::default());
        assert!(f.n.dot(wo) > 0.0 && f.n.x < 0.0);
        let no_flip = PerturbOptions {
            flip_invalid_normals: false,
            ..Default::default()
        };
        let (f, _) = perturbed_frame(n, &base, wo, no_flip);
        assert!(f.n.dot(wo) < 0.0);
    }
}
