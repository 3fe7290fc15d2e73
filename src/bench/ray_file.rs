//! `--ray-file`: rays read from a file, so rdr and another tracer (Embree through
//! `shared/tools/embree_rays.py`) time exactly the same rays.
//!
//! Format: raw little-endian `f32`, six per ray (origin xyz, unit direction xyz),
//! traced from t = 0 to +∞. The distances file beside it (`X.rays.f32` → `X.t.f32`)
//! holds one little-endian `f32` per ray, the other tracer's closest-hit distance
//! (+∞ for a miss).

use crate::geometry::Ray;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// Allowed relative difference of a closest-hit distance from the file's.
pub const T_TOLERANCE: f32 = 1e-5;
/// Allowed fraction of rays that hit in one tracer and miss in the other (Embree
/// runs without its robust mode, so rays through edges and vertices may differ).
pub const HIT_MISS_FRACTION: f64 = 1e-4;

/// Reads a ray file; every value finite, every direction of unit length (±1e-3).
pub fn read_rays(path: &Path) -> Result<Vec<Ray>> {
    let bytes = crate::limits::read_input_file(path, crate::limits::max_input_file())
        .with_context(|| format!("cannot read ray file '{}'", path.display()))?;
    parse_rays(&bytes, path)
}

/// [`read_rays`] on the bytes of the file `path` (named in the errors).
pub fn parse_rays(bytes: &[u8], path: &Path) -> Result<Vec<Ray>> {
    if bytes.is_empty() || !bytes.len().is_multiple_of(24) {
        bail!(
            "ray file '{}': {} bytes is not a positive multiple of 24 (6 little-endian f32 a ray)",
            path.display(),
            bytes.len()
        );
    }
    let f: Vec<f32> = floats(bytes);
    f.chunks_exact(6)
        .enumerate()
        .map(|(i, r)| {
            if let Some(v) = r.iter().find(|v| !v.is_finite()) {
                bail!("ray file '{}': ray {i} has a non-finite value {v}", path.display());
            }
            let (o, d) = (crate::math::Vec3::new(r[0], r[1], r[2]), crate::math::Vec3::new(r[3], r[4], r[5]));
            if (d.length() - 1.0).abs() > 1e-3 {
                bail!(
                    "ray file '{}': ray {i} has a direction of length {} (must be a unit vector)",
                    path.display(),
                    d.length()
                );
            }
            Ok(Ray::with_range(o, d, 0.0, f32::INFINITY))
        })
        .collect()
}

fn floats(bytes: &[u8]) -> Vec<f32> {
    bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

/// The distances file beside a ray file (`.rays.f32` → `.t.f32`), if the name has that form.
pub fn distances_path(rays: &Path) -> Option<PathBuf> {
    let name = rays.file_name()?.to_str()?;
    let stem = name.strip_suffix(".rays.f32")?;
    Some(rays.with_file_name(format!("{stem}.t.f32")))
}

/// Reads `n` distances (+∞ = miss; no NaN, nothing negative).
pub fn read_distances(path: &Path, n: usize) -> Result<Vec<f32>> {
    let bytes = crate::limits::read_input_file(path, crate::limits::max_input_file())
        .with_context(|| format!("cannot read distances file '{}'", path.display()))?;
    if bytes.len() != n * 4 {
        bail!(
            "distances file '{}': {} bytes, but its ray file has {n} rays ({} bytes expected)",
            path.display(),
            bytes.len(),
            n * 4
        );
    }
    let t = floats(&bytes);
    if let Some(i) = t.iter().position(|t| t.is_nan() || *t < 0.0) {
        bail!("distances file '{}': value {i} is {} (must be ≥ 0 or +inf)", path.display(), t[i]);
    }
    Ok(t)
}

/// How our closest-hit distances compare with the file's.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct Agreement {
    /// Rays one tracer hits and the other misses.
    pub hit_miss: usize,
    /// Rays both hit whose distances differ by more than [`T_TOLERANCE`] relative.
    pub distance: usize,
}

impl Agreement {
    pub fn compare(ours: &[f32], theirs: &[f32]) -> Agreement {
        let mut a = Agreement::default();
        for (&x, &y) in ours.iter().zip(theirs) {
            match (x.is_finite(), y.is_finite()) {
                (true, true) => {
                    if (x - y).abs() > T_TOLERANCE * y.abs().max(x.abs()) {
                        a.distance += 1;
                    }
                }
                (false, false) => {}
                _ => a.hit_miss += 1,
            }
        }
        a
    }

    /// Within the limits: hit/miss disagreements at most [`HIT_MISS_FRACTION`] of the
    /// rays, and as many distance disagreements at most.
    pub fn ok(&self, rays: usize) -> bool {
        let limit = (HIT_MISS_FRACTION * rays as f64).floor() as usize;
        self.hit_miss <= limit && self.distance <= limit
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_sit_beside_the_rays() {
        assert_eq!(
            distances_path(Path::new("/a/bunny_primary.rays.f32")),
            Some(PathBuf::from("/a/bunny_primary.t.f32"))
        );
        assert_eq!(distances_path(Path::new("/a/rays.bin")), None);
    }

    #[test]
    fn agreement_counts_both_kinds() {
        let inf = f32::INFINITY;
        let a = Agreement::compare(&[1.0, 2.0, inf, 3.0, inf], &[1.0 + 1e-7, 2.001, inf, inf, 4.0]);
        assert_eq!(a, Agreement { hit_miss: 2, distance: 1 });
        assert!(!a.ok(10_000));
        assert!(a.ok(20_000));
    }
}
