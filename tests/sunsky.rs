//! Mitsuba 3's `sunsky` emitter (issue 41): rdr's `path` converges to Mitsuba 3's
//! images (`tests/refs/sunsky/`, made by `scripts/make_sunsky_refs.py`) of a ground and
//! ball under sun and sky and of the sky alone (placed by date and time, turned by
//! `to_world`), from the XML and from its conversion to JSON and back; importance
//! sampling of the sky and the sun's disc matches its pdf (χ²); bad parameters fail
//! with the key named.

mod common;
use common::chi2::chi2_test;
use common::*;
use rdr::desc::SceneDesc;
use rdr::light::environment::EnvironmentLight;
use rdr::light::sunsky::{one_minus_cos, SkyModel, SunModel, SunSkyParams, SUN_HALF_APERTURE};
use rdr::light::LightSampling;
use rdr::math::{Frame, Mat4, Vec2, Vec3, PI};
use rdr::Profile;
use std::path::{Path, PathBuf};

fn refs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/sunsky")
}

/// `name`.xml converted to JSON (and that back to XML) in `dir`: the two files.
fn converted(name: &str, dir: &Path) -> (PathBuf, PathBuf) {
    let xml = refs().join(format!("{name}.xml"));
    let desc = SceneDesc::load(&xml, &[]).unwrap_or_else(|e| panic!("{e}"));
    let json = dir.join(format!("{name}.json"));
    let out = rdr::desc::convert::to_json(&desc, &json).unwrap_or_else(|e| panic!("{e}"));
    write_converted(&json, out);
    let back = dir.join(format!("{name}_back.xml"));
    let desc = SceneDesc::load(&json, &[]).unwrap_or_else(|e| panic!("{e}"));
    let out = rdr::desc::convert::to_xml(&desc, &back).unwrap_or_else(|e| panic!("{e}"));
    write_converted(&back, out);
    (json, back)
}

fn write_converted(file: &Path, out: rdr::desc::convert::Converted) {
    for (p, bytes) in &out.files {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }
    std::fs::write(file, out.text).unwrap();
}

#[test]
fn path_converges_to_mitsubas_images() {
    let dir = temp_dir("rdr-sunsky");
    let mut failed = Vec::new();
    for (name, spp) in [("sunsky", 256), ("sky_up", 16)] {
        let (json, back) = converted(name, dir.path());
        for file in [refs().join(format!("{name}.xml")), json, back] {
            // the same model as Mitsuba's: a floor ten times below the other references'
            if !converges_to_ref_within(&refs(), &file, name, &[], spp, 2e-5) {
                failed.push(file.display().to_string());
            }
        }
    }
    assert!(failed.is_empty(), "not converging to Mitsuba: {failed:?}");
}

/// The sky alone, pixel by pixel: rdr's image of `sky_up` against Mitsuba's, each
/// pixel within 4 standard deviations of the two images' noise (the camera sees the
/// sky directly: only the pixel footprint is sampled).
#[test]
fn sky_matches_mitsuba_pixel_by_pixel() {
    let s = load_scene(&refs().join("sky_up.xml"), &[], Profile::Physical);
    let (a, b) = (render(&s, 64, 1), render(&s, 64, 2));
    let r = read(&refs().join("sky_up.exr"));
    let vr = read(&refs().join("sky_up.var.exr"));
    let mut worst = 0.0f32;
    for i in 0..r.pixels.len() {
        let mean = (a.pixels[i] + b.pixels[i]) * 0.5;
        // the two renders' spread as the variance of their mean
        let d = a.pixels[i] - b.pixels[i];
        let var = d * d * 0.25 + vr.pixels[i] + Vec3::splat(1e-10);
        let z = ((mean - r.pixels[i]).abs() / (var * 2.0).powf(0.5)).max_element();
        worst = worst.max(z);
    }
    let rel = a.mean() / r.mean();
    eprintln!("sky_up: worst pixel {worst:.2} sigma, mean ratio {rel}");
    assert!(
        worst < 6.0 && (rel - Vec3::ONE).abs().max_element() < 3e-3,
        "worst {worst}, ratio {rel}"
    );
}

fn params(sun: Vec3) -> SunSkyParams {
    SunSkyParams {
        turbidity: 4.0,
        albedo: Vec3::new(0.2, 0.3, 0.15),
        sun: sun.normalize(),
        sky_scale: 1.0,
        sun_scale: 1.0,
        sun_half_aperture: SUN_HALF_APERTURE,
        complex_sun: false,
    }
}

