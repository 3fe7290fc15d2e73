//! The description layer: a scene file read into plain values that remember where
//! they came from ([`Source`]), and [`build`](mod@build), the separate step that turns
//! them into the render-ready [`crate::scene::Scene`] (the job's camera, film and
//! integrator become a [`crate::render::RenderJob`]). The RDR171 JSON (spec §3–§12)
//! is read by [`json`], Mitsuba XML by [`xml`] (which also reads `<include>`d files and
//! looks up where named files are); [`convert`] writes a description in either format.
//! Meshes and textures are loaded when the scene is built.
//!
//! The variant families are the render layer's own types with their unresolved
//! parts as parameters: [`Material<TextureRef>`](Material), [`Texture<ImageFile>`](Texture),
//! [`Shape<MeshFile>`](Shape), and [`Filter`], [`CameraParams`], [`UvMapping`] as they
//! are. Each type's documentation (here or on the shared type) lists its keys with
//! their defaults; values that later steps may report on keep their [`Source`].

pub mod build;
pub mod convert;
pub mod json;
pub mod principled;
pub mod source;
pub mod xml;

pub use build::{build, BuildOptions};
pub use source::{Located, Source};

use crate::camera::CameraParams;
use crate::error::Result;
use crate::film::Filter;
use crate::geometry::sphere::Sphere;
use crate::material::{Distribution, Material};
use crate::math::{Mat4, Vec2, Vec3};
use crate::scene::Shape;
use crate::texture::{Texture, UvMapping};
use json::{Context, Props};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The whole scene. Top-level keys: `integrator`, `film`, `camera` (required),
/// `textures`, `materials`, `objects`, `shapegroups`, `environment_map`.
#[derive(Clone, Debug)]
pub struct SceneDesc {
    pub file: PathBuf,
    /// Folder every relative path resolves against: the scene file's own.
    pub base_dir: PathBuf,
    pub integrator: IntegratorDesc,
    pub film: FilmDesc,
    pub camera: CameraParams,
    pub textures: Vec<TextureDesc>,
    pub materials: Vec<MaterialDesc>,
    pub objects: Vec<ObjectDesc>,
    /// Named groups of objects shown by `instances` ([`ShapeGroupDesc`]).
    pub shapegroups: Vec<ShapeGroupDesc>,
    /// The `instance` entries of `objects` ([`InstanceDesc`]).
    pub instances: Vec<InstanceDesc>,
    pub environment_map: Option<EnvMapDesc>,
    pub warnings: Vec<String>,
    /// The files a Mitsuba XML scene's `<include>`s read, in the order read (empty
    /// for JSON): part of what made the image (see `render::identity`).
    pub included: Vec<PathBuf>,
    /// What `rdr convert` to the other format loses that the reader saw (one line
    /// each, naming the element): a Mitsuba `twosided` the JSON cannot keep.
    pub convert_notes: Vec<String>,
}

/// `shapegroups.NAME`: `objects` (a list as the top-level one: meshes, spheres,
/// cylinders with their `material_name`; no `light`, as Mitsuba refuses emitters in
/// shape groups, and no `instance`). A group renders only through its instances,
/// which share one bottom-level BVH of it (Mitsuba's `shapegroup`).
///
/// ```json
/// "shapegroups": {"bunny": {"objects": [{"type": "mesh", "path": "bunny.obj", "material_name": "white"}]}}
/// ```
#[derive(Clone, Debug)]
pub struct ShapeGroupDesc {
    pub name: String,
    pub source: Source,
    pub objects: Vec<ObjectDesc>,
}

/// `objects[i]` of `type` `"instance"`: `shapegroup` (a name in `shapegroups`,
/// required), `transform` (16 numbers row-major, identity; affine and invertible),
/// `translate` ((0,0,0), added after `transform`). No `material_name` or `light`:
/// the group's objects bring theirs (Mitsuba's `instance`).
///
/// ```json
/// {"type": "instance", "shapegroup": "bunny", "translate": [2, 0, 0]}
/// ```
#[derive(Clone, Debug)]
pub struct InstanceDesc {
    pub source: Source,
    pub shapegroup: Located<String>,
    /// Object → world, `translate` included.
    pub transform: Mat4,
}

/// A cylinder from Mitsuba's parameters, checked: the segment `p0`–`p1` and `radius`
/// placed by `to_world`, which must keep it a circular cylinder (rotation,
/// translation, a scale uniform across the axis, no mirroring). `Err((key, why))`.
pub fn cylinder_shape(
    p0: Vec3,
    p1: Vec3,
    radius: f32,
    flip_normals: bool,
    to_world: &Mat4,
) -> std::result::Result<crate::geometry::cylinder::CylinderShape, (&'static str, String)> {
    use crate::geometry::cylinder::{mitsuba_frame, Cylinder, CylinderShape};
    if !(radius > 0.0 && radius <= crate::limits::MAX_COORD) {
        return Err(("radius", format!("must be positive, found {radius}")));
    }
    let axis = p1 - p0;
    if axis.length() <= 0.0 || axis.is_nan() {
        return Err(("p1", "must differ from p0".into()));
    }
    let (x, y) = mitsuba_frame(axis.normalize());
    let (wp0, wp1) = (to_world.transform_point3(p0), to_world.transform_point3(p1));
    let (wx, wy, wa) = (
        to_world.transform_vector3(x * radius),
        to_world.transform_vector3(y * radius),
        wp1 - wp0,
    );
    let r = wx.length();
    let (ux, uy, ua) = (wx / r, wy / wy.length(), wa / wa.length());
    let skew = ux.dot(uy).abs() + ux.dot(ua).abs() + uy.dot(ua).abs();
    if !(r.is_finite() && (wy.length() - r).abs() <= 1e-4 * r && skew < 1e-4 && wa.length().is_finite()) {
        return Err((
            "transform",
            "a cylinder's transform must be a rotation, translation and a scale uniform across its axis".into(),
        ));
    }
    if ux.cross(uy).dot(ua) < 0.0 {
        return Err(("transform", "a cylinder's transform must not mirror".into()));
    }
    for v in [wp0, wp1] {
        if v.abs().max_element() > crate::limits::MAX_COORD || r > crate::limits::MAX_COORD {
            return Err((
                "transform",
                format!(
                    "the cylinder is out of range (coordinates must be within ±{:e})",
                    crate::limits::MAX_COORD
                ),
            ));
        }
    }
    Ok(CylinderShape {
        cylinder: Cylinder {
            p0: wp0,
            axis: wa,
            x: ux,
            radius: r,
        },
        flip_normals,
    })
}

