//! The world, render-ready: loaded meshes, resolved names, lights with their
//! sampler, the BVH ([`Scene`]). It is built from the description layer
//! ([`crate::desc`]) by [`crate::desc::build`], and shares with it one definition of
//! each variant family, generic over what is still unresolved in the description:
//! [`Material`], [`Texture`], [`Shape`], [`crate::film::Filter`],
//! [`crate::camera::CameraParams`] and [`crate::texture::UvMapping`].

mod media;
pub use media::{sealed_media, MAX_NULL_CROSSINGS};

use crate::accel::instance::{Group, Instance, TwoLevel};
use crate::accel::WideBvh;
use crate::geometry::cylinder::CylinderShape;
pub use crate::geometry::interaction::Interaction;
use crate::geometry::interaction::SphereUv;
use crate::geometry::mesh::Mesh;
pub use crate::geometry::prim::{Hit, Prim};
use crate::geometry::sdfgrid::SdfGrid;
use crate::geometry::sphere::Sphere;
use crate::geometry::Ray;
use crate::light::Light;
use crate::material::Material;
use crate::math::{Vec2, Vec3};
use crate::medium::{Medium, MediumInterface};
use crate::texture::{TexCoord, Texture, TextureConvention};

/// An object's geometry, chosen by `objects[i].type`. The mesh is `M`: a file to
/// read in the scene description ([`desc::MeshFile`]: `path`, `transform`,
/// `translate`), the loaded [`Mesh`] (the default) once the scene is built; an
/// sdfgrid is `G`, its file ([`desc::SdfGridFile`]) or the loaded [`SdfGrid`].
#[derive(Clone, Debug)]
pub enum Shape<M = Mesh, G = SdfGrid> {
    /// `mesh`: `path` (OBJ, required), `transform` (16 numbers row-major, identity),
    /// `translate` ((0,0,0), added after `transform`); see [`desc::MeshFile`].
    Mesh(M),
    /// `sphere`: `center` (vec3, (0,0,0)), `radius` (> 0, 1), `uv_frame` (9 numbers
    /// row-major, a rotation whose columns are the sphere's own axes, z its pole: Mitsuba's
    /// uv in that frame, as the XML reader gives; absent: RDR171's uv about the world z);
    /// see [`Sphere::uv_frame`]. Example: `{"type": "sphere", "radius": 2, "uv_frame": [1,0,0, 0,0,-1, 0,1,0]}`.
    Sphere(Sphere),
    /// `cylinder`: Mitsuba's open cylinder, `p0` ((0,0,0)), `p1` ((0,0,1)), `radius` (1),
    /// `flip_normals` (false), `transform` (16 numbers row-major, identity; a rotation,
    /// translation and a scale uniform across the axis); see [`crate::desc`]'s `parse_cylinder`.
    Cylinder(CylinderShape),
    /// `sdfgrid`: Mitsuba's signed distance grid, `filename` (a one-channel `.vol`
    /// grid, required), `normals` (`smooth` | `analytic`, `smooth`), `transform` (16
    /// numbers row-major, identity: the unit cube to the world); no `light`.
    SdfGrid(G),
}

/// One entry of the scene's `objects` list, resolved.
#[derive(Clone, Debug)]
pub struct Object {
    pub shape: Shape,
    pub material: Option<u32>,
    /// Index into `Scene::lights` of the area light on this object.
    pub light: Option<u32>,
    /// The media on its two sides, if it declares any (indices into `Scene::media`).
    pub media: Option<MediumInterface>,
    /// A `null` BSDF: rays cross the surface unchanged (a boundary between media).
    pub null_bsdf: bool,
}

impl Interaction {
    /// The texture coordinates and their footprint, for [`crate::texture::Texture::eval`].
    #[inline]
    pub fn tex_coord(&self) -> TexCoord {
        TexCoord {
            uv: self.uv,
            duvdx: self.duvdx,
            duvdy: self.duvdy,
            attributes: self.attributes,
        }
    }
}

