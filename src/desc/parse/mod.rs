//! The RDR171 JSON scene (spec §3–§12) read into a [`SceneDesc`]: the scene, its
//! objects and environment here, the render job's parts in [`job`], textures and
//! materials in [`materials`]; the checks every reader here shares.

mod job;
mod materials;
mod media;
mod sunsky;

use self::job::{parse_camera, parse_film, parse_integrator};
use self::materials::{parse_materials, parse_texture};
use crate::desc::json::{Context, Props};
use crate::desc::{
    cylinder_shape, json, principled, rotation_quat, xml, AreaLightDesc, EnvMapDesc, InstanceDesc, IntegratorDesc, MeshFile, MeshFormat,
    MeshOptions, ObjectDesc, SceneDesc, ShapeGroupDesc, TextureRef,
};
use crate::error::Result;
use crate::geometry::sphere::Sphere;
use crate::math::{Mat4, Vec3};
use crate::scene::Shape;
use serde_json::Value;
use std::path::Path;

impl SceneDesc {
    /// Reads a scene file, applies `--override` patches (spec §1), and parses it.
    pub fn load(file: &Path, overrides: &[String]) -> Result<SceneDesc> {
        Self::load_with_defines(file, overrides, &[])
    }

    /// [`SceneDesc::load`] for either format: a `.xml` file is Mitsuba XML read with
    /// the `-D name=value` parameters `defines` (and no `--override`, which is JSON's);
    /// anything else is RDR171 JSON (and takes no parameters).
    pub fn load_with_defines(file: &Path, overrides: &[String], defines: &[(String, String)]) -> Result<SceneDesc> {
        if xml::is_xml(file) {
            if !overrides.is_empty() {
                return Err(crate::error::SceneError::new(
                    file,
                    None,
                    "--override patches JSON scenes; for a Mitsuba XML scene use -D name=value",
                ));
            }
            return xml::load(file, defines);
        }
        if let Some((k, _)) = defines.first() {
            return Err(crate::error::SceneError::new(
                file,
                None,
                format!("-D {k}=… sets a parameter of a Mitsuba XML scene; for a JSON scene use --override"),
            ));
        }
        let ctx = Context::new(file);
        let ext = file.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        if let Some(what) = foreign_format(&ext) {
            return Err(ctx.error("", format!("rdr does not read {what}; {SCENE_FORMATS}")));
        }
        // a regular file of a sane size: a FIFO would block, /dev/zero never end
        let bytes = crate::limits::read_input_file(file, crate::limits::max_input_file())
            .map_err(|e| ctx.error("", format!("cannot read scene: {e}")))?;
        // another extension: JSON only if it looks like JSON
        let first = bytes.iter().find(|b| !b.is_ascii_whitespace());
        if ext != "json" && first != Some(&b'{') {
            let looks = if first == Some(&b'<') {
                " (it looks like XML: name it .xml)"
            } else {
                ""
            };
            return Err(ctx.error("", format!("not a scene rdr reads{looks}; {SCENE_FORMATS}")));
        }
        let text = String::from_utf8(bytes).map_err(|_| ctx.error("", "cannot read scene: stream did not contain valid UTF-8"))?;
        let mut value = json::parse_text(&text, file)?;
        for patch in overrides {
            let p: Value = serde_json::from_str(patch).map_err(|e| ctx.error("", format!("--override is not valid JSON: {e}")))?;
            if !p.is_object() {
                return Err(ctx.error("", "--override must be a JSON object"));
            }
            json::merge(&mut value, &p);
        }
        let base = file.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        Self::from_value(&value, file, base)
    }

    /// Replaces the integrator by the one named `name` at its default settings
    /// (`--integrator`); the scene's lights and spp stay.
    pub fn set_integrator(&mut self, name: &str) -> Result<()> {
        let value = serde_json::json!({ "type": name });
        let ctx = Context::new(Path::new("--integrator"));
        let d = parse_integrator(&Props::root(&value, &ctx)?)?;
        self.integrator.integrator = d.integrator;
        Ok(())
    }

