//! Learned Russian roulette and splitting (`path` with `rr: "ears"`): the estimator's
//! splitting step stays unbiased under forced factors (splitting averaged by 1/n,
//! roulette's survivors weighted by 1/q), EARS renders converge to Mitsuba's reference
//! and to `path`, and do not depend on the thread count.

mod common;
use common::*;
use rdr::integrator::estimator::{trace, Branches, PathProfile, PathState, Policy};
use rdr::integrator::{PathTracer, RayCounts, Roulette};
use rdr::material::bsdf::Bsdf;
use rdr::math::{Vec2, Vec3};
use rdr::metrics::{compare, Comparison, Image};
use rdr::sampler::PixelSampler;
use rdr::scene::Interaction;
use rdr::Profile;
use std::path::Path;

/// A policy splitting or playing roulette by fixed factors, one per segment (the last
/// one for every later segment); emitters seen directly are hidden.
struct Forced<'a> {
    factors: [f32; 4],
    branches: &'a mut Branches,
}

impl Policy for Forced<'_> {
    type Plan = ();

    fn profile(&self) -> PathProfile {
        PathProfile::Mis
    }

    fn max_depth(&self) -> u32 {
        12
    }

    fn hide_emitters(&self) -> bool {
        true
    }

    fn plan(&mut self, _: &Interaction, _: &Bsdf, _: &mut PixelSampler) {}

    const SPLITS: bool = true;

    fn split_factor(&self, _: &Interaction, _: Vec3, _: f32, segment: u32) -> (f32, u32) {
        (self.factors[(segment as usize - 1).min(3)], 0)
    }

    fn branches(&mut self) -> Option<&mut Branches> {
        Some(self.branches)
    }
}

/// Mean and standard error of the channels' mean over `n` camera samples of cbox,
/// and rays per sample.
fn cbox_estimate(
    loaded: &rdr::Loaded,
    n: u32,
    seed: u32,
    li: &mut dyn FnMut(rdr::geometry::Ray, &mut PixelSampler, &mut RayCounts) -> Vec3,
) -> (f64, f64, f64) {
    let (w, h) = (loaded.job.film.width, loaded.job.film.height);
    let mut counts = RayCounts::default();
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    for i in 0..n {
        let (x, y) = (i % w, (i / w) % h);
        let mut sampler = PixelSampler::new(x, y, i / (w * h), seed);
        let ray = loaded.job.camera.sample_ray(x as f32 + 0.5, y as f32 + 0.5, Vec2::new(0.5, 0.5));
        let l = li(ray, &mut sampler, &mut counts);
        let v = ((l.x + l.y + l.z) / 3.0) as f64;
        s += v;
        s2 += v * v;
    }
    let m = s / n as f64;
    (m, ((s2 / n as f64 - m * m) / n as f64).sqrt(), counts.rays as f64 / n as f64)
}

#[test]
fn forced_splitting_and_roulette_keep_cbox_unbiased() {
    let Some(shared) = shared() else { return };
    let o = r#"{"film": {"resolution": [32, 32]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/cbox_path.json"), &[o], Profile::Physical);
    let scene = &loaded.scene;
    let path = PathTracer {
        max_depth: 12,
        profile: PathProfile::Mis,
        rr_threshold: 0.1,
        // the light seen directly, the noisiest term, is no business of roulette's
        hide_emitters: true,
        rr: Roulette::Mitsuba,
    };
    let n = 40_000;
    let (mp, sp, rays_p) = cbox_estimate(&loaded, n, 1, &mut |ray, sampler, counts| {
        path.li(scene, ray, None, sampler, counts)
    });
    let mut branches = Branches::default();
    // splitting into 2.5 (2 or 3) at the first vertex, roulette at 0.4 at the second,
    // splitting by 1.7 at the third, roulette at 0.8 from the fourth on
    let (mf, sf, rays_f) = cbox_estimate(&loaded, n, 2, &mut |ray, sampler, counts| {
        branches.begin(counts.rays);
        let mut policy = Forced {
            factors: [2.5, 0.4, 1.7, 0.8],
            branches: &mut branches,
        };
        trace(&mut policy, scene, PathState::new(ray), 1, None, sampler, counts)
    });
    let z = (mf - mp) / (sf * sf + sp * sp).sqrt();
    eprintln!("cbox: path {mp:.5} ± {sp:.5} ({rays_p:.1} rays), forced factors {mf:.5} ± {sf:.5} ({rays_f:.1} rays): z = {z:+.2}");
    // the splits were taken: more rays per camera sample than `path`'s
    assert!(rays_f > 1.5 * rays_p, "{rays_f} rays per sample against path's {rays_p}");
    assert!(z.abs() < 5.0, "z = {z}");
}

