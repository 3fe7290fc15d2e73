//! `rdr bench MESH`: the acceleration-structure benchmark.
//!
//! Loads a triangle mesh (OBJ or PLY), builds the BVH the renderer uses and
//! reports build time and size, then traces three fixed ray sets with closest-hit
//! and any-hit queries on one thread and on all threads:
//!
//! * **primary**: 1000×1000 pinhole rays, 40° field of view, the camera looking at
//!   the centre of the bounding box along −(0.35, 0.25, 1), pulled back until all
//!   eight corners of the box are inside the image with a 5 % margin;
//! * **incoherent**: 1,000,000 rays from uniform points on the bounding sphere
//!   towards uniform points inside the box (fixed seed);
//! * **bounce**: 1,000,000 cosine-distributed rays leaving the primary hit points
//!   (hit points reused in turn when fewer than a million primary rays hit),
//!   offset by 1e-4 of the bounding sphere's radius along the geometric normal on
//!   the side the primary ray came from.
//!
//! These are the definitions of `shared/tools/embree_rays.py`, which writes the same
//! three sets (identical rays) to files with Embree's distances; `--ray-file` traces
//! such files ([`ray_file`]) instead of the sets generated here.
//!
//! Ray figures are the CPU time of the busiest worker thread (Linux `schedstat`;
//! the workers claim chunks of rays until none are left), so time the OS gives
//! other processes does not inflate them, for one thread and for many alike.
//! Build figures are the worker's CPU time on one thread and wall-clock time on
//! more (the build's threads idle in turn). Each is the best of `--repeat` runs.
//!
//! Before timing, every traversal variant is checked against a simple reference
//! ([`crate::accel::reference`]: a binary BVH visited through a closure with the
//! scalar watertight kernel) on a sample of each ray set.
//!
//! Files: [`rays`] (the ray sets), `timing` (CPU and wall-clock timing), `report`
//! ([`run`]: the build, check and table); meshes load here, PLY files through
//! [`crate::geometry::ply`].

pub mod export;
pub mod ray_file;
pub mod rays;
mod report;
mod timing;

pub use rays::{bounce_rays, incoherent_rays, primary_rays, RaySets};
pub use report::{run, Report};
pub use timing::process_cpu_seconds;

use crate::accel::Isa;
use crate::geometry::mesh::Mesh;
use crate::geometry::prim::Prim;
use crate::geometry::{obj, ply};
use crate::math::{Mat4, Vec3};
use anyhow::{bail, Context, Result};
use std::path::Path;

/// Triangles of an OBJ or PLY file as scene primitives (object 0), degenerate
/// (zero-area) triangles dropped.
pub fn load_mesh(path: &Path) -> Result<Vec<Prim>> {
    // a regular file of a sane size whose parsed form fits the memory budget
    let bytes = crate::limits::read_input_file(path, crate::limits::max_input_file())
        .with_context(|| format!("cannot read '{}'", path.display()))?;
    crate::limits::check_memory((bytes.len() as u64).checked_mul(obj::MEMORY_PER_BYTE), || {
        format!("mesh '{}'", path.display())
    })
    .map_err(anyhow::Error::msg)?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let data = match ext.as_str() {
        "obj" => obj::parse_bytes(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?,
        "ply" => ply::parse_ply(&bytes).with_context(|| format!("{}", path.display()))?,
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
    /// Ray files to trace ([`ray_file`]); with any, the generated sets are timed
    /// only when `rays` names them.
    pub ray_files: Vec<std::path::PathBuf>,
    /// Pre-splitting budget of the tree (extra references per triangle,
    /// [`crate::accel::presplit`]; default none, as the renderer's).
    pub split_budget: Option<f32>,
}

/// The CPU's model name with its family, model and stepping (Linux `/proc/cpuinfo`), or
/// "unknown CPU".
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| cpu_model_of(&s))
        .unwrap_or_else(|| "unknown CPU".to_string())
}

/// [`cpu_model`] of `/proc/cpuinfo`'s text: the first processor's `model name`, and its
/// `cpu family`, `model` and `stepping` where given, which tell CPU generations apart
/// where a virtual machine names only the brand ("AMD EPYC, family 26 model 2
/// stepping 1" is a Zen 5).
fn cpu_model_of(cpuinfo: &str) -> Option<String> {
    // the first processor's block
    let block = cpuinfo.split("\n\n").next().unwrap_or("");
    let field = |key: &str| {
        block
            .lines()
            .filter_map(|l| l.split_once(':'))
            .find(|(k, _)| k.trim() == key)
            .map(|(_, v)| v.trim())
            .filter(|v| !v.is_empty())
    };
    let name = field("model name")?;
    let ids: Vec<String> = [("cpu family", "family"), ("model", "model"), ("stepping", "stepping")]
        .into_iter()
        .filter_map(|(key, label)| field(key).map(|v| format!("{label} {v}")))
        .collect();
    Some(if ids.is_empty() {
        name.to_string()
    } else {
        format!("{name}, {}", ids.join(" "))
    })
}

/// The CPU line of both benchmarks: model and the instruction sets the kernels use.
pub fn cpu_line(isa: Isa) -> String {
    let have: Vec<&str> = Isa::all_available().into_iter().map(Isa::name).collect();
    format!("{} (kernels {}; this CPU runs {})", cpu_model(), isa.name(), have.join(", "))
}

#[cfg(test)]
mod tests {
    use super::cpu_model_of;

    #[test]
    fn cpu_model_names_family_model_and_stepping() {
        let two = "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 26\nmodel\t\t: 2\nmodel name\t: AMD EPYC\nstepping\t: 1\n\n\
                   processor\t: 1\ncpu family\t: 6\nmodel\t\t: 85\nmodel name\t: Other\nstepping\t: 7\n";
        assert_eq!(cpu_model_of(two).as_deref(), Some("AMD EPYC, family 26 model 2 stepping 1"));
        // without the numbers (other platforms' files): the name alone
        assert_eq!(cpu_model_of("model name : Some CPU\n").as_deref(), Some("Some CPU"));
        assert_eq!(cpu_model_of("processor : 0\n"), None);
        assert_eq!(cpu_model_of("model name :   \n"), None);
    }
}
