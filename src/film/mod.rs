//! Film: reconstruction filters and weighted sample accumulation (spec §5).
//!
//! Film `y` grows upwards (row 0 is the bottom); [`Film::to_rgb_rows`] flips it
//! so output row 0 is the top of the picture. Work is accumulated in
//! [`FilmTile`]s that are merged in a fixed order, so the image does not depend
//! on the number of threads. Light-tracing contributions to arbitrary pixels go
//! through [`Splats`] lists, also merged in a fixed order, into a buffer of their own
//! that is added to the weighted average divided by the number of samples per pixel.

pub mod aov;

use crate::math::{Vec2, Vec3};

mod filter;
use crate::pages::{clone_huge, filled_huge};
pub use filter::{Filter, FilterSampler};
use rayon::prelude::*;

/// The range of `w` between its first and last non-zero entry (empty if all are 0):
/// the footprint's edges often weigh 0, and skipping them up front keeps the branch on
/// each pixel's weight predictable.
#[inline(always)]
fn non_zero_span(w: &[f32]) -> std::ops::Range<usize> {
    match w.iter().position(|&v| v != 0.0) {
        Some(first) => first..w.len() - w.iter().rev().position(|&v| v != 0.0).unwrap_or(0),
        None => 0..0,
    }
}

/// A rectangle of pixels `[x0, x0+w) × [y0, y0+h)` (already including the filter's
/// reach) accumulating samples: f32 sums in sample order, f64 weights.
#[derive(Clone, Debug)]
pub struct FilmTile {
    pub x0: i32,
    pub y0: i32,
    pub w: i32,
    pub h: i32,
    pub sum: Vec<[f32; 3]>,
    pub weight: Vec<f64>,
}

/// `x.floor() as i32`. The baseline x86-64 target has no rounding instruction, so
/// `floor` is a libm call; a non-negative `x` needs none: truncation is the floor
/// there (and `as` saturates alike).
#[inline]
fn floor_to_i32(x: f32) -> i32 {
    if x >= 0.0 {
        x as i32
    } else {
        x.floor() as i32
    }
}

impl FilmTile {
    /// A tile for samples taken in pixels `[x0, x1) × [y0, y1)` of a `film_w × film_h` film.
    pub fn new(x0: i32, y0: i32, x1: i32, y1: i32, reach: i32, film_w: i32, film_h: i32) -> Self {
        let mut tile = FilmTile {
            x0: 0,
            y0: 0,
            w: 0,
            h: 0,
            sum: Vec::new(),
            weight: Vec::new(),
        };
        tile.reset((x0, y0, x1, y1), reach, film_w, film_h);
        tile
    }

    /// [`FilmTile::new`]'s tile in this tile's buffers (a tile of an earlier
    /// pass), zeroed: a pass's tiles reuse the last pass's memory instead of
    /// faulting in fresh pages from the allocator (10 % of a `cbox_point` pass).
    pub fn reset(&mut self, (x0, y0, x1, y1): (i32, i32, i32, i32), reach: i32, film_w: i32, film_h: i32) {
        let (ax, ay) = ((x0 - reach).max(0), (y0 - reach).max(0));
        let (bx, by) = ((x1 + reach).min(film_w), (y1 + reach).min(film_h));
        let (w, h) = (bx - ax, by - ay);
        (self.x0, self.y0, self.w, self.h) = (ax, ay, w, h);
        self.sum.clear();
        self.sum.resize((w * h) as usize, [0.0; 3]);
        self.weight.clear();
        self.weight.resize((w * h) as usize, 0.0);
    }

    /// Adds radiance `l` seen through continuous film position `pos`. Samples
    /// outside the film are dropped (spec §5.1).
    #[inline]
    pub fn add(&mut self, pos: Vec2, l: Vec3, filter: &Filter, film_w: i32, film_h: i32) {
        self.add_weighted(pos, l, filter, (film_w, film_h), Filter::axis_weights);
    }

    /// [`FilmTile::add`] with every weight from [`Filter::axis`] (the library's `exp`
    /// pixel by pixel), as the RDR171 renderer weighed them: its images bit for bit.
    #[inline]
    pub fn add_exact(&mut self, pos: Vec2, l: Vec3, filter: &Filter, film_w: i32, film_h: i32) {
        self.add_weighted(pos, l, filter, (film_w, film_h), Filter::axis_weights_exact);
    }

