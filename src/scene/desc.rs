//! Scene description: the RDR171 JSON read into plain structs (spec §3–§12).
//! Nothing here touches the file system except reading the scene itself; meshes
//! and textures are loaded when the render-ready scene is built (`build.rs`).
//!
//! Each struct's documentation lists its keys with their defaults.

use super::json::{Context, Props};
use crate::error::Result;
use crate::math::{Mat4, Vec2, Vec3};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// A value together with the JSON path it was read from.
#[derive(Clone, Debug, PartialEq)]
pub struct At<T> {
    pub value: T,
    pub key: String,
}

/// The whole scene. Top-level keys: `integrator`, `film`, `camera` (required),
/// `textures`, `materials`, `objects`, `environment_map`.
#[derive(Clone, Debug)]
pub struct SceneDesc {
    pub file: PathBuf,
    /// Folder every relative path resolves against: the scene file's own.
    pub base_dir: PathBuf,
    pub integrator: IntegratorDesc,
    pub film: FilmDesc,
    pub camera: CameraDesc,
    pub textures: Vec<TextureDesc>,
    pub materials: Vec<MaterialDesc>,
    pub objects: Vec<ObjectDesc>,
    pub environment_map: Option<EnvMapDesc>,
    pub warnings: Vec<String>,
}

use crate::integrator::{bdpt::Heuristic, Bdpt, Integrator, IntersectionTest, Normals, PathProfile, PathTracer, Ptracer};

/// `integrator`:
/// * `type` (`"path"`) — `"path"`, `"bdpt"`, `"ptracer"`, `"intersection_test"` or
///   `"normals"` (a debug view: shading normals as colours); `"photon"` renders with
///   `path` (with a warning). The keys of each are documented on its type:
///   [`PathTracer`] (`spp` 32, `max_depth` 12, `profile`, `rr_threshold`),
///   [`Bdpt`] (as `path`, and `mis`, `strategy`, `strategy_weighted`), [`Ptracer`]
///   (`spp` 32, `max_depth` 12, `rr_threshold`),
///   [`IntersectionTest`] (`spp` 8, `max_depth` 16, `light_samples` 1), [`Normals`] (`spp` 8).
/// * `spp` (int ≥ 1) — samples per pixel, default per type as above.
/// * `point_light_position` (vec3, (0,5,0)), `point_light_flux` (vec3, (1,1,1)) —
///   the legacy single point light; present when either key is given or when
///   there is no `lights` list.
/// * `lights` — list of `{"type": "point", "position": [..], "flux": [..]}`.
/// * `light_sampling` (`"importance"` | `"uniform"`, `"importance"`) — lights drawn
///   by their own importance and chosen by power, or uniformly (for comparisons).
///
/// ```json
/// {"type": "intersection_test", "spp": 32, "max_depth": 16,
///  "lights": [{"type": "point", "position": [0, 1.5, 0.5], "flux": [17, 12, 5]}]}
/// ```
#[derive(Clone, Debug)]
pub struct IntegratorDesc {
    pub integrator: Integrator,
    pub spp: u32,
    pub point_lights: Vec<PointLightDesc>,
    pub light_sampling: crate::light::LightSampling,
}

/// A point light of total power `flux` Φ (radiant intensity Φ/4π).
#[derive(Clone, Debug)]
pub struct PointLightDesc {
    pub position: Vec3,
    pub flux: Vec3,
    pub key: String,
}

/// `film`: `resolution` ([int, int], [600, 600]), `block_side_length` (int ≥ 1, 16;
/// tile size, no effect on the image), `filter` (object, box of radius 0.5).
#[derive(Clone, Debug)]
pub struct FilmDesc {
    pub width: u32,
    pub height: u32,
    pub block_size: u32,
    pub filter: FilterDesc,
}

/// `film.filter`: `type` (`"box"` | `"gaussian"` | `"mitchell"`, `"box"`), `radius`
/// (0.5), `alpha` (gaussian, 2), `B`, `C` (mitchell, 1/3 each).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FilterDesc {
    Box { radius: f32 },
    Gaussian { radius: f32, alpha: f32 },
    Mitchell { radius: f32, b: f32, c: f32 },
}

/// `camera` (pinhole): `position` ((0,0,1)), `look_at` ((0,0,0)), `ref_up` ((0,1,0)),
/// `fov` (vertical degrees, 45), `focal_length` (1; cancels out).
#[derive(Clone, Debug)]
pub struct CameraDesc {
    pub position: Vec3,
    pub look_at: Vec3,
    pub ref_up: Vec3,
    pub fov: f32,
    pub focal_length: f32,
}