use crate::integrator::{
    bdpt::Heuristic, guided, Bdpt, Guided, Integrator, IntersectionTest, Normals, PathProfile, PathTracer, PhotonMapper, Ptracer, Sppm,
};

/// `integrator`:
/// * `type` (`"path"`) — `"path"`, `"bdpt"`, `"guided"`, `"ptracer"`, `"intersection_test"`, `"photon"`,
///   `"sppm"` or `"normals"` (a debug view: shading normals as colours). The keys of each
///   are documented on its type:
///   [`PathTracer`] (`spp` 32, `max_depth` 12, `profile`, `rr_threshold`),
///   [`Bdpt`] (as `path`, and `mis`, `strategy`, `strategy_weighted`, `visualize_strategies`, `connection_roulette`), [`Guided`] (`spp` 64,
///   `max_depth` 12, `rr_threshold`, `bsdf_fraction` 0.5, `training_iterations`, `combine`,
///   `spatial_threshold`, `learn_direct`, `training_share`, `learn_fraction`, `min_gain`, `learn_from`), [`Ptracer`]
///   (`spp` 32, `max_depth` 12, `rr_threshold`),
///   [`PhotonMapper`] (`spp` 16, `n_photons`, `n_iterations`, `n_near_photons`, …),
///   [`Sppm`] (`spp` 64 iterations, `photons_per_iteration`, `initial_radius`, …),
///   [`IntersectionTest`] (`spp` 8, `max_depth` 16, `light_samples` 1), [`Normals`] (`spp` 8).
/// * `spp` (int ≥ 1) — samples per pixel, default per type as above.
/// * `point_light_position` (vec3, (0,5,0)), `point_light_flux` (vec3, (1,1,1)) —
///   the legacy single point light; present when either key is given or when
///   there is no `lights` list.
/// * `lights` — list of `{"type": "point", "position": [..], "flux": [..]}`, and (for
///   every integrator; `--compat rdr171` refuses them) Mitsuba's delta lights:
///   `{"type": "spot", "position": [..], "look_at": [..] (or "direction": [..]), "intensity": [..]
///   ((1,1,1), radiant intensity on the axis), "cutoff_angle": 20, "beam_width": ¾ of
///   cutoff_angle}` (degrees, half-angles; linear falloff in angle between them) and
///   `{"type": "directional", "direction": [..] (of travel), "irradiance": [..] ((1,1,1))}`.
///   A spot with `"texture": "<texture name>"` projects that image over its cone
///   (Mitsuba's `spot` `texture`; `cutoff_angle` below 90 then), oriented by `ref_up`
///   ((0,1,0); the image's v axis, as a camera's); see [`crate::light::textured_spot`].
///   `{"type": "projector", "position": [..], "look_at": [..] (or "direction"), "ref_up":
///   [..] ((0,1,0)), "irradiance": "<texture name>" (or [r, g, b]; required), "scale": 1,
///   "fov": degrees (or 46.8 on the diagonal), "fov_axis": "x" | "y" | "diagonal" |
///   "smaller" | "larger" ("x")}`: Mitsuba's `projector`, an image through a pinhole,
///   intensity π·scale·E/cos³θ; see [`crate::light::projector`].
/// * `light_sampling` (`"importance"` | `"uniform"`, `"importance"`) — lights drawn
///   by their own importance and chosen by power, or uniformly (for comparisons).
///
/// ```json
/// {"type": "path", "profile": "NEE", "spp": 64, "max_depth": 8}
/// {"type": "intersection_test", "spp": 32, "max_depth": 16,
///  "lights": [{"type": "point", "position": [0, 1.5, 0.5], "flux": [17, 12, 5]}]}
/// {"type": "path", "lights": [{"type": "spot", "position": [0, 2, 0], "look_at": [0, 0, 0], "intensity": [5, 5, 5], "cutoff_angle": 30},
///                             {"type": "directional", "direction": [0, -1, -1], "irradiance": [2, 2, 2]}]}
/// ```
#[derive(Clone, Debug)]
pub struct IntegratorDesc {
    pub integrator: Integrator,
    pub spp: u32,
    pub point_lights: Vec<PointLightDesc>,
    /// Spot and directional lights ([`crate::light::Light::Spot`], `Directional`).
    pub delta_lights: Vec<DeltaLightDesc>,
    pub light_sampling: crate::light::LightSampling,
}

/// A spot or directional light, as it renders, and where it was given.
#[derive(Clone, Debug)]
pub struct DeltaLightDesc {
    pub light: crate::light::Light,
    pub key: String,
    /// The texture of a textured spot or a projector (the `light` holds a constant
    /// placeholder until the scene is built).
    pub texture: Option<TextureRef>,
}

/// The frame of a light at the origin of Mitsuba's `lookat` along `axis` with `up`:
/// `s = up × n` (its x, the camera's left), `t = n × s`, `n` the unit axis.
pub fn light_frame(axis: Vec3, up: Vec3) -> std::result::Result<crate::math::Frame, String> {
    let n = axis.normalize_or_zero();
    let s = up.cross(n).normalize_or_zero();
    if n == Vec3::ZERO || s == Vec3::ZERO || !n.is_finite() || !s.is_finite() {
        return Err("the light's direction is degenerate or parallel to its up vector".into());
    }
    Ok(crate::math::Frame { s, t: n.cross(s), n })
}

