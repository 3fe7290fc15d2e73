//! The structure of a Mitsuba XML file, before any plugin is interpreted: the
//! elements with their attributes after `$name` substitution, `<include>`d files
//! spliced in, `<default>` and `<path>` consumed, and the pre-2.0 dialect upgraded
//! (property names camelCase → snake_case, `<lookAt>` → `<lookat>`), each element
//! remembering its file, line and column.
//!
//! * `<default name="spp" value="64"/>` defines `$spp` unless the command line did
//!   (`-D spp=256`); a `$name` that nothing defines is an error (`\$` escapes a dollar).
//! * `<include filename="part.xml"/>` reads another file (looked up like any file, see
//!   below); a `<scene>` root is spliced in child by child. Including a file that is
//!   being included already is an error, as is nesting deeper than 15 files.
//! * `<path value="folder"/>` (a child of the root only) adds a folder where file names
//!   are looked up, before the others; relative file names are looked up in those
//!   folders and then in the folder of the file that names them (as Mitsuba's file
//!   resolver does).

use super::values::camel_to_snake;
use crate::desc::source::Source;
use crate::error::{Result, SceneError};
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Deepest `<include>` nesting.
pub const MAX_INCLUDE_DEPTH: usize = 15;
/// Deepest element nesting, counted through `<include>`s (the root is at depth 1).
/// Real scenes nest about ten deep (scene, shape, bsdf, nested bsdfs, texture); the
/// XML parser, this reader and what interprets its tree all recurse once per level,
/// so a file nested some 10,000 deep would overflow the stack instead of being refused.
pub const MAX_ELEMENT_DEPTH: usize = 100;
/// Most attributes on one element. Mitsuba's elements carry at most a few; the XML
/// parser compares each attribute with the element's earlier ones (for duplicates), so
/// an element with 300,000 of them took minutes.
pub const MAX_ATTRIBUTES: usize = 100;
/// Bytes of memory one element and one attribute take at most while a scene is read
/// (the parser's tree, this reader's, the plugins' properties): the text's counts are
/// checked against the budget with them before it is parsed. Measured peaks: 1.19 kB
/// per `<float name=".." value=".."/>`, 380 bytes per bare `<a/>`, 900 bytes per element
/// of 200,000 instances (BVH included).
const MEMORY_PER_ELEMENT: u64 = 1024;
const MEMORY_PER_ATTRIBUTE: u64 = 256;

/// One XML element.
#[derive(Clone, Debug)]
pub struct Element {
    pub tag: String,
    /// Attributes in document order, after `$` substitution (and, in pre-2.0 files,
    /// with `name` upgraded to snake_case).
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub source: Source,
    /// The `version` of the file the element is in is below 2.0 (the 0.6 dialect).
    pub legacy: bool,
    /// Folders where file names given in this element are looked up, first first.
    pub search: Rc<Vec<PathBuf>>,
}

impl Element {
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs.iter().find(|(k, _)| k == name).map(|(_, v)| v.as_str())
    }

    pub fn error(&self, msg: impl Into<String>) -> SceneError {
        self.source.error(Path::new(""), msg)
    }

    /// Where a file name given in this element is: the first folder of the search
    /// list that has it; a name found nowhere is returned relative to the element's
    /// own file's folder, so the error that it is missing names that place.
    pub fn resolve(&self, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        for dir in self.search.iter() {
            let c = dir.join(p);
            if c.exists() {
                return c;
            }
        }
        self.search.last().map(|d| d.join(p)).unwrap_or_else(|| p.to_path_buf())
    }
}

/// The values of `-D name=value` and `<default>`s, longest name first (so `$spp2`
/// is not read as `$spp` followed by `2`).
#[derive(Clone, Debug, Default)]
pub struct Params {
    list: Vec<(String, String)>,
    /// Names given on the command line, and those that were substituted somewhere.
    defined: Vec<String>,
    used: std::cell::RefCell<Vec<String>>,
    /// The files `<include>`s read, in order.
    pub included: Vec<PathBuf>,
    /// Memory the files read so far take at most, by [`MEMORY_PER_ELEMENT`] and
    /// [`MEMORY_PER_ATTRIBUTE`] (includes add up: a file may be included many times).
    memory: u64,
}

impl Params {
    pub fn new(defines: &[(String, String)]) -> Params {
        let mut p = Params::default();
        for (k, v) in defines {
            p.set(k, v);
            p.defined.push(k.clone());
        }
        p
    }

