//! The `guided` integrator (path guiding with an SD-tree): the sphere↔square map,
//! χ² tests of the directional quadtree and of the BSDF/guide mixture against
//! their densities, convergence to the Mitsuba references (reduced resolution,
//! compared with the reference averaged over k×k blocks), what the tree learns
//! in `caustic_cbox`, thread-count independence, interruption and time budgets.

mod common;
use common::chi2::chi2_test as chi2;
use common::*;
use rdr::integrator::guided::{
    difference_variances, pixel_variances, relative_variances, relative_variances_within, sphere_to_square, square_to_sphere, DTree,
    Mixture, Part, CHOICE_PASSES, GUIDED_PASS_COST,
};
use rdr::integrator::{Integrator, PassContext, PassState, StopToken};
use rdr::material::{Bsdf, Material};
use rdr::math::{Vec2, Vec3, PI};
use rdr::metrics::{compare, Comparison, Image};
use rdr::{Profile, RenderControl};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

fn uniform2(rng: &mut Rng) -> Vec2 {
    Vec2::new(rng.unit() as f32, rng.unit() as f32)
}

/// Bins of the unit square (`BINS`² of them) and their masses under `density`
/// (on the square) by a `GRID`² midpoint rule: exact for densities that are
/// piecewise constant on dyadic cells down to 1/`GRID`, and for ones linear in x
/// within such cells.
const BINS: usize = 32;
const GRID: usize = 512;

fn bin(p: Vec2) -> usize {
    let b = |t: f32| ((t * BINS as f32) as usize).min(BINS - 1);
    b(p.y) * BINS + b(p.x)
}

fn masses(density: impl Fn(Vec2) -> f64) -> Vec<f64> {
    let mut m = vec![0.0f64; BINS * BINS];
    let cell = 1.0 / (GRID * GRID) as f64;
    for j in 0..GRID {
        for i in 0..GRID {
            let p = Vec2::new((i as f32 + 0.5) / GRID as f32, (j as f32 + 0.5) / GRID as f32);
            m[bin(p)] += density(p) * cell;
        }
    }
    m
}

/// A quadtree learned in three rounds from energies peaked at a few points (and a
/// floor everywhere), each round recording into the refined structure of the last.
fn learned_quadtree(seed: u64) -> DTree {
    let mut rng = Rng::new(seed);
    let peaks: Vec<(Vec2, f32, f32)> = (0..3)
        .map(|_| (uniform2(&mut rng), 0.03 + 0.1 * rng.unit() as f32, 1.0 + 10.0 * rng.unit() as f32))
        .collect();
    let energy = |p: Vec2| {
        0.02 + peaks
            .iter()
            .map(|(c, s, a)| a * (-(p - *c).length_squared() / (s * s)).exp())
            .sum::<f32>()
    };
    let mut t = DTree::initial(0.01);
    for round in 0..3 {
        for _ in 0..20_000 {
            let p = uniform2(&mut rng);
            t.deposit(t.cell_of(p), energy(p));
        }
        t.finish_recording();
        if round == 2 {
            break;
        }
        t = t.refined(0.01);
    }
    t
}

#[test]
fn sphere_to_square_map_preserves_area() {
    let mut rng = Rng::new(1);
    let h = 1e-3f32;
    for _ in 0..2000 {
        let p = Vec2::new(rng.range(0.01, 0.99) as f32, rng.range(0.01, 0.99) as f32);
        let d = square_to_sphere(p);
        assert!((d.length() - 1.0).abs() < 1e-5);
        assert!((sphere_to_square(d) - p).abs().max_element() < 1e-4, "round trip at {p}");
        let dx = (square_to_sphere(p + Vec2::new(h, 0.0)) - square_to_sphere(p - Vec2::new(h, 0.0))) / (2.0 * h);
        let dy = (square_to_sphere(p + Vec2::new(0.0, h)) - square_to_sphere(p - Vec2::new(0.0, h))) / (2.0 * h);
        let jacobian = dx.cross(dy).length();
        assert!((jacobian / (4.0 * PI) - 1.0).abs() < 5e-3, "area element {jacobian} at {p}");
    }
    // uniform directions land uniformly on the square
    let n = 400_000;
    let mut observed = vec![0.0f64; BINS * BINS];
    for _ in 0..n {
        observed[bin(sphere_to_square(rdr::sampling::uniform_sphere(uniform2(&mut rng))))] += 1.0;
    }
    chi2("uniform sphere on the square", n, &observed, &masses(|_| 1.0)).unwrap();
}

#[test]
fn quadtree_sampling_matches_its_pdf_and_a_wrong_pdf_is_rejected() {
    for seed in [1u64, 2, 3] {
        let t = learned_quadtree(seed);
        assert!(
            t.depth() <= 9 && t.node_count() > 40,
            "depth {} nodes {}",
            t.depth(),
            t.node_count()
        );
        let mut rng = Rng::new(seed + 100);
        let n = 500_000;
        let mut observed = vec![0.0f64; BINS * BINS];
        for _ in 0..n {
            let (p, pdf) = t.sample_square(uniform2(&mut rng)).unwrap();
            let again = t.pdf_square(p);
            assert!((pdf - again).abs() <= 1e-4 * again, "sampled pdf {pdf}, pdf {again}");
            observed[bin(p)] += 1.0;
        }
        chi2(&format!("quadtree {seed}"), n, &observed, &masses(|p| t.pdf_square(p) as f64)).unwrap();
        // a density off by ±10 % in a slow wave must fail
        let wrong = masses(|p| t.pdf_square(p) as f64 * (1.0 + 0.1 * (2.0 * std::f64::consts::PI * p.x as f64).sin()));
        {
            let e = chi2("quadtree against a wrong pdf", n, &observed, &wrong);
            eprintln!("  rejected as it must be: {e:?}");
            assert!(e.is_err());
        }
    }
}

/// A diffuse and a rough conductor BSDF at a surface facing +z (the map's axis,
/// so the hemisphere's edge is the square's line x = ½).
fn test_bsdfs() -> Vec<(&'static str, Bsdf)> {
    let wo = Vec3::new(0.3, -0.2, 0.9).normalize();
    let diffuse = Material::Diffuse {
        texture: 0,
        twosided: false,
    }
    .bsdf(Vec3::Z, wo, |_| Vec3::splat(0.8));
    let conductor = Material::RoughConductor {
        texture: 0,
        eta_i: Vec3::ONE,
        eta_t: Vec3::new(0.2, 0.92, 1.1),
        k: Vec3::new(3.9, 2.45, 2.14),
        alpha_x: 0.3,
        alpha_y: 0.3,
        alpha_textures: None,
        eta_k_textures: None,
        distribution: rdr::material::Distribution::Beckmann,
        twosided: true,
    }
    .bsdf(Vec3::Z, wo, |_| Vec3::ONE);
    vec![("diffuse", diffuse), ("rough conductor", conductor)]
}

fn mixture_histogram(mix: &Mixture, bsdf: &Bsdf, wo: Vec3, n: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    let mut observed = vec![0.0f64; BINS * BINS];
    for _ in 0..n {
        let Some(s) = mix.sample(bsdf, wo, rng.unit() as f32, uniform2(&mut rng), rng.unit() as f32) else {
            continue;
        };
        // the weight is f·cos / (the density reported)
        let fcos = bsdf.eval(wo, s.wi) * s.wi.z.abs();
        assert!(
            (s.weight * s.pdf - fcos).abs().max_element() <= 1e-3 * fcos.max_element() + 1e-6,
            "weight {} pdf {} f·cos {fcos}",
            s.weight,
            s.pdf
        );
        assert!(
            (s.pdf - mix.pdf(bsdf, wo, s.wi)).abs() <= 1e-3 * s.pdf,
            "reported and evaluated densities differ"
        );
        observed[bin(sphere_to_square(s.wi))] += 1.0;
    }
    observed
}

#[test]
fn mixture_sampling_matches_the_mixture_density_and_a_wrong_fraction_is_rejected() {
    let tree = learned_quadtree(7);
    let wo = Vec3::new(0.3, -0.2, 0.9).normalize();
    for (name, bsdf) in test_bsdfs() {
        for fraction in [0.5f32, 0.2] {
            let mix = Mixture {
                guide: Some(&tree),
                bsdf_fraction: fraction,
            };
            let n = 400_000;
            let observed = mixture_histogram(&mix, &bsdf, wo, n, 11);
            // solid-angle density × 4π = density on the square
            let on_square = |pdf: &dyn Fn(Vec3) -> f32| masses(|p| pdf(square_to_sphere(p)) as f64 * 4.0 * PI as f64);
            let right = on_square(&|w| mix.pdf(&bsdf, wo, w));
            let what = format!("{name}, bsdf_fraction {fraction}");
            if name == "diffuse" {
                chi2(&what, n, &observed, &right).unwrap();
            } else {
                // a glossy lobe is not piecewise linear: the midpoint rule is close, not exact
                let z = chi2(&what, n, &observed, &right);
                assert!(z.is_ok(), "{z:?}");
            }
            // the mixture density wrong by the BSDF fraction: off by 0.1, or left out of the BSDF's term
            let g = |w: Vec3| tree.pdf(w);
            let off = on_square(&|w| (fraction + 0.1) * bsdf.pdf(wo, w) + (0.9 - fraction) * g(w));
            {
                let e = chi2(&format!("{what}, fraction off by 0.1"), n, &observed, &off);
                eprintln!("  rejected as it must be: {e:?}");
                assert!(e.is_err());
            }
            let without = on_square(&|w| bsdf.pdf(wo, w) + (1.0 - fraction) * g(w));
            {
                let e = chi2(&format!("{what}, fraction left out"), n, &observed, &without);
                eprintln!("  rejected as it must be: {e:?}");
                assert!(e.is_err());
            }
        }
    }
}

