//! Colours from spectra as Mitsuba 3's RGB variants make them: reflectances weighted by
//! D65 and clamped to [0, 1], emissions equal-energy (a constant one is not white),
//! `eta`/`k` weighted by D65 and unbounded, and `blackbody` spectra as a spectral
//! render converges to. The references are what Mitsuba 3.9.1 loads from the same
//! properties, printed by `scripts/make_spectrum_refs.py` (Mitsuba is not needed here).

mod common;
use common::*;
use rdr::desc::SceneDesc;
use serde_json::Value;

// made by scripts/make_spectrum_refs.py with Mitsuba 3.9.1
const MITSUBA: [(&str, [f32; 3]); 8] = [
    ("white", [0.776367, 0.77981, 0.776029]),
    ("ramp", [0.474806, 0.259538, 0.634188]),
    ("clamped", [1.0, 1.0, 0.451295]),
    ("red", [0.478094, 0.0658765, 0.0384519]),
    ("eta", [1.25177, 1.3567, 1.45155]),
    ("light", [20.7108, 10.8546, 2.77115]),
    ("flat_light", [19.3153, 15.203, 14.5717]),
    ("sky", [0.984514, 1.21667, 1.10008]),
];
const MITSUBA_BLACKBODY: [([f64; 3], [f32; 3]); 3] = [
    ([2000.0, 360.0, 830.0], [16.0144, 4.1119, 0.130416]),
    ([5000.0, 360.0, 830.0], [15263.0, 12082.5, 9592.55]),
    ([6500.0, 400.0, 700.0], [43746.7, 41459.0, 43317.1]),
];

/// (label, where, property): the list of the script.
const CASES: [(&str, &str, &str); 8] = [
    (
        "white",
        "bsdf",
        r#"<spectrum name="reflectance" value="400:0.78, 500:0.78, 600:0.78, 700:0.78"/>"#,
    ),
    (
        "ramp",
        "bsdf",
        r#"<spectrum name="reflectance" value="380:0.3, 455.5:0.7, 530:0.2, 780:0.9"/>"#,
    ),
    (
        "clamped",
        "bsdf",
        r#"<spectrum name="reflectance" value="400:0.1, 500:0.9, 600:1.4, 700:0.2"/>"#,
    ),
    (
        "red",
        "bsdf",
        r#"<spectrum name="reflectance" value="400:0.04, 560:0.067, 600:0.287, 640:0.609, 700:0.642"/>"#,
    ),
    ("eta", "conductor", r#"<spectrum name="eta" value="400:1.5, 700:1.2"/>"#),
    (
        "light",
        "area",
        r#"<spectrum name="radiance" value="400:0, 500:8, 600:15.6, 700:18.4"/>"#,
    ),
    ("flat_light", "area", r#"<spectrum name="radiance" value="16.032"/>"#),
    (
        "sky",
        "constant",
        r#"<spectrum name="radiance" value="380:0.5, 480:1.5, 780:0.25"/>"#,
    ),
];

/// The colour rdr reads for `prop` placed `where`, read back from the scene converted
/// to RDR171 JSON.
fn rdr_colour(where_: &str, prop: &str) -> [f32; 3] {
    let body = match where_ {
        "constant" => format!(r#"<emitter type="constant">{prop}</emitter>"#),
        "area" => format!(r#"<shape type="sphere"><emitter type="area">{prop}</emitter></shape>"#),
        "bsdf" => format!(r#"<shape type="sphere"><bsdf type="diffuse">{prop}</bsdf></shape>"#),
        _ => format!(r#"<shape type="sphere"><bsdf type="conductor">{prop}</bsdf></shape>"#),
    };
    let dir = temp_dir("rdr-spectra");
    let file = dir.path().join("s.xml");
    let film = r#"<film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film>"#;
    let xml = format!(r#"<scene version="3.0.0"><sensor type="perspective">{film}</sensor>{body}</scene>"#);
    std::fs::write(&file, xml).unwrap();
    let desc = SceneDesc::load_with_defines(&file, &[], &[]).unwrap_or_else(|e| panic!("{e}"));
    let out = rdr::desc::convert::to_json(&desc, &dir.path().join("s.json")).unwrap_or_else(|e| panic!("{e}"));
    let v: Value = serde_json::from_str(&out.text).unwrap();
    let colour = match where_ {
        "constant" => &v["textures"]["environment"]["color"],
        "area" => &v["objects"][0]["light"]["radiance"],
        // a diffuse colour is written inline (`albedo`), other colours as textures
        "bsdf" if v["materials"]["bsdf_1"].get("albedo").is_some() => &v["materials"]["bsdf_1"]["albedo"],
        "bsdf" => &v["textures"]["bsdf_1_color"]["color"],
        _ => &v["materials"]["bsdf_1"]["eta"],
    };
    std::array::from_fn(|i| colour[i].as_f64().unwrap_or_else(|| panic!("no colour in {colour}")) as f32)
}

/// Largest error over the components, relative to the largest component of the reference.
fn error(a: [f32; 3], reference: [f32; 3]) -> f32 {
    let scale = reference.iter().fold(0.0f32, |m, c| m.max(c.abs()));
    (0..3).map(|i| (a[i] - reference[i]).abs() / scale).fold(0.0, f32::max)
}

const TOLERANCE: f32 = 2e-4;

#[test]
fn spectra_give_mitsubas_rgb_values() {
    let mut worst = 0.0f32;
    for ((label, where_, prop), (ref_label, reference)) in CASES.iter().zip(MITSUBA) {
        assert_eq!(*label, ref_label);
        let got = rdr_colour(where_, prop);
        let e = error(got, reference);
        println!("{label:>10}: rdr {got:?}  Mitsuba {reference:?}  error {e:.2e}");
        assert!(e < TOLERANCE, "{label}: rdr {got:?}, Mitsuba {reference:?} (error {e:.2e})");
        worst = worst.max(e);
    }
    println!("largest relative error {worst:.2e}");
}

#[test]
fn blackbody_spectra_give_what_mitsubas_spectral_render_converges_to() {
    for ([kelvin, lo, hi], reference) in MITSUBA_BLACKBODY {
        let bb = format!(
            r#"<spectrum type="blackbody" name="radiance"><float name="temperature" value="{kelvin}"/><float name="wavelength_min" value="{lo}"/><float name="wavelength_max" value="{hi}"/></spectrum>"#
        );
        let got = rdr_colour("constant", &bb);
        let e = error(got, reference);
        println!("{kelvin} K ({lo}-{hi} nm): rdr {got:?}  Mitsuba {reference:?}  error {e:.2e}");
        assert!(e < TOLERANCE, "{kelvin} K: rdr {got:?}, Mitsuba {reference:?} (error {e:.2e})");
    }
}
