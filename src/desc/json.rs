//! Reading JSON values with the RDR171 typing rules (spec §2), remembering the
//! JSON path of every value so errors and warnings can name it.

use super::source::{Located, Source};
use crate::error::{Result, SceneError};
use crate::math::{mat4_from_row_major, Mat4, Vec2, Vec3};
use serde_json::{Map, Value};
use std::cell::RefCell;
use std::path::{Path, PathBuf};

/// Shared by every [`Props`] of one scene: the file name and collected warnings.
#[derive(Debug, Default)]
pub struct Context {
    pub file: PathBuf,
    pub warnings: RefCell<Vec<String>>,
    /// The warnings about unknown keys (also in `warnings`), which the command line
    /// makes errors unless `--lenient`.
    pub unknown: RefCell<Vec<String>>,
}

impl Context {
    pub fn new(file: &Path) -> Self {
        Context {
            file: file.to_path_buf(),
            warnings: RefCell::new(Vec::new()),
            unknown: RefCell::new(Vec::new()),
        }
    }
    pub fn warn(&self, key: &str, msg: impl AsRef<str>) {
        let at = if key.is_empty() { String::new() } else { format!("{key}: ") };
        self.warnings
            .borrow_mut()
            .push(format!("{}: {at}{}", self.file.display(), msg.as_ref()));
    }
    pub fn error(&self, key: &str, msg: impl Into<String>) -> SceneError {
        SceneError::new(&self.file, (!key.is_empty()).then_some(key), msg)
    }
}

/// A JSON object being read. Keys that were never asked for are reported by
/// [`Props::finish`] as warnings, with the closest key that was asked for.
pub struct Props<'a> {
    map: &'a Map<String, Value>,
    pub path: String,
    ctx: &'a Context,
    used: RefCell<Vec<&'a str>>,
    /// Keys asked for that the object does not have (for "did you mean").
    absent: RefCell<Vec<String>>,
}

/// Sections of other renderers' scene formats and the RDR171 key for them.
const OTHER_NAMES: [(&str, &str); 5] = [
    ("shapes", "objects"),
    ("shape", "objects"),
    ("sensor", "camera"),
    ("bsdfs", "materials"),
    ("emitters", "objects"),
];

/// The object a missing optional section reads as.
fn empty_map() -> &'static Map<String, Value> {
    static EMPTY: std::sync::OnceLock<Map<String, Value>> = std::sync::OnceLock::new();
    EMPTY.get_or_init(Map::new)
}

/// The closest of `known` to the mistyped `word` (at most a third of its letters
/// changed, at least one), case ignored.
pub fn closest<'k>(word: &str, known: impl IntoIterator<Item = &'k str>) -> Option<&'k str> {
    let word = word.to_ascii_lowercase();
    let limit = (word.chars().count() / 3).max(1);
    known
        .into_iter()
        .map(|k| (edit_distance(&word, &k.to_ascii_lowercase()), k))
        .filter(|&(d, _)| d <= limit)
        .min_by_key(|&(d, k)| (d, k))
        .map(|(_, k)| k)
}

/// Levenshtein distance with adjacent transpositions counted as one edit.
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    d[0] = (0..=b.len()).collect();
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut v = (d[i - 1][j] + 1).min(d[i][j - 1] + 1).min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                v = v.min(d[i - 2][j - 2] + 1);
            }
            d[i][j] = v;
        }
    }
    d[a.len()][b.len()]
}

