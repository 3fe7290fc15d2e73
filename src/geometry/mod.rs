//! Geometry: rays, boxes, the triangle and sphere kernels, meshes and OBJ loading.

pub mod aabb;
pub mod mesh;
pub mod obj;
pub mod ray;
pub mod sphere;
pub mod triangle;

pub use aabb::Aabb;
pub use ray::{Ray, RayDifferential};
