//! Entropy search (the paper's Problem 3): the L1 linear program in ψ with
//! the metric K fixed.
//!
//! With M = Π(x) + K(x) the residual of sample i is
//! rᵢ(ψ) = ẋᵢ − M ∇H(xᵢ) − M J(xᵢ)ᵀ ψ, linear in ψ; the program is
//!
//! ```text
//! min Σᵢ ‖rᵢ(ψ)‖₁   s.t.  −η ≤ ψ ≤ η,
//! ```
//!
//! assembled from the system's per-sample [`entropy_block`](MetriplecticSystem::entropy_block)
//! and solved by the configured backend (see [`crate::conic`]).

use clarabel::solver::SupportedConeT;
use serde::{Deserialize, Serialize};

use crate::conic::{
    solve_l1, ConstraintGroup, L1Formulation, Regression, SolveReport, SolverSettings,
};
use crate::cost::{check_dataset, model_cost};
use crate::dataset::Dataset;
use crate::error::{check_finite, check_len, Error, Result};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// Options of one entropy search.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EntropySearchOptions {
    /// Box bound η: every entropy coefficient satisfies |ψₖ| ≤ η.
    pub eta: f64,
    /// How the L1 objective is written for Clarabel (Clarabel backend only).
    pub formulation: L1Formulation,
    /// Solver settings, including the backend.
    pub solver: SolverSettings,
}

impl Default for EntropySearchOptions {
    fn default() -> Self {
        Self {
            eta: 20.0,
            formulation: L1Formulation::default(),
            solver: SolverSettings::default(),
        }
    }
}

/// Result of an entropy search.
#[derive(Debug, Clone, PartialEq)]
pub struct EntropySearch {
    /// The entropy coefficients ψ returned by the solver, clipped to the box
    /// [−η, η] (interior-point solutions may overshoot it by the tolerance).
    /// Meaningful only if `report.status` is usable.
    pub coefficients: Vec<f64>,
    /// Status, timings and the recomputed cost of `coefficients`.
    pub report: SolveReport,
}

/// Validates η: finite and positive.
pub(crate) fn check_eta(eta: f64) -> Result<()> {
    if eta.is_finite() && eta > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidArgument {
            what: "eta (coefficient bound)".to_owned(),
            reason: format!("{eta} is not a finite positive number"),
        })
    }
}

/// Fits the entropy coefficients ψ to `data` with the metric coefficients θ
/// (`metric`) held fixed.
///
/// Errors on invalid input (dimension, lengths, non-finite θ, η ≤ 0) or if
/// the assembled problem is rejected by the solver. Solver trouble (infeasible,
/// iteration limit, numerical error) is *not* an error: it is reported in
/// [`SolveReport::status`].
pub fn entropy_search<S: MetriplecticSystem>(
    data: &Dataset,
    metric: &[f64],
    options: &EntropySearchOptions,
) -> Result<EntropySearch> {
    check_dataset::<S>(data)?;
    check_len("metric coefficients", metric, S::metric_coefficient_count())?;
    check_finite("metric coefficients", metric)?;
    check_eta(options.eta)?;
    options.solver.validate()?;

    let n = S::DIM;
    let p = S::entropy_coefficient_count();
    let start = std::time::Instant::now();
    let regression = entropy_regression::<S>(data, metric);
    let build_seconds = start.elapsed().as_secs_f64();

    // Box rows: ψₖ ≤ η and −ψₖ ≤ η.
    let mut entries = Vec::with_capacity(2 * p);
    for k in 0..p {
        entries.push((k, k, 1.0));
        entries.push((p + k, k, -1.0));
    }
    let bounds = ConstraintGroup {
        cone: SupportedConeT::NonnegativeConeT(2 * p),
        entries,
        rhs: vec![options.eta; 2 * p],
    };
    let outcome = solve_l1(
        &regression,
        0,
        &[bounds],
        options.formulation,
        &options.solver,
    )?;

    let coefficients: Vec<f64> = outcome
        .x
        .iter()
        .map(|&v| v.clamp(-options.eta, options.eta))
        .collect();
    let cost = Model::<S>::new(coefficients.clone(), metric.to_vec())
        .ok()
        .and_then(|model| model_cost(&model, data).ok());
    debug_assert_eq!(regression.len(), data.len() * n);
    Ok(EntropySearch {
        coefficients,
        report: SolveReport {
            status: outcome.status,
            iterations: outcome.iterations,
            assembly_seconds: build_seconds + outcome.assembly_seconds,
            solver_seconds: outcome.solver_seconds,
            cost,
        },
    })
}

