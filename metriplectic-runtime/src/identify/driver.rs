//! Bilevel identification: the paper's Algorithm 1 (full batch) and
//! Algorithm 2 (a fresh random minibatch every iteration). The entry points
//! and the result are here; the start, the warm-up, the loop and one
//! iteration's steps are in their own modules.

use std::ops::ControlFlow;
use std::path::Path;

use super::checkpoint;
use super::config::IdentifyConfig;
use super::cost::{data_scale, model_cost};
use super::history::{History, IterationRecord, StopReason};
use super::iterate::{iterate, Split};
use super::restart::restart;
use super::start::{initial_coefficients, start_sample};
use super::state::RunState;
use super::steps::iterate_on;
use super::warm_up::{warm_up, warms_up};
use super::warnings::{data_warnings, failed_solves, progress_warning, IdentifyWarning};
use crate::data::check_dataset;
use crate::data::IdentificationData;
use crate::error::Result;
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// Result of [`identify`].
#[derive(Debug, Clone)]
pub struct Identification<S: MetriplecticSystem> {
    /// The identified model: the last accepted iterate of a full-batch run,
    /// the best-scoring (and polished) one of a minibatch run.
    pub model: Model<S>,
    /// Per-iteration records.
    pub history: History,
    /// Why the run stopped.
    pub stop_reason: StopReason,
    /// What the data cannot determine, and whether the run stopped at its
    /// iteration cap while still improving: read these before trusting the
    /// coefficients. Empty when the run ended on its own, the data
    /// determine the coefficients (each block at the other's value, and
    /// the two together: the latter from the
    /// [`identifiability`](crate::identifiability) report, which names the
    /// combinations), and the scale (K, E) ↦ (cK, E/c) is fixed.
    /// Combinations hidden only by the fit's misfit are the report's alone.
    pub warnings: Vec<IdentifyWarning>,
}

