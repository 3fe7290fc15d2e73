//! The `guided` integrator (path guiding with an SD-tree).

mod common;
use common::*;
use rdr::film::Film;
use rdr::integrator::guided::{learned_tree, DTree};
use rdr::integrator::{Integrator, PassContext, StopToken};
use rdr::math::{Vec2, Vec3};
use rdr::Profile;

/// Runs a scene's guided job pass by pass and returns the film (holding the tree).
fn train(loaded: &rdr::Loaded, spp: u32) -> Film {
    let job = &loaded.job;
    let Integrator::Guided(g) = job.integrator else { panic!("not guided") };
    let mut film = Film::new(job.film.width, job.film.height, job.film.filter);
    let stop = StopToken::new();
    let ctx = PassContext {
        scene: &loaded.scene,
        camera: &job.camera,
        film: &job.film,
        spp,
        seed: 7,
        time_limit: None,
        stop: &stop,
        progress: &|_| {},
    };
    for pass in 0..spp {
        assert!(g.render_pass(&ctx, pass, &mut film).complete);
    }
    film
}

/// Fractions of `n` directions from `sample` whose rays from `p` hit object `a`, object `b`.
fn hit_fractions(scene: &rdr::Scene, p: Vec3, n: usize, mut sample: impl FnMut(Vec2) -> Option<Vec3>, objects: [u32; 2]) -> [f64; 2] {
    let mut rng = Rng::new(99);
    let mut hits = [0usize; 2];
    for _ in 0..n {
        let Some(d) = sample(Vec2::new(rng.unit() as f32, rng.unit() as f32)) else { continue };
        let ray = rdr::geometry::Ray::new(p, d);
        if let Some(h) = scene.intersect(&ray) {
            let it = scene.interaction(&ray, &h);
            for k in 0..2 {
                if it.object == objects[k] {
                    hits[k] += 1;
                }
            }
        }
    }
    [hits[0] as f64 / n as f64, hits[1] as f64 / n as f64]
}

#[test]
fn learned_distribution_points_at_the_light_and_the_glass_sphere() {
    let Some(shared) = shared() else { return };
    let o = r#"{"integrator": {"type": "guided", "spatial_threshold": 300}, "film": {"resolution": [64, 64]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[o], Profile::Physical);
    let film = train(&loaded, 64);
    let tree = learned_tree(&film).unwrap();
    let p = Vec3::new(-0.6, 0.001, -0.5);
    let dtree: &DTree = tree.sampling_tree_at(p);
    let learned = hit_fractions(&loaded.scene, p, 100_000, |u| dtree.sample(u).map(|s| s.0).filter(|d| d.y > 0.0), [0, 6]);
    let uniform = hit_fractions(
        &loaded.scene,
        p,
        100_000,
        |u| {
            let z = u.x;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * u.y;
            Some(Vec3::new(r * phi.cos(), z, r * phi.sin()))
        },
        [0, 6],
    );
    eprintln!("learned {learned:?}, solid-angle share {uniform:?}, tree {:?}", tree.stats());
    let q = Vec3::new(0.45, 0.001, 0.7);
    let dq = tree.sampling_tree_at(q);
    let lq = hit_fractions(&loaded.scene, q, 100_000, |u| dq.sample(u).map(|s| s.0).filter(|d| d.y > 0.0), [0, 6]);
    eprintln!("caustic point: learned {lq:?}");
    assert!(learned[0] >= 5.0 * uniform[0]);
    assert!(learned[1] > uniform[1]);
}

#[test]
#[ignore]
fn debug_true_radiance_shares() {
    let Some(shared) = shared() else { return };
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[], Profile::Physical);
    let pt = rdr::integrator::PathTracer { max_depth: 11, profile: rdr::integrator::PathProfile::Mis, rr_threshold: 0.1 };
    for p in [Vec3::new(-0.6, 0.001, -0.5), Vec3::new(0.45, 0.001, 0.7), Vec3::new(0.35, 0.001, 0.9), Vec3::new(0.6, 0.001, 0.6), Vec3::new(0.3, 0.001, 1.0)] {
    let mut rng = Rng::new(5);
    let (mut tot, mut light, mut sph) = (0.0f64, 0.0f64, 0.0f64);
    let mut counts = rdr::integrator::RayCounts::default();
    let n = 100_000;
    for i in 0..n {
        let (a, b) = (rng.unit() as f32, rng.unit() as f32);
        let z = a;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * b;
        let d = Vec3::new(r * phi.cos(), z, r * phi.sin());
        let ray = rdr::geometry::Ray::new(p, d);
        let Some(h) = loaded.scene.intersect(&ray) else { continue };
        let obj = loaded.scene.interaction(&ray, &h).object;
        let mut s = rdr::sampler::PixelSampler::new(i, 0, 0, 3);
        let l = pt.li(&loaded.scene, ray, None, &mut s, &mut counts);
        let m = ((l.x + l.y + l.z) / 3.0) as f64;
        tot += m;
        if obj == 0 { light += m; }
        if obj == 6 { sph += m; }
    }
    eprintln!("{p}: true shares of ∫L: light {}, sphere {}", light / tot, sph / tot);
    }
}

#[test]
#[ignore]
fn debug_local_variance() {
    let Some(shared) = shared() else { return };
    let o = r#"{"integrator": {"type": "guided", "spatial_threshold": 300}, "film": {"resolution": [64, 64]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[o], Profile::Physical);
    let film = train(&loaded, 64);
    let tree = learned_tree(&film).unwrap();
    let pt = rdr::integrator::PathTracer { max_depth: 11, profile: rdr::integrator::PathProfile::Mis, rr_threshold: 0.1 };
    for q in [Vec3::new(0.45, 0.001, 0.7), Vec3::new(-0.6, 0.001, -0.5)] {
        let guide = tree.sampling_tree_at(q);
        let m = rdr::material::Material::Diffuse { texture: 0, twosided: false };
        let bsdf = m.bsdf(Vec3::Y, Vec3::Y, |_| Vec3::splat(0.7));
        let mut counts = rdr::integrator::RayCounts::default();
        for frac in [1.0f32, 0.5, 0.2] {
            let mix = rdr::integrator::guided::Mixture { guide: Some(guide), bsdf_fraction: frac };
            let mut rng = Rng::new(1);
            let (mut s1, mut s2) = (0.0f64, 0.0f64);
            let n = 40000;
            for i in 0..n {
                let Some(bs) = mix.sample(&bsdf, Vec3::Y, rng.unit() as f32, Vec2::new(rng.unit() as f32, rng.unit() as f32), 0.5) else { continue };
                let ray = rdr::geometry::Ray::new(q, bs.wi);
                let mut s = rdr::sampler::PixelSampler::new(i, 1, 0, 3);
                let l = pt.li(&loaded.scene, ray, None, &mut s, &mut counts) * bs.weight;
                let y = ((l.x + l.y + l.z) / 3.0) as f64;
                s1 += y; s2 += y * y;
            }
            let mean = s1 / n as f64;
            eprintln!("{q} fraction {frac}: mean {mean:.4} var {:.4}", s2 / n as f64 - mean * mean);
        }
    }
}
