//! Arbitrary bytes through `rdr::robustness::film_state`: errors are fine, panics,
//! aborts and hangs are not.
//!
//! `cargo +nightly fuzz run film_state` (from the project root). `tests/fuzz_corpus.rs` replays
//! `fuzz/corpus/film_state` and mutates it on stable.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = rdr::robustness::run("film_state", data);
});
