//! `visualize_strategies` (pbrt-v4's view of BDPT): one render that also keeps every
//! strategy's MIS-weighted contribution in an image of its own. The `bdpt` image
//! itself is rendered as usual (the same bits as without the option); the strategy
//! images add up to it, and show which strategy carries which light.
//!
//! Each strategy's film sums only that strategy's contributions; its pixel weights
//! are the main film's (every sample counts in every pixel's weight, also where a
//! strategy contributed nothing), set when the images are made.

use super::{ctx, Bdpt, Engine, Select};
use crate::film::{AovTile, Film, FilmTile, Splats};
use crate::integrator::pass::{differential_scale, lens_sample, tile_grid, PassContext, PassResult, RayCounts};
use crate::math::{Vec2, Vec3};
use crate::sampler::PixelSampler;
use rayon::prelude::*;

/// The strategies (s, t) of paths of 1 to `max_depth` segments that a `bdpt` image
/// sums, by path length, then s: (0, 2), (0, 3), (1, 2), (2, 1), (0, 4), …
/// (s = 1, t = 1 joins a light to the camera directly, which s = 0, t = 2 does).
pub fn strategy_list(max_depth: u32) -> Vec<(u32, u32)> {
    let mut list = Vec::new();
    for len in 1..=max_depth {
        for s in 0..=len {
            let t = len + 1 - s;
            if (s, t) != (1, 1) {
                list.push((s, t));
            }
        }
    }
    list
}

/// The strategy films a render keeps beside the main film (in the render loop's [`crate::integrator::PassState`]).
pub struct StrategyFilms {
    pub list: Vec<(u32, u32)>,
    /// Film per entry of `list`.
    films: Vec<Film>,
    /// `index[s * (max_depth + 2) + t]`: the entry of (s, t).
    index: Vec<usize>,
    stride: usize,
}

impl StrategyFilms {
    fn new(max_depth: u32, film: &Film) -> StrategyFilms {
        let list = strategy_list(max_depth);
        let stride = max_depth as usize + 2;
        let mut index = vec![usize::MAX; stride * stride];
        for (i, &(s, t)) in list.iter().enumerate() {
            index[s as usize * stride + t as usize] = i;
        }
        let films = list.iter().map(|_| Film::new(film.width, film.height, film.filter)).collect();
        StrategyFilms {
            list,
            films,
            index,
            stride,
        }
    }

    fn slot(&self, s: usize, t: usize) -> usize {
        self.index[s * self.stride + t]
    }

    /// Each strategy's image, named `s{s}_t{t}`, row 0 = top; `weights` are the main
    /// film's pixel weights over all passes, `splat_scale` is 1 / samples per pixel.
    pub fn images(&self, weights: &[f64], splat_scale: f64) -> Vec<(String, Vec<Vec3>)> {
        self.list
            .iter()
            .zip(&self.films)
            .map(|(&(s, t), f)| {
                let mut sums = f.sums().clone();
                sums.weight.copy_from_slice(weights);
                (format!("s{s}_t{t}"), f.rgb_rows_of(&sums, splat_scale))
            })
            .collect()
    }
}

/// Memory the strategy films of a `width × height` film take (sums, weights and
/// splats in f64, and a pass's tiles in f32), for the memory check.
pub fn memory_bytes(max_depth: u32, width: u32, height: u32) -> Option<u64> {
    let pixels = (width as u64).checked_mul(height as u64)?;
    (strategy_list(max_depth).len() as u64).checked_mul(pixels.checked_mul(24 + 8 + 24 + 16)?)
}

/// What one tile of a pass made: the main film's tile and splats, each strategy's
/// tile (only where it contributed) and splats.
struct TileResult {
    main: FilmTile,
    splats: Splats,
    strategy_tiles: Vec<Option<FilmTile>>,
    strategy_splats: Vec<Splats>,
    counts: RayCounts,
    /// Feature sums (`--aov`), as [`camera_pass`](crate::integrator::camera_pass) keeps them.
    aov: Option<AovTile>,
}

