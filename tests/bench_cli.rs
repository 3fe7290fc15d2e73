//! `rdr bench MESH` end to end: it builds, checks every kernel variant against
//! the reference and prints the whole table; its options are checked.

mod common;

use std::fmt::Write as _;
use std::process::Command;

/// A UV sphere of `2·n·n` triangles as an OBJ file in a fresh temporary folder
/// (removed when the returned guard drops).
fn sphere_obj(name: &str, n: usize) -> (tempfile::TempDir, std::path::PathBuf) {
    let tmp = common::temp_dir(&format!("rdr-bench-cli-{name}"));
    let dir = tmp.path();
    let mut obj = String::new();
    for i in 0..=n {
        let theta = std::f64::consts::PI * i as f64 / n as f64;
        for j in 0..=n {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / n as f64;
            let (x, y, z) = (theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            writeln!(obj, "v {x} {y} {z}").unwrap();
        }
    }
    let v = |i: usize, j: usize| i * (n + 1) + j + 1;
    for i in 0..n {
        for j in 0..n {
            writeln!(obj, "f {} {} {}", v(i, j), v(i + 1, j), v(i + 1, j + 1)).unwrap();
            writeln!(obj, "f {} {} {}", v(i, j), v(i + 1, j + 1), v(i, j + 1)).unwrap();
        }
    }
    let path = dir.join("sphere.obj");
    std::fs::write(&path, obj).unwrap();
    (tmp, path)
}

fn bench(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_rdr"))
        .arg("bench")
        .args(args)
        .output()
        .expect("cannot run rdr");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn mesh_benchmark_checks_every_kernel_and_prints_the_table() {
    let (_tmp, mesh) = sphere_obj("full", 40);
    let (ok, out, err) = bench(&[mesh.to_str().unwrap(), "--repeat", "1", "--threads", "2"]);
    assert!(ok, "rdr bench failed: {err}");
    assert!(out.contains("triangles, loaded in"), "{out}");
    assert!(out.contains("(1 thread)") && out.contains("(2 threads)"), "{out}");
    let checks = out.lines().filter(|l| l.starts_with("check")).count();
    let agree = out
        .lines()
        .filter(|l| l.contains("closest and any hit agree with the reference"))
        .count();
    assert!(checks >= 1 && checks == agree, "{out}");
    assert!(out.contains("portable: closest and any hit agree"), "{out}");
    assert!(!out.contains("DISAGREE") && !out.contains("MISMATCH"), "{out}");
    for set in ["primary", "incoherent", "bounce"] {
        let row = out
            .lines()
            .find(|l| l.starts_with(set))
            .unwrap_or_else(|| panic!("no {set} row in\n{out}"));
        // four positive Mrays/s figures and a hit percentage
        let figures: Vec<f64> = row
            .split(|c: char| c == '|' || c.is_whitespace())
            .filter_map(|w| w.parse().ok())
            .collect();
        assert_eq!(figures.len(), 5, "{row}");
        assert!(figures[..4].iter().all(|&f| f > 0.0), "{row}");
    }
}

#[test]
fn mesh_benchmark_options() {
    let (_tmp, mesh) = sphere_obj("options", 10);
    let path = mesh.to_str().unwrap();
    // one ray set, no repeated builds or check
    let (ok, out, err) = bench(&[path, "--repeat", "1", "--threads", "1", "--rays", "bounce", "--trace-only"]);
    assert!(ok, "{err}");
    assert!(out.lines().any(|l| l.starts_with("bounce")), "{out}");
    assert!(!out.lines().any(|l| l.starts_with("primary") || l.starts_with("check")), "{out}");
    // the portable kernels can always be timed
    let (ok, out, err) = bench(&[path, "--repeat", "1", "--threads", "1", "--isa", "portable", "--rays", "primary"]);
    assert!(ok && out.contains("kernels       portable"), "{out}{err}");
    // bad values are errors that say what was wrong
    let (ok, _, err) = bench(&[path, "--rays", "sideways"]);
    assert!(!ok && err.contains("--rays") && err.contains("sideways"), "{err}");
    let (ok, _, err) = bench(&[path, "--isa", "sse9"]);
    assert!(!ok && err.contains("--isa") && err.contains("sse9"), "{err}");
}

/// Closest-hit distance of `o + t·d` against every triangle of the OBJ text (f64
/// Möller–Trumbore, brute force): the test's own oracle for `--ray-file`.
fn brute_force_t(obj: &str, o: [f64; 3], d: [f64; 3]) -> f64 {
    let v: Vec<[f64; 3]> = obj
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let x: Vec<f64> = l.split_whitespace().map(|w| w.parse().unwrap()).collect();
            [x[0], x[1], x[2]]
        })
        .collect();
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let mut best = f64::INFINITY;
    for l in obj.lines().filter_map(|l| l.strip_prefix("f ")) {
        let i: Vec<usize> = l.split_whitespace().map(|w| w.parse::<usize>().unwrap() - 1).collect();
        let (p0, p1, p2) = (v[i[0]], v[i[1]], v[i[2]]);
        let (e1, e2) = (sub(p1, p0), sub(p2, p0));
        let pv = cross(d, e2);
        let det = dot(e1, pv);
        if det.abs() < 1e-14 {
            continue;
        }
        let s = sub(o, p0);
        let u = dot(s, pv) / det;
        let q = cross(s, e1);
        let w = dot(d, q) / det;
        let t = dot(e2, q) / det;
        if u >= 0.0 && w >= 0.0 && u + w <= 1.0 && t > 0.0 {
            best = best.min(t);
        }
    }
    best
}