/// A spot light with a texture (its constant placeholder): a checked [`spot_light`]
/// in `frame`; the texture's square spans the cutoff cone, so the cutoff is below 90°.
pub fn textured_spot(
    position: Vec3,
    frame: crate::math::Frame,
    intensity: Vec3,
    cutoff_deg: f32,
    beam_deg: Option<f32>,
) -> std::result::Result<crate::light::Light, String> {
    let crate::light::Light::Spot { cutoff, beam_width, .. } = spot_light(position, frame.n, intensity, cutoff_deg, beam_deg)? else {
        unreachable!("spot_light makes spots")
    };
    if cutoff_deg >= 90.0 {
        return Err(format!("cutoff_angle must be below 90 degrees with a texture, found {cutoff_deg}"));
    }
    Ok(crate::light::Light::TexturedSpot(crate::light::TexturedSpot {
        position,
        frame,
        intensity,
        cutoff,
        beam_width,
        texture: Texture::Constant(Vec3::ONE),
    }))
}

/// A projector (constant placeholder image), checked: `fov_deg` in (0, 180), `scale` ≥ 0.
pub fn projector_light(
    position: Vec3,
    frame: crate::math::Frame,
    scale: f32,
    fov_deg: f32,
    axis: crate::light::projector::FovAxis,
) -> std::result::Result<crate::light::Light, String> {
    if !(fov_deg > 0.0 && fov_deg < 180.0) {
        return Err(format!("fov must be between 0 and 180 degrees, found {fov_deg}"));
    }
    if !(scale >= 0.0 && scale.is_finite()) {
        return Err(format!("scale must not be negative, found {scale}"));
    }
    Ok(crate::light::Light::Projector(crate::light::Projector::new(
        position,
        frame,
        scale,
        fov_deg.to_radians(),
        axis,
    )))
}

/// Mitsuba's default field of view: a 50 mm lens on a 35 mm film's diagonal, degrees.
pub fn default_fov_deg() -> f32 {
    2.0 * (36f32.hypot(24.0) / 100.0).atan().to_degrees()
}

/// A spot light from Mitsuba's parameters (angles in degrees), checked.
pub fn spot_light(
    position: Vec3,
    axis: Vec3,
    intensity: Vec3,
    cutoff_deg: f32,
    beam_deg: Option<f32>,
) -> std::result::Result<crate::light::Light, String> {
    if !(cutoff_deg > 0.0 && cutoff_deg <= 180.0) {
        return Err(format!("cutoff_angle must be in (0, 180] degrees, found {cutoff_deg}"));
    }
    let beam_deg = beam_deg.unwrap_or(cutoff_deg * 0.75);
    if !(beam_deg > 0.0 && beam_deg <= cutoff_deg) {
        return Err(format!("beam_width must be in (0, cutoff_angle] degrees, found {beam_deg}"));
    }
    if !(intensity.min_element() >= 0.0 && intensity.is_finite()) {
        return Err("intensity must not be negative".into());
    }
    let axis = axis.normalize_or_zero();
    if axis == Vec3::ZERO || !axis.is_finite() {
        return Err("the spot light's direction is degenerate".into());
    }
    Ok(crate::light::Light::Spot {
        position,
        axis,
        intensity,
        cutoff: cutoff_deg.to_radians(),
        beam_width: beam_deg.to_radians(),
    })
}

/// A directional light travelling along `direction`, checked.
pub fn directional_light(direction: Vec3, irradiance: Vec3) -> std::result::Result<crate::light::Light, String> {
    if !(irradiance.min_element() >= 0.0 && irradiance.is_finite()) {
        return Err("irradiance must not be negative".into());
    }
    let direction = direction.normalize_or_zero();
    if direction == Vec3::ZERO || !direction.is_finite() {
        return Err("the direction must not be zero".into());
    }
    Ok(crate::light::Light::Directional { direction, irradiance })
}

/// A point light of total power `flux` Φ (radiant intensity Φ/4π).
#[derive(Clone, Debug)]
pub struct PointLightDesc {
    pub position: Vec3,
    pub flux: Vec3,
    pub key: String,
}

/// `film`: `resolution` ([int, int], positive, at most 2²⁸ pixels, [600, 600]),
/// `block_side_length` (int ≥ 1, 16; tile size, no effect on the image), `filter`
/// (object, box of radius 0.5; see [`Filter`]).
#[derive(Clone, Debug)]
pub struct FilmDesc {
    pub width: u32,
    pub height: u32,
    pub block_size: u32,
    pub filter: Filter,
}

/// `textures.<name>`: `type` = `constant` (`color`, required) | `checkerboard`
/// (`color0` (0.4), `color1` (0.2), `tex_coordinate_generator`) | `image` (`path`,
/// `tex_coordinate_generator`, `filter` (`"trilinear"`), `raw` (false); see
/// [`ImageFile`]); see [`Texture`] and [`UvMapping`].
///
/// ```json
/// "textures": {"normals": {"type": "image", "path": "n.png", "filter": "nearest", "raw": true,
///              "tex_coordinate_generator": {"type": "uvmapping2d"}}}
/// ```
#[derive(Clone, Debug)]
pub struct TextureDesc {
    pub name: String,
    pub source: Source,
    pub texture: Texture<ImageFile>,
}

/// An `image` texture's file (`path`, relative to the scene file's folder, read when
/// the scene is built) and its `tex_coordinate_generator`.
#[derive(Clone, Debug)]
pub struct ImageFile {
    pub path: Located<String>,
    pub mapping: UvMapping,
    /// `filter`: `"trilinear"` (default: MIP-mapped by the ray footprint) | `"bilinear"`
    /// (the full-resolution image, Mitsuba's `filter_type` `bilinear`) | `"nearest"`.
    pub filter: crate::texture::image::ImageFilter,
    /// `raw` (false): PNG and JPEG values as they are, not decoded from sRGB
    /// (Mitsuba's `raw`; EXR and HDR are linear either way).
    pub raw: bool,
}

