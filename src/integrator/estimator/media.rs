//! The media loop of the camera-path estimator ([`trace_media`]) and a real scattering
//! event's vertex ([`PathState::scatter_in_medium`]): a file of their own beside the
//! surface steps they reuse.

use super::*;

/// [`trace`] in a scene with media, from the camera ray (`segment` 1, in the camera's
/// medium). The path's throughput stays f/mean_c(p_c) over the channels' densities
/// of its medium events ([`HeroWeights`]), so the surface steps use it unchanged.
#[inline(never)]
pub(super) fn trace_media<P: Policy>(
    policy: &mut P,
    scene: &Scene,
    mut path: PathState,
    mut segment: u32,
    mut diff: Option<&RayDifferential>,
    sampler: &mut PixelSampler,
    counts: &mut RayCounts,
) -> Vec3 {
    let mut medium = scene.camera_medium;
    let mut hero: Option<HeroWeights> = None;
    let mut crossings = 0;
    loop {
        counts.rays += 1;
        let hit = scene.intersect(&path.ray);
        if let Some(m) = medium {
            let t_end = hit.map_or(path.ray.t_max, |h| h.t);
            let weights = hero.get_or_insert_with(|| HeroWeights::new(sampler.next_1d()));
            let med = &scene.media[m as usize];
            let (found, f, le) = delta_tracking_emitting(med, &path.ray, t_end, weights, || sampler.next_1d());
            // the camera ray's own (as a surface light it meets) is hidden with the emitters
            if le != Vec3::ZERO && !(segment == 1 && policy.hide_emitters()) {
                policy.add_emission(&mut path.l, path.beta * le, path.after_delta);
            }
            weights.apply(f, &mut path.beta);
            if path.beta == Vec3::ZERO {
                return path.l;
            }
            match found {
                Tracked::Absorbed => return path.l,
                Tracked::Scattered { t, .. } => {
                    let x = path.ray.at(t);
                    if !path.scatter_in_medium(policy, scene, med.phase(), x, medium, segment, sampler, counts) {
                        return path.l;
                    }
                    (segment, diff) = (segment + 1, None);
                    continue;
                }
                Tracked::Passed => {}
            }
        }
        let Some(h) = hit else {
            path.advance(policy, scene, Found { hit, segment, diff }, sampler, counts);
            return path.l;
        };
        let it = scene.interaction(&path.ray, &h);
        if scene.is_null(&it) {
            // a boundary only: the ray goes on into the medium behind it, no vertex
            crossings += 1;
            if crossings > crate::scene::MAX_NULL_CROSSINGS {
                return path.l;
            }
            medium = scene.medium_after(&it, path.ray.d, medium);
            path.ray = Scene::ray_beyond(&path.ray, &it);
            continue;
        }
        let (shadow, goes_on) = path.advance(policy, scene, Found { hit, segment, diff }, sampler, counts);
        if let Some(s) = shadow {
            let from = scene.medium_after(&it, s.ray.d, medium);
            let tr = scene.transmittance_through_media(&s.ray, from, || sampler.next_1d());
            path.add_transmitted(policy, &s, tr, (tr.x + tr.y + tr.z) / 3.0);
        }
        if !goes_on {
            return path.l;
        }
        medium = scene.medium_after(&it, path.ray.d, medium);
        (segment, diff) = (segment + 1, None);
    }
}

impl PathState {
    /// The vertex of a real scattering event at `x` in `medium` (phase function
    /// `phase`), reached by segment `segment`: the light sample (MIS against the phase
    /// function's sampling, its shadow ray through the media) and the next segment's
    /// direction drawn from the phase function (weight 1). Returns whether the path
    /// goes on; the light's and the phase function's numbers are drawn as at a surface.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn scatter_in_medium<P: Policy>(
        &mut self,
        policy: &mut P,
        scene: &Scene,
        phase: PhaseFunction,
        x: Vec3,
        medium: Option<u32>,
        segment: u32,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
    ) -> bool {
        if segment >= policy.max_depth() {
            return false;
        }
        let (profile, wo) = (policy.profile(), -self.ray.d);
        // in a sealed medium no light sample arrives: the phase sample alone finds light
        let samples_light = profile != PathProfile::RandomWalk && !scene.lights.is_empty() && scene.lights_reach(medium);
        if samples_light {
            let (index, pmf, u) = choose_light(scene, sampler);
            let light = &scene.lights[index];
            if let Some(mut ls) = light.sample_unlit(x, u, scene.light_sampling, None) {
                let f = phase.eval(wo, ls.wi);
                if f > 0.0 && ls.pdf > 0.0 && pmf > 0.0 {
                    counts.rays += 1;
                    let tr = scene.transmittance_through_media(&shadow_ray_from_point(x, &ls), medium, || sampler.next_1d());
                    // the radiance only for a sample that arrives
                    if tr != Vec3::ZERO {
                        ls.radiance = light.radiance_of(&ls);
                        let light_pdf = pmf * ls.pdf;
                        let w = if profile == PathProfile::NextEvent {
                            1.0
                        } else {
                            light_sample_weight(&ls, light_pdf, || phase.pdf(wo, ls.wi))
                        };
                        self.l += self.beta * ls.radiance * tr * (f * w / light_pdf);
                    }
                }
            }
        }
        let (wi, pdf) = phase.sample(wo, Vec2::from(sampler.next_2d()));
        // emission the phase sample finds weighs 1 where no light was sampled
        self.after_delta = !samples_light;
        self.bsdf_pdf = pdf;
        self.prev_p = x;
        self.sky_coords = None;
        if P::ROULETTE && segment >= RR_DEPTH {
            let q = policy.survival(self.beta, self.eta_scale);
            if sampler.next_1d() >= q {
                return false;
            }
            self.beta /= q;
        }
        self.ray = Ray::with_range(x, wi, 0.0, RAY_T_MAX);
        true
    }
}
