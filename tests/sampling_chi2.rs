//! Chi-square goodness-of-fit tests: each sampling routine's directions against
//! the pdf it reports (the Mitsuba approach: bins of equal solid angle in
//! (cos θ, φ), expected counts by integrating the pdf over each bin).

mod common;
use rdr::light::area::AreaLight;
use rdr::light::environment::{EnvImage, EnvironmentLight};
use rdr::light::LightSampling;
use rdr::math::{Frame, Mat4, Vec2, Vec3, PI};
use rdr::sampling::{cosine_hemisphere, uniform_sphere};
use rdr::texture::UvMapping;

/// Uniform numbers independent of the renderer's samplers.
struct Rng(rdr::sampling::SplitMix64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0.unit_f32()
    }
    fn next2(&mut self) -> Vec2 {
        Vec2::new(self.next(), self.next())
    }
}

use common::chi2::{bin_in_cap, chi2, chi2_bins, chi2_cap, N_COS, N_PHI};

fn bin_of(frame: &Frame, w: Vec3) -> usize {
    bin_in_cap(frame, w, -1.0).unwrap_or(0)
}

/// Environment directions binned on the map's own (u, v) grid (`nu × nv` bins
/// aligned with its cells), where pdf(ω)·2π² sin θ is piecewise constant, so the
/// bin masses from a midpoint rule are exact.
fn chi2_env(name: &str, n: usize, env: &EnvironmentLight, nu: usize, nv: usize, mode: LightSampling) {
    let mut rng = Rng(rdr::sampling::SplitMix64(0x9876_5432 ^ name.len() as u64));
    let mut observed = vec![0.0f64; nu * nv];
    for _ in 0..n {
        if let Some(s) = env.sample(rng.next2(), mode) {
            let uv = env.direction_to_uv(s.wi);
            let (i, j) = (((uv.x * nu as f32) as usize).min(nu - 1), ((uv.y * nv as f32) as usize).min(nv - 1));
            observed[j * nu + i] += 1.0;
        }
    }
    let k = 4;
    let mut mass = vec![0.0f64; nu * nv];
    for j in 0..nv {
        for i in 0..nu {
            let mut acc = 0.0f64;
            for a in 0..k {
                for b in 0..k {
                    let uv = Vec2::new(
                        (i as f32 + (a as f32 + 0.5) / k as f32) / nu as f32,
                        (j as f32 + (b as f32 + 0.5) / k as f32) / nv as f32,
                    );
                    let (w, sin_theta) = env.uv_to_direction(uv);
                    acc += (env.pdf(w, mode) * 2.0 * PI * PI * sin_theta) as f64 / (nu * nv * k * k) as f64;
                }
            }
            mass[j * nu + i] = acc;
        }
    }
    chi2_bins(name, n, &observed, &mass);
}

#[test]
fn warps_match_their_densities() {
    chi2(
        "cosine hemisphere",
        400_000,
        Frame::from_normal(Vec3::Z),
        |u| Some(cosine_hemisphere(u)),
        |w| w.z.max(0.0) / PI,
    );
    chi2(
        "uniform sphere",
        400_000,
        Frame::from_normal(Vec3::Z),
        |u| Some(uniform_sphere(u)),
        |_| 1.0 / (4.0 * PI),
    );
}

/// A synthetic sky: a bright sun, a gradient, a dark band and a black corner.
fn synthetic_env(transform: Mat4) -> EnvironmentLight {
    let (w, h) = (64, 32);
    let texels = (0..w * h)
        .map(|k| {
            let (x, y) = ((k % w) as f32, (k / w) as f32);
            let sun = if (x - 40.0).abs() < 2.0 && (y - 9.0).abs() < 2.0 {
                200.0
            } else {
                0.0
            };
            let dark = if (12..16).contains(&(k / w)) || (x < 8.0 && y > 24.0) {
                0.0
            } else {
                1.0
            };
            Vec3::new(sun + dark * (0.2 + x / 64.0), sun + dark * 0.5, dark * (1.0 - y / 32.0) + sun)
        })
        .collect();
    EnvironmentLight::new(
        EnvImage::Image {
            width: w,
            height: h,
            texels,
            mapping: UvMapping {
                scale: Vec2::ONE,
                delta: Vec2::ZERO,
            },
        },
        1.0,
        &transform,
    )
}

