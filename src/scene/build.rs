//! Description → render-ready scene: loads meshes, resolves names, builds the BVH.

use super::desc::{MaterialKind, SceneDesc, ShapeDesc, TextureKind};
use super::{Object, Prim, Scene, Shape};
use crate::accel::Bvh;
use crate::camera::Camera;
use crate::error::{Result, SceneError};
use crate::film::Filter;
use crate::geometry::mesh::Mesh;
use crate::geometry::sphere::Sphere;
use crate::geometry::{obj, Aabb};
use crate::light::environment::EnvImage;
use crate::light::{AreaLight, EnvironmentLight, Light, LightSampler};
use crate::material::Material;
use crate::math::Vec3;
use crate::texture::{Texture, UvMapping};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// Choices the `--compat` profile makes differently at build time.
#[derive(Clone, Copy, Debug)]
pub struct BuildOptions {
    /// Re-wind texture coordinates together with vertices (the original did not).
    pub swap_uv_on_rewind: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions { swap_uv_on_rewind: true }
    }
}

fn lookup(names: &HashMap<&str, u32>, name: &str, what: &str, desc: &SceneDesc, key: &str) -> Result<u32> {
    names.get(name).copied().ok_or_else(|| {
        let mut known: Vec<&str> = names.keys().copied().collect();
        known.sort();
        let known = if known.is_empty() {
            "none are defined".to_string()
        } else {
            format!("defined: {}", known.join(", "))
        };
        SceneError::new(&desc.file, Some(key), format!("no {what} named '{name}' ({known})"))
    })
}

fn load_mesh(
    desc: &SceneDesc,
    path: &super::desc::At<String>,
    opts: BuildOptions,
    transform: &crate::math::Mat4,
    translate: crate::math::Vec3,
) -> Result<(Mesh, Vec<String>)> {
    let full = desc.base_dir.join(&path.value);
    let err = |msg: String| SceneError::new(&desc.file, Some(&path.key), msg);
    let text = std::fs::read(&full).map_err(|e| err(format!("cannot read mesh '{}': {e}", full.display())))?;
    let text = String::from_utf8_lossy(&text);
    let data = obj::parse(&text).map_err(|e| err(format!("{}: {e}", full.display())))?;
    let mut warnings: Vec<String> = data.warnings.iter().map(|w| format!("{}: {w}", full.display())).collect();
    if data.triangles.is_empty() {
        return Err(err(format!("mesh '{}' has no faces", full.display())));
    }
    let (mesh, report) = Mesh::from_obj(data, transform, translate, opts.swap_uv_on_rewind);
    if report.degenerate > 0 {
        warnings.push(format!(
            "{}: {} degenerate (zero-area) triangle(s) skipped, the first from line {}",
            full.display(),
            report.degenerate,
            report.first_degenerate_line.unwrap_or(0)
        ));
    }
    if mesh.triangles.is_empty() {
        return Err(err(format!("mesh '{}' has only degenerate triangles", full.display())));
    }
    Ok((mesh, warnings))
}

