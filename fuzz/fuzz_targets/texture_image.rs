//! Arbitrary bytes through `rdr::robustness::texture_image`: errors are fine, panics,
//! aborts and hangs are not.
//!
//! `cargo +nightly fuzz run texture_image` (from the project root). `tests/fuzz_corpus.rs` replays
//! `fuzz/corpus/texture_image` and mutates it on stable.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = rdr::robustness::run("texture_image", data);
});
