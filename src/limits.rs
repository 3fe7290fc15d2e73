//! Resource limits every input is checked against before it is allocated or read:
//! the memory budget (a share of what the process may really use, or `--max-memory`),
//! input files that must be regular files of a sane size, and caps on counts.
//!
//! A file that claims a huge size (an image header, a PLY element count, a film
//! resolution) is refused with an error naming the size and where it came from,
//! instead of aborting the process on a failed allocation.

use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// Largest magnitude of a scene coordinate (positions, centres, radii): squares and
/// products of a few such numbers stay finite in f32.
pub const MAX_COORD: f32 = 1e15;

/// 0: not set yet (the default is computed on first use).
static BUDGET: AtomicU64 = AtomicU64::new(0);

/// Bytes of memory the process may use, as far as the system tells: the smallest of
/// physical memory, the address-space limit (`RLIMIT_AS`) and the cgroup's
/// `memory.max`. `None` when none of them can be read.
pub fn available_memory() -> Option<u64> {
    let mut best: Option<u64> = None;
    let mut take = |v: Option<u64>| {
        if let Some(v) = v {
            best = Some(best.map_or(v, |b| b.min(v)));
        }
    };
    take(meminfo_total());
    take(address_space_limit());
    take(cgroup_limit());
    best
}

fn meminfo_total() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kb.checked_mul(1024)
}

/// The soft `RLIMIT_AS` of this process, from `/proc/self/limits` (no `unsafe` call).
fn address_space_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/limits").ok()?;
    parse_limits_line(&text)
}

fn parse_limits_line(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("Max address space"))?;
    let soft = line["Max address space".len()..].split_whitespace().next()?;
    soft.parse().ok() // "unlimited" → None
}

fn cgroup_limit() -> Option<u64> {
    for f in ["/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"] {
        if let Ok(s) = std::fs::read_to_string(f) {
            if let Ok(v) = s.trim().parse::<u64>() {
                // cgroup v1 reports "no limit" as a huge number
                if v < 1 << 60 {
                    return Some(v);
                }
            }
        }
    }
    None
}

/// The default budget: half of [`available_memory`] (the rest is the program, thread
/// stacks, allocator slack and the short-lived copies made while writing), 4 GiB when
/// nothing is known.
pub fn default_budget() -> u64 {
    available_memory().map_or(4 << 30, |m| m / 2).max(64 << 20)
}

/// Bytes the large buffers of one run (film, images, meshes) may take together.
pub fn memory_budget() -> u64 {
    match BUDGET.load(Ordering::Relaxed) {
        0 => {
            let b = default_budget();
            BUDGET.store(b, Ordering::Relaxed);
            b
        }
        b => b,
    }
}

/// Sets the budget (`--max-memory`).
pub fn set_memory_budget(bytes: u64) {
    BUDGET.store(bytes.max(1), Ordering::Relaxed);
}

/// `1.5 GB`, `640 MB`, `12 kB`, `300 bytes`.
pub fn human_bytes(b: u64) -> String {
    let f = b as f64;
    if f >= 1e9 {
        format!("{:.1} GB", f / 1e9)
    } else if f >= 1e6 {
        format!("{:.0} MB", f / 1e6)
    } else if f >= 1e3 {
        format!("{:.0} kB", f / 1e3)
    } else {
        format!("{b} bytes")
    }
}

/// `Ok` when `bytes` fit the budget; otherwise a message saying what needs how much.
/// `bytes` is `None` when computing it overflowed.
pub fn check_memory(bytes: Option<u64>, what: impl FnOnce() -> String) -> Result<(), String> {
    let budget = memory_budget();
    match bytes {
        Some(b) if b <= budget => Ok(()),
        Some(b) => Err(format!(
            "{} needs about {} of memory, more than the {} allowed (a share of this machine's memory; raise it with --max-memory)",
            what(),
            human_bytes(b),
            human_bytes(budget)
        )),
        None => Err(format!("{} is too large to fit in memory", what())),
    }
}

