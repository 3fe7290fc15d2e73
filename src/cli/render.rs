//! `rdr render`: one render, or a part of a long one (resume, checkpoints, shards, previews, tev, AOVs, denoise).

use super::common::{load_desc, profile, refuse_input_as_output, same_file, say, scene_changes, setup_threads};
use super::signals::{Interrupts, Phase};
use super::{FlowArgs, SceneArgs};
use anyhow::Result;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rdr::imageio::{check_output_path, encode_image, save_elsewhere, write_atomically, ExrChannel, ExrPixels};
use rdr::integrator::StopToken;
use rdr::limits::sanitize;
use rdr::math::Vec3;
use rdr::render::identity::RenderIdentity;
use rdr::render::session::{self, Caller};
use rdr::render::statefile::{self, StateHeader};
use rdr::render::{FilmState, Periodic, Snapshot};
use rdr::{Loaded, Profile, RenderControl};
use std::io::IsTerminal;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

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
    let beside = statefile::state_path(output);
    if !beside.exists() && !output.exists() {
        return Ok(None);
    }
    let Some((path, file)) = statefile::read_for(output)? else {
        anyhow::bail!(
            "{}: cannot resume: there is no {} beside it, and it holds no rdr film state itself (written by another program, or with --no-state or --compat rdr171)",
            output.display(),
            beside.file_name().unwrap_or_default().to_string_lossy()
        );
    };
    let name = path.display();
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

/// `x0,y0,x1,y1` of `--crop` (image rows from the top), checked against the film.
fn parse_crop(text: &str, width: u32, height: u32) -> Result<(u32, u32, u32, u32)> {
    let bad = |why: &str| anyhow::anyhow!("--crop '{}': {why}", sanitize(text));
    let n: Vec<u32> = text
        .split(',')
        .map(|v| v.trim().parse::<u32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| bad("expected four pixel numbers x0,y0,x1,y1 (such as 100,50,300,200)"))?;
    let [x0, y0, x1, y1] = n[..] else {
        return Err(bad("expected four pixel numbers x0,y0,x1,y1 (such as 100,50,300,200)"));
    };
    if !(x0 < x1 && y0 < y1) {
        return Err(bad("needs x0 < x1 and y0 < y1 (x1 and y1 are excluded)"));
    }
    if x1 > width || y1 > height {
        return Err(bad(&format!("reaches outside the {width}x{height} film")));
    }
    Ok((x0, y0, x1, y1))
}

/// `pixels` brightened by `gain` (`--exposure`), or as they are.
fn exposed(pixels: &[rdr::math::Vec3], gain: f32) -> std::borrow::Cow<'_, [rdr::math::Vec3]> {
    if gain == 1.0 {
        std::borrow::Cow::Borrowed(pixels)
    } else {
        std::borrow::Cow::Owned(pixels.iter().map(|p| *p * gain).collect())
    }
}

