//! The guided path tracer's samples: the camera-path estimator
//! ([`crate::integrator::estimator`], `path`'s) under a policy that draws
//! directions from a mixture of the BSDF and the learned distribution at
//! non-specular vertices, judges roulette its own way and records the radiance
//! each such vertex receives for the next iteration's distribution.

use super::quadtree::{sphere_to_square, square_to_sphere, DTree, Target};
use super::sdtree::SdTree;
use crate::accel::wide::PACKET;
use crate::geometry::{Ray, RayDifferential};
use crate::integrator::ears;
use crate::integrator::estimator::{trace, Branches, PathProfile, PathState, Policy};
use crate::integrator::path::trace_block;
use crate::integrator::{CameraBlock, CameraSample, PathTracer, RayCounts};
use crate::light::LightSample;
use crate::material::{Bsdf, BsdfSample};
use crate::math::{Vec2, Vec3, PI};
use crate::sampler::PixelSampler;
use crate::scene::{Interaction, Scene};

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
/// A vertex's record has its `p` only where `fq` or `value` is positive and its
/// `cell` only where `value` is (elsewhere 0): nothing reads them there (no deposit,
/// no part in the choice), and most vertices of a pass that learns from photons
/// record nothing but their leaf.
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
    pdf: f32,
    /// Throughput from the camera up to and including this vertex's scattering
    /// (before roulette): a later contribution C arrived here as C / beta.
    beta: Vec3,
    /// The sample's weight f·|cos|/q, the BSDF's density and the direction.
    weight: Vec3,
    pb: f32,
    dir: Direction,
    /// The estimate when the vertex was made (or after its own direct light, when
    /// that is not recorded): what arrives here is the estimate's growth since (a
    /// prefix sum instead of adding every contribution to every waiting vertex).
    l_before: Vec3,
}

/// A vertex's sampled direction: its point on the square where a sample of the
/// guide's mixture made it, else the direction, whose point (an arctangent) is made
/// only for a record that reads it.
#[derive(Clone, Copy, Debug)]
enum Direction {
    Square(Vec2),
    Sphere(Vec3),
}

impl Direction {
    #[inline]
    fn point(self) -> Vec2 {
        match self {
            Direction::Square(p) => p,
            Direction::Sphere(d) => sphere_to_square(d),
        }
    }
}

/// Per-thread buffers: the records of a tile, and the current path's vertices.
#[derive(Debug, Default)]
pub struct Scratch {
    pub records: Vec<Record>,
    verts: Vec<Vertex>,
}

/// What the sampler needs besides the scene.
///
/// Russian roulette is `path`'s (Mitsuba's: survive with probability min(β, 0.95)
/// from the 5th segment on) until the path takes a guided sample, so that where
/// no leaf guides a sample is `path`'s, number for number; after it, a path survives
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
    /// What the records estimate (with `record_radiance`): with [`Target::Variance`] a
    /// vertex records the second moment of its estimate, (F/q)²·q (F = f·|cos|·L̂_i, q
    /// its density), whose mean over the directions of a cell is the cell's ∫E[F²].
    pub target: Target,
}

