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
    /// The per-vertex values a PLY file gives (one per position) and the per-face ones
    /// (one per triangle), named as Mitsuba names them ([`super::ply`]).
    pub attributes: Vec<super::attribute::MeshAttribute>,
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

/// Parses OBJ text (see [`parse_bytes`]).
pub fn parse(text: &str) -> Result<ObjData, ObjError> {
    parse_bytes(text.as_bytes())
}

/// Parses OBJ bytes as [`parse_reference`] parses their lossy UTF-8 decoding, with
/// the same result and errors, several times faster: lines of ASCII (all of any
/// real file) are read byte by byte, numbers through a fast path; other lines go
/// through the decoding and Unicode whitespace as before.
pub fn parse_bytes(bytes: &[u8]) -> Result<ObjData, ObjError> {
    let mut p = Reader::default();
    let mut pos = 0;
    let mut line = 0;
    while pos < bytes.len() {
        line += 1;
        let mut words = AsciiWords {
            s: bytes,
            pos,
            bailed: false,
        };
        let done = p.statement(&mut words, line)?;
        let from = if done { words.pos } else { pos };
        let end = bytes[from..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| from + i);
        if !done {
            // a word with a byte past ASCII: the line as decoded text. An ASCII
            // byte ('\n') ends any invalid sequence, so the line decodes as it does
            // inside the whole text.
            let text = String::from_utf8_lossy(&bytes[pos..end]);
            let content = text.split('#').next().unwrap_or("");
            p.statement(&mut StrWords(content.split_whitespace()), line)?;
        }
        pos = end + 1;
    }
    Ok(p.finish())
}

/// Words of a statement.
trait Words<'a> {
    fn word(&mut self) -> Option<&'a [u8]>;
    /// The next word if it is a plain decimal ([`scan_plain_f64`]) finite as an f32,
    /// read in the same pass; otherwise None and nothing consumed.
    #[inline]
    fn plain_number(&mut self) -> Option<f32> {
        None
    }
    /// The next word if it is a plain corner ([`scan_corner`]), read in the same pass; otherwise
    /// None and nothing consumed.
    #[inline]
    fn plain_corner(&mut self, _lens: [usize; 3]) -> Option<Corner> {
        None
    }
    /// The line has a word this reader cannot split (the statement must be reread).
    fn bailed(&self) -> bool;
}

/// Words of a `str` line (the reference's splitting).
struct StrWords<'a>(std::str::SplitWhitespace<'a>);

impl<'a> Words<'a> for StrWords<'a> {
    fn word(&mut self) -> Option<&'a [u8]> {
        self.0.next().map(str::as_bytes)
    }
    fn bailed(&self) -> bool {
        false
    }
}

/// Byte classes of the ASCII reader: 1 whitespace (Unicode White_Space within ASCII,
/// vertical tab included), 2 the end of the statement ('\n', '#'), 3 past ASCII.
const CLASS: [u8; 256] = {
    let mut c = [0u8; 256];
    let mut i = 0;
    while i < 256 {
        c[i] = match i as u8 {
            b' ' | b'\t' | b'\r' | 0x0b | 0x0c => 1,
            b'\n' | b'#' => 2,
            0x80..=0xff => 3,
            _ => 0,
        };
        i += 1;
    }
    c
};

/// Words of the statement at `pos` in the whole text, as `str::split_whitespace`
/// splits the line's text before any '#': it ends at the next word past ASCII
/// (`bailed`), since Unicode whitespace inside it could split it.
struct AsciiWords<'a> {
    s: &'a [u8],
    pos: usize,
    bailed: bool,
}

