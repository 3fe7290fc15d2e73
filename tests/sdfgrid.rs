//! Mitsuba's `sdfgrid`: hits and normals against a dense march of the trilinear
//! field written out here (random grids, transforms and rays), bad grids refused in
//! one line naming the file and the key, and a small scene (two grids with `smooth`
//! and `analytic` normals under non-uniform scales) converging to Mitsuba 3's image
//! of it (`tests/refs/shapes/`, made by `scripts/make_sdfgrid_refs.py`), read from
//! its XML and from the JSON `rdr convert` writes of it.

mod common;

use common::*;
use rdr::geometry::Ray;
use rdr::math::{Mat4, Vec3};
use rdr::volume::{vol_file, GridData};
use serde_json::json;
use std::path::Path;

/// The bytes of a one-channel `.vol` file of `values` (x fastest); the medium's
/// checks (no negative values) are not a distance's, so the grid is made as it is.
fn vol_bytes(res: [usize; 3], values: Vec<f32>) -> Vec<u8> {
    let bbox = rdr::geometry::Aabb::new(Vec3::ZERO, Vec3::ONE);
    vol_file::encode(&GridData {
        res,
        channels: 1,
        bbox,
        values,
    })
}

/// The trilinear interpolant of the grid at `u` in the unit cube (`None` outside),
/// written from the definition: samples at `(i, j, k)/(res − 1)`.
fn field(res: [usize; 3], values: &[f32], u: Vec3) -> Option<f64> {
    let u = u.as_dvec3().to_array();
    if u.iter().any(|&c| !(0.0..=1.0).contains(&c)) {
        return None;
    }
    let q: [f64; 3] = std::array::from_fn(|a| u[a] * (res[a] - 1) as f64);
    let i: [usize; 3] = std::array::from_fn(|a| (q[a].floor() as usize).min(res[a] - 2));
    let w: [f64; 3] = std::array::from_fn(|a| q[a] - i[a] as f64);
    let mut f = 0.0;
    for corner in 0..8 {
        let o = [corner & 1, corner >> 1 & 1, corner >> 2];
        let weight: f64 = (0..3).map(|a| if o[a] == 1 { w[a] } else { 1.0 - w[a] }).product();
        f += weight * values[((i[2] + o[2]) * res[1] + i[1] + o[1]) * res[0] + i[0] + o[0]] as f64;
    }
    Some(f)
}

/// A random grid: a sphere's distance with a bump, plus noise (the surface not a sphere).
fn random_grid(rng: &mut Rng) -> ([usize; 3], Vec<f32>) {
    let res = [rng.int(3, 12) as usize, rng.int(3, 12) as usize, rng.int(3, 12) as usize];
    let (c, r) = (
        Vec3::new(rng.rangef(0.4, 0.6), rng.rangef(0.4, 0.6), rng.rangef(0.4, 0.6)),
        rng.rangef(0.2, 0.35),
    );
    let mut values = Vec::new();
    for z in 0..res[2] {
        for y in 0..res[1] {
            for x in 0..res[0] {
                let p = Vec3::new(x as f32, y as f32, z as f32) / Vec3::new((res[0] - 1) as f32, (res[1] - 1) as f32, (res[2] - 1) as f32);
                values.push((p - c).length() - r + 0.08 * (7.0 * p.x).sin() * (5.0 * p.y).cos() + rng.rangef(-0.03, 0.03));
            }
        }
    }
    (res, values)
}

/// Loads a JSON scene of one sdfgrid (`grid.vol` in `dir`) placed by `to_world`.
fn grid_scene(dir: &Path, to_world: Mat4, normals: &str) -> rdr::scene::Scene {
    let m = to_world.transpose().to_cols_array();
    one_object_scene(
        dir,
        json!({"type": "sdfgrid", "filename": "grid.vol", "transform": m.to_vec(), "normals": normals}),
    )
}

/// The first sign change of the field along `ray` (world), by 4000 steps through
/// the unit cube's part of it and bisection; `None` when the field keeps its sign.
/// Also whether the march saw a second sign change within two steps (a grazing ray).
fn march(res: [usize; 3], values: &[f32], to_object: &Mat4, ray: &Ray) -> Option<(f64, bool)> {
    let f = |t: f64| field(res, values, to_object.transform_point3(ray.at(t as f32)));
    let (t0, t1) = (0.0f64, 40.0f64);
    let n = 4000;
    let step = (t1 - t0) / n as f64;
    let mut prev: Option<(f64, f64)> = None;
    for k in 0..=n {
        let t = t0 + step * k as f64;
        let Some(v) = f(t) else {
            prev = None;
            continue;
        };
        if let Some((tp, vp)) = prev {
            if vp * v <= 0.0 {
                let (mut a, mut b, fa) = (tp, t, vp);
                for _ in 0..60 {
                    let m = 0.5 * (a + b);
                    match f(m) {
                        Some(fm) if (fm > 0.0) == (fa > 0.0) && fm != 0.0 => a = m,
                        _ => b = m,
                    }
                }
                let graze = (1..=2).any(|j| match (f(t + step * (j - 1) as f64), f(t + step * j as f64)) {
                    (Some(x), Some(y)) => x * y <= 0.0,
                    _ => false,
                });
                return Some((0.5 * (a + b), graze || vp.abs().min(v.abs()) < 1e-4));
            }
        }
        prev = Some((t, v));
    }
    None
}