    #[inline(always)]
    fn add_weighted(
        &mut self,
        pos: Vec2,
        l: Vec3,
        filter: &Filter,
        (film_w, film_h): (i32, i32),
        weights: impl Fn(&Filter, f32, i32, &mut [f32; 16], usize),
    ) {
        if filter.is_own_pixel_box() {
            self.add_own_pixel(pos, l, film_w, film_h);
            return;
        }
        let (px, py) = (floor_to_i32(pos.x), floor_to_i32(pos.y));
        if px < 0 || py < 0 || px >= film_w || py >= film_h {
            return;
        }
        // the footprint clipped to this tile (which lies inside the film): the work per
        // sample is bounded by the tile, whatever the filter's radius
        let k = filter.reach();
        let (ya, yb) = ((py - k).max(self.y0), (py + k).min(self.y0 + self.h - 1));
        let (xa, xb) = ((px - k).max(self.x0), (px + k).min(self.x0 + self.w - 1));
        let (nx, ny) = ((xb - xa + 1).max(0) as usize, (yb - ya + 1).max(0) as usize);
        // the filter is separable: each column's and each row's factor once per sample
        let (mut columns, mut rows) = ([0.0f32; 16], [0.0f32; 16]);
        if nx > columns.len() || ny > rows.len() {
            for y in ya..=yb {
                let wy = filter.axis(pos.y - (y as f32 + 0.5));
                for x in xa..=xb {
                    let w = filter.axis(pos.x - (x as f32 + 0.5)) * wy;
                    if w != 0.0 {
                        self.splat(x, y, l, w);
                    }
                }
            }
            return;
        }
        weights(filter, pos.x, xa, &mut columns, nx);
        weights(filter, pos.y, ya, &mut rows, ny);
        let (cs, rs) = (non_zero_span(&columns[..nx]), non_zero_span(&rows[..ny]));
        for (j, &wy) in rows[rs.clone()].iter().enumerate() {
            let row = ((ya - self.y0 + (rs.start + j) as i32) * self.w + (xa - self.x0)) as usize + cs.start;
            for (i, &wx) in columns[cs.clone()].iter().enumerate() {
                let w = wx * wy;
                if w != 0.0 {
                    self.splat_at(row + i, l, w);
                }
            }
        }
    }

    /// [`FilmTile::add`] for a filter whose [`Filter::is_own_pixel_box`] holds, inlined
    /// into the caller's loop (the block passes' adds, compiled for the render's kernels;
    /// `add` itself goes through it).
    #[inline(always)]
    pub fn add_own_pixel(&mut self, pos: Vec2, l: Vec3, film_w: i32, film_h: i32) {
        let (px, py) = (floor_to_i32(pos.x), floor_to_i32(pos.y));
        if px < 0 || py < 0 || px >= film_w || py >= film_h {
            return;
        }
        self.splat(px, py, l, 1.0);
    }

    /// Adds radiance `l` with weight `w` to pixel `(x, y)` alone (filter importance
    /// sampling: the sample's offset was drawn from the filter).
    #[inline]
    pub fn add_to_pixel(&mut self, x: i32, y: i32, l: Vec3, w: f32) {
        self.splat(x, y, l, w);
    }

    #[inline]
    fn splat(&mut self, x: i32, y: i32, l: Vec3, w: f32) {
        let (lx, ly) = (x - self.x0, y - self.y0);
        if lx < 0 || ly < 0 || lx >= self.w || ly >= self.h {
            return; // only possible for samples a caller placed outside its tile
        }
        self.splat_at((ly * self.w + lx) as usize, l, w);
    }

    /// [`FilmTile::splat`] at index `i` of the tile's pixels (`l·1` is `l` bit for bit).
    #[inline(always)]
    fn splat_at(&mut self, i: usize, l: Vec3, w: f32) {
        let s = &mut self.sum[i];
        s[0] += l.x * w;
        s[1] += l.y * w;
        s[2] += l.z * w;
        self.weight[i] += w as f64;
    }
}

