//! Arbitrary bytes, read as UTF-8 text (lossily), through the scene reader and the
//! OBJ reader: both must return errors, never panic.
//!
//! `cargo +nightly fuzz run scene_json` (from the project root). CI runs the
//! deterministic version of this in `tests/parser_robustness.rs`.

#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let file = Path::new("fuzz.json");
    if let Ok(value) = rdr::desc::json::parse_text(&text, file) {
        // `from_value` reads nothing from disk; the base folder only anchors paths.
        let _ = rdr::desc::SceneDesc::from_value(&value, file, Path::new("."));
    }
    let _ = rdr::geometry::obj::parse(&text);
});