impl<'a> Words<'a> for AsciiWords<'a> {
    #[inline]
    fn word(&mut self) -> Option<&'a [u8]> {
        let s = self.s;
        let mut i = self.pos;
        while i < s.len() && CLASS[s[i] as usize] == 1 {
            i += 1;
        }
        let start = i;
        let mut high = false;
        while i < s.len() {
            let c = CLASS[s[i] as usize];
            if c == 1 || c == 2 {
                break;
            }
            high |= c == 3;
            i += 1;
        }
        self.pos = i;
        if high {
            self.bailed = true;
            return None;
        }
        (i > start).then(|| &s[start..i])
    }
    fn bailed(&self) -> bool {
        self.bailed
    }
    #[inline]
    fn plain_number(&mut self) -> Option<f32> {
        let s = self.s;
        let mut i = self.pos;
        while i < s.len() && CLASS[s[i] as usize] == 1 {
            i += 1;
        }
        let (v, end) = scan_plain_f64(s, i)?;
        let v = v as f32;
        // the word must end with the number (else the general path reads it)
        if (end < s.len() && CLASS[s[end] as usize] != 1 && CLASS[s[end] as usize] != 2) || !v.is_finite() {
            return None;
        }
        self.pos = end;
        Some(v)
    }
    #[inline]
    fn plain_corner(&mut self, lens: [usize; 3]) -> Option<Corner> {
        let s = self.s;
        let mut i = self.pos;
        while i < s.len() && CLASS[s[i] as usize] == 1 {
            i += 1;
        }
        let (c, end) = scan_corner(s, i, lens)?;
        // the word must end with the corner (else the general path reads it)
        if end < s.len() && CLASS[s[end] as usize] != 1 && CLASS[s[end] as usize] != 2 {
            return None;
        }
        self.pos = end;
        Some(c)
    }
}

/// `text` of an ASCII or UTF-8 word, for messages.
fn show(word: &[u8]) -> std::borrow::Cow<'_, str> {
    String::from_utf8_lossy(word)
}

/// A number as `str::parse::<f64>` reads it: plain decimals of up to 19 digits and
/// a power of ten up to 22 exactly (the mantissa and the power are exact f64s, so one
/// division or multiplication rounds correctly), anything else through `str::parse`.
#[inline]
fn parse_f64(w: &[u8]) -> Option<f64> {
    match scan_plain_f64(w, 0) {
        Some((v, end)) if end == w.len() => Some(v),
        _ => slow_f64(w),
    }
}

/// The plain decimal starting at `s[i]` (sign, digits, point, exponent: what
/// [`parse_f64`] reads exactly) and the position after it; None if it is not one.
#[inline(always)]
fn scan_plain_f64(s: &[u8], mut i: usize) -> Option<(f64, usize)> {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let neg = match s.get(i) {
        Some(b'-') => {
            i += 1;
            true
        }
        Some(b'+') => {
            i += 1;
            false
        }
        _ => false,
    };
    let mut m: u64 = 0;
    let mut digits = 0usize;
    let mut frac = 0i32;
    while i < s.len() && s[i].is_ascii_digit() {
        m = m.wrapping_mul(10).wrapping_add((s[i] - b'0') as u64);
        digits += 1;
        i += 1;
    }
    if i < s.len() && s[i] == b'.' {
        i += 1;
        while i < s.len() && s[i].is_ascii_digit() {
            m = m.wrapping_mul(10).wrapping_add((s[i] - b'0') as u64);
            digits += 1;
            frac += 1;
            i += 1;
        }
    }
    if digits == 0 || digits > 19 || m > (1u64 << 53) {
        return None;
    }
    let mut exp = 0i32;
    if i < s.len() && (s[i] == b'e' || s[i] == b'E') {
        let mut j = i + 1;
        let eneg = match s.get(j) {
            Some(b'-') => {
                j += 1;
                true
            }
            Some(b'+') => {
                j += 1;
                false
            }
            _ => false,
        };
        let start = j;
        while j < s.len() && s[j].is_ascii_digit() && j - start < 4 {
            exp = exp * 10 + (s[j] - b'0') as i32;
            j += 1;
        }
        if j == start {
            return None;
        }
        if eneg {
            exp = -exp;
        }
        i = j;
    }
    let e = exp - frac;
    let v = if e == 0 {
        m as f64
    } else if (1..=22).contains(&e) {
        m as f64 * POW10[e as usize]
    } else if (-22..0).contains(&e) {
        m as f64 / POW10[(-e) as usize]
    } else {
        return None;
    };
    Some((if neg { -v } else { v }, i))
}

#[cold]
fn slow_f64(w: &[u8]) -> Option<f64> {
    std::str::from_utf8(w).ok()?.parse().ok()
}

