//! A plugin element read as Mitsuba reads one: its named values (`<float>`,
//! `<rgb>`, `<transform>`, …), its nested and referenced objects, the property
//! names nobody asked for (warned about), and errors at the property's own line
//! and column.

use super::document::Element;
use super::plugins::table::{self, Families};
use super::values::{self, SpectrumRole, SpectrumValue};
use crate::error::{Result, SceneError};
use crate::math::{Mat4, Vec3};
use std::cell::RefCell;
use std::collections::{HashMap, HashSet};

/// The elements that are objects (plugins) rather than values.
pub const OBJECT_TAGS: [&str; 13] = [
    "scene",
    "integrator",
    "sensor",
    "film",
    "rfilter",
    "sampler",
    "shape",
    "bsdf",
    "emitter",
    "texture",
    "medium",
    "phase",
    "volume",
];

/// The ids of a document (and the `<alias>` names), and the warnings collected.
pub struct Ids<'a> {
    pub by_id: HashMap<String, &'a Element>,
    pub warnings: RefCell<Vec<String>>,
    /// What converting to RDR171 JSON loses (see `SceneDesc::convert_notes`).
    pub convert_notes: RefCell<Vec<String>>,
    /// The warnings about unknown properties (see `SceneDesc::unknown`).
    pub unknown: RefCell<Vec<String>>,
    /// The plugin table the readers are held to ([`table`]): a parameter read that it
    /// does not declare, or defaulted otherwise, is collected in `undeclared`.
    pub table: Option<&'static Families>,
    pub undeclared: RefCell<Vec<String>>,
}

impl<'a> Ids<'a> {
    pub fn collect(root: &'a Element) -> Result<Ids<'a>> {
        let mut ids = Ids {
            by_id: HashMap::new(),
            warnings: RefCell::new(Vec::new()),
            convert_notes: RefCell::new(Vec::new()),
            unknown: RefCell::new(Vec::new()),
            table: None,
            undeclared: RefCell::new(Vec::new()),
        };
        ids.walk(root)?;
        Ok(ids)
    }

    fn walk(&mut self, el: &'a Element) -> Result<()> {
        if OBJECT_TAGS.contains(&el.tag.as_str()) {
            if let Some(id) = el.attr("id") {
                if let Some(prev) = self.by_id.insert(id.to_string(), el) {
                    return Err(el.error(format!("duplicate id \"{id}\" (the first is at {})", where_is(prev))));
                }
            }
        }
        for c in &el.children {
            if c.tag == "alias" {
                let (Some(id), Some(alias)) = (c.attr("id"), c.attr("as")) else {
                    return Err(c.error("<alias> needs the attributes \"id\" and \"as\""));
                };
                let target = *self
                    .by_id
                    .get(id)
                    .ok_or_else(|| c.error(format!("alias source id \"{id}\" not found")))?;
                if self.by_id.insert(alias.to_string(), target).is_some() {
                    return Err(c.error(format!("alias destination id \"{alias}\" already exists")));
                }
                continue;
            }
            self.walk(c)?;
        }
        Ok(())
    }

    pub fn warn(&self, el: &Element, msg: impl AsRef<str>) {
        self.warnings.borrow_mut().push(format!("{}: {}", where_is(el), msg.as_ref()));
    }

    /// Notes what `rdr convert` to JSON loses at `el` (not a rendering warning).
    pub fn convert_note(&self, el: &Element, msg: impl AsRef<str>) {
        self.convert_notes.borrow_mut().push(format!("{}: {}", where_is(el), msg.as_ref()));
    }
}

/// `file: line L, column C` of an element.
pub fn where_is(el: &Element) -> String {
    match &el.source {
        crate::desc::Source::Position { file, line, column } => format!("{}: line {line}, column {column}", file.display()),
        crate::desc::Source::Json(p) => p.clone(),
        crate::desc::Source::Key { file, key } => format!("{}: {key}", file.display()),
    }
}

/// One value of a plugin.
#[derive(Clone, Debug)]
pub enum Value {
    Float(f64),
    Integer(i64),
    Boolean(bool),
    String(String),
    Point(Vec3),
    Vector(Vec3),
    Rgb(Vec3),
    Spectrum(SpectrumValue),
    Transform(Mat4),
}

impl Value {
    fn kind(&self) -> &'static str {
        match self {
            Value::Float(_) => "a float",
            Value::Integer(_) => "an integer",
            Value::Boolean(_) => "a boolean",
            Value::String(_) => "a string",
            Value::Point(_) => "a point",
            Value::Vector(_) => "a vector",
            Value::Rgb(_) => "an rgb",
            Value::Spectrum(_) => "a spectrum",
            Value::Transform(_) => "a transform",
        }
    }
}

