//! MIP pyramids of texture images and their lookups: repeat wrapping, bilinear
//! per level, trilinear between levels (spec §8).
//!
//! Two conventions, chosen per scene at build time ([`TextureConvention`]):
//!
//! **Physical** (default, as pbrt, Mitsuba and Blender):
//! * `t = 0` is the **bottom** row of the image file, `t = 1` its top; `s = 0` the left column.
//! * Level 0 is the image as it is, any size. Each further level has
//!   `max(1, ⌈w/2⌉) × max(1, ⌈h/2⌉)` texels down to 1×1, and every texel is the
//!   **area-weighted box average** of the part of the previous level it covers
//!   (separable; for an even size exactly the 2×2 average, for an odd size a texel
//!   covers 2·n/(n+1) texels with fractional weights at its ends). No resampling to a
//!   power of two is needed and the mean of the image is the same at every level.
//! * Bilinear lookup on a `w × h` level: texel centres at `((i + ½)/w, 1 − (j + ½)/h)`,
//!   `x = s·w − ½`, `y = (1 − t)·h − ½`, indices wrapped with `rem_euclid` (repeat,
//!   also for negative coordinates).
//! * Footprint width `f = max(|∂s/∂x|, |∂t/∂x|, |∂s/∂y|, |∂t/∂y|)` (spec §8's width,
//!   without pbrt's factor 2); level `ℓ = log2(f · max(W, H))`, i.e. the level whose
//!   texels are as wide as the footprint. `ℓ ≤ 0` → bilinear on level 0 (also when
//!   there are no derivatives), `ℓ ≥ levels − 1` → the coarsest level, otherwise a
//!   blend of levels `⌊ℓ⌋` and `⌊ℓ⌋ + 1` with weights `1 − frac(ℓ)` and `frac(ℓ)`.
//!
//! **Rdr171** (`--compat rdr171`, the original's exact lookup, spec §8):
//! * `t = 0` is the **top** row of the file (no flip).
//! * Level 0 has the next power-of-two size ≥ the image in each dimension; texel
//!   `(i, j)` of every level is the clamped bilinear sample of the previous level (the
//!   image for level 0) at `((i + ½)/w, (j + ½)/h)`. Levels halve (minimum 1) and stop
//!   before 1×1 (a 1×1 image, undefined in the original, keeps its single level).
//! * Per level: `s' = max(s·w − ½, 0)`, `t' = max(t·h − ½, 0)`, `lo = ⌊·⌋`,
//!   `hi = lo + 1`, indices wrapped by unsigned modulo (so negative coordinates clamp to
//!   the first texel and the last texel blends with the first).
//! * Level `ℓ = (levels − 1) + log2(max(f, 1e-8))`; `ℓ < 0` → level 0, `ℓ ≥ levels` →
//!   the coarsest level, else blend `⌊ℓ⌋` and `min(⌊ℓ⌋ + 1, coarsest)`.
//!
//! With MIP-mapping turned off ([`crate::desc::BuildOptions::mipmap`]) only level 0
//! is built and every lookup is bilinear on it.

use super::TextureConvention;
use crate::math::{Vec2, Vec3};

/// One level of a pyramid, row 0 = the top of the image (file order).
#[derive(Clone)]
pub struct Level {
    pub width: usize,
    pub height: usize,
    texels: Texels,
}

/// How a level keeps its texels. An 8-bit image keeps its bytes and the 256 values
/// they decode to (a quarter of the memory of `f32`s, read through the table to the
/// very same values), in 4×4 tiles of 64 bytes so that a bilinear lookup's four
/// texels mostly share one cache line; everything else (HDR files, the box-filtered
/// levels above) keeps linear `f32`s in rows.
#[derive(Clone)]
enum Texels {
    Linear(Vec<Vec3>),
    Encoded8 {
        tiles: Vec<Tile>,
        tiles_x: usize,
        decode: Box<[f32; 256]>,
    },
}

/// 4×4 texels of an 8-bit level, RGB and a pad byte each: one cache line.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Tile([[u8; 4]; 16]);

impl Level {
    pub fn new(width: usize, height: usize, texels: Vec<Vec3>) -> Level {
        assert!(width > 0 && height > 0 && texels.len() == width * height, "level size");
        Level {
            width,
            height,
            texels: Texels::Linear(texels),
        }
    }

