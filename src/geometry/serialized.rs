//! Mitsuba's `.serialized` meshes (the format of its `serialized` shape plugin, as its
//! documentation describes it), into [`ObjData`], and a writer for tests and
//! conversions.
//!
//! A file is a sequence of meshes followed by a table of where each starts (u64
//! offsets for format version 4, u32 for version 3) and the number of meshes (u32,
//! the last four bytes). A mesh is the header `0x041C` (u16), its version (u16), then
//! a zlib stream holding: flags (u32: 0x1 vertex normals, 0x2 texture coordinates,
//! 0x8 vertex colours, 0x10 "use face normals", 0x1000 single, 0x2000 double
//! precision), for version 4 a NUL-terminated name, vertex and triangle counts (u64
//! each), positions, [normals], [uvs], [colours], then the triangles' vertex indices
//! (u32, or u64 when there are more than 2³² vertices). All little-endian.

use super::obj::{ObjData, ObjTriangle};
use crate::math::{Vec2, Vec3};
use anyhow::{bail, Context, Result};
use std::io::Read;

const MAGIC: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x1;
const HAS_UVS: u32 = 0x2;
const HAS_COLORS: u32 = 0x8;
/// The mesh asks for flat shading.
pub const FACE_NORMALS: u32 = 0x10;
const SINGLE: u32 = 0x1000;
const DOUBLE: u32 = 0x2000;

/// Bytes of memory per vertex and per triangle of a decoded mesh, at most (the
/// reader's copy, the mesh, the scene's primitives and the BVH): counts are checked
/// against the memory budget with them before anything is allocated.
const BYTES_PER_VERTEX: u64 = 64;
const BYTES_PER_TRIANGLE: u64 = 160;
/// Deflate's largest expansion: a 258-byte match coded in two bits.
const MAX_INFLATE_RATIO: u64 = 1032;
/// Decompressed bytes read at a time, so memory grows with the data that is really
/// there rather than with the counts the file claims.
const BLOCK: usize = 1 << 20;

/// A decoded mesh and its flags.
#[derive(Debug)]
pub struct SerializedMesh {
    pub data: ObjData,
    pub name: String,
    pub flags: u32,
}

/// The decompression error, told apart: a stream that stops early from one that is not
/// zlib data at some point.
fn stream_error(e: std::io::Error) -> anyhow::Error {
    if e.kind() == std::io::ErrorKind::UnexpectedEof {
        anyhow::anyhow!("the compressed mesh data ends early (truncated?)")
    } else {
        anyhow::anyhow!("the compressed mesh data is corrupt ({e})")
    }
}

/// `n` values of `width` bytes each, decoded by `decode`, a block at a time (the
/// reserved memory is only touched as the data arrives; `n` is checked against what
/// the stream can hold before).
fn read_values<T>(z: &mut impl Read, n: usize, width: usize, decode: impl Fn(&[u8]) -> T) -> Result<Vec<T>> {
    let mut out = Vec::with_capacity(n);
    let mut buf = vec![0u8; (BLOCK / width).min(n) * width];
    let mut left = n;
    while left > 0 {
        let part = &mut buf[..left.min(BLOCK / width) * width];
        z.read_exact(part).map_err(stream_error)?;
        out.extend(part.chunks_exact(width).map(&decode));
        left -= part.len() / width;
    }
    Ok(out)
}

fn u32_at(b: &[u8], at: usize) -> Result<u32> {
    let s = b.get(at..at + 4).context("the file ends early")?;
    Ok(u32::from_le_bytes(s.try_into()?))
}

fn u64_at(b: &[u8], at: usize) -> Result<u64> {
    let s = b.get(at..at + 8).context("the file ends early")?;
    Ok(u64::from_le_bytes(s.try_into()?))
}