#[test]
fn environment_importance_sampling_matches_its_pdf() {
    let frame = Frame::from_normal(Vec3::Y);
    for (name, env) in [
        ("env identity", synthetic_env(Mat4::IDENTITY)),
        (
            "env rotated",
            synthetic_env(Mat4::from_rotation_z(0.7) * Mat4::from_rotation_y(1.1)),
        ),
    ] {
        chi2_env(name, 1_000_000, &env, 64, 32, LightSampling::Importance);
        chi2(
            &format!("{name} uniform"),
            200_000,
            frame,
            |u| env.sample(u, LightSampling::Uniform).map(|s| s.wi),
            |w| env.pdf(w, LightSampling::Uniform),
        );
        // (binning by (cos θ, φ) instead would need exact integration of the piecewise-
        // constant pdf across bins; the uv-domain test checks pdf(ω) exactly through sin θ)
    }
}

#[test]
fn real_sky_importance_sampling_matches_its_pdf() {
    let Some(shared) = common::shared() else { return };
    let img = rdr::imageio::read_texture_image(&shared.join("envmaps/industrial_sunset_puresky_1k.hdr")).unwrap();
    let env = EnvironmentLight::new(
        EnvImage::Image {
            width: img.width,
            height: img.height,
            texels: img.pixels,
            mapping: UvMapping {
                scale: Vec2::ONE,
                delta: Vec2::ZERO,
            },
        },
        1.0,
        &Mat4::IDENTITY,
    );
    // bins of 4×4 texels
    chi2_env("industrial sunset", 2_000_000, &env, 256, 128, LightSampling::Importance);
}

/// Bin masses of an area-sampled light computed in the area domain: the pdf of
/// a direction is p_A·d²/cos, which blows up at the silhouette where a midpoint
/// rule over directions cannot follow it; over the area it is just p_A.
fn area_domain_mass(frame: &Frame, p: Vec3, points: impl Iterator<Item = (Vec3, Vec3, f32)>) -> Vec<f64> {
    let mut mass = vec![0.0f64; N_COS * N_PHI];
    for (q, n, weight) in points {
        let w = (q - p).normalize();
        if n.dot(-w) > 0.0 {
            mass[bin_of(frame, w)] += weight as f64;
        }
    }
    mass
}

#[test]
fn sphere_light_uniform_area_sampling_matches_its_pdf() {
    // uniform area sampling: the visible cap's bins get (area in bin)/(sphere area);
    // areas from a fine (cos θ, φ) grid over the sphere, each cell weighted by its area
    let (p, center, radius) = (Vec3::new(0.3, -0.2, 0.1), Vec3::new(0.5, 1.0, 0.2), 0.8f32);
    let light = AreaLight::sphere(0, Vec3::ONE, center, radius);
    let frame = Frame::from_normal((center - p).normalize());
    let m = 1200;
    let cells = (0..m * 2 * m).map(|k| {
        let (i, j) = (k / (2 * m), k % (2 * m));
        let z = -1.0 + 2.0 * (i as f32 + 0.5) / m as f32;
        let phi = PI * (j as f32 + 0.5) / m as f32;
        let s = (1.0 - z * z).sqrt();
        let n = Vec3::new(s * phi.cos(), s * phi.sin(), z);
        (center + n * radius, n, 1.0 / (2 * m * m) as f32)
    });
    let mass = area_domain_mass(&frame, p, cells);
    let mut rng = Rng(rdr::sampling::SplitMix64(77));
    let n = 400_000;
    let mut observed = vec![0.0f64; N_COS * N_PHI];
    for _ in 0..n {
        if let Some(s) = light.sample(p, rng.next2(), LightSampling::Uniform) {
            observed[bin_of(&frame, s.wi)] += 1.0;
        }
    }
    chi2_bins("sphere uniform area", n, &observed, &mass);
}