/// A colour-valued property: a constant, or a texture object.
pub enum Colour<'a> {
    Constant(Vec3),
    Texture(&'a Element),
}

/// A plugin element with its values and child objects.
pub struct Plugin<'a> {
    pub el: &'a Element,
    pub ty: String,
    values: Vec<(String, Value, &'a Element)>,
    /// Where each name is in `values` (a plugin may hold any number of them).
    value_index: HashMap<String, usize>,
    /// Child objects, nested or referenced: (property name if given, element, where).
    objects: Vec<(Option<String>, &'a Element, &'a Element)>,
    used: RefCell<HashSet<String>>,
    /// Every property name asked for, present or not (for "did you mean"); bounded by the
    /// reader's own queries, not by the file.
    asked: RefCell<Vec<String>>,
    pub ids: &'a Ids<'a>,
}

impl<'a> Plugin<'a> {
    pub fn new(el: &'a Element, ids: &'a Ids<'a>) -> Result<Plugin<'a>> {
        let ty = match el.tag.as_str() {
            "scene" => "scene".to_string(),
            _ => el
                .attr("type")
                .ok_or_else(|| el.error(format!("<{}> needs a \"type\" attribute", el.tag)))?
                .to_string(),
        };
        let mut p = Plugin {
            el,
            ty,
            values: Vec::new(),
            value_index: HashMap::new(),
            objects: Vec::new(),
            used: RefCell::new(HashSet::new()),
            asked: RefCell::new(Vec::new()),
            ids,
        };
        for c in &el.children {
            p.child(c)?;
        }
        Ok(p)
    }

    /// `<bsdf type="diffuse">` for messages.
    pub fn describe(&self) -> String {
        match self.el.tag.as_str() {
            "scene" => "<scene>".to_string(),
            t => format!("<{t} type=\"{}\">", self.ty),
        }
    }

    pub fn error(&self, msg: impl Into<String>) -> SceneError {
        self.el.error(msg)
    }

    fn child(&mut self, c: &'a Element) -> Result<()> {
        let tag = c.tag.as_str();
        if OBJECT_TAGS.contains(&tag) {
            self.objects.push((c.attr("name").map(str::to_string), c, c));
            return Ok(());
        }
        if tag == "ref" {
            let id = c.attr("id").ok_or_else(|| c.error("<ref> needs an \"id\" attribute"))?;
            let target = self.ids.by_id.get(id).ok_or_else(|| {
                c.error(format!(
                    "reference to an unknown id \"{id}\" (make sure an object with id=\"{id}\" exists)"
                ))
            })?;
            self.objects.push((c.attr("name").map(str::to_string), target, c));
            return Ok(());
        }
        if tag == "alias" {
            return Ok(()); // collected with the ids
        }
        let name = c
            .attr("name")
            .ok_or_else(|| c.error(format!("<{tag}> needs a \"name\" attribute")))?
            .to_string();
        let bad = |msg: String| c.error(format!("<{tag} name=\"{name}\">: {msg}"));
        let value_attr = || c.attr("value").ok_or_else(|| bad("missing attribute \"value\"".into()));
        let xyz = |default: f64| -> Result<Vec3> {
            if let Some(v) = c.attr("value") {
                if ["x", "y", "z"].iter().any(|a| c.attr(a).is_some()) {
                    return Err(bad("cannot mix \"value\" and \"x\"/\"y\"/\"z\"".into()));
                }
                return values::numbers(v, 3, true).map(|n| values::vec3(&n)).map_err(bad);
            }
            let mut out = [default; 3];
            for (i, a) in ["x", "y", "z"].iter().enumerate() {
                if let Some(s) = c.attr(a) {
                    out[i] = values::number(s).map_err(bad)?;
                }
            }
            Ok(values::vec3(&out))
        };
        let value = match tag {
            "float" => Value::Float(values::number(value_attr()?).map_err(bad)?),
            "integer" => Value::Integer(values::integer(value_attr()?).map_err(bad)?),
            "boolean" => Value::Boolean(values::boolean(value_attr()?).map_err(bad)?),
            "string" => Value::String(value_attr()?.to_string()),
            "point" => Value::Point(xyz(0.0)?),
            "vector" => Value::Vector(xyz(0.0)?),
            "rgb" => Value::Rgb(values::numbers(value_attr()?, 3, true).map(|n| values::vec3(&n)).map_err(bad)?),
            "spectrum" if c.attr("type").is_some() => Value::Spectrum(self.typed_spectrum(c, &name)?),
            "spectrum" => {
                if c.attr("filename").is_some() {
                    return Err(bad("spectra read from files are not supported (give wavelength:value pairs)".into()));
                }
                let role = SpectrumRole::of(&name, self.el.tag == "emitter");
                let s = values::spectrum(value_attr()?, role).map_err(bad)?;
                if let SpectrumValue::Rgb(_) = s {
                    if !c.legacy {
                        return Err(bad("three values are not a spectrum (use <rgb>, or wavelength:value pairs)".into()));
                    }
                    self.ids.warn(
                        c,
                        format!("<spectrum name=\"{name}\"> with three values read as RGB, as Mitsuba 0.6 did"),
                    );
                }
                Value::Spectrum(s)
            }
            "transform" => Value::Transform(transform(c)?),
            "srgb" | "blackbody" => return Err(bad("this value type is not supported (use <rgb> or <spectrum>)".into())),
            _ => return Err(c.error(format!("unsupported XML element <{tag}>"))),
        };
        if let Some(e) = c.children.first() {
            if tag != "transform" && tag != "spectrum" {
                return Err(e.error(format!("<{}> cannot be a child of a property", e.tag)));
            }
        }
        if self.value_index.contains_key(&name) {
            return Err(bad(format!("property \"{name}\" was specified twice")));
        }
        self.value_index.insert(name.clone(), self.values.len());
        self.values.push((name, value, c));
        Ok(())
    }

    /// `<spectrum type="blackbody" name="…">` with its `temperature` (K) and optional
    /// `wavelength_min`/`wavelength_max` (nm), converted as a `wavelength:value` list would be.
    fn typed_spectrum(&self, c: &Element, name: &str) -> Result<SpectrumValue> {
        let ty = c.attr("type").unwrap_or_default();
        if ty != "blackbody" {
            return Err(c.error(format!(
                "<spectrum type=\"{ty}\" name=\"{name}\">: unsupported spectrum type (rdr reads \"blackbody\")"
            )));
        }
        let (mut kelvin, mut range) = (None, (360.0, 830.0));
        for p in &c.children {
            let (Some(n), Some(v)) = (p.attr("name"), p.attr("value")) else {
                return Err(p.error(format!("<{}> in <spectrum type=\"blackbody\"> needs \"name\" and \"value\"", p.tag)));
            };
            let x = values::number(v).map_err(|e| p.error(format!("<{} name=\"{n}\">: {e}", p.tag)))?;
            match n {
                "temperature" => kelvin = Some(x),
                "wavelength_min" => range.0 = x,
                "wavelength_max" => range.1 = x,
                _ => return Err(p.error(format!("unknown property \"{n}\" of <spectrum type=\"blackbody\">"))),
            }
        }
        let kelvin = kelvin.ok_or_else(|| c.error(format!("<spectrum type=\"blackbody\" name=\"{name}\">: needs a \"temperature\"")))?;
        if kelvin <= 0.0 || !(range.0 > 0.0 && range.0 < range.1 && range.1 <= 1e5) {
            return Err(c.error(format!(
                "<spectrum type=\"blackbody\" name=\"{name}\">: needs temperature > 0 and 0 < wavelength_min < wavelength_max"
            )));
        }
        let role = SpectrumRole::of(name, self.el.tag == "emitter");
        Ok(SpectrumValue::Converted(values::blackbody_rgb(kelvin, range, role)))
    }

    /// The table's row of parameter `name`, or `None` (the miss noted) where the
    /// table covers this element and does not declare it.
    fn declared(&self, name: &str) -> Option<&'static table::Param> {
        let families = self.ids.table?;
        if !table::covers(families, &self.el.tag) {
            return None;
        }
        match table::param(families, &self.el.tag, &self.ty, name) {
            Ok(p) => Some(p),
            Err(e) => {
                self.ids.undeclared.borrow_mut().push(format!("{}: {e}", where_is(self.el)));
                None
            }
        }
    }

