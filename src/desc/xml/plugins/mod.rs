//! Mitsuba plugins → the scene description, one file per family (`integrators`,
//! `sensors`, `shapes`, `bsdfs`, `principled`, `textures`, `emitters`, `volume`); the scene's
//! root element and the reader they share are here. What is read of each plugin,
//! with Mitsuba's defaults, is the plugin table in the manual:
//! `docs/src/mitsuba/plugins.md`.
//!
//! Anything else is an error naming the plugin and what is supported. Colours are
//! `<rgb>`, `<spectrum>` (a constant or wavelength:value pairs, see
//! [`values::spectrum_to_rgb`] and `docs/src/mitsuba/spectra.md`) or numbers.
//!
//! Texture coordinates: rdr's images put `v = 0` at the bottom row; Mitsuba's bitmap at
//! the top and its OBJ reader flips `v` (`flip_tex_coords`), so an OBJ's coordinates
//! are used as they are and `to_uv` is rewritten for rdr's orientation.

use super::document::Element;
use super::props::{where_is, Colour, Ids, Plugin};
use crate::desc::{
    EnvMapDesc, InstanceDesc, IntegratorDesc, Located, MaterialDesc, PointLightDesc, SceneDesc, ShapeGroupDesc, Source, TextureDesc,
    TextureRef, MAX_DEPTH,
};
use crate::error::Result;
use crate::integrator::{Integrator, PathProfile, PathTracer, Roulette};
use crate::math::{Mat4, Vec3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

mod bsdfs;
mod emitters;
mod integrators;
mod media;
mod principled;
mod sensors;
mod shapes;
mod sunsky;
pub mod table;
mod textures;
mod volume;
pub use volume::volume_property;

/// The plugin table's families, in the manual page's order ([`table`]).
pub const FAMILIES: &table::Families = &[
    ("Integrators", integrators::DOCS),
    ("Sensors, films, filters and samplers", sensors::DOCS),
    ("Shapes", shapes::DOCS),
    ("BSDFs", bsdfs::DOCS),
    ("Emitters", emitters::DOCS),
    ("Sun and sky", sunsky::DOCS),
    ("Textures", textures::DOCS),
    ("Spectra", SPECTRA_DOCS),
    ("Media and phase functions", media::DOCS),
    ("Volumes", volume::DOCS),
];

/// `<spectrum type="…">` (read by `props`, not as plugins: no parameter is checked).
const SPECTRA_DOCS: &[table::PluginDoc] = &[
    table::PluginDoc {
        element: "spectrum",
        names: &["blackbody"],
        status: table::Status::Read,
        note: "`temperature` (K, required), `wavelength_min` 360, `wavelength_max` 830 (nm), converted as a \
               `wavelength:value` list is.",
        params: &[],
    },
    table::PluginDoc {
        element: "spectrum",
        names: &["regular", "irregular", "uniform", "srgb", "d65"],
        status: table::Status::Refused,
        note: "as typed spectra; a constant or `wavelength:value` pairs in `value` are read (see [Colours from spectra](spectra.md))",
        params: &[],
    },
];

/// The manual's page of Mitsuba plugins and parameters, generated from [`FAMILIES`].
pub fn plugin_table_markdown() -> String {
    table::markdown(FAMILIES)
}

pub(super) const SHAPES: &str = "obj, ply, serialized, rectangle, cube, disk, sphere, cylinder, sdfgrid, shapegroup, instance";
pub(super) const BSDFS: &str = concat!(
    "diffuse, dielectric, thindielectric, roughdielectric, conductor, roughconductor, plastic, roughplastic, twosided, ",
    "bumpmap, normalmap, mask, principled, principledthin, blendbsdf, mixturebsdf, phong"
);
pub(super) const EMITTERS: &str = "point, spot, directional, projector, constant, envmap, sunsky (and area inside a <shape>)";
pub(super) const TEXTURES: &str = "bitmap, checkerboard, mesh_attribute, rawconstant, scale";
pub(super) const INTEGRATORS: &str = "path, volpath, volpathmis, direct, ptracer, bdpt, photonmapper, sppm";
pub(super) const VOLUMES: &str = "constvolume, gridvolume";
pub(super) const FILTERS: &str = "box, tent, gaussian, mitchell";

/// Nesting of materials and textures before a reference is taken to be circular.
const MAX_NESTING: usize = 32;

/// The scene of a document's root element.
pub fn scene(root: &Element, file: &Path) -> Result<SceneDesc> {
    if root.tag != "scene" {
        return Err(root.error(format!("the root element must be <scene>, found <{}>", root.tag)));
    }
    let mut ids = Ids::collect(root)?;
    ids.table = Some(FAMILIES);
    let ids = ids;
    let mut r = Reader::new(&ids, file);
    let top = Plugin::new(root, &ids)?;
    let integrators = top.objects("integrator");
    if let Some((_, second)) = integrators.get(1) {
        return Err(second.error("more than one <integrator>"));
    }
    let (integrator, max_depth_note, aovs) = match integrators.first() {
        Some((el, _)) => r.outer_integrator(el)?,
        None => (
            Integrator::Path(PathTracer {
                max_depth: MAX_DEPTH,
                profile: PathProfile::Mis,
                rr_threshold: 0.1,
                hide_emitters: false,
                rr: Roulette::Mitsuba,
            }),
            None,
            None,
        ),
    };
    let sensors = top.objects("sensor");
    let Some((sensor, _)) = sensors.first() else {
        return Err(root.error("the scene has no <sensor> (rdr needs a perspective, thinlens or orthographic camera)"));
    };
    for (s, at) in sensors.iter().skip(1) {
        ids.warn(
            at,
            format!("only the first <sensor> is rendered; this one ({}) is ignored", where_is(s)),
        );
    }
    let (camera, film, spp) = r.sensor(sensor)?;
    let mut camera_medium = match Plugin::new(sensor, &ids)?.objects("medium").as_slice() {
        [] => None,
        [(m, at)] => Some(Located {
            value: r.medium(m)?,
            source: source(at),
        }),
        [_, (_, second), ..] => return Err(second.error("a sensor takes one <medium>")),
    };
    for (el, _) in top.objects("medium") {
        r.medium(el)?;
    }
    for (el, _) in top.objects("bsdf").into_iter().filter(|(el, _)| el.attr("type") != Some("null")) {
        r.material(el)?;
    }
    for (el, _) in top.objects("texture") {
        r.texture(el)?;
    }
    for (el, _) in top.objects("volume") {
        r.volume(el)?;
    }
    let mut objects = Vec::new();
    let mut shapegroups: Vec<ShapeGroupDesc> = Vec::new();
    let mut group_of: HashMap<*const Element, String> = HashMap::new();
    let mut instances = Vec::new();
    for (el, _) in top.objects("shape") {
        match el.attr("type") {
            Some("shapegroup") => {
                r.shapegroup(el, &mut shapegroups, &mut group_of)?;
            }
            Some("instance") => {
                let p = Plugin::new(el, &ids)?;
                let shapes = p.objects("shape");
                let (g, at) = match shapes.as_slice() {
                    [one] => *one,
                    [] => return Err(p.error("an instance needs a <ref> to a shapegroup")),
                    [_, (_, second), ..] => return Err(second.error("an instance takes one shapegroup")),
                };
                if g.attr("type") != Some("shapegroup") {
                    return Err(at.error(format!(
                        "an instance must refer to a shapegroup, found <shape type=\"{}\">",
                        g.attr("type").unwrap_or("")
                    )));
                }
                let name = r.shapegroup(g, &mut shapegroups, &mut group_of)?;
                let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
                if crate::accel::instance::Instance::new(&to_world, 0).is_none() {
                    return Err(p.value_error("to_world", "an instance's transform must be affine and invertible"));
                }
                p.finish(&["shape"])?;
                instances.push(InstanceDesc {
                    source: source(el),
                    shapegroup: Located {
                        value: name,
                        source: source(at),
                    },
                    transform: to_world,
                });
            }
            _ => objects.push(r.shape(el)?),
        }
    }
    let mut point_lights = Vec::new();
    let mut delta_lights = Vec::new();
    let mut environment_map: Option<EnvMapDesc> = None;
    let mut sunsky = None;
    for (el, at) in top.objects("emitter") {
        let p = Plugin::new(el, &ids)?;
        match p.ty.as_str() {
            "point" => {
                let mut position = p.point_opt("position")?.unwrap_or(Vec3::ZERO);
                if let Some(m) = p.transform_opt("to_world")? {
                    position = m.transform_point3(position);
                }
                let intensity = p.rgb("intensity", Vec3::ONE)?;
                if intensity.min_element() < 0.0 {
                    return Err(p.value_error("intensity", "must not be negative"));
                }
                check_point(&p, "position", position)?;
                // Mitsuba's intensity I is radiant intensity; rdr's flux Φ = 4πI
                point_lights.push(PointLightDesc {
                    position,
                    flux: intensity * (4.0 * std::f32::consts::PI),
                    key: where_is(el),
                });
                p.finish(&[])?;
            }
            "spot" => {
                let m = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
                let position = m.transform_point3(Vec3::ZERO);
                check_point(&p, "to_world", position)?;
                let texture = match p.has("texture") {
                    false => None,
                    true => match p.colour("texture", Vec3::ONE)? {
                        // Mitsuba: "The parameter 'texture' must be spatially varying"
                        Colour::Constant(_) => return Err(p.value_error("texture", "must be a texture (e.g. a bitmap), not a constant")),
                        Colour::Texture(t) => Some(TextureRef::Named(Located {
                            value: r.texture(t)?,
                            source: source(t),
                        })),
                    },
                };
                let (intensity, cutoff, beam) = (
                    p.rgb("intensity", Vec3::ONE)?,
                    p.float("cutoff_angle", 20.0)?,
                    p.float_opt("beam_width")?,
                );
                let light = match &texture {
                    None => crate::desc::spot_light(position, m.transform_vector3(Vec3::Z), intensity, cutoff, beam),
                    Some(_) => light_frame(&m).and_then(|f| crate::desc::textured_spot(position, f, intensity, cutoff, beam)),
                }
                .map_err(|e| {
                    let key = ["cutoff_angle", "beam_width", "intensity"].into_iter().find(|k| e.starts_with(k));
                    p.value_error(key.unwrap_or("to_world"), e)
                })?;
                delta_lights.push(crate::desc::DeltaLightDesc {
                    light,
                    key: where_is(el),
                    texture,
                });
                p.finish(&[])?;
            }
            "projector" => {
                let m = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
                let position = m.transform_point3(Vec3::ZERO);
                check_point(&p, "to_world", position)?;
                if !p.has("irradiance") {
                    return Err(p.error("property \"irradiance\" (a texture or a colour) is required"));
                }
                let texture = r.texture_ref(&p, "irradiance", Vec3::ONE)?;
                let axis = p.string("fov_axis", "x")?;
                let (fov, axis) = match p.float_opt("fov")? {
                    Some(f) => (f, axis),
                    None => {
                        let fov = focal_length_fov(&p)? as f32;
                        if p.has("fov_axis") {
                            ids.warn(el, "fov_axis is ignored with focal_length (the image's diagonal is used)");
                        }
                        (fov, "diagonal".to_string())
                    }
                };
                let axis = crate::light::projector::FovAxis::parse(&axis)
                    .ok_or_else(|| p.value_error("fov_axis", format!("unknown axis \"{axis}\" (x, y, diagonal, smaller, larger)")))?;
                let scale = p.float("scale", 1.0)?;
                let light = light_frame(&m)
                    .and_then(|f| crate::desc::projector_light(position, f, scale, fov, axis))
                    .map_err(|e| p.value_error(["fov", "scale"].into_iter().find(|k| e.starts_with(k)).unwrap_or("to_world"), e))?;
                delta_lights.push(crate::desc::DeltaLightDesc {
                    light,
                    key: where_is(el),
                    texture: Some(texture),
                });
                p.finish(&[])?;
            }
            "directional" => {
                let direction = match p.transform_opt("to_world")? {
                    Some(m) if !p.has("direction") => m.transform_vector3(Vec3::Z),
                    Some(_) => return Err(p.error("give either direction or to_world")),
                    None => p.point_opt("direction")?.unwrap_or(Vec3::Z),
                };
                let light = crate::desc::directional_light(direction, p.rgb("irradiance", Vec3::ONE)?)
                    .map_err(|e| p.value_error(if e.starts_with("irradiance") { "irradiance" } else { "direction" }, e))?;
                delta_lights.push(crate::desc::DeltaLightDesc {
                    light,
                    key: where_is(el),
                    texture: None,
                });
                p.finish(&[])?;
            }
            "constant" | "envmap" | "sunsky" => {
                if environment_map.is_some() || sunsky.is_some() {
                    return Err(at.error("more than one environment emitter (rdr has one environment)"));
                }
                if p.ty == "sunsky" {
                    sunsky = Some(r.sunsky(&p)?);
                } else {
                    environment_map = Some(r.environment(&p)?);
                }
            }
            // Mitsuba 3: a top-level area emitter is attached to the one shape that refers to it
            // (read there); one nobody refers to is dropped
            "area" if r.area_owner.contains_key(&(el as *const Element)) => {}
            "area" => ids.warn(
                el,
                "an area emitter outside a <shape> that no shape refers to emits nothing (as in Mitsuba): left out",
            ),
            "timed_sunsky" => ids.warn(
                el,
                format!(
                    "emitter \"{}\" (Mitsuba 3's sun and sky) is not built in rdr: left out, the scene renders without it",
                    p.ty
                ),
            ),
            other => return Err(at.error(format!("unsupported emitter \"{other}\" (supported: {EMITTERS})"))),
        }
    }
    top.finish(&["integrator", "sensor", "bsdf", "texture", "shape", "emitter", "medium", "volume"])?;
    // Mitsuba's `path` (its default too) ignores media: null boundaries pass, media are vacuum
    let renders_media = integrators.first().is_some_and(|(el, _)| integrator_renders_media(el));
    if !renders_media && !r.media.is_empty() {
        let at = integrators.first().map_or(root, |(el, _)| *el);
        ids.warn(
            at,
            "the scene's media are vacuum under this integrator (as in Mitsuba): volpath renders them",
        );
        camera_medium = None;
        for o in objects.iter_mut().chain(shapegroups.iter_mut().flat_map(|g| g.objects.iter_mut())) {
            (o.interior, o.exterior) = (None, None);
        }
        r.media.clear();
    }
    if let Some(first) = ids.undeclared.borrow().first() {
        // a reader and its rows in the plugin table disagree: a bug in rdr, not in the scene
        return Err(root.error(format!("internal error, please report: {first}")));
    }
    if let Some((el, msg)) = max_depth_note {
        ids.warn(el, msg);
    }
    let warnings = ids.warnings.borrow().clone();
    let convert_notes = ids.convert_notes.borrow().clone();
    let unknown = ids.unknown.borrow().clone();
    Ok(SceneDesc {
        file: file.to_path_buf(),
        base_dir: r.base_dir.clone(),
        integrator: IntegratorDesc {
            integrator,
            spp,
            point_lights,
            delta_lights,
            light_sampling: crate::light::LightSampling::Importance,
            aovs,
        },
        film,
        camera,
        textures: r.textures,
        materials: r.materials,
        objects,
        shapegroups,
        instances,
        environment_map,
        sunsky,
        media: r.media,
        camera_medium,
        warnings,
        unknown,
        included: Vec::new(),
        convert_notes,
    })
}

/// Whether the integrator element (or the one an `aov` wraps) renders media: `volpath`
/// and `volpathmis`; Mitsuba's others see vacuum.
fn integrator_renders_media(el: &Element) -> bool {
    match el.attr("type") {
        Some("volpath" | "volpathmis") => true,
        Some("aov") => el.children.iter().any(|c| c.tag == "integrator" && integrator_renders_media(c)),
        _ => false,
    }
}

fn source(el: &Element) -> Source {
    el.source.clone()
}

fn check_point(p: &Plugin, name: &str, v: Vec3) -> Result<()> {
    if v.abs().max_element() > crate::limits::MAX_COORD {
        return Err(p.value_error(
            name,
            format!("{v} is out of range (coordinates must be within ±{:e})", crate::limits::MAX_COORD),
        ));
    }
    Ok(())
}

struct Reader<'a> {
    ids: &'a Ids<'a>,
    base_dir: PathBuf,
    textures: Vec<TextureDesc>,
    materials: Vec<MaterialDesc>,
    material_of: HashMap<*const Element, String>,
    texture_of: HashMap<*const Element, String>,
    /// The same for textures read as floats where they differ ([`Reader::float_texture_ref`]).
    float_texture_of: HashMap<*const Element, String>,
    depth: usize,
    media: Vec<crate::desc::MediumDesc>,
    medium_of: HashMap<*const Element, String>,
    /// The shape each area emitter is attached to (Mitsuba attaches one to one shape).
    area_owner: HashMap<*const Element, String>,
    /// The scene file (grid volumes' errors name it).
    file: PathBuf,
}

