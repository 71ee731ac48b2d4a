//! Entropy search (the paper's Problem 3): the L1 linear program in ψ with
//! the metric K fixed.

use super::centre::{centred_entropy_regression, entropy_shift};
use super::{check_sample_rows, SearchOptions, SearchReport};
use crate::data::check_dataset;
use crate::data::IdentificationData;
use crate::error::{check_finite, check_len, Result};
use crate::identify::cost::model_cost;
use crate::model::classical::{self, Equalities};
use crate::model::Model;
use crate::solve::{solve_l1, Cone, L1Problem, Regression};
use crate::system::MetriplecticSystem;

/// Result of an entropy search.
#[derive(Debug, Clone, PartialEq)]
pub struct EntropySearch {
    /// The entropy coefficients ψ returned by the solver, clipped to the box
    /// [−η, η] (interior-point solutions may overshoot it by the tolerance).
    /// Meaningful only if `report.status` is usable.
    pub coefficients: Vec<f64>,
    /// Status, timings and the recomputed cost of `coefficients`.
    pub report: SearchReport,
}

/// Fits the entropy coefficients ψ to `data` with the metric coefficients θ
/// (`metric`) held fixed.
///
/// Errors on invalid input (dimension, lengths, non-finite θ, η ≤ 0).
/// Solver trouble (infeasible, iteration limit, numerical error) is *not*
/// an error: it is reported in [`SearchReport::status`].
///
/// With M = Π(x) + K(x) the residual of sample i is
/// rᵢ(ψ) = ẋᵢ − M ∇H(xᵢ) − M J(xᵢ)ᵀ ψ, linear in ψ; the program is
///
/// ```text
/// min Σᵢ ‖rᵢ(ψ)‖₁   s.t.  −η ≤ ψ ≤ η,
/// ```
///
/// and, for a classical system, C_S ψ = 0 (S a Casimir of Π; the
/// solution is projected onto these rows, so they hold to rounding).
///
/// assembled from the system's per-sample
/// [`entropy_block`](MetriplecticSystem::entropy_block).
///
/// Where the data of some state variable lie farther from zero than their
/// spread (a temperature of 300 ± 2 K), the same program is solved for the
/// coefficients of S in y = x − c, c the centre of the data, whose
/// monomials are not nearly collinear, and ψ is converted back
/// (`docs/method.md` §2, "States far from the origin").
pub fn entropy_search<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    metric: &[f64],
    options: &SearchOptions,
) -> Result<EntropySearch> {
    check_dataset::<S>(data)?;
    check_len("metric coefficients", metric, S::metric_coefficient_count())?;
    check_finite("metric coefficients", metric)?;
    options.validate_for::<S>()?;
    let eta = options.eta_for::<S>();

    let start = std::time::Instant::now();
    // Coefficients outside the support are columns left out.
    let free = options.support.free_entropy::<S>();
    // States far from the origin are searched in centred coordinates.
    let centre = entropy_shift::<S>(data, &free);
    let mut regression = match &centre {
        Some(shift) => centred_entropy_regression::<S>(shift, data, metric)?,
        None => entropy_regression::<S>(data, metric)?,
    };
    if free.len() < S::entropy_coefficient_count() {
        regression = regression.select_columns(&free);
    }
    let p = free.len();
    let mut problem = L1Problem::new(regression, 0);
    // Box rows: ψₖ ≤ η and −ψₖ ≤ η, on the coefficients in x.
    let mut entries = Vec::with_capacity(2 * p);
    for k in 0..p {
        entries.push((k, k, 1.0));
        entries.push((p + k, k, -1.0));
    }
    let in_searched = |entries| match &centre {
        Some(shift) => shift.rows(entries, 0, p),
        None => entries,
    };
    problem.constrain(
        Cone::Nonnegative(2 * p),
        in_searched(entries),
        vec![eta; 2 * p],
    )?;
    // The classical form: S a Casimir of Π.
    let casimir = Equalities::new(classical::entropy_rows::<S>(), &free);
    if !casimir.is_empty() {
        problem.constrain(
            Cone::Zero(casimir.len()),
            in_searched(casimir.entries(0)),
            vec![0.0; casimir.len()],
        )?;
    }
    let build_seconds = start.elapsed().as_secs_f64();
    let solution = solve_l1(&problem, &options.solver)?;

    let found = match &centre {
        Some(shift) => shift.to_original(solution.coefficients()),
        None => solution.coefficients().to_vec(),
    };
    let mut coefficients = vec![0.0; S::entropy_coefficient_count()];
    for (&k, &v) in free.iter().zip(&found) {
        coefficients[k] = v.clamp(-eta, eta);
    }
    casimir.project_coefficients(&mut coefficients);
    let cost = Model::<S>::new(coefficients.clone(), metric.to_vec())
        .ok()
        .and_then(|model| model_cost(&model, data).ok());
    Ok(EntropySearch {
        coefficients,
        report: SearchReport::new(&solution, build_seconds, cost),
    })
}

