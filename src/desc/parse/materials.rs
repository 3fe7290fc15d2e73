//! `textures` and `materials`.

use super::{colour, finite, in_range, mesh_attribute_name, non_negative, roughness};
use crate::desc::json::Props;
use crate::desc::{principled, ImageFile, MaterialDesc, TextureDesc, TextureRef};
use crate::error::Result;
use crate::material::{Distribution, Material};
use crate::math::{Vec2, Vec3};
use crate::texture::{Texture, UvMapping};
use serde_json::Value;

fn parse_mapping(p: &Props) -> Result<UvMapping> {
    let g = p.object("tex_coordinate_generator")?;
    let ty = g.string("type")?;
    if ty != "uvmapping2d" {
        return Err(g.error(
            "type",
            format!("unknown texture coordinate generator '{ty}' (available: uvmapping2d)"),
        ));
    }
    let m = UvMapping {
        scale: g.vec2_or("scale", Vec2::ONE)?,
        delta: g.vec2_or("delta", Vec2::ZERO)?,
    };
    g.finish();
    Ok(m)
}

pub(super) fn parse_texture(name: &str, p: &Props) -> Result<TextureDesc> {
    let ty = p.string("type")?;
    let texture = match ty.as_str() {
        "constant" => Texture::Constant(p.vec3("color")?),
        "checkerboard" => Texture::Checkerboard {
            color0: p.vec3_or("color0", Vec3::splat(0.4))?,
            color1: p.vec3_or("color1", Vec3::splat(0.2))?,
            mapping: parse_mapping(p)?,
        },
        "image" => Texture::Image(ImageFile {
            path: p.located("path", p.string("path")?),
            mapping: parse_mapping(p)?,
            filter: match p.string_or("filter", "trilinear")?.as_str() {
                "trilinear" => crate::texture::image::ImageFilter::Trilinear,
                "bilinear" => crate::texture::image::ImageFilter::Bilinear,
                "nearest" => crate::texture::image::ImageFilter::Nearest,
                other => {
                    return Err(p.error(
                        "filter",
                        format!("unknown image filter '{other}' (available: trilinear, bilinear, nearest)"),
                    ))
                }
            },
            raw: p.bool_or("raw", false)?,
            wrap: {
                let w = p.string_or("wrap_mode", "repeat")?;
                crate::texture::image::WrapMode::parse(&w).ok_or_else(|| {
                    p.error(
                        "wrap_mode",
                        format!("unknown wrap_mode '{w}' (available: {})", crate::texture::image::WrapMode::NAMES),
                    )
                })?
            },
            scale: colour(p, "scale", Vec3::ONE)?,
        }),
        "mesh_attribute" => Texture::MeshAttribute {
            name: mesh_attribute_name(p, p.string("name")?)?,
            slot: 0,
            scale: finite(p, "scale", p.f32_or("scale", 1.0)?)?,
        },
        _ => {
            return Err(p.error(
                "type",
                format!("unknown texture type '{ty}' (available: constant, checkerboard, image, mesh_attribute)"),
            ))
        }
    };
    p.finish();
    Ok(TextureDesc {
        name: name.to_string(),
        source: p.own_source(),
        texture,
    })
}

/// `texture_name`, or a colour given inline (`inline`: `albedo` on diffuse), or
/// (accepted with a warning) the legacy inline colour key that older course scenes
/// use instead (`color` on diffuse, `R` on conductors).
/// A roughness key's number (`read`), or 0.1 when the key names a texture instead.
fn rough_number(p: &Props, key: &str, read: impl Fn(&str) -> Result<f32>) -> Result<f32> {
    match p.raw(key) {
        Some(serde_json::Value::String(_)) => Ok(0.1),
        _ => read(key),
    }
}

