//! Media in both output formats: JSON `media` entries and Mitsuba `<medium>` elements
//! (written with Mitsuba's parameters: `sigma_t`, `albedo`, `scale` 1, `<phase>`).

use crate::desc::MediumDesc;
use crate::math::Vec3;
use crate::medium::{Medium, PhaseFunction};
use serde_json::{json, Map, Value};

/// Mitsuba's `sigma_t` and `albedo` of a medium.
fn extinction_albedo(m: &Medium) -> (Vec3, Vec3) {
    match m {
        Medium::Homogeneous(h) => (h.sigma_t(), h.albedo()),
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
        let (sigma_t, albedo) = extinction_albedo(&d.medium);
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
        let (sigma_t, albedo) = extinction_albedo(&d.medium);
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
