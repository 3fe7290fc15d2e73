//! `rdr convert`: a scene description written as RDR171 JSON or Mitsuba 3 XML, for
//! everything both can say, with a warning for what the target cannot. Point lights:
//! Mitsuba's intensity I is rdr's flux 4πI. Paths are rewritten relative to the output
//! file. JSON can only name OBJ files, so meshes it cannot say as they are (PLY,
//! serialized, generated rectangles and cubes, Mitsuba's smoothed normals) are
//! written as OBJ files beside the output (`<stem>_meshes/`).
//!
//! [`to_json`] is in `write_json.rs`, [`to_xml`] in `write_xml.rs`; what both use is here.

mod media;
mod write_json;
mod write_xml;

pub use write_json::to_json;
pub use write_xml::to_xml;

use crate::desc::{MeshFile, SceneDesc};
use crate::error::Result;
use crate::geometry::obj::ObjData;
use crate::material::Distribution;
use crate::math::{Mat4, Vec2, Vec3};
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

/// A converted scene: its text, the extra files it refers to, and what could not be said.
pub struct Converted {
    pub text: String,
    pub files: Vec<(PathBuf, Vec<u8>)>,
    pub warnings: Vec<String>,
}

pub(super) fn absolute(p: &Path) -> PathBuf {
    let p = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().unwrap_or_default().join(p)
    };
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// `target` relative to the folder `from` (both made absolute), with `/` separators.
pub fn relative(target: &Path, from: &Path) -> String {
    let (t, f) = (absolute(target), absolute(from));
    let (tc, fc): (Vec<_>, Vec<_>) = (t.components().collect(), f.components().collect());
    let common = tc.iter().zip(&fc).take_while(|(a, b)| a == b).count();
    if common == 0 {
        return t.display().to_string();
    }
    let mut parts: Vec<String> = vec!["..".into(); fc.len() - common];
    parts.extend(tc[common..].iter().map(|c| c.as_os_str().to_string_lossy().into_owned()));
    parts.join("/")
}

pub(super) fn out_dir(out: &Path) -> PathBuf {
    out.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf()
}

/// A file named in the description, relative to the output's folder.
pub(super) fn rebase(desc: &SceneDesc, path: &str, out: &Path) -> String {
    relative(&desc.base_dir.join(path), &out_dir(out))
}

pub(super) fn obj_has_normals(desc: &SceneDesc, file: &MeshFile) -> Result<bool> {
    let full = desc.base_dir.join(&file.path.value);
    let bytes = crate::limits::read_input_file(&full, crate::limits::max_input_file()).map_err(|e| {
        file.path
            .source
            .error(&desc.file, format!("cannot read mesh '{}': {e}", full.display()))
    })?;
    Ok(String::from_utf8_lossy(&bytes).lines().any(|l| l.trim_start().starts_with("vn ")))
}

pub(super) fn num(x: f32) -> Value {
    // the shortest decimal that reads back as the same f32
    serde_json::from_str(&format!("{x}")).unwrap_or(Value::Null)
}

pub(super) fn vec3(v: Vec3) -> Value {
    Value::Array(v.to_array().into_iter().map(num).collect())
}

pub(super) fn vec2(v: Vec2) -> Value {
    Value::Array(v.to_array().into_iter().map(num).collect())
}

pub(super) fn row_major(m: &Mat4) -> [f32; 16] {
    m.transpose().to_cols_array()
}

pub(super) fn matrix(m: &Mat4) -> String {
    row_major(m).iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(" ")
}

/// An OBJ file of a mesh's data (1-based indices, uv and normal per corner).
pub fn obj_text(d: &ObjData) -> String {
    let mut s = String::from("# written by rdr convert\n");
    for p in &d.positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for t in &d.uvs {
        let _ = writeln!(s, "vt {} {}", t.x, t.y);
    }
    for n in &d.normals {
        let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
    }
    for t in &d.triangles {
        s += "f";
        for c in 0..3 {
            let _ = match (t.uv, t.n) {
                (None, None) => write!(s, " {}", t.p[c] + 1),
                (Some(uv), None) => write!(s, " {}/{}", t.p[c] + 1, uv[c] + 1),
                (None, Some(n)) => write!(s, " {}//{}", t.p[c] + 1, n[c] + 1),
                (Some(uv), Some(n)) => write!(s, " {}/{}/{}", t.p[c] + 1, uv[c] + 1, n[c] + 1),
            };
        }
        s += "\n";
    }
    s
}

