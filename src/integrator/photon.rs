//! Photon mapping (the `photon` integrator, Jensen's two passes) and what it
//! shares with [`super::sppm`]: shooting photons, and the camera path to a visible
//! point (the camera-path estimator's steps, direct light by light sampling).
//!
//! **Path lengths.** A camera path reaches its visible point after `k` segments
//! (1 when the surface is seen directly, more through specular bounces); a photon
//! is deposited after `s` segments from its light (1: straight from the light).
//! Direct light at the visible point comes from light sampling (length `k + 1`),
//! so only photons with `s ≥ 2` are stored, and a photon counts at a visible point
//! only if `k + s ≤ max_depth`: `photon`, `sppm` and `path` then mean the same
//! image for the same `max_depth` (up to the density estimate's blur).
//!
//! **Photons** leave the lights in proportion to power (the scene's light
//! sampler), start with flux `Le·|cos| / (pmf · pdf_pos · pdf_dir)`, and carry
//! flux, scattered by the adjoint BSDF ([`crate::material::adjoint`]: importance
//! transport at refractions, Veach's shading-normal correction). They are stored at every
//! non-specular surface after the first segment and continue by BSDF sampling;
//! Russian roulette (`rr_threshold`) starts once a photon's flux drops below that
//! fraction of its initial flux, survivors keep at least that fraction.
//! Random numbers: one [`SplitMix64`] per photon, seeded by (seed, iteration,
//! photon index); photons are shot in chunks of [`CHUNK`] in parallel and
//! concatenated in chunk order, so the map does not depend on the thread count.
//!
//! **Gathering.** At a visible point with BSDF `f` and camera throughput `β`,
//! `L = β · Σ f(wo, wi_p) · Φ_p / (N_emitted · π r²)` over the photons within
//! `r`. Photons whose direction lies on the other side of the surface (f = 0)
//! contribute nothing, and SPPM does not count them in its radius update.

use super::estimator::{trace, PathProfile, PathState, Policy};
use super::{camera_pass, spawn_ray, PassContext, PassResult, RayCounts, StopToken};
use crate::accel::photon_map::KdTree;
use crate::film::Film;
use crate::geometry::{Ray, RayDifferential};
use crate::light::SceneBounds;
use crate::material::{Bsdf, BsdfKind, Normals};
use crate::math::{offset_ray_origin, Vec2, Vec3, PI};
use crate::sampler::PixelSampler;
use crate::sampling::{mix64, SplitMix64};
use crate::scene::{Interaction, Scene};
use rayon::prelude::*;
use std::cell::RefCell;

/// Photons per parallel work item (and per stop-token check).
pub const CHUNK: usize = 4096;

/// A photon at a surface: where it came from, its flux, its path length.
#[derive(Clone, Copy, Debug)]
pub struct Photon {
    /// Unit direction back towards where the photon came from.
    pub wi: Vec3,
    pub power: Vec3,
    /// Segments from the light to here (≥ 2).
    pub segments: u32,
}

/// Bytes a stored photon takes: the kd-tree's point (12 + 4 + 1) and the payload.
pub const BYTES_PER_PHOTON: usize = KdTree::<3>::BYTES_PER_POINT + std::mem::size_of::<Photon>();

/// The photons of one iteration in a kd-tree; `photons[slot]` is the tree's point `slot`.
#[derive(Debug, Default)]
pub struct PhotonMap {
    pub tree: KdTree<3>,
    pub photons: Vec<Photon>,
    /// Photons shot (the density estimate's N).
    pub emitted: u64,
    pub rays: u64,
}

impl PhotonMap {
    pub fn bytes(&self) -> usize {
        self.photons.len() * BYTES_PER_PHOTON
    }
}

/// How photons are shot.
#[derive(Clone, Copy, Debug)]
pub struct Shooting {
    pub count: u32,
    /// Longest photon path stored (segments).
    pub max_segments: u32,
    pub rr_threshold: f32,
    /// Shortest photon path stored: 2 for the photon maps (direct light comes
    /// from light sampling), 1 where direct light is wanted too.
    pub min_segments: u32,
}

