//! Render objects made from description parameters and checked (cylinders, delta
//! lights, a sphere's frame): what the JSON and the XML readers share.

use crate::math::{Mat4, Vec3};
use crate::texture::Texture;

/// A cylinder from Mitsuba's parameters, checked: the segment `p0`–`p1` and `radius`
/// placed by `to_world`, which must keep it a circular cylinder (rotation,
/// translation, a scale uniform across the axis, no mirroring). `Err((key, why))`.
pub fn cylinder_shape(
    p0: Vec3,
    p1: Vec3,
    radius: f32,
    flip_normals: bool,
    to_world: &Mat4,
) -> std::result::Result<crate::geometry::cylinder::CylinderShape, (&'static str, String)> {
    use crate::geometry::cylinder::{mitsuba_frame, Cylinder, CylinderShape};
    if !(radius > 0.0 && radius <= crate::limits::MAX_COORD) {
        return Err(("radius", format!("must be positive, found {radius}")));
    }
    let axis = p1 - p0;
    if axis.length() <= 0.0 || axis.is_nan() {
        return Err(("p1", "must differ from p0".into()));
    }
    let (x, y) = mitsuba_frame(axis.normalize());
    let (wp0, wp1) = (to_world.transform_point3(p0), to_world.transform_point3(p1));
    let (wx, wy, wa) = (
        to_world.transform_vector3(x * radius),
        to_world.transform_vector3(y * radius),
        wp1 - wp0,
    );
    let r = wx.length();
    let (ux, uy, ua) = (wx / r, wy / wy.length(), wa / wa.length());
    let skew = ux.dot(uy).abs() + ux.dot(ua).abs() + uy.dot(ua).abs();
    if !(r.is_finite() && (wy.length() - r).abs() <= 1e-4 * r && skew < 1e-4 && wa.length().is_finite()) {
        return Err((
            "transform",
            "a cylinder's transform must be a rotation, translation and a scale uniform across its axis".into(),
        ));
    }
    if ux.cross(uy).dot(ua) < 0.0 {
        return Err(("transform", "a cylinder's transform must not mirror".into()));
    }
    for v in [wp0, wp1] {
        if v.abs().max_element() > crate::limits::MAX_COORD || r > crate::limits::MAX_COORD {
            return Err((
                "transform",
                format!(
                    "the cylinder is out of range (coordinates must be within ±{:e})",
                    crate::limits::MAX_COORD
                ),
            ));
        }
    }
    Ok(CylinderShape {
        cylinder: Cylinder {
            p0: wp0,
            axis: wa,
            x: ux,
            radius: r,
        },
        flip_normals,
    })
}

/// The frame of a light at the origin of Mitsuba's `lookat` along `axis` with `up`:
/// `s = up × n` (its x, the camera's left), `t = n × s`, `n` the unit axis.
pub fn light_frame(axis: Vec3, up: Vec3) -> std::result::Result<crate::math::Frame, String> {
    let n = axis.normalize_or_zero();
    let s = up.cross(n).normalize_or_zero();
    if n == Vec3::ZERO || s == Vec3::ZERO || !n.is_finite() || !s.is_finite() {
        return Err("the light's direction is degenerate or parallel to its up vector".into());
    }
    Ok(crate::math::Frame { s, t: n.cross(s), n })
}

/// A spot light with a texture (its constant placeholder): a checked [`spot_light`]
/// in `frame`; the texture's square spans the cutoff cone, so the cutoff is below 90°.
pub fn textured_spot(
    position: Vec3,
    frame: crate::math::Frame,
    intensity: Vec3,
    cutoff_deg: f32,
    beam_deg: Option<f32>,
) -> std::result::Result<crate::light::Light, String> {
    let crate::light::Light::Spot { cutoff, beam_width, .. } = spot_light(position, frame.n, intensity, cutoff_deg, beam_deg)? else {
        unreachable!("spot_light makes spots")
    };
    if cutoff_deg >= 90.0 {
        return Err(format!("cutoff_angle must be below 90 degrees with a texture, found {cutoff_deg}"));
    }
    Ok(crate::light::Light::TexturedSpot(crate::light::TexturedSpot {
        position,
        frame,
        intensity,
        cutoff,
        beam_width,
        texture: Texture::Constant(Vec3::ONE),
    }))
}

