//! Meshes made, not read: Mitsuba's `rectangle`, `cube` and (tessellated) `disk`
//! primitives in their local frames, and smooth vertex normals for meshes that
//! have none. Texture coordinates follow rdr's orientation (`v` = 1 at the top of an
//! image), i.e. Mitsuba's `v` flipped.

use super::obj::{ObjData, ObjTriangle};
use crate::math::{Vec2, Vec3};

fn tri(p: [u32; 3]) -> ObjTriangle {
    ObjTriangle {
        p,
        n: Some(p),
        uv: Some(p),
        line: 0,
    }
}

/// [−1, 1]² in the z = 0 plane, normal +z.
pub fn rectangle() -> ObjData {
    let c = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    ObjData {
        positions: c.iter().map(|&(x, y)| Vec3::new(x, y, 0.0)).collect(),
        normals: vec![Vec3::Z; 4],
        uvs: c.iter().map(|&(x, y)| Vec2::new((x + 1.0) / 2.0, 1.0 - (y + 1.0) / 2.0)).collect(),
        triangles: vec![tri([0, 1, 2]), tri([2, 3, 0])],
        warnings: Vec::new(),
        ..Default::default()
    }
}

/// [−1, 1]³ with outward face normals (four vertices per face).
pub fn cube() -> ObjData {
    let mut d = ObjData::default();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            // a right-handed frame (u, v, n) for the face
            let mut u = Vec3::ZERO;
            u[(axis + 1) % 3] = 1.0;
            let v = n.cross(u);
            let base = d.positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                d.positions.push(n + u * a + v * b);
                d.normals.push(n);
                d.uvs.push(Vec2::new((a + 1.0) / 2.0, (b + 1.0) / 2.0));
            }
            d.triangles.push(tri([base, base + 1, base + 2]));
            d.triangles.push(tri([base + 2, base + 3, base]));
        }
    }
    d
}

/// The unit disk at z = 0, normal +z, as a fan of `segments` triangles;
/// `uv = (r, φ/2π)`.
pub fn disk(segments: u32) -> ObjData {
    let mut d = ObjData {
        positions: vec![Vec3::ZERO],
        normals: vec![Vec3::Z],
        uvs: vec![Vec2::new(0.0, 1.0)],
        ..ObjData::default()
    };
    for i in 0..=segments {
        let phi = 2.0 * std::f32::consts::PI * i as f32 / segments as f32;
        d.positions.push(Vec3::new(phi.cos(), phi.sin(), 0.0));
        d.normals.push(Vec3::Z);
        d.uvs.push(Vec2::new(1.0, 1.0 - i as f32 / segments as f32));
    }
    for i in 0..segments {
        d.triangles.push(tri([0, i + 1, i + 2]));
    }
    d
}

/// Gives a mesh without normals area-weighted vertex normals (per position), as
/// Mitsuba computes for OBJ and PLY files without `face_normals`.
pub fn add_smooth_normals(d: &mut ObjData) {
    if !d.normals.is_empty() || d.triangles.iter().any(|t| t.n.is_some()) {
        return;
    }
    let mut n = vec![Vec3::ZERO; d.positions.len()];
    for t in &d.triangles {
        let p = t.p.map(|i| d.positions[i as usize]);
        // the cross product's length is twice the area: area weighting
        let c = (p[1] - p[0]).cross(p[2] - p[0]);
        if c.is_finite() {
            for &i in &t.p {
                n[i as usize] += c;
            }
        }
    }
    let face = |t: &ObjTriangle| {
        let p = t.p.map(|i| d.positions[i as usize]);
        (p[1] - p[0]).cross(p[2] - p[0])
    };
    // a vertex whose faces cancel keeps no normal: its triangles stay flat
    let ok: Vec<bool> = n.iter().map(|v| v.length_squared() > 0.0 && v.is_finite()).collect();
    let flat: Vec<bool> = d
        .triangles
        .iter()
        .map(|t| t.p.iter().any(|&i| !ok[i as usize]) || face(t) == Vec3::ZERO)
        .collect();
    d.normals = n
        .iter()
        .map(|v| if v.length_squared() > 0.0 { v.normalize() } else { Vec3::Z })
        .collect();
    for (t, flat) in d.triangles.iter_mut().zip(flat) {
        if !flat {
            t.n = Some(t.p);
        }
    }
}

/// Reverses every triangle's winding and every normal (Mitsuba's `flip_normals`).
pub fn flip_normals(d: &mut ObjData) {
    for n in &mut d.normals {
        *n = -*n;
    }
    for t in &mut d.triangles {
        t.p.swap(1, 2);
        if let Some(n) = t.n.as_mut() {
            n.swap(1, 2);
        }
        if let Some(uv) = t.uv.as_mut() {
            uv.swap(1, 2);
        }
    }
}

/// Drops the normals (flat shading).
pub fn drop_normals(d: &mut ObjData) {
    d.normals.clear();
    for t in &mut d.triangles {
        t.n = None;
    }
}

/// `v → 1 − v`.
pub fn flip_uv(d: &mut ObjData) {
    for uv in &mut d.uvs {
        uv.y = 1.0 - uv.y;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_meshes_face_their_normals() {
        for d in [rectangle(), cube(), disk(16)] {
            for t in &d.triangles {
                let p = t.p.map(|i| d.positions[i as usize]);
                let ng = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
                assert!((ng - d.normals[t.p[0] as usize]).length() < 1e-6, "{ng}");
            }
        }
        let c = cube();
        let area: f32 = c
            .triangles
            .iter()
            .map(|t| {
                let p = t.p.map(|i| c.positions[i as usize]);
                0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
            })
            .sum();
        assert!((area - 24.0).abs() < 1e-5);
    }

    #[test]
    fn smooth_normals_average_the_faces() {
        let mut d = ObjData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.0, 0.0, -1.0)],
            triangles: vec![
                ObjTriangle {
                    p: [0, 1, 2],
                    n: None,
                    uv: None,
                    line: 1,
                },
                ObjTriangle {
                    p: [0, 3, 1],
                    n: None,
                    uv: None,
                    line: 2,
                },
            ],
            ..ObjData::default()
        };
        add_smooth_normals(&mut d);
        let n0 = d.normals[0];
        assert!((n0 - Vec3::new(0.0, -1.0, 1.0).normalize()).length() < 1e-6, "{n0}");
        assert_eq!(d.triangles[0].n, Some([0, 1, 2]));
    }
}
