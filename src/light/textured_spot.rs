//! Mitsuba's `spot` with a `texture`: the spot light's cone (intensity, linear falloff
//! from `beam_width` to `cutoff`) times an image projected over it.
//!
//! In the light's frame (`s`, `t`, axis `n`; Mitsuba's `to_world` x, y, z) a direction
//! `(x, y, z)` reads the texture at Mitsuba's
//! `(½ + ½·x/(z·tan θc), ½ + ½·y/(z·tan θc))`, so the square `[0, 1]²` spans the tangent
//! plane out to the cutoff cone θc (the cone is the square's inscribed circle). rdr's
//! `v` runs the other way from Mitsuba's (its images put `v = 0` at the bottom row,
//! see [`crate::desc::xml`]), so rdr looks up `(u, 1 − v)`: the same texel.
//! The intensity towards a direction is `intensity · texture(uv) · falloff`.

use super::spot_falloff;
use crate::math::{Frame, Vec2, Vec3};
use crate::texture::Texture;

#[derive(Clone, Debug)]
pub struct TexturedSpot {
    pub position: Vec3,
    /// `s`, `t`: the light's local x and y (the image's u and v axes); `n`: its axis.
    pub frame: Frame,
    pub intensity: Vec3,
    /// Half-angles in radians, 0 < beam_width ≤ cutoff < π/2.
    pub cutoff: f32,
    pub beam_width: f32,
    pub texture: Texture,
}

impl TexturedSpot {
    /// The texture coordinates (rdr's orientation) of the local direction `local`.
    #[inline]
    pub fn uv(&self, local: Vec3) -> Vec2 {
        let k = 0.5 / (local.z * self.cutoff.tan());
        Vec2::new(0.5 + local.x * k, 0.5 - local.y * k)
    }

    /// Radiant intensity towards the unit world direction `dir` (away from the light).
    pub fn intensity_towards(&self, dir: Vec3) -> Vec3 {
        self.intensity_local(self.frame.to_local(dir))
    }

    /// Radiant intensity towards the unit local direction `local`.
    pub fn intensity_local(&self, local: Vec3) -> Vec3 {
        let f = spot_falloff(local.z, self.cutoff, self.beam_width);
        if f <= 0.0 {
            return Vec3::ZERO;
        }
        self.intensity * self.texture.eval(self.uv(local)) * f
    }
}
