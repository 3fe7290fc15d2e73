//! The benchmark itself: build timings, the kernel check and the table.

use super::ray_file::{distances_path, read_distances, read_rays, Agreement, T_TOLERANCE};
use super::rays::{bounce_rays, incoherent_rays, primary_rays};
use super::timing::{time_rays, timed};
use super::{load_mesh, Options, RAY_SETS};
use crate::accel::reference::{check, Reference, Tracer, Wide};
use crate::accel::wide::{TriBlock, WideNode};
use crate::accel::{Isa, WideBvh};
use crate::geometry::prim::{prim_bounds, Hit};
use crate::geometry::{Aabb, Ray};
use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// Runs the mesh benchmark and returns the report.
pub fn run(path: &Path, opts: &Options) -> Result<Report> {
    if let Some(r) = opts.rays.iter().find(|r| !RAY_SETS.contains(&r.as_str())) {
        bail!("--rays: unknown ray set '{r}' ({})", RAY_SETS.join(", "));
    }
    let mut out = String::new();
    let t0 = Instant::now();
    let prims = load_mesh(path)?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let n = prims.len();
    writeln!(out, "mesh          {} ({n} triangles, loaded in {load_ms:.0} ms)", path.display())?;
    let pools: Vec<(usize, rayon::ThreadPool)> = opts
        .threads
        .iter()
        .map(|&t| Ok((t, rayon::ThreadPoolBuilder::new().num_threads(t).build()?)))
        .collect::<Result<_>>()?;

    // build, best of `repeat`, on each thread count
    let mut built = None;
    for (threads, pool) in &pools {
        let mut best = f64::INFINITY;
        let runs = if opts.trace_only { 1 } else { opts.repeat.max(1) };
        for _ in 0..runs {
            let input = prims.clone();
            let (t, b) = timed(pool, || {
                let bvh = match opts.split_budget {
                    Some(budget) => WideBvh::build_split(&input, budget),
                    None => WideBvh::build(&input),
                };
                (input, bvh)
            });
            best = best.min(t);
            built = Some(b);
        }
        writeln!(
            out,
            "build         {:>7.1} ms  {:>6.2} Mtri/s  ({} thread{})",
            best * 1e3,
            n as f64 / best / 1e6,
            threads,
            if *threads == 1 { "" } else { "s" }
        )?;
    }
    let (ordered, bvh) = built.context("no thread count given")?;
    let bytes = bvh.memory_bytes();
    writeln!(
        out,
        "size          {:.1} MB, {:.1} bytes/triangle ({} nodes of {} B, {} blocks of {} B, stack {}; the scene's primitive list not counted)",
        bytes as f64 / 1e6,
        bytes as f64 / n as f64,
        bvh.nodes.len(),
        std::mem::size_of::<WideNode>(),
        bvh.blocks.len(),
        std::mem::size_of::<TriBlock>(),
        bvh.stack_need(),
    )?;
    // the same triangles without pre-splitting: what the split tree's hits must equal
    let unsplit = WideBvh::build_split(&ordered, 0.0);
    let refs: usize = bvh.children().map(|(_, _, c)| bvh.leaf_prims(c).len()).sum();
    writeln!(
        out,
        "quality       SAH cost {:.2} ({:.2} without pre-splitting), {refs} leaf references for {n} triangles",
        bvh.sah_cost(),
        unsplit.sah_cost()
    )?;

    let isa = opts.isa.unwrap_or_else(Isa::detect);
    let mut chosen = bvh.clone();
    if !chosen.set_isa(isa) {
        bail!("this CPU cannot run the {} kernels", isa.name());
    }
    let tracer = Wide {
        prims: &ordered,
        bvh: &chosen,
    };
    let reference = Reference::new(&ordered);
    let b = ordered.iter().map(prim_bounds).fold(Aabb::EMPTY, Aabb::union);
    let primary = primary_rays(&b, 1000);
    let incoherent = incoherent_rays(&b, 1_000_000, 0x5EED);
    let primary_hits: Vec<Option<Hit>> = pools[pools.len() - 1]
        .1
        .install(|| primary.par_iter().map(|r| tracer.closest(r)).collect());
    // 1e-4 of the bounding sphere's radius, as embree_rays.py
    let eps = 1e-4 * 0.5 * b.extent().length().max(1e-20);
    let bounce = bounce_rays(&ordered, &primary, &primary_hits, 1_000_000, eps, 0xB0B);
    let sets: Vec<(&str, &Vec<Ray>)> = RAY_SETS.into_iter().zip([&primary, &incoherent, &bounce]).collect();

    // correctness on a sample: every instruction set, closest and any hit
    let checked_isas = if opts.trace_only { Vec::new() } else { Isa::all_available() };
    for isa in checked_isas {
        let mut v = bvh.clone();
        v.set_isa(isa);
        let t = Wide { prims: &ordered, bvh: &v };
        let mut bad = Vec::new();
        let mut checked = 0;
        for (_, rays) in &sets {
            let step = (rays.len() / 2000).max(1);
            checked += rays.len().div_ceil(step);
            bad.extend(check(&reference, &t, &ordered, rays, step));
        }
        if bad.is_empty() {
            writeln!(
                out,
                "check         {}: closest and any hit agree with the reference on {checked} rays",
                isa.name()
            )?;
        } else {
            writeln!(
                out,
                "check         {}: {} DISAGREEMENTS on {checked} rays, e.g. {}",
                isa.name(),
                bad.len(),
                bad[0]
            )?;
        }
    }
    writeln!(out, "cpu           {}", super::cpu_line(isa))?;
    writeln!(out, "kernels       {} (the table below)", isa.name())?;
    let generated = opts.ray_files.is_empty() || !opts.rays.is_empty();
    if generated {
        table(&mut out, &sets, &pools, &tracer, opts)?;
    }
    let mut all_ok = true;
    for file in &opts.ray_files {
        all_ok &= ray_file_line(&mut out, file, &pools, &tracer, opts.repeat)?;
        let unsplit = Wide {
            prims: &ordered,
            bvh: &unsplit,
        };
        all_ok &= visits_line(&mut out, file, &tracer, &unsplit)?;
    }
    Ok(Report { text: out, agrees: all_ok })
}