    /// Parses an already-read JSON value. `base_dir` anchors relative paths.
    pub fn from_value(value: &Value, file: &Path, base_dir: &Path) -> Result<SceneDesc> {
        let ctx = Context::new(file);
        let root = Props::root(value, &ctx)?;
        let integrator = parse_integrator(&root.object_or_empty("integrator")?)?;
        let film = parse_film(&root.object("film")?)?;
        let camera = parse_camera(&root.object("camera")?)?;
        let camera_medium = {
            let c = root.object("camera")?;
            c.string_opt("medium")?.map(|m| c.located("medium", m))
        };
        let media = media::parse_media(&root, base_dir)?;
        let textures = root
            .named_objects("textures")?
            .iter()
            .map(|(n, p)| parse_texture(n, p))
            .collect::<Result<Vec<_>>>()?;
        let materials = parse_materials(&root)?;
        let mut objects = Vec::new();
        let mut instances = Vec::new();
        for p in root.objects("objects")? {
            if p.string_opt("type")?.as_deref() == Some("instance") {
                instances.push(parse_instance(&p)?);
            } else {
                objects.push(parse_object(&p)?);
            }
        }
        let shapegroups = root
            .named_objects("shapegroups")?
            .iter()
            .map(|(n, p)| parse_shapegroup(n, p))
            .collect::<Result<Vec<_>>>()?;
        let environment_map = root.object_opt("environment_map")?.map(|p| parse_env(&p)).transpose()?;
        let sunsky = root.object_opt("sunsky")?.map(|p| sunsky::parse_sunsky(&p)).transpose()?;
        if environment_map.is_some() && sunsky.is_some() {
            return Err(root.error("sunsky", "a scene has one environment: environment_map or sunsky, not both"));
        }
        root.finish();
        let warnings = ctx.warnings.borrow().clone();
        let unknown = ctx.unknown.borrow().clone();
        Ok(SceneDesc {
            file: file.to_path_buf(),
            base_dir: base_dir.to_path_buf(),
            integrator,
            film,
            camera,
            textures,
            materials,
            objects,
            shapegroups,
            instances,
            environment_map,
            sunsky,
            media,
            camera_medium,
            warnings,
            unknown,
            included: Vec::new(),
            convert_notes: Vec::new(),
        })
    }
}

/// An `integrator` object read on its own, as in a scene file (Python's
/// `render(integrator=...)`), with the warnings about it; `file` names it in messages.
pub fn integrator_from_value(value: &Value, file: &Path) -> Result<(IntegratorDesc, Vec<String>)> {
    let ctx = Context::new(file);
    let wrapped = serde_json::json!({ "integrator": value });
    let root = Props::root(&wrapped, &ctx)?;
    let integrator = parse_integrator(&root.object("integrator")?)?;
    let warnings = ctx.warnings.borrow().clone();
    Ok((integrator, warnings))
}

/// The scene formats rdr reads, as errors about other files name them.
const SCENE_FORMATS: &str = "it reads RDR171 JSON scenes (.json) and Mitsuba 3 XML scenes (.xml)";

/// What a file with extension `ext` (lower case) is, when it is a known format rdr
/// does not read as a scene.
fn foreign_format(ext: &str) -> Option<&'static str> {
    Some(match ext {
        "pbrt" => "pbrt scenes",
        "gltf" | "glb" => "glTF scenes",
        "usd" | "usda" | "usdc" | "usdz" => "USD scenes",
        "fbx" | "blend" | "dae" | "3ds" | "abc" => "3D applications' own scene files",
        "obj" | "ply" | "serialized" => "a mesh as a scene (a scene's objects can name it)",
        "exr" | "png" | "jpg" | "jpeg" | "hdr" | "pfm" => "an image as a scene",
        _ => return None,
    })
}

fn parse_instance(p: &Props) -> Result<InstanceDesc> {
    p.string("type")?;
    let shapegroup = p.located("shapegroup", p.string("shapegroup")?);
    let transform = p.mat4_or("transform", Mat4::IDENTITY)?;
    let translate = point(p, "translate", p.vec3_or("translate", Vec3::ZERO)?)?;
    let transform = Mat4::from_translation(translate) * transform;
    if crate::accel::instance::Instance::new(&transform, 0).is_none() {
        return Err(p.error("transform", "an instance's transform must be affine and invertible"));
    }
    for k in ["material_name", "light"] {
        if p.contains(k) {
            return Err(p.error(k, "an instance takes its objects' materials (give them in the shapegroup)"));
        }
    }
    p.finish();
    Ok(InstanceDesc {
        source: p.own_source(),
        shapegroup,
        transform,
    })
}

