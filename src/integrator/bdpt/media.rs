//! Media in both subpaths (and so in `ptracer`): a subpath's ray is tracked through
//! the media it crosses with the camera paths' delta tracking and hero-channel MIS
//! ([`crate::medium::tracking`]), `null` boundaries crossed without a vertex; a real
//! scattering event makes a medium vertex ([`Kind::Medium`], with its phase function). Connections carry the
//! media's transmittance by ratio tracking ([`Scene::transmittance_through_media`]).
//!
//! The MIS densities are pbrt-v4's: directional densities in area measure, a medium
//! vertex's without a cosine; the distance-sampling and transmittance factors are
//! left out on every side, so the weights still sum to 1 (unbiased) and each
//! subpath's hero channel stays its own (a chromatic medium is no special case).
//!
//! A light subpath starts in the medium its emitter's shape declares on the side it
//! emits to; an emitter on a shape without media (and every other light) starts in
//! the medium that the first media-declaring surface along its first ray says lies on
//! the ray's side, or the camera's medium if the ray meets none (as the camera
//! paths' tracking finds it in a scene whose boundaries are consistent).
//!
//! The camera subpath gathers an emissive medium's light as the path estimator does
//! ([`delta_tracking_emitting`]: at every collision, real or null, over its density):
//! only the camera subpath can find it (no light subpath starts in a medium's
//! volume), so these s = 0 paths weigh 1.
//!
//! [`Kind::Medium`]: super::vertex::Kind::Medium
//! [`Scene::transmittance_through_media`]: crate::scene::Scene::transmittance_through_media

use crate::geometry::Ray;
use crate::integrator::RayCounts;
use crate::light::Light;
use crate::math::Vec3;
use crate::medium::{delta_tracking, delta_tracking_emitting, HeroWeights, Tracked};
use crate::sampler::PixelSampler;
use crate::scene::{Hit, Scene, MAX_NULL_CROSSINGS};

/// What a subpath's ray meets next.
pub(super) enum Event {
    /// A real scattering event at `p` in medium `medium`.
    Scattered { p: Vec3, medium: u32 },
    /// A surface that is not `null`, or nothing (the ray escaped).
    Surface(Option<Hit>),
    /// The path was absorbed (or its throughput vanished).
    Absorbed,
}

/// The next real event along `ray`, which starts in `medium`: the tracking factors
/// applied to `beta` through `hero` (drawn when first needed), `ray` and `medium`
/// moved past the `null` boundaries crossed; with `glow`, the light emitted by the media
/// along the way (times the throughput) is added to it. Without media (`MEDIA` false: a
/// scene without any), the ray's hit.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn next_event<const MEDIA: bool>(
    scene: &Scene,
    ray: &mut Ray,
    medium: &mut Option<u32>,
    hero: &mut Option<HeroWeights>,
    beta: &mut Vec3,
    mut glow: Option<&mut Vec3>,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
) -> Event {
    if !MEDIA {
        counts.rays += 1;
        return Event::Surface(scene.intersect(ray));
    }
    for _ in 0..=MAX_NULL_CROSSINGS {
        counts.rays += 1;
        let hit = scene.intersect(ray);
        if let Some(m) = *medium {
            let t_end = hit.map_or(ray.t_max, |h| h.t);
            let w = hero.get_or_insert_with(|| HeroWeights::new(sampler.next_1d()));
            let med = &scene.media[m as usize];
            let (found, f) = match glow.as_deref_mut() {
                Some(g) => {
                    let (found, f, le) = delta_tracking_emitting(med, ray, t_end, w, || sampler.next_1d());
                    *g += *beta * le;
                    (found, f)
                }
                None => delta_tracking(med, ray, t_end, w.hero, || sampler.next_1d()),
            };
            w.apply(f, beta);
            match found {
                _ if *beta == Vec3::ZERO => return Event::Absorbed,
                Tracked::Absorbed => return Event::Absorbed,
                Tracked::Scattered { t, .. } => return Event::Scattered { p: ray.at(t), medium: m },
                Tracked::Passed => {}
            }
        }
        let Some(h) = hit else { return Event::Surface(None) };
        let it = scene.interaction(ray, &h);
        if !scene.is_null(&it) {
            return Event::Surface(Some(h));
        }
        *medium = scene.medium_after(&it, ray.d, *medium);
        *ray = Scene::ray_beyond(ray, &it);
    }
    Event::Absorbed
}

/// The media on the two sides of a light subpath's origin (see the module docs):
/// light `index`, its normal `n` there, its first ray `ray`.
pub(super) fn light_media(scene: &Scene, index: usize, n: Option<Vec3>, ray: &Ray) -> [Option<u32>; 2] {
    if !scene.has_media {
        return [None; 2];
    }
    if let (Light::Area(a), Some(n)) = (&scene.lights[index], n) {
        if let Some(mi) = scene.objects[a.object as usize].media {
            return [mi.along(n, n), mi.along(-n, n)];
        }
    }
    let mut r = *ray;
    for _ in 0..MAX_NULL_CROSSINGS {
        let Some(h) = scene.intersect(&r) else { break };
        let it = scene.interaction(&r, &h);
        if let Some(mi) = scene.objects[it.object as usize].media {
            return [mi.along(-r.d, it.ng); 2];
        }
        r = Scene::ray_beyond(&r, &it);
    }
    [scene.camera_medium; 2]
}