impl<'a> Reader<'a> {
    fn new(ids: &'a Ids<'a>, file: &Path) -> Reader<'a> {
        let base_dir = file
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf();
        Reader {
            ids,
            base_dir,
            textures: Vec::new(),
            materials: Vec::new(),
            material_of: HashMap::new(),
            texture_of: HashMap::new(),
            float_texture_of: HashMap::new(),
            depth: 0,
            media: Vec::new(),
            medium_of: HashMap::new(),
            area_owner: HashMap::new(),
            file: file.to_path_buf(),
        }
    }

    /// A file named in `el`, found as [`Element::resolve`] does, relative to the
    /// scene's folder when it is there and absolute otherwise.
    fn file(&self, el: &Element, p: &Plugin, name: &str) -> Result<Located<String>> {
        let given = p.required_string(name)?;
        let found = el.resolve(&given);
        let value = if found == self.base_dir.join(&given) {
            given
        } else if found.is_absolute() {
            found.display().to_string()
        } else {
            std::env::current_dir()
                .map(|d| d.join(&found))
                .unwrap_or(found)
                .display()
                .to_string()
        };
        Ok(Located { value, source: source(el) })
    }

    fn unique(&self, wanted: Option<&str>, prefix: &str) -> String {
        let taken = |n: &str| self.materials.iter().any(|m| m.name == n) || self.textures.iter().any(|t| t.name == n);
        if let Some(w) = wanted {
            if !taken(w) {
                return w.to_string();
            }
        }
        let base = wanted.unwrap_or(prefix);
        (1..).map(|i| format!("{base}_{i}")).find(|n| !taken(n)).expect("some name is free")
    }
}

