//! Scenes built on the fly for the light-transport tests: integrators against `path`
//! on glass and on shading normals (`tests/bdpt.rs`, `tests/photon_transport.rs`).

use super::render;
use rdr::math::Vec3;
use rdr::metrics::{compare, Comparison, Image};
use rdr::Profile;
use serde_json::{json, Value};
use std::path::Path;

pub fn scene_from(value: &Value, dir: &Path) -> rdr::Loaded {
    let desc = rdr::desc::SceneDesc::from_value(value, &dir.join("scene.json"), dir).unwrap_or_else(|e| panic!("{e}"));
    assert!(desc.warnings.is_empty(), "{:?}", desc.warnings);
    rdr::Loaded::build(&desc, Profile::Physical).unwrap_or_else(|e| panic!("{e}"))
}

/// A UV sphere of radius `r` about the origin, `n` segments around, with vertex
/// normals (outward) or without; triangles wound inwards when `inward`.
pub fn sphere_obj(n: usize, r: f32, inward: bool, normals: bool) -> String {
    use std::fmt::Write;
    let m = n / 2;
    let mut s = String::new();
    for i in 0..=m {
        let th = std::f32::consts::PI * i as f32 / m as f32;
        for j in 0..n {
            let ph = 2.0 * std::f32::consts::PI * j as f32 / n as f32;
            let d = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
            writeln!(s, "v {} {} {}", d.x * r, d.y * r, d.z * r).unwrap();
            if normals {
                writeln!(s, "vn {} {} {}", d.x, d.y, d.z).unwrap();
            }
        }
    }
    let id = |i: usize, j: usize| i * n + (j % n) + 1;
    let mut face = |a: usize, b: usize, c: usize| {
        let (b, c) = if inward { (c, b) } else { (b, c) };
        if normals {
            writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}").unwrap();
        } else {
            writeln!(s, "f {a} {b} {c}").unwrap();
        }
    };
    for i in 0..m {
        for j in 0..n {
            // outward winding: (i,j) (i,j+1) (i+1,j) seen from outside is counter-clockwise
            if i > 0 {
                face(id(i, j), id(i, j + 1), id(i + 1, j));
            }
            if i + 1 < m {
                face(id(i, j + 1), id(i + 1, j + 1), id(i + 1, j));
            }
        }
    }
    s
}

/// A sphere of `segments` segments around with vertex normals (10: ~100 triangles)
/// under a quad area light (or a point light beside it), on a large floor with an
/// image texture (4×4 texels, bilinear); `integrator`: the JSON object (`type` and
/// its keys; `max_depth` 5 and `lights` are added).
pub fn smooth_sphere(dir: &Path, integrator: Value, segments: usize, point_light: bool) -> rdr::Loaded {
    let texels: Vec<Vec3> = (0..16)
        .map(|i| Vec3::new(0.2 + 0.05 * i as f32, 0.9 - 0.04 * i as f32, 0.3 + 0.3 * (i % 2) as f32))
        .collect();
    rdr::imageio::write_png(&dir.join("tiles.png"), 4, 4, &texels).unwrap();
    std::fs::write(dir.join("ball.obj"), sphere_obj(segments, 0.6, false, true)).unwrap();
    std::fs::write(
        dir.join("lamp.obj"),
        "v -0.5 2.5 -0.5\nv 0.5 2.5 -0.5\nv 0.5 2.5 0.5\nv -0.5 2.5 0.5\nf 1 2 3 4\n",
    )
    .unwrap();
    let mut objects = vec![
        json!({"type": "mesh", "path": "ball.obj", "material_name": "white", "translate": [0.0, 0.6, 0.0]}),
        json!({"type": "sphere", "center": [0.0, -100.0, 0.0], "radius": 100.0, "material_name": "floor"}),
    ];
    let mut integ = integrator;
    integ["max_depth"] = json!(5);
    integ["lights"] = json!([]);
    if point_light {
        integ["lights"] = json!([{"type": "point", "position": [1.0, 1.8, 1.0], "flux": [40, 40, 40]}]);
    } else {
        objects.push(json!({"type": "mesh", "path": "lamp.obj", "light": {"type": "area", "radiance": [8, 8, 8]}}));
    }
    let v = json!({
        "integrator": integ,
        "film": {"resolution": [32, 24]},
        "camera": {"position": [0.0, 1.2, 3.2], "look_at": [0.0, 0.5, 0.0], "ref_up": [0.0, 1.0, 0.0], "fov": 40.0},
        "textures": {"white": {"type": "constant", "color": [0.8, 0.7, 0.6]},
                     "tiles": {"type": "image", "path": "tiles.png", "tex_coordinate_generator": {"type": "uvmapping2d", "scale": [400, 200]}}},
        "materials": {"white": {"type": "diffuse", "texture_name": "white"}, "floor": {"type": "diffuse", "texture_name": "tiles"}},
        "objects": objects
    });
    scene_from(&v, dir)
}

