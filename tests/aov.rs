//! `--aov albedo,normal,depth,position` against analytic values: a diffuse sphere
//! seen directly, and the same sphere seen in a perfect mirror (the features must come
//! from the first non-specular hit: the sphere, not the mirror, except depth and
//! position, which are the first hit's). Per pixel, only where the camera rays through
//! the pixel's centre and four corners all hit the sphere, so the pixel average is
//! close to the value at its centre (tolerances cover the curvature over a pixel).
//! Plus: the image is unchanged by `--aov`, and the refusals.

mod common;

use rdr::imageio::{read_exr_channels, ChannelData};
use std::path::Path;
use std::process::Command;

const W: usize = 40;
const H: usize = 30;
const FOV_DEG: f64 = 30.0;
const ALBEDO: [f64; 3] = [0.2, 0.45, 0.7];
const CAMERA_Z: f64 = 4.0;

type V = [f64; 3];

fn sub(a: V, b: V) -> V {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V, b: V) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn norm(a: V) -> V {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

/// The camera ray's direction through film position (`px`, `py`), `py` counted from
/// the top: camera at (0, 0, 4) looking down −z, `ref_up` +y, vertical fov.
fn direction(px: f64, py: f64) -> V {
    let t = (FOV_DEG.to_radians() / 2.0).tan();
    let aspect = W as f64 / H as f64;
    let sx = (2.0 * px / W as f64 - 1.0) * t * aspect;
    let sy = (1.0 - 2.0 * py / H as f64) * t;
    norm([sx, sy, -1.0])
}

/// Distance along the unit ray `o + t·d` to the sphere (centre `c`, radius 1).
fn hit_sphere(o: V, d: V, c: V) -> Option<f64> {
    let oc = sub(o, c);
    let b = dot(oc, d);
    let disc = b * b - (dot(oc, oc) - 1.0);
    (disc > 0.0).then(|| -b - disc.sqrt()).filter(|t| *t > 0.0)
}

fn scene_json(dir: &Path, mirror: bool) -> std::path::PathBuf {
    // the mirror: a quad in the plane z = -3 facing the camera; the sphere then sits
    // behind the camera (z = 6), seen only in the mirror
    let quad = dir.join("mirror.obj");
    std::fs::write(&quad, "v -40 -40 -3\nv 40 -40 -3\nv 40 40 -3\nv -40 40 -3\nf 1 2 3\nf 1 3 4\n").unwrap();
    let (centre, extra) = if mirror {
        (
            "[0, 0, 6]",
            r#", {"type": "mesh", "path": "mirror.obj", "material_name": "mirror"}"#,
        )
    } else {
        ("[0, 0, 0]", "")
    };
    let text = format!(
        r#"{{
  "integrator": {{"type": "path", "spp": 16, "max_depth": 3,
                  "lights": [{{"type": "point", "position": [0, 3, 3], "flux": [10, 10, 10]}}]}},
  "film": {{"resolution": [{W}, {H}]}},
  "camera": {{"position": [0, 0, {CAMERA_Z}], "look_at": [0, 0, 0], "ref_up": [0, 1, 0], "fov": {FOV_DEG}}},
  "textures": {{"ball": {{"type": "constant", "color": [{}, {}, {}]}}}},
  "materials": {{"ball": {{"type": "diffuse", "texture_name": "ball"}},
                 "mirror": {{"type": "conductor"}}}},
  "objects": [{{"type": "sphere", "center": {centre}, "radius": 1, "material_name": "ball"}}{extra}]
}}"#,
        ALBEDO[0], ALBEDO[1], ALBEDO[2]
    );
    let path = dir.join(if mirror { "mirror.json" } else { "ball.json" });
    std::fs::write(&path, text).unwrap();
    path
}

fn render(scene: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_rdr"))
        .arg("render")
        .arg(scene)
        .args(extra)
        .args(["-q", "-o"])
        .arg(out)
        .output()
        .unwrap()
}

fn channel(exr: &rdr::imageio::RawExr, name: &str) -> Vec<f32> {
    let c = exr
        .channels
        .iter()
        .find(|c| c.name == name)
        .unwrap_or_else(|| panic!("no channel {name}"));
    match &c.data {
        ChannelData::F32(v) => v.clone(),
        _ => panic!("{name} is not float"),
    }
}

