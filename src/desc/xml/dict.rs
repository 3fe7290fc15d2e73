//! Mitsuba's scene dictionaries (`mi.load_dict({"type": "scene", ...})`) read into
//! the element tree an XML file gives, so the plugins mean what they mean in XML.
//!
//! * A dictionary with a `type` is a plugin; its tag comes from the type (`sphere` is a
//!   `<shape>`, `diffuse` a `<bsdf>`). The keys of the scene's entries become `id`s,
//!   those of nested plugins `name`s (an `id` entry sets the id).
//! * `{"type": "rgb", "value": [r, g, b]}`, `{"type": "spectrum", "value": 0.5 or
//!   [[λ, v], ...]}`, `{"type": "ref", "id": "name"}` are the values and references of
//!   XML.
//! * Booleans, integers, floats and strings are `<boolean>`, `<integer>`, `<float>`,
//!   `<string>`; three numbers a `<vector>` (which reads as a point too); a 4×4 list of
//!   rows a `<transform>`.
//!
//! Errors name the key path (`sphere.bsdf.reflectance`) in place of a line.

use super::document::Element;
use crate::desc::{SceneDesc, Source};
use crate::error::{Result, SceneError};
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// A value of a scene dictionary, entries in their order.
#[derive(Clone, Debug, PartialEq)]
pub enum DictValue {
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
    List(Vec<DictValue>),
    Dict(Vec<(String, DictValue)>),
}

/// The XML tag of a plugin type, from the lists of types the XML reader takes (the
/// first word of each entry: "volpath (without media)"; `area` emitters sit in shapes).
fn tag_of(ty: &str) -> Option<&'static str> {
    use super::plugins::{BSDFS, EMITTERS, FILTERS, INTEGRATORS, SHAPES, TEXTURES};
    let lists = [
        ("sensor", "perspective, thinlens, orthographic"),
        ("film", "hdrfilm"),
        ("sampler", "independent, stratified, multijitter, ldsampler, orthogonal"),
        ("rfilter", FILTERS),
        ("integrator", INTEGRATORS),
        ("shape", SHAPES),
        ("bsdf", BSDFS),
        ("emitter", EMITTERS),
        ("texture", TEXTURES),
    ];
    if ty == "area" {
        return Some("emitter");
    }
    lists
        .iter()
        .find(|(_, list)| list.split(", ").any(|entry| entry.split_whitespace().next() == Some(ty)))
        .map(|(tag, _)| *tag)
}

/// Reads a scene dictionary; `name` stands for it in messages (`<dict>`), and relative
/// file names are looked up in `base_dir`.
pub fn load(root: &DictValue, name: &Path, base_dir: &Path) -> Result<SceneDesc> {
    let search = Rc::new(vec![base_dir.to_path_buf()]);
    let b = Builder { file: name, search };
    let DictValue::Dict(entries) = root else {
        return Err(SceneError::new(name, None, "a scene dictionary must be a dict"));
    };
    if type_of(entries) != Some("scene") {
        return Err(SceneError::new(name, Some("type"), "the root must have \"type\": \"scene\""));
    }
    let mut el = b.element("scene", Vec::new(), "");
    for (k, v) in entries.iter().filter(|(k, _)| k != "type") {
        el.children.push(b.child(k, v, k, true)?);
    }
    let mut desc = super::plugins::scene(&el, name)?;
    desc.base_dir = base_dir.to_path_buf();
    Ok(desc)
}

fn type_of(entries: &[(String, DictValue)]) -> Option<&str> {
    entries.iter().find_map(|(k, v)| match (k.as_str(), v) {
        ("type", DictValue::Str(t)) => Some(t.as_str()),
        _ => None,
    })
}

struct Builder<'a> {
    file: &'a Path,
    search: Rc<Vec<PathBuf>>,
}

