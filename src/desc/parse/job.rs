//! `integrator`, `film` and `camera`: the render job's parts.

use super::{capped, in_range, non_negative_flux, point, unit_interval};
use crate::camera::CameraParams;
use crate::desc::json::Props;
use crate::desc::{
    default_fov_deg, directional_light, light_frame, principled, projector_light, spot_light, textured_spot, DeltaLightDesc, FilmDesc,
    IntegratorDesc, PointLightDesc, TextureRef, MAX_DEPTH, MAX_FILTER_RADIUS, MAX_LIGHT_SAMPLES,
};
use crate::error::Result;
use crate::film::Filter;
use crate::integrator::{
    bdpt::Heuristic, guided, Bdpt, Guided, Integrator, IntersectionTest, Normals, PathProfile, PathTracer, PhotonMapper, Ptracer, Roulette,
    Sppm,
};
use crate::math::Vec3;

pub(super) fn parse_integrator(p: &Props) -> Result<IntegratorDesc> {
    let ty = p.string_or("type", "path")?;
    const TYPES: [&str; 8] = [
        "path",
        "bdpt",
        "guided",
        "ptracer",
        "intersection_test",
        "photon",
        "sppm",
        "normals",
    ];
    // the type first, so an unknown one is reported before any of its keys
    let kind = ty.as_str();
    if !TYPES.contains(&kind) {
        return Err(p.error("type", format!("unknown integrator '{ty}' (available: {})", TYPES.join(", "))));
    }
    let (integrator, spp) = match kind {
        "path" | "bdpt" => {
            let profile = match p.string_or("profile", "MIS")?.as_str() {
                "RW" | "RandomWalk" => PathProfile::RandomWalk,
                "NEE" | "NextEventEstimation" => PathProfile::NextEvent,
                "MIS" | "MultipleImportanceSampling" => PathProfile::Mis,
                other => return Err(p.error("profile", format!("unknown path profile '{other}' (available: RW, NEE, MIS)"))),
            };
            let rr_threshold = p.f32_or("rr_threshold", 0.1)?;
            let spp = p.int_at_least("spp", 32, 1)?;
            let max_depth = capped(p, "max_depth", p.int_at_least("max_depth", 12, 1)?, MAX_DEPTH);
            if kind == "path" {
                (
                    Integrator::Path(PathTracer {
                        max_depth,
                        profile,
                        rr_threshold,
                        hide_emitters: p.bool_or("hide_emitters", false)?,
                        rr: roulette(p)?,
                    }),
                    spp,
                )
            } else {
                (Integrator::Bdpt(parse_bdpt(p, max_depth, rr_threshold)?), spp)
            }
        }
        "guided" => (Integrator::Guided(parse_guided(p)?), p.int_at_least("spp", 64, 1)?),
        "ptracer" => {
            let rr_threshold = p.f32_or("rr_threshold", 0.1)?;
            let spp = p.int_at_least("spp", 32, 1)?;
            let max_depth = capped(p, "max_depth", p.int_at_least("max_depth", 12, 1)?, MAX_DEPTH);
            (Integrator::Ptracer(Ptracer { max_depth, rr_threshold }), spp)
        }
        "normals" => (Integrator::Normals(Normals), p.int_at_least("spp", 8, 1)?),
        "photon" => (
            Integrator::Photon(PhotonMapper {
                n_photons: p.int_at_least("n_photons", 100_000, 1)?,
                n_iterations: p.int_at_least("n_iterations", 1, 1)?,
                n_near_photons: p.int_at_least("n_near_photons", 64, 1)?,
                max_depth: capped(p, "max_depth", p.int_at_least("max_depth", 12, 1)?, MAX_DEPTH),
                rr_threshold: unit_interval(p, "rr_threshold", 0.1)?,
            }),
            p.int_at_least("spp", 16, 1)?,
        ),
        "sppm" => {
            let initial_radius = match p.contains("initial_radius") {
                true => Some(p.f32_or("initial_radius", 0.0)?).filter(|r| *r > 0.0),
                false => None,
            };
            if p.contains("initial_radius") && initial_radius.is_none() {
                return Err(p.error("initial_radius", "initial_radius must be positive"));
            }
            let alpha = p.f32_or("alpha", 2.0 / 3.0)?;
            if !(alpha > 0.0 && alpha <= 1.0) {
                return Err(p.error("alpha", "alpha must lie in (0, 1]"));
            }
            let sppm = Sppm {
                photons_per_iteration: p.int_at_least("photons_per_iteration", 100_000, 1)?,
                initial_radius,
                alpha,
                max_depth: capped(p, "max_depth", p.int_at_least("max_depth", 12, 1)?, MAX_DEPTH),
                rr_threshold: unit_interval(p, "rr_threshold", 0.1)?,
            };
            (Integrator::Sppm(sppm), p.int_at_least("spp", 64, 1)?)
        }
        _ => {
            let spp = p.int_at_least("spp", 8, 1)?;
            let max_depth = capped(p, "max_depth", p.int_at_least("max_depth", 16, 1)?, MAX_DEPTH);
            // read here, after the point lights, as before (errors come in key order)
            (
                Integrator::IntersectionTest(IntersectionTest {
                    max_depth,
                    light_samples: 1,
                }),
                spp,
            )
        }
    };
    let mut point_lights = Vec::new();
    let has_list = p.contains("lights");
    if !has_list || p.contains("point_light_position") || p.contains("point_light_flux") {
        point_lights.push(PointLightDesc {
            position: point(
                p,
                "point_light_position",
                p.vec3_or("point_light_position", Vec3::new(0.0, 5.0, 0.0))?,
            )?,
            flux: non_negative_flux(p, "point_light_flux", p.vec3_or("point_light_flux", Vec3::ONE)?)?,
            key: p.key_path("point_light_position"),
        });
    }
    let mut delta_lights = Vec::new();
    for l in p.objects("lights")? {
        let ty = l.string("type")?;
        let axis_of = |position: Vec3| -> Result<Vec3> {
            if l.contains("direction") {
                l.vec3("direction")
            } else {
                Ok(point(&l, "look_at", l.vec3("look_at")?)? - position)
            }
        };
        let frame_of = |axis: Vec3| {
            let key = ["ref_up", "direction"].into_iter().find(|k| l.contains(k)).unwrap_or("look_at");
            light_frame(axis, l.vec3_or("ref_up", Vec3::Y)?).map_err(|e| l.error(key, e))
        };
        if ty == "projector" {
            let position = point(&l, "position", l.vec3("position")?)?;
            let frame = frame_of(axis_of(position)?)?;
            let texture = match l.raw("irradiance") {
                None => return Err(l.error("irradiance", "required key is missing (a texture name or [r, g, b])")),
                Some(_) => principled::json_texture(&l, "irradiance", 1.0, true)?,
            };
            let (fov, axis) = match l.contains("fov") {
                true => (l.f32_or("fov", 45.0)?, l.string_or("fov_axis", "x")?),
                false => (default_fov_deg(), l.string_or("fov_axis", "diagonal")?),
            };
            let axis = crate::light::projector::FovAxis::parse(&axis)
                .ok_or_else(|| l.error("fov_axis", format!("unknown axis '{axis}' (x, y, diagonal, smaller, larger)")))?;
            let light = projector_light(position, frame, l.f32_or("scale", 1.0)?, fov, axis)
                .map_err(|e| l.error(if e.starts_with("fov") { "fov" } else { "scale" }, e))?;
            delta_lights.push(DeltaLightDesc {
                light,
                key: l.path.clone(),
                texture: Some(texture),
            });
            l.finish();
            continue;
        }
        if ty == "spot" {
            let position = point(&l, "position", l.vec3("position")?)?;
            let axis = axis_of(position)?;
            let cutoff = l.f32_or("cutoff_angle", 20.0)?;
            let beam = if l.contains("beam_width") {
                Some(l.f32_or("beam_width", 15.0)?)
            } else {
                None
            };
            let texture = l.string_opt("texture")?.map(|t| TextureRef::Named(l.located("texture", t)));
            let intensity = l.vec3_or("intensity", Vec3::ONE)?;
            if texture.is_none() {
                l.ignore("ref_up"); // orients the texture only
            }
            let light = match &texture {
                None => spot_light(position, axis, intensity, cutoff, beam),
                Some(_) => textured_spot(position, frame_of(axis)?, intensity, cutoff, beam),
            }
            .map_err(|e| {
                let key = if e.starts_with("beam") {
                    "beam_width"
                } else if e.starts_with("cutoff") {
                    "cutoff_angle"
                } else if e.starts_with("intensity") {
                    "intensity"
                } else {
                    "look_at"
                };
                l.error(key, e)
            })?;
            delta_lights.push(DeltaLightDesc {
                light,
                key: l.path.clone(),
                texture,
            });
            l.finish();
            continue;
        }
        if ty == "directional" {
            let light = directional_light(l.vec3("direction")?, l.vec3_or("irradiance", Vec3::ONE)?)
                .map_err(|e| l.error(if e.starts_with("irradiance") { "irradiance" } else { "direction" }, e))?;
            delta_lights.push(DeltaLightDesc {
                light,
                key: l.path.clone(),
                texture: None,
            });
            l.finish();
            continue;
        }
        if ty != "point" {
            return Err(l.error(
                "type",
                format!("unknown light type '{ty}' in the integrator's list (available: point, spot, directional, projector)"),
            ));
        }
        point_lights.push(PointLightDesc {
            position: point(&l, "position", l.vec3("position")?)?,
            flux: non_negative_flux(&l, "flux", l.vec3("flux")?)?,
            key: l.path.clone(),
        });
        l.finish();
    }
    let light_samples = capped(p, "light_samples", p.int_at_least("light_samples", 1, 1)?, MAX_LIGHT_SAMPLES);
    let mut integrator = integrator;
    if let Integrator::IntersectionTest(t) = &mut integrator {
        t.light_samples = light_samples;
    }
    let light_sampling = match p.string_or("light_sampling", "importance")?.as_str() {
        "importance" => crate::light::LightSampling::Importance,
        "uniform" => crate::light::LightSampling::Uniform,
        other => {
            return Err(p.error(
                "light_sampling",
                format!("unknown light sampling '{other}' (available: importance, uniform)"),
            ))
        }
    };
    // keys of another integrator (left by an `--override` of the type) are no typos
    let unread = p.unread_keys();
    if !unread.is_empty() {
        let others: Vec<String> = TYPES.iter().filter(|t| **t != kind).flat_map(|t| integrator_keys(t)).collect();
        for k in unread.iter().filter(|k| others.contains(k)) {
            p.ignore(k);
            p.ctx().warn(
                &p.path,
                format!("unknown key '{k}' ignored: it is another integrator's, not the '{kind}' integrator's"),
            );
        }
    }
    p.finish();
    Ok(IntegratorDesc {
        integrator,
        spp,
        point_lights,
        delta_lights,
        light_sampling,
        aovs: None,
    })
}