/// How camera samples are placed and weighted (`film.sampling` in a scene).
// the sampler's table (0.5 KB) lives in the film settings, one per render, read by reference
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum FilmSampling {
    /// Uniform in the pixel, each sample weighted by the filter in every pixel it
    /// reaches (neighbouring pixels share samples: their noise is correlated).
    #[default]
    Filter,
    /// Filter importance sampling (pbrt-v4): each sample's offset from its pixel's
    /// centre is drawn in proportion to |filter|, and the sample counts in its own pixel
    /// alone, with weight ±1 (the sign of the filter there). Pixels' noise is then
    /// independent, which a denoiser needs.
    Importance(FilterSampler),
}

impl FilmSampling {
    /// Importance sampling of `filter`; for a box of radius ≤ ½ (each sample in its own
    /// pixel with weight 1 either way) the plain sampling, so its images stay as they are.
    pub fn importance(filter: &Filter) -> FilmSampling {
        if filter.is_own_pixel_box() {
            FilmSampling::Filter
        } else {
            FilmSampling::Importance(FilterSampler::new(filter))
        }
    }
}

/// The film of a render job: size in pixels, reconstruction filter, how samples are
/// placed, and the tile size work is split into (no effect on the image).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmSettings {
    pub width: u32,
    pub height: u32,
    pub filter: Filter,
    pub sampling: FilmSampling,
    pub block_size: u32,
}

impl FilmSettings {
    /// The film position of pixel `(x, y)`'s sample `(u, v)` (in [0, 1)²) and its
    /// weight: uniform in the pixel with weight 1 (the filter weighs it when it is
    /// added), or drawn from the filter with weight ±1 (importance sampling).
    #[inline(always)]
    pub fn sample_position(&self, x: i32, y: i32, u: f32, v: f32) -> (Vec2, f32) {
        match &self.sampling {
            FilmSampling::Filter => (Vec2::new(x as f32 + u, y as f32 + v), 1.0),
            FilmSampling::Importance(s) => {
                let (d, w) = s.sample(u, v);
                (Vec2::new(x as f32 + 0.5 + d.x, y as f32 + 0.5 + d.y), w)
            }
        }
    }

    /// Whether each sample counts in its own pixel alone, with its weight (added with
    /// [`FilmTile::add_to_pixel`]).
    #[inline(always)]
    pub fn importance_sampled(&self) -> bool {
        matches!(self.sampling, FilmSampling::Importance(_))
    }

    /// Bytes a render of this film allocates at most, or `None` on overflow: the
    /// film's f64 sums, weights and splats, every tile of a pass (with the filter's
    /// reach around it; a pass keeps all its tiles until it is merged), the image and
    /// the file written from it.
    pub fn memory_bytes(&self) -> Option<u64> {
        let (w, h) = (self.width as u64, self.height as u64);
        let pixels = w.checked_mul(h)?;
        let b = self.block_size.max(1) as u64;
        let k = self.filter.reach().max(0) as u64;
        let (tx, ty) = (w.div_ceil(b), h.div_ceil(b));
        let tile_px = (b + 2 * k).min(w).checked_mul((b + 2 * k).min(h))?;
        let tiles = tx.checked_mul(ty)?.checked_mul(tile_px)?.checked_mul(20)?;
        pixels.checked_mul(24 + 8 + 24 + 12 + 12)?.checked_add(tiles)
    }
}

/// Contributions of one worker to arbitrary film positions (light tracing), in
/// the order they were made.
#[derive(Clone, Debug, Default)]
pub struct Splats {
    items: Vec<(Vec2, Vec3)>,
}

impl Splats {
    /// Radiance `l` arriving at continuous film position `pos` (film `y` up), as an
    /// estimate per sample: the film divides splats by the samples per pixel.
    #[inline]
    pub fn add(&mut self, pos: Vec2, l: Vec3) {
        self.items.push((pos, l));
    }
    pub fn len(&self) -> usize {
        self.items.len()
    }
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }
}

/// The film's accumulated state: per-pixel f64 sums of filter-weighted radiance,
/// their weights and the splat buffer (film rows, `y` up). Adding two of them is
/// elementwise, so the render loop can keep sums of blocks of passes apart and add
/// them in a fixed order ([`crate::render::blocks`]).
#[derive(Debug, PartialEq)]
pub struct Sums {
    pub sum: Vec<[f64; 3]>,
    pub weight: Vec<f64>,
    /// `None` until a splat lands (most integrators never splat).
    pub splat: Option<Vec<[f64; 3]>>,
}