impl Shooting {
    /// The photon maps' shooting for paths of at most `max_depth` segments: photons of
    /// 2 to `max_depth − 1` segments (a camera path takes at least one).
    pub fn for_maps(count: u32, max_depth: u32, rr_threshold: f32) -> Shooting {
        Shooting {
            count,
            max_segments: max_depth.saturating_sub(1),
            rr_threshold,
            min_segments: 2,
        }
    }
}

/// Photon deposits: positions, payloads (same order), rays cast.
pub type Deposits = (Vec<[f32; 3]>, Vec<Photon>, u64);

/// Rounds of [`shoot`] at most.
pub const MAX_ROUNDS: usize = 1024;

/// Shoots `s.count` photons for `iteration`; `None` when the stop token was set. With
/// `until_stored`, more rounds of as many until the map holds at least `s.count`
/// (Jensen's and Mitsuba's photon maps count stored photons); all photons shot are the
/// estimate's N. Where most photons leave the scene before a stored hit (a sky over a
/// wide floor: first hits are not stored) the map still fills, so its k-NN radii stay
/// small. Stops after a round that stored nothing and after [`MAX_ROUNDS`].
pub fn shoot(scene: &Scene, s: Shooting, iteration: u32, seed: u32, stop: &StopToken, until_stored: bool) -> Option<PhotonMap> {
    let (n, rounds) = (s.count as usize, if until_stored { MAX_ROUNDS } else { 1 });
    let (mut all, mut emitted) = (Deposits::default(), 0u64);
    for r in 0..rounds {
        let before = all.1.len();
        append(&mut all, shoot_chunks(scene, s, r * n..(r + 1) * n, iteration, seed, stop)?);
        emitted += n as u64;
        if all.1.len() >= n || all.1.len() == before {
            break;
        }
    }
    let (pts, photons, rays) = all;
    let tree = KdTree::build(pts);
    let photons = tree.permute(&photons);
    Some(PhotonMap {
        tree,
        photons,
        emitted,
        rays,
    })
}

/// Shoots photons `range` of `iteration` in chunks of [`CHUNK`] in parallel, each
/// chunk's deposits (position, payload) handed to `store` with the chunk's own
/// collection made by `new`: the collections in chunk order (so in photon order
/// whatever the thread count) and the rays cast; `None` when the stop token was set.
/// A caller that keeps less than the whole photon (`guided`'s recording cells) keeps
/// it as the photons land, not in a map of them first.
pub fn shoot_into<A, N, F>(
    scene: &Scene,
    s: Shooting,
    range: std::ops::Range<usize>,
    (iteration, seed): (u32, u32),
    stop: &StopToken,
    new: N,
    store: F,
) -> Option<(Vec<A>, u64)>
where
    A: Send,
    N: Fn() -> A + Sync,
    F: Fn(&mut A, Vec3, Photon) + Sync,
{
    if scene.lights.is_empty() || range.is_empty() || s.max_segments < s.min_segments.max(1) {
        return Some((Vec::new(), 0));
    }
    let chunks: Vec<(A, u64)> = (0..range.len().div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            if stop.is_stopped() {
                return None;
            }
            let (mut own, mut rays) = (new(), 0u64);
            let first = range.start + c * CHUNK;
            for i in first..(first + CHUNK).min(range.end) {
                let mut rng = photon_rng(seed, iteration, i as u64);
                rays += trace_photon(scene, s, &mut rng, &mut |p, photon| store(&mut own, p, photon));
            }
            Some((own, rays))
        })
        .collect::<Option<_>>()?;
    let rays = chunks.iter().map(|c| c.1).sum();
    Some((chunks.into_iter().map(|c| c.0).collect(), rays))
}

/// The deposits of photons `range`, shot in chunks of [`CHUNK`] from its start, in
/// photon order; `None` when the stop token was set.
fn shoot_chunks(
    scene: &Scene,
    s: Shooting,
    range: std::ops::Range<usize>,
    iteration: u32,
    seed: u32,
    stop: &StopToken,
) -> Option<Deposits> {
    let new = || (Vec::new(), Vec::new(), 0);
    let (chunks, rays) = shoot_into(scene, s, range, (iteration, seed), stop, new, |d: &mut Deposits, p, photon| {
        d.0.push(p.to_array());
        d.1.push(photon);
    })?;
    let mut all = (Vec::new(), Vec::new(), rays);
    chunks.into_iter().for_each(|c| append(&mut all, c));
    Some(all)
}