/// A projector (constant placeholder image), checked: `fov_deg` in (0, 180), `scale` ≥ 0.
pub fn projector_light(
    position: Vec3,
    frame: crate::math::Frame,
    scale: f32,
    fov_deg: f32,
    axis: crate::light::projector::FovAxis,
) -> std::result::Result<crate::light::Light, String> {
    if !(fov_deg > 0.0 && fov_deg < 180.0) {
        return Err(format!("fov must be between 0 and 180 degrees, found {fov_deg}"));
    }
    if !(scale >= 0.0 && scale.is_finite()) {
        return Err(format!("scale must not be negative, found {scale}"));
    }
    Ok(crate::light::Light::Projector(crate::light::Projector::new(
        position,
        frame,
        scale,
        fov_deg.to_radians(),
        axis,
    )))
}

/// Mitsuba's default field of view: a 50 mm lens on a 35 mm film's diagonal, degrees.
pub fn default_fov_deg() -> f32 {
    2.0 * (36f32.hypot(24.0) / 100.0).atan().to_degrees()
}

/// A spot light from Mitsuba's parameters (angles in degrees), checked.
pub fn spot_light(
    position: Vec3,
    axis: Vec3,
    intensity: Vec3,
    cutoff_deg: f32,
    beam_deg: Option<f32>,
) -> std::result::Result<crate::light::Light, String> {
    if !(cutoff_deg > 0.0 && cutoff_deg <= 180.0) {
        return Err(format!("cutoff_angle must be in (0, 180] degrees, found {cutoff_deg}"));
    }
    let beam_deg = beam_deg.unwrap_or(cutoff_deg * 0.75);
    if !(beam_deg > 0.0 && beam_deg <= cutoff_deg) {
        return Err(format!("beam_width must be in (0, cutoff_angle] degrees, found {beam_deg}"));
    }
    if !(intensity.min_element() >= 0.0 && intensity.is_finite()) {
        return Err("intensity must not be negative".into());
    }
    let axis = axis.normalize_or_zero();
    if axis == Vec3::ZERO || !axis.is_finite() {
        return Err("the spot light's direction is degenerate".into());
    }
    Ok(crate::light::Light::Spot {
        position,
        axis,
        intensity,
        cutoff: cutoff_deg.to_radians(),
        beam_width: beam_deg.to_radians(),
    })
}

/// A directional light travelling along `direction`, checked.
pub fn directional_light(direction: Vec3, irradiance: Vec3) -> std::result::Result<crate::light::Light, String> {
    if !(irradiance.min_element() >= 0.0 && irradiance.is_finite()) {
        return Err("irradiance must not be negative".into());
    }
    let direction = direction.normalize_or_zero();
    if direction == Vec3::ZERO || !direction.is_finite() {
        return Err("the direction must not be zero".into());
    }
    Ok(crate::light::Light::Directional { direction, irradiance })
}

/// The unit quaternion (x y z w) of `m` when it is a rotation (orthonormal columns
/// within 1e-4, determinant +1); a sphere's `uv_frame`.
pub fn rotation_quat(m: &glam::Mat3) -> Option<[f32; 4]> {
    let (x, y, z) = (m.x_axis, m.y_axis, m.z_axis);
    let ok = [x, y, z].iter().all(|a| (a.length() - 1.0).abs() < 1e-4)
        && x.dot(y).abs() + y.dot(z).abs() + x.dot(z).abs() < 1e-4
        && m.determinant() > 0.0;
    ok.then(|| glam::Quat::from_mat3(m).normalize().to_array())
}
