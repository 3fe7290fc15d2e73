//! Scene parameters that can change between renders without building the scene
//! again (Python's `rdr.traverse`): the camera, the film size, the samples per pixel,
//! constant colours and roughness of materials, the intensities of point and area
//! lights. Keys are the scene's JSON key paths (`camera.fov`, `textures.blue.color`,
//! `materials.gold.alpha_x`); anything else is refused by name.
//!
//! An edit changes the description and then exactly what the build made of it: the
//! job, the materials (their textures keep the indices the build gave them), the
//! lights and the light sampler. The BVH and meshes stay. So a render after an edit is
//! the render of the edited scene loaded afresh, bit for bit.

use super::job::{Loaded, RenderJob};
use crate::compat::Profile;
use crate::desc::{SceneDesc, Source, TextureRef};
use crate::light::{Light, LightSampler};
use crate::material::Material;
use crate::math::Vec3;
use crate::texture::Texture;

/// A parameter's value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParamValue {
    Int(u32),
    Float(f32),
    Vec3(Vec3),
    /// Width and height.
    Size(u32, u32),
}

/// What the editable keys are, for messages.
pub const EDITABLE: &str = "camera.position, camera.look_at, camera.ref_up, camera.fov, film.resolution, integrator.spp, \
     textures.NAME.color (constant textures), a material's constant colours, R, T, specular and roughness (alpha, alpha_x, alpha_y), \
     point_lights[i].flux, and the radiance of an object's light";

/// A number a material holds that an edit may change.
enum Field<'a> {
    Colour(&'a mut Vec3),
    Roughness(&'a mut f32),
}

/// `alpha_x` and `alpha_y`.
fn anisotropic<'a>(prefix: &str, x: &'a mut f32, y: &'a mut f32, out: &mut Vec<(String, Field<'a>)>) {
    out.push((format!("{prefix}alpha_x"), Field::Roughness(x)));
    out.push((format!("{prefix}alpha_y"), Field::Roughness(y)));
}

/// The editable fields of a material, named as under `materials.NAME.`, in a fixed order.
fn fields<'a>(m: &'a mut Material<TextureRef>, prefix: &str, out: &mut Vec<(String, Field<'a>)>) {
    let name = |k: &str| format!("{prefix}{k}");
    let colour = |k: &str, t: &'a mut TextureRef, out: &mut Vec<(String, Field<'a>)>| {
        if let TextureRef::Color(c) = t {
            out.push((name(k), Field::Colour(c)));
        }
    };
    match m {
        Material::Diffuse { texture, .. } | Material::Conductor { texture, .. } => colour("color", texture, out),
        Material::Glass { reflect, transmit, .. } | Material::ThinDielectric { reflect, transmit, .. } => {
            out.push((name("R"), Field::Colour(reflect)));
            out.push((name("T"), Field::Colour(transmit)));
        }
        Material::RoughConductor {
            texture,
            alpha_x,
            alpha_y,
            alpha_textures,
            ..
        } => {
            colour("color", texture, out);
            if alpha_textures.is_none() {
                anisotropic(prefix, alpha_x, alpha_y, out);
            }
        }
        Material::RoughDielectric {
            reflect,
            transmit,
            alpha_x,
            alpha_y,
            alpha_textures,
            ..
        } => {
            out.push((name("R"), Field::Colour(reflect)));
            out.push((name("T"), Field::Colour(transmit)));
            if alpha_textures.is_none() {
                anisotropic(prefix, alpha_x, alpha_y, out);
            }
        }
        Material::Plastic { texture, specular, .. } => {
            colour("color", texture, out);
            out.push((name("specular"), Field::Colour(specular)));
        }
        Material::Phong { texture, specular, .. } => {
            colour("color", texture, out);
            out.push((name("specular"), Field::Colour(specular)));
        }
        Material::RoughPlastic {
            texture, specular, alpha, ..
        } => {
            colour("color", texture, out);
            out.push((name("specular"), Field::Colour(specular)));
            out.push((name("alpha"), Field::Roughness(alpha)));
        }
        Material::TwoSided { front, back } => {
            fields(front, &name("front."), out);
            if let Some(b) = back {
                fields(b, &name("back."), out);
            }
        }
        Material::BumpMap { inner, .. } | Material::NormalMap { inner, .. } | Material::Mask { inner, .. } => {
            fields(inner, &name("inner."), out)
        }
        Material::BlendBsdf { first, second, .. } => {
            fields(first, &name("first."), out);
            fields(second, &name("second."), out);
        }
        Material::Refraction { .. } | Material::Principled(_) | Material::PrincipledThin(_) => {}
    }
}