/// Appends deposits `d` to `all`.
fn append(all: &mut Deposits, d: Deposits) {
    all.0.extend(d.0);
    all.1.extend(d.1);
    all.2 += d.2;
}

/// The random numbers of photon `i` of `iteration` for `seed`: the (seed, iteration) pair
/// hashed to a 64-bit key, and the photon's stream started at a hash of that key XOR `i`
/// ([`SplitMix64::for_key`]), so no two photons share numbers (a key packed from the
/// three lost seed bits, and streams started at key·γ overlapped: see the test).
fn photon_rng(seed: u32, iteration: u32, i: u64) -> SplitMix64 {
    SplitMix64::for_key(mix64((seed as u64) << 32 | iteration as u64) ^ i)
}

/// Traces one photon, calling `store` at each deposit; returns the rays cast.
fn trace_photon(scene: &Scene, s: Shooting, rng: &mut SplitMix64, store: &mut impl FnMut(Vec3, Photon)) -> u64 {
    let mut u2 = || Vec2::new(rng.unit_f32(), rng.unit_f32());
    let ul = u2();
    let (index, pmf, _) = scene.light_sampler.sample_emission(ul.x);
    let bounds = SceneBounds {
        center: scene.center,
        radius: scene.radius,
    };
    let light = &scene.lights[index];
    let Some(es) = light.sample_emission(u2(), u2(), bounds) else {
        return 0;
    };
    let cos = es.n.map_or(1.0, |n| n.dot(es.dir).abs());
    let denom = pmf * es.pdf_pos * es.pdf_dir;
    if denom <= 0.0 || es.le == Vec3::ZERO {
        return 0;
    }
    let mut beta = es.le * (cos / denom);
    let threshold = beta.max_element() * s.rr_threshold;
    let o = match (es.n, light.is_infinite()) {
        (Some(n), false) => offset_ray_origin(es.p, if n.dot(es.dir) >= 0.0 { n } else { -n }),
        _ => es.p,
    };
    let mut ray = Ray::new(o, es.dir);
    let mut rays = 0;
    let mut segments = 1u32;
    loop {
        rays += 1;
        let Some(hit) = scene.intersect(&ray) else { break };
        let it = scene.interaction(&ray, &hit);
        let Some(material) = scene.material_of(&it) else { break };
        let bsdf = material.bsdf_at(&it, &scene.textures);
        if !bsdf.is_delta() && segments >= s.min_segments {
            store(
                it.p,
                Photon {
                    wi: it.wo,
                    power: beta,
                    segments,
                },
            );
        }
        if segments >= s.max_segments {
            break;
        }
        let (uc, u) = (rng.unit_f32(), Vec2::new(rng.unit_f32(), rng.unit_f32()));
        // flux, not radiance: the adjoint BSDF
        let Some(bs) = bsdf.sample_adjoint(it.wo, u, uc, Normals { ns: it.ns, ng: it.ng }) else {
            break;
        };
        beta *= bs.weight;
        if !beta.is_finite() || beta.max_element() <= 0.0 {
            break;
        }
        let m = beta.max_element();
        if m < threshold {
            let q = m / threshold;
            if rng.unit_f32() >= q {
                break;
            }
            beta /= q;
        }
        ray = spawn_ray(&it, bs.wi);
        segments += 1;
    }
    rays
}

/// Where a camera path stops to gather photons.
#[derive(Clone, Debug)]
pub struct VisiblePoint {
    pub p: Vec3,
    pub wo: Vec3,
    pub bsdf: Bsdf,
    /// Camera throughput up to here.
    pub beta: Vec3,
    /// Camera segments to here.
    pub segments: u32,
    /// Length of the camera path (for a footprint-sized radius).
    pub distance: f32,
}