/// Checks every fully covered pixel; returns how many there were.
fn check(exr: &rdr::imageio::RawExr, mirror: bool) -> usize {
    let get = |n: &str| channel(exr, n);
    let (ar, ag, ab) = (get("albedo.R"), get("albedo.G"), get("albedo.B"));
    let (nx, ny, nz) = (get("normal.X"), get("normal.Y"), get("normal.Z"));
    let (px, py, pz) = (get("position.X"), get("position.Y"), get("position.Z"));
    let depth = get("depth.Z");
    let o = [0.0, 0.0, CAMERA_Z];
    // seen in the mirror z = -3, the sphere at z = 6 is a sphere at z = -12 along the
    // unfolded ray; its real normal has z flipped back
    let c = if mirror { [0.0, 0.0, -12.0] } else { [0.0, 0.0, 0.0] };
    let mut covered = 0;
    for j in 0..H {
        for i in 0..W {
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)];
            let hits: Vec<Option<f64>> = corners
                .iter()
                .map(|&(u, v)| hit_sphere(o, direction(i as f64 + u, j as f64 + v), c))
                .collect();
            if hits.iter().any(Option::is_none) {
                continue;
            }
            covered += 1;
            let d = direction(i as f64 + 0.5, j as f64 + 0.5);
            let t = hits[4].unwrap();
            let p = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
            let mut n = sub(p, c);
            let (first_t, first_p) = if mirror {
                n[2] = -n[2];
                let tm = (o[2] + 3.0) / -d[2];
                (tm, [o[0] + tm * d[0], o[1] + tm * d[1], -3.0])
            } else {
                (t, p)
            };
            let k = j * W + i;
            let at = format!("pixel ({i}, {j}), {}", if mirror { "mirror" } else { "direct" });
            // a diffuse surface's albedo is exact in every sample
            for (got, want) in [(ar[k], ALBEDO[0]), (ag[k], ALBEDO[1]), (ab[k], ALBEDO[2])] {
                assert!((got as f64 - want).abs() < 1e-4, "{at}: albedo {got} not {want}");
            }
            for (got, want) in [(nx[k], n[0]), (ny[k], n[1]), (nz[k], n[2])] {
                assert!((got as f64 - want).abs() < 0.03, "{at}: normal {got} not {want:.4}");
            }
            assert!(
                (depth[k] as f64 - first_t).abs() < 0.01 * first_t,
                "{at}: depth {} not {first_t:.4}",
                depth[k]
            );
            for (got, want) in [(px[k], first_p[0]), (py[k], first_p[1]), (pz[k], first_p[2])] {
                assert!((got as f64 - want).abs() < 0.03, "{at}: position {got} not {want:.4}");
            }
        }
    }
    covered
}

#[test]
fn aov_layers_match_the_analytic_sphere_directly_and_through_a_mirror() {
    let dir = tempfile::tempdir().unwrap();
    for mirror in [false, true] {
        let scene = scene_json(dir.path(), mirror);
        let out = dir.path().join("aov.exr");
        let o = render(&scene, &out, &["--aov", "albedo,normal,depth,position"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let exr = read_exr_channels(&out).unwrap();
        let covered = check(&exr, mirror);
        let least = if mirror { 20 } else { 200 };
        assert!(covered >= least, "only {covered} pixels fully on the sphere");
        eprintln!("mirror {mirror}: {covered} pixels checked");
        // the image itself does not change with --aov
        let plain = dir.path().join("plain.exr");
        let o = render(&scene, &plain, &[]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let plain = read_exr_channels(&plain).unwrap();
        for c in ["R", "G", "B"] {
            assert_eq!(channel(&exr, c), channel(&plain, c), "channel {c} changed with --aov");
        }
    }
}

#[test]
fn aov_refusals_are_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_json(dir.path(), false);
    let cases: [(&[&str], &str, &str); 4] = [
        (&["--aov", "albedo,shadow"], "aov.exr", "unknown AOV 'shadow'"),
        (&["--aov", "albedo"], "aov.png", "needs an .exr output"),
        (
            &["--aov", "normal", "--override", r#"{"integrator":{"type":"guided"}}"#],
            "aov.exr",
            "the guided integrator does not make feature buffers",
        ),
        (&["--aov", "depth", "--resume"], "aov.exr", "not with --resume or --shard"),
    ];
    for (args, out, want) in cases {
        let o = render(&scene, &dir.path().join(out), args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(want) && err.lines().count() == 1, "{args:?}: {err}");
    }
}
