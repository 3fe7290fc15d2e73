//! JSON `media` (see [`crate::desc::MediumDesc`]) and the camera's `medium`; the volumes
//! of heterogeneous media (Mitsuba's `constvolume` and `gridvolume`, with its names).

use super::super::json::Props;
use crate::desc::{build_heterogeneous, check_max_value, grid_of, GridFile, Located, MediumDesc, MediumVolumes, VolumeDesc};
use crate::error::Result;
use crate::math::{Mat4, Vec3};
use crate::medium::{Homogeneous, Medium, PhaseFunction};
use crate::volume::grid::GridOptions;
use crate::volume::{ConstVolume, GridFilter, Volume, WrapMode};
use std::path::Path;

/// The scene's `media`, by name; grid files are read from `base_dir`.
pub(super) fn parse_media(root: &Props, base_dir: &Path) -> Result<Vec<MediumDesc>> {
    root.named_objects("media")?
        .iter()
        .map(|(n, p)| parse_medium(n, p, base_dir))
        .collect()
}

fn parse_medium(name: &str, p: &Props, base_dir: &Path) -> Result<MediumDesc> {
    let ty = p.string("type")?;
    let scale = p.f32_or("scale", 1.0)?;
    let sample_emitters = p.bool_or("sample_emitters", true)?;
    let phase = match p.object_opt("phase")? {
        None => PhaseFunction::Isotropic,
        Some(q) => parse_phase(&q)?,
    };
    let mut volumes = None;
    let medium = match ty.as_str() {
        "homogeneous" => {
            let sigma_t = colour(p, "sigma_t", 1.0)?;
            let albedo = colour(p, "albedo", 0.75)?;
            let radiance = colour(p, "radiance", 0.0)?;
            let medium = Homogeneous::new(sigma_t, albedo, scale, phase).and_then(|m| m.with_radiance(radiance));
            Medium::Homogeneous(medium.map_err(|(k, e)| p.error(k, e))?)
        }
        "heterogeneous" => {
            let v = MediumVolumes {
                sigma_t: volume(p, "sigma_t", 1.0)?,
                albedo: volume(p, "albedo", 0.75)?,
                radiance: volume(p, "radiance", 0.0)?,
            };
            let medium = build_heterogeneous(&v, scale, phase, &p.ctx().file, base_dir)?;
            volumes = Some(v);
            medium.map_err(|(k, e)| p.error(k, e))?
        }
        other => {
            let msg = format!("unknown medium type '{other}' (available: homogeneous, heterogeneous)");
            return Err(p.error("type", msg));
        }
    };
    p.finish();
    Ok(MediumDesc {
        name: name.to_string(),
        source: p.own_source(),
        medium,
        sample_emitters,
        volumes,
    })
}

/// A heterogeneous medium's volume `key`: a number or RGB triple (a constant), or a
/// `constvolume` or `gridvolume` object; values finite and not negative.
fn volume(p: &Props, key: &str, default: f32) -> Result<VolumeDesc> {
    let constant = |value: Vec3, to_world: Mat4| Volume::Constant(ConstVolume { value, to_world });
    let q = match p.raw(key) {
        Some(v) if v.is_object() => p.object_opt(key)?,
        _ => None,
    };
    let Some(q) = q else {
        let value = colour(p, key, default)?;
        check_constant(p, key, value)?;
        return Ok(p.located(key, constant(value, Mat4::IDENTITY)));
    };
    let ty = q.string("type")?;
    let to_world = q.mat4_or("to_world", Mat4::IDENTITY)?;
    crate::volume::check_affine(&to_world).map_err(|e| q.error("to_world", e))?;
    let value = match ty.as_str() {
        "constvolume" => {
            let value = colour(&q, "value", 1.0)?;
            check_constant(&q, "value", value)?;
            constant(value, to_world)
        }
        "gridvolume" => {
            let filename = q.string("filename")?;
            let use_grid_bbox = q.bool_or("use_grid_bbox", false)?;
            let grid = grid_of(&filename, q.string_opt("grid")?, use_grid_bbox).map_err(|(k, e)| q.error(k, e))?;
            let filter = GridFilter::from_name(&q.string_or("filter_type", "trilinear")?).map_err(|e| q.error("filter_type", e))?;
            let wrap = WrapMode::from_name(&q.string_or("wrap_mode", "clamp")?).map_err(|e| q.error("wrap_mode", e))?;
            let max_value = match q.raw("max_value") {
                None => None,
                Some(_) => Some(q.f32_or("max_value", 0.0)?),
            };
            check_max_value(max_value).map_err(|e| q.error("max_value", e))?;
            Volume::Grid(GridFile {
                path: q.located("filename", filename),
                grid,
                options: GridOptions {
                    filter,
                    wrap,
                    max_value,
                    to_world,
                    use_grid_bbox,
                },
                max_value_source: max_value.map(|_| q.source("max_value")),
            })
        }
        other => {
            return Err(q.error(
                "type",
                format!("unknown volume type '{other}' (available: constvolume, gridvolume)"),
            ))
        }
    };
    q.finish();
    Ok(Located {
        value,
        source: q.own_source(),
    })
}

fn check_constant(p: &Props, key: &str, v: Vec3) -> Result<()> {
    if v.min_element() < 0.0 {
        return Err(p.error(key, format!("{v} must not be negative")));
    }
    Ok(())
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
