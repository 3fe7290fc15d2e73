//! A coarse grid of upper bounds over a volume's unit cube, and the walk of a ray
//! through it (pbrt-v4's majorant grid and DDA iterator): delta and ratio tracking
//! sample against the bound of the cell they are in, not the volume's global maximum.

use super::{GridFilter, Volume};
use crate::math::{Mat4, Vec3};

/// pbrt-v4's resolution of a grid medium's majorant grid.
pub const DEFAULT_RES: [usize; 3] = [16, 16, 16];

/// How far (in voxels) a cell's footprint reaches past its exact bounds, so that a
/// point the ray walk puts in one cell by rounding, though it is a hair inside the
/// next, is still bounded.
const FOOTPRINT_SLACK: f32 = 0.01;

/// Per-cell maxima over the unit cube of a volume.
#[derive(Clone, Debug)]
pub struct MajorantGrid {
    res: [usize; 3],
    max: Vec<f32>,
    to_local: Mat4,
}

/// A piece `[t0, t1]` of a ray with the bound of the volume along it (the medium
/// multiplies it by its own scale).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MajorantSegment {
    pub t0: f32,
    pub t1: f32,
    pub scale: f32,
}

impl MajorantGrid {
    /// The bounds of `volume` on a `res` grid. A grid volume's cell holds the largest
    /// value of every voxel the lookups inside the cell read: with trilinear filtering
    /// the voxels whose centres are within one voxel of the cell (wrapped as the
    /// lookups wrap them). A constant volume has one cell.
    pub fn new(volume: &Volume, res: [usize; 3]) -> MajorantGrid {
        let Volume::Grid(g) = volume else {
            return MajorantGrid {
                res: [1, 1, 1],
                max: vec![volume.max()],
                to_local: volume.to_local(),
            };
        };
        let res = res.map(|n| n.max(1));
        let data = g.data();
        // the voxel index range an axis's cell `c` reads
        let span = |axis: usize, c: usize| -> (i64, i64) {
            let n = data.res[axis] as f32;
            let (a, b) = (c as f32 / res[axis] as f32 * n, (c + 1) as f32 / res[axis] as f32 * n);
            match g.filter() {
                GridFilter::Trilinear => (
                    (a - 0.5 - FOOTPRINT_SLACK).floor() as i64,
                    (b - 0.5 + FOOTPRINT_SLACK).floor() as i64 + 1,
                ),
                GridFilter::Nearest => ((a - FOOTPRINT_SLACK).floor() as i64, (b + FOOTPRINT_SLACK).floor() as i64),
            }
        };
        let spans: Vec<Vec<(i64, i64)>> = (0..3).map(|a| (0..res[a]).map(|c| span(a, c)).collect()).collect();
        let n = data.res.map(|n| n as i64);
        let wrap = g.wrap();
        let mut max = vec![0.0f32; res[0] * res[1] * res[2]];
        for cz in 0..res[2] {
            for cy in 0..res[1] {
                for cx in 0..res[0] {
                    let mut m = 0.0f32;
                    let ((x0, x1), (y0, y1), (z0, z1)) = (spans[0][cx], spans[1][cy], spans[2][cz]);
                    // clamping repeats the edge voxels: visit each once
                    let range = |lo: i64, hi: i64, n: i64| if hi - lo + 1 >= n { (0, n - 1) } else { (lo, hi) };
                    let (x0, x1) = if wrap == super::WrapMode::Clamp {
                        (x0.max(0), x1.min(n[0] - 1))
                    } else {
                        range(x0, x1, n[0])
                    };
                    let (y0, y1) = if wrap == super::WrapMode::Clamp {
                        (y0.max(0), y1.min(n[1] - 1))
                    } else {
                        range(y0, y1, n[1])
                    };
                    let (z0, z1) = if wrap == super::WrapMode::Clamp {
                        (z0.max(0), z1.min(n[2] - 1))
                    } else {
                        range(z0, z1, n[2])
                    };
                    for z in z0..=z1 {
                        for y in y0..=y1 {
                            for x in x0..=x1 {
                                let v = data.voxel(wrap.index(x, n[0]), wrap.index(y, n[1]), wrap.index(z, n[2]));
                                m = m.max(v[0]).max(v[1]).max(v[2]);
                            }
                        }
                    }
                    max[(cz * res[1] + cy) * res[0] + cx] = m;
                }
            }
        }
        MajorantGrid {
            res,
            max,
            to_local: g.to_local(),
        }
    }

