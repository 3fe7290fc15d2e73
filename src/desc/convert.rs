//! `rdr convert`: a scene description written as RDR171 JSON or Mitsuba 3 XML, for
//! everything both can say, with a warning for what the target cannot. Point lights:
//! Mitsuba's intensity I is rdr's flux 4πI. Paths are rewritten relative to the output
//! file. JSON can only name OBJ files, so meshes it cannot say as they are (PLY,
//! serialized, generated rectangles and cubes, Mitsuba's smoothed normals) are
//! written as OBJ files beside the output (`<stem>_meshes/`).

use super::{MeshFile, MeshFormat, MeshNormals, MeshOptions, SceneDesc, TextureRef};
use crate::error::{Result, SceneError};
use crate::film::Filter;
use crate::geometry::obj::ObjData;
use crate::integrator::{bdpt::Heuristic, Integrator, PathProfile};
use crate::material::{Distribution, Material};
use crate::math::{Mat4, Vec2, Vec3};
use crate::scene::Shape;
use crate::texture::{Texture, UvMapping};
use serde_json::{json, Map, Value};
use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

/// A converted scene: its text, the extra files it refers to, and what could not be said.
pub struct Converted {
    pub text: String,
    pub files: Vec<(PathBuf, Vec<u8>)>,
    pub warnings: Vec<String>,
}

fn absolute(p: &Path) -> PathBuf {
    let p = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(p)
    };
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// `target` relative to the folder `from` (both made absolute), with `/` separators.
pub fn relative(target: &Path, from: &Path) -> String {
    let (t, f) = (absolute(target), absolute(from));
    let (tc, fc): (Vec<_>, Vec<_>) = (t.components().collect(), f.components().collect());
    let common = tc.iter().zip(&fc).take_while(|(a, b)| a == b).count();
    if common == 0 {
        return t.display().to_string();
    }
    let mut parts: Vec<String> = vec!["..".into(); fc.len() - common];
    parts.extend(tc[common..].iter().map(|c| c.as_os_str().to_string_lossy().into_owned()));
    parts.join("/")
}

fn out_dir(out: &Path) -> PathBuf {
    out.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf()
}

/// A file named in the description, relative to the output's folder.
fn rebase(desc: &SceneDesc, path: &str, out: &Path) -> String {
    relative(&desc.base_dir.join(path), &out_dir(out))
}

fn obj_has_normals(desc: &SceneDesc, file: &MeshFile) -> Result<bool> {
    let full = desc.base_dir.join(&file.path.value);
    let bytes = crate::limits::read_input_file(&full, crate::limits::max_input_file()).map_err(|e| {
        file.path
            .source
            .error(&desc.file, format!("cannot read mesh '{}': {e}", full.display()))
    })?;
    Ok(String::from_utf8_lossy(&bytes).lines().any(|l| l.trim_start().starts_with("vn ")))
}

fn num(x: f32) -> Value {
    // the shortest decimal that reads back as the same f32
    serde_json::from_str(&format!("{x}")).unwrap_or(Value::Null)
}

fn vec3(v: Vec3) -> Value {
    Value::Array(v.to_array().into_iter().map(num).collect())
}

fn vec2(v: Vec2) -> Value {
    Value::Array(v.to_array().into_iter().map(num).collect())
}

fn row_major(m: &Mat4) -> [f32; 16] {
    m.transpose().to_cols_array()
}

/// An OBJ file of a mesh's data (1-based indices, uv and normal per corner).
pub fn obj_text(d: &ObjData) -> String {
    let mut s = String::from("# written by rdr convert\n");
    for p in &d.positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for t in &d.uvs {
        let _ = writeln!(s, "vt {} {}", t.x, t.y);
    }
    for n in &d.normals {
        let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
    }
    for t in &d.triangles {
        s += "f";
        for c in 0..3 {
            let _ = match (t.uv, t.n) {
                (None, None) => write!(s, " {}", t.p[c] + 1),
                (Some(uv), None) => write!(s, " {}/{}", t.p[c] + 1, uv[c] + 1),
                (None, Some(n)) => write!(s, " {}//{}", t.p[c] + 1, n[c] + 1),
                (Some(uv), Some(n)) => write!(s, " {}/{}/{}", t.p[c] + 1, uv[c] + 1, n[c] + 1),
            };
        }
        s += "\n";
    }
    s
}

// ---------------------------------------------------------------------------
// → RDR171 JSON
// ---------------------------------------------------------------------------

/// The description as RDR171 JSON, for the file `out`.
/// Textured emitters (a spot's `texture`, a projector, an area light's radiance
/// texture) are not carried yet: an error naming the first, not a silently plain light.
fn refuse_textured_emitters(desc: &SceneDesc) -> Result<()> {
    if let Some(l) = desc.integrator.delta_lights.iter().find(|l| l.texture.is_some()) {
        return Err(SceneError::new(
            &desc.file,
            Some(&l.key),
            "rdr convert does not carry textured spot lights and projectors yet",
        ));
    }
    if let Some(t) = desc.objects.iter().find_map(|o| o.light.as_ref().and_then(|l| l.texture.as_ref())) {
        return Err(t
            .source
            .error(&desc.file, "rdr convert does not carry area lights with a radiance texture yet"));
    }
    Ok(())
}

