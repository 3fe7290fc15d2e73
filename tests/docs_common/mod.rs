//! Reading the manual's Markdown for the documentation tests: the pages, their fenced
//! blocks (with the info string that tags scene examples) and everything outside them.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// README.md and every page under docs/src and docs/dev, sorted.
pub fn pages() -> Vec<PathBuf> {
    let mut out = vec![root().join("README.md")];
    for dir in ["docs/src", "docs/dev"] {
        collect(&root().join(dir), &mut out);
    }
    out.sort();
    out
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            collect(&p, out);
        } else if p.extension().is_some_and(|x| x == "md") {
            out.push(p);
        }
    }
}

/// A fenced code block: its info string (`json scene`), text and first line (1-based).
pub struct Block {
    pub info: String,
    pub text: String,
    pub line: usize,
}

/// The fenced blocks of a Markdown text, and the text outside them (fenced lines
/// replaced by empty lines, so line numbers stay).
pub fn split(text: &str) -> (Vec<Block>, String) {
    let mut blocks = Vec::new();
    let mut prose = String::new();
    let mut open: Option<(String, String, usize, String)> = None; // fence, info, line, text
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start();
        match &mut open {
            None if t.starts_with("```") || t.starts_with("~~~") => {
                let fence: String = t.chars().take_while(|c| *c == '`' || *c == '~').collect();
                open = Some((fence.clone(), t[fence.len()..].trim().to_string(), i + 1, String::new()));
                prose.push('\n');
            }
            None => {
                prose.push_str(line);
                prose.push('\n');
            }
            Some((fence, _, _, body)) => {
                if t.starts_with(fence.as_str()) && t.trim_start_matches(['`', '~']).trim().is_empty() {
                    let (_, info, line, text) = open.take().expect("open");
                    blocks.push(Block { info, text, line });
                } else {
                    body.push_str(line);
                    body.push('\n');
                }
                prose.push('\n');
            }
        }
    }
    (blocks, prose)
}

pub fn rel(p: &Path) -> String {
    p.strip_prefix(root()).unwrap_or(p).display().to_string()
}

/// Merges a JSON patch into a scene as `--override` does.
#[allow(unused_imports)] // not every documentation test merges
pub use rdr::desc::json::merge;

/// A generated page (`page`, relative to the repository) against its fresh text: with
/// `RDR_BLESS` set it is rewritten, otherwise a difference fails naming the first line
/// and the command (`RDR_BLESS=1 cargo test --release --test {test}`) that regenerates it.
pub fn check_generated_page(page: &str, fresh: &str, source: &str, test: &str) {
    let path = root().join(page);
    if std::env::var_os("RDR_BLESS").is_some() {
        std::fs::write(&path, fresh).unwrap_or_else(|e| panic!("write {page}: {e}"));
        eprintln!("rewrote {page}");
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if committed != fresh {
        let line = committed
            .lines()
            .zip(fresh.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(committed.lines().count().min(fresh.lines().count()));
        panic!(
            "{page} differs from {source} (first at line {}); regenerate it with RDR_BLESS=1 cargo test --release --test {test}",
            line + 1
        );
    }
}
