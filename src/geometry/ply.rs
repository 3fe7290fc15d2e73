//! PLY meshes (for scenes and `rdr bench`), into the same [`ObjData`] the OBJ reader gives.

use super::attribute::MeshAttribute;
use super::obj::{ObjData, ObjTriangle};
use crate::math::{Vec2, Vec3};
use anyhow::{bail, Context, Result};

/// A PLY reader: `ascii`, `binary_little_endian` or `binary_big_endian`; vertex
/// `x y z`, optional normals `nx ny nz` and texture coordinates (`u v`, `s t`,
/// `texture_u texture_v` or `texture_s texture_t`), any scalar types, other
/// properties skipped; faces as a list property (fans for polygons). Counts the body
/// cannot hold, a body that ends early and face indices out of range are errors.
pub fn parse_ply(bytes: &[u8]) -> Result<ObjData> {
    if !bytes.starts_with(b"ply") {
        bail!("not a PLY file (it does not start with 'ply')");
    }
    let header_end = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .context("no 'end_header' in the PLY header")?;
    let header = std::str::from_utf8(&bytes[..header_end]).context("PLY header is not text")?;
    let mut body = header_end + 10;
    while body < bytes.len() && bytes[body] != b'\n' {
        body += 1;
    }
    body += 1;
    let mut format = "";
    // (name, count, properties); a property is (type, Some(count type) for lists, name)
    type Prop = (String, Option<String>, String);
    let mut elements: Vec<(String, usize, Vec<Prop>)> = Vec::new();
    for (i, line) in header.lines().enumerate() {
        let w: Vec<&str> = line.split_whitespace().collect();
        let n = i + 1;
        match w.as_slice() {
            ["format", f, ..] => format = f,
            ["element", name, count] => elements.push((
                name.to_string(),
                count
                    .parse()
                    .with_context(|| format!("header line {n}: bad element count '{count}'"))?,
                Vec::new(),
            )),
            ["property", "list", ct, t, name] => elements
                .last_mut()
                .with_context(|| format!("header line {n}: property before any element"))?
                .2
                .push((t.to_string(), Some(ct.to_string()), name.to_string())),
            ["property", t, name] => elements
                .last_mut()
                .with_context(|| format!("header line {n}: property before any element"))?
                .2
                .push((t.to_string(), None, name.to_string())),
            ["element", ..] | ["property", ..] => bail!("header line {n}: malformed '{line}'"),
            _ => {}
        }
    }
    let (binary, big) = match format {
        "ascii" => (false, false),
        "binary_little_endian" => (true, false),
        "binary_big_endian" => (true, true),
        f => bail!("unsupported PLY format '{f}'"),
    };
    let size = |t: &str| -> Result<usize> {
        Ok(match t {
            "char" | "uchar" | "int8" | "uint8" => 1,
            "short" | "ushort" | "int16" | "uint16" => 2,
            "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
            "double" | "float64" => 8,
            _ => bail!("unknown PLY type '{t}'"),
        })
    };
    for (_, _, props) in &elements {
        for (t, list, _) in props {
            size(t)?;
            if let Some(ct) = list {
                size(ct)?;
            }
        }
    }
    let mut pos = body;
    let mut words = if binary {
        None
    } else {
        Some(
            std::str::from_utf8(bytes.get(body..).unwrap_or_default())
                .context("PLY body is not text")?
                .split_whitespace(),
        )
    };
    let mut read = |t: &str| -> Result<f64> {
        if let Some(words) = words.as_mut() {
            let w = words.next().context("PLY body ends early")?;
            return w.parse::<f64>().with_context(|| format!("bad number '{w}' in the PLY body"));
        }
        let n = size(t)?;
        let b = bytes.get(pos..pos + n).context("PLY body ends early")?;
        pos += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if big {
            a[..n].reverse();
        }
        Ok(match t {
            "char" | "int8" => a[0] as i8 as f64,
            "uchar" | "uint8" => a[0] as f64,
            "short" | "int16" => i16::from_le_bytes([a[0], a[1]]) as f64,
            "ushort" | "uint16" => u16::from_le_bytes([a[0], a[1]]) as f64,
            "int" | "int32" => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            "uint" | "uint32" => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            "float" | "float32" => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            _ => f64::from_le_bytes(a),
        })
    };
    // Every record takes some bytes of the body (binary: its scalars and list counts;
    // ASCII: a number and a separator per property): counts the body cannot hold are
    // refused before anything is allocated or looped over.
    let body_len = bytes.len().saturating_sub(body) as u64;
    let mut need = 0u64;
    for (name, count, props) in &elements {
        let mut per = 0u64;
        for (t, list, _) in props {
            per += match (binary, list) {
                (true, None) => size(t)? as u64,
                (true, Some(ct)) => size(ct)? as u64,
                (false, _) => 2,
            };
        }
        if per == 0 {
            if name == "vertex" && *count > 0 {
                bail!("element 'vertex' has no properties (x, y, z are needed)");
            }
            continue;
        }
        need = (*count as u64)
            .checked_mul(per)
            .and_then(|n| n.checked_add(need))
            .filter(|&n| n <= body_len + 1)
            .with_context(|| format!("element '{name}' claims {count} records, more than the {body_len} bytes of the body can hold"))?;
    }
    let mut data = ObjData::default();
    let vertex_props: &[Prop] = elements.iter().find(|e| e.0 == "vertex").map_or(&[], |e| &e.2);
    let has = |n: &str| vertex_props.iter().any(|p| p.2 == n && p.1.is_none());
    let has_normals = has("nx") && has("ny") && has("nz");
    let uv_names = [("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")]
        .into_iter()
        .find(|(a, b)| has(a) && has(b));
    // the other scalar properties, grouped into attributes as Mitsuba groups them
    let mut reserved = vec!["x", "y", "z", "nx", "ny", "nz", "u", "v"];
    reserved.extend(uv_names.map_or([""; 2], |(a, b)| [a, b]));
    let groups: Vec<Vec<AttributeFields>> = elements
        .iter()
        .map(|(name, _, props)| {
            if name != "vertex" && name != "face" {
                return Vec::new();
            }
            let scalars: Vec<&str> = props.iter().filter(|p| p.1.is_none()).map(|p| p.2.as_str()).collect();
            let (groups, ignored) = attribute_fields(name, &scalars, &reserved);
            if !ignored.is_empty() {
                data.warnings.push(format!(
                    "element '{name}': properties that make no attribute by Mitsuba 3's rules, not read: {}",
                    ignored.join(", ")
                ));
            }
            groups
        })
        .collect();
    let colour_scale = |t: &str| match t {
        "uchar" | "uint8" => 1.0 / 255.0,
        "ushort" | "uint16" => 1.0 / 65535.0,
        _ => 1.0,
    };
    if vertex_props.iter().all(|p| p.2 != "x") && elements.iter().any(|e| e.0 == "vertex" && e.1 > 0) {
        bail!("element 'vertex' has no property 'x'");
    }
    for (e, (name, count, props)) in elements.iter().enumerate() {
        if props.is_empty() {
            continue; // records of nothing
        }
        let attributes = &groups[e];
        // each property's attribute and channel
        let channel: Vec<Option<(usize, usize)>> = props
            .iter()
            .map(|p| {
                attributes
                    .iter()
                    .enumerate()
                    .find_map(|(a, g)| g.fields.iter().position(|f| *f == p.2).map(|c| (a, c)))
            })
            .collect();
        let first = data.attributes.len();
        data.attributes.extend(attributes.iter().map(|g| MeshAttribute {
            name: g.name.clone(),
            channels: g.fields.len() as u8,
            values: Vec::new(),
        }));
        for _ in 0..*count {
            let (mut xyz, mut n, mut uv) = ([0.0f32; 3], [0.0f32; 3], [0.0f32; 2]);
            let mut values = vec![[0.0f32; 3]; attributes.len()];
            let mut face: Vec<u32> = Vec::new();
            for ((t, list, pname), channel) in props.iter().zip(&channel) {
                match list {
                    None => {
                        let v = read(t)? as f32;
                        match pname.as_str() {
                            "x" => xyz[0] = v,
                            "y" => xyz[1] = v,
                            "z" => xyz[2] = v,
                            "nx" => n[0] = v,
                            "ny" => n[1] = v,
                            "nz" => n[2] = v,
                            p if uv_names.is_some_and(|(a, _)| a == p) => uv[0] = v,
                            p if uv_names.is_some_and(|(_, b)| b == p) => uv[1] = v,
                            _ => {
                                if let Some((a, c)) = *channel {
                                    if c < 3 {
                                        let scale = if attributes[a].colour { colour_scale(t) } else { 1.0 };
                                        values[a][c] = v * scale;
                                    }
                                }
                            }
                        }
                    }
                    Some(ct) => {
                        let k = read(ct)?;
                        if !(0.0..=1e6).contains(&k) {
                            bail!("a list of {k} entries in element '{name}'");
                        }
                        for _ in 0..k as usize {
                            let v = read(t)?;
                            if name == "face" && (pname == "vertex_indices" || pname == "vertex_index") {
                                if !(v >= 0.0 && v < data.positions.len() as f64) {
                                    bail!("face index {v} out of range (the file has {} vertices)", data.positions.len());
                                }
                                face.push(v as u32);
                            }
                        }
                    }
                }
            }
            if name == "vertex" {
                if !(xyz.iter().all(|c| c.is_finite()) && n.iter().all(|c| c.is_finite()) && uv.iter().all(|c| c.is_finite())) {
                    bail!("vertex {} is not finite", data.positions.len());
                }
                data.positions.push(Vec3::from_array(xyz));
                if has_normals {
                    data.normals.push(Vec3::from_array(n));
                }
                if uv_names.is_some() {
                    data.uvs.push(Vec2::from_array(uv));
                }
                push_values(&mut data.attributes[first..], &values, 1);
            } else if name == "face" {
                for k in 2..face.len() {
                    let idx = [face[0], face[k - 1], face[k]];
                    data.triangles.push(ObjTriangle {
                        p: idx,
                        n: has_normals.then_some(idx),
                        uv: uv_names.is_some().then_some(idx),
                        line: 0,
                    });
                }
                push_values(&mut data.attributes[first..], &values, face.len().saturating_sub(2));
            }
        }
    }
    Ok(data)
}

