//! Every scene example in README.md and the manual is loaded and rendered at tiny size,
//! so a documented example that stops working fails the suite.
//!
//! Tagged fenced blocks: ` ```json scene ` and ` ```xml scene ` are whole scenes;
//! ` ```json fragment ` is an `--override` patch, merged into the page's last
//! ` ```json scene ` above it. Examples are written as if saved in `scenes/`: relative
//! paths may name the bundled assets (`showcase/tiles.png`, `cornell/floor.obj`).
//! Every `json` or `xml` block must carry one of these tags, so no example escapes.

mod docs_common;

use docs_common::{merge, pages, rel, split, Block};
use rdr::desc::SceneDesc;
use rdr::{Loaded, Profile, RenderControl, RenderJob};
use serde_json::Value;
use std::path::Path;

/// One example: where it is and the scene text to load.
struct Example {
    place: String,
    xml: bool,
    text: String,
}

/// The tagged examples of one page; untagged json/xml blocks are errors.
fn examples_of(page: &Path, blocks: &[Block], errors: &mut Vec<String>) -> Vec<Example> {
    let mut out = Vec::new();
    let mut base: Option<Value> = None;
    for b in blocks {
        let place = format!("{}:{}", rel(page), b.line);
        let words: Vec<&str> = b.info.split_whitespace().collect();
        let lang = words.first().copied().unwrap_or("");
        let tag = words.get(1).copied().unwrap_or("");
        match (lang, tag) {
            ("json", "scene") => {
                match serde_json::from_str::<Value>(&b.text) {
                    Ok(v) => base = Some(v),
                    Err(e) => errors.push(format!("{place}: not JSON: {e}")),
                }
                out.push(Example {
                    place,
                    xml: false,
                    text: b.text.clone(),
                });
            }
            ("json", "fragment") => {
                let Some(mut scene) = base.clone() else {
                    errors.push(format!("{place}: a fragment needs a `json scene` block above it on the page"));
                    continue;
                };
                match serde_json::from_str::<Value>(&b.text) {
                    Ok(patch) if patch.is_object() => {
                        merge(&mut scene, &patch);
                        out.push(Example {
                            place,
                            xml: false,
                            text: scene.to_string(),
                        });
                    }
                    Ok(_) => errors.push(format!("{place}: a fragment must be a JSON object")),
                    Err(e) => errors.push(format!("{place}: not JSON: {e}")),
                }
            }
            ("xml", "scene") => out.push(Example {
                place,
                xml: true,
                text: b.text.clone(),
            }),
            ("json" | "xml", _) => errors.push(format!(
                "{place}: a ```{lang} block must be tagged `{lang} scene`{} so the suite tests it",
                if lang == "json" { " or `json fragment`" } else { "" }
            )),
            _ => {}
        }
    }
    out
}

/// Loads an example (no warnings allowed) and renders it at 16 pixels across, 1 spp.
fn check(ex: &Example, dir: &Path) -> Result<(), String> {
    let file = dir.join(if ex.xml { "example.xml" } else { "example.json" });
    std::fs::write(&file, &ex.text).map_err(|e| e.to_string())?;
    let mut desc = SceneDesc::load_with_defines(&file, &[], &[]).map_err(|e| e.to_string())?;
    if !desc.warnings.is_empty() {
        return Err(format!("warnings: {}", desc.warnings.join("; ")));
    }
    let (w, h) = (desc.film.width, desc.film.height);
    desc.film.width = 16;
    desc.film.height = ((16 * h + w / 2) / w).max(1);
    let loaded = Loaded::build(&desc, Profile::Physical).map_err(|e| e.to_string())?;
    let job = RenderJob {
        spp: 1,
        target_spp: 1,
        ..loaded.job.clone()
    };
    let out = rdr::render(&loaded.scene, &job, &RenderControl::default());
    if out.pixels.is_empty() || !out.pixels.iter().all(|p| p.is_finite()) {
        return Err("the render is empty or not finite".into());
    }
    Ok(())
}

#[test]
fn every_documented_scene_loads_and_renders() {
    let root = docs_common::root();
    let dir = tempfile::tempdir().expect("temporary folder");
    // examples are written as if saved in scenes/, beside the bundled assets
    for sub in ["showcase", "cornell", "volumes"] {
        std::os::unix::fs::symlink(root.join("scenes").join(sub), dir.path().join(sub)).expect("link assets");
    }
    let mut errors = Vec::new();
    let (mut n, mut in_readme) = (0, 0);
    for page in pages() {
        let text = std::fs::read_to_string(&page).expect("read page");
        let (blocks, _) = split(&text);
        for ex in examples_of(&page, &blocks, &mut errors) {
            n += 1;
            in_readme += usize::from(ex.place.starts_with("README.md"));
            if let Err(e) = check(&ex, dir.path()) {
                errors.push(format!("{}: {e}", ex.place));
            }
        }
    }
    eprintln!("{n} documented scene examples loaded and rendered ({in_readme} in README.md)");
    assert!(errors.is_empty(), "broken documentation examples:\n{}", errors.join("\n"));
    // the README's two scenes, and the scene format page's examples at least
    assert!(
        in_readme >= 2 && n >= 30,
        "only {n} examples found ({in_readme} in README.md): tags lost?"
    );
}
