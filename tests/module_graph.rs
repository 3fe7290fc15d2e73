//! The library's import graph, read from `src/` by a small hand-written parser:
//! no import cycles between files or between top-level modules, and the layering
//! rules (the geometry and acceleration core knows nothing of scenes, rendering or
//! shading; camera, film and texture know nothing of the scene).
//!
//! References are `use crate::…`, `use super::…`, `use self::…`, uniform `use
//! child::…` paths, grouped trees (`use crate::{a, b::{c, d}}`), `pub use`, and
//! `crate::a::b` / `super::a` / `child::a` paths in code; comments and string
//! and char literals are blanked out first. `mod x;` declares a module and is not
//! an import. A path resolves to the file of the longest existing module prefix
//! (`a/b.rs` or `a/b/mod.rs`), and then through that file's `pub use` re-exports
//! to the file that defines the name, so `crate::accel::WideBvh` names
//! `accel/wide.rs`. `main.rs` and its modules under `cli/` are the binary crate and
//! are not part of the graph.
//!
//! Containment edges are left out: a module file referring to its own
//! submodules (a `mod.rs` re-exporting or calling its children, `lib.rs`
//! re-exporting everything) is how a module presents its parts, not an import.
//! At the top level a module's submodules importing each other is not a cycle.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::path::Path;

// ---------------------------------------------------------------------------
// Lexing
// ---------------------------------------------------------------------------

