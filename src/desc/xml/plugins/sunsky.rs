//! `<emitter type="sunsky">`: Mitsuba 3's sun and sky, its rows and its reader.

use super::table::{read, PluginDoc, Status};
use super::{source, Reader};
use crate::desc::xml::props::Plugin;
use crate::desc::{read_sun_position, SunPlacement, SunSkyDesc, SUN_POSITION_KEYS};
use crate::error::Result;
use crate::math::{Mat4, Vec3};

pub(super) const DOCS: &[PluginDoc] = &[PluginDoc {
    element: "emitter",
    names: &["sunsky"],
    status: Status::Read,
    note: "The environment (one per scene): the Hošek–Wilkie sky and sun in RGB, +z up; the sky is evaluated per direction, \
           the sun's disc sampled by its cone.",
    params: &[
        read("turbidity", "float", "3", "in [1, 10]"),
        read("albedo", "colour", "0.3", "ground albedo in [0, 1]; one colour"),
        read(
            "sun_direction",
            "vector",
            "",
            "world direction to the sun; or the place and time below, not both",
        ),
        read("latitude", "float", "35.6894", "degrees"),
        read("longitude", "float", "139.6917", "degrees"),
        read("timezone", "float", "9", "hours"),
        read("year", "integer", "2010", ""),
        read("month", "integer", "7", ""),
        read("day", "integer", "10", ""),
        read("hour", "float", "15", ""),
        read("minute", "float", "0", ""),
        read("second", "float", "0", ""),
        read("sun_scale", "float", "1", ""),
        read("sky_scale", "float", "1", ""),
        read("sun_aperture", "float", "0.5358", "degrees (the sun's power does not change)"),
        read("complex_sun", "boolean", "false", "limb darkening"),
        read("to_world", "transform", "identity", "a rotation"),
    ],
}];

impl<'a> Reader<'a> {
    pub(super) fn sunsky(&mut self, p: &Plugin<'a>) -> Result<SunSkyDesc> {
        let sun = match p.point_opt("sun_direction")? {
            Some(d) => {
                if let Some(k) = SUN_POSITION_KEYS.iter().find(|k| p.has(k)) {
                    return Err(p.value_error(k, "sun_direction and a place or time cannot both be given"));
                }
                SunPlacement::Direction(d)
            }
            None => {
                let int = |k: &str, default: i32| -> Result<i32> {
                    let v = p.integer(k, default as i64)?;
                    i32::try_from(v).map_err(|_| p.value_error(k, "out of range"))
                };
                SunPlacement::At(read_sun_position(|k, d| p.float(k, d), int)?)
            }
        };
        let desc = SunSkyDesc {
            source: source(p.el),
            turbidity: p.float("turbidity", SunSkyDesc::TURBIDITY)?,
            albedo: p.rgb("albedo", Vec3::splat(SunSkyDesc::ALBEDO))?,
            sun,
            sun_scale: p.float("sun_scale", 1.0)?,
            sky_scale: p.float("sky_scale", 1.0)?,
            sun_aperture: p.float("sun_aperture", SunSkyDesc::SUN_APERTURE)?,
            complex_sun: p.boolean("complex_sun", false)?,
            transform: p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY),
        };
        desc.check().map_err(|(key, msg)| p.value_error(key, msg))?;
        p.finish(&[])?;
        Ok(desc)
    }
}