/// An index as `str::parse::<i64>` reads it (fast path for up to 18 digits).
#[inline]
fn parse_i64(w: &[u8]) -> Option<i64> {
    let (neg, body) = match w.first() {
        Some(b'-') => (true, &w[1..]),
        Some(b'+') => (false, &w[1..]),
        _ => (false, w),
    };
    if body.is_empty() || body.len() > 18 {
        return std::str::from_utf8(w).ok()?.parse().ok();
    }
    let mut v = 0i64;
    for &b in body {
        if !b.is_ascii_digit() {
            return None;
        }
        v = v * 10 + (b - b'0') as i64;
    }
    Some(if neg { -v } else { v })
}

/// `N` numbers; `None` when the words bailed out.
#[inline]
fn floats_of<'a, const N: usize>(words: &mut impl Words<'a>, line: usize, what: &str) -> Result<Option<[f32; N]>, ObjError> {
    let mut out = [0.0f32; N];
    for (i, o) in out.iter_mut().enumerate() {
        if let Some(v) = words.plain_number() {
            *o = v;
            continue;
        }
        let Some(w) = words.word() else {
            if words.bailed() {
                return Ok(None);
            }
            return Err(err(line, format!("'{what}' needs {N} numbers, found {i}")));
        };
        let v = parse_f64(w).ok_or_else(|| err(line, format!("'{what}': '{}' is not a number", show(w))))? as f32;
        if !v.is_finite() {
            return Err(err(line, format!("'{what}': '{}' is not a finite number", show(w))));
        }
        *o = v;
    }
    Ok(Some(out))
}