/// Whether the field keeps its sign one march step (0.01) either side of `t`: a
/// surface the ray only touches there, which the march steps over.
fn touches(res: [usize; 3], values: &[f32], to_object: &Mat4, ray: &Ray, t: f64) -> bool {
    let f = |t: f64| field(res, values, to_object.transform_point3(ray.at(t as f32)));
    matches!((f(t - 0.01), f(t + 0.01)), (Some(a), Some(b)) if a * b > 0.0)
}

#[test]
fn hits_and_normals_agree_with_a_dense_march_of_the_field() {
    let mut rng = Rng::new(41);
    let (mut checked, mut grazing, mut normals) = (0, 0, 0);
    for case in 0..6 {
        let (res, values) = random_grid(&mut rng);
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("grid.vol"), vol_bytes(res, values.clone())).unwrap();
        // a rotation, a non-uniform scale and a translation
        let q = glam::Quat::from_axis_angle(rng.dir(), rng.rangef(0.0, 3.0));
        let s = Vec3::new(rng.rangef(1.0, 3.0), rng.rangef(1.0, 3.0), rng.rangef(1.0, 3.0));
        let to_world =
            Mat4::from_rotation_translation(q, rng.in_cube(1.0)) * Mat4::from_scale(s) * Mat4::from_translation(Vec3::splat(-0.5));
        let to_object = to_world.inverse();
        let scene = grid_scene(dir.path(), to_world, if case % 2 == 0 { "smooth" } else { "analytic" });
        let centre = to_world.transform_point3(Vec3::splat(0.5));
        for k in 0..400 {
            let target = to_world.transform_point3(Vec3::new(rng.rangef(0.1, 0.9), rng.rangef(0.1, 0.9), rng.rangef(0.1, 0.9)));
            let o = if k % 4 == 0 {
                // from inside the grid
                to_world.transform_point3(Vec3::new(rng.rangef(0.2, 0.8), rng.rangef(0.2, 0.8), rng.rangef(0.2, 0.8)))
            } else {
                centre + rng.dir() * rng.rangef(6.0, 9.0)
            };
            let ray = Ray::new(o, (target - o).normalize());
            let got = scene.intersect(&ray);
            let want = march(res, &values, &to_object, &ray);
            match (got, want) {
                (None, None) => {}
                (Some(h), Some((t, graze))) if ((h.t as f64) - t).abs() < 2e-4 * t.max(1.0) => {
                    // the geometric normal: the field's gradient in the world, by differences
                    let p = ray.at(h.t);
                    let e = 1e-3;
                    let g = Vec3::from_array(std::array::from_fn(|a| {
                        let mut d = Vec3::ZERO;
                        d[a] = e;
                        let f = |q: Vec3| field(res, &values, to_object.transform_point3(q));
                        match (f(p + d), f(p - d)) {
                            (Some(x), Some(y)) => ((x - y) / (2.0 * e as f64)) as f32,
                            _ => f32::NAN,
                        }
                    }));
                    let it = scene.interaction(&ray, &h);
                    // the gradient jumps across voxel faces: compare away from them
                    let q = to_object.transform_point3(p).to_array();
                    let near_face = (0..3).any(|a| {
                        let x = q[a] * (res[a] - 1) as f32;
                        (x - x.round()).abs() < 0.03
                    });
                    if g.is_finite() && g.length() > 0.0 && !near_face {
                        let cos = it.ng.dot(g.normalize());
                        assert!(
                            cos > 0.999 || graze,
                            "case {case} ray {k}: ng {} vs the field's gradient {}",
                            it.ng,
                            g.normalize()
                        );
                        normals += 1;
                    }
                    let unit = it.ns.is_finite() && (it.ns.length() - 1.0).abs() < 1e-4;
                    assert!(
                        unit && it.ns.dot(it.ng) > 0.0,
                        "case {case} ray {k}: ns {} against ng {}",
                        it.ns,
                        it.ng
                    );
                    checked += 1;
                }
                // a disagreement where the ray grazes the surface (two roots close together)
                (_, Some((_, true))) => grazing += 1,
                (Some(h), None) if touches(res, &values, &to_object, &ray, h.t as f64) => grazing += 1,
                (got, want) => panic!("case {case} ray {k} {ray:?}: rdr {:?}, the march {want:?}", got.map(|h| h.t)),
            }
        }
    }
    eprintln!("{checked} hits agree with the march ({normals} normals compared), {grazing} grazing rays left aside");
    assert!(
        checked > 800 && normals > 400 && grazing * 50 < checked,
        "{checked} checked, {grazing} grazing"
    );
}