/// One line for a ray file: inner nodes visited and primitives tested per closest-hit
/// ray in the tree and in the tree without pre-splitting (portable traversal, a sample
/// of 100,000 rays), and whether both trees give every ray the same hit (primitive,
/// distance and barycentric bits). False when they do not.
fn visits_line(out: &mut String, file: &Path, tracer: &Wide, unsplit: &Wide) -> Result<bool> {
    let rays = read_rays(file)?;
    let step = (rays.len() / 100_000).max(1);
    let visits = |w: &Wide| {
        let (mut nodes, mut tests) = (0usize, 0usize);
        for r in rays.iter().step_by(step) {
            w.bvh.traverse_counted(
                r,
                |p, t_max| {
                    tests += 1;
                    if let Some((t, _)) = w.prims[p as usize].intersect(r, *t_max) {
                        *t_max = t;
                    }
                    false
                },
                &mut nodes,
            );
        }
        let k = rays.len().div_ceil(step) as f64;
        (nodes as f64 / k, tests as f64 / k)
    };
    let ((n1, t1), (n0, t0)) = (visits(tracer), visits(unsplit));
    let key = |h: Option<Hit>| h.map(|h| (h.prim, h.t.to_bits(), h.b.map(f32::to_bits)));
    let differ: Vec<usize> = (0..rays.len())
        .into_par_iter()
        .filter(|&i| key(tracer.closest(&rays[i])) != key(unsplit.closest(&rays[i])))
        .collect();
    write!(
        out,
        "  per ray: {n1:.1} nodes, {t1:.1} triangle tests ({n0:.1} and {t0:.1} without pre-splitting); \
         hits differing from the unsplit tree's: {}",
        differ.len()
    )?;
    if let Some(&i) = differ.first() {
        let show = |h: Option<Hit>| h.map_or("none".to_string(), |h| format!("triangle {} at t {:e}", h.prim, h.t));
        write!(
            out,
            " (ray {i}: {} split, {} unsplit)",
            show(tracer.closest(&rays[i])),
            show(unsplit.closest(&rays[i]))
        )?;
    }
    writeln!(out)?;
    Ok(differ.is_empty())
}