/// Parses a `--max-memory` value: bytes, or with a suffix k, M, G, T (powers of 1024,
/// an optional `B`/`iB`).
pub fn parse_bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let lower = t.to_ascii_lowercase();
    let lower = lower.trim_end_matches("ib").trim_end_matches('b');
    let (num, mult) = match lower.chars().last() {
        Some('k') => (&lower[..lower.len() - 1], 1u64 << 10),
        Some('m') => (&lower[..lower.len() - 1], 1 << 20),
        Some('g') => (&lower[..lower.len() - 1], 1 << 30),
        Some('t') => (&lower[..lower.len() - 1], 1 << 40),
        _ => (lower, 1),
    };
    let v: f64 = num
        .trim()
        .parse()
        .map_err(|_| format!("'{t}' is not a size (such as 2G, 512M or 1000000)"))?;
    if !(v.is_finite() && v > 0.0) || v * mult as f64 > 1.8e19 {
        return Err(format!("'{t}' is not a positive size"));
    }
    Ok((v * mult as f64) as u64)
}

/// Checks that `path` is a regular file (not a folder, FIFO or device, which could
/// block or never end) of at most `max_bytes`, and returns its size. The error says
/// what is wrong without the path (callers name the file).
pub fn check_input_file(path: &Path, max_bytes: u64) -> std::io::Result<u64> {
    use std::io::{Error, ErrorKind};
    let meta = std::fs::metadata(path)?;
    if meta.is_dir() {
        return Err(Error::new(ErrorKind::IsADirectory, "it is a folder, not a file"));
    }
    if !meta.is_file() {
        return Err(Error::new(ErrorKind::InvalidInput, "not a regular file (a pipe, socket or device)"));
    }
    if meta.len() > max_bytes {
        return Err(Error::new(
            ErrorKind::FileTooLarge,
            format!(
                "the file is {}, more than the {} allowed (raise it with --max-memory)",
                human_bytes(meta.len()),
                human_bytes(max_bytes)
            ),
        ));
    }
    Ok(meta.len())
}

/// Reads a whole input file after [`check_input_file`]; reads at most `max_bytes`
/// even when the file grows meanwhile.
pub fn read_input_file(path: &Path, max_bytes: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let len = check_input_file(path, max_bytes)?;
    let f = std::fs::File::open(path)?;
    let mut out = Vec::with_capacity(len as usize);
    f.take(max_bytes.saturating_add(1)).read_to_end(&mut out)?;
    if out.len() as u64 > max_bytes {
        return Err(std::io::Error::new(
            std::io::ErrorKind::FileTooLarge,
            format!("the file grew past {}", human_bytes(max_bytes)),
        ));
    }
    Ok(out)
}

/// The largest input file (scene, mesh) read whole: an eighth of the memory budget,
/// since parsed data takes several times the text.
pub fn max_input_file() -> u64 {
    memory_budget() / 8
}

/// Escapes control characters (terminal escapes, carriage returns) so text taken from
/// input files cannot drive the terminal it is printed on.
pub fn sanitize(s: &str) -> String {
    if !s.chars().any(char::is_control) {
        return s.to_string();
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        if c.is_control() {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_file_and_sizes() {
        let text = "Limit                     Soft Limit           Hard Limit           Units     \n\
                    Max address space         2147483648           unlimited            bytes     \n";
        assert_eq!(parse_limits_line(text), Some(2147483648));
        assert_eq!(parse_limits_line(&text.replace("2147483648", "unlimited")), None);
        assert_eq!(parse_bytes("2G").unwrap(), 2 << 30);
        assert_eq!(parse_bytes("512MiB").unwrap(), 512 << 20);
        assert_eq!(parse_bytes("1000").unwrap(), 1000);
        assert!(parse_bytes("-1").is_err() && parse_bytes("x").is_err() && parse_bytes("0").is_err());
        assert!(available_memory().is_some_and(|m| m > 0));
        assert_eq!(sanitize("a\x1b[2Jb\n"), "a\\u{1b}[2Jb\\n");
    }

    #[test]
    fn input_files_must_be_regular() {
        let e = |p: &str| check_input_file(Path::new(p), 1 << 20).unwrap_err().to_string();
        assert!(e("/dev/zero").contains("not a regular file"));
        assert!(e("/").contains("folder"));
        let f = tempfile::NamedTempFile::new().unwrap();
        std::fs::write(f.path(), b"0123456789").unwrap();
        assert_eq!(read_input_file(f.path(), 10).unwrap().len(), 10);
        assert!(read_input_file(f.path(), 9).unwrap_err().to_string().contains("more than"));
    }
}