/// `textures.<name>`: `type` = `constant` (`color`, required) | `checkerboard`
/// (`color0` (0.4), `color1` (0.2), `tex_coordinate_generator`) | `image` (`path`,
/// `tex_coordinate_generator`); see [`TextureKind`].
#[derive(Clone, Debug)]
pub struct TextureDesc {
    pub name: String,
    pub key: String,
    pub kind: TextureKind,
}

#[derive(Clone, Debug)]
pub enum TextureKind {
    /// `constant`: `color` (vec3, required).
    Constant { color: Vec3 },
    /// `checkerboard`: `color0` (vec3, (0.4, 0.4, 0.4)), `color1` (vec3, (0.2, 0.2, 0.2)),
    /// `tex_coordinate_generator` (required); checks 0.5 wide in `st`.
    Checkerboard {
        color0: Vec3,
        color1: Vec3,
        mapping: UvMappingDesc,
    },
    /// `image`:
    /// * `path` (string, required) — relative to the scene file's folder. EXR and Radiance
    ///   `.hdr` are read as linear values, PNG and JPEG decoded from sRGB; alpha is dropped.
    ///   The file is read when the scene is built (once, however many textures name it);
    ///   a missing or undecodable file is an error naming this key.
    /// * `tex_coordinate_generator` (required) — `st = scale ⊙ uv + delta`.
    ///
    /// `st = (0, 0)` is the bottom-left corner of the picture and `(1, 1)` the top-right
    /// (`--compat rdr171`: `t = 0` is the top row, as in the original); the picture repeats
    /// outside [0, 1]². Lookups are MIP-mapped (trilinear) from the ray footprint; see
    /// `src/texture/mipmap.rs`.
    ///
    /// ```json
    /// "grid": {"type": "image", "path": "textures/uv_grid.png",
    ///          "tex_coordinate_generator": {"type": "uvmapping2d", "scale": [4, 4]}}
    /// ```
    Image { path: At<String>, mapping: UvMappingDesc },
}

/// `tex_coordinate_generator`: `type` = `"uvmapping2d"`, `scale` ((1,1)), `delta`
/// ((0,0)): `st = scale ⊙ uv + delta`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvMappingDesc {
    pub scale: Vec2,
    pub delta: Vec2,
}

/// `materials.<name>`: `type` (`"diffuse"`) and per type:
/// * `diffuse`: `texture_name` (required), `twosided` (false);
/// * `refraction`: `eta` (1.5);
/// * `glass`: `R` ((1,1,1)), `T` ((1,1,1)), `eta` (1.5);
/// * `roughconductor`: `texture_name` (required), `etaI`, `etaT`, `k` ((1,1,1)),
///   `alpha_x`, `alpha_y` (0.1), `distribution` (`"beckmann"` | `"ggx"`, `"beckmann"`).
#[derive(Clone, Debug)]
pub struct MaterialDesc {
    pub name: String,
    pub key: String,
    pub kind: MaterialKind,
}

#[derive(Clone, Debug)]
pub enum MaterialKind {
    Diffuse {
        texture: TextureRef,
        twosided: bool,
    },
    Refraction {
        eta: f32,
    },
    Glass {
        reflect: Vec3,
        transmit: Vec3,
        eta: f32,
    },
    RoughConductor {
        texture: TextureRef,
        eta_i: Vec3,
        eta_t: Vec3,
        k: Vec3,
        alpha_x: f32,
        alpha_y: f32,
        distribution: crate::material::Distribution,
    },
}

/// A material's texture: by name, or an inline colour (legacy keys).
#[derive(Clone, Debug)]
pub enum TextureRef {
    Named(At<String>),
    Color(Vec3),
}

/// `objects[i]`: `type` (`"mesh"` | `"sphere"`), `material_name`, `light`; at least
/// one of the last two.
#[derive(Clone, Debug)]
pub struct ObjectDesc {
    pub key: String,
    pub shape: ShapeDesc,
    pub material: Option<At<String>>,
    pub light: Option<AreaLightDesc>,
}

/// * `mesh`: `path` (OBJ, required), `transform` (16 numbers row-major, identity),
///   `translate` ((0,0,0), added after `transform`);
/// * `sphere`: `center` ((0,0,0)), `radius` (1).
#[derive(Clone, Debug)]
pub enum ShapeDesc {
    Mesh {
        path: At<String>,
        transform: Mat4,
        translate: Vec3,
    },
    Sphere {
        center: Vec3,
        radius: f32,
    },
}

