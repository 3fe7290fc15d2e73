//! Participating media: the phase functions sample their densities (χ²); delta
//! tracking with hero-channel MIS gives exp(−σt·d) per channel; analytic scenes (a
//! furnace of scattering medium with the camera inside it, single scattering in a thin
//! slab, nested medium boundaries) render their closed-form answers; bad medium
//! parameters are one-line errors naming file and key.

mod common;
use common::chi2::chi2;
use common::*;
use rdr::desc::SceneDesc;
use rdr::math::{Frame, Vec3};
use rdr::medium::{delta_tracking, HeroWeights, Heterogeneous, Homogeneous, Medium, PhaseFunction, Tracked};
use rdr::{Loaded, Profile};
use std::path::{Path, PathBuf};

#[test]
fn phase_functions_sample_their_density() {
    let wo = Vec3::new(0.3, -0.4, 0.8).normalize();
    for phase in [
        PhaseFunction::Isotropic,
        PhaseFunction::HenyeyGreenstein { g: 0.8 },
        PhaseFunction::HenyeyGreenstein { g: 0.3 },
        PhaseFunction::HenyeyGreenstein { g: -0.6 },
    ] {
        // the pdf returned with a sample is the density at it, the value equals the density
        let mut rng = rdr::sampling::SplitMix64(7);
        for _ in 0..1000 {
            let u = rdr::math::Vec2::new(rng.unit_f32(), rng.unit_f32());
            let (wi, pdf) = phase.sample(wo, u);
            assert!((wi.length() - 1.0).abs() < 1e-4 && (pdf - phase.pdf(wo, wi)).abs() <= 1e-4 * pdf);
            assert_eq!(phase.eval(wo, wi), phase.pdf(wo, wi));
        }
        // bins about the direction light keeps when it is not deflected (−wo)
        chi2(
            &format!("{phase:?}"),
            300_000,
            Frame::from_normal(-wo),
            |u| Some(phase.sample(wo, u).0),
            |w| phase.pdf(wo, w),
        );
    }
}

/// The mean over `n` paths of a channel's weight when delta tracking passes a
/// homogeneous slab of thickness `d` (0 when it scatters or is absorbed).
fn tracked_transmittance(m: &Medium, d: f32, n: usize) -> Vec3 {
    let mut rng = rdr::sampling::SplitMix64(11);
    let ray = rdr::geometry::Ray::with_range(Vec3::ZERO, Vec3::Z, 0.0, 1e7);
    let mut sum = Vec3::ZERO;
    for _ in 0..n {
        let mut w = HeroWeights::new(rng.unit_f32());
        let (found, f) = delta_tracking(m, &ray, d, w.hero, || rng.unit_f32());
        let mut beta = Vec3::ONE;
        w.apply(f, &mut beta);
        if found == Tracked::Passed {
            sum += beta;
        }
    }
    sum / n as f32
}

#[test]
fn delta_tracking_passes_a_slab_with_its_transmittance() {
    let sigma_t = Vec3::new(0.5, 1.0, 2.0);
    let m = Medium::Homogeneous(Homogeneous::new(sigma_t, Vec3::splat(0.7), 1.0, PhaseFunction::Isotropic).unwrap());
    let (d, n) = (0.8, 400_000);
    let got = tracked_transmittance(&m, d, n);
    for c in 0..3 {
        let exact = (-sigma_t[c] * d).exp();
        // binomial-like noise of a weight at most 3
        let sigma = 3.0 * (exact / n as f32).sqrt();
        eprintln!("channel {c}: {} vs exp(-σt·d) = {exact} (σ {sigma:.1e})", got[c]);
        assert!((got[c] - exact).abs() < 4.0 * sigma, "channel {c}: {} vs {exact}", got[c]);
    }
}