impl VisiblePoint {
    /// `Σ f·Φ` over the photons of `slots` that pass the path-length rule, and how many did.
    pub fn gather(&self, map: &PhotonMap, max_depth: u32, slots: impl Iterator<Item = usize>) -> (Vec3, u32) {
        let mut sum = Vec3::ZERO;
        let mut m = 0;
        for slot in slots {
            let ph = &map.photons[slot];
            if self.segments + ph.segments > max_depth {
                continue;
            }
            let f = self.bsdf.eval(self.wo, ph.wi);
            if f != Vec3::ZERO {
                sum += f * ph.power;
                m += 1;
            }
        }
        (sum, m)
    }
}

/// The camera path of `photon` and `sppm`, a [`Policy`] of the camera-path estimator:
/// light sampling alone (emission counts where the camera or a specular bounce finds
/// it), no roulette, BSDF sampling through specular vertices (and glossy ones when
/// `through_glossy`, as pbrt-v4's SPPM does, with light sampling at each), and the path
/// stops at its first other vertex, its visible point, after that vertex's light sample.
struct ToVisiblePoint {
    max_depth: u32,
    through_glossy: bool,
    /// The last vertex (the camera's position first) and the path's length to it.
    last: Vec3,
    distance: f32,
    visible: Option<VisiblePoint>,
}

impl Policy for ToVisiblePoint {
    type Plan = ();
    const ROULETTE: bool = false;

    fn profile(&self) -> PathProfile {
        PathProfile::NextEvent
    }

    fn max_depth(&self) -> u32 {
        self.max_depth
    }

    fn plan(&mut self, _: &Interaction, _: &Bsdf, _: &mut PixelSampler) {}

    fn stops_at(&mut self, it: &Interaction, bsdf: &Bsdf, beta: Vec3, segment: u32) -> bool {
        self.distance += (it.p - self.last).length();
        self.last = it.p;
        if bsdf.is_delta() {
            return false;
        }
        if self.through_glossy && matches!(bsdf.kind, BsdfKind::Conductor { .. }) {
            // a photon path of at least 2 segments must still fit behind the next vertex
            return segment + 2 > self.max_depth;
        }
        if segment + 2 <= self.max_depth {
            self.visible = Some(VisiblePoint {
                p: it.p,
                wo: it.wo,
                bsdf: bsdf.clone(),
                beta,
                segments: segment,
                distance: self.distance,
            });
        }
        true
    }
}

/// Follows a camera ray to its visible point ([`ToVisiblePoint`]). Returns the emission
/// seen and the direct light found on the way, and the visible point (if the path reaches
/// one where photons may still count).
pub fn camera_path(
    scene: &Scene,
    ray: Ray,
    diff: Option<RayDifferential>,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
    max_depth: u32,
    through_glossy: bool,
) -> (Vec3, Option<VisiblePoint>) {
    let mut policy = ToVisiblePoint {
        max_depth,
        through_glossy,
        last: ray.o,
        distance: 0.0,
        visible: None,
    };
    let l = trace(&mut policy, scene, PathState::new(ray), 1, diff.as_ref(), sampler, counts);
    (l, policy.visible)
}

/// Parameters (JSON `integrator` keys, besides `type`):
/// * `n_photons` (int ≥ 1, 100000) — photons shot per map, and more until the map holds
///   at least as many (see [`shoot`]);
/// * `n_iterations` (int ≥ 1, 1) — independent photon maps; the image averages them;
/// * `spp` (int ≥ 1, 16) — camera samples per pixel per iteration (`--spp` sets it);
///   a render takes `n_iterations · spp` passes of one sample per pixel;
/// * `n_near_photons` (int ≥ 1, 64) — k of the k-nearest-neighbour estimate
///   `β · Σ f·Φ / (N_emitted · π r²)` over the k nearest photons, r the distance of
///   the (k+1)-th (so a uniform density is estimated without bias);
/// * `max_depth` (int ≥ 1, 12) — longest path in segments, camera and photon
///   segments together (see the module docs);
/// * `rr_threshold` (number in [0, 1], 0.1) — photon Russian roulette starts below
///   this fraction of the photon's initial flux (0: never).
///
/// The camera path follows specular bounces to the first non-specular surface,
/// takes direct light there by light sampling and the rest from the photon map.
///
/// ```json
/// {"type": "photon", "n_photons": 100000, "n_iterations": 4, "spp": 16, "n_near_photons": 64}
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonMapper {
    pub n_photons: u32,
    pub n_iterations: u32,
    pub n_near_photons: u32,
    pub max_depth: u32,
    pub rr_threshold: f32,
}

