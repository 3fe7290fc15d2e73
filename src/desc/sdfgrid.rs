//! The `sdfgrid` shape in the description layer: the grid file it names with its
//! placement and normals ([`SdfGridFile`]); [`load_sdf_grid`] reads and checks the
//! file into the render-ready [`SdfGrid`]. Both readers (JSON `parse/`, Mitsuba
//! `xml/plugins/shapes.rs`) make an [`SdfGridFile`].

use crate::desc::Located;
use crate::error::Result;
use crate::geometry::sdfgrid::{SdfGrid, SdfNormals};
use crate::math::Mat4;
use crate::volume::vol_file;
use std::path::Path;

/// `sdfgrid` as described: `filename` (a one-channel `.vol` grid, relative to the
/// scene's folder or absolute), `transform` (the unit cube to the world, affine and
/// invertible) and `normals`.
///
/// ```json
/// {"type": "sdfgrid", "filename": "showcase/torus.vol", "normals": "smooth", "material_name": "white"}
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct SdfGridFile {
    pub path: Located<String>,
    pub transform: Mat4,
    pub normals: SdfNormals,
}

/// Reads the grid of `file` (the scene file `scene`, its folder `base_dir`): errors
/// name the scene, the key (`filename`) and the grid file, in one line.
pub fn load_sdf_grid(file: &SdfGridFile, scene: &Path, base_dir: &Path) -> Result<SdfGrid> {
    let full = base_dir.join(&file.path.value);
    let named = |e: String| file.path.source.error(scene, format!("filename \"{}\": {e}", full.display()));
    let vol = vol_file::read_file(&full).map_err(named)?;
    if vol.channels != 1 {
        return Err(named(format!("{} channels per sample (an sdfgrid reads 1)", vol.channels)));
    }
    SdfGrid::new(vol.res, vol.values, file.transform, file.normals).map_err(named)
}
