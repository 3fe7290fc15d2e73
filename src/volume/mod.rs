//! Volumes: values (a density, an albedo, a radiance) defined over a region of space,
//! what Mitsuba calls its "volume" plugins and what a heterogeneous medium reads.
//! A closed family, used by the media and usable without them:
//!
//! * [`Volume::Constant`] (`constvolume`): one value (a number or an RGB colour)
//!   everywhere; its box is `to_world` of the unit cube, as Mitsuba's.
//! * [`Volume::Grid`] (`gridvolume`, [`GridVolume`]): a voxel grid, 1 or 3 channels, read
//!   from Mitsuba's binary `.vol` format ([`vol_file`]) or an OpenVDB `.vdb` file ([`vdb`]).
//!
//! Every volume maps world space to its unit cube `[0, 1]³` by `to_world⁻¹`;
//! [`MajorantGrid`] bounds a volume from above on a coarse grid of that cube and walks
//! a ray through it (the majorants of delta and ratio tracking).
//!
//! The description layer uses the same enum with the grid still a file
//! (`Volume<desc::GridFile>`); it is loaded when the scene is built.

pub mod grid;
pub mod majorant;
pub mod vdb;
pub mod vol_file;

use crate::geometry::Aabb;
use crate::math::{Mat4, Vec3};
pub use grid::{GridData, GridFilter, GridVolume, WrapMode};
pub use majorant::{MajorantGrid, MajorantIter, MajorantSegment};

/// A volume; `G` is the grid's representation (loaded: [`GridVolume`]).
#[derive(Clone, Debug)]
pub enum Volume<G = GridVolume> {
    Constant(ConstVolume),
    Grid(G),
}

/// `constvolume`: `value` (a number or an RGB colour, Mitsuba's default 1) and
/// `to_world` (which only places its box).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstVolume {
    pub value: Vec3,
    pub to_world: Mat4,
}

impl Volume {
    /// The value at world point `p` (a one-channel grid's value in all three).
    #[inline]
    pub fn eval(&self, p: Vec3) -> [f32; 3] {
        match self {
            Volume::Constant(c) => c.value.to_array(),
            Volume::Grid(g) => g.eval(p),
        }
    }

    /// An upper bound of every channel anywhere: a grid's largest value (or its
    /// `max_value`); a constant's largest channel.
    pub fn max(&self) -> f32 {
        match self {
            Volume::Constant(c) => c.value.max_element(),
            Volume::Grid(g) => g.max(),
        }
    }

    /// The world-space box of the volume's unit cube.
    pub fn world_bounds(&self) -> Aabb {
        unit_cube_bounds(&self.to_local().inverse())
    }

    /// World space to the unit cube.
    pub fn to_local(&self) -> Mat4 {
        match self {
            Volume::Constant(c) => c.to_world.inverse(),
            Volume::Grid(g) => g.to_local(),
        }
    }
}

/// The box of `to_world` applied to the unit cube's corners.
pub fn unit_cube_bounds(to_world: &Mat4) -> Aabb {
    let corners: Vec<Vec3> = (0..8)
        .map(|i| to_world.transform_point3(Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32)))
        .collect();
    Aabb::from_points(&corners)
}

/// `Ok` when `m` is a finite, invertible affine map (what `to_world` must be).
pub fn check_affine(m: &Mat4) -> Result<(), String> {
    let last = m.row(3);
    if !m.is_finite() || last != crate::math::Vec4::new(0.0, 0.0, 0.0, 1.0) {
        return Err("must be a finite affine transform (no projection)".into());
    }
    let det = m.determinant();
    if det == 0.0 || !m.inverse().is_finite() {
        return Err("must be invertible (it collapses the volume's box)".into());
    }
    Ok(())
}