#[test]
fn grid_medium_tracking_gives_the_transmittance_of_a_constant_volume() {
    // a heterogeneous medium over a constant volume: its majorant is the largest channel,
    // so the other channels see null collisions (delta tracking) and ratios (ratio tracking)
    use rdr::volume::{ConstVolume, Volume};
    let sigma_t = Vec3::new(0.5, 1.0, 2.0);
    let box_of = |value: Vec3| {
        Volume::Constant(ConstVolume {
            value,
            to_world: rdr::math::Mat4::from_translation(Vec3::splat(-5.0)) * rdr::math::Mat4::from_scale(Vec3::splat(10.0)),
        })
    };
    let m = Medium::Heterogeneous(Box::new(
        Heterogeneous::new(box_of(sigma_t), box_of(Vec3::splat(0.7)), 1.0, PhaseFunction::Isotropic).unwrap(),
    ));
    let (d, n) = (0.8, 400_000);
    let delta = tracked_transmittance(&m, d, n);
    let mut rng = rdr::sampling::SplitMix64(5);
    let ray = rdr::geometry::Ray::with_range(Vec3::ZERO, Vec3::Z, 0.0, 1e7);
    let ratio = (0..n)
        .map(|_| rdr::medium::ratio_tracking(&m, &ray, d, || rng.unit_f32()))
        .sum::<Vec3>()
        / n as f32;
    for c in 0..3 {
        let exact = (-sigma_t[c] * d).exp();
        let sigma = 3.0 * (exact / n as f32).sqrt();
        eprintln!(
            "channel {c}: delta {} ratio {} vs exp(-σt·d) = {exact} (σ {sigma:.1e})",
            delta[c], ratio[c]
        );
        assert!(
            (delta[c] - exact).abs() < 4.0 * sigma,
            "delta tracking, channel {c}: {} vs {exact}",
            delta[c]
        );
        assert!(
            (ratio[c] - exact).abs() < 4.0 * sigma,
            "ratio tracking, channel {c}: {} vs {exact}",
            ratio[c]
        );
    }
}

/// Renders a Mitsuba XML scene given as text (twice, `spp` each); the mean over both
/// images' pixels and its standard error from their spread (the scenes' pixels all
/// estimate nearly the same value).
fn render_xml(xml: &str, spp: u32) -> (Vec3, Vec3) {
    let dir = temp_dir("rdr-media");
    let path = dir.path().join("scene.xml");
    std::fs::write(&path, xml).unwrap();
    let s = load_scene(&path, &[], Profile::Physical);
    let (a, b) = (render(&s, spp, 1), render(&s, spp, 2));
    let px: Vec<glam::DVec3> = a.pixels.iter().chain(&b.pixels).map(|p| p.as_dvec3()).collect();
    let n = px.len() as f64;
    let mean = px.iter().sum::<glam::DVec3>() / n;
    let var = px.iter().map(|p| (*p - mean) * (*p - mean)).sum::<glam::DVec3>() / (n - 1.0);
    (mean.as_vec3(), (var / n).as_vec3().map(f32::sqrt))
}

fn camera(origin: &str, target: &str, up: &str, fov: f32, medium: &str) -> String {
    format!(
        r#"<sensor type="perspective"><float name="fov" value="{fov}"/>
             <transform name="to_world"><lookat origin="{origin}" target="{target}" up="{up}"/></transform>
             <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/><rfilter type="box"/></film>
             {medium}</sensor>"#
    )
}

