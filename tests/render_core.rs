//! The render core: splats land where they should and merge identically for any
//! thread count, a pass can be abandoned mid-way through the stop token, and images
//! do not depend on the thread count.

mod common;

use rdr::film::{Film, FilmSettings, Filter, Splats};
use rdr::integrator::{camera_pass, PassContext, StopToken};
use rdr::math::{Vec2, Vec3};
use rdr::{Loaded, Profile, RenderControl};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

fn cornell(overrides: &[&str]) -> Loaded {
    common::load_scene(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.json"),
        overrides,
        Profile::Physical,
    )
}

#[test]
fn splats_land_in_the_pixel_they_hit_and_keep_their_value_through_any_filter() {
    // box filter: one pixel, divided by the samples per pixel
    let mut film = Film::new(4, 3, Filter::Box { radius: 0.5 });
    let mut s = Splats::default();
    s.add(Vec2::new(2.25, 0.75), Vec3::new(1.0, 2.0, 3.0)); // film row 0 = output row 2
    s.add(Vec2::new(-0.1, 1.0), Vec3::ONE); // outside: dropped
    s.add(Vec2::new(1.0, 3.0), Vec3::ONE); // outside (y = height): dropped
    film.add_splats(&s);
    let img = film.to_rgb_rows(0.5);
    for (i, p) in img.iter().enumerate() {
        let expected = if i == 2 * 4 + 2 { Vec3::new(0.5, 1.0, 1.5) } else { Vec3::ZERO };
        assert_eq!(*p, expected, "pixel {i}");
    }

    // wide filters spread a splat over its neighbours; over positions spread evenly
    // within a pixel the total is the splat's value (the filter is normalised by its
    // integral, which a single position samples only approximately)
    for filter in [
        Filter::Gaussian {
            radius: 1.5,
            alpha: 2.0,
            tail: (-2.0f32 * 1.5 * 1.5).exp(),
        },
        Filter::Mitchell {
            radius: 2.0,
            b: 1.0 / 3.0,
            c: 1.0 / 3.0,
        },
        Filter::Box { radius: 1.5 },
    ] {
        let mut film = Film::new(9, 9, filter);
        let mut one = Film::new(9, 9, filter);
        let mut s = Splats::default();
        s.add(Vec2::new(4.3, 4.6), Vec3::splat(10.0));
        one.add_splats(&s);
        let img = one.to_rgb_rows(1.0);
        let lit = img.iter().filter(|p| p.x != 0.0).count();
        assert!(lit >= 9, "{filter:?}: spread over {lit} pixels");
        // the pixel under the splat gets the most
        let centre = img[(8 - 4) * 9 + 4].x;
        assert!(img.iter().all(|p| p.x <= centre), "{filter:?}");

        let n = 32;
        let mut s = Splats::default();
        for i in 0..n * n {
            let (u, v) = ((i % n) as f32 + 0.5, (i / n) as f32 + 0.5);
            s.add(Vec2::new(4.0 + u / n as f32, 4.0 + v / n as f32), Vec3::splat(10.0));
        }
        film.add_splats(&s);
        let total: f64 = film.to_rgb_rows(1.0 / (n * n) as f64).iter().map(|p| p.x as f64).sum();
        assert!((total - 10.0).abs() < 2e-3, "{filter:?}: splat total {total}");
    }
}

/// Passes of `camera_pass` whose samples also splat to positions and values drawn
/// from their sampler, over thirty orders of magnitude, so that any change in the
/// order of the f64 additions shows in the sums.
fn splatting_pass(loaded: &Loaded, film_settings: &FilmSettings, passes: u32) -> (Vec<Vec3>, Vec<[f64; 3]>) {
    let mut film = Film::new(film_settings.width, film_settings.height, film_settings.filter);
    let stop = StopToken::new();
    let ctx = PassContext {
        scene: &loaded.scene,
        camera: &loaded.job.camera,
        film: film_settings,
        spp: passes,
        target_spp: passes,
        seed: 3,
        time_limit: None,
        stop: &stop,
        progress: &|_| {},
    };
    let (w, h) = (film_settings.width as f32, film_settings.height as f32);
    for pass in 0..passes {
        let r = camera_pass(&ctx, pass, &mut film, |s| {
            for _ in 0..3 {
                let (u, v) = s.sampler.next_2d();
                let (a, b) = s.sampler.next_2d();
                let value = Vec3::new(10f32.powf(30.0 * a - 15.0), b, 1.0 - b);
                s.splats.add(Vec2::new(u * w, v * h), value);
            }
            Vec3::new(s.pos.x, s.pos.y, 1.0)
        });
        assert!(r.complete);
    }
    (film.to_rgb_rows(1.0 / passes as f64), film.splat_sums().to_vec())
}