/// `rdr render`.
pub fn render(
    args: &SceneArgs,
    output: Option<PathBuf>,
    quiet: bool,
    time_limit: Option<f64>,
    flow: &FlowArgs,
    crop: Option<&str>,
    exposure: Option<f32>,
) -> Result<ExitCode> {
    session::check_time_limit(time_limit, Caller::Cli).map_err(anyhow::Error::msg)?;
    for (name, t) in [("--checkpoint", flow.checkpoint), ("--preview", flow.preview)] {
        if let Some(t) = t {
            anyhow::ensure!(t.is_finite() && t > 0.0, "{name} must be a positive number of seconds");
        }
    }
    let shard = flow.shard.as_deref().map(parse_shard).transpose()?;
    if let Some(text) = &flow.aov {
        rdr::film::aov::AovSet::parse(text).map_err(|e| anyhow::anyhow!("--aov '{}': {e}", sanitize(text)))?;
    }
    setup_threads(args.threads)?;
    let (Loaded { scene, mut job }, desc) = load_desc(args, quiet)?;
    // --aov, else the layers the scene asks for (Mitsuba's `aov` integrator)
    let aov = match flow.aov.as_ref().or(desc.integrator.aovs.as_ref()) {
        Some(text) => rdr::film::aov::AovSet::parse(text).map_err(|e| anyhow::anyhow!("--aov '{}': {e}", sanitize(text)))?,
        None => rdr::film::aov::AovSet::default(),
    };
    job.time_limit = time_limit;
    if flow.denoise {
        // a denoiser needs each pixel's noise its own: samples drawn from the filter
        job.film.sampling = rdr::film::FilmSampling::importance(&job.film.filter);
    }
    let output = output.unwrap_or_else(|| default_output(&args.scene));
    let is_png = output.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"));
    let gain = match exposure {
        Some(e) => {
            anyhow::ensure!(
                e.is_finite() && e.abs() <= 64.0,
                "--exposure must be a number of stops between -64 and 64"
            );
            anyhow::ensure!(
                is_png || flow.preview.is_some(),
                "--exposure: applies to PNG images, and {} is not one (an .exr keeps the radiance as rendered)",
                output.display()
            );
            2f32.powf(e)
        }
        None => 1.0,
    };
    if let Some(text) = crop {
        let (x0, y0, x1, y1) = parse_crop(text, job.film.width, job.film.height)?;
        anyhow::ensure!(
            !matches!(job.integrator.name(), "bdpt" | "ptracer"),
            "--crop: the {} integrator splats light paths over the whole film; crop with path, guided, photon, sppm or the others",
            job.integrator.name()
        );
        anyhow::ensure!(matches!(profile(args), Profile::Physical), "--crop: not with --compat rdr171");
        // film rows count from the bottom
        job.camera.crop(x0, job.film.height - y1, x1 - x0, y1 - y0);
        (job.film.width, job.film.height) = (x1 - x0, y1 - y0);
    }
    // Fail before the render, not after it.
    if same_file(&output, &args.scene) {
        anyhow::bail!(
            "{}: refusing to write the image over the scene file (choose another output with -o)",
            output.display()
        );
    }
    refuse_input_as_output(&output, &desc.input_files(), "the scene's files")?;
    check_output_path(&output)?;
    let is_exr = output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let state_path = statefile::state_path(&output);
    if is_exr && !flow.no_state {
        let mut inputs = desc.input_files();
        inputs.push(args.scene.clone());
        refuse_input_as_output(&state_path, &inputs, "the scene's files")?;
    }
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
        anyhow::ensure!(
            !flow.no_state || what == "--checkpoint",
            "{what}: not with --no-state (the passes continue from the state file {})",
            state_path.display()
        );
    }
    if flow.denoise {
        rdr::render::denoise::check().map_err(|e| anyhow::anyhow!("--denoise: {e}"))?;
    }
    for what in ["--aov", "--denoise"] {
        if (what == "--aov" && !aov.any()) || (what == "--denoise" && !flow.denoise) {
            continue;
        }
        session::check_features(&what[2..], &job, profile(args), Caller::Cli).map_err(anyhow::Error::msg)?;
        anyhow::ensure!(
            !flow.resume && shard.is_none(),
            "{what}: not with --resume or --shard yet (the feature sums are not kept in the film state)"
        );
    }
    if aov.any() {
        anyhow::ensure!(is_exr, "--aov: needs an .exr output ({} cannot hold layers)", output.display());
    }
    let identity = if physical && is_exr {
        Some(RenderIdentity::of(
            &args.scene,
            &args.overrides,
            &scene_changes(args, crop),
            &desc,
            job.seed,
        )?)
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
    let interrupts = Interrupts::install(stop.clone(), output.display().to_string())?;
    let exr = match profile(args) {
        Profile::Physical => ExrPixels::Float,
        Profile::Rdr171 => ExrPixels::HalfTinyexr,
    };
    // the files of a render so far, in the order they are written: the state file
    // (`state_pixels`, its pieces), then the image (`pixels` and the layers)
    let keep_state = header.is_some() && resumable && !flow.no_state;
    let encode = {
        let (output, state_path, header) = (output.clone(), state_path.clone(), header.clone());
        move |w: u32,
              h: u32,
              state_pixels: &[Vec3],
              pixels: &[Vec3],
              state: &FilmState,
              layers: Vec<ExrChannel>|
              -> Result<Vec<(PathBuf, Vec<u8>)>> {
            Ok(match &header {
                Some(hd) => {
                    let mut files = Vec::new();
                    if keep_state {
                        files.push((
                            state_path.clone(),
                            statefile::encode(w, h, state_pixels, state, true, hd, Vec::new()),
                        ));
                    }
                    files.push((output.clone(), statefile::encode_image(w, h, pixels, state, hd, layers)));
                    files
                }
                None => vec![(
                    output.clone(),
                    encode_image(&output, w, h, &exposed(pixels, if is_png { gain } else { 1.0 }), exr)?,
                )],
            })
        }
    };
    let encode = Arc::new(encode);
    let write_all = |files: Vec<(PathBuf, Vec<u8>)>| files.iter().try_for_each(|(path, bytes)| write_atomically(path, bytes));
    let mut periodic = Vec::new();
    if let Some(every) = flow.checkpoint {
        let encode = encode.clone();
        periodic.push(Periodic {
            every,
            call: Arc::new(move |snap: &Snapshot| {
                let written = encode(snap.width, snap.height, snap.pixels, snap.pixels, snap.state, Vec::new()).and_then(write_all);
                if let Err(e) = written {
                    note!("warning: checkpoint: {e:#}");
                }
            }),
        });
    }
    if let Some(every) = flow.preview {
        let encode = encode.clone();
        let png = preview_path(&output);
        periodic.push(Periodic {
            every,
            call: Arc::new(move |snap: &Snapshot| {
                let written = rdr::imageio::write_png(&png, snap.width, snap.height, &exposed(snap.pixels, gain))
                    .and_then(|_| encode(snap.width, snap.height, snap.pixels, snap.pixels, snap.state, Vec::new()))
                    .and_then(write_all);
                if let Err(e) = written {
                    note!("warning: preview: {e:#}");
                }
            }),
        });
    }
    // the viewer gets the image through a sender thread: a stalled tev costs the render nothing
    let tev = match &flow.tev {
        Some(addr) => {
            let name = output.file_name().map_or("rdr".into(), |n| n.to_string_lossy().into_owned());
            let on_error = Box::new(|e: String| note!("warning: --tev: {e}; no more updates"));
            let t = rdr::render::tev::Tev::connect(addr, &name, job.film.width, job.film.height, on_error)
                .map_err(|e| anyhow::anyhow!("--tev {addr}: cannot connect to tev: {e}"))?;
            Some(Arc::new(t))
        }
        None => None,
    };
    if let Some(tev) = &tev {
        let tev = tev.clone();
        periodic.push(Periodic {
            every: 0.5,
            call: Arc::new(move |snap: &Snapshot| {
                tev.update(snap.width, snap.height, snap.pixels);
            }),
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
    let pool = session::thread_pool(args.threads, Caller::Cli).map_err(anyhow::Error::msg)?;
    let out = session::run(&scene, &job, &control, start, aov.any() || flow.denoise, &pool);
    // the periodic callbacks hold the viewer: let them go
    drop(control);
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
    if flow.preview.is_some() {
        if let Err(e) = rdr::imageio::write_png(&preview_path(&output), out.width, out.height, &exposed(&out.pixels, gain)) {
            note!("warning: preview: {e:#}");
        }
    }
    let layers = out.aov.as_ref().map_or_else(Vec::new, |sums| rdr::film::aov::channels(sums, aov));
    let clean = if flow.denoise {
        let sums = out.aov.as_ref().expect("feature sums for --denoise");
        let (albedo, normal) = (rdr::film::aov::layer_rgb(sums, 0), rdr::film::aov::layer_rgb(sums, 3));
        let clean = rdr::render::denoise::denoise(out.width, out.height, &out.pixels, &albedo, &normal)
            .map_err(|e| anyhow::anyhow!("--denoise: {e}"))?;
        Some(clean)
    } else {
        None
    };
    interrupts.set_phase(Phase::Saving);
    // the image is the denoised one; the state file keeps the noisy image its passes make
    let image = clean.as_deref().unwrap_or(&out.pixels);
    let files = encode(out.width, out.height, &out.pixels, image, &out.state, layers)?;
    let mut lost = Vec::new();
    for (path, bytes) in &files {
        if let Err(e) = write_atomically(path, bytes) {
            // the render is not lost: keep it where it can be written
            lost.push(match save_elsewhere(path, bytes) {
                Ok(saved) => format!("{e:#}; it was saved to {} instead", saved.display()),
                Err(e2) => format!("{e:#}; saving it in the temporary folder failed too ({e2:#}): it is lost"),
            });
        }
    }
    if !lost.is_empty() {
        anyhow::bail!("{}", lost.join("; "));
    }
    interrupts.set_phase(Phase::Saved);
    say(output.display())?;
    // the image is saved: the viewer gets the last one if it takes it within a second
    if let Some(tev) = tev.and_then(|t| Arc::try_unwrap(t).ok()) {
        if tev.update(out.width, out.height, image) && !tev.finish(std::time::Duration::from_secs(1)) {
            note!("warning: --tev: the viewer did not take the last image within 1 s; not waiting for it");
        }
    }
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
