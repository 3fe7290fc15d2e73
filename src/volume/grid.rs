//! `gridvolume`: values on a voxel grid, looked up as Mitsuba 3 does (Dr.Jit's 3D
//! texture): voxel `(i, j, k)` sits at the unit-cube point `((i, j, k) + ½) / res`;
//! `trilinear` blends the eight voxels around a point, `nearest` takes the voxel the
//! point falls in; indices outside the grid wrap by [`WrapMode`].

use crate::geometry::Aabb;
use crate::math::{Mat4, Vec3};

/// `filter_type`: `trilinear` (Mitsuba's default) or `nearest`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum GridFilter {
    #[default]
    Trilinear,
    Nearest,
}

/// `wrap_mode`: how voxel indices outside the grid are brought back into it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WrapMode {
    /// The edge voxel (Mitsuba's default).
    #[default]
    Clamp,
    /// The grid tiles space.
    Repeat,
    /// The grid tiles space, every other tile mirrored.
    Mirror,
}

impl GridFilter {
    /// Mitsuba's `filter_type` name.
    pub fn name(self) -> &'static str {
        match self {
            GridFilter::Trilinear => "trilinear",
            GridFilter::Nearest => "nearest",
        }
    }

    /// The filter named `name`; the error lists the names.
    pub fn from_name(name: &str) -> Result<GridFilter, String> {
        [GridFilter::Trilinear, GridFilter::Nearest]
            .into_iter()
            .find(|f| f.name() == name)
            .ok_or_else(|| format!("unknown filter_type \"{name}\" (trilinear, nearest)"))
    }
}

impl WrapMode {
    /// Mitsuba's `wrap_mode` name.
    pub fn name(self) -> &'static str {
        match self {
            WrapMode::Clamp => "clamp",
            WrapMode::Repeat => "repeat",
            WrapMode::Mirror => "mirror",
        }
    }

    /// The wrap mode named `name`; the error lists the names.
    pub fn from_name(name: &str) -> Result<WrapMode, String> {
        [WrapMode::Clamp, WrapMode::Repeat, WrapMode::Mirror]
            .into_iter()
            .find(|w| w.name() == name)
            .ok_or_else(|| format!("unknown wrap_mode \"{name}\" (clamp, repeat, mirror)"))
    }

    /// Index `i` of an axis of `n` voxels, brought into `0..n`.
    #[inline]
    pub fn index(self, i: i64, n: i64) -> usize {
        (match self {
            WrapMode::Clamp => i.clamp(0, n - 1),
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        }) as usize
    }
}

/// A grid as a file holds it: `res` voxels per axis, `channels` (1 or 3) values per
/// voxel stored x fastest, then y, then z; `bbox` the file's box (what
/// `use_grid_bbox` maps to the unit cube).
#[derive(Clone, Debug)]
pub struct GridData {
    pub res: [usize; 3],
    pub channels: usize,
    pub bbox: Aabb,
    pub values: Vec<f32>,
}

impl GridData {
    /// Checks the shape and the values: 1 or 3 channels, as many values as the
    /// resolution asks, every value finite and not negative (a density, albedo or
    /// radiance is neither). The error names the first bad voxel.
    pub fn new(res: [usize; 3], channels: usize, bbox: Aabb, values: Vec<f32>) -> Result<GridData, String> {
        if channels != 1 && channels != 3 {
            return Err(format!("{channels} channels per voxel (rdr reads 1 or 3)"));
        }
        if res.contains(&0) {
            return Err(format!("an empty grid ({}×{}×{} voxels)", res[0], res[1], res[2]));
        }
        let want = res.iter().try_fold(channels, |a, &n| a.checked_mul(n));
        if want != Some(values.len()) {
            return Err(format!(
                "{} values for a {}×{}×{}×{channels} grid",
                values.len(),
                res[0],
                res[1],
                res[2]
            ));
        }
        if let Some(bad) = values.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            let v = bad / channels;
            let (x, y, z) = (v % res[0], (v / res[0]) % res[1], v / (res[0] * res[1]));
            return Err(format!(
                "voxel ({x}, {y}, {z}) holds {} (values must be finite and not negative)",
                values[bad]
            ));
        }
        Ok(GridData {
            res,
            channels,
            bbox,
            values,
        })
    }

    /// The largest value of any channel.
    pub fn max(&self) -> f32 {
        self.values.iter().copied().fold(0.0, f32::max)
    }

    /// The values of voxel `(x, y, z)` (in range), one channel replicated.
    #[inline]
    pub fn voxel(&self, x: usize, y: usize, z: usize) -> [f32; 3] {
        let i = ((z * self.res[1] + y) * self.res[0] + x) * self.channels;
        if self.channels == 1 {
            [self.values[i]; 3]
        } else {
            [self.values[i], self.values[i + 1], self.values[i + 2]]
        }
    }
}

