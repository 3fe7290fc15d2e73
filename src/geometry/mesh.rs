//! Triangle meshes in world space.

pub use super::attribute::{MeshAttribute, ATTRIBUTE_SLOTS};
use super::obj::{ObjData, ObjTriangle};
use crate::math::{transform_point, transform_vector, Mat4, Vec2, Vec3};

#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<ObjTriangle>,
    /// The per-vertex and per-face values the file gave (a PLY file's properties
    /// beyond positions, normals and uvs), for the `mesh_attribute` texture.
    pub attributes: Vec<MeshAttribute>,
    /// Which of `attributes` each of the scene's attribute slots reads (the scene
    /// numbers the attribute names its textures use; [`Mesh::bind_attributes`]).
    pub slots: [Option<u16>; ATTRIBUTE_SLOTS],
}

/// What [`Mesh::from_obj`] dropped or changed, for the caller's warnings.
#[derive(Clone, Debug, Default)]
pub struct MeshReport {
    pub degenerate: usize,
    pub first_degenerate_line: Option<u32>,
    /// Triangles with a coordinate beyond ±[`crate::limits::MAX_COORD`] (after the
    /// transform) or whose area overflows f32, skipped.
    pub too_large: usize,
    pub first_too_large_line: Option<u32>,
    pub rewound: usize,
}

impl Mesh {
    /// Applies `v' = M·v / w + translate` to positions and `(M⁻¹)ᵀ` to normals
    /// (spec §10.1), drops zero-area triangles, and re-winds triangles whose first
    /// vertex normal disagrees with the winding. `swap_uv` re-winds their texture
    /// coordinates too (the original forgot to; `--compat rdr171` keeps that).
    pub fn from_obj(obj: ObjData, transform: &Mat4, translate: Vec3, swap_uv: bool) -> (Mesh, MeshReport) {
        let identity = *transform == Mat4::IDENTITY;
        let positions: Vec<Vec3> = obj
            .positions
            .iter()
            .map(|&v| {
                if identity {
                    v + translate
                } else {
                    transform_point(transform, v) + translate
                }
            })
            .collect();
        let normal_matrix = transform.as_dmat4().inverse().transpose().as_mat4();
        let normals: Vec<Vec3> = obj
            .normals
            .iter()
            .map(|&n| if identity { n } else { transform_vector(&normal_matrix, n) })
            .collect();
        let mut report = MeshReport::default();
        let mut triangles = Vec::with_capacity(obj.triangles.len());
        // the faces kept, to keep their face attributes' values
        let mut kept = Vec::with_capacity(obj.triangles.len());
        for (i, mut t) in obj.triangles.into_iter().enumerate() {
            let p = t.p.map(|i| positions[i as usize]);
            let c = (p[1] - p[0]).cross(p[2] - p[0]);
            let max = crate::limits::MAX_COORD;
            if !c.is_finite() || p.iter().any(|v| !v.is_finite() || v.abs().max_element() > max) {
                // not degenerate: too large for f32 ray arithmetic (or made non-finite
                // by the transform)
                report.too_large += 1;
                report.first_too_large_line.get_or_insert(t.line);
                continue;
            }
            if c == Vec3::ZERO {
                report.degenerate += 1;
                report.first_degenerate_line.get_or_insert(t.line);
                continue;
            }
            if let Some(n) = t.n {
                let ng = crate::math::normalize_div(c);
                if ng.dot(normals[n[0] as usize]) < 0.0 {
                    t.p.swap(1, 2);
                    t.n = Some([n[0], n[2], n[1]]);
                    if swap_uv {
                        if let Some(uv) = t.uv.as_mut() {
                            uv.swap(1, 2);
                        }
                    }
                    report.rewound += 1;
                }
            }
            triangles.push(t);
            kept.push(i);
        }
        let attributes = obj
            .attributes
            .into_iter()
            .map(|mut a| {
                if a.per_face() {
                    a.values = kept.iter().map(|&i| a.values[i]).collect();
                }
                a
            })
            .collect();
        (
            Mesh {
                positions,
                normals,
                uvs: obj.uvs,
                triangles,
                attributes,
                slots: [None; ATTRIBUTE_SLOTS],
            },
            report,
        )
    }

    /// Points slot `k` at the attribute named `names[k]`; the names it lacks.
    pub fn bind_attributes<'a>(&mut self, names: &[&'a str]) -> Vec<&'a str> {
        let mut missing = Vec::new();
        for (k, name) in names.iter().enumerate().take(ATTRIBUTE_SLOTS) {
            self.slots[k] = self.attributes.iter().position(|a| a.name == *name).map(|i| i as u16);
            if self.slots[k].is_none() {
                missing.push(*name);
            }
        }
        missing
    }

    #[inline]
    pub fn vertices(&self, i: usize) -> [Vec3; 3] {
        self.triangles[i].p.map(|k| self.positions[k as usize])
    }

    pub fn area(&self, i: usize) -> f32 {
        let p = self.vertices(i);
        0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
    }
}
