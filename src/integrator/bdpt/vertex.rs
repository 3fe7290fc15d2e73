//! Path vertices of bidirectional path tracing and the densities between them,
//! all in area measure (solid angle towards the environment, which has no area).

use crate::camera::Camera;
use crate::light::{Light, LightSample, SceneBounds, ShadowTarget};
use crate::material::{Bsdf, Normals, TransportMode};
use crate::math::{offset_ray_origin, Vec3, INV_4PI, INV_PI, PI};
use crate::medium::PhaseFunction;
use crate::scene::Scene;

/// What a vertex is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// The pinhole (delta position; its density is 1).
    Camera,
    /// The start of a light subpath, or a light sampled for a connection: index
    /// into `Scene::lights`.
    Light(u32),
    /// A surface point; it emits when `emitter` names its area light.
    Surface,
    /// A real scattering event in a medium, with its phase function (no normal:
    /// densities towards it take no cosine).
    Medium(PhaseFunction),
}

/// [`Vertex::media`]'s vacuum.
const VACUUM: u32 = u32::MAX;

/// One vertex of a camera or light subpath.
#[derive(Clone, Debug)]
pub struct Vertex {
    pub kind: Kind,
    pub p: Vec3,
    /// Geometric normal (zero for the camera and point lights); for a vertex at
    /// infinity (the environment), the unit direction from the scene to the sky.
    pub ng: Vec3,
    /// Shading normal (surfaces; else equal to `ng`).
    pub ns: Vec3,
    /// Direction to the previous vertex of its subpath (surfaces).
    pub wo: Vec3,
    pub infinite: bool,
    pub bsdf: Option<Bsdf>,
    /// The area light of the surface, if it emits.
    pub emitter: Option<u32>,
    /// Texture coordinates (surfaces and area-light origins: a textured emitter's radiance).
    pub uv: crate::math::Vec2,
    /// Throughput of the subpath up to and including this vertex (for a light
    /// subpath's first vertex: 1/(pmf·pdf_pos), its emission is evaluated apart).
    pub beta: Vec3,
    /// Scattered by a Dirac-delta BSDF (such a vertex cannot be connected).
    pub delta: bool,
    /// Density of this vertex as its own subpath sampled it, area measure.
    pub pdf_fwd: f32,
    /// Density of this vertex had the other subpath sampled it, area measure.
    pub pdf_rev: f32,
    /// The media a ray leaving here starts in: on the side of `ng` (and for vertices
    /// without a normal), and on the other side ([`Vertex::set_media`]; packed, as
    /// every vertex is copied in surface-only scenes too).
    pub media: [u32; 2],
}

impl Vertex {
    pub fn new(kind: Kind, p: Vec3, ng: Vec3, beta: Vec3) -> Vertex {
        Vertex {
            kind,
            p,
            ng,
            ns: ng,
            wo: Vec3::ZERO,
            infinite: false,
            bsdf: None,
            emitter: None,
            uv: crate::math::Vec2::ZERO,
            beta,
            delta: false,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            media: [VACUUM; 2],
        }
    }

    /// Sets the media on the side of `ng` and on the other side.
    #[inline]
    pub fn set_media(&mut self, media: [Option<u32>; 2]) {
        self.media = media.map(|m| m.unwrap_or(VACUUM));
    }

    /// The medium a ray leaving here in direction `w` starts in.
    #[inline]
    pub fn medium_towards(&self, w: Vec3) -> Option<u32> {
        let m = self.media[(w.dot(self.ng) < 0.0) as usize];
        (m != VACUUM).then_some(m)
    }

    /// On a surface: densities towards it pick up the cosine of its normal.
    #[inline]
    pub fn on_surface(&self) -> bool {
        !self.infinite && self.ng != Vec3::ZERO
    }

    /// The light this vertex emits as (a light vertex, or an emitting surface).
    #[inline]
    pub fn light(&self) -> Option<u32> {
        match self.kind {
            Kind::Light(i) => Some(i),
            Kind::Surface => self.emitter,
            Kind::Camera | Kind::Medium(_) => None,
        }
    }

