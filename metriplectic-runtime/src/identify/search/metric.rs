//! Metric search (the paper's Problem 2): the L1 fit of the metric
//! coefficients θ with the entropy fixed, under sum-of-squares constraints
//! that make 0 ⪯ K(x) ⪯ ηI hold for every x (see [`super::sos`]).

use super::centre::centred_metric_regression;
use super::sos::{add_metric_restrictions, add_sos_constraints, layout, SosConstraints};
use super::{check_sample_rows, SearchOptions, SearchReport};
use crate::data::check_dataset;
use crate::data::IdentificationData;
use crate::error::{check_finite, check_len, Result};
use crate::identify::cost::model_cost;
use crate::model::{theta_from_gram, GramCertificate, Model};
use crate::solve::{solve_l1, L1Problem, Regression};
use crate::system::MetriplecticSystem;

/// Result of a metric search.
#[derive(Debug, Clone, PartialEq)]
pub struct MetricSearch {
    /// Metric coefficients θ, recomputed from the lower Gram matrices of
    /// `certificate` through the matching tables. Meaningful only if
    /// `report.status` is usable.
    pub coefficients: Vec<f64>,
    /// The Gram matrices proving 0 ⪯ K and K ⪯ ηI (everywhere, or on the
    /// system's region), one per block of the system's certificate.
    pub certificate: GramCertificate,
    /// Status, timings and the recomputed cost of `coefficients`.
    pub report: SearchReport,
}

/// Fits the metric coefficients θ to `data` with the entropy coefficients ψ
/// (`entropy`) held fixed, under the SOS constraints 0 ⪯ K(x) ⪯ ηI: for
/// every x, or, for a system that declares a region, K(x) ⪯ ηI on the
/// region and K(x) ⪰ 0 everywhere or on the region as its certificate mode
/// says.
///
/// Errors on invalid input; solver trouble is reported in
/// [`SearchReport::status`], not as an error.
///
/// With g = ∇H + ∇S the residual ẋ − Π g − K(x; θ) g is linear in θ. By
/// default the facially reduced tables [`MetriplecticSystem::SOS_REDUCED`]
/// are used: the full tables describe a program without a strictly feasible
/// point, which interior-point solvers handle badly.
///
/// The returned θ is recomputed from the solver's lower Gram matrices
/// (taken from the cone slacks, which lie in the PSD cones), so the lower
/// certificate holds on the metric basis exactly and K(x) ⪰ 0 up to
/// rounding whatever the solver's feasibility tolerance (for a region far
/// from the origin, up to the rounding of converting θ from the centred
/// coordinates the certificate is in). For a classical
/// system the rows K(x)∇H(x) ≡ 0 are imposed too, and θ is projected onto
/// them (a change of the size of the solver's equality residual).
pub fn metric_search<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    entropy: &[f64],
    options: &SearchOptions,
) -> Result<MetricSearch> {
    check_dataset::<S>(data)?;
    check_len(
        "entropy coefficients",
        entropy,
        S::entropy_coefficient_count(),
    )?;
    check_finite("entropy coefficients", entropy)?;
    options.validate_for::<S>()?;
    let layout = layout::<S>(options.sos)?;

    let start = std::time::Instant::now();
    let theta_len = S::metric_coefficient_count();
    // A region far from the origin: θ in the centred coordinates.
    let regression = match layout.shift() {
        Some(shift) => centred_metric_regression::<S>(shift, data, entropy)?,
        None => metric_regression::<S>(data, entropy)?,
    };
    let mut problem = L1Problem::new(regression, SosConstraints::variables::<S>(&layout));
    let sos =
        add_sos_constraints::<S>(&mut problem, &layout, options.eta_for::<S>(), 0, theta_len)?;
    let degenerate = add_metric_restrictions::<S>(&mut problem, &layout, options, 0)?;
    let build_seconds = start.elapsed().as_secs_f64();
    let solution = solve_l1(&problem, &options.solver)?;

    let certificate = sos.certificate(&solution);
    let mut coefficients = theta_from_gram::<S>(&layout, &certificate.lower);
    degenerate.project_coefficients(&mut coefficients);
    options.support.zero_held_metric(&mut coefficients);
    let cost = Model::<S>::new(entropy.to_vec(), coefficients.clone())
        .ok()
        .and_then(|model| model_cost(&model, data).ok());
    Ok(MetricSearch {
        coefficients,
        certificate,
        report: SearchReport::new(&solution, build_seconds, cost),
    })
}

/// The dense rows of θ ↦ K(x; θ) g and targets ẋ − Π g of every sample;
/// errors name the first sample whose rows overflow.
pub(crate) fn metric_regression<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    entropy: &[f64],
) -> Result<Regression> {
    let n = S::DIM;
    let width = S::metric_coefficient_count();
    let (rows, target) = data.equations().assemble(
        width,
        || (vec![0.0; n], vec![0.0; n]),
        |(gradient, grad_h), j, x, block, drift| {
            S::entropy_gradient(x, entropy, gradient);
            S::hamiltonian_gradient(x, grad_h);
            gradient
                .iter_mut()
                .zip(grad_h.iter())
                .for_each(|(g, h)| *g += h);
            S::metric_block(x, gradient, block, drift);
            check_sample_rows(j, x, block, drift)
        },
    )?;
    Ok(Regression {
        width,
        rows,
        target,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::search::SosBasis;
    use crate::model::identity_metric;
    use crate::test_system::{reference_data, Quadratic2d};
    use crate::SolveStatus;

    fn max_error(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn reduced_tables_recover_the_identity_metric() {
        let data = reference_data(40, 4);
        let entropy = Quadratic2d::REFERENCE_ENTROPY.unwrap();
        let fit = metric_search::<Quadratic2d>(&data, entropy, &SearchOptions::default()).unwrap();
        assert_eq!(fit.report.status, SolveStatus::Solved);
        let error = max_error(&fit.coefficients, &identity_metric::<Quadratic2d>(1.0));
        assert!(error < 1e-7, "max θ error {error}");
        assert!(fit.report.cost.unwrap().per_component < 1e-7);
        assert_eq!(fit.certificate.lower[0].size, 2);
    }

    #[test]
    fn full_tables_reach_the_same_metric() {
        let data = reference_data(40, 5);
        let entropy = Quadratic2d::REFERENCE_ENTROPY.unwrap();
        let options = SearchOptions {
            sos: SosBasis::Full,
            ..SearchOptions::default()
        };
        let fit = metric_search::<Quadratic2d>(&data, entropy, &options).unwrap();
        let error = max_error(&fit.coefficients, &identity_metric::<Quadratic2d>(1.0));
        eprintln!(
            "full SOS tables: status {:?}, {} iterations, max θ error {error:.2e}",
            fit.report.status, fit.report.iterations
        );
        assert!(fit.report.status.is_usable());
        assert!(error < 1e-6, "max θ error {error}");
        assert_eq!(fit.certificate.lower[0].size, 6);
    }
}
