//! The iteration loop of a run and its stopping rules: which samples the
//! batches come from and which score the model ([`Split`]), the
//! iterations until the model converges, stagnates, fails or runs out of
//! budget ([`iterate`]), and the best-scoring model so far.

use std::ops::ControlFlow;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::checkpoint;
use super::config::{IdentifyConfig, Validation};
use super::cost::{data_scale, model_cost, Cost};
use super::history::{IterationRecord, StepOutcome, StopReason};
use super::state::RunState;
use super::steps::{iterate_on, metric_is_fitted};
use crate::data::IdentificationData;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// The samples batches are drawn from and those that score the model.
pub(super) struct Split<D> {
    pub(super) pool: D,
    pub(super) validation: Option<D>,
}

impl<D: IdentificationData> Split<D> {
    pub(super) fn new(data: &D, config: &IdentifyConfig) -> Result<Self> {
        let count = data.equation_count();
        let held_out = config.held_out(count);
        if config.batch_size.is_none() {
            return Ok(Self {
                pool: data.clone(),
                validation: None,
            });
        }
        match config.validation {
            Validation::None => Ok(Self {
                pool: data.clone(),
                validation: None,
            }),
            Validation::AllData => Ok(Self {
                pool: data.clone(),
                validation: Some(data.clone()),
            }),
            _ => {
                // A stream of its own, so that the batches do not depend on it.
                let mut rng = ChaCha8Rng::seed_from_u64(config.seed ^ 0x0ba1_1da7_e000_0000);
                let mut order = rand::seq::index::sample(&mut rng, count, count).into_vec();
                let validation = order.split_off(count - held_out);
                order.sort_unstable();
                Ok(Self {
                    pool: data.select(&order)?,
                    validation: Some(data.select(&validation)?),
                })
            }
        }
    }
}

/// Iterations on `split` from `state` until a stopping rule holds; their
/// records are marked `warm_up` and `restart` as asked.
pub(super) fn iterate<S, D, F>(
    data: &D,
    config: &IdentifyConfig,
    split: &Split<D>,
    mut state: RunState<S>,
    observer: &mut F,
    warm_up: bool,
    restart: bool,
) -> Result<RunState<S>>
where
    S: MetriplecticSystem,
    D: IdentificationData,
    F: FnMut(&IterationRecord, &Model<S>) -> ControlFlow<()>,
{
    let first = state.history.iterations.len() + 1;
    state.stopped = None;

    for iteration in first..=config.max_iterations {
        let batch = match config.batch_size {
            None => None,
            Some(q) => {
                let indices =
                    rand::seq::index::sample(&mut state.rng, split.pool.equation_count(), q)
                        .into_vec();
                Some(split.pool.select(&indices)?)
            }
        };
        let batch = batch.as_ref().unwrap_or(&split.pool);
        let fitted = metric_is_fitted(config, &state.history, warm_up, restart);
        let (cost_before, metric, entropy, joint) = iterate_on(batch, config, &mut state, fitted)?;

        let accepted = [
            Some(&metric),
            Some(&entropy),
            joint.as_ref().map(|j| &j.step),
        ]
        .iter()
        .flatten()
        .any(|s| s.outcome == StepOutcome::Accepted);
        state.ever_accepted |= accepted;
        let both_failed = [&metric, &entropy]
            .iter()
            .all(|s| s.outcome == StepOutcome::RejectedFailed);
        state.failed_in_a_row = if both_failed {
            state.failed_in_a_row + 1
        } else {
            0
        };

        let mut record = IterationRecord {
            iteration,
            batch_size: batch.equation_count(),
            cost_before,
            metric,
            entropy,
            joint,
            validation_cost: None,
            polish: false,
            warm_up,
            restart,
        };
        let cost_now = record.cost_after();
        // The score: on the validation samples, or the batch when it is all the data.
        let score = match (&split.validation, config.batch_size) {
            (Some(validation), _) => Some(model_cost(&state.model, validation)?),
            (None, None) => Some(cost_now),
            (None, Some(_)) => None,
        };
        record.validation_cost = split.validation.as_ref().and(score);
        // Converged when the model fits the scoring samples (or, without
        // them, all the samples it may use) to the tolerance: a model fitted
        // to one small batch has not converged. A batch with fewer equations
        // than unknowns is fitted exactly by some wrong model, so a batch
        // within the tolerance is confirmed on the pool.
        let converged = match (&split.validation, score) {
            (Some(validation), Some(score)) => {
                score.per_component <= config.tolerance * data_scale(validation)
            }
            _ => {
                cost_now.per_component <= config.tolerance * data_scale(batch)
                    && (config.batch_size.is_none()
                        || model_cost(&state.model, &split.pool)?.per_component
                            <= config.tolerance * data_scale(&split.pool))
            }
        };
        if let Some(score) = score {
            track_best(&mut state, score, config.stagnation.as_ref());
        }
        let flow = observer(&record, &state.model);
        state.history.iterations.push(record);

        let stagnated = config
            .stagnation
            .is_some_and(|s| score.is_some() && state.since_improvement >= s.window);
        if state.failed_in_a_row >= config.max_failed_iterations {
            if !state.ever_accepted {
                let last = &state.history.iterations[state.history.iterations.len() - 1];
                return Err(Error::IdentificationFailed {
                    iterations: iteration,
                    reason: format!(
                        "no subproblem was ever solved: last metric search {}, last entropy search {}",
                        last.metric.report.status, last.entropy.report.status
                    ),
                });
            }
            state.stopped = Some(StopReason::SolverFailures);
        } else if converged {
            state.stopped = Some(StopReason::Converged);
        } else if stagnated {
            state.stopped = Some(StopReason::Stagnated);
        } else if flow.is_break() {
            state.stopped = Some(StopReason::Interrupted);
        } else if iteration == config.max_iterations {
            state.stopped = Some(StopReason::MaxIterations);
        }
        if let Some(checkpoint) = &config.checkpoint {
            if state.stopped.is_some() || iteration % checkpoint.every == 0 {
                checkpoint::save(&checkpoint.path, data, config, &state)?;
            }
        }
        if state.stopped.is_some() {
            break;
        }
    }
    // A resumed run whose cap was already reached runs no iteration.
    state.stopped = Some(state.stopped.unwrap_or(StopReason::MaxIterations));
    Ok(state)
}

/// Keeps the best-scoring model and counts iterations without improvement.
fn track_best<S: MetriplecticSystem>(
    state: &mut RunState<S>,
    score: Cost,
    stagnation: Option<&super::config::Stagnation>,
) {
    let delta = stagnation.map_or(0.0, |s| s.relative_improvement);
    match &state.best {
        Some((_, best)) if score.sum > best.sum * (1.0 - delta) => {
            state.since_improvement += 1;
            if score.sum < best.sum {
                state.best = Some((state.model.clone(), score));
            }
        }
        _ => {
            state.best = Some((state.model.clone(), score));
            state.since_improvement = 0;
        }
    }
}
