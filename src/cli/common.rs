//! What the subcommands share: standard output, threads, loading a scene.

use super::{Compat, SceneArgs, UnknownArgs};
use anyhow::{Context, Result};
use rdr::limits::sanitize;
use rdr::render::session::Caller;
use rdr::{Loaded, Profile};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Standard output was closed by its reader (`rdr … | head`): end quietly.
#[derive(Debug)]
pub struct BrokenPipe;

impl std::fmt::Display for BrokenPipe {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("broken pipe")
    }
}

impl std::error::Error for BrokenPipe {}

/// Writes `text` and a newline to standard output.
pub fn say(text: impl std::fmt::Display) -> Result<()> {
    let mut o = std::io::stdout().lock();
    match writeln!(o, "{text}").and_then(|_| o.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(BrokenPipe.into()),
        Err(e) => Err(anyhow::anyhow!("cannot write to standard output: {e}")),
    }
}

pub fn check_threads(n: usize) -> Result<()> {
    rdr::render::session::check_threads(n, Caller::Cli).map_err(anyhow::Error::msg)
}

pub fn profile(args: &SceneArgs) -> Profile {
    match args.compat {
        Some(Compat::Rdr171) => Profile::Rdr171,
        None => Profile::Physical,
    }
}

pub fn setup_threads(threads: Option<usize>) -> Result<()> {
    if let Some(n) = threads {
        check_threads(n)?;
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("cannot start the thread pool")?;
    }
    Ok(())
}

/// Loads the scene and the job it describes, with the command line's `--spp` and
/// `--seed` applied.
pub fn load(args: &SceneArgs, quiet: bool) -> Result<Loaded> {
    Ok(load_desc(args, quiet)?.0)
}

/// [`load`], also returning the scene's description.
pub fn load_desc(args: &SceneArgs, quiet: bool) -> Result<(Loaded, rdr::desc::SceneDesc)> {
    let mut desc = rdr::desc::SceneDesc::load_with_defines(&args.scene, &args.overrides, &args.defines).map_err(anyhow::Error::msg)?;
    // the course's format ignores keys it does not know (its own files carry some), and
    // `--compat rdr171` keeps the course's rules
    if profile(args) != Profile::Rdr171 {
        refuse_unknown(&desc, args.unknown)?;
    }
    if let Some((w, h)) = args.res {
        anyhow::ensure!((w as u64) * (h as u64) <= 1 << 28, "--res {w}x{h}: too large");
        (desc.film.width, desc.film.height) = (w, h);
    }
    if let Some(name) = &args.integrator {
        desc.set_integrator(name).map_err(anyhow::Error::msg)?;
    }
    let mut loaded = Loaded::build(&desc, profile(args)).map_err(anyhow::Error::msg)?;
    if !quiet {
        for w in &loaded.scene.warnings {
            note!("warning: {}", sanitize(w));
        }
    }
    if let Some(spp) = args.spp {
        anyhow::ensure!(spp > 0, "--spp must be at least 1");
        loaded.job.spp = spp;
    }
    loaded.job.seed = args.seed;
    Ok((loaded, desc))
}

/// JSON scenes' unknown keys are errors unless `--lenient`; XML scenes' unknown
/// properties only with `--strict`.
pub fn refuse_unknown(desc: &rdr::desc::SceneDesc, unknown: UnknownArgs) -> Result<()> {
    let xml = rdr::desc::xml::is_xml(&desc.file);
    let Some(first) = desc.unknown.first().filter(|_| if xml { unknown.strict } else { !unknown.lenient }) else {
        return Ok(());
    };
    let more = match desc.unknown.len() - 1 {
        0 => String::new(),
        n => format!(" (and {n} more)"),
    };
    let why = if xml {
        "--strict refuses unknown properties"
    } else {
        "--lenient ignores unknown keys with a warning"
    };
    anyhow::bail!("{first}{more}; {why}")
}

/// What the command line changes in the scene (`--res`, `--integrator`, `--crop`) as
/// `-D`-style pairs, for the render's identity (a resumed render must match).
pub fn scene_changes(args: &SceneArgs, crop: Option<&str>) -> Vec<(String, String)> {
    let mut out = args.defines.clone();
    if let Some((w, h)) = args.res {
        out.push(("rdr:res".into(), format!("{w}x{h}")));
    }
    if let Some(i) = &args.integrator {
        out.push(("rdr:integrator".into(), i.clone()));
    }
    if let Some(c) = crop {
        out.push(("rdr:crop".into(), c.into()));
    }
    out
}

/// Whether two paths name the same existing file: the same device and inode, so
/// spellings, symbolic and hard links all count.
pub fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) => (x.dev(), x.ino()) == (y.dev(), y.ino()),
        _ => false,
    }
}

/// Refuses an output that is one of the run's inputs (`what` names them).
pub fn refuse_input_as_output(output: &Path, inputs: &[PathBuf], what: &str) -> Result<()> {
    if let Some(input) = inputs.iter().find(|i| same_file(output, i)) {
        anyhow::bail!(
            "{}: refusing to write over {}, one of {what} (choose another output with -o)",
            output.display(),
            input.display()
        );
    }
    Ok(())
}
