//! What every front end of a render shares around [`render_with_aov`]: the checks of
//! the render options (samples, seed, threads, time limit, feature buffers), the job
//! they make of a loaded scene, and the thread pool a render runs on. `rdr render`
//! and the Python package both go through here, so they refuse the same options with
//! the same messages and give the same image for the same scene, spp and seed.

use super::{render_with_aov, FilmState, RenderControl, RenderJob, RenderOutput};
use crate::compat::Profile;
use crate::film::aov::AovSet;
use crate::scene::Scene;

/// Who is asking, for the spelling of option names in messages: the command line's
/// `--time-limit` or Python's `time_limit`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Caller {
    Cli,
    Python,
}

impl Caller {
    /// The option `name` (written with `-`) as this caller spells it.
    pub fn option(self, name: &str) -> String {
        match self {
            Caller::Cli => format!("--{name}"),
            Caller::Python => name.replace('-', "_"),
        }
    }
}

/// The options of one render besides the scene.
#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    /// Samples per pixel in place of the scene's.
    pub spp: Option<u32>,
    pub seed: u32,
    /// Worker threads (all cores when `None`).
    pub threads: Option<usize>,
    /// Seconds: no pass starts that would end after them.
    pub time_limit: Option<f64>,
    /// Feature buffers to sum besides the image.
    pub aov: AovSet,
}

/// Most worker threads: a few per core is plenty; more only costs memory (stacks).
pub fn max_threads() -> usize {
    4 * std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// A worker-thread count, checked.
pub fn check_threads(n: usize, caller: Caller) -> Result<(), String> {
    let name = caller.option("threads");
    if n == 0 {
        return Err(format!("{name} must be at least 1"));
    }
    let max = max_threads();
    if n > max {
        return Err(format!("{name} {n} is more than the {max} supported (4 per core)"));
    }
    Ok(())
}

/// A thread pool of its own for one render (`threads` workers, all cores when
/// `None`): a render never depends on rayon's global pool, which a process can build
/// only once.
pub fn thread_pool(threads: Option<usize>, caller: Caller) -> Result<rayon::ThreadPool, String> {
    if let Some(n) = threads {
        check_threads(n, caller)?;
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .thread_name(|i| format!("rdr-render-{i}"))
        .build()
        .map_err(|e| format!("cannot start the thread pool: {e}"))
}

/// A time limit, checked.
pub fn check_time_limit(seconds: Option<f64>, caller: Caller) -> Result<(), String> {
    match seconds {
        Some(t) if !(t.is_finite() && t > 0.0) => Err(format!("{} must be a positive number of seconds", caller.option("time-limit"))),
        _ => Ok(()),
    }
}

impl RenderOptions {
    /// Checks the options against `job` (rendered in `profile`) and applies them to it.
    pub fn apply(&self, job: &mut RenderJob, profile: Profile, caller: Caller) -> Result<(), String> {
        check_time_limit(self.time_limit, caller)?;
        if let Some(n) = self.threads {
            check_threads(n, caller)?;
        }
        if let Some(spp) = self.spp {
            if spp == 0 {
                return Err(format!("{} must be at least 1", caller.option("spp")));
            }
            job.spp = spp;
        }
        job.seed = self.seed;
        job.time_limit = self.time_limit;
        if self.aov.any() {
            check_features("aov", job, profile, caller)?;
        }
        Ok(())
    }
}

/// Whether `job` can make feature buffers (for `--aov` and `--denoise`, named by `what`).
pub fn check_features(what: &str, job: &RenderJob, profile: Profile, caller: Caller) -> Result<(), String> {
    let name = caller.option(what);
    if profile != Profile::Physical {
        return Err(format!(
            "{name}: not with --compat rdr171 (the course renderer had no feature buffers)"
        ));
    }
    if !job.integrator.supports_aov() {
        return Err(format!(
            "{name}: the {} integrator does not make feature buffers (path, intersection_test, bdpt, ptracer, photon, sppm and normals do)",
            job.integrator.name()
        ));
    }
    Ok(())
}

/// Renders `job` on `pool` from `start`, summing feature buffers when `aov`.
pub fn run(scene: &Scene, job: &RenderJob, control: &RenderControl, start: FilmState, aov: bool, pool: &rayon::ThreadPool) -> RenderOutput {
    pool.install(|| render_with_aov(scene, job, control, start, aov))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn option_names_follow_the_caller() {
        assert_eq!(Caller::Cli.option("time-limit"), "--time-limit");
        assert_eq!(Caller::Python.option("time-limit"), "time_limit");
        assert_eq!(check_threads(0, Caller::Python).unwrap_err(), "threads must be at least 1");
        assert!(check_threads(max_threads() + 1, Caller::Cli).unwrap_err().starts_with("--threads "));
    }

    #[test]
    fn a_pool_has_the_threads_asked() {
        let pool = thread_pool(Some(3), Caller::Cli).unwrap();
        assert_eq!(pool.install(rayon::current_num_threads), 3);
    }
}
