//! Image textures: orientation (default vs. `--compat rdr171`), MIP-mapping against
//! aliasing, the pyramid and the lookups, uv derivatives from ray differentials.

mod common;

use rdr::desc::BuildOptions;
use rdr::math::{Vec2, Vec3};
use rdr::metrics::Image;
use rdr::texture::mipmap::{Level, MipMap};
use rdr::texture::{Texture, TextureConvention};
use rdr::Profile;
use std::path::{Path, PathBuf};

/// The unit quad `[-1, 1]²` at z = 0 facing +z, uv (0,0) bottom-left to (1,1) top-right.
const QUAD_OBJ: &str = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";

/// A head-on view of the quad that exactly fills a `res`² film (vertical fov 2·atan ½),
/// lit from the eye.
fn quad_scene(dir: &Path, texture: &Path, res: u32) -> PathBuf {
    std::fs::write(dir.join("quad.obj"), QUAD_OBJ).unwrap();
    let fov = 2.0 * 0.5f64.atan().to_degrees();
    let scene = serde_json::json!({
        "integrator": {"type": "intersection_test", "spp": 4,
                       "lights": [{"type": "point", "position": [0, 0, 2], "flux": [50, 50, 50]}]},
        "film": {"resolution": [res, res]},
        "camera": {"position": [0, 0, 2], "look_at": [0, 0, 0], "ref_up": [0, 1, 0], "fov": fov},
        "textures": {"grid": {"type": "image", "path": texture.to_str().unwrap(),
                              "tex_coordinate_generator": {"type": "uvmapping2d"}}},
        "materials": {"m": {"type": "diffuse", "texture_name": "grid"}},
        "objects": [{"type": "mesh", "path": "quad.obj", "material_name": "m"}]
    });
    let path = dir.join("quad.json");
    std::fs::write(&path, serde_json::to_string_pretty(&scene).unwrap()).unwrap();
    path
}

fn px(img: &Image, x: usize, y: usize) -> Vec3 {
    img.pixels[y * img.width + x]
}

/// White marker, blue corner, red to the right, green upwards (or downwards when
/// `flipped`), for a 64×64 render of the uv grid on the quad.
fn check_uv_grid(img: &Image, flipped: bool, what: &str) {
    let (top, bottom) = if flipped { (62, 1) } else { (1, 62) };
    // the 32-texel white square at uv (0, 0) covers 4×4 pixels in a corner
    let white = px(img, 1, bottom);
    assert!(
        white.min_element() > 0.8 * white.max_element() && white.min_element() > 0.05,
        "{what}: uv (0,0) should be the white marker at column 1 row {bottom}, found {white}"
    );
    let blue = px(img, 62, top);
    assert!(
        blue.z > 5.0 * blue.x.max(blue.y) && blue.z > 0.01,
        "{what}: uv (1,1) should be the blue square at column 62 row {top}, found {blue}"
    );
    // the opposite corners are not white/blue
    let c = px(img, 1, top);
    assert!(c.z < 0.5 * c.y.max(c.x), "{what}: uv (0,1) is green-ish, found {c}");
    // symmetric pixels (same lighting) in the middle of grid cells
    let (left, right) = (px(img, 12, 36), px(img, 51, 36));
    assert!(right.x > 2.0 * left.x, "{what}: red grows to the right: {left} vs {right}");
    let (upper, lower) = (px(img, 36, 12), px(img, 36, 51));
    if flipped {
        assert!(lower.y > 2.0 * upper.y, "{what}: green grows downwards: {upper} vs {lower}");
    } else {
        assert!(upper.y > 2.0 * lower.y, "{what}: green grows upwards: {upper} vs {lower}");
    }
}

#[test]
fn uv_grid_is_upright_and_compat_flips_it() {
    let Some(shared) = common::shared() else { return };
    let tmp = common::temp_dir("rdr-textures-uvgrid");
    let dir = tmp.path();
    let scene = quad_scene(dir, &shared.join("textures/uv_grid_512.png"), 64);

    let s = common::load_scene(&scene, &[], Profile::Physical);
    let img = common::render(&s, 4, 0);
    check_uv_grid(&img, false, "default");

    let s = common::load_scene(&scene, &[], Profile::Rdr171);
    let img = common::render(&s, 4, 0);
    check_uv_grid(&img, true, "--compat rdr171");
}

