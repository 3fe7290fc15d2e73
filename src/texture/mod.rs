//! Textures (spec §8): a closed family evaluated at texture coordinates.

use crate::math::{Vec2, Vec3};
use crate::scene::desc::UvMappingDesc;

/// `st = scale ⊙ uv + delta`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvMapping {
    pub scale: Vec2,
    pub delta: Vec2,
}

impl UvMapping {
    pub fn new(d: &UvMappingDesc) -> Self {
        UvMapping {
            scale: d.scale,
            delta: d.delta,
        }
    }
    #[inline]
    pub fn map(&self, uv: Vec2) -> Vec2 {
        self.scale * uv + self.delta
    }
}

#[derive(Clone, Debug)]
pub enum Texture {
    Constant(Vec3),
    /// Checks 0.5 wide in `st`; the cells on both sides of 0 merge (spec §8).
    Checkerboard {
        color0: Vec3,
        color1: Vec3,
        mapping: UvMapping,
    },
}

impl Texture {
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checkerboard { color0, color1, mapping } => {
                let st = mapping.map(uv);
                let parity = |v: f32| ((((2.0 * v) as i64) % 2) + 2) % 2;
                if parity(st.x) == parity(st.y) {
                    *color0
                } else {
                    *color1
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkerboard_cells_are_half_wide() {
        let t = Texture::Checkerboard {
            color0: Vec3::ONE,
            color1: Vec3::ZERO,
            mapping: UvMapping {
                scale: Vec2::ONE,
                delta: Vec2::ZERO,
            },
        };
        assert_eq!(t.eval(Vec2::new(0.1, 0.1)), Vec3::ONE);
        assert_eq!(t.eval(Vec2::new(0.6, 0.1)), Vec3::ZERO);
        assert_eq!(t.eval(Vec2::new(0.6, 0.6)), Vec3::ONE);
        assert_eq!(t.eval(Vec2::new(-0.4, 0.1)), Vec3::ONE, "cells around 0 merge");
    }
}