impl Builder<'_> {
    fn element(&self, tag: &str, attrs: Vec<(String, String)>, path: &str) -> Element {
        Element {
            tag: tag.to_string(),
            attrs,
            children: Vec::new(),
            source: Source::Key {
                file: self.file.to_path_buf(),
                key: path.to_string(),
            },
            legacy: false,
            search: self.search.clone(),
        }
    }

    fn error(&self, path: &str, msg: impl Into<String>) -> SceneError {
        SceneError::new(self.file, (!path.is_empty()).then_some(path), msg)
    }

    /// The element of entry `key` (at key path `path`); `top`: an entry of the scene.
    fn child(&self, key: &str, v: &DictValue, path: &str, top: bool) -> Result<Element> {
        let named = |tag: &str, value: String| self.element(tag, vec![("name".into(), key.into()), ("value".into(), value)], path);
        Ok(match v {
            DictValue::Bool(b) => named("boolean", b.to_string()),
            DictValue::Int(i) => named("integer", i.to_string()),
            DictValue::Float(x) => named("float", number(*x)),
            DictValue::Str(s) => named("string", s.clone()),
            DictValue::List(items) => {
                if let Some(rows) = matrix(items) {
                    let mut t = self.element("transform", vec![("name".into(), key.into())], path);
                    let m = self.element("matrix", vec![("value".into(), rows.join(" "))], path);
                    t.children.push(m);
                    t
                } else if let Some(xyz) = numbers(items).filter(|n| n.len() == 3) {
                    named("vector", xyz.join(", "))
                } else {
                    return Err(self.error(path, "a list must be three numbers (a vector) or four rows of four (a transform)"));
                }
            }
            DictValue::Dict(entries) => self.plugin(key, entries, path, top)?,
        })
    }

    fn plugin(&self, key: &str, entries: &[(String, DictValue)], path: &str, top: bool) -> Result<Element> {
        let Some(ty) = type_of(entries) else {
            return Err(self.error(path, "a nested dict needs a \"type\" (a plugin, \"rgb\", \"spectrum\" or \"ref\")"));
        };
        let value = || entries.iter().find(|(k, _)| k == "value").map(|(_, v)| v);
        let name = || ("name".to_string(), key.to_string());
        match ty {
            "rgb" => {
                let text = match value() {
                    Some(DictValue::List(items)) => numbers(items).filter(|n| n.len() == 3).map(|n| n.join(", ")),
                    Some(DictValue::Float(x)) => Some(number(*x)),
                    Some(DictValue::Int(i)) => Some(i.to_string()),
                    _ => None,
                };
                let text = text.ok_or_else(|| self.error(path, "an \"rgb\" needs a \"value\" of three numbers"))?;
                return Ok(self.element("rgb", vec![name(), ("value".into(), text)], path));
            }
            "spectrum" => {
                let text = match value() {
                    Some(DictValue::Float(x)) => Some(number(*x)),
                    Some(DictValue::Int(i)) => Some(i.to_string()),
                    Some(DictValue::List(pairs)) => pairs
                        .iter()
                        .map(|p| match p {
                            DictValue::List(two) => numbers(two).filter(|n| n.len() == 2).map(|n| format!("{}:{}", n[0], n[1])),
                            _ => None,
                        })
                        .collect::<Option<Vec<_>>>()
                        .map(|v| v.join(", ")),
                    _ => None,
                };
                let text =
                    text.ok_or_else(|| self.error(path, "a \"spectrum\" needs a \"value\": a number or [wavelength, value] pairs"))?;
                return Ok(self.element("spectrum", vec![name(), ("value".into(), text)], path));
            }
            "ref" => {
                let Some((_, DictValue::Str(id))) = entries.iter().find(|(k, _)| k == "id") else {
                    return Err(self.error(path, "a \"ref\" needs an \"id\" (a string)"));
                };
                return Ok(self.element("ref", vec![name(), ("id".into(), id.clone())], path));
            }
            _ => {}
        }
        let Some(tag) = tag_of(ty) else {
            return Err(self.error(&join(path, "type"), format!("unknown plugin type \"{ty}\"")));
        };
        let id = entries.iter().find_map(|(k, v)| match (k.as_str(), v) {
            ("id", DictValue::Str(s)) => Some(s.clone()),
            _ => None,
        });
        let mut attrs = vec![("type".to_string(), ty.to_string())];
        match (id, top) {
            (Some(id), _) => attrs.push(("id".into(), id)),
            (None, true) => attrs.push(("id".into(), key.to_string())),
            (None, false) => {}
        }
        if !top {
            attrs.push(name());
        }
        let mut el = self.element(tag, attrs, path);
        for (k, v) in entries.iter().filter(|(k, _)| k != "type" && k != "id") {
            el.children.push(self.child(k, v, &join(path, k), false)?);
        }
        Ok(el)
    }
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

/// A number as XML text that reads back to the same `f64`.
fn number(x: f64) -> String {
    format!("{x:?}")
}

fn numbers(items: &[DictValue]) -> Option<Vec<String>> {
    items
        .iter()
        .map(|v| match v {
            DictValue::Float(x) => Some(number(*x)),
            DictValue::Int(i) => Some(i.to_string()),
            _ => None,
        })
        .collect()
}

