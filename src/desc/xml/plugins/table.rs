//! The plugin table: every Mitsuba plugin and parameter with what rdr does with it.
//! Each family file declares its plugins' rows (`DOCS`) beside the code that reads
//! them, and `plugins::FAMILIES` lists the families; a plugin reader
//! (`props::Plugin`) refuses to read a parameter its plugin's rows do not declare,
//! or with a default other than the declared one, so the table cannot drift from
//! the readers. The manual's page (`docs/src/mitsuba/plugins.md`) is [`markdown`]
//! of it (`tests/doc_mitsuba_plugins.rs`).

/// What rdr does with a plugin or a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Read as Mitsuba reads it.
    Read,
    /// Read, with a difference the note names.
    Differs,
    /// Accepted and without effect (a warning where it would change the image).
    Noted,
    /// An error naming it.
    Refused,
    /// Warned about and left out of the scene.
    Skipped,
}

impl Status {
    fn word(self) -> &'static str {
        match self {
            Status::Read => "read",
            Status::Differs => "differs",
            Status::Noted => "noted",
            Status::Refused => "refused",
            Status::Skipped => "skipped",
        }
    }
}

/// One parameter of a plugin.
#[derive(Clone, Copy, Debug)]
pub struct Param {
    pub name: &'static str,
    /// `float`, `integer`, `boolean`, `string`, `point`, `transform`, `colour` (`<rgb>`,
    /// `<spectrum>` or a number), `texture` (a colour or a nested `<texture>`), …
    pub kind: &'static str,
    /// Mitsuba's default as rdr reads it; a plain value (a number, `true`, a word) is
    /// checked against the reader's, anything with a space is a description.
    pub default: &'static str,
    pub status: Status,
    pub note: &'static str,
}

/// One plugin (or several read alike) of one element.
#[derive(Debug)]
pub struct PluginDoc {
    /// `bsdf`, `shape`, …
    pub element: &'static str,
    /// Its `type` names; `*` is any type.
    pub names: &'static [&'static str],
    pub status: Status,
    pub note: &'static str,
    pub params: &'static [Param],
}

/// A parameter read as Mitsuba reads it.
pub const fn read(name: &'static str, kind: &'static str, default: &'static str, note: &'static str) -> Param {
    Param {
        name,
        kind,
        default,
        status: Status::Read,
        note,
    }
}

/// A parameter read with a difference (`note` says which).
pub const fn differs(name: &'static str, kind: &'static str, default: &'static str, note: &'static str) -> Param {
    Param {
        name,
        kind,
        default,
        status: Status::Differs,
        note,
    }
}

/// A parameter accepted without effect.
pub const fn noted(name: &'static str, kind: &'static str, note: &'static str) -> Param {
    Param {
        name,
        kind,
        default: "",
        status: Status::Noted,
        note,
    }
}

/// A parameter that is an error when given (or given other than its default).
pub const fn refused(name: &'static str, kind: &'static str, default: &'static str, note: &'static str) -> Param {
    Param {
        name,
        kind,
        default,
        status: Status::Refused,
        note,
    }
}

/// A Mitsuba 3 plugin rdr does not read.
pub const fn not_read(element: &'static str, names: &'static [&'static str], status: Status, note: &'static str) -> PluginDoc {
    PluginDoc {
        element,
        names,
        status,
        note,
        params: &[],
    }
}

/// Plugin families in the page's order: (heading, their rows).
pub type Families = [(&'static str, &'static [PluginDoc])];

/// Whether the table has rows for `element` (an element without rows is not checked).
pub fn covers(families: &Families, element: &str) -> bool {
    families.iter().any(|(_, docs)| docs.iter().any(|d| d.element == element))
}

/// The rows of `<element type="ty">`.
pub fn lookup(families: &Families, element: &str, ty: &str) -> Option<&'static PluginDoc> {
    let find = |want: &str| {
        families
            .iter()
            .flat_map(|(_, docs)| docs.iter())
            .find(|d| d.element == element && d.names.contains(&want))
    };
    find(ty).or_else(|| find("*"))
}

/// The parameter `name` of `<element type="ty">`, or why it is not in the table.
pub fn param(families: &Families, element: &str, ty: &str, name: &str) -> Result<&'static Param, String> {
    let doc = lookup(families, element, ty).ok_or_else(|| format!("the plugin table has no <{element} type=\"{ty}\">"))?;
    doc.params
        .iter()
        .find(|p| p.name == name)
        .ok_or_else(|| format!("rdr reads property \"{name}\" of <{element} type=\"{ty}\">, which the plugin table does not declare"))
}

/// Whether `given` (the reader's default, as text) agrees with the declared default.
/// Descriptions (with a space) and empty defaults are not checked.
pub fn default_agrees(declared: &str, given: &str) -> bool {
    if declared.is_empty() || declared.contains(' ') {
        return true;
    }
    match (declared.parse::<f64>(), given.parse::<f64>()) {
        (Ok(a), Ok(b)) => (a - b).abs() <= 1e-6 * a.abs().max(1.0),
        _ => declared == given,
    }
}

fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// The manual's page of plugins and parameters.
pub fn markdown(families: &Families) -> String {
    let mut out = String::from(
        "# Mitsuba XML plugins\n\n\
         <!-- Generated from the plugin readers' tables (src/desc/xml/plugins/) by tests/doc_mitsuba_plugins.rs; do not edit.\n     \
         After changing what a reader reads run RDR_BLESS=1 cargo test --release --test doc_mitsuba_plugins -->\n\n\
         Every Mitsuba 3 plugin and every parameter rdr reads, with Mitsuba's defaults (which differ from the JSON \
         format's in places), and some of Mitsuba 0.6's. The table is generated from the readers' own declarations: \
         a reader cannot read a parameter, or default it, other than as declared here. Spectra become RGB as \
         Mitsuba's RGB variants make them: see [Colours from spectra](spectra.md).\n\n\
         Status: **read** as Mitsuba reads it; **differs**: read, with the difference in the notes; **noted**: \
         accepted without effect (a warning where the image would differ); **refused**: an error naming it; \
         **skipped**: a warning naming it, and the scene renders without it. A parameter not listed is warned \
         about as unknown (`--strict` makes that an error).\n",
    );
    for (heading, docs) in families {
        out.push_str(&format!("\n## {heading}\n"));
        let mut refused: Vec<String> = Vec::new();
        for d in docs.iter() {
            let names = d.names.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ");
            if d.params.is_empty() && matches!(d.status, Status::Refused) {
                refused.push(format!("`<{}>` {names}: {}", d.element, d.note));
                continue;
            }
            out.push_str(&format!("\n### `<{}>` {names}: {}\n\n{}\n", d.element, d.status.word(), d.note));
            if d.params.is_empty() {
                continue;
            }
            out.push_str("\n| parameter | type | default | status | notes |\n|---|---|---|---|---|\n");
            for p in d.params {
                let default = match p.default {
                    "" => "—".to_string(),
                    s if s.contains(' ') => cell(s),
                    s => format!("`{}`", cell(s)),
                };
                out.push_str(&format!(
                    "| `{}` | {} | {default} | {} | {} |\n",
                    p.name,
                    p.kind,
                    p.status.word(),
                    cell(p.note)
                ));
            }
        }
        if !refused.is_empty() {
            out.push_str("\n### Not read\n\n");
            for r in refused {
                out.push_str(&format!("* {r}\n"));
            }
        }
    }
    out
}