#[test]
fn ray_files_are_traced_and_checked_against_their_distances() {
    let (tmp, mesh) = sphere_obj("rayfile", 12);
    let obj = std::fs::read_to_string(&mesh).unwrap();
    // 400 rays from a sphere of radius 3 towards points near the centre; some miss
    let mut state = 12345u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut rays, mut ts) = (Vec::new(), Vec::new());
    for _ in 0..400 {
        let (z, phi) = (2.0 * next() - 1.0, 2.0 * std::f64::consts::PI * next());
        let r = (1.0 - z * z).sqrt();
        let o = [3.0 * r * phi.cos(), 3.0 * r * phi.sin(), 3.0 * z];
        let target = [2.4 * next() - 1.2, 2.4 * next() - 1.2, 2.4 * next() - 1.2];
        let mut d = [target[0] - o[0], target[1] - o[1], target[2] - o[2]];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        d.iter_mut().for_each(|x| *x /= len);
        // the file's values are f32; the oracle traces those exact values
        let o32 = o.map(|x| x as f32 as f64);
        let d32 = d.map(|x| x as f32 as f64);
        rays.extend(o32.iter().chain(&d32).map(|&x| x as f32));
        ts.push(brute_force_t(&obj, o32, d32) as f32);
    }
    let hits = ts.iter().filter(|t| t.is_finite()).count();
    assert!(hits > 100 && hits < 390, "{hits} of 400 rays hit: the test needs both");
    let le = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let rays_path = tmp.path().join("sphere_test.rays.f32");
    std::fs::write(&rays_path, le(&rays)).unwrap();
    std::fs::write(tmp.path().join("sphere_test.t.f32"), le(&ts)).unwrap();
    let (m, r) = (mesh.to_str().unwrap(), rays_path.to_str().unwrap());
    let (ok, out, err) = bench(&[m, "--repeat", "1", "--threads", "2", "--trace-only", "--ray-file", r]);
    assert!(ok, "{out}{err}");
    let line = out
        .lines()
        .find(|l| l.starts_with("sphere_test.rays.f32"))
        .unwrap_or_else(|| panic!("no ray-file line in\n{out}"));
    assert!(
        line.contains("1T closest") && line.contains("2T closest") && line.contains(" any "),
        "{line}"
    );
    assert!(line.contains("0 hit/miss and 0 distance"), "{line}");
    // the generated sets are not timed unless asked for
    assert!(!out.lines().any(|l| l.starts_with("primary")), "{out}");

    // distances 1 % too long: every hit disagrees, and the run fails saying so
    let wrong: Vec<f32> = ts.iter().map(|t| t * 1.01).collect();
    std::fs::write(tmp.path().join("sphere_test.t.f32"), le(&wrong)).unwrap();
    let (ok, out, err) = bench(&[m, "--repeat", "1", "--threads", "1", "--trace-only", "--ray-file", r]);
    assert!(
        !ok && out.contains(&format!("0 hit/miss and {hits} distance")) && out.contains("TOO MANY"),
        "{out}"
    );
    assert!(err.contains("disagree"), "{err}");
    // a truncated ray file is a one-line error naming it
    std::fs::write(&rays_path, &le(&rays)[..100]).unwrap();
    let (ok, _, err) = bench(&[m, "--repeat", "1", "--threads", "1", "--trace-only", "--ray-file", r]);
    assert!(
        !ok && err.contains("sphere_test.rays.f32") && err.contains("multiple of 24"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

/// `rdr bench SCENE --record-rays`: the closest-hit rays of a render and the scene's
/// triangles (the sphere tessellated) come out in the formats `--ray-file` and Embree
/// read. Inside a closed box every ray hits something, so traced again against the
/// exported triangles every one must hit (a hole in the export lets rays out).
#[test]
fn scene_rays_are_recorded_with_the_scene_triangles() {
    let tmp = common::temp_dir("rdr-bench-cli-record");
    let dir = tmp.path();
    // the closed cube [-1, 1]³: per face two triangles (winding does not matter here)
    let mut obj = String::new();
    for i in 0..8 {
        let c = |b: usize| if i >> b & 1 == 1 { 1 } else { -1 };
        writeln!(obj, "v {} {} {}", c(0), c(1), c(2)).unwrap();
    }
    for f in [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]] {
        writeln!(
            obj,
            "f {} {} {}\nf {} {} {}",
            f[0] + 1,
            f[1] + 1,
            f[2] + 1,
            f[0] + 1,
            f[2] + 1,
            f[3] + 1
        )
        .unwrap();
    }
    std::fs::write(dir.join("box.obj"), obj).unwrap();
    let scene = r#"{
        "integrator": {"type": "path", "spp": 2, "max_depth": 4},
        "film": {"resolution": [16, 16]},
        "camera": {"position": [0.1, 0.2, 0.7], "look_at": [0.0, 0.0, -1.0], "ref_up": [0.0, 1.0, 0.0], "fov": 60.0},
        "textures": {"grey": {"type": "constant", "color": [0.5, 0.5, 0.5]}},
        "materials": {"grey": {"type": "diffuse", "texture_name": "grey"}},
        "objects": [
            {"type": "mesh", "path": "box.obj", "material_name": "grey", "light": {"type": "area", "radiance": [1.0, 1.0, 1.0]}},
            {"type": "sphere", "center": [0.0, 0.0, -0.3], "radius": 0.4, "material_name": "grey"}
        ]
    }"#;
    let scene_path = dir.join("box.json");
    std::fs::write(&scene_path, scene).unwrap();
    let rays = dir.join("rec.rays.f32");
    let s = scene_path.to_str().unwrap();
    let (ok, out, err) = bench(&[s, "--threads", "1", "--record-rays", rays.to_str().unwrap()]);
    assert!(ok, "{out}{err}");
    let bytes = std::fs::read(&rays).unwrap();
    let n = bytes.len() / 24;
    assert!(n >= 512 && bytes.len().is_multiple_of(24), "{} bytes", bytes.len());
    assert!(out.contains(&format!("recorded         {n} closest-hit rays")), "{out}");
    // the first ray is a camera ray: from the camera (moved by its t_min)
    let f: Vec<f32> = bytes.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
    let o = [f[0] - 0.1, f[1] - 0.2, f[2] - 0.7];
    assert!(o.iter().map(|x| x * x).sum::<f32>().sqrt() < 1e-3, "first ray from {:?}", &f[..3]);
    let exported = std::fs::read_to_string(dir.join("rec.obj")).unwrap();
    let faces = exported.lines().filter(|l| l.starts_with("f ")).count();
    assert!(
        exported.lines().filter(|l| l.starts_with("o ")).count() == 2 && faces > 1000,
        "{faces} faces"
    );
    let (ok, out, err) = bench(&[
        dir.join("rec.obj").to_str().unwrap(),
        "--threads",
        "1",
        "--repeat",
        "1",
        "--trace-only",
        "--ray-file",
        rays.to_str().unwrap(),
    ]);
    assert!(ok, "{out}{err}");
    assert!(out.contains(&format!("{n} rays, hit 100.0 %")), "{out}");
    // the output's name is checked before the render
    let (ok, _, err) = bench(&[s, "--threads", "1", "--record-rays", dir.join("rec.bin").to_str().unwrap()]);
    assert!(!ok && err.contains("rec.bin") && err.contains(".rays.f32"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

/// `rdr bench FOLDER`: every `FOLDER/*/bench.xml` in name order (folders without one
/// skipped), each at its own spp, then a summary line per scene; a folder holding none
/// is a one-line error naming it.
#[test]
fn a_folder_benchmarks_each_bench_xml_in_it() {
    let tmp = common::temp_dir("rdr-bench-cli-folder");
    let dir = tmp.path();
    let xml = |spp: u32| {
        format!(
            r#"<scene version="3.0.0">
    <integrator type="path"/>
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>
        <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/></film>
    </sensor>
    <shape type="sphere"><bsdf type="diffuse"/></shape>
    <emitter type="constant"/>
</scene>"#
        )
    };
    for (name, spp) in [("b-second", 6), ("a-first", 4)] {
        std::fs::create_dir(dir.join(name)).unwrap();
        std::fs::write(dir.join(name).join("bench.xml"), xml(spp)).unwrap();
    }
    std::fs::create_dir(dir.join("c-none")).unwrap();
    std::fs::write(dir.join("c-none").join("scene.xml"), xml(1)).unwrap();
    let (ok, out, err) = bench(&[dir.to_str().unwrap(), "--threads", "1"]);
    assert!(ok, "{out}{err}");
    assert_eq!(out.matches("render           64x48 at").count(), 2, "{out}");
    let summary: Vec<Vec<&str>> = out
        .lines()
        .skip_while(|l| !l.starts_with("scene ") || !l.contains("samples per cpu s"))
        .skip(1)
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert_eq!(summary.len(), 2, "{out}");
    for (row, (name, spp)) in summary.iter().zip([("a-first", "4"), ("b-second", "6")]) {
        assert_eq!((row[0], row[1]), (name, spp), "{out}");
        let rate: f64 = row[3].parse().unwrap();
        assert!(rate > 0.0 && rate.is_finite(), "{out}");
    }
    let (ok, _, err) = bench(&[dir.join("c-none").to_str().unwrap()]);
    assert!(!ok && err.contains("c-none") && err.contains("bench.xml"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}