fn type_name(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(n) if n.is_f64() => "a number",
        Value::Number(_) => "an integer",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

impl<'a> Props<'a> {
    pub fn root(value: &'a Value, ctx: &'a Context) -> Result<Self> {
        match value {
            Value::Object(map) => Ok(Props {
                map,
                path: String::new(),
                ctx,
                used: RefCell::new(Vec::new()),
                absent: RefCell::new(Vec::new()),
            }),
            other => Err(ctx.error("", format!("the scene must be a JSON object, found {}", type_name(other)))),
        }
    }

    pub fn ctx(&self) -> &'a Context {
        self.ctx
    }

    /// JSON path of `key` inside this object.
    pub fn key_path(&self, key: &str) -> String {
        if self.path.is_empty() {
            key.to_string()
        } else {
            format!("{}.{key}", self.path)
        }
    }

    pub fn error(&self, key: &str, msg: impl Into<String>) -> SceneError {
        self.ctx.error(&self.key_path(key), msg)
    }

    /// Where `key` of this object is.
    pub fn source(&self, key: &str) -> Source {
        Source::Json(self.key_path(key))
    }

    /// Where this object itself is.
    pub fn own_source(&self) -> Source {
        Source::Json(self.path.clone())
    }

    /// `value`, read from `key` of this object.
    pub fn located<T>(&self, key: &str, value: T) -> Located<T> {
        Located {
            value,
            source: self.source(key),
        }
    }

    pub fn contains(&self, key: &str) -> bool {
        self.map.contains_key(key)
    }

    fn get(&self, key: &str) -> Option<&'a Value> {
        let Some((k, v)) = self.map.get_key_value(key) else {
            let mut absent = self.absent.borrow_mut();
            if !absent.iter().any(|a| a == key) {
                absent.push(key.to_string());
            }
            return None;
        };
        self.used.borrow_mut().push(k.as_str());
        Some(v)
    }

    /// The value of `key` as it is (marked as read), for keys that take several types.
    pub fn raw(&self, key: &str) -> Option<&'a Value> {
        self.get(key)
    }

    /// Marks a key as known without reading it.
    pub fn ignore(&self, key: &str) {
        self.get(key);
    }

    fn required(&self, key: &str) -> Result<&'a Value> {
        self.get(key).ok_or_else(|| self.error(key, "required key is missing"))
    }

    fn number(&self, key: &str, v: &Value) -> Result<f32> {
        let x = v
            .as_f64()
            .ok_or_else(|| self.error(key, format!("expected a number, found {}", type_name(v))))?;
        let x = x as f32;
        if !x.is_finite() {
            return Err(self.error(key, format!("{} is not a finite 32-bit float", v)));
        }
        Ok(x)
    }

    fn integer(&self, key: &str, v: &Value) -> Result<i32> {
        let bad = || {
            self.error(
                key,
                format!(
                    "expected an integer, found {}",
                    if v.is_number() { v.to_string() } else { type_name(v).to_string() }
                ),
            )
        };
        let x = v.as_f64().ok_or_else(bad)?;
        if x.fract() != 0.0 || x < i32::MIN as f64 || x > i32::MAX as f64 {
            return Err(bad());
        }
        Ok(x as i32)
    }

    fn numbers<const N: usize>(&self, key: &str, v: &Value) -> Result<[f32; N]> {
        let arr = match v {
            Value::Array(a) if a.len() == N => a,
            _ => return Err(self.error(key, format!("expected an array of {N} numbers, found {}", describe(v)))),
        };
        let mut out = [0.0; N];
        for (i, (o, x)) in out.iter_mut().zip(arr).enumerate() {
            *o = self.number(&format!("{key}[{i}]"), x)?;
        }
        Ok(out)
    }

    pub fn f32_or(&self, key: &str, default: f32) -> Result<f32> {
        self.get(key).map_or(Ok(default), |v| self.number(key, v))
    }

    pub fn i32_or(&self, key: &str, default: i32) -> Result<i32> {
        self.get(key).map_or(Ok(default), |v| self.integer(key, v))
    }

    /// An integer that must be ≥ `min`.
    pub fn int_at_least(&self, key: &str, default: i32, min: i32) -> Result<u32> {
        let x = self.i32_or(key, default)?;
        if x < min {
            return Err(self.error(key, format!("must be at least {min}, found {x}")));
        }
        Ok(x as u32)
    }

    pub fn bool_or(&self, key: &str, default: bool) -> Result<bool> {
        match self.get(key) {
            None => Ok(default),
            Some(Value::Bool(b)) => Ok(*b),
            Some(v) => Err(self.error(key, format!("expected true or false, found {}", type_name(v)))),
        }
    }

    pub fn string(&self, key: &str) -> Result<String> {
        self.string_opt(key)?.ok_or_else(|| self.error(key, "required key is missing"))
    }

    pub fn string_or(&self, key: &str, default: &str) -> Result<String> {
        Ok(self.string_opt(key)?.unwrap_or_else(|| default.to_string()))
    }

    pub fn string_opt(&self, key: &str) -> Result<Option<String>> {
        match self.get(key) {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s.clone())),
            Some(v) => Err(self.error(key, format!("expected a string, found {}", type_name(v)))),
        }
    }

    pub fn vec3_or(&self, key: &str, default: Vec3) -> Result<Vec3> {
        self.get(key)
            .map_or(Ok(default), |v| self.numbers::<3>(key, v).map(Vec3::from_array))
    }

    pub fn vec3(&self, key: &str) -> Result<Vec3> {
        self.numbers::<3>(key, self.required(key)?).map(Vec3::from_array)
    }

    pub fn vec2_or(&self, key: &str, default: Vec2) -> Result<Vec2> {
        self.get(key)
            .map_or(Ok(default), |v| self.numbers::<2>(key, v).map(Vec2::from_array))
    }

    pub fn vec2i_or(&self, key: &str, default: [i32; 2]) -> Result<[i32; 2]> {
        let Some(v) = self.get(key) else { return Ok(default) };
        let arr = match v {
            Value::Array(a) if a.len() == 2 => a,
            _ => return Err(self.error(key, format!("expected an array of 2 integers, found {}", describe(v)))),
        };
        Ok([
            self.integer(&format!("{key}[0]"), &arr[0])?,
            self.integer(&format!("{key}[1]"), &arr[1])?,
        ])
    }

    /// 16 numbers in row-major order (translation in elements 3, 7, 11). Unlike the
    /// original, an all-integer matrix is accepted.
    pub fn mat4_or(&self, key: &str, default: Mat4) -> Result<Mat4> {
        let Some(v) = self.get(key) else { return Ok(default) };
        let m = self.numbers::<16>(key, v)?;
        let m = mat4_from_row_major(&m);
        if m.determinant() == 0.0 || !m.determinant().is_finite() {
            return Err(self.error(key, "matrix is singular (determinant 0)"));
        }
        Ok(m)
    }

    /// 9 numbers in row-major order, if the key is present.
    pub fn mat3_opt(&self, key: &str) -> Result<Option<glam::Mat3>> {
        let Some(v) = self.get(key) else { return Ok(None) };
        let m = self.numbers::<9>(key, v)?;
        Ok(Some(glam::Mat3::from_cols_array(&m).transpose()))
    }

    pub fn object(&self, key: &str) -> Result<Props<'a>> {
        self.object_opt(key)?.ok_or_else(|| self.error(key, "required section is missing"))
    }

    /// `key`'s object, or an empty one (every key at its default) when absent.
    pub fn object_or_empty(&self, key: &str) -> Result<Props<'a>> {
        Ok(self.object_opt(key)?.unwrap_or_else(|| Props {
            map: empty_map(),
            path: self.key_path(key),
            ctx: self.ctx,
            used: RefCell::new(Vec::new()),
            absent: RefCell::new(Vec::new()),
        }))
    }

    pub fn object_opt(&self, key: &str) -> Result<Option<Props<'a>>> {
        match self.get(key) {
            None => Ok(None),
            Some(Value::Object(map)) => Ok(Some(Props {
                map,
                path: self.key_path(key),
                ctx: self.ctx,
                used: RefCell::new(Vec::new()),
                absent: RefCell::new(Vec::new()),
            })),
            Some(v) => Err(self.error(key, format!("expected an object, found {}", type_name(v)))),
        }
    }

    /// An array of objects (an empty array is fine).
    pub fn objects(&self, key: &str) -> Result<Vec<Props<'a>>> {
        let arr = match self.get(key) {
            None => return Ok(Vec::new()),
            Some(Value::Array(a)) => a,
            Some(v) => return Err(self.error(key, format!("expected an array of objects, found {}", type_name(v)))),
        };
        arr.iter()
            .enumerate()
            .map(|(i, v)| {
                let path = format!("{}[{i}]", self.key_path(key));
                match v {
                    Value::Object(map) => Ok(Props {
                        map,
                        path,
                        ctx: self.ctx,
                        used: RefCell::new(Vec::new()),
                        absent: RefCell::new(Vec::new()),
                    }),
                    other => Err(self.ctx.error(&path, format!("expected an object, found {}", type_name(other)))),
                }
            })
            .collect()
    }

    /// An object used as a name → object map, in sorted key order.
    pub fn named_objects(&self, key: &str) -> Result<Vec<(String, Props<'a>)>> {
        let Some(section) = self.object_opt(key)? else {
            return Ok(Vec::new());
        };
        let mut names: Vec<&'a String> = section.map.keys().collect();
        names.sort();
        names
            .into_iter()
            .map(|name| {
                let p = section.object(name)?;
                Ok((name.clone(), p))
            })
            .collect::<Result<Vec<_>>>()
            .inspect(|_| section.finish())
    }

    /// The keys of this object nobody has read yet.
    pub fn unread_keys(&self) -> Vec<String> {
        let used = self.used.borrow();
        self.map.keys().filter(|k| !used.contains(&k.as_str())).cloned().collect()
    }

    /// Every key asked for so far, present or not.
    pub fn asked_keys(&self) -> Vec<String> {
        let used = self.used.borrow();
        used.iter()
            .map(|k| k.to_string())
            .chain(self.absent.borrow().iter().cloned())
            .collect()
    }

    /// Warns about every key of this object that nobody read.
    pub fn finish(&self) {
        let used = self.used.borrow();
        let mut unknown: Vec<&str> = self.map.keys().map(String::as_str).filter(|k| !used.contains(k)).collect();
        unknown.sort();
        let absent = self.absent.borrow();
        for k in unknown {
            let known = used.iter().copied().chain(absent.iter().map(String::as_str));
            let known: Vec<&str> = known.collect();
            // other renderers' names for a section
            let other = OTHER_NAMES.iter().find(|(o, n)| *o == k && known.contains(n)).map(|(_, n)| *n);
            let hint = match closest(k, known).or(other) {
                Some(m) => format!(" (did you mean '{m}'?)"),
                None => String::new(),
            };
            let at = if self.path.is_empty() {
                String::new()
            } else {
                format!("{}: ", self.path)
            };
            self.ctx
                .unknown
                .borrow_mut()
                .push(format!("{}: {at}unknown key '{k}'{hint}", self.ctx.file.display()));
            self.ctx.warn(&self.path, format!("unknown key '{k}' ignored{hint}"));
        }
    }
}

