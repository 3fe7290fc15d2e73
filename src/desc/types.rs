//! The description types: a scene as read from either format, before it is built.

use crate::camera::CameraParams;
use crate::desc::{Located, Source};
use crate::film::Filter;
use crate::integrator::Integrator;
use crate::material::Material;
use crate::math::{Mat4, Vec3};
use crate::scene::Shape;
use crate::texture::{Texture, UvMapping};
use std::path::PathBuf;

/// The whole scene. Top-level keys: `integrator`, `film`, `camera` (required),
/// `textures`, `materials`, `objects`, `shapegroups`, `environment_map`, `media`.
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
    /// Mitsuba's `sunsky` (then no `environment_map`: one environment).
    pub sunsky: Option<SunSkyDesc>,
    /// Participating media by name ([`MediumDesc`]), which objects' `interior`/`exterior`
    /// and the camera's `medium` name.
    pub media: Vec<MediumDesc>,
    /// The medium the camera sits in (vacuum when absent); never inferred from geometry.
    pub camera_medium: Option<Located<String>>,
    pub warnings: Vec<String>,
    /// Keys (JSON) or properties (XML) the reader did not know, one message each with
    /// the closest known name; they are also in `warnings`. The command line refuses
    /// them in JSON unless `--lenient`, and in XML with `--strict`.
    pub unknown: Vec<String>,
    /// The files a Mitsuba XML scene's `<include>`s read, in the order read (empty
    /// for JSON): part of what made the image (see `render::identity`).
    pub included: Vec<PathBuf>,
    /// What `rdr convert` to the other format loses that the reader saw (one line
    /// each, naming the element): a Mitsuba `twosided` the JSON cannot keep.
    pub convert_notes: Vec<String>,
}

impl SceneDesc {
    /// The asset files the scene reads (image textures, then mesh files), as written
    /// in it (relative to `base_dir`), each once, first mention first.
    pub fn asset_paths(&self) -> Vec<String> {
        let textures = self.textures.iter().filter_map(|t| match &t.texture {
            Texture::Image(img) => Some(img.path.value.clone()),
            _ => None,
        });
        let objects = self.objects.iter().chain(self.shapegroups.iter().flat_map(|g| g.objects.iter()));
        let meshes = objects.filter_map(|o| match &o.shape {
            Shape::Mesh(m) if m.options.format.reads_file() => Some(m.path.value.clone()),
            _ => None,
        });
        let mut seen = std::collections::HashSet::new();
        textures.chain(meshes).filter(|p| seen.insert(p.clone())).collect()
    }

