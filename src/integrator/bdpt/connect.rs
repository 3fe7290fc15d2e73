//! Bidirectional path tracing's strategies: joining a light and a camera subpath
//! prefix (s, t), the contribution, and the densities its MIS weight reads.

use super::mis;
use super::vertex::{Kind, Vertex};
use super::{Engine, Heuristic};
use crate::geometry::ray::RAY_T_MAX;
use crate::geometry::Ray;
use crate::integrator::estimator::sample_light;
use crate::integrator::RayCounts;
use crate::material::TransportMode;
use crate::math::{Vec2, Vec3};
use crate::sampler::PixelSampler;

impl Engine<'_> {
    /// Whether strategy (s, t) can join these subpaths: its connection vertices can be
    /// connected (s = 0: the camera subpath ends on an emitter, which a camera ray can
    /// hit; t = 1: a light vertex the pinhole can see, not a delta-position light itself).
    pub(super) fn connectible(&self, light: &[Vertex], cam: &[Vertex], s: usize, t: usize) -> bool {
        let lights = &self.ctx.scene.lights;
        if s == 0 {
            cam[t - 1].light().is_some_and(|i| !lights[i as usize].is_delta())
        } else if t == 1 {
            let qs = &light[s - 1];
            qs.connectible() && !qs.infinite && (s > 1 || qs.light().is_some_and(|i| !lights[i as usize].is_delta_position()))
        } else if s == 1 {
            cam[t - 1].connectible() && !lights.is_empty()
        } else {
            light[s - 1].connectible() && cam[t - 1].connectible()
        }
    }

    /// Strategy (s, t): its contribution (MIS-weighted when `weighted`) and, for
    /// t = 1, the film position to splat it to.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn connect(
        &self,
        light: &[Vertex],
        cam: &[Vertex],
        s: usize,
        t: usize,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
        weighted: bool,
        rr: Option<f32>,
    ) -> Option<(Vec3, Option<Vec2>)> {
        let ctx = &self.ctx;
        let scene = ctx.scene;
        let mut sampled = None;
        let mut pos = None;
        if !self.connectible(light, cam, s, t) {
            return None;
        }
        let mut l;
        if s == 0 {
            let pt = &cam[t - 1];
            l = pt.beta * ctx.emitted(pt, pt.dir_to(&cam[t - 2]));
            if l == Vec3::ZERO {
                return None;
            }
        } else if t == 1 {
            let qs = &light[s - 1];
            // a thin lens: a point on it, drawn uniformly (its area density cancels
            // against the lens area in the importance)
            let lens = if ctx.camera.has_lens() {
                let mut c = Vertex::new(
                    Kind::Camera,
                    ctx.camera.lens_point(Vec2::from(sampler.next_2d())),
                    Vec3::ZERO,
                    Vec3::ONE,
                );
                c.pdf_fwd = 1.0 / ctx.camera.lens_area();
                c
            } else {
                cam[0].clone()
            };
            let (p, cos_cam) = ctx.camera.project_from(lens.p, qs.p)?;
            let v = lens.p - qs.p;
            let d2 = v.length_squared();
            let w = v / d2.sqrt();
            // We·cos_cam = 1/(A cos³θ): the pinhole's importance (1/(A cos⁴θ)) times its
            // cosine; a lens's 1/(A·lens_area·cos⁴θ) times cos over its density 1/lens_area
            let we = 1.0 / (ctx.camera.image_plane_area() * cos_cam * cos_cam * cos_cam);
            let f = if s == 1 {
                ctx.emitted(qs, w)
            } else {
                qs.f(w, TransportMode::Importance)
            };
            l = qs.beta * f * (qs.cos(w) * we / d2);
            if l == Vec3::ZERO {
                return None;
            }
            l = self.through(l, qs, &lens, sampler, counts)?;
            sampled = Some(lens);
            pos = Some(p);
        } else if s == 1 {
            let pt = &cam[t - 1];
            let (index, pmf, ls) = sample_light(scene, pt.p, sampler)?;
            if ls.pdf <= 0.0 || pmf <= 0.0 {
                return None;
            }
            let q = ctx.sampled_light(index, &ls, pt.p);
            l = pt.beta * pt.f(ls.wi, TransportMode::Radiance) * ls.radiance * (pt.cos(ls.wi) / (pmf * ls.pdf));
            if l == Vec3::ZERO {
                return None;
            }
            if let Some(tau) = rr {
                l = self.roulette(l, tau, sampler, s, t)?;
            }
            l = self.through(l, pt, &q, sampler, counts)?;
            sampled = Some(q);
        } else {
            let (qs, pt) = (&light[s - 1], &cam[t - 1]);
            let v = pt.p - qs.p;
            let d2 = v.length_squared();
            if d2 == 0.0 {
                return None;
            }
            let w = v / d2.sqrt();
            l = qs.beta * qs.f(w, TransportMode::Importance) * pt.f(-w, TransportMode::Radiance) * pt.beta * (qs.cos(w) * pt.cos(w) / d2);
            if l == Vec3::ZERO {
                return None;
            }
            if let Some(tau) = rr {
                l = self.roulette(l, tau, sampler, s, t)?;
            }
            l = self.through(l, qs, pt, sampler, counts)?;
        }
        if !weighted {
            return Some((l, pos));
        }
        let w = self.connection(light, cam, s, t, sampled.as_ref()).weight(self.heuristic);
        Some((l * w, pos))
    }

    /// `connection_roulette`: a contribution below `tau` survives with probability
    /// (its luminance)/`tau` and is divided by it; the number is keyed by (s, t), so
    /// it does not depend on what other strategies drew.
    fn roulette(&self, c: Vec3, tau: f32, sampler: &PixelSampler, s: usize, t: usize) -> Option<Vec3> {
        let y = crate::math::luminance(c);
        // (NaN and non-positive luminance pass untouched)
        if y.is_nan() || y >= tau || y <= 0.0 {
            return Some(c);
        }
        let q = y / tau;
        (sampler.keyed_1d((s as u32) << 16 | t as u32) < q).then(|| c / q)
    }

    /// The contribution `l` of a connection between two vertices (either may be at
    /// infinity) times the fraction of light passing between them
    /// ([`crate::scene::Scene::transmittance`]: 1 or 0 unless masks lie between; through
    /// media, their transmittance by ratio tracking); `None` when nothing passes.
    fn through(&self, l: Vec3, a: &Vertex, b: &Vertex, sampler: &mut PixelSampler, counts: &mut RayCounts) -> Option<Vec3> {
        counts.rays += 1;
        let (a, b) = if a.infinite { (b, a) } else { (a, b) };
        let ray = if b.infinite {
            Ray::with_range(a.origin_towards(b.ng), b.ng, 0.0, RAY_T_MAX)
        } else {
            let (oa, ob) = (a.origin_towards(b.p - a.p), b.origin_towards(a.p - b.p));
            let v = ob - oa;
            let dist = v.length();
            if dist == 0.0 {
                return None;
            }
            Ray::with_range(oa, v / dist, 0.0, dist * (1.0 - 1e-5))
        };
        let scene = self.ctx.scene;
        let tr = if scene.has_media {
            scene.transmittance_through_media(&ray, a.medium_towards(ray.d), || sampler.next_1d())
        } else {
            Vec3::splat(scene.transmittance(&ray))
        };
        (tr.max_element() > 0.0).then(|| l * tr)
    }

    /// The densities of the path strategy (s, t) made, from the subpaths' cached
    /// densities and the four the connection changes (pbrt-v4's `MISWeight` scheme),
    /// read in place by [`Connection::weight`].
    pub(super) fn connection<'v>(
        &self,
        light: &'v [Vertex],
        cam: &'v [Vertex],
        s: usize,
        t: usize,
        sampled: Option<&'v Vertex>,
    ) -> Connection<'v> {
        let ctx = &self.ctx;
        let mut c = Connection {
            light,
            cam,
            s,
            t,
            sampled,
            light_s: 0.0,
            light_s1: 0.0,
            cam_s1: 0.0,
            cam_s2: 0.0,
            delta_light: false,
        };
        let pt = c.cv(t - 1);
        let pt_minus = (t > 1).then(|| c.cv(t - 2));
        let qs = (s > 0).then(|| c.lv(s - 1));
        let qs_minus = (s > 1).then(|| c.lv(s - 2));
        // the four densities the connection changes, two at each connection vertex
        match (qs, qs_minus) {
            (Some(q), Some(qm)) => (c.light_s, c.cam_s2) = ctx.pdf_pair(q, qm, pt),
            (Some(q), None) => c.light_s = ctx.pdf(q, None, pt),
            (None, _) => c.light_s = ctx.pdf_light_origin(pt),
        }
        match (qs, pt_minus) {
            (Some(q), Some(pm)) => (c.cam_s1, c.light_s1) = ctx.pdf_pair(pt, pm, q),
            (Some(q), None) => c.cam_s1 = ctx.pdf(pt, None, q),
            (None, Some(pm)) => c.light_s1 = ctx.pdf_light(pt, pm),
            (None, None) => {}
        }
        let x0 = if s > 0 { c.lv(0) } else { pt };
        c.delta_light = x0.light().is_some_and(|i| ctx.scene.lights[i as usize].is_delta());
        c
    }
}

