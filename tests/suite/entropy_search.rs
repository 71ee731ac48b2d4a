//! Entropy search alone (metric fixed to the truth K = I) recovers the true
//! entropy of both paper systems from noise-free data.

use crate::common::*;
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{entropy_search, SearchOptions, SolveStatus};

fn recovers_reference_entropy<S: MetriplecticSystem>(data: &Dataset) {
    let options = SearchOptions::default();
    let fit = entropy_search::<S>(data, &identity_metric::<S>(1.0), &options).unwrap();
    let truth = S::REFERENCE_ENTROPY.unwrap();
    let error = max_abs_difference(&fit.coefficients, truth);
    let cost = fit.report.cost.unwrap();
    let mean_speed =
        data.derivatives().iter().map(|v| v.abs()).sum::<f64>() / data.derivatives().len() as f64;
    eprintln!(
        "{}: {} samples, {} coefficients, status {}, {} IPM iterations, \
         assembly {:.3}s, solver {:.3}s, max |ψ − ψ_true| = {error:.2e}, \
         mean |residual| = {:.2e} (mean |ẋ| = {mean_speed:.2e})",
        S::NAME,
        data.len(),
        truth.len(),
        fit.report.status,
        fit.report.iterations,
        fit.report.assembly_seconds,
        fit.report.solver_seconds,
        cost.per_component,
    );
    assert_eq!(fit.report.status, SolveStatus::Solved);
    assert!(
        error <= 1e-6 * options.eta_for::<S>(),
        "max coefficient error {error:.3e}"
    );
    assert!(
        cost.per_component <= 1e-8 * mean_speed,
        "mean residual {:.3e}",
        cost.per_component
    );
}

#[test]
fn linear2d_entropy_is_recovered_with_the_true_metric() {
    recovers_reference_entropy::<Linear2d>(&linear2d_data(300, 1));
}

#[test]
fn rigid_body_entropy_is_recovered_with_the_true_metric() {
    recovers_reference_entropy::<RigidBody>(&rigid_body_data(300, 2));
}
