//! A reference for the renderer's queries: a binary BVH visited through a closure
//! with the scalar kernels ([`Prim::intersect`]), and a comparison of any
//! [`Tracer`] with it. `rdr bench` checks every traversal variant with these;
//! tests can too.

use super::{Bvh, WideBvh};
use crate::geometry::prim::{prim_bounds, Hit, Prim};
use crate::geometry::{Aabb, Ray};

/// A closest-hit or any-hit implementation under test.
pub trait Tracer: Sync {
    fn closest(&self, ray: &Ray) -> Option<Hit>;
    fn any(&self, ray: &Ray) -> bool;
}

/// The reference: a binary BVH visited through a closure, scalar watertight kernel.
pub struct Reference<'a> {
    pub prims: &'a [Prim],
    pub bvh: Bvh,
}

impl<'a> Reference<'a> {
    pub fn new(prims: &'a [Prim]) -> Self {
        let bounds: Vec<Aabb> = prims.iter().map(prim_bounds).collect();
        Reference {
            prims,
            bvh: Bvh::build(&bounds),
        }
    }
}

impl Tracer for Reference<'_> {
    fn closest(&self, ray: &Ray) -> Option<Hit> {
        let mut best = None;
        self.bvh.traverse(ray, |i, t_max| {
            if let Some((t, b)) = self.prims[i as usize].intersect(ray, *t_max) {
                *t_max = t;
                best = Some(Hit { t, prim: i, b, sub: 0 });
            }
            false
        });
        best
    }
    fn any(&self, ray: &Ray) -> bool {
        let mut hit = false;
        self.bvh.traverse(ray, |i, t_max| {
            hit = self.prims[i as usize].intersect(ray, *t_max).is_some();
            hit
        });
        hit
    }
}

/// The renderer's queries (`Scene::intersect` and `occluded` call these).
pub struct Wide<'a> {
    pub prims: &'a [Prim],
    pub bvh: &'a WideBvh,
}

impl Tracer for Wide<'_> {
    #[inline]
    fn closest(&self, ray: &Ray) -> Option<Hit> {
        self.bvh.intersect(self.prims, ray)
    }
    #[inline]
    fn any(&self, ray: &Ray) -> bool {
        self.bvh.occluded(self.prims, ray)
    }
}

/// Compares `t` with the reference on every `step`-th ray; returns the mismatches.
pub fn check(reference: &dyn Tracer, t: &dyn Tracer, prims: &[Prim], rays: &[Ray], step: usize) -> Vec<String> {
    let mut bad = Vec::new();
    for (k, ray) in rays.iter().enumerate().step_by(step.max(1)) {
        let r = reference.closest(ray);
        let g = t.closest(ray);
        let ok = match (r, g) {
            (None, None) => true,
            (Some(a), Some(b)) => {
                (a.prim == b.prim && a.t == b.t && a.b == b.b)
                    || (a.t == b.t && prims[b.prim as usize].intersect(ray, ray.t_max).map(|h| h.0) == Some(b.t))
            }
            _ => false,
        };
        if !ok {
            bad.push(format!("ray {k}: closest hit {g:?}, reference {r:?}"));
        }
        let (ra, ga) = (r.is_some(), t.any(ray));
        if ra != ga {
            bad.push(format!("ray {k}: any-hit {ga}, reference {ra}"));
        }
    }
    bad
}
