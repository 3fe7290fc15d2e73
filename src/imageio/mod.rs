//! Image files: EXR (written by hand: uncompressed or ZIP scanlines, float, half or
//! uint; read with the `exr` crate) and 8-bit sRGB PNG.

use crate::math::Vec3;
use anyhow::{bail, Context, Result};
use std::io::Write;
use std::path::Path;

/// How EXR pixels are stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExrPixels {
    Float,
    /// Half floats rounded as tinyexr does (RDR171's writer).
    HalfTinyexr,
}

/// f32 → half with tinyexr's rounding: round half away from zero (spec §5.2).
pub fn f32_to_half_tinyexr(x: f32) -> u16 {
    let u = x.to_bits();
    let sign = ((u >> 16) & 0x8000) as u16;
    let e = ((u >> 23) & 0xff) as i32;
    let m = u & 0x7f_ffff;
    if e == 0 {
        return sign; // zero or f32 subnormal
    }
    if e == 255 {
        return sign | 0x7c00 | if m != 0 { 0x200 } else { 0 };
    }
    let ne = e - 127 + 15;
    if ne >= 31 {
        return sign | 0x7c00;
    }
    if ne <= 0 {
        if 14 - ne > 24 {
            return sign;
        }
        let mm = m | 0x80_0000;
        let mut v = mm >> (14 - ne);
        if (mm >> (13 - ne)) & 1 != 0 {
            v += 1;
        }
        return sign | v as u16;
    }
    let mut o = ((ne as u32) << 10) | (m >> 13);
    if m & 0x1000 != 0 {
        o += 1; // may carry into the exponent, up to infinity
    }
    sign | o as u16
}

/// Writes an OpenEXR 2.0 single-part scanline file, uncompressed, channels B, G, R
/// (the sorted order the format requires), rows top-down.
pub fn write_exr(path: &Path, width: u32, height: u32, rgb: &[Vec3], pixels: ExrPixels) -> Result<()> {
    write_atomically(path, &encode_exr(width, height, rgb, pixels))
}

/// The bytes of the file [`write_exr`] writes.
pub fn encode_exr(width: u32, height: u32, rgb: &[Vec3], pixels: ExrPixels) -> Vec<u8> {
    assert_eq!(rgb.len(), width as usize * height as usize, "image size");
    let channels: Vec<ExrChannel> = match pixels {
        ExrPixels::Float => rgb_channels("", rgb),
        ExrPixels::HalfTinyexr => ["R", "G", "B"]
            .iter()
            .enumerate()
            .map(|(c, n)| ExrChannel {
                name: n.to_string(),
                data: ChannelData::F16(rgb.iter().map(|p| f32_to_half_tinyexr(p[c])).collect()),
            })
            .collect(),
    };
    encode_exr_channels(width, height, &channels, &[])
}

/// One channel of an EXR written by [`encode_exr_channels`]: a name and `width·height`
/// values, rows top-down.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrChannel {
    pub name: String,
    pub data: ChannelData,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ChannelData {
    F32(Vec<f32>),
    /// Raw 32-bit words (the film state keeps f64 sums as two of them).
    U32(Vec<u32>),
    /// Half floats as bit patterns (RDR171's images).
    F16(Vec<u16>),
}

impl ChannelData {
    fn len(&self) -> usize {
        match self {
            ChannelData::F32(v) => v.len(),
            ChannelData::U32(v) => v.len(),
            ChannelData::F16(v) => v.len(),
        }
    }

    /// The EXR pixel type (0 uint, 1 half, 2 float) and its size in bytes.
    fn pixel_type(&self) -> (i32, usize) {
        match self {
            ChannelData::U32(_) => (0, 4),
            ChannelData::F16(_) => (1, 2),
            ChannelData::F32(_) => (2, 4),
        }
    }
}

/// An extra header attribute: name, EXR type name and its value's bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrAttribute {
    pub name: String,
    pub kind: String,
    pub value: Vec<u8>,
}

impl ExrAttribute {
    /// A `string` attribute.
    pub fn text(name: &str, value: &str) -> ExrAttribute {
        ExrAttribute {
            name: name.into(),
            kind: "string".into(),
            value: value.as_bytes().to_vec(),
        }
    }

    /// The standard `chromaticities` of linear sRGB (Rec. 709 primaries, D65 white).
    pub fn chromaticities_srgb() -> ExrAttribute {
        let xy: [f32; 8] = [0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290];
        ExrAttribute {
            name: "chromaticities".into(),
            kind: "chromaticities".into(),
            value: xy.iter().flat_map(|v| v.to_le_bytes()).collect(),
        }
    }
}

/// How [`encode_exr_channels_as`] stores the pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExrCompression {
    None,
    /// OpenEXR's ZIP: blocks of 16 rows, lossless (zlib after a byte predictor).
    Zip,
}

