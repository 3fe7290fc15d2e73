//! Description → render-ready scene: loads meshes, resolves names, builds the BVH.

use super::source::Source;
use super::{MeshFile, MeshFormat, MeshNormals, SceneDesc, TextureRef};
use crate::accel::WideBvh;
use crate::error::{Result, SceneError};
use crate::geometry::mesh::{Mesh, ATTRIBUTE_SLOTS};
/// Moved to the geometry layer; re-exported for existing callers.
pub use crate::geometry::prim::prim_bounds;
use crate::geometry::{obj, ply, serialized, shapes};
use crate::light::environment::EnvImage;
use crate::light::{AreaLight, EnvironmentLight, Light, LightSampler};
use crate::math::{Vec2, Vec3};
use crate::scene::{Object, Prim, Scene, Shape};
use crate::texture::image::{ImageCache, ImageFilter, ImageTexture, ImageUse};
use crate::texture::{Texture, TextureConvention};
use rayon::prelude::*;
use std::collections::HashMap;

/// Choices the `--compat` profile makes differently at build time, and build
/// switches for tests and experiments.
#[derive(Clone, Copy, Debug)]
pub struct BuildOptions {
    /// Re-wind texture coordinates together with vertices (the original did not).
    pub swap_uv_on_rewind: bool,
    /// Image rows vs. `v`, sphere uv order and the image lookup (see [`TextureConvention`]).
    pub textures: TextureConvention,
    /// Build MIP pyramids for image textures (default true). With `false` only level 0
    /// exists and every image lookup is bilinear on it, whatever the ray footprint:
    /// the aliasing test compares both.
    pub mipmap: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            swap_uv_on_rewind: true,
            textures: TextureConvention::Physical,
            mipmap: true,
        }
    }
}

impl crate::compat::Profile {
    /// The build options of this profile (`--compat rdr171`: the original's uv
    /// re-winding and texture convention).
    pub fn build_options(self) -> BuildOptions {
        match self {
            Self::Physical => BuildOptions::default(),
            Self::Rdr171 => BuildOptions {
                swap_uv_on_rewind: false,
                textures: TextureConvention::Rdr171,
                ..BuildOptions::default()
            },
        }
    }
}

fn lookup(names: &HashMap<&str, u32>, name: &str, what: &str, desc: &SceneDesc, source: &Source) -> Result<u32> {
    names.get(name).copied().ok_or_else(|| {
        let mut known: Vec<&str> = names.keys().copied().collect();
        known.sort();
        let known = if known.is_empty() {
            "none are defined".to_string()
        } else {
            format!("defined: {}", known.join(", "))
        };
        source.error(&desc.file, format!("no {what} named '{name}' ({known})"))
    })
}

/// A mesh's triangles as read (in its own frame, before `transform`), with the
/// description's normal and orientation options applied.
pub fn mesh_data(desc: &SceneDesc, file: &MeshFile) -> Result<obj::ObjData> {
    let MeshFile { path, options, .. } = file;
    let full = desc.base_dir.join(&path.value);
    let err = |msg: String| path.source.error(&desc.file, msg);
    let read = || -> Result<Vec<u8>> {
        // a regular file of a sane size (a FIFO would block, /dev/zero never end), whose
        // parsed form fits the memory budget
        let bytes = crate::limits::read_input_file(&full, crate::limits::max_input_file())
            .map_err(|e| err(format!("cannot read mesh '{}': {e}", full.display())))?;
        if !matches!(options.format, MeshFormat::Serialized { .. }) {
            crate::limits::check_memory((bytes.len() as u64).checked_mul(obj::MEMORY_PER_BYTE), || {
                format!("mesh '{}'", full.display())
            })
            .map_err(err)?;
        }
        Ok(bytes)
    };
    let mut data = match &options.format {
        MeshFormat::Obj => obj::parse_bytes(&read()?).map_err(|e| err(format!("{}: {e}", full.display())))?,
        MeshFormat::Ply => ply::parse_ply(&read()?).map_err(|e| err(format!("{}: {e:#}", full.display())))?,
        MeshFormat::Serialized { shape_index } => {
            let m = serialized::parse(&read()?, *shape_index).map_err(|e| err(format!("{}: {e:#}", full.display())))?;
            let mut d = m.data;
            if m.flags & serialized::FACE_NORMALS != 0 {
                shapes::drop_normals(&mut d);
            }
            d
        }
        MeshFormat::Rectangle => shapes::rectangle(),
        MeshFormat::Cube => shapes::cube(),
        MeshFormat::Disk => shapes::disk(super::DISK_SEGMENTS),
    };
    match options.normals {
        MeshNormals::AsInFile => {}
        MeshNormals::Face => shapes::drop_normals(&mut data),
        MeshNormals::SmoothWhenMissing => shapes::add_smooth_normals(&mut data),
    }
    if options.flip_normals {
        shapes::flip_normals(&mut data);
    }
    if options.flip_uv {
        shapes::flip_uv(&mut data);
    }
    Ok(data)
}

