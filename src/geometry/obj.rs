//! Wavefront OBJ reader (positions, normals, texture coordinates, faces).
//!
//! Written by hand rather than with `tobj` because RDR171 compatibility needs the
//! original's triangulation (quads split along the shorter diagonal) and numbers
//! parsed as f64 then rounded to f32, and because errors should name the line.
//! Materials (`mtllib`/`usemtl`), groups and smoothing statements are ignored.

use crate::math::{Vec2, Vec3};

/// Bytes of memory a mesh may take per byte of its OBJ text, at most (a face line
/// `f 1 2 3` of 8 bytes becomes a triangle in the reader, the mesh, the scene's
/// primitives and the BVH): the file size is checked against the budget with it.
pub const MEMORY_PER_BYTE: u64 = 24;

/// Polygons with more corners than this are fan-triangulated (with a warning) instead
/// of ear-clipped: ear clipping here is cubic in the worst case.
pub const EAR_CLIP_MAX: usize = 256;

/// One triangle: indices into the mesh's positions, normals and uvs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ObjTriangle {
    pub p: [u32; 3],
    pub n: Option<[u32; 3]>,
    pub uv: Option<[u32; 3]>,
    /// 1-based line of the face statement it came from.
    pub line: u32,
}

#[derive(Clone, Debug, Default)]
pub struct ObjData {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<ObjTriangle>,
    pub warnings: Vec<String>,
}

#[derive(Debug, thiserror::Error)]
#[error("line {line}: {message}")]
pub struct ObjError {
    pub line: usize,
    pub message: String,
}

fn err(line: usize, message: impl Into<String>) -> ObjError {
    ObjError {
        line,
        message: message.into(),
    }
}

fn parse_floats<const N: usize>(words: &mut std::str::SplitWhitespace, line: usize, what: &str) -> Result<[f32; N], ObjError> {
    let mut out = [0.0f32; N];
    for (i, o) in out.iter_mut().enumerate() {
        let w = words
            .next()
            .ok_or_else(|| err(line, format!("'{what}' needs {N} numbers, found {i}")))?;
        let v: f64 = w.parse().map_err(|_| err(line, format!("'{what}': '{w}' is not a number")))?;
        let v = v as f32;
        if !v.is_finite() {
            return Err(err(line, format!("'{what}': '{w}' is not a finite number")));
        }
        *o = v;
    }
    Ok(out)
}

/// Resolves a 1-based (or negative, relative) OBJ index against `len` elements.
fn resolve(word: &str, len: usize, line: usize, what: &str) -> Result<u32, ObjError> {
    let i: i64 = word.parse().map_err(|_| err(line, format!("bad {what} index '{word}'")))?;
    let idx = if i > 0 {
        i - 1
    } else if i < 0 {
        len as i64 + i
    } else {
        -1
    };
    if idx < 0 || idx >= len as i64 {
        return Err(err(line, format!("{what} index {i} out of range (the file has {len} so far)")));
    }
    Ok(idx as u32)
}

/// A face corner: position, texture coordinate and normal indices.
type Corner = (u32, Option<u32>, Option<u32>);

pub fn parse(text: &str) -> Result<ObjData, ObjError> {
    let mut d = ObjData::default();
    let mut unknown: Vec<String> = Vec::new();
    let mut short_faces = 0usize;
    let mut big_polygons = 0usize;
    for (lineno, raw) in text.lines().enumerate() {
        let line = lineno + 1;
        let content = raw.split('#').next().unwrap_or("");
        let mut words = content.split_whitespace();
        let Some(kw) = words.next() else { continue };
        match kw {
            "v" => {
                let [x, y, z] = parse_floats::<3>(&mut words, line, "v")?;
                d.positions.push(Vec3::new(x, y, z));
            }
            "vn" => {
                let [x, y, z] = parse_floats::<3>(&mut words, line, "vn")?;
                d.normals.push(Vec3::new(x, y, z));
            }
            "vt" => {
                let [u, v] = parse_floats::<2>(&mut words, line, "vt")?;
                d.uvs.push(Vec2::new(u, v));
            }
            "f" => {
                let mut corners: Vec<Corner> = Vec::with_capacity(4);
                for w in words {
                    let mut parts = w.split('/');
                    let p = resolve(parts.next().unwrap_or(""), d.positions.len(), line, "vertex")?;
                    let t = match parts.next() {
                        Some(s) if !s.is_empty() => Some(resolve(s, d.uvs.len(), line, "texture coordinate")?),
                        _ => None,
                    };
                    let n = match parts.next() {
                        Some(s) if !s.is_empty() => Some(resolve(s, d.normals.len(), line, "normal")?),
                        _ => None,
                    };
                    corners.push((p, t, n));
                }
                if corners.len() < 3 {
                    short_faces += 1;
                    continue;
                }
                let has_n = corners.iter().all(|c| c.2.is_some());
                let has_t = corners.iter().all(|c| c.1.is_some());
                let tris = if corners.len() > EAR_CLIP_MAX {
                    big_polygons += 1;
                    (1..corners.len() - 1).map(|k| [0, k, k + 1]).collect()
                } else {
                    triangulate(&corners.iter().map(|c| d.positions[c.0 as usize]).collect::<Vec<_>>())
                };
                for [a, b, c] in tris {
                    let pick = |f: &dyn Fn(&Corner) -> u32| [f(&corners[a]), f(&corners[b]), f(&corners[c])];
                    d.triangles.push(ObjTriangle {
                        p: pick(&|c| c.0),
                        n: has_n.then(|| pick(&|c| c.2.unwrap())),
                        uv: has_t.then(|| pick(&|c| c.1.unwrap())),
                        line: line as u32,
                    });
                }
            }
            "mtllib" | "usemtl" | "o" | "g" | "s" | "l" | "p" | "vp" => {}
            other => {
                if !unknown.iter().any(|u| u == other) {
                    unknown.push(other.to_string());
                }
            }
        }
    }
    if short_faces > 0 {
        d.warnings.push(format!("{short_faces} face(s) with fewer than 3 vertices skipped"));
    }
    if big_polygons > 0 {
        d.warnings.push(format!(
            "{big_polygons} polygon(s) with more than {EAR_CLIP_MAX} vertices fan-triangulated (concave ones may render wrong)"
        ));
    }
    if !unknown.is_empty() {
        d.warnings.push(format!("unknown statement(s) ignored: {}", unknown.join(", ")));
    }
    Ok(d)
}