    fn set(&mut self, name: &str, value: &str) {
        self.list.retain(|(k, _)| k != name);
        self.list.push((name.to_string(), value.to_string()));
        self.list.sort_by(|a, b| b.0.len().cmp(&a.0.len()).then(a.0.cmp(&b.0)));
    }

    /// Command-line parameters that no attribute used (Mitsuba warns about them too).
    pub fn unused(&self) -> Vec<String> {
        let used = self.used.borrow();
        self.defined.iter().filter(|d| !used.contains(d)).cloned().collect()
    }

    fn has(&self, name: &str) -> bool {
        self.list.iter().any(|(k, _)| k == name)
    }

    /// `value` with every `$name` replaced; an undefined one is an error naming it.
    pub fn substitute(&self, value: &str) -> std::result::Result<String, String> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        let b = value.as_bytes();
        let mut out = String::with_capacity(value.len());
        let mut i = 0;
        while i < value.len() {
            if b[i] == b'\\' && b.get(i + 1) == Some(&b'$') {
                out.push('$');
                i += 2;
                continue;
            }
            if b[i] == b'$' {
                let rest = &value[i + 1..];
                if let Some((k, v)) = self.list.iter().find(|(k, _)| rest.starts_with(k.as_str())) {
                    self.used.borrow_mut().push(k.clone());
                    out.push_str(v);
                    i += 1 + k.len();
                    continue;
                }
                let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                return Err(format!(
                    "undefined parameter ${name} (define it with -D {name}=VALUE or a <default>)"
                ));
            }
            let ch = value[i..].chars().next().unwrap_or(' ');
            out.push(ch);
            i += ch.len_utf8();
        }
        Ok(out)
    }
}

/// 1-based line and column of byte offsets in one text, each found in time
/// logarithmic in the text's length: the line starts are found once, and a cursor
/// remembers the last answer so that offsets asked in document order (as the reader
/// asks them) count only the characters between one and the next, even on one long
/// line. (Counting from the start for each element made loading quadratic.)
pub struct Positions<'a> {
    text: &'a [u8],
    line_starts: Vec<usize>,
    /// The last offset asked, its line and its column.
    cursor: std::cell::Cell<(usize, u32, u32)>,
}