/// The keys the integrator `ty` reads.
fn integrator_keys(ty: &str) -> Vec<String> {
    let value = serde_json::json!({ "type": ty });
    let ctx = crate::desc::json::Context::new(std::path::Path::new(""));
    let Ok(p) = Props::root(&value, &ctx) else {
        return Vec::new();
    };
    let _ = parse_integrator(&p);
    p.asked_keys()
}

/// The keys of [`Guided`] (documented there).
fn parse_guided(p: &Props) -> Result<Guided> {
    let d = Guided::default();
    let rr_threshold = unit_interval(p, "rr_threshold", d.rr_threshold)?;
    let max_depth = capped(p, "max_depth", p.int_at_least("max_depth", d.max_depth as i32, 1)?, MAX_DEPTH);
    let bsdf_fraction = p.f32_or("bsdf_fraction", d.bsdf_fraction)?;
    if !(bsdf_fraction > 0.0 && bsdf_fraction <= 1.0) {
        return Err(p.error(
            "bsdf_fraction",
            "bsdf_fraction must lie in (0, 1] (without BSDF sampling directions the tree never learned would be missed)",
        ));
    }
    let training_iterations = match p.contains("training_iterations") {
        true => Some(capped(p, "training_iterations", p.int_at_least("training_iterations", 0, 0)?, 30)),
        false => None,
    };
    let combine = match p.string_or("combine", "samples")?.as_str() {
        "last" => guided::Combine::Last,
        "samples" => guided::Combine::Samples,
        other => return Err(p.error("combine", format!("unknown combine '{other}' (available: last, samples)"))),
    };
    let spatial_threshold = p.f32_or("spatial_threshold", d.spatial_threshold)?;
    if !(spatial_threshold > 0.0 && spatial_threshold.is_finite()) {
        return Err(p.error("spatial_threshold", "spatial_threshold must be a positive number"));
    }
    let learn_direct = p.bool_or("learn_direct", d.learn_direct)?;
    let learn_fraction = p.bool_or("learn_fraction", d.learn_fraction)?;
    let target = match p.string_or("target", "radiance")?.as_str() {
        "radiance" => guided::Target::Radiance,
        "variance" => guided::Target::Variance,
        other => return Err(p.error("target", format!("unknown target '{other}' (available: radiance, variance)"))),
    };
    // the variance-aware target is learned from the camera paths' second moments
    let variance = target == guided::Target::Variance;
    let learn_from = match p.string_or("learn_from", if variance { "paths" } else { "photons" })?.as_str() {
        "paths" => guided::LearnFrom::Paths,
        "photons" if variance => {
            return Err(p.error(
                "learn_from",
                "target 'variance' learns from the camera paths: learn_from must be 'paths' (or absent)",
            ))
        }
        "photons" => guided::LearnFrom::Photons,
        other => return Err(p.error("learn_from", format!("unknown learn_from '{other}' (available: paths, photons)"))),
    };
    Ok(Guided {
        rr: roulette(p)?,
        learn_from,
        target,
        learn_direct,
        learn_fraction,
        max_depth,
        rr_threshold,
        bsdf_fraction,
        training_iterations,
        combine,
        spatial_threshold,
    })
}