/// The frame of a light's `to_world` (its x, y and z axes, normalised): Mitsuba's
/// local frame of `spot` and `projector`.
/// The diagonal field of view (degrees) of the `focal_length` key ("50mm" by default) on
/// a 35 mm film's diagonal (36 × 24 mm), as Mitsuba's sensors and projector read it.
fn focal_length_fov(p: &Plugin) -> Result<f64> {
    let f = p.string("focal_length", "50mm")?;
    let mm: f64 = f
        .trim()
        .trim_end_matches("mm")
        .trim()
        .parse()
        .ok()
        .filter(|v: &f64| *v > 0.0)
        .ok_or_else(|| p.value_error("focal_length", format!("expected a length such as \"50mm\", found \"{f}\"")))?;
    Ok(2.0 * (36f64.hypot(24.0) / (2.0 * mm)).atan().to_degrees())
}

fn light_frame(m: &Mat4) -> std::result::Result<crate::math::Frame, String> {
    let (s, t, n) = (
        m.transform_vector3(Vec3::X).normalize_or_zero(),
        m.transform_vector3(Vec3::Y).normalize_or_zero(),
        m.transform_vector3(Vec3::Z).normalize_or_zero(),
    );
    if s == Vec3::ZERO || t == Vec3::ZERO || n == Vec3::ZERO || !(s.is_finite() && t.is_finite() && n.is_finite()) {
        return Err("the light's transform is degenerate".into());
    }
    Ok(crate::math::Frame { s, t, n })
}