/// The current iteration's photon map, kept between passes.
pub struct MapState {
    iteration: u32,
    map: PhotonMap,
    stored: u64,
    emitted: u64,
    bytes: usize,
}

thread_local! {
    static KNN: RefCell<Vec<(f32, u32)>> = const { RefCell::new(Vec::new()) };
}

impl PhotonMapper {
    pub fn pass_count(&self, spp: u32) -> u32 {
        self.n_iterations.saturating_mul(spp)
    }

    pub fn render_pass(&self, ctx: &PassContext, pass: u32, film: &mut Film, state: &mut Option<MapState>) -> PassResult {
        let scene = ctx.scene;
        let iteration = pass / ctx.spp.max(1);
        let mut shot_rays = 0;
        if state.as_ref().is_none_or(|s| s.iteration != iteration) {
            let shooting = Shooting::for_maps(self.n_photons, self.max_depth, self.rr_threshold);
            let Some(map) = shoot(scene, shooting, iteration, ctx.seed, ctx.stop, true) else {
                return PassResult::default();
            };
            shot_rays = map.rays;
            let (stored, emitted) = state.as_ref().map_or((0, 0), |s| (s.stored, s.emitted));
            *state = Some(MapState {
                iteration,
                stored: stored + map.photons.len() as u64,
                emitted: emitted + map.emitted,
                bytes: map.bytes(),
                map,
            });
        }
        let Some(state) = state else { return PassResult::default() };
        let map = &state.map;
        let k = self.n_near_photons as usize;
        let inv_n = 1.0 / map.emitted.max(1) as f32;
        let mut r = camera_pass(ctx, pass, film, |s| {
            let (l, vp) = camera_path(scene, s.ray, s.diff, s.sampler, s.counts, self.max_depth, false);
            let Some(vp) = vp else { return l };
            if map.photons.is_empty() {
                return l;
            }
            KNN.with_borrow_mut(|near| {
                map.tree.knn(&vp.p.to_array(), k + 1, f32::INFINITY, near);
                // the k nearest inside the sphere through the (k+1)-th: k/(π r²) is
                // unbiased for a uniform density, (k+1)/(π r²) would be k+1/k too high
                let Some(&(r2, _)) = near.last() else { return l };
                if r2 <= 0.0 || near.len() < 2 {
                    return l;
                }
                let inside = &near[..near.len() - 1];
                let (sum, _) = vp.gather(map, self.max_depth, inside.iter().map(|n| n.1 as usize));
                l + vp.beta * sum * (inv_n / (PI * r2))
            })
        });
        r.counts.rays += shot_rays;
        r
    }

    /// Photon counts and memory, for the render summary.
    pub fn summary(&self, s: &MapState) -> String {
        format!(
            "photon: {} photon map(s), {} photons shot, {} stored ({:.1} per map), last map {:.1} MB ({} bytes per photon), k = {}",
            s.iteration + 1,
            s.emitted,
            s.stored,
            s.stored as f64 / (s.iteration + 1) as f64,
            s.bytes as f64 / 1e6,
            BYTES_PER_PHOTON,
            self.n_near_photons
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// No two photons share a random number: the first draws of the streams of many
    /// photons, iterations and seeds (seeds 2²⁴ apart and iterations past 256 too, which
    /// the old packed key confused) are all different. Fails with the stream started at
    /// key·γ (each photon's numbers are its predecessor's, one draw later) and with keys
    /// that drop or overlap the seed's bits.
    #[test]
    fn photon_streams_share_no_numbers() {
        let mut seen: HashMap<u64, (u32, u32, u64)> = HashMap::new();
        for seed in [0u32, 1, 1 << 24, u32::MAX] {
            for iteration in [0u32, 1, 256, 257] {
                for i in 0..2000u64 {
                    let mut rng = photon_rng(seed, iteration, i);
                    for _ in 0..8 {
                        let x = rng.next_u64();
                        if let Some(other) = seen.insert(x, (seed, iteration, i)) {
                            panic!("photon {:?} and {other:?} share a number", (seed, iteration, i));
                        }
                    }
                }
            }
        }
    }
}