impl Guiding<'_> {
    /// What a record deposits for a sample of density `q` whose estimate F/q is
    /// `fq` and whose incident radiance over `q` is `l_q` (nothing without
    /// `record_radiance`: the tree learns from photons).
    #[inline]
    fn record_value(&self, l_q: f32, fq: f32, q: f32) -> f32 {
        if !self.record_radiance {
            return 0.0;
        }
        match self.target {
            Target::Radiance => l_q,
            Target::Variance => fq * fq * q,
        }
    }
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
        ray: Ray,
        diff: Option<RayDifferential>,
        sampler: &mut PixelSampler,
        counts: &mut RayCounts,
        scratch: &mut Scratch,
    ) -> Vec3 {
        let mut walk = Walk::<false>::new(self, scratch, None);
        let l = trace(&mut walk, scene, PathState::new(ray), 1, diff.as_ref(), sampler, counts);
        if self.record {
            walk.record_arrivals(l);
        }
        l
    }

    /// [`Guiding::li`] of a pixel block's camera samples as `path`'s packets trace them
    /// ([`trace_block`]), each lane's walk with its own buffers in `lanes` (one per lane
    /// of a packet): lane `i`'s radiance goes to `out[i]` and its records to
    /// `lanes[i].records`, each exactly as `li` makes them.
    pub fn li_block(&self, scene: &Scene, block: &mut CameraBlock, out: &mut [Vec3], lanes: &mut [Scratch; PACKET]) {
        let n = block.rays.len();
        let mut lanes = lanes.iter_mut();
        let mut walks: [Walk<false>; PACKET] =
            std::array::from_fn(|_| Walk::new(self, lanes.next().expect("a lane per packet lane"), None));
        trace_block(scene, block, out, &mut walks[..n]);
        if self.record {
            for (walk, &l) in walks.iter_mut().zip(out.iter()) {
                walk.record_arrivals(l);
            }
        }
    }

    /// [`Guiding::li`] with EARS's roulette and splitting (`rr: "ears"`) instead of
    /// guided's roulette, by the statistics `learned` (the sample's pixel factor
    /// `pixel_factor`), the sub-paths waiting in `branches`; only for passes that do not
    /// record (a waiting vertex's prefix sum of the estimate follows one path).
    pub fn li_ears(
        &self,
        scene: &Scene,
        s: &mut CameraSample,
        scratch: &mut Scratch,
        learned: (&ears::State, Option<f32>),
        branches: &mut Branches,
    ) -> Vec3 {
        debug_assert!(!self.record, "EARS sub-paths do not record");
        let (sampler, counts) = (&mut *s.sampler, &mut *s.counts);
        branches.begin(counts.rays);
        let (state, pixel_factor) = learned;
        let ears = Learned {
            state,
            pixel_factor,
            split: !scene.has_media,
            branches,
        };
        let mut walk = Walk::<true>::new(self, scratch, Some(ears));
        let l = trace(&mut walk, scene, PathState::new(s.ray), 1, s.diff.as_ref(), sampler, counts);
        if let (true, Some(e)) = (scene.has_media, walk.ears.as_mut()) {
            // the media loop ends its one path itself
            e.branches.end_path(l, counts.rays);
        }
        l
    }
}

/// EARS's statistics for a walk that splits (see [`Guiding::li_ears`]).
struct Learned<'s> {
    state: &'s ears::State,
    pixel_factor: Option<f32>,
    /// Whether factors above 1 split (not in media: their loop traces one path).
    split: bool,
    branches: &'s mut Branches,
}

/// `guided`'s policy along one camera path, with what it records; `EARS`: roulette
/// and splitting are EARS's ([`Guiding::li_ears`]).
struct Walk<'g, 's, const EARS: bool> {
    guiding: &'g Guiding<'g>,
    records: &'s mut Vec<Record>,
    verts: &'s mut Vec<Vertex>,
    /// Roulette's view of the throughput: β as if the guided vertices had sampled
    /// their BSDFs (see [`Guiding`]).
    rr_scale: f32,
    /// Whether a vertex sampled from a mixture with the guide (until then roulette
    /// is `path`'s, so a path that never meets the guide is `path`'s sample).
    guided: bool,
    /// The last sample's point on the square and densities, when the guide took part.
    square: Option<GuidedPoint>,
    /// A light sample to record should its shadow ray get through: its leaf,
    /// direction and value before the transmittance.
    waiting_light: Option<(u32, Vec3, f32)>,
    /// Whether this vertex made a waiting [`Vertex`] (its own direct light is then
    /// no light arriving along its sampled direction).
    vertex_made: bool,
    /// With `EARS`: the statistics and the sub-paths' stack.
    ears: Option<Learned<'s>>,
}

