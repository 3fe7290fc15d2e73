//! Acceleration structures.

pub mod build;
pub mod bvh;
pub mod reference;
pub mod wide;

pub use bvh::Bvh;
pub use wide::{Isa, WideBvh};
