//! Everything a run carries from one iteration to the next: what a
//! checkpoint saves and a resumed run starts from.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::config::{IdentifyConfig, IterationScheme};
use super::cost::Cost;
use super::history::{History, StopReason};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// Everything a run carries from one iteration to the next: what a
/// checkpoint saves.
pub(crate) struct RunState<S: MetriplecticSystem> {
    /// The current (last accepted) model.
    pub(crate) model: Model<S>,
    /// The best-scoring model so far and its score, when the run scores.
    pub(crate) best: Option<(Model<S>, Cost)>,
    /// Iterations since the best score last improved (for stagnation).
    pub(crate) since_improvement: usize,
    /// The iterations so far.
    pub(crate) history: History,
    /// The minibatch generator, positioned after the last batch drawn.
    pub(crate) rng: ChaCha8Rng,
    /// Consecutive iterations in which both solves failed.
    pub(crate) failed_in_a_row: usize,
    /// Whether any step was ever accepted.
    pub(crate) ever_accepted: bool,
    /// Trust radius of the next joint step (0 for the alternating scheme).
    pub(crate) radius: f64,
    /// Why the run stopped, if it did.
    pub(crate) stopped: Option<StopReason>,
}

impl<S: MetriplecticSystem> RunState<S> {
    /// A run about to take its first iteration from `model`.
    pub(super) fn start(model: Model<S>, config: &IdentifyConfig) -> Self {
        Self {
            model,
            history: History::default(),
            rng: ChaCha8Rng::seed_from_u64(config.seed),
            failed_in_a_row: 0,
            ever_accepted: false,
            radius: match &config.scheme {
                IterationScheme::AlternatingThenJoint(trust) => trust.initial_radius,
                IterationScheme::Alternating => 0.0,
            },
            stopped: None,
            best: None,
            since_improvement: 0,
        }
    }
}
