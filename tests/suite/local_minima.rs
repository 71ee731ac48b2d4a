//! Local minima of the bilinear cost: a run that stagnates far above what
//! the data allow restarts once from a larger metric
//! (`IdentifyConfig::restart_on_stagnation`), and keeps the restart only
//! when it scores clearly better.

use std::ops::ControlFlow;

use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    identify_resume, identify_with_observer, model_cost, synthesize, CheckpointConfig,
    InitialStates, Noise, SampleTimes, StopReason, SynthesisOptions, SyntheticData,
};

use crate::common::{scratch_dir, without_timings};

metriplectic! {
    /// Friction on the momentum that grows with the position (not from the
    /// paper), found by a probe: from the default start the iteration
    /// settles at K ≈ [[0.17, −0.30], [−0.30, 0.53 + 0.26q²]], a local
    /// minimum at a cost of 1e-3 where the truth fits exactly.
    pub struct PositionFriction;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * (p^2 + q^2);
    entropy degree 4;
    metric degree 2;
    region ball(radius = 2.5);
    reference {
        entropy = -(p^2 + q^2) - 0.25 * q^4;
        metric = [[0, 0], [0, 1 + q^2]];
    }
}

fn data(seed: u64, noise: f64) -> SyntheticData {
    let truth = Model::<PositionFriction>::reference().unwrap();
    synthesize(
        &truth,
        &SynthesisOptions {
            trajectories: 30,
            duration: 4.0,
            held_out_trajectories: 6,
            seed,
            noise: Noise {
                state_std: 0.0,
                derivative_std: noise,
            },
            ..SynthesisOptions::new(
                InitialStates::cube(2, 1.5),
                SampleTimes::LogUniform {
                    count: 30,
                    first: 1e-3,
                },
            )
        },
    )
    .unwrap()
}

/// Held-out error of the identified field against the truth.
fn error(model: &Model<PositionFriction>, data: &SyntheticData) -> f64 {
    let truth = Model::<PositionFriction>::reference().unwrap();
    let held_out = data.held_out.as_ref().unwrap();
    model.compare(&truth, held_out).unwrap().relative_error
}

#[test]
fn a_run_stuck_in_a_local_minimum_restarts_from_a_larger_metric() {
    for seed in [1, 2] {
        let data = data(seed, 0.0);
        let without = identify::<PositionFriction>(
            &data.train,
            &IdentifyConfig {
                restart_on_stagnation: false,
                ..IdentifyConfig::default()
            },
        )
        .unwrap();
        // The local minimum: every solve fine, the truth far better.
        assert_eq!(without.stop_reason, StopReason::Stagnated);
        let stuck = model_cost(&without.model, &data.train).unwrap();
        assert!(stuck.per_component > 1e-4, "seed {seed}: {stuck:?}");
        assert!(error(&without.model, &data) > 1e-3);

        let with = identify::<PositionFriction>(&data.train, &IdentifyConfig::default()).unwrap();
        let restarted = with.history.iterations.iter().filter(|r| r.restart).count();
        assert!(restarted > 0, "seed {seed}: no restart");
        // The run's own records come first, unchanged.
        let (with_history, without_history) = (
            without_timings(&with.history),
            without_timings(&without.history),
        );
        assert_eq!(
            with_history.iterations[..without_history.iterations.len()],
            without_history.iterations[..]
        );
        let cost = model_cost(&with.model, &data.train).unwrap();
        assert!(cost.per_component < 1e-6, "seed {seed}: {cost:?}");
        let err = error(&with.model, &data);
        assert!(err < 1e-5, "seed {seed}: held-out error {err:e}");
        eprintln!(
            "seed {seed}: {:.2e} -> {:.2e} ({restarted} restart iterations)",
            error(&without.model, &data),
            err
        );
    }
}

/// With noise the restart still leaves the local minimum, down to the
/// noise floor; a run that converged never restarts.
#[test]
fn noisy_runs_restart_to_the_noise_floor_and_converged_runs_never_restart() {
    let data = data(1, 1e-3);
    let with = identify::<PositionFriction>(&data.train, &IdentifyConfig::default()).unwrap();
    assert!(with.history.iterations.iter().any(|r| r.restart));
    let err = error(&with.model, &data);
    assert!(err < 2e-3, "held-out error {err:e}");

    let exact = self::data(3, 0.0);
    let truth = Model::<PositionFriction>::reference().unwrap();
    let from_truth = identify::<PositionFriction>(
        &exact.train,
        &IdentifyConfig {
            initial_entropy: Some(truth.entropy_coefficients().to_vec()),
            initial_metric: Some(truth.metric_coefficients().to_vec()),
            ..IdentifyConfig::default()
        },
    )
    .unwrap();
    assert_eq!(from_truth.stop_reason, StopReason::Converged);
    assert!(!from_truth.history.iterations.iter().any(|r| r.restart));
}

/// A run interrupted before its restart, or after it, resumes to
/// the uninterrupted run's result: the restart is decided from the run's
/// state alone.
#[test]
fn a_restarted_run_resumes_as_it_would_have_continued() {
    let dir = scratch_dir("local-minima", "resume");
    let path = dir.join("checkpoint.json");
    let data = data(1, 0.0);
    let config = IdentifyConfig {
        checkpoint: Some(CheckpointConfig {
            path: path.clone(),
            every: 1,
        }),
        ..IdentifyConfig::default()
    };
    let whole = identify::<PositionFriction>(&data.train, &config).unwrap();
    let first_restart = whole
        .history
        .iterations
        .iter()
        .position(|r| r.restart)
        .expect("a restart")
        + 1;
    for stop_at in [first_restart - 2, first_restart + 2] {
        let stopped =
            identify_with_observer::<PositionFriction, _>(&data.train, &config, |record, _| {
                if record.iteration == stop_at {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            })
            .unwrap();
        assert_eq!(stopped.stop_reason, StopReason::Interrupted, "at {stop_at}");
        let resumed = identify_resume::<PositionFriction>(&path, &data.train, &config).unwrap();
        assert_eq!(resumed.stop_reason, whole.stop_reason, "at {stop_at}");
        assert_eq!(
            without_timings(&resumed.history),
            without_timings(&whole.history),
            "at {stop_at}"
        );
        assert_eq!(resumed.model, whole.model, "at {stop_at}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