    /// Notes a reader's default that differs from the table's.
    fn check_default(&self, name: &str, given: impl std::fmt::Display) {
        let given = given.to_string();
        if let Some(p) = self.declared(name) {
            if !table::default_agrees(p.default, &given) {
                self.ids.undeclared.borrow_mut().push(format!(
                    "{}: the reader defaults property \"{name}\" of {} to {given}, the plugin table to {}",
                    where_is(self.el),
                    self.describe(),
                    p.default
                ));
            }
        }
    }

    fn get(&self, name: &str) -> Option<&(String, Value, &'a Element)> {
        if !self.asked.borrow().iter().any(|a| a == name) {
            self.asked.borrow_mut().push(name.to_string());
            self.declared(name);
        }
        let v = &self.values[*self.value_index.get(name)?];
        self.used.borrow_mut().insert(name.to_string());
        Some(v)
    }

    pub fn has(&self, name: &str) -> bool {
        self.value_index.contains_key(name) || self.objects.iter().any(|(n, _, _)| n.as_deref() == Some(name))
    }

    /// Marks a property as read without interpreting it.
    pub fn ignore(&self, name: &str) {
        self.get(name);
        self.used.borrow_mut().insert(name.to_string());
    }

    fn wrong(&self, el: &Element, name: &str, want: &str, found: &Value) -> SceneError {
        el.error(format!(
            "property \"{name}\" of {}: expected {want}, found {}",
            self.describe(),
            found.kind()
        ))
    }