/// How a [`GridData`] is looked up and placed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridOptions {
    pub filter: GridFilter,
    pub wrap: WrapMode,
    /// `max_value`: replaces the grid's largest value as [`GridVolume::max`]; it must not
    /// be below it (a majorant below the density would bias every estimate).
    pub max_value: Option<f32>,
    /// `to_world`: maps the unit cube to world space.
    pub to_world: Mat4,
    /// `use_grid_bbox`: the file's box is mapped to the unit cube first, so `to_world`
    /// places the box the file names.
    pub use_grid_bbox: bool,
}

impl Default for GridOptions {
    fn default() -> Self {
        GridOptions {
            filter: GridFilter::Trilinear,
            wrap: WrapMode::Clamp,
            max_value: None,
            to_world: Mat4::IDENTITY,
            use_grid_bbox: false,
        }
    }
}

/// A grid ready for lookups: world space goes to the unit cube by one precomputed
/// matrix, then to voxel coordinates by the resolution.
#[derive(Clone, Debug)]
pub struct GridVolume {
    data: GridData,
    filter: GridFilter,
    wrap: WrapMode,
    max: f32,
    to_local: Mat4,
    res_f: Vec3,
    res_i: [i64; 3],
}

impl GridVolume {
    /// The error says which option is wrong: it starts with `to_world` or `max_value`.
    pub fn new(data: GridData, opts: GridOptions) -> Result<GridVolume, String> {
        super::check_affine(&opts.to_world).map_err(|e| format!("to_world {e}"))?;
        let mut to_local = opts.to_world.inverse();
        if opts.use_grid_bbox {
            let b = data.bbox;
            if !(b.min.is_finite() && b.max.is_finite() && b.min.cmplt(b.max).all()) {
                return Err(format!(
                    "use_grid_bbox: the grid's box [{}, {}] is empty or not finite",
                    b.min, b.max
                ));
            }
            to_local = Mat4::from_scale(Vec3::ONE / (b.max - b.min)) * Mat4::from_translation(-b.min) * to_local;
        }
        if !to_local.is_finite() {
            return Err("to_world with the grid's box is not invertible".into());
        }
        let grid_max = data.max();
        let max = match opts.max_value {
            None => grid_max,
            Some(m) if m.is_finite() && m >= grid_max => m,
            Some(m) => {
                return Err(format!(
                    "max_value {m} is below the grid's largest value {grid_max} (a majorant must bound the values)"
                ))
            }
        };
        let res_i = data.res.map(|n| n as i64);
        Ok(GridVolume {
            res_f: Vec3::new(data.res[0] as f32, data.res[1] as f32, data.res[2] as f32),
            res_i,
            data,
            filter: opts.filter,
            wrap: opts.wrap,
            max,
            to_local,
        })
    }

    pub fn data(&self) -> &GridData {
        &self.data
    }

    pub fn filter(&self) -> GridFilter {
        self.filter
    }

    pub fn wrap(&self) -> WrapMode {
        self.wrap
    }

    pub fn max(&self) -> f32 {
        self.max
    }

    /// World space to the unit cube.
    pub fn to_local(&self) -> Mat4 {
        self.to_local
    }

    /// The value at world point `p`.
    #[inline]
    pub fn eval(&self, p: Vec3) -> [f32; 3] {
        self.eval_local(self.to_local.transform_point3(p))
    }

    /// The value at unit-cube point `u`.
    #[inline]
    pub fn eval_local(&self, u: Vec3) -> [f32; 3] {
        // far outside the grid every wrap mode is periodic or constant: keep the
        // float-to-int conversion in range (NaN becomes 0)
        let v = (u * self.res_f).clamp(Vec3::splat(-1e9), Vec3::splat(1e9));
        let w = self.wrap;
        let [nx, ny, nz] = self.res_i;
        match self.filter {
            GridFilter::Nearest => {
                let i = v.floor();
                self.data
                    .voxel(w.index(i.x as i64, nx), w.index(i.y as i64, ny), w.index(i.z as i64, nz))
            }
            GridFilter::Trilinear => {
                let c = v - Vec3::splat(0.5);
                let i0 = c.floor();
                let f = c - i0;
                let (ix, iy, iz) = (i0.x as i64, i0.y as i64, i0.z as i64);
                let xs = [w.index(ix, nx), w.index(ix + 1, nx)];
                let ys = [w.index(iy, ny), w.index(iy + 1, ny)];
                let zs = [w.index(iz, nz), w.index(iz + 1, nz)];
                let wx = [1.0 - f.x, f.x];
                let wy = [1.0 - f.y, f.y];
                let wz = [1.0 - f.z, f.z];
                let mut out = [0.0f32; 3];
                for (z, wz) in zs.iter().zip(wz) {
                    for (y, wy) in ys.iter().zip(wy) {
                        for (x, wx) in xs.iter().zip(wx) {
                            let wt = wx * wy * wz;
                            let val = self.data.voxel(*x, *y, *z);
                            for (o, v) in out.iter_mut().zip(val) {
                                *o += wt * v;
                            }
                        }
                    }
                }
                out
            }
        }
    }
}
