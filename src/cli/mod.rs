//! The subcommands of `rdr`, one module each, and their command-line definitions.

use anyhow::Result;
use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
use std::process::ExitCode;

mod bench;
pub mod common;
mod compare;
mod convert;
mod merge;
mod render;
mod signals;

#[derive(Parser)]
#[command(
    name = "rdr",
    version,
    about = "A physically based CPU ray tracer for RDR171 JSON (.json) and Mitsuba 3 XML (.xml) scenes"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// Memory the large buffers (film, images, meshes) may take, such as 8G or 512M;
    /// default half of what this process may use (physical memory, address-space
    /// limit, cgroup limit, whichever is smallest).
    #[arg(long, global = true, value_name = "SIZE", value_parser = parse_size)]
    pub max_memory: Option<u64>,
}

fn parse_define(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((k, v)) if !k.is_empty() && k.chars().all(|c| c.is_alphanumeric() || c == '_') => Ok((k.to_string(), v.to_string())),
        _ => Err(format!("expected NAME=VALUE (a name of letters, digits and _), found '{s}'")),
    }
}

/// `WxH` of `--res`, such as 640x480.
fn parse_res(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected WIDTHxHEIGHT in pixels (such as 640x480), found '{s}'");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (u32, u32) = (w.trim().parse().map_err(|_| bad())?, h.trim().parse().map_err(|_| bad())?);
    if w == 0 || h == 0 {
        return Err(bad());
    }
    Ok((w, h))
}

fn parse_size(s: &str) -> Result<u64, String> {
    rdr::limits::parse_bytes(s)
}

#[derive(Clone, Copy, ValueEnum)]
enum Compat {
    /// Reproduce the RDR171 course renderer's reference images bit for bit.
    Rdr171,
}

#[derive(clap::Args, Clone)]
pub struct SceneArgs {
    /// Scene file: RDR171 JSON (.json) or Mitsuba 3 XML (.xml).
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
    /// Image size in pixels, WIDTHxHEIGHT such as 640x480 (overrides the scene's film
    /// resolution; JSON and XML scenes alike).
    #[arg(long, value_name = "WxH", value_parser = parse_res)]
    res: Option<(u32, u32)>,
    /// Integrator to render with, at its default settings, in place of the scene's
    /// (path, bdpt, guided, ptracer, intersection_test, photon, sppm, normals); the
    /// scene's lights and spp stay.
    #[arg(long, value_name = "NAME")]
    integrator: Option<String>,
    #[command(flatten)]
    unknown: UnknownArgs,
}

/// What to do with scene keys and properties rdr does not know.
#[derive(clap::Args, Clone, Copy)]
pub struct UnknownArgs {
    /// JSON scenes: only warn about unknown keys (by default they are errors, with
    /// the closest known key suggested).
    #[arg(long)]
    lenient: bool,
    /// Mitsuba XML scenes: refuse unknown properties (by default they are ignored
    /// with a warning, as scenes often carry properties of other Mitsuba versions).
    #[arg(long)]
    strict: bool,
}

