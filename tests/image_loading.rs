//! Texture and environment images from `../shared` load as linear RGB, row 0 on top.

mod common;
use rdr::imageio::read_texture_image;

#[test]
fn shared_environment_maps_load() {
    let Some(shared) = common::shared() else { return };
    for name in [
        "industrial_sunset_puresky_1k.hdr",
        "venice_sunset_1k.exr",
        "studio_small_01_1k.exr",
        "courtyard_1k.exr",
    ] {
        let img = read_texture_image(&shared.join("envmaps").join(name)).unwrap();
        assert_eq!((img.width, img.height), (1024, 512), "{name}");
        assert!(img.pixels.iter().all(|p| p.is_finite()), "{name}");
        let mean: f32 = img.pixels.iter().map(|p| p.y).sum::<f32>() / img.pixels.len() as f32;
        assert!(mean > 0.01 && mean < 100.0, "{name}: mean {mean}");
        // the sky (top half) is brighter than the ground (bottom half) in all four
        let half = img.pixels.len() / 2;
        let top: f32 = img.pixels[..half].iter().map(|p| p.y).sum();
        let bottom: f32 = img.pixels[half..].iter().map(|p| p.y).sum();
        assert!(top > bottom, "{name}: is the image upside down?");
    }
}

#[test]
fn uv_grid_png_is_decoded_from_srgb_with_row_zero_on_top() {
    let Some(shared) = common::shared() else { return };
    let img = read_texture_image(&shared.join("textures/uv_grid_512.png")).unwrap();
    assert_eq!((img.width, img.height), (512, 512));
    // white marker square at (u, v) = (0, 0), the bottom-left corner of the picture
    let bottom_left = img.at(10, 500);
    assert!(bottom_left.min_element() > 0.9, "{bottom_left}");
    // R grows to the right; decoded to linear, mid-grey sRGB 128 is about 0.216
    let a = img.at(100, 300);
    let b = img.at(400, 300);
    assert!(b.x > a.x);
    let grey = rdr::imageio::srgb_to_linear(128.0 / 255.0);
    assert!((grey - 0.2158).abs() < 1e-3);
}
