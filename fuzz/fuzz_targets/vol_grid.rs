//! Arbitrary bytes through `rdr::robustness::vol_grid`: errors are fine, panics,
//! aborts and hangs are not.
//!
//! `cargo +nightly fuzz run vol_grid` (from the project root). `tests/fuzz_corpus.rs` replays
//! `fuzz/corpus/vol_grid` and mutates it on stable.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = rdr::robustness::run("vol_grid", data);
});
