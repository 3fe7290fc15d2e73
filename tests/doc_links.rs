//! Every relative link and anchor in README.md and the manual resolves, every page
//! under docs/src is in SUMMARY.md, and every `{{#include}}` names a file. (mdBook
//! fails on a page SUMMARY.md names that is missing, as docs/book.toml sets
//! `create-missing = false`, but only warns about broken links: this test is what
//! fails the suite on them.)

mod docs_common;

use docs_common::{pages, rel, root, split};
use std::collections::BTreeSet;
use std::path::PathBuf;

/// The link targets of Markdown prose: `[text](target)`, `![alt](target)` and
/// `<img src="target">`, with their line numbers (inline code spans left out).
fn links(prose: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, line) in prose.lines().enumerate() {
        let line: String = line.split('`').step_by(2).collect::<Vec<_>>().join(" ");
        let mut rest = line.as_str();
        while let Some(p) = rest.find("](") {
            let after = &rest[p + 2..];
            let end = after.find(')').unwrap_or(after.len());
            let target = after[..end].split_whitespace().next().unwrap_or("").to_string();
            out.push((i + 1, target));
            rest = &after[end..];
        }
        let mut rest = line.as_str();
        while let Some(p) = rest.find("src=\"") {
            let after = &rest[p + 5..];
            let end = after.find('"').unwrap_or(after.len());
            out.push((i + 1, after[..end].to_string()));
            rest = &after[end..];
        }
    }
    out
}

/// mdBook's heading ids: the heading's text, lower-cased, spaces to hyphens, only
/// letters, digits, `-` and `_` kept; repeated ids get `-1`, `-2`, ….
fn anchors(text: &str) -> BTreeSet<String> {
    let (_, prose) = split(text);
    let mut seen = BTreeSet::new();
    for line in prose.lines() {
        let t = line.trim_start();
        if !t.starts_with('#') {
            continue;
        }
        let title = t.trim_start_matches('#');
        if !title.starts_with(' ') {
            continue;
        }
        let plain: String = title.trim().chars().filter(|c| !matches!(c, '`' | '*')).collect();
        let id: String = plain
            .to_lowercase()
            .chars()
            .filter_map(|c| match c {
                ' ' => Some('-'),
                c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
                _ => None,
            })
            .collect();
        let mut unique = id.clone();
        let mut n = 1;
        while seen.contains(&unique) {
            unique = format!("{id}-{n}");
            n += 1;
        }
        seen.insert(unique);
    }
    seen
}

#[test]
fn every_link_and_anchor_resolves() {
    let mut errors = Vec::new();
    let mut checked = 0;
    let repo = root().canonicalize().expect("the repository");
    for page in pages() {
        let text = std::fs::read_to_string(&page).expect("read page");
        let (_, prose) = split(&text);
        let dir = page.parent().expect("folder");
        for (line, target) in links(&prose) {
            let place = format!("{}:{line}", rel(&page));
            if target.is_empty() || target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            checked += 1;
            let (path, anchor) = match target.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (target.as_str(), None),
            };
            let file = if path.is_empty() { page.clone() } else { dir.join(path) };
            let Ok(file) = file.canonicalize() else {
                errors.push(format!("{place}: {target}: no such file"));
                continue;
            };
            if !file.starts_with(&repo) {
                errors.push(format!("{place}: {target}: outside the repository"));
                continue;
            }
            if let Some(a) = anchor {
                let is_md = file.extension().is_some_and(|x| x == "md");
                let ids = is_md.then(|| anchors(&std::fs::read_to_string(&file).unwrap_or_default()));
                if !ids.is_some_and(|ids| ids.contains(a)) {
                    errors.push(format!("{place}: {target}: no heading with the id '{a}'"));
                }
            }
        }
        for (i, line) in text.lines().enumerate() {
            if let Some(p) = line.find("{{#include ") {
                let name = line[p + 11..].split(['}', ':']).next().unwrap_or("").trim();
                if !dir.join(name).is_file() {
                    errors.push(format!("{}:{}: include of a missing file {name}", rel(&page), i + 1));
                }
            }
        }
    }
    // every page is reachable from SUMMARY.md
    let src = root().join("docs/src");
    let summary = std::fs::read_to_string(src.join("SUMMARY.md")).expect("docs/src/SUMMARY.md");
    let listed: BTreeSet<PathBuf> = links(&summary)
        .into_iter()
        .filter_map(|(_, t)| src.join(t).canonicalize().ok())
        .collect();
    for page in pages().into_iter().filter(|p| p.starts_with(&src) && !p.ends_with("SUMMARY.md")) {
        if !page.canonicalize().is_ok_and(|p| listed.contains(&p)) {
            errors.push(format!("{}: not listed in docs/src/SUMMARY.md", rel(&page)));
        }
    }
    eprintln!("{checked} relative links checked");
    assert!(checked >= 20, "only {checked} relative links found");
    assert!(errors.is_empty(), "broken links in the documentation:\n{}", errors.join("\n"));
}