/// The world: geometry, materials, textures, lights with their sampler, and the
/// BVH. What is rendered of it, and how, is a [`crate::render::RenderJob`].
pub struct Scene {
    /// Some texture filters by footprint (an image texture that a material reads):
    /// camera rays carry differentials.
    pub uses_footprints: bool,
    /// Some material reads the surface's texture coordinates, uv tangents or mesh
    /// attributes (a texture other than a constant, a bump or normal map): only then
    /// does [`Scene::interaction`] compute them (they are zero otherwise; see
    /// [`crate::material::Material::reads_surface`]).
    pub texture_coords: bool,
    pub textures: Vec<Texture>,
    pub materials: Vec<Material>,
    pub objects: Vec<Object>,
    pub lights: Vec<Light>,
    /// Index of the environment light in `lights`.
    pub environment: Option<u32>,
    pub light_sampler: crate::light::LightSampler,
    pub light_sampling: crate::light::LightSampling,
    /// Bounding sphere of the geometry.
    pub center: Vec3,
    pub radius: f32,
    /// Primitives in BVH leaf order; the BVH's primitive indices index this.
    pub prims: Vec<Prim>,
    pub bvh: WideBvh,
    /// Placed groups ([`Prim::Instance`] entries of `prims` index this); empty
    /// without instancing, and then the BVH is traversed as a one-level tree.
    pub instances: Vec<Instance>,
    /// The instances' shared bottom levels; their primitives' `object`s index
    /// `objects` (the group members, after the scene's own objects).
    pub groups: Vec<Group>,
    pub warnings: Vec<String>,
    /// Seconds spent building the BVH.
    pub bvh_seconds: f64,
    /// Sphere uv order (and image orientation, baked into the textures).
    pub texture_convention: TextureConvention,
    /// Some object's material is a `mask`: hits are then tested for pass-through.
    pub has_masks: bool,
    /// Participating media (objects' [`MediumInterface`]s index this).
    pub media: Vec<Medium>,
    /// The medium the camera is in (vacuum: `None`).
    pub camera_medium: Option<u32>,
    /// Some object is a medium boundary or has a `null` BSDF (or the camera is in a
    /// medium): camera paths then track media ([`crate::integrator::estimator`]).
    pub has_media: bool,
    /// Per medium: no light sample is taken from inside it, because none can arrive
    /// ([`media::sealed_media`]) or its description asks for none (`sample_emitters`).
    pub sealed_media: Vec<bool>,
}

/// Masked surfaces one ray passes through at most (a stack of cut-outs deeper than
/// this counts as opaque).
const MAX_MASK_PASSES: u32 = 256;

