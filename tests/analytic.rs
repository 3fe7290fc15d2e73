//! Scenes with known answers, using only what the project ships or writes itself.

mod common;
use rdr::math::Vec3;
use rdr::metrics::Image;
use rdr::Profile;
use serde_json::json;
use std::path::Path;

fn scene_from(value: serde_json::Value) -> rdr::Loaded {
    let desc = rdr::desc::SceneDesc::from_value(&value, Path::new("analytic.json"), Path::new(".")).unwrap();
    rdr::Loaded::build(&desc, rdr::Profile::Physical).unwrap()
}

/// A huge white-ish diffuse sphere acting as a floor (top at y = 0), a camera
/// looking straight down from height 1, a point light at height `h`.
fn floor_scene(h: f32, flux: [f32; 3], extra_lights: serde_json::Value) -> serde_json::Value {
    json!({
        "integrator": {"type": "intersection_test", "spp": 4, "point_light_position": [0.0, h, 0.0], "point_light_flux": flux, "lights": extra_lights},
        "film": {"resolution": [33, 33]},
        "camera": {"position": [0.0, 1.0, 0.0], "look_at": [0.0, 0.0, 0.0], "ref_up": [0.0, 0.0, -1.0], "fov": 60.0},
        "textures": {"albedo": {"type": "constant", "color": [0.8, 0.5, 0.2]}},
        "materials": {"floor": {"type": "diffuse", "texture_name": "albedo"}},
        "objects": [{"type": "sphere", "center": [0.0, -1.0e4, 0.0], "radius": 1.0e4, "material_name": "floor"}]
    })
}

/// Radiance of the floor point under the centre of pixel (x, y) of `floor_scene`.
fn expected(x: usize, y: usize, h: f32, flux: Vec3) -> Vec3 {
    let half = (30.0f32.to_radians()).tan();
    let sx = ((x as f32 + 0.5) / 33.0 * 2.0 - 1.0) * half;
    let sy = -((y as f32 + 0.5) / 33.0 * 2.0 - 1.0) * half; // output row 0 is the top (−z)
                                                            // camera at height 1 looking down, right = +x, up = −z: the ray hits y = 0 at (sx, 0, −sy)
    let p = Vec3::new(sx, 0.0, -sy);
    let to_light = Vec3::new(0.0, h, 0.0) - p;
    let d2 = to_light.length_squared();
    let cos = to_light.y / d2.sqrt();
    Vec3::new(0.8, 0.5, 0.2) / std::f32::consts::PI * flux / (4.0 * std::f32::consts::PI) * cos / d2
}

#[test]
fn point_light_on_a_diffuse_floor_matches_the_formula() {
    let (h, flux) = (0.7, Vec3::new(10.0, 20.0, 30.0));
    let scene = scene_from(floor_scene(h, flux.to_array(), json!([])));
    let img = common::render(&scene, 16, 0);
    for (x, y) in [(16, 16), (0, 0), (32, 5), (7, 29), (20, 11)] {
        let got = img.pixels[y * 33 + x];
        let want = expected(x, y, h, flux);
        // a pixel averages a small footprint; the radiance varies smoothly over it
        let rel = ((got - want) / want).abs().max_element();
        assert!(rel < 3e-3, "pixel ({x},{y}): {got} vs {want}");
    }
}

#[test]
fn lights_add_up_and_shadows_are_black() {
    let flux = [5.0, 5.0, 5.0];
    let one = scene_from(floor_scene(0.7, flux, json!([])));
    let two = scene_from(floor_scene(
        0.7,
        flux,
        json!([{"type": "point", "position": [0.0, 0.7, 0.0], "flux": flux}]),
    ));
    let (a, b) = (common::render(&one, 4, 0), common::render(&two, 4, 0));
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        assert!((*q - *p * 2.0).abs().max_element() <= 1e-6 * q.max_element().max(1.0), "{p} {q}");
    }
    // a light under the floor lights nothing the camera sees
    let below = scene_from(floor_scene(-0.5, flux, json!([])));
    assert!(common::render(&below, 4, 0).pixels.iter().all(|p| *p == Vec3::ZERO));
}

