//! `exr_equal A.exr B.exr`: exit 0 when both decode to the same size and the same
//! float32 bits in every pixel and channel, else print the first difference and exit 1.
//! Used by `scripts/image-regress.sh`.

use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [a, b] = args.as_slice() else {
        eprintln!("usage: exr_equal A.exr B.exr");
        return ExitCode::from(2);
    };
    let read = |p: &str| rdr::imageio::read_exr(std::path::Path::new(p));
    let (x, y) = match (read(a), read(b)) {
        (Ok(x), Ok(y)) => (x, y),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("error: {e:#}");
            return ExitCode::from(2);
        }
    };
    if (x.width, x.height) != (y.width, y.height) {
        eprintln!("{a} is {}x{}, {b} is {}x{}", x.width, x.height, y.width, y.height);
        return ExitCode::from(1);
    }
    let differing = x
        .pixels
        .iter()
        .zip(&y.pixels)
        .filter(|(p, q)| p.to_array().map(f32::to_bits) != q.to_array().map(f32::to_bits))
        .count();
    if differing > 0 {
        let i = x
            .pixels
            .iter()
            .zip(&y.pixels)
            .position(|(p, q)| p.to_array().map(f32::to_bits) != q.to_array().map(f32::to_bits))
            .unwrap_or(0);
        eprintln!(
            "{differing} of {} pixels differ; first at ({}, {}): {:?} vs {:?}",
            x.pixels.len(),
            i % x.width,
            i / x.width,
            x.pixels[i],
            y.pixels[i]
        );
        return ExitCode::from(1);
    }
    ExitCode::SUCCESS
}
