//! Arbitrary bytes through `rdr::robustness::vdb_grid`: errors are fine, panics,
//! aborts and hangs are not.
//!
//! `cargo +nightly fuzz run vdb_grid` (from the project root). `tests/fuzz_corpus.rs` replays
//! `fuzz/corpus/vdb_grid` and mutates it on stable.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = rdr::robustness::run("vdb_grid", data);
});