    /// Whether a connection may end here (not a specular surface nor a black one).
    pub fn connectible(&self) -> bool {
        match self.kind {
            Kind::Camera | Kind::Light(_) | Kind::Medium(_) => true,
            Kind::Surface => self.bsdf.as_ref().is_some_and(|b| !b.is_delta()),
        }
    }

    /// Unit direction from this vertex towards `o`.
    #[inline]
    pub fn dir_to(&self, o: &Vertex) -> Vec3 {
        if o.infinite {
            o.ng
        } else if self.infinite {
            -self.ng
        } else {
            (o.p - self.p).normalize()
        }
    }

    /// |cos| between `w` and the normal that scatters (shading) or emits here; 1
    /// for the camera (its cosine is in the importance) and point lights.
    #[inline]
    pub fn cos(&self, w: Vec3) -> f32 {
        if self.on_surface() {
            self.ns.dot(w).abs()
        } else {
            1.0
        }
    }

    /// The BSDF from `wo` to `wi` (towards the next vertex) for the quantity the
    /// subpath carries: importance gets the adjoint ([`crate::material::adjoint`]).
    pub fn f(&self, wi: Vec3, mode: TransportMode) -> Vec3 {
        if let Kind::Medium(phase) = self.kind {
            // phase functions are symmetric: the same for both quantities
            return Vec3::splat(phase.eval(self.wo, wi));
        }
        let Some(bsdf) = &self.bsdf else { return Vec3::ZERO };
        match mode {
            TransportMode::Radiance => bsdf.eval(self.wo, wi),
            TransportMode::Importance => bsdf.eval_adjoint(self.wo, wi, Normals { ns: self.ns, ng: self.ng }),
        }
    }

    /// A point just off the surface, on the side of direction `w`.
    #[inline]
    pub fn origin_towards(&self, w: Vec3) -> Vec3 {
        if self.on_surface() {
            offset_ray_origin(self.p, if w.dot(self.ng) >= 0.0 { self.ng } else { -self.ng })
        } else {
            self.p
        }
    }
}

/// What the densities need besides the vertices.
#[derive(Clone, Copy)]
pub struct Ctx<'a> {
    pub scene: &'a Scene,
    pub camera: &'a Camera,
    pub bounds: SceneBounds,
}