/// Importance sampling of the whole sunsky against its pdf, binned on the sky's own
/// grid (64 × 32 bins of 4 × 4 cells, where the table's density is constant, so a
/// midpoint rule gives the masses exactly); the bin holding the sun also gets the
/// density integrated over a cap twice the disc's area around it (rings of equal
/// solid angle, the disc's edge on a ring boundary). Returns the χ² test's outcome.
fn sunsky_chi2(env: &EnvironmentLight, sun_world: Vec3, n: usize) -> Result<f64, String> {
    let (nu, nv) = (64, 32);
    let mode = LightSampling::Importance;
    let mut rng = rdr::sampling::SplitMix64(0x0005_eed5_u64);
    let bin = |w: Vec3| {
        let uv = env.direction_to_uv(w);
        ((uv.y * nv as f32) as usize).min(nv - 1) * nu + ((uv.x * nu as f32) as usize).min(nu - 1)
    };
    let mut observed = vec![0.0f64; nu * nv];
    for _ in 0..n {
        if let Some(s) = env.sample(Vec2::new(rng.unit_f32(), rng.unit_f32()), mode) {
            observed[bin(s.wi)] += 1.0;
        }
    }
    let k = 4;
    let mut mass = vec![0.0f64; nu * nv];
    for (b, m) in mass.iter_mut().enumerate() {
        let (i, j) = (b % nu, b / nu);
        for a in 0..k * k {
            let uv = Vec2::new(
                (i as f32 + ((a % k) as f32 + 0.5) / k as f32) / nu as f32,
                (j as f32 + ((a / k) as f32 + 0.5) / k as f32) / nv as f32,
            );
            let (w, sin_theta) = env.uv_to_direction(uv);
            *m += (env.pdf(w, mode) * 2.0 * PI * PI * sin_theta) as f64 / (nu * nv * k * k) as f64;
        }
    }
    let frame = Frame::from_normal(sun_world);
    let h_cap = 2.0 * one_minus_cos(SUN_HALF_APERTURE) as f64;
    let (rings, spokes) = (200, 64);
    let mut cap = 0.0f64;
    for r in 0..rings {
        let h = (r as f64 + 0.5) / rings as f64 * h_cap;
        let sin_t = (h * (2.0 - h)).sqrt();
        for s in 0..spokes {
            let phi = 2.0 * std::f64::consts::PI * (s as f64 + 0.5) / spokes as f64;
            let l = Vec3::new((sin_t * phi.cos()) as f32, (sin_t * phi.sin()) as f32, (1.0 - h) as f32);
            cap += env.pdf(frame.to_world(l).normalize(), mode) as f64;
        }
    }
    mass[bin(sun_world)] += cap * 2.0 * std::f64::consts::PI * h_cap / (rings * spokes) as f64;
    chi2_test("sunsky importance", n, &observed, &mass)
}

#[test]
fn importance_sampling_matches_its_pdf() {
    // the sun at the centre of a bin (of 64 × 32) is inside it (its disc is far
    // smaller) and off the midpoints of its 4 × 4 cells
    for (bin_uv, to_world) in [
        (Vec2::new(10.5 / 64.0, 9.5 / 32.0), Mat4::IDENTITY),
        (Vec2::new(40.5 / 64.0, 12.5 / 32.0), Mat4::from_rotation_x(-0.5 * PI)),
    ] {
        let grid = EnvironmentLight::sunsky(None, None, &to_world);
        let sun_local = to_world.inverse().transform_vector3(grid.uv_to_direction(bin_uv).0);
        assert!(sun_local.z > 0.1, "{sun_local}");
        let p = params(sun_local);
        // (the limb-darkened sun samples as the flat one: the same disc, the same power)
        let env = EnvironmentLight::sunsky(Some(SkyModel::new(&p)), Some(SunModel::new(&p)), &to_world);
        let sun_world = to_world.transform_vector3(p.sun).normalize();
        sunsky_chi2(&env, sun_world, 1_000_000).unwrap_or_else(|e| panic!("sun {sun_local}: {e}"));
    }
}

/// Each bad parameter fails with one line naming it.
#[test]
fn bad_parameters_are_refused_with_the_key() {
    let dir = temp_dir("rdr-sunsky-bad");
    for (prop, key) in [
        (r#"<float name="turbidity" value="11"/>"#, "turbidity"),
        (r#"<rgb name="albedo" value="0.5, 1.5, 0.5"/>"#, "albedo"),
        (r#"<float name="sun_scale" value="-1"/>"#, "sun_scale"),
        (r#"<float name="sun_aperture" value="0"/>"#, "sun_aperture"),
        (
            r#"<vector name="sun_direction" x="0" y="0" z="1"/><float name="hour" value="9"/>"#,
            "hour",
        ),
        (r#"<transform name="to_world"><scale x="2"/></transform>"#, "to_world"),
        (r#"<float name="turbidty" value="3"/>"#, "turbidty"),
    ] {
        let file = dir.path().join("s.xml");
        let xml = format!(r#"<scene version="3.0.0"><sensor type="perspective"/><emitter type="sunsky">{prop}</emitter></scene>"#);
        std::fs::write(&file, xml).unwrap();
        // a misspelt key is an unknown property (refused under --strict), the others errors
        let e = match SceneDesc::load(&file, &[]) {
            Err(e) => e.to_string(),
            Ok(d) => format!("s.xml: {}", d.unknown.join("; ")),
        };
        assert!(e.contains(key) && e.contains("s.xml") && !e.contains('\n'), "{prop}: {e}");
    }
    for (body, key) in [
        (r#""sunsky": {"turbidity": 0.5}"#, "turbidity"),
        (r#""sunsky": {"sun_direction": [0, 0, 1], "year": 2020}"#, "year"),
        (r#""sunsky": {"sun_dir": [0, 0, 1]}"#, "sun_dir"),
    ] {
        let file = dir.path().join("s.json");
        let json = format!(
            r#"{{"camera": {{"position": [0, 0, 0], "look_at": [0, 0, 1]}}, "film": {{"resolution": [4, 4]}}, "objects": [], {body}}}"#
        );
        std::fs::write(&file, json).unwrap();
        let msg = match SceneDesc::load(&file, &[]) {
            Err(e) => e.to_string(),
            Ok(d) => d.unknown.join("; "),
        };
        assert!(msg.contains(key), "{body}: {msg}");
    }
}
