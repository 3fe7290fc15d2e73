//! Mitsuba plugins → the scene description. What is read, with Mitsuba's defaults
//! (which differ from RDR171's in places):
//!
//! | element | plugins and properties (defaults) |
//! |---|---|
//! | `<integrator>` | `path` and `volpath` (rdr has no media: `volpath` is `path`, whose rays pass through `mask`s as volpath's do; `max_depth` −1 = unbounded, capped at [`MAX_DEPTH`]; `rr_depth` 5, read and checked: rdr's Russian roulette is its own and unbiased; `hide_emitters` false, only false), `direct` (= `path` with `max_depth` 2: light at the first surface by emitter and BSDF sampling; `emitter_samples`, `bsdf_samples` noted), `ptracer`, `bdpt` (`max_depth`), `photonmapper`/`photon` (`global_photons` 100000, `lookup_size` 64 … rdr's `photon`), `sppm` (`photon_count`, `initial_radius`, `alpha` 0.7). No integrator: `path`. |
//! | `<sensor>` | `perspective`: `fov` (or `focal_length`, "50mm" on the 36×24 mm diagonal), `fov_axis` (`x` \| `y` \| `diagonal` \| `smaller` \| `larger`, `x`), `to_world` (a rigid transform, no mirroring); `thinlens`: as `perspective`, and `aperture_radius` (required; 0 is a pinhole), `focus_distance` (`far_clip`, 10⁴), no scale in `to_world` (JSON `camera.type` `thinlens`); `orthographic`: `to_world` whose scale s (equal in x and y) sizes the window as Mitsuba's, 2s wide and 2s·height/width tall (JSON `orthographic` with that `height`); `near_clip`, `far_clip` (distances along the view axis, as Mitsuba's; applied only when given: 0 and unbounded otherwise). One sensor; more are ignored with a warning. Example: `<sensor type="orthographic"><transform name="to_world"><scale value="1.1"/><lookat origin="0, 1, 6.8" target="0, 1, 0" up="0, 1, 0"/></transform></sensor>`. |
//! | `<film>` | `hdrfilm`: `width` 768, `height` 576, `rfilter` (default `gaussian`); `pixel_format`, `component_format`, `file_format`, `banner` noted. |
//! | `<rfilter>` | `box` (`radius` 0.5), `tent` (`radius` 1), `gaussian` (`stddev` 0.5, radius 4·stddev), `mitchell` (`B`, `C` 1/3, radius 2) |
//! | `<sampler>` | any type: `sample_count` (4) → spp; the type is noted, rdr uses its own sampler. |
//! | `<shape>` | `obj`, `ply` (`filename`, `face_normals` false: else smooth vertex normals when the file has none; `flip_normals`; `flip_tex_coords`, true for OBJ, false for PLY), `serialized` (`filename`, `shape_index` 0), `rectangle`, `cube`, `disk` (generated meshes), `sphere` (`center` 0, `radius` 1; Mitsuba's uv (φ/2π, θ/π) about the object frame's z, `to_world`'s rotation included, which rdr holds as (φ/2π, 1 − θ/π) like a mesh's: JSON `uv_frame`), `cylinder` (open, analytic: `p0` (0,0,0), `p1` (0,0,1), `radius` 1, `flip_normals`; Mitsuba's uv (φ/2π, height), which rdr holds as (φ/2π, 1 − height) like a mesh's; `to_world` a rotation, translation and scale uniform across the axis); all take `to_world`, one `<bsdf>` and one `area` `<emitter>`. A shape with neither gets Mitsuba's default, a diffuse 0.5. `shapegroup` (an `id`, plain shapes inside, no emitters: Mitsuba refuses them too; rendered only through instances) and `instance` (a `<ref>` to a shapegroup, `to_world` affine and invertible): a two-level BVH, one bottom level per group shared by its instances. Example: `<shape type="shapegroup" id="g"><shape type="obj">…</shape></shape> <shape type="instance"><ref id="g"/><transform name="to_world"><translate x="2"/></transform></shape>`. |
//! | `<bsdf>` | `diffuse` (`reflectance` 0.5, a colour or texture); `dielectric`, `thindielectric` (`int_ior` "bk7", `ext_ior` "air": numbers or names, η = int/ext; `specular_reflectance`, `specular_transmittance` 1, colours); `roughdielectric` (as `dielectric`, and `distribution` beckmann \| ggx, `alpha` 0.1 or `alpha_u`+`alpha_v`); `conductor` and `roughconductor` (`material` "none", or a name from [`values::NAMED_CONDUCTORS`] such as "Au"; else `eta` 0 / `k` 1 (a perfect mirror); `specular_reflectance` 1, a colour or texture; `roughconductor`'s `alpha`, `alpha_u`/`alpha_v`, `distribution` as `roughdielectric`; the 0.6 `ext_eta` folded into η and k); `plastic` (`diffuse_reflectance` 0.5, a colour or texture; `specular_reflectance` 1; `int_ior` "polypropylene" (1.49), `ext_ior` "air"; `nonlinear` false), `roughplastic` (as `plastic`, and `alpha` 0.1 (isotropic), `distribution` beckmann); `twosided` (one or two nested non-transmitting bsdfs: around one `diffuse` it is rdr's two-sided diffuse, around one `roughconductor` that material made two-sided (a bare one is black from behind, as Mitsuba's), otherwise rdr's `twosided` with the second as the back). `bumpmap` (one nested `<texture>`, the heights; `scale` 1; `flip_invalid_normals`, `use_shadowing_function` true), `normalmap` (`<texture name="normalmap">`, the same two switches), `mask` (`opacity` 0.5, a float or texture; outermost only), each around one nested `<bsdf>`; see [`crate::material::bump`] and [`Material::Mask`]. `principled` (`base_color` 0.5, `roughness` 0.5, `metallic`, `spec_tint`, `anisotropic`, `sheen`, `sheen_tint`, `clearcoat`, `clearcoat_gloss`, `spec_trans`, `flatness` 0: numbers, colours or textures; `eta` or `specular` 0.5, not both; `main_specular_sampling_rate`, `clearcoat_sampling_rate`, `diffuse_reflectance_sampling_rate` 1; see [`crate::desc::principled`]); `principledthin` (`base_color`, `roughness` 0.5, `anisotropic`, `spec_trans`, `spec_tint`, `sheen`, `sheen_tint`, `flatness`, `diff_trans` 0 (up to 2), `eta` 1.5, each a number, colour or texture; four sampling rates); `blendbsdf` (`weight`, required, a float or texture; two nested bsdfs, the first at weight 0). Example: `<bsdf type="twosided"><bsdf type="roughplastic"><float name="alpha" value="0.2"/></bsdf></bsdf>`. |
//! | `<emitter>` | `area` (in a shape: `radiance` 1, a colour or a texture looked up at the emitting point's uv), `point` (`position` or `to_world`; `intensity` I (1) → flux 4πI), `spot` (`to_world`: at its origin, along its +z; `intensity` 1, `cutoff_angle` 20°, `beam_width` ¾ of it; linear falloff in angle; `texture`: an image projected over the cone, its x and y along `to_world`'s, `cutoff_angle` < 90° then, see [`crate::light::textured_spot`]), `projector` (`irradiance` a texture or colour, required; `scale` 1; `fov` with `fov_axis` (`x`) or `focal_length` ("50mm", on the diagonal); `to_world`: a pinhole at its origin looking along +z; intensity π·scale·E/cos³θ, see [`crate::light::projector`]), `directional` (`direction` or `to_world`'s +z, of travel; `irradiance` 1) — these two for every integrator, `constant` (`radiance` 1), `envmap` (`filename`, `scale` 1, `to_world`) |
//! | `<texture>` | `bitmap` (`filename`, `to_uv`; `filter_type` `bilinear` (the full-resolution image: Mitsuba has no MIP maps) \| `nearest`; `raw` false (true: 8-bit PNG/JPEG values as they are, not decoded from sRGB); `wrap_mode` noted), `checkerboard` (`color0` 0.4, `color1` 0.2, `to_uv`); the 0.6 `uoffset`, `voffset`, `uscale`, `vscale` become `to_uv`; `mesh_attribute` (`name` "vertex_color" | "face_color", required: a PLY file's `red green blue`; `scale` 1) |
//!
//! Anything else is an error naming the plugin and what is supported. Colours are
//! `<rgb>`, `<spectrum>` (a constant or wavelength:value pairs, see
//! [`values::spectrum_to_rgb`]) or numbers.
//!
//! Texture coordinates: rdr's images put `v = 0` at the bottom row; Mitsuba's bitmap at
//! the top and its OBJ reader flips `v` (`flip_tex_coords`), so an OBJ's coordinates
//! are used as they are and `to_uv` is rewritten for rdr's orientation.