impl Ctx<'_> {
    /// A solid-angle density at `from` turned into area measure at `to`.
    pub fn convert(&self, pdf: f32, from: &Vertex, to: &Vertex) -> f32 {
        if to.infinite {
            return pdf;
        }
        let v = to.p - from.p;
        let d2 = v.length_squared();
        if d2 == 0.0 {
            return 0.0;
        }
        let mut pdf = pdf / d2;
        if to.on_surface() {
            pdf *= to.ng.dot(v).abs() / d2.sqrt();
        }
        pdf
    }

    /// Density with which `cur` (reached from `prev`) samples `next`.
    pub fn pdf(&self, cur: &Vertex, prev: Option<&Vertex>, next: &Vertex) -> f32 {
        match cur.kind {
            Kind::Camera => self.convert(self.camera.pdf_dir_from(cur.p, cur.dir_to(next)), cur, next),
            Kind::Light(_) => self.pdf_light(cur, next),
            Kind::Surface => {
                let (Some(bsdf), Some(prev)) = (&cur.bsdf, prev) else { return 0.0 };
                self.convert(bsdf.pdf(cur.dir_to(prev), cur.dir_to(next)), cur, next)
            }
            Kind::Medium(phase) => prev.map_or(0.0, |prev| self.convert(phase.pdf(cur.dir_to(prev), cur.dir_to(next)), cur, next)),
        }
    }

    /// [`Ctx::pdf`] both ways at a surface or end vertex `cur` between `prev` and
    /// `next`: (density of `next` reached from `prev`, of `prev` reached from `next`),
    /// sharing the directions and the BSDF's frame (bit-identical to two calls).
    pub fn pdf_pair(&self, cur: &Vertex, prev: &Vertex, next: &Vertex) -> (f32, f32) {
        match (cur.kind, &cur.bsdf) {
            (Kind::Surface, Some(bsdf)) => {
                let (to_next, to_prev) = bsdf.pdf_pair(cur.dir_to(prev), cur.dir_to(next));
                (self.convert(to_next, cur, next), self.convert(to_prev, cur, prev))
            }
            _ => (self.pdf(cur, Some(prev), next), self.pdf(cur, Some(next), prev)),
        }
    }

    /// Density with which light emission from `light` (a light vertex or an emitting
    /// surface) reaches `next`: the direction part, or the disk for the environment.
    pub fn pdf_light(&self, light: &Vertex, next: &Vertex) -> f32 {
        let Some(i) = light.light() else { return 0.0 };
        match &self.scene.lights[i as usize] {
            // the disk's density projected onto `next` (pbrt-v4 treats its distant light,
            // a delta direction, as its infinite lights here)
            Light::Environment(_) | Light::Directional { .. } => {
                let r = self.bounds.radius;
                let cos = if next.on_surface() { next.ng.dot(light.ng).abs() } else { 1.0 };
                cos / (PI * r * r)
            }
            Light::Point { .. } => self.convert(INV_4PI, light, next),
            l @ (Light::Spot { .. } | Light::TexturedSpot(_) | Light::Projector(_)) => {
                self.convert(l.pdf_emission(Vec3::ZERO, light.dir_to(next), self.bounds).1, light, next)
            }
            Light::Area(_) => {
                let w = light.dir_to(next);
                self.convert(light.ng.dot(w).max(0.0) * INV_PI, light, next)
            }
        }
    }

    /// Density of `light` as the origin of a light subpath (light choice and
    /// position; the direction for the environment, `light.ng` pointing to the sky;
    /// the choice alone for delta lights).
    pub fn pdf_light_origin(&self, light: &Vertex) -> f32 {
        let Some(i) = light.light() else { return 0.0 };
        let pmf = self.scene.light_sampler.pmf(i as usize);
        let l = &self.scene.lights[i as usize];
        match l {
            // a delta position (point, spot) or direction (directional): the light's
            // choice alone (a camera subpath never reaches them, so strategy s = 0,
            // the only one that compares with this density, is impossible)
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } | Light::TexturedSpot(_) | Light::Projector(_) => pmf,
            Light::Area(a) => pmf / a.area(),
            Light::Environment(_) => pmf * l.pdf_emission(Vec3::ZERO, -light.ng, self.bounds).1,
        }
    }

    /// The light vertex a light sample `ls` of light `index`, taken from `from`, reached (at
    /// infinity: the sample's direction), with its density as a light subpath's origin.
    pub fn sampled_light(&self, index: usize, ls: &LightSample, from: Vec3) -> Vertex {
        let kind = Kind::Light(index as u32);
        let mut q = match ls.target {
            ShadowTarget::Infinity => Vertex {
                infinite: true,
                ..Vertex::new(kind, from, ls.wi, Vec3::ONE)
            },
            ShadowTarget::Point { p, n } => Vertex::new(kind, p, n.unwrap_or(Vec3::ZERO), Vec3::ONE),
        };
        q.pdf_fwd = self.pdf_light_origin(&q);
        q
    }

    /// Radiance (intensity for point and spot lights, irradiance for a directional
    /// one) that `light` emits in direction `w`
    /// (of travel, away from it).
    pub fn emitted(&self, light: &Vertex, w: Vec3) -> Vec3 {
        let Some(i) = light.light() else { return Vec3::ZERO };
        match &self.scene.lights[i as usize] {
            Light::Environment(e) => e.radiance(light.ng),
            l @ (Light::Point { .. } | Light::Spot { .. } | Light::TexturedSpot(_) | Light::Projector(_)) => l.intensity_towards(w),
            // along its direction only (`light.ng` points back to where it comes from)
            Light::Directional { irradiance, .. } => *irradiance,
            Light::Area(a) => a.emitted(light.ng, w, light.uv),
        }
    }
}