/// The keys only `bdpt` has (see [`Bdpt`]): `mis`, `strategy`, `strategy_weighted`,
/// `visualize_strategies`, `connection_roulette`.
fn parse_bdpt(p: &Props, max_depth: u32, rr_threshold: f32) -> Result<Bdpt> {
    let heuristic = match p.string_or("mis", "power")?.as_str() {
        "power" => Heuristic::Power,
        "balance" => Heuristic::Balance,
        other => return Err(p.error("mis", format!("unknown MIS heuristic '{other}' (available: power, balance)"))),
    };
    let strategy = match p.contains("strategy") {
        true => match p.vec2i_or("strategy", [0, 0])? {
            [s, t] if s >= 0 && t >= 1 => Some((s as u32, t as u32)),
            _ => return Err(p.error("strategy", "expected [s, t] with s ≥ 0, t ≥ 1")),
        },
        false => None,
    };
    let visualize_strategies = p.bool_or("visualize_strategies", false)?;
    if visualize_strategies && strategy.is_some() {
        return Err(p.error(
            "visualize_strategies",
            "writes every strategy's image: it cannot be combined with 'strategy' (one strategy alone)",
        ));
    }
    Ok(Bdpt {
        max_depth,
        rr_threshold,
        heuristic,
        strategy,
        strategy_weighted: p.bool_or("strategy_weighted", false)?,
        visualize_strategies,
        connection_roulette: in_range(
            p,
            "connection_roulette",
            p.f32_or("connection_roulette", crate::integrator::bdpt::CONNECTION_ROULETTE)?,
            0.0,
            1e3,
        )?,
    })
}