pub fn to_json(desc: &SceneDesc, out: &Path) -> Result<Converted> {
    refuse_textured_emitters(desc)?;
    let mut warnings = Vec::new();
    let mut files = Vec::new();
    let d = &desc.integrator;
    let mut integ = Map::new();
    match d.integrator {
        Integrator::Path(p) => {
            integ.insert("type".into(), "path".into());
            integ.insert("max_depth".into(), p.max_depth.into());
            let profile = match p.profile {
                PathProfile::Mis => "MIS",
                PathProfile::NextEvent => "NEE",
                PathProfile::RandomWalk => "RW",
            };
            integ.insert("profile".into(), profile.into());
            integ.insert("rr_threshold".into(), num(p.rr_threshold));
        }
        Integrator::Bdpt(b) => {
            integ.insert("type".into(), "bdpt".into());
            integ.insert("max_depth".into(), b.max_depth.into());
            integ.insert("rr_threshold".into(), num(b.rr_threshold));
            integ.insert(
                "mis".into(),
                if b.heuristic == Heuristic::Balance { "balance" } else { "power" }.into(),
            );
            if let Some((s, t)) = b.strategy {
                integ.insert("strategy".into(), json!([s, t]));
                integ.insert("strategy_weighted".into(), b.strategy_weighted.into());
            }
            if b.visualize_strategies {
                integ.insert("visualize_strategies".into(), true.into());
            }
            if b.connection_roulette != crate::integrator::bdpt::CONNECTION_ROULETTE {
                integ.insert("connection_roulette".into(), num(b.connection_roulette));
            }
        }
        Integrator::Ptracer(p) => {
            integ.insert("type".into(), "ptracer".into());
            integ.insert("max_depth".into(), p.max_depth.into());
            integ.insert("rr_threshold".into(), num(p.rr_threshold));
        }
        Integrator::IntersectionTest(t) => {
            integ.insert("type".into(), "intersection_test".into());
            integ.insert("max_depth".into(), t.max_depth.into());
            integ.insert("light_samples".into(), t.light_samples.into());
        }
        Integrator::Photon(p) => {
            integ.insert("type".into(), "photon".into());
            integ.insert("n_photons".into(), p.n_photons.into());
            integ.insert("n_iterations".into(), p.n_iterations.into());
            integ.insert("n_near_photons".into(), p.n_near_photons.into());
            integ.insert("max_depth".into(), p.max_depth.into());
            integ.insert("rr_threshold".into(), num(p.rr_threshold));
        }
        Integrator::Sppm(p) => {
            integ.insert("type".into(), "sppm".into());
            integ.insert("photons_per_iteration".into(), p.photons_per_iteration.into());
            if let Some(r) = p.initial_radius {
                integ.insert("initial_radius".into(), num(r));
            }
            integ.insert("alpha".into(), num(p.alpha));
            integ.insert("max_depth".into(), p.max_depth.into());
            integ.insert("rr_threshold".into(), num(p.rr_threshold));
        }
        Integrator::Normals(_) => {
            integ.insert("type".into(), "normals".into());
        }
        Integrator::Guided(g) => {
            integ.insert("type".into(), "guided".into());
            integ.insert("max_depth".into(), g.max_depth.into());
            integ.insert("rr_threshold".into(), num(g.rr_threshold));
            integ.insert("bsdf_fraction".into(), num(g.bsdf_fraction));
            if let Some(n) = g.training_iterations {
                integ.insert("training_iterations".into(), n.into());
            }
            let combine = match g.combine {
                crate::integrator::guided::Combine::InverseVariance => "inverse_variance",
                crate::integrator::guided::Combine::Last => "last",
            };
            integ.insert("combine".into(), combine.into());
            integ.insert("spatial_threshold".into(), num(g.spatial_threshold));
            integ.insert("learn_direct".into(), g.learn_direct.into());
            integ.insert("learn_fraction".into(), g.learn_fraction.into());
            integ.insert("training_share".into(), num(g.training_share));
            integ.insert("min_gain".into(), num(g.min_gain));
            let learn_from = match g.learn_from {
                crate::integrator::guided::LearnFrom::Paths => "paths",
                crate::integrator::guided::LearnFrom::Photons => "photons",
            };
            integ.insert("learn_from".into(), learn_from.into());
        }
        Integrator::Rdr171(_) => unreachable!("a description never holds the compat integrator"),
    }
    integ.insert("spp".into(), d.spp.into());
    // an explicit list, so the format's default point light is not added
    let mut lights: Vec<Value> = d
        .point_lights
        .iter()
        .map(|l| json!({"type": "point", "position": vec3(l.position), "flux": vec3(l.flux)}))
        .collect();
    for l in &d.delta_lights {
        lights.push(match &l.light {
            crate::light::Light::Spot {
                position,
                axis,
                intensity,
                cutoff,
                beam_width,
            } => json!({
                "type": "spot", "position": vec3(*position), "direction": vec3(*axis), "intensity": vec3(*intensity),
                "cutoff_angle": num(cutoff.to_degrees()), "beam_width": num(beam_width.to_degrees()),
            }),
            crate::light::Light::Directional { direction, irradiance } => {
                json!({"type": "directional", "direction": vec3(*direction), "irradiance": vec3(*irradiance)})
            }
            _ => unreachable!("delta_lights holds spot and directional lights"),
        });
    }
    integ.insert("lights".into(), Value::Array(lights));
    if d.light_sampling == crate::light::LightSampling::Uniform {
        integ.insert("light_sampling".into(), "uniform".into());
    }
    let f = &desc.film;
    let filter = match f.filter {
        Filter::Box { radius } => json!({"type": "box", "radius": num(radius)}),
        Filter::Tent { radius } => json!({"type": "tent", "radius": num(radius)}),
        Filter::Gaussian { radius, alpha, .. } => json!({"type": "gaussian", "radius": num(radius), "alpha": num(alpha)}),
        Filter::Mitchell { radius, b, c } => json!({"type": "mitchell", "radius": num(radius), "B": num(b), "C": num(c)}),
    };
    let c = &desc.camera;
    let mut camera = json!({"position": vec3(c.position), "look_at": vec3(c.look_at), "ref_up": vec3(c.ref_up), "fov": num(c.fov), "focal_length": num(c.focal_length)});
    match c.projection {
        crate::camera::Projection::Pinhole => {}
        crate::camera::Projection::ThinLens {
            aperture_radius,
            focus_distance,
        } => {
            camera["type"] = "thinlens".into();
            camera["aperture_radius"] = num(aperture_radius);
            camera["focus_distance"] = num(focus_distance);
        }
        crate::camera::Projection::Orthographic { height } => {
            camera = json!({"type": "orthographic", "position": vec3(c.position), "look_at": vec3(c.look_at), "ref_up": vec3(c.ref_up), "height": num(height)});
        }
    }
    if c.near_clip != 0.0 {
        camera["near_clip"] = num(c.near_clip);
    }
    if c.far_clip != f32::INFINITY {
        camera["far_clip"] = num(c.far_clip);
    }
    let mut textures = Map::new();
    let mapping = |m: &UvMapping| json!({"type": "uvmapping2d", "scale": vec2(m.scale), "delta": vec2(m.delta)});
    for t in &desc.textures {
        let v = match &t.texture {
            Texture::Constant(c) => json!({"type": "constant", "color": vec3(*c)}),
            Texture::Checkerboard {
                color0,
                color1,
                mapping: m,
            } => {
                json!({"type": "checkerboard", "color0": vec3(*color0), "color1": vec3(*color1), "tex_coordinate_generator": mapping(m)})
            }
            Texture::Image(img) => {
                let mut v =
                    json!({"type": "image", "path": rebase(desc, &img.path.value, out), "tex_coordinate_generator": mapping(&img.mapping)});
                match img.filter {
                    crate::texture::image::ImageFilter::Trilinear => {}
                    crate::texture::image::ImageFilter::Bilinear => v["filter"] = "bilinear".into(),
                    crate::texture::image::ImageFilter::Nearest => v["filter"] = "nearest".into(),
                }
                if img.raw {
                    v["raw"] = true.into();
                }
                v
            }
            Texture::MeshAttribute { face, scale } => {
                json!({"type": "mesh_attribute", "name": if *face { "face_color" } else { "vertex_color" }, "scale": num(*scale)})
            }
        };
        textures.insert(t.name.clone(), v);
    }
    let texture_name = |r: &TextureRef, owner: &str, textures: &mut Map<String, Value>| -> String {
        match r {
            TextureRef::Named(n) => n.value.clone(),
            TextureRef::Color(c) => {
                let name = (0..)
                    .map(|i| {
                        if i == 0 {
                            format!("{owner}_color")
                        } else {
                            format!("{owner}_color_{i}")
                        }
                    })
                    .find(|n| !textures.contains_key(n))
                    .expect("a free name");
                textures.insert(name.clone(), json!({"type": "constant", "color": vec3(*c)}));
                name
            }
        }
    };
    let mut materials = Map::new();
    for m in &desc.materials {
        let v = material_json(&m.material, &m.name, &mut textures, &mut materials, &texture_name);
        materials.insert(m.name.clone(), v);
    }
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let mut objects = Vec::new();
    let mut groups: Vec<Vec<Value>> = vec![Vec::new(); desc.shapegroups.len()];
    // the scene's objects, then each group's members (their meshes' files named by group)
    let entries =
        desc.objects
            .iter()
            .enumerate()
            .map(|(i, o)| (i.to_string(), o, None))
            .chain(desc.shapegroups.iter().enumerate().flat_map(|(g, gd)| {
                gd.objects
                    .iter()
                    .enumerate()
                    .map(move |(j, o)| (format!("group{g}_{j}"), o, Some(g)))
            }));
    for (i, o, group) in entries {
        let mut v = match &o.shape {
            Shape::Sphere(s) => {
                let mut v = json!({"type": "sphere", "center": vec3(s.center), "radius": num(s.radius)});
                if let Some(q) = s.uv_frame {
                    let m = glam::Mat3::from_quat(glam::Quat::from_array(q)).transpose().to_cols_array();
                    v["uv_frame"] = Value::Array(m.iter().map(|x| num(*x)).collect());
                }
                v
            }
            Shape::Cylinder(c) => {
                let (p0, p1, r, m) = cylinder_params(c);
                let mut v = json!({"type": "cylinder", "p0": vec3(p0), "p1": vec3(p1), "radius": num(r)});
                if let Some(m) = m {
                    v["transform"] = Value::Array(row_major(&m).into_iter().map(num).collect());
                }
                if c.flip_normals {
                    v["flip_normals"] = true.into();
                }
                v
            }
            Shape::Mesh(m) => {
                let as_is = match (&m.options.format, m.options.normals, m.options.flip_normals, m.options.flip_uv) {
                    (MeshFormat::Obj, MeshNormals::AsInFile, false, false) => true,
                    (MeshFormat::Obj, MeshNormals::Face, false, false) => !obj_has_normals(desc, m)?,
                    (MeshFormat::Obj, MeshNormals::SmoothWhenMissing, false, false) => obj_has_normals(desc, m)?,
                    _ => false,
                };
                let path = if as_is {
                    rebase(desc, &m.path.value, out)
                } else {
                    let data = super::build::mesh_data(desc, m)?;
                    let name = format!("{stem}_meshes/{i}.obj");
                    files.push((out_dir(out).join(&name), obj_text(&data).into_bytes()));
                    name
                };
                let mut v = json!({"type": "mesh", "path": path});
                if m.transform != Mat4::IDENTITY {
                    v["transform"] = Value::Array(row_major(&m.transform).into_iter().map(num).collect());
                }
                if m.translate != Vec3::ZERO {
                    v["translate"] = vec3(m.translate);
                }
                v
            }
        };
        if let Some(mat) = &o.material {
            v["material_name"] = mat.value.clone().into();
        }
        if let Some(l) = &o.light {
            v["light"] = json!({"type": "area", "radiance": vec3(l.radiance)});
        }
        match group {
            None => objects.push(v),
            Some(g) => groups[g].push(v),
        }
    }
    for inst in &desc.instances {
        let mut v = json!({"type": "instance", "shapegroup": inst.shapegroup.value.clone()});
        if inst.transform != Mat4::IDENTITY {
            v["transform"] = Value::Array(row_major(&inst.transform).into_iter().map(num).collect());
        }
        objects.push(v);
    }
    let mut root = json!({
        "integrator": Value::Object(integ),
        "film": {"resolution": [f.width, f.height], "block_side_length": f.block_size, "filter": filter},
        "camera": camera,
        "textures": Value::Object(textures),
        "materials": Value::Object(materials),
        "objects": objects,
    });
    if !desc.shapegroups.is_empty() {
        let g: Map<String, Value> = desc
            .shapegroups
            .iter()
            .zip(groups)
            .map(|(d, objects)| (d.name.clone(), json!({ "objects": objects })))
            .collect();
        root["shapegroups"] = Value::Object(g);
    }
    if let Some(e) = &desc.environment_map {
        let mut env = json!({"texture_name": e.texture.value.clone(), "scale": num(e.scale)});
        if e.transform != Mat4::IDENTITY {
            env["transform"] = Value::Array(row_major(&e.transform).into_iter().map(num).collect());
        }
        root["environment_map"] = env;
    }
    if desc.materials.iter().any(|m| m.name == "__default_diffuse") {
        warnings.push("a shape without a material got Mitsuba's default diffuse 0.5 ('__default_diffuse')".into());
    }
    let text = serde_json::to_string_pretty(&root).expect("a JSON value prints") + "\n";
    for n in &desc.convert_notes {
        if !warnings.contains(n) {
            warnings.push(n.clone());
        }
    }
    Ok(Converted { text, files, warnings })
}

