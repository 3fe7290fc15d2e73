//! Volumes in the description layer: `Volume<GridFile>`, a `constvolume` as it is and a
//! `gridvolume` as the file it names with its lookup options; [`build_volume`] loads
//! the file into the render-ready [`Volume`]. The Mitsuba reader is
//! `xml/plugins/volume.rs`.

use crate::desc::{Located, Source};
use crate::error::Result;
use crate::medium::{Heterogeneous, Medium, PhaseFunction};
use crate::volume::grid::GridOptions;
use crate::volume::{vdb, vol_file, GridVolume, Volume};
use std::path::Path;

/// A volume as described: where it came from, and the volume with its grid unread.
pub type VolumeDesc = Located<Volume<GridFile>>;

/// `gridvolume`: `filename` (a `.vol` grid; `.vdb` files are OpenVDB) and how it is
/// looked up ([`GridOptions`]: `filter_type`, `wrap_mode`, `max_value`, `to_world`,
/// `use_grid_bbox`).
#[derive(Clone, Debug, PartialEq)]
pub struct GridFile {
    /// As written, relative to the scene's folder (or absolute).
    pub path: Located<String>,
    /// `grid`: the float grid of a `.vdb` file (`density` by default); `None` for `.vol`.
    pub grid: Option<String>,
    pub options: GridOptions,
    /// The key of `max_value` when given, so a value below the grid's largest one is
    /// reported there.
    pub max_value_source: Option<Source>,
}

/// The `grid` of a `gridvolume` reading `filename`: a `.vdb` file's grid by name
/// (`density` when absent), none for a `.vol` file; an error (the key and why) where
/// `grid` or `use_grid_bbox` does not fit the file's kind. Both readers' rule.
pub fn grid_of(
    filename: &str,
    grid: Option<String>,
    use_grid_bbox: bool,
) -> std::result::Result<Option<String>, (&'static str, &'static str)> {
    let vdb = filename.to_ascii_lowercase().ends_with(".vdb");
    if vdb && use_grid_bbox {
        return Err(("use_grid_bbox", "is for .vol grids; a .vdb grid is placed by its own transform"));
    }
    match (vdb, grid) {
        (true, g) => Ok(Some(g.unwrap_or_else(|| "density".into()))),
        (false, None) => Ok(None),
        (false, Some(_)) => Err(("grid", "names a grid of an OpenVDB (.vdb) file; this file is a .vol")),
    }
}

/// Loads a described volume: its grid file is read, checked and placed. Errors name
/// the scene file and the key (`filename` or the option) with the grid file.
pub fn build_volume(desc: &VolumeDesc, scene: &Path, base_dir: &Path) -> Result<Volume> {
    let file = match &desc.value {
        Volume::Constant(c) => return Ok(Volume::Constant(*c)),
        Volume::Grid(f) => f,
    };
    let full = base_dir.join(&file.path.value);
    let named = |e: String| file.path.source.error(scene, format!("filename \"{}\": {e}", full.display()));
    let (data, options) = match &file.grid {
        None => (vol_file::read(&full).map_err(named)?, file.options),
        // the grid's own index-to-world map places it, then `to_world`
        Some(grid) => {
            let g = vdb::read(&full, grid).map_err(named)?;
            let to_world = file.options.to_world * g.to_world;
            (g.data, GridOptions { to_world, ..file.options })
        }
    };
    GridVolume::new(data, options).map(Volume::Grid).map_err(|e| {
        let source = match (&file.max_value_source, e.starts_with("max_value")) {
            (Some(s), true) => s,
            _ => &desc.source,
        };
        source.error(scene, format!("{e} (grid \"{}\")", full.display()))
    })
}

/// A heterogeneous medium from its described volumes (grid files read): a loading error
/// names the scene and the key; a parameter out of range is returned as (key, reason)
/// for the reader to place.
pub fn build_heterogeneous(
    v: &MediumVolumes,
    scale: f32,
    phase: PhaseFunction,
    scene: &Path,
    base_dir: &Path,
) -> Result<std::result::Result<Medium, (&'static str, String)>> {
    let sigma_t = build_volume(&v.sigma_t, scene, base_dir)?;
    let albedo = build_volume(&v.albedo, scene, base_dir)?;
    let radiance = build_volume(&v.radiance, scene, base_dir)?;
    let medium = Heterogeneous::new(sigma_t, albedo, scale, phase).and_then(|m| m.with_radiance(radiance));
    Ok(medium.map(|m| Medium::Heterogeneous(Box::new(m))))
}

/// A heterogeneous medium's `sigma_t`, `albedo` and `radiance` volumes as described.
#[derive(Clone, Debug)]
pub struct MediumVolumes {
    pub sigma_t: VolumeDesc,
    pub albedo: VolumeDesc,
    pub radiance: VolumeDesc,
}

/// A grid's `max_value` as both formats check it: finite and not negative (it may
/// raise the grid's bound, never lower it: checked when the grid is read).
pub fn check_max_value(max_value: Option<f32>) -> std::result::Result<(), &'static str> {
    match max_value {
        Some(m) if !(m.is_finite() && m >= 0.0) => Err("must be a finite number, not negative"),
        _ => Ok(()),
    }
}
