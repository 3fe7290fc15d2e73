//! Mitsuba's binary `.vol` grid format (Mitsuba 0.6 and 3, little endian): `VOL`, the
//! version byte 3, the encoding (int32, 1 = float32, the only one Mitsuba 3 reads),
//! the resolution x, y, z (int32 each), the channel count (int32), the box (six
//! float32: min xyz, max xyz), then the values, x fastest, then y, then z, the
//! channels of a voxel together.

use super::GridData;
use crate::geometry::Aabb;
use crate::math::Vec3;
use std::path::Path;

const HEADER: usize = 48;

/// Reads a `.vol` file; the error is one line without the file's name (the caller
/// names the file and the key).
pub fn read(path: &Path) -> Result<GridData, String> {
    as_medium(read_file(path)?)
}

/// Decodes a `.vol` file's bytes into a medium's grid ([`GridData::new`] checks the
/// channels and the values).
pub fn parse(bytes: &[u8]) -> Result<GridData, String> {
    as_medium(parse_file(bytes)?)
}

fn as_medium(f: GridData) -> Result<GridData, String> {
    GridData::new(f.res, f.channels, f.bbox, f.values)
}

/// Reads a `.vol` file as it is ([`parse_file`]); the error is one line without the
/// file's name.
pub fn read_file(path: &Path) -> Result<GridData, String> {
    let bytes = crate::limits::read_input_file(path, crate::limits::memory_budget()).map_err(|e| e.to_string())?;
    parse_file(&bytes)
}

/// Decodes a `.vol` file's header and values as they are, checked for the format
/// only (1 or 3 channels; [`GridData::new`] checks a medium's values, an sdfgrid its
/// own). A header that claims more values than the bytes hold is refused before
/// anything is allocated.
pub fn parse_file(bytes: &[u8]) -> Result<GridData, String> {
    if bytes.len() < HEADER {
        return Err(format!("{} bytes, shorter than the 48-byte .vol header", bytes.len()));
    }
    if &bytes[..3] != b"VOL" {
        return Err("not a .vol grid (it does not start with \"VOL\")".into());
    }
    if bytes[3] != 3 {
        return Err(format!("version {} (rdr reads version 3)", bytes[3]));
    }
    let int = |at: usize| i32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    let float = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
    let encoding = int(4);
    if encoding != 1 {
        return Err(format!("encoding {encoding} (rdr reads 1, float32, as Mitsuba 3 does)"));
    }
    let (x, y, z, channels) = (int(8), int(12), int(16), int(20));
    if x <= 0 || y <= 0 || z <= 0 {
        return Err(format!("resolution {x}×{y}×{z} (each must be at least 1)"));
    }
    if channels != 1 && channels != 3 {
        return Err(format!("{channels} channels per voxel (rdr reads 1 or 3)"));
    }
    let count = [x, y, z, channels].iter().try_fold(1u64, |a, &n| a.checked_mul(n as u64));
    let held = ((bytes.len() - HEADER) / 4) as u64;
    match count {
        Some(n) if n <= held => {}
        _ => {
            return Err(format!(
                "the header claims {x}×{y}×{z}×{channels} values, more than the {held} its {} bytes hold",
                bytes.len()
            ))
        }
    }
    let n = count.expect("checked") as usize;
    let values: Vec<f32> = bytes[HEADER..HEADER + 4 * n]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().expect("4")))
        .collect();
    let bbox = Aabb::new(
        Vec3::new(float(24), float(28), float(32)),
        Vec3::new(float(36), float(40), float(44)),
    );
    Ok(GridData {
        res: [x as usize, y as usize, z as usize],
        channels: channels as usize,
        bbox,
        values,
    })
}

/// The bytes of a `.vol` file holding `grid` (for tests and tools).
pub fn encode(grid: &GridData) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + 4 * grid.values.len());
    out.extend_from_slice(b"VOL\x03");
    for v in [1, grid.res[0] as i32, grid.res[1] as i32, grid.res[2] as i32, grid.channels as i32] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in grid
        .bbox
        .min
        .to_array()
        .into_iter()
        .chain(grid.bbox.max.to_array())
        .chain(grid.values.iter().copied())
    {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}
