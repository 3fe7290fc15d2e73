//! Mitsuba XML scenes: every reference XML in `shared/refs/mitsuba/` converges to its
//! Mitsuba image (the noise-aware metric of `tests/path_tracing.rs`); the Cornell
//! boxes build the same scene from the XML as from their JSON twins; the course's
//! 0.6-dialect files load or name their missing asset; broken XML gives one-line
//! errors with file, line and column.
//!
//! Renders are made at 1/k of the resolution and compared with the reference averaged
//! over k×k blocks: with a box filter that is exact in expectation and k² cheaper.

mod common;
use common::*;
use rdr::desc::SceneDesc;
use rdr::metrics::{compare, Comparison, Image};
use rdr::{Loaded, Profile};
use std::f32::consts::PI;
use std::path::{Path, PathBuf};

fn xml_desc(path: &Path, defines: &[(&str, &str)]) -> SceneDesc {
    let d: Vec<(String, String)> = defines.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    SceneDesc::load_with_defines(path, &[], &d).unwrap_or_else(|e| panic!("{e}"))
}

/// The scene of `desc` with its film shrunk k times (the camera's vertical field of
/// view, already read, stays).
fn shrunk(mut desc: SceneDesc, k: u32) -> Loaded {
    assert!(desc.film.width.is_multiple_of(k) && desc.film.height.is_multiple_of(k));
    desc.film.width /= k;
    desc.film.height /= k;
    Loaded::build(&desc, Profile::Physical).unwrap_or_else(|e| panic!("{e}"))
}

struct Case {
    xml: &'static str,
    reference: &'static str,
    k: usize,
    spp: u32,
    /// Reference rows left out (veach's glossy band), multiples of k.
    mask: Option<(usize, usize)>,
    /// The reference times this is the image of the XML.
    scale: f32,
    /// Allowed bias beyond 5σ (veach's variance is a lower bound: heavy tails).
    slack: f64,
}

const CASES: [Case; 8] = [
    Case {
        xml: "cbox_path",
        reference: "cbox",
        k: 2,
        spp: 24,
        mask: None,
        scale: 1.0,
        slack: 2e-4,
    },
    Case {
        xml: "caustic_cbox",
        reference: "caustic_cbox",
        k: 4,
        spp: 64,
        mask: None,
        scale: 1.0,
        slack: 2e-4,
    },
    // intensity I = (17, 12, 5) is flux 4πI; the reference is the image for flux I
    Case {
        xml: "cbox_point",
        reference: "cbox_point_hq",
        k: 4,
        spp: 8,
        mask: None,
        scale: 4.0 * PI,
        slack: 2e-4,
    },
    Case {
        xml: "env_sphere",
        reference: "env_sphere",
        k: 2,
        spp: 12,
        mask: None,
        scale: 1.0,
        slack: 2e-4,
    },
    Case {
        xml: "glass_sphere",
        reference: "glass_sphere",
        k: 2,
        spp: 24,
        mask: None,
        scale: 1.0,
        slack: 2e-4,
    },
    Case {
        xml: "sphere_furnace",
        reference: "sphere_furnace",
        k: 2,
        spp: 16,
        mask: None,
        scale: 1.0,
        slack: 2e-4,
    },
    Case {
        xml: "two_spheres_path",
        reference: "two_spheres",
        k: 4,
        spp: 16,
        mask: None,
        scale: 1.0,
        slack: 2e-4,
    },
    Case {
        xml: "veach_path",
        reference: "veach",
        k: 2,
        spp: 16,
        mask: Some((194, 222)),
        scale: 1.0,
        slack: 3e-3,
    },
];

fn reference(shared: &Path, c: &Case) -> (Image, Image) {
    let mut r = read(&shared.join(format!("refs/{}.exr", c.reference)));
    let mut vr = read(&shared.join(format!("refs/{}.var.exr", c.reference)));
    if let Some((a, b)) = c.mask {
        r = r.without_rows(a, b);
        vr = vr.without_rows(a, b);
    }
    let s = c.scale;
    (scaled(&r.block_average(c.k, false), s), scaled(&vr.block_average(c.k, true), s * s))
}

fn check(label: &str, c: &Case, loaded: &Loaded, r: &(Image, Image)) -> Comparison {
    let mask = |img: Image| match c.mask {
        Some((a, b)) => img.without_rows(a / c.k, b / c.k),
        None => img,
    };
    let (x1, x2) = (mask(render(loaded, c.spp, 1)), mask(render(loaded, c.spp, 2)));
    let cmp = compare(&x1, &x2, &r.0, &r.1);
    eprintln!(
        "{label:>34}: relMSE corrected {:+.2e} ± {:.1e} (raw {:.2e}, noise {:.2e})",
        cmp.rel_mse_corrected, cmp.std_error, cmp.rel_mse_raw, cmp.rel_mse_noise
    );
    cmp
}

fn converges(c: &Comparison, slack: f64) -> bool {
    c.rel_mse_corrected.abs() < 5.0 * c.std_error + slack
}

fn fails(bad: &Comparison, good: &Comparison) -> bool {
    bad.rel_mse_corrected > 10.0 * (bad.std_error + good.std_error) + 1e-3
}

#[test]
fn every_reference_xml_converges_to_its_mitsuba_image() {
    let Some(shared) = shared() else { return };
    let mut bad = Vec::new();
    for c in &CASES {
        let path = shared.join(format!("refs/mitsuba/{}.xml", c.xml));
        let loaded = shrunk(xml_desc(&path, &[]), c.k as u32);
        let r = reference(&shared, c);
        let good = check(c.xml, c, &loaded, &r);
        if !converges(&good, c.slack) {
            bad.push(format!("{}: {good:?}", c.xml));
        }
        // deliberate mistakes the comparison must catch
        if c.xml == "cbox_point" {
            // reading intensity as flux (forgetting the 4π)
            let x1 = scaled(&render(&loaded, c.spp, 1), 1.0 / (4.0 * PI));
            let x2 = scaled(&render(&loaded, c.spp, 2), 1.0 / (4.0 * PI));
            let wrong = compare(&x1, &x2, &r.0, &r.1);
            eprintln!(
                "{:>34}: relMSE corrected {:+.2e}",
                "cbox_point, intensity as flux", wrong.rel_mse_corrected
            );
            assert!(fails(&wrong, &good), "{wrong:?}");
        }
        if c.xml == "veach_path" {
            // fov 35° along y instead of x (the reader's fov_axis ignored)
            let dir = temp_dir("rdr-xml-fov");
            let text = std::fs::read_to_string(&path).unwrap().replace(r#"value="x"/>"#, r#"value="y"/>"#);
            let p = dir.path().join("veach_y.xml");
            std::fs::write(&p, text).unwrap();
            let wrong = check("veach_path, fov_axis y", c, &shrunk(xml_desc(&p, &[]), c.k as u32), &r);
            assert!(fails(&wrong, &good), "{wrong:?}");
        }
    }
    assert!(bad.is_empty(), "not converged:\n{}", bad.join("\n"));
}

/// What an object of a built scene is, for comparisons: its triangles (corner
/// positions and shading normals) or sphere, its material and its light.
fn objects(s: &rdr::Scene) -> Vec<(Vec<[f32; 18]>, String, String)> {
    use rdr::scene::Shape;
    s.objects
        .iter()
        .map(|o| {
            let geometry = match &o.shape {
                Shape::Mesh(m) => (0..m.triangles.len())
                    .map(|i| {
                        let t = &m.triangles[i];
                        let p = m.vertices(i);
                        let n = match t.n {
                            Some(n) => n.map(|k| m.normals[k as usize]),
                            None => [(p[1] - p[0]).cross(p[2] - p[0]).normalize(); 3],
                        };
                        let mut a = [0.0; 18];
                        for c in 0..3 {
                            a[3 * c..3 * c + 3].copy_from_slice(&p[c].to_array());
                            a[9 + 3 * c..12 + 3 * c].copy_from_slice(&n[c].to_array());
                        }
                        a
                    })
                    .collect(),
                Shape::Sphere(sp) => vec![{
                    let mut a = [0.0; 18];
                    a[..3].copy_from_slice(&sp.center.to_array());
                    a[3] = sp.radius;
                    // the uv frame as a matrix (a quaternion's sign is free); RDR171's
                    // parameterisation (none) compares as the identity
                    let q = glam::Quat::from_array(sp.uv_frame.unwrap_or([0.0, 0.0, 0.0, 1.0]));
                    a[4..13].copy_from_slice(&glam::Mat3::from_quat(q).to_cols_array());
                    a
                }],
                Shape::Cylinder(c) => vec![{
                    let c = c.cylinder;
                    let mut a = [0.0; 18];
                    a[..3].copy_from_slice(&c.p0.to_array());
                    a[3..6].copy_from_slice(&c.axis.to_array());
                    a[6..9].copy_from_slice(&c.x.to_array());
                    a[9] = c.radius;
                    a
                }],
                // the transform (the grid's values are the file's)
                Shape::SdfGrid(g) => vec![{
                    let mut a = [0.0; 18];
                    a[..16].copy_from_slice(&g.to_world.to_cols_array());
                    a[16] = g.values.len() as f32;
                    a
                }],
            };
            let material = o.material.map_or("none".to_string(), |m| {
                let m = s.materials[m as usize]
                    .try_map_textures(|&t| Ok::<_, ()>(format!("{:?}", s.textures[t as usize])))
                    .unwrap();
                format!("{m:?}")
            });
            let light = o.light.map_or("none".to_string(), |l| match &s.lights[l as usize] {
                rdr::light::Light::Area(a) => format!("{:?}", a.radiance),
                _ => "other".to_string(),
            });
            (geometry, material, light)
        })
        .collect()
}

fn same_triangles(a: &[[f32; 18]], b: &[[f32; 18]]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.iter().zip(y).all(|(p, q)| (p - q).abs() <= 1e-6))
}