pub(super) fn parse_film(p: &Props) -> Result<FilmDesc> {
    let [w, h] = p.vec2i_or("resolution", [600, 600])?;
    if w <= 0 || h <= 0 {
        return Err(p.error("resolution", format!("must be positive, found [{w}, {h}]")));
    }
    if (w as u64) * (h as u64) > 1 << 28 {
        return Err(p.error("resolution", format!("[{w}, {h}] is too large")));
    }
    let block_size = p.int_at_least("block_side_length", 16, 1)?;
    let filter = match p.object_opt("filter")? {
        None => Filter::Box { radius: 0.5 },
        Some(f) => {
            let ty = f.string_or("type", "box")?;
            let radius = f.f32_or("radius", 0.5)?;
            if radius <= 0.0 {
                return Err(f.error("radius", format!("must be positive, found {radius}")));
            }
            if radius > MAX_FILTER_RADIUS {
                return Err(f.error("radius", format!("{radius} is too large (at most {MAX_FILTER_RADIUS} pixels)")));
            }
            let d = match ty.as_str() {
                "box" => Filter::Box { radius },
                "gaussian" => {
                    let alpha = f.f32_or("alpha", 2.0)?;
                    if alpha <= 0.0 {
                        return Err(f.error(
                            "alpha",
                            format!("must be positive, found {alpha} (the filter would weigh every sample 0)"),
                        ));
                    }
                    let g = Filter::gaussian(radius, alpha);
                    // the weight at a pixel's centre and half a pixel away must not vanish
                    if g.eval(0.0, 0.0) < 1e-4 || (radius > 0.5 && g.eval(0.5, 0.0) <= 0.0) {
                        return Err(f.error(
                            "alpha",
                            format!("{alpha} with radius {radius} makes the filter weights vanish (alpha·radius² must be at least 1e-4 and alpha at most about 300)"),
                        ));
                    }
                    g
                }
                "tent" => Filter::Tent { radius },
                "mitchell" => Filter::Mitchell {
                    radius,
                    b: f.f32_or("B", 1.0 / 3.0)?,
                    c: f.f32_or("C", 1.0 / 3.0)?,
                },
                _ => return Err(f.error("type", format!("unknown filter '{ty}' (available: box, tent, gaussian, mitchell)"))),
            };
            f.finish();
            d
        }
    };
    let importance_sampling = match p.string_or("sampling", "filter")?.as_str() {
        "filter" => false,
        "importance" => true,
        other => return Err(p.error("sampling", format!("unknown sampling '{other}' (available: filter, importance)"))),
    };
    p.finish();
    Ok(FilmDesc {
        width: w as u32,
        height: h as u32,
        block_size,
        filter,
        importance_sampling,
    })
}

