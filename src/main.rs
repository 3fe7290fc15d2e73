//! The `rdr` command line.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rdr::imageio::{check_output_path, encode_image, save_elsewhere, write_atomically, ExrPixels};
use rdr::integrator::StopToken;
use rdr::limits::sanitize;
use rdr::render::identity::RenderIdentity;
use rdr::render::statefile::{self, StateHeader};
use rdr::render::{FilmState, Periodic, Snapshot};
use rdr::{Loaded, Profile, RenderControl};
use std::io::IsTerminal;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

/// Large blocks on huge pages (`rdr::HugePageAllocator`: fewer page faults when a big
/// mesh is read and its BVH built).
#[global_allocator]
static ALLOCATOR: rdr::HugePageAllocator = rdr::HugePageAllocator;

#[derive(Parser)]
#[command(name = "rdr", version, about = "A physically based CPU ray tracer for RDR171 JSON scenes")]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Memory the large buffers (film, images, meshes) may take, such as 8G or 512M;
    /// default half of what this process may use (physical memory, address-space
    /// limit, cgroup limit, whichever is smallest).
    #[arg(long, global = true, value_name = "SIZE", value_parser = parse_size)]
    max_memory: Option<u64>,
}

fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.is_empty() && k.chars().all(|c| c.is_alphanumeric() || c == '_') => Ok((k.to_string(), v.to_string())),
        _ => Err(format!("expected NAME=VALUE (a name of letters, digits and _), found '{s}'")),
    }
}

fn parse_size(s: &str) -> Result<u64, String> {
    rdr::limits::parse_bytes(s)
}

/// A line on standard error; a full or closed stderr is not an error of ours.
macro_rules! note {
    ($($t:tt)*) => {{
        let _ = writeln!(std::io::stderr(), $($t)*);
    }};
}

/// Standard output was closed by its reader (`rdr … | head`): end quietly.
#[derive(Debug)]
struct BrokenPipe;

impl std::fmt::Display for BrokenPipe {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("broken pipe")
    }
}

impl std::error::Error for BrokenPipe {}

/// Writes `text` and a newline to standard output.
fn say(text: impl std::fmt::Display) -> Result<()> {
    let mut o = std::io::stdout().lock();
    match writeln!(o, "{text}").and_then(|_| o.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(BrokenPipe.into()),
        Err(e) => Err(anyhow::anyhow!("cannot write to standard output: {e}")),
    }
}

#[derive(Clone, Copy, ValueEnum)]
enum Compat {
    /// Reproduce the RDR171 course renderer's reference images bit for bit.
    Rdr171,
}

#[derive(clap::Args)]
struct SceneArgs {
    /// Scene file (RDR171 JSON, or Mitsuba XML when it ends in .xml).
    scene: PathBuf,
    /// JSON object merged into the scene before it is read; may be repeated.
    #[arg(long = "override", value_name = "JSON")]
    overrides: Vec<String>,
    /// Mitsuba XML scenes: sets the parameter `$NAME` (as Mitsuba's -D); may be repeated.
    #[arg(short = 'D', long = "define", value_name = "NAME=VALUE", value_parser = parse_define)]
    defines: Vec<(String, String)>,
    /// Emulate another renderer's conventions.
    #[arg(long, value_enum)]
    compat: Option<Compat>,
    /// Samples per pixel (overrides the scene's `spp`).
    #[arg(long)]
    spp: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Seed of the sampler; different seeds give independent images.
    #[arg(long, default_value_t = 0)]
    seed: u32,
}