impl<'a> Positions<'a> {
    pub fn new(text: &'a str) -> Positions<'a> {
        let text = text.as_bytes();
        let mut line_starts = vec![0];
        line_starts.extend(text.iter().enumerate().filter(|(_, b)| **b == b'\n').map(|(i, _)| i + 1));
        Positions {
            text,
            line_starts,
            cursor: std::cell::Cell::new((0, 1, 1)),
        }
    }

    /// 1-based line and column (in characters) of byte `pos`.
    pub fn line_column(&self, pos: usize) -> (u32, u32) {
        let pos = pos.min(self.text.len());
        let line = self.line_starts.partition_point(|s| *s <= pos);
        let start = self.line_starts[line - 1];
        let (cur, cur_line, cur_col) = self.cursor.get();
        let (from, col) = if cur_line as usize == line && cur <= pos {
            (cur, cur_col)
        } else {
            (start, 1)
        };
        // characters are the bytes that do not continue a UTF-8 sequence
        let col = col + self.text[from..pos].iter().filter(|b| (**b as i8) >= -64).count() as u32;
        self.cursor.set((pos, line as u32, col));
        (line as u32, col)
    }
}

/// Reads a scene file (and what it includes) into its root element.
pub fn read(file: &Path, params: &mut Params) -> Result<Element> {
    let mut stack = Vec::new();
    let search = Rc::new(Vec::new());
    read_file(file, params, &mut stack, &search, None, 1)
}

fn position(file: &Path, line: u32, column: u32) -> Source {
    Source::Position {
        file: file.to_path_buf(),
        line,
        column,
    }
}

fn read_file(
    file: &Path,
    params: &mut Params,
    stack: &mut Vec<PathBuf>,
    outer: &Rc<Vec<PathBuf>>,
    from: Option<&Source>,
    depth: usize,
) -> Result<Element> {
    let fail = |msg: String| match from {
        Some(s) => s.error(Path::new(""), msg),
        None => SceneError::new(file, None, msg),
    };
    let bytes = crate::limits::read_input_file(file, crate::limits::max_input_file())
        .map_err(|e| fail(format!("cannot read '{}': {e}", file.display())))?;
    let text = String::from_utf8(bytes).map_err(|_| fail(format!("'{}' is not valid UTF-8", file.display())))?;
    read_text(&text, file, params, stack, outer, depth)
}

/// Reads scene text as if it were the file `file` (whose folder anchors includes).
pub fn read_str(text: &str, file: &Path, params: &mut Params) -> Result<Element> {
    read_text(text, file, params, &mut Vec::new(), &Rc::new(Vec::new()), 1)
}

/// `depth`: where the file's root element stands in the whole tree (1 for the scene file).
fn read_text(
    text: &str,
    file: &Path,
    params: &mut Params,
    stack: &mut Vec<PathBuf>,
    outer: &Rc<Vec<PathBuf>>,
    depth: usize,
) -> Result<Element> {
    let positions = Positions::new(text);
    let counts = scan(text, depth).map_err(|(at, msg)| {
        let (l, c) = positions.line_column(at);
        position(file, l, c).error(Path::new(""), msg)
    })?;
    let memory = (counts.elements.saturating_mul(MEMORY_PER_ELEMENT))
        .saturating_add(counts.attributes.saturating_mul(MEMORY_PER_ATTRIBUTE))
        .saturating_add(text.len() as u64);
    params.memory = params.memory.saturating_add(memory);
    crate::limits::check_memory(Some(params.memory), || {
        format!(
            "reading its {} elements and {} attributes{}",
            counts.elements,
            counts.attributes,
            if params.included.is_empty() {
                ""
            } else {
                " (with the files included so far)"
            }
        )
    })
    .map_err(|msg| SceneError::new(file, None, msg))?;
    let doc = roxmltree::Document::parse_with_options(
        text,
        roxmltree::ParsingOptions {
            allow_dtd: false,
            nodes_limit: 4_000_000,
        },
    )
    .map_err(|e| {
        let p = e.pos();
        SceneError::new(
            file,
            Some(&format!("line {}, column {}", p.row, p.col)),
            format!("invalid XML: {}", strip_position(&e.to_string())),
        )
    })?;
    let root = doc.root_element();
    let at = |n: roxmltree::Node| {
        let (l, c) = positions.line_column(n.range().start);
        position(file, l, c)
    };
    let version = root.attribute("version").ok_or_else(|| {
        at(root).error(
            Path::new(""),
            format!("missing version attribute in root element <{}>", root.tag_name().name()),
        )
    })?;
    let major: u32 = version
        .split('.')
        .next()
        .and_then(|m| m.trim().parse().ok())
        .filter(|_| version.split('.').all(|p| p.trim().parse::<u32>().is_ok()))
        .ok_or_else(|| at(root).error(Path::new(""), format!("invalid version number \"{version}\"")))?;
    let legacy = major < 2;
    let canonical = file.canonicalize().unwrap_or_else(|_| file.to_path_buf());
    stack.push(canonical);
    let dir = file
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf();
    // this file's names are looked up in its own folder after the includer's folders
    let mut folders: Vec<PathBuf> = outer.iter().cloned().collect();
    folders.retain(|d| *d != dir);
    folders.push(dir);
    let mut ctx = Reader {
        positions,
        file,
        legacy,
        search: Rc::new(folders),
        params,
        stack,
    };
    let result = ctx.element(root, true, depth);
    stack.pop();
    result
}

struct Reader<'a> {
    positions: Positions<'a>,
    file: &'a Path,
    legacy: bool,
    search: Rc<Vec<PathBuf>>,
    params: &'a mut Params,
    stack: &'a mut Vec<PathBuf>,
}

