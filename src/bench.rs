//! `rdr bench MESH`: the acceleration-structure benchmark.
//!
//! Loads a triangle mesh (OBJ or PLY), builds the BVH the renderer uses and
//! reports build time and size, then traces three fixed ray sets with closest-hit
//! and any-hit queries on one thread and on all threads:
//!
//! * **primary**: 1000×1000 pinhole rays, 40° field of view, the camera looking at
//!   the centre of the bounding box from front-right-above (direction (1, 1, 1)),
//!   pulled back until all eight corners of the box are inside the image;
//! * **incoherent**: 1,000,000 rays from uniform points on the bounding sphere
//!   towards uniform points inside the box (fixed seed);
//! * **bounce**: 1,000,000 cosine-distributed rays leaving the primary hit points
//!   (hit points reused in turn when fewer than a million primary rays hit),
//!   offset along the geometric normal on the side the primary ray came from.
//!
//! Ray figures are the CPU time of the busiest worker thread (Linux `schedstat`;
//! the workers claim chunks of rays until none are left), so time the OS gives
//! other processes does not inflate them, for one thread and for many alike.
//! Build figures are the worker's CPU time on one thread and wall-clock time on
//! more (the build's threads idle in turn). Each is the best of `--repeat` runs.
//!
//! Before timing, every traversal variant is checked against a simple reference
//! (a binary BVH visited through a closure with the scalar watertight kernel) on a
//! sample of each ray set.

use crate::accel::{Isa, WideBvh};
use crate::geometry::mesh::Mesh;
use crate::geometry::{obj, Aabb, Ray};
use crate::math::{Mat4, Vec3};
use crate::scene::{Hit, Prim};
use anyhow::{bail, Context, Result};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// Fixed-seed generator for the ray sets.
type Rng = crate::sampling::SplitMix64;

/// Triangles of an OBJ or PLY file as scene primitives (object 0), degenerate
/// (zero-area) triangles dropped.
pub fn load_mesh(path: &Path) -> Result<Vec<Prim>> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read '{}'", path.display()))?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let data = match ext.as_str() {
        "obj" => obj::parse(&String::from_utf8_lossy(&bytes)).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?,
        "ply" => parse_ply(&bytes).with_context(|| format!("{}", path.display()))?,
        _ => bail!("'{}': the mesh benchmark reads .obj and .ply files", path.display()),
    };
    let (mesh, _) = Mesh::from_obj(data, &Mat4::IDENTITY, Vec3::ZERO, true);
    if mesh.triangles.is_empty() {
        bail!("'{}' has no (non-degenerate) triangles", path.display());
    }
    Ok((0..mesh.triangles.len())
        .map(|i| Prim::Triangle {
            p: mesh.vertices(i),
            object: 0,
            index: i as u32,
        })
        .collect())
}

