//! Mitsuba's analytic `cylinder`: intersection and surface points against a finely
//! triangulated cylinder (random cylinders and rays; uv and the frame written out
//! here from Mitsuba's definition, not from rdr's), and a small scene (an
//! image-textured cylinder, an emitting one, one with `flip_normals`) converging to
//! Mitsuba 3's image of it (`tests/refs/shapes/`, made by
//! `scripts/make_cylinder_refs.py`), read from its XML and from the JSON `rdr convert`
//! writes of it.

mod common;

use common::*;
use rdr::accel::wide::WideBvh;
use rdr::geometry::Ray;
use rdr::math::{Vec2, Vec3};
use rdr::metrics::compare;
use rdr::scene::Prim;
use rdr::Profile;
use serde_json::json;
use std::f32::consts::PI;
use std::path::Path;

/// Mitsuba's `coordinate_system` (Duff et al.), spelt out independently of rdr's.
fn frame(n: Vec3) -> (Vec3, Vec3) {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Mitsuba's cylinder at (u, v): `p0 + r(cos 2πu·s + sin 2πu·t) + v·(p1 − p0)`.
fn mitsuba_point(p0: Vec3, p1: Vec3, r: f32, u: f32, v: f32) -> Vec3 {
    let (s, t) = frame((p1 - p0).normalize());
    let (sn, cs) = (2.0 * PI * u).sin_cos();
    p0 + (s * cs + t * sn) * r + (p1 - p0) * v
}

#[test]
fn cylinder_hits_agree_with_a_fine_triangulation() {
    let mut rng = Rng::new(5);
    let (segs, rows) = (720usize, 4usize);
    let (mut checked, mut skipped) = (0, 0);
    for case in 0..6 {
        let p0 = rng.in_cube(2.0);
        let p1 = p0 + rng.dir() * rng.rangef(0.5, 3.0);
        let r = rng.rangef(0.2, 1.5);
        let flip = case % 2 == 1;
        let dir = tempfile::tempdir().unwrap();
        let object = json!({"type": "cylinder", "p0": p0.to_array(), "p1": p1.to_array(), "radius": r, "flip_normals": flip});
        let scene = one_object_scene(dir.path(), object);
        // the triangulation, with each triangle's uv corners
        let mut tris = Vec::new();
        let mut uvs = Vec::new();
        for i in 0..segs {
            for j in 0..rows {
                let (u0, u1) = (i as f32 / segs as f32, (i + 1) as f32 / segs as f32);
                let (v0, v1) = (j as f32 / rows as f32, (j + 1) as f32 / rows as f32);
                let q = |u, v| mitsuba_point(p0, p1, r, u, v);
                tris.push([q(u0, v0), q(u1, v0), q(u1, v1)]);
                uvs.push([Vec2::new(u0, v0), Vec2::new(u1, v0), Vec2::new(u1, v1)]);
                tris.push([q(u0, v0), q(u1, v1), q(u0, v1)]);
                uvs.push([Vec2::new(u0, v0), Vec2::new(u1, v1), Vec2::new(u0, v1)]);
            }
        }
        let prims = as_prims(tris.clone());
        let bvh = WideBvh::build(&prims);
        let axis = (p1 - p0).normalize();
        let c = (p0 + p1) * 0.5;
        for k in 0..1500 {
            let target = mitsuba_point(p0, p1, r, rng.rangef(0.0, 1.0), rng.rangef(-0.1, 1.1));
            let o = if k % 3 == 0 {
                // inside the cylinder: the far wall from within
                mitsuba_point(p0, p1, r * rng.rangef(0.0, 0.9), rng.rangef(0.0, 1.0), rng.rangef(0.05, 0.95))
            } else {
                c + rng.dir() * (r + (p1 - p0).length()) * rng.rangef(1.5, 3.0)
            };
            let ray = Ray::new(o, (target - o).normalize());
            let a = scene.intersect(&ray);
            let b = bvh.intersect(&prims, &ray);
            // leave aside rays near the rims, tangent to the surface or nearly along it
            let near_edge = |t: f32| {
                let p = ray.at(t);
                let h = (p - p0).dot(axis) / (p1 - p0).length();
                let radial = (p - p0 - axis * (p - p0).dot(axis)).normalize();
                h.abs() < 2e-3 || (h - 1.0).abs() < 2e-3 || radial.dot(ray.d).abs() < 0.05
            };
            match (a, b) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    if near_edge(b.t) || near_edge(a.t) {
                        skipped += 1;
                        continue;
                    }
                    assert!((a.t - b.t).abs() < 1e-3 * b.t.max(1.0), "case {case} ray {k}: t {} vs {}", a.t, b.t);
                    let it = scene.interaction(&ray, &a);
                    let tri = &tris[b.prim as usize];
                    let w = b.b;
                    let uv = uvs[b.prim as usize][0] * w[0] + uvs[b.prim as usize][1] * w[1] + uvs[b.prim as usize][2] * w[2];
                    // rdr's v runs the other way from Mitsuba's (as for meshes)
                    let du = (it.uv.x - uv.x).abs();
                    let dv = (it.uv.y - (1.0 - uv.y)).abs();
                    assert!(
                        du.min(1.0 - du) < 2e-3 && dv < 2e-3,
                        "case {case} ray {k}: uv {} vs Mitsuba's {uv}",
                        it.uv
                    );
                    // ∂p/∂u as Mitsuba's, ∂p/∂v of rdr's v = 1 − h
                    let h = 1e-3;
                    let fu = (mitsuba_point(p0, p1, r, uv.x + h, uv.y) - mitsuba_point(p0, p1, r, uv.x - h, uv.y)) / (2.0 * h);
                    assert!(
                        (it.dpdu - fu).length() < 1e-2 * fu.length(),
                        "case {case} ray {k}: dpdu {} vs {fu}",
                        it.dpdu
                    );
                    assert!(
                        (it.dpdv + (p1 - p0)).length() < 1e-4 * (p1 - p0).length(),
                        "case {case} ray {k}: dpdv {}",
                        it.dpdv
                    );
                    // outward normal as Mitsuba's (the triangles wind outwards), inward with flip_normals
                    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
                    let n = if flip { -n } else { n };
                    assert!(it.ng.dot(n) > 0.999, "case {case} ray {k}: ng {} vs {n}", it.ng);
                    assert!((it.p - ray.at(b.t)).length() < 2e-3 * r.max(1.0));
                    checked += 1;
                }
                (a, b) => {
                    let t = a.map(|h| h.t).or(b.map(|h| h.t)).unwrap();
                    if near_edge(t) {
                        skipped += 1;
                        continue;
                    }
                    panic!("case {case} ray {k} {ray:?}: analytic {a:?}, triangulated {b:?}");
                }
            }
            // and the prim is the cylinder
            if let Some(a) = a {
                assert!(matches!(scene.prims[a.prim as usize], Prim::Cylinder { .. }));
            }
        }
    }
    eprintln!("{checked} hits agree, {skipped} near a rim or grazing left aside");
    assert!(checked > 4000 && skipped * 10 < checked);
}

fn refs() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/shapes")
}

fn converges(file: &Path) -> bool {
    let s = load_scene(file, &[], Profile::Physical);
    let (a, b) = (render(&s, 256, 1), render(&s, 256, 2));
    let r = read(&refs().join("cylinder.exr"));
    let vr = read(&refs().join("cylinder.var.exr"));
    let c = compare(&a, &b, &r, &vr);
    eprintln!(
        "{}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
        file.display(),
        c.rel_mse_corrected,
        c.std_error,
        c.rel_mse_raw,
        c.rel_mse_noise
    );
    c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4
}

#[test]
fn cylinder_scene_converges_to_mitsubas_image() {
    let xml = refs().join("cylinder.xml");
    assert!(converges(&xml), "the XML scene does not converge to Mitsuba's image");
    // the JSON twin rdr convert writes (cylinder keys in JSON)
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("cylinder.json");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["convert", xml.to_str().unwrap(), "-o", json.to_str().unwrap(), "-q"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&json).unwrap();
    assert!(text.contains("\"cylinder\"") && text.contains("flip_normals"), "{text}");
    assert!(converges(&json), "the converted JSON scene does not converge to Mitsuba's image");
}