impl ExrCompression {
    /// The header's compression byte and the rows per block.
    fn code_and_rows(self) -> (u8, usize) {
        match self {
            ExrCompression::None => (0, 1),
            ExrCompression::Zip => (3, 16),
        }
    }
}

/// An uncompressed single-part scanline EXR of any float, half and uint channels (sorted
/// by name as the format requires; `B`, `G`, `R` come before lower-case layer names)
/// and extra attributes after the required ones. With channels `B`, `G`, `R` and no
/// attributes it is byte for byte the file [`encode_exr`] writes for float pixels.
pub fn encode_exr_channels(width: u32, height: u32, channels: &[ExrChannel], attributes: &[ExrAttribute]) -> Vec<u8> {
    encode_exr_channels_as(width, height, channels, attributes, ExrCompression::None)
}

/// [`encode_exr_channels`] with the pixels stored as `compression` says.
pub fn encode_exr_channels_as(
    width: u32,
    height: u32,
    channels: &[ExrChannel],
    attributes: &[ExrAttribute],
    compression: ExrCompression,
) -> Vec<u8> {
    let (w, h) = (width as usize, height as usize);
    let (code, block_rows) = compression.code_and_rows();
    let mut order: Vec<&ExrChannel> = channels.iter().collect();
    order.sort_by(|a, b| a.name.cmp(&b.name));
    for c in &order {
        assert_eq!(c.data.len(), w * h, "channel {} size", c.name);
    }
    let mut hd: Vec<u8> = Vec::new();
    hd.extend_from_slice(&[0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0]);
    let mut attr = |name: &str, ty: &str, value: &[u8]| {
        hd.extend_from_slice(name.as_bytes());
        hd.push(0);
        hd.extend_from_slice(ty.as_bytes());
        hd.push(0);
        hd.extend_from_slice(&(value.len() as i32).to_le_bytes());
        hd.extend_from_slice(value);
    };
    let mut ch = Vec::new();
    for c in &order {
        let (ptype, _) = c.data.pixel_type();
        ch.extend_from_slice(c.name.as_bytes());
        ch.push(0);
        ch.extend_from_slice(&ptype.to_le_bytes());
        ch.extend_from_slice(&[0, 0, 0, 0]);
        ch.extend_from_slice(&1i32.to_le_bytes());
        ch.extend_from_slice(&1i32.to_le_bytes());
    }
    ch.push(0);
    let window: Vec<u8> = [0i32, 0, w as i32 - 1, h as i32 - 1].iter().flat_map(|v| v.to_le_bytes()).collect();
    attr("channels", "chlist", &ch);
    attr("compression", "compression", &[code]);
    attr("dataWindow", "box2i", &window);
    attr("displayWindow", "box2i", &window);
    attr("lineOrder", "lineOrder", &[0]);
    attr("pixelAspectRatio", "float", &1.0f32.to_le_bytes());
    attr("screenWindowCenter", "v2f", &[0u8; 8]);
    attr("screenWindowWidth", "float", &1.0f32.to_le_bytes());
    for a in attributes {
        attr(&a.name, &a.kind, &a.value);
    }
    hd.push(0);

    let line_bytes: usize = order.iter().map(|c| c.data.pixel_type().1 * w).sum();
    let mut blocks = Vec::with_capacity(h.div_ceil(block_rows));
    for y0 in (0..h).step_by(block_rows) {
        let mut raw = Vec::with_capacity(line_bytes * block_rows);
        for y in y0..(y0 + block_rows).min(h) {
            for c in &order {
                match &c.data {
                    ChannelData::F32(v) => v[y * w..(y + 1) * w].iter().for_each(|x| raw.extend_from_slice(&x.to_le_bytes())),
                    ChannelData::U32(v) => v[y * w..(y + 1) * w].iter().for_each(|x| raw.extend_from_slice(&x.to_le_bytes())),
                    ChannelData::F16(v) => v[y * w..(y + 1) * w].iter().for_each(|x| raw.extend_from_slice(&x.to_le_bytes())),
                }
            }
        }
        blocks.push(match compression {
            ExrCompression::None => raw,
            ExrCompression::Zip => zip_block(raw),
        });
    }
    let mut out = Vec::with_capacity(hd.len() + 8 * blocks.len() + blocks.iter().map(|b| 8 + b.len()).sum::<usize>());
    out.extend_from_slice(&hd);
    let mut at = (hd.len() + 8 * blocks.len()) as u64;
    for b in &blocks {
        out.extend_from_slice(&at.to_le_bytes());
        at += 8 + b.len() as u64;
    }
    for (i, b) in blocks.iter().enumerate() {
        out.extend_from_slice(&((i * block_rows) as i32).to_le_bytes());
        out.extend_from_slice(&(b.len() as i32).to_le_bytes());
        out.extend_from_slice(b);
    }
    out
}