/// The key of object `i`'s light radiance.
fn area_key(desc: &SceneDesc, i: usize) -> String {
    match &desc.objects[i].source {
        Source::Json(path) if !path.is_empty() => format!("{path}.light.radiance"),
        _ => format!("objects[{i}].light.radiance"),
    }
}

/// Whether a light copies texture `name` when the scene is built (the sky, a textured
/// area light, spot or projector): its colour is then not editable here.
fn lights_copy(desc: &SceneDesc, name: &str) -> bool {
    desc.environment_map.as_ref().is_some_and(|e| e.texture.value == name)
        || desc
            .objects
            .iter()
            .any(|o| o.light.as_ref().and_then(|l| l.texture.as_ref()).is_some_and(|t| t.value == name))
        || desc
            .integrator
            .delta_lights
            .iter()
            .any(|l| matches!(&l.texture, Some(TextureRef::Named(t)) if t.value == name))
}

/// Every editable parameter of a scene with its value, in a fixed order.
pub fn list(desc: &SceneDesc) -> Vec<(String, ParamValue)> {
    let c = &desc.camera;
    let mut out = vec![
        ("camera.position".to_string(), ParamValue::Vec3(c.position)),
        ("camera.look_at".to_string(), ParamValue::Vec3(c.look_at)),
        ("camera.ref_up".to_string(), ParamValue::Vec3(c.ref_up)),
        ("camera.fov".to_string(), ParamValue::Float(c.fov)),
        ("film.resolution".to_string(), ParamValue::Size(desc.film.width, desc.film.height)),
        ("integrator.spp".to_string(), ParamValue::Int(desc.integrator.spp)),
    ];
    for t in &desc.textures {
        if let (Texture::Constant(c), false) = (&t.texture, lights_copy(desc, &t.name)) {
            out.push((format!("textures.{}.color", t.name), ParamValue::Vec3(*c)));
        }
    }
    for m in &desc.materials {
        let mut copy = m.material.clone();
        let mut fs = Vec::new();
        fields(&mut copy, "", &mut fs);
        for (k, f) in fs {
            let v = match f {
                Field::Colour(c) => ParamValue::Vec3(*c),
                Field::Roughness(a) => ParamValue::Float(*a),
            };
            out.push((format!("materials.{}.{k}", m.name), v));
        }
    }
    for (j, l) in desc.integrator.point_lights.iter().enumerate() {
        out.push((format!("point_lights[{j}].flux"), ParamValue::Vec3(l.flux)));
    }
    for (i, o) in desc.objects.iter().enumerate() {
        if let Some(l) = o.light.as_ref().filter(|l| l.texture.is_none()) {
            out.push((area_key(desc, i), ParamValue::Vec3(l.radiance)));
        }
    }
    out
}

/// The message for a key that cannot change between renders.
pub fn not_editable(key: &str) -> String {
    format!("{key}: not a parameter that can change between renders (those are: {EDITABLE}); for anything else load the scene again")
}

fn colour(key: &str, v: ParamValue, what: &str) -> Result<Vec3, String> {
    match v {
        ParamValue::Vec3(c) if c.is_finite() && c.min_element() >= 0.0 => Ok(c),
        _ => Err(format!("{key}: expected {what} (three finite numbers, none negative)")),
    }
}

fn vector(key: &str, v: ParamValue) -> Result<Vec3, String> {
    match v {
        ParamValue::Vec3(c) if c.is_finite() => Ok(c),
        _ => Err(format!("{key}: expected three finite numbers")),
    }
}

