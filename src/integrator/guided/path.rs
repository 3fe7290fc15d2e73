//! The guided path tracer's samples: the `path` integrator's MIS estimator with
//! directions drawn from a mixture of the BSDF and the learned distribution at
//! non-specular vertices, and the radiance each such vertex receives recorded
//! for the next iteration's distribution.

use super::quadtree::{sphere_to_square, square_to_sphere, DTree};
use super::sdtree::SdTree;
use crate::geometry::{Ray, RayDifferential};
use crate::integrator::{shadow_ray, spawn_ray, RayCounts};
use crate::material::{Bsdf, BsdfSample};
use crate::math::{Vec2, Vec3, PI};
use crate::sampler::PixelSampler;
use crate::sampling::power_heuristic;
use crate::scene::Scene;

/// Segment from which Russian roulette may end paths (as `path`).
const RR_DEPTH: u32 = 5;

/// Sampling at a vertex: the BSDF alone (`guide` None, or a specular BSDF), or
/// with probability `bsdf_fraction` the BSDF and otherwise the learned tree.
#[derive(Clone, Copy, Debug)]
pub struct Mixture<'a> {
    pub guide: Option<&'a DTree>,
    pub bsdf_fraction: f32,
}

impl Mixture<'_> {
    /// Solid-angle density of sampling `wi` (what MIS weighs against light sampling).
    #[inline]
    pub fn pdf(&self, bsdf: &Bsdf, wo: Vec3, wi: Vec3) -> f32 {
        let pb = bsdf.pdf(wo, wi);
        match self.guide {
            Some(g) if !bsdf.is_delta() && self.bsdf_fraction < 1.0 => self.bsdf_fraction * pb + (1.0 - self.bsdf_fraction) * g.pdf(wi),
            _ => pb,
        }
    }

    /// A direction with weight f·|cos|/pdf and the mixture's density; `u_choice`
    /// picks the strategy, `u` and `uc` drive it as in [`Bsdf::sample`].
    pub fn sample(&self, bsdf: &Bsdf, wo: Vec3, u_choice: f32, u: Vec2, uc: f32) -> Option<BsdfSample> {
        self.sample_on_square(bsdf, wo, u_choice, u, uc).map(|s| s.0)
    }

    /// [`Mixture::sample`], with the direction's point on the square of the
    /// sphere map and the two strategies' densities (BSDF, guide) when the guide
    /// took part (the cell a recording tree gives it, at no second map).
    #[inline]
    pub fn sample_on_square(&self, bsdf: &Bsdf, wo: Vec3, u_choice: f32, u: Vec2, uc: f32) -> Option<(BsdfSample, Option<GuidedPoint>)> {
        let guide = match self.guide {
            Some(g) if !bsdf.is_delta() => g,
            _ => return bsdf.sample(wo, u, uc).map(|s| (s, None)),
        };
        let a = self.bsdf_fraction;
        if u_choice < a {
            let bs = bsdf.sample(wo, u, uc)?;
            if bs.delta {
                // a delta lobe (plastic's coating): its density is no solid-angle one
                // and the guide cannot produce it, so it keeps its own weight
                let s = BsdfSample {
                    weight: bs.weight * (1.0 / a),
                    pdf: bs.pdf * a,
                    ..bs
                };
                return Some((s, None));
            }
            let p = sphere_to_square(bs.wi);
            let pg = guide.pdf_square(p) * (0.25 / PI);
            let pdf = a * bs.pdf + (1.0 - a) * pg;
            let s = BsdfSample {
                weight: bs.weight * (bs.pdf / pdf),
                pdf,
                ..bs
            };
            Some((s, Some(GuidedPoint { p, pb: bs.pdf, pg })))
        } else {
            // the guide's density is the sampled cell's (evaluating it again through
            // the map's round trip would cost a second descent)
            let (p, pg) = guide.sample_square(u)?;
            let pg = pg * (0.25 / PI);
            let wi = square_to_sphere(p);
            let pb = bsdf.pdf(wo, wi);
            let pdf = a * pb + (1.0 - a) * pg;
            if pdf <= 0.0 || !pdf.is_finite() {
                return None;
            }
            let cos = bsdf.frame.n.dot(wi).abs();
            let s = BsdfSample {
                wi,
                weight: bsdf.eval(wo, wi) * (cos / pdf),
                pdf,
                delta: false,
                eta: 1.0,
            };
            Some((s, Some(GuidedPoint { p, pb, pg })))
        }
    }
}