/// Four rows of four numbers, row-major text.
fn matrix(items: &[DictValue]) -> Option<Vec<String>> {
    if items.len() != 4 {
        return None;
    }
    let mut out = Vec::new();
    for row in items {
        match row {
            DictValue::List(r) if r.len() == 4 => out.extend(numbers(r)?),
            _ => return None,
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(entries: Vec<(&str, DictValue)>) -> DictValue {
        DictValue::Dict(entries.into_iter().map(|(k, v)| (k.to_string(), v)).collect())
    }
    fn s(x: &str) -> DictValue {
        DictValue::Str(x.into())
    }

    #[test]
    fn a_dict_reads_as_its_xml() {
        let f = DictValue::Float;
        let rgb = |v: [f64; 3]| {
            d(vec![
                ("type", s("rgb")),
                ("value", DictValue::List(v.iter().map(|x| f(*x)).collect())),
            ])
        };
        let scene = d(vec![
            ("type", s("scene")),
            ("integrator", d(vec![("type", s("path")), ("max_depth", DictValue::Int(5))])),
            (
                "camera",
                d(vec![
                    ("type", s("perspective")),
                    ("fov", f(30.0)),
                    (
                        "to_world",
                        DictValue::List(vec![
                            row([1.0, 0.0, 0.0, 0.5]),
                            row([0.0, 1.0, 0.0, 1.0]),
                            row([0.0, 0.0, 1.0, 4.0]),
                            row([0.0, 0.0, 0.0, 1.0]),
                        ]),
                    ),
                    (
                        "film",
                        d(vec![
                            ("type", s("hdrfilm")),
                            ("width", DictValue::Int(32)),
                            ("height", DictValue::Int(24)),
                        ]),
                    ),
                ]),
            ),
            ("red", d(vec![("type", s("diffuse")), ("reflectance", rgb([0.8, 0.1, 0.1]))])),
            (
                "ball",
                d(vec![
                    ("type", s("sphere")),
                    ("radius", f(0.5)),
                    ("bsdf", d(vec![("type", s("ref")), ("id", s("red"))])),
                ]),
            ),
        ]);
        let desc = load(&scene, Path::new("<dict>"), Path::new(".")).unwrap();
        let xml = r#"<scene version="3.0.0"><integrator type="path"><integer name="max_depth" value="5"/></integrator>
            <sensor type="perspective"><float name="fov" value="30"/><transform name="to_world"><translate x="0.5" y="1" z="4"/></transform>
            <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/></film></sensor>
            <bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf>
            <shape type="sphere"><float name="radius" value="0.5"/><ref id="red"/></shape></scene>"#;
        let mut params = super::super::document::Params::new(&[]);
        let el = super::super::document::read_str(xml, Path::new("x.xml"), &mut params).unwrap();
        let from_xml = super::super::plugins::scene(&el, Path::new("x.xml")).unwrap();
        let materials = |d: &SceneDesc| {
            d.materials
                .iter()
                .map(|m| format!("{} {:?}", m.name, m.material))
                .collect::<Vec<_>>()
        };
        assert_eq!(materials(&desc), materials(&from_xml));
        assert_eq!(format!("{:?}", desc.objects[0].shape), format!("{:?}", from_xml.objects[0].shape));
        assert_eq!(
            format!("{:?} {:?}", desc.camera, desc.film),
            format!("{:?} {:?}", from_xml.camera, from_xml.film)
        );
        assert_eq!(
            format!("{:?}", desc.integrator.integrator),
            format!("{:?}", from_xml.integrator.integrator)
        );
    }

    #[test]
    fn errors_name_the_key_path() {
        let scene = d(vec![
            ("type", s("scene")),
            ("ball", d(vec![("type", s("sphere")), ("radius", f64_list(&[1.0, 2.0]))])),
        ]);
        let e = load(&scene, Path::new("<dict>"), Path::new(".")).unwrap_err().to_string();
        assert!(e.starts_with("<dict>: ball.radius: a list must be"), "{e}");
        let scene = d(vec![("type", s("scene")), ("ball", d(vec![("type", s("sphear"))]))]);
        let e = load(&scene, Path::new("<dict>"), Path::new(".")).unwrap_err().to_string();
        assert_eq!(e, "<dict>: ball.type: unknown plugin type \"sphear\"");
    }

    fn row(v: [f64; 4]) -> DictValue {
        f64_list(&v)
    }

    fn f64_list(v: &[f64]) -> DictValue {
        DictValue::List(v.iter().map(|x| DictValue::Float(*x)).collect())
    }
}
