//! Arbitrary bytes through `rdr::robustness::scene_xml`: errors are fine, panics,
//! aborts and hangs are not.
//!
//! `cargo +nightly fuzz run scene_xml` (from the project root). `tests/fuzz_corpus.rs` replays
//! `fuzz/corpus/scene_xml` and mutates it on stable.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = rdr::robustness::run("scene_xml", data);
});
