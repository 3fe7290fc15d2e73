//! What an integrator's pass works with: the scene, the camera and film settings,
//! a stop token checked per tile, counters, and the film itself. Camera-ray
//! integrators share [`camera_pass`], which renders one sample per pixel over
//! tiles on all cores and merges the tiles (and any splats) in a fixed order.

use crate::camera::Camera;
use crate::film::{AovTile, Film, FilmSettings, FilmTile, Splats};
use crate::geometry::{Ray, RayDifferential};
use crate::math::{Vec2, Vec3};
use crate::sampler::{first_2d_lanes, PixelSampler, LANES};
use crate::scene::Scene;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Asks a render to stop. Integrators check it per tile (or column), so a long
/// pass can be abandoned without waiting for its end.
#[derive(Debug, Default)]
pub struct StopToken {
    flag: AtomicBool,
}

impl StopToken {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn stop(&self) {
        self.flag.store(true, Ordering::SeqCst);
    }
    #[inline]
    pub fn is_stopped(&self) -> bool {
        self.flag.load(Ordering::Relaxed)
    }
}

/// Counters a render thread keeps for the benchmark figures and the NaN report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub rays: u64,
    /// Samples whose value was NaN or infinite (dropped).
    pub invalid: u64,
}

impl std::ops::AddAssign for RayCounts {
    fn add_assign(&mut self, o: RayCounts) {
        self.rays += o.rays;
        self.invalid += o.invalid;
    }
}

/// Everything a pass reads; the film it writes is passed beside it.
#[derive(Clone, Copy)]
pub struct PassContext<'a> {
    pub scene: &'a Scene,
    pub camera: &'a Camera,
    pub film: &'a FilmSettings,
    /// Samples per pixel of the whole render (the pass count of camera-ray integrators).
    /// A pass must not depend on it if the integrator's passes are independent
    /// ([`crate::integrator::Integrator::passes_independent`]): a resumed render or a
    /// shard would then differ from one render of all passes.
    pub spp: u32,
    /// The samples per pixel the scene declares: what a pass may use for a sampling
    /// density (the texture footprint) without depending on the render's length.
    pub target_spp: u32,
    pub seed: u32,
    /// `--time-limit` in seconds (the render loop enforces it; `guided` plans by it).
    pub time_limit: Option<f64>,
    pub stop: &'a StopToken,
    /// Called with the number of samples finished since the last call.
    pub progress: &'a (dyn Fn(u64) + Sync),
}

/// How a pass ended.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassResult {
    /// False when the stop token cut the pass short.
    pub complete: bool,
    pub counts: RayCounts,
}

/// One camera sample: the pixel sampler (its first two dimensions already spent
/// on the film position), the ray and its differentials when textures need them.
pub struct CameraSample<'s> {
    /// The pixel, and the film position in it.
    pub pixel: (i32, i32),
    pub pos: Vec2,
    pub ray: Ray,
    pub diff: Option<RayDifferential>,
    pub sampler: &'s mut PixelSampler,
    pub counts: &'s mut RayCounts,
    /// Contributions to other pixels (light tracing), merged after the pass.
    pub splats: &'s mut Splats,
}

/// A finished tile: its samples, splats, counters and feature sums (`--aov`).
type TileResult = (FilmTile, Splats, RayCounts, Option<AovTile>);

/// Renders sample index `pass` of every pixel: tiles in parallel, each sample's
/// radiance from `li`, tiles and splats merged into `film` in tile order, so
/// the result does not depend on the thread count. When the stop token is set,
/// tiles not yet started are skipped and nothing of the pass is merged.
pub fn camera_pass<F>(ctx: &PassContext, pass: u32, film: &mut Film, li: F) -> PassResult
where
    F: Fn(&mut CameraSample) -> Vec3 + Sync,
{
    camera_pass_with(ctx, pass, film, || (), |s, _| li(s)).0
}