/// The variance-aware target (Rath et al. 2020): a tree that recorded second moments
/// gives each leaf cell the energy √(S·a), S the sum of its records and a its area (the
/// root of the cell's mean second moment, times its area), so its density on the square
/// is √(S·a) / (a·Σ√(S·a)); and a record left out ([`DTree::pdf_square_without`], the
/// leaves' choice of fractions) gives the density of the tree recorded without it.
/// Records at random points of a structure with cells of many sizes (refined from
/// peaks). Worst relative deviations: 2.3e-7 (density) and 2.0e-7 (left out); the
/// deliberate errors are in the assertions' comments.
#[test]
fn variance_target_takes_the_root_of_each_cells_second_moment() {
    let structure = learned_quadtree(4).refined(0.01);
    let mut rng = Rng::new(9);
    let records: Vec<(Vec2, f32)> = (0..20_000)
        .map(|i| {
            // half near a peak's corner, where the cells are small
            let u = uniform2(&mut rng);
            let p = if i % 2 == 0 {
                u
            } else {
                Vec2::new(0.5 + 0.05 * u.x, 0.5 + 0.05 * u.y)
            };
            let f = (1.0 + 20.0 * p.x) * rng.unit() as f32;
            (p, f * f)
        })
        .collect();
    let record = |skip: Option<usize>| {
        let mut t = structure.clone();
        for (i, &(p, m)) in records.iter().enumerate() {
            if Some(i) != skip {
                t.deposit_moment(t.cell_of(p), m);
            }
        }
        t.finish_recording();
        t
    };
    let tree = record(None);
    // the sums and areas of the cells
    let mut sums = std::collections::HashMap::<u32, (f64, f64)>::new();
    for &(p, m) in &records {
        let e = sums.entry(tree.cell_of(p)).or_insert((0.0, tree.pdf_square_and_area(p).1 as f64));
        e.0 += m as f64;
    }
    let total: f64 = sums.values().map(|(s, a)| (s * a).sqrt()).sum();
    let mut worst = 0.0f64;
    for &(p, _) in &records {
        let (s, a) = sums[&tree.cell_of(p)];
        let expected = (s * a).sqrt() / (a * total);
        worst = worst.max((tree.pdf_square(p) as f64 / expected - 1.0).abs());
    }
    eprintln!("density against √(S·a) / (a·Σ√(S·a)): worst relative deviation {worst:.2e}");
    // the second moments themselves (no root): 2.96; the root without the area: 11.0
    assert!(worst < 1e-4, "learned density off by {worst}");
    let mut worst = 0.0f64;
    for k in (0..records.len()).step_by(401) {
        let (p, m) = records[k];
        // a record that is most of its cell leaves a difference of rounding
        if (m as f64) > 0.5 * sums[&tree.cell_of(p)].0 {
            continue;
        }
        let without = record(Some(k)).pdf_square(p) as f64;
        worst = worst.max((tree.pdf_square_without(p, m) / without - 1.0).abs());
    }
    eprintln!("density without a record: worst relative deviation {worst:.2e}");
    // the record taken from the cell's root as if it were energy: 1.00
    assert!(worst < 1e-4, "density without a record off by {worst}");
}

/// Runs a loaded guided job pass by pass (seed 7) and returns the integrator's
/// state, which holds the learned tree.
fn train(loaded: &rdr::Loaded, spp: u32) -> PassState {
    train_with_seed(loaded, spp, 7)
}

/// [`train`] with seed `seed`.
fn train_with_seed(loaded: &rdr::Loaded, spp: u32, seed: u32) -> PassState {
    train_with(loaded, spp, seed, |_| {})
}

/// [`train_with_seed`], calling `before_pass` with the state before every pass.
fn train_with(loaded: &rdr::Loaded, spp: u32, seed: u32, mut before_pass: impl FnMut(&mut PassState)) -> PassState {
    let job = &loaded.job;
    let Integrator::Guided(g) = job.integrator else {
        panic!("not guided")
    };
    let mut state = PassState::default();
    let stop = StopToken::new();
    let ctx = PassContext {
        scene: &loaded.scene,
        camera: &job.camera,
        film: &job.film,
        spp,
        target_spp: spp,
        seed,
        time_limit: None,
        stop: &stop,
        progress: &|_| {},
    };
    for _ in 0..spp {
        before_pass(&mut state);
        assert!(g.render_pass(&ctx, state.guided()).complete);
    }
    state
}

/// Fractions of `n` directions from `sample` whose rays from `p` first hit
/// object `objects[0]`, `objects[1]`.
fn hit_fractions(scene: &rdr::Scene, p: Vec3, n: usize, mut sample: impl FnMut(Vec2) -> Option<Vec3>, objects: [u32; 2]) -> [f64; 2] {
    let mut rng = Rng::new(99);
    let mut hits = [0usize; 2];
    for _ in 0..n {
        let Some(d) = sample(uniform2(&mut rng)) else { continue };
        let ray = rdr::geometry::Ray::new(p, d);
        if let Some(h) = scene.intersect(&ray) {
            let object = scene.interaction(&ray, &h).object;
            for k in 0..2 {
                if object == objects[k] {
                    hits[k] += 1;
                }
            }
        }
    }
    [hits[0] as f64 / n as f64, hits[1] as f64 / n as f64]
}

fn upper_hemisphere(u: Vec2) -> Vec3 {
    let r = (1.0 - u.x * u.x).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), u.x, r * phi.sin())
}

/// Shares of ∫L_i over the upper hemisphere at `p` arriving from objects `a`
/// and `b`, estimated by the `path` integrator along uniform directions.
fn radiance_shares(loaded: &rdr::Loaded, p: Vec3, n: u32, objects: [u32; 2]) -> [f64; 2] {
    let pt = rdr::integrator::PathTracer {
        max_depth: 11,
        profile: rdr::integrator::PathProfile::Mis,
        rr_threshold: 0.1,
        hide_emitters: false,
        rr: rdr::integrator::Roulette::Mitsuba,
    };
    let mut rng = Rng::new(5);
    let mut counts = rdr::integrator::RayCounts::default();
    let (mut total, mut part) = (0.0f64, [0.0f64; 2]);
    for i in 0..n {
        let ray = rdr::geometry::Ray::new(p, upper_hemisphere(uniform2(&mut rng)));
        let Some(h) = loaded.scene.intersect(&ray) else { continue };
        let object = loaded.scene.interaction(&ray, &h).object;
        let mut sampler = rdr::sampler::PixelSampler::new(i, 0, 0, 3);
        let l = pt.li(&loaded.scene, ray, None, &mut sampler, &mut counts);
        let y = ((l.x + l.y + l.z) / 3.0) as f64;
        total += y;
        for k in 0..2 {
            if object == objects[k] {
                part[k] += y;
            }
        }
    }
    [part[0] / total, part[1] / total]
}

#[test]
fn learned_distribution_in_caustic_cbox_points_at_the_light_and_the_glass_sphere() {
    let Some(shared) = shared() else { return };
    // the paper's mode (direct light learned too), from camera paths (the paper) and from
    // photons; a small image trains few vertices: a lower split threshold gives the tree its
    // cells. Photons deposit flux, ∝ L_i·cos: the sphere above the caustic gets less
    // than the radiance-proportional paths give it, still more than its solid angle.
    // Over training seeds 1-8 the paths' tree gave the sphere 0.57-0.70 of its samples
    // at the caustic point (1.7-2.1x its solid-angle share 0.33; seed 7 once gave 0.82,
    // with libm's atan2 in the azimuth): 1.5x holds with margin for both, and an
    // untrained (uniform) tree, at 1.0x, fails it.
    for (from, sphere_factor) in [("paths", 1.5), ("photons", 1.5)] {
        learned_distribution_in_caustic_cbox(&shared, from, sphere_factor);
    }
}