/// `materials.<name>`: `type` (`"diffuse"`) and per type:
/// * `diffuse`: `texture_name` (required), `twosided` (false);
/// * `refraction`: `eta` (1.5);
/// * `glass`: `R` ((1,1,1)), `T` ((1,1,1)), `eta` (1.5);
/// * `roughconductor`: `texture_name` (required), `etaI`, `etaT`, `k` ((1,1,1)),
///   `alpha_x`, `alpha_y` (0.1), `distribution` (`"beckmann"` | `"ggx"`, `"beckmann"`);
/// * `conductor`: `texture_name` (optional tint), `eta` ((0,0,0)), `k` ((1,1,1));
/// * `thindielectric`: `R`, `T` ((1,1,1)), `eta` (1.5);
/// * `roughdielectric`: `R`, `T` ((1,1,1)), `eta` (1.5), `alpha_x`, `alpha_y` (0.1),
///   `distribution` (`"beckmann"`);
/// * `plastic`: `texture_name` (diffuse; constant 0.5 when absent),
///   `specular_reflectance` ((1,1,1)), `eta` (1.49, not 1), `nonlinear` (false);
/// * `roughplastic`: as `plastic`, and `alpha` (0.1), `distribution` (`"beckmann"`);
/// * `twosided`: `material_name` (required), `back_material_name` (optional);
/// * `bumpmap`: `material_name`, `texture_name` (both required; heights), `scale` (1),
///   `flip_invalid_normals`, `use_shadowing_function` (true each);
/// * `normalmap`: `material_name`, `texture_name` (both required; tangent-space
///   normals as `(n + 1)/2`), `flip_invalid_normals`, `use_shadowing_function` (true);
/// * `mask`: `material_name` (required), `opacity` (in [0, 1], 0.5) or `texture_name`
///   (an opacity texture); outermost only;
/// * `principled`: `base_color` (0.5), `roughness` (0.5), `metallic`, `specular` (0.5)
///   or `eta`, `spec_tint`, `anisotropic`, `sheen`, `sheen_tint`, `clearcoat`,
///   `clearcoat_gloss`, `spec_trans`, `flatness` (0 each; each a number or a texture
///   name), three sampling rates; see [`principled`];
/// * `principledthin`: `base_color`, `roughness` (0.5), `anisotropic`, `spec_trans`,
///   `spec_tint`, `sheen`, `sheen_tint`, `flatness`, `diff_trans` (0), `eta` (1.5), four
///   sampling rates; see [`principled`];
/// * `blendbsdf`: `weight` (required, a number or a texture name), `material_names`
///   (required, two names); see [`principled`];
///
/// see [`Material`], which also names the Mitsuba parameter behind each key.
///
/// ```json
/// "materials": {
///   "red": {"type": "roughplastic", "texture_name": "red", "alpha": 0.2, "distribution": "ggx"},
///   "mirror": {"type": "conductor"},
///   "card": {"type": "twosided", "material_name": "red"},
///   "bumpy": {"type": "bumpmap", "material_name": "card", "texture_name": "heights", "scale": 0.5},
///   "leaf": {"type": "mask", "material_name": "bumpy", "texture_name": "leaf_alpha"}
/// }
/// ```
#[derive(Clone, Debug)]
pub struct MaterialDesc {
    pub name: String,
    pub source: Source,
    pub material: Material<TextureRef>,
}

/// A material's texture: by name, or an inline colour (legacy keys).
#[derive(Clone, Debug)]
pub enum TextureRef {
    Named(Located<String>),
    Color(Vec3),
}

/// `objects[i]`: `type` (`"mesh"` | `"sphere"` | `"cylinder"`, required; see [`Shape`]),
/// `material_name`, `light`; at least one of the last two. (`"instance"` entries are
/// [`InstanceDesc`]s.) A cylinder (Mitsuba's, open, uv `(φ/2π, height)`):
///
/// ```json
/// {"type": "cylinder", "p0": [0, 0, 0], "p1": [0, 2, 0], "radius": 0.5, "flip_normals": false,
///  "transform": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "material_name": "white"}
/// ```
#[derive(Clone, Debug)]
pub struct ObjectDesc {
    pub source: Source,
    pub shape: Shape<MeshFile>,
    pub material: Option<Located<String>>,
    pub light: Option<AreaLightDesc>,
}

/// A `mesh` object's file and placement: `path` (OBJ, relative to the scene file's
/// folder, required; read when the scene is built), `transform` (16 numbers row-major,
/// identity), `translate` ((0,0,0), added after `transform`).
///
/// ```json
/// {"type": "mesh", "path": "meshes/bunny.obj", "translate": [0, 0.5, 0], "material_name": "white"}
/// ```
#[derive(Clone, Debug)]
pub struct MeshFile {
    pub path: Located<String>,
    pub transform: Mat4,
    pub translate: Vec3,
    /// How the file is read and its normals made (JSON meshes: the default, an OBJ
    /// with the normals it has).
    pub options: MeshOptions,
}

/// A mesh's file format and treatment, for what other scene formats say about
/// meshes (the Mitsuba reader, [`xml`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshOptions {
    pub format: MeshFormat,
    pub normals: MeshNormals,
    /// Reverse the winding and the normals (the emitting side of an area light too).
    pub flip_normals: bool,
    /// `v → 1 − v` for the texture coordinates.
    pub flip_uv: bool,
}

/// Where a mesh's triangles come from.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum MeshFormat {
    /// Wavefront OBJ (`path`).
    #[default]
    Obj,
    /// PLY, ASCII or binary (`path`).
    Ply,
    /// Mitsuba's zlib-compressed `.serialized` format: mesh `shape_index` of the file.
    Serialized {
        shape_index: u32,
    },
    /// Generated, no file: Mitsuba's `rectangle` ([−1, 1]² at z = 0, normal +z),
    /// `cube` ([−1, 1]³, outward face normals) and `disk` (unit radius at z = 0,
    /// normal +z, tessellated into [`DISK_SEGMENTS`] triangles).
    Rectangle,
    Cube,
    Disk,
}

