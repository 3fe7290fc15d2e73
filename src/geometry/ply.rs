//! PLY meshes (as read by `rdr bench`), into the same [`ObjData`] the OBJ reader gives.

use super::obj::{ObjData, ObjTriangle};
use crate::math::Vec3;
use anyhow::{bail, Context, Result};

/// A minimal PLY reader: `ascii` or `binary_little_endian`, vertex `x y z`
/// (any scalar types; other properties skipped), faces as a list property
/// (fans for polygons). Other elements must come after the faces or be empty.
pub fn parse_ply(bytes: &[u8]) -> Result<ObjData> {
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
    for line in header.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["format", f, ..] => format = f,
            ["element", name, n] => elements.push((name.to_string(), n.parse().context("bad element count")?, Vec::new())),
            ["property", "list", ct, t, name] => {
                elements
                    .last_mut()
                    .context("property before element")?
                    .2
                    .push((t.to_string(), Some(ct.to_string()), name.to_string()))
            }
            ["property", t, name] => {
                elements
                    .last_mut()
                    .context("property before element")?
                    .2
                    .push((t.to_string(), None, name.to_string()))
            }
            _ => {}
        }
    }
    let binary = match format {
        "ascii" => false,
        "binary_little_endian" => true,
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
            return words.next().context("PLY body ends early")?.parse::<f64>().context("bad number");
        }
        let n = size(t)?;
        let b = bytes.get(pos..pos + n).context("PLY body ends early")?;
        pos += n;
        Ok(match t {
            "char" | "int8" => b[0] as i8 as f64,
            "uchar" | "uint8" => b[0] as f64,
            "short" | "int16" => i16::from_le_bytes([b[0], b[1]]) as f64,
            "ushort" | "uint16" => u16::from_le_bytes([b[0], b[1]]) as f64,
            "int" | "int32" => i32::from_le_bytes(b.try_into()?) as f64,
            "uint" | "uint32" => u32::from_le_bytes(b.try_into()?) as f64,
            "float" | "float32" => f32::from_le_bytes(b.try_into()?) as f64,
            _ => f64::from_le_bytes(b.try_into()?),
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
    for (name, count, props) in &elements {
        if props.is_empty() {
            continue; // records of nothing
        }
        for _ in 0..*count {
            let mut xyz = [0.0f32; 3];
            let mut face: Vec<u32> = Vec::new();
            for (t, list, pname) in props {
                match list {
                    None => {
                        let v = read(t)?;
                        match pname.as_str() {
                            "x" => xyz[0] = v as f32,
                            "y" => xyz[1] = v as f32,
                            "z" => xyz[2] = v as f32,
                            _ => {}
                        }
                    }
                    Some(ct) => {
                        let n = read(ct)? as usize;
                        for _ in 0..n {
                            let v = read(t)?;
                            if name == "face" {
                                face.push(v as u32);
                            }
                        }
                    }
                }
            }
            if name == "vertex" {
                data.positions.push(Vec3::from_array(xyz));
            } else if name == "face" {
                if face.iter().any(|&i| i as usize >= data.positions.len()) {
                    bail!("face index out of range");
                }
                for k in 2..face.len() {
                    data.triangles.push(ObjTriangle {
                        p: [face[0], face[k - 1], face[k]],
                        n: None,
                        uv: None,
                        line: 0,
                    });
                }
            }
        }
    }
    Ok(data)
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
        assert!(parse_ply(b"ply\nformat binary_big_endian 1.0\nend_header\n").is_err());
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