/// `objects[i].light`: `type` (`"area"`), `radiance` ((1,1,1)); one-sided emission.
#[derive(Clone, Debug)]
pub struct AreaLightDesc {
    pub key: String,
    pub radiance: Vec3,
}

/// `environment_map`: `texture_name` (required), `scale` (1), `transform` (identity).
#[derive(Clone, Debug)]
pub struct EnvMapDesc {
    pub key: String,
    pub texture: At<String>,
    pub scale: f32,
    pub transform: Mat4,
}

impl SceneDesc {
    /// Reads a scene file, applies `--override` patches (spec §1), and parses it.
    pub fn load(file: &Path, overrides: &[String]) -> Result<SceneDesc> {
        let ctx = Context::new(file);
        let text = std::fs::read_to_string(file).map_err(|e| ctx.error("", format!("cannot read scene: {e}")))?;
        let mut value = super::json::parse_text(&text, file)?;
        for patch in overrides {
            let p: Value = serde_json::from_str(patch).map_err(|e| ctx.error("", format!("--override is not valid JSON: {e}")))?;
            if !p.is_object() {
                return Err(ctx.error("", "--override must be a JSON object"));
            }
            super::json::merge(&mut value, &p);
        }
        let base = file.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        Self::from_value(&value, file, base)
    }

    /// Parses an already-read JSON value. `base_dir` anchors relative paths.
    pub fn from_value(value: &Value, file: &Path, base_dir: &Path) -> Result<SceneDesc> {
        let ctx = Context::new(file);
        let root = Props::root(value, &ctx)?;
        let integrator = parse_integrator(&root.object("integrator")?)?;
        let film = parse_film(&root.object("film")?)?;
        let camera = parse_camera(&root.object("camera")?)?;
        let textures = root
            .named_objects("textures")?
            .iter()
            .map(|(n, p)| parse_texture(n, p))
            .collect::<Result<Vec<_>>>()?;
        let materials = root
            .named_objects("materials")?
            .iter()
            .map(|(n, p)| parse_material(n, p))
            .collect::<Result<Vec<_>>>()?;
        let objects = root.objects("objects")?.iter().map(parse_object).collect::<Result<Vec<_>>>()?;
        let environment_map = root.object_opt("environment_map")?.map(|p| parse_env(&p)).transpose()?;
        root.finish();
        let warnings = ctx.warnings.borrow().clone();
        Ok(SceneDesc {
            file: file.to_path_buf(),
            base_dir: base_dir.to_path_buf(),
            integrator,
            film,
            camera,
            textures,
            materials,
            objects,
            environment_map,
            warnings,
        })
    }
}

