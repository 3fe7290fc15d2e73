//! Integrators: a closed family, each owning how it renders a pass into the film.
//! The render loop ([`crate::render`](mod@crate::render)) only runs passes: it asks
//! [`Integrator::pass_count`] how many, and calls [`Integrator::render_pass`] for
//! each, with a [`StopToken`] the integrator checks per tile and the
//! integrator's [`PassState`], which the loop owns.
//!
//! Adding an integrator: one file with its parameters and its pass, one arm here
//! (and one in [`Integrator::render_pass`]), one in the scene reader.

pub mod aov;
pub mod bdpt;
pub mod ears;
pub mod estimator;
pub mod guided;
pub mod intersection_test;
pub mod normals;
pub mod pass;
pub mod path;
pub mod photon;
pub mod ptracer;
pub mod sppm;
pub mod state;

pub use bdpt::Bdpt;
pub use estimator::PathProfile;
pub use guided::Guided;
pub use intersection_test::IntersectionTest;
pub use normals::Normals;
pub use pass::{camera_pass, camera_pass_blocks, CameraBlock, CameraSample, PassContext, PassResult, RayCounts, StopToken};
pub use path::{PathTracer, Roulette};
pub use photon::PhotonMapper;
pub use ptracer::Ptracer;
pub use sppm::Sppm;
pub use state::PassState;

use crate::compat::rdr171::Rdr171Columns;
use crate::film::Film;
use crate::geometry::ray::RAY_T_MAX;
use crate::geometry::Ray;
use crate::light::{LightSample, ShadowTarget};
use crate::math::{offset_ray_origin, Vec3};
use crate::scene::Interaction;

/// The integrator a render job runs, with its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integrator {
    IntersectionTest(IntersectionTest),
    Path(PathTracer),
    /// Bidirectional path tracing.
    Bdpt(Bdpt),
    /// Path guiding (Müller et al. 2017): a path tracer sampling a learned SD-tree.
    Guided(Guided),
    /// Light tracing (particle tracing) alone.
    Ptracer(Ptracer),
    Normals(Normals),
    /// Photon mapping: direct light by light sampling, the rest from k-NN photon maps.
    Photon(PhotonMapper),
    /// Stochastic progressive photon mapping.
    Sppm(Sppm),
    /// The course renderer's `intersection_test`, quirks and all (`--compat rdr171`,
    /// [`crate::compat::rdr171`]).
    Rdr171(Rdr171Columns),
}

