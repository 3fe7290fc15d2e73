//! The fuzz targets on stable: every file of `fuzz/corpus/<target>/` goes through the
//! target's entry point ([`rdr::robustness`], the same functions `fuzz/fuzz_targets/*.rs`
//! call), then a bounded, seeded mutation loop over the corpus (bit flips, byte and
//! block edits, interesting numbers spliced in) runs each target for a while. Any
//! panic fails the test and the input is saved under `target/fuzz-failures/`.
//!
//! `RDR_FUZZ_SECONDS` (default 2 per target) sets the mutation budget, `RDR_FUZZ_SEED`
//! the seed: `RDR_FUZZ_SECONDS=120 cargo test --release --test fuzz_corpus` for a
//! longer run.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn corpus(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus").join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{} is empty", dir.display());
    files.into_iter().map(|p| (p.clone(), std::fs::read(&p).unwrap())).collect()
}

/// Runs one input; a panic is returned as its message.
fn attempt(target: &str, data: &[u8]) -> Result<(), String> {
    std::panic::catch_unwind(|| {
        let _ = rdr::robustness::run(target, data);
    })
    .map_err(|p| {
        p.downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_default()
    })
}

fn save_failure(target: &str, data: &[u8]) -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/fuzz-failures").join(target);
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("crash-{:016x}", fnv(data)));
    std::fs::write(&p, data).unwrap();
    p
}

fn fnv(data: &[u8]) -> u64 {
    data.iter()
        .fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3))
}

/// A small memory budget: mutated headers that claim big sizes are refused, not
/// allocated, and the test stays light.
fn small_budget() {
    rdr::limits::set_memory_budget(256 << 20);
}

#[test]
fn every_corpus_file_goes_through_its_target() {
    small_budget();
    for target in rdr::robustness::TARGETS {
        for (path, data) in corpus(target) {
            if let Err(msg) = attempt(target, &data) {
                panic!("{target}: {} panicked: {msg}", path.display());
            }
        }
    }
    // the seeds that must be accepted are
    for (target, file) in [
        ("scene_json", "base.json"),
        ("scene_json", "cornell.json"),
        ("scene_xml", "structure.xml"),
        ("scene_xml", "legacy.xml"),
        ("scene_xml", "veach_primitives.xml"),
        ("serialized", "two_meshes.bin"),
        ("obj", "faces.obj"),
        ("ply", "binary.ply"),
        ("texture_image", "float3x2.exr"),
        ("texture_image", "rgb2x2.png"),
        ("texture_image", "tiny.hdr"),
        ("film_state", "path_3x2.exr"),
        ("film_state", "bdpt_splats_2x2.exr"),
        ("film_state", "shard_2x1.exr"),
        ("ray_file", "three.rays.f32"),
        ("vol_grid", "grid_4x3x2.vol"),
        ("vol_grid", "rgb_2x2x2.vol"),
        ("vdb_grid", "small_zip.vdb"),
        ("vdb_grid", "small_raw.vdb"),
    ] {
        let data = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus").join(target).join(file)).unwrap();
        if let Err(e) = rdr::robustness::run(target, &data) {
            panic!("{target}/{file} is rejected: {e}");
        }
        if target == "film_state" {
            let state = rdr::render::statefile::decode_bytes(&data).unwrap();
            assert!(state.is_some_and(|s| !s.state.pieces.is_empty()), "{file}: no film state decoded");
        }
    }
    for (target, file, why) in [
        ("texture_image", "lying100000.exr", "100000x100000"),
        ("texture_image", "lying23170.png", "more than its 60 bytes"),
        ("texture_image", "oom-png-header-claims-2g-pixels", "more than its 65 bytes"),
        ("ply", "huge_count.ply", "no properties"),
        ("scene_xml", "syntax_error.xml", "line 3, column 55"),
        (
            "scene_xml",
            "attrs101.xml",
            "line 2, column 1: <shape> has more than 100 attributes",
        ),
        ("serialized", "truncated.bin", "truncated"),
        ("film_state", "truncated.exr", "too short"),
        ("film_state", "no-channels-claims-19G-pixels.exr", "no channels"),
        ("ray_file", "not_unit.rays.f32", "direction of length"),
        ("vol_grid", "lying.vol", "claims"),
    ] {
        let data = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus").join(target).join(file)).unwrap();
        let e = rdr::robustness::run(target, &data).unwrap_err();
        assert!(e.contains(why), "{target}/{file}: {e}");
    }
}

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const INTERESTING: [&[u8]; 14] = [
    b"0",
    b"-1",
    b"1e39",
    b"4294967295",
    b"18446744073709551615",
    b"2147483647",
    b"NaN",
    b"1e-45",
    &[0xff, 0xff, 0xff, 0x7f],
    &[0, 0, 0, 0x80],
    &[0xff; 8],
    &[0; 4],
    b"\n",
    b" ",
];