// A film's sums are megabytes, made once per block of passes: on huge pages they cost a
// few page faults instead of two per 4 KiB (`crate::pages::filled_huge`).
impl Sums {
    pub fn zero(pixels: usize) -> Sums {
        Sums {
            sum: filled_huge(pixels, [0.0; 3]),
            weight: filled_huge(pixels, 0.0),
            splat: None,
        }
    }

    /// [`Sums::zero`] on zeroed memory from the allocator, which the system fills in
    /// only where it is touched (slower to add to: its pages fault 4 KiB at a time).
    pub fn zero_lazily(pixels: usize) -> Sums {
        Sums {
            sum: vec![[0.0; 3]; pixels],
            weight: vec![0.0; pixels],
            splat: None,
        }
    }

    /// `self += other`, pixel by pixel (a missing splat buffer counts as absent, not
    /// as zeros, so an empty one never changes a bit of the other).
    pub fn add(&mut self, other: &Sums) {
        assert_eq!(self.sum.len(), other.sum.len(), "sums of different films");
        for (a, b) in self.sum.iter_mut().zip(&other.sum) {
            for c in 0..3 {
                a[c] += b[c];
            }
        }
        for (a, b) in self.weight.iter_mut().zip(&other.weight) {
            *a += *b;
        }
        match (&mut self.splat, &other.splat) {
            (_, None) => {}
            (None, Some(b)) => self.splat = Some(clone_huge(b)),
            (Some(a), Some(b)) => {
                for (a, b) in a.iter_mut().zip(b) {
                    for c in 0..3 {
                        a[c] += b[c];
                    }
                }
            }
        }
    }
}

impl Clone for Sums {
    fn clone(&self) -> Self {
        Sums {
            sum: clone_huge(&self.sum),
            weight: clone_huge(&self.weight),
            splat: self.splat.as_deref().map(clone_huge),
        }
    }
}

/// The whole film: f64 sums of tiles, merged in a deterministic order, and the
/// splat buffer. Integrators whose pixel value is not an average of samples
/// (SPPM) keep their statistics in their own state
/// ([`crate::integrator::PassState`]), which makes their image
/// ([`crate::integrator::Integrator::estimate`]).
#[derive(Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub filter: Filter,
    sums: Sums,
    /// 1 / ∫∫ filter, so a splat spreads exactly its value over the pixels.
    splat_norm: f64,
    /// Feature-buffer sums (`--aov`), when asked for.
    aov: Option<AovSums>,
    /// Tiles of the last pass, merged: buffers for the next pass's tiles.
    pub(crate) spare_tiles: Vec<FilmTile>,
}

impl Film {
    pub fn new(width: u32, height: u32, filter: Filter) -> Film {
        let n = (width * height) as usize;
        Film {
            width,
            height,
            filter,
            sums: Sums::zero(n),
            splat_norm: 1.0 / filter_integral(&filter),
            aov: None,
            spare_tiles: Vec::new(),
        }
    }

    /// Starts feature-buffer sums (`--aov`): [`crate::integrator::camera_pass`] then
    /// adds every camera sample's features.
    pub fn enable_aov(&mut self) {
        self.aov = Some(AovSums::zero(self.width, self.height));
    }

    pub fn aov(&self) -> Option<&AovSums> {
        self.aov.as_ref()
    }

    /// Adds a tile's feature sums (tiles are disjoint, so the order does not matter
    /// for a pixel; callers keep the tile order anyway).
    pub fn merge_aov(&mut self, t: &AovTile) {
        let Some(a) = &mut self.aov else { return };
        for y in 0..t.h {
            for x in 0..t.w {
                let src = &t.sums[(y * t.w + x) as usize];
                let dst = &mut a.sums[((t.y0 + y) * a.width as i32 + t.x0 + x) as usize];
                for (d, s) in dst.iter_mut().zip(src) {
                    *d += s;
                }
            }
        }
    }

