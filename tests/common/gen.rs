//! Generators of primitives and rays for the property tests.

use super::rng::Rng;
use rdr::desc::build::prim_bounds;
use rdr::geometry::aabb::Aabb;
use rdr::geometry::Ray;
use rdr::math::Vec3;
use rdr::scene::Prim;

pub fn tri(p: [Vec3; 3], index: u32) -> Prim {
    Prim::Triangle { p, object: 0, index }
}

pub fn as_prims(tris: Vec<[Vec3; 3]>) -> Vec<Prim> {
    tris.into_iter().enumerate().map(|(i, p)| tri(p, i as u32)).collect()
}

/// A random well-shaped triangle of size ~`scale` somewhere up to 100·scale from the origin.
pub fn random_triangle(rng: &mut Rng) -> ([Vec3; 3], f32) {
    loop {
        let scale = rng.log_range(1e-2, 1e3) as f32;
        let center = rng.in_cube(1.0) * scale * rng.rangef(0.0, 100.0);
        let p = [0; 3].map(|_| center + rng.in_cube(scale));
        let area2 = (p[1] - p[0]).cross(p[2] - p[0]).length();
        let longest = (p[1] - p[0]).length().max((p[2] - p[1]).length()).max((p[0] - p[2]).length());
        if area2 > 0.05 * longest * longest {
            return (p, scale);
        }
    }
}

/// Random triangles in a cube of half-size `extent`, sizes log-uniform in `sizes`.
pub fn random_soup(rng: &mut Rng, n: usize, extent: f32, sizes: (f64, f64)) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = rng.in_cube(extent);
            let s = rng.log_range(sizes.0, sizes.1) as f32;
            [c + rng.in_cube(s), c + rng.in_cube(s), c + rng.in_cube(s)]
        })
        .collect()
}

/// Rays for a scene: aimed at random primitives, random, axis-parallel, with
/// assorted `[t_min, t_max]`.
pub fn scene_rays(rng: &mut Rng, prims: &[Prim], count: usize) -> Vec<Ray> {
    let usable = |p: &&Prim| {
        let b = prim_bounds(p);
        !b.is_empty() && b.min.is_finite() && b.max.is_finite()
    };
    let prims: Vec<Prim> = prims.iter().filter(usable).copied().collect();
    let bounds = prims.iter().map(prim_bounds).fold(Aabb::EMPTY, Aabb::union);
    let (c, r) = if prims.is_empty() {
        (Vec3::ZERO, 1.0)
    } else {
        (bounds.centroid(), (bounds.extent().max_element() * 0.5).max(1e-3))
    };
    let wide = Aabb::new(c - Vec3::splat(r * 1.5), c + Vec3::splat(r * 1.5));
    let mut rays = Vec::with_capacity(count);
    while rays.len() < count {
        let target = if prims.is_empty() {
            rng.in_box(&wide)
        } else {
            match prims[rng.below(prims.len())] {
                Prim::Triangle { p, .. } => {
                    let b = rng.bary();
                    p[0] * b[0] + p[1] * b[1] + p[2] * b[2]
                }
                Prim::Sphere { sphere, .. } => sphere.center + rng.dir() * sphere.radius * rng.rangef(0.0, 1.0),
                Prim::Cylinder { cylinder, .. } => cylinder.at(rdr::math::Vec2::new(rng.rangef(0.0, 1.0), rng.rangef(0.0, 1.0))).0,
                Prim::Instance { bounds, .. } => rng.in_box(&bounds),
                p @ Prim::SdfVoxel { .. } => rng.in_box(&p.bounds()),
            }
        };
        let (o, d) = match rng.below(5) {
            // from outside the scene towards a primitive
            0 | 1 => {
                let o = c + rng.dir() * r * rng.rangef(1.2, 3.0);
                (o, target - o)
            }
            // from inside the scene towards a primitive
            2 => {
                let o = rng.in_box(&wide);
                (o, target - o)
            }
            // random
            3 => (rng.in_box(&wide), rng.dir()),
            // axis-parallel through a primitive's point: zero direction components
            _ => {
                let axis = rng.below(3);
                let mut o = target;
                o[axis] = c[axis] + rng.rangef(-3.0, 3.0) * r;
                let mut d = Vec3::ZERO;
                d[axis] = if target[axis] >= o[axis] { 1.0 } else { -1.0 };
                (o, d)
            }
        };
        if d.length().is_nan() || d.length() <= 1e-6 * r {
            continue;
        }
        let d = if rng.chance(0.7) { d.normalize() } else { d };
        let t_min = if rng.chance(0.5) { 0.0 } else { 1e-4 * r / d.length() };
        let t_max = match rng.below(3) {
            0 => f32::INFINITY,
            1 => 1e7,
            _ => rng.rangef(0.0, 4.0 * r / d.length()),
        };
        rays.push(Ray::with_range(o, d, t_min, t_max));
    }
    rays
}

/// A 4×4 scene of one white diffuse `object` (a JSON object without its material)
/// seen from (0, 0, 10), loaded from `dir` and built: for tests of a shape's hits.
pub fn one_object_scene(dir: &std::path::Path, mut object: serde_json::Value) -> rdr::scene::Scene {
    object["material_name"] = "white".into();
    let v = serde_json::json!({
        "integrator": {"type": "path", "spp": 1},
        "film": {"resolution": [4, 4]},
        "camera": {"position": [0, 0, 10], "look_at": [0, 0, 0], "ref_up": [0, 1, 0], "fov": 40},
        "textures": {"w": {"type": "constant", "color": [0.5, 0.5, 0.5]}},
        "materials": {"white": {"type": "diffuse", "texture_name": "w"}},
        "objects": [object],
    });
    let desc = rdr::desc::SceneDesc::from_value(&v, &dir.join("s.json"), dir).unwrap();
    rdr::desc::build(&desc, rdr::desc::BuildOptions::default()).unwrap()
}