#[test]
fn uv_derivatives_of_a_head_on_quad_are_one_pixel() {
    let tmp = common::temp_dir("rdr-textures-derivs");
    let dir = tmp.path();
    // any picture will do; this one is generated
    let tex = dir.join("t.png");
    rdr::imageio::write_png(&tex, 2, 2, &[Vec3::ONE; 4]).unwrap();
    let rdr::Loaded { scene, job } = common::load_scene(&quad_scene(dir, &tex, 64), &[], Profile::Physical);
    let (ray, diff) = job.camera.ray_differential(20.5, 40.5);
    let hit = scene.intersect(&ray).expect("the quad fills the view");
    let mut it = scene.interaction(&ray, &hit);
    assert!((it.dpdu - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-5, "dpdu {}", it.dpdu);
    assert!((it.dpdv - Vec3::new(0.0, 2.0, 0.0)).length() < 1e-5, "dpdv {}", it.dpdv);
    assert!((it.uv - Vec2::new(20.5, 40.5) / 64.0).length() < 1e-5, "uv {}", it.uv);
    assert_eq!((it.duvdx, it.duvdy), (Vec2::ZERO, Vec2::ZERO), "no differentials yet");
    it.compute_uv_derivatives(&diff);
    // film y grows upwards, and so does v
    assert!((it.duvdx - Vec2::new(1.0 / 64.0, 0.0)).length() < 1e-5, "duvdx {}", it.duvdx);
    assert!((it.duvdy - Vec2::new(0.0, 1.0 / 64.0)).length() < 1e-5, "duvdy {}", it.duvdy);
    // half the footprint when scaled by ½
    it.compute_uv_derivatives(&diff.scaled(&ray, 0.5));
    assert!((it.duvdx - Vec2::new(0.5 / 64.0, 0.0)).length() < 1e-5, "duvdx {}", it.duvdx);
}

#[test]
fn sphere_uv_order_follows_the_profile() {
    let tmp = common::temp_dir("rdr-textures-sphere");
    let dir = tmp.path();
    let scene = serde_json::json!({
        "integrator": {"type": "intersection_test"},
        "film": {"resolution": [8, 8]},
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "textures": {"c": {"type": "constant", "color": [1, 1, 1]}},
        "materials": {"m": {"type": "diffuse", "texture_name": "c"}},
        "objects": [{"type": "sphere", "radius": 1, "material_name": "m"}]
    });
    let path = dir.join("s.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    // a ray hitting the sphere at (x, y, z) ∝ (0.6, 0.48, 0.64): φ = atan2(y, x), θ = acos z
    let n = Vec3::new(0.6, 0.48, 0.64).normalize();
    let ray = rdr::geometry::Ray::new(n * 3.0, -n);
    let phi = n.y.atan2(n.x) / (2.0 * std::f32::consts::PI);
    let theta = n.z.acos() / std::f32::consts::PI;
    for (profile, uv) in [(Profile::Physical, Vec2::new(phi, theta)), (Profile::Rdr171, Vec2::new(theta, phi))] {
        let mut s = common::load_scene(&path, &[], profile).scene;
        // a constant texture reads no uv, so the scene would not compute them
        assert!(!s.texture_coords);
        s.texture_coords = true;
        let it = s.interaction(&ray, &s.intersect(&ray).unwrap());
        assert!((it.uv - uv).length() < 1e-5, "{profile:?}: uv {} expected {uv}", it.uv);
        // ∂p/∂u points along increasing φ (default) or θ (compat)
        let along_phi = Vec3::new(-n.y, n.x, 0.0);
        let c = it.dpdu.normalize().dot(along_phi.normalize());
        match profile {
            Profile::Physical => assert!(c > 0.999, "dpdu {}", it.dpdu),
            Profile::Rdr171 => assert!(c.abs() < 1e-4, "dpdu {}", it.dpdu),
        }
        assert!(it.dpdu.cross(it.dpdv).length() > 0.0);
    }
}

#[test]
fn textures_sharing_a_file_share_its_pyramid() {
    let tmp = common::temp_dir("rdr-textures-shared");
    let dir = tmp.path();
    rdr::imageio::write_png(&dir.join("t.png"), 4, 4, &[Vec3::splat(0.5); 16]).unwrap();
    std::fs::write(dir.join("quad.obj"), QUAD_OBJ).unwrap();
    let gen = |s: f32| serde_json::json!({"type": "uvmapping2d", "scale": [s, s]});
    let scene = serde_json::json!({
        "integrator": {"type": "intersection_test"},
        "film": {"resolution": [8, 8]},
        "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "textures": {"a": {"type": "image", "path": "t.png", "tex_coordinate_generator": gen(1.0)},
                     "b": {"type": "image", "path": "./t.png", "tex_coordinate_generator": gen(4.0)},
                     "c": {"type": "image", "path": "t.png", "tex_coordinate_generator": gen(2.0)}},
        "materials": {"m1": {"type": "diffuse", "texture_name": "a"}, "m2": {"type": "diffuse", "texture_name": "a"},
                      "m3": {"type": "diffuse", "texture_name": "c"}},
        "objects": [{"type": "mesh", "path": "quad.obj", "material_name": "m1"}]
    });
    let path = dir.join("s.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let s = common::load_scene(&path, &[], Profile::Physical).scene;
    let pyramid = |i: usize| match &s.textures[i] {
        Texture::Image(t) => t.mipmap.clone(),
        other => panic!("texture {i} is {other:?}"),
    };
    assert!(std::sync::Arc::ptr_eq(&pyramid(0), &pyramid(2)), "same path, one pyramid");
    assert!(
        std::sync::Arc::ptr_eq(&pyramid(0), &pyramid(1)),
        "the same file spelled differently"
    );
    assert_eq!(pyramid(0).levels().len(), 3, "4x4, 2x2, 1x1");
}

// --- aliasing ------------------------------------------------------------------------

/// A floor of 400×400 checks (a generated 64×64 PNG of 8×8 checks, repeated 50 times
/// each way) seen from 1 unit above it, looking at the horizon; one point light far
/// above, so the shading is nearly uniform.
fn checker_floor_scene(dir: &Path, res: [u32; 2]) -> PathBuf {
    let (n, check) = (64usize, 8usize);
    let texels: Vec<Vec3> = (0..n * n)
        .map(|i| {
            let (x, y) = (i % n, i / n);
            if (x / check + y / check) % 2 == 0 {
                Vec3::splat(0.8)
            } else {
                Vec3::splat(0.05)
            }
        })
        .collect();
    rdr::imageio::write_png(&dir.join("checker.png"), n as u32, n as u32, &texels).unwrap();
    let obj = "v -100 0 5\nv 100 0 5\nv 100 0 -195\nv -100 0 -195\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";
    std::fs::write(dir.join("floor.obj"), obj).unwrap();
    // E = I/d² ≈ π at the floor: L ≈ albedo
    let flux = 4.0 * std::f64::consts::PI * std::f64::consts::PI * 1e6;
    let scene = serde_json::json!({
        "integrator": {"type": "intersection_test",
                       "lights": [{"type": "point", "position": [0, 1000, -60], "flux": [flux, flux, flux]}]},
        "film": {"resolution": res},
        "camera": {"position": [0, 1, 3], "look_at": [0, 1, -10], "ref_up": [0, 1, 0], "fov": 24},
        "textures": {"checks": {"type": "image", "path": "checker.png",
                                "tex_coordinate_generator": {"type": "uvmapping2d", "scale": [50, 50]}}},
        "materials": {"floor": {"type": "diffuse", "texture_name": "checks"}},
        "objects": [{"type": "mesh", "path": "floor.obj", "material_name": "floor"}]
    });
    let path = dir.join("floor.json");
    std::fs::write(&path, serde_json::to_string_pretty(&scene).unwrap()).unwrap();
    path
}

/// Relative RMS difference over rows `rows`: sqrt(mean (a − b)²) / mean(b).
fn rel_rms(a: &Image, b: &Image, rows: std::ops::Range<usize>) -> f64 {
    let (mut se, mut sum, mut n) = (0.0f64, 0.0f64, 0usize);
    for y in rows {
        for x in 0..a.width {
            let (p, q) = (px(a, x, y), px(b, x, y));
            for c in 0..3 {
                se += ((p[c] - q[c]) as f64).powi(2);
                sum += q[c] as f64;
                n += 1;
            }
        }
    }
    (se / n as f64).sqrt() / (sum / n as f64)
}

#[test]
fn mipmapping_removes_aliasing_of_a_distant_checker_floor() {
    let tmp = common::temp_dir("rdr-textures-aliasing");
    let dir = tmp.path();
    let (w, h) = (160u32, 120u32);
    let path = checker_floor_scene(dir, [w, h]);
    let desc = rdr::desc::SceneDesc::load(&path, &[]).unwrap();
    let build = |mipmap: bool| {
        rdr::Loaded::build_with(
            &desc,
            Profile::Physical,
            BuildOptions {
                mipmap,
                ..Profile::Physical.build_options()
            },
        )
        .unwrap()
    };
    let (on, off) = (build(true), build(false));
    assert!(
        matches!(&on.scene.textures[0], Texture::Image(t) if t.mipmap.levels().len() == 7),
        "64x64: 7 levels"
    );
    assert!(matches!(&off.scene.textures[0], Texture::Image(t) if t.mipmap.levels().len() == 1));

    // The distant region: rows whose pixel centres see the floor between 16 and 180
    // units away (it ends at 198). There a check (0.5 units) is less than half a pixel
    // high, so the unfiltered texture aliases; nearer, checks are a few pixels wide
    // and high and the isotropic MIP filter would mostly measure its own blur.
    let tan_half = (12f64).to_radians().tan();
    let rows: Vec<usize> = (0..h as usize)
        .filter(|&r| {
            let sy = 2.0 * (h as f64 - r as f64 - 0.5) / h as f64 - 1.0;
            let down = -sy * tan_half; // tan of the angle below the horizon
            down > 0.0 && (16.0..180.0).contains(&(1.0 / down))
        })
        .collect();
    let rows = rows[0]..rows[rows.len() - 1] + 1;
    assert!(rows.len() >= 15, "{rows:?}");

    let t0 = std::time::Instant::now();
    // ground truth: 256 samples per pixel of the unfiltered texture
    let truth = common::render(&off, 256, 1);
    let converged_on = common::render(&on, 256, 1);
    let mut report = Vec::new();
    let mut errors = Vec::new();
    for spp in [1u32, 4] {
        let e_on = rel_rms(&common::render(&on, spp, 2), &truth, rows.clone());
        let e_off = rel_rms(&common::render(&off, spp, 2), &truth, rows.clone());
        report.push(format!("{spp} spp: MIP on {e_on:.4}, MIP off {e_off:.4}"));
        errors.push((spp, e_on, e_off));
    }
    let e_conv = rel_rms(&converged_on, &truth, rows.clone());
    eprintln!(
        "aliasing (relative RMS vs. 256-spp unfiltered render, rows {rows:?}): {}; 256 spp MIP on: {e_conv:.4}; {:.2} s",
        report.join("; "),
        t0.elapsed().as_secs_f64()
    );
    const BOUND: f64 = 0.15;
    for (spp, e_on, e_off) in errors {
        assert!(e_on < BOUND, "{spp} spp with MIP-mapping: error {e_on:.4} ≥ {BOUND}");
        assert!(
            e_off > BOUND,
            "{spp} spp without MIP-mapping: error {e_off:.4} ≤ {BOUND} (no aliasing to remove?)"
        );
    }
    // many samples with MIP-mapping converge to nearly the unfiltered picture (footprints shrink with 1/√spp)
    assert!(e_conv < BOUND / 2.0, "256 spp with MIP-mapping: {e_conv:.4}");
}

// --- pyramid and lookups ----------------------------------------------------------------

/// Deterministic pseudo-random texels.
fn noise_level(w: usize, h: usize, seed: u32) -> Level {
    let mut x = seed.wrapping_mul(2654435761).wrapping_add(12345);
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        (x % 10000) as f32 / 10000.0
    };
    Level::new(w, h, (0..w * h).map(|_| Vec3::new(next(), next(), next())).collect())
}

fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol
}