    /// A level of 8-bit texels (`rgb`: three bytes a texel, rows from the top), each
    /// channel read as `decode[byte]`.
    pub fn encoded8(width: usize, height: usize, rgb: &[u8], decode: Box<[f32; 256]>) -> Level {
        assert!(width > 0 && height > 0 && rgb.len() == 3 * width * height, "level size");
        let (tiles_x, tiles_y) = (width.div_ceil(4), height.div_ceil(4));
        let mut tiles = vec![Tile([[0; 4]; 16]); tiles_x * tiles_y];
        for (y, row) in rgb.chunks_exact(3 * width).enumerate() {
            for (x, p) in row.chunks_exact(3).enumerate() {
                tiles[(y >> 2) * tiles_x + (x >> 2)].0[(y & 3) * 4 + (x & 3)] = [p[0], p[1], p[2], 0];
            }
        }
        Level {
            width,
            height,
            texels: Texels::Encoded8 { tiles, tiles_x, decode },
        }
    }

    /// Texel in file order (row 0 = top).
    #[inline]
    pub fn texel(&self, x: usize, y: usize) -> Vec3 {
        match &self.texels {
            Texels::Linear(t) => t[y * self.width + x],
            Texels::Encoded8 { tiles, tiles_x, decode } => {
                let [r, g, b, _] = tiles[(y >> 2) * tiles_x + (x >> 2)].0[(y & 3) * 4 + (x & 3)];
                Vec3::new(decode[r as usize], decode[g as usize], decode[b as usize])
            }
        }
    }

    /// The four texels of a bilinear lookup: `(xa, ya)`, `(xb, ya)`, `(xa, yb)`, `(xb, yb)`.
    #[inline]
    fn quad(&self, xa: usize, xb: usize, ya: usize, yb: usize) -> [Vec3; 4] {
        match &self.texels {
            Texels::Linear(t) => {
                let (ra, rb) = (ya * self.width, yb * self.width);
                [t[ra + xa], t[ra + xb], t[rb + xa], t[rb + xb]]
            }
            Texels::Encoded8 { tiles, tiles_x, decode } => {
                let at = |x: usize, y: usize| {
                    let [r, g, b, _] = tiles[(y >> 2) * tiles_x + (x >> 2)].0[(y & 3) * 4 + (x & 3)];
                    Vec3::new(decode[r as usize], decode[g as usize], decode[b as usize])
                };
                [at(xa, ya), at(xb, ya), at(xa, yb), at(xb, yb)]
            }
        }
    }

    /// Number of texels.
    pub fn len(&self) -> usize {
        self.width * self.height
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Every texel as linear RGB, in file order.
    pub fn to_linear(&self) -> Vec<Vec3> {
        match &self.texels {
            Texels::Linear(t) => t.clone(),
            Texels::Encoded8 { .. } => (0..self.height)
                .flat_map(|y| (0..self.width).map(move |x| self.texel(x, y)))
                .collect(),
        }
    }

    /// Whether the texels are kept as 8-bit values.
    pub fn is_encoded8(&self) -> bool {
        matches!(self.texels, Texels::Encoded8 { .. })
    }

    /// Mean of all texels.
    pub fn mean(&self) -> Vec3 {
        let mut s = glam::DVec3::ZERO;
        for y in 0..self.height {
            for x in 0..self.width {
                s += self.texel(x, y).as_dvec3();
            }
        }
        (s / self.len() as f64).as_vec3()
    }
}

impl std::fmt::Debug for Level {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Level({}x{})", self.width, self.height)
    }
}

/// An image texture's pyramid, built for one [`TextureConvention`].
#[derive(Clone, Debug)]
pub struct MipMap {
    levels: Vec<Level>,
    convention: TextureConvention,
    /// Texels of the image that were NaN or infinite (made black).
    non_finite: usize,
}