fn learned_distribution_in_caustic_cbox(shared: &Path, from: &str, sphere_factor: f64) {
    let o = format!(
        r#"{{"integrator": {{"type": "guided", "learn_direct": true, "learn_from": "{from}", "spatial_threshold": 300}}, "film": {{"resolution": [64, 64]}}}}"#
    );
    let o = o.as_str();
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[o], Profile::Physical);
    let (light, sphere) = (0u32, 6u32); // objects[0] is the ceiling light, objects[6] the glass sphere
    let state = train(&loaded, 64);
    let tree = state.learned_tree().unwrap();
    let learned_at = |p: Vec3| {
        let t = tree.sampling_tree_at(p);
        hit_fractions(&loaded.scene, p, 100_000, |u| t.sample(u).map(|s| s.0), [light, sphere])
    };
    let share_at = |p: Vec3| hit_fractions(&loaded.scene, p, 100_000, |u| Some(upper_hemisphere(u)), [light, sphere]);

    // the issue's point: the light seen directly
    let p = Vec3::new(-0.6, 0.001, -0.5);
    let (learned, share, truth) = (learned_at(p), share_at(p), radiance_shares(&loaded, p, 40_000, [light, sphere]));
    eprintln!(
        "{from}: at {p}: learned (light, sphere) {learned:?}, solid-angle share {share:?}, share of ∫L_i {truth:?}; {:?}",
        tree.stats()
    );
    assert!(learned[0] >= 5.0 * share[0], "light: learned {} vs share {}", learned[0], share[0]);
    // what the glass sphere shows from here (the room, refracted) is dimmer than the average
    // direction: a radiance-proportional density gives it less than its solid angle
    assert!(truth[1] < share[1]);

    // in the sphere's caustic (the light hidden behind it) the sphere carries most of the light
    let q = Vec3::new(0.45, 0.001, 0.7);
    let (learned, share, truth) = (learned_at(q), share_at(q), radiance_shares(&loaded, q, 40_000, [light, sphere]));
    eprintln!("at {q}: learned {learned:?}, solid-angle share {share:?}, share of ∫L_i {truth:?}");
    assert!(
        learned[1] > sphere_factor * share[1],
        "{from}: sphere: learned {} vs share {}",
        learned[1],
        share[1]
    );
    // the sphere's share of the learned density there is its share of ∫L_i: 0.93x (paths)
    // and 0.89x (photons) of it; a tree that learned nothing there gives the solid-angle
    // share, 0.45x: the tolerance of 25 % leaves 5x between the baseline's deviation and
    // that one's. Errors that only sharpen or blur the learned lobe stay inside it (the
    // paths' values without their 1/pdf: 1.25x): the records test below catches them
    assert!(
        (learned[1] / truth[1] - 1.0).abs() < 0.25,
        "{from}: sphere at the caustic point: learned {} vs ∫L_i share {}",
        learned[1],
        truth[1]
    );
    let fraction = |x: Vec3| tree.bsdf_fraction(tree.leaf_of(x));
    eprintln!(
        "BSDF fractions chosen: {} at {p}, {} at {q}; {:?}",
        fraction(p),
        fraction(q),
        tree.stats().fractions
    );
}

/// Mean and standard error of `n` samples given as (Σx, Σx²).
fn mean_and_error(sum: [f64; 2], n: u32) -> (f64, f64) {
    let m = sum[0] / n as f64;
    (m, ((sum[1] / n as f64 - m * m).max(0.0) / n as f64).sqrt())
}

/// What training paths record at a vertex is the radiance arriving there divided
/// by the density its direction was sampled with, so the records of many paths
/// through one point estimate the integral of the incident radiance there. At a
/// floor point of `caustic_cbox` in the glass sphere's caustic, the first vertex's
/// records are summed over the directions through the glass sphere and over the
/// other directions that do not see the light (its direct light is left to light
/// sampling), and compared with the same integrals of `path`'s radiance along
/// uniform directions; the guide takes half of the vertex's samples, so the
/// mixture's density is the one to divide by. With the variance-aware target the same
/// paths record the second moment of the vertex's estimate, (F/q)²·q with F =
/// f·|cos|·L̂, which through the glass is checked against `path`'s the same way. The
/// deliberate errors the tolerances of 15 % are set against are in the assertions'
/// comments.
#[test]
fn path_records_estimate_the_radiance_arriving_through_the_glass_and_from_the_walls() {
    let Some(shared) = shared() else { return };
    let o = r#"{"integrator": {"type": "guided", "learn_from": "paths", "spatial_threshold": 300}, "film": {"resolution": [64, 64]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[o], Profile::Physical);
    let (light, floor, sphere) = (0u32, 3u32, 6u32);
    let state = train(&loaded, 16);
    let tree = state.learned_tree().unwrap();
    let scene = &loaded.scene;
    // inside the caustic: the light, focused by the sphere, lands about (0.33, 0, 0.40)
    let q = Vec3::new(0.38, 0.0, 0.52);
    let object_towards = |d: Vec3| {
        let ray = rdr::geometry::Ray::new(q + Vec3::new(0.0, 1e-3, 0.0), d);
        scene.intersect(&ray).map(|h| scene.interaction(&ray, &h).object)
    };
    // which integral a direction arriving at q counts in: 0 the glass sphere, 1 the rest
    // but the light
    let part = |d: Vec3| match object_towards(d) {
        Some(o) if o == sphere => Some(0),
        Some(o) if o == light => None,
        _ => Some(1),
    };
    let n = 200_000u32;
    let camera = Vec3::new(0.0, 1.0, 6.8);
    let ray = rdr::geometry::Ray::new(camera, (q - camera).normalize());
    let hit = scene.intersect(&ray).unwrap();
    let it = scene.interaction(&ray, &hit);
    assert!(
        it.object == floor && (it.p - q).length() < 1e-3,
        "the camera ray reaches {} on object {}",
        it.p,
        it.object
    );
    let bsdf = scene.material_of(&it).unwrap().bsdf_at(&it, &scene.textures);

    // the truth: path's radiance along uniform directions of the upper hemisphere (and
    // the second moment of the vertex's estimate f·|cos|·L̂ through the glass)
    let pt = rdr::integrator::PathTracer {
        max_depth: 11,
        profile: rdr::integrator::PathProfile::Mis,
        rr_threshold: 0.1,
        hide_emitters: false,
        rr: rdr::integrator::Roulette::Mitsuba,
    };
    let mut counts = rdr::integrator::RayCounts::default();
    let mut rng = Rng::new(5);
    let mut truth = [[0.0f64; 2]; 2];
    let mut moment_truth = [0.0f64; 2];
    for i in 0..n {
        let d = upper_hemisphere(uniform2(&mut rng));
        let Some(k) = part(d) else { continue };
        let ray = rdr::geometry::Ray::new(q + Vec3::new(0.0, 1e-3, 0.0), d);
        let mut sampler = rdr::sampler::PixelSampler::new(i, 0, 0, 3);
        let l = pt.li(scene, ray, None, &mut sampler, &mut counts);
        let y = 2.0 * std::f64::consts::PI * ((l.x + l.y + l.z) / 3.0) as f64;
        truth[k][0] += y;
        truth[k][1] += y * y;
        if k == 0 {
            let f = bsdf.eval(it.wo, d) * l * bsdf.frame.n.dot(d).abs();
            let y = 2.0 * std::f64::consts::PI * (((f.x + f.y + f.z) / 3.0) as f64).powi(2);
            moment_truth[0] += y;
            moment_truth[1] += y * y;
        }
    }

    // the records: camera rays through q, the first vertex's record per path
    let guiding = rdr::integrator::guided::Guiding {
        tree,
        bsdf_fraction: 0.5,
        record: true,
        record_radiance: true,
        max_depth: 12,
        rr_threshold: 0.1,
        record_direct: false,
        learn_fraction: false,
        target: rdr::integrator::guided::Target::Radiance,
    };
    // the same paths recording second moments (the variance-aware target)
    let moments = rdr::integrator::guided::Guiding {
        target: rdr::integrator::guided::Target::Variance,
        ..guiding
    };
    let mut scratch = rdr::integrator::guided::Scratch::default();
    let mut recorded = [[0.0f64; 2]; 2];
    let mut moment_recorded = [0.0f64; 2];
    for i in 0..n {
        for (g, variance) in [(&guiding, false), (&moments, true)] {
            scratch.records.clear();
            let mut sampler = rdr::sampler::PixelSampler::new(7, 9, i, 3);
            g.li(scene, ray, None, &mut sampler, &mut counts, &mut scratch);
            let Some(r) = scratch.records.iter().find(|r| r.counted) else {
                continue;
            };
            let Some(k) = part(square_to_sphere(r.p)) else { continue };
            let y = r.value as f64;
            if variance {
                if k == 0 {
                    moment_recorded[0] += y;
                    moment_recorded[1] += y * y;
                }
            } else {
                recorded[k][0] += y;
                recorded[k][1] += y * y;
            }
        }
    }
    for (k, name) in ["through the glass sphere", "from the rest (not the light)"].iter().enumerate() {
        let (t, te) = mean_and_error(truth[k], n);
        let (r, re) = mean_and_error(recorded[k], n);
        eprintln!("∫L_i {name}: recorded {r:.4} ± {re:.4}, path {t:.4} ± {te:.4}, ratio {:.3}", r / t);
        // baseline ratios 0.986 (glass, ± 0.8 %) and 0.951 (rest, ± 3 %): 3.1x inside the
        // tolerance of 15 %; values not divided by their density: glass 0.524, 3.2x outside
        // it (9.7x the baseline's deviation); light through the glass not credited to the
        // vertex (treated as its direct light): glass 0.053
        assert!((r / t - 1.0).abs() < 0.15, "{name}: recorded {r} against {t}");
    }
    // through the glass the guided vertex's estimate continues as `path`'s (specular
    // vertices to the light), so the second moments recorded there estimate the same
    // ∫E[(f·|cos|·L̂)²] as `path`'s along uniform directions
    let (t, te) = mean_and_error(moment_truth, n);
    let (r, re) = mean_and_error(moment_recorded, n);
    eprintln!(
        "∫E[F²] through the glass sphere: recorded {r:.4} ± {re:.4}, path {t:.4} ± {te:.4}, ratio {:.3}",
        r / t
    );
    // baseline ratio 0.992 (± 0.9 %), 19x inside the tolerance; the BSDF and cosine left
    // out of F (the radiance's second moment): 23.0; F/q recorded instead of (F/q)²·q
    // (the product of radiance and BSDF, Müller's target with the BSDF): 0.426
    assert!(
        (r / t - 1.0).abs() < 0.15,
        "second moments through the glass: recorded {r} against {t}"
    );
}

