//! Rays through media and their boundaries: the transmittance of a shadow ray that
//! crosses `null` surfaces (Mitsuba's `volpath` shadow rays), estimated by ratio
//! tracking in each medium it passes ([`crate::medium::tracking`]).

use super::{Hit, Interaction, Prim, Scene, Shape};
use crate::geometry::aabb::Aabb;
use crate::geometry::Ray;
use crate::light::Light;
use crate::math::{offset_ray_origin, Vec3};
use crate::medium::ratio_tracking;
use std::collections::HashMap;

/// Null surfaces one ray crosses at most (a deeper stack counts as opaque).
pub const MAX_NULL_CROSSINGS: u32 = 256;

impl Scene {
    /// The medium a ray in direction `d` is in after crossing or leaving the surface
    /// point `it` (`current` when its object declares no media).
    #[inline]
    pub fn medium_after(&self, it: &Interaction, d: Vec3, current: Option<u32>) -> Option<u32> {
        match self.objects[it.object as usize].media {
            Some(mi) => mi.along(d, it.ng),
            None => current,
        }
    }

    /// Whether the surface of `it` is a `null` boundary, which rays cross unchanged.
    #[inline]
    pub fn is_null(&self, it: &Interaction) -> bool {
        self.objects[it.object as usize].null_bsdf
    }

    /// `ray` continued from the far side of the surface point `it` it reached
    /// (unchanged direction; `t_max` shortened by the distance travelled).
    #[inline]
    pub fn ray_beyond(ray: &Ray, it: &Interaction) -> Ray {
        let side = if ray.d.dot(it.ng) >= 0.0 { it.ng } else { -it.ng };
        let o = offset_ray_origin(it.p, side);
        let advanced = (o - ray.o).dot(ray.d) / ray.d.length_squared();
        Ray::with_range(o, ray.d, 0.0, ray.t_max - advanced)
    }

    /// The fraction of light of each channel that passes along `ray` (which starts in
    /// `medium`) over `[t_min, t_max]`: 0 at a surface that is not `null`, the media's
    /// transmittance (ratio tracking, numbers from `u`) across `null` boundaries.
    pub fn transmittance_through_media(&self, ray: &Ray, mut medium: Option<u32>, mut u: impl FnMut() -> f32) -> Vec3 {
        let (mut r, mut tr) = (*ray, Vec3::ONE);
        for _ in 0..MAX_NULL_CROSSINGS {
            let hit: Option<Hit> = self.intersect(&r);
            // an opaque surface first: the medium before it need not be tracked
            let it = hit.map(|h| self.interaction(&r, &h));
            if it.as_ref().is_some_and(|it| !self.is_null(it)) {
                return Vec3::ZERO;
            }
            if let Some(m) = medium {
                let t_end = hit.map_or(r.t_max, |h| h.t);
                tr *= ratio_tracking(&self.media[m as usize], &r, t_end, &mut u);
                if tr.max_element() <= 0.0 {
                    return Vec3::ZERO;
                }
            }
            let Some(it) = it else {
                return tr;
            };
            medium = self.medium_after(&it, r.d, medium);
            r = Scene::ray_beyond(&r, &it);
            if r.t_max <= 0.0 {
                return tr;
            }
        }
        Vec3::ZERO
    }
}

impl Scene {
    /// Whether a light sample taken at a vertex in `medium` may arrive: false in a
    /// [sealed](sealed_media) medium, whose vertices then sample no light.
    #[inline]
    pub fn lights_reach(&self, medium: Option<u32>) -> bool {
        medium.is_none_or(|m| !self.sealed_media[m as usize])
    }
}

/// Which media are sealed: no shadow ray from a point inside one can reach a light, because
/// the medium is only the interior of closed, outward-facing, opaque (not `null`, no mask),
/// non-emitting shapes, the camera is not in it and no light lies within those shapes'
/// boxes (a glass of milk under the sky: its light arrives only through the glass, by
/// scattering). Light sampling there would cost a shadow ray per event for nothing.
/// Conservative (false when unsure); a wrong true would only add noise, never bias, as a
/// vertex that samples no light weighs the emission its phase sample finds by 1.
pub fn sealed_media(scene: &Scene) -> Vec<bool> {
    let n = scene.media.len();
    if scene.has_masks || !scene.instances.is_empty() || !scene.groups.is_empty() {
        return vec![false; n];
    }
    let mut bounds = vec![Aabb::EMPTY; scene.objects.len()];
    for prim in &scene.prims {
        if let Prim::Triangle { object, .. } | Prim::Sphere { object, .. } | Prim::Cylinder { object, .. } = *prim {
            bounds[object as usize] = bounds[object as usize].union(prim.bounds());
        }
    }
    // boxes a light may lie in: `None` for lights at infinity
    let mut light_boxes = Vec::new();
    for (li, light) in scene.lights.iter().enumerate() {
        match light {
            Light::Environment(_) | Light::Directional { .. } => {}
            Light::Point { position, .. } | Light::Spot { position, .. } => light_boxes.push(Aabb::new(*position, *position)),
            Light::Area(_) => {
                let objects = scene.objects.iter().enumerate().filter(|(_, o)| o.light == Some(li as u32));
                light_boxes.extend(objects.map(|(oi, _)| bounds[oi]));
            }
            Light::TexturedSpot(_) | Light::Projector(_) => return vec![false; n],
        }
    }
    let overlap = |a: &Aabb, b: &Aabb| (a.min.cmple(b.max) & b.min.cmple(a.max)).all();
    (0..n as u32)
        .map(|m| {
            let mut boundaries = 0;
            for (oi, o) in scene.objects.iter().enumerate() {
                let Some(mi) = o.media else { continue };
                if mi.exterior == Some(m) {
                    return false;
                }
                if mi.interior == Some(m) {
                    let opaque = !o.null_bsdf && o.light.is_none() && encloses_inside(&o.shape);
                    if !opaque || light_boxes.iter().any(|b| overlap(b, &bounds[oi])) {
                        return false;
                    }
                    boundaries += 1;
                }
            }
            boundaries > 0 && scene.camera_medium != Some(m)
        })
        .collect()
}

/// Whether `shape` is closed with its geometric normals outwards, so that its interior
/// side is bounded: a sphere; a mesh whose every directed edge (by vertex position) meets
/// its reverse exactly once, with a positive signed volume. Open cylinders are not.
fn encloses_inside(shape: &Shape) -> bool {
    let mesh = match shape {
        Shape::Sphere(_) => return true,
        // a grid's surface may end open at the grid's faces
        Shape::Cylinder(_) | Shape::SdfGrid(_) => return false,
        Shape::Mesh(m) => m,
    };
    let key = |p: Vec3| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let mut edges: HashMap<([u32; 3], [u32; 3]), u32> = HashMap::new();
    let mut volume = 0.0f64;
    for i in 0..mesh.triangles.len() {
        let p = mesh.vertices(i);
        for k in 0..3 {
            *edges.entry((key(p[k]), key(p[(k + 1) % 3]))).or_default() += 1;
        }
        volume += f64::from(p[0].dot(p[1].cross(p[2])));
    }
    volume > 0.0 && edges.iter().all(|(&(a, b), &count)| count == 1 && edges.get(&(b, a)) == Some(&1))
}
