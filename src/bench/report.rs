//! The benchmark itself: build timings, the kernel check and the table.

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
pub fn run(path: &Path, opts: &Options) -> Result<String> {
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
                let bvh = WideBvh::build(&input);
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
    let eps = 1e-4 * b.extent().length().max(1e-20);
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
    writeln!(out, "kernels       {} (the table below)", isa.name())?;

    // the table
    write!(out, "\n{:<11}", "Mrays/s")?;
    for (t, _) in &pools {
        write!(out, " | {:>8} {:>8}", format!("{t}T close"), format!("{t}T any"))?;
    }
    writeln!(out, " | hit %")?;
    for (name, rays) in sets
        .iter()
        .filter(|(name, _)| opts.rays.is_empty() || opts.rays.iter().any(|r| r == name))
    {
        write!(out, "{name:<11}")?;
        let mut hit_frac = 0.0;
        for (_, pool) in &pools {
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
    Ok(out)
}