impl MeshFormat {
    /// Whether the mesh is read from its `path` (not generated).
    pub fn reads_file(&self) -> bool {
        !matches!(self, MeshFormat::Rectangle | MeshFormat::Cube | MeshFormat::Disk)
    }
}

/// Triangles a generated `disk` is made of.
pub const DISK_SEGMENTS: u32 = 256;

/// Which normals a mesh gets.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MeshNormals {
    /// The file's vertex normals, if any (flat shading otherwise).
    #[default]
    AsInFile,
    /// None: flat shading even when the file has normals (Mitsuba's `face_normals`).
    Face,
    /// The file's, or when it has none, area-weighted averages of the faces around
    /// each vertex (Mitsuba's default for OBJ and PLY).
    SmoothWhenMissing,
}

/// `objects[i].light`: `type` (`"area"`), `radiance` ([r, g, b] or a texture name,
/// (1,1,1)); one-sided emission. A texture's radiance is looked up at the emitting
/// point's uv (Mitsuba's `area` with a `bitmap` `radiance`); points are still sampled
/// by area (see [`crate::light::area`]).
///
/// ```json
/// "light": {"type": "area", "radiance": "sign"}
/// ```
#[derive(Clone, Debug)]
pub struct AreaLightDesc {
    pub source: Source,
    pub radiance: Vec3,
    /// A radiance texture (then `radiance` is unused).
    pub texture: Option<Located<String>>,
}

/// `environment_map`: `texture_name` (required), `scale` (1), `transform` (identity).
#[derive(Clone, Debug)]
pub struct EnvMapDesc {
    pub source: Source,
    pub texture: Located<String>,
    pub scale: f32,
    pub transform: Mat4,
}

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
        // a regular file of a sane size: a FIFO would block, /dev/zero never end
        let bytes = crate::limits::read_input_file(file, crate::limits::max_input_file())
            .map_err(|e| ctx.error("", format!("cannot read scene: {e}")))?;
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
            shapegroups,
            instances,
            environment_map,
            warnings,
            included: Vec::new(),
            convert_notes: Vec::new(),
        })
    }
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

fn parse_integrator(p: &Props) -> Result<IntegratorDesc> {
    let ty = p.string_or("type", "path")?;
    const TYPES: [&str; 8] = [
        "path",
        "bdpt",
        "guided",
        "ptracer",
        "intersection_test",
        "photon",
        "sppm",
        "normals",
    ];
    // the type first, so an unknown one is reported before any of its keys
    let kind = ty.as_str();
    if !TYPES.contains(&kind) {
        return Err(p.error("type", format!("unknown integrator '{ty}' (available: {})", TYPES.join(", "))));
    }
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
            let max_depth = capped(p, "max_depth", p.int_at_least("max_depth", 12, 1)?, MAX_DEPTH);
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
        "guided" => (Integrator::Guided(parse_guided(p)?), p.int_at_least("spp", 64, 1)?),
        "ptracer" => {
            let rr_threshold = p.f32_or("rr_threshold", 0.1)?;
            let spp = p.int_at_least("spp", 32, 1)?;
            let max_depth = capped(p, "max_depth", p.int_at_least("max_depth", 12, 1)?, MAX_DEPTH);
            (Integrator::Ptracer(Ptracer { max_depth, rr_threshold }), spp)
        }
        "normals" => (Integrator::Normals(Normals), p.int_at_least("spp", 8, 1)?),
        "photon" => (
            Integrator::Photon(PhotonMapper {
                n_photons: p.int_at_least("n_photons", 100_000, 1)?,
                n_iterations: p.int_at_least("n_iterations", 1, 1)?,
                n_near_photons: p.int_at_least("n_near_photons", 64, 1)?,
                max_depth: capped(p, "max_depth", p.int_at_least("max_depth", 12, 1)?, MAX_DEPTH),
                rr_threshold: unit_interval(p, "rr_threshold")?,
            }),
            p.int_at_least("spp", 16, 1)?,
        ),
        "sppm" => {
            let initial_radius = match p.contains("initial_radius") {
                true => Some(p.f32_or("initial_radius", 0.0)?).filter(|r| *r > 0.0),
                false => None,
            };
            if p.contains("initial_radius") && initial_radius.is_none() {
                return Err(p.error("initial_radius", "initial_radius must be positive"));
            }
            let alpha = p.f32_or("alpha", 2.0 / 3.0)?;
            if !(alpha > 0.0 && alpha <= 1.0) {
                return Err(p.error("alpha", "alpha must lie in (0, 1]"));
            }
            let sppm = Sppm {
                photons_per_iteration: p.int_at_least("photons_per_iteration", 100_000, 1)?,
                initial_radius,
                alpha,
                max_depth: capped(p, "max_depth", p.int_at_least("max_depth", 12, 1)?, MAX_DEPTH),
                rr_threshold: unit_interval(p, "rr_threshold")?,
            };
            (Integrator::Sppm(sppm), p.int_at_least("spp", 64, 1)?)
        }
        _ => {
            let spp = p.int_at_least("spp", 8, 1)?;
            let max_depth = capped(p, "max_depth", p.int_at_least("max_depth", 16, 1)?, MAX_DEPTH);
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
            position: point(
                p,
                "point_light_position",
                p.vec3_or("point_light_position", Vec3::new(0.0, 5.0, 0.0))?,
            )?,
            flux: non_negative_flux(p, "point_light_flux", p.vec3_or("point_light_flux", Vec3::ONE)?)?,
            key: p.key_path("point_light_position"),
        });
    }
    let mut delta_lights = Vec::new();
    for l in p.objects("lights")? {
        let ty = l.string("type")?;
        let axis_of = |position: Vec3| -> Result<Vec3> {
            if l.contains("direction") {
                l.vec3("direction")
            } else {
                Ok(point(&l, "look_at", l.vec3("look_at")?)? - position)
            }
        };
        let frame_of = |axis: Vec3| {
            let key = ["ref_up", "direction"].into_iter().find(|k| l.contains(k)).unwrap_or("look_at");
            light_frame(axis, l.vec3_or("ref_up", Vec3::Y)?).map_err(|e| l.error(key, e))
        };
        if ty == "projector" {
            let position = point(&l, "position", l.vec3("position")?)?;
            let frame = frame_of(axis_of(position)?)?;
            let texture = match l.raw("irradiance") {
                None => return Err(l.error("irradiance", "required key is missing (a texture name or [r, g, b])")),
                Some(_) => principled::json_texture(&l, "irradiance", 1.0, true)?,
            };
            let (fov, axis) = match l.contains("fov") {
                true => (l.f32_or("fov", 45.0)?, l.string_or("fov_axis", "x")?),
                false => (default_fov_deg(), l.string_or("fov_axis", "diagonal")?),
            };
            let axis = crate::light::projector::FovAxis::parse(&axis)
                .ok_or_else(|| l.error("fov_axis", format!("unknown axis '{axis}' (x, y, diagonal, smaller, larger)")))?;
            let light = projector_light(position, frame, l.f32_or("scale", 1.0)?, fov, axis)
                .map_err(|e| l.error(if e.starts_with("fov") { "fov" } else { "scale" }, e))?;
            delta_lights.push(DeltaLightDesc {
                light,
                key: l.path.clone(),
                texture: Some(texture),
            });
            l.finish();
            continue;
        }
        if ty == "spot" {
            let position = point(&l, "position", l.vec3("position")?)?;
            let axis = axis_of(position)?;
            let cutoff = l.f32_or("cutoff_angle", 20.0)?;
            let beam = if l.contains("beam_width") {
                Some(l.f32_or("beam_width", 15.0)?)
            } else {
                None
            };
            let texture = l.string_opt("texture")?.map(|t| TextureRef::Named(l.located("texture", t)));
            let intensity = l.vec3_or("intensity", Vec3::ONE)?;
            if texture.is_none() {
                l.ignore("ref_up"); // orients the texture only
            }
            let light = match &texture {
                None => spot_light(position, axis, intensity, cutoff, beam),
                Some(_) => textured_spot(position, frame_of(axis)?, intensity, cutoff, beam),
            }
            .map_err(|e| {
                let key = if e.starts_with("beam") {
                    "beam_width"
                } else if e.starts_with("cutoff") {
                    "cutoff_angle"
                } else if e.starts_with("intensity") {
                    "intensity"
                } else {
                    "look_at"
                };
                l.error(key, e)
            })?;
            delta_lights.push(DeltaLightDesc {
                light,
                key: l.path.clone(),
                texture,
            });
            l.finish();
            continue;
        }
        if ty == "directional" {
            let light = directional_light(l.vec3("direction")?, l.vec3_or("irradiance", Vec3::ONE)?)
                .map_err(|e| l.error(if e.starts_with("irradiance") { "irradiance" } else { "direction" }, e))?;
            delta_lights.push(DeltaLightDesc {
                light,
                key: l.path.clone(),
                texture: None,
            });
            l.finish();
            continue;
        }
        if ty != "point" {
            return Err(l.error(
                "type",
                format!("unknown light type '{ty}' in the integrator's list (available: point, spot, directional, projector)"),
            ));
        }
        point_lights.push(PointLightDesc {
            position: point(&l, "position", l.vec3("position")?)?,
            flux: non_negative_flux(&l, "flux", l.vec3("flux")?)?,
            key: l.path.clone(),
        });
        l.finish();
    }
    let light_samples = capped(p, "light_samples", p.int_at_least("light_samples", 1, 1)?, MAX_LIGHT_SAMPLES);
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
        delta_lights,
        light_sampling,
    })
}