/// One block as OpenEXR's ZIP stores it: the even-indexed bytes, then the odd ones,
/// each as its difference to the byte before (+128, mod 256), deflated. A block that
/// would not shrink is stored as it is (readers tell by its size).
fn zip_block(raw: Vec<u8>) -> Vec<u8> {
    let mut t: Vec<u8> = raw.iter().step_by(2).chain(raw.iter().skip(1).step_by(2)).copied().collect();
    for i in (1..t.len()).rev() {
        t[i] = t[i].wrapping_sub(t[i - 1]).wrapping_add(128);
    }
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::new(6));
    let packed = z.write_all(&t).and_then(|_| z.finish()).expect("deflate into memory");
    if packed.len() < raw.len() {
        packed
    } else {
        raw
    }
}

/// [`zip_block`] undone: `data` expands to exactly `size` bytes, or it is an error.
fn unzip_block(data: &[u8], size: usize) -> std::result::Result<Vec<u8>, String> {
    use std::io::Read;
    if data.len() == size {
        return Ok(data.to_vec());
    }
    let mut t = Vec::with_capacity(size);
    flate2::read::ZlibDecoder::new(data)
        .take(size as u64 + 1)
        .read_to_end(&mut t)
        .map_err(|e| format!("a compressed block is corrupt ({e})"))?;
    if t.len() != size {
        return Err(format!("a compressed block holds {} bytes, not {size}", t.len()));
    }
    for i in 1..t.len() {
        t[i] = t[i].wrapping_add(t[i - 1]).wrapping_sub(128);
    }
    let half = size.div_ceil(2);
    let mut raw = vec![0u8; size];
    for (i, r) in raw.iter_mut().enumerate() {
        *r = if i % 2 == 0 { t[i / 2] } else { t[half + i / 2] };
    }
    Ok(raw)
}

/// The B, G, R float channels of an image (rows top-down).
pub fn rgb_channels(prefix: &str, rgb: &[Vec3]) -> Vec<ExrChannel> {
    ["R", "G", "B"]
        .iter()
        .enumerate()
        .map(|(c, n)| ExrChannel {
            name: format!("{prefix}{n}"),
            data: ChannelData::F32(rgb.iter().map(|p| p[c]).collect()),
        })
        .collect()
}

/// An EXR as [`encode_exr_channels`] writes it, read back: its size, attributes and
/// channels (float channels as their bit patterns).
#[derive(Clone, Debug)]
pub struct RawExr {
    pub width: u32,
    pub height: u32,
    pub attributes: Vec<ExrAttribute>,
    pub channels: Vec<ExrChannel>,
}

impl RawExr {
    pub fn attribute(&self, name: &str) -> Option<&ExrAttribute> {
        self.attributes.iter().find(|a| a.name == name)
    }

    /// A `string` attribute's text.
    pub fn text(&self, name: &str) -> Option<String> {
        let a = self.attribute(name)?;
        (a.kind == "string").then(|| String::from_utf8_lossy(&a.value).into_owned())
    }

    pub fn channel(&self, name: &str) -> Option<&ChannelData> {
        self.channels.iter().find(|c| c.name == name).map(|c| &c.data)
    }
}

/// Reads an EXR that [`encode_exr_channels_as`] wrote (single-part scanlines,
/// uncompressed or ZIP, float, half and uint channels); anything else is an error
/// naming the file.
pub fn read_exr_channels(path: &Path) -> Result<RawExr> {
    let bytes = read_input(path)?;
    decode_exr_channels(&bytes).map_err(|m| anyhow::anyhow!("{}: {m}", path.display()))
}