pub(super) fn parse_camera(p: &Props) -> Result<CameraParams> {
    use crate::camera::Projection;
    let ty = p.string_or("type", "perspective")?;
    // the camera's medium, a name resolved with the scene's media
    p.ignore("medium");
    let positive = |key: &str| -> Result<f32> {
        if !p.contains(key) {
            return Err(p.error(key, format!("is required for a '{ty}' camera")));
        }
        let v = p.f32_or(key, 0.0)?;
        if v.is_nan() || v <= 0.0 {
            return Err(p.error(key, format!("must be positive, found {v}")));
        }
        in_range(p, key, v, 1e-6, 1e15)?;
        Ok(v)
    };
    let projection = match ty.as_str() {
        "perspective" => Projection::Pinhole,
        "thinlens" => {
            if !p.contains("aperture_radius") {
                return Err(p.error("aperture_radius", "is required for a 'thinlens' camera"));
            }
            let aperture_radius = p.f32_or("aperture_radius", 0.0)?;
            if aperture_radius.is_nan() || aperture_radius < 0.0 {
                return Err(p.error("aperture_radius", format!("must be at least 0, found {aperture_radius}")));
            }
            in_range(p, "aperture_radius", aperture_radius, 0.0, 1e15)?;
            Projection::ThinLens {
                aperture_radius,
                focus_distance: positive("focus_distance")?,
            }
        }
        "orthographic" => {
            let height = if p.contains("height") { positive("height")? } else { 2.0 };
            if p.contains("fov") {
                p.ctx()
                    .warn(&p.key_path("fov"), "an orthographic camera has no field of view: ignored");
            }
            Projection::Orthographic { height }
        }
        other => {
            return Err(p.error(
                "type",
                format!("unknown camera type '{other}' (available: perspective, thinlens, orthographic)"),
            ));
        }
    };
    let near_clip = p.f32_or("near_clip", 0.0)?;
    let far_clip = if p.contains("far_clip") {
        p.f32_or("far_clip", 0.0)?
    } else {
        f32::INFINITY
    };
    crate::camera::check_clip_range(near_clip, far_clip).map_err(|(key, why)| p.error(key, why))?;
    let c = CameraParams {
        position: point(p, "position", p.vec3_or("position", Vec3::new(0.0, 0.0, 1.0))?)?,
        look_at: point(p, "look_at", p.vec3_or("look_at", Vec3::ZERO)?)?,
        ref_up: point(p, "ref_up", p.vec3_or("ref_up", Vec3::Y)?)?,
        fov: p.f32_or("fov", 45.0)?,
        focal_length: p.f32_or("focal_length", 1.0)?,
        projection,
        near_clip,
        far_clip,
        mirrored: p.bool_or("mirrored", false)?,
    };
    if !(c.fov > 0.0 && c.fov < 180.0) {
        return Err(p.error("fov", format!("must be between 0 and 180 degrees, found {}", c.fov)));
    }
    if c.focal_length <= 0.0 {
        return Err(p.error("focal_length", format!("must be positive, found {}", c.focal_length)));
    }
    // it cancels out of the rays, but scales the basis: keep that arithmetic finite
    in_range(p, "focal_length", c.focal_length, 1e-6, 1e6)?;
    let forward = c.look_at - c.position;
    if forward.length_squared() == 0.0 {
        return Err(p.error("look_at", "equals the camera position"));
    }
    if forward.normalize().cross(c.ref_up).length_squared() < 1e-12 {
        return Err(p.error("ref_up", "is zero or parallel to the viewing direction"));
    }
    // the basis the rays are made of must come out finite (any resolution's aspect
    // only scales `right`, which the film size check keeps finite)
    if !crate::camera::Camera::new(&c, 1, 1).is_finite() {
        return Err(p.ctx().error(
            &p.path,
            "the camera's view basis is not finite (position, look_at, ref_up or focal_length out of range)",
        ));
    }
    p.finish();
    Ok(c)
}

/// `path`'s and `guided`'s `rr`: their Russian roulette, by name.
fn roulette(p: &Props) -> Result<Roulette> {
    let name = p.string_or("rr", Roulette::Mitsuba.name())?;
    Roulette::from_name(&name).ok_or_else(|| {
        p.error(
            "rr",
            format!("unknown Russian roulette '{name}' (available: {})", Roulette::NAMES.join(", ")),
        )
    })
}
