//! `<medium>` and `<phase>`: Mitsuba's participating media (read as in Mitsuba 3:
//! `homogeneous` with `sigma_t`, `albedo` and `scale`, its defaults 1, 0.75 and 1;
//! `isotropic` and `hg` phase functions, `g` 0.8 by default).

use super::{source, Reader};
use crate::desc::xml::document::Element;
use crate::desc::xml::props::Plugin;
use crate::desc::MediumDesc;
use crate::error::Result;
use crate::math::Vec3;
use crate::medium::{Homogeneous, Medium, PhaseFunction};

impl<'a> Reader<'a> {
    /// Reads a `<medium>` once, however often it is referenced; returns its name.
    pub(super) fn medium(&mut self, el: &'a Element) -> Result<String> {
        if let Some(n) = self.medium_of.get(&(el as *const Element)) {
            return Ok(n.clone());
        }
        let p = Plugin::new(el, self.ids)?;
        let medium = match p.ty.as_str() {
            "homogeneous" => {
                let sigma_t = medium_colour(&p, "sigma_t", Vec3::ONE)?;
                let albedo = medium_colour(&p, "albedo", Vec3::splat(0.75))?;
                let scale = p.float("scale", 1.0)?;
                let phase = phase(&p)?;
                if !p.boolean("sample_emitters", true)? {
                    self.ids
                        .warn(el, "sample_emitters false noted: rdr samples emitters from every medium vertex");
                }
                // rdr tracks every channel alike: a grey extinction needs no switch
                p.boolean("has_spectral_extinction", true)?;
                Medium::Homogeneous(Homogeneous::new(sigma_t, albedo, scale, phase).map_err(|(k, e)| p.value_error(k, e))?)
            }
            "heterogeneous" => return Err(p.error("heterogeneous media (grid volumes) are not supported yet")),
            other => return Err(p.error(format!("unsupported medium \"{other}\" (supported: homogeneous)"))),
        };
        p.finish(&["phase", "volume"])?;
        let wanted = el.attr("id").unwrap_or("medium");
        let name = (0..)
            .map(|i| if i == 0 { wanted.to_string() } else { format!("{wanted}_{i}") })
            .find(|n| self.media.iter().all(|m| &m.name != n))
            .expect("some name is free");
        self.media.push(MediumDesc {
            name: name.clone(),
            source: source(el),
            medium,
        });
        self.medium_of.insert(el as *const Element, name.clone());
        Ok(name)
    }
}

/// A medium's colour `name`: a number, `<rgb>`/`<spectrum>`, or a nested or referenced
/// `<volume type="constvolume">` holding one.
fn medium_colour(p: &Plugin, name: &str, default: Vec3) -> Result<Vec3> {
    for (vol, at) in p.objects("volume") {
        if at.attr("name") != Some(name) {
            continue;
        }
        let vp = Plugin::new(vol, p.ids)?;
        if vp.ty != "constvolume" {
            return Err(at.error(format!(
                "property \"{name}\" of {}: <volume type=\"{}\"> is not supported yet (constvolume is)",
                p.describe(),
                vp.ty
            )));
        }
        let v = vp.rgb("value", Vec3::ONE)?;
        vp.finish(&[])?;
        return Ok(v);
    }
    p.rgb(name, default)
}

/// The medium's `<phase>` (isotropic when absent).
fn phase(p: &Plugin) -> Result<PhaseFunction> {
    let phases = p.objects("phase");
    if let Some((_, second)) = phases.get(1) {
        return Err(second.error("a medium takes one <phase>"));
    }
    let Some((el, _)) = phases.first() else {
        return Ok(PhaseFunction::Isotropic);
    };
    let pp = Plugin::new(el, p.ids)?;
    let phase = match pp.ty.as_str() {
        "isotropic" => PhaseFunction::Isotropic,
        "hg" => PhaseFunction::henyey_greenstein(pp.float("g", 0.8)?).map_err(|e| pp.value_error("g", e))?,
        other => return Err(pp.error(format!("unsupported phase function \"{other}\" (supported: isotropic, hg)"))),
    };
    pp.finish(&[])?;
    Ok(phase)
}