#[test]
fn refraction_follows_snell_into_a_denser_medium() {
    // A refracting face at z = 0 (normal +z) seen at 30° from vacuum; a wall at z = −1.
    // Snell: sin θt = sin 30° / 1.5, so the ray meets the wall at x = tan θt ≈ 0.354.
    // Only the band 0.3 < x < 0.45 of the wall is red. Going straight on would reach
    // x = 0.577, and the original's η ratio (bending away) x ≈ 1.13: both green.
    let tmp = common::temp_dir("rdr-snell");
    let dir = tmp.path();
    let quad = |x0: f32, x1: f32, z: f32| format!("v {x0} -50 {z}\nv {x1} -50 {z}\nv {x1} 50 {z}\nv {x0} 50 {z}\nf 1 2 3 4\n");
    std::fs::write(dir.join("face.obj"), quad(-50.0, 50.0, 0.0)).unwrap();
    std::fs::write(dir.join("red.obj"), quad(0.3, 0.45, -1.0)).unwrap();
    std::fs::write(dir.join("green1.obj"), quad(-50.0, 0.3, -1.0)).unwrap();
    std::fs::write(dir.join("green2.obj"), quad(0.45, 50.0, -1.0)).unwrap();
    let s = 30.0f32.to_radians();
    let value = json!({
        "integrator": {"type": "intersection_test", "spp": 1, "lights": [{"type": "point", "position": [0.5, 0.0, -0.5], "flux": [1, 1, 1]}]},
        "film": {"resolution": [1, 1]},
        "camera": {"position": [-s.sin(), 0.0, s.cos()], "look_at": [0.0, 0.0, 0.0], "ref_up": [0.0, 1.0, 0.0], "fov": 0.01},
        "textures": {"r": {"type": "constant", "color": [1, 0, 0]}, "g": {"type": "constant", "color": [0, 1, 0]}},
        "materials": {"glass": {"type": "refraction", "eta": 1.5}, "red": {"type": "diffuse", "texture_name": "r"}, "green": {"type": "diffuse", "texture_name": "g"}},
        "objects": [
            {"type": "mesh", "path": "face.obj", "material_name": "glass"},
            {"type": "mesh", "path": "red.obj", "material_name": "red"},
            {"type": "mesh", "path": "green1.obj", "material_name": "green"},
            {"type": "mesh", "path": "green2.obj", "material_name": "green"}
        ]
    });
    let desc = rdr::desc::SceneDesc::from_value(&value, &dir.join("snell.json"), dir).unwrap();
    let pixel = |profile: Profile| {
        let scene = rdr::Loaded::build(&desc, profile).unwrap();
        common::render(&scene, 1, 0).pixels[0]
    };
    let (physical, original) = (pixel(Profile::Physical), pixel(Profile::Rdr171));
    assert!(
        physical.x > 0.0 && physical.y == 0.0,
        "refracted ray should reach the red band: {physical}"
    );
    assert!(
        original.x == 0.0 && original.y > 0.0,
        "the original's ratio bends away and misses it: {original}"
    );
}

fn render_with_threads(scene: &rdr::Loaded, threads: usize) -> Image {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(|| common::render(scene, 8, 7))
}

#[test]
fn example_scene_renders_the_same_on_any_number_of_threads() {
    let scene = common::load_scene(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.json"),
        &[r#"{"film": {"resolution": [64, 48], "filter": {"type": "gaussian", "radius": 1.5}}}"#],
        Profile::Physical,
    );
    let (a, b) = (render_with_threads(&scene, 1), render_with_threads(&scene, 3));
    assert!(a.pixels == b.pixels, "thread count changed the image");
    let c = common::render(&scene, 8, 8);
    assert!(a.pixels != c.pixels, "the seed changes the image");
}

#[test]
fn example_scene_looks_like_a_cornell_box() {
    let scene = common::load_scene(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.json"),
        &[r#"{"film": {"resolution": [64, 64]}}"#],
        Profile::Physical,
    );
    assert!(scene.scene.warnings.is_empty(), "{:?}", scene.scene.warnings);
    let img = common::render(&scene, 4, 0);
    let px = |x: usize, y: usize| img.pixels[y * 64 + x];
    let left = px(2, 32);
    let right = px(61, 32);
    assert!(left.x > 3.0 * left.z && left.x > 3.0 * left.y, "left wall is red: {left}");
    assert!(right.z > 1.5 * right.x, "right wall is blue: {right}");
    assert!(px(32, 2).length() > px(32, 20).length(), "ceiling near the light is brightest");
    assert!(img.pixels.iter().all(|p| p.is_finite() && p.min_element() >= 0.0));
}