/// A conductor's `eta` or `k` as a colour: a placeholder when it names a texture
/// (read by [`eta_k_textures`]).
fn eta_k_number(p: &Props, key: &str, read: impl Fn(&str) -> Result<Vec3>) -> Result<Vec3> {
    match p.raw(key) {
        Some(serde_json::Value::String(_)) => Ok(Vec3::ONE),
        _ => read(key),
    }
}

fn eta_k_colour(p: &Props, key: &str, default: Vec3) -> Result<Vec3> {
    eta_k_number(p, key, |k| colour(p, k, default))
}

/// A conductor's η and k keys (`keys`; η's default `eta_default`, k's 1) as textures
/// when either names one (a colour stays a constant).
fn eta_k_textures(p: &Props, keys: [&str; 2], eta_default: f32) -> Result<Option<[TextureRef; 2]>> {
    if !keys.iter().any(|k| matches!(p.raw(k), Some(serde_json::Value::String(_)))) {
        return Ok(None);
    }
    Ok(Some([
        principled::json_texture(p, keys[0], eta_default, true)?,
        principled::json_texture(p, keys[1], 1.0, true)?,
    ]))
}

/// `alpha_x` and `alpha_y` as textures when either names one (a number stays a constant).
fn rough_textures(p: &Props) -> Result<Option<[TextureRef; 2]>> {
    if !["alpha_x", "alpha_y"]
        .iter()
        .any(|k| matches!(p.raw(k), Some(serde_json::Value::String(_))))
    {
        return Ok(None);
    }
    Ok(Some([
        principled::json_texture(p, "alpha_x", 0.1, false)?,
        principled::json_texture(p, "alpha_y", 0.1, false)?,
    ]))
}

fn texture_ref(p: &Props, legacy: &str, inline: Option<&str>) -> Result<TextureRef> {
    if let Some(key) = inline.filter(|k| p.contains(k)) {
        if let Some(other) = ["texture_name", legacy].into_iter().find(|k| p.contains(k)) {
            return Err(p.error(key, format!("give '{key}' or '{other}', not both")));
        }
        return Ok(TextureRef::Color(colour(p, key, Vec3::ONE)?));
    }
    if !p.contains("texture_name") && p.contains(legacy) {
        p.ctx().warn(
            &p.key_path(legacy),
            format!("legacy key '{legacy}' accepted as a constant texture; prefer 'texture_name'"),
        );
        return Ok(TextureRef::Color(p.vec3(legacy)?));
    }
    if let (Some(key), false) = (inline, p.contains("texture_name")) {
        return Err(p.error(key, "give a colour such as [0.8, 0.2, 0.2], or a 'texture_name'"));
    }
    texture_name(p)?.ok_or_else(|| p.error("texture_name", "required key is missing"))
}

/// `texture_name`: the name of a texture, or a colour given inline (`[0.8, 0.2, 0.2]`,
/// a constant texture without an entry of its own); `None` when absent.
fn texture_name(p: &Props) -> Result<Option<TextureRef>> {
    if let Some(Value::Array(_)) = p.raw("texture_name") {
        return Ok(Some(TextureRef::Color(colour(p, "texture_name", Vec3::ONE)?)));
    }
    Ok(p.string_opt("texture_name")?
        .map(|t| TextureRef::Named(p.located("texture_name", t))))
}

/// Every material type, as the error for an unknown one lists them.
const MATERIAL_TYPES: [&str; 17] = [
    "diffuse",
    "refraction",
    "glass",
    "roughconductor",
    "conductor",
    "thindielectric",
    "roughdielectric",
    "plastic",
    "roughplastic",
    "phong",
    "twosided",
    "bumpmap",
    "normalmap",
    "mask",
    "principled",
    "principledthin",
    "blendbsdf",
];

/// The material types that wrap others by name (`material_name`).
const WRAPPERS: [&str; 5] = ["twosided", "bumpmap", "normalmap", "mask", "blendbsdf"];