#[test]
fn cornell_boxes_build_the_same_scene_from_xml_and_json() {
    let Some(shared) = shared() else { return };
    for (xml, json, flux_scale) in [
        ("cbox_path", "cbox_path", 1.0),
        ("caustic_cbox", "caustic_cbox", 1.0),
        ("cbox_point", "cbox_point", 4.0 * PI),
    ] {
        let xd = xml_desc(&shared.join(format!("refs/mitsuba/{xml}.xml")), &[]);
        let jd = SceneDesc::load(&shared.join(format!("refs/scenes/{json}.json")), &[]).unwrap();
        // camera and film
        let (xc, jc) = (&xd.camera, &jd.camera);
        assert!((xc.position - jc.position).length() < 1e-6, "{xml}: camera position");
        let dir = |c: &rdr::camera::CameraParams| (c.look_at - c.position).normalize();
        assert!((dir(xc) - dir(jc)).length() < 1e-6, "{xml}: camera direction");
        assert!((xc.fov - jc.fov).abs() < 1e-4, "{xml}: fov {} vs {}", xc.fov, jc.fov);
        assert_eq!((xd.film.width, xd.film.height), (jd.film.width, jd.film.height), "{xml}: film");
        assert_eq!(format!("{:?}", xd.film.filter), format!("{:?}", jd.film.filter), "{xml}: filter");
        let (xs, js) = (
            Loaded::build(&xd, Profile::Physical).unwrap().scene,
            Loaded::build(&jd, Profile::Physical).unwrap().scene,
        );
        let (xo, mut jo) = (objects(&xs), objects(&js));
        assert_eq!(xo.len(), jo.len(), "{xml}: object count");
        for (g, m, l) in &xo {
            let i = jo
                .iter()
                .position(|(jg, _, _)| same_triangles(g, jg))
                .unwrap_or_else(|| panic!("{xml}: an XML object ({} triangles) has no JSON twin", g.len()));
            let (_, jm, jl) = jo.remove(i);
            assert_eq!(m, &jm, "{xml}: material");
            assert_eq!(l, &jl, "{xml}: light");
        }
        // point lights: Mitsuba's intensity is a 4π smaller number than rdr's flux
        let points = |s: &rdr::Scene| -> Vec<(rdr::math::Vec3, rdr::math::Vec3)> {
            s.lights
                .iter()
                .filter_map(|l| match l {
                    rdr::light::Light::Point { position, flux } => Some((*position, *flux)),
                    _ => None,
                })
                .collect()
        };
        let (xp, mut jp) = (points(&xs), points(&js));
        // a JSON scene without any point light key has RDR171's default one (flux 1 at
        // (0, 5, 0), above these closed boxes); Mitsuba has no such thing
        let json_text = std::fs::read_to_string(shared.join(format!("refs/scenes/{json}.json"))).unwrap();
        if !json_text.contains("point_light") && !json_text.contains("\"lights\"") {
            jp.retain(|&(p, f)| (p, f) != (rdr::math::Vec3::new(0.0, 5.0, 0.0), rdr::math::Vec3::ONE));
        }
        assert_eq!(xp.len(), jp.len(), "{xml}: point lights");
        for ((xpos, xf), (jpos, jf)) in xp.iter().zip(&jp) {
            assert!((*xpos - *jpos).length() < 1e-6);
            assert!(
                (*xf - *jf * flux_scale).abs().max_element() < 1e-4 * xf.max_element(),
                "{xml}: flux {xf} vs {jf}"
            );
        }
        assert_eq!(xs.environment.is_some(), js.environment.is_some());
    }
}

#[test]
fn every_course_xml_loads_or_names_its_missing_asset() {
    let Some(shared) = shared() else { return };
    let dir = shared.join("scenes/rdr171/data/mitsuba");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    files.sort();
    assert!(files.len() >= 10);
    let (mut loaded, mut missing) = (0, 0);
    for f in &files {
        match rdr::load_with_defines(f, &[], &[], Profile::Physical) {
            Ok(_) => loaded += 1,
            Err(e) => {
                let msg = e.to_string();
                let name = f.file_name().unwrap().to_string_lossy();
                assert!(!msg.contains('\n'), "{name}: {msg}");
                // the asset named in the file, and that it is absent
                let asset = msg
                    .split(['\'', ' '])
                    .find(|w| w.contains("/assets/"))
                    .unwrap_or_else(|| panic!("{name}: the error names no asset: {msg}"));
                assert!(!Path::new(asset).exists(), "{name}: {asset} exists: {msg}");
                assert!(msg.contains("No such file") && msg.contains("line "), "{name}: {msg}");
                eprintln!("{name}: {msg}");
                missing += 1;
            }
        }
    }
    eprintln!("{loaded} loaded, {missing} name a missing asset");
    assert!(loaded >= 5, "the course scenes whose assets exist load");
}

/// A scene around `body` (the sensor and a sphere are always there).
fn scene(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
  </sensor>
{body}
</scene>
"#
    )
}

