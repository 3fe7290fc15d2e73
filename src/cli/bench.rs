//! `rdr bench`: a scene's load, build and render timings, or a mesh's BVH benchmark.

use super::common::{check_threads, load, say, setup_threads};
use super::SceneArgs;
use anyhow::{Context, Result};
use rdr::{Loaded, RenderControl};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

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
pub fn bench_mesh(
    args: &SceneArgs,
    repeat: usize,
    isa: Option<&str>,
    rays: Vec<String>,
    trace_only: bool,
    ray_files: Vec<PathBuf>,
    split_budget: Option<f32>,
) -> Result<ExitCode> {
    if let Some(b) = split_budget {
        anyhow::ensure!((0.0..=4.0).contains(&b), "--split-budget {b}: must be between 0 and 4");
    }
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
        split_budget,
    };
    let report = rdr::bench::run(&args.scene, &opts)?;
    say(report.text.trim_end_matches('\n'))?;
    anyhow::ensure!(
        report.agrees,
        "closest-hit distances disagree with a distances file beyond the tolerance, or hits with the unsplit tree's (see above)"
    );
    Ok(ExitCode::SUCCESS)
}

/// `rdr bench SCENE.json`: load, build and render without writing.
pub fn bench_scene(args: &SceneArgs, isa: Option<&str>, packet: Option<usize>, record: Option<(PathBuf, usize)>) -> Result<ExitCode> {
    setup_threads(args.threads)?;
    run_scene(args, parse_isa(isa)?, packet, record)?;
    Ok(ExitCode::SUCCESS)
}

/// `rdr bench DIR`: the scene benchmark of every `DIR/*/bench.xml` (such as
/// ../shared/scenes/real), in name order, then one summary line per scene.
pub fn bench_folder(args: &SceneArgs, isa: Option<&str>, packet: Option<usize>) -> Result<ExitCode> {
    let dir = &args.scene;
    let entries = std::fs::read_dir(dir).with_context(|| format!("cannot read the folder '{}'", dir.display()))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| Some(e.ok()?.path().join("bench.xml")))
        .filter(|f| f.is_file())
        .collect();
    files.sort();
    anyhow::ensure!(!files.is_empty(), "'{}': no folder in it holds a bench.xml", dir.display());
    setup_threads(args.threads)?;
    let isa = parse_isa(isa)?;
    let mut summary = String::from("scene                            spp  render cpu s  samples per cpu s");
    for file in files {
        let name = file
            .parent()
            .and_then(|p| p.file_name())
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let one = SceneArgs {
            scene: file,
            ..args.clone()
        };
        let (spp, samples, cpu) = run_scene(&one, isa, packet, None)?;
        say("")?;
        // a render shorter than the CPU clock's tick has no rate
        summary += &match cpu.filter(|&c| c > 0.0) {
            Some(cpu) => format!("\n{name:<30} {spp:>5} {cpu:>13.3} {:>18.3e}", samples as f64 / cpu),
            None => format!("\n{name:<30} {spp:>5}  (no CPU time measured)"),
        };
    }
    say(summary)?;
    Ok(ExitCode::SUCCESS)
}

/// One scene's benchmark, printed; returns its spp, samples and render CPU seconds.
fn run_scene(
    args: &SceneArgs,
    isa: Option<rdr::accel::Isa>,
    packet: Option<usize>,
    record: Option<(PathBuf, usize)>,
) -> Result<(u32, u64, Option<f64>)> {
    // the outputs' names, checked before the render
    let record = match record {
        Some((rays, cap)) => {
            let name = rays.file_name().and_then(|n| n.to_str()).unwrap_or("");
            let Some(stem) = name.strip_suffix(".rays.f32").filter(|s| !s.is_empty()) else {
                anyhow::bail!("--record-rays '{}': the file name must end in .rays.f32", rays.display());
            };
            let obj = rays.with_file_name(format!("{stem}.obj"));
            anyhow::ensure!(
                obj != args.scene && rays != args.scene,
                "--record-rays '{}' would overwrite the scene",
                rays.display()
            );
            Some((rays, obj, std::sync::Arc::new(rdr::accel::record::RayLog::new(cap))))
        }
        None => None,
    };
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
    if let Some((_, _, log)) = &record {
        anyhow::ensure!(
            scene.instances.is_empty(),
            "--record-rays: the scene uses instances (flat scenes only)"
        );
        scene.bvh.log = Some(log.clone());
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
    if let Some((rays_path, obj_path, log)) = record {
        scene.bvh.log = None;
        let rays = log.take();
        let obj = rdr::bench::export::scene_obj(&scene.prims)?;
        std::fs::write(&obj_path, obj).with_context(|| format!("cannot write '{}'", obj_path.display()))?;
        std::fs::write(&rays_path, rdr::bench::export::ray_bytes(&rays))
            .with_context(|| format!("cannot write '{}'", rays_path.display()))?;
        let _ = writeln!(
            t,
            "recorded         {} closest-hit rays to {}, triangles to {}",
            rays.len(),
            rays_path.display(),
            obj_path.display()
        );
    }
    say(t.trim_end_matches('\n'))?;
    Ok((out.spp_done, out.samples, render_cpu))
}
