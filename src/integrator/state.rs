//! What an integrator keeps from one pass to the next, owned by the render loop
//! and handed to each pass beside the film (which only accumulates samples and
//! splats): photon maps, SPPM's pixel statistics, guiding's SD-tree and its
//! iterations, EARS's learned statistics, BDPT's strategy films. None of it is saved with the film state,
//! so the integrators that keep any refuse `--resume` and `--shard`
//! ([`super::Integrator::passes_independent`]).

use super::bdpt::strategies::StrategyFilms;
use super::{ears, guided, photon, sppm};

/// One integrator's state between passes, empty until its first pass.
#[derive(Default)]
pub enum PassState {
    /// Integrators whose passes keep nothing.
    #[default]
    Stateless,
    /// `photon`: the current iteration's photon map.
    Photon(Option<photon::MapState>),
    /// `sppm`: the pixels' radii, photon counts and flux.
    Sppm(Option<sppm::State>),
    /// `guided`: the SD-tree, the iterations and their images.
    Guided(Option<Box<guided::State>>),
    /// `path` with `rr: "ears"`: the statistics its roulette and splitting learn.
    Ears(Option<Box<ears::State>>),
    /// `bdpt` with `visualize_strategies`: a film per strategy.
    Strategies(Option<StrategyFilms>),
}

impl PassState {
    /// The SD-tree `guided` has learned so far (for tests and inspection).
    pub fn learned_tree(&self) -> Option<&guided::SdTree> {
        match self {
            PassState::Guided(Some(s)) => Some(&s.tree),
            _ => None,
        }
    }
}

/// An accessor of one variant's state, making the variant (empty) if the state
/// is another's.
macro_rules! slot {
    ($name:ident, $variant:ident, $t:ty) => {
        pub fn $name(&mut self) -> &mut Option<$t> {
            if !matches!(self, PassState::$variant(_)) {
                *self = PassState::$variant(None);
            }
            match self {
                PassState::$variant(s) => s,
                _ => unreachable!("the variant was set above"),
            }
        }
    };
}

impl PassState {
    slot!(photon, Photon, photon::MapState);
    slot!(sppm, Sppm, sppm::State);
    slot!(guided, Guided, Box<guided::State>);
    slot!(ears, Ears, Box<ears::State>);
    slot!(strategies, Strategies, StrategyFilms);
}