/// Triangles of a polygon, as corner indices. Quads split along the shorter
/// diagonal (as tinyobjloader does for RDR171); larger polygons by ear clipping.
pub fn triangulate(p: &[Vec3]) -> Vec<[usize; 3]> {
    match p.len() {
        3 => vec![[0, 1, 2]],
        4 => {
            let d02 = p[2] - p[0];
            let d13 = p[3] - p[1];
            if d02.dot(d02) < d13.dot(d13) {
                vec![[0, 1, 2], [0, 2, 3]]
            } else {
                vec![[0, 1, 3], [1, 2, 3]]
            }
        }
        _ => ear_clip(p),
    }
}

fn ear_clip(p: &[Vec3]) -> Vec<[usize; 3]> {
    // Newell normal, then work in the plane orthogonal to its largest axis.
    let mut n = Vec3::ZERO;
    for i in 0..p.len() {
        let (a, b) = (p[i], p[(i + 1) % p.len()]);
        n += Vec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    let ax = n.abs();
    let (i0, i1) = if ax.x >= ax.y && ax.x >= ax.z {
        (1, 2)
    } else if ax.y >= ax.z {
        (2, 0)
    } else {
        (0, 1)
    };
    let sign = if n[3 - i0 - i1] >= 0.0 { 1.0 } else { -1.0 };
    let q: Vec<Vec2> = p.iter().map(|v| Vec2::new(v[i0], v[i1])).collect();
    let cross = |a: Vec2, b: Vec2, c: Vec2| sign * ((b - a).perp_dot(c - a));
    let mut idx: Vec<usize> = (0..p.len()).collect();
    let mut out = Vec::with_capacity(p.len() - 2);
    let mut guard = 0;
    while idx.len() > 3 && guard < 4 * p.len() * p.len() {
        guard += 1;
        let m = idx.len();
        let mut clipped = false;
        for k in 0..m {
            let (a, b, c) = (idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]);
            if cross(q[a], q[b], q[c]) <= 0.0 {
                continue; // reflex or degenerate corner
            }
            let inside = idx.iter().any(|&j| {
                j != a
                    && j != b
                    && j != c
                    && cross(q[a], q[b], q[j]) >= 0.0
                    && cross(q[b], q[c], q[j]) >= 0.0
                    && cross(q[c], q[a], q[j]) >= 0.0
            });
            if !inside {
                out.push([a, b, c]);
                idx.remove(k);
                clipped = true;
                break;
            }
        }
        if !clipped {
            break; // self-intersecting polygon: fan the rest
        }
    }
    for k in 1..idx.len().saturating_sub(1) {
        out.push([idx[0], idx[k], idx[k + 1]]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_all_face_forms_and_negative_indices() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\n\
                    f 1 2 3\nf 1/1 2/2 3/3\nf 1//1 2//1 3//1\nf -4/-3/-1 -3/-2/-1 -2/-1/-1\n";
        let d = parse(text).unwrap();
        assert_eq!(d.triangles.len(), 4);
        assert_eq!(d.triangles[0].n, None);
        assert_eq!(d.triangles[1].uv, Some([0, 1, 2]));
        assert_eq!(d.triangles[2].n, Some([0, 0, 0]));
        assert_eq!(d.triangles[3].p, [0, 1, 2]);
        assert_eq!(d.triangles[3].uv, Some([0, 1, 2]));
    }

    #[test]
    fn quads_split_along_the_shorter_diagonal() {
        // long diagonal 0-2, short 1-3
        let p = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, -0.2, 0.0),
            Vec3::new(3.0, 0.0, 0.0),
            Vec3::new(2.0, 0.2, 0.0),
        ];
        assert_eq!(triangulate(&p), vec![[0, 1, 3], [1, 2, 3]]);
        let sq = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 2.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        // diagonal 0-2 has length² 5, 1-3 has 2
        assert_eq!(triangulate(&sq), vec![[0, 1, 3], [1, 2, 3]]);
    }

    #[test]
    fn ear_clipping_covers_a_concave_polygon() {
        // an L shape, area 3
        let p = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)].map(|(x, y)| Vec3::new(x, y, 0.0));
        let tris = triangulate(&p);
        assert_eq!(tris.len(), 4);
        let area: f32 = tris.iter().map(|t| 0.5 * (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).z).sum();
        assert!((area - 3.0).abs() < 1e-6, "area {area}: all triangles keep the winding");
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse("v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap_err();
        assert_eq!(e.line, 3);
        assert!(e.message.contains("out of range"));
        assert_eq!(parse("v 0 zero 0\n").unwrap_err().line, 1);
        assert_eq!(parse("v 0 0\n").unwrap_err().line, 1);
        assert_eq!(parse("v 0 0 1e39\n").unwrap_err().line, 1);
    }
}