/// [`read_exr_channels`] on the file's bytes (the error without the file's name).
pub fn decode_exr_channels(b: &[u8]) -> std::result::Result<RawExr, String> {
    let bad = || "not a single-part EXR as rdr writes it (uncompressed or ZIP scanlines)".to_string();
    if b.len() < 8 || b[..4] != [0x76, 0x2f, 0x31, 0x01] || b[4] != 2 || b[5..8] != [0, 0, 0] {
        return Err(bad());
    }
    let mut at = 8usize;
    let cstr = |at: &mut usize| -> std::result::Result<String, String> {
        let end = b[*at..].iter().position(|&c| c == 0).ok_or_else(bad)? + *at;
        let s = String::from_utf8_lossy(&b[*at..end]).into_owned();
        *at = end + 1;
        Ok(s)
    };
    let mut attributes = Vec::new();
    loop {
        if *b.get(at).ok_or_else(bad)? == 0 {
            at += 1;
            break;
        }
        let name = cstr(&mut at)?;
        let kind = cstr(&mut at)?;
        let size = i32::from_le_bytes(b.get(at..at + 4).ok_or_else(bad)?.try_into().unwrap());
        at += 4;
        let size = usize::try_from(size).map_err(|_| bad())?;
        let value = b.get(at..at + size).ok_or_else(bad)?.to_vec();
        at += size;
        attributes.push(ExrAttribute { name, kind, value });
    }
    let get = |n: &str| attributes.iter().find(|a| a.name == n).map(|a| a.value.clone());
    let compression = match get("compression").as_deref() {
        Some([0]) => ExrCompression::None,
        Some([3]) => ExrCompression::Zip,
        _ => return Err(bad()),
    };
    let block_rows = compression.code_and_rows().1;
    let window = get("dataWindow").filter(|v| v.len() == 16).ok_or_else(bad)?;
    let wi = |i: usize| i32::from_le_bytes(window[4 * i..4 * i + 4].try_into().unwrap());
    if wi(0) != 0 || wi(1) != 0 || wi(2) < 0 || wi(3) < 0 {
        return Err(bad());
    }
    let (w, h) = (wi(2) as usize + 1, wi(3) as usize + 1);
    let chlist = get("channels").ok_or_else(bad)?;
    let mut names = Vec::new();
    let mut c = 0usize;
    while c < chlist.len() && chlist[c] != 0 {
        let end = chlist[c..].iter().position(|&x| x == 0).ok_or_else(bad)? + c;
        let name = String::from_utf8_lossy(&chlist[c..end]).into_owned();
        let ptype = i32::from_le_bytes(chlist.get(end + 1..end + 5).ok_or_else(bad)?.try_into().unwrap());
        if !(0..=2).contains(&ptype) {
            return Err(bad());
        }
        names.push((name, ptype));
        c = end + 17;
    }
    // (without channels, the size checks below bound nothing)
    if names.is_empty() {
        return Err("the header lists no channels".into());
    }
    let size_of = |ptype: i32| if ptype == 1 { 2 } else { 4 };
    let line: usize = names.iter().map(|&(_, t)| size_of(t) * w).sum();
    // offsets, then per block its first row, size and data: all must be in the file
    // (compressed data expands at most 1032:1, deflate's limit)
    let blocks = h.div_ceil(block_rows) as u64;
    let least = match compression {
        ExrCompression::None => (h as u64) * (line as u64),
        ExrCompression::Zip => (h as u64) * (line as u64) / 1032,
    };
    if blocks * 16 + least + at as u64 > b.len() as u64 {
        return Err(format!("the header claims {w}x{h} pixels but the file is too short"));
    }
    let mut words: Vec<Vec<u32>> = vec![Vec::with_capacity(w * h); names.len()];
    for k in 0..blocks as usize {
        let rows = block_rows.min(h - k * block_rows);
        let size = rows * line;
        let off = u64::from_le_bytes(b[at + 8 * k..at + 8 * k + 8].try_into().unwrap()) as usize;
        let head = off.checked_add(8).and_then(|e| b.get(off..e)).ok_or_else(bad)?;
        let (first, n) = (
            i32::from_le_bytes(head[..4].try_into().unwrap()),
            i32::from_le_bytes(head[4..].try_into().unwrap()),
        );
        let n = usize::try_from(n).map_err(|_| bad())?;
        if first as i64 != (k * block_rows) as i64 || n > size {
            return Err(bad());
        }
        let data = (off + 8).checked_add(n).and_then(|e| b.get(off + 8..e)).ok_or_else(bad)?;
        let block = match compression {
            ExrCompression::None if n == size => std::borrow::Cow::Borrowed(data),
            ExrCompression::None => return Err(bad()),
            ExrCompression::Zip => std::borrow::Cow::Owned(unzip_block(data, size)?),
        };
        for row in block.chunks_exact(line.max(1)).take(rows) {
            let mut part = row;
            for (ws, &(_, ptype)) in words.iter_mut().zip(&names) {
                let (this, rest) = part.split_at(size_of(ptype) * w);
                part = rest;
                if ptype == 1 {
                    ws.extend(this.chunks_exact(2).map(|q| u16::from_le_bytes([q[0], q[1]]) as u32));
                } else {
                    ws.extend(this.chunks_exact(4).map(|q| u32::from_le_bytes(q.try_into().unwrap())));
                }
            }
        }
    }
    let channels = names
        .into_iter()
        .zip(words)
        .map(|((name, ptype), ws)| ExrChannel {
            name,
            data: match ptype {
                2 => ChannelData::F32(ws.into_iter().map(f32::from_bits).collect()),
                1 => ChannelData::F16(ws.into_iter().map(|x| x as u16).collect()),
                _ => ChannelData::U32(ws),
            },
        })
        .collect();
    Ok(RawExr {
        width: w as u32,
        height: h as u32,
        attributes,
        channels,
    })
}

