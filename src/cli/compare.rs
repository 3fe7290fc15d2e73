//! `rdr compare`: an image against a reference (mean RGB, relative MSE).

use super::common::say;
use anyhow::Result;
use std::path::Path;
use std::process::ExitCode;

/// `rdr compare`.
pub fn compare(image: &Path, reference: &Path, variance: Option<&Path>) -> Result<ExitCode> {
    let x = rdr::imageio::read_exr(image)?;
    let r = rdr::imageio::read_exr(reference)?;
    anyhow::ensure!(
        (x.width, x.height) == (r.width, r.height),
        "{} is {}x{} but {} is {}x{}",
        image.display(),
        x.width,
        x.height,
        reference.display(),
        r.width,
        r.height
    );
    let v = variance.map(rdr::imageio::read_exr).transpose()?;
    if let (Some(v), Some(vp)) = (&v, variance) {
        anyhow::ensure!(
            (v.width, v.height) == (r.width, r.height),
            "{} is {}x{} but the reference {} is {}x{}",
            vp.display(),
            v.width,
            v.height,
            reference.display(),
            r.width,
            r.height
        );
    }
    let (rel, noise) = rdr::metrics::rel_mse(&x, &r, v.as_ref());
    let (mx, mr) = (x.mean(), r.mean());
    let mut t = format!(
        "mean RGB      {:.5} {:.5} {:.5}   (reference {:.5} {:.5} {:.5})\nrelMSE        {rel:.4e}",
        mx.x, mx.y, mx.z, mr.x, mr.y, mr.z
    );
    if v.is_some() {
        t += &format!("\nof which the reference's own noise {noise:.4e}");
    }
    say(t)?;
    Ok(ExitCode::SUCCESS)
}