/// The camera and a diffuse ball inside a big glass (or `refraction`) ball, lit from
/// outside by an area light in a big diffuse sphere: every light subpath that
/// reaches the camera crossed the glass once more inwards than outwards, so the
/// η² of refraction must be right on both subpaths (radiance: scaled, importance:
/// not, for `glass`; the reverse for `refraction`). `shells`: 1, or 2 for a second
/// ball of the same material inside the first (radius 1.9), the camera inside both.
/// `integrator`: the JSON object (`max_depth` 8 and `lights` are added).
pub fn nested_glass(dir: &Path, integrator: Value, outer: &str, shells: usize) -> rdr::Loaded {
    std::fs::write(
        dir.join("lamp.obj"),
        "v -0.6 2.6 -0.6\nv 0.6 2.6 -0.6\nv 0.6 2.6 0.6\nv -0.6 2.6 0.6\nf 1 2 3 4\n",
    )
    .unwrap();
    let mut integ = integrator;
    integ["max_depth"] = json!(8);
    integ["lights"] = json!([]);
    let mut v = json!({
        "integrator": integ,
        "film": {"resolution": [24, 24]},
        "camera": {"position": [0.0, 0.3, 1.6], "look_at": [0.0, 0.0, 0.0], "ref_up": [0.0, 1.0, 0.0], "fov": 50.0},
        "textures": {"white": {"type": "constant", "color": [0.8, 0.8, 0.8]}, "red": {"type": "constant", "color": [0.8, 0.3, 0.2]}},
        "materials": {
            "white": {"type": "diffuse", "texture_name": "white", "twosided": true},
            "red": {"type": "diffuse", "texture_name": "red"},
            "glass": {"type": "glass", "eta": 1.5},
            "refraction": {"type": "refraction", "eta": 1.5}
        },
        "objects": [
            {"type": "sphere", "center": [0.0, 0.0, 0.0], "radius": 2.2, "material_name": outer},
            {"type": "sphere", "center": [0.0, 0.0, 0.0], "radius": 0.6, "material_name": "red"},
            {"type": "sphere", "center": [0.0, 0.0, 0.0], "radius": 6.0, "material_name": "white"},
            {"type": "mesh", "path": "lamp.obj", "light": {"type": "area", "radiance": [6, 6, 6]}}
        ]
    });
    if shells == 2 {
        let inner = json!({"type": "sphere", "center": [0.0, 0.0, 0.0], "radius": 1.9, "material_name": outer});
        v["objects"].as_array_mut().unwrap().push(inner);
    }
    scene_from(&v, dir)
}

/// An integrator against `path` on the same scene (path's two halves as the
/// reference), both at seeds of their own, averaged over k×k blocks: the comparison,
/// and the largest relative difference of the two images' channel means.
pub fn against_path(name: &str, path: &rdr::Loaded, other: &rdr::Loaded, spp_path: u32, spp_other: u32, k: usize) -> (Comparison, f32) {
    let (p1, p2) = (render(path, spp_path, 21), render(path, spp_path, 22));
    let r = Image::new(
        p1.width,
        p1.height,
        p1.pixels.iter().zip(&p2.pixels).map(|(a, b)| (*a + *b) * 0.5).collect(),
    );
    let vr = Image::new(
        p1.width,
        p1.height,
        p1.pixels
            .iter()
            .zip(&p2.pixels)
            .map(|(a, b)| (*a - *b) * (*a - *b) * 0.25)
            .collect(),
    );
    let (b1, b2) = (render(other, spp_other, 23), render(other, spp_other, 24));
    let c = compare(
        &b1.block_average(k, false),
        &b2.block_average(k, false),
        &r.block_average(k, false),
        &vr.block_average(k, true),
    );
    let (mo, mp) = ((b1.mean() + b2.mean()) * 0.5, (p1.mean() + p2.mean()) * 0.5);
    let off = ((mo - mp) / mp).abs().max_element();
    eprintln!(
        "{name:>36}: relMSE corrected {:+.2e} ± {:.1e} (raw {:.2e}, noise {:.2e}); mean {mo} vs path {mp}, off by {:.2} %",
        c.rel_mse_corrected,
        c.std_error,
        c.rel_mse_raw,
        c.rel_mse_noise,
        100.0 * off
    );
    (c, off)
}
