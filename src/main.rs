//! The `rdr` command line.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rdr::imageio::{check_output_path, encode_image, save_elsewhere, write_atomically, ExrPixels};
use rdr::integrator::StopToken;
use rdr::limits::sanitize;
use rdr::{Loaded, Profile, RenderControl};
use std::io::IsTerminal;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

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
    /// Scene file (RDR171 JSON).
    scene: PathBuf,
    /// JSON object merged into the scene before it is read; may be repeated.
    #[arg(long = "override", value_name = "JSON")]
    overrides: Vec<String>,
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
        /// Mesh benchmark: kernels to time (portable, avx2, avx512; default the best available).
        #[arg(long)]
        isa: Option<String>,
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
        } => render(&args, output, quiet, time_limit),
        Command::Compare {
            image,
            reference,
            variance,
        } => compare(&image, &reference, variance.as_deref()),
        Command::Bench {
            args,
            repeat,
            isa,
            rays,
            trace_only,
            ray_file,
        } => {
            let ext = args.scene.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
            if ext == "obj" || ext == "ply" {
                bench_mesh(&args, repeat, isa.as_deref(), rays, trace_only, ray_file)
            } else {
                bench_scene(&args)
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
            note!("error: a subcommand is needed: render, compare or bench (see rdr --help)");
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
    let mut loaded = rdr::load(&args.scene, &args.overrides, profile(args)).map_err(anyhow::Error::msg)?;
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
    Ok(loaded)
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

/// `rdr render`.
fn render(args: &SceneArgs, output: Option<PathBuf>, quiet: bool, time_limit: Option<f64>) -> Result<ExitCode> {
    if let Some(t) = time_limit {
        anyhow::ensure!(t.is_finite() && t > 0.0, "--time-limit must be a positive number of seconds");
    }
    setup_threads(args.threads)?;
    let Loaded { scene, mut job } = load(args, quiet)?;
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
    let total = job.film.width as u64 * job.film.height as u64 * job.spp as u64;
    let bar = if !quiet && std::io::stderr().is_terminal() {
        let b = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
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
    };
    let out = rdr::render(&scene, &job, &control);
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let exr = match profile(args) {
        Profile::Physical => ExrPixels::Float,
        Profile::Rdr171 => ExrPixels::HalfTinyexr,
    };
    if out.invalid_samples > 0 {
        note!("warning: {} sample(s) were NaN or infinite and were left out", out.invalid_samples);
    }
    if out.invalid_rays > 0 {
        note!(
            "warning: {} ray(s) were NaN or infinite and were counted as misses",
            out.invalid_rays
        );
    }
    let bytes = encode_image(&output, out.width, out.height, &out.pixels, exr)?;
    if let Err(e) = write_atomically(&output, &bytes) {
        // the render is not lost: keep it where it can be written
        match save_elsewhere(&output, &bytes) {
            Ok(saved) => anyhow::bail!("{e:#}; the image was saved to {} instead", saved.display()),
            Err(e2) => anyhow::bail!("{e:#}; saving it in the temporary folder failed too ({e2:#}): the image is lost"),
        }
    }
    say(output.display())?;
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
    let isa = match isa {
        None => None,
        Some("portable") => Some(rdr::accel::Isa::Portable),
        Some("avx2") => Some(rdr::accel::Isa::Avx2),
        Some("avx512") => Some(rdr::accel::Isa::Avx512),
        Some(other) => anyhow::bail!("--isa: unknown instruction set '{other}' (portable, avx2, avx512)"),
    };
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

/// `rdr bench SCENE.json`: load, build and render without writing.
fn bench_scene(args: &SceneArgs) -> Result<ExitCode> {
    setup_threads(args.threads)?;
    let t0 = Instant::now();
    let Loaded { scene, job } = load(args, true)?;
    let load_s = t0.elapsed().as_secs_f64();
    let out = rdr::render(&scene, &job, &RenderControl::default());
    use std::fmt::Write as _;
    let mut t = String::new();
    let _ = writeln!(t, "scene            {}", args.scene.display());
    let _ = writeln!(t, "threads          {}", rayon::current_num_threads());
    let _ = writeln!(t, "cpu              {}", rdr::bench::cpu_line(scene.bvh.isa()));
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