fn parse_integrator(p: &Props) -> Result<IntegratorDesc> {
    let ty = p.string_or("type", "path")?;
    let kind = match ty.as_str() {
        "intersection_test" | "normals" | "bdpt" | "ptracer" => ty.as_str(),
        "path" | "photon" => {
            if ty != "path" {
                p.ctx().warn(
                    &p.key_path("type"),
                    format!("integrator '{ty}' is not implemented; rendering with the path tracer"),
                );
            }
            "path"
        }
        _ => {
            return Err(p.error(
                "type",
                format!("unknown integrator '{ty}' (available: intersection_test, path, bdpt, ptracer, normals; photon renders as path)"),
            ))
        }
    };
    let (integrator, spp) = match kind {
        "path" | "bdpt" => {
            let profile = match p.string_or("profile", "MIS")?.as_str() {
                "RW" | "RandomWalk" => PathProfile::RandomWalk,
                "NEE" | "NextEventEstimation" => PathProfile::NextEvent,
                "MIS" | "MultipleImportanceSampling" => PathProfile::Mis,
                other => return Err(p.error("profile", format!("unknown path profile '{other}' (available: RW, NEE, MIS)"))),
            };
            let rr_threshold = p.f32_or("rr_threshold", 0.1)?;
            let spp = p.int_at_least("spp", 32, 1)?;
            let max_depth = p.int_at_least("max_depth", 12, 1)?;
            if kind == "path" {
                (
                    Integrator::Path(PathTracer {
                        max_depth,
                        profile,
                        rr_threshold,
                    }),
                    spp,
                )
            } else {
                (Integrator::Bdpt(parse_bdpt(p, max_depth, rr_threshold)?), spp)
            }
        }
        "ptracer" => {
            let rr_threshold = p.f32_or("rr_threshold", 0.1)?;
            let spp = p.int_at_least("spp", 32, 1)?;
            let max_depth = p.int_at_least("max_depth", 12, 1)?;
            (Integrator::Ptracer(Ptracer { max_depth, rr_threshold }), spp)
        }
        "normals" => (Integrator::Normals(Normals), p.int_at_least("spp", 8, 1)?),
        _ => {
            let spp = p.int_at_least("spp", 8, 1)?;
            let max_depth = p.int_at_least("max_depth", 16, 1)?;
            // read here, after the point lights, as before (errors come in key order)
            (
                Integrator::IntersectionTest(IntersectionTest {
                    max_depth,
                    light_samples: 1,
                }),
                spp,
            )
        }
    };
    let mut point_lights = Vec::new();
    let has_list = p.contains("lights");
    if !has_list || p.contains("point_light_position") || p.contains("point_light_flux") {
        point_lights.push(PointLightDesc {
            position: p.vec3_or("point_light_position", Vec3::new(0.0, 5.0, 0.0))?,
            flux: non_negative_flux(p, "point_light_flux", p.vec3_or("point_light_flux", Vec3::ONE)?)?,
            key: p.key_path("point_light_position"),
        });
    }
    for l in p.objects("lights")? {
        let ty = l.string("type")?;
        if ty != "point" {
            return Err(l.error(
                "type",
                format!("unknown light type '{ty}' in the integrator's list (available: point)"),
            ));
        }
        point_lights.push(PointLightDesc {
            position: l.vec3("position")?,
            flux: non_negative_flux(&l, "flux", l.vec3("flux")?)?,
            key: l.path.clone(),
        });
        l.finish();
    }
    let light_samples = p.int_at_least("light_samples", 1, 1)?;
    let mut integrator = integrator;
    if let Integrator::IntersectionTest(t) = &mut integrator {
        t.light_samples = light_samples;
    }
    let light_sampling = match p.string_or("light_sampling", "importance")?.as_str() {
        "importance" => crate::light::LightSampling::Importance,
        "uniform" => crate::light::LightSampling::Uniform,
        other => {
            return Err(p.error(
                "light_sampling",
                format!("unknown light sampling '{other}' (available: importance, uniform)"),
            ))
        }
    };
    p.finish();
    Ok(IntegratorDesc {
        integrator,
        spp,
        point_lights,
        light_sampling,
    })
}

/// The keys only `bdpt` has (see [`Bdpt`]): `mis`, `strategy`, `strategy_weighted`.
fn parse_bdpt(p: &Props, max_depth: u32, rr_threshold: f32) -> Result<Bdpt> {
    let heuristic = match p.string_or("mis", "power")?.as_str() {
        "power" => Heuristic::Power,
        "balance" => Heuristic::Balance,
        other => return Err(p.error("mis", format!("unknown MIS heuristic '{other}' (available: power, balance)"))),
    };
    let strategy = match p.contains("strategy") {
        true => match p.vec2i_or("strategy", [0, 0])? {
            [s, t] if s >= 0 && t >= 1 => Some((s as u32, t as u32)),
            _ => return Err(p.error("strategy", "expected [s, t] with s ≥ 0, t ≥ 1")),
        },
        false => None,
    };
    Ok(Bdpt {
        max_depth,
        rr_threshold,
        heuristic,
        strategy,
        strategy_weighted: p.bool_or("strategy_weighted", false)?,
    })
}

/// A point light's flux; the error names the flux key itself.
fn non_negative_flux(p: &Props, key: &str, flux: Vec3) -> Result<Vec3> {
    if flux.min_element() < 0.0 {
        return Err(p.error(key, "light flux must not be negative"));
    }
    Ok(flux)
}