#[test]
fn pyramid_levels_are_box_averages() {
    let img = noise_level(8, 4, 1);
    let m = MipMap::new(img.clone(), TextureConvention::Physical, true);
    let sizes: Vec<_> = m.levels().iter().map(|l| (l.width, l.height)).collect();
    assert_eq!(sizes, vec![(8, 4), (4, 2), (2, 1), (1, 1)]);
    for k in 1..m.levels().len() {
        let (prev, l) = (&m.levels()[k - 1], &m.levels()[k]);
        for y in 0..l.height {
            for x in 0..l.width {
                let ys: Vec<usize> = if prev.height == 1 { vec![0] } else { vec![2 * y, 2 * y + 1] };
                let avg = ys
                    .iter()
                    .flat_map(|&yy| [prev.texel(2 * x, yy), prev.texel(2 * x + 1, yy)])
                    .fold(Vec3::ZERO, |a, t| a + t)
                    / (2 * ys.len()) as f32;
                assert!(close(l.texel(x, y), avg, 1e-6), "level {k} texel ({x},{y})");
            }
        }
    }
    assert!(close(m.levels()[3].texel(0, 0), img.mean(), 1e-5));
    // the original's pyramid of a power-of-two image: level 0 is a copy, then 2×2 averages, no 1×1
    let r = MipMap::new(img.clone(), TextureConvention::Rdr171, true);
    let sizes: Vec<_> = r.levels().iter().map(|l| (l.width, l.height)).collect();
    assert_eq!(sizes, vec![(8, 4), (4, 2), (2, 1)]);
    assert_eq!(r.levels()[0].to_linear(), img.to_linear());
    for (a, b) in r.levels()[1..].iter().zip(&m.levels()[1..]) {
        for (p, q) in a.to_linear().iter().zip(&b.to_linear()) {
            assert!(close(*p, *q, 1e-6));
        }
    }
}

