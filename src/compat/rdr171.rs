//! The RDR171 `intersection_test` exactly as the course's reference images were
//! made (spec §5, §7, §13, §14): the integrator rows of the table in [`super`].
//! Deliberately unphysical. It runs in place of `intersection_test` under
//! `--compat rdr171` (`Integrator::Rdr171`, which hands it the pass's settings).

use crate::camera::Camera;
use crate::film::{Film, FilmSettings, FilmTile};
use crate::geometry::triangle::intersect_moller_trumbore_f64;
use crate::geometry::Ray;
use crate::light::Light;
use crate::material::Material;
use crate::math::{reflect, refract, Vec2, Vec3, INV_PI, PI};
use crate::sampler::Mt19937Sampler;
use crate::scene::{Hit, Interaction, Prim, Scene};
use rayon::prelude::*;

struct Candidate {
    key: (u32, u32),
    prim: u32,
    t: f64,
    b: [f32; 3],
}

/// Closest hit with the original's semantics: primitives in scene order, each
/// accepted when `t_min ≤ t ≤ f32(t_max)` and then `t_max = f32(t)`. The BVH
/// collects every hit that could take part; they are replayed in scene order.
pub fn intersect(scene: &Scene, ray: &Ray) -> Option<Hit> {
    let mut cands: Vec<Candidate> = Vec::new();
    let mut best = ray.t_max;
    scene.bvh.traverse(ray, |i, t_max| {
        let prim = &scene.prims[i as usize];
        let found = match prim {
            Prim::Triangle { p, .. } => {
                intersect_moller_trumbore_f64(ray.o, ray.d, ray.t_min as f64, best as f64, p).map(|h| (h.t, h.bary()))
            }
            Prim::Sphere { sphere, .. } => sphere.intersect(ray.o, ray.d, ray.t_min, best).map(|t| (t as f64, [0.0; 3])),
            // the course had neither (`RenderJob::from_desc` refuses them under --compat rdr171)
            Prim::Cylinder { .. } | Prim::SdfVoxel { .. } | Prim::Instance { .. } => None,
        };
        if let Some((t, b)) = found {
            cands.push(Candidate {
                key: prim.order_key(),
                prim: i,
                t,
                b,
            });
            best = best.min(t as f32);
            // a little slack so boxes holding exact ties are not culled
            *t_max = best.next_up().next_up();
        }
        false
    });
    cands.sort_by_key(|c| c.key);
    let mut t_max = ray.t_max;
    let mut hit = None;
    for c in cands {
        if c.t <= t_max as f64 {
            t_max = c.t as f32;
            hit = Some(Hit {
                t: t_max,
                prim: c.prim,
                b: c.b,
                sub: 0,
            });
        }
    }
    hit
}

/// The column renderer: the scene's `max_depth` (surface hits, not segments).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rdr171Columns {
    pub max_depth: u32,
}

pub fn li(scene: &Scene, mut ray: Ray, max_depth: u32) -> Vec3 {
    for _ in 0..max_depth {
        let Some(hit) = intersect(scene, &ray) else { return Vec3::ZERO };
        let it = scene.interaction(&ray, &hit);
        match scene.material_of(&it) {
            Some(Material::Refraction { eta }) => {
                let n = it.ns;
                let entering = n.dot(it.wo) > 0.0;
                let (ratio, n) = if entering { (*eta, n) } else { (1.0 / *eta, -n) };
                let wi = refract(it.wo, n, ratio).unwrap_or_else(|| reflect(it.wo, n));
                // the offset along the normal faced forward (`dot(wi, ng) < 0 ? −ng : ng`)
                let ng = if wi.dot(it.ng) < 0.0 { -it.ng } else { it.ng };
                ray = Ray::new(it.p + ng * 1e-4, wi);
            }
            Some(Material::Diffuse { texture, twosided }) => {
                let albedo = scene.textures[*texture as usize].eval(it.uv);
                return direct(scene, &it, albedo, *twosided);
            }
            _ => return Vec3::ZERO,
        }
    }
    Vec3::ZERO
}

fn direct(scene: &Scene, it: &Interaction, albedo: Vec3, twosided: bool) -> Vec3 {
    let n_bsdf = if twosided && it.ns.dot(it.wo) < 0.0 { -it.ns } else { it.ns };
    let mut total = Vec3::ZERO;
    for light in &scene.lights {
        // the original lights only with its point light; area lights and the environment stay dark
        let Light::Point { position, flux } = light else { continue };
        let v = *position - it.p;
        let d = v.dot(v).sqrt();
        let l = v / d;
        if let Some(h) = intersect(scene, &Ray::new(it.p, l)) {
            if h.t < d {
                continue;
            }
        }
        let cos = l.dot(it.ng).max(0.0);
        let f = if l.dot(n_bsdf) < 0.0 || it.wo.dot(n_bsdf) < 0.0 {
            Vec3::ZERO
        } else {
            albedo * INV_PI
        };
        total += (((*flux * f) * cos) / (4.0 * PI)) * (d * d);
    }
    total
}

impl Rdr171Columns {
    /// The whole render into `film`, column by column, each with a fresh default-seeded
    /// sampler (spec §7) and `spp` samples a pixel; `column_done` is called after each
    /// column. Columns not started before `stopped()` are left out: returns whether
    /// none was (the columns finished are kept).
    pub fn render(
        &self,
        film: &mut Film,
        (scene, camera, settings): (&Scene, &Camera, &FilmSettings),
        spp: u32,
        stopped: &(dyn Fn() -> bool + Sync),
        column_done: &(dyn Fn() + Sync),
    ) -> bool {
        let (w, h, filter) = (settings.width as i32, settings.height as i32, &settings.filter);
        // one column of slack: a jittered position can round up into the next pixel
        let reach = filter.reach() + 1;
        let columns: Vec<Option<FilmTile>> = (0..w)
            .into_par_iter()
            .map(|px| {
                if stopped() {
                    return None;
                }
                let mut sampler = Mt19937Sampler::default();
                let mut tile = FilmTile::new(px, 0, px + 1, h, reach, w, h);
                for py in 0..h {
                    for _ in 0..spp {
                        let (u1, u2) = sampler.get_2d();
                        let pos = Vec2::new(px as f32 + u1, py as f32 + u2);
                        let l = li(scene, camera.ray(pos.x, pos.y), self.max_depth);
                        tile.add_exact(pos, l, filter, w, h);
                    }
                }
                column_done();
                Some(tile)
            })
            .collect();
        columns.iter().flatten().for_each(|t| film.merge(t));
        columns.iter().all(Option::is_some)
    }
}
