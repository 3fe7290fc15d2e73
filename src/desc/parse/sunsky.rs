//! `sunsky` (Mitsuba 3's sun and sky): its keys are Mitsuba's parameters, `transform`
//! for `to_world`.

use crate::desc::json::Props;
use crate::desc::{read_sun_position, SunPlacement, SunSkyDesc, SUN_POSITION_KEYS};
use crate::error::Result;
use crate::math::{Mat4, Vec3};

pub(super) fn parse_sunsky(p: &Props) -> Result<SunSkyDesc> {
    let sun = if p.contains("sun_direction") {
        if let Some(k) = SUN_POSITION_KEYS.iter().find(|k| p.contains(k)) {
            return Err(p.error(k, "sun_direction and a place or time cannot both be given"));
        }
        SunPlacement::Direction(p.vec3("sun_direction")?)
    } else {
        SunPlacement::At(read_sun_position(|k, d| p.f32_or(k, d), |k, d| p.i32_or(k, d))?)
    };
    let desc = SunSkyDesc {
        source: p.own_source(),
        turbidity: p.f32_or("turbidity", SunSkyDesc::TURBIDITY)?,
        albedo: p.vec3_or("albedo", Vec3::splat(SunSkyDesc::ALBEDO))?,
        sun,
        sun_scale: p.f32_or("sun_scale", 1.0)?,
        sky_scale: p.f32_or("sky_scale", 1.0)?,
        sun_aperture: p.f32_or("sun_aperture", SunSkyDesc::SUN_APERTURE)?,
        complex_sun: p.bool_or("complex_sun", false)?,
        transform: p.mat4_or("transform", Mat4::IDENTITY)?,
    };
    desc.check().map_err(|(key, msg)| p.error(key, msg))?;
    p.finish();
    Ok(desc)
}