/// [`camera_pass`] with something each tile collects besides its samples (`guided`'s
/// records), made by `new` and handed to `li` with every sample of the tile; the
/// tiles' collections come back in tile order (none when the pass was stopped).
pub fn camera_pass_with<T, N, F>(ctx: &PassContext, pass: u32, film: &mut Film, new: N, li: F) -> (PassResult, Vec<T>)
where
    T: Send,
    N: Fn() -> T + Sync,
    F: Fn(&mut CameraSample, &mut T) -> Vec3 + Sync,
{
    let diff_scale = differential_scale(ctx.target_spp);
    tile_pass(ctx, pass, film, |t| {
        let mut own = new();
        let (x0, y0, x1, y1) = t.rect;
        for y in y0..y1 {
            for x in x0..x1 {
                let (mut sampler, (pos, weight), ray, diff) = camera_sample(ctx, x, y, pass, diff_scale);
                t.add_features(x, y, &ray);
                let l = li(
                    &mut CameraSample {
                        pixel: (x, y),
                        pos,
                        ray,
                        diff,
                        sampler: &mut sampler,
                        counts: &mut t.counts,
                        splats: &mut t.splats,
                    },
                    &mut own,
                );
                t.add((x, y), pos, weight, l);
            }
        }
        own
    })
}

/// What a tile of a camera pass collects: its samples, splats, counters and
/// feature sums.
struct TileWork<'c, 'a> {
    ctx: &'c PassContext<'a>,
    pass: u32,
    /// The tile's pixels: x0, y0 (inclusive), x1, y1 (exclusive).
    rect: (i32, i32, i32, i32),
    tile: FilmTile,
    counts: RayCounts,
    splats: Splats,
    aov: Option<AovTile>,
}

impl TileWork<'_, '_> {
    /// Adds pixel `pixel`'s sample at film position `pos` with weight `weight` (see
    /// [`FilmSettings::sample_position`]); a non-finite one is dropped and counted,
    /// reported at the end.
    fn add(&mut self, pixel: (i32, i32), pos: Vec2, weight: f32, l: Vec3) {
        let film = self.ctx.film;
        if self.finite_or_counted(l) {
            if film.importance_sampled() {
                self.tile.add_to_pixel(pixel.0, pixel.1, l, weight);
            } else {
                self.tile.add(pos, l, &film.filter, film.width as i32, film.height as i32);
            }
        }
    }

    /// [`TileWork::add`] where the film's filter keeps each sample in its own pixel
    /// ([`crate::film::Filter::is_own_pixel_box`]), inlined into the caller's loop.
    #[inline(always)]
    fn add_own_pixel(&mut self, pos: Vec2, l: Vec3) {
        let film = self.ctx.film;
        debug_assert!(film.filter.is_own_pixel_box());
        if self.finite_or_counted(l) {
            self.tile.add_own_pixel(pos, l, film.width as i32, film.height as i32);
        }
    }

    /// Whether `l` is finite; a sample that is not is counted as invalid.
    #[inline(always)]
    fn finite_or_counted(&mut self, l: Vec3) -> bool {
        let ok = l.is_finite();
        if !ok {
            self.counts.invalid += 1;
        }
        ok
    }

    /// With `--aov`, adds the features of pixel `(x, y)`'s camera ray.
    fn add_features(&mut self, x: i32, y: i32, ray: &Ray) {
        if let Some(aov) = &mut self.aov {
            let mut aux = super::aov::aov_sampler(x as u32, y as u32, self.pass, self.ctx.seed);
            aov.add(x, y, &super::aov::features(self.ctx.scene, ray, &mut aux));
        }
    }
}