/// Mean and per-sample relative variance of `n` estimates of the radiance along
/// the camera ray of `caustic_cbox` towards `target` (Sobol samples of one pixel).
fn ray_estimates(
    scene: &rdr::Scene,
    target: Vec3,
    n: u32,
    mut li: impl FnMut(rdr::geometry::Ray, &mut rdr::sampler::PixelSampler) -> Vec3,
) -> (f64, f64) {
    let camera = Vec3::new(0.0, 1.0, 6.8);
    let ray = rdr::geometry::Ray::new(camera, (target - camera).normalize());
    assert!(scene.intersect(&ray).is_some());
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for i in 0..n {
        let mut sampler = rdr::sampler::PixelSampler::new(7, 9, i, 3);
        let l = li(ray, &mut sampler);
        let y = ((l.x + l.y + l.z) / 3.0) as f64;
        s1 += y;
        s2 += y * y;
    }
    let m = s1 / n as f64;
    (m, (s2 / n as f64 - m * m) / (m * m))
}

/// The ceiling of `caustic_cbox` sees the floor's caustic through the glass sphere
/// (camera–D–S–S–D–S–S–light, 7 segments): most of `path`'s error there. A tree
/// learned from photons, sampled half of the time, with the guided roulette, must at
/// least halve a ceiling pixel's per-sample variance against `path` (measured:
/// 60 → 10–12); with `path`'s roulette (throughput alone) the guided estimator
/// stays at `path`'s variance (59), and a tree trained on photons deposited
/// along the wrong direction does not help either.
#[test]
fn photon_guide_and_guided_roulette_cut_the_ceiling_variance_of_caustic_cbox() {
    let Some(shared) = shared() else { return };
    let o = r#"{"integrator": {"type": "guided", "spatial_threshold": 500, "learn_fraction": false}, "film": {"resolution": [128, 128]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[o], Profile::Physical);
    let state = train(&loaded, 64);
    let tree = state.learned_tree().unwrap();
    let scene = &loaded.scene;
    let path = rdr::integrator::PathTracer {
        max_depth: 12,
        profile: rdr::integrator::PathProfile::Mis,
        rr_threshold: 0.1,
        hide_emitters: false,
        rr: rdr::integrator::Roulette::Mitsuba,
    };
    let guiding = rdr::integrator::guided::Guiding {
        tree,
        bsdf_fraction: 0.5,
        record: false,
        record_radiance: false,
        max_depth: 12,
        rr_threshold: 0.1,
        record_direct: false,
        learn_fraction: false,
        target: rdr::integrator::guided::Target::Radiance,
    };
    let mut counts = rdr::integrator::RayCounts::default();
    let mut scratch = rdr::integrator::guided::Scratch::default();
    let n = 150_000;
    for target in [Vec3::new(0.0, 2.0, 0.45), Vec3::new(0.3, 2.0, 0.6)] {
        let (mp, vp) = ray_estimates(scene, target, n, |r, s| path.li(scene, r, None, s, &mut counts));
        let (mg, vg) = ray_estimates(scene, target, n, |r, s| guiding.li(scene, r, None, s, &mut counts, &mut scratch));
        eprintln!("ceiling at {target}: path mean {mp:.4} relative variance {vp:.1}; guided {mg:.4}, {vg:.1}");
        // both unbiased: the means agree within 4 standard errors
        let se = ((vp * mp * mp + vg * mg * mg) / n as f64).sqrt();
        assert!((mp - mg).abs() < 4.0 * se, "means {mp} and {mg} differ by more than 4 × {se}");
        assert!(vg < 0.5 * vp, "guided relative variance {vg} not below half of path's {vp}");
    }
}

/// Guiding with its defaults: the leaves guide wherever they chose to.
const GUIDED: &str = r#"{"integrator": {"type": "guided"}}"#;