/// `materials`: every entry by [`parse_material`]; then each wrapper (`twosided`,
/// `bumpmap`, `normalmap`, `mask`, `blendbsdf`) gets a copy of the materials it names, wrappers
/// of wrappers once those are built. The rules: the named materials must be defined
/// and not form a cycle; `twosided` wraps neither a `twosided` nor a transmitting
/// material; a `mask` is outermost (nothing wraps it); bump and normal maps do not
/// wrap each other.
pub(super) fn parse_materials(root: &Props) -> Result<Vec<MaterialDesc>> {
    let entries = root.named_objects("materials")?;
    let mut slots: Vec<Option<MaterialDesc>> = Vec::with_capacity(entries.len());
    let mut types = Vec::with_capacity(entries.len());
    for (name, p) in &entries {
        let ty = p.string_or("type", "diffuse")?;
        slots.push(if WRAPPERS.contains(&ty.as_str()) {
            None
        } else {
            Some(parse_material(name, p, &ty)?)
        });
        types.push(ty);
    }
    loop {
        let mut progress = false;
        let mut waiting = None;
        for i in 0..entries.len() {
            if slots[i].is_some() {
                continue;
            }
            let (name, p) = &entries[i];
            let ty = types[i].as_str();
            // the materials it names, by index; None: one of them is not built yet
            let target = |key: &str, target: Option<String>| -> Result<Option<usize>> {
                let Some(target) = target else { return Ok(None) };
                match entries.iter().position(|(n, _)| *n == target) {
                    Some(j) => Ok(Some(j)),
                    None => {
                        let known: Vec<&str> = entries.iter().map(|(n, _)| n.as_str()).collect();
                        Err(p.error(key, format!("no material named '{target}' (defined: {})", known.join(", "))))
                    }
                }
            };
            let (front_key, front_name) = if ty == "blendbsdf" {
                let names = blend_names(p)?;
                ("material_names", names[0].clone())
            } else {
                ("material_name", p.string("material_name")?)
            };
            let front = target(front_key, Some(front_name))?.expect("given");
            let back = match ty {
                "twosided" => target("back_material_name", p.string_opt("back_material_name")?)?,
                "blendbsdf" => target("material_names", Some(blend_names(p)?[1].clone()))?,
                _ => None,
            };
            if [Some(front), back].iter().flatten().any(|&j| slots[j].is_none()) {
                waiting.get_or_insert(i);
                continue;
            }
            let get = |key: &str, j: usize| -> Result<Box<Material<TextureRef>>> {
                let (target, m) = (&entries[j].0, &slots[j].as_ref().expect("built").material);
                let wrapped = |why: &str| Err(p.error(key, format!("'{target}' {why}")));
                match (ty, m) {
                    (_, Material::Mask { .. }) => wrapped("is a mask; a mask must be the outermost material (put the others inside it)")?,
                    ("twosided", Material::TwoSided { .. }) => wrapped("is a twosided material itself; twosided cannot nest")?,
                    ("twosided", m) if m.transmits() => wrapped("transmits light; twosided wraps only reflecting materials")?,
                    ("bumpmap" | "normalmap", Material::BumpMap { .. } | Material::NormalMap { .. }) => {
                        wrapped("is a bump or normal map itself; they cannot wrap each other")?
                    }
                    _ => Ok(Box::new(m.clone())),
                }
            };
            let inner = get(front_key, front)?;
            let material = match ty {
                "blendbsdf" => Material::BlendBsdf {
                    weight: principled::json_weight(p)?,
                    first: inner,
                    second: get("material_names", back.expect("two names"))?,
                },
                "twosided" => Material::TwoSided {
                    front: inner,
                    back: back.map(|j| get("back_material_name", j)).transpose()?,
                },
                "bumpmap" => Material::BumpMap {
                    height: TextureRef::Named(p.located("texture_name", p.string("texture_name")?)),
                    scale: finite(p, "scale", p.f32_or("scale", 1.0)?)?,
                    options: perturb_options(p)?,
                    inner,
                },
                "normalmap" => Material::NormalMap {
                    normals: TextureRef::Named(p.located("texture_name", p.string("texture_name")?)),
                    options: perturb_options(p)?,
                    inner,
                },
                _ => Material::Mask {
                    opacity: match (p.string_opt("texture_name")?, p.contains("opacity")) {
                        (Some(_), true) => return Err(p.error("opacity", "give an 'opacity' or a 'texture_name', not both")),
                        (Some(t), false) => TextureRef::Named(p.located("texture_name", t)),
                        (None, _) => TextureRef::Color(Vec3::splat(in_range(p, "opacity", p.f32_or("opacity", 0.5)?, 0.0, 1.0)?)),
                    },
                    inner,
                },
            };
            p.finish();
            slots[i] = Some(MaterialDesc {
                name: name.clone(),
                source: p.own_source(),
                material,
            });
            progress = true;
        }
        match waiting {
            None => break,
            Some(i) if !progress => {
                let key = if types[i] == "blendbsdf" {
                    "material_names"
                } else {
                    "material_name"
                };
                return Err(entries[i].1.error(key, "materials that wrap each other form a cycle"));
            }
            Some(_) => {}
        }
    }
    Ok(slots.into_iter().flatten().collect())
}

