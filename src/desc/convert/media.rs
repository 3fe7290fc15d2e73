//! Media in both output formats: JSON `media` entries and Mitsuba `<medium>` elements
//! (written with Mitsuba's parameters: `sigma_t`, `albedo`, `scale`, `<phase>`, a
//! heterogeneous medium's volumes with their grid files rebased on the output's folder,
//! and rdr's `radiance` of an emissive medium).

use super::{matrix, num, rebase, row_major};
use crate::desc::{SceneDesc, VolumeDesc};
use crate::math::{Mat4, Vec3};
use crate::medium::{Medium, PhaseFunction};
use crate::volume::Volume;
use serde_json::{json, Map, Value};
use std::path::Path;

/// A medium's parameters as its description says them: `sigma_t`, `albedo` and
/// `radiance` as volumes (a homogeneous medium's as constants), `scale`, the phase function.
struct Params {
    ty: &'static str,
    sigma_t: VolumeDesc,
    albedo: VolumeDesc,
    radiance: VolumeDesc,
    scale: f32,
    phase: PhaseFunction,
}

fn params(m: &crate::desc::MediumDesc) -> Params {
    let constant = |value: Vec3| VolumeDesc {
        value: Volume::Constant(crate::volume::ConstVolume {
            value,
            to_world: Mat4::IDENTITY,
        }),
        source: m.source.clone(),
    };
    match (&m.medium, &m.volumes) {
        (Medium::Heterogeneous(h), Some(v)) => Params {
            ty: "heterogeneous",
            sigma_t: v.sigma_t.clone(),
            albedo: v.albedo.clone(),
            radiance: v.radiance.clone(),
            scale: h.scale,
            phase: h.phase,
        },
        // a heterogeneous medium is always described with its volumes
        (Medium::Heterogeneous(h), None) => Params {
            ty: "heterogeneous",
            sigma_t: constant(Vec3::ZERO),
            albedo: constant(Vec3::ZERO),
            radiance: constant(Vec3::ZERO),
            scale: h.scale,
            phase: h.phase,
        },
        (Medium::Homogeneous(h), _) => Params {
            ty: "homogeneous",
            sigma_t: constant(h.sigma_t()),
            albedo: constant(h.albedo()),
            radiance: constant(h.radiance),
            scale: 1.0,
            phase: h.phase,
        },
    }
}

/// Whether a volume is the constant zero (an absent `radiance`).
fn is_zero(v: &VolumeDesc) -> bool {
    matches!(&v.value, Volume::Constant(c) if c.value == Vec3::ZERO)
}

fn colour_json(c: Vec3) -> Value {
    if c.x == c.y && c.y == c.z {
        num(c.x)
    } else {
        json!([num(c.x), num(c.y), num(c.z)])
    }
}

fn matrix_json(m: &Mat4) -> Value {
    Value::Array(row_major(m).into_iter().map(num).collect())
}

fn volume_json(desc: &SceneDesc, v: &VolumeDesc, out: &Path) -> Value {
    match &v.value {
        Volume::Constant(c) if c.to_world == Mat4::IDENTITY => colour_json(c.value),
        Volume::Constant(c) => json!({"type": "constvolume", "value": colour_json(c.value), "to_world": matrix_json(&c.to_world)}),
        Volume::Grid(g) => {
            let o = &g.options;
            let mut j = json!({
                "type": "gridvolume",
                "filename": rebase(desc, &g.path.value, out),
                "filter_type": o.filter.name(),
                "wrap_mode": o.wrap.name(),
            });
            if let Some(grid) = &g.grid {
                j["grid"] = grid.clone().into();
            }
            if let Some(m) = o.max_value {
                j["max_value"] = num(m);
            }
            if o.to_world != Mat4::IDENTITY {
                j["to_world"] = matrix_json(&o.to_world);
            }
            if o.use_grid_bbox {
                j["use_grid_bbox"] = true.into();
            }
            j
        }
    }
}