impl Reader<'_> {
    fn source(&self, n: roxmltree::Node) -> Source {
        let (l, c) = self.positions.line_column(n.range().start);
        position(self.file, l, c)
    }

    fn element(&mut self, node: roxmltree::Node, is_root: bool, depth: usize) -> Result<Element> {
        let source = self.source(node);
        let err = |msg: String| source.error(Path::new(""), msg);
        let mut tag = node.tag_name().name().to_string();
        if self.legacy && tag == "lookAt" {
            tag = "lookat".into();
        }
        let mut attrs = Vec::new();
        for a in node.attributes() {
            let mut v = self.params.substitute(a.value()).map_err(&err)?;
            if self.legacy && a.name() == "name" && tag != "default" {
                v = camel_to_snake(&v);
            }
            attrs.push((a.name().to_string(), v));
        }
        let mut el = Element {
            tag,
            attrs,
            children: Vec::new(),
            source: source.clone(),
            legacy: self.legacy,
            search: self.search.clone(),
        };
        for child in node.children() {
            if child.is_text() && !child.text().unwrap_or("").trim().is_empty() {
                return Err(self
                    .source(child)
                    .error(Path::new(""), format!("unexpected text inside <{}>", el.tag)));
            }
            if !child.is_element() {
                continue;
            }
            match child.tag_name().name() {
                "default" => {
                    let c = self.element(child, false, depth + 1)?;
                    let (Some(name), Some(value)) = (c.attr("name"), c.attr("value")) else {
                        return Err(c.error("<default> needs the attributes \"name\" and \"value\""));
                    };
                    if name.is_empty() {
                        return Err(c.error("<default>: name must be non-empty"));
                    }
                    if !self.params.has(name) {
                        let (n, v) = (name.to_string(), value.to_string());
                        self.params.set(&n, &v);
                    }
                }
                "path" => {
                    let c = self.element(child, false, depth + 1)?;
                    if !is_root {
                        return Err(c.error("<path> can only be a child of the root element"));
                    }
                    let value = c.attr("value").ok_or_else(|| c.error("<path> needs the attribute \"value\""))?;
                    let folder = c.resolve(value);
                    if !folder.is_dir() {
                        return Err(c.error(format!("<path>: folder \"{}\" not found", folder.display())));
                    }
                    let mut s: Vec<PathBuf> = vec![folder];
                    s.extend(self.search.iter().cloned());
                    self.search = Rc::new(s);
                }
                "include" => {
                    let c = self.element(child, false, depth + 1)?;
                    let name = c
                        .attr("filename")
                        .ok_or_else(|| c.error("<include> needs the attribute \"filename\""))?;
                    let path = c.resolve(name);
                    if !path.is_file() {
                        return Err(c.error(format!("included file \"{}\" not found", path.display())));
                    }
                    let canonical = path.canonicalize().unwrap_or_else(|_| path.clone());
                    if self.stack.contains(&canonical) {
                        return Err(c.error(format!("recursive <include> of \"{}\"", path.display())));
                    }
                    if self.stack.len() >= MAX_INCLUDE_DEPTH {
                        return Err(c.error(format!("<include> nested deeper than {MAX_INCLUDE_DEPTH} files")));
                    }
                    let search = self.search.clone();
                    self.params.included.push(path.clone());
                    let inc = read_file(&path, self.params, self.stack, &search, Some(&c.source), depth + 1)?;
                    if inc.tag == "scene" {
                        el.children.extend(inc.children);
                    } else {
                        el.children.push(inc);
                    }
                }
                _ => {
                    let c = self.element(child, false, depth + 1)?;
                    el.children.push(c);
                }
            }
        }
        Ok(el)
    }
}

/// Elements and attributes of a text, counted by [`scan`].
struct Counts {
    elements: u64,
    attributes: u64,
}