/// The folder a file is written into (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."))
}

/// A new, uniquely named temporary file beside `path`, created exclusively (never an
/// existing file or a planted symbolic link), removed again when dropped.
fn temp_beside(path: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".partial");
    // an image is an ordinary file: created 0666 less the umask (as `open` creates files),
    // not tempfile's private 0600, which the rename would keep
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    builder.tempfile_in(folder_of(path))
}

/// Writes through a unique temporary file beside `path` and a rename, so a failed
/// write never leaves a truncated image (nor its temporary file) behind, and two
/// writers of one path never mix their bytes: the file is always one of them whole.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let fail = |e: std::io::Error| anyhow::anyhow!("cannot write {}: {e}", path.display());
    let mut tmp = temp_beside(path).map_err(fail)?;
    tmp.write_all(bytes).map_err(fail)?;
    tmp.as_file().sync_data().map_err(fail)?;
    tmp.persist(path).map_err(|e| fail(e.error))?;
    Ok(())
}

/// Saves `bytes` (an image whose real output could not be written) as a new file in
/// the system's temporary folder, named after `path`, and returns where.
pub fn save_elsewhere(path: &Path, bytes: &[u8]) -> Result<std::path::PathBuf> {
    let stem = path
        .file_stem()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "image".into());
    let ext = path
        .extension()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "exr".into());
    let mut f = tempfile::Builder::new()
        .prefix(&format!("rdr-{stem}-"))
        .suffix(&format!(".{ext}"))
        .tempfile()
        .context("cannot create a file in the temporary folder")?;
    f.write_all(bytes).context("cannot write to the temporary folder")?;
    let (_, kept) = f.keep().context("cannot keep the file in the temporary folder")?;
    Ok(kept)
}

/// Linear → sRGB-encoded 8 bit, clamped.
pub fn linear_to_srgb8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[Vec3]) -> Result<()> {
    let buf = encode_png(width, height, rgb).with_context(|| format!("cannot encode {}", path.display()))?;
    write_atomically(path, &buf)
}

/// The bytes of the file [`write_png`] writes.
pub fn encode_png(width: u32, height: u32, rgb: &[Vec3]) -> Result<Vec<u8>> {
    let bytes: Vec<u8> = rgb
        .iter()
        .flat_map(|p| [linear_to_srgb8(p.x), linear_to_srgb8(p.y), linear_to_srgb8(p.z)])
        .collect();
    let mut buf = std::io::Cursor::new(Vec::new());
    image::write_buffer_with_format(
        &mut buf,
        &bytes,
        width,
        height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )?;
    Ok(buf.into_inner())
}

/// Checks, before rendering, that `path` can be written by [`write_image`]: a
/// supported extension, an existing folder we may create files in (a probe
/// temporary file is made and removed), and no folder of that name.
pub fn check_output_path(path: &Path) -> Result<()> {
    output_format(path)?;
    let dir = folder_of(path);
    if !dir.is_dir() {
        bail!("{}: cannot write: folder {} does not exist", path.display(), dir.display());
    }
    if path.is_dir() {
        bail!("{}: cannot write: it is a folder", path.display());
    }
    if let Ok(m) = std::fs::symlink_metadata(path) {
        if !m.is_file() && !m.file_type().is_symlink() {
            bail!("{}: cannot write: it exists and is not a regular file", path.display());
        }
    }
    temp_beside(path).map_err(|e| anyhow::anyhow!("{}: cannot write in folder {}: {e}", path.display(), dir.display()))?;
    Ok(())
}

/// `"exr"` or `"png"`, from the file extension.
fn output_format(path: &Path) -> Result<&'static str> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("exr") => Ok("exr"),
        Some("png") => Ok("png"),
        _ => bail!("{}: unsupported output format (use .exr or .png)", path.display()),
    }
}

/// Output format from the file extension: `.exr` or `.png`.
pub fn write_image(path: &Path, width: u32, height: u32, rgb: &[Vec3], exr: ExrPixels) -> Result<()> {
    write_atomically(path, &encode_image(path, width, height, rgb, exr)?)
}

/// The bytes of the file [`write_image`] writes to `path`.
pub fn encode_image(path: &Path, width: u32, height: u32, rgb: &[Vec3], exr: ExrPixels) -> Result<Vec<u8>> {
    match output_format(path)? {
        "exr" => Ok(encode_exr(width, height, rgb, exr)),
        _ => encode_png(width, height, rgb).with_context(|| format!("cannot encode {}", path.display())),
    }
}