fn load_mesh(desc: &SceneDesc, file: &MeshFile, opts: BuildOptions) -> Result<(Mesh, Vec<String>)> {
    let MeshFile {
        path,
        transform,
        translate,
        ..
    } = file;
    let full = desc.base_dir.join(&path.value);
    let err = |msg: String| path.source.error(&desc.file, msg);
    let data = mesh_data(desc, file)?;
    let mut warnings: Vec<String> = data.warnings.iter().map(|w| format!("{}: {w}", full.display())).collect();
    if data.triangles.is_empty() {
        return Err(err(format!("mesh '{}' has no faces", full.display())));
    }
    let (mesh, report) = Mesh::from_obj(data, transform, *translate, opts.swap_uv_on_rewind);
    if report.degenerate > 0 {
        warnings.push(format!(
            "{}: {} degenerate (zero-area) triangle(s) skipped, the first from line {}",
            full.display(),
            report.degenerate,
            report.first_degenerate_line.unwrap_or(0)
        ));
    }
    if report.too_large > 0 {
        warnings.push(format!(
            "{}: {} triangle(s) with coordinates beyond ±{:e} (after the transform) skipped, the first from line {}",
            full.display(),
            report.too_large,
            crate::limits::MAX_COORD,
            report.first_too_large_line.unwrap_or(0)
        ));
    }
    if mesh.triangles.is_empty() {
        if report.too_large > 0 {
            return Err(err(format!(
                "mesh '{}' has no usable triangles: {} are too large (coordinates beyond ±{:e}), {} degenerate",
                full.display(),
                report.too_large,
                crate::limits::MAX_COORD,
                report.degenerate
            )));
        }
        // Mitsuba renders such scenes (meshes of nothing but zero-area triangles come out
        // of 3D tools): the mesh is left empty, and `build` warns once for all of them
        warnings.pop();
    }
    Ok((mesh, warnings))
}

