//! A second start for a run that stagnated above its tolerance
//! ([`IdentifyConfig::restart_on_stagnation`]): the cost is bilinear in the
//! entropy and the metric and has local minima, where every step of the
//! iteration is optimal and the truth still fits better (`docs/method.md`
//! §7, "Local minima"). The measured ones held a metric smaller than the
//! truth's, and runs from a larger metric left them.

use std::ops::ControlFlow;

use super::config::{IdentifyConfig, Stagnation, Validation};
use super::cost::{data_scale, model_cost};
use super::driver::Identification;
use super::history::{IterationRecord, StopReason};
use super::iterate::{iterate, Split};
use super::start::{fitted_start, start_sample};
use super::state::RunState;
use crate::data::IdentificationData;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// The trial starts at the stagnated metric times this (less where η
/// bounds it): on the measured local minimum, 10 left it on every seed
/// and 1.5–3 on none.
const RESTART_SCALE: f64 = 10.0;
/// A scale η allows that is smaller than this is no restart.
const MIN_SCALE: f64 = 2.0;
/// Iterations of the trial at most.
const TRIAL_ITERATIONS: usize = 20;
/// The trial replaces the run only if it scores at most this fraction of
/// the stagnated model's score: a noise floor is reached from any start
/// alike, and 10% below the run is no difference of rounding or noise. On
/// the measured local minimum with noise of 1e-3 on ẋ the restarted runs
/// ended at 0.36–0.51 of the stagnated cost (the noise floor), on exact
/// data at 2e-5 of it.
const RESTART_GAIN: f64 = 0.9;
/// The trial stops when its best score fell by less than this in its last
/// [`TRIAL_WINDOW`] iterations, or as soon as it scores [`RESTART_GAIN`] of
/// the stagnated model on its subsample: it only has to show where it
/// leads, and its iterations are what the restart costs a run at a noise
/// floor. (Stopping at the first iteration that does not halve the cost,
/// as the warm-up does, ended the trials on the measured local minimum
/// before they left it.)
const TRIAL_PROGRESS: f64 = 0.1;
/// See [`TRIAL_PROGRESS`].
const TRIAL_WINDOW: usize = 2;
/// The trial also ends once it has settled: its cost on its subsample is
/// back at the stagnated model's to this relative difference (the same
/// minimum, which the run already left by stagnation), or one iteration
/// lowered it by less than [`SETTLED`] of it. Noisy runs at their noise
/// floor settle so (measured: back to 4e-5 and 1e-7 of the stagnated
/// cost, or falling by 3e-5 at a subsample's own optimum, one or two
/// iterations before the stagnation test), while the trials that left
/// the measured local minimum fell by 3% or more in every iteration.
const SAME_MINIMUM: f64 = 1e-4;
/// See [`SAME_MINIMUM`].
const SETTLED: f64 = 1e-3;

/// Whether `result`, a finished run, restarts: it stagnated (a run that
/// converged has nothing to gain; one cut short by its cap, the observer
/// or failures keeps its reason), has not restarted already, has
/// iterations left, and the metric's scale is free (no gauge) with a
/// metric to scale.
fn restarts<S: MetriplecticSystem>(result: &Identification<S>, config: &IdentifyConfig) -> bool {
    config.restart_on_stagnation
        && result.stop_reason == StopReason::Stagnated
        && config.search.gauge.is_none()
        && result.history.iterations.len() < config.max_iterations
        && !result.history.iterations.iter().any(|r| r.restart)
        && result.model.metric_coefficients().iter().any(|&v| v != 0.0)
}