/// A minimal PLY reader: `ascii` or `binary_little_endian`, vertex `x y z`
/// (any scalar types; other properties skipped), faces as a list property
/// (fans for polygons). Other elements must come after the faces or be empty.
pub fn parse_ply(bytes: &[u8]) -> Result<obj::ObjData> {
    let header_end = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .context("no 'end_header' in the PLY header")?;
    let header = std::str::from_utf8(&bytes[..header_end]).context("PLY header is not text")?;
    let mut body = header_end + 10;
    while body < bytes.len() && bytes[body] != b'\n' {
        body += 1;
    }
    body += 1;
    let mut format = "";
    // (name, count, properties); a property is (type, Some(count type) for lists, name)
    type Prop = (String, Option<String>, String);
    let mut elements: Vec<(String, usize, Vec<Prop>)> = Vec::new();
    for line in header.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["format", f, ..] => format = f,
            ["element", name, n] => elements.push((name.to_string(), n.parse().context("bad element count")?, Vec::new())),
            ["property", "list", ct, t, name] => {
                elements
                    .last_mut()
                    .context("property before element")?
                    .2
                    .push((t.to_string(), Some(ct.to_string()), name.to_string()))
            }
            ["property", t, name] => {
                elements
                    .last_mut()
                    .context("property before element")?
                    .2
                    .push((t.to_string(), None, name.to_string()))
            }
            _ => {}
        }
    }
    let binary = match format {
        "ascii" => false,
        "binary_little_endian" => true,
        f => bail!("unsupported PLY format '{f}'"),
    };
    let size = |t: &str| -> Result<usize> {
        Ok(match t {
            "char" | "uchar" | "int8" | "uint8" => 1,
            "short" | "ushort" | "int16" | "uint16" => 2,
            "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
            "double" | "float64" => 8,
            _ => bail!("unknown PLY type '{t}'"),
        })
    };
    let mut pos = body;
    let mut words = if binary {
        None
    } else {
        Some(
            std::str::from_utf8(&bytes[body..])
                .context("PLY body is not text")?
                .split_whitespace(),
        )
    };
    let mut read = |t: &str| -> Result<f64> {
        if let Some(words) = words.as_mut() {
            return words.next().context("PLY body ends early")?.parse::<f64>().context("bad number");
        }
        let n = size(t)?;
        let b = bytes.get(pos..pos + n).context("PLY body ends early")?;
        pos += n;
        Ok(match t {
            "char" | "int8" => b[0] as i8 as f64,
            "uchar" | "uint8" => b[0] as f64,
            "short" | "int16" => i16::from_le_bytes([b[0], b[1]]) as f64,
            "ushort" | "uint16" => u16::from_le_bytes([b[0], b[1]]) as f64,
            "int" | "int32" => i32::from_le_bytes(b.try_into()?) as f64,
            "uint" | "uint32" => u32::from_le_bytes(b.try_into()?) as f64,
            "float" | "float32" => f32::from_le_bytes(b.try_into()?) as f64,
            _ => f64::from_le_bytes(b.try_into()?),
        })
    };
    let mut data = obj::ObjData::default();
    for (name, count, props) in &elements {
        for _ in 0..*count {
            let mut xyz = [0.0f32; 3];
            let mut face: Vec<u32> = Vec::new();
            for (t, list, pname) in props {
                match list {
                    None => {
                        let v = read(t)?;
                        match pname.as_str() {
                            "x" => xyz[0] = v as f32,
                            "y" => xyz[1] = v as f32,
                            "z" => xyz[2] = v as f32,
                            _ => {}
                        }
                    }
                    Some(ct) => {
                        let n = read(ct)? as usize;
                        for _ in 0..n {
                            let v = read(t)?;
                            if name == "face" {
                                face.push(v as u32);
                            }
                        }
                    }
                }
            }
            if name == "vertex" {
                data.positions.push(Vec3::from_array(xyz));
            } else if name == "face" {
                if face.iter().any(|&i| i as usize >= data.positions.len()) {
                    bail!("face index out of range");
                }
                for k in 2..face.len() {
                    data.triangles.push(obj::ObjTriangle {
                        p: [face[0], face[k - 1], face[k]],
                        n: None,
                        uv: None,
                        line: 0,
                    });
                }
            }
        }
    }
    Ok(data)
}

fn bounds_of(prims: &[Prim]) -> Aabb {
    prims.iter().map(crate::scene::build::prim_bounds).fold(Aabb::EMPTY, Aabb::union)
}

/// The three ray sets.
pub struct RaySets {
    pub primary: Vec<Ray>,
    pub incoherent: Vec<Ray>,
    pub bounce: Vec<Ray>,
}