fn refs() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/shapes")
}

#[test]
fn sdfgrid_scene_converges_to_mitsubas_image() {
    // a small floor beyond 5σ: rdr's hits and normals are Mitsuba's to 5e-5 per ray
    let xml = refs().join("sdfgrid.xml");
    assert!(
        converges_to_ref_within(&refs(), &xml, "sdfgrid", &[], 128, 2e-5),
        "the XML scene does not converge to Mitsuba's image"
    );
    // the JSON twin rdr convert writes, and the XML it writes back
    let dir = tempfile::tempdir().unwrap();
    let (json, text) = converted_to_json(&xml, dir.path());
    assert!(text.contains("\"sdfgrid\"") && text.contains("\"analytic\""), "{text}");
    assert!(
        converges_to_ref_within(&refs(), &json, "sdfgrid", &[], 128, 2e-5),
        "the converted JSON scene does not converge to Mitsuba's image"
    );
    let back = dir.path().join("back.xml");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["convert", "-q", json.to_str().unwrap(), "-o", back.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = std::fs::read_to_string(&back).unwrap();
    assert!(
        text.matches("type=\"sdfgrid\"").count() == 2 && text.contains("value=\"analytic\""),
        "{text}"
    );
    let loaded = load_scene(&back, &[], rdr::Profile::Physical);
    assert_eq!(loaded.scene.instances.len(), 2);
}

/// A Mitsuba scene of one sdfgrid reading `grid.vol`, with `extra` inside the shape.
fn xml_scene(extra: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
  <shape type="sdfgrid"><string name="filename" value="grid.vol"/>{extra}</shape>
</scene>"#
    )
}

#[test]
fn bad_grids_and_parameters_are_refused_in_one_line() {
    let mut sphere = Vec::new();
    for i in 0..64 {
        let p = Vec3::new((i % 4) as f32, (i / 4 % 4) as f32, (i / 16) as f32) / 3.0 - Vec3::splat(0.5);
        sphere.push(p.length() - 0.4);
    }
    let mut nan = sphere.clone();
    nan[1 + 4 * 2 + 16 * 3] = f32::NAN;
    let three = vol_file::encode(&GridData {
        res: [4, 4, 4],
        channels: 3,
        bbox: rdr::geometry::Aabb::new(Vec3::ZERO, Vec3::ONE),
        values: sphere.iter().flat_map(|&v| [v; 3]).collect(),
    });
    let cases: Vec<(&str, Option<Vec<u8>>, &str, &str)> = vec![
        ("missing file", None, "", "grid.vol"),
        ("NaN sample", Some(vol_bytes([4, 4, 4], nan)), "", "sample (1, 2, 3) holds NaN"),
        ("three channels", Some(three), "", "3 channels"),
        ("one sample across", Some(vol_bytes([1, 4, 16], sphere.clone())), "", "2 to"),
        (
            "no surface",
            Some(vol_bytes([4, 4, 4], vec![1.0; 64])),
            "",
            "no voxel has the surface",
        ),
        (
            "truncated",
            Some(vol_bytes([4, 4, 4], sphere.clone())[..100].to_vec()),
            "",
            "claims",
        ),
        (
            "an area emitter",
            Some(vol_bytes([4, 4, 4], sphere.clone())),
            r#"<emitter type="area"/>"#,
            "cannot be an area emitter",
        ),
        (
            "unknown normals",
            Some(vol_bytes([4, 4, 4], sphere.clone())),
            r#"<string name="normals" value="flat"/>"#,
            "normals",
        ),
        (
            "a singular transform",
            Some(vol_bytes([4, 4, 4], sphere.clone())),
            r#"<transform name="to_world"><scale x="0"/></transform>"#,
            "to_world",
        ),
    ];
    for (what, grid, extra, expect) in cases {
        let dir = tempfile::tempdir().unwrap();
        if let Some(bytes) = grid {
            std::fs::write(dir.path().join("grid.vol"), bytes).unwrap();
        }
        let scene = dir.path().join("scene.xml");
        std::fs::write(&scene, xml_scene(extra)).unwrap();
        let e = match rdr::load(&scene, &[], rdr::Profile::Physical) {
            Ok(_) => panic!("{what}: loaded"),
            Err(e) => format!("{e:#}"),
        };
        eprintln!("{what}: {e}");
        assert!(e.contains(expect) && e.contains("scene.xml") && !e.contains('\n'), "{what}: {e}");
        // the grid's own problems name the grid file and the key
        if extra.is_empty() {
            assert!(e.contains("grid.vol") && e.contains("filename"), "{what}: {e}");
        }
    }
}
