//! Mesh attributes (issue 17): `mesh_attribute` textures read a PLY mesh's vertex and
//! face colours.

mod common;
use common::*;
use rdr::math::Vec3;
use rdr::Profile;

/// `mesh_attribute` on a PLY quad with a colour per vertex (uchar) and per face: the
/// image seen straight on is the barycentric interpolation of the vertex colours, and
/// the face colours come back per triangle; the same scene from Mitsuba XML agrees.
#[test]
fn mesh_attribute_interpolates_ply_vertex_colours() {
    let dir = temp_dir("rdr-mesh-attribute");
    // a quad [-1, 1]² at z = 0 facing +z; vertex colours red, green, blue, white
    let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 2\nproperty list uchar int vertex_indices\n\
property float r\nproperty float g\nproperty float b\nend_header\n\
-1 -1 0 255 0 0\n1 -1 0 0 255 0\n1 1 0 0 0 255\n-1 1 0 255 255 255\n3 0 1 2 0.25 0.5 0.75\n3 0 2 3 1 0 0.5\n";
    std::fs::write(dir.path().join("quad.ply"), ply).unwrap();
    let corners = [
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::ONE,
    ];
    let pos = [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    // the expected colour at (x, y) on the quad: barycentrics in triangle (0 1 2) or (0 2 3)
    let expect = |x: f32, y: f32, face: bool| -> Vec3 {
        let tri = if y <= x { [0usize, 1, 2] } else { [0, 2, 3] };
        if face {
            return if tri[1] == 1 {
                Vec3::new(0.25, 0.5, 0.75)
            } else {
                Vec3::new(1.0, 0.0, 0.5)
            };
        }
        let p = |i: usize| glam::Vec2::new(pos[tri[i]].0, pos[tri[i]].1);
        let (a, b, c, q) = (p(0), p(1), p(2), glam::Vec2::new(x, y));
        let area = (b - a).perp_dot(c - a);
        let (l1, l2) = ((q - a).perp_dot(c - a) / area, (b - a).perp_dot(q - a) / area);
        corners[tri[0]] * (1.0 - l1 - l2) + corners[tri[1]] * l1 + corners[tri[2]] * l2
    };
    for (face, name) in [(false, "vertex_color"), (true, "face_color")] {
        // an orthographic-like view: a narrow field of view from far away, white sky, no light:
        // a diffuse of albedo = the attribute under a uniform sky of 1 reflects the albedo
        let xml = format!(
            r#"<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="2"/></integrator>
  <sensor type="perspective"><float name="fov" value="2.29"/>
    <transform name="to_world"><lookat origin="0, 0, 50" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
  </sensor>
  <shape type="ply"><string name="filename" value="quad.ply"/>
    <bsdf type="diffuse"><texture name="reflectance" type="mesh_attribute"><string name="name" value="{name}"/></texture></bsdf>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
</scene>"#
        );
        let f = dir.path().join(format!("{name}.xml"));
        std::fs::write(&f, xml).unwrap();
        let s = load_scene(&f, &[], Profile::Physical);
        let img = render(&s, 64, 1);
        let mut worst = 0.0f32;
        for py in 0..16 {
            for px in 0..16 {
                // pixel centres: the view spans [-1, 1]² (2.29° at 50 units ≈ 2 units)
                let (x, y) = ((px as f32 + 0.5) / 8.0 - 1.0, 1.0 - (py as f32 + 0.5) / 8.0);
                if (x - y).abs() < 0.2 || x.abs() > 0.85 || y.abs() > 0.85 {
                    continue; // pixels straddling the diagonal or the border
                }
                let got = img.pixels[py * 16 + px];
                worst = worst.max((got - expect(x, y, face)).abs().max_element());
            }
        }
        eprintln!("{name}: largest difference from the interpolated colours {worst:.3}");
        assert!(worst < 0.06, "{name}: the quad's colours are not the {name} ones (off by {worst})");
    }
}

/// Attributes beyond colours, by Mitsuba's PLY rules (`tint_r tint_g tint_b`:
/// vertex_tint_color; `shade_x`: the one-channel vertex_shade; per face `r g b`:
/// face_color and `rough_1`: face_rough, a rough conductor's roughness): the scene
/// converges to Mitsuba 3's image of it (tests/refs/shapes/mesh_attribute, made by
/// scripts/make_mesh_attribute_refs.py), read from its XML and from the JSON
/// `rdr convert` writes of it.
#[test]
fn mesh_attributes_of_any_name_converge_to_mitsubas_image() {
    assert!(
        converges_to_ref_beside("shapes", "mesh_attribute.xml", &[], 64),
        "the XML scene does not converge to Mitsuba's image"
    );
    let refs = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/shapes");
    let dir = temp_dir("rdr-mesh-attribute-json");
    let (json, text) = converted_to_json(&refs.join("mesh_attribute.xml"), dir.path());
    assert!(text.contains("vertex_tint_color") && text.contains(".ply"), "{text}");
    assert!(
        converges_to_ref_within(&refs, &json, "mesh_attribute", &[], 64, 2e-4),
        "the converted JSON scene does not converge to Mitsuba's image"
    );
}

/// Mitsuba 3.9's PLY reader, given this file, lists the attributes vertex_rough (1),
/// vertex_color (3), face_color (3), vertex_tint_color (3), vertex_temp (3) and
/// face_weight (1), and warns that it left out quality, w_x and w_y (2 fields).
#[test]
fn ply_attributes_are_named_as_mitsuba_names_them() {
    let ply = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
property uchar red\nproperty uchar green\nproperty uchar blue\nproperty float rough_x\nproperty int temp_0\nproperty int temp_1\n\
property int temp_2\nproperty float tint_r\nproperty float tint_g\nproperty float tint_b\nproperty float quality\n\
property float w_x\nproperty float w_y\nelement face 2\nproperty list uchar int vertex_indices\nproperty float weight_1\n\
property uchar r\nproperty uchar g\nproperty uchar b\nend_header\n\
0 0 0 255 128 0 0.5 1 2 3 0.1 0.2 0.3 7 1 2\n1 0 0 0 255 64 0.25 4 5 6 0.4 0.5 0.6 7 1 2\n0 1 0 10 20 30 0.125 7 8 9 0.7 0.8 0.9 7 1 2\n\
3 0 1 2 0.75 255 0 51\n3 2 1 0 0.5 0 0 0\n";
    let d = rdr::geometry::ply::parse_ply(ply).unwrap();
    let mut names: Vec<(&str, u8)> = d.attributes.iter().map(|a| (a.name.as_str(), a.channels)).collect();
    names.sort();
    let expected = [
        ("face_color", 3),
        ("face_weight", 1),
        ("vertex_color", 3),
        ("vertex_rough", 1),
        ("vertex_temp", 3),
        ("vertex_tint_color", 3),
    ];
    assert_eq!(names, expected);
    let get = |n: &str| &d.attributes.iter().find(|a| a.name == n).unwrap().values;
    assert_eq!(get("vertex_rough")[1], Vec3::splat(0.25), "one channel: a grey");
    assert_eq!(get("vertex_temp")[2], Vec3::new(7.0, 8.0, 9.0), "integers of no colour as they are");
    assert!(
        (get("vertex_color")[0] - Vec3::new(1.0, 128.0 / 255.0, 0.0)).abs().max_element() < 1e-6,
        "uchar colours in 255ths"
    );
    assert!(
        (get("face_color")[0] - Vec3::new(1.0, 0.0, 0.2)).abs().max_element() < 1e-6,
        "uchar 255 0 51"
    );
    assert_eq!(get("face_weight").len(), 2);
    let warned = d.warnings.join("\n");
    assert!(warned.contains("quality, w_x, w_y"), "{warned}");
}

/// What cannot be read is refused in one line naming the file and the place: an
/// attribute the mesh lacks (the error lists the ones it has), a colour with alpha (4
/// channels: Mitsuba evaluates 1 or 3), and a fifth attribute name in one scene.
#[test]
fn unreadable_mesh_attributes_are_refused() {
    let dir = temp_dir("rdr-mesh-attribute-refusals");
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
property float r\nproperty float g\nproperty float b\nproperty float a\nproperty float w_x\nelement face 1\n\
property list uchar int vertex_indices\nend_header\n0 0 0 1 0 0 1 0.5\n1 0 0 0 1 0 1 0.5\n0 1 0 0 0 1 1 0.5\n3 0 1 2\n";
    std::fs::write(dir.path().join("tri.ply"), ply).unwrap();
    let shape = |names: &[&str]| -> String {
        names
            .iter()
            .map(|n| {
                let texture = format!(r#"<texture name="reflectance" type="mesh_attribute"><string name="name" value="{n}"/></texture>"#);
                format!(r#"  <shape type="ply"><string name="filename" value="tri.ply"/><bsdf type="diffuse">{texture}</bsdf></shape>"#)
            })
            .collect::<Vec<_>>()
            .join("\n")
    };
    let cases: [(&[&str], &str); 3] = [
        (
            &["vertex_x"],
            "reads the mesh attribute vertex_x, which this object's mesh has not (it has: vertex_color, vertex_w)",
        ),
        (
            &["vertex_color"],
            "reads the mesh attribute vertex_color of 4 channels; a mesh_attribute reads 1 or 3",
        ),
        (
            &["vertex_w", "vertex_a", "vertex_b", "vertex_c", "vertex_d"],
            "read 5 mesh attributes (vertex_w, vertex_a, vertex_b, vertex_c, vertex_d); at most 4",
        ),
    ];
    for (names, expected) in cases {
        let f = dir.path().join("scene.xml");
        let sensor = r#"<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>"#;
        std::fs::write(&f, format!("<scene version=\"3.0.0\">\n{}\n{sensor}\n</scene>\n", shape(names))).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
            .args([
                "render",
                "-q",
                f.to_str().unwrap(),
                "-o",
                dir.path().join("out.exr").to_str().unwrap(),
            ])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        eprintln!("{names:?}: {}", err.trim());
        assert!(
            !out.status.success() && err.contains(expected) && err.contains("scene.xml"),
            "{names:?}: {err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
        assert!(err.contains("line ") && err.contains(", column "), "no place: {err}");
    }
}