/// Runs `render_tile` on every tile of the film in parallel and merges the tiles
/// into `film` in tile order, so the result does not depend on the thread count.
/// When the stop token is set, tiles not yet started are skipped and nothing of
/// the pass is merged.
fn tile_pass<T, F>(ctx: &PassContext, pass: u32, film: &mut Film, render_tile: F) -> (PassResult, Vec<T>)
where
    T: Send,
    F: Fn(&mut TileWork) -> T + Sync,
{
    let (w, h) = (ctx.film.width as i32, ctx.film.height as i32);
    let with_aov = film.aov().is_some();
    let reach = ctx.film.filter.reach();
    let spare = std::sync::Mutex::new(std::mem::take(&mut film.spare_tiles));
    let new_tile = |x0, y0, x1, y1| {
        let reused = spare.lock().ok().and_then(|mut s| s.pop());
        match reused {
            Some(mut t) => {
                t.reset((x0, y0, x1, y1), reach, w, h);
                t
            }
            None => FilmTile::new(x0, y0, x1, y1, reach, w, h),
        }
    };
    let done: Vec<Option<(TileResult, T)>> = tile_grid(ctx.film)
        .par_iter()
        .map(|&(x0, y0, x1, y1)| {
            if ctx.stop.is_stopped() {
                return None;
            }
            let mut t = TileWork {
                ctx,
                pass,
                rect: (x0, y0, x1, y1),
                tile: new_tile(x0, y0, x1, y1),
                counts: RayCounts::default(),
                splats: Splats::default(),
                aov: with_aov.then(|| AovTile::new(x0, y0, x1, y1)),
            };
            let own = render_tile(&mut t);
            (ctx.progress)(((x1 - x0) * (y1 - y0)) as u64);
            Some(((t.tile, t.splats, t.counts, t.aov), own))
        })
        .collect();
    let (done, own): (Vec<_>, Vec<_>) = done.into_iter().map(Option::unzip).unzip();
    // the tiles' collections only when every tile was rendered (and merged)
    (merge_tiles(done, film), own.into_iter().collect::<Option<_>>().unwrap_or_default())
}

/// Pixel `(x, y)`'s sampler at sample index `pass` and the film position (and
/// weight) it draws first.
#[inline(always)]
fn film_sample(ctx: &PassContext, x: i32, y: i32, pass: u32) -> (PixelSampler, (Vec2, f32)) {
    let mut sampler = PixelSampler::new(x as u32, y as u32, pass, ctx.seed);
    let (u, v) = sampler.next_2d();
    (sampler, ctx.film.sample_position(x, y, u, v))
}

/// The camera sample of pixel `(x, y)` at sample index `pass`: its sampler (film
/// position and lens point drawn), the film position and the sample's weight, the ray
/// and its differentials.
#[inline(always)]
pub fn camera_sample(
    ctx: &PassContext,
    x: i32,
    y: i32,
    pass: u32,
    diff_scale: f32,
) -> (PixelSampler, (Vec2, f32), Ray, Option<RayDifferential>) {
    let (mut sampler, (pos, weight)) = film_sample(ctx, x, y, pass);
    let u_lens = lens_sample(ctx.camera, &mut sampler);
    // differentials only matter to image textures: skip them otherwise
    let (ray, diff) = if ctx.scene.uses_footprints {
        let (ray, diff) = ctx.camera.sample_ray_differential(pos.x, pos.y, u_lens);
        (ray, Some(diff.scaled(&ray, diff_scale)))
    } else {
        (ctx.camera.sample_ray(pos.x, pos.y, u_lens), None)
    };
    (sampler, (pos, weight), ray, diff)
}

/// Merges a pass's tiles (and splats, feature sums) into the film in tile order, if
/// every tile was rendered.
fn merge_tiles(done: Vec<Option<TileResult>>, film: &mut Film) -> PassResult {
    let mut result = PassResult {
        complete: done.iter().all(Option::is_some),
        counts: RayCounts::default(),
    };
    for (_, _, c, _) in done.iter().flatten() {
        result.counts += *c;
    }
    if result.complete {
        // each buffer takes its tiles' parts in tile order
        let tiles: Vec<&FilmTile> = done.iter().flatten().map(|r| &r.0).collect();
        film.merge_all(&tiles);
        for (_, splats, _, aov) in done.iter().flatten() {
            film.add_splats(splats);
            if let Some(aov) = aov {
                film.merge_aov(aov);
            }
        }
    }
    film.spare_tiles.extend(done.into_iter().flatten().map(|r| r.0));
    result
}

/// Pixel blocks of [`camera_pass_blocks`]: 4×4, one packet of coherent camera rays.
pub const BLOCK_W: i32 = 4;
pub const BLOCK_H: i32 = 4;
// a block's first samples are drawn as one set of sampler lanes
const _: () = assert!((BLOCK_W * BLOCK_H) as usize == LANES);