    pub fn float_opt(&self, name: &str) -> Result<Option<f32>> {
        match self.get(name) {
            // a texture where rdr reads a number (textured roughness): an error, not the default
            None => match self.objects.iter().find(|(n, _, _)| n.as_deref() == Some(name)) {
                Some((_, el, at)) => Err(at.error(format!(
                    "property \"{name}\" of {} must be a number here, not a <{}> (rdr does not read it as a texture)",
                    self.describe(),
                    el.tag
                ))),
                None => Ok(None),
            },
            Some((_, Value::Float(v), _)) => Ok(Some(*v as f32)),
            Some((_, Value::Integer(v), _)) => Ok(Some(*v as f32)),
            Some((n, v, el)) => Err(self.wrong(el, n, "a float", v)),
        }
    }

    pub fn float(&self, name: &str, default: f32) -> Result<f32> {
        self.check_default(name, default);
        Ok(self.float_opt(name)?.unwrap_or(default))
    }

    pub fn integer_opt(&self, name: &str) -> Result<Option<i64>> {
        match self.get(name) {
            None => Ok(None),
            Some((_, Value::Integer(v), _)) => Ok(Some(*v)),
            Some((n, v, el)) => Err(self.wrong(el, n, "an integer", v)),
        }
    }

    pub fn integer(&self, name: &str, default: i64) -> Result<i64> {
        self.check_default(name, default);
        Ok(self.integer_opt(name)?.unwrap_or(default))
    }

    /// An integer in `[lo, hi]`.
    pub fn integer_in(&self, name: &str, default: i64, lo: i64, hi: i64) -> Result<i64> {
        let v = self.integer(name, default)?;
        if v < lo || v > hi {
            return Err(self.value_error(name, format!("must be between {lo} and {hi}, found {v}")));
        }
        Ok(v)
    }

    pub fn boolean(&self, name: &str, default: bool) -> Result<bool> {
        self.check_default(name, default);
        match self.get(name) {
            None => Ok(default),
            Some((_, Value::Boolean(b), _)) => Ok(*b),
            Some((n, v, el)) => Err(self.wrong(el, n, "a boolean", v)),
        }
    }

    pub fn string_opt(&self, name: &str) -> Result<Option<String>> {
        match self.get(name) {
            None => Ok(None),
            Some((_, Value::String(s), _)) => Ok(Some(s.clone())),
            Some((n, v, el)) => Err(self.wrong(el, n, "a string", v)),
        }
    }

    pub fn string(&self, name: &str, default: &str) -> Result<String> {
        self.check_default(name, default);
        Ok(self.string_opt(name)?.unwrap_or_else(|| default.to_string()))
    }

    pub fn required_string(&self, name: &str) -> Result<String> {
        self.string_opt(name)?
            .ok_or_else(|| self.error(format!("{} needs the property \"{name}\"", self.describe())))
    }

    /// A point (or vector) property.
    pub fn point_opt(&self, name: &str) -> Result<Option<Vec3>> {
        match self.get(name) {
            None => Ok(None),
            Some((_, Value::Point(p) | Value::Vector(p), _)) => Ok(Some(*p)),
            Some((n, v, el)) => Err(self.wrong(el, n, "a point", v)),
        }
    }