/// The keys of [`Guided`] (documented there).
fn parse_guided(p: &Props) -> Result<Guided> {
    let d = Guided::default();
    let rr_threshold = unit_interval(p, "rr_threshold")?;
    let max_depth = capped(p, "max_depth", p.int_at_least("max_depth", d.max_depth as i32, 1)?, MAX_DEPTH);
    let bsdf_fraction = p.f32_or("bsdf_fraction", d.bsdf_fraction)?;
    if !(bsdf_fraction > 0.0 && bsdf_fraction <= 1.0) {
        return Err(p.error(
            "bsdf_fraction",
            "bsdf_fraction must lie in (0, 1] (without BSDF sampling directions the tree never learned would be missed)",
        ));
    }
    let training_iterations = match p.contains("training_iterations") {
        true => Some(capped(p, "training_iterations", p.int_at_least("training_iterations", 0, 0)?, 30)),
        false => None,
    };
    let combine = match p.string_or("combine", "inverse_variance")?.as_str() {
        "inverse_variance" => guided::Combine::InverseVariance,
        "last" => guided::Combine::Last,
        other => return Err(p.error("combine", format!("unknown combine '{other}' (available: inverse_variance, last)"))),
    };
    let spatial_threshold = p.f32_or("spatial_threshold", d.spatial_threshold)?;
    if !(spatial_threshold > 0.0 && spatial_threshold.is_finite()) {
        return Err(p.error("spatial_threshold", "spatial_threshold must be a positive number"));
    }
    let learn_direct = p.bool_or("learn_direct", d.learn_direct)?;
    let learn_fraction = p.bool_or("learn_fraction", d.learn_fraction)?;
    let training_share = p.f32_or("training_share", d.training_share)?;
    if !(training_share > 0.0 && training_share <= 1.0) {
        return Err(p.error("training_share", "training_share must lie in (0, 1]"));
    }
    let learn_from = match p.string_or("learn_from", "photons")?.as_str() {
        "paths" => guided::LearnFrom::Paths,
        "photons" => guided::LearnFrom::Photons,
        other => return Err(p.error("learn_from", format!("unknown learn_from '{other}' (available: paths, photons)"))),
    };
    let min_gain = p.f32_or("min_gain", d.min_gain)?;
    if !(0.0..1.0).contains(&min_gain) {
        return Err(p.error("min_gain", "min_gain must lie in [0, 1)"));
    }
    Ok(Guided {
        min_gain,
        learn_from,
        training_share,
        learn_direct,
        learn_fraction,
        max_depth,
        rr_threshold,
        bsdf_fraction,
        training_iterations,
        combine,
        spatial_threshold,
    })
}