/// The benchmark camera's 1000×1000 primary rays.
pub fn primary_rays(b: &Aabb, res: usize) -> Vec<Ray> {
    let c = b.centroid();
    let w = Vec3::ONE.normalize(); // from the centre towards the camera
    let right = Vec3::Y.cross(w).normalize();
    let up = w.cross(right);
    let tan_half = (20.0f32).to_radians().tan();
    let mut dist = 0.0f32;
    for k in 0..8 {
        let corner = Vec3::new(
            if k & 1 == 0 { b.min.x } else { b.max.x },
            if k & 2 == 0 { b.min.y } else { b.max.y },
            if k & 4 == 0 { b.min.z } else { b.max.z },
        );
        let q = corner - c;
        dist = dist.max(q.dot(w) + q.dot(right).abs().max(q.dot(up).abs()) / tan_half);
    }
    let eye = c + w * dist.max(1e-6);
    let mut rays = Vec::with_capacity(res * res);
    for y in 0..res {
        for x in 0..res {
            let sx = (2.0 * (x as f32 + 0.5) / res as f32 - 1.0) * tan_half;
            let sy = (1.0 - 2.0 * (y as f32 + 0.5) / res as f32) * tan_half;
            let d = (-w + right * sx + up * sy).normalize();
            rays.push(Ray::with_range(eye, d, 0.0, f32::INFINITY));
        }
    }
    rays
}

fn uniform_sphere(rng: &mut Rng) -> Vec3 {
    let z = 1.0 - 2.0 * rng.unit_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * rng.unit_f32();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub fn incoherent_rays(b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::from(seed);
    let c = b.centroid();
    let r = b.extent().length() * 0.5;
    (0..n)
        .map(|_| {
            let o = c + uniform_sphere(&mut rng) * r;
            let t = b.min + b.extent() * Vec3::new(rng.unit_f32(), rng.unit_f32(), rng.unit_f32());
            Ray::with_range(o, (t - o).normalize(), 0.0, f32::INFINITY)
        })
        .collect()
}

/// Cosine-distributed rays from the primary hits (`hits[i]` belongs to `primary[i]`).
pub fn bounce_rays(prims: &[Prim], primary: &[Ray], hits: &[Option<Hit>], n: usize, eps: f32, seed: u64) -> Vec<Ray> {
    let points: Vec<(Vec3, Vec3)> = primary
        .iter()
        .zip(hits)
        .filter_map(|(ray, h)| {
            let h = h.as_ref()?;
            let Prim::Triangle { p, .. } = &prims[h.prim as usize] else {
                return None;
            };
            let mut ng = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
            if ng.dot(ray.d) > 0.0 {
                ng = -ng;
            }
            let pos = (p[0] * h.b[0] + p[1] * h.b[1]) + p[2] * h.b[2];
            Some((pos + ng * eps, ng))
        })
        .collect();
    if points.is_empty() {
        return Vec::new();
    }
    let mut rng = Rng::from(seed);
    (0..n)
        .map(|i| {
            let (o, ng) = points[i % points.len()];
            let (t, bt) = crate::math::coordinate_system(ng);
            let r = rng.unit_f32().sqrt();
            let phi = 2.0 * std::f32::consts::PI * rng.unit_f32();
            let z = (1.0 - r * r).max(0.0).sqrt();
            let d = (t * (r * phi.cos()) + bt * (r * phi.sin()) + ng * z).normalize();
            Ray::with_range(o, d, 0.0, f32::INFINITY)
        })
        .collect()
}

/// A closest-hit or any-hit implementation under test.
pub trait Tracer: Sync {
    fn closest(&self, ray: &Ray) -> Option<Hit>;
    fn any(&self, ray: &Ray) -> bool;
}

/// The reference: a binary BVH visited through a closure, scalar watertight kernel.
pub struct Reference<'a> {
    pub prims: &'a [Prim],
    pub bvh: crate::accel::Bvh,
}

impl<'a> Reference<'a> {
    pub fn new(prims: &'a [Prim]) -> Self {
        let bounds: Vec<Aabb> = prims.iter().map(crate::scene::build::prim_bounds).collect();
        Reference {
            prims,
            bvh: crate::accel::Bvh::build(&bounds),
        }
    }
}

fn prim_hit(p: &Prim, ray: &Ray, t_max: f32) -> Option<(f32, [f32; 3])> {
    match p {
        Prim::Triangle { p, .. } => crate::geometry::triangle::intersect_watertight(ray.o, ray.d, ray.t_min, t_max, p).map(|h| (h.t, h.b)),
        Prim::Sphere { sphere, .. } => sphere.intersect(ray.o, ray.d, ray.t_min, t_max).map(|t| (t, [0.0; 3])),
    }
}