/// Options of `rdr render` for long renders: resume, checkpoints, shards, previews.
#[derive(clap::Args, Default)]
pub struct FlowArgs {
    /// Continue from the passes the output's state file (OUT.state.exr) holds, after an
    /// interruption or to add passes up to a higher --spp; starts afresh when there is
    /// none yet.
    #[arg(long)]
    resume: bool,
    /// Write no state file beside an .exr output (OUT.state.exr: the film's exact sums,
    /// what --resume, --shard and `rdr merge` continue from).
    #[arg(long)]
    no_state: bool,
    /// Rewrite the output and its state file (atomically) every this many seconds
    /// while rendering, so a killed render can --resume from it.
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
pub enum Command {
    /// Render a scene to an image.
    Render {
        #[command(flatten)]
        args: SceneArgs,
        /// Output image, .exr (float32 RGB) or .png (8-bit sRGB); default `<scene>.exr`
        /// beside the scene file.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Render only this region of the film: pixel columns x0..x1 and rows y0..y1
        /// (x1 and y1 excluded), such as 100,50,300,200; the image is the region's size.
        #[arg(long, value_name = "x0,y0,x1,y1")]
        crop: Option<String>,
        /// Brighten (positive) or darken (negative) PNG images by this many stops
        /// (a factor 2^EXPOSURE) before the sRGB conversion; .exr images keep the
        /// radiance as rendered.
        #[arg(long, value_name = "STOPS", allow_negative_numbers = true)]
        exposure: Option<f32>,
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
        /// The parts (.exr files written by `rdr render --shard`; each part's state is
        /// read from its PART.state.exr, or from the part itself if it is a state file).
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// The merged image (.exr); its state file goes beside it (OUT.state.exr).
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
    /// Convert a scene between RDR171 JSON and Mitsuba 3 XML, by the extensions. Shapes
    /// JSON has no type for (such as Mitsuba's rectangle or cube) are written as OBJ
    /// meshes beside the output.
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
        #[command(flatten)]
        unknown: UnknownArgs,
    },
    /// Compare an image with a reference of the same size: mean RGB and the relative
    /// MSE, mean((x − r)² / (r² + 0.01)) over pixels and channels.
    Compare {
        /// The image to measure (.exr).
        image: PathBuf,
        /// The reference image (.exr), such as a long render of the same scene.
        reference: PathBuf,
        /// The reference's variance image (`<name>.var.exr`): also print the
        /// part of the error that is the reference's own noise.
        #[arg(long)]
        variance: Option<PathBuf>,
    },
    /// Benchmark: with a scene (.json or .xml), load, build and render it without writing
    /// it and print timings; with a folder, so every `FOLDER/*/bench.xml` (such as
    /// ../shared/scenes/real), then a line per scene of samples per CPU second; with a
    /// mesh (.obj or .ply), benchmark the BVH (build time and size, Mrays/s of primary,
    /// incoherent and bounce rays, closest and any hit, 1 and all threads) after checking
    /// every traversal variant against a reference.
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
        /// Mesh benchmark: pre-split large triangles (Karras and Aila 2013) within this
        /// many extra references per triangle (the paper's 0.3; default 0, as the renderer),
        /// and compare every hit with the unsplit tree's.
        #[arg(long)]
        split_budget: Option<f32>,
        /// Scene benchmark: record the closest-hit rays the render traces (up to
        /// --record-max) into FILE (NAME.rays.f32, the --ray-file format, each from its
        /// t_min on), and the scene's triangles into NAME.obj beside it (spheres and
        /// cylinders tessellated), for `rdr bench NAME.obj --ray-file FILE` and Embree.
        #[arg(long, value_name = "FILE")]
        record_rays: Option<PathBuf>,
        /// Scene benchmark: most rays --record-rays keeps (the first traced).
        #[arg(long, default_value_t = 4_000_000)]
        record_max: usize,
    },
}

/// Runs a subcommand.
pub fn run(command: Command) -> Result<ExitCode> {
    match command {
        Command::Render {
            args,
            output,
            crop,
            exposure,
            quiet,
            time_limit,
            flow,
        } => render::render(&args, output, quiet, time_limit, &flow, crop.as_deref(), exposure),
        Command::Merge {
            parts,
            output,
            partial,
            quiet,
        } => merge::merge(&parts, &output, partial, quiet),
        Command::Compare {
            image,
            reference,
            variance,
        } => compare::compare(&image, &reference, variance.as_deref()),
        Command::Convert {
            input,
            output,
            overrides,
            defines,
            quiet,
            unknown,
        } => convert::convert(&input, &output, &overrides, &defines, quiet, unknown),
        Command::Bench {
            args,
            repeat,
            isa,
            packet,
            rays,
            trace_only,
            ray_file,
            split_budget,
            record_rays,
            record_max,
        } => {
            let ext = args.scene.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
            if args.scene.is_dir() {
                anyhow::ensure!(
                    record_rays.is_none(),
                    "--record-rays takes one scene file, not the folder '{}'",
                    args.scene.display()
                );
                bench::bench_folder(&args, isa.as_deref(), packet)
            } else if ext == "obj" || ext == "ply" {
                bench::bench_mesh(&args, repeat, isa.as_deref(), rays, trace_only, ray_file, split_budget)
            } else {
                bench::bench_scene(&args, isa.as_deref(), packet, record_rays.map(|f| (f, record_max)))
            }
        }
    }
}