/// Options of `rdr render` for long renders: resume, checkpoints, shards, previews.
#[derive(clap::Args, Default)]
struct FlowArgs {
    /// Continue from the passes the output (.exr) already holds, after an interruption
    /// or to add passes up to a higher --spp; starts afresh when it does not exist yet.
    #[arg(long)]
    resume: bool,
    /// Rewrite the output (atomically) every this many seconds while rendering, so a
    /// killed render can --resume from it.
    #[arg(long, value_name = "SECONDS")]
    checkpoint: Option<f64>,
    /// Render only the K-th (0-based) of N disjoint runs of pass blocks; combine the
    /// N outputs with `rdr merge`.
    #[arg(long, value_name = "K/N")]
    shard: Option<String>,
    /// Keep `<output>.preview.png` (sRGB) and the output itself up to date while
    /// rendering, every SECONDS (2 when not given), written atomically.
    #[arg(long, value_name = "SECONDS", num_args = 0..=1, default_missing_value = "2")]
    preview: Option<f64>,
    /// Stream the image to a running tev viewer (`tev`, default port 14158).
    #[arg(long, value_name = "HOST:PORT")]
    tev: Option<String>,
    /// Also write feature buffers as layers of the .exr output: albedo, normal,
    /// depth, position (comma-separated; from the first non-specular hit).
    #[arg(long, value_name = "LIST")]
    aov: Option<String>,
    /// Denoise the image with Intel Open Image Denoise, guided by albedo and normal
    /// (needs the `denoise` build feature and libOpenImageDenoise; see RDR_OIDN_LIB).
    #[arg(long)]
    denoise: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to an image.
    Render {
        #[command(flatten)]
        args: SceneArgs,
        /// Output image, .exr (float32 RGB) or .png (8-bit sRGB); default `<scene>.exr`
        /// beside the scene file.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Print only errors: no warnings, progress bar or summary.
        #[arg(short, long, alias = "quite")]
        quiet: bool,
        /// Stop after the last pass that completes within this many seconds and
        /// write the image with the samples so far.
        #[arg(long, value_name = "SECONDS")]
        time_limit: Option<f64>,
        #[command(flatten)]
        flow: FlowArgs,
    },
    /// Merge the parts of a render (`render --shard K/N` outputs) into one image,
    /// identical to rendering it on one machine.
    Merge {
        /// The parts (.exr files written by `rdr render`).
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// The merged image (.exr).
        #[arg(short, long)]
        output: PathBuf,
        /// Merge even when passes are missing (says which); the result can be merged
        /// again with the missing parts later.
        #[arg(long)]
        partial: bool,
        /// Print only errors.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Convert a scene between RDR171 JSON and Mitsuba 3 XML (by the extensions; meshes
    /// JSON cannot name as they are are written as OBJ files beside the output).
    Convert {
        /// Scene to read (.json or .xml).
        input: PathBuf,
        /// Scene to write (.json or .xml).
        #[arg(short, long)]
        output: PathBuf,
        /// JSON object merged into a JSON input before it is read; may be repeated.
        #[arg(long = "override", value_name = "JSON")]
        overrides: Vec<String>,
        /// Parameter `$NAME` of an XML input; may be repeated.
        #[arg(short = 'D', long = "define", value_name = "NAME=VALUE", value_parser = parse_define)]
        defines: Vec<(String, String)>,
        /// Print only errors.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Compare an image with a reference: mean RGB and relative MSE,
    /// mean((x − r)² / (r² + 0.01)), the metric of shared/refs/README.md.
    Compare {
        image: PathBuf,
        reference: PathBuf,
        /// The reference's variance image (`<name>.var.exr`): also print the
        /// part of the error that is the reference's own noise.
        #[arg(long)]
        variance: Option<PathBuf>,
    },
    /// Benchmark: with a scene (.json), load, build and render it without writing it and
    /// print timings; with a mesh (.obj or .ply), benchmark the BVH (build time and size,
    /// Mrays/s of primary, incoherent and bounce rays, closest and any hit, 1 and all
    /// threads) after checking every traversal variant against a reference.
    Bench {
        #[command(flatten)]
        args: SceneArgs,
        /// Mesh benchmark: best of this many runs of each measurement.
        #[arg(long, default_value_t = 3)]
        repeat: usize,
        /// Kernels to time (portable, avx2, avx512; default the best available).
        #[arg(long)]
        isa: Option<String>,
        /// Scene benchmark: rays a packet traversal takes (8 or 16, 0: every ray alone;
        /// default 8 with the AVX2 kernels, else 16) where the integrator traces packets.
        #[arg(long)]
        packet: Option<usize>,
        /// Mesh benchmark: ray sets to time, comma-separated (primary, incoherent, bounce; default all).
        #[arg(long, value_delimiter = ',')]
        rays: Vec<String>,
        /// Mesh benchmark: skip the build timings and the kernel check (for profiling).
        #[arg(long)]
        trace_only: bool,
        /// Mesh benchmark: trace the rays of this file (raw little-endian f32, 6 a ray:
        /// origin, unit direction) and check them against X.t.f32 beside X.rays.f32;
        /// repeatable. The generated sets are then timed only if --rays names them.
        #[arg(long, value_name = "FILE")]
        ray_file: Vec<PathBuf>,
    },
}

fn main() -> ExitCode {
    // a bug must still end as one `error:` line and exit status 1, not a trace per thread
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        note!(
            "error: internal error (a bug in rdr, please report it): {}{at}",
            sanitize(&msg).replace('\n', " ")
        );
        std::process::exit(1);
    }));
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return parse_error(e),
    };
    if let Some(m) = cli.max_memory {
        rdr::limits::set_memory_budget(m);
    }
    let result = match cli.command {
        Command::Render {
            args,
            output,
            quiet,
            time_limit,
            flow,
        } => render(&args, output, quiet, time_limit, &flow),
        Command::Merge {
            parts,
            output,
            partial,
            quiet,
        } => merge(&parts, &output, partial, quiet),
        Command::Compare {
            image,
            reference,
            variance,
        } => compare(&image, &reference, variance.as_deref()),
        Command::Convert {
            input,
            output,
            overrides,
            defines,
            quiet,
        } => convert(&input, &output, &overrides, &defines, quiet),
        Command::Bench {
            args,
            repeat,
            isa,
            packet,
            rays,
            trace_only,
            ray_file,
        } => {
            let ext = args.scene.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
            if ext == "obj" || ext == "ply" {
                bench_mesh(&args, repeat, isa.as_deref(), rays, trace_only, ray_file)
            } else {
                bench_scene(&args, isa.as_deref(), packet)
            }
        }
    };
    match result {
        Ok(code) => code,
        Err(e) if e.is::<BrokenPipe>() => ExitCode::SUCCESS,
        Err(e) => {
            let msg: Vec<String> = e.chain().map(|c| c.to_string()).collect();
            note!("error: {}", sanitize(&msg.join(": ")));
            ExitCode::from(1)
        }
    }
}

