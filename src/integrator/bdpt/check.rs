//! `bdpt`'s self-check of its multiple importance sampling, on random paths of a
//! scene: do the MIS weights of every path's strategies sum to 1, and are the
//! densities the subpaths cache those of the path's geometry?
//!
//! Each strategy's weight is the integrator's own ([`Engine::connection`]) on the
//! subpaths that strategy would have joined, their cached densities as the walks
//! cache them: a strategy the integrator drops (not selected, not connectible, or
//! left out of the weights' sums) or densities one strategy assembles differently
//! from the others break the sum.

use super::vertex::{Ctx, Kind, Vertex};
use super::{Engine, Heuristic, PathDensities, Select};
use crate::integrator::estimator::sample_light;
use crate::integrator::RayCounts;
use crate::math::Vec3;
use crate::sampler::PixelSampler;

/// What [`mis_self_check`] found.
#[derive(Clone, Copy, Debug, Default)]
pub struct MisCheck {
    /// Connections (paths) checked.
    pub paths: usize,
    /// Of those, paths with a vertex in a medium.
    pub medium_paths: usize,
    /// Largest |Σ_s w_s − 1| over the paths, w_s from strategy s's own densities.
    pub max_sum_error: f32,
    /// Largest relative difference between the cached densities a connection
    /// assembles and those recomputed from the path's geometry.
    pub max_density_error: f32,
    /// Camera samples with a path whose density is off by more than 1 % (relative).
    /// Vertices close to each other at grazing angles (in corners) differ by
    /// 0.1–20 %: the sampled direction is the ray's, the recomputed one joins the
    /// (rounded) hit points.
    pub samples_off: usize,
}

/// The densities of a whole path x₀ (light) … x_{n−1} (camera) from its geometry
/// alone, as the subpaths' walks cache them: p_L(x_i) sampled from x_{i−1} (after
/// x_{i−2}), p_E(x_i) from x_{i+1} (after x_{i+2}), 0 when sampled by a specular
/// vertex.
fn path_densities(ctx: &Ctx, x: &[Vertex]) -> PathDensities {
    let n = x.len();
    let mut d = PathDensities::default();
    for i in 0..n {
        let pl = match i {
            0 => ctx.pdf_light_origin(&x[0]),
            _ if x[i - 1].delta => 0.0,
            1 => ctx.pdf_light(&x[0], &x[1]),
            _ => ctx.pdf(&x[i - 1], Some(&x[i - 2]), &x[i]),
        };
        let pe = if i == n - 1 {
            1.0
        } else if x[i + 1].delta {
            0.0
        } else {
            ctx.pdf(&x[i + 1], x.get(i + 2), &x[i])
        };
        d.push(pl, pe, x[i].delta && i > 0 && i < n - 1);
    }
    d.delta_light = x[0].light().is_some_and(|i| ctx.scene.lights[i as usize].is_delta());
    d
}

/// The sum of the MIS weights of every strategy that `e` evaluates and can
/// connect for the path `x`, each from the subpaths it joins.
fn weight_sum(e: &Engine, x: &[Vertex], d: &PathDensities) -> f32 {
    let n = x.len();
    let mut sum = 0.0;
    for s in 0..n {
        let t = n - s;
        let light: Vec<Vertex> = (0..s)
            .map(|i| Vertex {
                pdf_fwd: d.light[i],
                pdf_rev: d.camera[i],
                ..x[i].clone()
            })
            .collect();
        let cam: Vec<Vertex> = (s..n)
            .rev()
            .map(|i| Vertex {
                pdf_fwd: d.camera[i],
                pdf_rev: d.light[i],
                ..x[i].clone()
            })
            .collect();
        if e.selected(s, t, &cam) != Some(true) || !e.connectible(&light, &cam, s, t) {
            continue;
        }
        // the vertex a connection samples (s = 1: a light; t = 1: the camera)
        let sampled = match (s, t) {
            (1, _) => Some(&light[0]),
            (_, 1) => Some(&cam[0]),
            _ => None,
        };
        sum += e.connection(&light, &cam, s, t, sampled).weight(e.heuristic);
    }
    sum
}

