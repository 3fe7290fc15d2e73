//! A description written as Mitsuba 3 XML.

use super::{cylinder_params, distribution_name, matrix, obj_has_normals, rebase, Converted};
use crate::desc::{MeshFormat, MeshNormals, MeshOptions, SceneDesc, TextureRef};
use crate::error::{Result, SceneError};
use crate::film::Filter;
use crate::integrator::{bdpt::Heuristic, Integrator, PathProfile, Roulette};
use crate::material::{Distribution, Material};
use crate::math::{Mat4, Vec2, Vec3};
use crate::scene::Shape;
use crate::texture::Texture;
use std::fmt::Write as _;
use std::path::Path;

// ---------------------------------------------------------------------------
// → Mitsuba 3 XML
// ---------------------------------------------------------------------------

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
    let alphas = |ax: f32, ay: f32, textures: &Option<[TextureRef; 2]>, d: Distribution| {
        let property = |key: &str, t: &TextureRef| crate::desc::principled::xml_property(key, t, false, colour);
        let a = match textures {
            Some([tx, ty]) if same_texture(tx, ty) => property("alpha", tx),
            Some([tx, ty]) => property("alpha_u", tx) + &property("alpha_v", ty),
            None if ax == ay => format!("<float name=\"alpha\" value=\"{ax}\"/>"),
            None => format!("<float name=\"alpha_u\" value=\"{ax}\"/><float name=\"alpha_v\" value=\"{ay}\"/>"),
        };
        format!("{a}<string name=\"distribution\" value=\"{}\"/>", distribution_name(d))
    };
    let eta_k = |eta: Vec3, k: Vec3, textures: &Option<[TextureRef; 2]>| match textures {
        Some([e, k]) => colour("eta", e) + &colour("k", k),
        None => format!("<rgb name=\"eta\" value=\"{}\"/><rgb name=\"k\" value=\"{}\"/>", v3(eta), v3(k)),
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
            alpha_textures,
            eta_k_textures,
            distribution,
            twosided,
        } => {
            // rdr's roughconductor reflects on both sides unless `twosided` is false,
            // Mitsuba's on the front only: a two-sided one is wrapped in a twosided
            // (unless it is one side of a twosided already), a one-sided one bare
            let wrap = *twosided && id.is_some();
            if eta_k_textures.is_some() && *eta_i != Vec3::ONE {
                w.push(format!(
                    "material '{name}': etaI is not written beside a textured etaT or k (Mitsuba has no ext_eta on conductors)"
                ));
            }
            let bsdf = format!(
                "{}{}{}{}</bsdf>",
                if wrap {
                    "<bsdf type=\"roughconductor\">".to_string()
                } else {
                    open("roughconductor")
                },
                alphas(*alpha_x, *alpha_y, alpha_textures, *distribution),
                eta_k(*eta_t / *eta_i, *k / *eta_i, eta_k_textures),
                colour("specular_reflectance", texture)
            );
            if wrap {
                format!("{}{bsdf}</bsdf>", open("twosided"))
            } else {
                bsdf
            }
        }
        Material::Conductor {
            texture,
            eta,
            k,
            eta_k_textures,
        } => format!(
            "{}{}{}</bsdf>",
            open("conductor"),
            eta_k(*eta, *k, eta_k_textures),
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
            alpha_textures,
            distribution,
        } => format!(
            "{}{}{}{}{}</bsdf>",
            open("roughdielectric"),
            alphas(*alpha_x, *alpha_y, alpha_textures, *distribution),
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
            alphas(*alpha, *alpha, &None, *distribution),
            colour("diffuse_reflectance", texture),
            rgb_unless_one("specular_reflectance", *specular),
            iors(*eta)
        ),
        Material::Phong {
            texture,
            specular,
            exponent,
            ..
        } => {
            w.push(format!("material '{name}': phong is Mitsuba 0.6's (Mitsuba 3 cannot read it)"));
            format!(
                "{}{}<rgb name=\"specular_reflectance\" value=\"{}\"/><float name=\"exponent\" value=\"{exponent}\"/></bsdf>",
                open("phong"),
                colour("diffuse_reflectance", texture),
                v3(*specular)
            )
        }
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
        Material::Principled(p) => format!(
            "{}{}</bsdf>",
            open("principled"),
            crate::desc::principled::xml_properties(p, colour)
        ),
        Material::PrincipledThin(p) => format!(
            "{}{}</bsdf>",
            open("principledthin"),
            crate::desc::principled::thin_xml_properties(p, colour)
        ),
        Material::BlendBsdf { weight, first, second } => format!(
            "{}{}{}{}</bsdf>",
            open("blendbsdf"),
            crate::desc::principled::xml_property("weight", weight, false, colour),
            material_xml(first, name, None, colour, w),
            material_xml(second, name, None, colour, w)
        ),
    }
}

