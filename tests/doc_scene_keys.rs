//! The JSON scene format page (`docs/src/reference/scene-format.md`) cannot drift from
//! the parser: for every parameter table, each documented key must be read by the
//! parser for that object, and each key the parser reads there must be documented.
//!
//! A table is marked `<!-- keys: ID at=POINTER also=ID,ID -->`: POINTER (a JSON pointer)
//! names the object in the page's base scene merged with the next `json fragment`
//! (the table's example); `also` adds the keys of shared tables (marked without `at`).
//! Whether the parser reads a key is observed, not listed: the key is added to the
//! example with a value of the wrong type; a key the parser reads then fails or is
//! accepted, one it does not read gets the warning "unknown key '…' ignored". The
//! candidates are every documented key and every identifier-like string literal in
//! src/ (keys are read by name, so a key the parser reads appears there).

mod docs_common;

use docs_common::{merge, root, split};
use rdr::desc::SceneDesc;
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

const PAGE: &str = "docs/src/reference/scene-format.md";

struct Table {
    id: String,
    at: Option<String>,
    also: Vec<String>,
    keys: BTreeSet<String>,
    /// The example scene for this table (base scene + the next fragment).
    example: Option<Value>,
    line: usize,
}

/// The backticked names in the first cell of a table row.
fn row_keys(line: &str) -> Vec<String> {
    let cell = line.trim().trim_start_matches('|').split('|').next().unwrap_or("");
    cell.split('`').skip(1).step_by(2).map(str::to_string).collect()
}

fn tables(text: &str) -> Vec<Table> {
    let (blocks, prose) = split(text);
    let base: Value = blocks
        .iter()
        .find(|b| b.info == "json scene")
        .map(|b| serde_json::from_str(&b.text).expect("base scene is JSON"))
        .expect("the page has a base `json scene`");
    let lines: Vec<&str> = prose.lines().collect();
    let mut out: Vec<Table> = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        let Some(spec) = l.trim().strip_prefix("<!-- keys:").and_then(|s| s.strip_suffix("-->")) else {
            continue;
        };
        let mut words = spec.split_whitespace();
        let id = words.next().expect("table id").to_string();
        let (mut at, mut also) = (None, Vec::new());
        for w in words {
            if let Some(p) = w.strip_prefix("at=") {
                at = Some(p.to_string());
            } else if let Some(a) = w.strip_prefix("also=") {
                also = a.split(',').map(str::to_string).collect();
            } else {
                panic!("{PAGE}:{}: unknown word '{w}' in a keys marker", i + 1);
            }
        }
        let mut keys = BTreeSet::new();
        let rows = lines[i + 1..]
            .iter()
            .skip_while(|l| l.trim().is_empty())
            .take_while(|l| l.trim_start().starts_with('|'));
        for row in rows.skip(2) {
            keys.extend(row_keys(row));
        }
        assert!(!keys.is_empty(), "{PAGE}:{}: no table with backticked keys after the marker", i + 1);
        let example = at.as_ref().map(|_| {
            let b = blocks
                .iter()
                .find(|b| b.line > i + 1 && b.info == "json fragment")
                .unwrap_or_else(|| panic!("{PAGE}:{}: no `json fragment` example after the table", i + 1));
            let mut scene = base.clone();
            merge(&mut scene, &serde_json::from_str(&b.text).expect("fragment is JSON"));
            scene
        });
        out.push(Table {
            id,
            at,
            also,
            keys,
            example,
            line: i + 1,
        });
    }
    out
}

/// Identifier-like string literals of every source file under `dir`.
fn literals(dir: &Path, out: &mut BTreeSet<String>) {
    for e in std::fs::read_dir(dir).expect("read src").flatten() {
        let p = e.path();
        if p.is_dir() {
            literals(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            let text = std::fs::read_to_string(&p).expect("read source");
            for (i, s) in text.split('"').enumerate() {
                let ident = s.len() <= 48
                    && s.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
                    && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
                if i % 2 == 1 && ident {
                    out.insert(s.to_string());
                }
            }
        }
    }
}

fn parse(scene: &Value) -> Result<Vec<String>, String> {
    let file = root().join("scenes/doc-example.json");
    SceneDesc::from_value(scene, &file, &root().join("scenes"))
        .map(|d| d.warnings)
        .map_err(|e| e.to_string())
}

/// Whether the parser reads `key` of the object at `at` in `scene`.
fn reads(scene: &Value, at: &str, key: &str) -> bool {
    let mut probe = scene.clone();
    let obj = probe.pointer_mut(at).and_then(Value::as_object_mut).expect("object at pointer");
    obj.insert(key.to_string(), serde_json::json!({"not": ["a", "valid", "value"]}));
    match parse(&probe) {
        Err(_) => true,
        Ok(warnings) => !warnings.iter().any(|w| w.contains(&format!("unknown key '{key}'"))),
    }
}

#[test]
fn scene_format_page_matches_the_parser() {
    let text = std::fs::read_to_string(root().join(PAGE)).expect("read the scene format page");
    let tables = tables(&text);
    let by_id: BTreeMap<&str, &Table> = tables.iter().map(|t| (t.id.as_str(), t)).collect();
    let mut candidates = BTreeSet::new();
    literals(&root().join("src"), &mut candidates);
    let mut errors = Vec::new();
    let mut included = BTreeSet::new();
    let mut probes = 0;
    for t in tables.iter().filter(|t| t.at.is_some()) {
        let at = t.at.as_deref().expect("at");
        let scene = t.example.as_ref().expect("example");
        let mut documented = t.keys.clone();
        for a in &t.also {
            match by_id.get(a.as_str()) {
                Some(s) => documented.extend(s.keys.iter().cloned()),
                None => errors.push(format!("{PAGE}:{}: also={a}: no such table", t.line)),
            }
            included.insert(a.clone());
        }
        match parse(scene) {
            Ok(w) if w.is_empty() => {}
            Ok(w) => errors.push(format!("{PAGE}:{}: the example warns: {}", t.line, w.join("; "))),
            Err(e) => errors.push(format!("{PAGE}:{}: the example does not load: {e}", t.line)),
        }
        let Some(present) = scene.pointer(at).and_then(Value::as_object) else {
            errors.push(format!("{PAGE}:{}: the example has no object at {at}", t.line));
            continue;
        };
        for k in present.keys() {
            if !documented.contains(k) {
                errors.push(format!("{PAGE}:{} ({}): the example's key '{k}' is not in the table", t.line, t.id));
            }
        }
        let probed: BTreeSet<&String> = documented.iter().chain(&candidates).collect();
        for k in probed {
            if present.contains_key(k) {
                continue;
            }
            probes += 1;
            match (reads(scene, at, k), documented.contains(k)) {
                (false, true) => errors.push(format!(
                    "{PAGE}:{} ({}): '{k}' is documented but the parser ignores it",
                    t.line, t.id
                )),
                (true, false) => errors.push(format!(
                    "{PAGE}:{} ({}): the parser reads '{k}' but the table does not list it",
                    t.line, t.id
                )),
                _ => {}
            }
        }
    }
    for t in tables.iter().filter(|t| t.at.is_none()) {
        if !included.contains(&t.id) {
            errors.push(format!(
                "{PAGE}:{}: shared table {} is included by no table with an example",
                t.line, t.id
            ));
        }
    }
    eprintln!("{} tables, {} candidate keys, {probes} probes", tables.len(), candidates.len());
    assert!(tables.len() >= 30, "only {} key tables found in {PAGE}", tables.len());
    assert!(
        errors.is_empty(),
        "the scene format page and the parser disagree:\n{}",
        errors.join("\n")
    );
}
