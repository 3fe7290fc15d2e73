//! Multiple importance sampling over the strategies of one path (Veach 1997 §10.2).
//!
//! A path of n vertices x₀ (on a light) … x_{n−1} (the camera) is made by strategy
//! s (s light vertices, t = n − s camera vertices) with density
//! P_s = Π_{i<s} p_L(x_i) · Π_{i≥s} p_E(x_i), where p_L is the density of x_i when
//! the light subpath samples it and p_E when the camera subpath does. Strategy s
//! is possible unless one of its two connection vertices x_{s−1}, x_s is specular
//! (or, for s = 0, the light has a delta position). Ratios P_j/P_s telescope over
//! the vertices between, so a weight costs O(n); delta vertices carry density 0,
//! read as 1 (their Dirac factors cancel in every ratio).

/// How strategies are weighted against each other.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Heuristic {
    /// w_s = P_s² / Σ_j P_j² (the default).
    #[default]
    Power,
    /// w_s = P_s / Σ_j P_j.
    Balance,
}

/// The densities of a whole path, index 0 at the light.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PathDensities {
    /// p_L: density of each vertex sampled from the light side.
    pub light: Vec<f32>,
    /// p_E: density of each vertex sampled from the camera side.
    pub camera: Vec<f32>,
    /// Specular vertices.
    pub delta: Vec<bool>,
    /// x₀ is a delta light: point, spot or directional (no camera subpath can hit it).
    pub delta_light: bool,
}

impl PathDensities {
    pub fn push(&mut self, p_light: f32, p_camera: f32, delta: bool) {
        self.light.push(p_light);
        self.camera.push(p_camera);
        self.delta.push(delta);
    }

    /// Whether strategy `s` can produce this path. Paths of one segment are
    /// left to s = 0 (the emitter seen directly) alone.
    pub fn possible(&self, s: usize) -> bool {
        let n = self.light.len();
        if n == 2 {
            return s == 0 && !self.delta_light;
        }
        let delta = |i: usize| self.delta[i];
        s < n && possible_of(s, self.delta_light, delta)
    }

    /// The MIS weight of strategy `s` for this path.
    pub fn weight(&self, s: usize, heuristic: Heuristic) -> f32 {
        weight_of(self.light.len(), s, self.delta_light, heuristic, |i| {
            (self.light[i], self.camera[i], self.delta[i])
        })
    }
}

/// Whether strategy `s` (< n, of a path of more than two vertices) is possible,
/// `delta(i)` telling the specular vertices.
#[inline(always)]
fn possible_of(s: usize, delta_light: bool, delta: impl Fn(usize) -> bool) -> bool {
    !delta(s) && if s == 0 { !delta_light } else { !delta(s - 1) }
}

/// The MIS weight of strategy `s` for a path of `n` vertices whose vertex `i` has
/// the densities `at(i)` = (p_L, p_E, specular): the one computation behind
/// [`PathDensities::weight`] and the integrator's connections, which read their
/// densities from the subpaths in place.
#[inline(always)]
pub fn weight_of(n: usize, s: usize, delta_light: bool, heuristic: Heuristic, at: impl Fn(usize) -> (f32, f32, bool)) -> f32 {
    if n == 2 {
        return 1.0;
    }
    let remap = |p: f32| if p != 0.0 { p } else { 1.0 };
    let h = |r: f32| match heuristic {
        Heuristic::Power => r * r,
        Heuristic::Balance => r,
    };
    let delta = |i: usize| at(i).2;
    let mut sum = 0.0f32;
    // more light vertices: x_s, x_{s+1}, … move to the light side
    let mut r = 1.0f32;
    for i in s..n - 1 {
        let (pl, pe, _) = at(i);
        r *= remap(pl) / remap(pe);
        if possible_of(i + 1, delta_light, delta) {
            sum += h(r);
        }
    }
    // fewer light vertices: x_{s−1}, x_{s−2}, … move to the camera side
    let mut r = 1.0f32;
    for i in (0..s).rev() {
        let (pl, pe, _) = at(i);
        r *= remap(pe) / remap(pl);
        if possible_of(i, delta_light, delta) {
            sum += h(r);
        }
    }
    let w = 1.0 / (1.0 + sum);
    if w.is_finite() {
        w
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::SplitMix64;

    #[test]
    fn weights_of_the_possible_strategies_sum_to_one() {
        let mut rng = SplitMix64(3);
        for _ in 0..2000 {
            let n = 3 + rng.below(8);
            let mut d = PathDensities {
                delta_light: rng.unit_f32() < 0.2,
                ..Default::default()
            };
            for i in 0..n {
                let delta = i > 0 && i < n - 1 && rng.unit_f32() < 0.2;
                let p = |rng: &mut SplitMix64| if delta { 0.0 } else { (8.0 * rng.unit_f32() - 4.0).exp() };
                let (a, b) = (p(&mut rng), p(&mut rng));
                d.push(a, b, delta);
            }
            for heuristic in [Heuristic::Power, Heuristic::Balance] {
                let sum: f32 = (0..n).filter(|&s| d.possible(s)).map(|s| d.weight(s, heuristic)).sum();
                let any = (0..n).any(|s| d.possible(s));
                assert!(!any || (sum - 1.0).abs() < 1e-4, "{d:?}: {sum}");
            }
        }
    }
}