/// The benchmark's output.
pub struct Report {
    pub text: String,
    /// False when a ray file's distances disagree beyond the tolerance.
    pub agrees: bool,
}

/// The table of the generated ray sets.
fn table(out: &mut String, sets: &[(&str, &Vec<Ray>)], pools: &[(usize, rayon::ThreadPool)], tracer: &Wide, opts: &Options) -> Result<()> {
    write!(out, "\n{:<11}", "Mrays/s")?;
    for (t, _) in pools {
        write!(out, " | {:>8} {:>8}", format!("{t}T close"), format!("{t}T any"))?;
    }
    writeln!(out, " | hit %")?;
    for (name, rays) in sets
        .iter()
        .filter(|(name, _)| opts.rays.is_empty() || opts.rays.iter().any(|r| r == name))
    {
        write!(out, "{name:<11}")?;
        let mut hit_frac = 0.0;
        for (_, pool) in pools {
            let (tc, hits) = time_rays(pool, rays, opts.repeat, &|r| tracer.closest(r).is_some());
            let (ta, hits_any) = time_rays(pool, rays, opts.repeat, &|r| tracer.any(r));
            if hits != hits_any {
                writeln!(out, "  (closest hits {hits}, any hits {hits_any}: MISMATCH)")?;
            }
            hit_frac = hits as f64 / rays.len().max(1) as f64;
            let m = |t: f64| rays.len() as f64 / t / 1e6;
            write!(out, " | {:>8.2} {:>8.2}", m(tc), m(ta))?;
        }
        writeln!(out, " | {:>5.1}", hit_frac * 100.0)?;
    }
    Ok(())
}

/// One line for a ray file: its name, then `1T closest X any Y` Mrays/s per thread
/// count, the hit percentage and the check against its distances file. False when
/// the check fails.
fn ray_file_line(out: &mut String, file: &Path, pools: &[(usize, rayon::ThreadPool)], tracer: &Wide, repeat: usize) -> Result<bool> {
    let rays = read_rays(file)?;
    let name = file
        .file_name()
        .map_or_else(|| file.display().to_string(), |n| n.to_string_lossy().into_owned());
    write!(out, "{name}")?;
    let mut hits = 0;
    for (threads, pool) in pools {
        let (tc, h) = time_rays(pool, &rays, repeat, &|r| tracer.closest(r).is_some());
        let (ta, _) = time_rays(pool, &rays, repeat, &|r| tracer.any(r));
        hits = h;
        let m = |t: f64| rays.len() as f64 / t / 1e6;
        write!(out, "  {threads}T closest {:.2} any {:.2}", m(tc), m(ta))?;
    }
    write!(
        out,
        "  Mrays/s, {} rays, hit {:.1} %",
        rays.len(),
        100.0 * hits as f64 / rays.len() as f64
    )?;
    let mut ok = true;
    match distances_path(file).filter(|p| p.exists()) {
        None => write!(out, ", no distances file")?,
        Some(tp) => {
            let theirs = read_distances(&tp, rays.len())?;
            let pool = &pools[pools.len() - 1].1;
            let ours: Vec<f32> = pool.install(|| rays.par_iter().map(|r| tracer.closest(r).map_or(f32::INFINITY, |h| h.t)).collect());
            let a = Agreement::compare(&ours, &theirs);
            ok = a.ok(rays.len());
            let tp_name = tp.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            write!(
                out,
                ", vs {tp_name}: {} hit/miss and {} distance (> {:e} relative) disagreements, {}",
                a.hit_miss,
                a.distance,
                T_TOLERANCE,
                if ok { "ok" } else { "TOO MANY" }
            )?;
        }
    }
    writeln!(out)?;
    Ok(ok)
}