#[test]
fn non_power_of_two_pyramids_keep_the_mean_and_constants() {
    for (w, h) in [(5, 3), (600, 400), (7, 1), (1, 9)] {
        let img = noise_level(w, h, 7);
        let mean = img.mean();
        let m = MipMap::new(img, TextureConvention::Physical, true);
        let last = m.levels().last().unwrap();
        assert_eq!((last.width, last.height), (1, 1), "{w}x{h} goes down to 1x1");
        for (k, l) in m.levels().iter().enumerate() {
            assert!(close(l.mean(), mean, 1e-4), "{w}x{h} level {k}: mean {} vs {mean}", l.mean());
        }
        for conv in [TextureConvention::Physical, TextureConvention::Rdr171] {
            let c = Vec3::new(0.25, 0.5, 2.0);
            let m = MipMap::new(Level::new(w, h, vec![c; w * h]), conv, true);
            for (k, l) in m.levels().iter().enumerate() {
                assert!(
                    l.to_linear().iter().all(|t| close(*t, c, 1e-6)),
                    "{conv:?} {w}x{h} level {k} is not constant"
                );
            }
            // and so is every lookup, whatever the footprint
            for fw in [0.0, 1e-3, 0.05, 0.3, 10.0] {
                let v = m.lookup(Vec2::new(0.37, -2.9), Vec2::new(fw, 0.0), Vec2::new(0.0, fw * 0.5));
                assert!(close(v, c, 1e-5), "{conv:?} {w}x{h} footprint {fw}: {v}");
            }
        }
    }
}

