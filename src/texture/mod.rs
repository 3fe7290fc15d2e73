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

use crate::geometry::mesh::ATTRIBUTE_SLOTS;
use crate::math::{Vec2, Vec3};
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
    /// The point's mesh attributes by slot (zero where the mesh has none): what
    /// [`Texture::MeshAttribute`] returns.
    pub attributes: [Vec3; ATTRIBUTE_SLOTS],
}

impl TexCoord {
    /// Coordinates without a footprint.
    #[inline]
    pub fn at(uv: Vec2) -> TexCoord {
        TexCoord {
            uv,
            duvdx: Vec2::ZERO,
            duvdy: Vec2::ZERO,
            attributes: [Vec3::ZERO; ATTRIBUTE_SLOTS],
        }
    }
}

impl From<Vec2> for TexCoord {
    #[inline]
    fn from(uv: Vec2) -> TexCoord {
        TexCoord::at(uv)
    }
}

/// `st = scale ⊙ uv + delta`: a texture's `tex_coordinate_generator` in a scene,
/// `type` = `"uvmapping2d"` (required), `scale` (vec2, (1,1)), `delta` (vec2, (0,0)).
///
/// ```json
/// "tex_coordinate_generator": {"type": "uvmapping2d", "scale": [4, 4], "delta": [0.5, 0]}
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvMapping {
    pub scale: Vec2,
    pub delta: Vec2,
}

impl UvMapping {
    #[inline]
    pub fn map(&self, uv: Vec2) -> Vec2 {
        self.scale * uv + self.delta
    }
}

/// A texture, `textures.<name>` in a scene, chosen by `type` (required). The image
/// is `I`: a file to read in the scene description, the loaded [`ImageTexture`] (the
/// default) once the scene is built.
#[derive(Clone, Debug)]
pub enum Texture<I = ImageTexture> {
    /// `constant`: `color` (vec3, required).
    Constant(Vec3),
    /// `checkerboard`: `color0` (vec3, (0.4, 0.4, 0.4)), `color1` (vec3, (0.2, 0.2, 0.2)),
    /// `tex_coordinate_generator` (required, a [`UvMapping`]); checks 0.5 wide in `st`,
    /// the cells on both sides of 0 merge (spec §8).
    Checkerboard { color0: Vec3, color1: Vec3, mapping: UvMapping },
    /// `image` (spec §8):
    /// * `path` (string, required) — relative to the scene file's folder. EXR and Radiance
    ///   `.hdr` are read as linear values, PNG and JPEG decoded from sRGB; alpha is dropped.
    ///   The file is read when the scene is built (once, however many textures name it);
    ///   a missing or undecodable file is an error naming this key.
    /// * `tex_coordinate_generator` (required, a [`UvMapping`]) — `st = scale ⊙ uv + delta`.
    ///
    /// `st = (0, 0)` is the bottom-left corner of the picture and `(1, 1)` the top-right
    /// (`--compat rdr171`: `t = 0` is the top row, as in the original); the picture repeats
    /// outside [0, 1]². Lookups are MIP-mapped (trilinear) from the ray footprint; see
    /// [`mipmap`]. Once built, the picture is shared with other textures using the same file.
    ///
    /// ```json
    /// "grid": {"type": "image", "path": "textures/uv_grid.png",
    ///          "tex_coordinate_generator": {"type": "uvmapping2d", "scale": [4, 4]}}
    /// ```
    Image(I),
    /// `mesh_attribute` (Mitsuba's `mesh_attribute`): a value the mesh carries, read
    /// from a PLY file's properties by Mitsuba's rules (`red green blue` or `r g b`:
    /// `vertex_color` / `face_color`; `P_x P_y P_z`, `P_0 P_1 P_2` or `P_1 P_2 P_3`:
    /// `vertex_P`; `P_r P_g P_b`: `vertex_P_color`; one such property alone: a
    /// one-channel `vertex_P`, a grey; colours in integers divided by their type's
    /// maximum, 255 for `uchar`; the rest as they are). `name` (required): `"vertex_…"`
    /// (per vertex, interpolated with the barycentrics) or `"face_…"` (per face);
    /// `scale` (1). An object whose mesh lacks the attribute is an error when the scene
    /// is built; a scene reads at most four names. No filtering, no uv gradient.
    ///
    /// ```json
    /// "paint": {"type": "mesh_attribute", "name": "vertex_color"}
    /// ```
    MeshAttribute { name: String, slot: u8, scale: f32 },
}

impl<I> Texture<I> {
    /// The same texture with its image replaced by `f(image)` (the other variants are
    /// copied): how a description's file becomes a loaded picture.
    pub fn try_map_image<J, E>(&self, f: impl FnOnce(&I) -> Result<J, E>) -> Result<Texture<J>, E> {
        Ok(match self {
            Texture::Constant(c) => Texture::Constant(*c),
            Texture::Checkerboard { color0, color1, mapping } => Texture::Checkerboard {
                color0: *color0,
                color1: *color1,
                mapping: *mapping,
            },
            Texture::Image(i) => Texture::Image(f(i)?),
            Texture::MeshAttribute { name, slot, scale } => Texture::MeshAttribute {
                name: name.clone(),
                slot: *slot,
                scale: *scale,
            },
        })
    }
}

impl Texture {
    /// The texture's mean over its domain (as Mitsuba's `Texture::mean`, which steers
    /// the plastics' lobe sampling): the colour, the two checks' average, the image's
    /// texel average.
    pub fn mean(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checkerboard { color0, color1, .. } => 0.5 * (*color0 + *color1),
            Texture::Image(t) => t.mipmap.levels()[0].mean() * t.scale,
            // not known before a point is shaded
            Texture::MeshAttribute { scale, .. } => Vec3::splat(0.5 * scale),
        }
    }

    /// The uv gradient of the texture's luminance at `uv` (Mitsuba's `eval_1_grad`):
    /// of an image, the bilinear interpolation of its full-resolution texels (through
    /// the uv mapping, times the luminance of its `scale`: exact for a grey one);
    /// constants and checkerboards are flat almost everywhere (zero).
    pub fn luminance_gradient(&self, uv: Vec2) -> Vec2 {
        match self {
            Texture::Constant(_) | Texture::Checkerboard { .. } | Texture::MeshAttribute { .. } => Vec2::ZERO,
            Texture::Image(t) => t.mipmap.luminance_gradient(t.mapping.map(uv)) * t.mapping.scale * luminance(t.scale),
        }
    }

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
            Texture::MeshAttribute { slot, scale, .. } => tc.attributes[*slot as usize] * *scale,
        }
    }
}

/// Rec. 709 luminance (Mitsuba's `luminance`, what its `eval_1` gives of a colour).
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
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