// ---------------------------------------------------------------------------
// → Mitsuba 3 XML
// ---------------------------------------------------------------------------

fn distribution_name(d: Distribution) -> &'static str {
    if d == Distribution::Ggx {
        "ggx"
    } else {
        "beckmann"
    }
}

/// Names the texture of a reference (inline colours get a constant texture of their own).
type TextureNamer = dyn Fn(&TextureRef, &str, &mut Map<String, Value>) -> String;

/// A material as RDR171 JSON; a `twosided`'s inner materials (inline in XML) become
/// materials of their own, `<name>_front` and `<name>_back`.
fn material_json(
    m: &Material<TextureRef>,
    name: &str,
    textures: &mut Map<String, Value>,
    materials: &mut Map<String, Value>,
    texture_name: &TextureNamer,
) -> Value {
    match m {
        Material::Diffuse { texture, twosided } => {
            json!({"type": "diffuse", "texture_name": texture_name(texture, name, textures), "twosided": twosided})
        }
        Material::Refraction { eta } => json!({"type": "refraction", "eta": num(*eta)}),
        Material::Glass { reflect, transmit, eta } => {
            json!({"type": "glass", "R": vec3(*reflect), "T": vec3(*transmit), "eta": num(*eta)})
        }
        Material::RoughConductor {
            texture,
            eta_i,
            eta_t,
            k,
            alpha_x,
            alpha_y,
            distribution,
            twosided,
        } => {
            let mut v = json!({
                "type": "roughconductor",
                "texture_name": texture_name(texture, name, textures),
                "etaI": vec3(*eta_i), "etaT": vec3(*eta_t), "k": vec3(*k),
                "alpha_x": num(*alpha_x), "alpha_y": num(*alpha_y),
                "distribution": distribution_name(*distribution),
            });
            if !twosided {
                v["twosided"] = json!(false);
            }
            v
        }
        Material::Conductor { texture, eta, k } => json!({
            "type": "conductor", "texture_name": texture_name(texture, name, textures), "eta": vec3(*eta), "k": vec3(*k),
        }),
        Material::ThinDielectric { reflect, transmit, eta } => {
            json!({"type": "thindielectric", "R": vec3(*reflect), "T": vec3(*transmit), "eta": num(*eta)})
        }
        Material::RoughDielectric {
            reflect,
            transmit,
            eta,
            alpha_x,
            alpha_y,
            distribution,
        } => json!({
            "type": "roughdielectric", "R": vec3(*reflect), "T": vec3(*transmit), "eta": num(*eta),
            "alpha_x": num(*alpha_x), "alpha_y": num(*alpha_y), "distribution": distribution_name(*distribution),
        }),
        Material::Plastic {
            texture,
            specular,
            eta,
            nonlinear,
            ..
        } => json!({
            "type": "plastic", "texture_name": texture_name(texture, name, textures),
            "specular_reflectance": vec3(*specular), "eta": num(*eta), "nonlinear": nonlinear,
        }),
        Material::RoughPlastic {
            texture,
            specular,
            eta,
            nonlinear,
            alpha,
            distribution,
            ..
        } => json!({
            "type": "roughplastic", "texture_name": texture_name(texture, name, textures),
            "specular_reflectance": vec3(*specular), "eta": num(*eta), "nonlinear": nonlinear,
            "alpha": num(*alpha), "distribution": distribution_name(*distribution),
        }),
        Material::TwoSided { front, back } => {
            let mut v = json!({"type": "twosided", "material_name": nested_json(front, name, "front", textures, materials, texture_name)});
            if let Some(b) = back {
                v["back_material_name"] = nested_json(b, name, "back", textures, materials, texture_name).into();
            }
            v
        }
        Material::BumpMap {
            height,
            scale,
            options,
            inner,
        } => {
            let inner = nested_json(inner, name, "inner", textures, materials, texture_name);
            let mut v = json!({"type": "bumpmap", "material_name": inner, "texture_name": texture_name(height, name, textures),
                               "scale": num(*scale)});
            perturb_json(&mut v, options);
            v
        }
        Material::NormalMap { normals, options, inner } => {
            let inner = nested_json(inner, name, "inner", textures, materials, texture_name);
            let mut v = json!({"type": "normalmap", "material_name": inner, "texture_name": texture_name(normals, name, textures)});
            perturb_json(&mut v, options);
            v
        }
        Material::Mask { opacity, inner } => {
            let inner = nested_json(inner, name, "inner", textures, materials, texture_name);
            match opacity {
                TextureRef::Color(c) if c.x == c.y && c.y == c.z => json!({"type": "mask", "material_name": inner, "opacity": num(c.x)}),
                t => json!({"type": "mask", "material_name": inner, "texture_name": texture_name(t, name, textures)}),
            }
        }
        Material::Principled(p) => super::principled::to_json(p),
        Material::PrincipledThin(p) => super::principled::thin_to_json(p),
        Material::BlendBsdf { weight, first, second } => {
            let names = [
                nested_json(first, name, "0", textures, materials, texture_name),
                nested_json(second, name, "1", textures, materials, texture_name),
            ];
            let weight = match weight {
                TextureRef::Named(n) => Value::String(n.value.clone()),
                TextureRef::Color(c) => num(c.x),
            };
            json!({"type": "blendbsdf", "weight": weight, "material_names": names})
        }
    }
}