pub fn build(desc: &SceneDesc, opts: BuildOptions) -> Result<Scene> {
    let mut warnings = desc.warnings.clone();

    let texture_names: HashMap<&str, u32> = desc.textures.iter().enumerate().map(|(i, t)| (t.name.as_str(), i as u32)).collect();
    let mut textures = Vec::with_capacity(desc.textures.len());
    for t in &desc.textures {
        textures.push(match &t.kind {
            TextureKind::Constant { color } => Texture::Constant(*color),
            TextureKind::Checkerboard { color0, color1, mapping } => Texture::Checkerboard {
                color0: *color0,
                color1: *color1,
                mapping: UvMapping::new(mapping),
            },
            TextureKind::Image { path, .. } => {
                return Err(SceneError::new(&desc.file, Some(&path.key), "image textures are not supported yet"));
            }
        });
    }

    let material_names: HashMap<&str, u32> = desc
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| (m.name.as_str(), i as u32))
        .collect();
    let mut materials = Vec::with_capacity(desc.materials.len());
    for m in &desc.materials {
        materials.push(match &m.kind {
            MaterialKind::Diffuse { texture, twosided } => Material::Diffuse {
                texture: lookup(&texture_names, &texture.value, "texture", desc, &texture.key)?,
                twosided: *twosided,
            },
            MaterialKind::Refraction { eta } => Material::Refraction { eta: *eta },
            MaterialKind::Glass { reflect, transmit, eta } => Material::Glass {
                reflect: *reflect,
                transmit: *transmit,
                eta: *eta,
            },
            MaterialKind::RoughConductor {
                texture,
                eta_i,
                eta_t,
                k,
                alpha_x,
                alpha_y,
            } => Material::RoughConductor {
                texture: lookup(&texture_names, &texture.value, "texture", desc, &texture.key)?,
                eta_i: *eta_i,
                eta_t: *eta_t,
                k: *k,
                alpha_x: *alpha_x,
                alpha_y: *alpha_y,
            },
        });
    }

    // Meshes load in parallel; errors are reported for the first failing object.
    let shapes: Vec<Result<(Shape, Vec<String>)>> = desc
        .objects
        .par_iter()
        .map(|o| match &o.shape {
            ShapeDesc::Mesh {
                path,
                transform,
                translate,
            } => load_mesh(desc, path, opts, transform, *translate).map(|(m, w)| (Shape::Mesh(m), w)),
            ShapeDesc::Sphere { center, radius } => Ok((
                Shape::Sphere(Sphere {
                    center: *center,
                    radius: *radius,
                }),
                Vec::new(),
            )),
        })
        .collect();
    let mut objects = Vec::with_capacity(desc.objects.len());
    let mut lights: Vec<Light> = desc
        .integrator
        .point_lights
        .iter()
        .map(|l| Light::Point {
            position: l.position,
            flux: l.flux,
        })
        .collect();
    for (oi, (o, shape)) in desc.objects.iter().zip(shapes).enumerate() {
        let (shape, w) = shape?;
        warnings.extend(w);
        let material = o
            .material
            .as_ref()
            .map(|m| lookup(&material_names, &m.value, "material", desc, &m.key))
            .transpose()?;
        let light = o.light.as_ref().map(|l| {
            lights.push(Light::Area(match &shape {
                Shape::Mesh(m) => AreaLight::mesh(oi as u32, l.radiance, (0..m.triangles.len()).map(|i| m.vertices(i)).collect()),
                Shape::Sphere(s) => AreaLight::sphere(oi as u32, l.radiance, s.center, s.radius),
            }));
            lights.len() as u32 - 1
        });
        objects.push(Object { shape, material, light });
    }

    let environment = match &desc.environment_map {
        None => None,
        Some(env) => {
            let t = lookup(&texture_names, &env.texture.value, "texture", desc, &env.texture.key)?;
            let image = match &desc.textures[t as usize].kind {
                TextureKind::Constant { color } => EnvImage::Constant(*color),
                TextureKind::Image { path, mapping } => {
                    let full = desc.base_dir.join(&path.value);
                    let img = crate::imageio::read_texture_image(&full)
                        .map_err(|e| SceneError::new(&desc.file, Some(&path.key), format!("environment map: {e:#}")))?;
                    EnvImage::Image {
                        width: img.width,
                        height: img.height,
                        texels: img.pixels,
                        mapping: UvMapping::new(mapping),
                    }
                }
                TextureKind::Checkerboard { .. } => {
                    return Err(SceneError::new(
                        &desc.file,
                        Some(&env.texture.key),
                        "an environment map needs an image or constant texture",
                    ))
                }
            };
            lights.push(Light::Environment(EnvironmentLight::new(image, env.scale, &env.transform)));
            Some(lights.len() as u32 - 1)
        }
    };

    let mut prims = Vec::new();
    for (oi, o) in objects.iter().enumerate() {
        match &o.shape {
            Shape::Mesh(m) => prims.extend((0..m.triangles.len()).map(|i| Prim::Triangle {
                p: m.vertices(i),
                object: oi as u32,
                index: i as u32,
            })),
            Shape::Sphere(s) => prims.push(Prim::Sphere {
                sphere: *s,
                object: oi as u32,
            }),
        }
    }
    let bvh_start = std::time::Instant::now();
    let (prims, bvh) = build_bvh(prims);
    let bvh_seconds = bvh_start.elapsed().as_secs_f64();

    let bounds = bvh.bounds();
    let (center, radius) = if bounds.is_empty() {
        (Vec3::ZERO, 1.0)
    } else {
        (bounds.centroid(), (bounds.extent().length() * 0.5).max(1e-3))
    };
    let light_sampler = LightSampler::new(&lights, radius, desc.integrator.light_sampling);
    Ok(Scene {
        camera: Camera::new(&desc.camera, desc.film.width, desc.film.height),
        width: desc.film.width,
        height: desc.film.height,
        block_size: desc.film.block_size,
        filter: Filter::new(&desc.film.filter),
        spp: desc.integrator.spp,
        max_depth: desc.integrator.max_depth,
        textures,
        materials,
        objects,
        lights,
        environment,
        light_sampler,
        light_sampling: desc.integrator.light_sampling,
        light_samples: desc.integrator.light_samples,
        center,
        radius,
        prims,
        bvh,
        warnings,
        bvh_seconds,
    })
}

pub fn prim_bounds(p: &Prim) -> Aabb {
    match p {
        Prim::Triangle { p, .. } => Aabb::from_points(p),
        Prim::Sphere { sphere, .. } => {
            let r = crate::math::Vec3::splat(sphere.radius * (1.0 + 1e-6) + 1e-6);
            Aabb::new(sphere.center - r, sphere.center + r)
        }
    }
}

/// Builds the BVH and reorders primitives into leaf order.
pub fn build_bvh(prims: Vec<Prim>) -> (Vec<Prim>, Bvh) {
    let bounds: Vec<Aabb> = prims.iter().map(prim_bounds).collect();
    let mut bvh = Bvh::build(&bounds);
    let ordered: Vec<Prim> = bvh.order.iter().map(|&i| prims[i as usize]).collect();
    bvh.order = (0..ordered.len() as u32).collect();
    (ordered, bvh)
}

/// Loads and builds a scene file in one step.
pub fn load(file: &Path, overrides: &[String], opts: BuildOptions) -> Result<Scene> {
    build(&SceneDesc::load(file, overrides)?, opts)
}
