//! `rdr merge`: the parts of a sharded render into one image.

use super::common::{refuse_input_as_output, same_file, say};
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
        "{}: merge writes an .exr (and the merged film state beside it)",
        output.display()
    );
    let state_out = statefile::state_path(output);
    // each part's state: its state file, or the part itself when it holds the state
    let mut inputs = parts.to_vec();
    let mut read: Vec<(PathBuf, statefile::StateFile)> = Vec::new();
    let mut named: Vec<PathBuf> = Vec::new();
    for p in parts {
        let Some((file, f)) = statefile::read_for(p)? else {
            anyhow::bail!(
                "{}: holds no rdr film state and has no {} beside it (not written by rdr render, or with --no-state or --compat rdr171)",
                p.display(),
                statefile::state_path(p).file_name().unwrap_or_default().to_string_lossy()
            );
        };
        inputs.push(file.clone());
        // `part_*.exr` names both a part's image and its state file: one part (the
        // same file named twice is an overlap, refused below)
        let again = read.iter().zip(&named).any(|((q, _), n)| same_file(q, &file) && !same_file(n, p));
        if !again {
            read.push((file, f));
            named.push(p.clone());
        }
    }
    refuse_input_as_output(output, &inputs, "the parts merged")?;
    refuse_input_as_output(&state_out, &inputs, "the parts merged")?;
    check_output_path(output)?;
    let parts_read = read.len();
    let (merged, missing) = statefile::merge(read, partial)?;
    let pixels = statefile::image(merged.width, merged.height, &merged.state);
    let (w, h) = (merged.width, merged.height);
    let state = statefile::encode(w, h, &pixels, &merged.state, true, &merged.header, Vec::new());
    write_atomically(&state_out, &state)?;
    write_atomically(
        output,
        &statefile::encode_image(w, h, &pixels, &merged.state, &merged.header, Vec::new()),
    )?;
    say(output.display())?;
    if !quiet {
        if missing.is_empty() {
            note!("merged {} part(s): {} passes", parts_read, merged.state.passes_done());
        } else {
            note!(
                "warning: merged {} part(s) with passes {} of {} missing: the image has {} passes",
                parts_read,
                rdr::render::blocks::format_ranges(&missing),
                merged.header.spp,
                merged.state.passes_done()
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