/// An RGB image read from an EXR file (any compression the `exr` crate reads).
#[derive(Clone, Debug)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    /// Row 0 = top.
    pub pixels: Vec<Vec3>,
}

impl RgbImage {
    pub fn at(&self, x: usize, y: usize) -> Vec3 {
        self.pixels[y * self.width + x]
    }
}

/// Reads an EXR file (a regular file of a sane size, its header checked against the
/// file's size and the memory budget before any pixel is allocated).
pub fn read_exr(path: &Path) -> Result<RgbImage> {
    let bytes = read_input(path)?;
    decode_exr(&bytes, path, 12)
}

/// A whole input image file, after checking it is a regular file within the budget.
fn read_input(path: &Path) -> Result<Vec<u8>> {
    crate::limits::read_input_file(path, crate::limits::memory_budget()).map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))
}

/// Checks an EXR's header before decoding: every part's offset table (8 bytes a
/// chunk, always stored) must fit in the file, and `bytes_per_pixel` of the caller's
/// plus the decoder's own 16 per pixel of the largest part must fit the memory budget.
fn check_exr_header(bytes: &[u8], name: &Path) -> Result<()> {
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", name.display()))?;
    for h in meta.headers.iter() {
        let (w, ht) = (h.layer_size.width() as u64, h.layer_size.height() as u64);
        // Decompressed, a chunk is at most so many times its stored bytes (deflate's limit
        // is 1032:1, PIZ's run-length Huffman about 450:1, RLE 64:1, B44A 11:1): a header
        // claiming more samples than the whole file could expand to lies, and is refused
        // before the pixels it claims are allocated.
        let ratio: u64 = if matches!(h.compression, exr::compression::Compression::Uncompressed) {
            1
        } else {
            4096
        };
        let samples: u64 = h
            .channels
            .list
            .iter()
            .map(|c| {
                let (sx, sy) = (c.sampling.x().max(1) as u64, c.sampling.y().max(1) as u64);
                ((w / sx).saturating_mul(ht / sy)).saturating_mul(c.sample_type.bytes_per_sample() as u64)
            })
            .fold(w.saturating_mul(ht), u64::max);
        if samples > (bytes.len() as u64).saturating_mul(ratio) {
            bail!(
                "cannot read {}: the header claims {w}x{ht} pixels, more than its {} bytes can hold",
                name.display(),
                bytes.len()
            );
        }
        let table = (h.chunk_count as u64).checked_mul(8);
        if table.is_none_or(|t| t > bytes.len() as u64) {
            bail!(
                "cannot read {}: the header claims {w}x{ht} pixels ({} chunks) but the file has only {} bytes",
                name.display(),
                h.chunk_count,
                bytes.len()
            );
        }
    }
    Ok(())
}

/// Decodes EXR bytes (`name` is only for messages); `bytes_per_pixel` is what the
/// caller keeps per pixel afterwards, for the memory check.
pub fn decode_exr(bytes: &[u8], name: &Path, bytes_per_pixel: u64) -> Result<RgbImage> {
    use exr::prelude::*;
    check_exr_header(bytes, name)?;
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", name.display()))?;
    for h in meta.headers.iter() {
        let (w, ht) = (h.layer_size.width() as u64, h.layer_size.height() as u64);
        crate::limits::check_memory(w.checked_mul(ht).and_then(|n| n.checked_mul(bytes_per_pixel + 16)), || {
            format!("{} ({w}x{ht} pixels)", name.display())
        })
        .map_err(|m| anyhow::anyhow!("cannot read {m}"))?;
    }
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res, _| RgbImage {
                width: res.width(),
                height: res.height(),
                pixels: vec![Vec3::ZERO; res.width() * res.height()],
            },
            |img: &mut RgbImage, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let w = img.width;
                img.pixels[pos.y() * w + pos.x()] = Vec3::new(r, g, b);
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        // the exr error shows its I/O cause in its own message: keep it flat, not chained
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", name.display()))?;
    Ok(img.layer_data.channel_data.pixels)
}

/// The raw half bit patterns of an EXR's R, G, B channels, for bit-exact tests.
pub fn read_exr_half_bits(path: &Path) -> Result<(usize, usize, Vec<[u16; 3]>)> {
    let img = read_exr(path)?;
    let bits = img
        .pixels
        .iter()
        .map(|p| [0, 1, 2].map(|c| exr::prelude::f16::from_f32(p[c]).to_bits()))
        .collect();
    Ok((img.width, img.height, bits))
}