/// Runs Algorithm 1 or 2 (per [`IdentifyConfig::batch_size`]) on `data`.
///
/// Each iteration runs the metric search with the entropy fixed, then the
/// entropy search with the metric fixed, on the same batch. A step replaces
/// the current model only if its solve ended usable ([`SolveStatus::is_usable`](crate::SolveStatus::is_usable)),
/// its coefficients are finite, and its cost **on the same batch**, recomputed
/// from the coefficients, is lower than the current model's. The paper's
/// Theorem 1 needs "not larger"; requiring a decrease also refuses the
/// free moves of a block the cost does not see (with S = 0 every metric has
/// the same cost, and accepting one near K = 0 would freeze the entropy
/// search), so the cost still never increases and every rejected step is
/// recorded in the [`History`].
///
/// # Iteration schemes
///
/// [`IterationScheme::Alternating`](crate::IterationScheme::Alternating) ([`IdentifyConfig::paper`]'s) is the
/// paper's algorithm: metric search, then entropy search.
/// [`IterationScheme::AlternatingThenJoint`](crate::IterationScheme::AlternatingThenJoint) (the default) adds, on the
/// same batch, a joint linearised step in both blocks inside an adaptive
/// trust region ([`joint_step`](super::joint_step)), accepted under the
/// same rule. On the nonsmooth L1 cost the alternation alone can crawl (each block
/// optimal, the pair not jointly stationary); the joint step removes that.
///
/// # Warm-up
///
/// A full-batch run on at least twice the start's subsample
/// ([`IdentifyConfig::start_samples`], 2000 by default) takes its first
/// iterations on that subsample, while each halves its cost, and then
/// iterates on all the data from the model reached
/// ([`IdentifyConfig::warm_up`]): the early iterations, with the metric far
/// from the truth, are the costly ones, and on exact data of a 6-state
/// system at q = 16000 the whole run took 55 s instead of 271 s.
///
/// # Stopping
///
/// * the per-component cost on the iteration's batch reaches
///   [`IdentifyConfig::tolerance`] ([`StopReason::Converged`]);
/// * [`IdentifyConfig::max_iterations`] iterations ran ([`StopReason::MaxIterations`]);
/// * the observer returned [`ControlFlow::Break`] ([`StopReason::Interrupted`]);
/// * [`IdentifyConfig::max_failed_iterations`] consecutive iterations in which
///   *both* solves failed (not merely failed to improve): if some step had been
///   accepted before, the best model so far is returned with
///   [`StopReason::SolverFailures`]; if none ever was, no progress was possible
///   and the result is [`Error::IdentificationFailed`](crate::Error::IdentificationFailed).
///
/// # Checkpoints
///
/// With [`IdentifyConfig::checkpoint`] set, the run's full state is saved
/// atomically every few iterations and when it stops; [`identify_resume`]
/// continues it, with the same history an uninterrupted run would have had.
///
/// # Example: measured states to a validated model
///
/// Noisy states without derivatives (here synthesised and written as the
/// CSV an instrument would give): hold whole trajectories out, identify on
/// the weak form of the rest, score on the held-out ones.
///
/// ```
/// use metriplectic_runtime::prelude::*;
/// use metriplectic_runtime::{
///     read_trajectories_from, synthesize, write_trajectories_to, InitialStates, Noise,
///     SampleTimes, SynthesisOptions,
/// };
///
/// metriplectic! {
///     pub struct Decay;
///     state (x, y);
///     poisson = [[0, 1], [-1, 0]];
///     hamiltonian = 0.5 * x^2 + 0.5 * y^2;
///     entropy degree 2;
///     metric degree 0;
///     reference { entropy = -(x^2 + y^2); metric = [[1, 0], [0, 1]]; }
/// }
///
/// // Stand-in for measurements: 1e-3 state noise, states only.
/// let truth = Model::<Decay>::reference()?;
/// let synthetic = synthesize(&truth, &SynthesisOptions {
///     trajectories: 12,
///     duration: 3.0,
///     noise: Noise { state_std: 1e-3, derivative_std: 0.0 },
///     ..SynthesisOptions::new(InitialStates::cube(2, 1.0), SampleTimes::Uniform { interval: 0.02 })
/// })?;
/// let mut csv = Vec::new();
/// write_trajectories_to(&mut csv, &synthetic.measured)?;
///
/// // The workflow.
/// let trajectories = read_trajectories_from(csv.as_slice(), &["x", "y"])?;
/// let (train, validation) = split_by_trajectory(&trajectories, 0.25, 1)?;
/// let form = WeakForm::default();
/// let fit = identify::<Decay>(&WeakDataset::from_trajectories(&train, &form)?, &IdentifyConfig::default())?;
/// let validation = WeakDataset::from_trajectories(&validation, &form)?;
/// let score = fit.model.score(&validation)?;
/// assert!(score.r_squared > 0.999, "{score}");
/// // Against the truth (unknown in practice): within the noise.
/// assert!(fit.model.compare(&truth, &validation)?.relative_error < 1e-2);
/// # Ok::<(), metriplectic_runtime::Error>(())
/// ```
pub fn identify<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    config: &IdentifyConfig,
) -> Result<Identification<S>> {
    identify_with_observer(data, config, |_, _| ControlFlow::Continue(()))
}

/// [`identify`] with an observer called after every iteration with its
/// record and the current model; returning [`ControlFlow::Break`] stops the
/// run (e.g. from a progress bar's cancel button).
pub fn identify_with_observer<S, F>(
    data: &impl IdentificationData,
    config: &IdentifyConfig,
    observer: F,
) -> Result<Identification<S>>
where
    S: MetriplecticSystem,
    F: FnMut(&IterationRecord, &Model<S>) -> ControlFlow<()>,
{
    check_dataset::<S>(data)?;
    config.validate::<S>(data.equation_count())?;
    let split = Split::new(data, config)?;
    let sample = start_sample::<S, _>(&split.pool, config)?;
    let start_batch = sample.as_ref().unwrap_or(&split.pool);
    let (entropy, metric) = initial_coefficients::<S>(start_batch, config)?;
    let state = RunState::start(Model::<S>::new(entropy, metric)?, config);
    let mut observer = observer;
    let state = match sample {
        Some(sample) if warms_up(config, &sample, &split.pool) => {
            warm_up(&sample, config, state, &mut observer)?
        }
        _ => state,
    };
    if state.stopped == Some(StopReason::Interrupted) {
        return finish(data, config, &split, state);
    }
    run(data, config, &split, state, observer)
}