/// The path of strategy (s, t): the subpaths' prefixes, the vertex the connection
/// sampled (s = 1: a light; t = 1: the pinhole), and the densities it changes.
pub(super) struct Connection<'v> {
    light: &'v [Vertex],
    cam: &'v [Vertex],
    s: usize,
    t: usize,
    sampled: Option<&'v Vertex>,
    /// p_L of x_s and x_{s+1}; p_E of x_{s−1} and x_{s−2}.
    light_s: f32,
    light_s1: f32,
    cam_s1: f32,
    cam_s2: f32,
    delta_light: bool,
}

impl<'v> Connection<'v> {
    /// Path vertex `i` of the light side.
    #[inline(always)]
    pub(super) fn lv(&self, i: usize) -> &'v Vertex {
        match self.sampled {
            Some(v) if self.s == 1 && i == 0 => v,
            _ => &self.light[i],
        }
    }

    /// Camera-side vertex `j` (0 at the camera).
    #[inline(always)]
    pub(super) fn cv(&self, j: usize) -> &'v Vertex {
        match self.sampled {
            Some(v) if self.t == 1 && j == 0 => v,
            _ => &self.cam[j],
        }
    }

    /// Path vertex `i` (0 at the light): (p_L, p_E, specular).
    #[inline(always)]
    pub(super) fn at(&self, i: usize) -> (f32, f32, bool) {
        let s = self.s;
        if i < s {
            let v = self.lv(i);
            match s - i {
                1 => (v.pdf_fwd, self.cam_s1, false),
                2 => (v.pdf_fwd, self.cam_s2, v.delta),
                _ => (v.pdf_fwd, v.pdf_rev, v.delta),
            }
        } else {
            let v = self.cv(s + self.t - 1 - i);
            match i - s {
                0 => (self.light_s, v.pdf_fwd, false),
                1 => (self.light_s1, v.pdf_fwd, v.delta),
                _ => (v.pdf_rev, v.pdf_fwd, v.delta),
            }
        }
    }

    pub(super) fn weight(&self, heuristic: Heuristic) -> f32 {
        mis::weight_of(self.s + self.t, self.s, self.delta_light, heuristic, |i| self.at(i))
    }
}