/// Checks the MIS of `bdpt` on random paths of a scene: for `samples` camera
/// samples (random film positions), every connection (s, t) that carries light is
/// taken as a path; the weights of all strategies that could have made it must sum
/// to 1 (see the module docs), and the densities the connection assembled must equal
/// those recomputed from the vertices alone (next to specular vertices they are
/// conventions, and not compared).
pub fn mis_self_check(
    scene: &crate::scene::Scene,
    camera: &crate::camera::Camera,
    width: u32,
    height: u32,
    max_depth: u32,
    samples: u32,
) -> MisCheck {
    let e = Engine::new(scene, camera, max_depth, Heuristic::Power, Select::All, 0.0);
    let mut out = MisCheck::default();
    let mut counts = RayCounts::default();
    for i in 0..samples {
        let mut sampler = PixelSampler::new(i % width, (i / width) % height, i, 77);
        let (u, v) = sampler.next_2d();
        let ray = camera.ray(u * width as f32, v * height as f32);
        let mut cam = Vec::new();
        e.camera_subpath(ray, None, e.max_depth + 1, &mut cam, &mut Vec::new(), &mut sampler, &mut counts);
        let mut light = Vec::new();
        e.light_subpath(&mut light, &mut sampler, &mut counts);
        let mut sample_off = false;
        for t in 1..=cam.len() {
            for s in 0..=light.len() {
                let n = s + t;
                if n < 3 || n - 1 > e.max_depth {
                    continue;
                }
                let mut probe = sampler;
                let Some((c, _)) = e.connect(&light, &cam, s, t, &mut probe, &mut counts, false, None) else {
                    continue;
                };
                if c == Vec3::ZERO {
                    continue;
                }
                // the vertex a connection samples (s = 1: a light; t = 1: the pinhole)
                let mut sampled = None;
                if s == 1 && t > 1 {
                    // the light sample `connect` drew (from the same numbers)
                    let Some((index, _, ls)) = sample_light(scene, cam[t - 1].p, &mut sampler.clone()) else {
                        continue;
                    };
                    sampled = Some(e.ctx.sampled_light(index, &ls, cam[t - 1].p));
                } else if t == 1 {
                    sampled = Some(cam[0].clone());
                }
                // the path and the densities (p_L, p_E) the connection assembled for its weight
                let c = e.connection(&light, &cam, s, t, sampled.as_ref());
                let assembled: Vec<(f32, f32, bool)> = (0..n).map(|i| c.at(i)).collect();
                let mut x: Vec<Vertex> = (0..s)
                    .map(|i| c.lv(i).clone())
                    .chain((0..t).rev().map(|j| c.cv(j).clone()))
                    .collect();
                // an emitter the camera subpath hit, as the light vertex a light subpath starts with
                if let (Kind::Surface, Some(index)) = (x[0].kind, x[0].emitter) {
                    let (p, ng, uv) = (x[0].p, x[0].ng, x[0].uv);
                    x[0] = Vertex::new(Kind::Light(index), p, ng, Vec3::ONE);
                    x[0].uv = uv;
                }
                let fresh = path_densities(&e.ctx, &x);
                let mut off = false;
                for (i, &(pl, pe, _)) in assembled.iter().enumerate() {
                    if fresh.delta[i] || (i > 0 && fresh.delta[i - 1]) || (i + 1 < n && fresh.delta[i + 1]) {
                        continue; // densities next to specular vertices are conventions
                    }
                    for (a, b) in [(pl, fresh.light[i]), (pe, fresh.camera[i])] {
                        let err = (a - b).abs() / a.abs().max(b.abs()).max(1e-20);
                        out.max_density_error = out.max_density_error.max(err);
                        off |= err > 1e-2;
                    }
                }
                let sum = weight_sum(&e, &x, &fresh);
                out.max_sum_error = out.max_sum_error.max((sum - 1.0).abs());
                out.paths += 1;
                out.medium_paths += x.iter().any(|v| matches!(v.kind, Kind::Medium(_))) as usize;
                sample_off |= off;
            }
        }
        out.samples_off += sample_off as usize;
    }
    out
}
