//! `<volume>`: `constvolume` and `gridvolume`, and the volume-valued properties of a
//! medium (`sigma_t`, `albedo`, `radiance`): a number, `<rgb>` or `<spectrum>` there is
//! a `constvolume`, as in Mitsuba 3.

use super::table::{noted, read, Param, PluginDoc, Status};
use super::{source, Reader, VOLUMES};
use crate::desc::xml::document::Element;
use crate::desc::xml::props::{Ids, Plugin};
use crate::desc::{check_max_value, grid_of, GridFile, Located, VolumeDesc};
use crate::error::Result;
use crate::math::{Mat4, Vec3};
use crate::volume::grid::GridOptions;
use crate::volume::{ConstVolume, GridFilter, Volume, WrapMode};
use std::path::Path;

/// Property `name` of the plugin element `plugin` (in the document `root` read from
/// `file`) as a volume, as [`Reader::volume_property`] reads it inside a scene.
pub fn volume_property(root: &Element, plugin: &Element, name: &str, default: Vec3, file: &Path) -> Result<VolumeDesc> {
    let ids = Ids::collect(root)?;
    let mut r = Reader::new(&ids, file);
    let p = Plugin::new(plugin, &ids)?;
    r.volume_property(&p, name, default)
}

impl<'a> Reader<'a> {
    /// Property `name` of `p` as a volume: a nested or referenced `<volume>`, or a
    /// constant (a number, `<rgb>` or `<spectrum>`; `default` when absent). Values must
    /// be finite and not negative; what else a medium requires of them (an albedo of
    /// at most 1) is the medium's to check.
    pub(super) fn volume_property(&mut self, p: &Plugin<'a>, name: &str, default: Vec3) -> Result<VolumeDesc> {
        if let Some((el, at)) = p.object_named(name) {
            if el.tag != "volume" {
                return Err(at.error(format!(
                    "property \"{name}\" of {} must be a <volume> or a constant, found <{}>",
                    p.describe(),
                    el.tag
                )));
            }
            return self.volume(el);
        }
        let value = p.rgb(name, default)?;
        check_constant(value).map_err(|e| p.value_error(name, e))?;
        Ok(Located {
            value: Volume::Constant(ConstVolume {
                value,
                to_world: Mat4::IDENTITY,
            }),
            source: source(p.el),
        })
    }

    /// A `<volume>` element.
    pub(super) fn volume(&mut self, el: &'a Element) -> Result<VolumeDesc> {
        let p = Plugin::new(el, self.ids)?;
        let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        crate::volume::check_affine(&to_world).map_err(|e| p.value_error("to_world", e))?;
        let value = match p.ty.as_str() {
            "constvolume" => {
                let value = p.rgb("value", Vec3::ONE)?;
                check_constant(value).map_err(|e| p.value_error("value", e))?;
                Volume::Constant(ConstVolume { value, to_world })
            }
            "gridvolume" => {
                let path = self.file(el, &p, "filename")?;
                let use_grid_bbox = p.boolean("use_grid_bbox", false)?;
                let grid = grid_of(&path.value, p.string_opt("grid")?, use_grid_bbox).map_err(|(k, e)| p.value_error(k, e))?;
                let filter = GridFilter::from_name(&p.string("filter_type", "trilinear")?).map_err(|e| p.value_error("filter_type", e))?;
                let wrap = WrapMode::from_name(&p.string("wrap_mode", "clamp")?).map_err(|e| p.value_error("wrap_mode", e))?;
                let max_value = p.float_opt("max_value")?;
                check_max_value(max_value).map_err(|e| p.value_error("max_value", e))?;
                // Mitsuba's spectral upsampling switch: rdr renders RGB, nothing to switch
                p.ignore("raw");
                let max_value_source = p.value_source("max_value");
                Volume::Grid(GridFile {
                    path,
                    grid,
                    options: GridOptions {
                        filter,
                        wrap,
                        max_value,
                        to_world,
                        use_grid_bbox,
                    },
                    max_value_source,
                })
            }
            other => return Err(p.error(format!("unsupported volume \"{other}\" (supported: {VOLUMES})"))),
        };
        p.finish(&[])?;
        Ok(Located { value, source: source(el) })
    }
}

fn check_constant(v: Vec3) -> std::result::Result<(), String> {
    if !v.is_finite() || v.min_element() < 0.0 {
        return Err(format!("{v} must be finite and not negative"));
    }
    Ok(())
}

/// The volumes' rows of the plugin table.
pub(super) const DOCS: &[PluginDoc] = &[
    PluginDoc {
        element: "volume",
        names: &["constvolume"],
        status: Status::Read,
        note: "A number, `<rgb>` or `<spectrum>` where a volume is expected is a `constvolume` too.",
        params: &[read("value", "colour", "1", "finite, not negative"), TO_WORLD],
    },
    PluginDoc {
        element: "volume",
        names: &["gridvolume"],
        status: Status::Differs,
        note: "Mitsuba's binary `.vol` (float32, 1 or 3 channels), and OpenVDB `.vdb` files (uncompressed or zlib \
               float and half grids, placed by the grid's own transform, then `to_world`), which Mitsuba 3 does not read.",
        params: &[
            read("filename", "string", "", "required: a `.vol` or `.vdb` file"),
            read("grid", "string", "", "a `.vdb` file's grid by name (`density` when absent)"),
            read(
                "filter_type",
                "string",
                "trilinear",
                "`trilinear` or `nearest`; values at voxel centres",
            ),
            read("wrap_mode", "string", "clamp", "`clamp`, `repeat` or `mirror`"),
            read(
                "use_grid_bbox",
                "boolean",
                "false",
                "the `.vol` file's box mapped to the unit cube first",
            ),
            read(
                "max_value",
                "float",
                "",
                "the majorant's bound: may raise the grid's maximum, never lower it",
            ),
            noted("raw", "boolean", "ignored: rdr renders RGB, nothing to upsample"),
            TO_WORLD,
        ],
    },
];

const TO_WORLD: Param = read("to_world", "transform", "", "maps the unit cube");
