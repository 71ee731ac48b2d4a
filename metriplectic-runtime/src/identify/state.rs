//! Everything a run carries from one iteration to the next: what a
//! checkpoint saves and a resumed run starts from.

use rand_chacha::ChaCha8Rng;

use super::history::{History, StopReason};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// Everything a run carries from one iteration to the next: what a
/// checkpoint saves.
pub(crate) struct RunState<S: MetriplecticSystem> {
    /// The current (last accepted) model.
    pub(crate) model: Model<S>,
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
