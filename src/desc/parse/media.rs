//! JSON `media` (see [`crate::desc::MediumDesc`]) and the camera's `medium`.

use super::super::json::Props;
use crate::desc::MediumDesc;
use crate::error::Result;
use crate::math::Vec3;
use crate::medium::{Homogeneous, Medium, PhaseFunction};

/// The scene's `media`, by name.
pub(super) fn parse_media(root: &Props) -> Result<Vec<MediumDesc>> {
    root.named_objects("media")?.iter().map(|(n, p)| parse_medium(n, p)).collect()
}

fn parse_medium(name: &str, p: &Props) -> Result<MediumDesc> {
    let ty = p.string("type")?;
    let medium = match ty.as_str() {
        "homogeneous" => {
            let sigma_t = colour(p, "sigma_t", 1.0)?;
            let albedo = colour(p, "albedo", 0.75)?;
            let scale = p.f32_or("scale", 1.0)?;
            let phase = match p.object_opt("phase")? {
                None => PhaseFunction::Isotropic,
                Some(q) => parse_phase(&q)?,
            };
            Medium::Homogeneous(Homogeneous::new(sigma_t, albedo, scale, phase).map_err(|(k, e)| p.error(k, e))?)
        }
        other => return Err(p.error("type", format!("unknown medium type '{other}' (available: homogeneous)"))),
    };
    p.finish();
    Ok(MediumDesc {
        name: name.to_string(),
        source: p.own_source(),
        medium,
    })
}

fn parse_phase(p: &Props) -> Result<PhaseFunction> {
    let ty = p.string("type")?;
    let phase = match ty.as_str() {
        "isotropic" => PhaseFunction::Isotropic,
        "hg" => PhaseFunction::henyey_greenstein(p.f32_or("g", 0.8)?).map_err(|e| p.error("g", e))?,
        other => return Err(p.error("type", format!("unknown phase function '{other}' (available: isotropic, hg)"))),
    };
    p.finish();
    Ok(phase)
}

/// A number (all channels) or an RGB triple.
fn colour(p: &Props, key: &str, default: f32) -> Result<Vec3> {
    match p.raw(key) {
        Some(v) if v.is_number() => Ok(Vec3::splat(p.f32_or(key, default)?)),
        Some(_) => p.vec3(key),
        None => Ok(Vec3::splat(default)),
    }
}
