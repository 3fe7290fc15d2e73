//! Acceleration structures.

pub mod bvh;

pub use bvh::Bvh;
