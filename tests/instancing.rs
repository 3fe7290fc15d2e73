//! Instancing end to end: 10,000 instances of the bunny render with a peak
//! resident memory below twice that of one bunny with the same film (both measured
//! on a child `rdr render` process), and the instanced picture is the flattened
//! one's where both can be made.

mod common;

use serde_json::{json, Value};
use std::path::Path;
use std::process::Command;

/// A 32×32, 1 spp scene: the bunny once, or `n` instances of it in a grid.
fn bunny_scene(bunny: &Path, instances: Option<usize>) -> Value {
    let mut objects = vec![json!({"type": "sphere", "center": [0, 6, 0], "radius": 1, "light": {"radiance": [5, 5, 5]}})];
    let mut v = json!({
        "integrator": {"type": "path", "spp": 1, "max_depth": 3},
        "film": {"resolution": [32, 32]},
        "camera": {"position": [0, 0, 40], "look_at": [0, 0, 0], "ref_up": [0, 1, 0], "fov": 40},
        "textures": {"w": {"type": "constant", "color": [0.7, 0.7, 0.7]}},
        "materials": {"white": {"type": "diffuse", "texture_name": "w"}},
    });
    let mesh = json!({"type": "mesh", "path": bunny.to_str().unwrap(), "material_name": "white"});
    match instances {
        None => objects.push(mesh),
        Some(n) => {
            v["shapegroups"] = json!({"bunny": {"objects": [mesh]}});
            for i in 0..n {
                let (x, y) = ((i % 100) as f32 * 0.25 - 12.5, (i / 100) as f32 * 0.25 - 12.5);
                objects.push(json!({"type": "instance", "shapegroup": "bunny", "translate": [x, y, 0]}));
            }
        }
    }
    v["objects"] = Value::Array(objects);
    v
}

/// Peak resident set (KiB) of `rdr render SCENE` run as a child, from `wait4`.
fn peak_rss_kib(scene: &Path, out: &Path) -> i64 {
    let child = Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["render", scene.to_str().unwrap(), "--threads", "2", "--spp", "1", "-q", "-o"])
        .arg(out)
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: `rusage` is plain data that wait4 fills in; `status` and `usage` are
    // valid for writes for the duration of the call, and `pid` is our own child,
    // which `child` never waits for (it is forgotten after this).
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    std::mem::forget(child);
    assert_eq!(r, pid, "wait4 failed");
    assert!(
        libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        "rdr render failed: {status}"
    );
    usage.ru_maxrss
}

#[test]
fn ten_thousand_bunnies_cost_less_than_two_bunnies() {
    let Some(shared) = common::shared() else { return };
    let bunny = shared.join("meshes/bunny.obj");
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("one.json");
    let many = dir.path().join("many.json");
    std::fs::write(&one, bunny_scene(&bunny, None).to_string()).unwrap();
    std::fs::write(&many, bunny_scene(&bunny, Some(10_000)).to_string()).unwrap();
    let t = std::time::Instant::now();
    let a = peak_rss_kib(&one, &dir.path().join("one.exr"));
    let b = peak_rss_kib(&many, &dir.path().join("many.exr"));
    eprintln!(
        "peak RSS: one bunny {a} KiB, 10,000 instances {b} KiB ({:.2}x), {:.1} s",
        b as f64 / a as f64,
        t.elapsed().as_secs_f64()
    );
    assert!(b < 2 * a, "10,000 instances take {b} KiB, one bunny {a} KiB");
    // the instances were rendered: the picture is not empty
    let img = rdr::imageio::read_exr(&dir.path().join("many.exr")).unwrap();
    assert!(img.pixels.iter().any(|p| p.max_element() > 0.0));
}

/// An octahedron with texture coordinates.
const OCTA: &str = "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\nvt 0 0\nvt 1 0\nvt 0.5 1\n\
f 1/1 3/2 5/3\nf 3/1 2/2 5/3\nf 2/1 4/2 5/3\nf 4/1 1/2 5/3\nf 3/1 1/2 6/3\nf 2/1 3/2 6/3\nf 4/1 2/2 6/3\nf 1/1 4/2 6/3\n";

/// Nine octahedra on a floor under a spherical light, as instances or as meshes,
/// rendered by `integrator`.
fn octa_scene(integrator: &str, instanced: bool) -> Value {
    let mut objects = vec![
        json!({"type": "sphere", "center": [0, 4, 2], "radius": 0.7, "light": {"radiance": [8, 8, 8]}}),
        json!({"type": "sphere", "center": [0, -101, 0], "radius": 100, "material_name": "white"}),
    ];
    for i in 0..9 {
        let m = [
            0.6,
            0.0,
            0.2,
            (i % 3) as f32 * 1.6 - 1.6,
            0.0,
            0.8,
            0.0,
            0.0,
            -0.1,
            0.0,
            0.5,
            (i / 3) as f32 * 1.6 - 1.6,
            0.0,
            0.0,
            0.0,
            1.0,
        ];
        objects.push(if instanced {
            json!({"type": "instance", "shapegroup": "octa", "transform": m})
        } else {
            json!({"type": "mesh", "path": "octa.obj", "transform": m, "material_name": "check"})
        });
    }
    let mut v = json!({
        "integrator": {"type": integrator, "spp": 4},
        "film": {"resolution": [24, 24]},
        "camera": {"position": [0, 3, 6], "look_at": [0, 0, 0], "ref_up": [0, 1, 0], "fov": 45},
        "textures": {"w": {"type": "constant", "color": [0.7, 0.7, 0.7]},
                     "c": {"type": "checkerboard", "color0": [0.9, 0.2, 0.1], "color1": [0.1, 0.3, 0.9],
                           "tex_coordinate_generator": {"type": "uvmapping2d", "scale": [4, 4]}}},
        "materials": {"white": {"type": "diffuse", "texture_name": "w"}, "check": {"type": "diffuse", "texture_name": "c"}},
        "objects": objects,
    });
    if instanced {
        v["shapegroups"] = json!({"octa": {"objects": [{"type": "mesh", "path": "octa.obj", "material_name": "check"}]}});
    }
    v
}