impl Integrator {
    /// The name scenes use for it.
    pub fn name(&self) -> &'static str {
        match self {
            Integrator::IntersectionTest(_) => "intersection_test",
            Integrator::Path(_) => "path",
            Integrator::Bdpt(_) => "bdpt",
            Integrator::Guided(_) => "guided",
            Integrator::Ptracer(_) => "ptracer",
            Integrator::Normals(_) => "normals",
            Integrator::Photon(_) => "photon",
            Integrator::Sppm(_) => "sppm",
            Integrator::Rdr171(_) => "intersection_test (rdr171)",
        }
    }

    /// Passes a render of `spp` samples per pixel takes: one sample per pixel per
    /// pass (fine steps for `--time-limit` and Ctrl-C), or one pass for the
    /// column renderer of `--compat rdr171`; `photon` takes `spp` passes for
    /// each of its iterations.
    pub fn pass_count(&self, spp: u32) -> u32 {
        match self {
            Integrator::Rdr171(_) => 1,
            Integrator::Photon(p) => p.pass_count(spp),
            _ => spp,
        }
    }

    /// Whether pass `p` depends only on the scene, the seed, the declared target spp and
    /// `p` itself: not on earlier passes (SPPM's radii, a photon map per iteration of
    /// `spp` passes) nor on the render's total spp. Only then can a render be resumed
    /// (`--resume`) or split into shards (`--shard`) and give the same bits as one
    /// render; the others refuse both. An integrator opting in must also keep its
    /// pass's contributions in the film's sums and splats and nothing in its
    /// [`PassState`], which is not saved.
    pub fn passes_independent(&self) -> bool {
        match self {
            // the strategy images of `visualize_strategies` live outside the film state
            Integrator::Bdpt(b) => !b.visualize_strategies,
            // EARS learns its factors from the passes before
            Integrator::Path(p) => p.rr == Roulette::Mitsuba,
            Integrator::IntersectionTest(_) | Integrator::Ptracer(_) | Integrator::Normals(_) => true,
            // the guiding tree learns from the passes before
            Integrator::Photon(_) | Integrator::Sppm(_) | Integrator::Guided(_) | Integrator::Rdr171(_) => false,
        }
    }

    /// Whether `--aov` feature buffers come with its passes: those of the integrators
    /// whose camera samples go through [`camera_pass`] into the render's film (`guided`'s
    /// go into films of its iterations).
    pub fn supports_aov(&self) -> bool {
        match self {
            Integrator::IntersectionTest(_)
            | Integrator::Path(_)
            | Integrator::Bdpt(_)
            | Integrator::Ptracer(_)
            | Integrator::Normals(_)
            | Integrator::Photon(_)
            | Integrator::Sppm(_) => true,
            Integrator::Guided(_) | Integrator::Rdr171(_) => false,
        }
    }

    /// Samples per pixel that `passes` finished passes stand for.
    pub fn spp_done(&self, spp: u32, passes: u32) -> u32 {
        match self {
            Integrator::Rdr171(_) => spp.saturating_mul(passes),
            _ => passes,
        }
    }

    /// Renders pass `pass` (0-based) into `film`, with the state the integrator
    /// keeps between passes in `state` (start with [`PassState::default`]).
    pub fn render_pass(&self, ctx: &PassContext, pass: u32, film: &mut Film, state: &mut PassState) -> PassResult {
        let scene = ctx.scene;
        match self {
            Integrator::IntersectionTest(i) if i.packets(scene) => camera_pass_blocks(ctx, pass, film, |b, out| i.li_block(scene, b, out)),
            Integrator::IntersectionTest(i) => camera_pass(ctx, pass, film, |s| i.li(scene, s.ray, s.diff, s.sampler, s.counts)),
            Integrator::Path(p) if p.rr == Roulette::Ears => ears::render_pass(p, ctx, pass, film, state.ears()),
            Integrator::Path(p) if scene.packets() && !scene.has_media => p.render_pass_blocks(ctx, pass, film),
            Integrator::Path(p) => camera_pass(ctx, pass, film, |s| p.li(scene, s.ray, s.diff, s.sampler, s.counts)),
            Integrator::Bdpt(b) if b.visualize_strategies => bdpt::strategies::render_pass(b, ctx, pass, film, state.strategies()),
            Integrator::Bdpt(b) => camera_pass(ctx, pass, film, |s| b.li(scene, ctx.camera, s)),
            Integrator::Ptracer(p) => camera_pass(ctx, pass, film, |s| p.li(scene, ctx.camera, s)),
            Integrator::Normals(n) => camera_pass(ctx, pass, film, |s| n.li(scene, s.ray, s.counts)),
            Integrator::Photon(p) => p.render_pass(ctx, pass, film, state.photon()),
            Integrator::Guided(g) => g.render_pass(ctx, state.guided()),
            Integrator::Sppm(p) => p.render_pass(ctx, pass, film, state.sppm()),
            Integrator::Rdr171(c) => {
                // the whole render in one pass
                let column = ctx.film.height as u64 * ctx.spp as u64;
                let stopped = || ctx.stop.is_stopped();
                let complete = c.render(film, (scene, ctx.camera, ctx.film), ctx.spp, &stopped, &|| (ctx.progress)(column));
                let counts = RayCounts::default();
                PassResult { complete, counts }
            }
        }
    }

    /// The image of integrators whose pixel value is not the film's average of
    /// samples (`sppm`, `guided`), from their state: film rows, `y` up; `None` for
    /// the others (and before a first pass).
    pub fn estimate(&self, state: &PassState, width: usize) -> Option<Vec<Vec3>> {
        match (self, state) {
            (Integrator::Sppm(_), PassState::Sppm(Some(s))) => s.image(),
            (Integrator::Guided(g), PassState::Guided(Some(s))) => Some(g.image(s, width)),
            _ => None,
        }
    }

    /// Images an integrator makes besides the main one (`bdpt`'s strategy images),
    /// named, row 0 = top; `weights` gives the film's pixel weights over all passes (the
    /// film itself may hold only the last block's), `splat_scale` is 1 / samples per pixel.
    pub fn extra_images(&self, state: &PassState, weights: impl FnOnce() -> Vec<f64>, splat_scale: f64) -> Vec<(String, Vec<Vec3>)> {
        match (self, state) {
            (Integrator::Bdpt(b), PassState::Strategies(Some(f))) if b.visualize_strategies => f.images(&weights(), splat_scale),
            _ => Vec::new(),
        }
    }

    /// A line for the render summary (photon counts, memory, radii), if any.
    pub fn summary(&self, state: &PassState) -> Option<String> {
        match (self, state) {
            (Integrator::Photon(p), PassState::Photon(Some(s))) => Some(p.summary(s)),
            (Integrator::Sppm(_), PassState::Sppm(Some(s))) => Some(s.summary()),
            (Integrator::Guided(g), PassState::Guided(Some(s))) => Some(g.summary(s)),
            (Integrator::Path(_), PassState::Ears(Some(s))) => Some(s.summary()),
            _ => None,
        }
    }
}

/// A ray leaving a surface in direction `d`, its origin pushed off the surface
/// to the side `d` goes (robust offset, so `t_min` can be 0).
#[inline]
pub fn spawn_ray(it: &Interaction, d: Vec3) -> Ray {
    let n = if d.dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
    Ray::with_range(offset_ray_origin(it.p, n), d, 0.0, RAY_T_MAX)
}

/// A shadow ray from a surface towards a light sample, stopping just short of
/// the light: both ends are pushed off their surfaces.
#[inline(always)]
pub fn shadow_ray(it: &Interaction, ls: &LightSample) -> Ray {
    match ls.target {
        ShadowTarget::Infinity => spawn_ray(it, ls.wi),
        ShadowTarget::Point { p, n } => {
            let side = if (p - it.p).dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
            ray_to_light(offset_ray_origin(it.p, side), it.p, p, n)
        }
    }
}

/// A shadow ray from a point in a medium (no surface to leave) towards a light sample.
#[inline]
pub fn shadow_ray_from_point(x: Vec3, ls: &LightSample) -> Ray {
    match ls.target {
        ShadowTarget::Infinity => Ray::with_range(x, ls.wi, 0.0, RAY_T_MAX),
        ShadowTarget::Point { p, n } => ray_to_light(x, x, p, n),
    }
}

/// The ray from `o` (pushed off the point `from`) to the light point `p` (pushed off its
/// surface, of normal `n`, towards `from`), stopping just short of it.
#[inline(always)]
fn ray_to_light(o: Vec3, from: Vec3, p: Vec3, n: Option<Vec3>) -> Ray {
    let target = match n {
        Some(n) => offset_ray_origin(p, if (from - p).dot(n) >= 0.0 { n } else { -n }),
        None => p,
    };
    let v = target - o;
    let dist = v.length();
    Ray::with_range(o, v / dist, 0.0, dist * (1.0 - 1e-5))
}