impl MipMap {
    /// Builds the pyramid of `image` (row 0 = top). With `mipmap == false` only level 0.
    /// NaN and infinite texels become black first: the pyramid would spread them into
    /// their neighbours and every lookup near one would be NaN.
    pub fn new(mut image: Level, convention: TextureConvention, mipmap: bool) -> MipMap {
        let mut non_finite = 0;
        if let Texels::Linear(texels) = &mut image.texels {
            for t in texels.iter_mut().filter(|t| !t.is_finite()) {
                *t = Vec3::ZERO;
                non_finite += 1;
            }
        }
        let mut levels = Vec::new();
        match convention {
            TextureConvention::Physical => {
                levels.push(image);
                while let Some(prev) = levels.last().filter(|l| mipmap && (l.width, l.height) != (1, 1)) {
                    let next = box_downsample(prev, prev.width.div_ceil(2), prev.height.div_ceil(2));
                    levels.push(next);
                }
            }
            TextureConvention::Rdr171 => {
                let (w, h) = (image.width.next_power_of_two(), image.height.next_power_of_two());
                levels.push(if (w, h) == (image.width, image.height) {
                    image
                } else {
                    resample_rdr171(&image, w, h)
                });
                let half = |l: &Level| ((l.width / 2).max(1), (l.height / 2).max(1));
                while let Some(prev) = levels.last().filter(|l| mipmap && half(l) != (1, 1)) {
                    let (w, h) = half(prev);
                    let next = resample_rdr171(prev, w, h);
                    levels.push(next);
                }
            }
        }
        MipMap {
            levels,
            convention,
            non_finite,
        }
    }

    pub fn levels(&self) -> &[Level] {
        &self.levels
    }

    /// How many texels of the image were NaN or infinite (they are black here).
    pub fn non_finite_texels(&self) -> usize {
        self.non_finite
    }

    pub fn convention(&self) -> TextureConvention {
        self.convention
    }

    /// Bilinear lookup on one level at `st` with this pyramid's wrap and orientation.
    pub fn bilinear(&self, level: usize, st: Vec2) -> Vec3 {
        let l = &self.levels[level.min(self.levels.len() - 1)];
        match self.convention {
            TextureConvention::Physical => bilinear_repeat(l, st.x * l.width as f32 - 0.5, (1.0 - st.y) * l.height as f32 - 0.5),
            TextureConvention::Rdr171 => bilinear_rdr171(l, st),
        }
    }

    /// The level-0 texel `st` falls in (repeat wrapping; the same orientation as
    /// [`MipMap::bilinear`]).
    pub fn nearest(&self, st: Vec2) -> Vec3 {
        let l = &self.levels[0];
        let y = match self.convention {
            TextureConvention::Physical => 1.0 - st.y,
            TextureConvention::Rdr171 => st.y,
        };
        // saturating float → int casts keep absurd coordinates finite
        let (i, j) = ((st.x * l.width as f32).floor() as i64, (y * l.height as f32).floor() as i64);
        l.texel(i.rem_euclid(l.width as i64) as usize, j.rem_euclid(l.height as i64) as usize)
    }

    /// The st gradient of the luminance of [`MipMap::bilinear`] on level 0 (the
    /// derivative of the bilinear interpolation inside the texel cell at `st`).
    pub fn luminance_gradient(&self, st: Vec2) -> Vec2 {
        let l = &self.levels[0];
        let (w, h) = (l.width as f32, l.height as f32);
        let lum = super::luminance;
        let cell = |x: f32, y: f32| {
            let (x0, y0) = (x.floor(), y.floor());
            let (fx, fy) = (x - x0, y - y0);
            let (wi, hi) = (l.width as i64, l.height as i64);
            let (x0, y0) = (x0 as i64, y0 as i64);
            let (xa, xb) = (x0.rem_euclid(wi) as usize, (x0 + 1).rem_euclid(wi) as usize);
            let (ya, yb) = (y0.rem_euclid(hi) as usize, (y0 + 1).rem_euclid(hi) as usize);
            let (f00, f10) = (lum(l.texel(xa, ya)), lum(l.texel(xb, ya)));
            let (f01, f11) = (lum(l.texel(xa, yb)), lum(l.texel(xb, yb)));
            Vec2::new(
                (1.0 - fy) * (f10 - f00) + fy * (f11 - f01),
                (1.0 - fx) * (f01 - f00) + fx * (f11 - f10),
            )
        };
        match self.convention {
            TextureConvention::Physical => {
                let d = cell(st.x * w - 0.5, (1.0 - st.y) * h - 0.5);
                // y = (1 − t)·h − ½ runs against t
                Vec2::new(d.x * w, -d.y * h)
            }
            TextureConvention::Rdr171 => {
                let d = cell((st.x * w - 0.5).max(0.0), (st.y * h - 0.5).max(0.0));
                Vec2::new(d.x * w, d.y * h)
            }
        }
    }