/// `scene.json` of the references at 1/k resolution: two independent renders.
fn reduced(shared: &Path, scene: &str, k: u64, spp: u32, extra: &[&str]) -> (Image, Image) {
    let path = shared.join(format!("refs/scenes/{scene}.json"));
    let full: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let (w, h) = (
        full["film"]["resolution"][0].as_u64().unwrap(),
        full["film"]["resolution"][1].as_u64().unwrap(),
    );
    let res = format!(r#"{{"film": {{"resolution": [{}, {}]}}}}"#, w / k, h / k);
    let mut o = vec![GUIDED, res.as_str()];
    o.extend_from_slice(extra);
    let s = load_scene(&path, &o, Profile::Physical);
    (render(&s, spp, 1), render(&s, spp, 2))
}

fn check(name: &str, x: (&Image, &Image), r: &Image, vr: &Image) -> Comparison {
    let c = compare(x.0, x.1, r, vr);
    eprintln!(
        "{name:>30}: relMSE corrected {:+.2e} ± {:.1e}  (raw {:.2e}, noise {:.2e})",
        c.rel_mse_corrected, c.std_error, c.rel_mse_raw, c.rel_mse_noise
    );
    c
}

fn converges(c: &Comparison) -> bool {
    c.rel_mse_corrected.abs() < 5.0 * c.std_error + 2e-4
}

#[test]
fn converges_to_the_path_traced_references() {
    let Some(shared) = shared() else { return };
    for (name, scene, k, spp) in [
        ("cbox", "cbox_path", 4, 32),
        ("glass_sphere", "glass_sphere", 4, 16),
        ("caustic_cbox", "caustic_cbox", 8, 128),
        ("env_sphere", "env_sphere", 4, 16),
    ] {
        let r = read(&shared.join(format!("refs/{name}.exr"))).block_average(k as usize, false);
        let vr = read(&shared.join(format!("refs/{name}.var.exr"))).block_average(k as usize, true);
        let (a, b) = reduced(&shared, scene, k, spp, &[r#"{"integrator": {"spatial_threshold": 1000}}"#]);
        let c = check(&format!("guided {name}"), (&a, &b), &r, &vr);
        assert!(converges(&c), "{name}: {c:?}");
    }
}

/// The variance-aware target (`target: "variance"`, learned from the camera paths'
/// second moments) converges as the radiance target does: what the guide learned moves
/// only the density directions are drawn with, and the estimate divides by the mixture's.
/// The guide takes half of every vertex's samples (`learn_fraction` off). With the
/// directions the BSDF drew weighted by the BSDF's density instead of the mixture's,
/// see the assertion's message.
#[test]
fn variance_target_converges_to_the_path_traced_references() {
    let Some(shared) = shared() else { return };
    for (name, scene, k, spp) in [("cbox", "cbox_path", 4, 32), ("caustic_cbox", "caustic_cbox", 8, 128)] {
        let r = read(&shared.join(format!("refs/{name}.exr"))).block_average(k as usize, false);
        let vr = read(&shared.join(format!("refs/{name}.var.exr"))).block_average(k as usize, true);
        let extra = r#"{"integrator": {"target": "variance", "spatial_threshold": 1000, "learn_fraction": false}}"#;
        let (a, b) = reduced(&shared, scene, k, spp, &[extra]);
        let c = check(&format!("guided variance {name}"), (&a, &b), &r, &vr);
        // baseline: cbox +9.8e-5 ± 3.1e-4, caustic_cbox -1.1e-3 ± 2.0e-3; BSDF-drawn
        // directions weighted by the BSDF's density: cbox +4.4e-3 ± 2.1e-4 (3.5x its bound)
        assert!(converges(&c), "{name}: {c:?}");
    }
}

/// The cost-aware switch ([`rdr::integrator::guided::State::guide`]): at full size and
/// 64 spp caustic_cbox (seeds 1 and 3) takes the guide up and renders its final 32 spp
/// guided; cbox_path (seed 1), where guiding does not pay its cost, leaves it off and
/// stops training after the first two measurements, 8 spp
/// (`guided::DECLINES_TO_STOP_TRAINING`): its final iteration, unguided, takes the rest of
/// the 64 spp. Decisions depend on sample counts and images only, so the outcome is fixed.
/// Measured relative variance per sample with the guide over without, times the guided
/// pass's cost (1.5), per training iteration: caustic_cbox seed 1 0.70, 0.92, 0.65, 0.50;
/// seed 3 1.19, 0.57, 0.77, 0.89 (it never took the guide up when two measurements in a
/// row had to pay); cbox_path 1.21, 1.50. With the plain means over all pixels
/// (`guided::PROBE_BLOCKS` 1) cbox_path measured 0.97, took the guide up and trained 16 spp;
/// with three declines to stop, it trained 16 spp too. With the cost divided instead of
/// multiplied cbox_path takes the guide up (see the assertion's message).
#[test]
fn the_cost_aware_switch_guides_caustic_cbox_and_not_cbox_path() {
    let Some(shared) = shared() else { return };
    for (scene, seed, wanted) in [("caustic_cbox", 1, true), ("caustic_cbox", 3, true), ("cbox_path", 1, false)] {
        let loaded = load_scene(&shared.join(format!("refs/scenes/{scene}.json")), &[GUIDED], Profile::Physical);
        let mut state = train_with_seed(&loaded, 64, seed);
        let s = state.guided().as_ref().expect("guided state");
        let measured: Vec<String> = s
            .history
            .iter()
            .filter_map(|i| i.variance_ratio)
            .map(|r| format!("{:.2}", r * GUIDED_PASS_COST))
            .collect();
        let last = s.history.last().expect("iterations");
        eprintln!(
            "{scene} seed {seed}: variance ratio x cost per training iteration {}; final {} spp guided: {}; {}",
            measured.join(", "),
            last.spp,
            last.guided,
            s.schedule
        );
        assert!(
            last.guided == wanted,
            "{scene}: final iteration guided {} (wanted {wanted}); variance ratio x cost {}",
            last.guided,
            measured.join(", ")
        );
        // the guide taken up trains to the end; the guide declined stops training
        let trained: u32 = s.history.iter().filter(|i| !i.last).map(|i| i.spp).sum();
        assert!(
            last.last && last.spp + trained == 64,
            "{scene}: {trained} spp trained, final {last:?}"
        );
        assert_eq!(
            s.training_stopped, !wanted,
            "{scene}: training stopped {} after {trained} spp",
            s.training_stopped
        );
        assert_eq!(last.spp > 32, !wanted, "{scene}: final iteration of {} spp", last.spp);
        // declined by the first two measurements, after 1 + 1 + 2 + 4 spp
        assert!(wanted || trained <= 8, "{scene}: {trained} spp trained before the stop");
    }
}

/// Each pixel's squared differences [(X−Y)², (X−Z)², (Y−Z)²] of three independent
/// images around the same pixel values (the terms of the cost-aware switch's measurement),
/// `noise(rng, image, pixel)` the deviation of image 0 (X), 1 (Y) or 2 (Z) at a pixel.
fn difference_terms(rng: &mut Rng, pixels: usize, mut noise: impl FnMut(&mut Rng, usize, usize) -> f64) -> Vec<[f64; 3]> {
    (0..pixels)
        .map(|i| {
            let [x, y, z] = std::array::from_fn(|image| noise(rng, image, i));
            [(x - y).powi(2), (x - z).powi(2), (y - z).powi(2)]
        })
        .collect()
}

/// Uniform noise of variance `variance`.
fn uniform_noise(rng: &mut Rng, variance: f64) -> f64 {
    (2.0 * rng.unit() - 1.0) * (3.0 * variance).sqrt()
}

/// The cost-aware switch's measurement ([`difference_variances`]): the variances of two
/// independent images X and Y from their squared differences with each other and with a
/// third, Z. 256² pixels, X of variance 1, Y of 2 (ratio 0.5), Z of 0.5. (a) Seven
/// pixels hold fireflies (five of X, one of Y, one of Z, 300 each): a handful of pixels
/// must not decide; measured ratio 0.506 (|ln| error 0.012); the plain means over all
/// pixels (the estimate before; `PROBE_BLOCKS` 1) gave 2.31 (error 1.53). (b) Y's
/// variance 3 comes mostly from a tail that a render does see: 50 in one pixel of 1000
/// (2.5 of the 3): measured 0.438 (error 0.132); with 255 blocks of pixels instead of
/// 15 (257 pixels each, most without a tail sample) 2.81 (error 1.73).
#[test]
fn the_switchs_measurement_ignores_a_handful_of_fireflies_but_not_a_heavy_tail() {
    let pixels = 256 * 256;
    let mut rng = Rng::new(39);
    let fireflies: Vec<(usize, usize)> = [0, 0, 0, 0, 0, 1, 2].iter().map(|&image| (image, rng.below(pixels))).collect();
    let terms = difference_terms(&mut rng, pixels, |rng, image, i| {
        let spike = if fireflies.contains(&(image, i)) { 300.0 } else { 0.0 };
        uniform_noise(rng, [1.0, 2.0, 0.5][image]) + spike
    });
    let (p, q) = (1e-3, 50.0);
    let tail = p * (1.0 - p) * q * q;
    let heavy = difference_terms(&mut rng, pixels, |rng, image, _| match image {
        1 => uniform_noise(rng, 0.5) + if rng.chance(p) { q } else { 0.0 } - p * q,
        _ => uniform_noise(rng, [1.5, 0.0, 0.5][image]),
    });
    for (case, terms, truth) in [
        ("a handful of fireflies", &terms, 0.5),
        ("a heavy tail", &heavy, 1.5 / (0.5 + tail)),
    ] {
        let (x, y) = difference_variances(terms).expect("positive variances");
        let error = (x / y / truth).ln().abs();
        eprintln!(
            "{case}: measured variance ratio {:.3}, true {truth:.3}, |ln| error {error:.3}",
            x / y
        );
        assert!(error < 0.25, "{case}: measured ratio {:.3}, true {truth:.3}", x / y);
    }
}

/// The leaves choose their BSDF fractions from the vertices of a training iteration's
/// first `CHOICE_PASSES` recording passes, not its first pass alone (where the caustic
/// light a choice hinges on reaches few vertices) nor all of them (memory). caustic_cbox
/// at 64², learning from the camera paths, every leaf held at fraction ≤ 0.5 before each
/// pass so that every pass records; iterations of 1, 1, 2, 4 and 8 passes: the vertices
/// that chose after the 2-, 4- and 8-pass iterations, against the passes' count (the
/// guided passes' paths grow longer as the guide improves). Measured ratios 4-pass/2-pass
/// 2.05, 8-pass/4-pass 1.12 (wanted 2 and 1); with the first pass alone 1.03 and 1.12, with
/// every recording pass 2.05 and 2.23.
#[test]
fn the_leaves_choose_their_fractions_from_the_first_recording_passes() {
    let Some(shared) = shared() else { return };
    let o = r#"{"integrator": {"type": "guided", "learn_from": "paths", "training_iterations": 5}, "film": {"resolution": [64, 64]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[o], Profile::Physical);
    let mut state = train_with(&loaded, 20, 1, |state| {
        if let Some(s) = state.guided().as_mut() {
            s.tree.map_fractions(|f| f.min(0.5));
        }
    });
    let s = state.guided().as_ref().expect("guided state");
    let counts: Vec<(u32, u64)> = s.history.iter().filter(|i| !i.last).map(|i| (i.spp, i.choice_vertices)).collect();
    eprintln!("(passes, vertices that chose the fractions) per training iteration: {counts:?}");
    let vertices = |passes: u32| counts.iter().find(|c| c.0 == passes).map_or(0, |c| c.1) as f64;
    let (two, four, eight) = (vertices(2), vertices(4), vertices(8));
    let expected = |passes: u32| passes.min(CHOICE_PASSES) as f64;
    let (r42, r84) = (four / two, eight / four);
    eprintln!("ratios 4-pass/2-pass {r42:.2}, 8-pass/4-pass {r84:.2}");
    assert!(two > 0.0, "no vertices chose the fractions: {counts:?}");
    for (ratio, wanted) in [(r42, expected(4) / expected(2)), (r84, expected(8) / expected(4))] {
        assert!(
            (ratio / wanted - 1.0).abs() < 0.3,
            "vertices ratio {ratio:.2}, wanted {wanted:.2}: {counts:?}"
        );
    }
}

/// A pass keeps at most its budget of vertices for the leaves' choice of fractions
/// (`State::choice_budget`, at 1080p about a quarter of them), exactly that many where it
/// has more, and the choice still takes place. caustic_cbox at 64², learning from the
/// camera paths, every leaf held at fraction ≤ 0.5 so that every pass records, a budget
/// of 300 per pass from the second pass on (the first iteration, created in its pass,
/// keeps its own); iterations of 1, 1, 2, 4 and 8 passes. Measured: the first held
/// 6,161, the later 300, 600, 1,200 and 1,200 (300 × their choosing passes); without
/// the budget (a pass keeping all its vertices) 4,290, 12,545, 25,771 and 28,871.
#[test]
fn a_pass_keeps_at_most_its_budget_of_choice_vertices() {
    let Some(shared) = shared() else { return };
    let budget = 300;
    let o = r#"{"integrator": {"type": "guided", "learn_from": "paths", "training_iterations": 5}, "film": {"resolution": [64, 64]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[o], Profile::Physical);
    let mut state = train_with(&loaded, 20, 1, |state| {
        if let Some(s) = state.guided().as_mut() {
            s.choice_budget = budget;
            s.tree.map_fractions(|f| f.min(0.5));
        }
    });
    let s = state.guided().as_ref().expect("guided state");
    let held: Vec<(u32, u64, u64)> = s
        .history
        .iter()
        .filter(|i| !i.last)
        .map(|i| (i.spp, i.choice_samples, i.choice_vertices))
        .collect();
    eprintln!("(passes, vertices held, vertices that chose) per training iteration: {held:?}");
    assert_eq!(held.len(), 5, "{held:?}");
    // the first iteration's pass, unbudgeted, has more than the budget: the budget binds
    assert!(held[0].1 > 3 * budget as u64, "the first pass holds only {}", held[0].1);
    for &(passes, samples, vertices) in &held[1..] {
        let most = budget as u64 * passes.min(CHOICE_PASSES) as u64;
        assert_eq!(
            samples, most,
            "{passes} passes held {samples} vertices for the choice, budget {most}"
        );
        assert!(vertices > 0, "no vertex chose the fractions after {passes} passes");
    }
}

/// `rr: "ears"` in `guided`: the final iteration's passes (which do not record for the
/// guide) play EARS's learned roulette and splitting while sampling the guide (every
/// leaf at fraction 0.5). caustic_cbox at 128², 64 spp (32 of them the final
/// iteration's, EARS learning at its 2nd, 4th, 8th, 16th and 32nd pass), two seeds against
/// the reference averaged over 2×2 blocks: relMSE corrected −1.3e-4 ± 4.5e-4, raw 7.3e-3.
/// With the splitting's 1/n left out (split sub-paths weighted 1 each): corrected
/// +9.1 ± 2.8, which the noise hides from `converges`, raw 22.8.
#[test]
fn guided_with_ears_splits_and_converges_to_the_reference() {
    let Some(shared) = shared() else { return };
    let r = read(&shared.join("refs/caustic_cbox.exr")).block_average(2, false);
    let vr = read(&shared.join("refs/caustic_cbox.var.exr")).block_average(2, true);
    let o = r#"{"integrator": {"type": "guided", "rr": "ears", "learn_fraction": false}, "film": {"resolution": [128, 128]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[o], Profile::Physical);
    let run = |seed: u32| {
        let job = rdr::RenderJob {
            spp: 64,
            target_spp: 64,
            seed,
            ..loaded.job.clone()
        };
        rdr::render(&loaded.scene, &job, &RenderControl::default())
    };
    let (a, b) = (run(1), run(2));
    let summary = a.summary.clone().unwrap_or_default();
    let ears = summary.split("; ").find(|p| p.starts_with("ears:")).unwrap_or("no ears line");
    eprintln!("{ears}; {:.1} rays per sample", a.rays as f64 / a.samples as f64);
    let number = |i: usize| -> usize {
        let words: Vec<&str> = ears.split([' ', ',']).filter(|w| !w.is_empty()).collect();
        words.get(i).and_then(|n| n.parse().ok()).unwrap_or(0)
    };
    // "ears: 5 iterations, 2164 of 32768 cells learned, ..."
    assert!(number(1) >= 3 && number(3) > 0, "EARS did not learn: {ears}");
    let image = |o: &rdr::RenderOutput| Image::new(o.width as usize, o.height as usize, o.pixels.clone());
    let c = check("guided rr ears caustic_cbox", (&image(&a), &image(&b)), &r, &vr);
    // a bias that splitting makes also makes fireflies, whose noise can hide it from
    // `converges` alone: the error itself is bounded too (4x the baseline's)
    assert!(converges(&c) && c.rel_mse_raw < 0.03, "{c:?}");
}

/// Every decision of the schedule depends on sample counts only: the same scene,
/// spp and seed give the same image with 1 thread on a quiet run and with 2 threads,
/// under a time limit it does not reach, with every tile slowed by a sleep in the
/// progress callback (a busy machine: 32 passes in about 3 s instead of 0.1 s).
/// With the former wall-clock rule (a training iteration starts only if predicted
/// to end within 12 % of the time limit) the slowed render stops training after 3
/// iterations instead of 4 and the images differ.
#[test]
fn the_image_depends_on_sample_counts_not_on_threads_or_timing() {
    let Some(shared) = shared() else { return };
    let o = r#"{"integrator": {"type": "guided", "spatial_threshold": 100}, "film": {"resolution": [32, 32]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[o], Profile::Physical);
    let run = |threads: usize, time_limit: Option<f64>, delay: Option<std::time::Duration>| {
        let job = rdr::RenderJob {
            spp: 32,
            target_spp: 32,
            seed: 3,
            time_limit,
            ..loaded.job.clone()
        };
        let progress = delay.map(|d| Arc::new(move |_| std::thread::sleep(d)) as Arc<dyn Fn(u64) + Send + Sync>);
        let control = RenderControl {
            progress,
            ..RenderControl::default()
        };
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| rdr::render(&loaded.scene, &job, &control))
    };
    let quiet = run(1, None, None);
    let slowed = run(2, Some(20.0), Some(std::time::Duration::from_millis(100)));
    for (what, out) in [("quiet, 1 thread", &quiet), ("slowed, 2 threads", &slowed)] {
        eprintln!(
            "{what}: {} passes in {:.2} s; {}",
            out.spp_done,
            out.seconds,
            out.summary.as_deref().unwrap_or("")
        );
    }
    assert!(slowed.spp_done == 32 && !slowed.time_limited, "the slowed render ran out of time");
    assert!(slowed.seconds > 1.5, "not slowed: {} s", slowed.seconds);
    let differ = quiet.pixels.iter().zip(&slowed.pixels).filter(|(a, b)| a != b).count();
    assert!(
        differ == 0,
        "{differ} of {} pixels differ between the quiet and the slowed render",
        quiet.pixels.len()
    );
}

/// Where no leaf guides (`bsdf_fraction` 1, `learn_fraction` off), `guided` is `path`
/// number for number: its iterations continue each pixel's one sample sequence
/// (iteration k ≥ 1 takes indices [2^(k−1), 2^k)), a vertex without the guide draws
/// no strategy number, roulette is `path`'s until a guided sample, and the
/// iterations weigh by their spp; the images agree to rounding. env_sphere at 32²,
/// 16 spp (max_depth 64: roulette decides most paths).
#[test]
fn without_guiding_the_image_is_paths_sample_for_sample() {
    let Some(shared) = shared() else { return };
    let file = shared.join("refs/scenes/env_sphere.json");
    let res = r#"{"film": {"resolution": [32, 32]}}"#;
    let off = r#"{"integrator": {"type": "guided", "bsdf_fraction": 1.0, "learn_fraction": false, "training_iterations": 3, "learn_from": "paths"}}"#;
    let (path, guided) = (
        render(&load_scene(&file, &[res], Profile::Physical), 16, 5),
        render(&load_scene(&file, &[res, off], Profile::Physical), 16, 5),
    );
    let worst = path
        .pixels
        .iter()
        .zip(&guided.pixels)
        .map(|(p, g)| {
            let d = *p - *g;
            d.x.abs().max(d.y.abs()).max(d.z.abs()) / (p.max_element() + 1e-3)
        })
        .fold(0.0f32, f32::max);
    eprintln!("largest relative difference between path and unguided guided: {worst:.2e}");
    assert!(worst < 1e-4, "guided without guiding is not path's image: {worst}");
}

#[test]
fn veach_converges_outside_the_glossy_band() {
    let Some(shared) = shared() else { return };
    // rows 195–220 masked (glossy reflections of the tiny light), widened to 4×4 blocks
    let (a0, a1) = (192, 224);
    let r = read(&shared.join("refs/veach.exr")).without_rows(a0, a1).block_average(4, false);
    let vr = read(&shared.join("refs/veach.var.exr")).without_rows(a0, a1).block_average(4, true);
    let (a, b) = reduced(&shared, "veach_path", 4, 32, &[r#"{"integrator": {"spatial_threshold": 1000}}"#]);
    let c = check(
        "guided veach",
        (&a.without_rows(a0 / 4, a1 / 4), &b.without_rows(a0 / 4, a1 / 4)),
        &r,
        &vr,
    );
    // veach's variance file is a lower bound (heavy tails): the looser bound of path's test
    assert!(c.rel_mse_corrected.abs() < 5.0 * c.std_error + 3e-3, "{c:?}");
}

#[test]
fn same_image_for_1_2_3_threads() {
    let Some(shared) = shared() else { return };
    assert_same_image_for_1_2_3_threads(
        &shared.join("refs/scenes/caustic_cbox.json"),
        12,
        r#"{"integrator": {"type": "guided", "spatial_threshold": 100}, "film": {"resolution": [40, 40]}}"#,
        "guided caustic_cbox",
    );
}

#[test]
fn an_interrupted_render_is_the_shorter_render_and_time_budgets_are_followed() {
    let Some(shared) = shared() else { return };
    let o = r#"{"integrator": {"type": "guided", "training_iterations": 3}, "film": {"resolution": [32, 32]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/cbox_path.json"), &[o], Profile::Physical);
    // stop during pass 10 of 20 (the tiles of a 32² film with 16² blocks report 4 times a pass)
    let reports = Arc::new(AtomicU64::new(0));
    let control = RenderControl {
        progress: None,
        stop: Arc::new(StopToken::new()),
        periodic: Vec::new(),
    };
    let (r2, stop) = (reports.clone(), control.stop.clone());
    let control = RenderControl {
        progress: Some(Arc::new(move |_| {
            if r2.fetch_add(1, Ordering::SeqCst) + 1 == 4 * 9 + 2 {
                stop.stop();
            }
        })),
        ..control
    };
    let job = rdr::RenderJob {
        spp: 20,
        seed: 4,
        ..loaded.job.clone()
    };
    let cut = rdr::render(&loaded.scene, &job, &control);
    assert!(cut.interrupted && cut.spp_done == 9, "{} passes", cut.spp_done);
    let short = rdr::render(&loaded.scene, &rdr::RenderJob { spp: 9, ..job.clone() }, &RenderControl::default());
    assert!(cut.pixels == short.pixels, "the interrupted image is the 9-pass image");
    assert!(cut.pixels.iter().all(|p| p.is_finite()));

    // a time budget: training and the final iteration within it
    let o = r#"{"integrator": {"type": "guided"}, "film": {"resolution": [32, 32]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/cbox_path.json"), &[o], Profile::Physical);
    let job = rdr::RenderJob {
        spp: 1_000_000,
        time_limit: Some(2.0),
        ..loaded.job.clone()
    };
    let out = rdr::render(&loaded.scene, &job, &RenderControl::default());
    let summary = out.summary.unwrap();
    eprintln!("{} passes in {:.2} s; {summary}", out.spp_done, out.seconds);
    assert!(out.time_limited && out.seconds < 3.0, "{} s", out.seconds);
    assert!(summary.contains("training iterations for 1000000 spp"), "{summary}");
    let reference = read(&shared.join("refs/cbox.exr")).mean();
    let m = Image::new(32, 32, out.pixels).mean();
    assert!(
        (m - reference).abs().max_element() < 0.05 * reference.max_element(),
        "mean {m} vs {reference}"
    );
}

/// The white furnace (a white diffuse sphere under a uniform white sky) is 1
/// everywhere: with the defaults, and with the guide learning the sky's light
/// (`learn_direct`) and forced on at half of every vertex's samples, so the light
/// samples' MIS weights must use the mixture's density (the guide's density
/// there differs from the BSDF's). Leaving the guide's density out of the light
/// samples' weights (the BSDF's alone there) gave 0.960 with the guide forced on,
/// 13× the tolerance of 3e-3 there (the baseline: 1.00021–1.00058, 5× below it or more).
#[test]
fn white_furnace_is_one() {
    let Some(shared) = shared() else { return };
    // (the mean of 100² pixels at 256 spp has a standard error of 1.6e-4 with the
    // defaults; half the samples from a guide spread over the sphere raise it)
    for (extra, tolerance) in [
        (r#"{}"#, 8e-4),
        (
            r#"{"integrator": {"learn_direct": true, "learn_fraction": false, "bsdf_fraction": 0.5}}"#,
            3e-3,
        ),
    ] {
        let o = r#"{"integrator": {"type": "guided", "spatial_threshold": 200}, "film": {"resolution": [100, 100]}}"#;
        let s = load_scene(&shared.join("refs/scenes/sphere_furnace.json"), &[o, extra], Profile::Physical);
        let img = render(&s, 256, 3);
        let m = img.mean();
        eprintln!("guided furnace {extra}: mean {m}");
        assert!((m - Vec3::ONE).abs().max_element() < tolerance, "{extra}: {m}");
    }
}

/// Per-pixel moments (Σy, Σy², n) and pixel means of `spp` samples a pixel from a
/// heavy-tailed distribution: 0.5, or 100 with probability 1 %.
fn firefly_iteration(rng: &mut Rng, pixels: usize, spp: u32) -> (Vec<[f64; 3]>, Vec<Vec3>) {
    iteration_of(pixels, spp, |_, _| if rng.unit() < 0.01 { 100.0 } else { 0.5 })
}

/// Per-pixel moments (Σy, Σy², n) and pixel means of `spp` samples `sample(pixel, j)`
/// a pixel, drawn pixel by pixel.
fn iteration_of(pixels: usize, spp: u32, mut sample: impl FnMut(usize, u32) -> f64) -> (Vec<[f64; 3]>, Vec<Vec3>) {
    let mut moments = vec![[0.0f64; 3]; pixels];
    for (i, m) in moments.iter_mut().enumerate() {
        for j in 0..spp {
            let y = sample(i, j);
            m[0] += y;
            m[1] += y * y;
            m[2] += 1.0;
        }
    }
    let image = moments.iter().map(|m| Vec3::splat((m[0] / m[2]) as f32)).collect();
    (moments, image)
}

#[test]
fn iteration_weights_follow_the_true_variance_of_heavy_tailed_iterations() {
    // two iterations of the same per-sample distribution, 2 and 8 spp: their pixel
    // means' variances are 4:1, and so must the estimated variances be
    let (width, pixels) = (200usize, 40_000usize);
    let mut rng = Rng::new(5);
    let (ma, ia) = firefly_iteration(&mut rng, pixels, 2);
    let (mb, ib) = firefly_iteration(&mut rng, pixels, 8);
    let (va, vb) = (pixel_variances(&ma, width), pixel_variances(&mb, width));
    let parts = [
        Part {
            image: &ia,
            pixel_variance: &va,
            spp: 2,
        },
        Part {
            image: &ib,
            pixel_variance: &vb,
            spp: 8,
        },
    ];
    let v = relative_variances(&parts);
    let ratio = v[0] / v[1];
    eprintln!("estimated variance ratio {ratio:.3} (true 4)");
    assert!((ratio - 4.0).abs() < 0.6, "ratio {ratio}");
    // each iteration's own pixel mean as the denominator (the weighting before):
    // a rare bright sample raises the mean with the variance, and the 2-spp
    // iteration looks better than the 8-spp one
    let own = |m: &[[f64; 3]], var: &[f32]| {
        m.iter()
            .zip(var)
            .map(|(m, v)| *v as f64 / ((m[0] / m[2]).powi(2) + 0.01))
            .sum::<f64>()
            / pixels as f64
    };
    let wrong = own(&ma, &va) / own(&mb, &vb);
    eprintln!("  with each iteration's own pixel means: {wrong:.3}, rejected as it must be");
    assert!((wrong - 4.0).abs() >= 0.6);
}

/// An iteration of `spp` samples per pixel around the pixel's value `mu`: i.i.d.
/// uniform noise of half-width 1, or (`paired`) the noise in antithetic pairs
/// (e, −e) plus i.i.d. noise of half-width 0.25, so the samples spread as widely
/// but their mean varies 16× less (what a stratified sampler does to a long
/// iteration).
fn stratified_iteration(rng: &mut Rng, mu: &[f64], spp: u32, paired: bool) -> (Vec<[f64; 3]>, Vec<Vec3>) {
    let mut e = 0.0;
    iteration_of(mu.len(), spp, |i, j| {
        let noise = if paired {
            if j % 2 == 0 {
                e = 2.0 * rng.unit() - 1.0;
            } else {
                e = -e;
            }
            e + 0.25 * (2.0 * rng.unit() - 1.0)
        } else {
            2.0 * rng.unit() - 1.0
        };
        mu[i] + 0.1 * noise
    })
}

#[test]
fn iteration_variances_from_image_differences_see_stratification() {
    // three iterations: 4 spp i.i.d., 4 spp paired (16× less variance of the mean
    // than i.i.d. 4 spp, for the same spread within pixels), 8 spp i.i.d.; true
    // variances of the pixel means 4 : 0.25 : 2 (relative to the 8-spp one: 2, 0.125)
    let (width, pixels) = (200usize, 40_000usize);
    let mut rng = Rng::new(11);
    let mu: Vec<f64> = (0..pixels).map(|_| 0.2 + rng.unit()).collect();
    let its = [(4, false), (4, true), (8, false)].map(|(spp, paired)| {
        let (m, image) = stratified_iteration(&mut rng, &mu, spp, paired);
        (pixel_variances(&m, width), image, spp)
    });
    let parts: Vec<Part> = its
        .iter()
        .map(|(v, image, spp)| Part {
            image,
            pixel_variance: v,
            spp: *spp,
        })
        .collect();
    let v = relative_variances(&parts);
    let (a, b) = (v[0] / v[2], v[1] / v[2]);
    eprintln!("from image differences: variance ratios {a:.3} (true 2), {b:.3} (true 0.125)");
    assert!((a - 2.0).abs() < 0.2 && (b - 0.125).abs() < 0.04, "{a} {b}");
    // the spread within pixels cannot see the pairing (the estimator before)
    let w = relative_variances_within(&parts);
    let (a, b) = (w[0] / w[2], w[1] / w[2]);
    eprintln!("  from the spread within pixels: {a:.3}, {b:.3}, rejected as it must be");
    assert!(!((a - 2.0).abs() < 0.2 && (b - 0.125).abs() < 0.04));
}

/// The cube [-1, 1]³ as an OBJ, each face two triangles facing inwards.
fn inward_cube_obj() -> String {
    let corner = |i: usize| {
        Vec3::new(
            if i & 1 == 1 { 1.0 } else { -1.0 },
            if i & 2 == 2 { 1.0 } else { -1.0 },
            if i & 4 == 4 { 1.0 } else { -1.0 },
        )
    };
    let mut obj = String::new();
    for i in 0..8 {
        let c = corner(i);
        obj += &format!("v {} {} {}\n", c.x, c.y, c.z);
    }
    // each face's four corners in cyclic order
    let faces = [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]];
    for f in faces {
        for t in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
            let (a, b, c) = (corner(t[0]), corner(t[1]), corner(t[2]));
            let outward = (b - a).cross(c - a).dot(a + b + c) > 0.0;
            let t = if outward { [t[0], t[2], t[1]] } else { t };
            obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
        }
    }
    obj
}

/// A closed cube whose inside walls emit radiance 1 and reflect diffusely with albedo
/// ρ = 0.5: every segment of a path finds emission 1 and the throughput falls by ρ
/// per bounce, so a camera inside sees Σ_{k<D} ρ^k for `max_depth` D = 12, whatever
/// the guide learned, as long as roulette divides by its survival probability (from
/// the 5th segment on, ρ⁴ < `rr_threshold`, it ends most paths). The guide is forced
/// on (fraction 0.5), so the roulette's guided throughput is exercised. Image means
/// of 8 seeds at 4096 spp: 1.99936 ± 0.00018 against 1.99951; without the division
/// by the survival probability see the assertion's message.
#[test]
fn guided_roulette_keeps_a_glowing_box_at_its_geometric_series() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cube.obj"), inward_cube_obj()).unwrap();
    let (rho, depth) = (0.5f64, 12);
    let scene = serde_json::json!({
        "integrator": {"type": "guided", "spp": 64, "max_depth": depth, "learn_fraction": false, "training_iterations": 3, "combine": "last"},
        "film": {"resolution": [16, 16]},
        "camera": {"position": [0.1, 0.2, 0.3], "look_at": [0.0, 0.0, -1.0], "ref_up": [0.0, 1.0, 0.0], "fov": 60.0},
        "textures": {"wall": {"type": "constant", "color": [rho, rho, rho]}},
        "materials": {"wall": {"type": "diffuse", "texture_name": "wall"}},
        "objects": [{"type": "mesh", "path": "cube.obj", "material_name": "wall", "light": {"type": "area", "radiance": [1.0, 1.0, 1.0]}}]
    });
    let path = dir.path().join("box.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let expected = (1.0 - rho.powi(depth)) / (1.0 - rho);
    for integrator in ["guided", "path"] {
        // the image mean's standard error at 1024 spp is about 0.001 (guided) and 0.0002 (path)
        let o = format!(r#"{{"integrator": {{"type": "{integrator}"}}}}"#);
        let loaded = load_scene(&path, &[o.as_str()], Profile::Physical);
        let mean = render(&loaded, 1024, 1).mean();
        let m = (mean.x + mean.y + mean.z) as f64 / 3.0;
        eprintln!("{integrator}: mean {m:.4}, expected {expected:.4}");
        assert!((m - expected).abs() < 0.005, "{integrator}: {m} against {expected}");
    }
}

/// The MIS weights of light samples use the density guided sampling really has (the
/// mixture of the BSDF and the guide), so that each direction's weights sum to one: a
/// box lit by a square light below its ceiling (which the guide learns, `learn_direct`),
/// with the guide at half of every vertex's samples, against `path` on the same scene. Leaving
/// the guide's density out of the light samples' weight (the BSDF's alone there, the
/// mixture's in the BSDF samples' weight) counts the ceiling's light twice where the
/// guide points at it: the image mean then rose by 8.8 % (guided 0.18551 against path
/// 0.17049); the baseline differed by 0.002 %, the test allows 2.5 % (3.5x below the error).
#[test]
fn guided_mis_weights_the_light_samples_by_the_mixture_density() {
    let dir = tempfile::tempdir().unwrap();
    // a square light below the ceiling, facing down
    let light = "v -0.5 0.98 -0.5\nv 0.5 0.98 -0.5\nv 0.5 0.98 0.5\nv -0.5 0.98 0.5\nf 1 2 3\nf 1 3 4\n";
    std::fs::write(dir.path().join("walls.obj"), inward_cube_obj()).unwrap();
    std::fs::write(dir.path().join("light.obj"), light).unwrap();
    let scene = serde_json::json!({
        "integrator": {"type": "guided", "spp": 64, "max_depth": 6, "learn_fraction": false, "learn_direct": true,
                       "training_iterations": 5, "spatial_threshold": 300, "combine": "last"},
        "film": {"resolution": [32, 32]},
        "camera": {"position": [0.0, 0.5, 0.95], "look_at": [0.0, -1.0, -0.2], "ref_up": [0.0, 1.0, 0.0], "fov": 70.0},
        "textures": {"wall": {"type": "constant", "color": [0.5, 0.5, 0.5]}},
        "materials": {"wall": {"type": "diffuse", "texture_name": "wall"}},
        "objects": [
            {"type": "mesh", "path": "walls.obj", "material_name": "wall"},
            {"type": "mesh", "path": "light.obj", "light": {"type": "area", "radiance": [4.0, 4.0, 4.0]}}
        ]
    });
    let path = dir.path().join("box.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let mut means = Vec::new();
    for integrator in ["guided", "path"] {
        let o = format!(r#"{{"integrator": {{"type": "{integrator}"}}}}"#);
        let loaded = load_scene(&path, &[o.as_str()], Profile::Physical);
        let mean = render(&loaded, 256, 1).mean();
        means.push((mean.x + mean.y + mean.z) as f64 / 3.0);
    }
    let (guided, path) = (means[0], means[1]);
    eprintln!("image mean: guided {guided:.6}, path {path:.6}, ratio {:.5}", guided / path);
    assert!((guided / path - 1.0).abs() < 0.025, "guided {guided} against path {path}");
}

#[test]
fn batched_recording_cells_are_the_one_at_a_time_cells() {
    let Some(shared) = shared() else { return };
    // the training photons' cells come from lockstep batches of descents
    // (`SdTree::record_cells`): every one must be `record_cell`'s, in order, over trained
    // (refined) recording trees and a query count that leaves a partial batch
    let o = r#"{"integrator": {"type": "guided", "spatial_threshold": 300}, "film": {"resolution": [64, 64]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[o], Profile::Physical);
    let state = train(&loaded, 8);
    let tree = state.learned_tree().unwrap();
    let deepest = tree.leaves.iter().map(|l| l.building.depth()).max().unwrap();
    assert!(
        tree.leaves.len() > 1 && deepest > 2,
        "{} leaves, depth {deepest}: too little tree to test",
        tree.leaves.len()
    );
    let mut rng = Rng::new(3);
    let queries: Vec<(u32, Vec2)> = (0..10_005)
        .map(|_| (rng.below(tree.leaves.len()) as u32, uniform2(&mut rng)))
        .collect();
    let batched = tree.record_cells(&queries);
    let wrong = queries
        .iter()
        .zip(&batched)
        .filter(|(&(leaf, p), &c)| tree.record_cell_at(leaf, p) != c)
        .count();
    eprintln!(
        "{} queries over {} leaves (recording depth up to {deepest}): {wrong} cells differ",
        queries.len(),
        tree.leaves.len()
    );
    assert_eq!((batched.len(), wrong), (queries.len(), 0));
}

/// A guided pass where the scene traces packets takes `path`'s: camera rays and their
/// shadow rays as packets, each lane then walking on alone with its own records, which
/// are put back in the pixels' order. The trees learned (mid-iteration too: 6 passes
/// end inside the 4-spp iteration, whose recording trees hold part of their
/// deposits) and the image are those of ray-by-ray passes bit for bit:
/// records from paths with direct light (cornell, 37×29 under a wide filter, whose
/// samples add in order), from photons (caustic_cbox), the variance target under a
/// sky (env_sphere).
#[test]
fn packet_passes_learn_and_render_as_ray_by_ray() {
    let res = r#"{"film": {"resolution": [37, 29], "filter": {"type": "gaussian", "radius": 1.5}}}"#;
    let mut cases = vec![(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.json"),
        r#"{"integrator": {"type": "guided", "learn_fraction": false, "learn_from": "paths", "learn_direct": true, "spatial_threshold": 100}}"#,
    )];
    if let Some(shared) = shared() {
        cases.push((
            shared.join("refs/scenes/caustic_cbox.json"),
            r#"{"integrator": {"type": "guided", "learn_fraction": false, "spatial_threshold": 100}}"#,
        ));
        cases.push((
            shared.join("refs/scenes/env_sphere.json"),
            r#"{"integrator": {"type": "guided", "learn_fraction": false, "target": "variance", "spatial_threshold": 100}}"#,
        ));
    }
    for (file, o) in cases {
        let mut loaded = load_scene(&file, &[res, o], Profile::Physical);
        assert!(loaded.scene.packets(), "{}: packets expected", file.display());
        let run = |loaded: &rdr::Loaded| {
            let mut state = train(loaded, 6);
            let tree = state.guided().as_ref().expect("a guided state").tree.clone();
            let job = rdr::RenderJob {
                spp: 16,
                target_spp: 16,
                seed: 5,
                ..loaded.job.clone()
            };
            let out = rdr::render(&loaded.scene, &job, &RenderControl::default());
            let bits: Vec<[u32; 3]> = out.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect();
            (tree, bits)
        };
        let packets = run(&loaded);
        assert!(loaded.scene.bvh.set_packet_width(0));
        let alone = run(&loaded);
        let name = file.display();
        let differ = packets.1.iter().zip(&alone.1).filter(|(a, b)| a != b).count();
        let leaves_differ = packets.0.leaves.iter().zip(&alone.0.leaves).filter(|(a, b)| a != b).count();
        eprintln!(
            "{name}: {leaves_differ} of {} leaves and {differ} pixels differ",
            alone.0.leaves.len()
        );
        assert!(packets.0 == alone.0, "{name}: the trees differ ({leaves_differ} leaves)");
        assert_eq!(differ, 0, "{name}: {differ} pixels differ from ray-by-ray");
    }
}

/// The training photons are kept and deposited again into every later recording tree
/// (`guided::photons`): with one spatial leaf (which always takes up what it recorded),
/// the tree learned at the end of each training iteration (16 spp: 1, 1, 2, 4, every
/// pass recording) holds the energy of all the photons kept so far, the earlier
/// iterations' and its own, at least one per pixel and pass of the iteration, while the
/// iterations after the first shoot fewer than that. Fails where
/// the earlier iterations' photons are not deposited again (the trees hold 0.20, 0.37 and
/// 0.50 of the kept energy; 1 ± 2e-7 when right) and where they are deposited twice (1.80,
/// 1.63, 1.50).
#[test]
fn kept_training_photons_go_into_every_later_tree() {
    let Some(shared) = shared() else { return };
    let o = r#"{"integrator": {"type": "guided", "spatial_threshold": 1e9, "learn_fraction": false}, "film": {"resolution": [64, 64]}}"#;
    let loaded = load_scene(&shared.join("refs/scenes/caustic_cbox.json"), &[o], Profile::Physical);
    let mut pass = 0;
    let mut seen = Vec::new();
    train_with(&loaded, 16, 7, |state| {
        let s = state.guided().as_ref();
        // before the passes that follow the training iterations' ends
        if [1, 2, 4, 8].contains(&pass) {
            let s = s.expect("a guided state");
            assert_eq!(s.tree.leaves.len(), 1, "the tree was split");
            let (photons, _) = s.photons.kept();
            seen.push((photons, s.tree.leaves[0].sampling.total() as f64 / s.photons.kept_energy()));
        }
        pass += 1;
    });
    eprintln!("(photons kept, tree's energy / kept energy) after each training iteration: {seen:?}");
    let pixels = 64 * 64;
    for (i, length) in [1, 1, 2, 4].into_iter().enumerate() {
        let new = seen[i].0 - if i > 0 { seen[i - 1].0 } else { 0 };
        assert!(
            seen[i].0 >= length * pixels && (i == 0 || new < length * pixels),
            "photons kept {seen:?}: after iteration {i} of {length} passes {} (new: {new}) for {pixels} pixels",
            seen[i].0
        );
    }
    for (photons, ratio) in &seen {
        assert!(
            (ratio - 1.0).abs() < 1e-3,
            "with {photons} photons kept the tree holds {ratio} of their energy"
        );
    }
}