/// A `blendbsdf`'s `material_names`: two names.
fn blend_names(p: &Props) -> Result<[String; 2]> {
    match p.raw("material_names") {
        Some(Value::Array(a)) if a.len() == 2 && a.iter().all(|v| v.is_string()) => Ok([
            a[0].as_str().unwrap_or_default().to_string(),
            a[1].as_str().unwrap_or_default().to_string(),
        ]),
        Some(_) => Err(p.error("material_names", "expected an array of two material names")),
        None => Err(p.error("material_names", "required key is missing")),
    }
}

/// `flip_invalid_normals` and `use_shadowing_function` (both true) of a bump or normal map.
fn perturb_options(p: &Props) -> Result<crate::material::bump::PerturbOptions> {
    Ok(crate::material::bump::PerturbOptions {
        flip_invalid_normals: p.bool_or("flip_invalid_normals", true)?,
        use_shadowing_function: p.bool_or("use_shadowing_function", true)?,
    })
}

/// `distribution`: `"beckmann"` (the default) or `"ggx"`.
fn distribution(p: &Props) -> Result<Distribution> {
    match p.string_or("distribution", "beckmann")?.as_str() {
        "beckmann" => Ok(Distribution::Beckmann),
        "ggx" => Ok(Distribution::Ggx),
        other => Err(p.error(
            "distribution",
            format!("unknown microfacet distribution '{other}' (available: beckmann, ggx)"),
        )),
    }
}

/// `texture_name` (a name or an inline colour) when given, else the constant `default` (the optional textures
/// of the Mitsuba materials).
fn texture_or(p: &Props, default: Vec3) -> Result<TextureRef> {
    Ok(texture_name(p)?.unwrap_or(TextureRef::Color(default)))
}

