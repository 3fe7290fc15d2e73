//! `rdr merge`: the parts of a sharded render into one image.

use super::common::{refuse_input_as_output, say};
use anyhow::Result;
use rdr::imageio::{check_output_path, write_atomically};
use rdr::render::statefile;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// `rdr merge`.
pub fn merge(parts: &[PathBuf], output: &Path, partial: bool, quiet: bool) -> Result<ExitCode> {
    anyhow::ensure!(
        output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")),
        "{}: merge writes an .exr (the merged film state goes in it)",
        output.display()
    );
    refuse_input_as_output(output, parts, "the parts merged")?;
    check_output_path(output)?;
    let mut read = Vec::new();
    for p in parts {
        let Some(f) = statefile::read(p)? else {
            anyhow::bail!(
                "{}: holds no rdr film state (not written by rdr render, or with --compat rdr171)",
                p.display()
            );
        };
        read.push((p.clone(), f));
    }
    let (merged, missing) = statefile::merge(read, partial)?;
    let pixels = statefile::image(merged.width, merged.height, &merged.state);
    let bytes = statefile::encode(
        merged.width,
        merged.height,
        &pixels,
        &merged.state,
        true,
        &merged.header,
        Vec::new(),
    );
    write_atomically(output, &bytes)?;
    say(output.display())?;
    if !quiet {
        if missing.is_empty() {
            note!("merged {} part(s): {} passes", parts.len(), merged.state.passes_done());
        } else {
            note!(
                "warning: merged {} part(s) with passes {} of {} missing: the image has {} passes",
                parts.len(),
                rdr::render::blocks::format_ranges(&missing),
                merged.header.spp,
                merged.state.passes_done()
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
