//! Conductors whose `eta` and `k` are textures (Mitsuba 3 reads them as textures): a
//! rough conductor rectangle and a smooth conductor sphere with bitmaps of η and k
//! converge to Mitsuba 3's image (tests/refs/materials/conductor_textured, made by
//! scripts/make_conductor_texture_refs.py), read from the XML and from the JSON
//! `rdr convert` writes of it.

mod common;
use common::*;

#[test]
fn textured_eta_and_k_converge_to_mitsubas_image() {
    assert!(
        converges_to_ref_beside("materials", "conductor_textured.xml", &[], 64),
        "the XML scene does not converge to Mitsuba's image"
    );
    let refs = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/materials");
    let dir = temp_dir("rdr-conductor-textures");
    let (json, text) = converted_to_json(&refs.join("conductor_textured.xml"), dir.path());
    assert!(
        text.contains("\"etaT\": \"") && text.contains("\"eta\": \""),
        "η is not a texture name in the JSON: {text}"
    );
    assert!(
        converges_to_ref_within(&refs, &json, "conductor_textured", &[], 64, 2e-4),
        "the converted JSON scene does not converge to Mitsuba's image"
    );
}
