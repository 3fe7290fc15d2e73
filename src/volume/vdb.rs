//! OpenVDB `.vdb` files read directly: one float grid by name, its sparse tree made
//! dense over the box of its active voxels (one voxel of its background around), placed
//! by the grid's own index-to-world map. Files of format version 222 and newer
//! (OpenVDB 3 on) with their values uncompressed or zlib-compressed (with or without
//! OpenVDB's active-mask compression), float or half-float; Blosc-compressed files are
//! refused with a message saying so.
//!
//! The layout (OpenVDB's `io/Archive.cc`, `tree/RootNode.h`, `InternalNode.h`,
//! `LeafNode.h`, `io/Compression.h`): a header, the file's metadata, one descriptor per
//! grid (name, tree type, offsets); at a grid's offset its compression flags, metadata,
//! transform and tree topology (the root's background, tiles and children; each
//! internal node's child and value masks and tile values; each leaf's value mask), then
//! the leaves' values in the same order. Index `(x, y, z)` of a node is `z` fastest;
//! OpenVDB's voxel `(i, j, k)` is centred on index point `(i, j, k)`.

use super::GridData;
use crate::geometry::Aabb;
use crate::math::{Mat4, Vec3};
use std::io::Read;
use std::path::Path;

const MAGIC: u32 = 0x5644_4220;
const COMPRESS_ZIP: u32 = 1;
const COMPRESS_ACTIVE_MASK: u32 = 2;
const COMPRESS_BLOSC: u32 = 4;

/// A grid read from a `.vdb` file: its values on a dense box of voxels, and the map
/// from that box's unit cube to the file's world space.
#[derive(Clone, Debug)]
pub struct VdbGrid {
    pub data: GridData,
    pub to_world: Mat4,
}

/// Reads grid `name` of a `.vdb` file; the error is one line without the file's name.
pub fn read(path: &Path, name: &str) -> Result<VdbGrid, String> {
    let bytes = crate::limits::read_input_file(path, crate::limits::memory_budget()).map_err(|e| e.to_string())?;
    parse(&bytes, name)
}

/// Decodes grid `name` of a `.vdb` file's bytes.
pub fn parse(bytes: &[u8], name: &str) -> Result<VdbGrid, String> {
    let mut r = Cursor { bytes, pos: 0 };
    if r.u32()? != MAGIC || r.u32()? != 0 {
        return Err("not an OpenVDB file (no \"VDB\" magic number)".into());
    }
    let version = r.u32()?;
    if version < 222 {
        return Err(format!(
            "OpenVDB file format version {version} (rdr reads 222 and newer, OpenVDB 3 on)"
        ));
    }
    r.skip(8)?; // library version
    let has_offsets = r.u8()? != 0;
    r.skip(36)?; // uuid
    if !has_offsets {
        return Err("a .vdb stream without grid offsets (rdr reads files written by io::File)".into());
    }
    skip_metadata(&mut r)?;
    let count = r.u32()?;
    let mut found = None;
    let mut names = Vec::new();
    for _ in 0..count {
        let unique = r.string()?;
        let ty = r.string()?;
        let parent = r.string()?;
        let (grid_pos, block_pos, end) = (r.u64()?, r.u64()?, r.u64()?);
        // each descriptor is followed by its grid; the next starts at this one's end
        if end <= r.pos as u64 {
            return Err(format!("a grid descriptor whose end ({end}) is not after it (byte {})", r.pos));
        }
        // duplicate names carry a suffix after a record separator
        let base = unique.split('\x1e').next().unwrap_or_default().to_string();
        if base == name && found.is_none() {
            found = Some((ty, parent, grid_pos, block_pos));
        }
        names.push(base);
        if names.len() < count as usize {
            r.seek(end)?;
        }
    }
    let Some((ty, parent, grid_pos, block_pos)) = found else {
        let list = names
            .iter()
            .map(|n| format!("\"{}\"", crate::limits::sanitize(n)))
            .collect::<Vec<_>>()
            .join(", ");
        return Err(format!(
            "no grid named \"{}\" (the file has {})",
            crate::limits::sanitize(name),
            if list.is_empty() { "none".into() } else { list }
        ));
    };
    let half = match ty.as_str() {
        "Tree_float_5_4_3" => false,
        "Tree_float_5_4_3_HalfFloat" => true,
        other => {
            return Err(format!(
                "grid \"{name}\" is a {} (rdr reads float grids, Tree_float_5_4_3)",
                crate::limits::sanitize(other)
            ))
        }
    };
    if !parent.is_empty() {
        return Err(format!("grid \"{name}\" is an instance of another grid (not supported)"));
    }
    r.seek(grid_pos)?;
    let compression = r.u32()?;
    if compression & COMPRESS_BLOSC != 0 {
        return Err(format!(
            "grid \"{name}\" is Blosc-compressed (rdr reads uncompressed and zlib .vdb files; re-save it with zip compression, e.g. io::File::setCompression(COMPRESS_ZIP | COMPRESS_ACTIVE_MASK))"
        ));
    }
    if compression & !(COMPRESS_ZIP | COMPRESS_ACTIVE_MASK) != 0 {
        return Err(format!("grid \"{name}\": unknown compression flags {compression:#x}"));
    }
    skip_metadata(&mut r)?;
    let index_to_world = transform(&mut r)?;
    let mut tree = Tree::default();
    if r.u32()? != 1 {
        return Err(format!("grid \"{name}\": a tree with more than one buffer (not supported)"));
    }
    read_root_topology(&mut r, &mut tree, compression, half)?;
    r.seek(block_pos)?;
    // values inflate: count what the leaves will hold before reading them
    crate::limits::check_memory(Some(tree.leaves.len() as u64 * 512 * 4), || {
        format!("grid \"{name}\"'s {} leaves", tree.leaves.len())
    })?;
    let values = Values {
        compression,
        half,
        background: tree.background,
    };
    for leaf in &mut tree.leaves {
        let mask = Mask::load(&mut r, 512)?;
        leaf.values = values.read(&mut r, 512, &mask)?;
    }
    densify(&tree, &index_to_world, name)
}