fn parse_shapegroup(name: &str, p: &Props) -> Result<ShapeGroupDesc> {
    let mut objects = Vec::new();
    for o in p.objects("objects")? {
        if o.string_opt("type")?.as_deref() == Some("instance") {
            return Err(o.error(
                "type",
                "an instance inside a shapegroup (nested instancing is not supported, as in Mitsuba)",
            ));
        }
        if o.contains("light") {
            return Err(o.error("light", "emitters inside a shapegroup are not supported (Mitsuba refuses them too)"));
        }
        objects.push(parse_object(&o)?);
    }
    p.finish();
    Ok(ShapeGroupDesc {
        name: name.to_string(),
        source: p.own_source(),
        objects,
    })
}

/// A number in [0, 1] (`rr_threshold`), `default` when absent.
fn unit_interval(p: &Props, key: &str, default: f32) -> Result<f32> {
    let v = p.f32_or(key, default)?;
    if !(0.0..=1.0).contains(&v) {
        return Err(p.error(key, format!("{key} must lie in [0, 1]")));
    }
    Ok(v)
}

/// `v` capped at `max`, with a warning when it was larger.
fn capped(p: &Props, key: &str, v: u32, max: u32) -> u32 {
    if v > max {
        p.ctx()
            .warn(&p.key_path(key), format!("{v} is more than the {max} supported; using {max}"));
        return max;
    }
    v
}

/// A position or size read from `key`: every coordinate within ±[`MAX_COORD`], so the
/// arithmetic of rays and bounds stays finite.
///
/// [`MAX_COORD`]: crate::limits::MAX_COORD
fn point(p: &Props, key: &str, v: Vec3) -> Result<Vec3> {
    let max = crate::limits::MAX_COORD;
    if v.abs().max_element() > max {
        return Err(p.error(
            key,
            format!(
                "[{:?}, {:?}, {:?}] is out of range (coordinates must be within ±{max:e})",
                v.x, v.y, v.z
            ),
        ));
    }
    Ok(v)
}

/// A scalar in `[lo, hi]`.
fn in_range(p: &Props, key: &str, v: f32, lo: f32, hi: f32) -> Result<f32> {
    if !(v >= lo && v <= hi) {
        return Err(p.error(key, format!("must be between {lo:e} and {hi:e}, found {v:e}")));
    }
    Ok(v)
}

/// A point light's flux; the error names the flux key itself.
fn non_negative_flux(p: &Props, key: &str, flux: Vec3) -> Result<Vec3> {
    if flux.min_element() < 0.0 {
        return Err(p.error(key, "light flux must not be negative"));
    }
    Ok(flux)
}

/// A `mesh_attribute`'s `name` (`vertex_…` or `face_…`).
fn mesh_attribute_name(p: &Props, name: String) -> Result<String> {
    crate::geometry::mesh::MeshAttribute::check_name(&name).map_err(|m| p.error("name", m))?;
    Ok(name)
}

fn non_negative(p: &Props, key: &str, v: f32) -> Result<f32> {
    if v < 0.0 {
        return Err(p.error(key, format!("must not be negative, found {v}")));
    }
    Ok(v)
}

/// A finite number.
fn finite(p: &Props, key: &str, v: f32) -> Result<f32> {
    if !v.is_finite() {
        return Err(p.error(key, format!("must be a finite number, found {v}")));
    }
    Ok(v)
}

/// A non-negative reflectance or transmittance colour (default `default`).
fn colour(p: &Props, key: &str, default: Vec3) -> Result<Vec3> {
    let c = p.vec3_or(key, default)?;
    if c.min_element() < 0.0 {
        return Err(p.error(key, "must not be negative"));
    }
    Ok(c)
}

/// A roughness `alpha` in [0, 10] (beyond that the microfacet forms lose precision).
fn roughness(p: &Props, key: &str) -> Result<f32> {
    let a = non_negative(p, key, p.f32_or(key, 0.1)?)?;
    in_range(p, key, a, 0.0, 10.0)
}