    /// Every file the scene came from or reads: the scene file, its includes, its assets.
    pub fn input_files(&self) -> Vec<PathBuf> {
        let mut files = vec![self.file.clone()];
        files.extend(self.included.iter().cloned());
        files.extend(self.asset_paths().iter().map(|p| self.base_dir.join(p)));
        files
    }
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

/// `integrator`:
/// * `type` (`"path"`) — `"path"`, `"bdpt"`, `"guided"`, `"ptracer"`, `"intersection_test"`, `"photon"`,
///   `"sppm"` or `"normals"` (a debug view: shading normals as colours). The keys of each
///   are documented on its type:
///   [`PathTracer`] (`spp` 32, `max_depth` 12, `profile`, `rr_threshold`),
///   [`Bdpt`] (as `path`, and `mis`, `strategy`, `strategy_weighted`, `visualize_strategies`, `connection_roulette`), [`Guided`] (`spp` 64,
///   `max_depth` 12, `rr_threshold`, `bsdf_fraction` 0.5, `training_iterations`, `combine`,
///   `spatial_threshold`, `learn_direct`, `learn_fraction`, `learn_from`, `target`), [`Ptracer`]
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
///   by their own importance and chosen half by power, half uniformly, or uniformly (for comparisons).
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
    /// Feature buffers the scene asks for (Mitsuba's `aov` integrator), as an `--aov`
    /// list; the command line's `--aov` replaces it.
    pub aovs: Option<String>,
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
    /// `sampling: "importance"`: camera samples drawn from the filter (each in its own
    /// pixel, so neighbours' noise is independent); `"filter"` (default) weighs them.
    pub importance_sampling: bool,
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
    /// `wrap_mode`: `"repeat"` (default) | `"clamp"` | `"mirror"`, outside [0, 1]².
    pub wrap: crate::texture::image::WrapMode,
    /// `scale` (vec3, (1,1,1)): a factor on every value (what the Mitsuba reader makes
    /// of Mitsuba 0.6's `scale` texture around a bitmap).
    pub scale: Vec3,
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

/// `objects[i]`: `type` (`"mesh"` | `"sphere"` | `"cylinder"` | `"sdfgrid"`, required; see [`Shape`]),
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
    pub shape: Shape<MeshFile, super::SdfGridFile>,
    pub material: Option<Located<String>>,
    pub light: Option<AreaLightDesc>,
    /// The media inside and outside the shape (names in `media`; absent: vacuum).
    pub interior: Option<Located<String>>,
    pub exterior: Option<Located<String>>,
    /// Mitsuba's `null` BSDF: the surface is only a boundary between media, which rays
    /// cross unchanged (`material_name` "null" in JSON).
    pub null_bsdf: bool,
}

/// `media.<name>`: a participating medium (see [`crate::medium`]). `homogeneous`:
/// `sigma_t` (number or RGB, ≥ 0, 1), `albedo` (number or RGB in [0, 1], 0.75), `scale`
/// (≥ 0, 1; multiplies `sigma_t`), `phase` (`{"type": "isotropic"}` or
/// `{"type": "hg", "g": 0.8}`; isotropic when absent) — Mitsuba's names and defaults —
/// and `radiance` (number or RGB, ≥ 0, 0): emitted radiance Le, the medium adding σa·Le
/// per unit length (pbrt-v4's convention; not multiplied by `scale`).
///
/// ```json
/// "media": {"fog": {"type": "homogeneous", "sigma_t": 1.5, "albedo": 0.9, "phase": {"type": "hg", "g": 0.6}}}
/// ```
///
/// `heterogeneous`: the same keys but `sigma_t`, `albedo` and `radiance` are volumes —
/// a number, an RGB triple, `{"type": "constvolume", "value", "to_world"}` or
/// `{"type": "gridvolume", "filename", "grid", "filter_type", "wrap_mode", "max_value",
/// "to_world", "use_grid_bbox"}` (Mitsuba's names and defaults; `to_world` 16 numbers
/// row-major); the medium exists inside its `sigma_t` volume's box only.
#[derive(Clone, Debug)]
pub struct MediumDesc {
    pub name: String,
    pub source: Source,
    pub medium: crate::medium::Medium,
    /// Whether light is sampled from its scattering points (Mitsuba's `sample_emitters`,
    /// true by default); when false the phase function's sample alone finds light.
    pub sample_emitters: bool,
    /// A heterogeneous medium's volumes as described (grid files by name, for `rdr convert`).
    pub volumes: Option<super::volume::MediumVolumes>,
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

/// Mitsuba 3's `sunsky` environment (JSON `sunsky`): the Hošek–Wilkie sky and sun.
#[derive(Clone, Debug)]
pub struct SunSkyDesc {
    pub source: Source,
    pub turbidity: f32,
    pub albedo: Vec3,
    pub sun: SunPlacement,
    pub sun_scale: f32,
    pub sky_scale: f32,
    /// The sun's aperture (full angle), degrees.
    pub sun_aperture: f32,
    pub complex_sun: bool,
    /// The sky's frame (+z up) to the world; a rotation.
    pub transform: Mat4,
}

impl SunSkyDesc {
    /// Mitsuba 3's defaults, read by both scene formats.
    pub const TURBIDITY: f32 = 3.0;
    pub const ALBEDO: f32 = 0.3;
    /// Degrees across.
    pub const SUN_APERTURE: f32 = 0.5358;
}

/// Where `sunsky`'s sun is: a world direction, or a place and time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SunPlacement {
    Direction(Vec3),
    At(crate::light::sunsky::SunPosition),
}