/// The file's bytes and where reading is.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: u64) -> Result<&'a [u8], String> {
        let left = (self.bytes.len() - self.pos) as u64;
        if n > left {
            return Err(format!("truncated: {n} bytes wanted at byte {}, {left} left", self.pos));
        }
        let s = &self.bytes[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(s)
    }
    fn skip(&mut self, n: u64) -> Result<(), String> {
        self.take(n).map(|_| ())
    }
    fn seek(&mut self, pos: u64) -> Result<(), String> {
        if pos > self.bytes.len() as u64 {
            return Err(format!("an offset ({pos}) past the end of the file ({} bytes)", self.bytes.len()));
        }
        self.pos = pos as usize;
        Ok(())
    }
    fn array<const N: usize>(&mut self) -> Result<[u8; N], String> {
        Ok(self.take(N as u64)?.try_into().expect("N bytes"))
    }
    fn u8(&mut self) -> Result<u8, String> {
        Ok(self.array::<1>()?[0])
    }
    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    fn i32(&mut self) -> Result<i32, String> {
        Ok(i32::from_le_bytes(self.array()?))
    }
    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.array()?))
    }
    fn f32(&mut self) -> Result<f32, String> {
        Ok(f32::from_le_bytes(self.array()?))
    }
    fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.array()?))
    }
    fn string(&mut self) -> Result<String, String> {
        let n = self.u32()?;
        Ok(String::from_utf8_lossy(self.take(n as u64)?).into_owned())
    }
    fn coord(&mut self) -> Result<[i64; 3], String> {
        Ok([self.i32()? as i64, self.i32()? as i64, self.i32()? as i64])
    }
}

fn skip_metadata(r: &mut Cursor) -> Result<(), String> {
    let n = r.u32()?;
    for _ in 0..n {
        r.string()?; // name
        r.string()?; // type
        let size = r.u32()?;
        r.skip(size as u64)?;
    }
    Ok(())
}