    pub fn transform_opt(&self, name: &str) -> Result<Option<Mat4>> {
        match self.get(name) {
            None => Ok(None),
            Some((_, Value::Transform(m), _)) => Ok(Some(*m)),
            Some((n, v, el)) => Err(self.wrong(el, n, "a transform", v)),
        }
    }

    /// An index of refraction: a number, or a name from [`values::NAMED_IORS`].
    pub fn ior(&self, name: &str, default: &str) -> Result<f32> {
        self.check_default(name, default);
        let (v, el) = match self.get(name) {
            None => return values::ior(default).map_err(|e| self.error(e)),
            Some((_, Value::Float(v), el)) => (*v as f32, *el),
            Some((_, Value::Integer(v), el)) => (*v as f32, *el),
            Some((_, Value::String(s), el)) => (values::ior(s).map_err(|e| el.error(format!("property \"{name}\": {e}")))?, *el),
            Some((n, v, el)) => return Err(self.wrong(el, n, "a float or the name of a material", v)),
        };
        if !(1e-3..=1e3).contains(&v) {
            return Err(el.error(format!(
                "property \"{name}\" of {}: must be between 1e-3 and 1e3, found {v}",
                self.describe()
            )));
        }
        Ok(v)
    }

    /// A constant colour given as `<rgb>`, `<spectrum>` or a number.
    pub fn rgb_opt(&self, name: &str) -> Result<Option<Vec3>> {
        match self.get(name) {
            None => Ok(None),
            Some((_, v, el)) => colour_of(v)
                .map(Some)
                .ok_or_else(|| self.wrong(el, name, "a colour (<rgb> or <spectrum>)", v)),
        }
    }

    pub fn rgb(&self, name: &str, default: Vec3) -> Result<Vec3> {
        self.check_default(name, colour_text(default));
        if let Some((_, el, _)) = self.objects.iter().find(|(n, _, _)| n.as_deref() == Some(name)) {
            return Err(el.error(format!(
                "property \"{name}\" of {} must be a constant colour here, not a texture",
                self.describe()
            )));
        }
        Ok(self.rgb_opt(name)?.unwrap_or(default))
    }

    /// A colour that may also be a texture (nested or referenced by `name`).
    pub fn colour(&self, name: &str, default: Vec3) -> Result<Colour<'a>> {
        self.check_default(name, colour_text(default));
        if let Some((_, el, at)) = self.objects.iter().find(|(n, _, _)| n.as_deref() == Some(name)) {
            self.used.borrow_mut().insert(name.to_string());
            if el.tag != "texture" {
                return Err(at.error(format!(
                    "property \"{name}\" of {} must be a texture, found <{}>",
                    self.describe(),
                    el.tag
                )));
            }
            return Ok(Colour::Texture(el));
        }
        Ok(Colour::Constant(self.rgb_opt(name)?.unwrap_or(default)))
    }

    /// The child object given for property `name` (nested or referenced), with where
    /// it was named; marks the property read.
    pub fn object_named(&self, name: &str) -> Option<(&'a Element, &'a Element)> {
        let (_, el, at) = self.objects.iter().find(|(n, _, _)| n.as_deref() == Some(name))?;
        self.used.borrow_mut().insert(name.to_string());
        Some((*el, *at))
    }

    /// Where value property `name` was given.
    pub fn value_source(&self, name: &str) -> Option<crate::desc::Source> {
        self.value_index.get(name).map(|i| self.values[*i].2.source.clone())
    }

    /// Where a value property is (the plugin itself when absent).
    pub fn value_error(&self, name: &str, msg: impl Into<String>) -> SceneError {
        let el = self.value_index.get(name).map_or(self.el, |i| self.values[*i].2);
        el.error(format!("property \"{name}\" of {}: {}", self.describe(), msg.into()))
    }

    /// Child objects with tag `tag` (nested or referenced), with where they were named.
    pub fn objects(&self, tag: &str) -> Vec<(&'a Element, &'a Element)> {
        let mut out = Vec::new();
        for (n, el, at) in &self.objects {
            if el.tag == tag {
                if let Some(n) = n {
                    self.used.borrow_mut().insert(n.clone());
                }
                out.push((*el, *at));
            }
        }
        out
    }

    /// Warns about every property nobody read, and errors on objects of kinds
    /// this plugin does not take.
    pub fn finish(&self, takes: &[&str]) -> Result<()> {
        let used = self.used.borrow();
        for (n, _, el) in &self.values {
            if !used.contains(n) {
                let asked = self.asked.borrow();
                let hint = match crate::desc::json::closest(n, asked.iter().map(String::as_str)) {
                    Some(m) => format!(" (did you mean \"{m}\"?)"),
                    None => String::new(),
                };
                let msg = format!("unknown property \"{n}\" of {}", self.describe());
                self.ids.unknown.borrow_mut().push(format!("{}: {msg}{hint}", where_is(el)));
                self.ids.warn(el, format!("{msg} ignored{hint}"));
            }
        }
        for (n, el, at) in &self.objects {
            if !takes.contains(&el.tag.as_str()) && !n.as_ref().is_some_and(|n| used.contains(n)) {
                return Err(at.error(format!(
                    "{} cannot contain a <{}>{}",
                    self.describe(),
                    el.tag,
                    if takes.is_empty() {
                        String::new()
                    } else {
                        format!(" (it takes: {})", takes.join(", "))
                    }
                )));
            }
        }
        Ok(())
    }
}

