//! `rdr render --compat rdr171` reproduces the course's two reference images in
//! every half value (and, in fact, byte for byte).

mod common;
use std::process::Command;

fn render_and_compare(name: &str) {
    let Some(shared) = common::shared() else { return };
    let data = shared.join("scenes/rdr171/data");
    let tmp = common::temp_dir(&format!("rdr-compat-{name}"));
    let out = tmp.path().join(format!("{name}.exr"));
    let status = Command::new(env!("CARGO_BIN_EXE_rdr"))
        .args(["render", "--compat", "rdr171", "-q"])
        .arg(data.join(format!("{name}.json")))
        .arg("-o")
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let (w, h, ours) = rdr::imageio::read_exr_half_bits(&out).unwrap();
    let (rw, rh, reference) = rdr::imageio::read_exr_half_bits(&data.join(format!("{name}.exr"))).unwrap();
    assert_eq!((w, h), (rw, rh));
    let differing: Vec<(usize, usize, usize)> = (0..w * h)
        .flat_map(|i| (0..3).map(move |c| (i, c)))
        .filter(|&(i, c)| ours[i][c] != reference[i][c])
        .map(|(i, c)| (i / w, i % w, c))
        .collect();
    assert!(
        differing.is_empty(),
        "{} half values differ (row, column, channel), first: {:?}",
        differing.len(),
        &differing[..differing.len().min(10)]
    );
    let same_bytes = std::fs::read(&out).unwrap() == std::fs::read(data.join(format!("{name}.exr"))).unwrap();
    assert!(same_bytes, "pixels agree but the file layout differs from the original's");
}

#[test]
fn cbox_no_light_is_bit_exact() {
    render_and_compare("cbox_no_light");
}

#[test]
fn cbox_no_light_refract_is_bit_exact() {
    render_and_compare("cbox_no_light_refract");
}