impl Tracer for Reference<'_> {
    fn closest(&self, ray: &Ray) -> Option<Hit> {
        let mut best = None;
        self.bvh.traverse(ray, |i, t_max| {
            if let Some((t, b)) = prim_hit(&self.prims[i as usize], ray, *t_max) {
                *t_max = t;
                best = Some(Hit { t, prim: i, b });
            }
            false
        });
        best
    }
    fn any(&self, ray: &Ray) -> bool {
        let mut hit = false;
        self.bvh.traverse(ray, |i, t_max| {
            hit = prim_hit(&self.prims[i as usize], ray, *t_max).is_some();
            hit
        });
        hit
    }
}

/// Compares `t` with the reference on every `step`-th ray; returns the mismatches.
pub fn check(reference: &dyn Tracer, t: &dyn Tracer, prims: &[Prim], rays: &[Ray], step: usize) -> Vec<String> {
    let mut bad = Vec::new();
    for (k, ray) in rays.iter().enumerate().step_by(step.max(1)) {
        let r = reference.closest(ray);
        let g = t.closest(ray);
        let ok = match (r, g) {
            (None, None) => true,
            (Some(a), Some(b)) => {
                (a.prim == b.prim && a.t == b.t && a.b == b.b)
                    || (a.t == b.t && prim_hit(&prims[b.prim as usize], ray, ray.t_max).map(|h| h.0) == Some(b.t))
            }
            _ => false,
        };
        if !ok {
            bad.push(format!("ray {k}: closest hit {g:?}, reference {r:?}"));
        }
        let (ra, ga) = (r.is_some(), t.any(ray));
        if ra != ga {
            bad.push(format!("ray {k}: any-hit {ga}, reference {ra}"));
        }
    }
    bad
}

/// Seconds to trace all rays (best of `repeat`) and the number of hits. Every
/// worker claims chunks of 4096 rays until none are left and measures its own
/// CPU time over that (Linux `schedstat`); the time is the busiest worker's, so
/// time the OS gives other processes on a shared machine does not count, for
/// one thread and for many alike (wall-clock time where `schedstat` is missing).
fn time_rays(pool: &rayon::ThreadPool, rays: &[Ray], repeat: usize, f: &(dyn Fn(&Ray) -> bool + Sync)) -> (f64, usize) {
    use std::sync::atomic::{AtomicUsize, Ordering};
    const CHUNK: usize = 4096;
    let mut best = f64::INFINITY;
    let mut hits = 0;
    for _ in 0..repeat.max(1) {
        let next = AtomicUsize::new(0);
        let w0 = Instant::now();
        let per_worker: Vec<(Option<f64>, usize)> = pool.broadcast(|_| {
            let c0 = thread_cpu_seconds();
            let mut hits = 0;
            loop {
                let start = next.fetch_add(1, Ordering::Relaxed) * CHUNK;
                if start >= rays.len() {
                    break;
                }
                hits += rays[start..(start + CHUNK).min(rays.len())].iter().filter(|r| f(r)).count();
            }
            let cpu = match (c0, thread_cpu_seconds()) {
                (Some(a), Some(b)) if b >= a => Some(b - a),
                _ => None,
            };
            (cpu, hits)
        });
        let wall = w0.elapsed().as_secs_f64();
        let busiest = per_worker
            .iter()
            .map(|w| w.0)
            .collect::<Option<Vec<f64>>>()
            .and_then(|t| t.into_iter().reduce(f64::max));
        best = best.min(busiest.unwrap_or(wall).max(1e-9));
        hits = per_worker.iter().map(|w| w.1).sum();
    }
    (best, hits)
}

/// On-CPU time of the calling thread in seconds (Linux), from its schedstat.
fn thread_cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(s.split_whitespace().next()?.parse::<u64>().ok()? as f64 * 1e-9)
}