#[test]
fn trilinear_weights_follow_the_footprint() {
    let m = MipMap::new(noise_level(16, 16, 3), TextureConvention::Physical, true);
    assert_eq!(m.levels().len(), 5);
    // level ℓ = log2(width · 16)
    let w = |l: f32| 2f32.powf(l) / 16.0;
    let [(a, wa), (b, wb)] = m.level_weights(w(1.25));
    assert_eq!((a, b), (1, 2));
    assert!((wa - 0.75).abs() < 1e-5 && (wb - 0.25).abs() < 1e-5);
    assert_eq!(m.level_weights(0.0)[0], (0, 1.0), "no footprint: finest level");
    assert_eq!(m.level_weights(w(-2.0))[0], (0, 1.0));
    assert_eq!(m.level_weights(w(7.0))[0], (4, 1.0), "huge footprint: coarsest level");
    // the lookup is that blend of bilinear lookups; the largest derivative component counts
    let st = Vec2::new(0.3, 0.7);
    let expect = m.bilinear(1, st) * 0.75 + m.bilinear(2, st) * 0.25;
    let got = m.lookup(st, Vec2::new(w(1.25) * 0.5, -w(1.25)), Vec2::new(0.0, w(1.25) * 0.1));
    assert!(close(got, expect, 1e-6), "{got} vs {expect}");
    assert!(close(m.lookup(st, Vec2::ZERO, Vec2::ZERO), m.bilinear(0, st), 0.0));

    // the original's formula: ℓ = (levels − 1) + log2(w) with levels 16, 8, 4, 2
    let r = MipMap::new(noise_level(16, 16, 3), TextureConvention::Rdr171, true);
    assert_eq!(r.levels().len(), 4);
    let [(a, wa), (b, wb)] = r.level_weights(2f32.powf(1.25 - 3.0));
    assert_eq!((a, b), (1, 2));
    assert!((wa - 0.75).abs() < 1e-5 && (wb - 0.25).abs() < 1e-5);
    assert_eq!(r.level_weights(0.0)[0], (0, 1.0));
    let [(a, _), (b, wb)] = r.level_weights(2f32.powf(3.5 - 3.0));
    assert_eq!((a, b), (3, 3), "between levels − 1 and levels: the coarsest, twice");
    assert!((wb - 0.5).abs() < 1e-5);
    assert_eq!(r.level_weights(4.0)[0], (3, 1.0));

    // without MIP-mapping every lookup is bilinear on level 0
    let flat = MipMap::new(noise_level(16, 16, 3), TextureConvention::Physical, false);
    assert_eq!(flat.levels().len(), 1);
    assert_eq!(flat.lookup(st, Vec2::splat(0.5), Vec2::ZERO), flat.bilinear(0, st));
}

