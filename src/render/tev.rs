//! Streams the image to the tev viewer over its TCP protocol, as pbrt-v4's
//! `--display-server` does: one CreateImage packet, then UpdateImage packets of
//! horizontal bands as the render goes on.
//!
//! A packet is a little-endian u32 length (the whole packet, these 4 bytes included),
//! a type byte and its fields: `bool` one byte, strings NUL-terminated, integers and
//! floats little-endian. CreateImage (4): grab focus, name, width, height, channel
//! count, channel names. UpdateImage (6, tev's "v3"): grab focus, name, channel count,
//! channel names, x, y, width, height (i32), one i64 offset and one i64 stride per
//! channel into the float data that follows (here interleaved R, G, B: offsets 0, 1,
//! 2 and stride 3).

use crate::math::Vec3;
use std::io::Write;
use std::net::TcpStream;

pub const CREATE_IMAGE: u8 = 4;
pub const UPDATE_IMAGE: u8 = 6;

/// Floats an UpdateImage packet carries at most (tev reads packets whole).
const BAND_FLOATS: usize = 1 << 20;

struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8) -> Packet {
        Packet(vec![0, 0, 0, 0, kind])
    }
    fn flag(&mut self, b: bool) -> &mut Self {
        self.0.push(b as u8);
        self
    }
    fn text(&mut self, s: &str) -> &mut Self {
        // a NUL would end the string early
        self.0.extend(s.bytes().filter(|&b| b != 0));
        self.0.push(0);
        self
    }
    fn i32(&mut self, v: i32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn i64(&mut self, v: i64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn f32(&mut self, v: f32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn finish(&mut self) -> Vec<u8> {
        let n = self.0.len() as u32;
        self.0[..4].copy_from_slice(&n.to_le_bytes());
        std::mem::take(&mut self.0)
    }
}

/// The CreateImage packet of an RGB image.
pub fn create_image(name: &str, width: u32, height: u32) -> Vec<u8> {
    let mut p = Packet::new(CREATE_IMAGE);
    p.flag(true).text(name).i32(width as i32).i32(height as i32).i32(3);
    for c in ["R", "G", "B"] {
        p.text(c);
    }
    p.finish()
}

/// UpdateImage packets covering the whole image (row 0 = top), in bands of rows.
pub fn update_image(name: &str, width: u32, height: u32, pixels: &[Vec3]) -> Vec<Vec<u8>> {
    let w = width as usize;
    let rows_per_band = (BAND_FLOATS / (3 * w.max(1))).max(1);
    let mut out = Vec::new();
    let mut y0 = 0usize;
    while y0 < height as usize {
        let rows = rows_per_band.min(height as usize - y0);
        let mut p = Packet::new(UPDATE_IMAGE);
        p.flag(false).text(name).i32(3);
        for c in ["R", "G", "B"] {
            p.text(c);
        }
        p.i32(0).i32(y0 as i32).i32(width as i32).i32(rows as i32);
        for c in 0..3 {
            p.i64(c);
        }
        for _ in 0..3 {
            p.i64(3);
        }
        for px in &pixels[y0 * w..(y0 + rows) * w] {
            p.f32(px.x).f32(px.y).f32(px.z);
        }
        out.push(p.finish());
        y0 += rows;
    }
    out
}

/// A connection to tev showing one image.
pub struct Tev {
    stream: TcpStream,
    name: String,
}

impl Tev {
    /// Connects to tev at `addr` (`HOST:PORT`) and creates the image `name`.
    pub fn connect(addr: &str, name: &str, width: u32, height: u32) -> std::io::Result<Tev> {
        let mut stream = TcpStream::connect(addr)?;
        stream.set_nodelay(true).ok();
        stream.write_all(&create_image(name, width, height))?;
        Ok(Tev {
            stream,
            name: name.to_string(),
        })
    }

    /// Sends the whole image.
    pub fn update(&mut self, width: u32, height: u32, pixels: &[Vec3]) -> std::io::Result<()> {
        for p in update_image(&self.name, width, height, pixels) {
            self.stream.write_all(&p)?;
        }
        self.stream.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packets_are_framed_by_their_length() {
        let c = create_image("a", 2, 1);
        assert_eq!(u32::from_le_bytes(c[..4].try_into().unwrap()) as usize, c.len());
        assert_eq!(c[4], CREATE_IMAGE);
        assert_eq!(&c[5..8], &[1, b'a', 0]);
        let px = vec![Vec3::new(1.0, 2.0, 3.0); 2];
        let u = update_image("a", 2, 1, &px);
        assert_eq!(u.len(), 1);
        // header: 4 + 1 + 1 + 2 + 4 + 6 + 16 + 48, then 6 floats
        assert_eq!(u[0].len(), 82 + 24);
    }
}