fn parse_film(p: &Props) -> Result<FilmDesc> {
    let [w, h] = p.vec2i_or("resolution", [600, 600])?;
    if w <= 0 || h <= 0 {
        return Err(p.error("resolution", format!("must be positive, found [{w}, {h}]")));
    }
    if (w as u64) * (h as u64) > 1 << 28 {
        return Err(p.error("resolution", format!("[{w}, {h}] is too large")));
    }
    let block_size = p.int_at_least("block_side_length", 16, 1)?;
    let filter = match p.object_opt("filter")? {
        None => FilterDesc::Box { radius: 0.5 },
        Some(f) => {
            let ty = f.string_or("type", "box")?;
            let radius = f.f32_or("radius", 0.5)?;
            if radius <= 0.0 {
                return Err(f.error("radius", format!("must be positive, found {radius}")));
            }
            let d = match ty.as_str() {
                "box" => FilterDesc::Box { radius },
                "gaussian" => FilterDesc::Gaussian {
                    radius,
                    alpha: f.f32_or("alpha", 2.0)?,
                },
                "mitchell" => FilterDesc::Mitchell {
                    radius,
                    b: f.f32_or("B", 1.0 / 3.0)?,
                    c: f.f32_or("C", 1.0 / 3.0)?,
                },
                _ => return Err(f.error("type", format!("unknown filter '{ty}' (available: box, gaussian, mitchell)"))),
            };
            f.finish();
            d
        }
    };
    p.finish();
    Ok(FilmDesc {
        width: w as u32,
        height: h as u32,
        block_size,
        filter,
    })
}

fn parse_camera(p: &Props) -> Result<CameraDesc> {
    let c = CameraDesc {
        position: p.vec3_or("position", Vec3::new(0.0, 0.0, 1.0))?,
        look_at: p.vec3_or("look_at", Vec3::ZERO)?,
        ref_up: p.vec3_or("ref_up", Vec3::Y)?,
        fov: p.f32_or("fov", 45.0)?,
        focal_length: p.f32_or("focal_length", 1.0)?,
    };
    if !(c.fov > 0.0 && c.fov < 180.0) {
        return Err(p.error("fov", format!("must be between 0 and 180 degrees, found {}", c.fov)));
    }
    if c.focal_length <= 0.0 {
        return Err(p.error("focal_length", format!("must be positive, found {}", c.focal_length)));
    }
    let forward = c.look_at - c.position;
    if forward.length_squared() == 0.0 {
        return Err(p.error("look_at", "equals the camera position"));
    }
    if forward.normalize().cross(c.ref_up).length_squared() < 1e-12 {
        return Err(p.error("ref_up", "is zero or parallel to the viewing direction"));
    }
    p.finish();
    Ok(c)
}

fn parse_mapping(p: &Props) -> Result<UvMappingDesc> {
    let g = p.object("tex_coordinate_generator")?;
    let ty = g.string("type")?;
    if ty != "uvmapping2d" {
        return Err(g.error(
            "type",
            format!("unknown texture coordinate generator '{ty}' (available: uvmapping2d)"),
        ));
    }
    let m = UvMappingDesc {
        scale: g.vec2_or("scale", Vec2::ONE)?,
        delta: g.vec2_or("delta", Vec2::ZERO)?,
    };
    g.finish();
    Ok(m)
}

fn at(p: &Props, key: &str, value: String) -> At<String> {
    At {
        value,
        key: p.key_path(key),
    }
}

fn parse_texture(name: &str, p: &Props) -> Result<TextureDesc> {
    let ty = p.string("type")?;
    let kind = match ty.as_str() {
        "constant" => TextureKind::Constant { color: p.vec3("color")? },
        "checkerboard" => TextureKind::Checkerboard {
            color0: p.vec3_or("color0", Vec3::splat(0.4))?,
            color1: p.vec3_or("color1", Vec3::splat(0.2))?,
            mapping: parse_mapping(p)?,
        },
        "image" => TextureKind::Image {
            path: at(p, "path", p.string("path")?),
            mapping: parse_mapping(p)?,
        },
        _ => {
            return Err(p.error(
                "type",
                format!("unknown texture type '{ty}' (available: constant, checkerboard, image)"),
            ))
        }
    };
    p.finish();
    Ok(TextureDesc {
        name: name.to_string(),
        key: p.path.clone(),
        kind,
    })
}

fn non_negative(p: &Props, key: &str, v: f32) -> Result<f32> {
    if v < 0.0 {
        return Err(p.error(key, format!("must not be negative, found {v}")));
    }
    Ok(v)
}

/// `texture_name`, or (accepted with a warning) the legacy inline colour key that
/// older course scenes use instead (`color` on diffuse, `R` on conductors).
fn texture_ref(p: &Props, legacy: &str) -> Result<TextureRef> {
    if !p.contains("texture_name") && p.contains(legacy) {
        p.ctx().warn(
            &p.key_path(legacy),
            format!("legacy key '{legacy}' accepted as a constant texture; prefer 'texture_name'"),
        );
        return Ok(TextureRef::Color(p.vec3(legacy)?));
    }
    Ok(TextureRef::Named(at(p, "texture_name", p.string("texture_name")?)))
}

