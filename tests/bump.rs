//! Surface detail (issue 17): `bumpmap` and `normalmap` scenes read from Mitsuba XML
//! converge to Mitsuba 3's images of them (`tests/refs/bump/`, made by
//! `scripts/make_bump_refs.py` with textures it computes).

mod common;
use common::*;

#[test]
fn bump_and_normal_maps_converge_to_mitsubas_images() {
    let failed: Vec<&str> = ["bumpmap.xml", "normalmap.xml"]
        .into_iter()
        .filter(|f| !converges_to_ref_beside("bump", f, &[], 128))
        .collect();
    assert!(failed.is_empty(), "not converging to Mitsuba: {failed:?}");
}
