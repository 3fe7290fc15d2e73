//! Rendering profiles. The default is physically based; [`Profile::Rdr171`]
//! (`--compat rdr171`) reproduces the course renderer's reference images bit for
//! bit. Every difference of that profile lives in this module:
//!
//! | what | default | `rdr171` |
//! |---|---|---|
//! | sampler | Owen-scrambled Sobol per pixel | `mt19937`, fresh per image column (§7) |
//! | triangle test | watertight f32 | Möller–Trumbore in f64, ties go to the later object (§14.2) |
//! | point light | `ρ/π·cosθ·Φ/(4π d²)` | `ρ/π·cosθ·Φ·d²/(4π)` in the original's f32 order (§13) |
//! | refraction ratio | 1/η entering (Snell) | η entering (§9.2) |
//! | ray offsets | robust float offset along the normal | `p + 1e-4·n`; shadow rays not offset (§14.5) |
//! | `max_depth` | path segments (Mitsuba) | surface hits |
//! | EXR output | float32 RGB | half B,G,R with tinyexr's rounding (§5.2) |
//! | OBJ re-winding | also re-winds texture coordinates | leaves them (§10.1) |
//! | image rows | `v = 0` is the bottom row (pbrt, Mitsuba, Blender) | `v = 0` is the top row (§8) |
//! | sphere uv | `(φ/2π, θ/π)` | `(θ/π, φ/2π)`, `dpdu`/`dpdv` swapped alike (§10.2) |
//! | image MIP levels | the image as it is, area-averaged levels down to 1×1 | power-of-two level 0 (bilinear resample), levels stop before 1×1 (§8) |
//! | image lookup | repeat wrap, footprint-driven trilinear, level `log2(w·max(W,H))` | `max(W·s − ½, 0)`, unsigned-modulo wrap, level `(levels−1) + log2(w)` (§8) |
//! | ray differentials | camera rays (scaled by `max(1/8, 1/√spp)`), dropped after refraction | none: every lookup on level 0 (§13) |
//!
//! The integrator rows are [`rdr171`] (the column renderer that `--compat rdr171`
//! runs in place of `intersection_test`, see [`crate::render::RenderJob::from_desc`]);
//! the texture rows are one switch, [`crate::desc::BuildOptions::textures`]
//! ([`crate::texture::TextureConvention`]), which [`Profile::build_options`] sets
//! (in `desc/build.rs`, so that this module imports nothing above the integrators);
//! see `src/texture/mipmap.rs`.

pub mod rdr171;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Profile {
    #[default]
    Physical,
    Rdr171,
}