#[test]
fn bad_xml_gives_one_line_errors_with_file_line_and_column() {
    let dir = temp_dir("rdr-xml-bad");
    let d = dir.path();
    std::fs::write(
        d.join("a.xml"),
        "<scene version=\"3.0.0\">\n  <include filename=\"b.xml\"/>\n</scene>\n",
    )
    .unwrap();
    std::fs::write(
        d.join("b.xml"),
        "<scene version=\"3.0.0\">\n  <include filename=\"a.xml\"/>\n</scene>\n",
    )
    .unwrap();
    rdr::imageio::write_png(&d.join("t.png"), 1, 1, &[rdr::math::Vec3::ONE]).unwrap();
    let sphere = r#"<shape type="sphere"><float name="radius" value="1"/></shape>"#;
    // (case, file text, expected "line L, column C", expected words)
    let cases: Vec<(&str, String, &str, &str)> = vec![
        ("malformed", "<scene version=\"3.0.0\">\n  <shape type=\"obj\">\n</scene>\n".into(), "line 3, column 1", "invalid XML"),
        ("no version", "<scene>\n</scene>\n".into(), "line 1, column 1", "missing version"),
        ("unknown bsdf", scene(r#"  <shape type="sphere"><bsdf type="hair"/></shape>"#), "line 6, column 24", "unsupported bsdf \"hair\" (supported: diffuse"),
        ("unknown shape", scene(r#"  <shape type="teapot"/>"#), "line 6, column 3", "unsupported shape \"teapot\" (supported: obj"),
        ("unknown emitter", scene(r#"  <emitter type="laser"/>"#), "line 6, column 3", "unsupported emitter \"laser\" (supported: point, spot, directional"),
        ("spot beam too wide", scene(r#"  <emitter type="spot"><float name="cutoff_angle" value="10"/><float name="beam_width" value="30"/></emitter>"#), "line 6, column 63", "beam_width must be in (0, cutoff_angle]"),
        ("spot cutoff as a string", scene(r#"  <emitter type="spot"><string name="cutoff_angle" value="wide"/></emitter>"#), "line 6, column 24", "expected a float, found a string"),
        ("directional both ways", scene(r#"  <emitter type="directional"><vector name="direction" value="0, -1, 0"/><transform name="to_world"><rotate x="1" angle="90"/></transform></emitter>"#), "line 6, column 3", "either direction or to_world"),
        ("directional zero", scene(r#"  <emitter type="directional"><vector name="direction" value="0, 0, 0"/></emitter>"#), "line 6, column 31", "must not be zero"),
        ("unknown integrator", scene(r#"  <integrator type="mlt"/>"#), "line 6, column 3", "unsupported integrator \"mlt\""),
        ("unknown element", scene(r#"  <shape type="sphere"><colour name="x" value="1"/></shape>"#), "line 6, column 24", "unsupported XML element <colour>"),
        ("missing $param", scene(r#"  <shape type="sphere"><float name="radius" value="$r"/></shape>"#), "line 6, column 24", "undefined parameter $r"),
        ("recursive include", "<scene version=\"3.0.0\">\n  <include filename=\"a.xml\"/>\n</scene>\n".into(), "line 2, column 3", "recursive <include>"),
        ("missing include", scene(r#"  <include filename="nowhere.xml"/>"#), "line 6, column 3", "included file"),
        ("bad rotate", scene(r#"  <shape type="sphere"><transform name="to_world"><rotate angle="90"/></transform></shape>"#), "line 6, column 51", "rotation axis cannot be zero"),
        ("bad matrix", scene(r#"  <shape type="sphere"><transform name="to_world"><matrix value="1 2 3"/></transform></shape>"#), "line 6, column 51", "9 or 16 values"),
        ("bad translate", scene(r#"  <shape type="sphere"><transform name="to_world"><translate value="1 2"/></transform></shape>"#), "line 6, column 51", "expected 1 or 3 values"),
        ("skewed sphere", scene(r#"  <shape type="sphere"><transform name="to_world"><scale x="2"/></transform></shape>"#), "line 6, column 24", "uniform scale"),
        ("missing mesh", scene(r#"  <shape type="obj"><string name="filename" value="gone.obj"/></shape>"#), "line 6, column 3", "gone.obj"),
        ("float as text", scene(r#"  <shape type="sphere"><float name="radius" value="big"/></shape>"#), "line 6, column 24", "could not parse floating point value \"big\""),
        ("string for a float", scene(r#"  <shape type="sphere"><string name="radius" value="1"/></shape>"#), "line 6, column 24", "expected a float, found a string"),
        ("fractional integer", scene(r#"  <integrator type="path"><integer name="max_depth" value="1.5"/></integrator>"#), "line 6, column 27", "could not parse integer value"),
        ("bad boolean", scene(r#"  <shape type="obj"><boolean name="face_normals" value="yes"/></shape>"#), "line 6, column 21", "must be \"true\" or \"false\""),
        ("unknown ref", scene(r#"  <shape type="sphere"><ref id="gold"/></shape>"#), "line 6, column 24", "unknown id \"gold\""),
        ("duplicate id", scene(&format!("  <bsdf type=\"diffuse\" id=\"a\"/>\n  <bsdf type=\"diffuse\" id=\"a\"/>\n  {sphere}")), "line 7, column 3", "duplicate id \"a\""),
        ("rgb in a spectrum", scene(r#"  <shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="0.1 0.2 0.3"/></bsdf></shape>"#), "line 6, column 45", "three values are not a spectrum"),
        ("unknown conductor", scene(r#"  <shape type="sphere"><bsdf type="roughconductor"><string name="material" value="Unobtainium"/></bsdf></shape>"#), "line 6, column 52", "unknown conductor \"Unobtainium\" (known: none, Ag, Al"),
        ("unknown conductor (smooth)", scene(r#"  <shape type="sphere"><bsdf type="conductor"><string name="material" value="au"/></bsdf></shape>"#), "line 6, column 47", "unknown conductor \"au\""),
        ("conductor named and given", scene(r#"  <shape type="sphere"><bsdf type="conductor"><string name="material" value="Au"/><rgb name="eta" value="1"/></bsdf></shape>"#), "line 6, column 47", "either material or eta and k"),
        ("conductor eta as a string", scene(r#"  <shape type="sphere"><bsdf type="conductor"><string name="eta" value="gold"/></bsdf></shape>"#), "line 6, column 47", "expected a colour"),
        ("twosided without a bsdf", scene(r#"  <shape type="sphere"><bsdf type="twosided"/></shape>"#), "line 6, column 24", "needs a nested <bsdf>"),
        ("bumpmap without a bsdf", scene(r#"  <shape type="sphere"><bsdf type="bumpmap"><texture type="checkerboard"/></bsdf></shape>"#), "line 6, column 24", "a bumpmap bsdf needs a nested <bsdf>"),
        ("bumpmap without a texture", scene(r#"  <shape type="sphere"><bsdf type="bumpmap"><bsdf type="diffuse"/></bsdf></shape>"#), "line 6, column 24", "needs a nested <texture>"),
        ("bumpmap scale as a string", scene(r#"  <shape type="sphere"><bsdf type="bumpmap"><string name="scale" value="big"/><texture type="checkerboard"/><bsdf type="diffuse"/></bsdf></shape>"#), "line 6, column 45", "expected a float, found a string"),
        ("normalmap without its texture", scene(r#"  <shape type="sphere"><bsdf type="normalmap"><bsdf type="diffuse"/></bsdf></shape>"#), "line 6, column 24", "needs the texture \"normalmap\""),
        ("normalmap flip as a string", scene(r#"  <shape type="sphere"><bsdf type="normalmap"><string name="flip_invalid_normals" value="no"/><texture name="normalmap" type="checkerboard"/><bsdf type="diffuse"/></bsdf></shape>"#), "line 6, column 47", "expected a boolean, found a string"),
        ("mask without a bsdf", scene(r#"  <shape type="sphere"><bsdf type="mask"><float name="opacity" value="0.5"/></bsdf></shape>"#), "line 6, column 24", "a mask bsdf needs a nested <bsdf>"),
        ("mask opacity as a string", scene(r#"  <shape type="sphere"><bsdf type="mask"><string name="opacity" value="half"/><bsdf type="diffuse"/></bsdf></shape>"#), "line 6, column 42", "expected a colour"),
        ("mask opacity above 1", scene(r#"  <shape type="sphere"><bsdf type="mask"><float name="opacity" value="2"/><bsdf type="diffuse"/></bsdf></shape>"#), "line 6, column 42", "between 0 and 1"),
        ("mask inside twosided", scene(r#"  <shape type="sphere"><bsdf type="twosided"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></bsdf></shape>"#), "line 6, column 46", "outermost"),
        ("mesh_attribute without a name", scene(r#"  <shape type="sphere"><bsdf type="diffuse"><texture name="reflectance" type="mesh_attribute"/></bsdf></shape>"#), "line 6, column 45", "needs the property \"name\""),
        ("mesh_attribute of an unknown name", scene(r#"  <shape type="sphere"><bsdf type="diffuse"><texture name="reflectance" type="mesh_attribute"><string name="name" value="uv"/></texture></bsdf></shape>"#), "line 6, column 95", "mesh attribute \"uv\" must start with \"vertex_\" or \"face_\""),
        ("mesh_attribute on a sphere", scene(r#"  <shape type="sphere"><bsdf type="diffuse"><texture name="reflectance" type="mesh_attribute"><string name="name" value="vertex_color"/></texture></bsdf></shape>"#), "line 6, column 24", "vertex_color, which this object's mesh has not"),
        ("sphere mirrored by to_world", scene(r#"  <shape type="sphere"><transform name="to_world"><scale value="-1"/></transform></shape>"#), "line 6, column 24", "(this one mirrors)"),
        ("twosided around a pane", scene(r#"  <shape type="sphere"><bsdf type="twosided"><bsdf type="thindielectric"/></bsdf></shape>"#), "line 6, column 46", "transmits light"),
        ("twosided in twosided", scene(r#"  <shape type="sphere"><bsdf type="twosided"><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf></shape>"#), "line 6, column 46", "cannot wrap another twosided"),
        ("plastic ior as rgb", scene(r#"  <shape type="sphere"><bsdf type="plastic"><rgb name="int_ior" value="1, 2, 3"/></bsdf></shape>"#), "line 6, column 45", "expected a float or the name of a material"),
        ("plastic without a coating", scene(r#"  <shape type="sphere"><bsdf type="plastic"><float name="int_ior" value="1.2"/><float name="ext_ior" value="1.2"/></bsdf></shape>"#), "line 6, column 45", "int_ior and ext_ior to differ"),
        ("plastic unknown ior", scene(r#"  <shape type="sphere"><bsdf type="plastic"><string name="int_ior" value="bk8"/></bsdf></shape>"#), "line 6, column 45", "unknown index of refraction \"bk8\""),
        ("anisotropic roughplastic", scene(r#"  <shape type="sphere"><bsdf type="roughplastic"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/></bsdf></shape>"#), "line 6, column 24", "isotropic"),
        ("roughdielectric textured", scene(r#"  <shape type="sphere"><bsdf type="roughdielectric"><texture type="checkerboard" name="specular_transmittance"/></bsdf></shape>"#), "line 6, column 53", "must be a constant colour here, not a texture"),
        ("roughdielectric distribution", scene(r#"  <shape type="sphere"><bsdf type="roughdielectric"><string name="distribution" value="phong"/></bsdf></shape>"#), "line 6, column 53", "unknown distribution \"phong\""),
        ("roughdielectric alpha_u alone", scene(r#"  <shape type="sphere"><bsdf type="roughdielectric"><float name="alpha_u" value="0.1"/></bsdf></shape>"#), "line 6, column 24", "both alpha_u and alpha_v"),
        ("negative alpha", scene(r#"  <shape type="sphere"><bsdf type="roughplastic"><float name="alpha" value="-1"/></bsdf></shape>"#), "line 6, column 50", "between 0 and 10"),
        ("principled roughness a string", scene(r#"  <shape type="sphere"><bsdf type="principled"><string name="roughness" value="low"/></bsdf></shape>"#), "line 6, column 48", "expected a colour"),
        ("principled eta as rgb", scene(r#"  <shape type="sphere"><bsdf type="principled"><rgb name="eta" value="1, 2, 3"/></bsdf></shape>"#), "line 6, column 48", "expected a float, found an rgb"),
        ("principled eta and specular", scene(r#"  <shape type="sphere"><bsdf type="principled"><float name="eta" value="1.5"/><float name="specular" value="0.5"/></bsdf></shape>"#), "line 6, column 79", "either eta or specular"),
        ("principled negative metallic", scene(r#"  <shape type="sphere"><bsdf type="principled"><float name="metallic" value="-1"/></bsdf></shape>"#), "line 6, column 48", "must not be negative"),
        ("principled with a bsdf", scene(r#"  <shape type="sphere"><bsdf type="principled"><bsdf type="diffuse"/></bsdf></shape>"#), "line 6, column 48", "cannot contain a <bsdf>"),
        ("twosided around principled glass", scene(r#"  <shape type="sphere"><bsdf type="twosided"><bsdf type="principled"><float name="spec_trans" value="1"/></bsdf></bsdf></shape>"#), "line 6, column 46", "transmits light"),
        ("principledthin eta a string", scene(r#"  <shape type="sphere"><bsdf type="principledthin"><string name="eta" value="glass"/></bsdf></shape>"#), "line 6, column 52", "expected a colour"),
        ("principledthin diff_trans beyond 2", scene(r#"  <shape type="sphere"><bsdf type="principledthin"><float name="diff_trans" value="3"/></bsdf></shape>"#), "line 6, column 52", "at most 2"),
        ("blendbsdf without weight", scene(r#"  <shape type="sphere"><bsdf type="blendbsdf"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf></shape>"#), "line 6, column 24", "needs a weight"),
        ("blendbsdf weight a string", scene(r#"  <shape type="sphere"><bsdf type="blendbsdf"><string name="weight" value="half"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf></shape>"#), "line 6, column 47", "expected a colour"),
        ("blendbsdf with one bsdf", scene(r#"  <shape type="sphere"><bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/></bsdf></shape>"#), "line 6, column 24", "two nested <bsdf>s, found 1"),
        ("blendbsdf with three bsdfs", scene(r#"  <shape type="sphere"><bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf></shape>"#), "line 6, column 125", "two nested <bsdf>s, found 3"),
        ("negative radiance", scene(r#"  <emitter type="constant"><rgb name="radiance" value="-1"/></emitter>"#), "line 6, column 28", "must not be negative"),
        ("cylinder radius as a string", scene(r#"  <shape type="cylinder"><string name="radius" value="1"/></shape>"#), "line 6, column 26", "expected a float, found a string"),
        ("cylinder p0 = p1", scene(r#"  <shape type="cylinder"><point name="p1" value="0, 0, 0"/></shape>"#), "line 6, column 26", "must differ from p0"),
        ("cylinder negative radius", scene(r#"  <shape type="cylinder"><float name="radius" value="-2"/></shape>"#), "line 6, column 26", "must be positive"),
        ("cylinder skewed", scene(r#"  <shape type="cylinder"><transform name="to_world"><scale x="2"/></transform></shape>"#), "line 6, column 26", "uniform across its axis"),
        ("instance of an unknown shapegroup", scene(r#"  <shape type="instance"><ref id="nope"/></shape>"#), "line 6, column 26", "unknown id \"nope\""),
        ("instance without a shapegroup", scene(r#"  <shape type="instance"/>"#), "line 6, column 3", "needs a <ref> to a shapegroup"),
        ("instance of a sphere", scene(r#"  <shape type="sphere" id="s"/><shape type="instance"><ref id="s"/></shape>"#), "line 6, column 55", "must refer to a shapegroup"),
        ("instance matrix as a string", scene(r#"  <shape type="shapegroup" id="g"><shape type="sphere"/></shape><shape type="instance"><ref id="g"/><string name="to_world" value="1"/></shape>"#), "line 6, column 101", "expected a transform"),
        ("shapegroup without an id", scene(r#"  <shape type="shapegroup"><shape type="sphere"/></shape>"#), "line 6, column 3", "needs an \"id\""),
        ("emitter in a shapegroup", scene(r#"  <shape type="shapegroup" id="g"><shape type="sphere"><emitter type="area"/></shape></shape>"#), "line 6, column 56", "emitters inside a shapegroup"),
        ("nested instancing", scene(r#"  <shape type="shapegroup" id="g"><shape type="instance"><ref id="g"/></shape></shape>"#), "line 6, column 35", "nested instancing"),
        ("unknown sensor", "<scene version=\"3.0.0\">\n  <sensor type=\"fisheye\">\n    <float name=\"fov\" value=\"40\"/>\n  </sensor>\n</scene>\n".into(), "line 2, column 3", "unsupported sensor \"fisheye\" (supported: perspective, thinlens, orthographic)"),
        ("thinlens without aperture", "<scene version=\"3.0.0\">\n  <sensor type=\"thinlens\">\n    <float name=\"focus_distance\" value=\"3\"/>\n  </sensor>\n</scene>\n".into(), "line 2, column 3", "needs the property \"aperture_radius\""),
        ("thinlens aperture as a string", "<scene version=\"3.0.0\">\n  <sensor type=\"thinlens\">\n    <string name=\"aperture_radius\" value=\"wide\"/>\n  </sensor>\n</scene>\n".into(), "line 3, column 5", "expected a float, found a string"),
        ("thinlens negative aperture", "<scene version=\"3.0.0\">\n  <sensor type=\"thinlens\">\n    <float name=\"aperture_radius\" value=\"-1\"/>\n  </sensor>\n</scene>\n".into(), "line 3, column 5", "must be at least 0"),
        ("thinlens focus as a string", "<scene version=\"3.0.0\">\n  <sensor type=\"thinlens\">\n    <float name=\"aperture_radius\" value=\"0.1\"/><string name=\"focus_distance\" value=\"far\"/>\n  </sensor>\n</scene>\n".into(), "line 3, column 48", "expected a float, found a string"),
        ("near_clip negative", "<scene version=\"3.0.0\">\n  <sensor type=\"perspective\">\n    <float name=\"near_clip\" value=\"-1\"/>\n  </sensor>\n</scene>\n".into(), "line 3, column 5", "must be a finite distance of at least 0"),
        ("far_clip before near_clip", "<scene version=\"3.0.0\">\n  <sensor type=\"perspective\">\n    <float name=\"near_clip\" value=\"2\"/><float name=\"far_clip\" value=\"1\"/>\n  </sensor>\n</scene>\n".into(), "line 3, column 40", "must be greater than near_clip (2)"),
        ("near_clip as a string", "<scene version=\"3.0.0\">\n  <sensor type=\"perspective\">\n    <string name=\"near_clip\" value=\"close\"/>\n  </sensor>\n</scene>\n".into(), "line 3, column 5", "expected a float, found a string"),
        ("thinlens zero focus", "<scene version=\"3.0.0\">\n  <sensor type=\"thinlens\">\n    <float name=\"aperture_radius\" value=\"0.1\"/><float name=\"focus_distance\" value=\"0\"/>\n  </sensor>\n</scene>\n".into(), "line 3, column 48", "must be positive"),
        ("thinlens scaled", "<scene version=\"3.0.0\">\n  <sensor type=\"thinlens\">\n    <float name=\"aperture_radius\" value=\"0.1\"/><transform name=\"to_world\"><scale value=\"2\"/></transform>\n  </sensor>\n</scene>\n".into(), "line 3, column 48", "cannot scale"),
        ("orthographic anisotropic", "<scene version=\"3.0.0\">\n  <sensor type=\"orthographic\">\n    <transform name=\"to_world\"><scale x=\"1\" y=\"2\"/></transform>\n  </sensor>\n</scene>\n".into(), "line 3, column 5", "scaled differently in x"),
        ("bitmap filter_type unknown", scene(r#"  <shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="t.png"/><string name="filter_type" value="ewa"/></texture></bsdf></shape>"#), "line 6, column 126", "unknown filter_type \"ewa\" (bilinear, nearest)"),
        ("bitmap raw as a string", scene(r#"  <shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="t.png"/><string name="raw" value="yes"/></texture></bsdf></shape>"#), "line 6, column 126", "expected a boolean"),
        ("orthographic to_world as a float", "<scene version=\"3.0.0\">\n  <sensor type=\"orthographic\">\n    <float name=\"to_world\" value=\"2\"/>\n  </sensor>\n</scene>\n".into(), "line 3, column 5", "expected a transform"),
    ];
    let mut failures = Vec::new();
    for (name, text, at, words) in &cases {
        let file = d.join(format!("{}.xml", name.replace(['$', ' '], "_")));
        let file = if *name == "recursive include" { d.join("a.xml") } else { file };
        if *name != "recursive include" {
            std::fs::write(&file, text).unwrap();
        }
        let msg = match rdr::load_with_defines(&file, &[], &[], Profile::Physical) {
            Ok(_) => {
                failures.push(format!("{name}: accepted"));
                continue;
            }
            Err(e) => e.to_string(),
        };
        let ok = !msg.contains('\n') && msg.contains(&format!(".xml: {at}: ")) && msg.contains(words);
        eprintln!("{name:>20}: {msg}");
        if !ok {
            failures.push(format!("{name}: expected '{at}' and '{words}', got: {msg}"));
        }
    }
    // through the binary: exit status 1 and one `error:` line
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["render", "-q"])
        .arg(d.join("unknown_bsdf.xml"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("error: ") && err.contains("line 6, column 24"), "{err}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn structure_defaults_defines_includes_paths_refs_and_aliases() {
    let dir = temp_dir("rdr-xml-structure");
    let d = dir.path();
    std::fs::create_dir(d.join("meshes")).unwrap();
    std::fs::create_dir(d.join("parts")).unwrap();
    std::fs::write(d.join("meshes/tri.obj"), "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(
        d.join("parts/materials.xml"),
        r#"<scene version="3.0.0"><bsdf type="diffuse" id="grey"><rgb name="reflectance" value="$albedo"/></bsdf></scene>"#,
    )
    .unwrap();
    let main = r#"<scene version="3.0.0">
  <path value="meshes"/>
  <default name="albedo" value="0.25"/>
  <default name="spp" value="3"/>
  <include filename="parts/materials.xml"/>
  <alias id="grey" as="matte"/>
  <integrator type="direct"/>
  <sensor type="perspective">
    <float name="fov" value="90"/>
    <transform name="to_world"><translate z="-1"/><rotate y="1" angle="180"/><translate z="5"/></transform>
    <film type="hdrfilm"><integer name="width" value="20"/><integer name="height" value="10"/></film>
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
  </sensor>
  <shape type="obj"><string name="filename" value="tri.obj"/><ref id="matte"/></shape>
  <shape type="obj"><string name="filename" value="tri.obj"/><ref name="bsdf" id="grey"/></shape>
</scene>
"#;
    std::fs::write(d.join("main.xml"), main).unwrap();
    let desc = xml_desc(&d.join("main.xml"), &[("spp", "7")]);
    assert_eq!(desc.integrator.spp, 7, "-D wins over <default>");
    assert_eq!(desc.materials.len(), 1, "one material, referenced twice and through an alias");
    assert_eq!(desc.objects.len(), 2);
    let rdr::material::Material::Diffuse {
        texture: rdr::desc::TextureRef::Color(c),
        ..
    } = &desc.materials[0].material
    else {
        panic!("{:?}", desc.materials[0])
    };
    assert_eq!(*c, rdr::math::Vec3::splat(0.25), "the included file sees the includer's <default>");
    // translate(0,0,−1), then a half turn about y, then translate(0,0,5): the camera
    // sits at (0,0,6) looking down −z; fov 90 along x on a 2:1 film
    assert!(
        (desc.camera.position - rdr::math::Vec3::new(0.0, 0.0, 6.0)).length() < 1e-5,
        "{:?}",
        desc.camera.position
    );
    assert!((desc.camera.look_at - desc.camera.position - rdr::math::Vec3::NEG_Z).length() < 1e-5);
    let vfov = 2.0 * (0.5f32).atan().to_degrees();
    assert!((desc.camera.fov - vfov).abs() < 1e-3, "{} vs {vfov}", desc.camera.fov);
    // the mesh was found through <path>
    let loaded = Loaded::build(&desc, Profile::Physical).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(loaded.scene.objects.len(), 2);
    assert!(
        matches!(loaded.job.integrator, rdr::integrator::Integrator::Path(p) if p.max_depth == 2),
        "direct = path with max_depth 2"
    );
    // Mitsuba's default filter: a gaussian of stddev 0.5 cut at 2 pixels
    assert_eq!(
        format!("{:?}", desc.film.filter),
        format!("{:?}", rdr::film::Filter::gaussian(2.0, 2.0))
    );
}

/// A small bumpy grid: (positions, normals, uvs, triangles).
/// Positions, normals, uvs, triangles.
type Grid = (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<[f32; 2]>, Vec<[u32; 3]>);

fn grid() -> Grid {
    let (mut p, mut n, mut uv, mut t) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for j in 0..4 {
        for i in 0..4 {
            let (x, y) = (i as f32 / 3.0, j as f32 / 3.0);
            p.push([x, y, 0.1 * ((3 * i + 5 * j) % 7) as f32]);
            let nn = rdr::math::Vec3::new(0.1 * i as f32, -0.2, 1.0).normalize();
            n.push(nn.to_array());
            uv.push([x, y * 0.5]);
        }
    }
    for j in 0..3u32 {
        for i in 0..3u32 {
            let a = 4 * j + i;
            t.push([a, a + 1, a + 5]);
            t.push([a, a + 5, a + 4]);
        }
    }
    (p, n, uv, t)
}

fn obj_text(normals: bool, uvs: bool) -> String {
    let (p, n, uv, t) = grid();
    let mut s = String::new();
    for v in &p {
        s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
    }
    if normals {
        for v in &n {
            s += &format!("vn {} {} {}\n", v[0], v[1], v[2]);
        }
    }
    if uvs {
        for v in &uv {
            s += &format!("vt {} {}\n", v[0], v[1]);
        }
    }
    for f in &t {
        let c = |i: u32| match (uvs, normals) {
            (false, false) => format!("{}", i + 1),
            (true, false) => format!("{0}/{0}", i + 1),
            (false, true) => format!("{0}//{0}", i + 1),
            (true, true) => format!("{0}/{0}/{0}", i + 1),
        };
        s += &format!("f {} {} {}\n", c(f[0]), c(f[1]), c(f[2]));
    }
    s
}

/// The grid as PLY: `format` ascii, binary_little_endian or binary_big_endian.
fn ply_bytes(format: &str, normals: bool, uvs: bool) -> Vec<u8> {
    let (p, n, uv, t) = grid();
    let mut h = format!(
        "ply\nformat {format} 1.0\ncomment made by rdr's tests\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        p.len()
    );
    if normals {
        h += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    if uvs {
        h += "property float u\nproperty float v\n";
    }
    h += &format!("element face {}\nproperty list uchar int vertex_indices\nend_header\n", t.len());
    let mut out = h.into_bytes();
    let big = format == "binary_big_endian";
    let put = |out: &mut Vec<u8>, x: f32| {
        if format == "ascii" {
            out.extend_from_slice(format!("{x} ").as_bytes());
        } else if big {
            out.extend_from_slice(&x.to_be_bytes());
        } else {
            out.extend_from_slice(&x.to_le_bytes());
        }
    };
    for i in 0..p.len() {
        let mut vals: Vec<f32> = p[i].to_vec();
        if normals {
            vals.extend(n[i]);
        }
        if uvs {
            vals.extend(uv[i]);
        }
        for v in vals {
            put(&mut out, v);
        }
        if format == "ascii" {
            out.push(b'\n');
        }
    }
    for f in &t {
        if format == "ascii" {
            out.extend_from_slice(format!("3 {} {} {}\n", f[0], f[1], f[2]).as_bytes());
        } else {
            out.push(3);
            for i in f {
                out.extend_from_slice(&if big {
                    (*i as i32).to_be_bytes()
                } else {
                    (*i as i32).to_le_bytes()
                });
            }
        }
    }
    out
}

/// A one-shape scene of `shape` (its inner XML given) in `dir`.
fn mesh_scene(dir: &Path, name: &str, shape: &str) -> PathBuf {
    let p = dir.join(format!("{name}.xml"));
    std::fs::write(&p, scene(&format!("  <shape {shape}</shape>"))).unwrap();
    p
}

/// Triangles of the one object of a scene, with their uvs.
/// Triangles (corners and normals) and their uvs.
type MeshOf = (Vec<[f32; 18]>, Vec<[f32; 6]>);

fn mesh_of(path: &Path) -> Result<MeshOf, String> {
    let loaded = rdr::load_with_defines(path, &[], &[], Profile::Physical).map_err(|e| e.to_string())?;
    let tris = objects(&loaded.scene).remove(0).0;
    let rdr::scene::Shape::Mesh(m) = &loaded.scene.objects[0].shape else {
        panic!()
    };
    let uvs = m
        .triangles
        .iter()
        .map(|t| {
            let mut a = [0.0; 6];
            if let Some(uv) = t.uv {
                for c in 0..3 {
                    a[2 * c..2 * c + 2].copy_from_slice(&m.uvs[uv[c] as usize].to_array());
                }
            }
            a
        })
        .collect();
    Ok((tris, uvs))
}

#[test]
fn ply_and_serialized_meshes_give_the_triangles_of_the_same_obj() {
    let dir = temp_dir("rdr-xml-meshes");
    let d = dir.path();
    for (normals, uvs) in [(false, false), (true, false), (false, true), (true, true)] {
        let tag = format!("n{}uv{}", normals as u8, uvs as u8);
        std::fs::write(d.join(format!("{tag}.obj")), obj_text(normals, uvs)).unwrap();
        let obj = mesh_of(&mesh_scene(
            d,
            &format!("{tag}_obj"),
            &format!(r#"type="obj"><string name="filename" value="{tag}.obj"/>"#),
        ))
        .unwrap();
        assert_eq!(obj.0.len(), 18);
        for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
            let file = format!("{tag}_{format}.ply");
            std::fs::write(d.join(&file), ply_bytes(format, normals, uvs)).unwrap();
            // flip_tex_coords as the OBJ reader does by default
            let shape = format!(r#"type="ply"><string name="filename" value="{file}"/><boolean name="flip_tex_coords" value="true"/>"#);
            let ply = mesh_of(&mesh_scene(d, &format!("{tag}_{format}"), &shape)).unwrap();
            assert!(same_triangles(&ply.0, &obj.0), "{file}: other triangles or normals than the OBJ");
            assert_eq!(ply.1, obj.1, "{file}: other texture coordinates than the OBJ");
        }
    }
    // face_normals drops the file's normals: flat like the OBJ without them
    let flat = mesh_of(&mesh_scene(
        d,
        "flat",
        r#"type="obj"><string name="filename" value="n1uv0.obj"/><boolean name="face_normals" value="true"/>"#,
    ))
    .unwrap();
    let flat_ply = mesh_of(&mesh_scene(
        d,
        "flat_ply",
        r#"type="ply"><string name="filename" value="n1uv0_ascii.ply"/><boolean name="face_normals" value="true"/>"#,
    ))
    .unwrap();
    assert!(same_triangles(&flat.0, &flat_ply.0));
    let smooth = mesh_of(&mesh_scene(
        d,
        "smooth",
        r#"type="obj"><string name="filename" value="n0uv0.obj"/>"#,
    ))
    .unwrap();
    assert!(
        !same_triangles(&flat.0, &smooth.0),
        "without face_normals a mesh without normals is smoothed"
    );

    // serialized, by rdr's own encoder: mesh 1 of 2
    let obj = rdr::geometry::obj::parse(&obj_text(true, true)).unwrap();
    let other = rdr::geometry::obj::parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let bytes = rdr::geometry::serialized::write(&[("other", &other), ("grid", &obj)]);
    std::fs::write(d.join("grid.serialized"), &bytes).unwrap();
    let shape = r#"type="serialized"><string name="filename" value="grid.serialized"/><integer name="shape_index" value="1"/>"#;
    let ser = mesh_of(&mesh_scene(d, "ser", shape)).unwrap();
    let reference = mesh_of(&mesh_scene(
        d,
        "ref",
        r#"type="ply"><string name="filename" value="n1uv1_ascii.ply"/>"#,
    ))
    .unwrap();
    // both keep Mitsuba's v, which rdr turns around
    assert!(same_triangles(&ser.0, &reference.0));
    assert_eq!(ser.1, reference.1);

    // broken files: one line naming the shape's line and column and the file
    std::fs::write(d.join("short.ply"), &ply_bytes("binary_little_endian", true, true)[..400]).unwrap();
    let mut lying = ply_bytes("ascii", false, false);
    let text = String::from_utf8(lying.clone())
        .unwrap()
        .replace("element vertex 16", "element vertex 1600000");
    lying = text.into_bytes();
    std::fs::write(d.join("lying.ply"), lying).unwrap();
    std::fs::write(d.join("headless.ply"), b"ply\nformat ascii 1.0\nelement vertex 3\n").unwrap();
    std::fs::write(d.join("cut.serialized"), &bytes[..bytes.len() * 2 / 3]).unwrap();
    for (file, kind, words) in [
        ("short.ply", "ply", "more than the 113 bytes of the body"),
        ("lying.ply", "ply", "claims 1600000 records"),
        ("headless.ply", "ply", "end_header"),
        ("cut.serialized", "serialized", "truncated"),
    ] {
        let p = mesh_scene(
            d,
            &format!("bad_{file}"),
            &format!(r#"type="{kind}"><string name="filename" value="{file}"/>"#),
        );
        let e = mesh_of(&p).unwrap_err();
        eprintln!("{e}");
        assert!(
            !e.contains('\n') && e.contains("line 6, column 3") && e.contains(file) && e.contains(words),
            "{e}"
        );
    }
}

/// `a` and `b` with every number compared to a relative 1e-4 (the rest exactly).
fn approx_eq(a: &str, b: &str) -> bool {
    let split = |s: &str| -> Vec<String> {
        let mut out = Vec::new();
        let mut cur = String::new();
        let mut in_num = false;
        for ch in s.chars() {
            let numeric = ch.is_ascii_digit() || ch == '.' || ch == '-' || ch == 'e' && in_num;
            if numeric != in_num && !cur.is_empty() {
                out.push(std::mem::take(&mut cur));
            }
            in_num = numeric;
            cur.push(ch);
        }
        out.push(cur);
        out
    };
    let (x, y) = (split(a), split(b));
    x.len() == y.len()
        && x.iter().zip(&y).all(|(p, q)| match (p.parse::<f64>(), q.parse::<f64>()) {
            (Ok(u), Ok(v)) => (u - v).abs() <= 1e-4 * u.abs().max(v.abs()) + 1e-5,
            _ => p == q,
        })
}

/// The two descriptions build the same world and camera (within rounding).
fn assert_same_scene(label: &str, a: &SceneDesc, b: &SceneDesc) {
    let (la, lb) = (
        Loaded::build(a, Profile::Physical).unwrap_or_else(|e| panic!("{label}: {e}")),
        Loaded::build(b, Profile::Physical).unwrap_or_else(|e| panic!("{label}: {e}")),
    );
    let close = |x: &[[f32; 18]], y: &[[f32; 18]]| {
        x.len() == y.len()
            && x.iter()
                .zip(y)
                .all(|(p, q)| p.iter().zip(q).all(|(u, v)| (u - v).abs() <= 1e-5 * (1.0 + u.abs())))
    };
    let (oa, mut ob) = (objects(&la.scene), objects(&lb.scene));
    assert_eq!(oa.len(), ob.len(), "{label}: object count");
    for (g, m, l) in &oa {
        let i = ob
            .iter()
            .position(|(h, n, k)| close(g, h) && approx_eq(m, n) && approx_eq(l, k))
            .unwrap_or_else(|| panic!("{label}: an object ({} triangles, {m}, light {l}) has no twin", g.len()));
        ob.remove(i);
    }
    let lights = |s: &rdr::Scene| {
        s.lights
            .iter()
            .filter_map(|l| match l {
                rdr::light::Light::Point { position, flux } => Some(format!("{position:?} {flux:?}")),
                _ => None,
            })
            .collect::<Vec<_>>()
            .join(";")
    };
    assert!(
        approx_eq(&lights(&la.scene), &lights(&lb.scene)),
        "{label}: point lights {} vs {}",
        lights(&la.scene),
        lights(&lb.scene)
    );
    let env = |d: &SceneDesc| {
        d.environment_map.as_ref().map(|e| {
            let t = &d.textures.iter().find(|t| t.name == e.texture.value).unwrap().texture;
            match t {
                rdr::texture::Texture::Constant(c) => format!("constant {:?} {:?}", *c * e.scale, e.transform),
                rdr::texture::Texture::Image(i) => {
                    let p = d.base_dir.join(&i.path.value).canonicalize().unwrap();
                    format!("image {} {} {:?}", p.display(), e.scale, e.transform)
                }
                other => format!("{other:?}"),
            }
        })
    };
    assert_eq!(env(a).is_some(), env(b).is_some(), "{label}: environment");
    if let (Some(x), Some(y)) = (env(a), env(b)) {
        assert!(approx_eq(&x, &y), "{label}: environment {x} vs {y}");
    }
    let (ca, cb) = (&a.camera, &b.camera);
    let dir = |c: &rdr::camera::CameraParams| (c.look_at - c.position).normalize();
    assert!(
        (ca.position - cb.position).length() < 1e-4 && (dir(ca) - dir(cb)).length() < 1e-5 && (ca.fov - cb.fov).abs() < 1e-4,
        "{label}: camera"
    );
    assert_eq!(
        (a.film.width, a.film.height, a.integrator.spp),
        (b.film.width, b.film.height, b.integrator.spp),
        "{label}: film, spp"
    );
    assert!(
        approx_eq(&format!("{:?}", a.film.filter), &format!("{:?}", b.film.filter)),
        "{label}: filter"
    );
    let (ia, ib) = (format!("{:?}", la.job.integrator), format!("{:?}", lb.job.integrator));
    use rdr::integrator::Integrator::{IntersectionTest, Path as P};
    let direct =
        matches!((la.job.integrator, lb.job.integrator), (IntersectionTest(_), P(p)) | (P(p), IntersectionTest(_)) if p.max_depth == 2);
    assert!(approx_eq(&ia, &ib) || direct, "{label}: integrator {ia} vs {ib}");
}

fn convert(input: &Path, output: &Path) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["convert", "-q"])
        .arg(input)
        .arg("-o")
        .arg(output)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "convert {}: {}",
        input.display(),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn convert_round_trips_json_xml_json_and_xml_json_xml() {
    let Some(shared) = shared() else { return };
    let dir = temp_dir("rdr-convert");
    let d = dir.path();
    for c in &CASES {
        // JSON → XML → JSON
        let json = shared.join(format!("refs/scenes/{}.json", c.xml));
        let (x, y) = (d.join(format!("{}_a.xml", c.xml)), d.join(format!("{}_b.json", c.xml)));
        convert(&json, &x);
        convert(&x, &y);
        let original = SceneDesc::load(&json, &[]).unwrap();
        // a JSON without point light keys has the format's default light; the XML says it explicitly
        assert_same_scene(&format!("{} JSON → XML", c.xml), &original, &xml_desc(&x, &[]));
        assert_same_scene(
            &format!("{} JSON → XML → JSON", c.xml),
            &original,
            &SceneDesc::load(&y, &[]).unwrap(),
        );
        // XML → JSON → XML
        let xml = shared.join(format!("refs/mitsuba/{}.xml", c.xml));
        let (j, z) = (d.join(format!("{}_c.json", c.xml)), d.join(format!("{}_d.xml", c.xml)));
        convert(&xml, &j);
        convert(&j, &z);
        let original = xml_desc(&xml, &[]);
        assert_same_scene(&format!("{} XML → JSON", c.xml), &original, &SceneDesc::load(&j, &[]).unwrap());
        assert_same_scene(&format!("{} XML → JSON → XML", c.xml), &original, &xml_desc(&z, &[]));
    }
    // the point light's flux 4πI in JSON is Mitsuba's intensity I
    let text = std::fs::read_to_string(d.join("cbox_point_c.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let flux = v["integrator"]["lights"][0]["flux"][0].as_f64().unwrap();
    assert!((flux - 17.0 * 4.0 * std::f64::consts::PI).abs() < 1e-3, "{flux}");
    let text = std::fs::read_to_string(d.join("cbox_point_a.xml")).unwrap();
    assert!(text.contains(&format!("value=\"{}, ", 17.0f32 / (4.0 * PI))), "{text}");
}

#[test]
fn tent_filter_from_xml_and_json() {
    let f = rdr::film::Filter::Tent { radius: 1.0 };
    assert_eq!(f.eval(0.0, 0.0), 1.0);
    assert_eq!(f.eval(0.5, 0.0), 0.5);
    assert_eq!(f.eval(0.5, -0.5), 0.25);
    assert_eq!(f.eval(1.0, 0.0), 0.0);
    assert_eq!(f.eval(1.5, 0.0), 0.0);
    let v = serde_json::json!({
        "integrator": {"type": "path", "spp": 1, "lights": []},
        "film": {"resolution": [4, 4], "filter": {"type": "tent", "radius": 1.5}},
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "objects": []
    });
    let d = SceneDesc::from_value(&v, Path::new("t.json"), Path::new(".")).unwrap();
    assert_eq!(
        format!("{:?}", d.film.filter),
        format!("{:?}", rdr::film::Filter::Tent { radius: 1.5 })
    );
}

fn material_refs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/materials")
}

#[test]
fn mitsuba_material_scenes_build_the_same_scene_as_their_json_twins() {
    for name in [
        "conductor",
        "conductor_cu",
        "thindielectric",
        "roughdielectric",
        "plastic",
        "roughplastic",
        "twosided",
        "principled_coat",
        "principled_sheen_coat",
        "principled_glass",
        "principledthin",
        "blendbsdf",
    ] {
        let dir = material_refs();
        let xml = xml_desc(&dir.join(format!("{name}.xml")), &[("spp", "64")]);
        let json = SceneDesc::load(&dir.join(format!("{name}.json")), &[]).unwrap();
        assert_same_scene(name, &xml, &json);
    }
}

/// A scene of one sphere with `bsdf` in XML, and its JSON twin with `material`.
fn one_sphere(bsdf: &str, material: serde_json::Value) -> (SceneDesc, SceneDesc) {
    let dir = temp_dir("rdr-xml-material");
    let file = dir.path().join("s.xml");
    std::fs::write(
        &file,
        format!(
            r#"<scene version="3.0.0">
  <integrator type="path"/>
  <sensor type="perspective">
    <float name="fov" value="40"/><string name="fov_axis" value="y"/>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/><rfilter type="box"/></film>
  </sensor>
  <shape type="sphere"><point name="center" x="0" y="0" z="3"/>{bsdf}</shape>
</scene>
"#
        ),
    )
    .unwrap();
    let xml = xml_desc(&file, &[]);
    let v = serde_json::json!({
        "integrator": {"type": "path", "spp": 4, "max_depth": 1024, "lights": []},
        "film": {"resolution": [8, 8], "filter": {"type": "box"}},
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "ref_up": [0, 1, 0], "fov": 40},
        "textures": {
            "half": {"type": "constant", "color": [0.5, 0.5, 0.5]},
            "white": {"type": "constant", "color": [1, 1, 1]},
            // Mitsuba's default checkerboard, its v turned to rdr's
            "checks": {"type": "checkerboard", "color0": [0.4, 0.4, 0.4], "color1": [0.2, 0.2, 0.2],
                       "tex_coordinate_generator": {"type": "uvmapping2d", "scale": [1, -1], "delta": [0, 1]}}
        },
        "materials": {"m": material, "plain": {"type": "conductor"}},
        "objects": [{"type": "sphere", "center": [0, 0, 3], "radius": 1, "material_name": "m"}]
    });
    let json = SceneDesc::from_value(&v, Path::new("t.json"), Path::new(".")).unwrap_or_else(|e| panic!("{e}"));
    (xml, json)
}

#[test]
fn mitsuba_material_defaults_and_names() {
    use serde_json::json;
    let (bk7, air, pp) = (1.5046f32, 1.000277f32, 1.49f32);
    // Mitsuba's (bsdf, the same in rdr's JSON)
    let cases = [
        ("<bsdf type=\"conductor\"/>", json!({"type": "conductor", "eta": [0, 0, 0], "k": [1, 1, 1]})),
        (
            "<bsdf type=\"conductor\"><string name=\"material\" value=\"none\"/><rgb name=\"specular_reflectance\" value=\"0.5\"/></bsdf>",
            json!({"type": "conductor", "texture_name": "half"}),
        ),
        ("<bsdf type=\"thindielectric\"/>", json!({"type": "thindielectric", "eta": bk7 / air})),
        (
            "<bsdf type=\"thindielectric\"><string name=\"int_ior\" value=\"water\"/><float name=\"ext_ior\" value=\"1\"/><rgb name=\"specular_transmittance\" value=\"0.5\"/></bsdf>",
            json!({"type": "thindielectric", "eta": 1.333, "T": [0.5, 0.5, 0.5]}),
        ),
        (
            "<bsdf type=\"roughdielectric\"/>",
            json!({"type": "roughdielectric", "eta": bk7 / air, "alpha_x": 0.1, "alpha_y": 0.1, "distribution": "beckmann"}),
        ),
        (
            "<bsdf type=\"roughdielectric\"><float name=\"alpha_u\" value=\"0.1\"/><float name=\"alpha_v\" value=\"0.3\"/><string name=\"distribution\" value=\"ggx\"/><float name=\"int_ior\" value=\"1.33\"/></bsdf>",
            json!({"type": "roughdielectric", "eta": 1.33 / air, "alpha_x": 0.1, "alpha_y": 0.3, "distribution": "ggx"}),
        ),
        ("<bsdf type=\"plastic\"/>", json!({"type": "plastic", "eta": pp / air, "nonlinear": false})),
        (
            "<bsdf type=\"plastic\"><texture type=\"checkerboard\" name=\"diffuse_reflectance\"/><boolean name=\"nonlinear\" value=\"true\"/><rgb name=\"specular_reflectance\" value=\"0.5\"/></bsdf>",
            json!({"type": "plastic", "eta": pp / air, "nonlinear": true, "specular_reflectance": [0.5, 0.5, 0.5], "texture_name": "checks"}),
        ),
        (
            "<bsdf type=\"roughplastic\"/>",
            json!({"type": "roughplastic", "eta": pp / air, "alpha": 0.1, "distribution": "beckmann"}),
        ),
        (
            "<bsdf type=\"twosided\"><bsdf type=\"conductor\"/></bsdf>",
            json!({"type": "twosided", "material_name": "plain"}),
        ),
        (
            "<bsdf type=\"roughconductor\"><float name=\"alpha_u\" value=\"0.2\"/><float name=\"alpha_v\" value=\"0.05\"/></bsdf>",
            // bare: one-sided, as Mitsuba's
            json!({"type": "roughconductor", "texture_name": "white", "etaT": [1e-4, 1e-4, 1e-4], "k": [1, 1, 1], "alpha_x": 0.2, "alpha_y": 0.05, "twosided": false}),
        ),
    ];
    for (bsdf, material) in cases {
        let (xml, json) = one_sphere(bsdf, material);
        assert_same_scene(bsdf, &xml, &json);
    }
    // named conductors against Mitsuba 3.9.1's scalar_rgb values for its own table
    // (mi.traverse of a conductor with material="Au" / "Cu" / "Ag" / "Al" / "Cr")
    let mitsuba = [
        ("Au", [0.14304, 0.37531, 1.442], [3.983, 2.3856, 1.6034]),
        ("Cu", [0.20101, 0.92375, 1.1022], [3.9133, 2.453, 2.1421]),
        ("Ag", [0.1553, 0.1167, 0.1384], [4.828, 3.122, 2.147]),
        ("Al", [1.658, 0.8804, 0.5212], [9.224, 6.27, 4.837]),
    ];
    for (name, eta, k) in mitsuba {
        let (xml, _) = one_sphere(
            &format!("<bsdf type=\"conductor\"><string name=\"material\" value=\"{name}\"/></bsdf>"),
            json!({"type": "conductor"}),
        );
        let m = xml.materials.iter().find(|m| m.name.starts_with("bsdf")).unwrap();
        let rdr::material::Material::Conductor { eta: e, k: kk, .. } = &m.material else {
            panic!("{name}: {:?}", m.material)
        };
        let close = |a: rdr::math::Vec3, b: [f32; 3]| (0..3).all(|i| (a[i] - b[i]).abs() <= 0.03 * b[i]);
        assert!(close(*e, eta) && close(*kk, k), "{name}: eta {e} k {kk}, Mitsuba {eta:?} {k:?}");
    }
}

#[test]
fn convert_round_trips_the_mitsuba_materials() {
    let dir = temp_dir("rdr-convert-materials");
    let d = dir.path();
    for name in [
        "conductor",
        "conductor_cu",
        "thindielectric",
        "roughdielectric",
        "plastic",
        "roughplastic",
        "twosided",
        "principled_coat",
        "principled_sheen_coat",
        "principled_glass",
        "principledthin",
        "blendbsdf",
    ] {
        let json = material_refs().join(format!("{name}.json"));
        let (x, y) = (d.join(format!("{name}_a.xml")), d.join(format!("{name}_b.json")));
        convert(&json, &x);
        convert(&x, &y);
        let original = SceneDesc::load(&json, &[]).unwrap();
        assert_same_scene(&format!("{name} JSON → XML"), &original, &xml_desc(&x, &[]));
        assert_same_scene(&format!("{name} JSON → XML → JSON"), &original, &SceneDesc::load(&y, &[]).unwrap());
        let xml = material_refs().join(format!("{name}.xml"));
        let (j, z) = (d.join(format!("{name}_c.json")), d.join(format!("{name}_d.xml")));
        convert(&xml, &j);
        convert(&j, &z);
        let original = xml_desc(&xml, &[]);
        assert_same_scene(&format!("{name} XML → JSON"), &original, &SceneDesc::load(&j, &[]).unwrap());
        assert_same_scene(&format!("{name} XML → JSON → XML"), &original, &xml_desc(&z, &[]));
    }
    // non-default parameters and a twosided around one material survive both ways
    let objects: Vec<serde_json::Value> = ["a", "b", "c", "d", "e", "f", "g", "h", "i"]
        .iter()
        .enumerate()
        .map(|(i, m)| serde_json::json!({"type": "sphere", "center": [i as f32 * 3.0, 0, 5], "radius": 1, "material_name": m}))
        .collect();
    let v = serde_json::json!({
        "integrator": {"type": "path", "spp": 4, "lights": []},
        "film": {"resolution": [8, 8], "filter": {"type": "box"}},
        "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1]},
        "textures": {"c": {"type": "checkerboard", "color0": [1, 0, 0], "color1": [0, 0, 1],
                           "tex_coordinate_generator": {"type": "uvmapping2d", "scale": [4, 2], "delta": [0.1, 0.2]}}},
        "materials": {
            "a": {"type": "roughdielectric", "R": [0.9, 0.8, 0.7], "T": [0.5, 0.6, 0.7], "eta": 1.33, "alpha_x": 0.05, "alpha_y": 0.3, "distribution": "ggx"},
            "b": {"type": "plastic", "texture_name": "c", "specular_reflectance": [0.5, 0.5, 0.5], "eta": 1.7, "nonlinear": true},
            "c": {"type": "roughplastic", "eta": 1.3, "alpha": 0.4, "distribution": "ggx"},
            "d": {"type": "conductor", "texture_name": "c", "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.1]},
            "e": {"type": "thindielectric", "R": [0.5, 1, 1], "eta": 1.2},
            "f": {"type": "twosided", "material_name": "d"},
            "g": {"type": "bumpmap", "material_name": "c", "texture_name": "c", "scale": 0.3, "use_shadowing_function": false},
            "h": {"type": "normalmap", "material_name": "b", "texture_name": "c", "flip_invalid_normals": false},
            "i": {"type": "mask", "material_name": "f", "opacity": 0.25}
        },
        "objects": objects
    });
    let json = d.join("many.json");
    std::fs::write(&json, v.to_string()).unwrap();
    let (x, y) = (d.join("many_a.xml"), d.join("many_b.json"));
    convert(&json, &x);
    convert(&x, &y);
    let original = SceneDesc::load(&json, &[]).unwrap();
    assert_same_scene("many JSON → XML", &original, &xml_desc(&x, &[]));
    assert_same_scene("many JSON → XML → JSON", &original, &SceneDesc::load(&y, &[]).unwrap());
}

/// `dir/label.xml`: `shapes` before a 32×32 camera at (0, 0, 4) under a white constant
/// sky, path traced to depth 2, rendered at `spp` through the command line.
fn render_under_white_sky(dir: &Path, label: &str, shapes: &str, spp: u32) -> rdr::imageio::RgbImage {
    let xml = format!(
        r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="2"/></integrator>
<sensor type="perspective"><float name="fov" value="40"/>
<transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
<film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/><rfilter type="box"/></film>
<sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler></sensor>
{shapes}
<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>"#
    );
    let (scene, out) = (dir.join(format!("{label}.xml")), dir.join(format!("{label}-image.exr")));
    std::fs::write(&scene, xml).unwrap();
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["render", "-q", "--spp", &spp.to_string(), "-o"])
        .arg(&out)
        .arg(&scene)
        .output()
        .unwrap();
    assert!(run.status.success(), "{label}: {}", String::from_utf8_lossy(&run.stderr));
    rdr::imageio::read_exr(&out).unwrap()
}

/// Texture orientation as Mitsuba 3 has it (checked with Mitsuba 3.9.1, `scalar_rgb`, on
/// these two scenes): a `rectangle`'s uv (0, 0) is at its (−1, −1) corner and v = 0
/// reads the image's top row, so seen from +z the image appears upside down; an OBJ
/// quad with the usual v-up coordinates (`flip_tex_coords` true) shows it upright.
/// Also renders to an `.exr` through the command line (the film-state identity once
/// tried to hash a generated mesh's empty file name).
#[test]
fn bitmap_textures_face_the_way_mitsuba_shows_them() {
    use rdr::math::Vec3;
    let dir = tempfile::tempdir().unwrap();
    // a 4×4 image: top-left red, top-right green, bottom-left blue, bottom-right white
    let (red, green, blue, white) = (
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::ONE,
    );
    let px: Vec<Vec3> = (0..16)
        .map(|i| match (i / 4 < 2, i % 4 < 2) {
            (true, true) => red,
            (true, false) => green,
            (false, true) => blue,
            (false, false) => white,
        })
        .collect();
    rdr::imageio::write_png(&dir.path().join("quad.png"), 4, 4, &px).unwrap();
    std::fs::write(
        dir.path().join("quad.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    )
    .unwrap();
    for (shape, top_left, top_right, bottom_left) in [
        (r#"<shape type="rectangle">"#, blue, white, red),
        (r#"<shape type="obj"><string name="filename" value="quad.obj"/>"#, red, green, blue),
    ] {
        let shapes = format!(
            r#"{shape}<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="quad.png"/></texture></bsdf></shape>"#
        );
        let img = render_under_white_sky(dir.path(), "quad", &shapes, 16);
        let at = |x: usize, y: usize| img.pixels[y * img.width + x];
        for (label, (x, y), want) in [
            ("top-left", (8, 8), top_left),
            ("top-right", (24, 8), top_right),
            ("bottom-left", (8, 24), bottom_left),
        ] {
            let got = at(x, y);
            // unoccluded constant sky on an albedo-1 (or 0) surface: radiance = albedo, noise aside
            assert!((got - want).abs().max_element() < 0.25, "{shape} {label}: {got} not {want}");
        }
    }
}

/// Mitsuba 0.6's `scale` texture (rdr reads it, Mitsuba 3 cannot): a bitmap scaled by
/// a colour and a checkerboard scaled by a number render as the pre-multiplied file and
/// colours do (to rounding: the factor multiplies the filtered value).
#[test]
fn scale_textures_render_as_their_premultiplied_textures() {
    use rdr::math::Vec3;
    let dir = tempfile::tempdir().unwrap();
    let (s, k) = (Vec3::new(0.5, 0.25, 1.5), 0.5f32);
    let px: Vec<Vec3> = (0..16)
        .map(|i| Vec3::new(0.2 + 0.05 * i as f32, 0.9 - 0.04 * i as f32, 0.3))
        .collect();
    let write = |name: &str, f: Vec3| {
        let scaled: Vec<Vec3> = px.iter().map(|p| *p * f).collect();
        rdr::imageio::write_exr(&dir.path().join(name), 4, 4, &scaled, rdr::imageio::ExrPixels::Float).unwrap();
    };
    write("plain.exr", Vec3::ONE);
    write("premultiplied.exr", s);
    let render = |label: &str, bitmap: &str, checks: &str| {
        let shapes = format!(
            r#"<shape type="rectangle"><transform name="to_world"><scale value="0.7"/><translate x="-0.75"/></transform>
<bsdf type="diffuse">{bitmap}</bsdf></shape>
<shape type="rectangle"><transform name="to_world"><scale value="0.7"/><translate x="0.75"/></transform>
<bsdf type="diffuse">{checks}</bsdf></shape>"#
        );
        render_under_white_sky(dir.path(), label, &shapes, 4).pixels
    };
    let checks = |c0: f32, c1: f32| {
        format!(r#"<texture type="checkerboard"><rgb name="color0" value="{c0}"/><rgb name="color1" value="{c1}"/></texture>"#)
    };
    let scaled = render(
        "scaled",
        &format!(
            r#"<texture type="scale" name="reflectance"><rgb name="scale" value="{}, {}, {}"/>
               <texture type="bitmap"><string name="filename" value="plain.exr"/></texture></texture>"#,
            s.x, s.y, s.z
        ),
        &format!(
            r#"<texture type="scale" name="reflectance"><float name="scale" value="{k}"/>{}</texture>"#,
            checks(0.8, 0.3)
        ),
    );
    let premultiplied = render(
        "premultiplied",
        r#"<texture type="bitmap" name="reflectance"><string name="filename" value="premultiplied.exr"/></texture>"#,
        &checks(0.8 * k, 0.3 * k).replace("<texture ", r#"<texture name="reflectance" "#),
    );
    let worst = scaled
        .iter()
        .zip(&premultiplied)
        .map(|(a, b)| ((*a - *b).abs() / (a.abs() + b.abs() + Vec3::splat(1e-6))).max_element())
        .fold(0.0f32, f32::max);
    let mean = scaled.iter().map(|p| p.element_sum() as f64).sum::<f64>() / (3 * scaled.len()) as f64;
    println!("largest relative difference of the scaled and pre-multiplied images: {worst:e} (mean value {mean:.3})");
    assert!(mean > 0.05, "the scaled textures' image is black");
    assert!(worst < 1e-4, "scaled textures render unlike their pre-multiplied twins: {worst}");
}

/// The film-state identity covers what an XML scene's `<include>`s read: a `--resume`
/// after an included file changed is refused (in one line naming the scene), one with
/// everything as it was goes on.
#[test]
fn resume_is_refused_when_an_included_file_changed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("main.xml"),
        r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="2"/></integrator>
<sensor type="perspective"><float name="fov" value="40"/>
<transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/><rfilter type="box"/></film>
<sampler type="independent"><integer name="sample_count" value="4"/></sampler></sensor>
<include filename="parts/ball.xml"/>
<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>"#,
    )
    .unwrap();
    std::fs::create_dir(d.join("parts")).unwrap();
    let ball = |albedo: &str| {
        std::fs::write(
            d.join("parts/ball.xml"),
            format!(r#"<scene version="3.0.0"><shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="{albedo}"/></bsdf></shape></scene>"#),
        )
        .unwrap()
    };
    ball("0.5");
    let out = d.join("out.exr");
    let render = |spp: &str, resume: bool| {
        let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"));
        c.args(["render", "-q", "--spp", spp, "-o"]).arg(&out).arg(d.join("main.xml"));
        if resume {
            c.arg("--resume");
        }
        c.output().unwrap()
    };
    let o = render("2", false);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = render("4", true);
    assert!(o.status.success(), "unchanged: {}", String::from_utf8_lossy(&o.stderr));
    ball("0.6");
    let before = std::fs::read(&out).unwrap();
    let o = render("8", true);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.lines().count() == 1 && err.contains("scene"),
        "resume after the included file changed: {} {err}",
        o.status
    );
    assert_eq!(std::fs::read(&out).unwrap(), before, "a refused resume leaves the file");
}

/// `rdr convert` of `twosided`: around a `diffuse`, a `conductor` and a `roughconductor`
/// (rdr's is two-sided, so the JSON has no wrapper and the XML written from it gets one
/// back) the round trip keeps it; around a `dielectric` (read as the dielectric alone)
/// it is lost, and the conversion says so in one line naming the element.
#[test]
fn convert_keeps_twosided_or_says_it_is_lost() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="4"/></integrator>
<sensor type="perspective"><float name="fov" value="40"/>
<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
<shape type="sphere"><bsdf type="twosided"><bsdf type="roughconductor"><float name="alpha" value="0.2"/></bsdf></bsdf></shape>
<shape type="sphere"><point name="center" value="3,0,0"/><bsdf type="twosided"><bsdf type="dielectric"/></bsdf></shape>
<shape type="sphere"><point name="center" value="6,0,0"/><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></shape>
<shape type="sphere"><point name="center" value="9,0,0"/><bsdf type="twosided"><bsdf type="conductor"/></bsdf></shape>
<emitter type="constant"/>
</scene>"#;
    std::fs::write(d.join("ts.xml"), scene).unwrap();
    let convert = |from: &str, to: &str| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
            .arg("convert")
            .arg(d.join(from))
            .arg("-o")
            .arg(d.join(to))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let err = convert("ts.xml", "ts.json");
    let notes: Vec<&str> = err.lines().filter(|l| l.contains("twosided")).collect();
    assert!(
        notes.len() == 1 && notes[0].contains("ts.xml: line 6, column") && notes[0].contains("dielectric"),
        "{err}"
    );
    let err = convert("ts.json", "back.xml");
    assert!(!err.contains("twosided"), "{err}");
    let back = std::fs::read_to_string(d.join("back.xml")).unwrap();
    let wrapped = |inner: &str| {
        back.lines()
            .any(|l| l.contains(r#"<bsdf type="twosided""#) && l.contains(&format!(r#"<bsdf type="{inner}">"#)))
    };
    for inner in ["roughconductor", "diffuse", "conductor"] {
        assert!(wrapped(inner), "{inner} lost its twosided:\n{back}");
    }
    assert!(!wrapped("dielectric"), "{back}");
    // the scene read back is the scene converted
    let a = xml_desc(&d.join("ts.xml"), &[]);
    let b = xml_desc(&d.join("back.xml"), &[]);
    assert_same_scene("twosided XML → JSON → XML", &a, &b);
}

/// Mitsuba's bitmap `filter_type` and `raw`, against what a 2×2 image must give (v = 0
/// at its top row, as Mitsuba reads a bitmap): its
/// top row black | white, its bottom row 8-bit 128 | 64. Halfway between the top
/// texels' centres `bilinear` is their mean, ½, and `nearest` the right one, 1; at the
/// bottom-left texel's centre a `raw` read is 128/255, an sRGB-decoded one 0.2158
/// (the sRGB curve). The JSON `image` texture's `filter` and `raw` say the same, and
/// `rdr convert` carries both either way.
#[test]
fn bitmap_filter_type_and_raw_are_honoured() {
    use rdr::math::{Vec2, Vec3};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let grey = |v: f32| Vec3::splat(v);
    // write_png encodes linear values to sRGB: pick the linear values of the 8-bit codes
    let code = |c: u8| {
        let v = c as f32 / 255.0;
        if v <= 0.04045 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    };
    rdr::imageio::write_png(&d.join("t.png"), 2, 2, &[grey(0.0), grey(1.0), grey(code(128)), grey(code(64))]).unwrap();
    let bitmap = |filter: &str, raw: bool| {
        format!(
            r#"<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="t.png"/><string name="filter_type" value="{filter}"/><boolean name="raw" value="{raw}"/></texture></bsdf></shape>"#
        )
    };
    let xml = scene(
        &[
            bitmap("bilinear", false),
            bitmap("nearest", false),
            bitmap("bilinear", true),
            bitmap("nearest", true),
        ]
        .join("\n"),
    );
    std::fs::write(d.join("t.xml"), xml).unwrap();
    let json = d.join("t.json");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["convert", "-q"])
        .arg(d.join("t.xml"))
        .arg("-o")
        .arg(&json)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&json).unwrap();
    assert!(text.contains(r#""filter": "nearest""#) && text.contains(r#""raw": true"#), "{text}");
    let back = d.join("back.xml");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["convert", "-q"])
        .arg(&json)
        .arg("-o")
        .arg(&back)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let srgb_128 = code(128);
    for file in [d.join("t.xml"), json, back] {
        let l = rdr::load(&file, &[], rdr::Profile::Physical).unwrap_or_else(|e| panic!("{e}"));
        let t = &l.scene.textures;
        assert_eq!(t.len(), 4, "{}", file.display());
        // (rdr's uv: v = 1 at the image's top row, the XML mapping turning Mitsuba's v)
        let at = |i: usize, u: f32, v: f32| t[i].eval(Vec2::new(u, 1.0 - v)).x;
        let expect = [
            // (texture, u, v, value): top row halfway, bottom-left centre
            (0, 0.5, 0.25, 0.5),
            (1, 0.5, 0.25, 1.0),
            (2, 0.5, 0.25, 0.5),
            (3, 0.5, 0.25, 1.0),
            (0, 0.25, 0.75, srgb_128),
            (1, 0.25, 0.75, srgb_128),
            (2, 0.25, 0.75, 128.0 / 255.0),
            (3, 0.25, 0.75, 128.0 / 255.0),
            // nearest stays on its texel up to the edge
            (1, 0.49, 0.49, 0.0),
            (1, 0.51, 0.51, code(64)),
        ];
        for (i, u, v, want) in expect {
            let got = at(i, u, v);
            assert!(
                (got - want).abs() < 2e-3,
                "{}: texture {i} at ({u}, {v}): {got}, not {want}",
                file.display()
            );
        }
    }
}

fn shape_refs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/shapes")
}

/// `file` in tests/refs/shapes rendered at `spp` (seeds 1 and 2) against Mitsuba's image.
fn converges_to_shape_ref(file: &str, spp: u32) -> bool {
    let name = file.split('.').next().unwrap();
    let s = load_scene(&shape_refs().join(file), &[], Profile::Physical);
    let (a, b) = (render(&s, spp, 1), render(&s, spp, 2));
    let c = compare(
        &a,
        &b,
        &read(&shape_refs().join(format!("{name}.exr"))),
        &read(&shape_refs().join(format!("{name}.var.exr"))),
    );
    eprintln!(
        "{file:>14}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
        c.rel_mse_corrected, c.std_error, c.rel_mse_raw, c.rel_mse_noise
    );
    c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4
}

/// Mitsuba's analytic sphere carries its uv in its object frame, `to_world`'s rotation
/// included, with v = θ/π reading the image from its top row: a textured sphere and a
/// rotated one converge to Mitsuba's image (`tests/refs/shapes/sphere_uv.*`, made by
/// `scripts/make_sphere_uv_refs.py`), and XML → JSON → XML keeps the frame.
#[test]
fn textured_spheres_turn_with_their_transform_as_in_mitsuba() {
    assert!(
        converges_to_shape_ref("sphere_uv.xml", 64),
        "textured spheres differ from Mitsuba's"
    );
    let dir = temp_dir("rdr-sphere-uv");
    let (j, x) = (dir.path().join("s.json"), dir.path().join("s.xml"));
    convert(&shape_refs().join("sphere_uv.xml"), &j);
    convert(&j, &x);
    let text = std::fs::read_to_string(&j).unwrap();
    assert_eq!(text.matches("uv_frame").count(), 2, "{text}");
    let original = xml_desc(&shape_refs().join("sphere_uv.xml"), &[]);
    assert_same_scene("sphere_uv XML → JSON", &original, &SceneDesc::load(&j, &[]).unwrap());
    assert_same_scene("sphere_uv XML → JSON → XML", &original, &xml_desc(&x, &[]));
}

/// Bare `roughconductor`, `conductor` and `plastic` are black from behind in Mitsuba,
/// a `twosided` roughconductor is not: four rectangles seen from behind converge to
/// Mitsuba's image (`tests/refs/shapes/onesided.*`), and convert keeps each side.
#[test]
fn bare_xml_conductors_and_plastics_are_one_sided_as_in_mitsuba() {
    assert!(
        converges_to_shape_ref("onesided.xml", 64),
        "one-sided materials differ from Mitsuba's"
    );
    let d = xml_desc(&shape_refs().join("onesided.xml"), &[]);
    let sided: Vec<bool> = d
        .materials
        .iter()
        .filter_map(|m| match m.material {
            rdr::material::Material::RoughConductor { twosided, .. } => Some(twosided),
            _ => None,
        })
        .collect();
    assert_eq!(sided, [false, true], "bare and wrapped roughconductor");
    let dir = temp_dir("rdr-onesided");
    let (j, x) = (dir.path().join("o.json"), dir.path().join("o.xml"));
    convert(&shape_refs().join("onesided.xml"), &j);
    convert(&j, &x);
    assert_same_scene("onesided XML → JSON", &d, &SceneDesc::load(&j, &[]).unwrap());
    assert_same_scene("onesided XML → JSON → XML", &d, &xml_desc(&x, &[]));
}

/// A sensor's `near_clip` and `far_clip` are applied (distances along the view axis, as
/// Mitsuba's): a sphere nearer than `near_clip` vanishes from the image, the wall behind
/// it shows; and `rdr convert` carries both keys to JSON and back.
#[test]
fn sensor_clipping_is_applied_and_converted() {
    let dir = temp_dir("rdr-xml-clip");
    let body = |clip: &str| {
        format!(
            r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="30"/>{clip}
    <transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, 1" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
  </sensor>
  <shape type="sphere"><point name="center" x="0" y="0" z="2"/><float name="radius" value="0.5"/>
    <emitter type="area"><rgb name="radiance" value="1, 0, 0"/></emitter></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="10"/><rotate y="1" angle="180"/><translate z="5"/></transform>
    <emitter type="area"><rgb name="radiance" value="0, 0, 1"/></emitter></shape>
</scene>
"#
        )
    };
    let centre = |xml: &str, name: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, xml).unwrap();
        let out = dir.path().join(format!("{name}.exr"));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
            .args(["render", "-q", "--spp", "4"])
            .arg(&path)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        let img = rdr::imageio::read_exr(&out).unwrap();
        (img.pixels[4 * 8 + 4], path)
    };
    let (plain, _) = centre(&body(""), "plain.xml");
    assert!(plain.x > 0.9 && plain.z < 0.1, "without clipping the sphere shows: {plain}");
    let (clipped, path) = centre(&body(r#"<float name="near_clip" value="2.6"/>"#), "near.xml");
    assert!(clipped.x < 0.1 && clipped.z > 0.9, "near_clip 2.6 hides the sphere: {clipped}");
    let (far, _) = centre(&body(r#"<float name="far_clip" value="4"/>"#), "far.xml");
    assert!(far.x > 0.9, "far_clip 4 keeps the sphere: {far}");
    let (none, _) = centre(
        &body(r#"<float name="near_clip" value="2.6"/><float name="far_clip" value="4"/>"#),
        "both.xml",
    );
    assert!(none.max_element() < 0.1, "between 2.6 and 4 nothing is seen: {none}");
    let (json, back) = (dir.path().join("near.json"), dir.path().join("near_back.xml"));
    convert(&path, &json);
    convert(&json, &back);
    assert_eq!(xml_desc(&back, &[]).camera.near_clip, 2.6);
    assert_eq!(SceneDesc::load(&json, &[]).unwrap().camera.near_clip, 2.6);
}

/// Mitsuba 3's top-level area emitters: one with an `id` that a shape refers to lights
/// that shape (Mitsuba's own `cbox` files), one nobody refers to is left out with a
/// warning, one two shapes refer to is refused (Mitsuba attaches an emitter to one shape);
/// and every scene file of `../shared/scenes/real/` loads.
#[test]
fn top_level_area_emitters_attach_to_the_shape_that_refers_to_them() {
    let dir = temp_dir("rdr-xml-area");
    let emitter = r#"<emitter type="area" id="glow"><rgb name="radiance" value="2, 3, 4"/></emitter>"#;
    let load = |name: &str, body: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, scene(body)).unwrap();
        SceneDesc::load_with_defines(&p, &[], &[])
    };
    let lit = |d: &SceneDesc| d.objects.iter().filter_map(|o| o.light.as_ref()).count();
    // referred to before it is declared, as cbox-rgb.xml's include does
    let d = load(
        "ref.xml",
        &format!(
            r#"<shape type="sphere"><ref id="glow"/></shape><shape type="sphere"><point name="center" x="3" y="0" z="0"/></shape>{emitter}"#
        ),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(lit(&d), 1, "the shape that refers to the emitter emits");
    let light = d.objects[0].light.as_ref().expect("the first sphere emits");
    assert_eq!(light.radiance, rdr::math::Vec3::new(2.0, 3.0, 4.0));
    let d = load("unreferenced.xml", &format!(r#"<shape type="sphere"/>{emitter}"#)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(lit(&d), 0);
    assert!(d.warnings.iter().any(|w| w.contains("no shape refers to")), "{:?}", d.warnings);
    let e = load(
        "twice.xml",
        &format!(r#"{emitter}<shape type="sphere"><ref id="glow"/></shape><shape type="sphere"><ref id="glow"/></shape>"#),
    )
    .expect_err("two shapes on one emitter");
    let msg = e.to_string();
    assert!(
        msg.contains("twice.xml: line 6") && msg.contains("already attached") && !msg.contains('\n'),
        "{msg}"
    );

    let Some(shared) = shared() else { return };
    let mut files: Vec<PathBuf> = std::fs::read_dir(shared.join("scenes/real"))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .flat_map(|d| std::fs::read_dir(d).unwrap().filter_map(|e| e.ok().map(|e| e.path())))
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    files.sort();
    assert!(files.len() >= 12, "{files:?}");
    for f in &files {
        let d = xml_desc(f, &[]);
        let name = f.strip_prefix(&shared).unwrap().display().to_string();
        assert!(
            lit(&d) + d.integrator.delta_lights.len() + d.environment_map.iter().count() > 0,
            "{name}: no light"
        );
        eprintln!("{name}: loaded, {} objects", d.objects.len());
    }
    let cbox = xml_desc(&shared.join("scenes/real/mitsuba-cbox/cbox-rgb.xml"), &[]);
    assert_eq!(lit(&cbox), 1, "cbox-rgb.xml: the luminaire alone emits");
}