/// The JSON `media` object, for the file `out`.
pub fn media_json(desc: &SceneDesc, out: &Path) -> Value {
    let mut media = Map::new();
    for d in &desc.media {
        let p = params(d);
        let mut v = json!({
            "type": p.ty,
            "sigma_t": volume_json(desc, &p.sigma_t, out),
            "albedo": volume_json(desc, &p.albedo, out),
        });
        if p.scale != 1.0 {
            v["scale"] = num(p.scale);
        }
        if !is_zero(&p.radiance) {
            v["radiance"] = volume_json(desc, &p.radiance, out);
        }
        if !d.sample_emitters {
            v["sample_emitters"] = false.into();
        }
        if let PhaseFunction::HenyeyGreenstein { g } = p.phase {
            v["phase"] = json!({"type": "hg", "g": num(g)});
        }
        media.insert(d.name.clone(), v);
    }
    Value::Object(media)
}

fn volume_xml(desc: &SceneDesc, name: &str, v: &VolumeDesc, out: &Path, esc: &impl Fn(&str) -> String) -> String {
    let rgb = |c: Vec3| format!("{}, {}, {}", c.x, c.y, c.z);
    let to_world = |m: &Mat4| format!("<transform name=\"to_world\"><matrix value=\"{}\"/></transform>", matrix(m));
    match &v.value {
        // a grey as a float; Mitsuba's RGB variants read a bare <rgb> as a reflectance
        // (refused above 1: a sigma_t of 1.5), a constvolume's <rgb> as it is
        Volume::Constant(c) if c.to_world == Mat4::IDENTITY && c.value == Vec3::splat(c.value.x) => {
            format!("    <float name=\"{name}\" value=\"{}\"/>\n", c.value.x)
        }
        Volume::Constant(c) if c.to_world == Mat4::IDENTITY && c.value.max_element() <= 1.0 => {
            format!("    <rgb name=\"{name}\" value=\"{}\"/>\n", rgb(c.value))
        }
        Volume::Constant(c) => {
            let transform = if c.to_world == Mat4::IDENTITY {
                String::new()
            } else {
                format!("\n      {}", to_world(&c.to_world))
            };
            format!(
                "    <volume type=\"constvolume\" name=\"{name}\">\n      <rgb name=\"value\" value=\"{}\"/>{transform}\n    </volume>\n",
                rgb(c.value),
            )
        }
        Volume::Grid(g) => {
            let o = &g.options;
            let mut s = format!(
                "    <volume type=\"gridvolume\" name=\"{name}\">\n      <string name=\"filename\" value=\"{}\"/>\n",
                esc(&rebase(desc, &g.path.value, out))
            );
            if let Some(grid) = &g.grid {
                s += &format!("      <string name=\"grid\" value=\"{}\"/>\n", esc(grid));
            }
            s += &format!(
                "      <string name=\"filter_type\" value=\"{}\"/>\n      <string name=\"wrap_mode\" value=\"{}\"/>\n",
                o.filter.name(),
                o.wrap.name()
            );
            if let Some(m) = o.max_value {
                s += &format!("      <float name=\"max_value\" value=\"{m}\"/>\n");
            }
            if o.use_grid_bbox {
                s += "      <boolean name=\"use_grid_bbox\" value=\"true\"/>\n";
            }
            if o.to_world != Mat4::IDENTITY {
                s += &format!("      {}\n", to_world(&o.to_world));
            }
            s + "    </volume>\n"
        }
    }
}

/// The media as top-level `<medium id="name">` elements, for the file `out`.
pub fn media_xml(desc: &SceneDesc, out: &Path, esc: impl Fn(&str) -> String) -> String {
    let mut s = String::new();
    for d in &desc.media {
        let p = params(d);
        s += &format!("  <medium type=\"{}\" id=\"{}\">\n", p.ty, esc(&d.name));
        s += &volume_xml(desc, "sigma_t", &p.sigma_t, out, &esc);
        s += &volume_xml(desc, "albedo", &p.albedo, out, &esc);
        if p.scale != 1.0 {
            s += &format!("    <float name=\"scale\" value=\"{}\"/>\n", p.scale);
        }
        if !is_zero(&p.radiance) {
            s += &volume_xml(desc, "radiance", &p.radiance, out, &esc);
        }
        if !d.sample_emitters {
            s += "    <boolean name=\"sample_emitters\" value=\"false\"/>\n";
        }
        if let PhaseFunction::HenyeyGreenstein { g } = p.phase {
            s += &format!("    <phase type=\"hg\">\n      <float name=\"g\" value=\"{g}\"/>\n    </phase>\n");
        }
        s += "  </medium>\n";
    }
    s
}