#[test]
fn sphere_light_sampling_matches_its_pdf() {
    let p = Vec3::new(0.3, -0.2, 0.1);
    for (name, center, radius) in [
        ("sphere near", Vec3::new(0.5, 1.0, 0.2), 0.8),
        ("sphere far", Vec3::new(-3.0, 2.0, 6.0), 0.5),
        ("sphere tiny", Vec3::new(0.0, 0.0, 30.0), 0.3),
    ] {
        let light = AreaLight::sphere(0, Vec3::ONE, center, radius);
        let frame = Frame::from_normal((center - p).normalize());
        // (uniform area sampling of spheres: see sphere_light_uniform_area_sampling_matches_its_pdf)
        {
            let mode = LightSampling::Importance;
            let hit = |w: Vec3| -> Option<(Vec3, Vec3)> {
                let s = rdr::geometry::sphere::Sphere {
                    center,
                    radius,
                    uv_frame: None,
                };
                let t = s.intersect(p, w, 0.0, f32::INFINITY)?;
                let (q, n) = s.project(p + w * t);
                Some((q, n))
            };
            // bins over the cone the sphere subtends (widened a little)
            let sin2_max = radius * radius / (center - p).length_squared();
            let cos_min = (1.0 - 1.05 * sin2_max).max(-1.0).sqrt();
            chi2_cap(
                &format!("{name} {mode:?}"),
                400_000,
                frame,
                cos_min,
                |u| light.sample(p, u, mode).map(|s| s.wi),
                |w| hit(w).map_or(0.0, |(q, n)| light.pdf(p, w, q, n, mode)),
            );
        }
    }
}

#[test]
fn triangle_mesh_light_sampling_matches_its_pdf() {
    // four triangles of different sizes around the point; two face away from it
    let tris = vec![
        [Vec3::new(-1.0, 1.0, -1.0), Vec3::new(1.0, 1.0, -1.0), Vec3::new(0.0, 1.0, 1.5)],
        [Vec3::new(2.0, -0.5, 0.0), Vec3::new(2.0, 0.5, 0.0), Vec3::new(2.0, 0.0, 0.3)],
        [Vec3::new(-2.0, -1.0, -1.0), Vec3::new(-2.0, -1.0, 1.0), Vec3::new(-2.0, 0.5, 0.0)],
        [Vec3::new(0.0, -3.0, 0.0), Vec3::new(0.5, -3.0, 1.0), Vec3::new(1.0, -3.0, 0.0)],
    ];
    let p = Vec3::ZERO;
    let light = AreaLight::mesh(0, Vec3::ONE, tris.clone());
    let area = |t: &[Vec3; 3]| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
    let total: f32 = tris.iter().map(area).sum();
    let frame = Frame::from_normal(Vec3::Y);
    for mode in [LightSampling::Importance, LightSampling::Uniform] {
        // expected bin masses over the area: each triangle cut into m² small ones
        let m = 300;
        let mut cells = Vec::new();
        for t in &tris {
            let p_area = match mode {
                LightSampling::Importance => 1.0 / total,
                LightSampling::Uniform => 1.0 / (tris.len() as f32 * area(t)),
            };
            let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
            let cell = area(t) / (m * m) as f32;
            let (e1, e2) = ((t[1] - t[0]) / m as f32, (t[2] - t[0]) / m as f32);
            for i in 0..m {
                for j in 0..m - i {
                    let base = t[0] + e1 * i as f32 + e2 * j as f32;
                    cells.push((base + (e1 + e2) / 3.0, n, p_area * cell));
                    if i + j + 1 < m {
                        cells.push((base + (e1 + e2) * (2.0 / 3.0), n, p_area * cell));
                    }
                }
            }
        }
        let mass = area_domain_mass(&frame, p, cells.into_iter());
        let mut rng = Rng(rdr::sampling::SplitMix64(5 + mode as u64));
        let n = 600_000;
        let mut observed = vec![0.0f64; N_COS * N_PHI];
        for _ in 0..n {
            if let Some(s) = light.sample(p, rng.next2(), mode) {
                observed[bin_of(&frame, s.wi)] += 1.0;
                // the pdf MIS asks for agrees with the sample's own
                let rdr::light::ShadowTarget::Point { p: q, n: Some(nq) } = s.target else {
                    panic!("area lights sample points")
                };
                let again = light.pdf(p, s.wi, q, nq, mode);
                assert!(
                    (again - s.pdf).abs() <= 1e-3 * s.pdf,
                    "{mode:?}: pdf {} vs sample pdf {}",
                    again,
                    s.pdf
                );
            }
        }
        chi2_bins(&format!("triangles {mode:?}"), n, &observed, &mass);
    }
}

