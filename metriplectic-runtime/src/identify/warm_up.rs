//! The warm-up of a full-batch run ([`IdentifyConfig::warm_up`]): its first
//! iterations, with the metric far from the truth and the programs at their
//! most degenerate, run on the start's subsample instead of all the data.

use std::ops::ControlFlow;

use super::config::{IdentifyConfig, Stagnation};
use super::history::{IterationRecord, StopReason};
use super::iterate::{iterate, Split};
use super::state::RunState;
use crate::data::IdentificationData;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// Whether a run warms up on the start's subsample `sample` of `pool`
/// ([`IdentifyConfig::warm_up`]): full-batch runs with an iteration to
/// spare, on a pool of at least twice the subsample. Below that the
/// warm-up's iterations cost more than the iterations on all the data they
/// save: on exact data three on the subsample and one on all replace about
/// three on all.
pub(super) fn warms_up<D: IdentificationData>(
    config: &IdentifyConfig,
    sample: &D,
    pool: &D,
) -> bool {
    config.batch_size.is_none()
        && config.warm_up
        && config.max_iterations > 1
        && 2 * sample.equation_count() <= pool.equation_count()
}

/// A warm-up iteration continues only while it divides the subsample's cost
/// by at least this much: exact data fall by orders of magnitude per
/// iteration until they fit, noisy data stop improving after one or two,
/// and their run on all the data needs its own iterations anyway.
const WARM_UP_PROGRESS: f64 = 0.5;

/// The warm-up of a full-batch run ([`IdentifyConfig::warm_up`]): iterations
/// on the start's subsample `sample`, recorded and observed as the run's
/// first, while each halves its cost, to the tolerance or to all but one of
/// the iteration budget. Returns the state the run on all the data starts
/// from: the model reached, the trust radius, the warm-up's records, and
/// nothing of its scores (those were on the subsample). If no step of the
/// warm-up could be solved, the run starts from `state` as it was (or
/// stops there, if the observer asked it to).
pub(super) fn warm_up<S, D, F>(
    sample: &D,
    config: &IdentifyConfig,
    state: RunState<S>,
    observer: &mut F,
) -> Result<RunState<S>>
where
    S: MetriplecticSystem,
    D: IdentificationData,
    F: FnMut(&IterationRecord, &Model<S>) -> ControlFlow<()>,
{
    let phase = IdentifyConfig {
        max_iterations: config.max_iterations - 1,
        stagnation: Some(Stagnation {
            window: 1,
            relative_improvement: WARM_UP_PROGRESS,
        }),
        checkpoint: None,
        ..config.clone()
    };
    let split = Split::new(sample, &phase)?;
    let start = state.model.clone();
    // A stop asked for in the warm-up ends the run, even in an iteration
    // that also ended the warm-up by converging.
    let mut interrupted = false;
    let mut watch = |record: &IterationRecord, model: &Model<S>| {
        let flow = observer(record, model);
        interrupted |= flow.is_break();
        flow
    };
    match iterate(sample, &phase, &split, state, &mut watch, true, false) {
        Ok(warm) => Ok(RunState {
            history: warm.history,
            radius: warm.radius,
            ever_accepted: warm.ever_accepted,
            stopped: interrupted.then_some(StopReason::Interrupted),
            ..RunState::start(warm.model, config)
        }),
        // A stop asked for still ends the run; only the failed records go.
        Err(Error::IdentificationFailed { .. }) => Ok(RunState {
            stopped: interrupted.then_some(StopReason::Interrupted),
            ..RunState::start(start, config)
        }),
        Err(error) => Err(error),
    }
}
