//! The render job: what is rendered of a scene and how — camera, film, integrator
//! with its parameters, samples per pixel, seed and time limit. The world itself
//! (geometry, materials, lights, BVH) is the [`Scene`].

use crate::camera::{Camera, Projection};
use crate::compat::rdr171::Rdr171Columns;
use crate::compat::Profile;
use crate::desc::{build, BuildOptions, SceneDesc};
use crate::error::{Result, SceneError};
use crate::film::{FilmSampling, FilmSettings};
use crate::integrator::Integrator;
use crate::scene::Scene;
use std::path::Path;

#[derive(Clone, Debug)]
pub struct RenderJob {
    pub camera: Camera,
    pub film: FilmSettings,
    pub integrator: Integrator,
    /// Samples per pixel (the scene's `integrator.spp` unless overridden).
    pub spp: u32,
    /// The samples per pixel the scene declares (`integrator.spp`, whatever `--spp`
    /// says): passes that depend on a sample count (the texture footprint) use this,
    /// so a pass is the same in a render of any length, resumed or not.
    pub target_spp: u32,
    /// The passes to render (a shard's share), all of them when `None`.
    pub passes: Option<std::ops::Range<u32>>,
    /// Seed of the sampler; different seeds give independent images.
    pub seed: u32,
    /// Wall-clock budget in seconds: no pass starts that would end after it.
    pub time_limit: Option<f64>,
}

impl RenderJob {
    /// The job a scene description asks for, in `profile`: `--compat rdr171` runs
    /// the course renderer's column integrator in place of `intersection_test`.
    pub fn from_desc(desc: &SceneDesc, profile: Profile) -> Result<RenderJob> {
        let integrator = match (profile, desc.integrator.integrator) {
            (Profile::Physical, i) => i,
            (Profile::Rdr171, Integrator::IntersectionTest(t)) => Integrator::Rdr171(Rdr171Columns { max_depth: t.max_depth }),
            (Profile::Rdr171, _) => {
                return Err(SceneError::new(
                    &desc.file,
                    Some("integrator.type"),
                    "--compat rdr171 reproduces the course renderer's intersection_test only (it had no other integrator)",
                ))
            }
        };
        if profile == Profile::Rdr171 {
            let cylinder = desc
                .objects
                .iter()
                .position(|o| matches!(o.shape, crate::scene::Shape::Cylinder(_) | crate::scene::Shape::SdfGrid(_)));
            let key = match (cylinder, desc.instances.first()) {
                (Some(i), _) => Some(format!("objects[{i}].type")),
                (None, Some(inst)) => Some(match &inst.source {
                    crate::desc::Source::Json(p) => p.clone(),
                    _ => "instance".to_string(),
                }),
                (None, None) => None,
            };
            if let Some(key) = key {
                return Err(SceneError::new(
                    &desc.file,
                    Some(&key),
                    "--compat rdr171 has the course renderer's meshes and spheres only (no cylinders, sdfgrids or instances)",
                ));
            }
            if let Some(m) = desc.materials.iter().find(|m| m.material.mask_opacity().is_some()) {
                return Err(SceneError::new(
                    &desc.file,
                    Some(&format!("materials.{}", m.name)),
                    "--compat rdr171 (the course renderer's intersection_test) cannot render mask materials; render without --compat",
                ));
            }
        }
        if let (Some(t), Profile::Rdr171) = (
            desc.objects.iter().find_map(|o| o.light.as_ref().and_then(|l| l.texture.as_ref())),
            profile,
        ) {
            return Err(t.source.error(
                &desc.file,
                "--compat rdr171 does not support textured area lights (the course renderer's emitters are constant)",
            ));
        }
        if let (Some(l), Profile::Rdr171) = (desc.integrator.delta_lights.first(), profile) {
            return Err(SceneError::new(
                &desc.file,
                Some(&l.key),
                "--compat rdr171 does not support spot and directional lights (the course renderer had point lights only)",
            ));
        }
        let projection = desc.camera.projection;
        let refuse = |why: String| Err(SceneError::new(&desc.file, Some("camera.type"), why));
        if profile == Profile::Rdr171
            && (projection != Projection::Pinhole || desc.camera.near_clip != 0.0 || desc.camera.far_clip != f32::INFINITY)
        {
            return refuse("--compat rdr171 has the course renderer's pinhole camera only (no lens, orthographic view or clipping)".into());
        }
        if let (Projection::Orthographic { .. }, Integrator::Bdpt(_) | Integrator::Ptracer(_)) = (projection, integrator) {
            return refuse(format!(
                "{}: light paths cannot be joined to an orthographic camera (its rays are parallel); use a perspective or thinlens camera, or path",
                integrator.name()
            ));
        }
        let f = &desc.film;
        let camera = Camera::new(&desc.camera, f.width, f.height);
        if !camera.is_finite() {
            return Err(SceneError::new(
                &desc.file,
                Some("camera"),
                "the camera's view basis is not finite for this film's aspect ratio",
            ));
        }
        let film = FilmSettings {
            width: f.width,
            height: f.height,
            filter: f.filter,
            sampling: if f.importance_sampling {
                FilmSampling::importance(&f.filter)
            } else {
                FilmSampling::Filter
            },
            block_size: f.block_size,
        };
        crate::limits::check_memory(film.memory_bytes(), || {
            format!(
                "a film of {}x{} pixels (filter radius {}, blocks of {})",
                f.width,
                f.height,
                f.filter.radius(),
                f.block_size
            )
        })
        .map_err(|m| SceneError::new(&desc.file, Some("film.resolution"), m))?;
        if let Integrator::Bdpt(b) = integrator {
            if b.visualize_strategies {
                let bytes = crate::integrator::bdpt::strategies::memory_bytes(b.max_depth, f.width, f.height);
                crate::limits::check_memory(bytes, || {
                    format!(
                        "visualize_strategies: {} strategy images of {}x{} pixels (max_depth {})",
                        crate::integrator::bdpt::strategies::strategy_list(b.max_depth).len(),
                        f.width,
                        f.height,
                        b.max_depth
                    )
                })
                .map_err(|m| SceneError::new(&desc.file, Some("integrator.visualize_strategies"), m))?;
            }
        }
        Ok(RenderJob {
            camera,
            film,
            integrator,
            spp: desc.integrator.spp,
            target_spp: desc.integrator.spp,
            passes: None,
            seed: 0,
            time_limit: None,
        })
    }
}

