//! Arbitrary bytes through `rdr::robustness::ray_file`: errors are fine, panics,
//! aborts and hangs are not.
//!
//! `cargo +nightly fuzz run ray_file` (from the project root). `tests/fuzz_corpus.rs` replays
//! `fuzz/corpus/ray_file` and mutates it on stable.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = rdr::robustness::run("ray_file", data);
});