    /// Adds a worker's splats, in their order, through the reconstruction filter
    /// normalised to integrate to one. Positions outside the film are dropped.
    pub fn add_splats(&mut self, splats: &Splats) {
        if splats.is_empty() {
            return;
        }
        let n = self.sums.sum.len();
        let buffer = self.sums.splat.get_or_insert_with(|| filled_huge(n, [0.0; 3]));
        let (w, h) = (self.width as i32, self.height as i32);
        let k = self.filter.reach();
        for &(pos, l) in &splats.items {
            let inside = pos.x >= 0.0 && pos.y >= 0.0 && pos.x < w as f32 && pos.y < h as f32;
            if !inside || !l.is_finite() {
                continue;
            }
            let (px, py) = (pos.x.floor() as i32, pos.y.floor() as i32);
            for y in (py - k).max(0)..=(py + k).min(h - 1) {
                for x in (px - k).max(0)..=(px + k).min(w - 1) {
                    let wt = self.filter.eval(pos.x - (x as f32 + 0.5), pos.y - (y as f32 + 0.5)) as f64 * self.splat_norm;
                    if wt != 0.0 {
                        let s = &mut buffer[(y * w + x) as usize];
                        s[0] += l.x as f64 * wt;
                        s[1] += l.y as f64 * wt;
                        s[2] += l.z as f64 * wt;
                    }
                }
            }
        }
    }

    pub fn merge(&mut self, t: &FilmTile) {
        let w = self.width as usize;
        let Sums { sum, weight, .. } = &mut self.sums;
        for y in t.y0 as usize..(t.y0 + t.h) as usize {
            add_tile_row(sum, weight, y * w, t, y);
        }
    }

    /// [`Film::merge`] of `tiles` one after another, with the film's rows shared out
    /// among threads in bands: every pixel still receives its tiles' sums in the order
    /// given, so the sums are those of merging tile by tile (a pass's merge was serial
    /// work between two parallel passes: a tenth of a short pass's time on two cores).
    pub fn merge_all(&mut self, tiles: &[&FilmTile]) {
        /// Film rows per band.
        const BAND: usize = 16;
        let w = self.width as usize;
        if w == 0 {
            return;
        }
        let Sums { sum, weight, .. } = &mut self.sums;
        sum.par_chunks_mut(BAND * w)
            .zip(weight.par_chunks_mut(BAND * w))
            .enumerate()
            .for_each(|(band, (sum, weight))| {
                let (r0, r1) = (band * BAND, band * BAND + sum.len() / w);
                for t in tiles {
                    let ty0 = t.y0 as usize;
                    for y in (ty0.max(r0))..((ty0 + t.h as usize).min(r1)) {
                        add_tile_row(sum, weight, (y - r0) * w, t, y);
                    }
                }
            });
    }

    /// The splat buffer as summed (film rows, `y` up; empty without splats).
    pub fn splat_sums(&self) -> &[[f64; 3]] {
        self.sums.splat.as_deref().unwrap_or(&[])
    }

    /// The sums accumulated so far.
    pub fn sums(&self) -> &Sums {
        &self.sums
    }

    /// Takes the sums out, leaving the film's at zero (the render loop keeps blocks
    /// of passes apart this way). Unless `more` passes follow, the new zeros are left to
    /// the operating system (`calloc`'s untouched pages): megabytes nothing may read,
    /// which need no writing.
    pub fn take_sums(&mut self, more: bool) -> Sums {
        let n = self.sums.sum.len();
        let zero = if more { Sums::zero(n) } else { Sums::zero_lazily(n) };
        std::mem::replace(&mut self.sums, zero)
    }

    /// Replaces the sums (a resumed render's unfinished block).
    pub fn set_sums(&mut self, sums: Sums) {
        assert_eq!(sums.sum.len(), self.sums.sum.len(), "sums of another film");
        self.sums = sums;
    }

    /// Pixel values, row 0 = top of the picture. A pixel without weight is black.
    /// The division is `f32(sum) / f32(weight)` as in the original (spec §5.2).
    /// Splats, if any, are added times `splat_scale` (1 / samples per pixel).
    pub fn to_rgb_rows(&self, splat_scale: f64) -> Vec<Vec3> {
        self.rgb_rows_of(&self.sums, splat_scale)
    }

    /// [`Film::to_rgb_rows`] of other sums of this film.
    pub fn rgb_rows_of(&self, sums: &Sums, splat_scale: f64) -> Vec<Vec3> {
        rgb_rows(self.width, self.height, sums, None, splat_scale)
    }
}

