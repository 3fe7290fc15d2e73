//! `<medium>` and `<phase>`: Mitsuba's participating media (read as in Mitsuba 3:
//! `homogeneous` and `heterogeneous` with `sigma_t`, `albedo` and `scale`, their defaults
//! 1, 0.75 and 1, the heterogeneous one's from volumes; `isotropic` and `hg` phase
//! functions, `g` 0.8 by default), and rdr's emissive media (`radiance`, a constant or
//! a volume, as pbrt-v4's `Le`). Grid volumes are loaded as they are read.

use super::table::{differs, noted, read, Param, PluginDoc, Status};
use super::{source, Reader};
use crate::desc::xml::document::Element;
use crate::desc::xml::props::Plugin;
use crate::desc::{build_heterogeneous, Located, MediumDesc, MediumVolumes};
use crate::error::Result;
use crate::math::Vec3;
use crate::medium::{Homogeneous, Medium, PhaseFunction};
use crate::volume::Volume;

impl<'a> Reader<'a> {
    /// Reads a `<medium>` once, however often it is referenced; returns its name.
    pub(super) fn medium(&mut self, el: &'a Element) -> Result<String> {
        if let Some(n) = self.medium_of.get(&(el as *const Element)) {
            return Ok(n.clone());
        }
        let p = Plugin::new(el, self.ids)?;
        if !matches!(p.ty.as_str(), "homogeneous" | "heterogeneous") {
            return Err(p.error(format!("unsupported medium \"{}\" (supported: homogeneous, heterogeneous)", p.ty)));
        }
        let scale = p.float("scale", 1.0)?;
        let phase = phase(&p)?;
        let sample_emitters = p.boolean("sample_emitters", true)?;
        // rdr tracks every channel alike: a grey extinction needs no switch
        p.boolean("has_spectral_extinction", true)?;
        let mut volumes = None;
        let medium = if p.ty == "homogeneous" {
            let sigma_t = self.constant_property(&p, "sigma_t", Vec3::ONE)?;
            let albedo = self.constant_property(&p, "albedo", Vec3::splat(0.75))?;
            let radiance = self.constant_property(&p, "radiance", Vec3::ZERO)?;
            let medium = Homogeneous::new(sigma_t, albedo, scale, phase).and_then(|m| m.with_radiance(radiance));
            Medium::Homogeneous(medium.map_err(|(k, e)| p.value_error(k, e))?)
        } else {
            let sigma_t = self.volume_property(&p, "sigma_t", Vec3::ONE)?;
            let albedo = self.volume_property(&p, "albedo", Vec3::splat(0.75))?;
            let radiance = self.volume_property(&p, "radiance", Vec3::ZERO)?;
            let v = MediumVolumes { sigma_t, albedo, radiance };
            let medium = build_heterogeneous(&v, scale, phase, &self.file, &self.base_dir)?;
            volumes = Some(v);
            medium.map_err(|(k, e)| p.value_error(k, e))?
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
            sample_emitters,
            volumes,
        });
        self.medium_of.insert(el as *const Element, name.clone());
        Ok(name)
    }

    /// A homogeneous medium's property `name`: a constant (a number, a colour or a
    /// `constvolume`); a grid is refused.
    fn constant_property(&mut self, p: &Plugin<'a>, name: &str, default: Vec3) -> Result<Vec3> {
        match self.volume_property(p, name, default)? {
            Located {
                value: Volume::Constant(c),
                ..
            } => Ok(c.value),
            Located { source, .. } => Err(source.error(
                &self.file,
                format!("property \"{name}\" of {}: a grid needs a heterogeneous medium", p.describe()),
            )),
        }
    }
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

const MEDIUM_PARAMS: &[Param] = &[
    read("sigma_t", "colour or volume", "1", "extinction per unit length (before `scale`)"),
    read(
        "albedo",
        "colour or volume",
        "0.75",
        "single-scattering albedo, each channel in [0, 1]",
    ),
    read("scale", "float", "1", "multiplies `sigma_t`"),
    differs(
        "radiance",
        "colour or volume",
        "0",
        "rdr's (pbrt-v4's) emission, which Mitsuba 3.9 does not read: the medium adds σa·Le per unit length",
    ),
    read(
        "sample_emitters",
        "boolean",
        "true",
        "false: no light sample from its scattering points; the phase function's sample finds light",
    ),
    noted(
        "has_spectral_extinction",
        "boolean",
        "read and not needed: every channel is tracked alike",
    ),
];

/// The media's and phase functions' rows of the plugin table.
pub(super) const DOCS: &[PluginDoc] = &[
    PluginDoc {
        element: "medium",
        names: &["homogeneous"],
        status: Status::Read,
        note: "Constant `sigma_t` and `albedo` (numbers, colours or `constvolume`s); rendered by `volpath` and \
               `volpathmis` (see [Media](../media.md)).",
        params: MEDIUM_PARAMS,
    },
    PluginDoc {
        element: "medium",
        names: &["heterogeneous"],
        status: Status::Read,
        note: "`sigma_t` and `albedo` from grid volumes; the medium exists only inside the world box of its \
               `sigma_t` grid.",
        params: MEDIUM_PARAMS,
    },
    PluginDoc {
        element: "phase",
        names: &["isotropic"],
        status: Status::Read,
        note: "The default of a medium without `<phase>`.",
        params: &[],
    },
    PluginDoc {
        element: "phase",
        names: &["hg"],
        status: Status::Read,
        note: "Henyey-Greenstein.",
        params: &[read("g", "float", "0.8", "in (−1, 1)")],
    },
];