/// Command-line errors as every other failure: one `error:` line, exit status 1
/// (`--help` and `--version` print as usual and succeed).
fn parse_error(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            let _ = e.print();
            ExitCode::SUCCESS
        }
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand | ErrorKind::MissingSubcommand => {
            note!("error: a subcommand is needed: render, merge, compare or bench (see rdr --help)");
            ExitCode::from(1)
        }
        _ => {
            let text = e.render().to_string();
            let first = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("error: invalid command line");
            let first = first.strip_prefix("error: ").unwrap_or(first);
            note!("error: {} (see rdr --help)", sanitize(first));
            ExitCode::from(1)
        }
    }
}

/// Most worker threads: a few per core is plenty; more only costs memory (stacks).
fn max_threads() -> usize {
    4 * std::thread::available_parallelism().map_or(1, |n| n.get())
}

fn check_threads(n: usize) -> Result<()> {
    anyhow::ensure!(n > 0, "--threads must be at least 1");
    let max = max_threads();
    anyhow::ensure!(n <= max, "--threads {n} is more than the {max} supported (4 per core)");
    Ok(())
}

fn profile(args: &SceneArgs) -> Profile {
    match args.compat {
        Some(Compat::Rdr171) => Profile::Rdr171,
        None => Profile::Physical,
    }
}