#[test]
fn splats_merge_identically_for_any_thread_count() {
    let loaded = cornell(&[]);
    let settings = FilmSettings {
        width: 37,
        height: 29,
        filter: Filter::Gaussian {
            radius: 1.5,
            alpha: 2.0,
            tail: (-2.0f32 * 1.5 * 1.5).exp(),
        },
        sampling: rdr::film::FilmSampling::Filter,
        block_size: 8,
    };
    let with_threads = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| splatting_pass(&loaded, &settings, 3))
    };
    let bits = |img: &[Vec3]| img.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<u32>>();
    let sum_bits = |s: &[[f64; 3]]| s.iter().flat_map(|p| p.map(f64::to_bits)).collect::<Vec<u64>>();
    let (one, one_sums) = with_threads(1);
    assert!(one.iter().any(|p| p.x > 1e3), "the splats reached the film");
    for n in [2, 3] {
        let (img, sums) = with_threads(n);
        assert_eq!(bits(&one), bits(&img), "{n} threads");
        assert_eq!(sum_bits(&one_sums), sum_bits(&sums), "{n} threads: splat sums");
    }
}

#[test]
fn the_stop_token_abandons_a_pass_midway_and_keeps_the_finished_ones() {
    let loaded = cornell(&[r#"{"film": {"resolution": [64, 64], "block_side_length": 8}}"#]);
    let job = rdr::RenderJob {
        spp: 4,
        ..loaded.job.clone()
    };
    let pixels = 64u64 * 64;
    let control = RenderControl::default();
    let seen = Arc::new(AtomicU64::new(0));
    let control = RenderControl {
        progress: Some({
            let (seen, stop) = (seen.clone(), control.stop.clone());
            Arc::new(move |n| {
                // stop in the middle of the second pass
                if seen.fetch_add(n, Ordering::SeqCst) + n >= pixels + pixels / 2 {
                    stop.stop();
                }
            })
        }),
        ..control
    };
    let out = rdr::render(&loaded.scene, &job, &control);
    assert!(out.interrupted);
    assert_eq!(out.spp_done, 1, "only the first pass finished");
    assert!(seen.load(Ordering::SeqCst) < 2 * pixels, "the second pass stopped before its end");
    // what was kept is exactly the one-sample image
    let one = common::render(&loaded, 1, 0);
    assert_eq!(out.pixels, one.pixels);
}

#[test]
fn cli_images_are_byte_identical_for_one_two_and_three_threads() {
    common::assert_same_image_for_1_2_3_threads(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.json"),
        3,
        r#"{"film": {"resolution": [40, 30], "block_side_length": 7, "filter": {"type": "mitchell", "radius": 2}},
            "integrator": {"type": "path", "max_depth": 6}}"#,
        "path, mitchell filter",
    );
}

/// Filter importance sampling (`film.sampling: "importance"`) keeps each sample in its
/// own pixel: the noise of neighbouring pixels is independent, where the filter's
/// weights spread each sample over its neighbours (a denoiser cannot remove that), and
/// the image is the same on average.
#[test]
fn importance_sampled_films_have_independent_pixel_noise() {
    let render = |sampling: &str, seed: u32| {
        let film = format!(
            r#"{{"film":{{"resolution":[48,48],"filter":{{"type":"gaussian","radius":1.5,"alpha":2}},"sampling":"{sampling}"}},
                "integrator":{{"type":"path","max_depth":3,"spp":4}}}}"#
        );
        let mut loaded = cornell(&[&film]);
        loaded.job.seed = seed;
        rdr::render::render(&loaded.scene, &loaded.job, &RenderControl::default()).pixels
    };
    let luma = |p: &Vec3| (p.x + p.y + p.z) as f64;
    // the noise alone: the difference of two seeds
    let neighbour_correlation = |a: &[Vec3], b: &[Vec3]| {
        let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| luma(x) - luma(y)).collect();
        let (mut xy, mut xx) = (0.0, 0.0);
        for row in d.chunks(48) {
            for i in 0..47 {
                xy += row[i] * row[i + 1];
                xx += row[i] * row[i];
            }
        }
        xy / xx
    };
    let (f1, f2) = (render("filter", 1), render("filter", 2));
    let (i1, i2) = (render("importance", 1), render("importance", 2));
    let (cf, ci) = (neighbour_correlation(&f1, &f2), neighbour_correlation(&i1, &i2));
    let mean = |a: &[Vec3], b: &[Vec3]| a.iter().chain(b).map(luma).sum::<f64>() / (2 * a.len()) as f64;
    let (mf, mi) = (mean(&f1, &f2), mean(&i1, &i2));
    eprintln!("neighbour noise correlation: filter weights {cf:.3}, importance {ci:.3}; mean {mf:.4} vs {mi:.4}");
    assert!(cf > 0.15, "the filter's weights should correlate neighbours ({cf:.3})");
    assert!(ci.abs() < 0.1, "importance-sampled pixels' noise is correlated ({ci:.3})");
    assert!(
        (mi / mf - 1.0).abs() < 0.02,
        "mean {mi:.4} with importance sampling, {mf:.4} with the filter's weights"
    );
}