/// The keys of a place and time (`sunsky`'s `latitude` … `second`).
pub const SUN_POSITION_KEYS: [&str; 9] = [
    "latitude",
    "longitude",
    "timezone",
    "year",
    "month",
    "day",
    "hour",
    "minute",
    "second",
];

/// A place and time read by a reader's `float(key, default)` and `int(key, default)`,
/// Mitsuba's defaults where a key is absent.
pub fn read_sun_position(
    float: impl Fn(&str, f32) -> crate::error::Result<f32>,
    int: impl Fn(&str, i32) -> crate::error::Result<i32>,
) -> crate::error::Result<crate::light::sunsky::SunPosition> {
    let d = crate::light::sunsky::SunPosition::default();
    Ok(crate::light::sunsky::SunPosition {
        latitude: float("latitude", d.latitude)?,
        longitude: float("longitude", d.longitude)?,
        timezone: float("timezone", d.timezone)?,
        year: int("year", d.year)?,
        month: int("month", d.month)?,
        day: int("day", d.day)?,
        hour: float("hour", d.hour)?,
        minute: float("minute", d.minute)?,
        second: float("second", d.second)?,
    })
}

impl SunSkyDesc {
    /// Mitsuba's ranges: the key at fault and why, or nothing.
    pub fn check(&self) -> std::result::Result<(), (&'static str, String)> {
        if !(1.0..=10.0).contains(&self.turbidity) {
            return Err(("turbidity", format!("turbidity {} is outside [1, 10]", self.turbidity)));
        }
        if !(self.albedo.min_element() >= 0.0 && self.albedo.max_element() <= 1.0) {
            return Err(("albedo", format!("albedo {} is outside [0, 1]", self.albedo)));
        }
        for (key, v) in [("sun_scale", self.sun_scale), ("sky_scale", self.sky_scale)] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err((key, format!("{key} {v} must be a finite number >= 0")));
            }
        }
        if !(self.sun_aperture > 0.0 && self.sun_aperture < 180.0) {
            return Err((
                "sun_aperture",
                format!("sun_aperture {} must be in ]0, 180[ degrees", self.sun_aperture),
            ));
        }
        match self.sun {
            SunPlacement::Direction(d) if !(d.length_squared() > 0.0 && d.is_finite()) => {
                Err(("sun_direction", "sun_direction must be a non-zero vector".into()))
            }
            SunPlacement::At(at) if !(-90.0..=90.0).contains(&at.latitude) || !(1..=12).contains(&at.month) => {
                Err(("latitude", format!("latitude {} or month {} out of range", at.latitude, at.month)))
            }
            _ => {
                let m = glam::Mat3::from_mat4(self.transform);
                let gram = m.transpose() * m;
                let s = gram.x_axis.x;
                let off = (gram - glam::Mat3::from_diagonal(Vec3::splat(s))).abs().to_cols_array();
                if !(s > 0.0 && off.iter().all(|x| *x <= 1e-4 * s)) {
                    return Err(("to_world", "the sky's transform must be a rotation (and a uniform scale)".into()));
                }
                Ok(())
            }
        }
    }
}

/// Most path segments a sample may take (`max_depth`): glass without absorption
/// never ends a path by Russian roulette, so the depth bounds the work per sample.
pub const MAX_DEPTH: u32 = 1024;
/// Most `light_samples` per shading point.
pub const MAX_LIGHT_SAMPLES: u32 = 1024;
/// Largest filter radius in pixels: each sample touches (2·radius)² pixels.
pub const MAX_FILTER_RADIUS: f32 = 32.0;
