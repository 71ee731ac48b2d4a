//! Metric search alone (entropy fixed to the truth) recovers K = I for both
//! paper systems; the returned K(x) is PSD and equals Z(x)ᵀ Q₁ Z(x).

use crate::common::*;
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{metric_search, MetricSearch, SearchOptions, SolveStatus, SosBasis};
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Checks the Gram certificate (its identities only if `exact`: the full
/// tables' program has no strictly feasible point and ends inexact) and
/// K(x) ⪯ ηI at random points; returns the smallest eigenvalue of K(x) seen.
fn check_certificate<S: MetriplecticSystem>(
    fit: &MetricSearch,
    eta: f64,
    seed: u64,
    exact: bool,
) -> f64 {
    let n = S::DIM;
    let model = Model::<S>::new(
        S::REFERENCE_ENTROPY.unwrap().to_vec(),
        fit.coefficients.clone(),
    )
    .unwrap();
    // The Gram matrices prove both bounds: identities exact, matrices PSD.
    let check = fit.certificate.check::<S>(&fit.coefficients).unwrap();
    assert!(!exact || check.identity_residual <= 1e-9, "{check:?}");
    assert!(check.smallest_eigenvalue >= -1e-12, "{check:?}");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut min_eigen = f64::INFINITY;
    let mut k = vec![0.0; n * n];
    for _ in 0..100 {
        let x: Vec<f64> = (0..n).map(|_| rng.random_range(-3.0..3.0)).collect();
        model.metric(&x, &mut k).unwrap();
        let eigen = DMatrix::from_row_slice(n, n, &k)
            .symmetric_eigen()
            .eigenvalues;
        min_eigen = min_eigen.min(eigen.min());
        assert!(
            eigen.max() <= eta * (1.0 + 1e-7),
            "K(x) exceeds ηI at {x:?}: {eigen}"
        );
    }
    min_eigen
}

fn recovers_identity<S: MetriplecticSystem>(data: &Dataset) {
    let options = SearchOptions::default();
    let fit = metric_search::<S>(data, S::REFERENCE_ENTROPY.unwrap(), &options).unwrap();
    let error = max_abs_difference(&fit.coefficients, &identity_metric::<S>(1.0));
    let cost = fit.report.cost.unwrap();
    let min_eigen = check_certificate::<S>(&fit, options.eta_for::<S>(), 5, true);
    eprintln!(
        "{}: status {}, {} IPM iterations, assembly {:.3}s, solver {:.3}s, \
         max |θ − θ_true| = {error:.2e}, mean |residual| = {:.2e}, min eig K(x) = {min_eigen:.3e}",
        S::NAME,
        fit.report.status,
        fit.report.iterations,
        fit.report.assembly_seconds,
        fit.report.solver_seconds,
        cost.per_component
    );
    assert_eq!(fit.report.status, SolveStatus::Solved);
    assert!(error <= 1e-6, "max θ error {error:.3e}");
    assert!(min_eigen >= -1e-12, "K(x) not PSD: {min_eigen:e}");
}

#[test]
fn linear2d_metric_is_recovered_with_the_true_entropy() {
    recovers_identity::<Linear2d>(&linear2d_data(300, 3));
}

#[test]
fn rigid_body_metric_is_recovered_with_the_true_entropy() {
    recovers_identity::<RigidBody>(&rigid_body_data(300, 4));
}

/// The full (not facially reduced) tables describe a program with no
/// strictly feasible point (docs/method.md §2). Record what Clarabel does with it
/// and check that whatever it returns is still a valid certificate.
fn full_tables<S: MetriplecticSystem>(data: &Dataset) {
    let options = SearchOptions {
        sos: SosBasis::Full,
        ..SearchOptions::default()
    };
    let fit = metric_search::<S>(data, S::REFERENCE_ENTROPY.unwrap(), &options).unwrap();
    let error = max_abs_difference(&fit.coefficients, &identity_metric::<S>(1.0));
    let min_eigen = check_certificate::<S>(&fit, options.eta_for::<S>(), 6, false);
    eprintln!(
        "{} full SOS tables (Gram {}×{}): status {}, {} IPM iterations, solver {:.3}s, \
         max |θ − θ_true| = {error:.2e}, min eig K(x) = {min_eigen:.3e}",
        S::NAME,
        fit.certificate.lower[0].size,
        fit.certificate.lower[0].size,
        fit.report.status,
        fit.report.iterations,
        fit.report.solver_seconds
    );
    assert!(
        fit.report.status.is_usable(),
        "status {}",
        fit.report.status
    );
    assert!(error <= 1e-4, "max θ error {error:.3e}");
}

#[test]
fn linear2d_full_sos_tables_reach_the_same_metric() {
    full_tables::<Linear2d>(&linear2d_data(300, 3));
}

#[test]
fn rigid_body_full_sos_tables_reach_the_same_metric() {
    full_tables::<RigidBody>(&rigid_body_data(300, 4));
}