#[test]
fn bilinear_lookup_wraps_and_puts_v_zero_at_the_bottom() {
    // 4×2 image, file rows top-down: texel (i, j) = (i, j, 0)
    let texels = (0..8).map(|k| Vec3::new((k % 4) as f32, (k / 4) as f32, 0.0)).collect();
    let img = Level::new(4, 2, texels);
    let m = MipMap::new(img.clone(), TextureConvention::Physical, true);
    let at = |s: f32, t: f32| m.bilinear(0, Vec2::new(s, t));
    // texel centres: (i + ½)/4, and t = 1 − (j + ½)/2 (file row 1 is the bottom)
    assert_eq!(at(0.125, 0.25), Vec3::new(0.0, 1.0, 0.0), "bottom-left texel is the last file row");
    assert_eq!(at(0.875, 0.75), Vec3::new(3.0, 0.0, 0.0), "top-right texel is the first file row");
    assert_eq!(at(0.25, 0.25), Vec3::new(0.5, 1.0, 0.0), "halfway between columns 0 and 1");
    assert_eq!(at(0.125, 0.5), Vec3::new(0.0, 0.5, 0.0), "halfway between the rows");
    // repeat: the seam blends the last column with the first, integer shifts change nothing
    assert_eq!(at(0.0, 0.25), Vec3::new(1.5, 1.0, 0.0));
    assert_eq!(at(1.0, 0.25), Vec3::new(1.5, 1.0, 0.0));
    for (ds, dt) in [(1.0, 0.0), (-3.0, 2.0), (5.0, -7.0)] {
        for (s, t) in [(0.3, 0.6), (0.01, 0.99), (0.9, 0.1)] {
            assert!(close(at(s + ds, t + dt), at(s, t), 1e-4), "({s}+{ds}, {t}+{dt})");
        }
    }
    // vertical seam: t = 0 blends the bottom row with the top row
    assert_eq!(at(0.125, 0.0), Vec3::new(0.0, 0.5, 0.0));

    // the original's lookup: no flip, coordinates below ½ texel clamp to the first texel,
    // the last texel blends with the first, wrapping by modulo above 1
    let r = MipMap::new(img, TextureConvention::Rdr171, true);
    let at = |s: f32, t: f32| r.bilinear(0, Vec2::new(s, t));
    assert_eq!(at(0.125, 0.25), Vec3::new(0.0, 0.0, 0.0), "t = 0.25 is the first (top) file row");
    assert_eq!(at(0.125, 0.75), Vec3::new(0.0, 1.0, 0.0));
    assert_eq!(at(-0.3, 0.25), Vec3::new(0.0, 0.0, 0.0), "negative s clamps to the first texel");
    assert_eq!(at(0.0, 0.0), Vec3::ZERO);
    assert_eq!(at(1.0, 0.25), Vec3::new(1.5, 0.0, 0.0), "s = 1: last and first column blended");
    assert_eq!(at(1.125, 0.25), at(0.125, 0.25), "wraps above 1");
}