/// The source with comments (line, doc and nested block comments) and string,
/// raw string, byte string and char literals replaced by spaces; newlines are
/// kept, so line numbers stay right. Lifetimes are kept.
fn strip(src: &str) -> String {
    let c: Vec<char> = src.chars().collect();
    let mut out = String::with_capacity(src.len());
    let blank = |out: &mut String, ch: char| out.push(if ch == '\n' { '\n' } else { ' ' });
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut i = 0;
    while i < c.len() {
        let at = |k: usize| c.get(i + k).copied().unwrap_or('\0');
        let prev_ident = i > 0 && ident(c[i - 1]);
        if at(0) == '/' && at(1) == '/' {
            while i < c.len() && c[i] != '\n' {
                blank(&mut out, c[i]);
                i += 1;
            }
        } else if at(0) == '/' && at(1) == '*' {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
        } else if !prev_ident && (at(0) == 'r' || (at(0) == 'b' && at(1) == 'r')) && {
            let s = if at(0) == 'b' { 2 } else { 1 };
            let mut k = s;
            while at(k) == '#' {
                k += 1;
            }
            at(k) == '"' && (k > s || at(s) == '"')
        } {
            // raw string: r"…", r#"…"#, br"…"
            let s = if at(0) == 'b' { 2 } else { 1 };
            let mut hashes = 0;
            while at(s + hashes) == '#' {
                hashes += 1;
            }
            let start = i;
            i += s + hashes + 1;
            while i < c.len() && !(c[i] == '"' && (1..=hashes).all(|h| c.get(i + h) == Some(&'#'))) {
                i += 1;
            }
            i = (i + 1 + hashes).min(c.len());
            for &ch in &c[start..i] {
                blank(&mut out, ch);
            }
        } else if at(0) == '"' || (!prev_ident && at(0) == 'b' && at(1) == '"') {
            let start = i;
            i += if at(0) == 'b' { 2 } else { 1 };
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i = (i + 1).min(c.len());
            for &ch in &c[start..i] {
                blank(&mut out, ch);
            }
        } else if at(0) == '\'' && (at(1) == '\\' || (at(1) != '\0' && at(1) != '\'' && at(2) == '\'')) {
            // a char literal ('x', '\n', '\'', '\u{1F600}'); otherwise a lifetime
            let start = i;
            i += 1;
            if c[i] == '\\' {
                i += 2; // the backslash and the escaped character
            }
            while i < c.len() && c[i] != '\'' {
                i += 1;
            }
            i = (i + 1).min(c.len());
            for &ch in &c[start..i] {
                blank(&mut out, ch);
            }
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    Path, // `::`
    Open,
    Close,
    Comma,
    Semi,
    Star,
    Other(char),
}

/// Tokens of stripped source, each with its 1-based line.
fn tokens(code: &str) -> Vec<(Tok, usize)> {
    let c: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    while i < c.len() {
        let ch = c[i];
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch.is_alphabetic() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push((Tok::Ident(c[start..i].iter().collect()), line));
        } else if ch.is_ascii_digit() {
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
        } else if ch == '\'' {
            // a lifetime or label: not a path
            i += 1;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
        } else {
            let t = match ch {
                ':' if c.get(i + 1) == Some(&':') => {
                    i += 1;
                    Tok::Path
                }
                '{' => Tok::Open,
                '}' => Tok::Close,
                ',' => Tok::Comma,
                ';' => Tok::Semi,
                '*' => Tok::Star,
                other => Tok::Other(other),
            };
            out.push((t, line));
            i += 1;
        }
    }
    out
}

// ---------------------------------------------------------------------------
// References of one file
// ---------------------------------------------------------------------------

/// One reference as written: its path segments (`crate`, `super`, `self`, `::`
/// for a leading `::`, or a first plain name), the name it binds in a `use`
/// (the last segment or the `as` alias), its line, and whether it is a `pub use`.
#[derive(Clone, Debug, PartialEq)]
struct RawRef {
    path: Vec<String>,
    name: Option<String>,
    line: usize,
    reexport: bool,
}

/// Parses one use tree at `toks[*i]` with the segments before it in `prefix`.
fn use_tree(toks: &[(Tok, usize)], i: &mut usize, prefix: Vec<String>, out: &mut Vec<(Vec<String>, Option<String>, usize)>) {
    let mut path = prefix;
    let line = toks.get(*i).map_or(0, |t| t.1);
    if toks.get(*i).map(|t| &t.0) == Some(&Tok::Path) {
        path.push("::".into());
        *i += 1;
    }
    loop {
        match toks.get(*i).map(|t| &t.0) {
            Some(Tok::Ident(s)) => {
                path.push(s.clone());
                *i += 1;
                if toks.get(*i).map(|t| &t.0) == Some(&Tok::Path) {
                    *i += 1;
                    continue;
                }
                break;
            }
            Some(Tok::Open) => {
                *i += 1;
                while *i < toks.len() && toks[*i].0 != Tok::Close {
                    use_tree(toks, i, path.clone(), out);
                    if toks.get(*i).map(|t| &t.0) == Some(&Tok::Comma) {
                        *i += 1;
                    } else if toks.get(*i).map(|t| &t.0) != Some(&Tok::Close) {
                        // not a use tree after all: skip to the group's end
                        *i += 1;
                    }
                }
                *i += 1;
                return;
            }
            Some(Tok::Star) => {
                *i += 1;
                out.push((path, None, line));
                return;
            }
            _ => break,
        }
    }
    if path.last().is_some_and(|s| s == "self") && path.len() > 1 {
        path.pop();
    }
    let mut name = path.last().cloned();
    if toks.get(*i).map(|t| &t.0) == Some(&Tok::Ident("as".into())) {
        name = match toks.get(*i + 1).map(|t| &t.0) {
            Some(Tok::Ident(a)) if a != "_" => Some(a.clone()),
            _ => None,
        };
        *i += 2;
    }
    if !path.is_empty() {
        out.push((path, name, line));
    }
}

/// Every path reference in a file's stripped source, with the module (from the
/// crate root) it is written in: the file's module, or an inline `mod x { … }`
/// inside it. `is_child(module, name)` tells whether `name` is a submodule of
/// `module` (for paths that start with a child module's name).
fn raw_refs(code: &str, module: &[String], is_child: &dyn Fn(&[String], &str) -> bool) -> Vec<(Vec<String>, RawRef)> {
    let toks = tokens(code);
    let mut out = Vec::new();
    let mut scope: Vec<String> = module.to_vec();
    let mut inline: Vec<usize> = Vec::new(); // brace depth at each inline `mod x {`
    let mut depth = 0;
    let ident = |k: usize| match toks.get(k).map(|t| &t.0) {
        Some(Tok::Ident(s)) => Some(s.as_str()),
        _ => None,
    };
    let mut i = 0;
    while i < toks.len() {
        match &toks[i].0 {
            Tok::Ident(kw) if kw == "use" && i + 1 < toks.len() && toks[i + 1].0 != Tok::Other('!') => {
                let reexport = i > 0 && (ident(i - 1) == Some("pub") || toks[i - 1].0 == Tok::Other(')'));
                let mut trees = Vec::new();
                i += 1;
                use_tree(&toks, &mut i, Vec::new(), &mut trees);
                for (path, name, line) in trees {
                    out.push((
                        scope.clone(),
                        RawRef {
                            path,
                            name,
                            line,
                            reexport,
                        },
                    ));
                }
                while i < toks.len() && toks[i].0 != Tok::Semi {
                    i += 1;
                }
            }
            Tok::Ident(kw) if kw == "mod" && ident(i + 1).is_some() => {
                if toks.get(i + 2).map(|t| &t.0) == Some(&Tok::Open) {
                    scope.push(ident(i + 1).unwrap().to_string());
                    inline.push(depth);
                    depth += 1;
                    i += 3;
                } else {
                    i += 2; // `mod x;` declares, it does not import
                }
                continue;
            }
            Tok::Ident(first) if toks.get(i + 1).map(|t| &t.0) == Some(&Tok::Path) => {
                let after_path = i > 0 && toks[i - 1].0 == Tok::Path;
                let in_vis = i > 1 && ident(i - 1) == Some("in"); // pub(in crate::a)
                let starts = matches!(first.as_str(), "crate" | "super" | "self") || is_child(&scope, first);
                if !after_path && !in_vis && starts {
                    let line = toks[i].1;
                    let mut path = vec![first.clone()];
                    i += 1;
                    while toks.get(i).map(|t| &t.0) == Some(&Tok::Path) {
                        match ident(i + 1) {
                            Some(s) => {
                                path.push(s.to_string());
                                i += 2;
                            }
                            None => break,
                        }
                    }
                    out.push((
                        scope.clone(),
                        RawRef {
                            path,
                            name: None,
                            line,
                            reexport: false,
                        },
                    ));
                    continue;
                }
            }
            Tok::Open => depth += 1,
            Tok::Close => {
                depth -= 1;
                if inline.last() == Some(&depth) {
                    inline.pop();
                    scope.pop();
                }
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// A written path made absolute (segments from the crate root), or `None` for
/// a path into another crate or to a local item.
fn absolute(path: &[String], scope: &[String], is_child: &dyn Fn(&[String], &str) -> bool) -> Option<Vec<String>> {
    let rest = |k: usize| path[k..].iter().filter(|s| *s != "self").cloned();
    match path.first()?.as_str() {
        "crate" => Some(rest(1).collect()),
        "super" => {
            let ups = path.iter().take_while(|s| *s == "super").count();
            let base = scope.get(..scope.len().checked_sub(ups)?)?;
            Some(base.iter().cloned().chain(rest(ups)).collect())
        }
        "self" => Some(scope.iter().cloned().chain(rest(1)).collect()),
        "::" => None,
        first if is_child(scope, first) => Some(scope.iter().cloned().chain(rest(0)).collect()),
        _ => None,
    }
}

// ---------------------------------------------------------------------------
// The crate
// ---------------------------------------------------------------------------

#[derive(Clone, Debug)]
struct Edge {
    from: String, // file, relative to src/
    to: String,
    line: usize,
}

struct Crate {
    /// module path → file (relative to `src/`)
    modules: BTreeMap<Vec<String>, String>,
    /// file → (scope, reference)
    refs: BTreeMap<String, Vec<(Vec<String>, RawRef)>>,
}

/// `a/b.rs` and `a/b/mod.rs` → `[a, b]`; `lib.rs` → `[]`.
fn module_of(file: &str) -> Vec<String> {
    let mut segs: Vec<String> = file.trim_end_matches(".rs").split('/').map(str::to_string).collect();
    if segs.last().is_some_and(|s| s == "mod" || s == "lib") {
        segs.pop();
    }
    segs
}

impl Crate {
    /// From `(path relative to src/, source)` pairs of the library crate.
    fn new(files: &BTreeMap<String, String>) -> Crate {
        let modules: BTreeMap<Vec<String>, String> = files.keys().map(|f| (module_of(f), f.clone())).collect();
        let is_child = |m: &[String], name: &str| {
            let mut p = m.to_vec();
            p.push(name.to_string());
            modules.contains_key(&p)
        };
        let refs = files
            .iter()
            .map(|(f, src)| (f.clone(), raw_refs(&strip(src), &module_of(f), &is_child)))
            .collect();
        Crate { modules, refs }
    }

    fn is_child(&self, m: &[String], name: &str) -> bool {
        let mut p = m.to_vec();
        p.push(name.to_string());
        self.modules.contains_key(&p)
    }

    /// The file an absolute path names: the longest existing module prefix,
    /// then through that file's `pub use` of the next segment, if any.
    fn resolve(&self, abs: &[String], hops: usize) -> String {
        let k = (0..=abs.len()).rev().find(|&k| self.modules.contains_key(&abs[..k])).unwrap();
        let file = &self.modules[&abs[..k]];
        if let (Some(name), true) = (abs.get(k), hops < 16) {
            for (scope, r) in &self.refs[file] {
                if r.reexport && r.name.as_ref() == Some(name) {
                    if let Some(target) = absolute(&r.path, scope, &|m, n| self.is_child(m, n)) {
                        if target != abs[..=k] {
                            let full: Vec<String> = target.iter().chain(&abs[k + 1..]).cloned().collect();
                            return self.resolve(&full, hops + 1);
                        }
                    }
                }
            }
        }
        file.clone()
    }

    /// Every file-to-file reference, without self references and containment
    /// (a module file referring into its own submodules).
    fn edges(&self) -> Vec<Edge> {
        let mut edges = Vec::new();
        for (file, refs) in &self.refs {
            let own = module_of(file);
            for (scope, r) in refs {
                let Some(abs) = absolute(&r.path, scope, &|m, n| self.is_child(m, n)) else {
                    continue;
                };
                let to = self.resolve(&abs, 0);
                let target = module_of(&to);
                if to == *file || (target.len() > own.len() && target.starts_with(&own)) {
                    continue;
                }
                if !edges.iter().any(|e: &Edge| e.from == *file && e.to == to && e.line == r.line) {
                    edges.push(Edge {
                        from: file.clone(),
                        to,
                        line: r.line,
                    });
                }
            }
        }
        edges
    }
}

/// The top-level module of a file (`scene/build.rs` → `scene`; `lib.rs` → `crate`).
fn top(file: &str) -> String {
    module_of(file).first().cloned().unwrap_or_else(|| "crate".into())
}

/// Edges between top-level modules (each keeping its file and line).
fn top_edges(edges: &[Edge]) -> Vec<(String, String, &Edge)> {
    edges
        .iter()
        .map(|e| (top(&e.from), top(&e.to), e))
        .filter(|(a, b, _)| a != b && a != "crate" && b != "crate")
        .collect()
}

/// Elementary cycles covering every edge that lies on one: for each such edge
/// `u → v`, the shortest path back from `v` to `u`. Each cycle is given as its
/// nodes (the first repeated at the end), rotated to start at its smallest node.
fn cycles(nodes_edges: &[(String, String)]) -> Vec<Vec<String>> {
    let mut adj: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for (a, b) in nodes_edges {
        adj.entry(a).or_default().insert(b);
    }
    let mut found = BTreeSet::new();
    for (u, v) in nodes_edges {
        // BFS from v to u
        let mut prev: BTreeMap<&str, &str> = BTreeMap::new();
        let mut queue = VecDeque::from([v.as_str()]);
        let mut seen = BTreeSet::from([v.as_str()]);
        while let Some(x) = queue.pop_front() {
            if x == u {
                break;
            }
            for &y in adj.get(x).into_iter().flatten() {
                if seen.insert(y) {
                    prev.insert(y, x);
                    queue.push_back(y);
                }
            }
        }
        if !seen.contains(u.as_str()) {
            continue;
        }
        let mut path = vec![u.as_str()];
        while *path.last().unwrap() != v {
            path.push(prev[path.last().unwrap()]);
        }
        path.reverse(); // v … u
        let mut cycle: Vec<String> = std::iter::once(u.as_str()).chain(path).map(str::to_string).collect();
        cycle.pop(); // u v … (u)
        let start = (0..cycle.len()).min_by_key(|&k| &cycle[k]).unwrap();
        cycle.rotate_left(start);
        cycle.push(cycle[0].clone());
        found.insert(cycle);
    }
    found.into_iter().collect()
}

/// Where an edge `a → b` is written: the first place, and how many more.
fn sites<'a>(edges: impl Iterator<Item = (String, String, &'a Edge)>, a: &str, b: &str) -> String {
    let all: Vec<&Edge> = edges.filter(|(x, y, _)| x == a && y == b).map(|t| t.2).collect();
    let e = all[0];
    let more = if all.len() > 1 {
        format!(" (+{} more)", all.len() - 1)
    } else {
        String::new()
    };
    format!("src/{}:{}{more}", e.from, e.line)
}

/// The cycles of the file graph and of the top-level graph, one report each
/// (`a → b → a` and where each edge is written).
fn cycle_report(c: &Crate) -> Vec<String> {
    let edges = c.edges();
    let file_level: Vec<(String, String, &Edge)> = edges.iter().map(|e| (e.from.clone(), e.to.clone(), e)).collect();
    let top_level = top_edges(&edges);
    let mut report = Vec::new();
    for (level, graph) in [("file", &file_level), ("top-level module", &top_level)] {
        let pairs: Vec<(String, String)> = graph.iter().map(|(a, b, _)| (a.clone(), b.clone())).collect();
        for cycle in cycles(&pairs) {
            let mut s = format!("{level} cycle: {}", cycle.join(" → "));
            for w in cycle.windows(2) {
                s += &format!("\n    {} → {}: {}", w[0], w[1], sites(graph.iter().cloned(), &w[0], &w[1]));
            }
            report.push(s);
        }
    }
    report
}

/// Top-level modules that must not import the listed ones.
const LAYERS: &[(&[&str], &[&str])] = &[
    (
        &["geometry", "accel"],
        &[
            "scene",
            "integrator",
            "render",
            "compat",
            "light",
            "material",
            "camera",
            "film",
            "bench",
            "desc",
        ],
    ),
    (&["camera", "film", "texture", "volume"], &["scene", "desc", "integrator", "render"]),
    // the world knows neither its description nor who renders it
    (&["scene", "light", "material"], &["desc", "integrator", "render", "compat"]),
    // media are physics: the world places them, integrators track them
    (&["medium"], &["scene", "desc", "integrator", "render", "compat"]),
    // integrators read render-ready objects only; their parameters are parsed above them
    (&["integrator"], &["desc", "render"]),
];

fn layer_report(c: &Crate) -> Vec<String> {
    let edges = c.edges();
    let top_level = top_edges(&edges);
    let mut pairs: BTreeSet<(String, String)> = BTreeSet::new();
    for (a, b, _) in &top_level {
        if LAYERS
            .iter()
            .any(|(low, high)| low.contains(&a.as_str()) && high.contains(&b.as_str()))
        {
            pairs.insert((a.clone(), b.clone()));
        }
    }
    pairs
        .into_iter()
        .map(|(a, b)| {
            let all: Vec<String> = top_level
                .iter()
                .filter(|(x, y, _)| *x == a && *y == b)
                .map(|(_, _, e)| format!("src/{}:{} → {}", e.from, e.line, e.to))
                .collect();
            format!("{a} must not import {b}:\n    {}", all.join("\n    "))
        })
        .collect()
}

fn assert_no_cycles(c: &Crate) {
    let r = cycle_report(c);
    assert!(r.is_empty(), "{} import cycles:\n{}", r.len(), r.join("\n"));
}

fn assert_layers(c: &Crate) {
    let r = layer_report(c);
    assert!(r.is_empty(), "{} layering violations:\n{}", r.len(), r.join("\n"));
}

/// The library crate's files under `src/` (not `main.rs` and `cli/`, the binary), or under
/// `$RDR_MODULE_GRAPH_SRC` when set (to check another tree, e.g. a branch's
/// `git archive` before merging it).
fn src_crate() -> Crate {
    let root = match std::env::var_os("RDR_MODULE_GRAPH_SRC") {
        Some(dir) => std::path::PathBuf::from(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("src"),
    };
    let mut files = BTreeMap::new();
    let mut stack = vec![root.clone()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "rs") {
                let rel = p.strip_prefix(&root).unwrap().to_string_lossy().replace('\\', "/");
                if rel != "main.rs" && !rel.starts_with("bin/") && !rel.starts_with("cli/") {
                    files.insert(rel, std::fs::read_to_string(&p).unwrap());
                }
            }
        }
    }
    assert!(files.contains_key("lib.rs"), "no src/lib.rs");
    Crate::new(&files)
}

// ---------------------------------------------------------------------------
// The real src/
// ---------------------------------------------------------------------------

#[test]
fn src_has_no_import_cycles() {
    assert_no_cycles(&src_crate());
}

#[test]
fn src_respects_the_layers() {
    assert_layers(&src_crate());
}

#[test]
fn src_graph_is_read() {
    // the parser finds the library's references at all (guards the two tests above
    // against passing on an empty graph)
    let c = src_crate();
    assert!(c.modules.len() > 20, "{} modules", c.modules.len());
    let edges = c.edges();
    assert!(edges.len() > 100, "only {} edges", edges.len());
    let tops: BTreeSet<(String, String)> = top_edges(&edges).into_iter().map(|(a, b, _)| (a, b)).collect();
    assert!(tops.contains(&("accel".into(), "geometry".into())), "{tops:?}");
    assert!(tops.contains(&("render".into(), "film".into())), "{tops:?}");
    // every file but the crate root is named by some reference
    let named: BTreeSet<&str> = edges.iter().map(|e| e.to.as_str()).collect();
    eprintln!("{} modules, {} edges; files no one imports: {:?}", c.modules.len(), edges.len(), {
        c.modules.values().filter(|f| !named.contains(f.as_str())).collect::<Vec<_>>()
    });
    // print today's findings (the ignored tests fail with the same text)
    for line in cycle_report(&c).iter().chain(&layer_report(&c)) {
        eprintln!("{line}");
    }
}

// ---------------------------------------------------------------------------
// The parser itself
// ---------------------------------------------------------------------------

fn files(list: &[(&str, &str)]) -> Crate {
    Crate::new(&list.iter().map(|(f, s)| (f.to_string(), s.to_string())).collect())
}

fn edge_list(c: &Crate) -> Vec<String> {
    c.edges().iter().map(|e| format!("{}:{} → {}", e.from, e.line, e.to)).collect()
}

#[test]
fn comments_and_literals_are_blanked() {
    let src = "a // crate::x\nb /* crate::y /* nested */ still */ c\n\"crate::z \\\" crate::w\" d\n\
               r#\"crate::\"raw\"\"# e '\"' f 'g: &'a str; '\\'' h b\"crate::q\" br\"crate::p\" i\n";
    let s = strip(src);
    assert_eq!(s.lines().count(), src.lines().count());
    assert!(!s.contains("crate"), "{s}");
    let words: Vec<&str> = s.split_whitespace().collect();
    assert_eq!(words, ["a", "b", "c", "d", "e", "f", "'g:", "&'a", "str;", "h", "i"]);
}

#[test]
fn use_forms_are_all_read() {
    let c = files(&[
        ("lib.rs", "pub mod a;\npub mod b;\npub mod c;\npub use a::Thing;\n"),
        ("a/mod.rs", "pub mod x;\npub mod y;\npub use x::Thing;\n"),
        ("a/x.rs", "pub struct Thing;\nuse super::y::{self, Other};\n"),
        (
            "a/y.rs",
            "pub struct Other;\n#[cfg(test)]\nmod tests {\n    use super::*;\n    use super::super::x;\n}\n",
        ),
        (
            "b.rs",
            "use crate::{a::{x::Thing as T, y}, c};\n// use crate::c::Hidden;\nfn f() -> &'static str { \"crate::c\" }\n\
             fn g() { let _ = crate::Thing; }\npub(in crate::b) fn h() {}\n",
        ),
        (
            "c.rs",
            "mod inner {\n    use super::super::b;\n}\npub use self::inner::*;\nuse std::fmt;\nfn k() { ::std::mem::drop(1); }\n",
        ),
    ]);
    assert_eq!(
        edge_list(&c),
        [
            "a/x.rs:2 → a/y.rs",
            "a/y.rs:5 → a/x.rs",
            "b.rs:1 → a/x.rs", // a::x::Thing
            "b.rs:1 → a/y.rs",
            "b.rs:1 → c.rs",
            "b.rs:4 → a/x.rs", // crate::Thing, through two re-exports
            "c.rs:2 → b.rs",   // from the inline module
        ]
    );
}

#[test]
fn code_paths_and_child_paths_are_read() {
    let c = files(&[
        ("lib.rs", "pub mod m;\npub mod n;\n"),
        (
            "m/mod.rs",
            "pub mod k;\npub fn f() { k::g(); crate::n::h(); }\nstruct S { n: crate::n::T }\n",
        ),
        ("m/k.rs", "pub fn g() { super::f(); Self::x(); }\n"),
        ("n.rs", "pub fn h() {}\npub struct T;\nfn i() { k::g() }\n"),
    ]);
    // m/mod.rs → m/k.rs is containment; `k::` in n.rs is not a child of n
    assert_eq!(edge_list(&c), ["m/k.rs:1 → m/mod.rs", "m/mod.rs:2 → n.rs", "m/mod.rs:3 → n.rs"]);
}

fn cyclic() -> Crate {
    files(&[
        ("lib.rs", "pub mod a;\npub mod b;\npub mod c;\npub mod d;\n"),
        ("a.rs", "use crate::b::B;\npub struct A;\n"),
        ("b.rs", "pub struct B;\nfn f() { let _ = crate::c::C; }\n"),
        ("c.rs", "pub struct C;\n\nuse crate::{a::A, d};\n"),
        ("d.rs", "// use crate::a::A;\npub const S: &str = \"crate::a::A\";\n"),
    ])
}

#[test]
fn cycles_are_found_with_their_edges() {
    let r = cycle_report(&cyclic());
    assert_eq!(
        r,
        [
            "file cycle: a.rs → b.rs → c.rs → a.rs\n    a.rs → b.rs: src/a.rs:1\n    b.rs → c.rs: src/b.rs:2\n    c.rs → a.rs: src/c.rs:3",
            "top-level module cycle: a → b → c → a\n    a → b: src/a.rs:1\n    b → c: src/b.rs:2\n    c → a: src/c.rs:3",
        ]
    );
}

#[test]
#[should_panic(expected = "a → b → c → a")]
fn a_cyclic_crate_fails_the_check() {
    assert_no_cycles(&cyclic());
}

#[test]
fn submodules_importing_each_other_are_no_top_level_cycle() {
    let c = files(&[
        ("lib.rs", "pub mod s;\npub mod g;\n"),
        ("s/mod.rs", "pub mod p;\npub mod q;\npub use p::P;\n"),
        ("s/p.rs", "use super::q::Q;\npub struct P;\n"),
        ("s/q.rs", "use super::p::P;\npub struct Q;\n"),
        ("g.rs", "pub fn f() -> crate::s::P { todo!() }\n"),
    ]);
    let r = cycle_report(&c);
    assert_eq!(r.len(), 1, "{r:?}");
    assert!(r[0].starts_with("file cycle: s/p.rs → s/q.rs → s/p.rs"), "{r:?}");
    // g → s (s/p.rs through the re-export) and s → g are a top-level cycle
    let c2 = files(&[
        ("lib.rs", "pub mod s;\npub mod g;\n"),
        ("s/mod.rs", "pub mod p;\npub use p::P;\n"),
        ("s/p.rs", "pub struct P;\nuse crate::g;\n"),
        ("g.rs", "pub fn f() -> crate::s::P { todo!() }\n"),
    ]);
    let r = cycle_report(&c2);
    assert!(r.iter().any(|s| s.starts_with("top-level module cycle: g → s → g")), "{r:?}");
}

#[test]
fn layer_violations_are_reported() {
    let c = files(&[
        ("lib.rs", "pub mod geometry;\npub mod scene;\npub mod camera;\n"),
        ("geometry/mod.rs", "pub mod ray;\n"),
        ("geometry/ray.rs", "use crate::scene::desc::Thing;\n"),
        ("scene/mod.rs", "pub mod desc;\nuse crate::geometry::ray;\n"),
        ("scene/desc.rs", "pub struct Thing;\n"),
        ("camera.rs", "use crate::geometry::ray;\n"),
    ]);
    assert_eq!(
        layer_report(&c),
        ["geometry must not import scene:\n    src/geometry/ray.rs:1 → scene/desc.rs"]
    );
    let ok = files(&[
        ("lib.rs", "pub mod geometry;\npub mod camera;\n"),
        ("geometry.rs", ""),
        ("camera.rs", "use crate::geometry;\n"),
    ]);
    assert!(layer_report(&ok).is_empty());
}
