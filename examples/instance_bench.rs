//! Build and traversal figures of the two-level BVH (`docs/dev/acceleration.md`, "Instancing").
//!
//! `cargo run --release --example instance_bench -- MESH.obj [N]`: the mesh as one
//! plain object, as one instance (the two-level path's overhead), as N instances on a
//! grid and (for N ≤ 64) the same N placements flattened into plain meshes. Prints
//! the BVH build time, the acceleration structure's bytes and, on one thread,
//! closest-hit and any-hit Mrays/s for rays from a sphere around the scene towards
//! random points in its box (the same rays for each variant of one scene).

use rdr::desc::{build, BuildOptions, SceneDesc};
use rdr::geometry::Ray;
use rdr::math::Vec3;
use rdr::scene::Scene;
use serde_json::{json, Value};
use std::path::Path;
use std::time::Instant;

fn scene_json(mesh: &str, n: usize, instanced: bool, spacing: f32) -> Value {
    let side = (n as f32).sqrt().ceil() as usize;
    let mut objects = Vec::new();
    for i in 0..n {
        let t = [(i % side) as f32 * spacing, (i / side) as f32 * spacing, 0.0];
        objects.push(if instanced {
            json!({"type": "instance", "shapegroup": "m", "translate": t})
        } else {
            json!({"type": "mesh", "path": mesh, "translate": t, "material_name": "w"})
        });
    }
    let mut v = json!({
        "integrator": {"type": "path", "spp": 1},
        "film": {"resolution": [8, 8]},
        "camera": {"position": [0, 0, 10], "look_at": [0, 0, 0], "ref_up": [0, 1, 0], "fov": 40},
        "textures": {"w": {"type": "constant", "color": [0.5, 0.5, 0.5]}},
        "materials": {"w": {"type": "diffuse", "texture_name": "w"}},
        "objects": objects,
    });
    if instanced {
        v["shapegroups"] = json!({"m": {"objects": [{"type": "mesh", "path": mesh, "material_name": "w"}]}});
    }
    v
}

fn load(v: &Value) -> (Scene, f64) {
    let desc = SceneDesc::from_value(v, Path::new("bench.json"), Path::new(".")).unwrap_or_else(|e| panic!("{e}"));
    let t = Instant::now();
    let s = build(&desc, BuildOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let total = t.elapsed().as_secs_f64();
    (s, total)
}

fn rays(scene: &Scene, n: usize) -> Vec<Ray> {
    let b = scene.bvh.bounds();
    let (c, r) = (b.centroid(), b.extent().length() * 0.5);
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut u = move || {
        s = s.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let d = Vec3::new(u() * 2.0 - 1.0, u() * 2.0 - 1.0, u() * 2.0 - 1.0).normalize();
            let o = c + d * r * 1.5;
            let t = b.min + b.extent() * Vec3::new(u(), u(), u());
            Ray::new(o, (t - o).normalize())
        })
        .collect()
}

fn bytes(s: &Scene) -> usize {
    s.bvh.memory_bytes()
        + s.prims.len() * std::mem::size_of::<rdr::scene::Prim>()
        + s.instances.len() * std::mem::size_of::<rdr::accel::instance::Instance>()
        + s.groups.iter().map(|g| g.memory_bytes()).sum::<usize>()
}

fn time(scene: &Scene, rays: &[Ray]) -> (f64, f64, f64) {
    let mut best = (0.0f64, 0.0f64);
    let mut hits = 0;
    for _ in 0..3 {
        let t = Instant::now();
        hits = rays.iter().filter(|r| scene.intersect(r).is_some()).count();
        let c = rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6;
        let t = Instant::now();
        let a = rays.iter().filter(|r| scene.occluded(r)).count();
        let o = rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6;
        assert_eq!(a, hits);
        best = (best.0.max(c), best.1.max(o));
    }
    (best.0, best.1, hits as f64 / rays.len() as f64)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mesh = std::fs::canonicalize(args.get(1).expect("usage: instance_bench MESH.obj [N]")).unwrap();
    let mesh = mesh.to_str().unwrap();
    let n: usize = args.get(2).map_or(10_000, |a| a.parse().unwrap());
    let n_rays = 200_000;
    rayon::ThreadPoolBuilder::new().num_threads(1).build_global().ok();
    let report = |label: &str, s: &Scene, total: f64, rays: &[Ray]| {
        let (c, a, h) = time(s, rays);
        println!(
            "{label:<28} build {:>8.1} ms (BVHs {:>7.1} ms)  {:>9.2} MB  closest {c:>6.2} / any {a:>6.2} Mrays/s  hit {:.0} %",
            total * 1e3,
            s.bvh_seconds * 1e3,
            bytes(s) as f64 / 1e6,
            h * 100.0
        );
    };
    let (one, t1) = load(&scene_json(mesh, 1, false, 1.0));
    let spacing = one.bvh.bounds().extent().max_element() * 1.1;
    let r = rays(&one, n_rays);
    report("1 mesh (one level)", &one, t1, &r);
    let (inst1, ti) = load(&scene_json(mesh, 1, true, spacing));
    report("1 instance (two levels)", &inst1, ti, &r);
    for k in [16usize, n] {
        let (many, tm) = load(&scene_json(mesh, k, true, spacing));
        let r = rays(&many, n_rays);
        report(&format!("{k} instances"), &many, tm, &r);
        if k <= 64 {
            let (flat, tf) = load(&scene_json(mesh, k, false, spacing));
            report(&format!("{k} meshes (flattened)"), &flat, tf, &r);
        }
    }
}