/// Continues the run saved in the checkpoint at `path` (written by a run
/// with [`IdentifyConfig::checkpoint`] set) on the same `data` with the same
/// `config`, as if it had never stopped: with the same seed, the resumed
/// run's history equals that of an uninterrupted run.
///
/// `config` may raise [`IdentifyConfig::max_iterations`] (to extend a run:
/// it continues as a run with the larger cap would, except that a warm-up
/// the smaller cap cut short, or ruled out at a cap of 1, stays as it
/// was) and change [`IdentifyConfig::checkpoint`]; anything else that differs
/// from the checkpointed run, or other data, is
/// [`Error::CheckpointMismatch`](crate::Error::CheckpointMismatch) naming what differs. A checkpoint of a run
/// that had stopped by itself (converged, stagnated or given up on solver
/// failures) gives that run's result without iterating again.
pub fn identify_resume<S: MetriplecticSystem>(
    path: impl AsRef<Path>,
    data: &impl IdentificationData,
    config: &IdentifyConfig,
) -> Result<Identification<S>> {
    identify_resume_with_observer(path, data, config, |_, _| ControlFlow::Continue(()))
}

/// [`identify_resume`] with an observer, as in [`identify_with_observer`];
/// it sees only the iterations run after resuming.
pub fn identify_resume_with_observer<S, F>(
    path: impl AsRef<Path>,
    data: &impl IdentificationData,
    config: &IdentifyConfig,
    observer: F,
) -> Result<Identification<S>>
where
    S: MetriplecticSystem,
    F: FnMut(&IterationRecord, &Model<S>) -> ControlFlow<()>,
{
    check_dataset::<S>(data)?;
    config.validate::<S>(data.equation_count())?;
    let state = checkpoint::load::<S>(path.as_ref(), data, config)?;
    let split = Split::new(data, config)?;
    match state.stopped {
        // The checkpoint holds the state before `finish`, so finishing it
        // again gives the uninterrupted run's result (best model, polish).
        Some(StopReason::Converged | StopReason::Stagnated | StopReason::SolverFailures) => {
            let mut observer = observer;
            let result = finish(data, config, &split, state)?;
            restart(data, config, &split, result, &mut observer)
        }
        _ => run(data, config, &split, state, observer),
    }
}

/// The iterations of [`identify_with_observer`] from `state` on, and the
/// result.
fn run<S, D, F>(
    data: &D,
    config: &IdentifyConfig,
    split: &Split<D>,
    state: RunState<S>,
    mut observer: F,
) -> Result<Identification<S>>
where
    S: MetriplecticSystem,
    D: IdentificationData,
    F: FnMut(&IterationRecord, &Model<S>) -> ControlFlow<()>,
{
    // A run resumed after its restart continues the restart's phase.
    let restarted = state.history.iterations.iter().any(|r| r.restart);
    let state = iterate(data, config, split, state, &mut observer, false, restarted)?;
    let result = finish(data, config, split, state)?;
    restart(data, config, split, result, &mut observer)
}