pub fn build(desc: &SceneDesc, opts: BuildOptions) -> Result<Scene> {
    let mut warnings = desc.warnings.clone();

    let texture_names: HashMap<&str, u32> = desc.textures.iter().enumerate().map(|(i, t)| (t.name.as_str(), i as u32)).collect();
    // Image files load first (once per distinct file, in parallel); a pyramid only
    // for files that a trilinear lookup reads (Mitsuba's bitmaps read level 0 only).
    let image_paths: Vec<(std::path::PathBuf, bool, bool, &Source)> = desc
        .textures
        .iter()
        .filter_map(|t| match &t.texture {
            Texture::Image(file) => Some((
                desc.base_dir.join(&file.path.value),
                file.raw,
                file.filter == ImageFilter::Trilinear,
                &file.path.source,
            )),
            _ => None,
        })
        .collect();
    let mut images = ImageCache::default();
    let files: Vec<ImageUse> = image_paths.iter().map(|(p, raw, pyramid, _)| (p.clone(), *raw, *pyramid)).collect();
    images.load_all(&files, opts.textures, opts.mipmap).map_err(|(i, e)| {
        let (full, _, _, source) = &image_paths[i];
        // the loader's messages name the file already; name it here only when not
        let (e, full) = (format!("{e:#}"), full.display().to_string());
        let msg = if e.contains(&full) {
            format!("cannot load image texture: {e}")
        } else {
            format!("cannot load image texture '{full}': {e}")
        };
        source.error(&desc.file, msg)
    })?;
    let mut textures = Vec::with_capacity(desc.textures.len());
    for t in &desc.textures {
        textures.push(t.texture.try_map_image(|file| {
            Ok::<_, SceneError>(ImageTexture {
                mipmap: images.get(&desc.base_dir.join(&file.path.value), file.raw).expect("loaded above"),
                mapping: file.mapping,
                filter: file.filter,
                wrap: file.wrap,
                scale: file.scale,
            })
        })?);
    }

    let material_names: HashMap<&str, u32> = desc
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| (m.name.as_str(), i as u32))
        .collect();
    let mut materials = Vec::with_capacity(desc.materials.len());
    for m in &desc.materials {
        materials.push(
            m.material
                .try_map_textures(|t| resolve_texture(t, &texture_names, &mut textures, desc))?,
        );
    }
    for m in &mut materials {
        m.prepare(&|t: &u32| textures[*t as usize].mean());
    }
    // the mesh attribute names the textures read, each a slot of the surface interaction
    let mut attribute_names: Vec<String> = Vec::new();
    for (i, t) in textures.iter_mut().enumerate() {
        if let Texture::MeshAttribute { name, slot, .. } = t {
            let k = attribute_names.iter().position(|n| n == name).unwrap_or_else(|| {
                attribute_names.push(name.clone());
                attribute_names.len() - 1
            });
            if k >= ATTRIBUTE_SLOTS {
                let message = format!(
                    "the scene's textures read {} mesh attributes ({}); at most {ATTRIBUTE_SLOTS} are supported",
                    k + 1,
                    attribute_names.join(", ")
                );
                return Err(match desc.textures.get(i) {
                    Some(t) => t.source.error(&desc.file, message),
                    None => SceneError::new(&desc.file, None, message),
                });
            }
            *slot = k as u8;
        }
    }
    let attribute_names: Vec<&str> = attribute_names.iter().map(String::as_str).collect();

    // Meshes load in parallel; errors are reported for the first failing object.
    // The scene's own objects, then the members of each shape group (in order).
    let all: Vec<&super::ObjectDesc> = desc
        .objects
        .iter()
        .chain(desc.shapegroups.iter().flat_map(|g| g.objects.iter()))
        .collect();
    let shapes: Vec<Result<(Shape, Vec<String>)>> = all
        .par_iter()
        .map(|o| match &o.shape {
            Shape::Mesh(file) => load_mesh(desc, file, opts).map(|(m, w)| (Shape::Mesh(m), w)),
            Shape::Sphere(s) => Ok((Shape::Sphere(*s), Vec::new())),
            Shape::Cylinder(c) => Ok((Shape::Cylinder(*c), Vec::new())),
            Shape::SdfGrid(f) => super::load_sdf_grid(f, &desc.file, &desc.base_dir).map(|g| (Shape::SdfGrid(g), Vec::new())),
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
        .chain(desc.integrator.delta_lights.iter().map(|l| l.light.clone()))
        .collect();
    // the images of textured spots and projectors
    let first_delta = desc.integrator.point_lights.len();
    for (i, l) in desc.integrator.delta_lights.iter().enumerate() {
        let Some(r) = &l.texture else { continue };
        let t = emitter_texture(r, &texture_names, &mut textures, desc, |m| {
            SceneError::new(&desc.file, Some(&l.key), m)
        })?;
        let light = &mut lights[first_delta + i];
        *light = match std::mem::replace(
            light,
            Light::Point {
                position: Vec3::ZERO,
                flux: Vec3::ZERO,
            },
        ) {
            Light::TexturedSpot(mut s) => {
                s.texture = t;
                Light::TexturedSpot(s)
            }
            Light::Projector(p) => Light::Projector(p.with_texture(t)),
            other => other,
        };
    }
    let mut degenerate: Vec<&str> = Vec::new();
    let medium_names: HashMap<&str, u32> = desc.media.iter().enumerate().map(|(i, m)| (m.name.as_str(), i as u32)).collect();
    let medium = |m: &Option<super::Located<String>>| {
        m.as_ref()
            .map(|m| lookup(&medium_names, &m.value, "medium", desc, &m.source))
            .transpose()
    };
    let camera_medium = medium(&desc.camera_medium)?;
    for (oi, (o, shape)) in all.iter().zip(shapes).enumerate() {
        let (mut shape, w) = shape?;
        warnings.extend(w);
        if let Shape::Mesh(mesh) = &mut shape {
            mesh.bind_attributes(&attribute_names);
        }
        let empty = matches!(&shape, Shape::Mesh(m) if m.triangles.is_empty());
        if let (true, Shape::Mesh(file)) = (empty, &o.shape) {
            degenerate.push(&file.path.value);
        }
        let material = o
            .material
            .as_ref()
            .map(|m| lookup(&material_names, &m.value, "material", desc, &m.source))
            .transpose()?;
        let light = match &o.light {
            None => None,
            Some(_) if empty => None,
            Some(l) => {
                let mut a = match &shape {
                    Shape::Mesh(m) => AreaLight::mesh(oi as u32, l.radiance, (0..m.triangles.len()).map(|i| m.vertices(i)).collect()),
                    Shape::Sphere(s) => AreaLight::sphere(oi as u32, l.radiance, s.center, s.radius).with_sphere_uv_frame(s.uv_frame),
                    Shape::Cylinder(c) => AreaLight::cylinder(oi as u32, l.radiance, c.cylinder, c.flip_normals),
                    Shape::SdfGrid(_) => {
                        let e = "an sdfgrid cannot be an area emitter (Mitsuba 3's has no area and no sampling)";
                        return Err(l.source.error(&desc.file, e));
                    }
                };
                if let Some(t) = &l.texture {
                    let texture = emitter_texture(&TextureRef::Named(t.clone()), &texture_names, &mut textures, desc, |m| {
                        t.source.error(&desc.file, m)
                    })?;
                    // the corners' uv, as a ray's hit interpolates them
                    let uvs = match &shape {
                        Shape::Mesh(m) => m
                            .triangles
                            .iter()
                            .map(|tri| match tri.uv {
                                Some(i) => i.map(|i| m.uvs[i as usize]),
                                None => [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0)],
                            })
                            .collect(),
                        _ => Vec::new(),
                    };
                    a = a.with_texture(texture, uvs);
                }
                lights.push(Light::Area(a));
                Some(lights.len() as u32 - 1)
            }
        };
        if let (Some(m), false) = (material, empty) {
            // the mesh attributes it reads must be on this object's mesh, of 1 or 3 channels
            let mut needs: Vec<&str> = Vec::new();
            let _ = materials[m as usize].try_map_textures(|&t| {
                if let Texture::MeshAttribute { name, .. } = &textures[t as usize] {
                    needs.push(name);
                }
                Ok::<(), ()>(())
            });
            let on_mesh = |name: &str| match &shape {
                Shape::Mesh(mesh) => mesh.attributes.iter().find(|a| a.name == name),
                Shape::Sphere(_) | Shape::Cylinder(_) | Shape::SdfGrid(_) => None,
            };
            let material_name = &desc.materials[m as usize].name;
            let problem = needs.iter().find_map(|&name| match on_mesh(name) {
                None => {
                    let has: Vec<&str> = match &shape {
                        Shape::Mesh(mesh) => mesh.attributes.iter().map(|a| a.name.as_str()).collect(),
                        Shape::Sphere(_) | Shape::Cylinder(_) | Shape::SdfGrid(_) => Vec::new(),
                    };
                    let has = if has.is_empty() { "none".to_string() } else { has.join(", ") };
                    Some(format!(
                        "material '{material_name}' reads the mesh attribute {name}, which this object's mesh has not (it has: {has})"
                    ))
                }
                Some(a) if a.channels != 1 && a.channels != 3 => Some(format!(
                    "material '{material_name}' reads the mesh attribute {name} of {} channels; a mesh_attribute reads 1 or 3 (as Mitsuba)",
                    a.channels
                )),
                Some(_) => None,
            });
            if let Some(problem) = problem {
                let source = o.material.as_ref().map_or(&o.source, |m| &m.source);
                return Err(source.error(&desc.file, problem));
            }
        }
        let (interior, exterior) = (medium(&o.interior)?, medium(&o.exterior)?);
        objects.push(Object {
            shape,
            material,
            light,
            media: (interior.is_some() || exterior.is_some()).then_some(crate::medium::MediumInterface { interior, exterior }),
            null_bsdf: o.null_bsdf,
        });
    }
    if let Some(first) = degenerate.first() {
        warnings.push(format!(
            "{} mesh(es) with only degenerate (zero-area) triangles skipped, the first '{}'",
            degenerate.len(),
            desc.base_dir.join(first).display()
        ));
    }

    let environment = match &desc.environment_map {
        None if desc.sunsky.is_some() => {
            let sky = desc.sunsky.as_ref().expect("matched");
            lights.push(Light::Environment(sunsky_light(sky, &desc.file, &mut warnings)?));
            Some(lights.len() as u32 - 1)
        }
        None => None,
        Some(env) => {
            let t = lookup(&texture_names, &env.texture.value, "texture", desc, &env.texture.source)?;
            // the texture's file is loaded already: its level 0 is the image as read
            let image = match &textures[t as usize] {
                Texture::Constant(color) => EnvImage::Constant(*color),
                Texture::Image(img) => {
                    let level = &img.mipmap.levels()[0];
                    let texels = level.to_linear();
                    // NaN and infinite texels were made black when the file was read
                    let (_, negative) = crate::light::environment::unusable_texels(&texels);
                    let not_finite = img.mipmap.non_finite_texels();
                    if not_finite + negative > 0 {
                        let file = match &desc.textures[t as usize].texture {
                            Texture::Image(f) => desc.base_dir.join(&f.path.value).display().to_string(),
                            _ => env.texture.value.clone(),
                        };
                        warnings.push(format!(
                            "{file}: environment map with {not_finite} NaN or infinite and {negative} negative texel(s) of {}; they emit nothing",
                            texels.len()
                        ));
                    }
                    EnvImage::Image {
                        width: level.width,
                        height: level.height,
                        texels,
                        mapping: img.mapping,
                    }
                }
                Texture::Checkerboard { .. } | Texture::MeshAttribute { .. } => {
                    return Err(env
                        .texture
                        .source
                        .error(&desc.file, "an environment map needs an image or constant texture"))
                }
            };
            lights.push(Light::Environment(EnvironmentLight::new(image, env.scale, &env.transform)));
            Some(lights.len() as u32 - 1)
        }
    };

    // the other image files with NaN or infinite texels (the environment map's said so above)
    let env_texture = desc
        .environment_map
        .as_ref()
        .and_then(|e| texture_names.get(e.texture.value.as_str()));
    let mut told: Vec<std::path::PathBuf> = Vec::new();
    for (i, (t, file)) in textures.iter().zip(&desc.textures).enumerate() {
        if let (Texture::Image(img), Texture::Image(f)) = (t, &file.texture) {
            let path = desc.base_dir.join(&f.path.value);
            let n = img.mipmap.non_finite_texels();
            if n > 0 && env_texture != Some(&(i as u32)) && !told.contains(&path) {
                let all = img.mipmap.levels()[0].len();
                warnings.push(format!(
                    "{}: image texture with {n} NaN or infinite texel(s) of {all}; they are read as black",
                    path.display()
                ));
                told.push(path);
            }
        }
    }

    let n_top = desc.objects.len();
    // a masked emitter would hide its emission from some rays and not from light sampling
    let masked = |o: &Object| o.material.is_some_and(|m| materials[m as usize].mask_opacity().is_some());
    if let Some((o, _)) = desc.objects.iter().zip(&objects).find(|(_, o)| o.light.is_some() && masked(o)) {
        let source = o.material.as_ref().map_or(&o.source, |m| &m.source);
        return Err(source.error(&desc.file, "a mask material on an emitting object is not supported"));
    }
    let has_masks = objects.iter().any(masked);
    let objects_have_media = objects.iter().any(|o| o.media.is_some() || o.null_bsdf);

    let mut prims = Vec::new();
    for (oi, o) in objects.iter().enumerate().take(n_top) {
        object_prims(&mut prims, oi as u32, &o.shape);
    }
    let bvh_start = std::time::Instant::now();
    // shape groups: one bottom level each; instances: one top-level entry each
    let mut groups = Vec::with_capacity(desc.shapegroups.len());
    let mut members = Vec::with_capacity(desc.shapegroups.len());
    let mut first = n_top;
    for g in &desc.shapegroups {
        let mut gp = Vec::new();
        for (oi, o) in objects.iter().enumerate().skip(first).take(g.objects.len()) {
            object_prims(&mut gp, oi as u32, &o.shape);
        }
        members.push(first..first + g.objects.len());
        first += g.objects.len();
        groups.push(crate::accel::instance::Group::new(gp));
    }
    // sdfgrids: each grid's voxels a bottom level of its own, placed by an instance
    // (index space to the world; in a shape group, once per instance of the group)
    let mut sdf_groups = vec![None; objects.len()];
    for (oi, o) in objects.iter().enumerate() {
        if let Shape::SdfGrid(g) = &o.shape {
            sdf_groups[oi] = Some(groups.len() as u32);
            let voxels = g.voxels().map(|voxel| Prim::SdfVoxel { voxel, object: oi as u32 });
            groups.push(crate::accel::instance::Group::new(voxels.collect()));
        }
    }
    let mut instances = Vec::with_capacity(desc.instances.len());
    let mut place = |to_world: &crate::math::Mat4, gi: u32, prims: &mut Vec<Prim>| {
        let inst = crate::accel::instance::Instance::new(to_world, gi)?;
        prims.push(Prim::Instance {
            bounds: inst.world_bounds(groups[gi as usize].bvh.bounds()),
            instance: instances.len() as u32,
        });
        instances.push(inst);
        Some(())
    };
    for (oi, o) in objects.iter().enumerate().take(n_top) {
        if let (Shape::SdfGrid(g), Some(gi)) = (&o.shape, sdf_groups[oi]) {
            if place(&g.index_to_world(), gi, &mut prims).is_none() {
                return Err(all[oi]
                    .source
                    .error(&desc.file, "an sdfgrid's transform must be affine and invertible"));
            }
        }
    }
    let group_names: HashMap<&str, u32> = desc
        .shapegroups
        .iter()
        .enumerate()
        .map(|(i, g)| (g.name.as_str(), i as u32))
        .collect();
    for d in &desc.instances {
        let gi = lookup(&group_names, &d.shapegroup.value, "shapegroup", desc, &d.shapegroup.source)?;
        let invalid = || d.source.error(&desc.file, "an instance's transform must be affine and invertible");
        place(&d.transform, gi, &mut prims).ok_or_else(invalid)?;
        for oi in members[gi as usize].clone() {
            if let (Shape::SdfGrid(g), Some(si)) = (&objects[oi].shape, sdf_groups[oi]) {
                place(&(d.transform * g.index_to_world()), si, &mut prims).ok_or_else(invalid)?;
            }
        }
    }
    let (prims, bvh) = build_bvh(prims);
    let bvh_seconds = bvh_start.elapsed().as_secs_f64();

    let bounds = bvh.bounds();
    let (center, radius) = if bounds.is_empty() {
        (Vec3::ZERO, 1.0)
    } else {
        (bounds.centroid(), (bounds.extent().length() * 0.5).max(1e-3))
    };
    let light_sampler = LightSampler::new(&lights, radius, desc.integrator.light_sampling);
    // the environment's image is looked up by direction, not through a surface
    // so does a textured area light's radiance, at the point a ray hits
    let texture_coords = materials
        .iter()
        .any(|m| m.reads_surface(|&t| matches!(textures[t as usize], Texture::Constant(_))))
        || lights.iter().any(|l| matches!(l, Light::Area(a) if a.texture.is_some()));
    let mut scene = Scene {
        uses_footprints: texture_coords && textures.iter().any(|t| matches!(t, Texture::Image(_))),
        texture_coords,
        textures,
        materials,
        objects,
        lights,
        environment,
        light_sampler,
        light_sampling: desc.integrator.light_sampling,
        center,
        radius,
        prims,
        bvh,
        instances,
        groups,
        warnings,
        bvh_seconds,
        texture_convention: opts.textures,
        has_masks,
        has_media: camera_medium.is_some() || objects_have_media,
        media: desc.media.iter().map(|m| m.medium.clone()).collect(),
        camera_medium,
        sealed_media: Vec::new(),
    };
    // a medium that asks for no light sample (`sample_emitters` false) is treated as sealed
    let sealed = crate::scene::sealed_media(&scene).into_iter().zip(&desc.media);
    scene.sealed_media = sealed.map(|(sealed, m)| sealed || !m.sample_emitters).collect();
    Ok(scene)
}