/// Applies `changes` to the description; which parts of the scene they touch.
fn edit_desc(desc: &mut SceneDesc, changes: &[(String, ParamValue)]) -> Result<(bool, bool, bool), String> {
    let (mut job, mut materials, mut lights) = (false, false, false);
    for (key, v) in changes {
        let key = key.as_str();
        let v = *v;
        match key {
            "camera.position" => desc.camera.position = vector(key, v)?,
            "camera.look_at" => desc.camera.look_at = vector(key, v)?,
            "camera.ref_up" => desc.camera.ref_up = vector(key, v)?,
            "camera.fov" => match v {
                ParamValue::Float(f) if f > 0.0 && f < 180.0 => desc.camera.fov = f,
                _ => return Err(format!("{key}: expected a number of degrees between 0 and 180")),
            },
            "film.resolution" => match v {
                ParamValue::Size(w, h) if w > 0 && h > 0 => (desc.film.width, desc.film.height) = (w, h),
                _ => return Err(format!("{key}: expected a width and a height of at least 1")),
            },
            "integrator.spp" => match v {
                ParamValue::Int(n) if n > 0 => desc.integrator.spp = n,
                _ => return Err(format!("{key}: expected a whole number of at least 1")),
            },
            _ => {
                if let Some(i) = desc.textures.iter().position(|t| key == format!("textures.{}.color", t.name)) {
                    if lights_copy(desc, &desc.textures[i].name) {
                        return Err(not_editable(key));
                    }
                    let Texture::Constant(c) = &mut desc.textures[i].texture else {
                        return Err(not_editable(key));
                    };
                    *c = colour(key, v, "a colour")?;
                    materials = true;
                    continue;
                }
                if let Some(j) = (0..desc.integrator.point_lights.len()).find(|j| key == format!("point_lights[{j}].flux")) {
                    desc.integrator.point_lights[j].flux = colour(key, v, "a flux")?;
                    lights = true;
                    continue;
                }
                if let Some(i) = (0..desc.objects.len()).find(|&i| key == area_key(desc, i)) {
                    match desc.objects[i].light.as_mut().filter(|l| l.texture.is_none()) {
                        Some(l) => l.radiance = colour(key, v, "a radiance")?,
                        None => return Err(not_editable(key)),
                    }
                    lights = true;
                    continue;
                }
                let found = desc.materials.iter_mut().find_map(|m| {
                    let rest = key.strip_prefix("materials.")?.strip_prefix(m.name.as_str())?.strip_prefix('.')?;
                    let mut fs = Vec::new();
                    fields(&mut m.material, "", &mut fs);
                    fs.into_iter().find(|(k, _)| k == rest).map(|(_, f)| f)
                });
                match found {
                    Some(Field::Colour(c)) => *c = colour(key, v, "a colour")?,
                    Some(Field::Roughness(a)) => match v {
                        ParamValue::Float(x) if x.is_finite() && x >= 0.0 => *a = x,
                        _ => return Err(format!("{key}: expected a roughness (a number, at least 0)")),
                    },
                    None => return Err(not_editable(key)),
                }
                materials = true;
                continue;
            }
        }
        job = true;
    }
    Ok((job, materials, lights))
}

/// Applies `changes` (all of them or, on an error naming the key, none) to a scene
/// loaded from `desc` in `profile`.
pub fn update(desc: &mut SceneDesc, loaded: &mut Loaded, profile: Profile, changes: &[(String, ParamValue)]) -> Result<(), String> {
    let mut edited = desc.clone();
    let (job, materials, lights) = edit_desc(&mut edited, changes)?;
    let new_job: Option<RenderJob> = match job {
        true => Some(RenderJob::from_desc(&edited, profile).map_err(|e| e.to_string())?),
        false => None,
    };
    let scene = &mut loaded.scene;
    if materials {
        for t in edited.textures.iter().enumerate() {
            if let (i, Texture::Constant(c)) = (t.0, &t.1.texture) {
                scene.textures[i] = Texture::Constant(*c);
            }
        }
        // each material again from its description, on the texture indices the build gave it
        for (m, built) in edited.materials.iter().zip(scene.materials.iter_mut()) {
            let mut indices = Vec::new();
            let _ = built.try_map_textures(|&t| {
                indices.push(t);
                Ok::<u32, ()>(t)
            });
            let mut next = indices.into_iter();
            let textures = &mut scene.textures;
            let rebuilt = m.material.try_map_textures(|r| {
                let t = next.next().ok_or(())?;
                if let TextureRef::Color(c) = r {
                    textures[t as usize] = Texture::Constant(*c);
                }
                Ok::<u32, ()>(t)
            });
            let Ok(mut rebuilt) = rebuilt else {
                return Err(format!("materials.{}: its textures changed shape (load the scene again)", m.name));
            };
            rebuilt.prepare(&|t: &u32| textures[*t as usize].mean());
            *built = rebuilt;
        }
    }
    if lights {
        for (j, l) in edited.integrator.point_lights.iter().enumerate() {
            if let Light::Point { flux, .. } = &mut scene.lights[j] {
                *flux = l.flux;
            }
        }
        for (o, object) in edited.objects.iter().zip(&scene.objects) {
            if let (Some(l), Some(i)) = (&o.light, object.light) {
                if let Light::Area(a) = &mut scene.lights[i as usize] {
                    if l.texture.is_none() {
                        a.radiance = l.radiance;
                    }
                }
            }
        }
        scene.light_sampler = LightSampler::new(&scene.lights, scene.radius, scene.light_sampling);
    }
    if let Some(j) = new_job {
        loaded.job = j;
    }
    *desc = edited;
    Ok(())
}