/// The grid's index-to-world map (the linear ones; a frustum map is refused).
fn transform(r: &mut Cursor) -> Result<Mat4, String> {
    let ty = r.string()?;
    let vec3 = |r: &mut Cursor| -> Result<Vec3, String> { Ok(Vec3::new(r.f64()? as f32, r.f64()? as f32, r.f64()? as f32)) };
    let m = match ty.as_str() {
        "ScaleMap" | "UniformScaleMap" => {
            let scale = vec3(r)?;
            r.skip(4 * 24)?; // voxel size, inverse scale, 1/scale², 1/(2 scale)
            Mat4::from_scale(scale)
        }
        "ScaleTranslateMap" | "UniformScaleTranslateMap" => {
            let (translation, scale) = (vec3(r)?, vec3(r)?);
            r.skip(4 * 24)?;
            Mat4::from_translation(translation) * Mat4::from_scale(scale)
        }
        "TranslationMap" => Mat4::from_translation(vec3(r)?),
        // OpenVDB's matrices act on row vectors: its rows are glam's columns
        "AffineMap" | "UnitaryMap" => {
            let mut m = [0.0f32; 16];
            for v in &mut m {
                *v = r.f64()? as f32;
            }
            Mat4::from_cols_array(&m)
        }
        other => {
            return Err(format!(
                "a {} transform (rdr reads linear maps, not frustums)",
                crate::limits::sanitize(other)
            ))
        }
    };
    super::check_affine(&m).map_err(|e| format!("the grid's transform {e}"))?;
    Ok(m)
}

/// A node mask: bit `i` of word `i / 64`.
struct Mask(Vec<u64>);

impl Mask {
    fn load(r: &mut Cursor, bits: usize) -> Result<Mask, String> {
        let bytes = r.take(bits as u64 / 8)?;
        Ok(Mask(
            bytes
                .chunks_exact(8)
                .map(|c| u64::from_le_bytes(c.try_into().expect("8")))
                .collect(),
        ))
    }
    fn on(&self, i: usize) -> bool {
        self.0[i >> 6] >> (i & 63) & 1 != 0
    }
    fn count(&self) -> usize {
        self.0.iter().map(|w| w.count_ones() as usize).sum()
    }
}

/// How a grid's value arrays are stored.
struct Values {
    compression: u32,
    half: bool,
    background: f32,
}

impl Values {
    /// `count` values of a node whose value mask is `mask` (OpenVDB's
    /// `readCompressedValues`).
    fn read(&self, r: &mut Cursor, count: usize, mask: &Mask) -> Result<Vec<f32>, String> {
        let meta = r.u8()?;
        if meta > 6 {
            return Err(format!("unknown value-mask code {meta} at byte {}", r.pos - 1));
        }
        let mut inactive1 = self.background;
        let mut inactive0 = if meta == 0 { self.background } else { -self.background };
        if matches!(meta, 2 | 4 | 5) {
            // stored as full floats even in a half-float grid
            inactive0 = r.f32()?;
            if meta == 5 {
                inactive1 = r.f32()?;
            }
        }
        let selection = if matches!(meta, 3..=5) { Some(Mask::load(r, count)?) } else { None };
        let masked = self.compression & COMPRESS_ACTIVE_MASK != 0 && meta != 6;
        let stored = if masked { mask.count() } else { count };
        let size = if self.half { 2 } else { 4 };
        // OpenVDB's half reader reads nothing at all for no values (not even a chunk size)
        let raw = if self.half && stored == 0 {
            Vec::new()
        } else {
            self.bytes(r, stored * size)?
        };
        let decode = |c: &[u8]| {
            if self.half {
                half_to_f32(u16::from_le_bytes([c[0], c[1]]))
            } else {
                f32::from_le_bytes([c[0], c[1], c[2], c[3]])
            }
        };
        let mut read = raw.chunks_exact(size).map(decode);
        if stored == count {
            return Ok(read.collect());
        }
        Ok((0..count)
            .map(|i| {
                if mask.on(i) {
                    read.next().unwrap_or(0.0)
                } else if selection.as_ref().is_some_and(|s| s.on(i)) {
                    inactive1
                } else {
                    inactive0
                }
            })
            .collect())
    }