fn mutate(rng: &mut Rng, input: &[u8], other: &[u8]) -> Vec<u8> {
    let mut d = input.to_vec();
    for _ in 0..1 + rng.below(4) {
        let len = d.len();
        match rng.below(8) {
            0 if len > 0 => {
                let i = rng.below(len);
                d[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                d[i] = rng.next() as u8;
            }
            2 => {
                let i = rng.below(len + 1);
                d.insert(i, rng.next() as u8);
            }
            3 if len > 0 => {
                let i = rng.below(len);
                let n = rng.below(16.min(len - i) + 1);
                d.drain(i..i + n);
            }
            4 => {
                let s = INTERESTING[rng.below(INTERESTING.len())];
                let i = rng.below(len + 1);
                if rng.below(2) == 0 && i + s.len() <= len {
                    d[i..i + s.len()].copy_from_slice(s);
                } else {
                    d.splice(i..i, s.iter().copied());
                }
            }
            5 if len > 0 => {
                // duplicate a block
                let i = rng.below(len);
                let n = rng.below(64.min(len - i) + 1);
                let block: Vec<u8> = d[i..i + n].to_vec();
                let j = rng.below(len + 1);
                d.splice(j..j, block);
            }
            6 if !other.is_empty() => {
                // splice in part of another corpus file
                let i = rng.below(other.len());
                let n = rng.below(64.min(other.len() - i) + 1);
                let j = rng.below(len + 1);
                d.splice(j..j, other[i..i + n].iter().copied());
            }
            _ if len > 1 => d.truncate(rng.below(len)),
            _ => d.push(rng.next() as u8),
        }
    }
    d.truncate(1 << 16);
    d
}

#[test]
fn mutated_corpus_files_never_panic() {
    small_budget();
    let seconds: f64 = std::env::var("RDR_FUZZ_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(2.0);
    let seed: u64 = std::env::var("RDR_FUZZ_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(0x5eed);
    // panics are caught and reported below; keep their messages off the log
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut failures = Vec::new();
    let mut report = Vec::new();
    for (ti, target) in rdr::robustness::TARGETS.iter().enumerate() {
        let files: Vec<Vec<u8>> = corpus(target).into_iter().map(|(_, d)| d).collect();
        let mut rng = Rng(seed ^ (ti as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let (start, budget) = (Instant::now(), Duration::from_secs_f64(seconds));
        let (mut runs, mut accepted, mut slowest) = (0u64, 0u64, 0.0f64);
        let mut pool = files.clone();
        while start.elapsed() < budget {
            let base = &pool[rng.below(pool.len())];
            let other = &files[rng.below(files.len())];
            let input = mutate(&mut rng, base, other);
            let t = Instant::now();
            let result = std::panic::catch_unwind(|| rdr::robustness::run(target, &input));
            slowest = slowest.max(t.elapsed().as_secs_f64());
            runs += 1;
            match result {
                Ok(Ok(())) => {
                    accepted += 1;
                    // accepted inputs seed further mutations (a crude coverage proxy)
                    if pool.len() < 256 {
                        pool.push(input);
                    }
                }
                Ok(Err(_)) => {}
                Err(_) => {
                    let p = save_failure(target, &input);
                    failures.push(format!("{target}: panic on {}", p.display()));
                    if failures.len() > 20 {
                        break;
                    }
                }
            }
        }
        report.push(format!(
            "{target}: {runs} inputs ({accepted} accepted), slowest {:.0} ms",
            slowest * 1e3
        ));
        if slowest > 5.0 {
            failures.push(format!("{target}: an input took {slowest:.1} s"));
        }
    }
    std::panic::set_hook(hook);
    eprintln!("{}", report.join("\n"));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
