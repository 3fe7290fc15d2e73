//! The manual's Mitsuba plugin table (`docs/src/mitsuba/plugins.md`) is generated from
//! the plugin readers' own rows (`src/desc/xml/plugins/`, each family's `DOCS`), which
//! the readers are held to: this test renders the page again and compares.
//! `RDR_BLESS=1 cargo test --release --test doc_mitsuba_plugins` rewrites the page after
//! a reader changes.

mod docs_common;

const PAGE: &str = "docs/src/mitsuba/plugins.md";

#[test]
fn plugin_table_matches_the_readers() {
    let fresh = rdr::desc::xml::plugins::plugin_table_markdown();
    docs_common::check_generated_page(PAGE, &fresh, "the readers' plugin table", "doc_mitsuba_plugins");
}

/// A scene reading many plugins loads: each reader keeps to its rows (a parameter read
/// that its rows do not declare, or defaulted otherwise, fails the load with an internal
/// error naming both); a plugin rdr leaves out is named in a warning.
#[test]
fn every_reader_keeps_to_its_rows() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("all.xml");
    std::fs::write(
        &file,
        r#"<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="4"/><boolean name="hide_emitters" value="true"/></integrator>
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="to_world"><scale x="-1"/><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/><rfilter type="tent"/></film>
    <sampler type="stratified"><integer name="sample_count" value="1"/></sampler>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
  <shape type="sphere"><bsdf type="roughconductor"><string name="material" value="Au"/></bsdf></shape>
  <shape type="rectangle"><bsdf type="plastic"><texture type="rawconstant" name="diffuse_reflectance"><vector name="value" value="0.1,0.2,0.3"/></texture></bsdf></shape>
  <shape type="cube"><bsdf type="mask"><float name="opacity" value="0.5"/><bsdf type="roughplastic"/></bsdf></shape>
  <shape type="cylinder"><bsdf type="principled"/><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
  <shape type="disk"><bsdf type="blendbsdf"><float name="weight" value="0.3"/><bsdf type="dielectric"/><bsdf type="thindielectric"/></bsdf></shape>
  <shape type="sdfgrid"><string name="filename" value="grid.vol"/><string name="normals" value="analytic"/></shape>
  <emitter type="timed_sunsky"/>
</scene>"#,
    )
    .unwrap();
    let desc = rdr::desc::xml::load(&file, &[]).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        desc.warnings.iter().any(|w| w.contains("timed_sunsky") && w.contains("not built")),
        "timed_sunsky is named in a warning: {:?}",
        desc.warnings
    );
}
