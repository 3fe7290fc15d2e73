//! `image` textures (spec §8): a picture file, its MIP pyramid and a `uvmapping2d`.
//!
//! Files are read with [`crate::imageio::read_texture_texels`] when the scene is built:
//! EXR and Radiance HDR as linear values, PNG and JPEG decoded from sRGB; alpha is
//! dropped. Every file is read and its pyramid built once per scene, however many
//! textures and materials use it ([`ImageCache`]).

use super::mipmap::{Level, MipMap};
use super::{TexCoord, TextureConvention, UvMapping};
use crate::imageio::TexelData;
use crate::math::Vec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// An image texture: a shared pyramid looked up through its own `uvmapping2d`.
#[derive(Clone, Debug)]
pub struct ImageTexture {
    pub mipmap: Arc<MipMap>,
    pub mapping: UvMapping,
    pub filter: ImageFilter,
    pub wrap: WrapMode,
    /// A factor on every value (Mitsuba 0.6's `scale` texture around a bitmap).
    pub scale: Vec3,
}

/// What an image texture shows outside [0, 1]² (JSON `wrap_mode`, Mitsuba's `wrap_mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WrapMode {
    /// The image tiles the plane.
    #[default]
    Repeat,
    /// The edge texels extend outwards.
    Clamp,
    /// The image tiles, every other copy mirrored.
    Mirror,
}

impl WrapMode {
    pub const NAMES: &'static str = "repeat, clamp, mirror";

    pub fn parse(s: &str) -> Option<WrapMode> {
        match s {
            "repeat" => Some(WrapMode::Repeat),
            "clamp" => Some(WrapMode::Clamp),
            "mirror" => Some(WrapMode::Mirror),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            WrapMode::Repeat => "repeat",
            WrapMode::Clamp => "clamp",
            WrapMode::Mirror => "mirror",
        }
    }

    /// `st` moved into the image so that the repeating lookups of [`MipMap`] read what
    /// Mitsuba's clamped or mirrored texel indices read: for a `w`×`h` image, clamping the
    /// coordinate half a texel inside the edges is clamping the bilinear or nearest
    /// texel indices, and mirroring the coordinate (a triangle wave of period 2) before
    /// that is mirroring them. Exact on the full-resolution level (Mitsuba's lookups);
    /// coarser MIP levels clamp at level 0's half texel.
    #[inline]
    pub fn apply(self, st: crate::math::Vec2, w: usize, h: usize) -> crate::math::Vec2 {
        let inside = |v: f32, n: usize| {
            let half = 0.5 / n as f32;
            // NaN stays NaN (the lookups' saturating casts handle it)
            v.clamp(half, 1.0 - half)
        };
        let mirror = |v: f32| {
            let m = v.rem_euclid(2.0);
            if m > 1.0 {
                2.0 - m
            } else {
                m
            }
        };
        match self {
            WrapMode::Repeat => st,
            WrapMode::Clamp => crate::math::Vec2::new(inside(st.x, w), inside(st.y, h)),
            WrapMode::Mirror => crate::math::Vec2::new(inside(mirror(st.x), w), inside(mirror(st.y), h)),
        }
    }
}

/// How an image texture is looked up (JSON `filter`, Mitsuba's `filter_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ImageFilter {
    /// MIP-mapped, the level from the ray footprint (rdr's default, spec §8).
    #[default]
    Trilinear,
    /// Bilinear on the full-resolution image (Mitsuba's `bilinear`: it has no MIP maps).
    Bilinear,
    /// The texel the point falls in (Mitsuba's `nearest`).
    Nearest,
}

