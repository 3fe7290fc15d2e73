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