/// A uniform number in [0, 1) for a mask's pass-through choice: a hash of the ray's
/// origin, direction and the primitive hit.
#[inline]
fn mask_sample(r: &Ray, prim: u32) -> f32 {
    use crate::sampler::hash_combine;
    let h = [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z]
        .iter()
        .fold(crate::sampler::hash_u32(prim), |h, v| hash_combine(h, v.to_bits()));
    (h >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

impl Scene {
    /// Closest hit in `[ray.t_min, ray.t_max]`. A hit on a `mask` material of opacity α
    /// at the point is kept with probability α and otherwise passed through (the ray
    /// goes on from just behind it; `t` stays the distance along `ray`), so every ray of
    /// every integrator sees cut-outs (Mitsuba's `volpath` semantics: its `mask` samples
    /// the pass-through with probability 1 − α, weight 1). Shadow rays and connections
    /// use [`Scene::transmittance`] instead, weighted by 1 − α. The choice is a hash of the ray and the primitive: deterministic,
    /// independent of threads, and exact for binary masks.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let hit = self.intersect_unmasked(ray)?;
        if !self.has_masks {
            return Some(hit);
        }
        self.through_masks(ray, hit)
    }

    /// Closest hit, masks not applied: the scene's own BVH, or its two levels.
    #[inline(always)]
    fn intersect_unmasked(&self, ray: &Ray) -> Option<Hit> {
        if self.instances.is_empty() {
            self.bvh.intersect(&self.prims, ray)
        } else {
            self.two_level().intersect(&self.bvh, ray)
        }
    }

    /// The two-level view of the top level's primitives.
    #[inline]
    pub fn two_level(&self) -> TwoLevel<'_> {
        TwoLevel {
            prims: &self.prims,
            instances: &self.instances,
            groups: &self.groups,
        }
    }

    /// Whether anything lies on the ray within `[t_min, t_max]` (masks as in
    /// [`Scene::intersect`]).
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if !self.has_masks {
            return self.occluded_unmasked(ray);
        }
        self.intersect(ray).is_some()
    }

    #[inline(always)]
    fn occluded_unmasked(&self, ray: &Ray) -> bool {
        if self.instances.is_empty() {
            self.bvh.occluded(&self.prims, ray)
        } else {
            self.two_level().occluded(&self.bvh, ray)
        }
    }

    /// Whether packet queries ([`Scene::intersect_packet_lanes`], [`Scene::occluded_packet`])
    /// trace rays together: a one-level tree without masks, with packets on.
    #[inline]
    pub fn packets(&self) -> bool {
        self.bvh.packet_width() != 0 && !self.has_masks && self.instances.is_empty()
    }

    /// [`Scene::intersect`] of up to [`crate::accel::wide::PACKET`] rays, by lane: lane
    /// `i` of `out` gets `rays[i]`'s hit for each bit `i` of `active` (other lanes are
    /// not found); traced together when [`Scene::packets`] says so.
    pub fn intersect_packet_lanes(&self, rays: &[Ray], active: u32, out: &mut crate::accel::wide::PacketHits) {
        if self.packets() {
            self.bvh.intersect_packet_lanes_with(&self.prims[..], rays, active, out);
        } else {
            out.found = 0;
            for (i, r) in rays
                .iter()
                .enumerate()
                .take(crate::accel::wide::PACKET)
                .filter(|(i, _)| active >> i & 1 != 0)
            {
                out.set(i, self.intersect(r));
            }
        }
    }

    /// [`Scene::occluded`] of up to [`crate::accel::wide::PACKET`] rays: bit `i` for
    /// `rays[i]` (0 outside `active`).
    pub fn occluded_packet(&self, rays: &[Ray], active: u32) -> u32 {
        if self.packets() {
            return self.bvh.occluded_packet(&self.prims, rays, active);
        }
        let hit = |(i, r): (usize, &Ray)| active >> i & 1 != 0 && self.occluded(r);
        rays.iter().enumerate().filter(|&x| hit(x)).fold(0, |m, (i, _)| m | 1 << i)
    }

    /// The fraction of light that passes along a shadow ray or a connection within
    /// `[t_min, t_max]`: 0 when an opaque surface lies on it, else the product of
    /// 1 − α over the masked surfaces it crosses (a `mask` of opacity α), as the
    /// shadow rays of Mitsuba's `volpath` weight them (its `eval_null_transmission`).
    /// Without masks it is exactly 1 or 0 ([`Scene::occluded`]).
    #[inline]
    pub fn transmittance(&self, ray: &Ray) -> f32 {
        if !self.has_masks {
            return if self.occluded_unmasked(ray) { 0.0 } else { 1.0 };
        }
        let Some(hit) = self.intersect_unmasked(ray) else {
            return 1.0;
        };
        let mut tr = 1.0f32;
        let stopped = self.walk_masks(ray, hit, |alpha, _, _| {
            if alpha >= 1.0 {
                return false;
            }
            tr *= 1.0 - alpha.max(0.0);
            tr > 0.0
        });
        if stopped.is_some() {
            0.0
        } else {
            tr
        }
    }

    /// The first hit from `hit` on (the closest hit of `ray`) that a mask does not pass.
    fn through_masks(&self, ray: &Ray, hit: Hit) -> Option<Hit> {
        self.walk_masks(ray, hit, |alpha, r, prim| {
            !(alpha >= 1.0 || (alpha > 0.0 && mask_sample(r, prim) < alpha))
        })
    }

    /// The first hit from `hit` on (the closest hit of `ray`) where `pass(α, ray, prim)`
    /// says no: a surface without a mask, or a mask of opacity α there that `pass`
    /// does not pass through (`ray` the segment that reached it). `None` when the ray
    /// leaves `[t_min, t_max]` through masks only.
    fn walk_masks(&self, ray: &Ray, mut hit: Hit, mut pass: impl FnMut(f32, &Ray, u32) -> bool) -> Option<Hit> {
        let mut r = *ray;
        // distance along `ray` of the current ray's origin
        let mut start = 0.0f32;
        for _ in 0..MAX_MASK_PASSES {
            let it = self.interaction(&r, &hit);
            let opacity = match self.objects[it.object as usize].material {
                Some(m) => self.materials[m as usize].mask_opacity(),
                None => None,
            };
            let Some(&t) = opacity else {
                hit.t += start;
                return Some(hit);
            };
            let tc = crate::texture::TexCoord {
                duvdx: Vec2::ZERO,
                duvdy: Vec2::ZERO,
                ..it.tex_coord()
            };
            let alpha = crate::texture::luminance(self.textures[t as usize].eval(tc));
            if !pass(alpha, &r, hit.prim) {
                hit.t += start;
                return Some(hit);
            }
            let side = if r.d.dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
            let o = crate::math::offset_ray_origin(it.p, side);
            let advanced = (o - ray.o).dot(ray.d) / ray.d.length_squared();
            if advanced.partial_cmp(&start) != Some(std::cmp::Ordering::Greater) || advanced >= ray.t_max {
                return None;
            }
            start = advanced;
            r = Ray::with_range(o, ray.d, (ray.t_min - start).max(0.0), ray.t_max - start);
            hit = self.intersect_unmasked(&r)?;
        }
        hit.t += start;
        Some(hit)
    }

    /// The surface point of a hit ([`Interaction::of_hit`]); spheres' uv order
    /// follows the scene's [`TextureConvention`]; texture coordinates, tangents and mesh
    /// attributes are computed when [`Scene::texture_coords`] says a material reads them.
    /// Inlined into the integrators' code: called, it read the caller's copy of the ray
    /// with loads that straddled the halves of the wide store that made it, which
    /// could not forward (perf: a sixth of `Interaction::of_hit`'s time on one load).
    #[inline(always)]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> Interaction {
        let sphere_uv = match self.texture_convention {
            TextureConvention::Physical => SphereUv::PhiTheta,
            // the original stores (θ/π, φ/2π), derivatives in the same order (§10.2)
            TextureConvention::Rdr171 => SphereUv::ThetaPhi,
        };
        let mesh = |object: u32| match &self.objects[object as usize].shape {
            Shape::Mesh(mesh) => mesh,
            _ => unreachable!("triangle of a non-mesh"),
        };
        let mut it = match &self.prims[hit.prim as usize] {
            // the common case in short: a triangle (of a mesh, so no cylinder's flip)
            // whose texture coordinates nothing reads
            Prim::Triangle { p, object, index } if !self.texture_coords => {
                return Interaction::on_triangle(p, hit.b, mesh(*object), *index, *object, -ray.d, false);
            }
            Prim::Instance { instance, .. } => {
                // made in the group's frame, then carried to the world
                let inst = &self.instances[*instance as usize];
                let group = &self.groups[inst.group as usize];
                let local_ray = inst.ray_to_object(ray);
                let local_hit = Hit {
                    prim: hit.sub,
                    sub: 0,
                    ..*hit
                };
                let mut l = Interaction::of_hit(
                    &group.prims[hit.sub as usize],
                    &local_ray,
                    &local_hit,
                    mesh,
                    sphere_uv,
                    self.texture_coords,
                );
                if let Shape::SdfGrid(g) = &self.objects[l.object as usize].shape {
                    l.ns = g.shading_normal(l.p, l.ng);
                }
                Interaction {
                    p: inst.point_to_world(l.p),
                    ng: inst.normal_to_world(l.ng),
                    ns: inst.normal_to_world(l.ns),
                    dpdu: inst.vector_to_world(l.dpdu),
                    dpdv: inst.vector_to_world(l.dpdv),
                    wo: -ray.d,
                    ..l
                }
            }
            prim => Interaction::of_hit(prim, ray, hit, mesh, sphere_uv, self.texture_coords),
        };
        if let Shape::Cylinder(CylinderShape { flip_normals: true, .. }) = self.objects[it.object as usize].shape {
            it.ng = -it.ng;
            it.ns = -it.ns;
        }
        it
    }

    /// The area light on the surface of `it`, if any.
    pub fn area_light_of(&self, it: &Interaction) -> Option<(u32, &crate::light::AreaLight)> {
        let i = self.objects[it.object as usize].light?;
        match &self.lights[i as usize] {
            Light::Area(a) => Some((i, a)),
            _ => None,
        }
    }

    /// The environment light and its index, if there is one.
    pub fn environment_light(&self) -> Option<(u32, &crate::light::environment::EnvironmentLight)> {
        let i = self.environment?;
        match &self.lights[i as usize] {
            Light::Environment(e) => Some((i, e)),
            _ => None,
        }
    }

    /// Radiance arriving from the environment along direction `w` (0 without one).
    pub fn environment_radiance(&self, w: Vec3) -> Vec3 {
        match self.environment.map(|i| &self.lights[i as usize]) {
            Some(Light::Environment(e)) => e.radiance(w),
            _ => Vec3::ZERO,
        }
    }

    /// The material at `it`, any `mask` around it taken off (masks act in
    /// [`Scene::intersect`]: a point that was hit is opaque).
    pub fn material_of(&self, it: &Interaction) -> Option<&Material> {
        self.material_of_object(it.object)
    }

    /// [`Scene::material_of`] a point of object `object`.
    pub fn material_of_object(&self, object: u32) -> Option<&Material> {
        self.objects[object as usize]
            .material
            .map(|m| self.materials[m as usize].unmasked())
    }

    /// Triangles in the top level (instanced ones not counted).
    pub fn triangle_count(&self) -> usize {
        self.prims.iter().filter(|p| p.is_triangle()).count()
    }
}
