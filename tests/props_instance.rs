//! Instancing against the flattened scene: 50 instances of a small mesh (random
//! rotations, non-uniform and mirroring scales, translations) through
//! `shapegroups` and `instance` objects, and the same 50 placements as plain mesh
//! objects with the instance's `transform`. Closest hits agree (same instance and
//! triangle, `t` within 1e-5 relative: of `t`, or of the hit's coordinates when
//! larger, for short rays from inside the scene), shadow rays agree, and the surface points
//! (position, geometric and shading normals, uv, ∂p/∂u) agree, with every
//! instruction set; rays that graze an edge (a barycentric below 1e-4 on either
//! side) or, for the distance, the surface (|cos| < 0.02 on the same triangle) are
//! left aside and counted.

mod common;

use common::Rng;
use rdr::accel::wide::Isa;
use rdr::desc::{build, BuildOptions, SceneDesc};
use rdr::geometry::Ray;
use rdr::math::{Mat4, Vec3};
use rdr::scene::{Prim, Scene};
use serde_json::{json, Value};
use std::fmt::Write;
use std::path::Path;

/// A lumpy UV sphere (rings × segments quads as triangles) with uvs and smooth normals.
fn small_mesh_obj() -> String {
    let (rings, segs) = (5, 8);
    let mut s = String::new();
    let pos = |i: usize, j: usize| {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        let ph = 2.0 * std::f32::consts::PI * j as f32 / segs as f32;
        let r = 1.0 + 0.2 * ((3 * j + i) as f32).sin();
        Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()) * r
    };
    for i in 0..=rings {
        for j in 0..=segs {
            let p = pos(i, j);
            let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
            let _ = writeln!(s, "vt {} {}", j as f32 / segs as f32, i as f32 / rings as f32);
            let n = p.normalize();
            let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
        }
    }
    let id = |i: usize, j: usize| i * (segs + 1) + j + 1;
    for i in 0..rings {
        for j in 0..segs {
            let (a, b, c, d) = (id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j));
            if i > 0 {
                let _ = writeln!(s, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}");
            }
            if i + 1 < rings {
                let _ = writeln!(s, "f {a}/{a}/{a} {c}/{c}/{c} {d}/{d}/{d}");
            }
        }
    }
    s
}

fn random_transform(rng: &mut Rng) -> Mat4 {
    let axis = rng.dir();
    let rot = Mat4::from_axis_angle(axis, rng.rangef(0.0, std::f32::consts::TAU));
    let mut scale = Vec3::new(rng.rangef(0.4, 1.5), rng.rangef(0.4, 1.5), rng.rangef(0.4, 1.5));
    if rng.chance(0.25) {
        scale.x = -scale.x; // mirrored
    }
    let t = rng.in_cube(8.0);
    Mat4::from_translation(t) * rot * Mat4::from_scale(scale)
}

fn row_major(m: &Mat4) -> Value {
    Value::Array(m.transpose().to_cols_array().iter().map(|&x| json!(x)).collect())
}

fn scene_json(transforms: &[Mat4], instanced: bool) -> Value {
    let mut objects: Vec<Value> = Vec::new();
    for m in transforms {
        objects.push(if instanced {
            json!({"type": "instance", "shapegroup": "lumps", "transform": row_major(m)})
        } else {
            json!({"type": "mesh", "path": "lumps.obj", "transform": row_major(m), "material_name": "white"})
        });
    }
    let mut v = json!({
        "integrator": {"type": "path", "spp": 1},
        "film": {"resolution": [8, 8]},
        "camera": {"position": [0, 0, 30], "look_at": [0, 0, 0], "ref_up": [0, 1, 0], "fov": 40},
        "textures": {"w": {"type": "constant", "color": [0.5, 0.5, 0.5]}},
        "materials": {"white": {"type": "diffuse", "texture_name": "w"}},
        "objects": objects,
    });
    if instanced {
        v["shapegroups"] = json!({"lumps": {"objects": [{"type": "mesh", "path": "lumps.obj", "material_name": "white"}]}});
    }
    v
}

/// (instance or object, triangle) of a hit, and its smallest barycentric.
fn key(scene: &Scene, prim: u32, sub: u32, b: [f32; 3]) -> (u32, u32, f32) {
    let bmin = b[0].min(b[1]).min(b[2]);
    match &scene.prims[prim as usize] {
        Prim::Instance { instance, .. } => {
            let g = &scene.groups[scene.instances[*instance as usize].group as usize];
            match g.prims[sub as usize] {
                Prim::Triangle { index, .. } => (*instance, index, bmin),
                _ => unreachable!(),
            }
        }
        Prim::Triangle { object, index, .. } => (*object, *index, bmin),
        _ => unreachable!(),
    }
}

