//! rdr — a physically based CPU ray tracer that reads the RDR171 JSON scene format.

pub mod accel;
pub mod bench;
pub mod camera;
pub mod compat;
pub mod desc;
pub mod error;
pub mod film;
pub mod geometry;
pub mod imageio;
pub mod integrator;
pub mod light;
pub mod limits;
pub mod material;
pub mod math;
pub mod medium;
pub mod metrics;
mod pages;
pub use pages::HugePageAllocator;
pub mod render;
pub mod robustness;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod texture;
pub mod volume;

pub use compat::Profile;
pub use error::SceneError;
pub use render::{load, load_with_defines, render, Loaded, RenderControl, RenderJob, RenderOutput};
pub use scene::Scene;
