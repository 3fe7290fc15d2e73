//! A description written as RDR171 JSON.

use super::{
    cylinder_params, distribution_name, num, obj_has_normals, obj_text, out_dir, ply_text, rebase, row_major, vec2, vec3, Converted,
};
use crate::desc::{MeshFormat, MeshNormals, SceneDesc, TextureRef};
use crate::error::{Result, SceneError};
use crate::film::Filter;
use crate::integrator::{bdpt::Heuristic, Integrator, PathProfile, Roulette};
use crate::material::Material;
use crate::math::{Mat4, Vec3};
use crate::scene::Shape;
use crate::texture::{Texture, UvMapping};
use serde_json::{json, Map, Value};
use std::path::Path;

// ---------------------------------------------------------------------------
// → RDR171 JSON
// ---------------------------------------------------------------------------

pub fn to_json(desc: &SceneDesc, out: &Path) -> Result<Converted> {
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
            if p.rr != Roulette::Mitsuba {
                integ.insert("rr".into(), p.rr.name().into());
            }
            if p.hide_emitters {
                integ.insert("hide_emitters".into(), true.into());
            }
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
                crate::integrator::guided::Combine::Last => "last",
                crate::integrator::guided::Combine::Samples => "samples",
            };
            integ.insert("combine".into(), combine.into());
            integ.insert("spatial_threshold".into(), num(g.spatial_threshold));
            integ.insert("learn_direct".into(), g.learn_direct.into());
            integ.insert("learn_fraction".into(), g.learn_fraction.into());
            let learn_from = match g.learn_from {
                crate::integrator::guided::LearnFrom::Paths => "paths",
                crate::integrator::guided::LearnFrom::Photons => "photons",
            };
            integ.insert("learn_from".into(), learn_from.into());
            if g.target == crate::integrator::guided::Target::Variance {
                integ.insert("target".into(), "variance".into());
            }
            if g.rr != Roulette::Mitsuba {
                integ.insert("rr".into(), g.rr.name().into());
            }
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
    // a textured spot's or a projector's image: the texture's name, or a colour
    let emitter_texture = |l: &crate::desc::DeltaLightDesc| -> Result<Value> {
        match &l.texture {
            Some(TextureRef::Named(n)) => Ok(n.value.clone().into()),
            Some(TextureRef::Color(c)) => Ok(vec3(*c)),
            None => Err(SceneError::new(&desc.file, Some(&l.key), "the light's texture is missing")),
        }
    };
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
            // the frame's t as `ref_up` gives back the same frame (s = up × n)
            crate::light::Light::TexturedSpot(t) => json!({
                "type": "spot", "position": vec3(t.position), "direction": vec3(t.frame.n), "ref_up": vec3(t.frame.t),
                "intensity": vec3(t.intensity), "cutoff_angle": num(t.cutoff.to_degrees()),
                "beam_width": num(t.beam_width.to_degrees()), "texture": emitter_texture(l)?,
            }),
            crate::light::Light::Projector(p) => json!({
                "type": "projector", "position": vec3(p.position), "direction": vec3(p.frame.n), "ref_up": vec3(p.frame.t),
                "irradiance": emitter_texture(l)?, "scale": num(p.scale), "fov": num(p.fov.to_degrees()), "fov_axis": p.fov_axis.name(),
            }),
            _ => unreachable!("delta_lights holds spot, directional and projector lights"),
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
    if c.mirrored {
        camera["mirrored"] = json!(true);
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
                if img.wrap != crate::texture::image::WrapMode::Repeat {
                    v["wrap_mode"] = img.wrap.name().into();
                }
                if img.scale != Vec3::ONE {
                    v["scale"] = vec3(img.scale);
                }
                v
            }
            Texture::MeshAttribute { name, scale, .. } => {
                json!({"type": "mesh_attribute", "name": name, "scale": num(*scale)})
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
            Shape::SdfGrid(g) => {
                let mut v = json!({"type": "sdfgrid", "filename": rebase(desc, &g.path.value, out)});
                if g.transform != Mat4::IDENTITY {
                    v["transform"] = Value::Array(row_major(&g.transform).into_iter().map(num).collect());
                }
                if g.normals != crate::geometry::sdfgrid::SdfNormals::Smooth {
                    v["normals"] = g.normals.name().into();
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
                    let data = crate::desc::build::mesh_data(desc, m)?;
                    // a mesh with attributes as a PLY file, which carries them
                    let ply = Some(&data).filter(|d| !d.attributes.is_empty()).and_then(ply_text);
                    let name = format!("{stem}_meshes/{i}.{}", if ply.is_some() { "ply" } else { "obj" });
                    files.push((out_dir(out).join(&name), ply.unwrap_or_else(|| obj_text(&data)).into_bytes()));
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
            let radiance = match &l.texture {
                Some(t) => t.value.clone().into(),
                None => vec3(l.radiance),
            };
            v["light"] = json!({"type": "area", "radiance": radiance});
        }
        for (key, m) in [("interior", &o.interior), ("exterior", &o.exterior)] {
            if let Some(m) = m {
                v[key] = m.value.clone().into();
            }
        }
        if o.null_bsdf {
            v["null_bsdf"] = true.into();
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
    if f.importance_sampling {
        root["film"]["sampling"] = "importance".into();
    }
    if !desc.shapegroups.is_empty() {
        let g: Map<String, Value> = desc
            .shapegroups
            .iter()
            .zip(groups)
            .map(|(d, objects)| (d.name.clone(), json!({ "objects": objects })))
            .collect();
        root["shapegroups"] = Value::Object(g);
    }
    if !desc.media.is_empty() {
        root["media"] = super::media::media_json(desc, out);
    }
    if let Some(m) = &desc.camera_medium {
        root["camera"]["medium"] = m.value.clone().into();
    }
    if let Some(e) = &desc.environment_map {
        let mut env = json!({"texture_name": e.texture.value.clone(), "scale": num(e.scale)});
        if e.transform != Mat4::IDENTITY {
            env["transform"] = Value::Array(row_major(&e.transform).into_iter().map(num).collect());
        }
        root["environment_map"] = env;
    }
    if let Some(d) = &desc.sunsky {
        let mut sky = json!({
            "turbidity": num(d.turbidity), "albedo": [num(d.albedo.x), num(d.albedo.y), num(d.albedo.z)],
            "sun_scale": num(d.sun_scale), "sky_scale": num(d.sky_scale), "sun_aperture": num(d.sun_aperture),
            "complex_sun": d.complex_sun,
        });
        match d.sun {
            crate::desc::SunPlacement::Direction(v) => sky["sun_direction"] = json!([num(v.x), num(v.y), num(v.z)]),
            crate::desc::SunPlacement::At(at) => {
                for (k, v) in [("latitude", at.latitude), ("longitude", at.longitude), ("timezone", at.timezone)] {
                    sky[k] = num(v);
                }
                for (k, v) in [("year", at.year), ("month", at.month), ("day", at.day)] {
                    sky[k] = v.into();
                }
                for (k, v) in [("hour", at.hour), ("minute", at.minute), ("second", at.second)] {
                    sky[k] = num(v);
                }
            }
        }
        if d.transform != Mat4::IDENTITY {
            sky["transform"] = Value::Array(row_major(&d.transform).into_iter().map(num).collect());
        }
        root["sunsky"] = sky;
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
        Material::Diffuse {
            texture: TextureRef::Color(c),
            twosided,
        } => json!({"type": "diffuse", "albedo": vec3(*c), "twosided": twosided}),
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
            alpha_textures,
            eta_k_textures,
            distribution,
            twosided,
        } => {
            let [ax, ay] = rough_json(*alpha_x, *alpha_y, alpha_textures);
            let [eta, k] = eta_k_json(*eta_t, *k, eta_k_textures);
            let mut v = json!({
                "type": "roughconductor",
                "texture_name": texture_name(texture, name, textures),
                "etaI": vec3(*eta_i), "etaT": eta, "k": k,
                "alpha_x": ax, "alpha_y": ay,
                "distribution": distribution_name(*distribution),
            });
            if !twosided {
                v["twosided"] = json!(false);
            }
            v
        }
        Material::Conductor {
            texture,
            eta,
            k,
            eta_k_textures,
        } => {
            let [eta, k] = eta_k_json(*eta, *k, eta_k_textures);
            json!({"type": "conductor", "texture_name": texture_name(texture, name, textures), "eta": eta, "k": k})
        }
        Material::ThinDielectric { reflect, transmit, eta } => {
            json!({"type": "thindielectric", "R": vec3(*reflect), "T": vec3(*transmit), "eta": num(*eta)})
        }
        Material::RoughDielectric {
            reflect,
            transmit,
            eta,
            alpha_x,
            alpha_y,
            alpha_textures,
            distribution,
        } => {
            let [ax, ay] = rough_json(*alpha_x, *alpha_y, alpha_textures);
            json!({
                "type": "roughdielectric", "R": vec3(*reflect), "T": vec3(*transmit), "eta": num(*eta),
                "alpha_x": ax, "alpha_y": ay, "distribution": distribution_name(*distribution),
            })
        }
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
        Material::Phong {
            texture,
            specular,
            exponent,
            ..
        } => json!({
            "type": "phong", "texture_name": texture_name(texture, name, textures),
            "specular_reflectance": vec3(*specular), "exponent": num(*exponent),
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
        Material::Principled(p) => crate::desc::principled::to_json(p),
        Material::PrincipledThin(p) => crate::desc::principled::thin_to_json(p),
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

/// `alpha_x` and `alpha_y` as JSON: numbers, or texture names where they are textures.
/// A conductor's η and k: colours, or texture names (a constant one as its colour).
fn eta_k_json(eta: Vec3, k: Vec3, textures: &Option<[TextureRef; 2]>) -> [Value; 2] {
    let one = |t: &TextureRef| match t {
        TextureRef::Named(n) => Value::String(n.value.clone()),
        TextureRef::Color(c) => vec3(*c),
    };
    match textures {
        Some([e, k]) => [one(e), one(k)],
        None => [vec3(eta), vec3(k)],
    }
}

fn rough_json(alpha_x: f32, alpha_y: f32, textures: &Option<[TextureRef; 2]>) -> [Value; 2] {
    let one = |t: &TextureRef| match t {
        TextureRef::Named(n) => Value::String(n.value.clone()),
        TextureRef::Color(c) => num(c.x),
    };
    match textures {
        Some([tx, ty]) => [one(tx), one(ty)],
        None => [num(alpha_x), num(alpha_y)],
    }
}