impl<'g, 's, const EARS: bool> Walk<'g, 's, EARS> {
    fn new(guiding: &'g Guiding<'g>, scratch: &'s mut Scratch, ears: Option<Learned<'s>>) -> Self {
        let Scratch { records, verts } = scratch;
        verts.clear();
        Walk {
            guiding,
            records,
            verts,
            rr_scale: 1.0,
            guided: false,
            square: None,
            waiting_light: None,
            vertex_made: false,
            ears,
        }
    }
}

/// A vertex's spatial leaf, sampling mixture and strategy choice.
#[derive(Clone, Copy)]
struct Plan<'a> {
    leaf: u32,
    mixture: Mixture<'a>,
    u_choice: f32,
}

impl<'g, const EARS: bool> Policy for Walk<'g, '_, EARS> {
    type Plan = Plan<'g>;

    const SPLITS: bool = EARS;

    #[inline]
    fn split_factor(&self, it: &Interaction, beta: Vec3, eta_scale: f32, segment: u32) -> (f32, u32) {
        match &self.ears {
            Some(e) => e.state.split_factor(e.pixel_factor, e.split, it.p, beta, eta_scale, segment),
            None => (1.0, u32::MAX),
        }
    }

    #[inline]
    fn branches(&mut self) -> Option<&mut Branches> {
        self.ears.as_mut().map(|e| &mut *e.branches)
    }

    #[inline]
    fn profile(&self) -> PathProfile {
        PathProfile::Mis
    }

    #[inline]
    fn max_depth(&self) -> u32 {
        self.guiding.max_depth
    }

    fn plan(&mut self, it: &Interaction, bsdf: &Bsdf, sampler: &mut PixelSampler) -> Plan<'g> {
        let g = self.guiding;
        self.vertex_made = false;
        // every iteration samples with the leaf's learned fraction, except that
        // training from the paths' radiance samples with the guide at
        // `bsdf_fraction` (what it learns from its own samples sharpens it:
        // trained by BSDF samples alone, the caustic leaf of caustic_cbox gave
        // the sphere 54 % of its samples instead of 76 %)
        let learned = g.learn_fraction && !(g.record && g.record_radiance);
        // a vertex that records nothing needs its leaf only where a leaf may guide
        let leaf = match (bsdf.is_delta(), g.record || !learned) {
            (true, _) => None,
            (false, true) => Some(g.tree.leaf_of(it.p)),
            (false, false) => g.tree.guiding_leaf_of(it.p),
        };
        let mixture = if let Some(leaf) = leaf {
            let fraction = if learned { g.tree.bsdf_fraction(leaf) } else { g.bsdf_fraction };
            // BSDF sampling alone skips the guide
            let guide = if fraction >= 1.0 { None } else { g.tree.guide(leaf) };
            if let Some(t) = guide {
                // its lookups come after the light sample
                t.prefetch_top();
            }
            Mixture {
                guide,
                bsdf_fraction: fraction,
            }
        } else {
            Mixture {
                guide: None,
                bsdf_fraction: 1.0,
            }
        };
        let leaf = leaf.unwrap_or(0);
        // the strategy's number only where there is a choice: a vertex without the
        // guide draws `path`'s numbers
        let u_choice = if mixture.guide.is_some() { sampler.next_1d() } else { 0.0 };
        Plan { leaf, mixture, u_choice }
    }

    #[inline]
    fn pdf(&self, plan: &Plan, bsdf: &Bsdf, wo: Vec3, wi: Vec3) -> f32 {
        // without the guide the mixture's density is the BSDF's own, as `path` takes it
        plan.mixture.pdf(bsdf, wo, wi)
    }

    #[inline]
    fn sample(&mut self, plan: &Plan, bsdf: &Bsdf, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        // without the guide the mixture's sample is the BSDF's own, as `path` takes it
        let (bs, square) = plan.mixture.sample_on_square(bsdf, wo, plan.u_choice, u, uc)?;
        if let Some(g) = square {
            self.guided = true;
            if g.pb > 0.0 {
                self.rr_scale *= bs.pdf / g.pb;
            }
        }
        self.square = square;
        Some(bs)
    }

    /// From the 5th segment on, survive with probability min(1, β'/`rr_threshold`)
    /// once the path took a guided sample, by `path`'s rule before (see [`Guiding`]).
    #[inline]
    fn survival(&self, beta: Vec3, eta_scale: f32) -> f32 {
        let t = self.guiding.rr_threshold;
        if !self.guided {
            PathTracer::throughput_survival(beta, eta_scale)
        } else if t > 0.0 {
            (beta.max_element() * eta_scale * self.rr_scale / t).min(1.0)
        } else {
            1.0
        }
    }

    #[inline]
    fn add_emission(&mut self, l: &mut Vec3, c: Vec3, after_delta: bool) {
        add_emission(l, self.verts, c, !after_delta && !self.guiding.record_direct);
    }

    fn light_sampled(&mut self, plan: &Plan, ls: &LightSample, f_cos: Vec3, w: f32, light_pdf: f32) {
        let g = self.guiding;
        // a point light is no direction a guided sample can find
        self.waiting_light = (g.record && g.record_radiance && g.record_direct && !ls.delta).then(|| {
            let fq = mean(f_cos * ls.radiance) * w / light_pdf;
            (plan.leaf, ls.wi, g.record_value(mean(ls.radiance) * w / light_pdf, fq, light_pdf))
        });
    }

    fn light_arrived(&mut self, c: Vec3, tr: f32) {
        if self.vertex_made {
            // the vertex's own direct light does not arrive along its sampled direction
            if let Some(v) = self.verts.last_mut() {
                v.l_before += c;
            }
        }
        if let Some((leaf, wi, value)) = self.waiting_light.take() {
            self.records.push(Record {
                leaf,
                cell: self.guiding.tree.record_cell(leaf, wi),
                // the estimate F carries the transmittance, a second moment its square
                value: value * if self.guiding.target == Target::Variance { tr * tr } else { tr },
                counted: false,
                fq: 0.0,
                q: 0.0,
                pb: 0.0,
                p: Vec2::ZERO,
            });
        }
    }

    fn scattered(&mut self, plan: &Plan, bs: &BsdfSample, beta: Vec3, l: Vec3) {
        let g = self.guiding;
        if !g.record || bs.delta {
            return;
        }
        let square = self.square;
        self.verts.push(Vertex {
            leaf: plan.leaf,
            pdf: bs.pdf,
            beta,
            weight: bs.weight,
            // without the guide the sample is the BSDF's own
            pb: square.map_or(bs.pdf, |s| s.pb),
            dir: square.map_or(Direction::Sphere(bs.wi), |s| Direction::Square(s.p)),
            l_before: l,
        });
        self.vertex_made = true;
    }
}