/// The dense rows M J(x)ᵀ and targets ẋ − M ∇H(x) of every sample; errors
/// name the first sample whose rows overflow.
pub(crate) fn entropy_regression<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    metric: &[f64],
) -> Result<Regression> {
    let n = S::DIM;
    let p = S::entropy_coefficient_count();
    let (rows, target) = data.equations().assemble(
        p,
        || vec![0.0; n * n],
        |k, j, x, block, drift| {
            S::metric_value(x, metric, k);
            S::entropy_block(x, k, block, drift);
            check_sample_rows(j, x, block, drift)
        },
    )?;
    Ok(Regression {
        width: p,
        rows,
        target,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;
    use crate::model::identity_metric;
    use crate::solve::tests::backends;
    use crate::test_system::{reference_data, Quadratic2d};
    use crate::{SolveStatus, SolverSettings};

    #[test]
    fn recovers_the_reference_entropy_with_zero_cost() {
        let data = reference_data(40, 1);
        let truth = Quadratic2d::REFERENCE_ENTROPY.unwrap();
        for backend in backends() {
            let options = SearchOptions {
                solver: SolverSettings {
                    backend,
                    ..SolverSettings::default()
                },
                ..SearchOptions::default()
            };
            let fit = entropy_search::<Quadratic2d>(
                &data,
                &identity_metric::<Quadratic2d>(1.0),
                &options,
            )
            .unwrap();
            assert_eq!(fit.report.status, SolveStatus::Solved);
            let error = fit
                .coefficients
                .iter()
                .zip(truth)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let cost = fit.report.cost.unwrap();
            assert!(error < 1e-7, "{backend:?}: max coefficient error {error}");
            assert!(cost.per_component < 1e-7, "{backend:?}: {cost:?}");
        }
    }

    #[test]
    fn box_bound_is_enforced() {
        // With η below the largest true coefficient (0.8) the fit must clip.
        let data = reference_data(30, 2);
        let options = SearchOptions {
            eta: Some(0.5),
            ..SearchOptions::default()
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
            let options = SearchOptions {
                eta: Some(eta),
                ..SearchOptions::default()
            };
            assert!(matches!(
                entropy_search::<Quadratic2d>(&data, &metric, &options),
                Err(Error::InvalidArgument { .. })
            ));
        }
        let options = SearchOptions::default();
        assert!(matches!(
            entropy_search::<Quadratic2d>(&data, &metric[1..], &options),
            Err(Error::DimensionMismatch { .. })
        ));
        let wrong_dim = crate::Dataset::from_flat(3, vec![0.0; 3], vec![0.0; 3]).unwrap();
        assert!(matches!(
            entropy_search::<Quadratic2d>(&wrong_dim, &metric, &options),
            Err(Error::DimensionMismatch { .. })
        ));
    }
}
