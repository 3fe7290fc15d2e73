//! Arbitrary bytes, read as UTF-8 text (lossily), through the scene reader, the job
//! built from it and the OBJ reader (`rdr::robustness::scene_json`): all must
//! return errors, never panic.
//!
//! `cargo +nightly fuzz run scene_json` (from the project root). CI runs the
//! deterministic version of this in `tests/parser_robustness.rs`, and replays and
//! mutates `fuzz/corpus/scene_json` in `tests/fuzz_corpus.rs`.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = rdr::robustness::run("scene_json", data);
});