/// A scene file, loaded: the world and the job it describes.
pub struct Loaded {
    pub scene: Scene,
    pub job: RenderJob,
}

impl Loaded {
    /// Builds the world and the job of a description for `profile`.
    pub fn build(desc: &SceneDesc, profile: Profile) -> Result<Loaded> {
        Self::build_with(desc, profile, profile.build_options())
    }

    /// [`Loaded::build`] with build switches of its own (tests and experiments).
    pub fn build_with(desc: &SceneDesc, profile: Profile, opts: BuildOptions) -> Result<Loaded> {
        let loaded = Loaded {
            scene: build::build(desc, opts)?,
            job: RenderJob::from_desc(desc, profile)?,
        };
        if loaded.scene.has_media {
            // media are tracked by the camera-path estimator, which `path` and `guided` run
            // (`guided` guides at surface vertices), and by `bdpt`'s subpaths (`ptracer`'s
            // too), whose camera subpaths collect light emitted by media; `ptracer`'s light
            // subpaths cannot find it (none starts in a medium's volume); the others would
            // render null boundaries as black and media as vacuum
            let emissive = loaded.scene.media.iter().any(|m| m.is_emissive());
            let refuse = match (profile, &loaded.job.integrator) {
                (Profile::Rdr171, _) => Some("--compat rdr171"),
                (_, Integrator::Path(_) | Integrator::Guided(_) | Integrator::Normals(_)) => None,
                (_, i @ Integrator::Ptracer(_)) if emissive => {
                    return Err(SceneError::new(
                        &desc.file,
                        None,
                        format!(
                            "{} does not render emissive media (this scene has one: a light tracer cannot see light emitted by a medium); use path or bdpt (volpath in Mitsuba XML)",
                            i.name()
                        ),
                    ));
                }
                (_, Integrator::Bdpt(_) | Integrator::Ptracer(_)) => None,
                (_, i) => Some(i.name()),
            };
            if let Some(who) = refuse {
                return Err(SceneError::new(
                    &desc.file,
                    None,
                    format!("{who} does not render participating media or null boundaries (this scene has them); use path (volpath in Mitsuba XML)"),
                ));
            }
        }
        Ok(loaded)
    }
}

/// Reads, builds and checks a scene file for `profile` in one step.
pub fn load(file: &Path, overrides: &[String], profile: Profile) -> Result<Loaded> {
    Loaded::build(&SceneDesc::load(file, overrides)?, profile)
}

/// [`load`] of a JSON or Mitsuba XML scene, with the XML's `-D name=value` parameters.
pub fn load_with_defines(file: &Path, overrides: &[String], defines: &[(String, String)], profile: Profile) -> Result<Loaded> {
    Loaded::build(&SceneDesc::load_with_defines(file, overrides, defines)?, profile)
}