/// Runs `work` in `pool`; seconds taken: the worker's CPU time for a one-thread
/// pool where the OS reports it (so other load on the machine does not count),
/// else wall-clock time.
fn timed<T: Send>(pool: &rayon::ThreadPool, work: impl FnOnce() -> T + Send) -> (f64, T) {
    let single = pool.current_num_threads() == 1;
    pool.install(|| {
        let (w0, c0) = (Instant::now(), thread_cpu_seconds());
        let out = work();
        let wall = w0.elapsed().as_secs_f64();
        match (single, c0, thread_cpu_seconds()) {
            (true, Some(a), Some(b)) if b >= a => ((b - a).max(1e-9), out),
            _ => (wall, out),
        }
    })
}

/// Names of the ray sets, in the table's order (`--rays`).
pub const RAY_SETS: [&str; 3] = ["primary", "incoherent", "bounce"];

pub struct Options {
    pub repeat: usize,
    /// Thread counts to build and trace with.
    pub threads: Vec<usize>,
    /// Kernels for the timings (default: the best the CPU has).
    pub isa: Option<Isa>,
    /// Ray sets to time (empty: all).
    pub rays: Vec<String>,
    /// Build once and skip the kernel check (for profiling the traversal).
    pub trace_only: bool,
}

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
            let (t, b) = timed(pool, || crate::scene::build::build_bvh(input));
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
        std::mem::size_of::<crate::accel::wide::WideNode>(),
        bvh.blocks.len(),
        std::mem::size_of::<crate::accel::wide::TriBlock>(),
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
    let b = bounds_of(&ordered);
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

/// The renderer's queries ([`crate::Scene::intersect`] and `occluded` call these).
pub struct Wide<'a> {
    pub prims: &'a [Prim],
    pub bvh: &'a WideBvh,
}

impl Tracer for Wide<'_> {
    #[inline]
    fn closest(&self, ray: &Ray) -> Option<Hit> {
        self.bvh.intersect(self.prims, ray)
    }
    #[inline]
    fn any(&self, ray: &Ray) -> bool {
        self.bvh.occluded(self.prims, ray)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ply_ascii_and_binary() {
        let ascii = b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\n\
element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 9\n1 0 0 9\n1 1 0 9\n0 1 0 9\n4 0 1 2 3\n";
        let d = parse_ply(ascii).unwrap();
        assert_eq!(d.positions.len(), 4);
        assert_eq!(d.triangles.iter().map(|t| t.p).collect::<Vec<_>>(), vec![[0, 1, 2], [0, 2, 3]]);
        let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
element face 1\nproperty list uchar uint vertex_indices\nend_header\n"
            .to_vec();
        for v in [[0.0f32, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.5]] {
            for c in v {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        bin.push(3);
        for i in [0u32, 1, 2] {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        let d = parse_ply(&bin).unwrap();
        assert_eq!(d.positions[2], Vec3::new(0.0, 2.0, 0.5));
        assert_eq!(d.triangles[0].p, [0, 1, 2]);
        assert!(parse_ply(b"ply\nformat binary_big_endian 1.0\nend_header\n").is_err());
        let mut short = bin.clone();
        short.truncate(bin.len() - 2);
        assert!(parse_ply(&short).is_err());
    }

    #[test]
    fn ray_sets_are_as_described() {
        let b = Aabb::new(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(1.0, 3.0, 2.5));
        let primary = primary_rays(&b, 16);
        assert_eq!(primary.len(), 256);
        // the camera sits outside the box, front-right-above its centre
        let eye = primary[0].o;
        assert!(eye.cmpgt(b.max).all());
        let inc = incoherent_rays(&b, 1000, 1);
        let r = b.extent().length() * 0.5;
        for ray in &inc {
            assert!(((ray.o - b.centroid()).length() - r).abs() < 1e-4 * r);
            assert!((ray.d.length() - 1.0).abs() < 1e-5);
        }
    }
}