/// The dense rows M J(x)ᵀ and targets ẋ − M ∇H(x) of every sample.
pub(crate) fn entropy_regression<S: MetriplecticSystem>(
    data: &Dataset,
    metric: &[f64],
) -> Regression {
    let n = S::DIM;
    let p = S::entropy_coefficient_count();
    let mut rows = vec![0.0; data.len() * n * p];
    let mut target = vec![0.0; data.len() * n];
    let mut k = vec![0.0; n * n];
    let mut drift = vec![0.0; n];
    for (i, (x, xdot)) in data.iter().enumerate() {
        S::metric_value(x, metric, &mut k);
        S::entropy_block(x, &k, &mut rows[i * n * p..(i + 1) * n * p], &mut drift);
        for j in 0..n {
            target[i * n + j] = xdot[j] - drift[j];
        }
    }
    Regression {
        width: p,
        rows,
        target,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conic::SolverBackend;
    use crate::model::identity_metric;
    use crate::test_system::{reference_data, Quadratic2d};

    #[test]
    fn recovers_the_reference_entropy_with_zero_cost() {
        let data = reference_data(40, 1);
        let truth = Quadratic2d::REFERENCE_ENTROPY.unwrap();
        for (backend, formulation) in [
            (SolverBackend::Clarabel, L1Formulation::Slack),
            (SolverBackend::Clarabel, L1Formulation::ExplicitResidual),
            (SolverBackend::Clarabel, L1Formulation::Split),
            (SolverBackend::Dense, L1Formulation::Split),
        ] {
            let options = EntropySearchOptions {
                formulation,
                solver: SolverSettings {
                    backend,
                    ..SolverSettings::default()
                },
                ..EntropySearchOptions::default()
            };
            let fit = entropy_search::<Quadratic2d>(
                &data,
                &identity_metric::<Quadratic2d>(1.0),
                &options,
            )
            .unwrap();
            assert_eq!(fit.report.status, crate::conic::SolveStatus::Solved);
            let error = fit
                .coefficients
                .iter()
                .zip(truth)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let cost = fit.report.cost.unwrap();
            assert!(
                error < 1e-7,
                "{backend:?} {formulation:?}: max coefficient error {error}"
            );
            assert!(
                cost.per_component < 1e-7,
                "{backend:?} {formulation:?}: {cost:?}"
            );
        }
    }

    #[test]
    fn box_bound_is_enforced() {
        // With η below the largest true coefficient (0.8) the fit must clip.
        let data = reference_data(30, 2);
        let options = EntropySearchOptions {
            eta: 0.5,
            ..EntropySearchOptions::default()
        };
        let fit =
            entropy_search::<Quadratic2d>(&data, &identity_metric::<Quadratic2d>(1.0), &options)
                .unwrap();
        assert!(fit.coefficients.iter().all(|c| c.abs() <= 0.5));
        assert!(fit.report.cost.unwrap().sum > 1e-3);
    }

    #[test]
    fn rejects_bad_input() {
        let data = reference_data(5, 3);
        let metric = identity_metric::<Quadratic2d>(1.0);
        for eta in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let options = EntropySearchOptions {
                eta,
                ..EntropySearchOptions::default()
            };
            assert!(matches!(
                entropy_search::<Quadratic2d>(&data, &metric, &options),
                Err(Error::InvalidArgument { .. })
            ));
        }
        let options = EntropySearchOptions::default();
        assert!(matches!(
            entropy_search::<Quadratic2d>(&data, &metric[1..], &options),
            Err(Error::DimensionMismatch { .. })
        ));
        let wrong_dim = Dataset::from_flat(3, vec![0.0; 3], vec![0.0; 3]).unwrap();
        assert!(matches!(
            entropy_search::<Quadratic2d>(&wrong_dim, &metric, &options),
            Err(Error::DimensionMismatch { .. })
        ));
    }
}