/// Adds film row `y` of tile `t` to the film row that starts at index `row` of `sum` and
/// `weight` (the film's, or a band of its rows).
#[inline]
fn add_tile_row(sum: &mut [[f64; 3]], weight: &mut [f64], row: usize, t: &FilmTile, y: usize) {
    let (tw, dst) = (t.w as usize, row + t.x0 as usize);
    let src = (y - t.y0 as usize) * tw;
    // the channels as one flat row: the loop vectorizes (pixel by pixel it did not)
    let to = sum[dst..dst + tw].as_flattened_mut();
    for (d, s) in to.iter_mut().zip(t.sum[src..src + tw].as_flattened()) {
        *d += *s as f64;
    }
    for (d, s) in weight[dst..dst + tw].iter_mut().zip(&t.weight[src..src + tw]) {
        *d += *s;
    }
}

/// Pixel values of `sums` on a `width × height` film, row 0 = top: `f32(sum) /
/// f32(weight)` (black without weight), or `estimate` where given, plus splats times
/// `splat_scale`.
pub fn rgb_rows(width: u32, height: u32, sums: &Sums, estimate: Option<&[Vec3]>, splat_scale: f64) -> Vec<Vec3> {
    let (w, h) = (width as usize, height as usize);
    let mut out = vec![Vec3::ZERO; w * h];
    for r in 0..h {
        let y = h - 1 - r;
        for x in 0..w {
            let j = y * w + x;
            let wt = sums.weight[j];
            if let Some(e) = estimate {
                out[r * w + x] = e[j];
            } else if wt != 0.0 {
                let s = sums.sum[j];
                let wf = wt as f32;
                out[r * w + x] = Vec3::new(s[0] as f32 / wf, s[1] as f32 / wf, s[2] as f32 / wf);
            }
            if let Some(splat) = &sums.splat {
                let s = splat[j];
                out[r * w + x] += Vec3::new(s[0] as f32, s[1] as f32, s[2] as f32) * splat_scale as f32;
            }
        }
    }
    out
}

