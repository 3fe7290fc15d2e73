//! Stochastic progressive photon mapping (Hachisuka & Jensen 2009), the `sppm`
//! integrator, in the design of pbrt-v4's `SPPMIntegrator` but with photons in a
//! kd-tree gathered per pixel (rather than visible points in a grid splatted by
//! photons): every iteration (= pass) traces one camera sample per pixel to its
//! visible point (through specular and glossy bounces, light sampling at every
//! non-specular vertex), shoots a fresh photon map, and each pixel gathers the
//! photons within its own radius `r`. With M photons counted this iteration
//! (see [`super::photon`] for which count),
//!
//! `N' = N + αM`, `r' = r·√(N'/(N + M))`, `τ' = (τ + β·Σ f·Φ)·(r'/r)²`,
//!
//! and the pixel is `Σ L_direct / n + τ / (n · N_photons · π r²)` after n
//! iterations. Pixels are independent, so the image depends only on the seed and
//! the iteration count; the state lives in the render loop's [`super::PassState`]
//! between passes. Camera samples are [`super::camera_pass`]'s, ray differentials
//! included: the camera ray's hit looks its textures up over the ray's footprint, as
//! `path` and `photon` do (and pbrt-v4's SPPM), so at the same declared spp they see the
//! same filtered textures. The pixel is its own square for the estimate (box filter of
//! radius ½; other filters are ignored).

use super::pass::camera_pass_with;
use super::photon::{camera_path, shoot, Shooting, BYTES_PER_PHOTON};
use super::{PassContext, PassResult};
use crate::film::Film;
use crate::math::{Vec3, PI};

/// Parameters (JSON `integrator` keys, besides `type`):
/// * `spp` (int ≥ 1, 64) — iterations, one camera sample per pixel each (`--spp`
///   and `--time-limit` count them as for every integrator);
/// * `photons_per_iteration` (int ≥ 1, 100000);
/// * `initial_radius` (number > 0; absent: 4 pixel footprints at each pixel's
///   first visible point, i.e. 4 × path length × the pixel's angle);
/// * `alpha` (number in (0, 1], 2/3) — the fraction of new photons kept;
/// * `max_depth` (int ≥ 1, 12) — segments, camera and photon together;
/// * `rr_threshold` (number in [0, 1], 0.1) — photon Russian roulette, as `photon`.
///
/// ```json
/// {"type": "sppm", "spp": 256, "photons_per_iteration": 200000}
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sppm {
    pub photons_per_iteration: u32,
    pub initial_radius: Option<f32>,
    pub alpha: f32,
    pub max_depth: u32,
    pub rr_threshold: f32,
}

/// Pixel footprints the default initial radius spans.
pub const FOOTPRINTS: f32 = 4.0;

#[derive(Clone, Copy, Debug, Default)]
struct Pixel {
    /// Sum of direct light (and emission) over the iterations.
    ld: Vec3,
    tau: Vec3,
    n: f32,
    /// 0 until the pixel's first visible point.
    r: f32,
}

/// The pixels' statistics between passes.
#[derive(Debug, Default)]
pub struct State {
    pixels: Vec<Pixel>,
    iterations: u32,
    photons_emitted: u64,
    photons_stored: u64,
    map_bytes: usize,
}

