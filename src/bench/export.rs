//! A scene's geometry as one OBJ of world-space triangles (`rdr bench SCENE
//! --record-rays`), one group per object, for tracers that take triangle meshes only
//! (Embree through `scripts/embree_time.py`): spheres and cylinders are tessellated.

use crate::geometry::prim::Prim;
use crate::math::Vec3;
use anyhow::{bail, Result};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// Segments around a tessellated sphere or cylinder (rings of a sphere: half as many).
pub const SEGMENTS: usize = 64;

/// The OBJ text of `prims`' triangles (vertices in Rust's shortest round-trip form, so
/// they read back bit for bit), spheres and cylinders as [`SEGMENTS`]-sided meshes.
/// Instances are refused (flatten the scene first).
pub fn scene_obj(prims: &[Prim]) -> Result<String> {
    let mut by_object: BTreeMap<u32, Vec<[Vec3; 3]>> = BTreeMap::new();
    for p in prims {
        match p {
            Prim::Triangle { p, object, .. } => by_object.entry(*object).or_default().push(*p),
            Prim::Sphere { sphere, object } => {
                let at = |i: usize, j: usize| {
                    let (theta, phi) = (
                        std::f32::consts::PI * j as f32 / (SEGMENTS / 2) as f32,
                        std::f32::consts::TAU * i as f32 / SEGMENTS as f32,
                    );
                    sphere.center + Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()) * sphere.radius
                };
                by_object.entry(*object).or_default().extend(grid(SEGMENTS / 2, at));
            }
            Prim::Cylinder { cylinder: c, object } => {
                let y = c.axis.normalize().cross(c.x);
                let at = |i: usize, j: usize| {
                    let phi = std::f32::consts::TAU * i as f32 / SEGMENTS as f32;
                    c.p0 + c.axis * j as f32 + (c.x * phi.cos() + y * phi.sin()) * c.radius
                };
                by_object.entry(*object).or_default().extend(grid(1, at));
            }
            Prim::Instance { .. } | Prim::SdfVoxel { .. } => {
                bail!("the scene uses instances or sdfgrids: --record-rays exports flat scenes only")
            }
        }
    }
    let mut out = String::from("# rdr bench --record-rays: the scene's triangles in world space\n");
    let mut base = 1usize;
    for (object, tris) in by_object {
        let _ = writeln!(out, "o object{object}");
        for v in tris.iter().flatten() {
            let _ = writeln!(out, "v {} {} {}", v.x, v.y, v.z);
        }
        for k in 0..tris.len() {
            let i = base + 3 * k;
            let _ = writeln!(out, "f {} {} {}", i, i + 1, i + 2);
        }
        base += 3 * tris.len();
    }
    Ok(out)
}

/// Triangles of a [`SEGMENTS`] × `rows` grid of points `at(i, j)` (`i` wrapping around).
fn grid(rows: usize, at: impl Fn(usize, usize) -> Vec3) -> Vec<[Vec3; 3]> {
    let mut tris = Vec::with_capacity(2 * SEGMENTS * rows);
    for j in 0..rows {
        for i in 0..SEGMENTS {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
            tris.push([a, b, d]);
            tris.push([a, d, c]);
        }
    }
    // degenerate ones (at a sphere's poles) are left out: they cannot be hit
    tris.retain(|t| (t[1] - t[0]).cross(t[2] - t[0]).length() > 0.0);
    tris
}

/// Writes `rays` in the ray-file format ([`super::ray_file`]).
pub fn ray_bytes(rays: &[[f32; 6]]) -> Vec<u8> {
    rays.iter().flatten().flat_map(|v| v.to_le_bytes()).collect()
}