/// Every integrator sees instanced geometry as it sees the same triangles placed as
/// meshes (camera rays, shadow rays, light paths, photons; uv and normals through
/// the checkerboard and the shading): the two images agree (the same samples, so
/// equal up to the few paths the transforms' rounding sends elsewhere).
#[test]
fn every_integrator_renders_instances_as_the_flattened_scene() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("octa.obj"), OCTA).unwrap();
    let mut bad = Vec::new();
    for integrator in [
        "path",
        "bdpt",
        "guided",
        "ptracer",
        "intersection_test",
        "photon",
        "sppm",
        "normals",
    ] {
        let mut images = Vec::new();
        for instanced in [true, false] {
            let file = dir.path().join(format!("{integrator}_{instanced}.json"));
            std::fs::write(&file, octa_scene(integrator, instanced).to_string()).unwrap();
            let loaded = common::load_scene(&file, &[], rdr::Profile::Physical);
            images.push(common::render(&loaded, 4, 3));
        }
        let (a, b) = (&images[0], &images[1]);
        let mean = |img: &rdr::metrics::Image| img.pixels.iter().map(|p| p.element_sum()).sum::<f32>() / img.pixels.len() as f32;
        let differing = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .filter(|(p, q)| (**p - **q).abs().max_element() > 1e-3 * (1.0 + q.max_element()))
            .count();
        eprintln!(
            "{integrator:>18}: mean {:.4} instanced, {:.4} flattened, {differing} of {} pixels differ",
            mean(a),
            mean(b),
            a.pixels.len()
        );
        if (mean(a) - mean(b)).abs() > 0.02 * mean(b) || differing * 10 > a.pixels.len() || mean(b) <= 0.0 {
            bad.push(integrator);
        }
    }
    assert!(bad.is_empty(), "instanced and flattened images differ for {bad:?}");
}

/// The XML reader's `shapegroup`/`instance` and `rdr convert` both ways: the XML
/// scene, its JSON conversion and that converted back hit the same instance and
/// triangle at the same distance.
#[test]
fn xml_instances_convert_both_ways() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("octa.obj"), OCTA).unwrap();
    let xml = r#"<scene version="3.0.0">
  <sensor type="perspective"><transform name="to_world"><lookat origin="0, 3, 6" target="0, 0, 0" up="0, 1, 0"/></transform></sensor>
  <shape type="shapegroup" id="g">
    <shape type="obj"><string name="filename" value="octa.obj"/><bsdf type="diffuse"/></shape>
    <shape type="cylinder"><float name="radius" value="0.3"/><bsdf type="diffuse"/></shape>
  </shape>
  <shape type="instance"><ref id="g"/><transform name="to_world"><scale x="0.5" y="1" z="0.7"/><translate x="-1"/></transform></shape>
  <shape type="instance"><ref id="g"/><transform name="to_world"><rotate y="1" angle="30"/><translate x="1"/></transform></shape>
</scene>
"#;
    std::fs::write(d.join("s.xml"), xml).unwrap();
    let convert = |from: &str, to: &str| {
        let out = Command::new(env!("CARGO_BIN_EXE_rdr"))
            .args(["convert", d.join(from).to_str().unwrap(), "-o", d.join(to).to_str().unwrap(), "-q"])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    };
    convert("s.xml", "s.json");
    convert("s.json", "back.xml");
    let scenes: Vec<rdr::Scene> = ["s.xml", "s.json", "back.xml"]
        .iter()
        .map(|f| common::load_scene(&d.join(f), &[], rdr::Profile::Physical).scene)
        .collect();
    for s in &scenes {
        assert_eq!((s.instances.len(), s.groups.len()), (2, 1));
    }
    let mut hits = 0;
    for i in 0..400 {
        let (x, y) = ((i % 20) as f32 / 10.0 - 1.0, (i / 20) as f32 / 10.0 - 1.0);
        let ray = rdr::geometry::Ray::new(rdr::math::Vec3::new(x * 2.0, y * 1.5, 5.0), -rdr::math::Vec3::Z);
        let h: Vec<_> = scenes.iter().map(|s| s.intersect(&ray).map(|h| (h.prim, h.sub, h.t))).collect();
        assert_eq!(h[0], h[1], "ray {i}");
        assert_eq!(h[0], h[2], "ray {i}");
        hits += h[0].is_some() as usize;
    }
    assert!(hits > 40, "{hits}");
}