fn parse_object(p: &Props) -> Result<ObjectDesc> {
    let ty = p.string("type")?;
    let shape = match ty.as_str() {
        "mesh" => {
            let path = p.string("path")?;
            // a PLY file by its name (read as it is: rdr's uv, its normals or none)
            let ply = Path::new(&path).extension().is_some_and(|e| e.eq_ignore_ascii_case("ply"));
            Shape::Mesh(MeshFile {
                path: p.located("path", path),
                transform: p.mat4_or("transform", Mat4::IDENTITY)?,
                translate: point(p, "translate", p.vec3_or("translate", Vec3::ZERO)?)?,
                options: MeshOptions {
                    format: if ply { MeshFormat::Ply } else { MeshFormat::Obj },
                    ..MeshOptions::default()
                },
            })
        }
        "sphere" => {
            let radius = p.f32_or("radius", 1.0)?;
            if radius <= 0.0 {
                return Err(p.error("radius", format!("must be positive, found {radius}")));
            }
            in_range(p, "radius", radius, 0.0, crate::limits::MAX_COORD)?;
            let uv_frame = match p.mat3_opt("uv_frame")? {
                None => None,
                Some(m) => Some(rotation_quat(&m).ok_or_else(|| p.error("uv_frame", "must be a rotation (orthonormal, determinant 1)"))?),
            };
            Shape::Sphere(Sphere {
                center: point(p, "center", p.vec3_or("center", Vec3::ZERO)?)?,
                radius,
                uv_frame,
            })
        }
        "cylinder" => {
            let p0 = point(p, "p0", p.vec3_or("p0", Vec3::ZERO)?)?;
            let p1 = point(p, "p1", p.vec3_or("p1", Vec3::Z)?)?;
            let radius = p.f32_or("radius", 1.0)?;
            let flip = p.bool_or("flip_normals", false)?;
            let m = p.mat4_or("transform", Mat4::IDENTITY)?;
            Shape::Cylinder(cylinder_shape(p0, p1, radius, flip, &m).map_err(|(k, e)| p.error(k, e))?)
        }
        "sdfgrid" => {
            let path = p.string("filename")?;
            let transform = p.mat4_or("transform", Mat4::IDENTITY)?;
            crate::volume::check_affine(&transform).map_err(|e| p.error("transform", e))?;
            let normals = p.string_or("normals", "smooth")?;
            let normals = crate::geometry::sdfgrid::SdfNormals::from_name(&normals).map_err(|e| p.error("normals", e))?;
            Shape::SdfGrid(crate::desc::SdfGridFile {
                path: p.located("filename", path),
                transform,
                normals,
            })
        }
        _ => {
            return Err(p.error(
                "type",
                format!("unknown object type '{ty}' (available: mesh, sphere, cylinder, sdfgrid, instance)"),
            ))
        }
    };
    let material = p.string_opt("material_name")?.map(|m| p.located("material_name", m));
    let light = match p.object_opt("light")? {
        None => None,
        Some(l) => {
            let ty = l.string_or("type", "area")?;
            if ty != "area" {
                return Err(l.error("type", format!("unknown light type '{ty}' on an object (available: area)")));
            }
            let (radiance, texture) = match principled::json_texture(&l, "radiance", 1.0, true)? {
                TextureRef::Color(c) => (c, None),
                TextureRef::Named(t) => (Vec3::ONE, Some(t)),
            };
            if !(radiance.min_element() >= 0.0 && radiance.is_finite()) {
                return Err(l.error("radiance", "must not be negative"));
            }
            l.finish();
            Some(AreaLightDesc {
                source: l.own_source(),
                radiance,
                texture,
            })
        }
    };
    let (interior, exterior) = (
        p.string_opt("interior")?.map(|m| p.located("interior", m)),
        p.string_opt("exterior")?.map(|m| p.located("exterior", m)),
    );
    let null_bsdf = p.bool_or("null_bsdf", false)?;
    if null_bsdf && material.is_some() {
        return Err(p.error("null_bsdf", "an object with a null BSDF takes no 'material_name'"));
    }
    if material.is_none() && light.is_none() && !null_bsdf {
        return Err(p.ctx().error(&p.path, "an object needs a 'material_name', a 'light', or both"));
    }
    p.finish();
    Ok(ObjectDesc {
        source: p.own_source(),
        shape,
        material,
        light,
        interior,
        exterior,
        null_bsdf,
    })
}

fn parse_env(p: &Props) -> Result<EnvMapDesc> {
    let e = EnvMapDesc {
        source: p.own_source(),
        texture: p.located("texture_name", p.string("texture_name")?),
        scale: non_negative(p, "scale", p.f32_or("scale", 1.0)?)?,
        transform: p.mat4_or("transform", Mat4::IDENTITY)?,
    };
    p.finish();
    Ok(e)
}