/// The camera samples of a pixel block (up to [`BLOCK_W`]×[`BLOCK_H`] pixels, rows
/// in order): what a packet integrator shades together.
pub struct CameraBlock<'s> {
    /// The pixels, and their film positions.
    pub pixels: &'s [(i32, i32)],
    pub pos: &'s [Vec2],
    pub rays: &'s [Ray],
    pub diffs: &'s [Option<RayDifferential>],
    pub samplers: &'s mut [PixelSampler],
    pub counts: &'s mut RayCounts,
    pub splats: &'s mut Splats,
}

/// [`camera_pass`] with the samples handed to `li` a pixel block at a time (it
/// writes one radiance per sample into its second argument). The image is the
/// same as [`camera_pass`]'s with the same per-sample radiance: each pixel's
/// sampler is its own, and the tile adds the samples in the same (row) order.
pub fn camera_pass_blocks<F>(ctx: &PassContext, pass: u32, film: &mut Film, li: F) -> PassResult
where
    F: Fn(&mut CameraBlock, &mut [Vec3]) + Sync,
{
    camera_pass_blocks_with(ctx, pass, film, || (), |b, out, _| li(b, out)).0
}

/// [`camera_pass_blocks`] with something each tile collects besides its samples (as
/// [`camera_pass_with`]), handed to `li` with every block of the tile; the tiles'
/// collections come back in tile order (none when the pass was stopped).
pub fn camera_pass_blocks_with<T, N, F>(ctx: &PassContext, pass: u32, film: &mut Film, new: N, li: F) -> (PassResult, Vec<T>)
where
    T: Send,
    N: Fn() -> T + Sync,
    F: Fn(&mut CameraBlock, &mut [Vec3], &mut T) + Sync,
{
    const N: usize = (BLOCK_W * BLOCK_H) as usize;
    let diff_scale = differential_scale(ctx.target_spp);
    // no lens, no differentials, no clipping: the block's rays are made together
    let plain_pinhole = ctx.camera.is_plain_pinhole() && !ctx.scene.uses_footprints;
    let isa = ctx.scene.bvh.isa();
    // the block loop (samplers, camera rays, film adds, the integrator's inlined code)
    // compiled for the render's kernel set
    tile_pass(ctx, pass, film, |t| {
        let mut own = new();
        isa.run(
            #[inline(always)]
            || {
                let (x0, y0, x1, y1) = t.rect;
                let tw = (x1 - x0) as usize;
                // each pixel's film position and radiance, added in row order at the end; a box
                // of radius ≤ ½ puts each sample in its own pixel only, where the order of the
                // additions cannot matter, so those are added as each block is done
                let in_order = t.aov.is_some() || !ctx.film.filter.is_own_pixel_box();
                let mut done_px = vec![(Vec2::ZERO, 1.0f32, Vec3::ZERO); if in_order { tw * (y1 - y0) as usize } else { 0 }];
                // each block's samplers written over the last block's (no copies of them)
                let mut samplers = [PixelSampler::new(0, 0, 0, 0); N];
                for by in (y0..y1).step_by(BLOCK_H as usize) {
                    for bx in (x0..x1).step_by(BLOCK_W as usize) {
                        // the block's pixels, rows in order (no allocation per block)
                        let (mut px, mut n) = ([(0, 0); N], 0);
                        for y in by..(by + BLOCK_H).min(y1) {
                            for x in bx..(bx + BLOCK_W).min(x1) {
                                px[n] = (x, y);
                                n += 1;
                            }
                        }
                        let px = &px[..n];
                        let mut pos = [Vec2::ZERO; N];
                        let mut weights = [1.0f32; N];
                        let mut rays = [Ray::IDLE; N];
                        let mut diffs = [None; N];
                        if plain_pinhole {
                            // `camera_sample` with the samples and rays made together (lanes past
                            // `n` repeat the last pixel)
                            let (xs, ys) = (
                                std::array::from_fn(|i| px[i.min(n - 1)].0 as u32),
                                std::array::from_fn(|i| px[i.min(n - 1)].1 as u32),
                            );
                            let uv = first_2d_lanes(isa, &xs, &ys, pass, ctx.seed, &mut samplers);
                            let (mut fx, mut fy) = ([0.0f32; N], [0.0f32; N]);
                            for (i, &(x, y)) in px.iter().enumerate() {
                                let (p, w) = ctx.film.sample_position(x, y, uv[i].0, uv[i].1);
                                (pos[i], weights[i], fx[i], fy[i]) = (p, w, p.x, p.y);
                            }
                            ctx.camera.pinhole_rays(&fx, &fy, n, &mut rays);
                        } else {
                            for (i, &(x, y)) in px.iter().enumerate() {
                                let (s, (p, w), r, d) = camera_sample(ctx, x, y, pass, diff_scale);
                                (pos[i], weights[i], rays[i], diffs[i], samplers[i]) = (p, w, r, d, s);
                            }
                        }
                        let mut l = [Vec3::ZERO; N];
                        li(
                            &mut CameraBlock {
                                pixels: px,
                                pos: &pos[..n],
                                rays: &rays[..n],
                                diffs: &diffs[..n],
                                samplers: &mut samplers[..n],
                                counts: &mut t.counts,
                                splats: &mut t.splats,
                            },
                            &mut l[..n],
                            &mut own,
                        );
                        for (i, &(x, y)) in px.iter().enumerate() {
                            if in_order {
                                done_px[(y - y0) as usize * tw + (x - x0) as usize] = (pos[i], weights[i], l[i]);
                            } else {
                                t.add_own_pixel(pos[i], l[i]);
                            }
                        }
                    }
                }
                if !in_order {
                    return;
                }
                for y in y0..y1 {
                    for x in x0..x1 {
                        if t.aov.is_some() {
                            let ray = camera_sample(ctx, x, y, pass, diff_scale).2;
                            t.add_features(x, y, &ray);
                        }
                        let (pos, weight, l) = done_px[(y - y0) as usize * tw + (x - x0) as usize];
                        t.add((x, y), pos, weight, l);
                    }
                }
            },
        );
        own
    })
}