    /// `n` bytes of values, inflated when the grid is zlib-compressed (a chunk of
    /// negative size is stored as it is, as OpenVDB writes what does not compress).
    fn bytes(&self, r: &mut Cursor, n: usize) -> Result<Vec<u8>, String> {
        if self.compression & COMPRESS_ZIP == 0 {
            return Ok(r.take(n as u64)?.to_vec());
        }
        let at = r.pos;
        let size = r.u64()? as i64;
        if size <= 0 {
            if size.unsigned_abs() != n as u64 {
                return Err(format!(
                    "a stored chunk of {} bytes at byte {at}, {n} expected",
                    size.unsigned_abs()
                ));
            }
            return Ok(r.take(n as u64)?.to_vec());
        }
        let zipped = r.take(size as u64)?;
        let mut out = vec![0u8; n];
        let mut z = flate2::read::ZlibDecoder::new(zipped);
        z.read_exact(&mut out)
            .map_err(|e| format!("a zlib chunk at byte {at} does not inflate to {n} bytes: {e}"))?;
        Ok(out)
    }
}

/// IEEE 754 half to float.
fn half_to_f32(h: u16) -> f32 {
    let (sign, exp, frac) = ((h >> 15) as u32, ((h >> 10) & 0x1f) as u32, (h & 0x3ff) as u32);
    let magnitude = match exp {
        0 => frac as f32 * (1.0 / (1 << 24) as f32),
        31 if frac == 0 => f32::INFINITY,
        31 => f32::NAN,
        _ => f32::from_bits((exp + 112) << 23 | frac << 13),
    };
    if sign == 1 {
        -magnitude
    } else {
        magnitude
    }
}

#[derive(Default)]
struct Tree {
    background: f32,
    /// Constant regions: the lowest corner, the edge length, the value, active.
    tiles: Vec<([i64; 3], i64, f32, bool)>,
    leaves: Vec<Leaf>,
}

struct Leaf {
    origin: [i64; 3],
    active: Mask,
    values: Vec<f32>,
}

fn read_root_topology(r: &mut Cursor, tree: &mut Tree, compression: u32, half: bool) -> Result<(), String> {
    tree.background = r.f32()?;
    let (tiles, children) = (r.u32()?, r.u32()?);
    for _ in 0..tiles {
        let origin = r.coord()?;
        let value = r.f32()?;
        let active = r.u8()? != 0;
        tree.tiles.push((origin, 1 << 12, value, active));
    }
    let values = Values {
        compression,
        half,
        background: tree.background,
    };
    for _ in 0..children {
        let origin = r.coord()?;
        read_internal(r, tree, &values, origin, 5)?;
    }
    Ok(())
}

/// An internal node with `2^log2` children per axis (5, then 4): its tiles, then its
/// children in index order.
fn read_internal(r: &mut Cursor, tree: &mut Tree, values: &Values, origin: [i64; 3], log2: u32) -> Result<(), String> {
    let child_log2 = if log2 == 5 { 7 } else { 3 };
    let n = 1usize << (3 * log2);
    let children = Mask::load(r, n)?;
    let active = Mask::load(r, n)?;
    let tile = values.read(r, n, &active)?;
    let dim = 1usize << log2;
    let at = |i: usize| {
        let l = [i >> (2 * log2), (i >> log2) & (dim - 1), i & (dim - 1)];
        [0, 1, 2].map(|a| origin[a] + ((l[a] as i64) << child_log2))
    };
    for (i, &v) in tile.iter().enumerate() {
        if !children.on(i) && (v != tree.background || active.on(i)) {
            tree.tiles.push((at(i), 1 << child_log2, v, active.on(i)));
        }
    }
    let tile_bytes = std::mem::size_of::<([i64; 3], i64, f32, bool)>() as u64;
    crate::limits::check_memory(Some(tree.tiles.len() as u64 * tile_bytes), || format!("{} tiles", tree.tiles.len()))?;
    for i in (0..n).filter(|&i| children.on(i)) {
        if log2 == 5 {
            read_internal(r, tree, values, at(i), 4)?;
        } else {
            tree.leaves.push(Leaf {
                origin: at(i),
                active: Mask::load(r, 512)?,
                values: Vec::new(),
            });
        }
    }
    Ok(())
}