#[test]
fn chi2_rejects_a_sampler_whose_pdf_is_wrong() {
    // cosine-distributed samples claimed to be uniform over the hemisphere
    let wrong = std::panic::catch_unwind(|| {
        chi2(
            "cosine claimed uniform",
            100_000,
            Frame::from_normal(Vec3::Z),
            |u| Some(cosine_hemisphere(u)),
            |w| {
                if w.z > 0.0 {
                    0.5 / PI
                } else {
                    0.0
                }
            },
        )
    });
    assert!(wrong.is_err(), "the χ² test must catch a wrong pdf");
}

/// A rough conductor's BSDF at a surface facing +z.
fn conductor(kind: rdr::material::Distribution, ax: f32, ay: f32, wo: Vec3) -> rdr::material::Bsdf {
    let m = rdr::material::Material::RoughConductor {
        texture: 0,
        eta_i: Vec3::ONE,
        eta_t: Vec3::new(0.2, 0.92, 1.1),
        k: Vec3::new(3.9, 2.45, 2.14),
        alpha_x: ax,
        alpha_y: ay,
        alpha_textures: None,
        eta_k_textures: None,
        distribution: kind,
        twosided: true,
    };
    m.bsdf(Vec3::Z, wo, |_| Vec3::ONE)
}

#[test]
fn rough_conductor_sampling_matches_its_pdf() {
    use rdr::material::Distribution::{Beckmann, Ggx};
    for kind in [Beckmann, Ggx] {
        for (ax, ay) in [(0.3, 0.3), (0.6, 0.6), (0.2, 0.5)] {
            for theta in [0.2f32, 0.9, 1.35] {
                let wo = Vec3::new(theta.sin() * 0.8, theta.sin() * 0.6, theta.cos());
                let bsdf = conductor(kind, ax, ay, wo);
                let name = format!("{kind:?} α=({ax},{ay}) θo={theta}");
                let mut rng = Rng(rdr::sampling::SplitMix64(99));
                // each sample's weight is f·cos/pdf of its own direction
                for _ in 0..2000 {
                    if let Some(s) = bsdf.sample(wo, rng.next2(), 0.5) {
                        let expect = bsdf.eval(wo, s.wi) * s.wi.z / bsdf.pdf(wo, s.wi);
                        assert!(
                            (s.weight - expect).abs().max_element() <= 1e-3 * expect.max_element().max(1e-3),
                            "{name}: weight {} vs {}",
                            s.weight,
                            expect
                        );
                        assert!((s.pdf - bsdf.pdf(wo, s.wi)).abs() <= 1e-3 * s.pdf, "{name}: pdf");
                    }
                }
                chi2(
                    &name,
                    300_000,
                    Frame::from_normal(Vec3::Z),
                    |u| bsdf.sample(wo, u, 0.5).map(|s| s.wi),
                    |w| bsdf.pdf(wo, w),
                );
            }
        }
    }
}

