//! Feature buffers as output (`rdr render --aov albedo,normal,depth,position`): which
//! layers a render writes, and the film's feature sums averaged into EXR channels or a
//! denoiser's layers. The features themselves come from the camera rays
//! ([`crate::integrator::aov`]).

use super::{AovSums, AOV_VALUES};
use crate::imageio::{ChannelData, ExrChannel};
use crate::math::Vec3;

/// Which feature buffers a render writes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AovSet {
    pub albedo: bool,
    pub normal: bool,
    pub depth: bool,
    pub position: bool,
}

impl AovSet {
    pub const NAMES: &'static str = "albedo, normal, depth, position";

    /// `albedo,normal,depth` (comma-separated names, any order).
    pub fn parse(text: &str) -> Result<AovSet, String> {
        let mut set = AovSet::default();
        for name in text.split(',').map(str::trim) {
            match name {
                "albedo" => set.albedo = true,
                "normal" => set.normal = true,
                "depth" => set.depth = true,
                "position" => set.position = true,
                other => return Err(format!("unknown AOV '{other}' (known: {})", Self::NAMES)),
            }
        }
        Ok(set)
    }

    pub fn any(&self) -> bool {
        self.albedo || self.normal || self.depth || self.position
    }
}

/// The feature layers `set` asks for, averaged from `sums`, as EXR channels
/// (`albedo.R`…, `normal.X`…, `position.X`…, `depth.Z`), rows top-down.
pub fn channels(sums: &AovSums, set: AovSet) -> Vec<ExrChannel> {
    // (wanted, layer, components, first value, averaged over the samples that hit)
    let layers = [
        (set.albedo, "albedo", "RGB", 0, false),
        (set.normal, "normal", "XYZ", 3, false),
        (set.position, "position", "XYZ", 6, true),
        (set.depth, "depth", "Z", 9, true),
    ];
    let mut out = Vec::new();
    for (_, layer, components, first, per_hit) in layers.into_iter().filter(|l| l.0) {
        for (i, c) in components.chars().enumerate() {
            let data = ChannelData::F32(top_down(sums, |s| mean(s, first + i, per_hit)));
            out.push(ExrChannel {
                name: format!("{layer}.{c}"),
                data,
            });
        }
    }
    out
}

/// One feature layer (`albedo`, `normal`; three values a pixel, rows top-down), for
/// a denoiser.
pub fn layer_rgb(sums: &AovSums, first: usize) -> Vec<Vec3> {
    top_down(sums, |s| {
        Vec3::new(mean(s, first, false), mean(s, first + 1, false), mean(s, first + 2, false))
    })
}

/// `value` of every pixel's sums, rows top-down (file row r is film row h − 1 − r).
fn top_down<T>(sums: &AovSums, value: impl Fn(&[f64; AOV_VALUES]) -> T) -> Vec<T> {
    let (w, h) = (sums.width as usize, sums.height as usize);
    (0..w * h).map(|j| value(&sums.sums[(h - 1 - j / w) * w + j % w])).collect()
}

/// Sum `value` over the pixel's samples (`per_hit`: over those whose ray hit something);
/// 0 where there were none.
fn mean(s: &[f64; AOV_VALUES], value: usize, per_hit: bool) -> f32 {
    let n = if per_hit { s[10] } else { s[11] };
    if n > 0.0 {
        (s[value] / n) as f32
    } else {
        0.0
    }
}