/// ∫∫ of the filter over its support: exact for the box, otherwise from the
/// separable 1D integral (midpoint rule, 4096 steps; both filters factor as
/// `f(x, y) = g(x)·g(y)`, so ∫∫f = (∫f(x, 0) dx)² / f(0, 0)).
fn filter_integral(filter: &Filter) -> f64 {
    let r = filter.radius() as f64;
    if let Filter::Box { .. } = filter {
        return 4.0 * r * r;
    }
    let n = 4096;
    let dx = 2.0 * r / n as f64;
    let line: f64 = (0..n)
        .map(|i| filter.eval((-r + (i as f64 + 0.5) * dx) as f32, 0.0) as f64 * dx)
        .sum();
    line * line / filter.eval(0.0, 0.0) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reused tile is a new one: same rectangle, zero sums, whatever it held.
    #[test]
    fn reset_tile_is_a_new_tile() {
        let mut t = FilmTile::new(0, 0, 16, 16, 2, 40, 30);
        t.splat(3, 4, Vec3::splat(2.0), 0.5);
        for (rect, reach) in [((16, 16, 32, 30), 2), ((32, 0, 40, 16), 0), ((0, 0, 40, 30), 3), ((8, 8, 9, 9), 1)] {
            t.reset(rect, reach, 40, 30);
            let fresh = FilmTile::new(rect.0, rect.1, rect.2, rect.3, reach, 40, 30);
            assert_eq!((t.x0, t.y0, t.w, t.h), (fresh.x0, fresh.y0, fresh.w, fresh.h));
            assert_eq!((&t.sum, &t.weight), (&fresh.sum, &fresh.weight));
            t.splat(t.x0, t.y0, Vec3::ONE, 1.0);
        }
    }

    /// Merging a pass's tiles in bands on several threads gives the sums of merging
    /// them one after another, bit for bit: overlapping tiles (a filter reaching two
    /// pixels), a film whose height is not a multiple of the band, sums that round
    /// differently in another order.
    #[test]
    fn merge_all_is_merge_tile_by_tile() {
        let (w, h) = (37, 45);
        let filter = Filter::gaussian(2.0, 2.0);
        let mut tiles = Vec::new();
        let mut k = 0u32;
        for y0 in (0..h).step_by(8) {
            for x0 in (0..w).step_by(8) {
                let mut t = FilmTile::new(x0, y0, (x0 + 8).min(w), (y0 + 8).min(h), filter.reach(), w, h);
                for y in y0..(y0 + 8).min(h) {
                    for x in x0..(x0 + 8).min(w) {
                        k += 1;
                        let u = crate::sampler::hash_u32(k) as f32 / 4_294_967_296.0;
                        // values of very different sizes, so the order of additions shows
                        let l = Vec3::new(u * 1e7, u, 1.0 / (u + 1e-3));
                        t.add(Vec2::new(x as f32 + u, y as f32 + 1.0 - u), l, &filter, w, h);
                    }
                }
                tiles.push(t);
            }
        }
        let (mut one_by_one, mut banded) = (Film::new(w as u32, h as u32, filter), Film::new(w as u32, h as u32, filter));
        for _ in 0..2 {
            for t in &tiles {
                one_by_one.merge(t);
            }
            banded.merge_all(&tiles.iter().collect::<Vec<_>>());
        }
        let bits = |f: &Film| -> Vec<u64> { f.sums.sum.iter().flatten().chain(&f.sums.weight).map(|x| x.to_bits()).collect() };
        assert_eq!(bits(&one_by_one), bits(&banded));
        // the tiles overlap, so the order matters: reversed, some sums differ
        let mut reversed = Film::new(w as u32, h as u32, filter);
        for _ in 0..2 {
            reversed.merge_all(&tiles.iter().rev().collect::<Vec<_>>());
        }
        assert_ne!(bits(&one_by_one), bits(&reversed), "a test whose tiles' order does not show");
    }

    #[test]
    fn floor_to_i32_is_floor() {
        for x in [
            0.0f32,
            -0.0,
            0.5,
            0.999_999_94,
            1.0,
            511.999_97,
            -0.5,
            -1.0,
            -1.5,
            1e10,
            -1e10,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ] {
            assert_eq!(floor_to_i32(x), x.floor() as i32, "{x}");
        }
    }

    #[test]
    fn box_filter_puts_each_sample_in_its_own_pixel() {
        let f = Filter::Box { radius: 0.5 };
        let mut t = FilmTile::new(0, 0, 4, 4, f.reach(), 4, 4);
        t.add(Vec2::new(1.99, 2.01), Vec3::ONE, &f, 4, 4);
        t.add(Vec2::new(4.0, 0.0), Vec3::ONE, &f, 4, 4); // outside: dropped
        let mut film = Film::new(4, 4, f);
        film.merge(&t);
        let img = film.to_rgb_rows(1.0);
        // film row 2 is output row 1
        assert_eq!(img[4 + 1], Vec3::ONE);
        assert_eq!(img.iter().filter(|v| **v != Vec3::ZERO).count(), 1);
    }

    #[test]
    fn filters_vanish_at_their_radius_and_peak_at_the_centre() {
        for f in [
            Filter::gaussian(1.5, 2.0),
            Filter::Mitchell {
                radius: 2.0,
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
        ] {
            let r = f.radius();
            assert!(f.eval(r, 0.0).abs() < 1e-6 && f.eval(r + 0.01, 0.0) == 0.0);
            assert!(f.eval(0.0, 0.0) > f.eval(0.5, 0.2));
        }
        assert_eq!(Filter::gaussian(1.5, 2.0).reach(), 1);
    }

    #[test]
    fn wide_filter_spreads_a_sample_over_neighbours() {
        let f = Filter::gaussian(1.5, 2.0);
        let mut t = FilmTile::new(1, 1, 2, 2, f.reach(), 3, 3);
        t.add(Vec2::new(1.5, 1.5), Vec3::ONE, &f, 3, 3);
        assert_eq!(t.weight.iter().filter(|w| **w > 0.0).count(), 9);
    }

    /// Filter importance sampling is an estimator of the filtered value: on one axis,
    /// the mean of weight · h(offset) over stratified samples, times ∫|f|, is ∫ f·h for
    /// each filter (mitchell's negative lobes included) and a test function h; the 2D
    /// weight is the product of the axes' signs.
    #[test]
    fn importance_sampled_offsets_integrate_the_filter() {
        let filters = [
            Filter::gaussian(1.5, 2.0),
            Filter::Mitchell {
                radius: 2.0,
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
            Filter::Tent { radius: 1.0 },
            Filter::Box { radius: 1.5 },
        ];
        let h = |x: f64| 1.0 + (1.3 * x).cos() + x * x;
        for f in filters {
            let FilmSampling::Importance(s) = FilmSampling::importance(&f) else {
                panic!("{f:?} is sampled by importance")
            };
            let g = |x: f64| f.eval(x as f32, 0.0) as f64;
            // ∫ g·h and ∫|g| by the midpoint rule on a fine grid
            let (r, n) = (f.radius() as f64, 200_000);
            let dx = 2.0 * r / n as f64;
            let (mut gh, mut abs) = (0.0, 0.0);
            for i in 0..n {
                let x = -r + (i as f64 + 0.5) * dx;
                gh += g(x) * h(x) * dx;
                abs += g(x).abs() * dx;
            }
            let m = 200_000;
            let (mut est, mut negative) = (0.0, 0);
            for i in 0..m {
                // v = ½: the offset's y is at the filter's centre, where it is positive
                let (d, w) = s.sample((i as f32 + 0.5) / m as f32, 0.5);
                assert!(d.x.abs() <= f.radius() && d.y.abs() < 0.05, "{f:?}: offset {d:?}");
                est += w as f64 * h(d.x as f64);
                negative += (w < 0.0) as u32;
            }
            est *= abs / m as f64;
            let err = (est / gh - 1.0).abs();
            eprintln!("{f:?}: ∫g·h {gh:.6}, estimate {est:.6}, relative error {err:.2e}, {negative} negative weights of {m}");
            assert!(err < 1e-3, "{f:?}: estimate {est} for ∫g·h = {gh} ({err:.2e} off)");
            assert_eq!(
                negative > 0,
                matches!(f, Filter::Mitchell { .. }),
                "{f:?}: {negative} negative weights"
            );
            if negative > 0 {
                // a negative lobe on both axes makes a positive weight
                let u = (0..m)
                    .map(|i| (i as f32 + 0.5) / m as f32)
                    .find(|&u| s.sample(u, 0.5).1 < 0.0)
                    .unwrap();
                assert_eq!((s.sample(u, u).1, s.sample(0.5, u).1), (1.0, -1.0));
            }
        }
        // a box of radius ½ keeps the plain sampling (the same images as before)
        assert_eq!(FilmSampling::importance(&Filter::Box { radius: 0.5 }), FilmSampling::Filter);
    }
}

/// Per-pixel sums of feature values, one box-filtered sample a pixel a pass (f64):
/// albedo RGB, normal XYZ, position XYZ, depth, hits (samples whose camera ray hit
/// something: depth and position are averaged over them), samples.
pub const AOV_VALUES: usize = 12;

/// The feature sums of a whole film (film rows, `y` up).
#[derive(Clone, Debug, PartialEq)]
pub struct AovSums {
    pub width: u32,
    pub height: u32,
    pub sums: Vec<[f64; AOV_VALUES]>,
}

impl AovSums {
    pub fn zero(width: u32, height: u32) -> AovSums {
        AovSums {
            width,
            height,
            sums: vec![[0.0; AOV_VALUES]; (width * height) as usize],
        }
    }
}

/// One camera sample's features ([`crate::integrator::aov`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AovSample {
    pub albedo: Vec3,
    pub normal: Vec3,
    pub position: Vec3,
    /// Distance from the camera to the first surface, `None` for a miss.
    pub depth: Option<f32>,
}

/// The feature sums of one tile.
pub struct AovTile {
    x0: i32,
    y0: i32,
    w: i32,
    h: i32,
    sums: Vec<[f64; AOV_VALUES]>,
}

impl AovTile {
    pub fn new(x0: i32, y0: i32, x1: i32, y1: i32) -> AovTile {
        let (w, h) = (x1 - x0, y1 - y0);
        AovTile {
            x0,
            y0,
            w,
            h,
            sums: vec![[0.0; AOV_VALUES]; (w * h) as usize],
        }
    }

    /// Adds the features of a sample of pixel (`x`, `y`) (film coordinates).
    pub fn add(&mut self, x: i32, y: i32, f: &AovSample) {
        let s = &mut self.sums[((y - self.y0) * self.w + x - self.x0) as usize];
        let v = |i: usize, a: Vec3, s: &mut [f64; AOV_VALUES]| {
            s[i] += a.x as f64;
            s[i + 1] += a.y as f64;
            s[i + 2] += a.z as f64;
        };
        v(0, f.albedo, s);
        v(3, f.normal, s);
        if let Some(d) = f.depth {
            v(6, f.position, s);
            s[9] += d as f64;
            s[10] += 1.0;
        }
        s[11] += 1.0;
    }
}
