//! Bilevel identification (Algorithms 1 and 2) on the paper systems, and the
//! model file round trip.

mod common;

use common::paper_systems::*;
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{identify, identify_with_observer, History, IdentifyConfig};
use std::ops::ControlFlow;

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
                "iteration {}: cost rose from {previous:e} to {cost:e}",
                r.iteration
            );
            previous = cost;
        }
    }
}

#[test]
fn algorithm1_full_batch_cost_is_non_increasing() {
    let data = linear2d_data(200, 21);
    let config = IdentifyConfig {
        max_iterations: 8,
        tolerance: 0.0,
        initial_entropy: Some(perturbed_reference_entropy::<Linear2d>(0.5, 21)),
        ..IdentifyConfig::default()
    };
    let result = identify::<Linear2d>(&data, &config).unwrap();
    for r in &result.history.iterations {
        eprintln!(
            "iteration {}: {:.3e} -> metric {} {:?} {:.3e} -> entropy {} {:?} {:.3e}",
            r.iteration,
            r.cost_before.per_component,
            r.metric.report.status,
            r.metric.outcome,
            r.metric.cost_after.per_component,
            r.entropy.report.status,
            r.entropy.outcome,
            r.entropy.cost_after.per_component
        );
    }
    assert_eq!(result.history.iterations.len(), 8);
    assert_non_increasing(&result.history);
    let first = result.history.iterations[0].cost_before.sum;
    let last = result.history.iterations[7].entropy.cost_after.sum;
    assert!(last < first, "no progress: {first:e} -> {last:e}");
}

/// Algorithm 2 from the paper's start (truth + N(0, 0.5²) per coefficient).
///
/// Measured (see the report of issue 3): the held-out relative error falls
/// from ≈ 0.39 to ≈ 3e-3 within ~30 iterations and then crawls; the
/// alternation stalls at blockwise-optimal points with K ≠ I, far from the
/// paper's "loss ≈ 0". This test pins down the part that works (a > 100×
/// reduction, every solve `Solved`) and fails if it regresses.
#[test]
fn algorithm2_reduces_the_error_on_linear2d_from_the_paper_protocol() {
    let train = linear2d_data(2000, 22);
    let held_out = linear2d_data(500, 23);
    let start = perturbed_reference_entropy::<Linear2d>(0.5, 22);
    let truth = Linear2d::REFERENCE_ENTROPY.unwrap();
    let config = IdentifyConfig {
        batch_size: Some(200),
        max_iterations: 40,
        tolerance: 1e-10,
        seed: 22,
        initial_entropy: Some(start.clone()),
        ..IdentifyConfig::default()
    };
    let initial = Model::<Linear2d>::with_identity_metric(start.clone()).unwrap();
    let initial_error = relative_error(&initial, &held_out);
    let result = identify_with_observer::<Linear2d, _>(&train, &config, |r, model| {
        eprintln!(
            "iteration {}: batch cost {:.3e} -> {:.3e}, held-out relative error {:.3e}, \
             max |ψ − ψ_true| {:.3e}",
            r.iteration,
            r.cost_before.per_component,
            r.entropy.cost_after.per_component,
            relative_error(model, &held_out),
            max_abs_difference(model.entropy_coefficients(), truth)
        );
        ControlFlow::Continue(())
    })
    .unwrap();
    let final_error = relative_error(&result.model, &held_out);
    eprintln!(
        "stopped: {:?} after {} iterations; held-out relative error {initial_error:.3e} -> {final_error:.3e}; \
         statuses {:?}",
        result.stop_reason,
        result.history.iterations.len(),
        result.history.status_counts()
    );
    assert!(
        final_error < 1e-2 * initial_error,
        "{initial_error:e} -> {final_error:e}"
    );
    assert!(
        final_error < 5e-3,
        "held-out relative error {final_error:e}"
    );
    for (status, metric, entropy) in result.history.status_counts() {
        assert_eq!(
            status,
            metriplectic_runtime::SolveStatus::Solved,
            "{metric} metric and {entropy} entropy solves ended {status}"
        );
    }
}

#[test]
fn model_file_round_trips_and_rejects_the_wrong_system() {
    let model = Model::<RigidBody>::reference().unwrap();
    let json = model.to_json().unwrap();
    assert_eq!(Model::<RigidBody>::from_json(&json).unwrap(), model);
    let err = Model::<Linear2d>::from_json(&json).unwrap_err();
    let message = err.to_string();
    assert!(matches!(err, Error::WrongSystem { .. }), "{message}");
    assert!(
        message.contains("Linear2d") && message.contains("RigidBody"),
        "{message}"
    );
}