impl Sppm {
    /// Iteration `pass`: the pixels' statistics in `state` (the image is
    /// [`State::image`]); the film gets the direct light's samples.
    pub fn render_pass(&self, ctx: &PassContext, pass: u32, film: &mut Film, state: &mut Option<State>) -> PassResult {
        let scene = ctx.scene;
        let (w, h) = (ctx.film.width as usize, ctx.film.height as usize);
        debug_assert_eq!(w * h, film.width as usize * film.height as usize);
        let shooting = Shooting::for_maps(self.photons_per_iteration, self.max_depth, self.rr_threshold);
        let Some(map) = shoot(scene, shooting, pass, ctx.seed, ctx.stop, false) else {
            return PassResult::default();
        };
        let state = state.get_or_insert_with(|| State {
            pixels: vec![Pixel::default(); w * h],
            ..State::default()
        });
        let spread = ctx.camera.pixel_spread();
        let (alpha, max_depth) = (self.alpha, self.max_depth);
        let pixels = &state.pixels;
        // camera_pass's samples (the film gets each visible point's direct light, and
        // the features with `--aov`); each tile collects its pixels' new statistics
        let new_tile = || (Vec::<(usize, Pixel)>::new(), Vec::new());
        let (mut result, tiles) = camera_pass_with(ctx, pass, film, new_tile, |s, (updated, slots)| {
            let (x, y) = s.pixel;
            let i = y as usize * w + x as usize;
            let mut px = pixels[i];
            let (l, vp) = camera_path(scene, s.ray, s.diff, s.sampler, s.counts, max_depth, true);
            if l.is_finite() {
                px.ld += l;
            }
            updated.push((i, px));
            let Some(vp) = vp else { return l };
            let px = &mut updated.last_mut().expect("pushed above").1;
            if px.r == 0.0 {
                px.r = self.initial_radius.unwrap_or(FOOTPRINTS * spread * vp.distance);
            }
            if px.r <= 0.0 || !px.r.is_finite() {
                return l;
            }
            slots.clear();
            map.tree.within(&vp.p.to_array(), px.r, |s, _| slots.push(s));
            let (phi, m) = vp.gather(&map, max_depth, slots.iter().copied());
            if m == 0 {
                return l;
            }
            let add = vp.beta * phi;
            if !add.is_finite() {
                s.counts.invalid += 1;
                return l;
            }
            let n_new = px.n + alpha * m as f32;
            let r_new = px.r * (n_new / (px.n + m as f32)).sqrt();
            px.tau = (px.tau + add) * ((r_new * r_new) / (px.r * px.r));
            px.n = n_new;
            px.r = r_new;
            l
        });
        result.counts.rays += map.rays;
        if result.complete {
            for (i, px) in tiles.into_iter().flat_map(|t| t.0) {
                state.pixels[i] = px;
            }
            state.iterations += 1;
            state.photons_emitted += map.emitted;
            state.photons_stored += map.photons.len() as u64;
            state.map_bytes = state.map_bytes.max(map.bytes());
        }
        result
    }
}

impl State {
    /// The pixels' values after the iterations so far (film rows, `y` up); `None`
    /// before the first.
    pub fn image(&self) -> Option<Vec<Vec3>> {
        if self.iterations == 0 {
            return None;
        }
        let n = self.iterations as f32;
        let photons = self.photons_emitted as f32;
        let image = self
            .pixels
            .iter()
            .map(|p| {
                let indirect = if p.r > 0.0 {
                    p.tau / (photons * PI * p.r * p.r)
                } else {
                    Vec3::ZERO
                };
                p.ld / n + indirect
            })
            .collect();
        Some(image)
    }

    /// Photon counts, memory and radii, for the render summary.
    pub fn summary(&self) -> String {
        let mut radii: Vec<f32> = self.pixels.iter().map(|p| p.r).filter(|r| *r > 0.0).collect();
        radii.sort_by(f32::total_cmp);
        let q = |f: f64| radii.get(((radii.len() as f64 - 1.0) * f).round() as usize).copied().unwrap_or(0.0);
        format!(
            "sppm: {} iterations, {} photons shot, {} stored ({:.0} per iteration, at most {:.1} MB, {} bytes per photon); final radius min/median/max {:.3e}/{:.3e}/{:.3e}",
            self.iterations,
            self.photons_emitted,
            self.photons_stored,
            self.photons_stored as f64 / self.iterations.max(1) as f64,
            self.map_bytes as f64 / 1e6,
            BYTES_PER_PHOTON,
            q(0.0),
            q(0.5),
            q(1.0)
        )
    }
}
