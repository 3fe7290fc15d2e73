//! The description layer: a scene file read into plain values that remember where
//! they came from ([`Source`]), and [`build`](mod@build), the separate step that turns
//! them into the render-ready [`crate::scene::Scene`] (the job's camera, film and
//! integrator become a [`crate::render::RenderJob`]). The RDR171 JSON (spec §3–§12)
//! is read by [`json`], Mitsuba XML by [`xml`] (which also reads `<include>`d files and
//! looks up where named files are); [`convert`] writes a description in either format.
//! Meshes and textures are loaded when the scene is built.
//!
//! The variant families are the render layer's own types with their unresolved
//! parts as parameters: [`Material<TextureRef>`](crate::material::Material),
//! [`Texture<ImageFile>`](crate::texture::Texture), [`Shape<MeshFile, SdfGridFile>`](crate::scene::Shape),
//! and [`Filter`](crate::film::Filter), [`CameraParams`](crate::camera::CameraParams),
//! [`UvMapping`](crate::texture::UvMapping) as they are. The types are in `types.rs`,
//! the JSON reader in `parse/`. Each type's documentation (there or on the shared type) lists its keys with
//! their defaults; values that later steps may report on keep their [`Source`].

pub mod build;
mod checked;
pub mod convert;
pub mod json;
mod parse;
pub mod principled;
mod sdfgrid;
pub mod source;
mod types;
pub mod volume;
pub mod xml;

pub use build::{build, BuildOptions};
pub use checked::{
    cylinder_shape, default_fov_deg, directional_light, light_frame, projector_light, rotation_quat, spot_light, textured_spot,
};
pub use parse::integrator_from_value;
pub use sdfgrid::{load_sdf_grid, SdfGridFile};
pub use source::{Located, Source};
pub use types::{
    read_sun_position, AreaLightDesc, DeltaLightDesc, EnvMapDesc, FilmDesc, ImageFile, InstanceDesc, IntegratorDesc, MaterialDesc,
    MediumDesc, MeshFile, MeshFormat, MeshNormals, MeshOptions, ObjectDesc, PointLightDesc, SceneDesc, ShapeGroupDesc, SunPlacement,
    SunSkyDesc, TextureDesc, TextureRef, DISK_SEGMENTS, MAX_DEPTH, MAX_FILTER_RADIUS, MAX_LIGHT_SAMPLES, SUN_POSITION_KEYS,
};
pub use volume::{build_heterogeneous, build_volume, check_max_value, grid_of, GridFile, MediumVolumes, VolumeDesc};