    /// The levels and weights a trilinear lookup with footprint width `width` (in st
    /// units) blends; the second weight is 0 when only one level is used.
    pub fn level_weights(&self, width: f32) -> [(usize, f32); 2] {
        let n = self.levels.len();
        let coarsest = n - 1;
        let l = match self.convention {
            TextureConvention::Physical => {
                let res = self.levels[0].width.max(self.levels[0].height) as f32;
                if width > 0.0 {
                    (width * res).log2()
                } else {
                    f32::NEG_INFINITY
                }
            }
            TextureConvention::Rdr171 => coarsest as f32 + width.max(1e-8).log2(),
        };
        let top = match self.convention {
            TextureConvention::Physical => coarsest as f32,
            TextureConvention::Rdr171 => n as f32,
        };
        if l.is_nan() || l <= 0.0 {
            // l < 0 in the original; at exactly 0 its blend gives level 0 with weight 1 too
            [(0, 1.0), (0, 0.0)]
        } else if l >= top {
            [(coarsest, 1.0), (coarsest, 0.0)]
        } else {
            let lo = l.floor();
            let d = l - lo;
            let lo = lo as usize;
            [(lo, 1.0 - d), ((lo + 1).min(coarsest), d)]
        }
    }

    /// Trilinear lookup at `st` with screen-space derivatives `dstdx`, `dstdy`
    /// (zero: bilinear on level 0).
    pub fn lookup(&self, st: Vec2, dstdx: Vec2, dstdy: Vec2) -> Vec3 {
        if self.levels.len() == 1 {
            return self.bilinear(0, st);
        }
        let width = dstdx.x.abs().max(dstdx.y.abs()).max(dstdy.x.abs()).max(dstdy.y.abs());
        let [(l0, w0), (l1, w1)] = self.level_weights(width);
        if w1 == 0.0 {
            self.bilinear(l0, st)
        } else {
            self.bilinear(l0, st) * w0 + self.bilinear(l1, st) * w1
        }
    }
}

/// Bilinear interpolation at continuous texel coordinates (`x = i` is the centre of
/// column `i`, `y = j` that of file row `j`), wrapping both axes (repeat).
#[inline]
pub fn bilinear_repeat(l: &Level, x: f32, y: f32) -> Vec3 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (w, h) = (l.width as i64, l.height as i64);
    // saturating float → int casts keep absurd coordinates finite
    let (x0, y0) = (x0 as i64, y0 as i64);
    let (xa, xb) = (x0.rem_euclid(w) as usize, (x0 + 1).rem_euclid(w) as usize);
    let (ya, yb) = (y0.rem_euclid(h) as usize, (y0 + 1).rem_euclid(h) as usize);
    let [a, b, c, d] = l.quad(xa, xb, ya, yb);
    let top = a * (1.0 - fx) + b * fx;
    let bottom = c * (1.0 - fx) + d * fx;
    top * (1.0 - fy) + bottom * fy
}

/// The original's per-level lookup: `max(·w − ½, 0)`, unsigned-modulo wrap, no flip.
fn bilinear_rdr171(l: &Level, st: Vec2) -> Vec3 {
    let s = (st.x * l.width as f32 - 0.5).max(0.0);
    let t = (st.y * l.height as f32 - 0.5).max(0.0);
    let (s0, t0) = (s.floor(), t.floor());
    let (s1, t1) = (s0 + 1.0, t0 + 1.0);
    let xi = |v: f32| (v as u64 % l.width as u64) as usize;
    let yi = |v: f32| (v as u64 % l.height as u64) as usize;
    let (xa, xb, ya, yb) = (xi(s0), xi(s1), yi(t0), yi(t1));
    (l.texel(xa, ya) * (s1 - s) + l.texel(xb, ya) * (s - s0)) * (t1 - t)
        + (l.texel(xa, yb) * (s1 - s) + l.texel(xb, yb) * (s - s0)) * (t - t0)
}