/// A light's `to_world` at `position` with `frame`: Mitsuba's `lookat` with the frame's t
/// as `up` gives back the same frame (its x is up × n).
fn light_to_world(position: Vec3, frame: &crate::math::Frame) -> String {
    format!(
        "<transform name=\"to_world\"><lookat origin=\"{}\" target=\"{}\" up=\"{}\"/></transform>",
        v3(position),
        v3(position + frame.n),
        v3(frame.t)
    )
}

/// A `spot` emitter (angles in radians) with `extra` properties (its texture).
fn spot_xml(to_world: &str, intensity: Vec3, cutoff: f32, beam_width: f32, extra: &str) -> String {
    format!(
        "  <emitter type=\"spot\">\n    {to_world}\n    <rgb name=\"intensity\" value=\"{}\"/>\n    \
         <float name=\"cutoff_angle\" value=\"{}\"/>\n    <float name=\"beam_width\" value=\"{}\"/>\n{}  </emitter>\n",
        v3(intensity),
        cutoff.to_degrees(),
        beam_width.to_degrees(),
        if extra.is_empty() {
            String::new()
        } else {
            format!("    {extra}\n")
        }
    )
}

/// Whether two references are the same constant or name the same texture.
fn same_texture(a: &TextureRef, b: &TextureRef) -> bool {
    match (a, b) {
        (TextureRef::Named(x), TextureRef::Named(y)) => x.value == y.value,
        (TextureRef::Color(x), TextureRef::Color(y)) => x == y,
        _ => false,
    }
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

/// The description as Mitsuba 3 XML, for the file `out`.
pub fn to_xml(desc: &SceneDesc, out: &Path) -> Result<Converted> {
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
    // rdr's shadow rays pass through masks as Mitsuba's volpath's do (its path's stop there)
    let has_masks = desc.materials.iter().any(|m| matches!(m.material, Material::Mask { .. }));
    let depth = |d: u32| format!("    <integer name=\"max_depth\" value=\"{d}\"/>\n");
    s += &match desc.integrator.integrator {
        Integrator::Path(p) => {
            if p.profile != PathProfile::Mis {
                w.push("the path profile (NEE/RW) has no Mitsuba counterpart: written as path (the same converged image)".into());
            }
            if p.rr != Roulette::Mitsuba {
                w.push("rr \"ears\" has no Mitsuba counterpart: written with Mitsuba's roulette (the same converged image)".into());
            }
            let hide = if p.hide_emitters {
                "    <boolean name=\"hide_emitters\" value=\"true\"/>\n"
            } else {
                ""
            };
            // Mitsuba's `path` ignores media and masks' null BSDFs: `volpath` renders what rdr's `path`
            // does; with media `volpathmis`, whose spectral MIS over chromatic extinction is rdr's
            // (volpath converges to the same image with far more noise: milk_sphere 8x its floor)
            let ty = match (desc.media.is_empty(), has_masks) {
                (false, _) => "volpathmis",
                (true, true) => "volpath",
                (true, false) => "path",
            };
            format!("  <integrator type=\"{ty}\">\n{}{hide}  </integrator>\n", depth(p.max_depth))
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
        Filter::Box { radius } => {
            // Mitsuba 3's box has radius 0.5 and refuses the parameter
            if radius != 0.5 {
                w.push(format!("Mitsuba 3's box filter has radius 0.5, not {radius}"));
            }
            "<rfilter type=\"box\"/>".to_string()
        }
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
    // a mirrored camera: Mitsuba's negative scale in x
    let scale = match (c.mirrored, scale.is_empty()) {
        (false, _) => scale,
        (true, true) => "      <scale x=\"-1\"/>\n".to_string(),
        (true, false) => scale.replacen("<scale x=\"", "<scale x=\"-", 1),
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
        "  <sensor type=\"{sensor}\">\n{keys}    <transform name=\"to_world\">\n\
         {scale}      <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n    </transform>\n    \
         <film type=\"hdrfilm\">\n      <integer name=\"width\" value=\"{}\"/>\n      \
         <integer name=\"height\" value=\"{}\"/>\n      <string name=\"pixel_format\" value=\"rgb\"/>\n      \
         {filter}\n    </film>\n    <sampler type=\"independent\">\n      \
         <integer name=\"sample_count\" value=\"{}\"/>\n    </sampler>\n{}  </sensor>\n",
        v3(c.position),
        v3(c.look_at),
        v3(c.ref_up),
        f.width,
        f.height,
        desc.integrator.spp,
        desc.camera_medium
            .as_ref()
            .map_or(String::new(), |m| format!("    <ref id=\"{}\"/>\n", esc(&m.value)))
    );
    s += &super::media::media_xml(desc, out, esc);
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
            Texture::MeshAttribute { name, scale, .. } => {
                let id = id_for(&t.name, "texture-");
                let _ = writeln!(
                    s,
                    "  <texture type=\"mesh_attribute\" id=\"{}\">\n    <string name=\"name\" value=\"{}\"/>\n    <float name=\"scale\" value=\"{scale}\"/>\n  </texture>",
                    esc(&id),
                    esc(name)
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
                if img.scale != Vec3::ONE {
                    w.push(format!(
                        "texture '{}': Mitsuba 3 has no scaled bitmap (Mitsuba 0.6's `scale` texture): its scale is left out",
                        t.name
                    ));
                }
                let _ = writeln!(
                    s,
                    "  <texture type=\"bitmap\" id=\"{}\">\n    <string name=\"filename\" value=\"{}\"/>\n    \
                     <string name=\"filter_type\" value=\"{filter}\"/>\n    <boolean name=\"raw\" value=\"{}\"/>\n    \
                     {}{}\n  </texture>",
                    esc(&id),
                    esc(&rebase(desc, &img.path.value, out)),
                    img.raw,
                    match img.wrap {
                        crate::texture::image::WrapMode::Repeat => String::new(),
                        w => format!("<string name=\"wrap_mode\" value=\"{}\"/>\n    ", w.name()),
                    },
                    to_uv(sm, om)
                );
                texture_ids.insert(t.name.clone(), id);
            }
        }
    }
    let colour = |name: &str, r: &TextureRef| -> String {
        // parameters Mitsuba reads as colours (and bump heights, whose checkerboard has
        // no gradient); the others as floats (`eval_1`)
        const COLOURS: [&str; 12] = [
            "eta",
            "irradiance",
            "texture",
            "k",
            "radiance",
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
            Shape::SdfGrid(g) => {
                let mut h = format!(
                    "  <shape type=\"sdfgrid\">\n    <string name=\"filename\" value=\"{}\"/>\n",
                    esc(&rebase(desc, &g.path.value, out))
                );
                if g.normals != crate::geometry::sdfgrid::SdfNormals::Smooth {
                    let _ = writeln!(h, "    <string name=\"normals\" value=\"{}\"/>", g.normals.name());
                }
                if g.transform != Mat4::IDENTITY {
                    let _ = writeln!(
                        h,
                        "    <transform name=\"to_world\"><matrix value=\"{}\"/></transform>",
                        matrix(&g.transform)
                    );
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
        if o.null_bsdf {
            inner += "    <bsdf type=\"null\"/>\n";
        }
        for (key, m) in [("interior", &o.interior), ("exterior", &o.exterior)] {
            if let Some(m) = m {
                let _ = writeln!(inner, "    <ref name=\"{key}\" id=\"{}\"/>", esc(&m.value));
            }
        }
        if let Some(l) = &o.light {
            let radiance = match &l.texture {
                Some(t) => TextureRef::Named(t.clone()),
                None => TextureRef::Color(l.radiance),
            };
            let _ = writeln!(inner, "    <emitter type=\"area\">{}</emitter>", colour("radiance", &radiance));
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
    // a textured spot's or a projector's image, its file path already relative to `out`
    let emitter_texture = |l: &crate::desc::DeltaLightDesc, key: &str| match &l.texture {
        Some(t) => Ok(colour(key, t)),
        None => Err(SceneError::new(&desc.file, Some(&l.key), "the light's texture is missing")),
    };
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
                let to_world = format!(
                    "<transform name=\"to_world\"><lookat origin=\"{}\" target=\"{}\" up=\"{}\"/></transform>",
                    v3(*position),
                    v3(*position + *axis),
                    v3(up)
                );
                s += &spot_xml(&to_world, *intensity, *cutoff, *beam_width, "");
            }
            crate::light::Light::Directional { direction, irradiance } => {
                let _ = writeln!(
                    s,
                    "  <emitter type=\"directional\">\n    <vector name=\"direction\" value=\"{}\"/>\n    <rgb name=\"irradiance\" value=\"{}\"/>\n  </emitter>",
                    v3(*direction),
                    v3(*irradiance)
                );
            }
            crate::light::Light::TexturedSpot(t) => {
                let to_world = light_to_world(t.position, &t.frame);
                // Mitsuba's spot wants an image: a constant one is a plain spot of intensity × colour
                let constant = match &l.texture {
                    Some(TextureRef::Color(c)) => Some(*c),
                    Some(TextureRef::Named(n)) => match desc.textures.iter().find(|d| d.name == n.value).map(|d| &d.texture) {
                        Some(Texture::Constant(c)) => Some(*c),
                        _ => None,
                    },
                    None => None,
                };
                s += &match constant {
                    Some(c) => spot_xml(&to_world, t.intensity * c, t.cutoff, t.beam_width, ""),
                    None => spot_xml(&to_world, t.intensity, t.cutoff, t.beam_width, &emitter_texture(l, "texture")?),
                };
            }
            crate::light::Light::Projector(p) => {
                let _ = writeln!(
                    s,
                    "  <emitter type=\"projector\">\n    {}\n    <float name=\"scale\" value=\"{}\"/>\n    \
                     <float name=\"fov\" value=\"{}\"/>\n    <string name=\"fov_axis\" value=\"{}\"/>\n    {}\n  </emitter>",
                    light_to_world(p.position, &p.frame),
                    p.scale,
                    p.fov.to_degrees(),
                    p.fov_axis.name(),
                    emitter_texture(l, "irradiance")?
                );
            }
            _ => unreachable!("delta_lights holds spot, directional and projector lights"),
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
    if let Some(d) = &desc.sunsky {
        let _ = writeln!(s, "  <emitter type=\"sunsky\">");
        for (k, v) in [
            ("turbidity", d.turbidity),
            ("sun_scale", d.sun_scale),
            ("sky_scale", d.sky_scale),
            ("sun_aperture", d.sun_aperture),
        ] {
            let _ = writeln!(s, "    <float name=\"{k}\" value=\"{v}\"/>");
        }
        let _ = writeln!(s, "    <rgb name=\"albedo\" value=\"{}\"/>", v3(d.albedo));
        let _ = writeln!(s, "    <boolean name=\"complex_sun\" value=\"{}\"/>", d.complex_sun);
        match d.sun {
            crate::desc::SunPlacement::Direction(v) => {
                let _ = writeln!(s, "    <vector name=\"sun_direction\" x=\"{}\" y=\"{}\" z=\"{}\"/>", v.x, v.y, v.z);
            }
            crate::desc::SunPlacement::At(at) => {
                for (k, v) in [("latitude", at.latitude), ("longitude", at.longitude), ("timezone", at.timezone)] {
                    let _ = writeln!(s, "    <float name=\"{k}\" value=\"{v}\"/>");
                }
                for (k, v) in [("year", at.year), ("month", at.month), ("day", at.day)] {
                    let _ = writeln!(s, "    <integer name=\"{k}\" value=\"{v}\"/>");
                }
                for (k, v) in [("hour", at.hour), ("minute", at.minute), ("second", at.second)] {
                    let _ = writeln!(s, "    <float name=\"{k}\" value=\"{v}\"/>");
                }
            }
        }
        if d.transform != Mat4::IDENTITY {
            let _ = writeln!(
                s,
                "    <transform name=\"to_world\"><matrix value=\"{}\"/></transform>",
                matrix(&d.transform)
            );
        }
        s += "  </emitter>\n";
    }
    s += "</scene>\n";
    Ok(Converted {
        text: s,
        files: Vec::new(),
        warnings: w,
    })
}