use super::document::Element;
use super::props::{where_is, Colour, Ids, Plugin};
use super::values;
use crate::camera::CameraParams;
use crate::desc::{
    AreaLightDesc, EnvMapDesc, FilmDesc, ImageFile, InstanceDesc, IntegratorDesc, Located, MaterialDesc, MeshFile, MeshFormat, MeshNormals,
    MeshOptions, ObjectDesc, PointLightDesc, SceneDesc, ShapeGroupDesc, Source, TextureDesc, TextureRef, MAX_DEPTH, MAX_FILTER_RADIUS,
};
use crate::error::Result;
use crate::film::Filter;
use crate::geometry::sphere::Sphere;
use crate::integrator::{bdpt::Heuristic, Bdpt, Integrator, PathProfile, PathTracer, PhotonMapper, Ptracer, Sppm};
use crate::material::{Distribution, Material};
use crate::math::{Mat4, Vec2, Vec3};
use crate::scene::Shape;
use crate::texture::{Texture, UvMapping};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

mod principled;

const SHAPES: &str = "obj, ply, serialized, rectangle, cube, disk, sphere, cylinder, shapegroup, instance";
const BSDFS: &str =
    "diffuse, dielectric, thindielectric, roughdielectric, conductor, roughconductor, plastic, roughplastic, twosided, bumpmap, normalmap, mask, principled, principledthin, blendbsdf";
const EMITTERS: &str = "point, spot, directional, projector, constant, envmap (and area inside a <shape>)";
const TEXTURES: &str = "bitmap, checkerboard, mesh_attribute";
const INTEGRATORS: &str = "path, volpath (without media), direct, ptracer, bdpt, photonmapper, sppm";
const FILTERS: &str = "box, tent, gaussian, mitchell";

/// Nesting of materials and textures before a reference is taken to be circular.
const MAX_NESTING: usize = 32;