/// A default colour as the plugin table writes it: one number when grey.
fn colour_text(c: Vec3) -> String {
    if c.x == c.y && c.y == c.z {
        c.x.to_string()
    } else {
        format!("{}, {}, {}", c.x, c.y, c.z)
    }
}

fn colour_of(v: &Value) -> Option<Vec3> {
    match v {
        Value::Rgb(c) => Some(*c),
        Value::Float(x) => Some(Vec3::splat(*x as f32)),
        Value::Integer(x) => Some(Vec3::splat(*x as f32)),
        Value::Spectrum(SpectrumValue::Constant(x)) => Some(Vec3::splat(*x)),
        Value::Spectrum(SpectrumValue::Rgb(c) | SpectrumValue::Converted(c)) => Some(*c),
        _ => None,
    }
}

/// A `<transform>`: its operations composed in order, each applied after the
/// ones before it (`M = opₙ · … · op₁`), as Mitsuba does.
pub fn transform(t: &Element) -> Result<Mat4> {
    let mut m = Mat4::IDENTITY;
    for op in &t.children {
        let bad = |msg: String| op.error(format!("<{}> in <transform>: {msg}", op.tag));
        let allowed = |names: &[&str]| -> Result<()> {
            for (a, _) in &op.attrs {
                if !names.contains(&a.as_str()) {
                    return Err(bad(format!("unexpected attribute \"{a}\"")));
                }
            }
            Ok(())
        };
        let xyz = |default: f64| -> Result<Vec3> {
            if let Some(v) = op.attr("value") {
                return values::numbers(v, 3, true).map(|n| values::vec3(&n)).map_err(bad);
            }
            let mut out = [default; 3];
            for (i, a) in ["x", "y", "z"].iter().enumerate() {
                if let Some(s) = op.attr(a) {
                    out[i] = values::number(s).map_err(bad)?;
                }
            }
            Ok(values::vec3(&out))
        };
        let vec_attr = |name: &str| -> Result<Vec3> {
            let s = op.attr(name).ok_or_else(|| bad(format!("missing attribute \"{name}\"")))?;
            values::numbers(s, 3, false).map(|n| values::vec3(&n)).map_err(bad)
        };
        let step = match op.tag.as_str() {
            "translate" => {
                allowed(&["x", "y", "z", "value"])?;
                values::translate(xyz(0.0)?)
            }
            "scale" => {
                allowed(&["x", "y", "z", "value"])?;
                values::scale(xyz(1.0)?)
            }
            "rotate" => {
                allowed(&["x", "y", "z", "value", "angle"])?;
                let angle = op.attr("angle").ok_or_else(|| bad("missing attribute \"angle\"".into()))?;
                values::rotate(xyz(0.0)?, values::number(angle).map_err(bad)?).map_err(bad)?
            }
            "matrix" => {
                allowed(&["value"])?;
                values::matrix(op.attr("value").ok_or_else(|| bad("missing attribute \"value\"".into()))?).map_err(bad)?
            }
            "lookat" => {
                allowed(&["origin", "target", "up"])?;
                let up = if op.attr("up").is_some() { vec_attr("up")? } else { Vec3::ZERO };
                values::look_at(vec_attr("origin")?, vec_attr("target")?, up).map_err(bad)?
            }
            other => return Err(op.error(format!("unexpected <{other}> element inside <transform>"))),
        };
        m = step * m;
    }
    if !m.is_finite() {
        return Err(t.error("the transform is not finite"));
    }
    Ok(m)
}