/// `rr_threshold` of the photon integrators: a number in [0, 1], 0.1 when absent.
fn unit_interval(p: &Props, key: &str) -> Result<f32> {
    let v = p.f32_or(key, 0.1)?;
    if !(0.0..=1.0).contains(&v) {
        return Err(p.error(key, format!("{key} must lie in [0, 1]")));
    }
    Ok(v)
}

/// Most path segments a sample may take (`max_depth`): glass without absorption
/// never ends a path by Russian roulette, so the depth bounds the work per sample.
pub const MAX_DEPTH: u32 = 1024;
/// Most `light_samples` per shading point.
pub const MAX_LIGHT_SAMPLES: u32 = 1024;
/// Largest filter radius in pixels: each sample touches (2·radius)² pixels.
pub const MAX_FILTER_RADIUS: f32 = 32.0;

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

/// The keys only `bdpt` has (see [`Bdpt`]): `mis`, `strategy`, `strategy_weighted`,
/// `visualize_strategies`, `connection_roulette`.
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
    let visualize_strategies = p.bool_or("visualize_strategies", false)?;
    if visualize_strategies && strategy.is_some() {
        return Err(p.error(
            "visualize_strategies",
            "writes every strategy's image: it cannot be combined with 'strategy' (one strategy alone)",
        ));
    }
    Ok(Bdpt {
        max_depth,
        rr_threshold,
        heuristic,
        strategy,
        strategy_weighted: p.bool_or("strategy_weighted", false)?,
        visualize_strategies,
        connection_roulette: in_range(
            p,
            "connection_roulette",
            p.f32_or("connection_roulette", crate::integrator::bdpt::CONNECTION_ROULETTE)?,
            0.0,
            1e3,
        )?,
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
        None => Filter::Box { radius: 0.5 },
        Some(f) => {
            let ty = f.string_or("type", "box")?;
            let radius = f.f32_or("radius", 0.5)?;
            if radius <= 0.0 {
                return Err(f.error("radius", format!("must be positive, found {radius}")));
            }
            if radius > MAX_FILTER_RADIUS {
                return Err(f.error("radius", format!("{radius} is too large (at most {MAX_FILTER_RADIUS} pixels)")));
            }
            let d = match ty.as_str() {
                "box" => Filter::Box { radius },
                "gaussian" => {
                    let alpha = f.f32_or("alpha", 2.0)?;
                    if alpha <= 0.0 {
                        return Err(f.error(
                            "alpha",
                            format!("must be positive, found {alpha} (the filter would weigh every sample 0)"),
                        ));
                    }
                    let g = Filter::gaussian(radius, alpha);
                    // the weight at a pixel's centre and half a pixel away must not vanish
                    if g.eval(0.0, 0.0) < 1e-4 || (radius > 0.5 && g.eval(0.5, 0.0) <= 0.0) {
                        return Err(f.error(
                            "alpha",
                            format!("{alpha} with radius {radius} makes the filter weights vanish (alpha·radius² must be at least 1e-4 and alpha at most about 300)"),
                        ));
                    }
                    g
                }
                "tent" => Filter::Tent { radius },
                "mitchell" => Filter::Mitchell {
                    radius,
                    b: f.f32_or("B", 1.0 / 3.0)?,
                    c: f.f32_or("C", 1.0 / 3.0)?,
                },
                _ => return Err(f.error("type", format!("unknown filter '{ty}' (available: box, tent, gaussian, mitchell)"))),
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

fn parse_camera(p: &Props) -> Result<CameraParams> {
    use crate::camera::Projection;
    let ty = p.string_or("type", "perspective")?;
    let positive = |key: &str| -> Result<f32> {
        if !p.contains(key) {
            return Err(p.error(key, format!("is required for a '{ty}' camera")));
        }
        let v = p.f32_or(key, 0.0)?;
        if v.is_nan() || v <= 0.0 {
            return Err(p.error(key, format!("must be positive, found {v}")));
        }
        in_range(p, key, v, 1e-6, 1e15)?;
        Ok(v)
    };
    let projection = match ty.as_str() {
        "perspective" => Projection::Pinhole,
        "thinlens" => {
            if !p.contains("aperture_radius") {
                return Err(p.error("aperture_radius", "is required for a 'thinlens' camera"));
            }
            let aperture_radius = p.f32_or("aperture_radius", 0.0)?;
            if aperture_radius.is_nan() || aperture_radius < 0.0 {
                return Err(p.error("aperture_radius", format!("must be at least 0, found {aperture_radius}")));
            }
            in_range(p, "aperture_radius", aperture_radius, 0.0, 1e15)?;
            Projection::ThinLens {
                aperture_radius,
                focus_distance: positive("focus_distance")?,
            }
        }
        "orthographic" => {
            let height = if p.contains("height") { positive("height")? } else { 2.0 };
            if p.contains("fov") {
                p.ctx()
                    .warn(&p.key_path("fov"), "an orthographic camera has no field of view: ignored");
            }
            Projection::Orthographic { height }
        }
        other => {
            return Err(p.error(
                "type",
                format!("unknown camera type '{other}' (available: perspective, thinlens, orthographic)"),
            ));
        }
    };
    let near_clip = p.f32_or("near_clip", 0.0)?;
    let far_clip = if p.contains("far_clip") {
        p.f32_or("far_clip", 0.0)?
    } else {
        f32::INFINITY
    };
    crate::camera::check_clip_range(near_clip, far_clip).map_err(|(key, why)| p.error(key, why))?;
    let c = CameraParams {
        position: point(p, "position", p.vec3_or("position", Vec3::new(0.0, 0.0, 1.0))?)?,
        look_at: point(p, "look_at", p.vec3_or("look_at", Vec3::ZERO)?)?,
        ref_up: point(p, "ref_up", p.vec3_or("ref_up", Vec3::Y)?)?,
        fov: p.f32_or("fov", 45.0)?,
        focal_length: p.f32_or("focal_length", 1.0)?,
        projection,
        near_clip,
        far_clip,
    };
    if !(c.fov > 0.0 && c.fov < 180.0) {
        return Err(p.error("fov", format!("must be between 0 and 180 degrees, found {}", c.fov)));
    }
    if c.focal_length <= 0.0 {
        return Err(p.error("focal_length", format!("must be positive, found {}", c.focal_length)));
    }
    // it cancels out of the rays, but scales the basis: keep that arithmetic finite
    in_range(p, "focal_length", c.focal_length, 1e-6, 1e6)?;
    let forward = c.look_at - c.position;
    if forward.length_squared() == 0.0 {
        return Err(p.error("look_at", "equals the camera position"));
    }
    if forward.normalize().cross(c.ref_up).length_squared() < 1e-12 {
        return Err(p.error("ref_up", "is zero or parallel to the viewing direction"));
    }
    // the basis the rays are made of must come out finite (any resolution's aspect
    // only scales `right`, which the film size check keeps finite)
    if !crate::camera::Camera::new(&c, 1, 1).is_finite() {
        return Err(p.ctx().error(
            &p.path,
            "the camera's view basis is not finite (position, look_at, ref_up or focal_length out of range)",
        ));
    }
    p.finish();
    Ok(c)
}

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

/// A `mesh_attribute`'s `name`: whether it is `face_color` (else `vertex_color`).
fn mesh_attribute_name(p: &Props, name: &str) -> Result<bool> {
    match name {
        "vertex_color" => Ok(false),
        "face_color" => Ok(true),
        other => Err(p.error(
            "name",
            format!("unknown mesh attribute '{other}' (available: vertex_color, face_color: a PLY file's red, green, blue)"),
        )),
    }
}

fn parse_texture(name: &str, p: &Props) -> Result<TextureDesc> {
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
        }),
        "mesh_attribute" => Texture::MeshAttribute {
            face: mesh_attribute_name(p, &p.string("name")?)?,
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
    Ok(TextureRef::Named(p.located("texture_name", p.string("texture_name")?)))
}

/// Every material type, as the error for an unknown one lists them.
const MATERIAL_TYPES: [&str; 16] = [
    "diffuse",
    "refraction",
    "glass",
    "roughconductor",
    "conductor",
    "thindielectric",
    "roughdielectric",
    "plastic",
    "roughplastic",
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
fn parse_materials(root: &Props) -> Result<Vec<MaterialDesc>> {
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

/// A finite number.
fn finite(p: &Props, key: &str, v: f32) -> Result<f32> {
    if !v.is_finite() {
        return Err(p.error(key, format!("must be a finite number, found {v}")));
    }
    Ok(v)
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

/// `texture_name` when given, else the constant `default` (the optional textures
/// of the Mitsuba materials).
fn texture_or(p: &Props, default: Vec3) -> Result<TextureRef> {
    match p.string_opt("texture_name")? {
        Some(t) => Ok(TextureRef::Named(p.located("texture_name", t))),
        None => Ok(TextureRef::Color(default)),
    }
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
            texture: texture_ref(p, "color")?,
            twosided: p.bool_or("twosided", false)?,
        },
        "refraction" => Material::Refraction { eta: positive_eta("eta")? },
        "glass" => Material::Glass {
            reflect: p.vec3_or("R", Vec3::ONE)?,
            transmit: p.vec3_or("T", Vec3::ONE)?,
            eta: positive_eta("eta")?,
        },
        "roughconductor" => Material::RoughConductor {
            texture: texture_ref(p, "R")?,
            eta_i: p.vec3_or("etaI", Vec3::ONE)?,
            eta_t: p.vec3_or("etaT", Vec3::ONE)?,
            k: p.vec3_or("k", Vec3::ONE)?,
            alpha_x: non_negative(p, "alpha_x", p.f32_or("alpha_x", 0.1)?)?,
            alpha_y: non_negative(p, "alpha_y", p.f32_or("alpha_y", 0.1)?)?,
            distribution: distribution(p)?,
            twosided: p.bool_or("twosided", true)?,
        },
        "conductor" => Material::Conductor {
            texture: texture_or(p, Vec3::ONE)?,
            eta: colour(p, "eta", Vec3::ZERO)?,
            k: colour(p, "k", Vec3::ONE)?,
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
            alpha_x: roughness(p, "alpha_x")?,
            alpha_y: roughness(p, "alpha_y")?,
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

fn parse_object(p: &Props) -> Result<ObjectDesc> {
    let ty = p.string("type")?;
    let shape = match ty.as_str() {
        "mesh" => Shape::Mesh(MeshFile {
            path: p.located("path", p.string("path")?),
            transform: p.mat4_or("transform", Mat4::IDENTITY)?,
            translate: point(p, "translate", p.vec3_or("translate", Vec3::ZERO)?)?,
            options: MeshOptions::default(),
        }),
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
        _ => {
            return Err(p.error(
                "type",
                format!("unknown object type '{ty}' (available: mesh, sphere, cylinder, instance)"),
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
    if material.is_none() && light.is_none() {
        return Err(p.ctx().error(&p.path, "an object needs a 'material_name', a 'light', or both"));
    }
    p.finish();
    Ok(ObjectDesc {
        source: p.own_source(),
        shape,
        material,
        light,
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

/// The unit quaternion (x y z w) of `m` when it is a rotation (orthonormal columns
/// within 1e-4, determinant +1); a sphere's `uv_frame`.
pub fn rotation_quat(m: &glam::Mat3) -> Option<[f32; 4]> {
    let (x, y, z) = (m.x_axis, m.y_axis, m.z_axis);
    let ok = [x, y, z].iter().all(|a| (a.length() - 1.0).abs() < 1e-4)
        && x.dot(y).abs() + y.dot(z).abs() + x.dot(z).abs() < 1e-4
        && m.determinant() > 0.0;
    ok.then(|| glam::Quat::from_mat3(m).normalize().to_array())
}