/// Where a mixture sample lies on the square, and the densities of its two
/// strategies there (solid angle).
#[derive(Clone, Copy, Debug)]
pub struct GuidedPoint {
    pub p: Vec2,
    pub pb: f32,
    pub pg: f32,
}

/// Radiance arriving at a spatial leaf from a directional cell of its recording
/// tree, divided by the density it was sampled with (an estimate of the cell's
/// integral of incident radiance). `counted` marks the vertex's own sampled
/// direction (one per vertex, for the spatial split); light samples are not.
/// `fq` is the vertex's local estimate F/q (F = f·|cos|·L_i, luminance; q the
/// density it was sampled with), `pb` the BSDF's density there and `p` the
/// direction's point on the square, for the leaf's choice of BSDF fraction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    pub leaf: u32,
    pub cell: u32,
    pub value: f32,
    pub counted: bool,
    pub fq: f32,
    pub q: f32,
    pub pb: f32,
    pub p: Vec2,
}

/// A non-specular vertex of the current path waiting for the radiance that
/// arrives along its sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct Vertex {
    leaf: u32,
    cell: u32,
    pdf: f32,
    /// Throughput from the camera up to and including this vertex's scattering
    /// (before roulette): a later contribution C arrived here as C / beta.
    beta: Vec3,
    /// The sample's weight f·|cos|/q, the BSDF's density and the point on the square.
    weight: Vec3,
    pb: f32,
    p: Vec2,
    /// The estimate when the vertex was made (or after its own direct light, when
    /// that is not recorded): what arrives here is the estimate's growth since (a
    /// prefix sum instead of adding every contribution to every waiting vertex).
    l_before: Vec3,
}

/// Per-thread buffers: the records of a tile, and the current path's vertices.
#[derive(Debug, Default)]
pub struct Scratch {
    pub records: Vec<Record>,
    verts: Vec<Vertex>,
}

/// What the sampler needs besides the scene.
///
/// Russian roulette differs from `path`'s (Mitsuba's: survive with probability
/// min(β, 0.95) from the 5th segment on): from the 5th segment on a path survives
/// with probability min(1, β'/`rr_threshold`), where β' is the throughput as if
/// every guided vertex had sampled its BSDF (β times the mixture's density over
/// the BSDF's at each). Guiding sends paths where light arrives at a lower
/// weight than BSDF sampling would; judged by β they were ended for exactly
/// that (caustic_cbox: a ceiling vertex's estimate had the same variance with
/// the learned mixture as with BSDF sampling under Mitsuba's rule, 2.5× less
/// with this one, 60 → 8–12 per-sample relative variance), and the light through
/// the glass arrives after the 5th segment.
pub struct Guiding<'a> {
    pub tree: &'a SdTree,
    pub bsdf_fraction: f32,
    /// Record what paths find (training iterations).
    pub record: bool,
    /// With `record`: also the radiance paths find, for the tree to learn from
    /// (`learn_from: "paths"`); otherwise only the vertices (for the spatial splits
    /// and the choice of BSDF fractions), with no cells and values.
    pub record_radiance: bool,
    pub max_depth: u32,
    /// Roulette's threshold (see above).
    pub rr_threshold: f32,
    /// Record direct light too (what light sampling finds, and emitters hit
    /// straight from a vertex); otherwise a vertex learns only the light that
    /// reaches it by way of other surfaces or specular chains.
    pub record_direct: bool,
    /// Sample with the leaves' learned fractions instead of `bsdf_fraction`.
    pub learn_fraction: bool,
}

