//! The packet passes of `intersection_test` (4×4 pixel blocks: camera rays and
//! point-light shadow rays as packets, shading points in SoA form) and of `path`
//! (camera rays and their shadow rays as packets, then each path alone) render the
//! same pixels, bit for bit, as the passes that trace every ray alone (and make
//! every camera ray alone: a block's pinhole rays are made together), for both
//! packet widths and every instruction set this CPU has. The bundled Cornell box
//! has two point lights, a refracting sphere (a generic leaf, and paths that go
//! on after the first hit) and tiles cut by the film's edge (a 4×4 block does not
//! divide 37×29); a wide filter makes the order samples are added in matter.

mod common;

use rdr::accel::wide::Isa;
use rdr::Profile;
use std::path::Path;

fn bits(img: &rdr::metrics::Image) -> Vec<[u32; 3]> {
    img.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn check(file: &Path, overrides: &[&str]) {
    let mut loaded = common::load_scene(file, overrides, Profile::Physical);
    assert!(loaded.scene.packets(), "{}: packets expected", file.display());
    assert!(loaded.scene.bvh.set_packet_width(0));
    assert!(!loaded.scene.packets());
    let alone = bits(&common::render(&loaded, 3, 5));
    for isa in Isa::all_available() {
        for w in [8, 16] {
            assert!(loaded.scene.bvh.set_isa(isa) && loaded.scene.bvh.set_packet_width(w));
            let got = bits(&common::render(&loaded, 3, 5));
            let diff = got.iter().zip(&alone).filter(|(a, b)| a != b).count();
            assert_eq!(
                diff,
                0,
                "{} {} x{w}: {diff} pixels differ from ray-by-ray",
                file.display(),
                isa.name()
            );
        }
    }
}

#[test]
fn packet_pass_matches_ray_by_ray() {
    let film = r#"{"film": {"resolution": [37, 29], "filter": {"type": "gaussian", "radius": 1.5}}}"#;
    check(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.json"), &[film]);
    if let Some(s) = common::shared() {
        check(&s.join("refs/scenes/cbox_point.json"), &[film]);
    }
}

#[test]
fn path_packet_pass_matches_ray_by_ray() {
    let over = r#"{"film": {"resolution": [37, 29], "filter": {"type": "gaussian", "radius": 1.5}},
                   "integrator": {"type": "path", "max_depth": 8}}"#;
    check(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.json"), &[over]);
    // the sky, and second segments that hit something (a floor, glass, metal): a tree
    // of one node (second segments traced as a packet), and with a row of small
    // spheres added, of several (traced ray by ray)
    let showcase = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/showcase.json");
    check(&showcase, &[over]);
    let row: Vec<String> = (0..24)
        .map(|k| {
            format!(
                r#"{{"type": "sphere", "center": [{}, 0.15, 1.2], "radius": 0.12, "material_name": "blue"}}"#,
                k as f32 * 0.3 - 3.6
            )
        })
        .collect();
    let objects = format!(
        r#"{{"objects": [{{"type": "mesh", "path": "showcase/floor.obj", "material_name": "floor"}},
            {{"type": "sphere", "center": [0.0, 0.8, 0.0], "radius": 0.8, "material_name": "glass"}}, {}]}}"#,
        row.join(", ")
    );
    check(&showcase, &[over, &objects]);
    if let Some(s) = common::shared() {
        // an area light and a glass sphere; the sky
        check(&s.join("refs/scenes/caustic_cbox.json"), &[over]);
        check(&s.join("refs/scenes/env_sphere.json"), &[over]);
        // a blend of two BSDFs (one boxed), whose vertices the sky's block drops
        let blend = r#"{"materials": {"diffuse": {"type": "blendbsdf", "weight": 0.3, "material_names": ["matte", "glossy"]},
                        "matte": {"type": "diffuse", "texture_name": "white"},
                        "glossy": {"type": "roughplastic", "texture_name": "white", "alpha": 0.2}}}"#;
        check(&s.join("refs/scenes/env_sphere.json"), &[over, blend]);
    }
}
