//! Timing: the busiest worker's CPU time (Linux `schedstat`), else wall-clock time.

use crate::geometry::Ray;
use std::time::Instant;

/// Seconds to trace all rays (best of `repeat`) and the number of hits. Every
/// worker claims chunks of 4096 rays until none are left and measures its own
/// CPU time over that (Linux `schedstat`); the time is the busiest worker's, so
/// time the OS gives other processes on a shared machine does not count, for
/// one thread and for many alike (wall-clock time where `schedstat` is missing).
pub(super) fn time_rays(pool: &rayon::ThreadPool, rays: &[Ray], repeat: usize, f: &(dyn Fn(&Ray) -> bool + Sync)) -> (f64, usize) {
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
    Some(schedstat_ns("/proc/thread-self/schedstat".as_ref())? as f64 * 1e-9)
}

/// A `schedstat` file's first field: nanoseconds on the CPU.
fn schedstat_ns(path: &std::path::Path) -> Option<u64> {
    std::fs::read_to_string(path).ok()?.split_whitespace().next()?.parse().ok()
}

/// On-CPU time of all this process's threads so far in seconds (Linux: the sum of
/// `/proc/self/task/*/schedstat`, nanoseconds; threads that have ended no longer count,
/// also one that ends between the listing and the reading of its file).
/// `None` where that is not available.
pub fn process_cpu_seconds() -> Option<f64> {
    let mut ns = 0u64;
    let mut read_any = false;
    for task in std::fs::read_dir("/proc/self/task").ok()?.flatten() {
        if let Some(t) = schedstat_ns(&task.path().join("schedstat")) {
            ns += t;
            read_any = true;
        }
    }
    // the calling thread is always listed: nothing readable means no schedstat here
    read_any.then_some(ns as f64 * 1e-9)
}

/// Runs `work` in `pool`; seconds taken: the worker's CPU time for a one-thread
/// pool where the OS reports it (so other load on the machine does not count),
/// else wall-clock time.
pub(super) fn timed<T: Send>(pool: &rayon::ThreadPool, work: impl FnOnce() -> T + Send) -> (f64, T) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc;

    /// The process's CPU time counts every thread's: across a stretch of work on two
    /// threads it grows by at least what each thread's own CPU time grew by (on Linux,
    /// where the figures exist).
    #[test]
    fn process_cpu_time_counts_every_thread() {
        let Some(before) = process_cpu_seconds() else {
            eprintln!("skipped: no /proc/self/task on this system");
            return;
        };
        // a thread's own CPU time across a fixed amount of work
        let spin = || {
            let c0 = thread_cpu_seconds().expect("schedstat where /proc/self/task is");
            let mut x = 0u64;
            for _ in 0..20_000_000 {
                x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
            }
            thread_cpu_seconds().expect("still readable") - c0
        };
        // the other thread stays alive until its time has been read; channels rather
        // than barriers, so that a panic on either side ends the wait (a sender dropped)
        // instead of leaving the other thread waiting for ever
        let (mine, other, after) = std::thread::scope(|s| {
            let (done_tx, done_rx) = mpsc::channel::<()>();
            let (read_tx, read_rx) = mpsc::channel::<()>();
            let t = s.spawn(move || {
                let own = spin();
                drop(done_tx);
                let _ = read_rx.recv();
                own
            });
            let mine = spin();
            let _ = done_rx.recv();
            let after = process_cpu_seconds().expect("still readable");
            drop(read_tx);
            (mine, t.join().expect("no panic"), after)
        });
        assert!(mine > 0.0 && other > 0.0, "{mine} {other}");
        assert!(
            after - before >= mine + other - 1e-3,
            "{before} -> {after}, threads {mine} + {other}"
        );
    }
}