/// A scattering medium (albedo 1, chromatic extinction) inside a closed box whose
/// inner walls emit radiance 1, the camera inside the medium: every pixel is 1.
fn furnace_xml() -> String {
    format!(
        r#"<scene version="3.0.0">
          <integrator type="volpath"><integer name="max_depth" value="-1"/></integrator>
          <medium type="homogeneous" id="fog"><rgb name="sigma_t" value="0.5, 1, 2"/><float name="albedo" value="1"/>
            <phase type="hg"><float name="g" value="0.5"/></phase></medium>
          {}
          <shape type="cube"><boolean name="flip_normals" value="true"/>
            <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
        </scene>"#,
        camera("0, 0, 0", "0, 0, 1", "0, 1, 0", 60.0, r#"<ref id="fog"/>"#)
    )
}

#[test]
fn scattering_medium_in_an_emitting_box_renders_its_radiance() {
    let (mean, err) = render_xml(&furnace_xml(), 256);
    eprintln!("furnace: {mean} ± {err}");
    for c in 0..3 {
        assert!(
            (mean[c] - 1.0).abs() < 4.0 * err[c] + 0.01,
            "channel {c}: {mean} ± {err}, expected 1"
        );
    }
}

/// A slab z ∈ [−d/2, d/2] of absorbing medium (σt (0.5, 1, 2), albedo 0) emitting
/// radiance `le`, seen head-on in vacuum with nothing behind it; `grid`: the medium is
/// a heterogeneous one over a constant volume, whose majorant (the largest channel)
/// makes the other channels meet null collisions.
fn emissive_slab_xml(d: f32, le: Vec3, grid: bool) -> String {
    let (sigma, le) = ("0.5, 1, 2", format!("{}, {}, {}", le.x, le.y, le.z));
    let medium = if grid {
        format!(
            r#"<medium type="heterogeneous" name="interior">
              <volume type="constvolume" name="sigma_t"><rgb name="value" value="{sigma}"/>
                <transform name="to_world"><scale x="200" y="200" z="{d}"/><translate x="-100" y="-100" z="{}"/></transform></volume>
              <float name="albedo" value="0"/><rgb name="radiance" value="{le}"/></medium>"#,
            -d / 2.0
        )
    } else {
        format!(
            r#"<medium type="homogeneous" name="interior"><rgb name="sigma_t" value="{sigma}"/>
              <float name="albedo" value="0"/><rgb name="radiance" value="{le}"/></medium>"#
        )
    };
    format!(
        r#"<scene version="3.0.0">
          <integrator type="volpath"/>
          {}
          <shape type="cube"><transform name="to_world"><scale x="100" y="100" z="{}"/></transform>
            <bsdf type="null"/>{medium}</shape>
        </scene>"#,
        camera("0, 0, 5", "0, 0, 0", "0, 1, 0", 1.0, ""),
        d / 2.0
    )
}

#[test]
fn emissive_absorbing_slab_glows_as_the_closed_form() {
    // L = Le·(1 − exp(−σa·d)) per channel: emission σa·Le per unit length, attenuated
    // by the same σa on its way out
    let (d, le) = (1.0f32, Vec3::new(1.0, 2.0, 0.5));
    for grid in [false, true] {
        let (mean, err) = render_xml(&emissive_slab_xml(d, le, grid), 512);
        let sigma = Vec3::new(0.5, 1.0, 2.0);
        let exact = le * (Vec3::ONE - (-sigma * d).exp());
        eprintln!("emissive slab (grid {grid}): {mean} ± {err} vs {exact}");
        for c in 0..3 {
            assert!(
                (mean[c] - exact[c]).abs() < 4.0 * err[c] + 2e-3 * exact[c],
                "grid {grid}, channel {c}: {mean} ± {err} vs {exact}"
            );
        }
    }
}

/// An emissive scattering medium (σt (0.5, 1, 2), albedo 0.6, radiance `le`) filling a
/// closed box whose walls emit `le`, the camera inside: radiance Le everywhere solves
/// the transport equation (−σt·Le + σa·Le + σs·Le = 0), so every pixel is Le. `grid`:
/// the medium over a constant volume larger than the box, with null collisions.
fn emissive_furnace_xml(le: Vec3, grid: bool) -> String {
    let le = format!("{}, {}, {}", le.x, le.y, le.z);
    let sigma_t = if grid {
        r#"<volume type="constvolume" name="sigma_t"><rgb name="value" value="0.5, 1, 2"/>
             <transform name="to_world"><scale value="4"/><translate value="-2"/></transform></volume>"#
    } else {
        r#"<rgb name="sigma_t" value="0.5, 1, 2"/>"#
    };
    format!(
        r#"<scene version="3.0.0">
          <integrator type="volpath"><integer name="max_depth" value="-1"/></integrator>
          <medium type="{}" id="glow">{sigma_t}<float name="albedo" value="0.6"/><rgb name="radiance" value="{le}"/>
            <phase type="hg"><float name="g" value="0.5"/></phase></medium>
          {}
          <shape type="cube"><boolean name="flip_normals" value="true"/>
            <emitter type="area"><rgb name="radiance" value="{le}"/></emitter></shape>
        </scene>"#,
        if grid { "heterogeneous" } else { "homogeneous" },
        camera("0, 0, 0", "0, 0, 1", "0, 1, 0", 60.0, r#"<ref id="glow"/>"#)
    )
}

#[test]
fn emissive_scattering_medium_in_a_box_of_its_radiance_renders_it() {
    let le = Vec3::new(1.0, 2.0, 0.5);
    for grid in [false, true] {
        let (mean, err) = render_xml(&emissive_furnace_xml(le, grid), 512);
        eprintln!("emissive furnace (grid {grid}): {mean} ± {err} vs {le}");
        for c in 0..3 {
            assert!(
                (mean[c] - le[c]).abs() < 4.0 * err[c] + 0.01 * le[c],
                "grid {grid}, channel {c}: {mean} ± {err}, expected {le}"
            );
        }
    }
}

#[test]
fn hide_emitters_hides_what_the_camera_ray_sees_of_an_emissive_medium() {
    // the emissive furnace's box 100 times larger: the camera ray sees Le·(1 − albedo)
    // emitted along it before its first scattering (and no wall), hidden; the rest,
    // Le·albedo, arrives after scattering and stays
    let le = Vec3::new(1.0, 2.0, 0.5);
    let xml = emissive_furnace_xml(le, false)
        .replace(r#"value="-1"/>"#, r#"value="-1"/><boolean name="hide_emitters" value="true"/>"#)
        .replace(
            r#"<boolean name="flip_normals" value="true"/>"#,
            r#"<boolean name="flip_normals" value="true"/><transform name="to_world"><scale value="100"/></transform>"#,
        );
    let (mean, err) = render_xml(&xml, 256);
    let exact = le * 0.6;
    eprintln!("hidden emitters in an emissive medium: {mean} ± {err} vs {exact}");
    for c in 0..3 {
        assert!(
            (mean[c] - exact[c]).abs() < 4.0 * err[c] + 0.01 * exact[c],
            "channel {c}: {mean} ± {err}, expected {exact}"
        );
    }
}

/// E2(x) = ∫₀¹ exp(−x/μ) dμ by the midpoint rule.
fn e2(x: f64) -> f64 {
    let n = 4000;
    (0..n).map(|i| (-x / ((i as f64 + 0.5) / n as f64)).exp()).sum::<f64>() / n as f64
}

#[test]
fn thin_slab_single_scattering_matches_the_closed_form() {
    // a slab y ∈ [0, d] of isotropic medium under a uniform sky of radiance 1, seen
    // straight down; max_depth 2: the sky through the slab, and light scattered once
    let (sigma, albedo, d) = (1.0f64, 0.8f64, 1.0f64);
    let xml = format!(
        r#"<scene version="3.0.0">
          <integrator type="volpath"><integer name="max_depth" value="2"/></integrator>
          {}
          <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
          <shape type="cube"><transform name="to_world"><scale x="100" y="{h}" z="100"/><translate y="{h}"/></transform>
            <bsdf type="null"/>
            <medium type="homogeneous" name="interior"><float name="sigma_t" value="{sigma}"/><float name="albedo" value="{albedo}"/></medium>
          </shape>
        </scene>"#,
        camera("0, 5, 0", "0, 0, 0", "0, 0, 1", 1.0, ""),
        h = d / 2.0
    );
    let (mean, err) = render_xml(&xml, 1024);
    // ∫₀^d σs e^{−σt} · ½[E2(σt) + E2(σ(d−t))] dt, and the sky seen through the slab
    let n = 2000;
    let single: f64 = (0..n)
        .map(|i| {
            let t = (i as f64 + 0.5) / n as f64 * d;
            albedo * sigma * (-sigma * t).exp() * 0.5 * (e2(sigma * t) + e2(sigma * (d - t)))
        })
        .sum::<f64>()
        * d
        / n as f64;
    let exact = ((-sigma * d).exp() + single) as f32;
    eprintln!("thin slab: {mean} ± {err} vs {exact} (single scattering {single:.4})");
    for c in 0..3 {
        assert!((mean[c] - exact).abs() < 4.0 * err[c] + 2e-3, "channel {c}: {mean} vs {exact}");
    }
}

/// An absorbing sphere (interior A, exterior B) inside an absorbing box (interior B),
/// both null, under a uniform sky: seen through 2 units of B and 2 of A. B takes no light
/// sample (`sample_emitters` false; it does not scatter, so the image is the same).
fn nested_xml() -> String {
    format!(
        r#"<scene version="3.0.0">
          <integrator type="volpath"/>
          {}
          <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
          <medium type="homogeneous" id="b"><float name="sigma_t" value="0.25"/><float name="albedo" value="0"/>
            <boolean name="sample_emitters" value="false"/></medium>
          <shape type="cube"><transform name="to_world"><scale value="2"/></transform><bsdf type="null"/><ref name="interior" id="b"/></shape>
          <shape type="sphere"><float name="radius" value="1"/><bsdf type="null"/>
            <medium type="homogeneous" name="interior"><float name="sigma_t" value="0.5"/><float name="albedo" value="0"/></medium>
            <ref name="exterior" id="b"/></shape>
        </scene>"#,
        camera("0, 0, 10", "0, 0, 0", "0, 1, 0", 0.5, "")
    )
}

#[test]
fn nested_boundaries_switch_media_as_mitsuba_does() {
    let (mean, err) = render_xml(&nested_xml(), 1024);
    let exact = (-(0.25f32 * 2.0 + 0.5 * 2.0)).exp();
    eprintln!("nested: {mean} ± {err} vs {exact}");
    for c in 0..3 {
        assert!(
            (mean[c] - exact).abs() < 4.0 * err[c] + 0.01 * exact,
            "channel {c}: {mean} vs {exact}"
        );
    }
}

/// Each medium's phase function and its σa, σs and emitted radiance at a few points.
type MediumParams = Vec<(PhaseFunction, Vec<Vec3>)>;

/// What a built scene says about media: each medium's parameters, the camera's medium,
/// and each object's interface and null flag.
fn media_of(desc: &SceneDesc) -> (MediumParams, Option<u32>, Vec<String>) {
    let scene = Loaded::build(desc, Profile::Physical).unwrap_or_else(|e| panic!("{e}")).scene;
    // the last outside the grid's box, where its wrap mode decides
    let points = [
        Vec3::ZERO,
        Vec3::new(0.3, -0.2, 0.55),
        Vec3::new(-0.7, 0.4, 0.1),
        Vec3::new(0.9, 0.85, -0.6),
        Vec3::new(1.6, 0.2, 0.3),
    ];
    let media = scene
        .media
        .iter()
        .map(|m| {
            let values = points
                .iter()
                .flat_map(|&p| [m.at(p).sigma_a, m.at(p).sigma_s, m.radiance(p)])
                .collect();
            (m.phase(), values)
        })
        .collect();
    let objects = scene.objects.iter().map(|o| format!("{:?} {}", o.media, o.null_bsdf)).collect();
    (media, scene.camera_medium, objects)
}

/// A heterogeneous medium over `vols/grid.vol` (4³, values 0 to 6.3) with every
/// option of a grid volume, a placed constant albedo and a grid radiance.
fn grid_medium_xml() -> String {
    format!(
        r#"<scene version="3.0.0"><integrator type="volpath"/>{}
          <medium type="heterogeneous" id="smoke">
            <volume type="gridvolume" name="sigma_t"><string name="filename" value="vols/grid.vol"/>
              <string name="filter_type" value="nearest"/><string name="wrap_mode" value="repeat"/>
              <float name="max_value" value="9"/>
              <transform name="to_world"><scale value="2"/><translate value="-1"/></transform></volume>
            <volume type="constvolume" name="albedo"><rgb name="value" value="0.5, 0.6, 0.7"/>
              <transform name="to_world"><scale value="3"/><translate value="-1.5"/></transform></volume>
            <volume type="gridvolume" name="radiance"><string name="filename" value="vols/grid.vol"/>
              <boolean name="use_grid_bbox" value="true"/></volume>
            <float name="scale" value="2"/><phase type="hg"><float name="g" value="0.4"/></phase>
          </medium>
          <shape type="cube"><bsdf type="null"/><ref name="interior" id="smoke"/></shape></scene>"#,
        camera("0, 0, 5", "0, 0, 0", "0, 1, 0", 30.0, "")
    )
}

fn grid_file() -> Vec<u8> {
    let values = (0..64).map(|i| (i % 7) as f32 * 0.9 + (i / 16) as f32 * 0.1).collect();
    let bbox = rdr::geometry::Aabb::new(Vec3::splat(-1.0), Vec3::new(1.0, 0.5, 2.0));
    rdr::volume::vol_file::encode(&rdr::volume::GridData::new([4, 4, 4], 1, bbox, values).unwrap())
}

#[test]
fn convert_carries_media_both_ways() {
    let dir = temp_dir("rdr-media-convert");
    let write = |name: &str, text: &str, files: &[(PathBuf, Vec<u8>)]| {
        for (p, bytes) in files {
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, bytes).unwrap();
        }
        let p = dir.path().join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, text).unwrap();
        SceneDesc::load(&p, &[]).unwrap_or_else(|e| panic!("{e}"))
    };
    let emissive = emissive_furnace_xml(Vec3::new(1.0, 2.0, 0.5), false);
    let grid = (dir.path().join("vols/grid.vol"), grid_file());
    for (i, xml) in [nested_xml(), furnace_xml(), emissive, grid_medium_xml()].iter().enumerate() {
        let original = write(&format!("s{i}.xml"), xml, std::slice::from_ref(&grid));
        // the JSON in a folder of its own: grid files are named relative to it
        let out = rdr::desc::convert::to_json(&original, &dir.path().join(format!("json/s{i}.json"))).unwrap();
        let json = write(&format!("json/s{i}.json"), &out.text, &out.files);
        let out = rdr::desc::convert::to_xml(&json, &dir.path().join(format!("s{i}_back.xml"))).unwrap();
        let back = write(&format!("s{i}_back.xml"), &out.text, &out.files);
        let (a, b, c) = (media_of(&original), media_of(&json), media_of(&back));
        let sample_emitters = |d: &SceneDesc| d.media.iter().map(|m| m.sample_emitters).collect::<Vec<_>>();
        // only nested_xml's medium b takes no light sample
        let expected = if i == 0 {
            vec![false, true]
        } else {
            vec![true; original.media.len()]
        };
        assert_eq!(sample_emitters(&original), expected, "scene {i}: as read");
        for other in [&json, &back] {
            assert_eq!(sample_emitters(&original), sample_emitters(other), "scene {i}: sample_emitters");
        }
        assert!(!a.0.is_empty());
        for other in [&b, &c] {
            assert_eq!((&a.1, &a.2), (&other.1, &other.2), "scene {i}: camera medium or boundaries changed");
            assert_eq!(a.0.len(), other.0.len());
            for (x, y) in a.0.iter().zip(&other.0) {
                assert_eq!(x.0, y.0, "scene {i}: phase function");
                for (u, v) in x.1.iter().zip(&y.1) {
                    assert!(
                        (*u - *v).abs().max_element() <= 1e-5 * u.abs().max_element().max(1.0),
                        "scene {i}: {x:?} vs {y:?}"
                    );
                }
            }
        }
        if i == 3 {
            assert!(a.0[0].1.iter().any(|v| v.x > 0.0), "the grid medium is empty where sampled");
        }
    }
}

/// Loading `xml` fails with one line naming the file and `key`.
fn refused(xml: &str, key: &str) {
    let dir = temp_dir("rdr-media-bad");
    let path = dir.path().join("bad_medium.xml");
    std::fs::write(&path, xml).unwrap();
    let Err(e) = rdr::load(&path, &[], Profile::Physical) else {
        panic!("{xml} was accepted")
    };
    let msg = e.to_string();
    eprintln!("{msg}");
    assert!(
        !msg.trim().contains('\n') && msg.contains("bad_medium.xml") && msg.contains(&format!("\"{key}\"")),
        "{msg}"
    );
}

#[test]
fn bad_medium_parameters_are_one_line_errors() {
    let scene = |medium: &str| {
        format!(
            r#"<scene version="3.0.0"><integrator type="volpath"/>{}
              <shape type="sphere"><bsdf type="null"/>{medium}</shape></scene>"#,
            camera("0, 0, 5", "0, 0, 0", "0, 1, 0", 30.0, "")
        )
    };
    refused(
        &scene(r#"<medium type="homogeneous" name="interior"><phase type="hg"><float name="g" value="1.5"/></phase></medium>"#),
        "g",
    );
    refused(
        &scene(r#"<medium type="homogeneous" name="interior"><float name="albedo" value="1.2"/></medium>"#),
        "albedo",
    );
    refused(
        &scene(r#"<medium type="homogeneous" name="interior"><float name="sigma_t" value="-1"/></medium>"#),
        "sigma_t",
    );
    refused(&scene(r#"<medium type="homogeneous" name="inside"/>"#), "inside");
}

/// `file` rendered at 1/k of its resolution (twice, `spp` each) against the reference
/// `refs/<name>.exr` averaged over k×k blocks: the noise-aware relative MSE, and the
/// image means' difference per channel with its standard error (ours and the
/// reference's noise), a sharper test where fireflies make the relative MSE noisy.
/// A JSON translation's grid files are read from `shared` (which `RDR_SHARED` may move);
/// `extra` overrides come after the grid path's own.
fn against_reference(
    shared: &Path,
    file: &Path,
    name: &str,
    k: usize,
    spp: u32,
    extra: &[String],
) -> (rdr::metrics::Comparison, Vec3, Vec3) {
    let mut overrides = match (name, file.extension().is_some_and(|e| e == "json")) {
        ("smoke_grid", true) => {
            let vol = shared.join("volumes/smoke.vol");
            vec![serde_json::json!({"media": {"smoke": {"sigma_t": {"filename": vol}}}}).to_string()]
        }
        _ => Vec::new(),
    };
    overrides.extend_from_slice(extra);
    let mut desc = SceneDesc::load(file, &overrides).unwrap_or_else(|e| panic!("{e}"));
    desc.film.width /= k as u32;
    desc.film.height /= k as u32;
    let loaded = Loaded::build(&desc, Profile::Physical).unwrap_or_else(|e| panic!("{e}"));
    let r = read(&shared.join(format!("refs/{name}.exr"))).block_average(k, false);
    let vr = read(&shared.join(format!("refs/{name}.var.exr"))).block_average(k, true);
    let (x1, x2) = (render(&loaded, spp, 1), render(&loaded, spp, 2));
    let c = rdr::metrics::compare(&x1, &x2, &r, &vr);
    let n = r.pixels.len() as f32;
    let diff = (x1.mean() + x2.mean()) * 0.5 - r.mean();
    let spread: Vec3 = x1.pixels.iter().zip(&x2.pixels).map(|(a, b)| (*a - *b) * (*a - *b) * 0.25).sum();
    let se = ((spread + vr.pixels.iter().sum::<Vec3>()) / (n * n)).map(f32::sqrt);
    eprintln!(
        "{:>18}: relMSE corrected {:+.2e} ± {:.1e} (raw {:.2e}, noise {:.2e}); mean − reference {diff:.4} ± {se:.4} (reference {:.4})",
        file.file_name().unwrap().to_string_lossy(),
        c.rel_mse_corrected,
        c.std_error,
        c.rel_mse_raw,
        c.rel_mse_noise,
        r.mean()
    );
    (c, diff, se)
}

fn translations() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/refs/media")
}

/// The reference's XML and its JSON translation (`tests/refs/media/`, if `json`)
/// converge to it.
fn assert_converges(shared: &Path, name: &str, k: usize, spp: u32, json: bool) {
    let xml = shared.join(format!("refs/mitsuba/{name}.xml"));
    let json = json.then(|| translations().join(format!("{name}.json")));
    for file in std::iter::once(xml).chain(json) {
        assert_close(shared, &file, name, k, spp, &[]);
    }
}

/// `file` (with `overrides`) converges to `refs/<name>.exr`: the relative MSE and the
/// image means ([`against_reference`]).
fn assert_close(shared: &Path, file: &Path, name: &str, k: usize, spp: u32, overrides: &[String]) {
    let (c, diff, se) = against_reference(shared, file, name, k, spp, overrides);
    assert!(
        c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4,
        "{} {overrides:?} does not converge to refs/{name}.exr: {c:?}",
        file.display()
    );
    for ch in 0..3 {
        assert!(
            diff[ch].abs() < 4.0 * se[ch],
            "{} {overrides:?}: channel {ch}'s mean is off the reference's by {} (± {})",
            file.display(),
            diff[ch],
            se[ch]
        );
    }
}

#[test]
fn fog_cbox_converges_to_mitsubas_volpath() {
    let Some(shared) = shared() else { return };
    assert_converges(&shared, "fog_cbox", 4, 64, true);
}

/// `guided` renders media through `path`'s estimator, guiding at surface vertices
/// (learning from the camera paths, which see the fog, or from photons, which do not):
/// fog_cbox converges to the reference either way.
#[test]
fn guided_fog_cbox_converges_to_mitsubas_volpath() {
    let Some(shared) = shared() else { return };
    // the JSON translation (overrides patch JSON scenes)
    let file = translations().join("fog_cbox.json");
    for from in ["paths", "photons"] {
        let o = format!(r#"{{"integrator": {{"type": "guided", "learn_from": "{from}", "spatial_threshold": 300}}}}"#);
        let (c, diff, se) = against_reference(&shared, &file, "fog_cbox", 4, 64, &[o]);
        assert!(
            c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4,
            "guided ({from}) does not converge to refs/fog_cbox.exr: {c:?}"
        );
        for ch in 0..3 {
            assert!(
                diff[ch].abs() < 4.0 * se[ch],
                "guided ({from}): channel {ch}'s mean is off the reference's by {} (± {})",
                diff[ch],
                se[ch]
            );
        }
    }
}

#[test]
fn fog_cbox_converges_with_ptracer_and_bdpt() {
    // light subpaths through the fog's null top face, medium vertices on both sides
    let Some(shared) = shared() else { return };
    for (integrator, spp) in [("ptracer", 64), ("bdpt", 32)] {
        let o = format!(r#"{{"integrator": {{"type": "{integrator}"}}}}"#);
        assert_close(&shared, &translations().join("fog_cbox.json"), "fog_cbox", 4, spp, &[o]);
    }
}

#[test]
fn smoke_grid_converges_to_mitsubas_volpath() {
    let Some(shared) = shared() else { return };
    assert_converges(&shared, "smoke_grid", 4, 64, true);
}

#[test]
fn milk_sphere_converges_to_mitsubas_volpathmis() {
    let Some(shared) = shared() else { return };
    assert_converges(&shared, "milk_sphere", 2, 64, true);
}

#[test]
fn mitsubas_path_renders_media_as_vacuum_with_a_warning() {
    // Mitsuba's `path` ignores media: the null boundaries pass, the sky arrives unattenuated
    let xml = nested_xml().replace(r#"<integrator type="volpath"/>"#, r#"<integrator type="path"/>"#);
    let dir = temp_dir("rdr-media-path");
    let path = dir.path().join("scene.xml");
    std::fs::write(&path, &xml).unwrap();
    let s = load_scene(&path, &[], Profile::Physical);
    let warned: Vec<&String> = s.scene.warnings.iter().filter(|w| w.contains("volpath renders them")).collect();
    assert_eq!(warned.len(), 1, "{:?}", s.scene.warnings);
    let (mean, err) = render_xml(&xml, 16);
    eprintln!("path: {mean} ± {err}");
    assert!((mean - Vec3::ONE).abs().max_element() < 1e-4, "{mean}");
}