/// A material another names (the side of a `twosided`, what a bump map, normal map
/// or mask wraps, a half of a `blendbsdf`), as a material of its own under the first
/// free name `<name>_<suffix>[_i]`; that name.
fn nested_json(
    m: &Material<TextureRef>,
    name: &str,
    suffix: &str,
    textures: &mut Map<String, Value>,
    materials: &mut Map<String, Value>,
    texture_name: &TextureNamer,
) -> String {
    let n = (0..)
        .map(|i| {
            if i == 0 {
                format!("{name}_{suffix}")
            } else {
                format!("{name}_{suffix}_{i}")
            }
        })
        .find(|n| !materials.contains_key(n))
        .expect("a free name");
    let v = material_json(m, &n, textures, materials, texture_name);
    materials.insert(n.clone(), v);
    n
}

/// The bump and normal maps' switches, when not their defaults.
fn perturb_json(v: &mut Value, o: &crate::material::bump::PerturbOptions) {
    if !o.flip_invalid_normals {
        v["flip_invalid_normals"] = false.into();
    }
    if !o.use_shadowing_function {
        v["use_shadowing_function"] = false.into();
    }
}

/// A material as a Mitsuba `<bsdf>` (with `id` when given; nested ones have none).
fn material_xml(
    m: &Material<TextureRef>,
    name: &str,
    id: Option<&str>,
    colour: &dyn Fn(&str, &TextureRef) -> String,
    w: &mut Vec<String>,
) -> String {
    let open = |ty: &str| match id {
        Some(id) => format!("<bsdf type=\"{ty}\" id=\"{}\">", esc(id)),
        None => format!("<bsdf type=\"{ty}\">"),
    };
    let rgb_unless_one = |key: &str, v: Vec3| {
        if v == Vec3::ONE {
            String::new()
        } else {
            format!("<rgb name=\"{key}\" value=\"{}\"/>", v3(v))
        }
    };
    let iors = |eta: f32| format!("<float name=\"int_ior\" value=\"{eta}\"/><float name=\"ext_ior\" value=\"1\"/>");
    let alphas = |ax: f32, ay: f32, d: Distribution| {
        let a = if ax == ay {
            format!("<float name=\"alpha\" value=\"{ax}\"/>")
        } else {
            format!("<float name=\"alpha_u\" value=\"{ax}\"/><float name=\"alpha_v\" value=\"{ay}\"/>")
        };
        format!("{a}<string name=\"distribution\" value=\"{}\"/>", distribution_name(d))
    };
    match m {
        Material::Diffuse { texture, twosided } => {
            if *twosided {
                format!(
                    "{}<bsdf type=\"diffuse\">{}</bsdf></bsdf>",
                    open("twosided"),
                    colour("reflectance", texture)
                )
            } else {
                format!("{}{}</bsdf>", open("diffuse"), colour("reflectance", texture))
            }
        }
        Material::Refraction { eta } => {
            w.push(format!(
                "material '{name}': perfect refraction without Fresnel has no Mitsuba counterpart: written as a dielectric"
            ));
            format!("{}{}</bsdf>", open("dielectric"), iors(*eta))
        }
        Material::Glass { reflect, transmit, eta } => format!(
            "{}{}{}{}</bsdf>",
            open("dielectric"),
            iors(*eta),
            rgb_unless_one("specular_reflectance", *reflect),
            rgb_unless_one("specular_transmittance", *transmit)
        ),
        Material::RoughConductor {
            texture,
            eta_i,
            eta_t,
            k,
            alpha_x,
            alpha_y,
            distribution,
            twosided,
        } => {
            // rdr's roughconductor reflects on both sides unless `twosided` is false,
            // Mitsuba's on the front only: a two-sided one is wrapped in a twosided
            // (unless it is one side of a twosided already), a one-sided one bare
            let wrap = *twosided && id.is_some();
            let bsdf = format!(
                "{}{}<rgb name=\"eta\" value=\"{}\"/><rgb name=\"k\" value=\"{}\"/>{}</bsdf>",
                if wrap {
                    "<bsdf type=\"roughconductor\">".to_string()
                } else {
                    open("roughconductor")
                },
                alphas(*alpha_x, *alpha_y, *distribution),
                v3(*eta_t / *eta_i),
                v3(*k / *eta_i),
                colour("specular_reflectance", texture)
            );
            if wrap {
                format!("{}{bsdf}</bsdf>", open("twosided"))
            } else {
                bsdf
            }
        }
        Material::Conductor { texture, eta, k } => format!(
            "{}<rgb name=\"eta\" value=\"{}\"/><rgb name=\"k\" value=\"{}\"/>{}</bsdf>",
            open("conductor"),
            v3(*eta),
            v3(*k),
            colour("specular_reflectance", texture)
        ),
        Material::ThinDielectric { reflect, transmit, eta } => format!(
            "{}{}{}{}</bsdf>",
            open("thindielectric"),
            iors(*eta),
            rgb_unless_one("specular_reflectance", *reflect),
            rgb_unless_one("specular_transmittance", *transmit)
        ),
        Material::RoughDielectric {
            reflect,
            transmit,
            eta,
            alpha_x,
            alpha_y,
            distribution,
        } => format!(
            "{}{}{}{}{}</bsdf>",
            open("roughdielectric"),
            alphas(*alpha_x, *alpha_y, *distribution),
            iors(*eta),
            rgb_unless_one("specular_reflectance", *reflect),
            rgb_unless_one("specular_transmittance", *transmit)
        ),
        Material::Plastic {
            texture,
            specular,
            eta,
            nonlinear,
            ..
        } => format!(
            "{}{}{}{}<boolean name=\"nonlinear\" value=\"{nonlinear}\"/></bsdf>",
            open("plastic"),
            colour("diffuse_reflectance", texture),
            rgb_unless_one("specular_reflectance", *specular),
            iors(*eta)
        ),
        Material::RoughPlastic {
            texture,
            specular,
            eta,
            nonlinear,
            alpha,
            distribution,
            ..
        } => format!(
            "{}{}{}{}{}<boolean name=\"nonlinear\" value=\"{nonlinear}\"/></bsdf>",
            open("roughplastic"),
            alphas(*alpha, *alpha, *distribution),
            colour("diffuse_reflectance", texture),
            rgb_unless_one("specular_reflectance", *specular),
            iors(*eta)
        ),
        Material::TwoSided { front, back } => {
            let mut inner = material_xml(front, name, None, colour, w);
            if let Some(b) = back {
                inner += &material_xml(b, name, None, colour, w);
            }
            format!("{}{inner}</bsdf>", open("twosided"))
        }
        Material::BumpMap {
            height,
            scale,
            options,
            inner,
        } => format!(
            "{}{}<float name=\"scale\" value=\"{scale}\"/>{}{}</bsdf>",
            open("bumpmap"),
            colour("height", height),
            perturb_xml(options),
            material_xml(inner, name, None, colour, w)
        ),
        Material::NormalMap { normals, options, inner } => format!(
            "{}{}{}{}</bsdf>",
            open("normalmap"),
            colour("normalmap", normals),
            perturb_xml(options),
            material_xml(inner, name, None, colour, w)
        ),
        Material::Mask { opacity, inner } => {
            let o = match opacity {
                TextureRef::Color(c) if c.x == c.y && c.y == c.z => format!("<float name=\"opacity\" value=\"{}\"/>", c.x),
                t => colour("opacity", t),
            };
            format!("{}{o}{}</bsdf>", open("mask"), material_xml(inner, name, None, colour, w))
        }
        Material::Principled(p) => format!("{}{}</bsdf>", open("principled"), super::principled::xml_properties(p, colour)),
        Material::PrincipledThin(p) => format!(
            "{}{}</bsdf>",
            open("principledthin"),
            super::principled::thin_xml_properties(p, colour)
        ),
        Material::BlendBsdf { weight, first, second } => format!(
            "{}{}{}{}</bsdf>",
            open("blendbsdf"),
            super::principled::xml_property("weight", weight, false, colour),
            material_xml(first, name, None, colour, w),
            material_xml(second, name, None, colour, w)
        ),
    }
}