/// The result of a stopped run: a scoring run returns its best model,
/// polished by one full-batch iteration when asked (and kept only if it
/// scores no worse). A function of the run's state alone, so that a run
/// resumed from the checkpoint of a stopped run returns the same result;
/// the checkpoint keeps the state before it, from which a longer run
/// continues as if it had never stopped.
pub(super) fn finish<S: MetriplecticSystem, D: IdentificationData>(
    data: &D,
    config: &IdentifyConfig,
    split: &Split<D>,
    mut state: RunState<S>,
) -> Result<Identification<S>> {
    let stop_reason = state.stopped.unwrap_or(StopReason::MaxIterations);
    // Measured before the polish, on the iterations the cap cut short.
    let still_improving = if stop_reason == StopReason::MaxIterations {
        let scale = match &split.validation {
            Some(validation) => data_scale(validation),
            None => data_scale(data),
        };
        progress_warning(&state.history, config, config.tolerance * scale)
    } else {
        None
    };
    if let Some((best, _)) = &state.best {
        state.model = best.clone();
    }
    let polishing = config.batch_size.is_some()
        && config.polish
        && !matches!(
            stop_reason,
            StopReason::Interrupted | StopReason::SolverFailures
        );
    if polishing {
        let best = state.best.clone();
        // On the pool: held-out samples never enter a batch, the polish's
        // neither, so that its score stays out of sample.
        let (cost_before, metric, entropy, joint) =
            iterate_on(&split.pool, config, &mut state, false)?;
        let score = model_cost(&state.model, split.validation.as_ref().unwrap_or(data))?;
        state.history.iterations.push(IterationRecord {
            iteration: state.history.iterations.len() + 1,
            batch_size: split.pool.equation_count(),
            cost_before,
            metric,
            entropy,
            joint,
            validation_cost: split.validation.as_ref().map(|_| score),
            polish: true,
            warm_up: false,
            restart: state.history.iterations.iter().any(|r| r.restart),
        });
        if let Some((best, best_score)) = best {
            if score.sum > best_score.sum {
                state.model = best;
            }
        }
    }
    // What the fit's own samples determine: held-out samples never entered
    // it (a probe's pool of one sample, held out of 200, got no warning).
    let mut warnings = data_warnings(&split.pool, &state.model, config)?;
    warnings.extend(still_improving);
    warnings.extend(failed_solves(&state.history));
    Ok(Identification {
        model: state.model,
        history: state.history,
        stop_reason,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::entropy_search;
    use crate::identify::config::{IterationScheme, Validation};
    use crate::identify::history::StepOutcome;
    use crate::identify::start::fitted_start;
    use crate::identify::warnings::Subproblem;
    use crate::model::identity_metric;
    use crate::test_system::{reference_data, Quadratic2d};
    use crate::Error;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// The paper's alternation on the full batch with no stopping rule but
    /// the tolerance: the defaults these tests were written for.
    fn alternation() -> IdentifyConfig {
        IdentifyConfig {
            batch_size: None,
            stagnation: None,
            validation: Validation::None,
            polish: false,
            scheme: IterationScheme::Alternating,
            ..IdentifyConfig::default()
        }
    }
    use crate::{SearchOptions, SolveStatus, SolverSettings};

    fn assert_non_increasing(history: &History) {
        let mut previous = f64::INFINITY;
        for record in &history.iterations {
            for cost in [
                record.cost_before.sum,
                record.metric.cost_after.sum,
                record.entropy.cost_after.sum,
            ] {
                assert!(cost <= previous, "cost rose from {previous} to {cost}");
                previous = cost;
            }
        }
    }

    #[test]
    fn full_batch_cost_never_increases() {
        // From ψ = 0 the alternation stalls at a bad stationary point (the
        // metric search shrinks K towards 0); Theorem 1 still holds.
        let data = reference_data(60, 11);
        let config = IdentifyConfig {
            max_iterations: 6,
            tolerance: 0.0,
            initial_entropy: Some(vec![0.0; Quadratic2d::entropy_coefficient_count()]),
            ..alternation()
        };
        let result = identify::<Quadratic2d>(&data, &config).unwrap();
        assert_eq!(result.history.iterations.len(), 6);
        assert_non_increasing(&result.history);
        let first = result.history.iterations[0].cost_before.sum;
        let last = result.history.iterations[5].entropy.cost_after.sum;
        assert!(last < 0.5 * first, "{first} -> {last}");
    }

    /// The default start (the entropy search's fit with K = I) avoids that
    /// stationary point: the alternation alone reaches the exact data.
    #[test]
    fn the_fitted_start_reaches_exact_data_from_no_knowledge() {
        let data = reference_data(60, 11);
        let config = IdentifyConfig {
            max_iterations: 20,
            ..alternation()
        };
        let result = identify::<Quadratic2d>(&data, &config).unwrap();
        assert_eq!(
            result.stop_reason,
            StopReason::Converged,
            "{:?}",
            result.history
        );
        assert_non_increasing(&result.history);
    }

    /// The start is fitted on at most `start_samples` samples, but never on
    /// fewer than ten equations per entropy coefficient; a run from the
    /// subsampled start still fits the exact data.
    #[test]
    fn the_fitted_start_takes_a_subsample_of_a_large_pool() {
        let data = reference_data(400, 11);
        let metric = identity_metric::<Quadratic2d>(1.0);
        let start = |start_samples| {
            let config = IdentifyConfig {
                start_samples,
                ..alternation()
            };
            let sample = start_sample::<Quadratic2d, _>(&data, &config).unwrap();
            fitted_start::<Quadratic2d>(sample.as_ref().unwrap_or(&data), &config, &metric).unwrap()
        };
        let everything =
            entropy_search::<Quadratic2d>(&data, &metric, &SearchOptions::default()).unwrap();
        assert_eq!(start(usize::MAX), everything.coefficients);
        assert_eq!(start(400), everything.coefficients);
        // p = 5 coefficients, n = 2 components: at least 25 samples.
        assert_eq!(start(1), start(25));
        assert_ne!(start(25), start(26));
        assert_ne!(start(40), everything.coefficients);

        let config = IdentifyConfig {
            start_samples: 40,
            max_iterations: 20,
            ..alternation()
        };
        let result = identify::<Quadratic2d>(&data, &config).unwrap();
        assert_eq!(result.stop_reason, StopReason::Converged);
        let zero = IdentifyConfig {
            start_samples: 0,
            ..alternation()
        };
        let error = identify::<Quadratic2d>(&data, &zero).unwrap_err();
        assert!(error.to_string().contains("start samples"), "{error}");
    }

    /// A full-batch run on at least twice the start's subsample first
    /// iterates on that subsample (recorded, observed and counted), then on
    /// all the data; without the warm-up, or with a budget of one
    /// iteration, every iteration is on all the data.
    #[test]
    fn a_large_full_batch_warms_up_on_the_start_subsample() {
        let data = reference_data(400, 11);
        // Half the true metric (the identity), so that the start misfits.
        let mut metric = vec![0.0; 18];
        (metric[0], metric[12]) = (0.5, 0.5);
        let config = IdentifyConfig {
            start_samples: 40,
            max_iterations: 20,
            initial_metric: Some(metric),
            scheme: IterationScheme::default(),
            ..alternation()
        };
        let mut observed = Vec::new();
        let result = identify_with_observer::<Quadratic2d, _>(&data, &config, |record, _| {
            observed.push((record.iteration, record.warm_up, record.batch_size));
            ControlFlow::Continue(())
        })
        .unwrap();
        assert_eq!(result.stop_reason, StopReason::Converged);
        let iterations = &result.history.iterations;
        let warm = iterations.iter().take_while(|r| r.warm_up).count();
        assert!(warm >= 1 && warm < iterations.len(), "{iterations:?}");
        assert!(iterations[warm..].iter().all(|r| !r.warm_up));
        for (i, record) in iterations.iter().enumerate() {
            assert_eq!(record.iteration, i + 1);
            assert_eq!(record.batch_size, if record.warm_up { 40 } else { 400 });
        }
        let seen: Vec<_> = iterations
            .iter()
            .map(|r| (r.iteration, r.warm_up, r.batch_size))
            .collect();
        assert_eq!(observed, seen);
        // The warm-up fitted its subsample from a start that misfits it, and
        // the run on all the data starts where it ended: near zero cost on
        // all the data too.
        assert!(iterations[0].cost_before.per_component > 1e-3);
        assert!(iterations[warm - 1].cost_after().per_component <= 1e-6);
        assert!(iterations[warm].cost_before.per_component <= 1e-6);

        for config in [
            IdentifyConfig {
                warm_up: false,
                ..config.clone()
            },
            IdentifyConfig {
                max_iterations: 1,
                ..config.clone()
            },
            // Less than twice the subsample.
            IdentifyConfig {
                start_samples: 201,
                ..config.clone()
            },
        ] {
            let result = identify::<Quadratic2d>(&data, &config).unwrap();
            assert!(result
                .history
                .iterations
                .iter()
                .all(|r| !r.warm_up && r.batch_size == 400));
        }
        // Stopped by the observer in the warm-up: no iteration on all the data.
        let stopped = identify_with_observer::<Quadratic2d, _>(&data, &config, |record, _| {
            assert!(record.warm_up);
            ControlFlow::Break(())
        })
        .unwrap();
        assert_eq!(stopped.stop_reason, StopReason::Interrupted);
        assert_eq!(stopped.history.iterations.len(), 1);
    }

    #[test]
    fn full_batch_from_a_perturbed_truth_fits_the_data() {
        let data = reference_data(60, 11);
        let start: Vec<f64> = Quadratic2d::REFERENCE_ENTROPY
            .unwrap()
            .iter()
            .zip([0.05, -0.1, 0.08, -0.03, 0.1])
            .map(|(c, d)| c + d)
            .collect();
        // The alternation converges linearly here (the cost halves per
        // iteration with the dense backend: 3.9e-7 after 20 iterations), so
        // the budget allows 40; Clarabel's less accurate block solutions
        // happen to jump to the exact fit after about 20.
        let config = IdentifyConfig {
            max_iterations: 40,
            tolerance: 1e-9,
            initial_entropy: Some(start),
            ..alternation()
        };
        let result = identify::<Quadratic2d>(&data, &config).unwrap();
        assert_non_increasing(&result.history);
        assert_eq!(result.stop_reason, StopReason::Converged);
        let cost = model_cost(&result.model, &data).unwrap();
        assert!(cost.per_component <= 1e-9, "{cost:?}");
    }

    #[test]
    fn minibatches_are_reproducible_for_a_seed() {
        let data = reference_data(50, 12);
        let config = IdentifyConfig {
            batch_size: Some(10),
            max_iterations: 3,
            tolerance: 0.0,
            seed: 7,
            initial_entropy: Some(vec![0.1; 5]),
            ..alternation()
        };
        let costs = |config: &IdentifyConfig| -> Vec<f64> {
            identify::<Quadratic2d>(&data, config)
                .unwrap()
                .history
                .iterations
                .iter()
                .map(|r| r.cost_before.sum)
                .collect()
        };
        let first = costs(&config);
        assert_eq!(first, costs(&config));
        let other_seed = IdentifyConfig {
            seed: 8,
            ..config.clone()
        };
        assert_ne!(first, costs(&other_seed));
    }

    #[test]
    fn observer_can_stop_the_run() {
        let data = reference_data(20, 13);
        let mut seen = 0;
        let result = identify_with_observer::<Quadratic2d, _>(
            &data,
            &IdentifyConfig {
                tolerance: 0.0,
                ..alternation()
            },
            |record, _model| {
                seen += 1;
                assert_eq!(record.iteration, seen);
                ControlFlow::Break(())
            },
        )
        .unwrap();
        assert_eq!(seen, 1);
        assert_eq!(result.stop_reason, StopReason::Interrupted);
        assert_eq!(result.history.iterations.len(), 1);
    }

    #[test]
    fn history_serialises_to_json_and_csv() {
        let data = reference_data(20, 14);
        let result = identify::<Quadratic2d>(
            &data,
            &IdentifyConfig {
                max_iterations: 2,
                tolerance: 0.0,
                ..alternation()
            },
        )
        .unwrap();
        let json = serde_json::to_string(&result.history).unwrap();
        let back: History = serde_json::from_str(&json).unwrap();
        assert_eq!(back, result.history);
        let mut csv = Vec::new();
        result.history.write_csv(&mut csv).unwrap();
        let text = String::from_utf8(csv).unwrap();
        assert_eq!(text.lines().count(), 3);
        let columns = text.lines().next().unwrap().split(',').count();
        assert!(text.lines().all(|l| l.split(',').count() == columns));
    }

    #[test]
    fn invalid_configurations_are_errors() {
        let data = reference_data(10, 15);
        let bad = [
            IdentifyConfig {
                batch_size: Some(0),
                ..alternation()
            },
            IdentifyConfig {
                batch_size: Some(11),
                ..alternation()
            },
            IdentifyConfig {
                search: SearchOptions {
                    eta: Some(0.0),
                    ..SearchOptions::default()
                },
                ..alternation()
            },
            IdentifyConfig {
                search: SearchOptions {
                    eta: Some(f64::NAN),
                    ..SearchOptions::default()
                },
                ..alternation()
            },
            IdentifyConfig {
                tolerance: f64::INFINITY,
                ..alternation()
            },
            IdentifyConfig {
                initial_entropy: Some(vec![0.0; 4]),
                ..alternation()
            },
            IdentifyConfig {
                initial_metric: Some(vec![f64::NAN; 18]),
                ..alternation()
            },
            IdentifyConfig {
                search: SearchOptions {
                    solver: SolverSettings {
                        max_iter: 0,
                        ..SolverSettings::default()
                    },
                    ..SearchOptions::default()
                },
                ..alternation()
            },
        ];
        for config in &bad {
            let err = identify::<Quadratic2d>(&data, config).unwrap_err();
            assert!(
                matches!(
                    err,
                    Error::InvalidArgument { .. }
                        | Error::DimensionMismatch { .. }
                        | Error::NonFinite { .. }
                ),
                "{config:?} gave {err}"
            );
        }
        let wrong_dim = crate::Dataset::from_flat(3, vec![0.0; 3], vec![0.0; 3]).unwrap();
        assert!(matches!(
            identify::<Quadratic2d>(&wrong_dim, &alternation()),
            Err(Error::DimensionMismatch { .. })
        ));
    }

    /// The alternation with a solver allowed one interior-point iteration,
    /// which solves nothing, stopping after two failed iterations.
    fn failing_solver() -> IdentifyConfig {
        IdentifyConfig {
            search: SearchOptions {
                solver: SolverSettings {
                    max_iter: 1,
                    ..SolverSettings::default()
                },
                ..SearchOptions::default()
            },
            max_failed_iterations: 2,
            ..alternation()
        }
    }

    #[test]
    fn solver_failures_after_progress_return_the_kept_model() {
        // A run that has accepted steps (here: resumed from such a state)
        // and then only sees failing solves stops with SolverFailures and
        // returns the model it had, not an error.
        let data = reference_data(20, 17);
        let config = failing_solver();
        // Off the truth, so the data are not already fitted (cost > 0).
        let reference = Model::<Quadratic2d>::reference().unwrap();
        let entropy = reference.entropy_coefficients().iter().map(|c| c + 0.1);
        let kept =
            Model::<Quadratic2d>::new(entropy.collect(), reference.metric_coefficients().to_vec())
                .unwrap();
        let state = RunState {
            model: kept.clone(),
            history: History::default(),
            rng: ChaCha8Rng::seed_from_u64(0),
            failed_in_a_row: 0,
            ever_accepted: true,
            radius: 0.0,
            stopped: None,
            best: None,
            since_improvement: 0,
        };
        let result = run(
            &data,
            &config,
            &Split::new(&data, &config).unwrap(),
            state,
            |_, _| ControlFlow::Continue(()),
        )
        .unwrap();
        assert_eq!(result.stop_reason, StopReason::SolverFailures);
        assert_eq!(result.history.iterations.len(), 2);
        assert!(result.history.iterations.iter().all(|r| {
            r.metric.outcome == StepOutcome::RejectedFailed
                && r.entropy.outcome == StepOutcome::RejectedFailed
        }));
        assert_eq!(result.model, kept);
        // …and the warnings say which solves failed.
        for subproblem in [Subproblem::MetricSearch, Subproblem::EntropySearch] {
            let expected = IdentifyWarning::FailedSolves {
                subproblem,
                failed: 2,
                attempted: 2,
            };
            assert!(result.warnings.contains(&expected), "{:?}", result.warnings);
        }
    }

    #[test]
    fn failed_solves_never_replace_the_model() {
        // One interior-point iteration cannot solve anything: every step
        // fails, the model stays at its start, and with nothing ever
        // accepted the run ends in a typed error.
        let data = reference_data(20, 16);
        let config = failing_solver();
        let mut models = Vec::new();
        let err = identify_with_observer::<Quadratic2d, _>(&data, &config, |record, model| {
            assert_eq!(record.metric.outcome, StepOutcome::RejectedFailed);
            assert_eq!(record.entropy.outcome, StepOutcome::RejectedFailed);
            assert_eq!(record.metric.report.status, SolveStatus::MaxIterations);
            models.push(model.clone());
            ControlFlow::Continue(())
        })
        .unwrap_err();
        assert!(
            matches!(err, Error::IdentificationFailed { iterations: 2, .. }),
            "{err}"
        );
        let start = Model::<Quadratic2d>::new(
            vec![0.0; 5],
            crate::model::identity_metric::<Quadratic2d>(1.0),
        )
        .unwrap();
        assert!(models.iter().all(|m| *m == start));
    }
}