/// The lens point's sample for a camera ray: a thin lens takes the pixel sampler's next
/// two dimensions, a pinhole or orthographic camera none (so their images stay as they were).
fn lens_sample(camera: &Camera, sampler: &mut PixelSampler) -> Vec2 {
    if camera.has_lens() {
        Vec2::from(sampler.next_2d())
    } else {
        Vec2::ZERO
    }
}

/// Camera-ray differentials span one pixel; with `spp` samples per pixel (the scene's
/// declared count, not `--spp`: see [`PassContext::target_spp`]) each sample
/// stands for a smaller footprint, so they are scaled by `max(1/8, 1/√spp)` (pbrt-v4).
/// Textures are then filtered over about one sample's share of the pixel: a 1-spp
/// image is antialiased by the MIP pyramid, and many samples converge to the
/// supersampled (not the over-blurred) picture.
pub fn differential_scale(spp: u32) -> f32 {
    (1.0 / (spp.max(1) as f32).sqrt()).max(0.125)
}

/// The tile of [`tile_grid`] that holds pixel `(x, y)`.
pub fn tile_of(film: &FilmSettings, (x, y): (i32, i32)) -> (i32, i32, i32, i32) {
    let b = film.block_size.max(1) as i32;
    let (x0, y0) = (x / b * b, y / b * b);
    (x0, y0, (x0 + b).min(film.width as i32), (y0 + b).min(film.height as i32))
}

/// Tiles of `block_size`² pixels in row order (film `y` up), clipped to the film.
pub fn tile_grid(film: &FilmSettings) -> Vec<(i32, i32, i32, i32)> {
    let b = film.block_size.max(1) as usize;
    let rows = (0..film.height as i32).step_by(b);
    rows.flat_map(|y| (0..film.width as i32).step_by(b).map(move |x| tile_of(film, (x, y))))
        .collect()
}