/// [`resolve`] on bytes.
#[inline]
fn index_of(word: &[u8], len: usize, line: usize, what: &str) -> Result<u32, ObjError> {
    let i = parse_i64(word).ok_or_else(|| err(line, format!("bad {what} index '{}'", show(word))))?;
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

/// A corner `p`, `p/t`, `p//n` or `p/t/n` of positive indices of up to 9 digits, all
/// in range, starting at `s[i]`, and the position after it; None for anything else
/// (read by the general path). The caller checks that the word ends there.
#[inline(always)]
fn scan_corner(s: &[u8], mut i: usize, lens: [usize; 3]) -> Option<(Corner, usize)> {
    let mut out = [None; 3];
    for (k, slot) in out.iter_mut().enumerate() {
        let start = i;
        let mut v = 0u32;
        while i < s.len() && s[i].is_ascii_digit() && i - start < 9 {
            v = v * 10 + (s[i] - b'0') as u32;
            i += 1;
        }
        if i > start {
            if v == 0 || v as usize > lens[k] {
                return None;
            }
            *slot = Some(v - 1);
        } else if k == 0 {
            return None;
        }
        if k == 2 || i == s.len() || s[i] != b'/' {
            break;
        }
        i += 1;
    }
    Some(((out[0]?, out[1], out[2]), i))
}

/// The fast reader's state between lines.
#[derive(Default)]
struct Reader {
    d: ObjData,
    unknown: Vec<String>,
    short_faces: usize,
    big_polygons: usize,
    corners: Vec<Corner>,
}

impl Reader {
    /// Reads one statement; false (and nothing read) when `words` bailed out.
    #[inline]
    fn statement<'a>(&mut self, words: &mut impl Words<'a>, line: usize) -> Result<bool, ObjError> {
        let Some(kw) = words.word() else { return Ok(!words.bailed()) };
        let d = &mut self.d;
        match kw {
            b"v" => {
                let Some([x, y, z]) = floats_of::<3>(words, line, "v")? else {
                    return Ok(false);
                };
                d.positions.push(Vec3::new(x, y, z));
            }
            b"vn" => {
                let Some([x, y, z]) = floats_of::<3>(words, line, "vn")? else {
                    return Ok(false);
                };
                d.normals.push(Vec3::new(x, y, z));
            }
            b"vt" => {
                let Some([u, v]) = floats_of::<2>(words, line, "vt")? else {
                    return Ok(false);
                };
                d.uvs.push(Vec2::new(u, v));
            }
            b"f" => {
                let corners = &mut self.corners;
                corners.clear();
                let lens = [d.positions.len(), d.uvs.len(), d.normals.len()];
                loop {
                    if let Some(c) = words.plain_corner(lens) {
                        corners.push(c);
                        continue;
                    }
                    let Some(w) = words.word() else { break };
                    let mut parts = w.split(|&b| b == b'/');
                    let p = index_of(parts.next().unwrap_or(b""), d.positions.len(), line, "vertex")?;
                    let t = match parts.next() {
                        Some(s) if !s.is_empty() => Some(index_of(s, d.uvs.len(), line, "texture coordinate")?),
                        _ => None,
                    };
                    let n = match parts.next() {
                        Some(s) if !s.is_empty() => Some(index_of(s, d.normals.len(), line, "normal")?),
                        _ => None,
                    };
                    corners.push((p, t, n));
                }
                if words.bailed() {
                    return Ok(false);
                }
                if corners.len() < 3 {
                    self.short_faces += 1;
                    return Ok(true);
                }
                let has_n = corners.iter().all(|c| c.2.is_some());
                let has_t = corners.iter().all(|c| c.1.is_some());
                let n = corners.len();
                let position = |k: usize| d.positions[corners[k].0 as usize];
                let quad = (n == 4).then(|| split_quad(&[0, 1, 2, 3].map(position)));
                let polygon = (n > 4 && n <= EAR_CLIP_MAX).then(|| triangulate(&(0..n).map(position).collect::<Vec<_>>()));
                let mut push = |[a, b, c]: [usize; 3]| {
                    let pick = |f: &dyn Fn(&Corner) -> u32| [f(&corners[a]), f(&corners[b]), f(&corners[c])];
                    d.triangles.push(ObjTriangle {
                        p: pick(&|c| c.0),
                        n: has_n.then(|| pick(&|c| c.2.unwrap())),
                        uv: has_t.then(|| pick(&|c| c.1.unwrap())),
                        line: line as u32,
                    });
                };
                if let Some(quad) = quad {
                    quad.into_iter().for_each(push);
                } else if let Some(polygon) = polygon {
                    polygon.into_iter().for_each(push);
                } else if n > EAR_CLIP_MAX {
                    self.big_polygons += 1;
                    (1..n - 1).for_each(|k| push([0, k, k + 1]));
                } else {
                    push([0, 1, 2]);
                }
            }
            b"mtllib" | b"usemtl" | b"o" | b"g" | b"s" | b"l" | b"p" | b"vp" => {}
            other => {
                let other = show(other);
                if !self.unknown.iter().any(|u| *u == other) {
                    self.unknown.push(other.into_owned());
                }
            }
        }
        Ok(true)
    }

    fn finish(self) -> ObjData {
        let mut d = self.d;
        if self.short_faces > 0 {
            d.warnings
                .push(format!("{} face(s) with fewer than 3 vertices skipped", self.short_faces));
        }
        if self.big_polygons > 0 {
            d.warnings.push(format!(
                "{} polygon(s) with more than {EAR_CLIP_MAX} vertices fan-triangulated (concave ones may render wrong)",
                self.big_polygons
            ));
        }
        if !self.unknown.is_empty() {
            d.warnings
                .push(format!("unknown statement(s) ignored: {}", self.unknown.join(", ")));
        }
        d
    }
}

/// The straightforward reader on decoded text: the oracle [`parse_bytes`] is tested
/// against (`tests/props_obj.rs`).
pub fn parse_reference(text: &str) -> Result<ObjData, ObjError> {
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
        4 => split_quad(&[p[0], p[1], p[2], p[3]]).to_vec(),
        _ => ear_clip(p),
    }
}

/// A quad's two triangles, split along the shorter diagonal.
#[inline]
fn split_quad(p: &[Vec3; 4]) -> [[usize; 3]; 2] {
    let d02 = p[2] - p[0];
    let d13 = p[3] - p[1];
    if d02.dot(d02) < d13.dot(d13) {
        [[0, 1, 2], [0, 2, 3]]
    } else {
        [[0, 1, 3], [1, 2, 3]]
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
