//! Sealed media (a glass of milk): a medium inside closed, opaque, non-emitting shapes
//! with no light within samples no light at its vertices, since no shadow ray from it
//! can arrive. The analysis finds exactly such media (closed outward-facing boundaries,
//! no light inside, camera outside), and a scene renders the same with it as with light
//! sampling at every medium vertex. A medium with `sample_emitters` false takes no
//! light sample either, and renders the same as with it.

mod common;
use common::*;
use rdr::math::Vec3;
use rdr::metrics::Image;
use rdr::{Loaded, Profile};

/// A 12×12 camera at `origin` looking at the origin, in `medium` (a `<ref>`, or empty).
fn sensor(origin: &str, fov: f32, medium: &str) -> String {
    format!(
        r#"<sensor type="perspective"><float name="fov" value="{fov}"/>
            <transform name="to_world"><lookat origin="{origin}" target="0, 0, 0" up="0, 1, 0"/></transform>
            <film type="hdrfilm"><integer name="width" value="12"/><integer name="height" value="12"/><rfilter type="box"/></film>
            {medium}</sensor>"#
    )
}

/// A unit sphere (or the `shape` given) at the origin around a scattering medium `milk`,
/// its boundary `bsdf`, under a uniform sky, the camera 4 units away (in `milk` if
/// `camera_in_milk`); `extra` is added to the scene.
fn milk_xml(shape: &str, bsdf: &str, extra: &str, camera_in_milk: bool) -> String {
    let camera_medium = if camera_in_milk { r#"<ref id="milk"/>"# } else { "" };
    format!(
        r#"<scene version="3.0.0">
          <integrator type="volpathmis"><integer name="max_depth" value="16"/></integrator>
          {}
          <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
          <medium type="homogeneous" id="milk"><rgb name="sigma_t" value="1, 2, 4"/><rgb name="albedo" value="0.95, 0.9, 0.8"/>
            <phase type="isotropic"/></medium>
          <shape type="{shape}">{bsdf}<ref name="interior" id="milk"/></shape>
          {extra}
        </scene>"#,
        sensor("0, 0, 4", 25.0, camera_medium)
    )
}

const DIELECTRIC: &str = r#"<bsdf type="dielectric"><float name="int_ior" value="1.33"/></bsdf>"#;
const ROUGH: &str = r#"<bsdf type="roughdielectric"><float name="alpha" value="0.3"/><float name="int_ior" value="1.33"/></bsdf>"#;
/// A point light at the sphere's centre.
const LIGHT_INSIDE: &str = r#"<emitter type="point"><point name="position" value="0, 0, 0"/><rgb name="intensity" value="3"/></emitter>"#;

fn load(xml: &str) -> Loaded {
    let dir = temp_dir("rdr-media-sealed");
    let path = dir.path().join("scene.xml");
    std::fs::write(&path, xml).unwrap();
    load_scene(&path, &[], Profile::Physical)
}

#[test]
fn sealed_media_are_those_no_light_sample_can_leave() {
    let cases = [
        ("dielectric sphere", milk_xml("sphere", DIELECTRIC, "", false), true),
        ("rough dielectric sphere", milk_xml("sphere", ROUGH, "", false), true),
        ("closed cube mesh", milk_xml("cube", DIELECTRIC, "", false), true),
        ("null boundary", milk_xml("sphere", r#"<bsdf type="null"/>"#, "", false), false),
        ("point light inside", milk_xml("sphere", DIELECTRIC, LIGHT_INSIDE, false), false),
        ("camera in the medium", milk_xml("sphere", DIELECTRIC, "", true), false),
        (
            "cube turned inside out",
            milk_xml(
                "cube",
                &format!(r#"{DIELECTRIC}<boolean name="flip_normals" value="true"/>"#),
                "",
                false,
            ),
            false,
        ),
        ("open rectangle", milk_xml("rectangle", DIELECTRIC, "", false), false),
        (
            "also another shape's exterior",
            milk_xml(
                "sphere",
                DIELECTRIC,
                r#"<shape type="sphere"><float name="radius" value="0.3"/><bsdf type="null"/><ref name="exterior" id="milk"/></shape>"#,
                false,
            ),
            false,
        ),
    ];
    let mut wrong = Vec::new();
    for (name, xml, sealed) in &cases {
        let found = load(xml).scene.sealed_media;
        eprintln!("{name:>30}: sealed {found:?}, expected [{sealed}]");
        if found != [*sealed] {
            wrong.push(*name);
        }
    }
    assert!(wrong.is_empty(), "sealed wrongly judged for: {wrong:?}");
}

/// `loaded` rendered with two seeds.
fn images(loaded: &Loaded, spp: u32) -> [Image; 2] {
    [render(loaded, spp, 1), render(loaded, spp, 2)]
}

/// The mean over pixels of the difference between two pairs of images (pixel by pixel,
/// so the image's own variation cancels), and its standard error.
fn pixel_difference(a: &[Image; 2], b: &[Image; 2]) -> (Vec3, Vec3) {
    let d: Vec<glam::DVec3> = a
        .iter()
        .zip(b)
        .flat_map(|(a, b)| a.pixels.iter().zip(&b.pixels).map(|(x, y)| (*x - *y).as_dvec3()))
        .collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<glam::DVec3>() / n;
    let var = d.iter().map(|p| (*p - mean) * (*p - mean)).sum::<glam::DVec3>() / (n - 1.0);
    (mean.as_vec3(), (var / n).as_vec3().map(f32::sqrt))
}

/// The difference between `loaded`'s images with the analysis's judgement and with light
/// sampled at every medium vertex ([`pixel_difference`]).
fn difference(loaded: &mut Loaded, spp: u32) -> (Vec3, Vec3) {
    let sealed = images(loaded, spp);
    loaded.scene.sealed_media.iter_mut().for_each(|s| *s = false);
    pixel_difference(&sealed, &images(loaded, spp))
}

#[test]
fn sealed_media_render_as_with_light_sampling_everywhere() {
    // a rough boundary (non-delta vertices on both sides of it), and a light inside
    // that only light sampling finds
    for (name, xml) in [
        ("rough dielectric sphere", milk_xml("sphere", ROUGH, "", false)),
        ("point light inside", milk_xml("sphere", DIELECTRIC, LIGHT_INSIDE, false)),
    ] {
        let mut loaded = load(&xml);
        let (d, se) = difference(&mut loaded, 128);
        // a medium the analysis leaves unsealed renders identically both ways
        let z = Vec3::select(se.cmpgt(Vec3::ZERO), d / se, Vec3::ZERO);
        eprintln!("{name}: analysis − light sampled everywhere {d} ± {se}, z {z}");
        assert!(z.abs().max_element() < 4.0, "{name}: the renders differ by {z} standard errors");
    }
}

/// A box of forward-scattering fog (null boundary) lit by a small area light above it
/// and a dim sky, seen from outside; the fog's `sample_emitters` as given.
fn fog_xml(sample_emitters: bool) -> String {
    format!(
        r#"<scene version="3.0.0">
          <integrator type="volpath"><integer name="max_depth" value="6"/></integrator>
          {}
          <emitter type="constant"><rgb name="radiance" value="0.1"/></emitter>
          <shape type="rectangle"><transform name="to_world"><scale value="0.4"/><rotate x="1" angle="90"/><translate y="1.5"/></transform>
            <emitter type="area"><rgb name="radiance" value="10"/></emitter></shape>
          <shape type="cube"><bsdf type="null"/>
            <medium type="homogeneous" name="interior"><rgb name="sigma_t" value="0.8, 1, 1.2"/><float name="albedo" value="0.9"/>
              <boolean name="sample_emitters" value="{sample_emitters}"/><phase type="hg"><float name="g" value="0.5"/></phase></medium>
          </shape>
        </scene>"#,
        sensor("0, 0.5, 4", 40.0, "")
    )
}

#[test]
fn fog_without_light_sampling_renders_as_with_it() {
    let (off, on) = (load(&fog_xml(false)), load(&fog_xml(true)));
    // the flag reaches the renderer through the sealed-media switch, and only there
    assert_eq!(
        (&off.scene.sealed_media[..], &on.scene.sealed_media[..]),
        (&[true][..], &[false][..])
    );
    let (d, se) = pixel_difference(&images(&off, 256), &images(&on, 256));
    let z = d / se;
    eprintln!("sample_emitters false − true: {d} ± {se}, z {z}");
    assert!(z.abs().max_element() < 4.0, "the renders differ by {z} standard errors");
}