impl<const EARS: bool> Walk<'_, '_, EARS> {
    /// Records what arrived at each waiting vertex of a path whose estimate is `l`.
    fn record_arrivals(&mut self, l: Vec3) {
        let g = self.guiding;
        for v in self.verts.iter() {
            let c = l - v.l_before;
            let arrived = Vec3::new(
                if v.beta.x > 0.0 { c.x / v.beta.x } else { 0.0 },
                if v.beta.y > 0.0 { c.y / v.beta.y } else { 0.0 },
                if v.beta.z > 0.0 { c.z / v.beta.z } else { 0.0 },
            );
            let fq = mean(arrived * v.weight).max(0.0);
            // nothing to deposit (and no deposit to leave out of the fraction
            // choice) when the tree learns from elsewhere
            let value = g.record_value(mean(arrived).max(0.0) / v.pdf, fq, v.pdf);
            // the point and the cell only where they are read (see `Record`)
            let (p, cell) = if fq > 0.0 || value > 0.0 {
                let p = v.dir.point();
                (p, if value > 0.0 { g.tree.record_cell_at(v.leaf, p) } else { 0 })
            } else {
                (Vec2::ZERO, 0)
            };
            self.records.push(Record {
                leaf: v.leaf,
                cell,
                value,
                counted: true,
                fq,
                q: v.pdf,
                pb: v.pb,
                p,
            });
        }
    }
}