fn load(dir: &Path, v: &Value) -> Scene {
    let file = dir.join("scene.json");
    let desc = SceneDesc::from_value(v, &file, dir).unwrap_or_else(|e| panic!("{e}"));
    let mut scene = build(&desc, BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    // the test compares uv and tangents, which a scene without textures does not compute
    scene.texture_coords = true;
    scene
}

#[test]
fn instances_agree_with_the_flattened_scene() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("lumps.obj"), small_mesh_obj()).unwrap();
    let mut rng = Rng::new(17);
    let transforms: Vec<Mat4> = (0..50).map(|_| random_transform(&mut rng)).collect();
    let mut inst = load(dir.path(), &scene_json(&transforms, true));
    let mut flat = load(dir.path(), &scene_json(&transforms, false));
    assert_eq!(inst.instances.len(), 50);
    assert_eq!(inst.groups.len(), 1);
    assert_eq!(inst.prims.len(), 50, "one top-level entry per instance");
    let tris = inst.groups[0].prims.len();
    assert_eq!(flat.prims.len(), 50 * tris);

    // rays from around the scene towards random points of random placed triangles
    // and in random directions from inside it
    let b = flat.bvh.bounds();
    let (c, r) = (b.centroid(), b.extent().length() * 0.5);
    let mut rays = Vec::new();
    for k in 0..4000 {
        let target = match flat.prims[rng.below(flat.prims.len())] {
            Prim::Triangle { p, .. } => {
                let w = rng.bary();
                p[0] * w[0] + p[1] * w[1] + p[2] * w[2]
            }
            _ => unreachable!(),
        };
        let o = if k % 4 == 3 {
            rng.in_box(&b)
        } else {
            c + rng.dir() * r * rng.rangef(1.1, 2.0)
        };
        let d = if k % 8 == 7 { rng.dir() } else { (target - o).normalize() };
        rays.push(Ray::new(o, d));
    }

    for isa in Isa::all_available() {
        assert!(inst.bvh.set_isa(isa) && flat.bvh.set_isa(isa));
        for g in &mut inst.groups {
            assert!(g.bvh.set_isa(isa));
        }
        let (mut hits, mut grazing) = (0, 0);
        for (k, ray) in rays.iter().enumerate() {
            let (hi, hf) = (inst.intersect(ray), flat.intersect(ray));
            assert_eq!(
                inst.occluded(ray),
                hi.is_some(),
                "{isa:?} ray {k}: occluded disagrees with intersect"
            );
            assert_eq!(flat.occluded(ray), hf.is_some());
            match (hi, hf) {
                (None, None) => {}
                (Some(a), Some(f)) => {
                    let (ka, kf) = (key(&inst, a.prim, a.sub, a.b), key(&flat, f.prim, f.sub, f.b));
                    // a ray grazing the surface (|cos| < 0.02) has its t moved by the
                    // rounding of the vertices' or the ray's transform over 1/|cos|
                    let cos = flat.interaction(ray, &f).ng.dot(ray.d).abs();
                    // relative to t, or for short rays from inside the scene to the
                    // hit's distance from the origin (coordinates round there)
                    let scale = f.t.max(ray.at(f.t).abs().max_element());
                    if (ka.0, ka.1) != (kf.0, kf.1) || (a.t - f.t).abs() > 1e-5 * scale {
                        if ka.2 < 1e-4 || kf.2 < 1e-4 || ((ka.0, ka.1) == (kf.0, kf.1) && cos < 0.02) {
                            grazing += 1;
                            continue;
                        }
                        panic!(
                            "{isa:?} ray {k} {ray:?}: instanced hit {ka:?} at t = {}, flattened {kf:?} at t = {}",
                            a.t, f.t
                        );
                    }
                    hits += 1;
                    let (ia, ifl) = (inst.interaction(ray, &a), flat.interaction(ray, &f));
                    let tol = 1e-4 * (1.0 + ifl.p.abs().max_element());
                    assert!((ia.p - ifl.p).length() < tol, "ray {k}: p {} vs {}", ia.p, ifl.p);
                    assert!(ia.ng.dot(ifl.ng) > 0.9999, "ray {k}: ng {} vs {}", ia.ng, ifl.ng);
                    assert!(ia.ns.dot(ifl.ns) > 0.9999, "ray {k}: ns {} vs {}", ia.ns, ifl.ns);
                    assert!((ia.uv - ifl.uv).length() < 1e-4, "ray {k}: uv {} vs {}", ia.uv, ifl.uv);
                    assert!(
                        (ia.dpdu - ifl.dpdu).length() < 1e-3 * (1.0 + ifl.dpdu.length()),
                        "ray {k}: dpdu {} vs {}",
                        ia.dpdu,
                        ifl.dpdu
                    );
                    assert_eq!(ia.object, 0);
                    assert!(inst.material_of(&ia).is_some());
                }
                (a, f) => {
                    let bmin = |h: Option<rdr::scene::Hit>, s: &Scene| h.map(|h| key(s, h.prim, h.sub, h.b).2);
                    if bmin(a, &inst).or(bmin(f, &flat)).is_some_and(|m| m < 1e-4) {
                        grazing += 1;
                        continue;
                    }
                    panic!("{isa:?} ray {k} {ray:?}: instanced {a:?}, flattened {f:?}");
                }
            }
        }
        eprintln!("{isa:?}: {hits} hits agree, {grazing} grazing rays left aside of {}", rays.len());
        assert!(hits > rays.len() / 2, "too few hits: {hits}");
        assert!(grazing * 100 < rays.len(), "too many grazing rays: {grazing}");
    }
}
