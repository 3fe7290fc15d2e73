//! The `rdr` command line.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rdr::imageio::{check_output_path, write_image, ExrPixels};
use rdr::integrator::StopToken;
use rdr::{Loaded, Profile, RenderControl};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

#[derive(Parser)]
#[command(name = "rdr", version, about = "A physically based CPU ray tracer for RDR171 JSON scenes")]
struct Cli {
    #[command(subcommand)]
    command: Command,
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
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
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
        } => {
            let ext = args.scene.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
            if ext == "obj" || ext == "ply" {
                bench_mesh(&args, repeat, isa.as_deref(), rays, trace_only)
            } else {
                bench_scene(&args)
            }
        }
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            let msg: Vec<String> = e.chain().map(|c| c.to_string()).collect();
            eprintln!("error: {}", msg.join(": "));
            ExitCode::from(1)
        }
    }
}

fn profile(args: &SceneArgs) -> Profile {
    match args.compat {
        Some(Compat::Rdr171) => Profile::Rdr171,
        None => Profile::Physical,
    }
}

fn setup_threads(threads: Option<usize>) -> Result<()> {
    if let Some(n) = threads {
        anyhow::ensure!(n > 0, "--threads must be at least 1");
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
            eprintln!("warning: {w}");
        }
    }
    if let Some(spp) = args.spp {
        anyhow::ensure!(spp > 0, "--spp must be at least 1");
        loaded.job.spp = spp;
    }
    loaded.job.seed = args.seed;
    Ok(loaded)
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
    check_output_path(&output)?;

    let stop = Arc::new(StopToken::new());
    {
        let stop = stop.clone();
        ctrlc::set_handler(move || {
            if stop.stop_again() {
                std::process::exit(130);
            }
            eprintln!("\ninterrupted: saving the finished passes (press Ctrl-C again to quit at once)");
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
        eprintln!("warning: {} sample(s) were NaN or infinite and were left out", out.invalid_samples);
    }
    write_image(&output, out.width, out.height, &out.pixels, exr)?;
    println!("{}", output.display());
    if !quiet {
        eprintln!(
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
fn bench_mesh(args: &SceneArgs, repeat: usize, isa: Option<&str>, rays: Vec<String>, trace_only: bool) -> Result<ExitCode> {
    let all = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    anyhow::ensure!(all > 0, "--threads must be at least 1");
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
    };
    print!("{}", rdr::bench::run(&args.scene, &opts)?);
    Ok(ExitCode::SUCCESS)
}

/// `rdr bench SCENE.json`: load, build and render without writing.
fn bench_scene(args: &SceneArgs) -> Result<ExitCode> {
    setup_threads(args.threads)?;
    let t0 = Instant::now();
    let Loaded { scene, job } = load(args, true)?;
    let load_s = t0.elapsed().as_secs_f64();
    let out = rdr::render(&scene, &job, &RenderControl::default());
    println!("scene            {}", args.scene.display());
    println!("threads          {}", rayon::current_num_threads());
    println!("primitives       {} ({} triangles)", scene.prims.len(), scene.triangle_count());
    println!(
        "load + build     {:.1} ms (BVH {:.2} ms, {} nodes)",
        load_s * 1e3,
        scene.bvh_seconds * 1e3,
        scene.bvh.nodes.len()
    );
    println!(
        "render           {}x{} at {} spp in {:.3} s",
        out.width, out.height, out.spp_done, out.seconds
    );
    println!("samples/s        {:.3e}", out.samples as f64 / out.seconds);
    if out.rays > 0 {
        println!(
            "rays/s           {:.3e} ({:.2} rays per sample)",
            out.rays as f64 / out.seconds,
            out.rays as f64 / out.samples as f64
        );
    }
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
    let (rel, noise) = rdr::metrics::rel_mse(&x, &r, v.as_ref());
    let (mx, mr) = (x.mean(), r.mean());
    println!(
        "mean RGB      {:.5} {:.5} {:.5}   (reference {:.5} {:.5} {:.5})",
        mx.x, mx.y, mx.z, mr.x, mr.y, mr.z
    );
    println!("relMSE        {rel:.4e}");
    if v.is_some() {
        println!("of which the reference's own noise {noise:.4e}");
    }
    Ok(ExitCode::SUCCESS)
}