/// Two renders (seeds 1, 2) of `scene` at half its resolution with `overrides`.
fn half_res(shared: &Path, scene: &str, spp: u32, overrides: &[&str]) -> (Image, Image) {
    let path = shared.join(format!("refs/scenes/{scene}.json"));
    let o = [&[r#"{"film": {"resolution": [128, 128]}}"#], overrides].concat();
    let s = load_scene(&path, &o, Profile::Physical);
    (render(&s, spp, 1), render(&s, spp, 2))
}

fn report(name: &str, c: &Comparison) -> bool {
    eprintln!(
        "{name:>32}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
        c.rel_mse_corrected, c.std_error, c.rel_mse_raw, c.rel_mse_noise
    );
    c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4
}

const EARS: &str = r#"{"integrator": {"rr": "ears"}}"#;

#[test]
fn ears_converges_to_the_reference_and_to_path() {
    let Some(shared) = shared() else { return };
    // caustic_cbox (256×256): the reference averaged over 2×2 blocks is exactly what a
    // box-filtered half-resolution render converges to
    let r = read(&shared.join("refs/caustic_cbox.exr")).block_average(2, false);
    let vr = read(&shared.join("refs/caustic_cbox.var.exr")).block_average(2, true);
    let (a, b) = half_res(&shared, "caustic_cbox", 32, &[EARS]);
    let to_reference = compare(&a, &b, &r, &vr);
    assert!(report("caustic_cbox ears vs reference", &to_reference), "{to_reference:?}");
    // env_sphere: against `path`'s own renders at seeds of their own (their mean, and the
    // variance of that mean from their difference)
    let file = shared.join("refs/scenes/env_sphere.json");
    let o = r#"{"film": {"resolution": [128, 128]}}"#;
    let (path, ears) = (
        load_scene(&file, &[o], Profile::Physical),
        load_scene(&file, &[o, EARS], Profile::Physical),
    );
    let (to_path, _) = common::transport::against_path("env_sphere ears vs path", &path, &ears, 32, 32, 1);
    assert!(to_path.rel_mse_corrected.abs() < 5.0 * to_path.std_error + 2e-4, "{to_path:?}");
}

#[test]
fn ears_image_is_the_same_for_1_2_3_threads() {
    let Some(shared) = shared() else { return };
    // passes 2, 4 and 8 end iterations: the factors learned change the later passes
    let o = r#"{"integrator": {"rr": "ears"}, "film": {"resolution": [48, 48]}}"#;
    assert_same_image_for_1_2_3_threads(&shared.join("refs/scenes/caustic_cbox.json"), 12, o, "path with rr ears");
}

#[test]
fn an_unknown_roulette_is_refused_by_name() {
    let Some(shared) = shared() else { return };
    let o = vec![r#"{"integrator": {"rr": "fast"}}"#.to_string()];
    let file = shared.join("refs/scenes/cbox_path.json");
    let e = rdr::load(&file, &o, Profile::Physical)
        .err()
        .expect("rr 'fast' is refused")
        .to_string();
    eprintln!("{e}");
    assert!(e.contains("integrator.rr") && e.contains("'fast'") && e.contains("ears"), "{e}");
}
