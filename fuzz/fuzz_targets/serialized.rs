//! Arbitrary bytes through `rdr::robustness::serialized_mesh`: errors are fine, panics,
//! aborts and hangs are not.
//!
//! `cargo +nightly fuzz run serialized` (from the project root). `tests/fuzz_corpus.rs` replays
//! `fuzz/corpus/serialized` and mutates it on stable.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = rdr::robustness::run("serialized", data);
});