/// The Veach MIS plates' Beckmann roughnesses (α 0.01 to 0.1) make lobes too narrow for
/// bins over the whole sphere: here the bins cover a cap about the mirror direction of
/// half-angle 8α, which holds all but e^−16 of the lobe (visible normals at most 4α
/// from the normal, reflected directions within twice that). A sampler and pdf that
/// disagree at low roughness keep the mean and only add noise (a caustic's MIS weights).
#[test]
fn narrow_beckmann_conductor_sampling_matches_its_pdf() {
    for alpha in [0.01f32, 0.05, 0.1] {
        for theta in [0.3f32, 1.2] {
            let wo = Vec3::new(theta.sin() * 0.6, theta.sin() * 0.8, theta.cos());
            let bsdf = conductor(rdr::material::Distribution::Beckmann, alpha, alpha, wo);
            let name = format!("Beckmann α={alpha} θo={theta}");
            let mut rng = Rng(rdr::sampling::SplitMix64(7));
            // the density a sample reports is the one MIS later evaluates for its direction
            for _ in 0..2000 {
                if let Some(s) = bsdf.sample(wo, rng.next2(), 0.5) {
                    let pdf = bsdf.pdf(wo, s.wi);
                    assert!((s.pdf - pdf).abs() <= 1e-3 * pdf, "{name}: sampled pdf {} vs pdf {pdf}", s.pdf);
                }
            }
            let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
            chi2_cap(
                &name,
                200_000,
                Frame::from_normal(mirror),
                (8.0 * alpha).cos(),
                |u| bsdf.sample(wo, u, 0.5).map(|s| s.wi),
                |w| bsdf.pdf(wo, w),
            );
        }
    }
}

#[test]
fn dielectric_chooses_reflection_with_the_fresnel_probability() {
    for eta in [1.5f32, 1.8] {
        for cos_o in [0.95f32, 0.5, 0.1, -0.9, -0.5] {
            let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
            let glass = rdr::material::Material::Glass {
                reflect: Vec3::ONE,
                transmit: Vec3::ONE,
                eta,
            };
            let bsdf = glass.bsdf(Vec3::Z, wo, |_| Vec3::ONE);
            let (f, _, eta_ti) = rdr::material::fresnel::dielectric(cos_o, eta);
            let mut rng = Rng(rdr::sampling::SplitMix64(3));
            let n = 200_000;
            let mut reflected = 0usize;
            for _ in 0..n {
                let s = bsdf.sample(wo, rng.next2(), rng.next()).unwrap();
                assert!(s.delta && bsdf.pdf(wo, s.wi) == 0.0 && bsdf.eval(wo, s.wi) == Vec3::ZERO);
                if s.wi.z * cos_o > 0.0 {
                    reflected += 1;
                    assert!((s.wi - Vec3::new(-wo.x, 0.0, wo.z)).length() < 1e-5, "mirror direction");
                    assert!((s.weight - Vec3::ONE).abs().max_element() < 1e-6);
                } else {
                    // Snell: η_i sin θi = η_t sin θt
                    assert!((s.wi.x.abs() - eta_ti * wo.x.abs()).abs() < 1e-5, "Snell");
                    assert!(
                        (s.weight - Vec3::splat(eta_ti * eta_ti)).abs().max_element() < 1e-5,
                        "1/η² radiance scaling"
                    );
                }
            }
            let p = reflected as f64 / n as f64;
            let sigma = (f as f64 * (1.0 - f as f64) / n as f64).sqrt().max(1e-9);
            assert!(
                (p - f as f64).abs() < 5.0 * sigma + 1e-6,
                "η={eta} cos={cos_o}: reflected {p}, Fresnel {f}"
            );
        }
    }
}