/// Mesh `index` of a `.serialized` file.
pub fn parse(bytes: &[u8], index: u32) -> Result<SerializedMesh> {
    if bytes.len() < 8 {
        bail!("too short for a serialized mesh file ({} bytes)", bytes.len());
    }
    let magic = u16::from_le_bytes([bytes[0], bytes[1]]);
    if magic != MAGIC {
        bail!("not a serialized mesh file (header {magic:#06x}, expected {MAGIC:#06x})");
    }
    let version = u16::from_le_bytes([bytes[2], bytes[3]]);
    if version != 3 && version != 4 {
        bail!("unsupported serialized format version {version} (3 and 4 are)");
    }
    let count = u32_at(bytes, bytes.len() - 4)?;
    if index >= count {
        bail!("shape_index {index} is out of range: the file has {count} mesh(es)");
    }
    let entry = if version == 4 { 8 } else { 4 };
    let table = (bytes.len() - 4)
        .checked_sub(entry * count as usize)
        .context("the table of mesh offsets does not fit the file (truncated?)")?;
    let offset_of = |i: usize| -> Result<u64> {
        if version == 4 {
            u64_at(bytes, table + 8 * i)
        } else {
            u32_at(bytes, table + 4 * i).map(u64::from)
        }
    };
    let start = offset_of(index as usize)?;
    let end = if index + 1 < count {
        offset_of(index as usize + 1)?
    } else {
        table as u64
    };
    if !(start.checked_add(4).is_some_and(|s| s <= end) && end <= table as u64) {
        bail!("mesh {index}'s offsets {start}..{end} lie outside the file (truncated?)");
    }
    let (start, end) = (start as usize, end as usize);
    if u16::from_le_bytes([bytes[start], bytes[start + 1]]) != MAGIC {
        bail!("mesh {index} does not start with the serialized header (a wrong offset table?)");
    }
    let mesh_version = u16::from_le_bytes([bytes[start + 2], bytes[start + 3]]);
    let compressed = (end - start - 4) as u64;
    let mut z = flate2::read::ZlibDecoder::new(&bytes[start + 4..end]);
    let read = |z: &mut flate2::read::ZlibDecoder<&[u8]>, n: usize| -> Result<Vec<u8>> {
        let mut buf = vec![0u8; n];
        z.read_exact(&mut buf).map_err(stream_error)?;
        Ok(buf)
    };
    let flags = u32::from_le_bytes(read(&mut z, 4)?.try_into().expect("4 bytes"));
    let mut name = String::new();
    if mesh_version == 4 {
        loop {
            let c = read(&mut z, 1)?[0];
            if c == 0 {
                break;
            }
            if name.len() > 4096 {
                bail!("mesh {index}'s name is not terminated");
            }
            name.push(c as char);
        }
    }
    let nv = u64::from_le_bytes(read(&mut z, 8)?.try_into().expect("8 bytes"));
    let nt = u64::from_le_bytes(read(&mut z, 8)?.try_into().expect("8 bytes"));
    // Mitsuba 3 reads a mesh as double precision only when the flag says so: files of
    // format version 3 declare neither
    let double = flags & DOUBLE != 0;
    // what the counts need from the stream, against the most its bytes can inflate to
    let width: u128 = if double { 8 } else { 4 };
    let floats_per_vertex = [(HAS_NORMALS, 3), (HAS_UVS, 2), (HAS_COLORS, 3)]
        .iter()
        .filter(|(f, _)| flags & f != 0)
        .fold(3u128, |a, (_, n)| a + n);
    let index_width: u128 = if nv > u32::MAX as u64 { 8 } else { 4 };
    let needed = nv as u128 * floats_per_vertex * width + nt as u128 * 3 * index_width;
    let most = (compressed as u128 + 1) * MAX_INFLATE_RATIO as u128;
    if needed > most {
        bail!(
            "mesh {index} claims {nv} vertices and {nt} triangles ({needed} bytes of data), more than its {compressed} compressed bytes can hold (corrupt or truncated?)"
        );
    }
    let memory = nv
        .checked_mul(BYTES_PER_VERTEX)
        .and_then(|a| nt.checked_mul(BYTES_PER_TRIANGLE).and_then(|b| a.checked_add(b)));
    crate::limits::check_memory(memory, || format!("a serialized mesh of {nv} vertices and {nt} triangles")).map_err(anyhow::Error::msg)?;
    let (nv, nt) = (nv as usize, nt as usize);
    let floats = |z: &mut flate2::read::ZlibDecoder<&[u8]>, n: usize| -> Result<Vec<f32>> {
        let v = if double {
            read_values(z, n, 8, |c| f64::from_le_bytes(c.try_into().expect("8")) as f32)?
        } else {
            read_values(z, n, 4, |c| f32::from_le_bytes(c.try_into().expect("4")))?
        };
        if v.iter().any(|x| !x.is_finite()) {
            bail!("mesh {index} has a coordinate that is not a finite 32-bit number");
        }
        Ok(v)
    };
    let mut data = ObjData {
        positions: floats(&mut z, nv * 3)?.chunks_exact(3).map(Vec3::from_slice).collect(),
        ..ObjData::default()
    };
    if flags & HAS_NORMALS != 0 {
        data.normals = floats(&mut z, nv * 3)?.chunks_exact(3).map(Vec3::from_slice).collect();
    }
    if flags & HAS_UVS != 0 {
        data.uvs = floats(&mut z, nv * 2)?.chunks_exact(2).map(Vec2::from_slice).collect();
    }
    if flags & HAS_COLORS != 0 {
        floats(&mut z, nv * 3)?;
    }
    let idx: Vec<u64> = if nv > u32::MAX as usize {
        read_values(&mut z, nt * 3, 8, |c| u64::from_le_bytes(c.try_into().expect("8")))?
    } else {
        read_values(&mut z, nt * 3, 4, |c| u32::from_le_bytes(c.try_into().expect("4")) as u64)?
    };
    if let Some(bad) = idx.iter().find(|&&i| i >= nv as u64) {
        bail!("mesh {index} has a vertex index {bad} out of range ({nv} vertices)");
    }
    let (has_n, has_uv) = (!data.normals.is_empty(), !data.uvs.is_empty());
    data.triangles = idx
        .chunks_exact(3)
        .map(|t| {
            let p = [t[0] as u32, t[1] as u32, t[2] as u32];
            ObjTriangle {
                p,
                n: has_n.then_some(p),
                uv: has_uv.then_some(p),
                line: 0,
            }
        })
        .collect();
    Ok(SerializedMesh { data, name, flags })
}

