//! Ill-posed and failing subproblems: the identifier keeps the best iterate,
//! records every outcome, and stops with a typed error only when no step
//! could ever be taken.

use std::ops::ControlFlow;

use crate::common::*;
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    identify, identify_with_observer, model_cost, History, IdentifyConfig, SearchOptions,
    SolveStatus, SolverSettings, StepOutcome, StopReason,
};

/// Theorem 1 on the full batch, checked from the records.
fn assert_non_increasing(history: &History) {
    let mut previous = f64::INFINITY;
    for r in &history.iterations {
        for cost in [
            r.cost_before.sum,
            r.metric.cost_after.sum,
            r.entropy.cost_after.sum,
        ] {
            assert!(
                cost <= previous,
                "iteration {}: {previous:e} -> {cost:e}",
                r.iteration
            );
            previous = cost;
        }
    }
}

fn statuses(history: &History) -> Vec<(SolveStatus, SolveStatus)> {
    history
        .iterations
        .iter()
        .map(|r| (r.metric.report.status, r.entropy.report.status))
        .collect()
}

#[test]
fn eta_too_small_for_the_truth_gives_the_best_fit_within_the_bound() {
    // The true entropy has a coefficient 16; with η = 1 it is outside the
    // feasible set. Both subproblems stay feasible (ψ = 0, K = 0 are inside),
    // so the run goes on, keeps |ψ| ≤ η, and cannot fit the data.
    let data = linear2d_data(40, 31);
    let config = IdentifyConfig {
        search: SearchOptions {
            eta: Some(1.0),
            ..SearchOptions::default()
        },
        max_iterations: 3,
        tolerance: 1e-9,
        ..alternation()
    };
    let result = identify::<Linear2d>(&data, &config).unwrap();
    eprintln!("eta = 1: statuses {:?}", statuses(&result.history));
    assert_eq!(result.stop_reason, StopReason::MaxIterations);
    assert_non_increasing(&result.history);
    let largest = result
        .model
        .entropy_coefficients()
        .iter()
        .fold(0.0_f64, |m, c| m.max(c.abs()));
    assert!(largest <= 1.0 + 1e-6, "|ψ| reached {largest}");
    let cost = model_cost(&result.model, &data).unwrap();
    assert!(cost.per_component > 1e-2, "{cost:?}");
    assert!(result
        .history
        .iterations
        .iter()
        .any(|r| r.metric.outcome == StepOutcome::Accepted
            || r.entropy.outcome == StepOutcome::Accepted));
}

#[test]
fn rank_deficient_data_is_solved_or_recorded_never_a_panic() {
    let truth = Model::<Linear2d>::reference().unwrap();
    let exact = |states: Vec<[f64; 2]>| exact_dataset(&truth, &states);
    let cases = [
        ("one state repeated", exact(vec![[0.4, -0.7]; 20])),
        (
            "states on the line p = 0",
            exact((0..20).map(|i| [-1.0 + 0.1 * i as f64, 0.0]).collect()),
        ),
        ("a single sample", exact(vec![[0.3, 0.2]])),
    ];
    for (name, data) in cases {
        let config = IdentifyConfig {
            max_iterations: 3,
            tolerance: 1e-9,
            ..alternation()
        };
        let result = identify::<Linear2d>(&data, &config).unwrap_or_else(|e| panic!("{name}: {e}"));
        eprintln!(
            "{name}: {:?}, statuses {:?}",
            result.stop_reason,
            statuses(&result.history)
        );
        assert_non_increasing(&result.history);
        // Few independent equations: many models fit the data, and the
        // degenerate entropy LP may end in a numerical error. Whatever the
        // status, it is recorded, a failed step is never accepted, and the
        // result is no worse than the start.
        for r in &result.history.iterations {
            for step in [&r.metric, &r.entropy] {
                if !step.report.status.is_usable() {
                    assert_eq!(step.outcome, StepOutcome::RejectedFailed, "{name}");
                }
            }
        }
        let start = result.history.iterations[0].cost_before.sum;
        let cost = model_cost(&result.model, &data).unwrap();
        assert!(cost.sum <= start, "{name}: {start:e} -> {:e}", cost.sum);
        eprintln!("{name}: cost {start:e} -> {:e}", cost.sum);
    }
}

