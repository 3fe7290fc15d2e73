//! Media in both output formats: JSON `media` entries and Mitsuba `<medium>` elements
//! (written with Mitsuba's parameters: `sigma_t`, `albedo`, `scale` 1, `<phase>`).

use crate::desc::{MediumDesc, SceneDesc};
use crate::error::Result;
use crate::math::Vec3;
use crate::medium::{Medium, PhaseFunction};
use serde_json::{json, Map, Value};

/// Mitsuba's `sigma_t` and `albedo` of a homogeneous medium.
fn extinction_albedo(m: &Medium) -> Option<(Vec3, Vec3)> {
    match m {
        Medium::Homogeneous(h) => Some((h.sigma_t(), h.albedo())),
        Medium::Heterogeneous(_) => None,
    }
}

/// Grid media are not converted yet (their volumes are loaded when read, the file names
/// are not kept): an error naming the medium.
pub fn refuse_grid_media(desc: &SceneDesc) -> Result<()> {
    match desc.media.iter().find(|m| extinction_albedo(&m.medium).is_none()) {
        Some(m) => Err(m.source.error(
            &desc.file,
            format!("medium '{}': heterogeneous media are not converted yet", m.name),
        )),
        None => Ok(()),
    }
}

fn colour_json(c: Vec3) -> Value {
    if c.x == c.y && c.y == c.z {
        json!(c.x)
    } else {
        json!([c.x, c.y, c.z])
    }
}

/// The JSON `media` object.
pub fn media_json(media: &[MediumDesc]) -> Value {
    let mut out = Map::new();
    for d in media {
        let Some((sigma_t, albedo)) = extinction_albedo(&d.medium) else {
            continue;
        };
        let mut v = json!({"type": "homogeneous", "sigma_t": colour_json(sigma_t), "albedo": colour_json(albedo)});
        if let PhaseFunction::HenyeyGreenstein { g } = d.medium.phase() {
            v["phase"] = json!({"type": "hg", "g": g});
        }
        out.insert(d.name.clone(), v);
    }
    Value::Object(out)
}

/// The media as top-level `<medium id="name">` elements.
pub fn media_xml(media: &[MediumDesc], esc: impl Fn(&str) -> String) -> String {
    let rgb = |c: Vec3| format!("{}, {}, {}", c.x, c.y, c.z);
    let mut s = String::new();
    for d in media {
        let Some((sigma_t, albedo)) = extinction_albedo(&d.medium) else {
            continue;
        };
        s += &format!(
            "  <medium type=\"homogeneous\" id=\"{}\">\n    <rgb name=\"sigma_t\" value=\"{}\"/>\n    <rgb name=\"albedo\" value=\"{}\"/>\n",
            esc(&d.name),
            rgb(sigma_t),
            rgb(albedo)
        );
        if let PhaseFunction::HenyeyGreenstein { g } = d.medium.phase() {
            s += &format!("    <phase type=\"hg\">\n      <float name=\"g\" value=\"{g}\"/>\n    </phase>\n");
        }
        s += "  </medium>\n";
    }
    s
}
