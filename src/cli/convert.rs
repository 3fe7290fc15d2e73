//! `rdr convert`: a scene between RDR171 JSON and Mitsuba XML.

use super::common::{refuse_unknown, same_file, say};
use super::UnknownArgs;
use anyhow::{Context, Result};
use std::path::Path;
use std::process::ExitCode;

/// `rdr convert IN -o OUT`: JSON ↔ Mitsuba XML.
pub fn convert(
    input: &Path,
    output: &Path,
    overrides: &[String],
    defines: &[(String, String)],
    quiet: bool,
    unknown: UnknownArgs,
) -> Result<ExitCode> {
    use rdr::desc::convert;
    let xml_out = match output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("xml") => true,
        Some("json") => false,
        _ => anyhow::bail!("{}: the output must end in .json or .xml", output.display()),
    };
    anyhow::ensure!(
        !same_file(output, input),
        "{}: refusing to write the conversion over its input",
        output.display()
    );
    let desc = rdr::desc::SceneDesc::load_with_defines(input, overrides, defines).map_err(anyhow::Error::msg)?;
    refuse_unknown(&desc, unknown)?;
    let c = if xml_out {
        convert::to_xml(&desc, output)
    } else {
        convert::to_json(&desc, output)
    }
    .map_err(anyhow::Error::msg)?;
    if !quiet {
        for w in desc.warnings.iter().chain(&c.warnings) {
            eprintln!("warning: {}", w.replace('\n', " "));
        }
    }
    for (path, bytes) in &c.files {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create the folder", dir.display()))?;
        }
        std::fs::write(path, bytes).with_context(|| format!("{}: cannot write", path.display()))?;
    }
    std::fs::write(output, &c.text).with_context(|| format!("{}: cannot write", output.display()))?;
    say(output.display())?;
    Ok(ExitCode::SUCCESS)
}