#[test]
fn zero_derivatives_are_fitted_by_a_model_without_motion() {
    // ẋ = 0 everywhere: the only consistent models have ∇E in the kernel of
    // Π + K on the data (e.g. K = 0 and ψ = −∇H-matching); the identifier
    // must reach zero cost, not a solver failure.
    let moving = linear2d_data(30, 32);
    let data = Dataset::from_flat(2, moving.states().to_vec(), vec![0.0; 60]).unwrap();
    let config = IdentifyConfig {
        max_iterations: 5,
        tolerance: 1e-7,
        ..alternation()
    };
    let result = identify::<Linear2d>(&data, &config).unwrap();
    eprintln!(
        "xdot = 0: {:?}, statuses {:?}",
        result.stop_reason,
        statuses(&result.history)
    );
    assert_eq!(result.stop_reason, StopReason::Converged);
    assert!(model_cost(&result.model, &data).unwrap().per_component <= 1e-7);
}

#[test]
fn solver_that_never_succeeds_is_a_typed_error_after_the_allowed_failures() {
    let data = rigid_body_data(30, 33);
    for (max_iter, failures) in [(1, 2), (2, 3)] {
        let config = IdentifyConfig {
            search: SearchOptions {
                solver: SolverSettings {
                    max_iter,
                    ..SolverSettings::default()
                },
                ..SearchOptions::default()
            },
            max_failed_iterations: failures,
            ..alternation()
        };
        let mut seen = Vec::new();
        let err = identify_with_observer::<RigidBody, _>(&data, &config, |record, _| {
            seen.push((
                record.metric.report.status,
                record.metric.outcome,
                record.entropy.report.status,
                record.entropy.outcome,
            ));
            ControlFlow::Continue(())
        })
        .unwrap_err();
        assert!(
            matches!(err, Error::IdentificationFailed { iterations, .. } if iterations == failures),
            "{err}"
        );
        assert!(err.to_string().contains("max_iterations"), "{err}");
        assert_eq!(seen.len(), failures);
        for (metric_status, metric, entropy_status, entropy) in seen {
            assert_eq!(metric_status, SolveStatus::MaxIterations);
            assert_eq!(entropy_status, SolveStatus::MaxIterations);
            assert_eq!(metric, StepOutcome::RejectedFailed);
            assert_eq!(entropy, StepOutcome::RejectedFailed);
        }
    }
}

#[test]
fn overflowing_magnitudes_never_produce_a_model_worse_than_the_start() {
    // States of 1e40 overflow the degree-8 entropy basis (1e320 = inf): the
    // candidate costs are not finite, every step is rejected as failed, and
    // no model is ever accepted, so the run ends in a typed error.
    let data = Dataset::from_flat(2, vec![1e40, -1e40, 2e40, 1e39], vec![1.0; 4]).unwrap();
    let config = IdentifyConfig {
        max_iterations: 3,
        ..alternation()
    };
    match identify::<Linear2d>(&data, &config) {
        Err(err) => {
            eprintln!("1e40 states: {err}");
            assert!(
                matches!(
                    err,
                    Error::IdentificationFailed { .. }
                        | Error::NonFinite { .. }
                        | Error::InvalidArgument { .. }
                        | Error::Solver { .. }
                ),
                "{err}"
            );
        }
        Ok(result) => {
            eprintln!(
                "1e40 states: {:?} {:?}",
                result.stop_reason,
                statuses(&result.history)
            );
            for r in &result.history.iterations {
                for step in [&r.metric, &r.entropy] {
                    if step.outcome == StepOutcome::Accepted {
                        assert!(step.cost_after.is_finite(), "accepted a non-finite cost");
                    }
                }
            }
            let coefficients = result
                .model
                .entropy_coefficients()
                .iter()
                .chain(result.model.metric_coefficients());
            assert!(coefficients.into_iter().all(|c| c.is_finite()));
        }
    }
}