fn parse_material(name: &str, p: &Props) -> Result<MaterialDesc> {
    let ty = p.string_or("type", "diffuse")?;
    let positive_eta = |key: &str| -> Result<f32> {
        let eta = p.f32_or(key, 1.5)?;
        if eta <= 0.0 {
            return Err(p.error(key, format!("must be positive, found {eta}")));
        }
        Ok(eta)
    };
    let kind = match ty.as_str() {
        "diffuse" => MaterialKind::Diffuse {
            texture: texture_ref(p, "color")?,
            twosided: p.bool_or("twosided", false)?,
        },
        "refraction" => MaterialKind::Refraction { eta: positive_eta("eta")? },
        "glass" => MaterialKind::Glass {
            reflect: p.vec3_or("R", Vec3::ONE)?,
            transmit: p.vec3_or("T", Vec3::ONE)?,
            eta: positive_eta("eta")?,
        },
        "roughconductor" => MaterialKind::RoughConductor {
            texture: texture_ref(p, "R")?,
            eta_i: p.vec3_or("etaI", Vec3::ONE)?,
            eta_t: p.vec3_or("etaT", Vec3::ONE)?,
            k: p.vec3_or("k", Vec3::ONE)?,
            alpha_x: non_negative(p, "alpha_x", p.f32_or("alpha_x", 0.1)?)?,
            alpha_y: non_negative(p, "alpha_y", p.f32_or("alpha_y", 0.1)?)?,
            distribution: match p.string_or("distribution", "beckmann")?.as_str() {
                "beckmann" => crate::material::Distribution::Beckmann,
                "ggx" => crate::material::Distribution::Ggx,
                other => {
                    return Err(p.error(
                        "distribution",
                        format!("unknown microfacet distribution '{other}' (available: beckmann, ggx)"),
                    ))
                }
            },
        },
        _ => {
            return Err(p.error(
                "type",
                format!("unknown material type '{ty}' (available: diffuse, refraction, glass, roughconductor)"),
            ))
        }
    };
    p.finish();
    Ok(MaterialDesc {
        name: name.to_string(),
        key: p.path.clone(),
        kind,
    })
}

fn parse_object(p: &Props) -> Result<ObjectDesc> {
    let ty = p.string("type")?;
    let shape = match ty.as_str() {
        "mesh" => ShapeDesc::Mesh {
            path: at(p, "path", p.string("path")?),
            transform: p.mat4_or("transform", Mat4::IDENTITY)?,
            translate: p.vec3_or("translate", Vec3::ZERO)?,
        },
        "sphere" => {
            let radius = p.f32_or("radius", 1.0)?;
            if radius <= 0.0 {
                return Err(p.error("radius", format!("must be positive, found {radius}")));
            }
            ShapeDesc::Sphere {
                center: p.vec3_or("center", Vec3::ZERO)?,
                radius,
            }
        }
        _ => return Err(p.error("type", format!("unknown object type '{ty}' (available: mesh, sphere)"))),
    };
    let material = p.string_opt("material_name")?.map(|m| at(p, "material_name", m));
    let light = match p.object_opt("light")? {
        None => None,
        Some(l) => {
            let ty = l.string_or("type", "area")?;
            if ty != "area" {
                return Err(l.error("type", format!("unknown light type '{ty}' on an object (available: area)")));
            }
            let radiance = l.vec3_or("radiance", Vec3::ONE)?;
            if radiance.min_element() < 0.0 {
                return Err(l.error("radiance", "must not be negative"));
            }
            l.finish();
            Some(AreaLightDesc {
                key: l.path.clone(),
                radiance,
            })
        }
    };
    if material.is_none() && light.is_none() {
        return Err(p.ctx().error(&p.path, "an object needs a 'material_name', a 'light', or both"));
    }
    p.finish();
    Ok(ObjectDesc {
        key: p.path.clone(),
        shape,
        material,
        light,
    })
}

fn parse_env(p: &Props) -> Result<EnvMapDesc> {
    let e = EnvMapDesc {
        key: p.path.clone(),
        texture: at(p, "texture_name", p.string("texture_name")?),
        scale: non_negative(p, "scale", p.f32_or("scale", 1.0)?)?,
        transform: p.mat4_or("transform", Mat4::IDENTITY)?,
    };
    p.finish();
    Ok(e)
}