/// `count` copies of one record's attribute values (a face fanned into `count`
/// triangles) appended to the attributes; one channel is kept in all three.
fn push_values(attributes: &mut [MeshAttribute], values: &[[f32; 3]], count: usize) {
    for (a, v) in attributes.iter_mut().zip(values) {
        let v = if a.channels == 1 { Vec3::splat(v[0]) } else { Vec3::from_array(*v) };
        a.values.extend(std::iter::repeat_n(v, count));
    }
}

/// The properties of one attribute: its Mitsuba name and their names, channel order.
struct AttributeFields<'a> {
    name: String,
    fields: Vec<&'a str>,
    /// A colour (integers are read as fractions of their type's maximum).
    colour: bool,
}

/// Suffix families of an attribute's properties `P_x P_y P_z`: the first property's
/// suffix picks the family, the next ones follow it in order.
const SUFFIX_FAMILIES: [&str; 4] = ["xyzw", "rgba", "0123", "1234"];

/// Mitsuba 3's grouping of an element's scalar properties (`element` "vertex" or
/// "face") other than `reserved` into attributes: `r g b [a]` or `red green blue
/// [alpha]` are `{element}_color`; consecutive properties `P_c` with one prefix `P`
/// and one-letter suffixes running through a family of [`SUFFIX_FAMILIES`] are
/// `{element}_P` (`{element}_P_color` for `r g b`), kept if there are 1 or 3 of them.
/// Also the names of the properties left out.
fn attribute_fields<'a>(element: &str, names: &[&'a str], reserved: &[&str]) -> (Vec<AttributeFields<'a>>, Vec<&'a str>) {
    let has = |n: &str| names.contains(&n);
    let mut groups = Vec::new();
    if let Some(rgb) = [["r", "g", "b", "a"], ["red", "green", "blue", "alpha"]]
        .into_iter()
        .find(|c| c[..3].iter().all(|n| has(n)))
    {
        let fields = rgb
            .iter()
            .filter(|n| has(n))
            .map(|n| *names.iter().find(|m| *m == n).expect("has"))
            .collect();
        groups.push(AttributeFields {
            name: format!("{element}_color"),
            fields,
            colour: true,
        });
    }
    let taken =
        |n: &str| reserved.contains(&n) || ["r", "g", "b", "a"].contains(&n) || groups.first().is_some_and(|g| g.fields.contains(&n));
    let taken: Vec<bool> = names.iter().map(|n| taken(n)).collect();
    let (mut ignored, mut done): (Vec<&str>, Vec<&str>) = (Vec::new(), Vec::new());
    // the attribute being read: its prefix, suffix family and properties
    let mut run: Option<(&str, usize, Vec<&str>)> = None;
    let mut flush = |run: &mut Option<(&'a str, usize, Vec<&'a str>)>, ignored: &mut Vec<&'a str>, done: &mut Vec<&'a str>| {
        if let Some((prefix, family, fields)) = run.take() {
            if fields.len() == 1 || fields.len() == 3 {
                let colour = if family == 1 { "_color" } else { "" };
                groups.push(AttributeFields {
                    name: format!("{element}_{prefix}{colour}"),
                    fields,
                    colour: family == 1,
                });
                done.push(prefix);
            } else {
                ignored.extend(fields);
            }
        }
    };
    let mut skipping: Option<&str> = None;
    for (&n, _) in names.iter().zip(&taken).filter(|(_, t)| !**t) {
        let split = n.rsplit_once('_').filter(|(_, s)| s.chars().count() == 1);
        if let (Some(p), Some((prefix, _))) = (skipping, split) {
            if p == prefix {
                ignored.push(n);
                continue;
            }
        }
        skipping = None;
        let Some((prefix, suffix)) = split else {
            flush(&mut run, &mut ignored, &mut done);
            ignored.push(n);
            continue;
        };
        let c = suffix.chars().next().expect("one letter");
        if run.as_ref().is_some_and(|r| r.0 != prefix) {
            flush(&mut run, &mut ignored, &mut done);
        }
        match run.as_mut() {
            None => match SUFFIX_FAMILIES.iter().position(|f| f.starts_with(c)) {
                Some(family) if !done.contains(&prefix) => run = Some((prefix, family, vec![n])),
                Some(_) => {
                    // a second attribute of this prefix
                    ignored.push(n);
                    skipping = Some(prefix);
                }
                None => ignored.push(n),
            },
            Some((_, family, fields)) => {
                if SUFFIX_FAMILIES[*family].chars().nth(fields.len()) == Some(c) {
                    fields.push(n);
                } else {
                    // out of sequence: the whole attribute is left out
                    ignored.extend(run.take().expect("reading").2);
                    ignored.push(n);
                    skipping = Some(prefix);
                }
            }
        }
    }
    flush(&mut run, &mut ignored, &mut done);
    (groups, ignored)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ply_ascii_and_binary() {
        let ascii = b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\n\
element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n4 0 1 2 3\n";
        let d = parse_ply(ascii).unwrap();
        assert_eq!(d.positions.len(), 4);
        assert_eq!(d.triangles.iter().map(|t| t.p).collect::<Vec<_>>(), vec![[0, 1, 2], [0, 2, 3]]);
        let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
element face 1\nproperty list uchar uint vertex_indices\nend_header\n"
            .to_vec();
        for v in [[0.0f32, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.5]] {
            for c in v {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        bin.push(3);
        for i in [0u32, 1, 2] {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        let d = parse_ply(&bin).unwrap();
        assert_eq!(d.positions[2], Vec3::new(0.0, 2.0, 0.5));
        assert_eq!(d.triangles[0].p, [0, 1, 2]);
        assert!(parse_ply(b"ply\nformat binary_middle_endian 1.0\nend_header\n").is_err());
        let mut short = bin.clone();
        short.truncate(bin.len() - 2);
        assert!(parse_ply(&short).is_err());
        // counts the body cannot hold, and records without properties
        let huge = b"ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nend_header\n0\n";
        assert!(format!("{:#}", parse_ply(huge).unwrap_err()).contains("4000000000 records"));
        let empty = b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nend_header\n";
        assert!(format!("{:#}", parse_ply(empty).unwrap_err()).contains("no properties"));
        let other = b"ply\nformat ascii 1.0\nelement junk 18446744073709551615\nend_header\n";
        assert!(parse_ply(other).unwrap().positions.is_empty());
    }
}