/// sRGB-encoded value in [0, 1] → linear.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Reads a texture or environment image as linear RGB, row 0 = top of the file.
/// EXR (any compression the `exr` crate reads, DWAA included), Radiance HDR and PFM
/// are linear already; PNG, JPEG, BMP, TGA and PPM/PGM are decoded from sRGB (as
/// Mitsuba's bitmap does for 8- and 16-bit images). Alpha is dropped.
pub fn read_texture_image(path: &Path) -> Result<RgbImage> {
    decode_texture_image(&read_input(path)?, path)
}

/// [`read_texture_image`], PNG and JPEG read `raw` if asked ([`decode_texture_image_as`]).
pub fn read_texture_image_as(path: &Path, raw: bool) -> Result<RgbImage> {
    decode_texture_image_as(&read_input(path)?, path, raw)
}

/// Bytes a texture keeps per pixel after decoding: linear RGB and its MIP pyramid.
const TEXTURE_BYTES_PER_PIXEL: u64 = 12 + 16;

/// [`read_texture_image`] of bytes already read; `path` gives the format (its
/// extension, unless the content says otherwise) and names the file in messages.
pub fn decode_texture_image(bytes: &[u8], path: &Path) -> Result<RgbImage> {
    decode_texture_image_as(bytes, path, false)
}

/// The most pixels a compressed texture file may claim per byte of the file.
const MAX_PIXELS_PER_BYTE: u64 = 32_768;

/// [`decode_texture_image`], with PNG and JPEG values taken as they are (`raw`, as
/// Mitsuba's bitmap `raw`: for data such as normal or roughness maps) rather than
/// decoded from sRGB.
pub fn decode_texture_image_as(bytes: &[u8], path: &Path, raw: bool) -> Result<RgbImage> {
    let img = decode_texture_texels(bytes, path, raw)?;
    let pixels = match img.texels {
        TexelData::Linear(p) => p,
        TexelData::Encoded8 { rgb, decode } => rgb
            .chunks_exact(3)
            .map(|p| Vec3::new(decode[p[0] as usize], decode[p[1] as usize], decode[p[2] as usize]))
            .collect(),
    };
    Ok(RgbImage {
        width: img.width,
        height: img.height,
        pixels,
    })
}

/// A texture file's texels as read: linear values, or for 8-bit files their bytes
/// and the table of the 256 linear values they stand for.
pub enum TexelData {
    Linear(Vec<Vec3>),
    /// Three bytes a pixel (RGB), rows from the top.
    Encoded8 {
        rgb: Vec<u8>,
        decode: Box<[f32; 256]>,
    },
}

/// A texture file read for a pyramid ([`decode_texture_texels`]).
pub struct TextureTexels {
    pub width: usize,
    pub height: usize,
    pub texels: TexelData,
}

/// [`read_texture_image_as`] keeping an 8-bit file's bytes ([`TexelData::Encoded8`]).
pub fn read_texture_texels(path: &Path, raw: bool) -> Result<TextureTexels> {
    decode_texture_texels(&read_input(path)?, path, raw)
}

