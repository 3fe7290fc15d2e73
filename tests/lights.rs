//! Lights of every kind against references: Mitsuba's env_sphere, and a Cornell
//! box with two point lights and an area light against an independent
//! brute-force estimator (cosine-weighted hemisphere sampling, which never asks
//! the lights how to sample them).

mod common;
use common::*;
use rdr::math::{Frame, Vec2, Vec3};
use rdr::metrics::{compare, Image};
use rdr::Profile;
use std::path::Path;

/// Mean relative variance of a render at `spp` (from two independent halves).
fn own_variance(scene: &rdr::Loaded, spp: u32) -> f64 {
    relative_variance_of_mean(&render(scene, spp, 11), &render(scene, spp, 12))
}

fn env_scene(shared: &Path, extra: &str) -> rdr::Loaded {
    let base = r#"{"integrator": {"type": "intersection_test", "spp": 8}}"#;
    let mut o = vec![base];
    if !extra.is_empty() {
        o.push(extra);
    }
    load_scene(&shared.join("refs/scenes/env_sphere.json"), &o, Profile::Physical)
}

#[test]
fn env_sphere_converges_to_mitsuba_and_importance_sampling_helps() {
    let Some(shared) = shared() else { return };
    let refs = shared.join("refs");
    let (r, vr) = (read(&refs.join("env_sphere.exr")), read(&refs.join("env_sphere.var.exr")));
    let block = |i: &Image| i.block_average(2, false);
    let (rb, vrb) = (block(&r), vr.block_average(2, true));

    // A white diffuse sphere is convex: direct light is all the light, so the
    // direct-lighting integrator must match Mitsuba's path tracer.
    let scene = env_scene(&shared, "");
    let (x1, x2) = (render(&scene, 16, 1), render(&scene, 16, 2));
    let good = compare(&block(&x1), &block(&x2), &rb, &vrb);
    eprintln!("importance: {good:?}");
    assert!(good.rel_mse_corrected.abs() < 5.0 * good.std_error + 2e-4, "{good:?}");

    // equal sample count, uniform directions: unbiased too ...
    let uniform = env_scene(&shared, r#"{"integrator": {"light_sampling": "uniform"}}"#);
    let (u1, u2) = (render(&uniform, 16, 1), render(&uniform, 16, 2));
    let unif = compare(&block(&u1), &block(&u2), &rb, &vrb);
    assert!(
        unif.rel_mse_corrected.abs() < 5.0 * unif.std_error + 2e-4,
        "uniform sampling is unbiased too: {unif:?}"
    );
    // ... but noisier (fixed seeds: the figures are deterministic)
    eprintln!(
        "env_sphere at 16 spp, relative MSE against Mitsuba: importance sampling {:.3e}, uniform directions {:.3e}",
        good.rel_mse_raw, unif.rel_mse_raw
    );
    assert!(
        unif.rel_mse_raw > 1.3 * good.rel_mse_raw,
        "importance sampling should cut the error"
    );

    // a mirrored environment (x → −x) is caught
    let mirrored = env_scene(
        &shared,
        r#"{"environment_map": {"transform": [-1.0,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}}"#,
    );
    let (m1, m2) = (render(&mirrored, 16, 1), render(&mirrored, 16, 2));
    let bad = compare(&block(&m1), &block(&m2), &rb, &vrb);
    eprintln!("mirrored: {bad:?}");
    assert!(
        bad.rel_mse_corrected > 20.0 * (good.std_error + bad.std_error) && bad.rel_mse_corrected > 1e-3,
        "{bad:?}"
    );
}

/// A square light of side 0.6 (two triangles) and ten tiny triangles beside it:
/// choosing triangles uniformly wastes most samples on the tiny ones.
fn cornell_light_obj() -> String {
    let mut s = String::from("v -0.3 1.98 -0.3\nv 0.3 1.98 -0.3\nv 0.3 1.98 0.3\nv -0.3 1.98 0.3\nf 1 2 3 4\n");
    for k in 0..10 {
        let x = -0.5 + 0.1 * k as f32;
        s += &format!("v {x} 1.98 0.5\nv {} 1.98 0.5\nv {x} 1.98 0.52\nf -3 -2 -1\n", x + 0.02);
    }
    s
}

/// The bundled Cornell box without its lens, with two point lights and a small
/// area light under the ceiling (winding faces down).
fn cornell_with_area_light(sampling: &str) -> rdr::Loaded {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let tmp = common::temp_dir("rdr-lights");
    let dir = tmp.path();
    let light_obj = dir.join("ceiling_light.obj");
    std::fs::write(&light_obj, cornell_light_obj()).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(root.join("cornell.json")).unwrap()).unwrap();
    let objects = v["objects"].as_array_mut().unwrap();
    objects.retain(|o| o["type"] != "sphere");
    objects.push(
        serde_json::json!({"type": "mesh", "path": light_obj.to_str().unwrap(), "light": {"type": "area", "radiance": [4.0, 3.5, 3.0]}}),
    );
    v["film"]["resolution"] = serde_json::json!([24, 24]);
    v["integrator"]["light_sampling"] = serde_json::json!(sampling);
    let desc = rdr::desc::SceneDesc::from_value(&v, &root.join("cornell.json"), &root).unwrap();
    rdr::Loaded::build(&desc, rdr::Profile::Physical).unwrap()
}

