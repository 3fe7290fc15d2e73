//! Geometry: rays, boxes, the triangle and sphere kernels, primitives and their
//! surface interactions, meshes and OBJ/PLY/serialized loading, generated meshes.

pub mod aabb;
pub mod attribute;
pub mod cylinder;
pub mod interaction;
pub mod mesh;
pub mod obj;
pub mod ply;
pub mod prim;
pub mod ray;
pub mod sdfgrid;
pub mod serialized;
pub mod shapes;
pub mod sphere;
pub mod triangle;

pub use aabb::Aabb;
pub use ray::{Ray, RayDifferential};