/// The run's result, or, if it stagnated and a trial from a larger metric
/// scores at most 0.9 of it, the result of continuing the run from that
/// trial. The trial (on the start's subsample, at most
/// [`TRIAL_ITERATIONS`] iterations) is neither recorded nor observed; the
/// continued iterations are, marked [`IterationRecord::restart`], numbered
/// after the run's, and checkpointed like them. A function of the run's
/// result alone, so a resumed run restarts as the uninterrupted one did.
pub(super) fn restart<S, D, F>(
    data: &D,
    config: &IdentifyConfig,
    split: &Split<D>,
    result: Identification<S>,
    observer: &mut F,
) -> Result<Identification<S>>
where
    S: MetriplecticSystem,
    D: IdentificationData,
    F: FnMut(&IterationRecord, &Model<S>) -> ControlFlow<()>,
{
    if !restarts(&result, config) {
        return Ok(result);
    }
    let Some(trial) = trial::<S, D>(&split.pool, config, &result.model)? else {
        return Ok(result);
    };
    // Judged where the run scores: its validation samples, or all the data.
    let scoring = split.validation.as_ref().unwrap_or(data);
    let (stuck, found) = (
        model_cost(&result.model, scoring)?,
        model_cost(&trial, scoring)?,
    );
    // NaN compares false: no restart.
    let wins = found.sum <= RESTART_GAIN * stuck.sum;
    if !wins {
        return Ok(result);
    }
    let state = RunState {
        history: result.history.clone(),
        ..RunState::start(trial, config)
    };
    match iterate(data, config, split, state, observer, false, true) {
        Ok(state) => super::driver::finish(data, config, split, state),
        // Every solve after the restart failed: the run's own result stands.
        Err(Error::IdentificationFailed { .. }) => Ok(result),
        Err(error) => Err(error),
    }
}

/// The model a short run on the start's subsample reaches from `model`'s
/// metric times [`RESTART_SCALE`] (within η) and the entropy fitted at it;
/// `None` if η leaves no room or the trial fails.
fn trial<S: MetriplecticSystem, D: IdentificationData>(
    pool: &D,
    config: &IdentifyConfig,
    model: &Model<S>,
) -> Result<Option<Model<S>>> {
    let eta = config.search.eta_for::<S>();
    let largest = model
        .metric_coefficients()
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    let scale = RESTART_SCALE.min(eta / largest);
    let room = scale >= MIN_SCALE;
    if !room {
        return Ok(None);
    }
    let metric: Vec<f64> = model
        .metric_coefficients()
        .iter()
        .map(|v| v * scale)
        .collect();
    let sample = start_sample::<S, D>(pool, config)?;
    let batch = sample.as_ref().unwrap_or(pool);
    let stuck = model_cost(model, batch)?.per_component;
    // "Converged" once it beats the stagnated model here: a tolerance
    // relative to the batch's scale, as every tolerance is.
    let target = RESTART_GAIN * stuck / data_scale(batch);
    let phase = IdentifyConfig {
        batch_size: None,
        validation: Validation::None,
        polish: false,
        warm_up: false,
        checkpoint: None,
        max_iterations: TRIAL_ITERATIONS,
        tolerance: target.max(config.tolerance),
        stagnation: Some(Stagnation {
            window: TRIAL_WINDOW,
            relative_improvement: TRIAL_PROGRESS,
        }),
        ..config.clone()
    };
    let entropy = fitted_start::<S>(batch, &phase, &metric)?;
    let Ok(start) = Model::<S>::new(entropy, metric) else {
        return Ok(None);
    };
    let split = Split::new(batch, &phase)?;
    // Silent, and ended (as an interrupted run) once it has settled. An
    // iteration that changed nothing is left to the stagnation test: a
    // joint step refused at one radius may pass at the next.
    let mut previous = f64::INFINITY;
    let mut until_settled = |record: &IterationRecord, _: &Model<S>| {
        let cost = record.cost_after().per_component;
        let back = (cost - stuck).abs() <= SAME_MINIMUM * stuck;
        let crawling = cost < previous && previous - cost < SETTLED * previous;
        previous = cost;
        if back || crawling {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    };
    match iterate(
        batch,
        &phase,
        &split,
        RunState::start(start, &phase),
        &mut until_settled,
        false,
        true,
    ) {
        Ok(state) => Ok(Some(state.best.map_or(state.model, |(best, _)| best))),
        Err(Error::IdentificationFailed { .. }) => Ok(None),
        Err(error) => Err(error),
    }
}