/// Independent estimate of the same image: at the first diffuse hit, point lights
/// exactly, and the area light by cosine-weighted directions that happen to hit
/// it (ρ·Le per hit). Returns the mean and the variance of the mean per pixel.
fn brute_force(loaded: &rdr::Loaded, per_pixel: usize) -> (Image, Image) {
    let (scene, job) = (&loaded.scene, &loaded.job);
    let (w, h) = (job.film.width as usize, job.film.height as usize);
    let mut mean = vec![Vec3::ZERO; w * h];
    let mut var = vec![Vec3::ZERO; w * h];
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut rnd = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    for row in 0..h {
        for x in 0..w {
            let (mut s1, mut s2) = (Vec3::ZERO, Vec3::ZERO);
            for _ in 0..per_pixel {
                let film = Vec2::new(x as f32 + rnd(), (h - 1 - row) as f32 + rnd());
                let ray = job.camera.ray(film.x, film.y);
                let mut l = Vec3::ZERO;
                if let Some(hit) = scene.intersect(&ray) {
                    let it = scene.interaction(&ray, &hit);
                    if let Some((_, a)) = scene.area_light_of(&it) {
                        l += a.emitted(it.ng, it.wo, it.uv);
                    }
                    if let Some(rdr::material::Material::Diffuse { texture, .. }) = scene.material_of(&it) {
                        let rho = match &scene.textures[*texture as usize] {
                            rdr::texture::Texture::Constant(c) => *c,
                            _ => panic!("constant textures only"),
                        };
                        let n = if it.ns.dot(it.wo) > 0.0 { it.ns } else { Vec3::ZERO };
                        if n != Vec3::ZERO {
                            let side = if it.ng.dot(n) > 0.0 { it.ng } else { -it.ng };
                            let o = rdr::math::offset_ray_origin(it.p, side);
                            for light in &scene.lights {
                                if let rdr::light::Light::Point { position, flux } = light {
                                    let v = *position - o;
                                    let d2 = v.length_squared();
                                    let cos = n.dot(v) / d2.sqrt();
                                    let shadow = rdr::geometry::Ray::with_range(o, v / d2.sqrt(), 0.0, d2.sqrt() * 0.9999);
                                    if cos > 0.0 && !scene.occluded(&shadow) {
                                        l += rho / std::f32::consts::PI * *flux / (4.0 * std::f32::consts::PI) * cos / d2;
                                    }
                                }
                            }
                            let d = Frame::from_normal(n).to_world(rdr::sampling::cosine_hemisphere(Vec2::new(rnd(), rnd())));
                            let probe = rdr::geometry::Ray::with_range(o, d, 0.0, 1e7);
                            if let Some(h2) = scene.intersect(&probe) {
                                let it2 = scene.interaction(&probe, &h2);
                                if let Some((_, a)) = scene.area_light_of(&it2) {
                                    l += rho * a.emitted(it2.ng, it2.wo, it2.uv);
                                }
                            }
                        }
                    }
                }
                s1 += l;
                s2 += l * l;
            }
            let m = s1 / per_pixel as f32;
            mean[row * w + x] = m;
            var[row * w + x] = (s2 / per_pixel as f32 - m * m).max(Vec3::ZERO) / (per_pixel as f32 - 1.0);
        }
    }
    (Image::new(w, h, mean), Image::new(w, h, var))
}

#[test]
fn point_and_area_lights_match_a_brute_force_estimate() {
    let scene = cornell_with_area_light("importance");
    let (bf, bf_var) = brute_force(&scene, 4096);
    let (x1, x2) = (render(&scene, 64, 1), render(&scene, 64, 2));
    let good = compare(&x1, &x2, &bf, &bf_var);
    eprintln!("importance: {good:?}");
    assert!(good.rel_mse_corrected.abs() < 5.0 * good.std_error + 1e-4, "{good:?}");

    let uniform = cornell_with_area_light("uniform");
    let (u1, u2) = (render(&uniform, 64, 1), render(&uniform, 64, 2));
    let unif = compare(&u1, &u2, &bf, &bf_var);
    assert!(unif.rel_mse_corrected.abs() < 5.0 * unif.std_error + 1e-4, "{unif:?}");
    // the area light's noise alone (point lights add none, but their shadow edges
    // add the same pixel noise to both)
    let only_area = |mut s: rdr::Loaded| {
        for l in s.scene.lights.iter_mut() {
            if let rdr::light::Light::Point { flux, .. } = l {
                *flux = Vec3::ZERO;
            }
        }
        s
    };
    let (vi, vu) = (
        own_variance(&only_area(cornell_with_area_light("importance")), 64),
        own_variance(&only_area(cornell_with_area_light("uniform")), 64),
    );
    eprintln!(
        "cornell at 64 spp, relative MSE against the brute-force estimate: area sampling {:.3e}, uniform triangles {:.3e}; area light alone, relative variance: {vi:.3e} vs {vu:.3e}",
        good.rel_mse_raw, unif.rel_mse_raw
    );
    assert!(vu > 1.2 * vi, "sampling by area should cut the variance");

    // a renderer that ignores area lights fails
    let dark = without_area_lights();
    let wrong = compare(&dark.0, &dark.1, &bf, &bf_var);
    eprintln!("area light missing: {wrong:?}");
    assert!(wrong.rel_mse_corrected > 10.0 * (good.std_error + wrong.std_error), "{wrong:?}");
}

/// The render of a renderer that ignores area lights (the lights removed after building).
fn without_area_lights() -> (Image, Image) {
    let mut s = cornell_with_area_light("importance");
    s.scene.lights.retain(|l| !matches!(l, rdr::light::Light::Area(_)));
    for o in s.scene.objects.iter_mut() {
        o.light = None;
    }
    (render(&s, 64, 1), render(&s, 64, 2))
}
