//! `visualize_strategies` (pbrt-v4's view of BDPT): one render that also keeps every
//! strategy's MIS-weighted contribution in an image of its own. The `bdpt` image
//! itself is rendered as usual (the same bits as without the option); the strategy
//! images add up to it, and show which strategy carries which light.
//!
//! Each strategy's film sums only that strategy's contributions; its pixel weights
//! are the main film's (every sample counts in every pixel's weight, also where a
//! strategy contributed nothing), set when the images are made.

use super::{Bdpt, Engine, Select};
use crate::film::{Film, FilmTile, Splats};
use crate::integrator::pass::{camera_pass_with, tile_of, PassContext, PassResult};
use crate::math::Vec3;

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

/// A tile's share of the strategy images: each strategy's samples (a tile where it
/// contributed) and splats.
struct StrategyTiles {
    tiles: Vec<Option<FilmTile>>,
    splats: Vec<Splats>,
}

/// Pass `pass` of a `bdpt` render with `visualize_strategies`: [`camera_pass_with`]
/// with `bdpt`'s sample (the main film gets the same additions in the same order),
/// and every strategy's contribution added to its own film too.
pub fn render_pass(bdpt: &Bdpt, pc: &PassContext, pass: u32, film: &mut Film, state: &mut Option<StrategyFilms>) -> PassResult {
    let films = state.get_or_insert_with(|| StrategyFilms::new(bdpt.max_depth, film));
    let e = Engine::new(
        pc.scene,
        pc.camera,
        bdpt.max_depth,
        bdpt.heuristic,
        Select::Each,
        bdpt.connection_roulette,
    );
    let n = films.list.len();
    let (w, h) = (pc.film.width as i32, pc.film.height as i32);
    let filter = &pc.film.filter;
    let new_tile = || StrategyTiles {
        tiles: (0..n).map(|_| None).collect(),
        splats: vec![Splats::default(); n],
    };
    let (result, tiles) = camera_pass_with(pc, pass, film, new_tile, |cs, own| {
        let mut l = Vec3::ZERO;
        let mut seen: Vec<(usize, Vec3)> = Vec::new();
        let (splats, strategy_splats) = (&mut *cs.splats, &mut own.splats);
        e.sample_each(cs.ray, cs.diff, cs.sampler, cs.counts, |s, t, c, at| {
            let i = films.slot(s, t);
            match at {
                Some(at) => {
                    splats.add(at, c);
                    strategy_splats[i].add(at, c);
                }
                None => {
                    l += c;
                    seen.push((i, c));
                }
            }
        });
        // as the main film: only samples whose sum is finite
        if l.is_finite() {
            let (x0, y0, x1, y1) = tile_of(pc.film, cs.pixel);
            for (i, c) in seen {
                own.tiles[i]
                    .get_or_insert_with(|| FilmTile::new(x0, y0, x1, y1, filter.reach(), w, h))
                    .add(cs.pos, c, filter, w, h);
            }
        }
        l
    });
    for own in tiles {
        for (f, (tile, splats)) in films.films.iter_mut().zip(own.tiles.iter().zip(&own.splats)) {
            if let Some(t) = tile {
                f.merge(t);
            }
            f.add_splats(splats);
        }
    }
    result
}