/// Appends the primitives of object `oi`'s shape.
fn object_prims(prims: &mut Vec<Prim>, oi: u32, shape: &Shape) {
    match shape {
        Shape::Mesh(m) => prims.extend((0..m.triangles.len()).map(|i| Prim::Triangle {
            p: m.vertices(i),
            object: oi,
            index: i as u32,
        })),
        Shape::Sphere(s) => prims.push(Prim::Sphere { sphere: *s, object: oi }),
        Shape::Cylinder(c) => prims.push(Prim::Cylinder {
            cylinder: c.cylinder,
            object: oi,
        }),
        // its voxels are a bottom level of their own, placed by an instance
        Shape::SdfGrid(_) => {}
    }
}

/// The texture of an emitter (a textured spot's, a projector's, an area light's
/// radiance), resolved: a constant, checkerboard or image; `at` places errors.
fn emitter_texture(
    r: &TextureRef,
    names: &HashMap<&str, u32>,
    textures: &mut Vec<Texture>,
    desc: &SceneDesc,
    at: impl Fn(String) -> SceneError,
) -> Result<Texture> {
    let i = resolve_texture(r, names, textures, desc)?;
    let t = textures[i as usize].clone();
    if let Texture::MeshAttribute { .. } = t {
        return Err(at(
            "an emitter's texture must be an image, checkerboard or constant (mesh_attribute colours are not available to lights)".into(),
        ));
    }
    Ok(t)
}