/// One material of type `ty` (see [`MaterialDesc`] and [`Material`] for the keys).
fn parse_material(name: &str, p: &Props, ty: &str) -> Result<MaterialDesc> {
    let eta_or = |key: &str, default: f32| -> Result<f32> {
        let eta = p.f32_or(key, default)?;
        if eta <= 0.0 {
            return Err(p.error(key, format!("must be positive, found {eta}")));
        }
        // refraction divides and squares it: beyond this the directions are not finite
        in_range(p, key, eta, 1e-3, 1e3)
    };
    let positive_eta = |key: &str| eta_or(key, 1.5);
    // a coating of index 1 is no coating (Mitsuba refuses it too)
    let coating_eta = || -> Result<f32> {
        let eta = eta_or("eta", 1.49)?;
        if eta == 1.0 {
            return Err(p.error("eta", "a coating needs an index other than 1"));
        }
        Ok(eta)
    };
    let material = match ty {
        "diffuse" => Material::Diffuse {
            texture: texture_ref(p, "color", Some("albedo"))?,
            twosided: p.bool_or("twosided", false)?,
        },
        "refraction" => Material::Refraction { eta: positive_eta("eta")? },
        "glass" => Material::Glass {
            reflect: p.vec3_or("R", Vec3::ONE)?,
            transmit: p.vec3_or("T", Vec3::ONE)?,
            eta: positive_eta("eta")?,
        },
        "roughconductor" => Material::RoughConductor {
            texture: texture_ref(p, "R", None)?,
            eta_i: p.vec3_or("etaI", Vec3::ONE)?,
            eta_t: eta_k_number(p, "etaT", |k| p.vec3_or(k, Vec3::ONE))?,
            k: eta_k_number(p, "k", |k| p.vec3_or(k, Vec3::ONE))?,
            alpha_x: rough_number(p, "alpha_x", |k| non_negative(p, k, p.f32_or(k, 0.1)?))?,
            alpha_y: rough_number(p, "alpha_y", |k| non_negative(p, k, p.f32_or(k, 0.1)?))?,
            alpha_textures: rough_textures(p)?,
            eta_k_textures: eta_k_textures(p, ["etaT", "k"], 1.0)?,
            distribution: distribution(p)?,
            twosided: p.bool_or("twosided", true)?,
        },
        "conductor" => Material::Conductor {
            texture: texture_or(p, Vec3::ONE)?,
            eta: eta_k_colour(p, "eta", Vec3::ZERO)?,
            k: eta_k_colour(p, "k", Vec3::ONE)?,
            eta_k_textures: eta_k_textures(p, ["eta", "k"], 0.0)?,
        },
        "thindielectric" => Material::ThinDielectric {
            reflect: colour(p, "R", Vec3::ONE)?,
            transmit: colour(p, "T", Vec3::ONE)?,
            eta: positive_eta("eta")?,
        },
        "roughdielectric" => Material::RoughDielectric {
            reflect: colour(p, "R", Vec3::ONE)?,
            transmit: colour(p, "T", Vec3::ONE)?,
            eta: positive_eta("eta")?,
            alpha_x: rough_number(p, "alpha_x", |k| roughness(p, k))?,
            alpha_y: rough_number(p, "alpha_y", |k| roughness(p, k))?,
            alpha_textures: rough_textures(p)?,
            distribution: distribution(p)?,
        },
        "plastic" => Material::Plastic {
            texture: texture_or(p, Vec3::splat(0.5))?,
            specular: colour(p, "specular_reflectance", Vec3::ONE)?,
            eta: coating_eta()?,
            nonlinear: p.bool_or("nonlinear", false)?,
            specular_sampling_weight: None,
        },
        "roughplastic" => Material::RoughPlastic {
            texture: texture_or(p, Vec3::splat(0.5))?,
            specular: colour(p, "specular_reflectance", Vec3::ONE)?,
            eta: coating_eta()?,
            nonlinear: p.bool_or("nonlinear", false)?,
            alpha: roughness(p, "alpha")?,
            distribution: distribution(p)?,
            specular_sampling_weight: None,
            tables: None,
        },
        "phong" => Material::Phong {
            texture: texture_or(p, Vec3::splat(0.5))?,
            specular: colour(p, "specular_reflectance", Vec3::splat(0.2))?,
            exponent: finite(p, "exponent", non_negative(p, "exponent", p.f32_or("exponent", 30.0)?)?)?,
            specular_sampling_weight: None,
        },
        "principled" => principled::json_principled(p)?,
        "principledthin" => principled::json_principled_thin(p)?,
        _ => {
            return Err(p.error(
                "type",
                format!("unknown material type '{ty}' (available: {})", MATERIAL_TYPES.join(", ")),
            ))
        }
    };
    p.finish();
    Ok(MaterialDesc {
        name: name.to_string(),
        source: p.own_source(),
        material,
    })
}