#[test]
fn rdr171_level_zero_is_the_power_of_two_bilinear_resample() {
    // 3×1 → 4×1: texel i samples s = max(3·(i + ½)/4 − ½, 0), indices clamped
    let img = Level::new(3, 1, vec![Vec3::splat(0.0), Vec3::splat(4.0), Vec3::splat(8.0)]);
    let r = MipMap::new(img, TextureConvention::Rdr171, false);
    let l0 = &r.levels()[0];
    assert_eq!((l0.width, l0.height), (4, 1));
    let got: Vec<f32> = l0.to_linear().iter().map(|t| t.x).collect();
    // s = 0 (clamped from −0.125), 0.625, 1.375, 2.125 → 0, 2.5, 5.5, 8 (index 3 clamps to 2)
    let want = [0.0, 2.5, 5.5, 8.0];
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() < 1e-5, "{got:?} vs {want:?}");
    }
}

/// 8-bit files keep their bytes (4×4 tiles, decoded through a table): every texel of
/// every level, and bilinear and trilinear lookups anywhere (tile edges, wrapping,
/// odd sizes), equal bit for bit those of the pyramid of the same file read as `f32`.
#[test]
fn eight_bit_texels_read_exactly_as_their_decoded_values() {
    let dir = common::temp_dir("rdr-textures-eight-bit");
    let mut mismatches = 0;
    let mut lookups = 0;
    for (w, h, conv) in [
        (13, 7, TextureConvention::Physical),
        (6, 9, TextureConvention::Physical),
        (16, 8, TextureConvention::Rdr171),
    ] {
        let png = dir.path().join(format!("noise{w}x{h}.png"));
        rdr::imageio::write_png(&png, w as u32, h as u32, &noise_level(w, h, 11).to_linear()).unwrap();
        for raw in [false, true] {
            let eight = rdr::texture::image::load_mipmap(&png, conv, true, raw).unwrap();
            assert!(eight.levels()[0].is_encoded8(), "{w}x{h}: level 0 keeps the bytes");
            let img = rdr::imageio::read_texture_image_as(&png, raw).unwrap();
            let float = MipMap::new(Level::new(img.width, img.height, img.pixels), conv, true);
            assert_eq!(eight.levels().len(), float.levels().len());
            for (a, b) in eight.levels().iter().zip(float.levels()) {
                mismatches += a.to_linear().iter().zip(&b.to_linear()).filter(|(p, q)| p != q).count();
            }
            for i in 0..400 {
                let st = Vec2::new(
                    -1.3 + 3.7 * ((i * 37 % 400) as f32 / 400.0),
                    -0.9 + 2.9 * ((i * 91 % 400) as f32 / 400.0),
                );
                let d = Vec2::splat(0.004 * (i % 7) as f32);
                for level in 0..eight.levels().len() {
                    mismatches += (eight.bilinear(level, st) != float.bilinear(level, st)) as usize;
                }
                mismatches += (eight.lookup(st, d, d) != float.lookup(st, d, d)) as usize;
                mismatches += (eight.luminance_gradient(st) != float.luminance_gradient(st)) as usize;
                mismatches += (eight.nearest(st) != float.nearest(st)) as usize;
                lookups += eight.levels().len() + 3;
            }
        }
    }
    assert_eq!(
        mismatches, 0,
        "{mismatches} of {lookups} lookups (and texels) differ from the f32 pyramid's"
    );
}
