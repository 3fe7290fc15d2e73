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
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

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

/// How long one write to tev may make no progress before the viewer counts as stalled.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(2);

/// One image for the sender: size and pixels.
struct Frame {
    width: u32,
    height: u32,
    pixels: Vec<Vec3>,
}

/// The sender's mailbox: at most one frame waits; a newer one replaces it (the
/// viewer only needs the latest image), and `closed` ends the sender.
#[derive(Default)]
struct Mailbox {
    frame: Option<Frame>,
    closed: bool,
    /// The sender has nothing in hand (its last frame is out, or it gave up).
    idle: bool,
}

/// A connection to tev showing one image, fed by a sender thread so the render never
/// waits for the viewer: [`Tev::update`] only leaves the image in a one-frame mailbox
/// (an update not yet sent is replaced, not queued), and a viewer that stops reading
/// for [`WRITE_TIMEOUT`] is dropped with one message through `on_error`.
pub struct Tev {
    shared: Arc<(Mutex<Mailbox>, Condvar)>,
    sender: Option<std::thread::JoinHandle<()>>,
}

impl Tev {
    /// Connects to tev at `addr` (`HOST:PORT`, within [`WRITE_TIMEOUT`] per address)
    /// and creates the image `name`. `on_error` gets the reason when the stream ends.
    pub fn connect(addr: &str, name: &str, width: u32, height: u32, on_error: Box<dyn Fn(String) + Send>) -> std::io::Result<Tev> {
        let mut last = std::io::Error::new(std::io::ErrorKind::NotFound, "no address");
        let mut stream = None;
        for a in addr.to_socket_addrs()? {
            match TcpStream::connect_timeout(&a, WRITE_TIMEOUT) {
                Ok(s) => {
                    stream = Some(s);
                    break;
                }
                Err(e) => last = e,
            }
        }
        let mut stream = stream.ok_or(last)?;
        stream.set_nodelay(true).ok();
        stream.set_write_timeout(Some(WRITE_TIMEOUT))?;
        stream.write_all(&create_image(name, width, height)).map_err(stalled)?;
        let shared = Arc::new((
            Mutex::new(Mailbox {
                idle: true,
                ..Mailbox::default()
            }),
            Condvar::new(),
        ));
        let name = name.to_string();
        let mail = shared.clone();
        let sender = std::thread::Builder::new().name("rdr-tev".into()).spawn(move || {
            let (lock, wake) = &*mail;
            loop {
                let frame = {
                    let mut m = lock.lock().unwrap_or_else(|e| e.into_inner());
                    loop {
                        if let Some(f) = m.frame.take() {
                            m.idle = false;
                            break f;
                        }
                        if m.closed {
                            return;
                        }
                        m = wake.wait(m).unwrap_or_else(|e| e.into_inner());
                    }
                };
                let sent = update_image(&name, frame.width, frame.height, &frame.pixels)
                    .iter()
                    .try_for_each(|p| stream.write_all(p))
                    .and_then(|_| stream.flush());
                let mut m = lock.lock().unwrap_or_else(|e| e.into_inner());
                m.idle = true;
                if let Err(e) = sent {
                    m.closed = true;
                    m.frame = None;
                    wake.notify_all();
                    drop(m);
                    on_error(stalled(e).to_string());
                    return;
                }
                wake.notify_all();
            }
        })?;
        Ok(Tev {
            shared,
            sender: Some(sender),
        })
    }

    /// Hands the image to the sender (a copy) and returns at once; `false` once the
    /// stream has ended.
    pub fn update(&self, width: u32, height: u32, pixels: &[Vec3]) -> bool {
        let (lock, wake) = &*self.shared;
        let mut m = lock.lock().unwrap_or_else(|e| e.into_inner());
        if m.closed {
            return false;
        }
        m.frame = Some(Frame {
            width,
            height,
            pixels: pixels.to_vec(),
        });
        wake.notify_all();
        true
    }

    /// Waits up to `limit` for the frames handed over to be sent, then closes the
    /// stream; `true` when everything was sent.
    pub fn finish(mut self, limit: Duration) -> bool {
        let (lock, wake) = &*self.shared;
        let deadline = Instant::now() + limit;
        let mut m = lock.lock().unwrap_or_else(|e| e.into_inner());
        while !m.closed && (!m.idle || m.frame.is_some()) {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            m = wake.wait_timeout(m, left).unwrap_or_else(|e| e.into_inner()).0;
        }
        let done = !m.closed && m.idle && m.frame.is_none();
        m.closed = true;
        wake.notify_all();
        drop(m);
        // a sender still blocked in a write is left to end with the process
        if done {
            if let Some(s) = self.sender.take() {
                let _ = s.join();
            }
        }
        done
    }
}

impl Drop for Tev {
    fn drop(&mut self) {
        let (lock, wake) = &*self.shared;
        lock.lock().unwrap_or_else(|e| e.into_inner()).closed = true;
        wake.notify_all();
    }
}

/// A write that made no progress for [`WRITE_TIMEOUT`] says so.
fn stalled(e: std::io::Error) -> std::io::Error {
    match e.kind() {
        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut => std::io::Error::new(
            std::io::ErrorKind::TimedOut,
            format!("the viewer stopped reading (no progress for {} s)", WRITE_TIMEOUT.as_secs()),
        ),
        _ => e,
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
