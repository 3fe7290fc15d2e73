//! What real Mitsuba scenes need loaded (issue 41): mirrored sensors, `hide_emitters`,
//! `rawconstant`, bitmap `wrap_mode`, BMP/TGA/PPM/PFM textures, meshes of nothing but
//! degenerate triangles. Each against an analytic answer or an equivalent scene.

mod common;
use common::render;
use rdr::math::{Vec2, Vec3};
use rdr::metrics::Image;
use rdr::Profile;
use std::path::Path;

/// A sphere left of centre under a grey sky, `extra` added to the sensor's transform
/// and `integrator` the integrator's properties.
fn sphere_scene(dir: &Path, name: &str, sensor_extra: &str, integrator: &str, bsdf: &str) -> std::path::PathBuf {
    let file = dir.join(name);
    std::fs::write(
        &file,
        format!(
            r#"<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="3"/>{integrator}</integrator>
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="to_world">{sensor_extra}<lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="16"/><rfilter type="box"/></film>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
  <shape type="sphere"><point name="center" x="-0.7" y="0.2" z="0"/><float name="radius" value="0.6"/>{bsdf}</shape>
</scene>"#
        ),
    )
    .unwrap();
    file
}

fn load(file: &Path) -> rdr::Loaded {
    rdr::load(file, &[], Profile::Physical).unwrap_or_else(|e| panic!("{e}"))
}

fn mean_abs_diff(a: &Image, b: &Image) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(x, y)| (*x - *y).abs().element_sum() as f64 / 3.0)
        .sum::<f64>()
        / a.pixels.len() as f64
}

fn flipped(a: &Image) -> Image {
    let mut p = Vec::with_capacity(a.pixels.len());
    for y in 0..a.height {
        for x in (0..a.width).rev() {
            p.push(a.pixels[y * a.width + x]);
        }
    }
    Image::new(a.width, a.height, p)
}

const DIFFUSE: &str = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>"#;