fn describe(v: &Value) -> String {
    match v {
        Value::Array(a) => format!("an array of {} element(s)", a.len()),
        other => type_name(other).to_string(),
    }
}

/// RFC 7396-like merge used by `--override` (spec §1): objects merge key by key,
/// anything else replaces.
pub fn merge(base: &mut Value, patch: &Value) {
    match (base, patch) {
        (Value::Object(b), Value::Object(p)) => {
            for (k, v) in p {
                match b.get_mut(k) {
                    Some(existing) if existing.is_object() && v.is_object() => merge(existing, v),
                    _ => {
                        b.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        (b, p) => *b = p.clone(),
    }
}

/// The JSON path (`camera.position[1]`) at a 1-based line/column of `text`, for
/// syntax errors. Best effort: it tracks objects, arrays, keys and strings.
pub fn path_at(text: &str, line: usize, column: usize) -> String {
    enum Frame {
        Obj(Option<String>),
        Arr(usize),
    }
    let mut stack: Vec<Frame> = Vec::new();
    let (mut l, mut c) = (1usize, 0usize);
    let mut chars = text.chars().peekable();
    let mut expecting_key = false;
    while let Some(ch) = chars.next() {
        if ch == '\n' {
            l += 1;
            c = 0;
        } else {
            c += 1;
        }
        if l > line || (l == line && c >= column) {
            break;
        }
        match ch {
            '{' => {
                stack.push(Frame::Obj(None));
                expecting_key = true;
            }
            '[' => stack.push(Frame::Arr(0)),
            '}' | ']' => {
                stack.pop();
            }
            ',' => match stack.last_mut() {
                Some(Frame::Arr(i)) => *i += 1,
                Some(Frame::Obj(k)) => {
                    *k = None;
                    expecting_key = true;
                }
                None => {}
            },
            ':' => expecting_key = false,
            '"' => {
                let mut s = String::new();
                while let Some(x) = chars.next() {
                    c += 1;
                    match x {
                        '"' => break,
                        '\\' => {
                            chars.next();
                            c += 1;
                        }
                        '\n' => {
                            l += 1;
                            c = 0;
                        }
                        _ => s.push(x),
                    }
                }
                if expecting_key {
                    if let Some(Frame::Obj(k)) = stack.last_mut() {
                        *k = Some(s);
                    }
                }
            }
            _ => {}
        }
    }
    let mut out = String::new();
    for f in &stack {
        match f {
            Frame::Obj(Some(k)) => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(k);
            }
            Frame::Obj(None) => {}
            Frame::Arr(i) => out.push_str(&format!("[{i}]")),
        }
    }
    out
}

/// Parses scene text; syntax errors name the line, column and the key there.
pub fn parse_text(text: &str, file: &Path) -> Result<Value> {
    crate::limits::check_memory(Some(parsed_memory_bound(text)), || "reading its JSON".to_string())
        .map_err(|msg| SceneError::new(file, None, msg))?;
    serde_json::from_str(text).map_err(|e| {
        let key = path_at(text, e.line(), e.column());
        let msg = format!(
            "invalid JSON at line {}, column {}: {}",
            e.line(),
            e.column(),
            strip_position(&e.to_string())
        );
        SceneError::new(file, (!key.is_empty()).then_some(key.as_str()), msg)
    })
}

/// Bytes the value parsed from `text` takes at most, counted from its punctuation (in
/// strings too, which only overestimates): every value but the first follows a `,`, `[`
/// or `:` and is a 32-byte `Value` in a vector that may have twice the room it needs;
/// every `:` is also an object entry (its key and map node). Measured peaks: 144 MB
/// for 3 M zeros (6 MB), 147 MB for 1 M keys (12 MB), 77 MB for 2 M empty arrays (6 MB).
fn parsed_memory_bound(text: &str) -> u64 {
    let (mut values, mut entries) = (1u64, 0u64);
    for b in text.bytes() {
        match b {
            b',' | b'[' => values += 1,
            b':' => (values, entries) = (values + 1, entries + 1),
            _ => {}
        }
    }
    text.len() as u64 + 64 * values + 128 * entries
}

fn strip_position(s: &str) -> String {
    match s.find(" at line ") {
        Some(i) => s[..i].to_string(),
        None => s.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_at_finds_the_key_of_a_syntax_error() {
        let text = "{\n \"camera\": {\n  \"position\": [0, NaN, 1]\n }\n}";
        let e = serde_json::from_str::<Value>(text).unwrap_err();
        assert_eq!(path_at(text, e.line(), e.column()), "camera.position[1]");
        let text = "{\"objects\": [{\"type\": \"mesh\"}, {\"type\": mesh}]}";
        let e = serde_json::from_str::<Value>(text).unwrap_err();
        assert_eq!(path_at(text, e.line(), e.column()), "objects[1].type");
    }

    #[test]
    fn merge_recurses_into_objects_and_replaces_arrays() {
        let mut a: Value = serde_json::json!({"integrator": {"type": "x", "spp": 4}, "film": {"resolution": [1, 2]}});
        merge(
            &mut a,
            &serde_json::json!({"integrator": {"spp": 8}, "film": {"resolution": [3, 4]}}),
        );
        assert_eq!(
            a,
            serde_json::json!({"integrator": {"type": "x", "spp": 8}, "film": {"resolution": [3, 4]}})
        );
    }

    #[test]
    fn typing_rules() {
        let ctx = Context::new(Path::new("s.json"));
        let v: Value = serde_json::json!({"a": 32, "b": 32.0, "c": 32.5, "d": [1, 2, 3], "e": [1, 2], "f": "x", "g": 1e39,
            "m": [1,0,0,2, 0,1,0,3, 0,0,1,4, 0,0,0,1]});
        let p = Props::root(&v, &ctx).unwrap();
        assert_eq!(p.i32_or("a", 0).unwrap(), 32);
        assert_eq!(p.i32_or("b", 0).unwrap(), 32, "an integral float is accepted for an int key");
        assert!(p.i32_or("c", 0).unwrap_err().to_string().contains("c: expected an integer"));
        assert_eq!(p.f32_or("a", 0.0).unwrap(), 32.0);
        assert_eq!(p.vec3_or("d", Vec3::ZERO).unwrap(), Vec3::new(1.0, 2.0, 3.0));
        assert!(p.vec3_or("e", Vec3::ZERO).is_err());
        assert!(p.f32_or("f", 0.0).is_err());
        assert!(p.f32_or("g", 0.0).unwrap_err().to_string().contains("finite"));
        let m = p.mat4_or("m", Mat4::IDENTITY).unwrap();
        assert_eq!(m.w_axis.truncate(), Vec3::new(2.0, 3.0, 4.0));
        p.finish();
        assert!(ctx.warnings.borrow().is_empty());
        let q = Props::root(&v, &ctx).unwrap();
        q.ignore("a");
        q.finish();
        assert_eq!(ctx.warnings.borrow().len(), 7);
        assert!(ctx.warnings.borrow()[0].contains("unknown key 'b'"));
    }
}