/// Pass `pass` of a `bdpt` render with `visualize_strategies`: as [`camera_pass`]
/// with `bdpt`'s sample (the main film gets the same additions in the same order),
/// and every strategy's contribution added to its own film too.
///
/// [`camera_pass`]: crate::integrator::camera_pass
pub fn render_pass(bdpt: &Bdpt, pc: &PassContext, pass: u32, film: &mut Film, state: &mut Option<StrategyFilms>) -> PassResult {
    let films = state.get_or_insert_with(|| StrategyFilms::new(bdpt.max_depth, film));
    let e = Engine {
        ctx: ctx(pc.scene, pc.camera),
        max_depth: bdpt.max_depth as usize,
        heuristic: bdpt.heuristic,
        select: Select::Each,
        roulette: bdpt.connection_roulette,
    };
    let n = films.list.len();
    let diff_scale = differential_scale(pc.target_spp);
    let (w, h) = (pc.film.width as i32, pc.film.height as i32);
    let filter = &pc.film.filter;
    let reach = filter.reach();
    let with_aov = film.aov().is_some();
    let done: Vec<Option<TileResult>> = tile_grid(pc.film)
        .par_iter()
        .map(|&(x0, y0, x1, y1)| {
            if pc.stop.is_stopped() {
                return None;
            }
            let mut r = TileResult {
                main: FilmTile::new(x0, y0, x1, y1, reach, w, h),
                splats: Splats::default(),
                strategy_tiles: (0..n).map(|_| None).collect(),
                strategy_splats: vec![Splats::default(); n],
                counts: RayCounts::default(),
                aov: with_aov.then(|| AovTile::new(x0, y0, x1, y1)),
            };
            for y in y0..y1 {
                for x in x0..x1 {
                    let mut sampler = PixelSampler::new(x as u32, y as u32, pass, pc.seed);
                    let (u, v) = sampler.next_2d();
                    let pos = Vec2::new(x as f32 + u, y as f32 + v);
                    let u_lens = lens_sample(pc.camera, &mut sampler);
                    let (ray, diff) = if pc.scene.uses_footprints {
                        let (ray, diff) = pc.camera.sample_ray_differential(pos.x, pos.y, u_lens);
                        (ray, Some(diff.scaled(&ray, diff_scale)))
                    } else {
                        (pc.camera.sample_ray(pos.x, pos.y, u_lens), None)
                    };
                    if let Some(aov) = &mut r.aov {
                        let mut aux = crate::integrator::aov::aov_sampler(x as u32, y as u32, pass, pc.seed);
                        aov.add(x, y, &crate::integrator::aov::features(pc.scene, &ray, &mut aux));
                    }
                    let mut l = Vec3::ZERO;
                    let mut own: Vec<(usize, Vec3)> = Vec::new();
                    let (splats, strategy_splats) = (&mut r.splats, &mut r.strategy_splats);
                    e.sample_each(ray, diff, &mut sampler, &mut r.counts, |s, t, c, at| {
                        let i = films.slot(s, t);
                        match at {
                            Some(at) => {
                                splats.add(at, c);
                                strategy_splats[i].add(at, c);
                            }
                            None => {
                                l += c;
                                own.push((i, c));
                            }
                        }
                    });
                    if l.is_finite() {
                        r.main.add(pos, l, filter, w, h);
                        for (i, c) in own {
                            r.strategy_tiles[i]
                                .get_or_insert_with(|| FilmTile::new(x0, y0, x1, y1, reach, w, h))
                                .add(pos, c, filter, w, h);
                        }
                    } else {
                        r.counts.invalid += 1;
                    }
                }
            }
            (pc.progress)(((x1 - x0) * (y1 - y0)) as u64);
            Some(r)
        })
        .collect();
    let mut result = PassResult {
        complete: done.iter().all(Option::is_some),
        counts: RayCounts::default(),
    };
    for r in done.iter().flatten() {
        result.counts += r.counts;
    }
    if result.complete {
        for r in done.iter().flatten() {
            film.merge(&r.main);
            film.add_splats(&r.splats);
            if let Some(aov) = &r.aov {
                film.merge_aov(aov);
            }
            for i in 0..n {
                if let Some(t) = &r.strategy_tiles[i] {
                    films.films[i].merge(t);
                }
                films.films[i].add_splats(&r.strategy_splats[i]);
            }
        }
    }
    result
}