/// Counts the start tags of `text` and their attributes without recursion, before the
/// (recursive) XML parser sees the text; refuses, with the byte offset of the tag and
/// a message, the first start tag that stands deeper than `MAX_ELEMENT_DEPTH` when the
/// root stands at `root_depth`, or carries more than `MAX_ATTRIBUTES` attributes.
/// Comments, CDATA sections, processing instructions and quoted attribute values are
/// skipped, so the counts are exact for well-formed XML; malformed XML is refused by
/// the parser after this.
fn scan(text: &str, root_depth: usize) -> std::result::Result<Counts, (usize, String)> {
    let b = text.as_bytes();
    let skip_to = |from: usize, end: &[u8]| {
        b[from.min(b.len())..]
            .windows(end.len())
            .position(|w| w == end)
            .map_or(b.len(), |p| from + p + end.len())
    };
    let mut counts = Counts {
        elements: 0,
        attributes: 0,
    };
    let mut depth = root_depth - 1;
    let mut i = 0;
    while let Some(p) = b[i..].iter().position(|c| *c == b'<') {
        let at = i + p;
        let rest = &b[at..];
        i = if rest.starts_with(b"<!--") {
            skip_to(at + 4, b"-->")
        } else if rest.starts_with(b"<![CDATA[") {
            skip_to(at + 9, b"]]>")
        } else if rest.starts_with(b"<?") {
            skip_to(at + 2, b"?>")
        } else if rest.starts_with(b"<!") {
            skip_to(at + 2, b">")
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            at + 2
        } else {
            let mut quote = None;
            let mut attributes = 0;
            let mut j = at + 1;
            while j < b.len() {
                match (quote, b[j]) {
                    (Some(q), c) if c == q => quote = None,
                    (None, c @ (b'"' | b'\'')) => quote = Some(c),
                    (None, b'=') => attributes += 1,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            let name = || {
                let name = text[at + 1..j.min(b.len())]
                    .split(|c: char| c.is_whitespace() || c == '/' || c == '>')
                    .next()
                    .unwrap_or("");
                name.chars().take(40).collect::<String>()
            };
            depth += 1;
            if depth > MAX_ELEMENT_DEPTH {
                return Err((at, format!("<{}> is nested deeper than {MAX_ELEMENT_DEPTH} elements", name())));
            }
            if attributes > MAX_ATTRIBUTES {
                return Err((at, format!("<{}> has more than {MAX_ATTRIBUTES} attributes", name())));
            }
            counts.elements += 1;
            counts.attributes += attributes as u64;
            if b[j - 1] == b'/' {
                depth -= 1;
            }
            j + 1
        };
        if i >= b.len() {
            break;
        }
    }
    Ok(counts)
}

fn strip_position(s: &str) -> String {
    match s.rfind(" at ") {
        Some(i) if s[i..].contains(':') => s[..i].to_string(),
        _ => s.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn substitution_takes_the_longest_name_and_reports_undefined_ones() {
        let p = Params::new(&[("spp".into(), "4".into()), ("spp2".into(), "8".into())]);
        assert_eq!(p.substitute("$spp2 $spp x").unwrap(), "8 4 x");
        assert_eq!(p.substitute("\\$spp").unwrap(), "$spp");
        assert!(p.substitute("$res").unwrap_err().contains("$res"));
    }

    #[test]
    fn nesting_is_counted_past_comments_cdata_and_quoted_brackets() {
        // a quoted "/>" does not close the tag
        let nest = |n: usize, inner: &str| format!("{}{inner}{}", "<a x='/>'>".repeat(n), "</a>".repeat(n));
        let max = MAX_ELEMENT_DEPTH;
        // `max` deep is fine, and nothing inside comments, CDATA or PIs counts
        let too_deep = |text: &str, root: usize| scan(text, root).err();
        assert_eq!(too_deep(&nest(max, "<!-- > <c> --><![CDATA[ > <d>]]><?pi > <e> ?>"), 1), None);
        let b = format!("<b> is nested deeper than {max} elements");
        assert_eq!(too_deep(&nest(max - 1, "<b/>"), 2).map(|(_, t)| t), Some(b));
        let deep = nest(max + 1, "");
        assert_eq!(too_deep(&deep, 1).map(|(at, _)| at), Some(max * 10));
        // through an include: the included root stands where the <include> was
        assert_eq!(too_deep(&nest(10, ""), max - 9), None);
        assert!(too_deep(&nest(10, ""), max - 8).is_some());
        // elements and attributes (not those in comments or quotes) are counted
        let c = scan(&nest(7, "<!-- <c d='1'> --><b y='=' z=\"2\"/>"), 1).unwrap();
        assert_eq!((c.elements, c.attributes), (8, 9));
        // the whole file is read (no recursion) and refused before the parser sees it
        let dir = std::env::temp_dir().join(format!("rdr-deep-{}", std::process::id()));
        let e = read_str(
            &format!("<scene version='3.0.0'>{}</scene>", nest(20_000, "")),
            &dir.join("d.xml"),
            &mut Params::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("line 1, column") && e.contains("nested deeper than"), "{e}");
    }

    #[test]
    fn elements_with_too_many_attributes_are_refused_before_parsing() {
        let tag = |n: usize| format!("<b {}/>", (0..n).map(|i| format!("a{i}='{i}'")).collect::<Vec<_>>().join(" "));
        assert!(scan(&format!("<a>{}</a>", tag(MAX_ATTRIBUTES)), 1).is_ok());
        let (at, msg) = scan(&format!("<a>{}</a>", tag(MAX_ATTRIBUTES + 1)), 1).err().unwrap();
        assert_eq!((at, msg.as_str()), (3, "<b> has more than 100 attributes"));
    }

    #[test]
    fn line_and_column_of_a_byte_in_any_order() {
        let text = "ab\ncé\n\nxyz";
        // what counting from the start gives
        let slow = |pos: usize| {
            let before = &text.as_bytes()[..pos];
            let line = before.iter().filter(|b| **b == b'\n').count() + 1;
            let start = before.iter().rposition(|b| *b == b'\n').map_or(0, |i| i + 1);
            (line as u32, (String::from_utf8_lossy(&before[start..]).chars().count() + 1) as u32)
        };
        let bounds: Vec<usize> = (0..=text.len()).filter(|i| text.is_char_boundary(*i)).collect();
        let p = Positions::new(text);
        for &i in bounds.iter().chain(bounds.iter().rev()).chain([4, 0, 9, 2, 100].iter()) {
            assert_eq!(p.line_column(i), slow(i.min(text.len())), "byte {i}");
        }
        assert_eq!(p.line_column(4), (2, 2));
    }
}