/// Adds emission `c` found along the direction the last vertex sampled: every
/// waiting vertex receives it, except that last one when its own direct light is
/// not recorded (`skip_last`).
#[inline]
fn add_emission(l: &mut Vec3, verts: &mut [Vertex], c: Vec3, skip_last: bool) {
    *l += c;
    if skip_last {
        // nothing was added since the vertex was made (its `l_before` equals `l`
        // before this addition), so this is exact: what it receives is 0 + later
        if let Some(v) = verts.last_mut() {
            v.l_before = *l;
        }
    }
}

#[inline]
pub(super) fn mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z) * (1.0 / 3.0)
}

impl Guiding<'_> {
    /// Radiance along a camera ray; records go to `scratch.records`.
    pub fn li(
        &self,
        scene: &Scene,
        mut ray: Ray,
        diff: Option<RayDifferential>,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
        scratch: &mut Scratch,
    ) -> Vec3 {
        let Scratch { records, verts } = scratch;
        verts.clear();
        let mode = scene.light_sampling;
        let mut l = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut eta_scale = 1.0f32;
        // roulette's view of the throughput: β as if the guided vertices had
        // sampled their BSDFs (see `Guiding::li`)
        let mut rr_scale = 1.0f32;
        let (mut after_delta, mut mix_pdf, mut prev_p) = (true, 0.0f32, ray.o);
        let mut segment = 1u32;
        loop {
            counts.rays += 1;
            let Some(hit) = scene.intersect(&ray) else {
                if let Some((env, sky)) = scene.environment_light() {
                    // the direction's texture coordinates once, for radiance and pdf
                    let (uv, sin_theta) = sky.direction_coords(ray.d);
                    let le = sky.radiance_at(uv);
                    if le != Vec3::ZERO {
                        let w = if after_delta {
                            1.0
                        } else {
                            let pl = scene.light_sampler.pmf(env as usize) * sky.pdf_at(uv, sin_theta, mode);
                            power_heuristic(mix_pdf, pl)
                        };
                        add_emission(&mut l, verts, beta * le * w, !after_delta && !self.record_direct);
                    }
                }
                break;
            };
            let mut it = scene.interaction(&ray, &hit);
            if let (1, Some(d)) = (segment, &diff) {
                it.compute_uv_derivatives(d);
            }
            if let Some((index, area)) = scene.area_light_of(&it) {
                let le = area.emitted(it.ng, it.wo, it.uv);
                if le != Vec3::ZERO {
                    let w = if after_delta {
                        1.0
                    } else {
                        let pl = scene.light_sampler.pmf(index as usize)
                            * scene.lights[index as usize].pdf(prev_p, ray.d, Some((it.p, it.ng)), mode);
                        power_heuristic(mix_pdf, pl)
                    };
                    add_emission(&mut l, verts, beta * le * w, !after_delta && !self.record_direct);
                }
            }
            if segment >= self.max_depth {
                break;
            }
            let Some(material) = scene.material_of(&it) else { break };
            let bsdf = material.bsdf_at(&it, &scene.textures);
            let delta = bsdf.is_delta();
            let leaf = if delta { 0 } else { self.tree.leaf_of(it.p) };
            let mixture = if delta {
                Mixture {
                    guide: None,
                    bsdf_fraction: 1.0,
                }
            } else {
                // training samples with the guide at `bsdf_fraction` (what it learns
                // from its own samples sharpens it: trained by BSDF samples alone,
                // the caustic leaf of caustic_cbox gave the sphere 54 % of its
                // samples instead of 76 %); the final iteration with the leaf's choice
                let fraction = if self.learn_fraction && !self.record {
                    self.tree.leaves[leaf as usize].bsdf_fraction
                } else {
                    self.bsdf_fraction
                };
                Mixture {
                    // BSDF sampling alone skips the guide
                    guide: if fraction >= 1.0 { None } else { self.tree.guide(leaf) },
                    bsdf_fraction: fraction,
                }
            };

            if !delta && !scene.lights.is_empty() {
                let (index, pmf, _) = scene.light_sampler.sample(sampler.next_1d());
                let light = &scene.lights[index];
                if let Some(ls) = light.sample(it.p, Vec2::from(sampler.next_2d()), mode) {
                    let f = bsdf.eval(it.wo, ls.wi);
                    let cos = it.ns.dot(ls.wi).abs();
                    if f != Vec3::ZERO && ls.pdf > 0.0 && ls.radiance != Vec3::ZERO && pmf > 0.0 {
                        counts.rays += 1;
                        let tr = scene.transmittance(&shadow_ray(&it, &ls));
                        if tr > 0.0 {
                            let light_pdf = pmf * ls.pdf;
                            let w = if ls.delta {
                                1.0
                            } else {
                                power_heuristic(light_pdf, mixture.pdf(&bsdf, it.wo, ls.wi))
                            };
                            l += beta * f * ls.radiance * (cos * w / light_pdf) * tr;
                            // a point light is no direction a guided sample can find
                            if self.record && self.record_radiance && self.record_direct && !ls.delta {
                                records.push(Record {
                                    leaf,
                                    cell: self.tree.record_cell(leaf, ls.wi),
                                    value: mean(ls.radiance) * w / light_pdf * tr,
                                    counted: false,
                                    fq: 0.0,
                                    q: 0.0,
                                    pb: 0.0,
                                    p: Vec2::ZERO,
                                });
                            }
                        }
                    }
                }
            }

            let u_choice = sampler.next_1d();
            let uc = sampler.next_1d();
            let Some((bs, square)) = mixture.sample_on_square(&bsdf, it.wo, u_choice, Vec2::from(sampler.next_2d()), uc) else {
                break;
            };
            beta *= bs.weight;
            eta_scale *= bs.eta * bs.eta;
            if let Some(g) = square {
                if g.pb > 0.0 {
                    rr_scale *= bs.pdf / g.pb;
                }
            }
            if beta == Vec3::ZERO || !beta.is_finite() {
                break;
            }
            if self.record && !bs.delta {
                let p = square.map_or_else(|| sphere_to_square(bs.wi), |g| g.p);
                verts.push(Vertex {
                    leaf,
                    cell: if self.record_radiance {
                        self.tree.record_cell_at(leaf, p)
                    } else {
                        0
                    },
                    pdf: bs.pdf,
                    beta,
                    weight: bs.weight,
                    // without the guide the sample is the BSDF's own
                    pb: square.map_or(bs.pdf, |g| g.pb),
                    p,
                    l_before: l,
                });
            }
            after_delta = bs.delta;
            mix_pdf = bs.pdf;
            prev_p = it.p;
            if segment >= RR_DEPTH {
                let q = if self.rr_threshold > 0.0 {
                    (beta.max_element() * eta_scale * rr_scale / self.rr_threshold).min(1.0)
                } else {
                    1.0
                };
                if sampler.next_1d() >= q {
                    break;
                }
                beta /= q;
            }
            ray = spawn_ray(&it, bs.wi);
            segment += 1;
        }
        if self.record {
            for v in verts.iter() {
                let c = l - v.l_before;
                let arrived = Vec3::new(
                    if v.beta.x > 0.0 { c.x / v.beta.x } else { 0.0 },
                    if v.beta.y > 0.0 { c.y / v.beta.y } else { 0.0 },
                    if v.beta.z > 0.0 { c.z / v.beta.z } else { 0.0 },
                );
                records.push(Record {
                    leaf: v.leaf,
                    cell: v.cell,
                    // nothing to deposit (and no deposit to leave out of the fraction
                    // choice) when the tree learns from elsewhere
                    value: if self.record_radiance {
                        mean(arrived).max(0.0) / v.pdf
                    } else {
                        0.0
                    },
                    counted: true,
                    fq: mean(arrived * v.weight).max(0.0),
                    q: v.pdf,
                    pb: v.pb,
                    p: v.p,
                });
            }
        }
        l
    }
}
