//! The `normals` integrator: it shows shading normals mapped to colours.

mod common;

use rdr::math::Vec3;
use rdr::Profile;

#[test]
fn normals_integrator_shows_the_shading_normal_of_a_sphere() {
    let dir = common::temp_dir("rdr-normals");
    let scene = serde_json::json!({
        "integrator": {"type": "normals", "spp": 1},
        "film": {"resolution": [33, 33]},
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "fov": 30},
        "materials": {"m": {"type": "refraction"}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material_name": "m"}]
    });
    let path = dir.path().join("normals.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let loaded = common::load_scene(&path, &[], Profile::Physical);
    let img = common::render(&loaded, 1, 0);
    // the centre pixel looks straight at the sphere: n = +z
    let c = img.at(16, 16);
    assert!((c - Vec3::new(0.5, 0.5, 1.0)).abs().max_element() < 0.02, "centre {c}");
    // corners miss it
    assert_eq!(img.at(0, 0), Vec3::ZERO);
    // left of centre the normal leans to −x (red below ½), above it to +y (green above ½)
    let (left, top) = (img.at(8, 16), img.at(16, 8));
    assert!(left.x < 0.4 && (left.y - 0.5).abs() < 0.02, "left {left}");
    assert!(top.y > 0.6 && (top.x - 0.5).abs() < 0.02, "top {top}");
    // every lit pixel is a unit normal mapped to [0, 1]³
    for p in img.pixels.iter().filter(|p| **p != Vec3::ZERO) {
        let n = *p * 2.0 - Vec3::ONE;
        assert!((n.length() - 1.0).abs() < 1e-3, "{n} is not a unit normal");
    }
}
