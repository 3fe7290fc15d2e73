//! Textures (spec §8): a closed family evaluated at texture coordinates with their
//! screen-space derivatives ([`TexCoord`]).
//!
//! * [`Texture::Constant`], [`Texture::Checkerboard`]: no filtering (the derivatives
//!   are ignored).
//! * [`Texture::Image`]: a picture file with a MIP pyramid, trilinear lookups driven by
//!   the derivatives ([`image`], [`mipmap`]). How rows map to `v` and how texels are
//!   looked up depends on the [`TextureConvention`] the scene was built with.

pub mod image;
pub mod mipmap;

use crate::math::{Vec2, Vec3};
use crate::scene::desc::UvMappingDesc;
pub use image::ImageTexture;
pub use mipmap::MipMap;

/// Texture-space conventions; the default is [`TextureConvention::Physical`], the
/// `--compat rdr171` profile selects [`TextureConvention::Rdr171`] (see the table in
/// [`crate::compat`] and [`mipmap`] for the details).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TextureConvention {
    /// As pbrt, Mitsuba and Blender: `v = 0` is the **bottom** row of an image; sphere
    /// `uv = (φ/2π, θ/π)`; area-averaged MIP levels of the image as it is, repeat
    /// wrapping, footprint-driven trilinear filtering.
    #[default]
    Physical,
    /// The original's: `v = 0` is the **top** row; sphere `uv = (θ/π, φ/2π)`; power-of-two
    /// level 0, `max(W·s − ½, 0)` clamping, unsigned-modulo wrap, its level formula.
    Rdr171,
}

/// A shading point's texture coordinates `uv` and their screen-space derivatives
/// (zero when the ray carries no differentials: then image textures use their
/// finest level).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TexCoord {
    pub uv: Vec2,
    pub duvdx: Vec2,
    pub duvdy: Vec2,
}

impl TexCoord {
    /// Coordinates without a footprint.
    #[inline]
    pub fn at(uv: Vec2) -> TexCoord {
        TexCoord {
            uv,
            duvdx: Vec2::ZERO,
            duvdy: Vec2::ZERO,
        }
    }
}

impl From<Vec2> for TexCoord {
    #[inline]
    fn from(uv: Vec2) -> TexCoord {
        TexCoord::at(uv)
    }
}

/// `st = scale ⊙ uv + delta`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvMapping {
    pub scale: Vec2,
    pub delta: Vec2,
}

impl UvMapping {
    pub fn new(d: &UvMappingDesc) -> Self {
        UvMapping {
            scale: d.scale,
            delta: d.delta,
        }
    }
    #[inline]
    pub fn map(&self, uv: Vec2) -> Vec2 {
        self.scale * uv + self.delta
    }
}

#[derive(Clone, Debug)]
pub enum Texture {
    Constant(Vec3),
    /// Checks 0.5 wide in `st`; the cells on both sides of 0 merge (spec §8).
    Checkerboard {
        color0: Vec3,
        color1: Vec3,
        mapping: UvMapping,
    },
    /// A picture (spec §8 `image`), shared with other textures using the same file.
    Image(ImageTexture),
}

impl Texture {
    /// The texture's value at `tc` (a [`TexCoord`], or a bare `uv` for a lookup
    /// without footprint).
    #[inline]
    pub fn eval(&self, tc: impl Into<TexCoord>) -> Vec3 {
        let tc = tc.into();
        match self {
            Texture::Constant(c) => *c,
            Texture::Checkerboard { color0, color1, mapping } => {
                let st = mapping.map(tc.uv);
                let parity = |v: f32| ((((2.0 * v) as i64) % 2) + 2) % 2;
                if parity(st.x) == parity(st.y) {
                    *color0
                } else {
                    *color1
                }
            }
            Texture::Image(t) => t.eval(&tc),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkerboard_cells_are_half_wide() {
        let t = Texture::Checkerboard {
            color0: Vec3::ONE,
            color1: Vec3::ZERO,
            mapping: UvMapping {
                scale: Vec2::ONE,
                delta: Vec2::ZERO,
            },
        };
        assert_eq!(t.eval(Vec2::new(0.1, 0.1)), Vec3::ONE);
        assert_eq!(t.eval(Vec2::new(0.6, 0.1)), Vec3::ZERO);
        assert_eq!(t.eval(Vec2::new(0.6, 0.6)), Vec3::ONE);
        assert_eq!(t.eval(Vec2::new(-0.4, 0.1)), Vec3::ONE, "cells around 0 merge");
    }
}