/// The scene of a document's root element.
pub fn scene(root: &Element, file: &Path) -> Result<SceneDesc> {
    if root.tag != "scene" {
        return Err(root.error(format!("the root element must be <scene>, found <{}>", root.tag)));
    }
    let ids = Ids::collect(root)?;
    let base_dir = file
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf();
    let mut r = Reader {
        ids: &ids,
        base_dir,
        textures: Vec::new(),
        materials: Vec::new(),
        material_of: HashMap::new(),
        texture_of: HashMap::new(),
        float_texture_of: HashMap::new(),
        depth: 0,
    };
    let top = Plugin::new(root, &ids)?;
    let integrators = top.objects("integrator");
    if let Some((_, second)) = integrators.get(1) {
        return Err(second.error("more than one <integrator>"));
    }
    let (integrator, max_depth_note) = match integrators.first() {
        Some((el, _)) => r.integrator(el)?,
        None => (
            Integrator::Path(PathTracer {
                max_depth: MAX_DEPTH,
                profile: PathProfile::Mis,
                rr_threshold: 0.1,
            }),
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
    for (el, _) in top.objects("bsdf") {
        r.material(el)?;
    }
    for (el, _) in top.objects("texture") {
        r.texture(el)?;
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
            "constant" | "envmap" => {
                if environment_map.is_some() {
                    return Err(at.error("more than one environment emitter (rdr has one environment)"));
                }
                environment_map = Some(r.environment(&p)?);
            }
            "area" => return Err(at.error("an area emitter must be inside a <shape>")),
            other => return Err(at.error(format!("unsupported emitter \"{other}\" (supported: {EMITTERS})"))),
        }
    }
    top.finish(&["integrator", "sensor", "bsdf", "texture", "shape", "emitter"])?;
    if let Some((el, msg)) = max_depth_note {
        ids.warn(el, msg);
    }
    let warnings = ids.warnings.borrow().clone();
    let convert_notes = ids.convert_notes.borrow().clone();
    Ok(SceneDesc {
        file: file.to_path_buf(),
        base_dir: r.base_dir.clone(),
        integrator: IntegratorDesc {
            integrator,
            spp,
            point_lights,
            delta_lights,
            light_sampling: crate::light::LightSampling::Importance,
        },
        film,
        camera,
        textures: r.textures,
        materials: r.materials,
        objects,
        shapegroups,
        instances,
        environment_map,
        warnings,
        included: Vec::new(),
        convert_notes,
    })
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

/// `int_ior` / `ext_ior` (numbers or names; `ext_ior` "air" by default).
fn ior_ratio(p: &Plugin, int_default: &str) -> Result<f32> {
    let eta = p.ior("int_ior", int_default)? / p.ior("ext_ior", "air")?;
    if !(1e-3..=1e3).contains(&eta) {
        return Err(p.error(format!("int_ior / ext_ior = {eta} is out of range")));
    }
    Ok(eta)
}

/// A constant, non-negative reflectance or transmittance (1 by default); rdr's
/// dielectrics and coatings take no textures here.
fn colour_of(p: &Plugin, name: &str) -> Result<Vec3> {
    let c = p.rgb(name, Vec3::ONE)?;
    if !(c.min_element() >= 0.0 && c.is_finite()) {
        return Err(p.value_error(name, "must not be negative"));
    }
    Ok(c)
}

/// `alpha` (0.1), or both `alpha_u` and `alpha_v`; each in [0, 10].
fn alphas(p: &Plugin) -> Result<(f32, f32)> {
    let (ax, ay) = if p.has("alpha_u") || p.has("alpha_v") {
        if !(p.has("alpha_u") && p.has("alpha_v")) || p.has("alpha") {
            return Err(p.error("give either alpha, or both alpha_u and alpha_v"));
        }
        (p.float("alpha_u", 0.1)?, p.float("alpha_v", 0.1)?)
    } else {
        let a = p.float("alpha", 0.1)?;
        (a, a)
    };
    for (k, a) in [("alpha", ax), ("alpha_v", ay)] {
        if !(0.0..=10.0).contains(&a) {
            return Err(p.value_error(k, format!("must be between 0 and 10, found {a}")));
        }
    }
    Ok((ax, ay))
}

/// `distribution`: `beckmann` (the default) or `ggx`.
fn distribution(p: &Plugin) -> Result<Distribution> {
    match p.string("distribution", "beckmann")?.to_ascii_lowercase().as_str() {
        "beckmann" => Ok(Distribution::Beckmann),
        "ggx" => Ok(Distribution::Ggx),
        other => Err(p.value_error("distribution", format!("unknown distribution \"{other}\" (beckmann, ggx)"))),
    }
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
}

impl<'a> Reader<'a> {
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

    fn integrator(&self, el: &'a Element) -> Result<(Integrator, Option<(&'a Element, String)>)> {
        let p = Plugin::new(el, self.ids)?;
        let mut note = None;
        let mut depth = |default: i64| -> Result<u32> {
            let d = p.integer("max_depth", default)?;
            if d == -1 || d > MAX_DEPTH as i64 {
                if d != -1 || default == -1 {
                    note = Some((
                        el,
                        format!("max_depth {d} is more than the {MAX_DEPTH} supported; using {MAX_DEPTH}"),
                    ));
                }
                return Ok(MAX_DEPTH);
            }
            if d < 1 {
                return Err(p.value_error("max_depth", format!("must be −1 (unbounded) or at least 1, found {d}")));
            }
            Ok(d as u32)
        };
        let integrator = match p.ty.as_str() {
            // rdr has no participating media: `volpath` of a scene without them is `path`
            // (whose shadow rays pass through masks as volpath's do)
            "path" | "volpath" => {
                let max_depth = depth(-1)?;
                p.integer_in("rr_depth", 5, 1, i32::MAX as i64)?;
                Integrator::Path(PathTracer {
                    max_depth,
                    profile: PathProfile::Mis,
                    rr_threshold: 0.1,
                })
            }
            "direct" => {
                for k in ["emitter_samples", "bsdf_samples", "shading_samples"] {
                    if let Some(n) = p.integer_opt(k)? {
                        if n != 1 {
                            self.ids
                                .warn(el, format!("{k} {n} noted: rdr takes one emitter and one BSDF sample per pass"));
                        }
                    }
                }
                Integrator::Path(PathTracer {
                    max_depth: 2,
                    profile: PathProfile::Mis,
                    rr_threshold: 0.1,
                })
            }
            "ptracer" => {
                let max_depth = depth(-1)?;
                p.integer_in("rr_depth", 5, 1, i32::MAX as i64)?;
                p.ignore("samples_per_pass");
                Integrator::Ptracer(Ptracer {
                    max_depth,
                    rr_threshold: 0.1,
                })
            }
            "bdpt" => {
                let max_depth = depth(-1)?;
                p.integer_in("rr_depth", 5, 1, i32::MAX as i64)?;
                for k in ["light_image", "sample_direct", "strict_normals"] {
                    p.ignore(k);
                }
                Integrator::Bdpt(Bdpt {
                    max_depth,
                    rr_threshold: 0.1,
                    heuristic: Heuristic::Power,
                    strategy: None,
                    strategy_weighted: false,
                    visualize_strategies: false,
                    connection_roulette: crate::integrator::bdpt::CONNECTION_ROULETTE,
                })
            }
            "photonmapper" | "photon" => {
                let max_depth = depth(-1)?;
                Integrator::Photon(PhotonMapper {
                    n_photons: p.integer_in("global_photons", 100_000, 1, i32::MAX as i64)? as u32,
                    n_iterations: 1,
                    n_near_photons: p.integer_in("lookup_size", 64, 1, 1 << 20)? as u32,
                    max_depth,
                    rr_threshold: 0.1,
                })
            }
            "sppm" => {
                let max_depth = depth(-1)?;
                let alpha = p.float("alpha", 0.7)?;
                if !(alpha > 0.0 && alpha <= 1.0) {
                    return Err(p.value_error("alpha", "must lie in (0, 1]"));
                }
                let r = p.float_opt("initial_radius")?.filter(|r| *r > 0.0);
                Integrator::Sppm(Sppm {
                    photons_per_iteration: p.integer_in("photon_count", 250_000, 1, i32::MAX as i64)? as u32,
                    initial_radius: r,
                    alpha,
                    max_depth,
                    rr_threshold: 0.1,
                })
            }
            other => return Err(p.error(format!("unsupported integrator \"{other}\" (supported: {INTEGRATORS})"))),
        };
        if p.boolean("hide_emitters", false)? {
            return Err(p.value_error("hide_emitters", "is not supported (rdr's camera rays always see emitters)"));
        }
        p.finish(&[])?;
        Ok((integrator, note))
    }

    fn sensor(&self, el: &'a Element) -> Result<(CameraParams, FilmDesc, u32)> {
        let p = Plugin::new(el, self.ids)?;
        if !["perspective", "thinlens", "orthographic"].contains(&p.ty.as_str()) {
            return Err(p.error(format!(
                "unsupported sensor \"{}\" (supported: perspective, thinlens, orthographic)",
                p.ty
            )));
        }
        let films = p.objects("film");
        let film = match films.first() {
            Some((f, _)) => self.film(f)?,
            None => FilmDesc {
                width: 768,
                height: 576,
                block_size: 16,
                filter: Filter::gaussian(2.0, 2.0),
            },
        };
        let spp = match p.objects("sampler").first() {
            Some((s, _)) => {
                let sp = Plugin::new(s, self.ids)?;
                if sp.ty != "independent" {
                    self.ids.warn(
                        s,
                        format!("sampler \"{}\" noted: rdr uses its own (Owen-scrambled Sobol) sampler", sp.ty),
                    );
                }
                let n = sp.integer_in("sample_count", 4, 1, u32::MAX as i64)? as u32;
                for k in ["seed", "jitter", "scramble", "dimension"] {
                    sp.ignore(k);
                }
                sp.finish(&[])?;
                n
            }
            None => 4,
        };
        if p.ty == "orthographic" {
            for k in ["fov", "fov_axis", "focal_length"] {
                if p.has(k) {
                    self.ids.warn(el, format!("{k} is ignored by an orthographic sensor"));
                    p.ignore(k);
                }
            }
            return self.camera(&p, 45.0, "x", film, spp);
        }
        let axis = p.string("fov_axis", "x")?;
        let fov_deg = match p.float_opt("fov")? {
            Some(f) => f as f64,
            None => {
                let fov = focal_length_fov(&p)?;
                if p.has("fov_axis") {
                    self.ids
                        .warn(el, "fov_axis is ignored with focal_length (the film's diagonal is used)");
                }
                return self.camera(&p, fov, "diagonal", film, spp);
            }
        };
        self.camera(&p, fov_deg, &axis, film, spp)
    }

    fn camera(&self, p: &Plugin, fov_deg: f64, axis: &str, film: FilmDesc, spp: u32) -> Result<(CameraParams, FilmDesc, u32)> {
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(p.value_error("fov", format!("must be between 0 and 180 degrees, found {fov_deg}")));
        }
        let (w, h) = (film.width as f64, film.height as f64);
        let t = (fov_deg.to_radians() / 2.0).tan();
        let axis = match axis {
            "smaller" if w <= h => "x",
            "smaller" => "y",
            "larger" if w >= h => "x",
            "larger" => "y",
            a => a,
        };
        let vt = match axis {
            "x" => t * h / w,
            "y" => t,
            "diagonal" => t * h / w.hypot(h),
            other => return Err(p.value_error("fov_axis", format!("unknown axis \"{other}\" (x, y, diagonal, smaller, larger)"))),
        };
        // clipping only where the scene asks for it (Mitsuba's defaults, 0.01 and 10⁴, would
        // hide nothing in the scenes rdr reads but change every ray's range)
        let near_clip = p.float_opt("near_clip")?.unwrap_or(0.0);
        let far_clip = p.float_opt("far_clip")?.unwrap_or(f32::INFINITY);
        crate::camera::check_clip_range(near_clip, far_clip).map_err(|(key, why)| p.value_error(key, why))?;
        for k in ["principal_point_offset_x", "principal_point_offset_y"] {
            if p.float(k, 0.0)? != 0.0 {
                return Err(p.value_error(k, "an off-centre principal point is not supported"));
            }
        }
        let m = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        let origin = m.transform_point3(Vec3::ZERO);
        let dir = m.transform_vector3(Vec3::Z);
        let up = m.transform_vector3(Vec3::Y);
        let left = m.transform_vector3(Vec3::X);
        if !(dir.length() > 0.0 && up.cross(dir).length() > 0.0) {
            return Err(p.value_error("to_world", "the camera transform is degenerate"));
        }
        if left.dot(up.cross(dir)) < 0.0 {
            return Err(p.value_error("to_world", "a mirroring camera transform (negative scale) is not supported"));
        }
        let projection = match p.ty.as_str() {
            "thinlens" => {
                // Mitsuba: aperture_radius required (0 becomes a tiny one), focus_distance
                // defaulting to far_clip (10⁴); no scale in to_world
                let aperture_radius = p
                    .float_opt("aperture_radius")?
                    .ok_or_else(|| p.error(format!("{} needs the property \"aperture_radius\"", p.describe())))?;
                if !(0.0..1e15).contains(&aperture_radius) {
                    return Err(p.value_error("aperture_radius", format!("must be at least 0, found {aperture_radius}")));
                }
                let focus_distance = p.float("focus_distance", p.float("far_clip", 1e4)?)?;
                if !(focus_distance > 0.0 && focus_distance < 1e15) {
                    return Err(p.value_error("focus_distance", format!("must be positive, found {focus_distance}")));
                }
                let scaled = |v: Vec3| (v.length() - 1.0).abs() > 1e-4;
                if scaled(dir) || scaled(up) || scaled(left) {
                    return Err(p.value_error("to_world", "a thinlens sensor's transform cannot scale (Mitsuba refuses it too)"));
                }
                if aperture_radius == 0.0 {
                    crate::camera::Projection::Pinhole
                } else {
                    crate::camera::Projection::ThinLens {
                        aperture_radius,
                        focus_distance,
                    }
                }
            }
            "orthographic" => {
                // Mitsuba's window is x ∈ [−1, 1], y ∈ [−1/aspect, 1/aspect] in camera
                // space, scaled by to_world: height 2·s_y·h/w (and width 2·s_x)
                let (sx, sy) = (left.length(), up.length());
                if (sx - sy).abs() > 1e-4 * sx.max(sy) {
                    return Err(p.value_error(
                        "to_world",
                        format!("an orthographic sensor scaled differently in x ({sx}) and y ({sy}) is not supported"),
                    ));
                }
                let height = 2.0 * sy * film.height as f32 / film.width as f32;
                if !(height > 1e-6 && height < 1e15) {
                    return Err(p.value_error("to_world", format!("the orthographic window's height {height} is out of range")));
                }
                crate::camera::Projection::Orthographic { height }
            }
            _ => crate::camera::Projection::Pinhole,
        };
        let camera = CameraParams {
            position: origin,
            look_at: origin + dir.normalize(),
            ref_up: up.normalize(),
            fov: (2.0 * vt.atan()).to_degrees() as f32,
            focal_length: 1.0,
            projection,
            near_clip,
            far_clip,
        };
        if origin.abs().max_element() > crate::limits::MAX_COORD || !crate::camera::Camera::new(&camera, 1, 1).is_finite() {
            return Err(p.value_error("to_world", "the camera's view basis is not finite"));
        }
        p.finish(&["film", "sampler"])?;
        Ok((camera, film, spp))
    }

    fn film(&self, el: &Element) -> Result<FilmDesc> {
        let p = Plugin::new(el, self.ids)?;
        if p.ty != "hdrfilm" {
            return Err(p.error(format!("unsupported film \"{}\" (supported: hdrfilm)", p.ty)));
        }
        let w = p.integer_in("width", 768, 1, 1 << 20)?;
        let h = p.integer_in("height", 576, 1, 1 << 20)?;
        if w * h > 1 << 28 {
            return Err(p.error(format!("a film of {w}x{h} pixels is too large")));
        }
        for k in [
            "pixel_format",
            "component_format",
            "file_format",
            "high_quality_edges",
            "sample_border",
            "compensate",
        ] {
            p.ignore(k);
        }
        if p.has("banner") {
            p.ignore("banner");
            self.ids.warn(el, "banner noted (Mitsuba 0.6): rdr writes no banner");
        }
        for k in ["crop_offset_x", "crop_offset_y", "crop_width", "crop_height"] {
            if p.has(k) {
                return Err(p.value_error(k, "cropped films are not supported"));
            }
        }
        let filter = match p.objects("rfilter").first() {
            None => Filter::gaussian(2.0, 2.0),
            Some((f, _)) => self.filter(f)?,
        };
        p.finish(&["rfilter"])?;
        Ok(FilmDesc {
            width: w as u32,
            height: h as u32,
            block_size: 16,
            filter,
        })
    }

    fn filter(&self, el: &Element) -> Result<Filter> {
        let p = Plugin::new(el, self.ids)?;
        let radius = |default: f32| -> Result<f32> {
            let r = p.float("radius", default)?;
            if !(r > 0.0 && r <= MAX_FILTER_RADIUS) {
                return Err(p.value_error("radius", format!("must be in (0, {MAX_FILTER_RADIUS}], found {r}")));
            }
            Ok(r)
        };
        let f = match p.ty.as_str() {
            "box" => Filter::Box { radius: radius(0.5)? },
            "tent" => Filter::Tent { radius: radius(1.0)? },
            "gaussian" => {
                let s = p.float("stddev", 0.5)?;
                if !(s >= 0.05 && 4.0 * s <= MAX_FILTER_RADIUS) {
                    return Err(p.value_error("stddev", format!("must be between 0.05 and {}, found {s}", MAX_FILTER_RADIUS / 4.0)));
                }
                // exp(−x²/2σ²), cut off at 4σ as Mitsuba does
                Filter::gaussian(4.0 * s, 1.0 / (2.0 * s * s))
            }
            "mitchell" => Filter::Mitchell {
                radius: 2.0,
                b: p.float("B", 1.0 / 3.0)?,
                c: p.float("C", 1.0 / 3.0)?,
            },
            other => return Err(p.error(format!("unsupported rfilter \"{other}\" (supported: {FILTERS})"))),
        };
        p.finish(&[])?;
        Ok(f)
    }

    fn shape(&mut self, el: &'a Element) -> Result<ObjectDesc> {
        let p = Plugin::new(el, self.ids)?;
        let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        if to_world.determinant() == 0.0 {
            return Err(p.value_error("to_world", "the transform is singular"));
        }
        let flip_normals = p.boolean("flip_normals", false)?;
        let mesh = |format: MeshFormat, path: Located<String>, flip_uv: bool, normals: MeshNormals| {
            Shape::Mesh(MeshFile {
                path,
                transform: to_world,
                translate: Vec3::ZERO,
                options: MeshOptions {
                    format,
                    normals,
                    flip_normals,
                    flip_uv,
                },
            })
        };
        let normals = |p: &Plugin| -> Result<MeshNormals> {
            Ok(if p.boolean("face_normals", false)? {
                MeshNormals::Face
            } else {
                MeshNormals::SmoothWhenMissing
            })
        };
        let none = Located {
            value: String::new(),
            source: source(el),
        };
        let shape = match p.ty.as_str() {
            "obj" => {
                let path = self.file(el, &p, "filename")?;
                // Mitsuba flips OBJ's v by default, which is rdr's orientation already
                let flip = !p.boolean("flip_tex_coords", true)?;
                mesh(MeshFormat::Obj, path, flip, normals(&p)?)
            }
            "ply" => {
                let path = self.file(el, &p, "filename")?;
                // Mitsuba's PLY reader keeps v as it is (v = 0 is an image's top row)
                let flip = !p.boolean("flip_tex_coords", false)?;
                mesh(MeshFormat::Ply, path, flip, normals(&p)?)
            }
            "serialized" => {
                let path = self.file(el, &p, "filename")?;
                let index = p.integer_in("shape_index", 0, 0, u32::MAX as i64)? as u32;
                let n = normals(&p)?;
                p.ignore("max_smooth_angle");
                mesh(MeshFormat::Serialized { shape_index: index }, path, true, n)
            }
            "rectangle" => mesh(MeshFormat::Rectangle, none, false, MeshNormals::AsInFile),
            "cube" => mesh(MeshFormat::Cube, none, false, MeshNormals::AsInFile),
            "disk" => {
                self.ids
                    .warn(el, format!("disk tessellated into {} triangles", crate::desc::DISK_SEGMENTS));
                mesh(MeshFormat::Disk, none, false, MeshNormals::AsInFile)
            }
            "sphere" => {
                let center = to_world.transform_point3(p.point_opt("center")?.unwrap_or(Vec3::ZERO));
                let r = p.float("radius", 1.0)?;
                // the transform's scale must be uniform for the sphere to stay one
                let axes = [Vec3::X, Vec3::Y, Vec3::Z].map(|a| to_world.transform_vector3(a));
                let s = axes[0].length();
                let orthogonal = axes[0].dot(axes[1]).abs() + axes[1].dot(axes[2]).abs() + axes[0].dot(axes[2]).abs() < 1e-4 * s * s;
                if !orthogonal || axes.iter().any(|a| (a.length() - s).abs() > 1e-4 * s) {
                    return Err(p.value_error("to_world", "a sphere's transform must be a rotation, translation and uniform scale"));
                }
                if flip_normals {
                    return Err(p.value_error("flip_normals", "is not supported on spheres"));
                }
                let radius = r * s;
                if !(radius > 0.0 && radius <= crate::limits::MAX_COORD) {
                    return Err(p.value_error("radius", format!("must be positive, found {radius}")));
                }
                check_point(&p, "center", center)?;
                // Mitsuba's uv lives in the object frame (z the pole), v in its sense
                let frame = glam::Mat3::from_cols(axes[0] / s, axes[1] / s, axes[2] / s);
                let Some(q) = crate::desc::rotation_quat(&frame) else {
                    return Err(p.value_error(
                        "to_world",
                        "a sphere's transform must be a rotation, translation and uniform scale (this one mirrors)",
                    ));
                };
                Shape::Sphere(Sphere {
                    center,
                    radius,
                    uv_frame: Some(q),
                })
            }
            "cylinder" => {
                let p0 = p.point_opt("p0")?.unwrap_or(Vec3::ZERO);
                let p1 = p.point_opt("p1")?.unwrap_or(Vec3::Z);
                check_point(&p, "p0", p0)?;
                check_point(&p, "p1", p1)?;
                let c = crate::desc::cylinder_shape(p0, p1, p.float("radius", 1.0)?, flip_normals, &to_world).map_err(|(k, e)| {
                    let k = if k == "transform" { "to_world" } else { k };
                    p.value_error(k, e)
                })?;
                Shape::Cylinder(c)
            }
            other => return Err(p.error(format!("unsupported shape \"{other}\" (supported: {SHAPES})"))),
        };
        let bsdfs = p.objects("bsdf");
        if let Some((_, second)) = bsdfs.get(1) {
            return Err(second.error("a shape takes one <bsdf>"));
        }
        let mut material = match bsdfs.first() {
            Some((b, at)) => Some(Located {
                value: self.material(b)?,
                source: source(at),
            }),
            None => None,
        };
        let emitters = p.objects("emitter");
        if let Some((_, second)) = emitters.get(1) {
            return Err(second.error("a shape takes one <emitter>"));
        }
        let light = match emitters.first() {
            None => None,
            Some((e, at)) => {
                let ep = Plugin::new(e, self.ids)?;
                if ep.ty != "area" {
                    return Err(at.error(format!("a shape's emitter must be \"area\", found \"{}\"", ep.ty)));
                }
                // a constant, or a texture looked up at the emitting point's uv
                let (radiance, texture) = match self.texture_ref(&ep, "radiance", Vec3::ONE)? {
                    TextureRef::Color(c) => (c, None),
                    TextureRef::Named(t) => (Vec3::ONE, Some(t)),
                };
                if let Some(w) = ep.float_opt("sampling_weight")? {
                    if w != 1.0 {
                        self.ids.warn(e, format!("sampling_weight {w} noted: rdr chooses lights by power"));
                    }
                }
                ep.finish(&[])?;
                Some(AreaLightDesc {
                    source: source(e),
                    radiance,
                    texture,
                })
            }
        };
        if material.is_none() && light.is_none() {
            // Mitsuba gives a shape without a BSDF a diffuse of reflectance 0.5
            material = Some(Located {
                value: self.default_material(),
                source: source(el),
            });
        }
        p.finish(&["bsdf", "emitter"])?;
        Ok(ObjectDesc {
            source: source(el),
            shape,
            material,
            light,
        })
    }

    /// Reads a `<shape type="shapegroup">` once (however often instanced); returns its name.
    fn shapegroup(
        &mut self,
        el: &'a Element,
        groups: &mut Vec<ShapeGroupDesc>,
        group_of: &mut HashMap<*const Element, String>,
    ) -> Result<String> {
        if let Some(n) = group_of.get(&(el as *const Element)) {
            return Ok(n.clone());
        }
        let p = Plugin::new(el, self.ids)?;
        let Some(id) = el.attr("id") else {
            return Err(p.error("a shapegroup needs an \"id\" (its instances refer to it)"));
        };
        let mut objects = Vec::new();
        for (m, at) in p.objects("shape") {
            if matches!(m.attr("type"), Some("shapegroup" | "instance")) {
                return Err(at.error("nested instancing is not supported (a shapegroup holds plain shapes, as in Mitsuba)"));
            }
            let o = self.shape(m)?;
            if let Some(l) = &o.light {
                return Err(l.source.error(
                    &PathBuf::new(),
                    "emitters inside a shapegroup are not supported (Mitsuba refuses them too)",
                ));
            }
            objects.push(o);
        }
        p.finish(&["shape"])?;
        let name = id.to_string();
        groups.push(ShapeGroupDesc {
            name: name.clone(),
            source: source(el),
            objects,
        });
        group_of.insert(el as *const Element, name.clone());
        Ok(name)
    }

    fn default_material(&mut self) -> String {
        if let Some(m) = self.materials.iter().find(|m| m.name == "__default_diffuse") {
            return m.name.clone();
        }
        self.materials.push(MaterialDesc {
            name: "__default_diffuse".into(),
            source: Source::Json(String::new()),
            material: Material::Diffuse {
                texture: TextureRef::Color(Vec3::splat(0.5)),
                twosided: false,
            },
        });
        "__default_diffuse".into()
    }

    /// The name of the material of a `<bsdf>` (read once however often referenced).
    fn material(&mut self, el: &'a Element) -> Result<String> {
        if let Some(n) = self.material_of.get(&(el as *const Element)) {
            return Ok(n.clone());
        }
        let material = self.material_value(el)?;
        let name = self.unique(el.attr("id"), "bsdf");
        self.materials.push(MaterialDesc {
            name: name.clone(),
            source: source(el),
            material,
        });
        self.material_of.insert(el as *const Element, name.clone());
        Ok(name)
    }

    fn nest(&mut self, el: &Element) -> Result<()> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(el.error("materials and textures nested too deeply (a circular reference?)"));
        }
        Ok(())
    }

    fn material_value(&mut self, el: &'a Element) -> Result<Material<TextureRef>> {
        self.nest(el)?;
        let r = self.material_inner(el);
        self.depth -= 1;
        r
    }

    fn material_inner(&mut self, el: &'a Element) -> Result<Material<TextureRef>> {
        let p = Plugin::new(el, self.ids)?;
        let m = match p.ty.as_str() {
            "diffuse" => {
                let name = if el.legacy && p.has("diffuse_reflectance") {
                    "diffuse_reflectance"
                } else {
                    "reflectance"
                };
                Material::Diffuse {
                    texture: self.texture_ref(&p, name, Vec3::splat(0.5))?,
                    twosided: false,
                }
            }
            "twosided" => {
                let inner = p.objects("bsdf");
                let Some((b, _)) = inner.first() else {
                    return Err(p.error("a twosided bsdf needs a nested <bsdf>"));
                };
                if let Some((_, at)) = inner.get(2) {
                    return Err(at.error("a twosided bsdf takes one or two nested <bsdf>s"));
                }
                let front = self.material_value(b)?;
                let back = match inner.get(1) {
                    Some((b, _)) => Some(self.material_value(b)?),
                    None => None,
                };
                for (m, (_, at)) in std::iter::once(&front).chain(back.as_ref()).zip(&inner) {
                    if matches!(m, Material::Mask { .. }) {
                        return Err(at.error("a mask must be the outermost bsdf (put the twosided inside it)"));
                    }
                    if matches!(m, Material::TwoSided { .. }) || matches!(m, Material::Diffuse { twosided: true, .. }) {
                        return Err(at.error("twosided cannot wrap another twosided bsdf"));
                    }
                    let new_transmitting = matches!(
                        m,
                        Material::Principled(_) | Material::PrincipledThin(_) | Material::BlendBsdf { .. }
                    ) && m.transmits();
                    if back.is_some() && m.transmits()
                        || new_transmitting
                        || matches!(m, Material::ThinDielectric { .. } | Material::RoughDielectric { .. })
                    {
                        return Err(at.error("twosided wraps only reflecting bsdfs (this one transmits light)"));
                    }
                }
                match (front, back) {
                    // rdr's own two-sided diffuse; its roughconductor is two-sided already
                    (Material::Diffuse { texture, .. }, None) => Material::Diffuse { texture, twosided: true },
                    (mut m @ Material::RoughConductor { .. }, None) => {
                        if let Material::RoughConductor { twosided, .. } = &mut m {
                            *twosided = true;
                        }
                        m
                    }
                    // smooth glass is the same from both sides (the 0.6 course files wrap it)
                    (m @ (Material::Glass { .. } | Material::Refraction { .. }), None) => {
                        self.ids.convert_note(
                            el,
                            "<bsdf type=\"twosided\"> around a dielectric is read as the dielectric alone: the JSON has no twosided, and converting back writes the dielectric unwrapped",
                        );
                        m
                    }
                    (front, back) => Material::TwoSided {
                        front: Box::new(front),
                        back: back.map(Box::new),
                    },
                }
            }
            "bumpmap" | "normalmap" | "mask" => return self.wrapper(p),
            "dielectric" => Material::Glass {
                reflect: colour_of(&p, "specular_reflectance")?,
                transmit: colour_of(&p, "specular_transmittance")?,
                eta: ior_ratio(&p, "bk7")?,
            },
            "roughconductor" => {
                let (alpha_x, alpha_y) = alphas(&p)?;
                let (eta, k) = self.conductor_eta_k(&p)?;
                p.ignore("sample_visible");
                Material::RoughConductor {
                    texture: self.texture_ref(&p, "specular_reflectance", Vec3::ONE)?,
                    eta_i: Vec3::ONE,
                    eta_t: eta.max(Vec3::splat(1e-4)),
                    k,
                    alpha_x,
                    alpha_y,
                    distribution: distribution(&p)?,
                    // Mitsuba's reflects on its front only (a twosided makes it two-sided)
                    twosided: false,
                }
            }
            "conductor" => {
                let (eta, k) = self.conductor_eta_k(&p)?;
                Material::Conductor {
                    texture: self.texture_ref(&p, "specular_reflectance", Vec3::ONE)?,
                    eta,
                    k,
                }
            }
            "thindielectric" => Material::ThinDielectric {
                reflect: colour_of(&p, "specular_reflectance")?,
                transmit: colour_of(&p, "specular_transmittance")?,
                eta: ior_ratio(&p, "bk7")?,
            },
            "roughdielectric" => {
                let (alpha_x, alpha_y) = alphas(&p)?;
                p.ignore("sample_visible");
                Material::RoughDielectric {
                    reflect: colour_of(&p, "specular_reflectance")?,
                    transmit: colour_of(&p, "specular_transmittance")?,
                    eta: ior_ratio(&p, "bk7")?,
                    alpha_x,
                    alpha_y,
                    distribution: distribution(&p)?,
                }
            }
            "plastic" | "roughplastic" => {
                let texture = self.texture_ref(&p, "diffuse_reflectance", Vec3::splat(0.5))?;
                let specular = colour_of(&p, "specular_reflectance")?;
                let eta = ior_ratio(&p, "polypropylene")?;
                if eta == 1.0 {
                    return Err(p.value_error("int_ior", "a coating needs int_ior and ext_ior to differ"));
                }
                let nonlinear = p.boolean("nonlinear", false)?;
                if p.ty == "plastic" {
                    Material::Plastic {
                        texture,
                        specular,
                        eta,
                        nonlinear,
                        specular_sampling_weight: None,
                    }
                } else {
                    if p.has("alpha_u") || p.has("alpha_v") {
                        return Err(p.error("roughplastic is isotropic: give alpha, not alpha_u and alpha_v"));
                    }
                    p.ignore("sample_visible");
                    Material::RoughPlastic {
                        texture,
                        specular,
                        eta,
                        nonlinear,
                        alpha: alphas(&p)?.0,
                        distribution: distribution(&p)?,
                        specular_sampling_weight: None,
                        tables: None,
                    }
                }
            }
            "principled" => self.principled(&p)?,
            "principledthin" => self.principled_thin(&p)?,
            "blendbsdf" => self.blendbsdf(&p)?,
            other => return Err(p.error(format!("unsupported bsdf \"{other}\" (supported: {BSDFS})"))),
        };
        p.finish(&["bsdf", "texture"])?;
        Ok(m)
    }

    /// `bumpmap` (one nested `<texture>`, the heights, any name; `scale` 1),
    /// `normalmap` (the `<texture name="normalmap">`), each with `flip_invalid_normals`
    /// and `use_shadowing_function` (true); `mask` (`opacity` 0.5, a float or texture).
    /// Each wraps exactly one nested `<bsdf>`; a mask must be the outermost.
    fn wrapper(&mut self, p: Plugin<'a>) -> Result<Material<TextureRef>> {
        let ty = p.ty.clone();
        let inner = p.objects("bsdf");
        let Some((b, _)) = inner.first() else {
            return Err(p.error(format!("a {ty} bsdf needs a nested <bsdf>")));
        };
        if let Some((_, at)) = inner.get(1) {
            return Err(at.error(format!("a {ty} bsdf takes one nested <bsdf>")));
        }
        let nested = self.material_value(b)?;
        let at = inner[0].1;
        if matches!(nested, Material::Mask { .. }) {
            return Err(at.error("a mask must be the outermost bsdf (put the others inside it)"));
        }
        if ty != "mask" && matches!(nested, Material::BumpMap { .. } | Material::NormalMap { .. }) {
            return Err(at.error("bump and normal maps cannot wrap each other"));
        }
        let inner = Box::new(nested);
        let options = || -> Result<crate::material::bump::PerturbOptions> {
            Ok(crate::material::bump::PerturbOptions {
                flip_invalid_normals: p.boolean("flip_invalid_normals", true)?,
                use_shadowing_function: p.boolean("use_shadowing_function", true)?,
            })
        };
        let m = match ty.as_str() {
            "bumpmap" => {
                let textures = p.objects("texture");
                let Some((t, _)) = textures.first() else {
                    return Err(p.error("a bumpmap bsdf needs a nested <texture> (the height field)"));
                };
                if let Some((_, at)) = textures.get(1) {
                    return Err(at.error("a bumpmap bsdf takes one nested <texture>"));
                }
                let scale = p.float("scale", 1.0)?;
                if !scale.is_finite() {
                    return Err(p.value_error("scale", "must be a finite number"));
                }
                Material::BumpMap {
                    height: TextureRef::Named(Located {
                        value: self.texture(t)?,
                        source: source(t),
                    }),
                    scale,
                    options: options()?,
                    inner,
                }
            }
            "normalmap" => {
                if !p.has("normalmap") {
                    return Err(p.error("a normalmap bsdf needs the texture \"normalmap\""));
                }
                Material::NormalMap {
                    normals: self.texture_ref(&p, "normalmap", Vec3::new(0.5, 0.5, 1.0))?,
                    options: options()?,
                    inner,
                }
            }
            _ => {
                let opacity = self.float_texture_ref(&p, "opacity", Vec3::splat(0.5))?;
                if let TextureRef::Color(c) = opacity {
                    if c.max_element() > 1.0 {
                        return Err(p.value_error("opacity", "must be between 0 and 1"));
                    }
                }
                Material::Mask { opacity, inner }
            }
        };
        p.finish(&["bsdf", "texture"])?;
        Ok(m)
    }

    /// A conductor's η and k: `eta` (0) and `k` (1), or `material` (a name from
    /// [`values::NAMED_CONDUCTORS`], or `none`, the default); the 0.6 `ext_eta` folded in.
    fn conductor_eta_k(&self, p: &Plugin) -> Result<(Vec3, Vec3)> {
        let named = p.string_opt("material")?;
        let (mut eta, mut k) = match named.as_deref() {
            Some(m) if m != "none" => {
                if p.has("eta") || p.has("k") {
                    return Err(p.value_error("material", "give either material or eta and k, not both"));
                }
                values::conductor(m).map_err(|e| p.value_error("material", e))?
            }
            _ => (p.rgb("eta", Vec3::ZERO)?, p.rgb("k", Vec3::ONE)?),
        };
        if !(eta.min_element() >= 0.0 && k.min_element() >= 0.0 && eta.is_finite() && k.is_finite()) {
            return Err(p.value_error(if p.has("k") { "k" } else { "eta" }, "must not be negative"));
        }
        if let Some(ext) = p.float_opt("ext_eta")? {
            if ext.is_nan() || ext <= 0.0 {
                return Err(p.value_error("ext_eta", "must be positive"));
            }
            // Mitsuba 3 has no ext_eta: η and k are relative to the outside
            eta /= ext;
            k /= ext;
            if ext != 1.0 {
                self.ids.warn(p.el, format!("ext_eta {ext} (Mitsuba 0.6) folded into eta and k"));
            }
        }
        Ok((eta, k))
    }

    fn texture_ref(&mut self, p: &Plugin<'a>, name: &str, default: Vec3) -> Result<TextureRef> {
        Ok(match p.colour(name, default)? {
            Colour::Constant(c) => {
                if c.min_element() < 0.0 || !c.is_finite() {
                    return Err(p.value_error(name, "a colour must not be negative"));
                }
                TextureRef::Color(c)
            }
            Colour::Texture(t) => TextureRef::Named(Located {
                value: self.texture(t)?,
                source: source(t),
            }),
        })
    }

    /// A texture parameter Mitsuba reads as a float (`eval_1`: blendbsdf's `weight`,
    /// mask's `opacity`, principled's float keys): as [`Reader::texture_ref`], except
    /// that Mitsuba 3's checkerboard `eval_1` gives `color1` where its `eval` gives
    /// `color0` (checked with 3.9.1: at uv (0.2, 0.2) `eval` is color0, `eval_1`
    /// color1), so a checkerboard read as a float is a twin with the colours swapped.
    pub(super) fn float_texture_ref(&mut self, p: &Plugin<'a>, name: &str, default: Vec3) -> Result<TextureRef> {
        let r = self.texture_ref(p, name, default)?;
        let (Colour::Texture(el), TextureRef::Named(n)) = (p.colour(name, default)?, &r) else {
            return Ok(r);
        };
        let key = el as *const Element;
        if let Some(twin) = self.float_texture_of.get(&key) {
            return Ok(TextureRef::Named(Located {
                value: twin.clone(),
                source: n.source.clone(),
            }));
        }
        let Some(t) = self.textures.iter().find(|t| t.name == n.value) else {
            return Ok(r);
        };
        let Texture::Checkerboard { color0, color1, mapping } = t.texture else {
            return Ok(r);
        };
        let twin = self.unique(Some(&format!("{}-as-float", n.value)), "texture");
        self.textures.push(TextureDesc {
            name: twin.clone(),
            source: t.source.clone(),
            texture: Texture::Checkerboard {
                color0: color1,
                color1: color0,
                mapping,
            },
        });
        self.float_texture_of.insert(key, twin.clone());
        Ok(TextureRef::Named(Located {
            value: twin,
            source: n.source.clone(),
        }))
    }

    /// The name of the texture of a `<texture>` (read once however often referenced).
    fn texture(&mut self, el: &'a Element) -> Result<String> {
        if let Some(n) = self.texture_of.get(&(el as *const Element)) {
            return Ok(n.clone());
        }
        self.nest(el)?;
        let t = self.texture_value(el);
        self.depth -= 1;
        let texture = t?;
        let name = self.unique(el.attr("id"), "texture");
        self.textures.push(TextureDesc {
            name: name.clone(),
            source: source(el),
            texture,
        });
        self.texture_of.insert(el as *const Element, name.clone());
        Ok(name)
    }

    fn texture_value(&mut self, el: &'a Element) -> Result<Texture<ImageFile>> {
        let p = Plugin::new(el, self.ids)?;
        let to_uv = self.to_uv(&p)?;
        let t = match p.ty.as_str() {
            "bitmap" => {
                let path = self.file(el, &p, "filename")?;
                // Mitsuba has no MIP maps: its bilinear reads the full-resolution image
                let filter = match p.string("filter_type", "bilinear")?.as_str() {
                    "bilinear" => crate::texture::image::ImageFilter::Bilinear,
                    "nearest" => crate::texture::image::ImageFilter::Nearest,
                    other => return Err(p.value_error("filter_type", format!("unknown filter_type \"{other}\" (bilinear, nearest)"))),
                };
                if let Some(w) = p.string_opt("wrap_mode")? {
                    if w != "repeat" {
                        self.ids.warn(el, format!("wrap_mode \"{w}\" noted: rdr repeats images"));
                    }
                }
                let raw = p.boolean("raw", false)?;
                // Mitsuba's row 0 is v = 0, rdr's is v = 1
                Texture::Image(ImageFile {
                    path,
                    mapping: UvMapping {
                        scale: to_uv.0,
                        delta: Vec2::new(to_uv.1.x, 1.0 - to_uv.0.y - to_uv.1.y),
                    },
                    filter,
                    raw,
                })
            }
            "checkerboard" => Texture::Checkerboard {
                color0: p.rgb("color0", Vec3::splat(0.4))?,
                color1: p.rgb("color1", Vec3::splat(0.2))?,
                // the same cells as Mitsuba's in its v, which runs the other way
                mapping: UvMapping {
                    scale: Vec2::new(to_uv.0.x, -to_uv.0.y),
                    delta: Vec2::new(to_uv.1.x, to_uv.0.y + to_uv.1.y),
                },
            },
            "mesh_attribute" => {
                let name = p.required_string("name")?;
                let face = match name.as_str() {
                    "vertex_color" => false,
                    "face_color" => true,
                    other => {
                        return Err(p.value_error(
                            "name",
                            format!("unsupported mesh attribute \"{other}\" (supported: vertex_color, face_color)"),
                        ))
                    }
                };
                let scale = p.float("scale", 1.0)?;
                if !scale.is_finite() {
                    return Err(p.value_error("scale", "must be a finite number"));
                }
                Texture::MeshAttribute { face, scale }
            }
            other => return Err(p.error(format!("unsupported texture \"{other}\" (supported: {TEXTURES})"))),
        };
        p.finish(&[])?;
        Ok(t)
    }

    /// `to_uv` (or the 0.6 `uscale`, `vscale`, `uoffset`, `voffset`) as scale and offset.
    fn to_uv(&self, p: &Plugin) -> Result<(Vec2, Vec2)> {
        let legacy = ["uoffset", "voffset", "uscale", "vscale"].iter().any(|k| p.has(k));
        let m = if legacy {
            let o = Vec3::new(p.float("uoffset", 0.0)?, p.float("voffset", 0.0)?, 0.0);
            let s = Vec3::new(p.float("uscale", 1.0)?, p.float("vscale", 1.0)?, 1.0);
            values::scale(s) * values::translate(o)
        } else {
            p.transform_opt("to_uv")?.unwrap_or(Mat4::IDENTITY)
        };
        let (s, o) = (Vec2::new(m.x_axis.x, m.y_axis.y), Vec2::new(m.w_axis.x, m.w_axis.y));
        if m.x_axis.y != 0.0 || m.y_axis.x != 0.0 || s.x == 0.0 || s.y == 0.0 {
            return Err(p.value_error("to_uv", "only a scale and offset of the texture coordinates are supported"));
        }
        Ok((s, o))
    }

    fn environment(&mut self, p: &Plugin<'a>) -> Result<EnvMapDesc> {
        let el = p.el;
        let (texture, scale) = if p.ty == "constant" {
            let c = p.rgb("radiance", Vec3::ONE)?;
            if c.min_element() < 0.0 {
                return Err(p.value_error("radiance", "must not be negative"));
            }
            let name = self.unique(el.attr("id").or(Some("environment")), "environment");
            self.textures.push(TextureDesc {
                name: name.clone(),
                source: source(el),
                texture: Texture::Constant(c),
            });
            (name, 1.0)
        } else {
            let path = self.file(el, p, "filename")?;
            let name = self.unique(el.attr("id").or(Some("environment")), "environment");
            self.textures.push(TextureDesc {
                name: name.clone(),
                source: source(el),
                texture: Texture::Image(ImageFile {
                    path,
                    mapping: UvMapping {
                        scale: Vec2::ONE,
                        delta: Vec2::ZERO,
                    },
                    filter: crate::texture::image::ImageFilter::Trilinear,
                    raw: false,
                }),
            });
            for k in ["filter_type", "mis_compensation"] {
                p.ignore(k);
            }
            let s = p.float("scale", 1.0)?;
            if s.is_nan() || s < 0.0 {
                return Err(p.value_error("scale", "must not be negative"));
            }
            (name, s)
        };
        let transform = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        if transform.determinant() == 0.0 {
            return Err(p.value_error("to_world", "the transform is singular"));
        }
        p.finish(&[])?;
        Ok(EnvMapDesc {
            source: source(el),
            texture: Located {
                value: texture,
                source: source(el),
            },
            scale,
            transform,
        })
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
