//! `cargo run --release --example exr_to_png IN.exr OUT.png`: a preview (clamped, sRGB).

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    anyhow::ensure!(args.len() == 3, "usage: exr_to_png IN.exr OUT.png");
    let img = rdr::imageio::read_exr(std::path::Path::new(&args[1]))?;
    rdr::imageio::write_png(std::path::Path::new(&args[2]), img.width as u32, img.height as u32, &img.pixels)
}