impl ImageTexture {
    /// The lookup its filter asks for; the trilinear footprint is `scale ⊙` the uv
    /// derivatives (spec §8).
    #[inline]
    pub fn eval(&self, tc: &TexCoord) -> Vec3 {
        let mut st = self.mapping.map(tc.uv);
        if self.wrap != WrapMode::Repeat {
            let l = &self.mipmap.levels()[0];
            st = self.wrap.apply(st, l.width, l.height);
        }
        let v = match self.filter {
            ImageFilter::Trilinear => self.mipmap.lookup(st, self.mapping.scale * tc.duvdx, self.mapping.scale * tc.duvdy),
            ImageFilter::Bilinear => self.mipmap.bilinear(0, st),
            ImageFilter::Nearest => self.mipmap.nearest(st),
        };
        v * self.scale
    }
}

/// Reads `path` (PNG and JPEG decoded from sRGB unless `raw`) and builds its pyramid.
pub fn load_mipmap(path: &Path, convention: TextureConvention, mipmap: bool, raw: bool) -> anyhow::Result<MipMap> {
    let img = crate::imageio::read_texture_texels(path, raw)?;
    Ok(MipMap::new(level_of(img), convention, mipmap))
}

/// Level 0 of a file read: 8-bit files keep their bytes ([`Level::encoded8`]).
fn level_of(img: crate::imageio::TextureTexels) -> Level {
    match img.texels {
        TexelData::Linear(pixels) => Level::new(img.width, img.height, pixels),
        TexelData::Encoded8 { rgb, decode } => Level::encoded8(img.width, img.height, &rgb, decode),
    }
}

/// [`load_mipmap`] of a file's bytes already read (`name` gives the format by its
/// extension and names the file in messages): the fuzz target's entry point.
pub fn decode_mipmap(bytes: &[u8], name: &Path, convention: TextureConvention, mipmap: bool) -> anyhow::Result<MipMap> {
    let img = crate::imageio::decode_texture_texels(bytes, name, false)?;
    Ok(MipMap::new(level_of(img), convention, mipmap))
}

/// The same file under different spellings (`a.png`, `./a.png`, `x/../a.png`, links)
/// gives the same key.
fn file_key(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

/// A file to load for a texture: its path, whether it is read `raw` (see
/// [`load_mipmap`]), and whether a trilinear lookup reads its pyramid.
pub type ImageUse = (PathBuf, bool, bool);

/// Pyramids by file, so a file used by several textures is read once.
#[derive(Default)]
pub struct ImageCache {
    /// By file and whether it is read `raw`.
    loaded: HashMap<(PathBuf, bool), Arc<MipMap>>,
}

impl ImageCache {
    /// Loads every distinct path (in parallel); the first failure is returned with
    /// the index of the path that caused it. A file's pyramid is built (with `mipmap`)
    /// when some use of it is trilinear; level 0 alone otherwise.
    pub fn load_all(&mut self, paths: &[ImageUse], convention: TextureConvention, mipmap: bool) -> Result<(), (usize, anyhow::Error)> {
        use rayon::prelude::*;
        let mut todo: Vec<(usize, &PathBuf, (PathBuf, bool), bool)> = Vec::new();
        for (i, (p, raw, pyramid)) in paths.iter().enumerate() {
            let key = (file_key(p), *raw);
            if self.loaded.contains_key(&key) {
                continue;
            }
            match todo.iter_mut().find(|(_, _, k, _)| *k == key) {
                Some(t) => t.3 |= *pyramid,
                None => todo.push((i, p, key, *pyramid)),
            }
        }
        let results: Vec<_> = todo
            .par_iter()
            .map(|(i, p, key, pyramid)| (*i, key.clone(), load_mipmap(p, convention, mipmap && *pyramid, key.1)))
            .collect();
        for (i, key, r) in results {
            match r {
                Ok(m) => {
                    self.loaded.insert(key, Arc::new(m));
                }
                Err(e) => return Err((i, e)),
            }
        }
        Ok(())
    }

    pub fn get(&self, path: &Path, raw: bool) -> Option<Arc<MipMap>> {
        self.loaded.get(&(file_key(path), raw)).cloned()
    }

    /// Number of distinct files loaded.
    pub fn len(&self) -> usize {
        self.loaded.len()
    }

    pub fn is_empty(&self) -> bool {
        self.loaded.is_empty()
    }
}
