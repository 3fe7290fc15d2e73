//! Mitsuba XML scenes (`version="3.x"`, 2.x, and the 0.6 dialect of the course
//! files) read into the same [`SceneDesc`] as the JSON reader gives. The structure
//! (includes, defaults, `$name` parameters, ids, references, aliases, the version
//! upgrade) is [`document`]; values and transforms are [`values`] and [`props`];
//! what each plugin means in rdr, with Mitsuba's defaults, is [`plugins`].
//!
//! ```xml
//! <scene version="3.0.0">
//!   <default name="spp" value="64"/>
//!   <integrator type="path"><integer name="max_depth" value="12"/></integrator>
//!   <sensor type="perspective">
//!     <float name="fov" value="19.5"/> <string name="fov_axis" value="y"/>
//!     <transform name="to_world"><lookat origin="0, 1, 6.8" target="0, 1, 0" up="0, 1, 0"/></transform>
//!     <film type="hdrfilm"><integer name="width" value="256"/><integer name="height" value="256"/></film>
//!     <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
//!   </sensor>
//!   <shape type="obj"><string name="filename" value="box.obj"/><bsdf type="diffuse"/></shape>
//! </scene>
//! ```

mod cie_table;
pub mod dict;
pub mod document;
pub mod plugins;
pub mod props;
pub mod values;

use crate::desc::SceneDesc;
use crate::error::Result;
use std::path::Path;

/// Reads a Mitsuba XML scene; `defines` are the command line's `-D name=value`.
pub fn load(file: &Path, defines: &[(String, String)]) -> Result<SceneDesc> {
    let mut params = document::Params::new(defines);
    let root = document::read(file, &mut params)?;
    let mut desc = plugins::scene(&root, file)?;
    desc.included = std::mem::take(&mut params.included);
    for name in params.unused() {
        desc.warnings
            .push(format!("{}: -D {name}=… is not used by the scene", file.display()));
    }
    Ok(desc)
}

/// Whether a scene file is Mitsuba XML (by its extension).
pub fn is_xml(file: &Path) -> bool {
    file.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}