/// [`decode_texture_image_as`] keeping an 8-bit file's bytes ([`TexelData::Encoded8`]).
pub fn decode_texture_texels(bytes: &[u8], path: &Path, raw: bool) -> Result<TextureTexels> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let as_linear = |img: RgbImage| TextureTexels {
        width: img.width,
        height: img.height,
        texels: TexelData::Linear(img.pixels),
    };
    if ext == "exr" {
        return decode_exr(bytes, path, TEXTURE_BYTES_PER_PIXEL).map(as_linear);
    }
    if ext == "pfm" {
        return decode_pfm(bytes)
            .map(as_linear)
            .map_err(|e| anyhow::anyhow!("cannot decode {}: {e}", path.display()));
    }
    let open = || -> Result<image::ImageReader<std::io::Cursor<&[u8]>>> {
        let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes));
        if let Ok(f) = image::ImageFormat::from_path(path) {
            reader.set_format(f);
        }
        reader
            .with_guessed_format()
            .with_context(|| format!("cannot read {}", path.display()))
    };
    // the size from the header first: decoded pixels (up to 16 bytes each), their
    // conversion and what the texture keeps must fit the memory budget
    // (read without the decoder's default limits, which would refuse a large header
    // here and leave the checks below to a decoder allowed the whole budget)
    let mut probe = open()?;
    probe.no_limits();
    if let Ok((w, h)) = probe.into_dimensions() {
        // no codec read here expands a byte into more than a few thousand pixels (PNG:
        // deflate's 1032:1 times 8 one-bit pixels), so a header claiming more lies
        if w as u64 * h as u64 > (bytes.len() as u64).saturating_mul(MAX_PIXELS_PER_BYTE) {
            bail!(
                "cannot read {}: the header claims {w}x{h} pixels, more than its {} bytes can hold",
                path.display(),
                bytes.len()
            );
        }
        crate::limits::check_memory((w as u64 * h as u64).checked_mul(32 + TEXTURE_BYTES_PER_PIXEL), || {
            format!("{} ({w}x{h} pixels)", path.display())
        })
        .map_err(|m| anyhow::anyhow!("cannot decode {m}"))?;
    }
    let mut reader = open()?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(crate::limits::memory_budget());
    reader.limits(limits);
    let format = reader.format();
    let img = reader
        .decode()
        .map_err(|e| anyhow::anyhow!("cannot decode {}: {e}", path.display()))?;
    let (width, height) = (img.width() as usize, img.height() as usize);
    let linear = |pixels: Vec<Vec3>| TexelData::Linear(pixels);
    let texels = match format {
        Some(image::ImageFormat::Hdr) => linear(img.into_rgb32f().pixels().map(|p| Vec3::new(p[0], p[1], p[2])).collect()),
        Some(
            image::ImageFormat::Png
            | image::ImageFormat::Jpeg
            | image::ImageFormat::Bmp
            | image::ImageFormat::Tga
            | image::ImageFormat::Pnm,
        ) => {
            let decode = |v: f32| if raw { v } else { srgb_to_linear(v) };
            match img {
                image::DynamicImage::ImageRgb16(_)
                | image::DynamicImage::ImageRgba16(_)
                | image::DynamicImage::ImageLuma16(_)
                | image::DynamicImage::ImageLumaA16(_) => linear(
                    img.into_rgb32f()
                        .pixels()
                        .map(|p| Vec3::new(decode(p[0]), decode(p[1]), decode(p[2])))
                        .collect(),
                ),
                _ => TexelData::Encoded8 {
                    rgb: img.into_rgb8().into_raw(),
                    decode: Box::new(std::array::from_fn(|i| decode(i as f32 / 255.0))),
                },
            }
        }
        other => anyhow::bail!(
            "{}: unsupported image format {:?} (use .exr, .hdr, .pfm, .png, .jpg, .bmp, .tga or .ppm)",
            path.display(),
            other
        ),
    };
    anyhow::ensure!(width > 0 && height > 0, "{}: image is empty", path.display());
    Ok(TextureTexels { width, height, texels })
}

/// A portable float map (`PF`: RGB, `Pf`: grey; a negative scale is little-endian),
/// whose rows run from the bottom up: turned to row 0 = top.
pub fn decode_pfm(bytes: &[u8]) -> std::result::Result<RgbImage, String> {
    // the header: three whitespace-separated tokens after the magic, then one byte
    let mut at = 0;
    let mut token = || -> std::result::Result<String, String> {
        while bytes.get(at).is_some_and(u8::is_ascii_whitespace) {
            at += 1;
        }
        let start = at;
        while bytes.get(at).is_some_and(|b| !b.is_ascii_whitespace()) && at - start < 32 {
            at += 1;
        }
        String::from_utf8(bytes[start..at].to_vec()).map_err(|_| "a PFM header that is not text".to_string())
    };
    let channels = match token()?.as_str() {
        "PF" => 3,
        "Pf" => 1,
        m => return Err(format!("not a PFM file (magic {m:?}, expected PF or Pf)")),
    };
    let mut number = |what: &str| token().and_then(|t| t.parse::<f64>().map_err(|_| format!("a PFM {what} of {t:?}")));
    let (w, h, scale) = (number("width")?, number("height")?, number("scale")?);
    if !(w >= 1.0 && h >= 1.0 && w.fract() == 0.0 && h.fract() == 0.0 && w <= 1e6 && h <= 1e6) || scale == 0.0 || !scale.is_finite() {
        return Err(format!("a PFM header with width {w}, height {h}, scale {scale}"));
    }
    let (w, h) = (w as usize, h as usize);
    let data = bytes.get(at + 1..).unwrap_or_default();
    let want = w * h * channels * 4;
    if data.len() < want {
        return Err(format!("{w}x{h} pixels need {want} bytes, the file has {}", data.len()));
    }
    crate::limits::check_memory((w as u64 * h as u64).checked_mul(12 + TEXTURE_BYTES_PER_PIXEL), || {
        format!("a {w}x{h} PFM")
    })?;
    let value = |i: usize| {
        let b: [u8; 4] = data[4 * i..4 * i + 4].try_into().expect("4 bytes");
        if scale < 0.0 {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        }
    };
    let mut pixels = Vec::with_capacity(w * h);
    for row in (0..h).rev() {
        for x in 0..w {
            let i = (row * w + x) * channels;
            pixels.push(match channels {
                3 => Vec3::new(value(i), value(i + 1), value(i + 2)),
                _ => Vec3::splat(value(i)),
            });
        }
    }
    Ok(RgbImage {
        width: w,
        height: h,
        pixels,
    })
}

#[cfg(test)]
mod tests;