/// The tree's values on the box of its active voxels and tiles grown by one voxel,
/// placed by `index_to_world` (voxel `i` of the box is OpenVDB's `lo + i`).
fn densify(tree: &Tree, index_to_world: &Mat4, name: &str) -> Result<VdbGrid, String> {
    let (mut lo, mut hi) = ([i64::MAX; 3], [i64::MIN; 3]);
    let mut grow = |a: [i64; 3], b: [i64; 3]| {
        for k in 0..3 {
            lo[k] = lo[k].min(a[k]);
            hi[k] = hi[k].max(b[k]);
        }
    };
    for &(o, size, _, active) in &tree.tiles {
        if active {
            grow(o, o.map(|c| c + size - 1));
        }
    }
    for leaf in &tree.leaves {
        for i in (0..512).filter(|&i| leaf.active.on(i)) {
            let p = voxel(leaf.origin, i);
            grow(p, p);
        }
    }
    if lo[0] > hi[0] {
        return Err(format!("grid \"{name}\" has no active voxels"));
    }
    let (lo, hi) = (lo.map(|c| c - 1), hi.map(|c| c + 1));
    let res = [0, 1, 2].map(|k| (hi[k] - lo[k] + 1) as u64);
    let count = res[0].checked_mul(res[1]).and_then(|n| n.checked_mul(res[2]));
    crate::limits::check_memory(count.and_then(|n| n.checked_mul(4)), || {
        format!("grid \"{name}\" made dense ({}×{}×{} voxels)", res[0], res[1], res[2])
    })?;
    let res = res.map(|n| n as usize);
    let mut dense = vec![tree.background; res[0] * res[1] * res[2]];
    let index = |p: [i64; 3]| -> Option<usize> {
        let l = [0, 1, 2].map(|k| p[k] - lo[k]);
        (0..3)
            .all(|k| l[k] >= 0 && l[k] < res[k] as i64)
            .then(|| (l[2] as usize * res[1] + l[1] as usize) * res[0] + l[0] as usize)
    };
    // a valid tree's tiles do not overlap: more filling than the box holds is a damaged
    // file, refused before it can take long
    let mut filled = 0u64;
    for &(o, size, v, _) in &tree.tiles {
        let (a, b) = ([0, 1, 2].map(|k| o[k].max(lo[k])), [0, 1, 2].map(|k| (o[k] + size - 1).min(hi[k])));
        filled += (0..3).map(|k| (b[k] - a[k] + 1).max(0) as u64).product::<u64>();
        if filled > dense.len() as u64 {
            return Err(format!("grid \"{name}\": tiles that overlap (a damaged file)"));
        }
        for z in a[2]..=b[2] {
            for y in a[1]..=b[1] {
                for x in a[0]..=b[0] {
                    dense[index([x, y, z]).expect("inside")] = v;
                }
            }
        }
    }
    for leaf in &tree.leaves {
        for (i, &v) in leaf.values.iter().enumerate() {
            if let Some(d) = index(voxel(leaf.origin, i)) {
                dense[d] = v;
            }
        }
    }
    if let Some(bad) = dense.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
        let p = [bad % res[0], (bad / res[0]) % res[1], bad / (res[0] * res[1])];
        let at = [0, 1, 2].map(|k| lo[k] + p[k] as i64);
        return Err(format!(
            "grid \"{name}\": voxel ({}, {}, {}) holds {} (values must be finite and not negative)",
            at[0], at[1], at[2], dense[bad]
        ));
    }
    let lo_f = Vec3::new(lo[0] as f32, lo[1] as f32, lo[2] as f32) - Vec3::splat(0.5);
    let size = Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
    let data = GridData::new(res, 1, Aabb::new(lo_f, lo_f + size), dense)?;
    Ok(VdbGrid {
        data,
        to_world: *index_to_world * Mat4::from_translation(lo_f) * Mat4::from_scale(size),
    })
}

/// OpenVDB index of voxel `i` of the leaf at `origin`.
fn voxel(origin: [i64; 3], i: usize) -> [i64; 3] {
    [
        origin[0] + (i >> 6) as i64,
        origin[1] + ((i >> 3) & 7) as i64,
        origin[2] + (i & 7) as i64,
    ]
}