/// Index of a material's texture; inline colours become constant textures.
fn resolve_texture(r: &TextureRef, names: &HashMap<&str, u32>, textures: &mut Vec<Texture>, desc: &SceneDesc) -> Result<u32> {
    match r {
        TextureRef::Named(t) => lookup(names, &t.value, "texture", desc, &t.source),
        TextureRef::Color(c) => {
            textures.push(Texture::Constant(*c));
            Ok(textures.len() as u32 - 1)
        }
    }
}

/// Builds the BVH over `prims` and returns both; the BVH's indices refer to
/// `prims`, which keeps its order (primitives with unusable bounds stay in it
/// but are left out of the tree).
pub fn build_bvh(prims: Vec<Prim>) -> (Vec<Prim>, WideBvh) {
    let bvh = WideBvh::build(&prims);
    (prims, bvh)
}

/// The environment light of a `sunsky`: its sun placed in the sky's frame (a world
/// `sun_direction` through the inverse of `transform`), sky and sun as Mitsuba's.
fn sunsky_light(d: &crate::desc::SunSkyDesc, file: &std::path::Path, warnings: &mut Vec<String>) -> Result<EnvironmentLight> {
    use crate::light::sunsky::{SkyModel, SunModel, SunSkyParams};
    d.check()
        .map_err(|(key, msg)| d.source.error(file, format!("sunsky {key}: {msg}")))?;
    let sun = match d.sun {
        crate::desc::SunPlacement::Direction(w) => (d.transform.inverse().transform_vector3(w)).normalize(),
        crate::desc::SunPlacement::At(at) => at.direction(),
    };
    let p = SunSkyParams {
        turbidity: d.turbidity,
        albedo: d.albedo,
        sun,
        sky_scale: d.sky_scale,
        sun_scale: d.sun_scale,
        sun_half_aperture: (0.5 * d.sun_aperture).to_radians(),
        complex_sun: d.complex_sun,
    };
    if p.sun_elevation() < 0.0 {
        warnings.push(format!(
            "{}: sunsky's sun is below the horizon (elevation {:.2}°): sky and sun emit nothing, as Mitsuba's",
            file.display(),
            p.sun_elevation().to_degrees()
        ));
        return Ok(EnvironmentLight::sunsky(None, None, &d.transform));
    }
    let sky = (p.sky_scale > 0.0).then(|| SkyModel::new(&p));
    let sun = (p.sun_scale > 0.0).then(|| SunModel::new(&p));
    Ok(EnvironmentLight::sunsky(sky, sun, &d.transform))
}