    /// The largest cell bound.
    pub fn max(&self) -> f32 {
        self.max.iter().fold(0.0, |m, &v| m.max(v))
    }

    /// A bound on the length, in world units, of a ray's piece inside one cell: the
    /// sum of a cell's three edges.
    pub fn cell_reach(&self) -> f32 {
        let to_world = self.to_local.inverse();
        let edge = |axis: Vec3, n: usize| to_world.transform_vector3(axis).length() / n as f32;
        edge(Vec3::X, self.res[0]) + edge(Vec3::Y, self.res[1]) + edge(Vec3::Z, self.res[2])
    }

    pub fn res(&self) -> [usize; 3] {
        self.res
    }

    /// The bound of cell `(x, y, z)`.
    pub fn cell(&self, x: usize, y: usize, z: usize) -> f32 {
        self.max[(z * self.res[1] + y) * self.res[0] + x]
    }

    /// The segments of the world-space ray `o + t·d`, `t ∈ [t_min, t_max]`, inside the
    /// volume's box, in order, each with its cell's bound. `d` need not be normalised:
    /// the `t` are the ray's own.
    pub fn iter(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> MajorantIter<'_> {
        let o = self.to_local.transform_point3(o);
        let d = self.to_local.transform_vector3(d);
        let mut it = MajorantIter {
            grid: self,
            t: 0.0,
            t_end: -1.0,
            cell: [0; 3],
            next_t: [f32::INFINITY; 3],
            delta_t: [0.0; 3],
            step: [0; 3],
        };
        // clip to the unit cube
        let (mut t0, mut t1) = (t_min, t_max);
        for a in 0..3 {
            if d[a] == 0.0 {
                if !(0.0..=1.0).contains(&o[a]) {
                    return it;
                }
                continue;
            }
            let (mut ta, mut tb) = ((0.0 - o[a]) / d[a], (1.0 - o[a]) / d[a]);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
        }
        // NaN bounds give an empty walk too
        if t0.partial_cmp(&t1) != Some(std::cmp::Ordering::Less) {
            return it;
        }
        let p = o + d * t0;
        for a in 0..3 {
            let n = self.res[a] as f32;
            let c = ((p[a] * n) as i64).clamp(0, self.res[a] as i64 - 1);
            it.cell[a] = c;
            if d[a] == 0.0 {
                continue;
            }
            let forward = d[a] > 0.0;
            let edge = if forward { c + 1 } else { c } as f32 / n;
            it.next_t[a] = t0 + (edge - p[a]) / d[a];
            it.delta_t[a] = 1.0 / (n * d[a].abs());
            it.step[a] = if forward { 1 } else { -1 };
        }
        it.t = t0;
        it.t_end = t1;
        it
    }
}

/// The walk of [`MajorantGrid::iter`]: a 3D DDA through the cells.
#[derive(Clone, Debug)]
pub struct MajorantIter<'a> {
    grid: &'a MajorantGrid,
    t: f32,
    t_end: f32,
    cell: [i64; 3],
    next_t: [f32; 3],
    delta_t: [f32; 3],
    step: [i64; 3],
}

impl Iterator for MajorantIter<'_> {
    type Item = MajorantSegment;

    fn next(&mut self) -> Option<MajorantSegment> {
        if self.t.partial_cmp(&self.t_end) != Some(std::cmp::Ordering::Less) {
            return None;
        }
        let a = if self.next_t[0] < self.next_t[1] {
            if self.next_t[0] < self.next_t[2] {
                0
            } else {
                2
            }
        } else if self.next_t[1] < self.next_t[2] {
            1
        } else {
            2
        };
        let [x, y, z] = self.cell.map(|c| c as usize);
        let t1 = self.next_t[a].min(self.t_end).max(self.t);
        let seg = MajorantSegment {
            t0: self.t,
            t1,
            scale: self.grid.cell(x, y, z),
        };
        self.t = t1;
        self.cell[a] += self.step[a];
        self.next_t[a] += self.delta_t[a];
        if self.step[a] != 0 && !(0..self.grid.res[a] as i64).contains(&self.cell[a]) {
            self.t_end = self.t; // left the grid
        }
        Some(seg)
    }
}
