//! Mitsuba's `aov` integrator: it renders with its nested integrator and writes the
//! layers its `aovs` list asks for as rdr's `--aov` does (Mitsuba's types mapped to
//! rdr's layers), so the file equals a render of the bare integrator with `--aov`.

mod common;
use common::*;
use rdr::imageio::{read_exr_channels, RawExr};
use std::path::Path;
use std::process::Command;

fn scene(integrator: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
  {integrator}
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="12"/><rfilter type="box"/></film>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
  </sensor>
  <shape type="sphere"><point name="center" x="0" y="0" z="4"/><bsdf type="diffuse"><rgb name="reflectance" value="0.2 0.5 0.7"/></bsdf></shape>
  <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>
"#
    )
}

fn render(scene: &Path, out: &Path, extra: &[&str]) -> RawExr {
    let o = Command::new(env!("CARGO_BIN_EXE_rdr"))
        .arg("render")
        .arg(scene)
        .args(extra)
        .args(["-q", "-o"])
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    read_exr_channels(out).unwrap_or_else(|e| panic!("{e}"))
}

/// Each channel's name and its values as written (any sample type).
fn channels(exr: &RawExr) -> Vec<(String, String)> {
    exr.channels.iter().map(|c| (c.name.clone(), format!("{:?}", c.data))).collect()
}

#[test]
fn the_aov_integrator_writes_rdrs_layers_around_its_nested_integrator() {
    let dir = temp_dir("rdr-mitsuba-aov");
    let wrapped = r#"<integrator type="aov">
    <string name="aovs" value="dd:depth, nn:sh_normal, gn:geo_normal, u:uv"/>
    <integrator type="path"><integer name="max_depth" value="4"/></integrator>
  </integrator>"#;
    let bare = r#"<integrator type="path"><integer name="max_depth" value="4"/></integrator>"#;
    let (a, b) = (dir.path().join("aov.xml"), dir.path().join("bare.xml"));
    std::fs::write(&a, scene(wrapped)).unwrap();
    std::fs::write(&b, scene(bare)).unwrap();
    let with_aov = channels(&render(&a, &dir.path().join("a.exr"), &[]));
    let by_flag = channels(&render(&b, &dir.path().join("b.exr"), &["--aov", "depth,normal"]));
    let plain = channels(&render(&b, &dir.path().join("c.exr"), &[]));
    let names = |c: &[(String, String)]| c.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    println!(
        "aov integrator: {:?}\n--aov: {:?}\nplain: {:?}",
        names(&with_aov),
        names(&by_flag),
        names(&plain)
    );
    assert!(names(&by_flag).len() > names(&plain).len(), "--aov adds layers");
    assert_eq!(names(&with_aov), names(&by_flag));
    assert!(with_aov == by_flag, "the aov integrator's file differs from --aov depth,normal");
    // a malformed list and a missing nested integrator are one-line errors
    for (bad, expect) in [
        (
            r#"<integrator type="aov"><string name="aovs" value="depth"/><integrator type="path"/></integrator>"#,
            "name:type",
        ),
        (
            r#"<integrator type="aov"><string name="aovs" value="d:depth"/></integrator>"#,
            "nested <integrator>",
        ),
    ] {
        std::fs::write(&a, scene(bad)).unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_rdr"))
            .arg("render")
            .arg(&a)
            .args(["-q", "-o"])
            .arg(dir.path().join("x.exr"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.contains(expect) && err.trim().lines().count() == 1,
            "{err}"
        );
    }
}