/// A cylinder as Mitsuba's parameters: `p0`, `p1`, `radius` and, when its `u = 0`
/// direction is not the one Mitsuba's frame of the axis gives, a `to_world` that
/// places the unit cylinder ((0,0,0)–(0,0,1), radius 1) exactly.
fn cylinder_params(c: &crate::geometry::cylinder::CylinderShape) -> (Vec3, Vec3, f32, Option<Mat4>) {
    let c = &c.cylinder;
    let (x, _) = crate::geometry::cylinder::mitsuba_frame(c.axis.normalize());
    if (x - c.x).length() < 1e-6 {
        return (c.p0, c.p0 + c.axis, c.radius, None);
    }
    let (_, y) = c.frame();
    let m = Mat4::from_cols(
        (c.x * c.radius).extend(0.0),
        (y * c.radius).extend(0.0),
        c.axis.extend(0.0),
        c.p0.extend(1.0),
    );
    (Vec3::ZERO, Vec3::Z, 1.0, Some(m))
}

/// A perspective or thin-lens sensor's field of view, vertical as rdr's.
fn fov_keys(fov: f32) -> String {
    format!("    <float name=\"fov\" value=\"{fov}\"/>\n    <string name=\"fov_axis\" value=\"y\"/>\n")
}

/// The bump and normal maps' switches, when not their defaults.
fn perturb_xml(o: &crate::material::bump::PerturbOptions) -> String {
    let mut s = String::new();
    if !o.flip_invalid_normals {
        s += "<boolean name=\"flip_invalid_normals\" value=\"false\"/>";
    }
    if !o.use_shadowing_function {
        s += "<boolean name=\"use_shadowing_function\" value=\"false\"/>";
    }
    s
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

fn v3(v: Vec3) -> String {
    format!("{}, {}, {}", v.x, v.y, v.z)
}

fn matrix(m: &Mat4) -> String {
    row_major(m).iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(" ")
}

/// The description as Mitsuba 3 XML, for the file `out`.
pub fn to_xml(desc: &SceneDesc, out: &Path) -> Result<Converted> {
    refuse_textured_emitters(desc)?;
    let mut w = Vec::new();
    let mut s = String::new();
    let _ = writeln!(s, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    let _ = writeln!(
        s,
        "<!-- converted by rdr from {} -->",
        esc(&desc.file.display().to_string()).replace("--", "- -")
    );
    s += "<scene version=\"3.0.0\">\n";
    let has_glass = desc
        .materials
        .iter()
        .any(|m| matches!(m.material, Material::Glass { .. } | Material::Refraction { .. }));
    let depth = |d: u32| format!("    <integer name=\"max_depth\" value=\"{d}\"/>\n");
    s += &match desc.integrator.integrator {
        Integrator::Path(p) => {
            if p.profile != PathProfile::Mis {
                w.push("the path profile (NEE/RW) has no Mitsuba counterpart: written as path (the same converged image)".into());
            }
            format!("  <integrator type=\"path\">\n{}  </integrator>\n", depth(p.max_depth))
        }
        Integrator::IntersectionTest(t) => {
            if has_glass {
                w.push("intersection_test follows perfect refraction to the first diffuse surface; Mitsuba's direct does not".into());
            }
            if t.max_depth < 2 {
                w.push("intersection_test with max_depth 1 written as direct".into());
            }
            let n = t.light_samples;
            format!("  <integrator type=\"direct\">\n    <integer name=\"emitter_samples\" value=\"{n}\"/>\n    <integer name=\"bsdf_samples\" value=\"{n}\"/>\n  </integrator>\n")
        }
        Integrator::Bdpt(b) => {
            if b.strategy.is_some()
                || b.visualize_strategies
                || b.heuristic != Heuristic::Power
                || b.connection_roulette != crate::integrator::bdpt::CONNECTION_ROULETTE
            {
                w.push("bdpt's mis/strategy/connection_roulette options have no Mitsuba counterpart".into());
            }
            format!("  <integrator type=\"bdpt\">\n{}  </integrator>\n", depth(b.max_depth))
        }
        Integrator::Ptracer(p) => format!("  <integrator type=\"ptracer\">\n{}  </integrator>\n", depth(p.max_depth)),
        Integrator::Photon(p) => {
            w.push("Mitsuba 3 has no photon mapper: written as Mitsuba 0.6's photonmapper".into());
            format!(
                "  <integrator type=\"photonmapper\">\n{}    <integer name=\"global_photons\" value=\"{}\"/>\n    <integer name=\"lookup_size\" value=\"{}\"/>\n  </integrator>\n",
                depth(p.max_depth),
                p.n_photons,
                p.n_near_photons
            )
        }
        Integrator::Sppm(p) => {
            w.push("Mitsuba 3 has no sppm: written as Mitsuba 0.6's sppm".into());
            format!(
                "  <integrator type=\"sppm\">\n{}    <integer name=\"photon_count\" value=\"{}\"/>\n    <float name=\"alpha\" value=\"{}\"/>\n  </integrator>\n",
                depth(p.max_depth),
                p.photons_per_iteration,
                p.alpha
            )
        }
        Integrator::Normals(_) => {
            w.push("the normals view has no Mitsuba counterpart: written as path".into());
            "  <integrator type=\"path\"/>\n".to_string()
        }
        Integrator::Guided(g) => {
            w.push("Mitsuba 3 has no path guiding: guided written as path (the same converged image)".into());
            format!("  <integrator type=\"path\">\n{}  </integrator>\n", depth(g.max_depth))
        }
        Integrator::Rdr171(_) => unreachable!("a description never holds the compat integrator"),
    };
    let c = &desc.camera;
    let f = &desc.film;
    let filter = match f.filter {
        Filter::Box { radius } => format!("<rfilter type=\"box\"><float name=\"radius\" value=\"{radius}\"/></rfilter>"),
        Filter::Tent { radius } => format!("<rfilter type=\"tent\"><float name=\"radius\" value=\"{radius}\"/></rfilter>"),
        Filter::Gaussian { radius, alpha, .. } => {
            let sd = (1.0 / (2.0 * alpha)).sqrt();
            if (radius - 4.0 * sd).abs() > 1e-3 * radius {
                w.push(format!(
                    "Mitsuba cuts its gaussian at 4 standard deviations ({}), not at the radius {radius}",
                    4.0 * sd
                ));
            }
            format!("<rfilter type=\"gaussian\"><float name=\"stddev\" value=\"{sd}\"/></rfilter>")
        }
        Filter::Mitchell { radius, b, c } => {
            if radius != 2.0 {
                w.push(format!("Mitsuba's mitchell filter has radius 2, not {radius}"));
            }
            format!("<rfilter type=\"mitchell\"><float name=\"B\" value=\"{b}\"/><float name=\"C\" value=\"{c}\"/></rfilter>")
        }
    };
    // the sensor's own keys, and a scale before the lookat (an orthographic window)
    let (sensor, keys, scale) = match c.projection {
        crate::camera::Projection::Pinhole => ("perspective", fov_keys(c.fov), String::new()),
        crate::camera::Projection::ThinLens {
            aperture_radius,
            focus_distance,
        } => (
            "thinlens",
            format!(
                "{}    <float name=\"aperture_radius\" value=\"{aperture_radius}\"/>\n    <float name=\"focus_distance\" value=\"{focus_distance}\"/>\n",
                fov_keys(c.fov)
            ),
            String::new(),
        ),
        // Mitsuba's window is 2s wide and 2s·h/w tall
        crate::camera::Projection::Orthographic { height } => (
            "orthographic",
            String::new(),
            format!(
                "      <scale x=\"{0}\" y=\"{0}\"/>\n",
                height * f.width as f32 / (2.0 * f.height as f32)
            ),
        ),
    };
    // rdr's unbounded range is Mitsuba's default (0.01, 10⁴) when left out
    let mut keys = keys;
    if c.near_clip != 0.0 {
        let _ = writeln!(keys, "    <float name=\"near_clip\" value=\"{}\"/>", c.near_clip);
    }
    if c.far_clip != f32::INFINITY {
        let _ = writeln!(keys, "    <float name=\"far_clip\" value=\"{}\"/>", c.far_clip);
    }
    let _ = write!(
        s,
        "  <sensor type=\"{sensor}\">\n{keys}    <transform name=\"to_world\">\n{scale}      <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n    </transform>\n    <film type=\"hdrfilm\">\n      <integer name=\"width\" value=\"{}\"/>\n      <integer name=\"height\" value=\"{}\"/>\n      <string name=\"pixel_format\" value=\"rgb\"/>\n      {filter}\n    </film>\n    <sampler type=\"independent\">\n      <integer name=\"sample_count\" value=\"{}\"/>\n    </sampler>\n  </sensor>\n",
        v3(c.position),
        v3(c.look_at),
        v3(c.ref_up),
        f.width,
        f.height,
        desc.integrator.spp
    );
    // ids are shared by textures and materials in XML
    let mut ids: Vec<String> = Vec::new();
    let mut id_for = |name: &str, prefix: &str| -> String {
        let id = if ids.iter().any(|i| i == name) {
            format!("{prefix}{name}")
        } else {
            name.to_string()
        };
        ids.push(id.clone());
        id
    };
    let mut texture_ids = std::collections::HashMap::new();
    // checkerboards' twins for float parameters
    let mut float_ids = std::collections::HashMap::new();
    // Mitsuba's v runs the other way (see the XML reader): inverse of its to_uv rewrite
    let to_uv = |scale: Vec2, delta: Vec2| {
        format!(
            "<transform name=\"to_uv\"><scale x=\"{}\" y=\"{}\"/><translate x=\"{}\" y=\"{}\"/></transform>",
            scale.x, scale.y, delta.x, delta.y
        )
    };
    for t in &desc.textures {
        match &t.texture {
            Texture::Constant(_) => {}
            Texture::Checkerboard { color0, color1, mapping } => {
                let id = id_for(&t.name, "texture-");
                let (sm, om) = (
                    Vec2::new(mapping.scale.x, -mapping.scale.y),
                    Vec2::new(mapping.delta.x, mapping.delta.y + mapping.scale.y),
                );
                let _ = writeln!(
                    s,
                    "  <texture type=\"checkerboard\" id=\"{}\">\n    <rgb name=\"color0\" value=\"{}\"/>\n    <rgb name=\"color1\" value=\"{}\"/>\n    {}\n  </texture>",
                    esc(&id),
                    v3(*color0),
                    v3(*color1),
                    to_uv(sm, om)
                );
                // its twin for float parameters, whose checkerboard (Mitsuba's `eval_1`)
                // has the colours the other way round (see the XML reader)
                let twin = id_for(&format!("{id}-as-float"), "texture-");
                let _ = writeln!(
                    s,
                    "  <texture type=\"checkerboard\" id=\"{}\">\n    <rgb name=\"color0\" value=\"{}\"/>\n    <rgb name=\"color1\" value=\"{}\"/>\n    {}\n  </texture>",
                    esc(&twin),
                    v3(*color1),
                    v3(*color0),
                    to_uv(sm, om)
                );
                float_ids.insert(t.name.clone(), twin);
                texture_ids.insert(t.name.clone(), id);
            }
            Texture::MeshAttribute { face, scale } => {
                let id = id_for(&t.name, "texture-");
                let _ = writeln!(
                    s,
                    "  <texture type=\"mesh_attribute\" id=\"{}\">\n    <string name=\"name\" value=\"{}\"/>\n    <float name=\"scale\" value=\"{scale}\"/>\n  </texture>",
                    esc(&id),
                    if *face { "face_color" } else { "vertex_color" }
                );
                texture_ids.insert(t.name.clone(), id);
            }
            Texture::Image(img) => {
                if desc.environment_map.as_ref().is_some_and(|e| e.texture.value == t.name) {
                    continue; // written as the envmap's own file
                }
                let id = id_for(&t.name, "texture-");
                let m = img.mapping;
                let (sm, om) = (m.scale, Vec2::new(m.delta.x, 1.0 - m.scale.y - m.delta.y));
                let filter = match img.filter {
                    crate::texture::image::ImageFilter::Trilinear => {
                        w.push(format!(
                            "texture '{}': Mitsuba has no MIP maps: the trilinear filter is written as bilinear",
                            t.name
                        ));
                        "bilinear"
                    }
                    crate::texture::image::ImageFilter::Bilinear => "bilinear",
                    crate::texture::image::ImageFilter::Nearest => "nearest",
                };
                let _ = writeln!(
                    s,
                    "  <texture type=\"bitmap\" id=\"{}\">\n    <string name=\"filename\" value=\"{}\"/>\n    <string name=\"filter_type\" value=\"{filter}\"/>\n    <boolean name=\"raw\" value=\"{}\"/>\n    {}\n  </texture>",
                    esc(&id),
                    esc(&rebase(desc, &img.path.value, out)),
                    img.raw,
                    to_uv(sm, om)
                );
                texture_ids.insert(t.name.clone(), id);
            }
        }
    }
    let colour = |name: &str, r: &TextureRef| -> String {
        // parameters Mitsuba reads as colours (and bump heights, whose checkerboard has
        // no gradient); the others as floats (`eval_1`)
        const COLOURS: [&str; 7] = [
            "reflectance",
            "specular_reflectance",
            "diffuse_reflectance",
            "specular_transmittance",
            "base_color",
            "normalmap",
            "height",
        ];
        match r {
            TextureRef::Color(c) => format!("<rgb name=\"{name}\" value=\"{}\"/>", v3(*c)),
            TextureRef::Named(n) => match texture_ids.get(&n.value) {
                Some(_) if !COLOURS.contains(&name) && float_ids.contains_key(&n.value) => {
                    format!("<ref name=\"{name}\" id=\"{}\"/>", esc(&float_ids[&n.value]))
                }
                Some(id) => format!("<ref name=\"{name}\" id=\"{}\"/>", esc(id)),
                None => match desc.textures.iter().find(|t| t.name == n.value).map(|t| &t.texture) {
                    Some(Texture::Constant(c)) => format!("<rgb name=\"{name}\" value=\"{}\"/>", v3(*c)),
                    _ => format!("<!-- texture '{}' cannot be said here -->", esc(&n.value)),
                },
            },
        }
    };
    let mut material_ids = std::collections::HashMap::new();
    for m in &desc.materials {
        let id = id_for(&m.name, "bsdf-");
        let body = format!("  {}", material_xml(&m.material, &m.name, Some(&id), &colour, &mut w));
        s += &body;
        s += "\n";
        material_ids.insert(m.name.clone(), id);
    }
    // shape groups first (instances refer to them), their members indented one more step
    let group_ids: Vec<String> = desc.shapegroups.iter().map(|g| id_for(&g.name, "group-")).collect();
    let entries = desc
        .shapegroups
        .iter()
        .enumerate()
        .flat_map(|(g, gd)| gd.objects.iter().enumerate().map(move |(j, o)| (o, Some((g, j, gd)))))
        .chain(desc.objects.iter().map(|o| (o, None)));
    for (o, group) in entries {
        if let Some((g, 0, _)) = group {
            let _ = writeln!(s, "  <shape type=\"shapegroup\" id=\"{}\">", esc(&group_ids[g]));
        }
        let mut inner = String::new();
        let head = match &o.shape {
            Shape::Sphere(sp) => match sp.uv_frame {
                // the rotation carries Mitsuba's parameterisation
                Some(q) => {
                    let m = glam::Mat4::from_scale_rotation_translation(Vec3::splat(sp.radius), glam::Quat::from_array(q), sp.center);
                    let rows = m.transpose().to_cols_array();
                    format!(
                        "  <shape type=\"sphere\">\n    <transform name=\"to_world\"><matrix value=\"{}\"/></transform>\n",
                        rows.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" ")
                    )
                }
                None => format!(
                    "  <shape type=\"sphere\">\n    <point name=\"center\" value=\"{}\"/>\n    <float name=\"radius\" value=\"{}\"/>\n",
                    v3(sp.center),
                    sp.radius
                ),
            },
            Shape::Cylinder(c) => {
                let (p0, p1, r, m) = cylinder_params(c);
                let mut h = format!(
                    "  <shape type=\"cylinder\">\n    <point name=\"p0\" value=\"{}\"/>\n    <point name=\"p1\" value=\"{}\"/>\n    <float name=\"radius\" value=\"{}\"/>\n",
                    v3(p0),
                    v3(p1),
                    r
                );
                if c.flip_normals {
                    h += "    <boolean name=\"flip_normals\" value=\"true\"/>\n";
                }
                if let Some(m) = m {
                    let _ = writeln!(h, "    <transform name=\"to_world\"><matrix value=\"{}\"/></transform>", matrix(&m));
                }
                h
            }
            Shape::Mesh(m) => {
                let MeshOptions {
                    format,
                    normals,
                    flip_normals,
                    flip_uv,
                } = &m.options;
                let (ty, file) = match format {
                    MeshFormat::Obj => ("obj", true),
                    MeshFormat::Ply => ("ply", true),
                    MeshFormat::Serialized { .. } => ("serialized", true),
                    MeshFormat::Rectangle => ("rectangle", false),
                    MeshFormat::Cube => ("cube", false),
                    MeshFormat::Disk => ("disk", false),
                };
                let mut h = format!("  <shape type=\"{ty}\">\n");
                if file {
                    let _ = writeln!(
                        h,
                        "    <string name=\"filename\" value=\"{}\"/>",
                        esc(&rebase(desc, &m.path.value, out))
                    );
                }
                if let MeshFormat::Serialized { shape_index } = format {
                    let _ = writeln!(h, "    <integer name=\"shape_index\" value=\"{shape_index}\"/>");
                }
                let face = match (format, normals) {
                    (MeshFormat::Obj, MeshNormals::AsInFile) => !obj_has_normals(desc, m)?,
                    (_, MeshNormals::Face) => true,
                    _ => false,
                };
                if face && file {
                    h += "    <boolean name=\"face_normals\" value=\"true\"/>\n";
                }
                if *flip_normals {
                    h += "    <boolean name=\"flip_normals\" value=\"true\"/>\n";
                }
                // rdr's uv = Mitsuba's flipped for PLY and serialized; OBJ's flip is the default
                let mitsuba_flip = match format {
                    MeshFormat::Obj => !*flip_uv,
                    MeshFormat::Ply => !*flip_uv,
                    _ => false,
                };
                if (ty == "obj" && !mitsuba_flip) || (ty == "ply" && mitsuba_flip) {
                    let _ = writeln!(h, "    <boolean name=\"flip_tex_coords\" value=\"{mitsuba_flip}\"/>");
                }
                let t = Mat4::from_translation(m.translate) * m.transform;
                if t != Mat4::IDENTITY {
                    let _ = writeln!(h, "    <transform name=\"to_world\"><matrix value=\"{}\"/></transform>", matrix(&t));
                }
                h
            }
        };
        if let Some(mat) = &o.material {
            match material_ids.get(&mat.value) {
                Some(id) => {
                    let _ = writeln!(inner, "    <ref id=\"{}\"/>", esc(id));
                }
                None => return Err(mat.source.error(&desc.file, format!("no material named '{}'", mat.value))),
            }
        }
        if let Some(l) = &o.light {
            let _ = writeln!(
                inner,
                "    <emitter type=\"area\"><rgb name=\"radiance\" value=\"{}\"/></emitter>",
                v3(l.radiance)
            );
        }
        let body = head + &inner + "  </shape>\n";
        match group {
            None => s += &body,
            Some((_, j, gd)) => {
                for line in body.lines() {
                    let _ = writeln!(s, "  {line}");
                }
                if j + 1 == gd.objects.len() {
                    s += "  </shape>\n";
                }
            }
        }
    }
    for inst in &desc.instances {
        let _ = writeln!(
            s,
            "  <shape type=\"instance\">\n    <ref id=\"{}\"/>\n    <transform name=\"to_world\"><matrix value=\"{}\"/></transform>\n  </shape>",
            esc(desc
                .shapegroups
                .iter()
                .position(|g| g.name == inst.shapegroup.value)
                .map_or(inst.shapegroup.value.as_str(), |g| group_ids[g].as_str())),
            matrix(&inst.transform)
        );
    }
    for l in &desc.integrator.point_lights {
        // rdr's flux Φ is Mitsuba's intensity Φ/4π
        let _ = writeln!(
            s,
            "  <emitter type=\"point\">\n    <point name=\"position\" value=\"{}\"/>\n    <rgb name=\"intensity\" value=\"{}\"/>\n  </emitter>",
            v3(l.position),
            v3(l.flux / (4.0 * std::f32::consts::PI))
        );
    }
    for l in &desc.integrator.delta_lights {
        match &l.light {
            crate::light::Light::Spot {
                position,
                axis,
                intensity,
                cutoff,
                beam_width,
            } => {
                // the up vector only has to differ from the axis (the cone is round)
                let up = if axis.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
                let _ = writeln!(
                    s,
                    "  <emitter type=\"spot\">\n    <transform name=\"to_world\"><lookat origin=\"{}\" target=\"{}\" up=\"{}\"/></transform>\n    <rgb name=\"intensity\" value=\"{}\"/>\n    <float name=\"cutoff_angle\" value=\"{}\"/>\n    <float name=\"beam_width\" value=\"{}\"/>\n  </emitter>",
                    v3(*position),
                    v3(*position + *axis),
                    v3(up),
                    v3(*intensity),
                    cutoff.to_degrees(),
                    beam_width.to_degrees()
                );
            }
            crate::light::Light::Directional { direction, irradiance } => {
                let _ = writeln!(
                    s,
                    "  <emitter type=\"directional\">\n    <vector name=\"direction\" value=\"{}\"/>\n    <rgb name=\"irradiance\" value=\"{}\"/>\n  </emitter>",
                    v3(*direction),
                    v3(*irradiance)
                );
            }
            _ => unreachable!("delta_lights holds spot and directional lights"),
        }
    }
    if desc.integrator.light_sampling == crate::light::LightSampling::Uniform {
        w.push("light_sampling uniform has no Mitsuba counterpart (the same converged image)".into());
    }
    if let Some(e) = &desc.environment_map {
        let tex = desc.textures.iter().find(|t| t.name == e.texture.value).map(|t| &t.texture);
        let to_world = if e.transform != Mat4::IDENTITY {
            format!(
                "    <transform name=\"to_world\"><matrix value=\"{}\"/></transform>\n",
                matrix(&e.transform)
            )
        } else {
            String::new()
        };
        match tex {
            Some(Texture::Constant(c)) => {
                let _ = writeln!(
                    s,
                    "  <emitter type=\"constant\">\n    <rgb name=\"radiance\" value=\"{}\"/>\n  </emitter>",
                    v3(*c * e.scale)
                );
            }
            Some(Texture::Image(img)) => {
                if img.mapping.scale != Vec2::ONE || img.mapping.delta != Vec2::ZERO {
                    w.push("the environment texture's tex_coordinate_generator has no Mitsuba counterpart: left out".into());
                }
                let _ = writeln!(
                    s,
                    "  <emitter type=\"envmap\">\n    <string name=\"filename\" value=\"{}\"/>\n    <float name=\"scale\" value=\"{}\"/>\n{to_world}  </emitter>",
                    esc(&rebase(desc, &img.path.value, out)),
                    e.scale
                );
            }
            _ => {
                return Err(SceneError::new(
                    &desc.file,
                    Some("environment_map.texture_name"),
                    "the environment needs an image or constant texture",
                ))
            }
        }
    }
    s += "</scene>\n";
    Ok(Converted {
        text: s,
        files: Vec::new(),
        warnings: w,
    })
}