/// A sensor with `<scale x="-1"/>` sees the mirror image (as Mitsuba's does): the plain
/// render flipped left to right matches it within noise, the plain render does not.
#[test]
fn a_mirrored_sensor_renders_the_mirror_image() {
    let dir = tempfile::tempdir().unwrap();
    let plain = render(&load(&sphere_scene(dir.path(), "plain.xml", "", "", DIFFUSE)), 32, 1);
    let mirrored_scene = load(&sphere_scene(dir.path(), "mirrored.xml", r#"<scale x="-1"/>"#, "", DIFFUSE));
    let mirrored = render(&mirrored_scene, 32, 2);
    let (as_mirror, as_is) = (mean_abs_diff(&flipped(&plain), &mirrored), mean_abs_diff(&plain, &mirrored));
    eprintln!("mean |flip(plain) − mirrored| {as_mirror:.4}, |plain − mirrored| {as_is:.4}");
    assert!(as_mirror * 10.0 < as_is, "flipped {as_mirror} against unflipped {as_is}");
}

/// `hide_emitters`: the sky the camera sees directly is black (exactly, as Mitsuba's
/// image is), while the sphere it lights keeps its brightness.
#[test]
fn hide_emitters_blacks_out_what_the_camera_sees_directly() {
    let dir = tempfile::tempdir().unwrap();
    let shown = render(&load(&sphere_scene(dir.path(), "shown.xml", "", "", DIFFUSE)), 64, 1);
    let hide = r#"<boolean name="hide_emitters" value="true"/>"#;
    let hidden = render(&load(&sphere_scene(dir.path(), "hidden.xml", "", hide, DIFFUSE)), 64, 2);
    // the right half holds no sphere: sky only
    let right = |img: &Image| -> Vec<Vec3> {
        (0..img.height)
            .flat_map(|y| (img.width - 6..img.width).map(move |x| (x, y)))
            .map(|(x, y)| img.pixels[y * img.width + x])
            .collect()
    };
    assert!(
        right(&shown).iter().all(|p| (*p - Vec3::ONE).abs().max_element() < 1e-4),
        "the sky shown is 1"
    );
    let brightest = right(&hidden).iter().fold(0.0f32, |m, p| m.max(p.max_element()));
    assert_eq!(brightest, 0.0, "the sky hidden is black");
    // the sphere's pixels (centre column of the sphere) keep the light the sky casts
    let sphere = |img: &Image| -> f64 {
        let (x0, y0) = (5, 6);
        (0..4)
            .flat_map(|dy| (0..4).map(move |dx| (x0 + dx, y0 + dy)))
            .map(|(x, y)| img.pixels[y * img.width + x].x as f64)
            .sum::<f64>()
            / 16.0
    };
    let (a, b) = (sphere(&shown), sphere(&hidden));
    eprintln!("sphere mean shown {a:.4}, hidden {b:.4}");
    assert!(
        a > 0.2 && (a - b).abs() < 0.05 * a,
        "the sphere lit by a hidden sky: {b} against {a}"
    );
}

/// `rawconstant` is its value as it is: the same image, bit for bit, as the `<rgb>`
/// of the same numbers (Mitsuba's RGB variants read both unchanged).
#[test]
fn rawconstant_is_its_value() {
    let dir = tempfile::tempdir().unwrap();
    let rgb = r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.5, 0.9"/></bsdf>"#;
    let raw = r#"<bsdf type="diffuse"><texture type="rawconstant" name="reflectance"><vector name="value" value="0.2, 0.5, 0.9"/></texture></bsdf>"#;
    let a = render(&load(&sphere_scene(dir.path(), "rgb.xml", "", "", rgb)), 4, 1);
    let b = render(&load(&sphere_scene(dir.path(), "raw.xml", "", "", raw)), 4, 1);
    let d = mean_abs_diff(&a, &b);
    assert!(d == 0.0, "rawconstant differs from rgb by {d}");
}

/// Mitsuba's bilinear lookup with its texel indices wrapped as `wrap_mode` says
/// (clamp: to the edge; mirror: `i mod 2n`, folded back): written out here apart from
/// rdr's lookup, which wraps the coordinate instead.
fn mitsuba_bilinear(texels: &[Vec3], w: usize, h: usize, mode: &str, st: Vec2) -> Vec3 {
    let wrap = |i: i64, n: usize| -> usize {
        let n = n as i64;
        (match mode {
            "clamp" => i.clamp(0, n - 1),
            "mirror" => {
                let m = i.rem_euclid(2 * n);
                if m >= n {
                    2 * n - m - 1
                } else {
                    m
                }
            }
            _ => i.rem_euclid(n),
        }) as usize
    };
    // rdr's rows run downwards from t = 1 (the file's top row), as Mitsuba's from v = 0
    let (x, y) = (st.x * w as f32 - 0.5, (1.0 - st.y) * h as f32 - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let t = |i: i64, j: i64| texels[wrap(j, h) * w + wrap(i, w)];
    let (i, j) = (x0 as i64, y0 as i64);
    (t(i, j) * (1.0 - fx) + t(i + 1, j) * fx) * (1.0 - fy) + (t(i, j + 1) * (1.0 - fx) + t(i + 1, j + 1) * fx) * fy
}

/// `wrap_mode` `repeat`, `clamp` and `mirror` read the texels Mitsuba's lookups read,
/// over uv from −2.5 to 3.5 (bilinear and nearest on a 3×2 image of distinct texels).
#[test]
fn wrap_modes_read_the_texels_mitsuba_reads() {
    use rdr::texture::image::{ImageFilter, ImageTexture, WrapMode};
    use rdr::texture::mipmap::{Level, MipMap};
    let (w, h) = (3, 2);
    let texels: Vec<Vec3> = (0..w * h)
        .map(|i| Vec3::new(i as f32, (i * i) as f32, 1.0 + 0.5 * i as f32))
        .collect();
    let mipmap = std::sync::Arc::new(MipMap::new(Level::new(w, h, texels.clone()), Default::default(), false));
    let mut worst = 0.0f32;
    for (name, wrap) in [
        ("repeat", WrapMode::Repeat),
        ("clamp", WrapMode::Clamp),
        ("mirror", WrapMode::Mirror),
    ] {
        let tex = ImageTexture {
            mipmap: mipmap.clone(),
            mapping: rdr::texture::UvMapping {
                scale: Vec2::ONE,
                delta: Vec2::ZERO,
            },
            filter: ImageFilter::Bilinear,
            wrap,
            scale: Vec3::ONE,
        };
        for i in 0..=240 {
            for j in 0..=160 {
                let st = Vec2::new(-2.5 + i as f32 * 6.0 / 240.0 + 1e-3, -2.5 + j as f32 * 6.0 / 160.0 + 1e-3);
                let tc = rdr::texture::TexCoord {
                    uv: st,
                    ..Default::default()
                };
                let got = tex.eval(&tc);
                let want = mitsuba_bilinear(&texels, w, h, name, st);
                worst = worst.max((got - want).abs().max_element());
                assert!(
                    (got - want).abs().max_element() < 1e-3,
                    "{name} at {st}: {got} against Mitsuba's {want}"
                );
            }
        }
    }
    eprintln!("largest difference from Mitsuba's wrapped lookups: {worst:e}");
}

/// BMP, TGA and PPM decode as PNG does (8-bit values from sRGB), PFM as linear floats
/// with its rows turned (the file stores the bottom row first).
#[test]
fn bmp_tga_ppm_and_pfm_textures() {
    let dir = tempfile::tempdir().unwrap();
    let bytes: Vec<u8> = (0..4 * 3 * 3).map(|i| (i * 7 % 256) as u8).collect();
    let img = image::RgbImage::from_raw(4, 3, bytes.clone()).unwrap();
    let want: Vec<Vec3> = bytes
        .chunks(3)
        .map(|c| {
            let f = |b: u8| rdr::imageio::srgb_to_linear(b as f32 / 255.0);
            Vec3::new(f(c[0]), f(c[1]), f(c[2]))
        })
        .collect();
    for ext in ["png", "bmp", "tga", "ppm"] {
        let f = dir.path().join(format!("t.{ext}"));
        img.save(&f).unwrap();
        let got = rdr::imageio::read_texture_image(&f).unwrap_or_else(|e| panic!("{ext}: {e:#}"));
        assert_eq!((got.width, got.height), (4, 3), "{ext}");
        assert_eq!(got.pixels, want, "{ext} decodes as 8-bit sRGB");
    }
    // a 2×2 PFM, little-endian (negative scale), bottom row first
    let values = [[1.0f32, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0], [10.0, 11.0, 12.5]];
    let mut pfm = b"PF\n2 2\n-1.0\n".to_vec();
    for v in values.iter().flatten() {
        pfm.extend_from_slice(&v.to_le_bytes());
    }
    let f = dir.path().join("t.pfm");
    std::fs::write(&f, &pfm).unwrap();
    let got = rdr::imageio::read_texture_image(&f).unwrap_or_else(|e| panic!("{e:#}"));
    let v = |i: usize| Vec3::from_array(values[i]);
    assert_eq!(got.pixels, vec![v(2), v(3), v(0), v(1)], "the top row is the file's last");
    // cut short: one line naming the file
    std::fs::write(&f, &pfm[..pfm.len() - 3]).unwrap();
    let e = format!("{:#}", rdr::imageio::read_texture_image(&f).unwrap_err());
    assert!(e.contains("t.pfm") && e.contains("bytes"), "{e}");
}

/// A mesh of nothing but zero-area triangles (20 of them in Bitterli's staircase) is
/// skipped with one warning for all such meshes; the scene renders as without it.
#[test]
fn meshes_of_only_degenerate_triangles_are_skipped_with_one_warning() {
    let dir = tempfile::tempdir().unwrap();
    for i in 0..3 {
        std::fs::write(dir.path().join(format!("flat{i}.obj")), "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap();
    }
    let flats: String = (0..3)
        .map(|i| format!(r#"<shape type="obj"><string name="filename" value="flat{i}.obj"/>{DIFFUSE}</shape>"#))
        .collect();
    let file = sphere_scene(dir.path(), "flats.xml", "", "", DIFFUSE);
    let text = std::fs::read_to_string(&file)
        .unwrap()
        .replace("</scene>", &format!("{flats}</scene>"));
    std::fs::write(&file, text).unwrap();
    let loaded = load(&file);
    let about: Vec<&String> = loaded.scene.warnings.iter().filter(|w| w.contains("degenerate")).collect();
    assert_eq!(about.len(), 1, "one warning: {about:?}");
    assert!(about[0].contains("3 mesh(es)") && about[0].contains("flat0.obj"), "{}", about[0]);
    let plain = render(&load(&sphere_scene(dir.path(), "plain.xml", "", "", DIFFUSE)), 2, 1);
    assert_eq!(mean_abs_diff(&render(&loaded, 2, 1), &plain), 0.0, "the same image as without them");
}

/// The mean of the 4×4 pixels at the sphere's middle in [`sphere_scene`]'s image.
fn sphere_middle(img: &Image) -> Vec3 {
    let (x0, y0) = (5, 6);
    (0..4)
        .flat_map(|dy| (0..4).map(move |dx| (x0 + dx, y0 + dy)))
        .map(|(x, y)| img.pixels[y * img.width + x])
        .sum::<Vec3>()
        / 16.0
}

/// Mitsuba 0.6's `mixturebsdf` of three diffuse bsdfs: a convex sphere under a sky of
/// radiance 1 shows its albedo, here Σ wᵢ·ρᵢ.
#[test]
fn mixturebsdf_is_the_weighted_sum_of_its_bsdfs() {
    let dir = tempfile::tempdir().unwrap();
    let (weights, albedos) = (
        [0.2f32, 0.3, 0.5],
        [Vec3::new(0.9, 0.05, 0.05), Vec3::new(0.05, 0.9, 0.05), Vec3::new(0.05, 0.05, 0.9)],
    );
    let inner: String = albedos
        .iter()
        .map(|a| {
            format!(
                r#"<bsdf type="diffuse"><rgb name="reflectance" value="{}, {}, {}"/></bsdf>"#,
                a.x, a.y, a.z
            )
        })
        .collect();
    let bsdf = format!(r#"<bsdf type="mixturebsdf"><string name="weights" value="0.2, 0.3, 0.5"/>{inner}</bsdf>"#);
    let got = sphere_middle(&render(&load(&sphere_scene(dir.path(), "mix.xml", "", "", &bsdf)), 256, 1));
    let want: Vec3 = weights.iter().zip(&albedos).map(|(w, a)| *a * *w).sum();
    eprintln!("mixture: {got} against Σ wᵢρᵢ = {want}");
    assert!((got - want).abs().max_element() < 0.01, "{got} against {want}");
}

/// `rdr convert` writes what Mitsuba 3 reads as rdr renders: a box filter without the
/// radius Mitsuba 3 refuses, and `volpath` for a scene with masks (Mitsuba's `path`
/// stops shadow rays at masks, rdr's and volpath's pass through them).
#[test]
fn convert_writes_box_filters_and_masked_scenes_as_mitsuba_3_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let masked = r#"<bsdf type="mask"><float name="opacity" value="0.5"/><bsdf type="diffuse"/></bsdf>"#;
    let src = sphere_scene(dir.path(), "masked.xml", "", "", masked);
    let (json, xml) = (dir.path().join("masked.json"), dir.path().join("back.xml"));
    for (from, to) in [(&src, &json), (&json, &xml)] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_rdr"))
            .args(["convert", "-q"])
            .arg(from)
            .arg("-o")
            .arg(to)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let text = std::fs::read_to_string(&xml).unwrap();
    assert!(text.contains(r#"<rfilter type="box"/>"#), "a bare box filter:\n{text}");
    assert!(text.contains(r#"<integrator type="volpath">"#), "volpath for masks:\n{text}");
}

/// Roughness given as a texture where rdr (like Mitsuba 3) reads only a number,
/// `roughplastic`'s `alpha`, is an error naming the property (it was silently the
/// default 0.1); `roughconductor`'s textured `alpha_u` is read (tests/materials_render.rs).
#[test]
fn a_texture_where_a_number_is_read_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let bsdf = r#"<bsdf type="roughplastic"><texture type="checkerboard" name="alpha"/></bsdf>"#;
    let e = rdr::load(&sphere_scene(dir.path(), "alpha.xml", "", "", bsdf), &[], Profile::Physical)
        .err()
        .expect("accepted")
        .to_string();
    assert!(
        !e.contains('\n') && e.contains("\"alpha\"") && e.contains("must be a number"),
        "{e}"
    );
}