/// Writes meshes in the version-4 format (single precision, u32 indices), with
/// their normals and uvs when every vertex has one.
pub fn write(meshes: &[(&str, &ObjData)]) -> Vec<u8> {
    use std::io::Write;
    let mut out = Vec::new();
    let mut offsets = Vec::new();
    for (name, d) in meshes {
        offsets.push(out.len() as u64);
        out.extend_from_slice(&MAGIC.to_le_bytes());
        out.extend_from_slice(&4u16.to_le_bytes());
        let (has_n, has_uv) = (
            d.normals.len() == d.positions.len() && !d.normals.is_empty(),
            d.uvs.len() == d.positions.len() && !d.uvs.is_empty(),
        );
        let flags = SINGLE | if has_n { HAS_NORMALS } else { 0 } | if has_uv { HAS_UVS } else { 0 };
        let mut raw = Vec::new();
        raw.extend_from_slice(&flags.to_le_bytes());
        raw.extend_from_slice(name.as_bytes());
        raw.push(0);
        raw.extend_from_slice(&(d.positions.len() as u64).to_le_bytes());
        raw.extend_from_slice(&(d.triangles.len() as u64).to_le_bytes());
        for p in &d.positions {
            for c in p.to_array() {
                raw.extend_from_slice(&c.to_le_bytes());
            }
        }
        if has_n {
            for n in &d.normals {
                for c in n.to_array() {
                    raw.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        if has_uv {
            for t in &d.uvs {
                for c in t.to_array() {
                    raw.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        for t in &d.triangles {
            for i in t.p {
                raw.extend_from_slice(&i.to_le_bytes());
            }
        }
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&raw).expect("writing to memory");
        out.extend_from_slice(&z.finish().expect("writing to memory"));
    }
    for o in &offsets {
        out.extend_from_slice(&o.to_le_bytes());
    }
    out.extend_from_slice(&(meshes.len() as u32).to_le_bytes());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A version-3 file (no name, 32-bit offsets) whose flags declare no precision, as
    /// real 0.6-era files do: Mitsuba 3 reads them as single precision.
    #[test]
    fn version_3_without_a_precision_flag_is_single() {
        use std::io::Write;
        let positions = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]];
        let mut raw = Vec::new();
        raw.extend_from_slice(&0u32.to_le_bytes()); // flags: neither 0x1000 nor 0x2000
        raw.extend_from_slice(&3u64.to_le_bytes());
        raw.extend_from_slice(&1u64.to_le_bytes());
        for c in positions.iter().flatten() {
            raw.extend_from_slice(&c.to_le_bytes());
        }
        for i in [0u32, 1, 2] {
            raw.extend_from_slice(&i.to_le_bytes());
        }
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&raw).unwrap();
        let mut bytes = MAGIC.to_le_bytes().to_vec();
        bytes.extend_from_slice(&3u16.to_le_bytes());
        bytes.extend_from_slice(&z.finish().unwrap());
        bytes.extend_from_slice(&0u32.to_le_bytes()); // the offset of mesh 0
        bytes.extend_from_slice(&1u32.to_le_bytes()); // one mesh
        let m = parse(&bytes, 0).expect("a version-3 mesh without a precision flag");
        let want: Vec<Vec3> = positions.iter().map(|p| Vec3::from_array(*p)).collect();
        assert_eq!(m.data.positions, want);
        assert_eq!(m.data.triangles[0].p, [0, 1, 2]);
    }

    #[test]
    fn round_trip_and_truncation() {
        let d = ObjData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::Z; 3],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::Y],
            triangles: vec![ObjTriangle {
                p: [0, 1, 2],
                n: None,
                uv: None,
                line: 0,
            }],
            warnings: Vec::new(),
            ..Default::default()
        };
        let bytes = write(&[("a", &d), ("b", &d)]);
        let m = parse(&bytes, 1).unwrap();
        assert_eq!(m.name, "b");
        assert_eq!(m.data.positions, d.positions);
        assert_eq!(m.data.normals, d.normals);
        assert_eq!(m.data.triangles[0].p, [0, 1, 2]);
        assert!(format!("{:#}", parse(&bytes, 2).unwrap_err()).contains("out of range"));
        for cut in [bytes.len() - 1, bytes.len() / 2, 10, 3] {
            assert!(parse(&bytes[..cut], 0).is_err(), "truncated at {cut}");
        }
    }
}