fn setup_threads(threads: Option<usize>) -> Result<()> {
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
fn load(args: &SceneArgs, quiet: bool) -> Result<Loaded> {
    Ok(load_desc(args, quiet)?.0)
}

/// [`load`], also returning the scene's description.
fn load_desc(args: &SceneArgs, quiet: bool) -> Result<(Loaded, rdr::desc::SceneDesc)> {
    let desc = rdr::desc::SceneDesc::load_with_defines(&args.scene, &args.overrides, &args.defines).map_err(anyhow::Error::msg)?;
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

/// Whether two paths name the same existing file (links and spellings resolved).
fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

fn default_output(scene: &Path) -> PathBuf {
    let stem = scene.file_stem().map(|s| s.to_os_string()).unwrap_or_else(|| "out".into());
    scene.with_file_name(Path::new(&stem).with_extension("exr"))
}

/// `K/N` of `--shard`, checked.
fn parse_shard(text: &str) -> Result<(u32, u32)> {
    let bad = || anyhow::anyhow!("--shard '{text}': expected K/N with 0 <= K < N (such as 0/4)");
    let (k, n) = text.split_once('/').ok_or_else(bad)?;
    let (k, n): (u32, u32) = (k.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
    anyhow::ensure!(n > 0 && k < n, bad());
    Ok((k, n))
}

fn state_header(identity: &rdr::render::identity::RenderIdentity, spp: u32, shard: Option<(u32, u32)>) -> StateHeader {
    StateHeader {
        identity: identity.clone(),
        spp,
        shard,
        version: env!("CARGO_PKG_VERSION").into(),
        commit: env!("RDR_COMMIT").into(),
    }
}

/// Where a resumed render starts: the state `output` holds, checked against the job.
/// `Ok(None)` when there is no file yet.
fn resume_state(
    output: &Path,
    identity: &rdr::render::identity::RenderIdentity,
    shard: Option<(u32, u32)>,
    total: u32,
    range: &std::ops::Range<u32>,
) -> Result<Option<FilmState>> {
    if !output.exists() {
        return Ok(None);
    }
    let name = output.display();
    let Some(file) = statefile::read(output)? else {
        anyhow::bail!("{name}: cannot resume: it holds no rdr film state (written by another program, or with --compat rdr171)");
    };
    if let Some(why) = statefile::mismatch(identity, &file.header.identity) {
        anyhow::bail!("{name}: cannot resume: {why}");
    }
    if file.header.shard != shard {
        let say = |s: Option<(u32, u32)>| s.map_or("the whole render".to_string(), |(k, n)| format!("shard {k}/{n}"));
        anyhow::bail!("{name}: cannot resume: it holds {}, not {}", say(file.header.shard), say(shard));
    }
    if shard.is_some() && file.header.spp != total {
        anyhow::bail!(
            "{name}: cannot resume: it is a shard of a render of {} passes, not {total} (shards split the passes of one --spp)",
            file.header.spp
        );
    }
    let ranges = file.state.ranges();
    let held = ranges.first().cloned().unwrap_or(range.start..range.start);
    if ranges.len() > 1 || held.start != range.start {
        anyhow::bail!(
            "{name}: cannot resume: it holds passes {}, not one run from pass {}",
            rdr::render::blocks::format_ranges(&ranges),
            range.start
        );
    }
    if held.end > range.end {
        anyhow::bail!(
            "{name}: cannot resume: it holds {} passes, more than the {} asked (give --spp {} or more)",
            held.end - held.start,
            range.end - range.start,
            held.end
        );
    }
    Ok(Some(file.state))
}

/// `rdr render`.
fn render(args: &SceneArgs, output: Option<PathBuf>, quiet: bool, time_limit: Option<f64>, flow: &FlowArgs) -> Result<ExitCode> {
    if let Some(t) = time_limit {
        anyhow::ensure!(t.is_finite() && t > 0.0, "--time-limit must be a positive number of seconds");
    }
    for (name, t) in [("--checkpoint", flow.checkpoint), ("--preview", flow.preview)] {
        if let Some(t) = t {
            anyhow::ensure!(t.is_finite() && t > 0.0, "{name} must be a positive number of seconds");
        }
    }
    let shard = flow.shard.as_deref().map(parse_shard).transpose()?;
    let aov = match &flow.aov {
        Some(text) => rdr::integrator::aov::AovSet::parse(text).map_err(|e| anyhow::anyhow!("--aov '{}': {e}", sanitize(text)))?,
        None => rdr::integrator::aov::AovSet::default(),
    };
    setup_threads(args.threads)?;
    let (Loaded { scene, mut job }, desc) = load_desc(args, quiet)?;
    job.time_limit = time_limit;
    let output = output.unwrap_or_else(|| default_output(&args.scene));
    // Fail before the render, not after it.
    if same_file(&output, &args.scene) {
        anyhow::bail!(
            "{}: refusing to write the image over the scene file (choose another output with -o)",
            output.display()
        );
    }
    check_output_path(&output)?;
    let is_exr = output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let physical = matches!(profile(args), Profile::Physical);
    let asked = |what: &str| {
        (what == "--resume" && flow.resume)
            || (what == "--shard" && shard.is_some())
            || (what == "--checkpoint" && flow.checkpoint.is_some())
    };
    for what in ["--resume", "--shard", "--checkpoint"] {
        if !asked(what) {
            continue;
        }
        anyhow::ensure!(
            physical,
            "{what}: --compat rdr171 renders in one pass of columns, which cannot be resumed, checkpointed or split"
        );
        anyhow::ensure!(
            job.integrator.passes_independent() || what == "--checkpoint",
            "{what}: the {} integrator's passes depend on earlier ones (or on the total spp), so they cannot be {}; render it in one go",
            job.integrator.name(),
            if what == "--shard" { "split over machines" } else { "continued" }
        );
        anyhow::ensure!(
            is_exr || what == "--checkpoint",
            "{what}: needs an .exr output ({} cannot hold the film state)",
            output.display()
        );
    }
    if flow.denoise {
        rdr::render::denoise::check().map_err(|e| anyhow::anyhow!("--denoise: {e}"))?;
    }
    for what in ["--aov", "--denoise"] {
        if (what == "--aov" && !aov.any()) || (what == "--denoise" && !flow.denoise) {
            continue;
        }
        anyhow::ensure!(
            physical,
            "{what}: not with --compat rdr171 (the course renderer had no feature buffers)"
        );
        anyhow::ensure!(
            job.integrator.supports_aov(),
            "{what}: the {} integrator does not make feature buffers (path, intersection_test, bdpt, ptracer, photon and normals do)",
            job.integrator.name()
        );
        anyhow::ensure!(
            !flow.resume && shard.is_none(),
            "{what}: not with --resume or --shard yet (the feature sums are not kept in the film state)"
        );
    }
    if aov.any() {
        anyhow::ensure!(is_exr, "--aov: needs an .exr output ({} cannot hold layers)", output.display());
    }
    let identity = if physical && is_exr {
        Some(RenderIdentity::of(&args.scene, &args.overrides, &args.defines, &desc, job.seed)?)
    } else {
        None
    };
    let total = job.integrator.pass_count(job.spp);
    let range = match shard {
        Some((k, n)) => rdr::render::blocks::shard_range(k, n, total),
        None => 0..total,
    };
    job.passes = Some(range.clone());
    let start = match (&identity, flow.resume) {
        (Some(id), true) => resume_state(&output, id, shard, total, &range)?.unwrap_or_default(),
        _ => FilmState::default(),
    };
    let header = identity.as_ref().map(|id| state_header(id, total, shard));
    let resumable = job.integrator.passes_independent();
    if flow.resume && start.passes_done() == range.end - range.start && range.end > range.start {
        say(output.display())?;
        if !quiet {
            note!(
                "{}: already holds all {} passes: nothing to render",
                output.display(),
                start.passes_done()
            );
        }
        return Ok(ExitCode::SUCCESS);
    }
    let passes_left = range.end - start.passes_done().min(range.end - range.start) - range.start;

    let stop = Arc::new(StopToken::new());
    {
        let stop = stop.clone();
        ctrlc::set_handler(move || {
            if stop.stop_again() {
                std::process::exit(130);
            }
            note!("\ninterrupted: saving the finished passes (press Ctrl-C again to quit at once)");
        })
        .context("cannot install the Ctrl-C handler")?;
    }
    let exr = match profile(args) {
        Profile::Physical => ExrPixels::Float,
        Profile::Rdr171 => ExrPixels::HalfTinyexr,
    };
    // the bytes of the output file for an image and its state
    let encode = {
        let output = output.clone();
        let header = header.clone();
        move |w: u32, h: u32, pixels: &[rdr::math::Vec3], state: &FilmState, layers: Vec<rdr::imageio::ExrChannel>| -> Result<Vec<u8>> {
            match &header {
                Some(hd) => Ok(statefile::encode(w, h, pixels, state, resumable, hd, layers)),
                None => encode_image(&output, w, h, pixels, exr),
            }
        }
    };
    let encode = Arc::new(encode);
    let mut periodic = Vec::new();
    if let Some(every) = flow.checkpoint {
        let (encode, output) = (encode.clone(), output.clone());
        periodic.push(Periodic {
            every,
            call: Arc::new(move |snap: &Snapshot| {
                let written =
                    encode(snap.width, snap.height, snap.pixels, snap.state, Vec::new()).and_then(|b| write_atomically(&output, &b));
                if let Err(e) = written {
                    note!("warning: checkpoint: {e:#}");
                }
            }),
        });
    }
    if let Some(every) = flow.preview {
        let (encode, output) = (encode.clone(), output.clone());
        let png = preview_path(&output);
        periodic.push(Periodic {
            every,
            call: Arc::new(move |snap: &Snapshot| {
                let written = rdr::imageio::write_png(&png, snap.width, snap.height, snap.pixels)
                    .and_then(|_| encode(snap.width, snap.height, snap.pixels, snap.state, Vec::new()))
                    .and_then(|b| write_atomically(&output, &b));
                if let Err(e) = written {
                    note!("warning: preview: {e:#}");
                }
            }),
        });
    }
    let tev = match &flow.tev {
        Some(addr) => {
            let name = output.file_name().map_or("rdr".into(), |n| n.to_string_lossy().into_owned());
            let t = rdr::render::tev::Tev::connect(addr, &name, job.film.width, job.film.height)
                .map_err(|e| anyhow::anyhow!("--tev {addr}: cannot connect to tev: {e}"))?;
            Some(Arc::new(std::sync::Mutex::new(Some(t))))
        }
        None => None,
    };
    // a failed send ends the stream (tev closed), with one warning
    let send_tev = |tev: &Arc<std::sync::Mutex<Option<rdr::render::tev::Tev>>>, w: u32, h: u32, px: &[rdr::math::Vec3]| {
        let mut guard = tev.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(t) = guard.as_mut() {
            if let Err(e) = t.update(w, h, px) {
                note!("warning: --tev: {e}; no more updates");
                *guard = None;
            }
        }
    };
    if let Some(tev) = &tev {
        let tev = tev.clone();
        periodic.push(Periodic {
            every: 0.5,
            call: Arc::new(move |snap: &Snapshot| send_tev(&tev, snap.width, snap.height, snap.pixels)),
        });
    }
    let samples_left = job.film.width as u64 * job.film.height as u64 * job.integrator.spp_done(job.spp, passes_left) as u64;
    let bar = if !quiet && std::io::stderr().is_terminal() {
        let b = ProgressBar::with_draw_target(Some(samples_left), ProgressDrawTarget::stderr());
        b.set_style(ProgressStyle::with_template("{bar:40} {percent:>3}%  {elapsed_precise} elapsed, ETA {eta}").expect("valid template"));
        Some(b)
    } else {
        None
    };
    let control = RenderControl {
        stop,
        progress: bar
            .clone()
            .map(|b| Arc::new(move |n: u64| b.inc(n)) as Arc<dyn Fn(u64) + Send + Sync>),
        periodic,
    };
    let mut out = rdr::render::render_with_aov(&scene, &job, &control, start, aov.any() || flow.denoise);
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if out.invalid_samples > 0 {
        note!("warning: {} sample(s) were NaN or infinite and were left out", out.invalid_samples);
    }
    if out.invalid_rays > 0 {
        note!(
            "warning: {} ray(s) were NaN or infinite and were counted as misses",
            out.invalid_rays
        );
    }
    if let Some(tev) = &tev {
        send_tev(tev, out.width, out.height, &out.pixels);
    }
    if flow.preview.is_some() {
        if let Err(e) = rdr::imageio::write_png(&preview_path(&output), out.width, out.height, &out.pixels) {
            note!("warning: preview: {e:#}");
        }
    }
    let mut layers = out
        .aov
        .as_ref()
        .map_or_else(Vec::new, |sums| rdr::integrator::aov::channels(sums, aov));
    if flow.denoise {
        let sums = out.aov.as_ref().expect("feature sums for --denoise");
        let (albedo, normal) = (rdr::integrator::aov::layer_rgb(sums, 0), rdr::integrator::aov::layer_rgb(sums, 3));
        let clean = rdr::render::denoise::denoise(out.width, out.height, &out.pixels, &albedo, &normal)
            .map_err(|e| anyhow::anyhow!("--denoise: {e}"))?;
        // the noisy image stays in the file, beside the film state it is made of
        if header.is_some() {
            layers.extend(rdr::imageio::rgb_channels("noisy.", &out.pixels));
        }
        out.pixels = clean;
    }
    let bytes = encode(out.width, out.height, &out.pixels, &out.state, layers)?;
    if let Err(e) = write_atomically(&output, &bytes) {
        // the render is not lost: keep it where it can be written
        match save_elsewhere(&output, &bytes) {
            Ok(saved) => anyhow::bail!("{e:#}; the image was saved to {} instead", saved.display()),
            Err(e2) => anyhow::bail!("{e:#}; saving it in the temporary folder failed too ({e2:#}): the image is lost"),
        }
    }
    say(output.display())?;
    for (name, pixels) in &out.extra_images {
        let path = extra_image_path(&output, name);
        let bytes = encode_image(&path, out.width, out.height, pixels, exr)?;
        write_atomically(&path, &bytes)?;
    }
    if !quiet && !out.extra_images.is_empty() {
        note!(
            "wrote {} strategy images beside it ({})",
            out.extra_images.len(),
            extra_image_path(&output, "sS_tT").display()
        );
    }
    if !quiet {
        note!(
            "rendered {}x{} at {} spp in {:.2} s ({:.3e} samples/s){}",
            out.width,
            out.height,
            out.spp_done,
            out.seconds,
            out.samples as f64 / out.seconds.max(1e-9),
            if out.interrupted {
                ", interrupted"
            } else if out.time_limited {
                ", time limit reached"
            } else {
                ""
            }
        );
        if let Some(summary) = &out.summary {
            eprintln!("{summary}");
        }
    }
    Ok(if out.interrupted { ExitCode::from(130) } else { ExitCode::SUCCESS })
}

/// `out.exr` and `s2_t1` → `out.s2_t1.exr`.
fn extra_image_path(output: &Path, name: &str) -> PathBuf {
    let ext = output.extension().map_or("exr".into(), |e| e.to_string_lossy().into_owned());
    output.with_extension(format!("{name}.{ext}"))
}

/// `out.exr` → `out.preview.png`.
fn preview_path(output: &Path) -> PathBuf {
    output.with_extension("preview.png")
}

/// `rdr merge`.
fn merge(parts: &[PathBuf], output: &Path, partial: bool, quiet: bool) -> Result<ExitCode> {
    anyhow::ensure!(
        output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")),
        "{}: merge writes an .exr (the merged film state goes in it)",
        output.display()
    );
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

/// `--isa NAME`.
fn parse_isa(isa: Option<&str>) -> Result<Option<rdr::accel::Isa>> {
    Ok(match isa {
        None => None,
        Some("portable") => Some(rdr::accel::Isa::Portable),
        Some("avx2") => Some(rdr::accel::Isa::Avx2),
        Some("avx512") => Some(rdr::accel::Isa::Avx512),
        Some(other) => anyhow::bail!("--isa: unknown instruction set '{other}' (portable, avx2, avx512)"),
    })
}

/// `rdr bench MESH`: the BVH benchmark.
fn bench_mesh(
    args: &SceneArgs,
    repeat: usize,
    isa: Option<&str>,
    rays: Vec<String>,
    trace_only: bool,
    ray_files: Vec<PathBuf>,
) -> Result<ExitCode> {
    let all = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    check_threads(all)?;
    anyhow::ensure!(repeat <= 1000, "--repeat {repeat} is more than the 1000 supported");
    let mut threads = vec![1];
    if all > 1 {
        threads.push(all);
    }
    let isa = parse_isa(isa)?;
    let opts = rdr::bench::Options {
        repeat,
        threads,
        isa,
        rays,
        trace_only,
        ray_files,
    };
    let report = rdr::bench::run(&args.scene, &opts)?;
    say(report.text.trim_end_matches('\n'))?;
    anyhow::ensure!(
        report.agrees,
        "closest-hit distances disagree with a distances file beyond the tolerance (see above)"
    );
    Ok(ExitCode::SUCCESS)
}

/// `rdr convert IN -o OUT`: JSON ↔ Mitsuba XML.
fn convert(input: &Path, output: &Path, overrides: &[String], defines: &[(String, String)], quiet: bool) -> Result<ExitCode> {
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

/// `rdr bench SCENE.json`: load, build and render without writing.
fn bench_scene(args: &SceneArgs, isa: Option<&str>, packet: Option<usize>) -> Result<ExitCode> {
    setup_threads(args.threads)?;
    let isa = parse_isa(isa)?;
    let t0 = Instant::now();
    let Loaded { mut scene, job } = load(args, true)?;
    let load_s = t0.elapsed().as_secs_f64();
    let trees = std::iter::once(&mut scene.bvh).chain(scene.groups.iter_mut().map(|g| &mut g.bvh));
    for bvh in trees {
        if let Some(i) = isa {
            anyhow::ensure!(bvh.set_isa(i), "--isa {}: this CPU cannot run these kernels", i.name());
        }
        if let Some(w) = packet {
            anyhow::ensure!(bvh.set_packet_width(w), "--packet {w}: 8, 16 or 0");
        }
    }
    let cpu0 = rdr::bench::process_cpu_seconds();
    let out = rdr::render(&scene, &job, &RenderControl::default());
    let render_cpu = cpu0.zip(rdr::bench::process_cpu_seconds()).map(|(a, b)| b - a);
    use std::fmt::Write as _;
    let mut t = String::new();
    let _ = writeln!(t, "scene            {}", args.scene.display());
    let _ = writeln!(t, "threads          {}", rayon::current_num_threads());
    let _ = writeln!(t, "cpu              {}", rdr::bench::cpu_line(scene.bvh.isa()));
    let _ = writeln!(
        t,
        "packets          {}",
        match scene.bvh.packet_width() {
            0 => "off".to_string(),
            w => format!("{w} rays"),
        }
    );
    let _ = writeln!(t, "primitives       {} ({} triangles)", scene.prims.len(), scene.triangle_count());
    let _ = writeln!(
        t,
        "load + build     {:.1} ms (BVH {:.2} ms, {} nodes)",
        load_s * 1e3,
        scene.bvh_seconds * 1e3,
        scene.bvh.nodes.len()
    );
    let _ = writeln!(
        t,
        "render           {}x{} at {} spp in {:.3} s",
        out.width, out.height, out.spp_done, out.seconds
    );
    if let Some(cpu) = render_cpu {
        // what `mi.render`'s process CPU time measures: the render alone, every thread
        let _ = writeln!(t, "render cpu       {cpu:.3} s (all threads)");
    }
    let _ = writeln!(t, "samples/s        {:.3e}", out.samples as f64 / out.seconds);
    if out.rays > 0 {
        let _ = writeln!(
            t,
            "rays/s           {:.3e} ({:.2} rays per sample)",
            out.rays as f64 / out.seconds,
            out.rays as f64 / out.samples as f64
        );
    }
    say(t.trim_end_matches('\n'))?;
    Ok(ExitCode::SUCCESS)
}

/// `rdr compare`.
fn compare(image: &Path, reference: &Path, variance: Option<&Path>) -> Result<ExitCode> {
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