/// An ASCII PLY file of a mesh's data with its attributes, each under the property
/// names the PLY reader makes that name of again (`vertex_color`: `r g b`;
/// `vertex_P_color`: `P_r P_g P_b`; `vertex_P`: `P_x [P_y P_z]`); `None` when a
/// triangle's normals or uvs are indexed apart from its positions (no PLY can say that).
pub fn ply_text(d: &ObjData) -> Option<String> {
    if d.triangles
        .iter()
        .any(|t| t.n.is_some_and(|n| n != t.p) || t.uv.is_some_and(|uv| uv != t.p))
    {
        return None;
    }
    let (has_n, has_uv) = (d.normals.len() == d.positions.len(), d.uvs.len() == d.positions.len());
    let properties = |a: &crate::geometry::mesh::MeshAttribute| -> Vec<String> {
        let rest = a.name.split_once('_').map_or("", |(_, r)| r);
        let names: Vec<String> = match rest.strip_suffix("color") {
            Some("") => ["r", "g", "b", "a"].map(String::from).to_vec(),
            Some(prefix) => ["r", "g", "b"].map(|c| format!("{prefix}{c}")).to_vec(),
            None => ["x", "y", "z"].map(|c| format!("{rest}_{c}")).to_vec(),
        };
        names.into_iter().take(a.channels as usize).collect()
    };
    let (vertex, face): (Vec<_>, Vec<_>) = d.attributes.iter().partition(|a| !a.per_face());
    let mut s = format!(
        "ply\nformat ascii 1.0\ncomment written by rdr convert\nelement vertex {}\n",
        d.positions.len()
    );
    let mut props = vec!["x", "y", "z"];
    props.extend(if has_n { &["nx", "ny", "nz"][..] } else { &[] });
    props.extend(if has_uv { &["u", "v"][..] } else { &[] });
    for p in props {
        let _ = writeln!(s, "property float {p}");
    }
    for a in &vertex {
        for p in properties(a) {
            let _ = writeln!(s, "property float {p}");
        }
    }
    let _ = writeln!(s, "element face {}\nproperty list uchar int vertex_indices", d.triangles.len());
    for a in &face {
        for p in properties(a) {
            let _ = writeln!(s, "property float {p}");
        }
    }
    s += "end_header\n";
    // one record: its attributes' channels (a fourth, alpha, is 1)
    let values = |attributes: &[&crate::geometry::mesh::MeshAttribute], i: usize, s: &mut String| {
        for a in attributes {
            let v = a.values[i];
            for c in 0..a.channels as usize {
                let _ = write!(s, " {}", if c < 3 { v[c] } else { 1.0 });
            }
        }
    };
    for (i, p) in d.positions.iter().enumerate() {
        let _ = write!(s, "{} {} {}", p.x, p.y, p.z);
        if has_n {
            let _ = write!(s, " {} {} {}", d.normals[i].x, d.normals[i].y, d.normals[i].z);
        }
        if has_uv {
            let _ = write!(s, " {} {}", d.uvs[i].x, d.uvs[i].y);
        }
        values(&vertex, i, &mut s);
        s += "\n";
    }
    for (i, t) in d.triangles.iter().enumerate() {
        let _ = write!(s, "3 {} {} {}", t.p[0], t.p[1], t.p[2]);
        values(&face, i, &mut s);
        s += "\n";
    }
    Some(s)
}

pub(super) fn distribution_name(d: Distribution) -> &'static str {
    if d == Distribution::Ggx {
        "ggx"
    } else {
        "beckmann"
    }
}

/// A cylinder as Mitsuba's parameters: `p0`, `p1`, `radius` and, when its `u = 0`
/// direction is not the one Mitsuba's frame of the axis gives, a `to_world` that
/// places the unit cylinder ((0,0,0)–(0,0,1), radius 1) exactly.
pub(super) fn cylinder_params(c: &crate::geometry::cylinder::CylinderShape) -> (Vec3, Vec3, f32, Option<Mat4>) {
    let c = &c.cylinder;
    let (x, _) = crate::geometry::cylinder::mitsuba_frame(c.axis.normalize());
    if (x - c.x).length() < 1e-6 {
        return (c.p0, c.p0 + c.axis, c.radius, None);
    }
    let (_, y) = c.frame();
    let m = Mat4::from_cols(
        (c.x * c.radius).extend(0.0),
        (y * c.radius).extend(0.0),
        c.axis.extend(0.0),
        c.p0.extend(1.0),
    );
    (Vec3::ZERO, Vec3::Z, 1.0, Some(m))
}