/// The original's resampling for level construction: bilinear with indices clamped
/// to the image, sampled at texel centres of the new size.
fn resample_rdr171(src: &Level, w: usize, h: usize) -> Level {
    let mut texels = Vec::with_capacity(w * h);
    let (sw, sh) = (src.width as f32, src.height as f32);
    for j in 0..h {
        for i in 0..w {
            let st = Vec2::new((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32);
            let s = (sw * st.x - 0.5).max(0.0);
            let t = (sh * st.y - 0.5).max(0.0);
            let (s0, t0) = (s.floor(), t.floor());
            let (s1, t1) = (s0 + 1.0, t0 + 1.0);
            let xi = |v: f32| (v as usize).min(src.width - 1);
            let yi = |v: f32| (v as usize).min(src.height - 1);
            let (xa, xb, ya, yb) = (xi(s0), xi(s1), yi(t0), yi(t1));
            texels.push(
                (src.texel(xa, ya) * (s1 - s) + src.texel(xb, ya) * (s - s0)) * (t1 - t)
                    + (src.texel(xa, yb) * (s1 - s) + src.texel(xb, yb) * (s - s0)) * (t - t0),
            );
        }
    }
    Level::new(w, h, texels)
}

/// Weights of an area-weighted box filter from `n` source cells to `m` cells: for
/// every output cell the overlapping source cells and the fraction of the output
/// cell each covers (the fractions sum to 1).
fn box_weights(n: usize, m: usize) -> Vec<Vec<(usize, f32)>> {
    let ratio = n as f64 / m as f64;
    (0..m)
        .map(|i| {
            let (a, b) = (i as f64 * ratio, (i + 1) as f64 * ratio);
            let first = a.floor() as usize;
            let last = (b.ceil() as usize).min(n);
            (first..last)
                .filter_map(|j| {
                    let overlap = b.min(j as f64 + 1.0) - a.max(j as f64);
                    (overlap > 1e-12).then_some((j, (overlap / ratio) as f32))
                })
                .collect()
        })
        .collect()
}

/// Exact box (area-average) downsampling to `w × h`, separable: each output row
/// sums the horizontally filtered source rows it covers, each filtered into a
/// one-row buffer when needed (the same sums in the same order as filtering the
/// whole level first, without a level-sized intermediate to allocate and fault in).
fn box_downsample(src: &Level, w: usize, h: usize) -> Level {
    let wx = box_weights(src.width, w);
    let wy = box_weights(src.height, h);
    let mut texels = Vec::with_capacity(w * h);
    let mut rows: Vec<(usize, Vec<Vec3>)> = Vec::new();
    for ws in &wy {
        // the rows this output row needs, filtered once each (odd sizes share one)
        rows.retain(|(y, _)| ws.iter().any(|&(yy, _)| yy == *y));
        for &(y, _) in ws {
            if !rows.iter().any(|(yy, _)| *yy == y) {
                let row = wx
                    .iter()
                    .map(|wsx| wsx.iter().fold(Vec3::ZERO, |a, &(x, k)| a + src.texel(x, y) * k))
                    .collect();
                rows.push((y, row));
            }
        }
        let parts: Vec<(&[Vec3], f32)> = ws
            .iter()
            .map(|&(y, k)| (rows.iter().find(|(yy, _)| *yy == y).map_or(&[][..], |r| &r.1[..]), k))
            .collect();
        for x in 0..w {
            texels.push(parts.iter().fold(Vec3::ZERO, |a, &(row, k)| a + row[x] * k));
        }
    }
    Level::new(w, h, texels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_weights_cover_each_output_once() {
        for (n, m) in [(4, 2), (5, 3), (600, 300), (3, 2), (7, 4), (1, 1)] {
            let w = box_weights(n, m);
            assert_eq!(w.len(), m);
            for ws in &w {
                assert!((ws.iter().map(|x| x.1).sum::<f32>() - 1.0).abs() < 1e-5, "{n}->{m}");
            }
            // every source cell contributes n/m... in total m/n·(n/m) = 1 output cell's worth
            let mut per_src = vec![0.0f32; n];
            for ws in &w {
                for &(j, k) in ws {
                    per_src[j] += k;
                }
            }
            for v in per_src {
                assert!((v - m as f32 / n as f32).abs() < 1e-5, "{n}->{m}: {v}");
            }
        }
    }

    #[test]
    fn rdr171_pyramid_stops_before_one_by_one() {
        let img = Level::new(5, 3, vec![Vec3::ONE; 15]);
        let m = MipMap::new(img, TextureConvention::Rdr171, true);
        let sizes: Vec<_> = m.levels().iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, vec![(8, 4), (4, 2), (2, 1)]);
    }
}