#[test]
fn diffuse_and_perfect_refraction_sampling() {
    let d = rdr::material::Material::Diffuse {
        texture: 0,
        twosided: false,
    }
    .bsdf(Vec3::Z, Vec3::new(0.3, 0.0, 0.95).normalize(), |_| Vec3::splat(0.5));
    let wo = Vec3::new(0.3, 0.0, 0.95).normalize();
    chi2(
        "diffuse bsdf",
        200_000,
        Frame::from_normal(Vec3::Z),
        |u| d.sample(wo, u, 0.5).map(|s| s.wi),
        |w| d.pdf(wo, w),
    );
    // seen from below a one-sided diffuse surface reflects nothing
    assert!(d.sample(-wo, Vec2::splat(0.5), 0.5).is_none() && d.eval(-wo, Vec3::Z) == Vec3::ZERO);
    let r = rdr::material::Material::Refraction { eta: 1.5 }.bsdf(Vec3::Z, wo, |_| Vec3::ONE);
    let s = r.sample(wo, Vec2::ZERO, 0.0).unwrap();
    assert!(s.delta && s.wi.z < 0.0 && (s.wi.x.abs() - wo.x / 1.5).abs() < 1e-6);
}

/// Mitsuba 0.6's `phong` at a surface facing +z (diffuse 0.5, specular 0.5: white).
fn phong(exponent: f32, wo: Vec3) -> rdr::material::Bsdf {
    let m = rdr::material::Material::Phong {
        texture: 0,
        specular: Vec3::splat(0.5),
        exponent,
        specular_sampling_weight: None,
    };
    m.bsdf(Vec3::Z, wo, |_| Vec3::splat(0.5))
}

/// Its samples (the lobe chosen by a second stream of numbers) follow its pdf, binned
/// about the mirror direction where the lobe is; each sample's weight is f·cos/pdf.
#[test]
fn phong_sampling_matches_its_pdf() {
    for exponent in [3.0f32, 30.0] {
        for theta in [0.3f32, 1.2] {
            let wo = Vec3::new(theta.sin() * 0.6, theta.sin() * 0.8, theta.cos());
            let bsdf = phong(exponent, wo);
            let name = format!("phong n={exponent} θo={theta}");
            let mut lobe = Rng(rdr::sampling::SplitMix64(7));
            for _ in 0..2000 {
                if let Some(s) = bsdf.sample(wo, lobe.next2(), lobe.next()) {
                    let expect = bsdf.eval(wo, s.wi) * s.wi.z / bsdf.pdf(wo, s.wi);
                    assert!(
                        (s.weight - expect).abs().max_element() <= 1e-4 * expect.max_element(),
                        "{name}: weight"
                    );
                }
            }
            chi2(
                &name,
                300_000,
                Frame::from_normal(Vec3::new(-wo.x, -wo.y, wo.z)),
                |u| bsdf.sample(wo, u, lobe.next()).map(|s| s.wi),
                |w| bsdf.pdf(wo, w),
            );
        }
    }
}

/// White furnace: with ρd + ρs = 1 the normalised lobe reflects everything at normal
/// incidence (∫ (n+2)/(2π) cos^(n+1) θ dω = 1) and less elsewhere (the lobe dips below
/// the horizon), never more.
#[test]
fn white_phong_reflects_all_light_at_normal_incidence_and_never_more() {
    let n = 200_000;
    for exponent in [3.0f32, 30.0] {
        for theta in [0.0f32, 0.7, 1.3] {
            let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
            let bsdf = phong(exponent, wo);
            let mut rng = Rng(rdr::sampling::SplitMix64(11));
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let w = bsdf.sample(wo, rng.next2(), rng.next()).map_or(0.0, |s| s.weight.x as f64);
                sum += w;
                sum2 += w * w;
            }
            let mean = sum / n as f64;
            let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
            println!("phong n={exponent} θo={theta}: albedo {mean:.5} ± {sigma:.5}");
            assert!(mean <= 1.0 + 4.0 * sigma, "n={exponent} θo={theta}: albedo {mean} > 1");
            if theta == 0.0 {
                assert!(
                    (mean - 1.0).abs() <= 4.0 * sigma + 1e-4,
                    "n={exponent}: albedo {mean} ± {sigma}, not 1"
                );
            }
        }
    }
}
