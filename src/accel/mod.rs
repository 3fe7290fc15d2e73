//! Acceleration structures.

pub mod build;
pub mod bvh;
pub mod instance;
pub mod photon_map;
pub mod presplit;
pub mod record;
pub mod reference;
pub mod wide;

pub use bvh::Bvh;
pub use photon_map::KdTree;
pub use wide::{Isa, WideBvh};
