//! Metric search (the paper's Problem 2): the L1 fit of the metric
//! coefficients θ with the entropy fixed, under sum-of-squares constraints
//! that make 0 ⪯ K(x) ⪯ ηI hold for every x.
//!
//! With g = ∇H + ∇S the residual ẋ − Π g − K(x; θ) g is linear in θ. With
//! Z(x) = I ⊗ m(x) over the SOS basis m, the constraints are
//!
//! ```text
//! θⱼₖ,α                  = Σ_{(β,γ) ∈ matching[α]} Q₁[(j,β),(k,γ)],   Q₁ ⪰ 0,
//! η·[j=k]·[α=0] − θⱼₖ,α  = Σ_{(β,γ) ∈ matching[α]} Q₂[(j,β),(k,γ)],   Q₂ ⪰ 0,
//! ```
//!
//! with Q₁, Q₂ in Clarabel's PSD cone (svec layout, see [`crate::conic::svec`]).
//! By default the facially reduced tables [`MetriplecticSystem::SOS_REDUCED`]
//! are used: the full tables describe a program without a strictly feasible
//! point (DESIGN.md §2), which interior-point solvers handle badly.
//!
//! The returned θ is recomputed from the solver's Q₁ (taken from the cone
//! slack, which lies in the PSD cone), so K(x) = Z(x)ᵀ Q₁ Z(x) holds exactly
//! and K(x) ⪰ 0 up to rounding whatever the solver's feasibility tolerance.

use clarabel::solver::SupportedConeT;
use serde::{Deserialize, Serialize};

use crate::conic::{
    solve_l1, svec_index, svec_len, unsvec, ConstraintGroup, L1Formulation, Regression,
    SolveReport, SolverSettings, SQRT_2,
};
use crate::cost::{check_dataset, model_cost};
use crate::dataset::Dataset;
use crate::entropy_search::check_eta;
use crate::error::{check_finite, check_len, Error, Result};
use crate::model::Model;
use crate::system::{metric_pair_index, MetriplecticSystem, SosTables};

/// Which SOS coefficient-matching tables the metric search uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum SosBasis {
    /// [`MetriplecticSystem::SOS_REDUCED`]: facially reduced, strictly feasible.
    #[default]
    Reduced,
    /// [`MetriplecticSystem::SOS_FULL`]: the full half-degree basis. The
    /// two-sided program then has no strictly feasible point.
    Full,
}

impl SosBasis {
    /// The tables of system `S` this choice selects.
    pub fn tables<S: MetriplecticSystem>(self) -> SosTables {
        match self {
            Self::Reduced => S::SOS_REDUCED,
            Self::Full => S::SOS_FULL,
        }
    }
}

/// Options of one metric search.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MetricSearchOptions {
    /// Upper bound: K(x) ⪯ ηI.
    pub eta: f64,
    /// How the L1 objective is written for Clarabel (Clarabel backend only).
    pub formulation: L1Formulation,
    /// Which SOS tables to use.
    pub sos: SosBasis,
    /// Solver settings, including the backend.
    pub solver: SolverSettings,
}

impl Default for MetricSearchOptions {
    fn default() -> Self {
        Self {
            eta: 20.0,
            formulation: L1Formulation::default(),
            sos: SosBasis::default(),
            solver: SolverSettings::default(),
        }
    }
}

/// Result of a metric search.
#[derive(Debug, Clone, PartialEq)]
pub struct MetricSearch {
    /// Metric coefficients θ, recomputed from `gram` through the matching
    /// tables. Meaningful only if `report.status` is usable.
    pub coefficients: Vec<f64>,
    /// Side N = n·|m| of the Gram matrices, m the SOS basis.
    pub gram_size: usize,
    /// Q₁ (row-major N×N) with K(x) = Z(x)ᵀ Q₁ Z(x); rows/columns indexed by
    /// (j, β) ↦ j·|m| + β.
    pub gram: Vec<f64>,
    /// Q₂ (row-major N×N) certifying ηI − K(x) ⪰ 0.
    pub gram_upper: Vec<f64>,
    /// The SOS basis monomials m(x) used.
    pub sos_exponents: &'static [&'static [u32]],
    /// Status, timings and the recomputed cost of `coefficients`.
    pub report: SolveReport,
}

/// Fits the metric coefficients θ to `data` with the entropy coefficients ψ
/// (`entropy`) held fixed, under the SOS constraints 0 ⪯ K(x) ⪯ ηI.
///
/// Errors on invalid input or malformed tables; solver trouble is reported in
/// [`SolveReport::status`], not as an error.
pub fn metric_search<S: MetriplecticSystem>(
    data: &Dataset,
    entropy: &[f64],
    options: &MetricSearchOptions,
) -> Result<MetricSearch> {
    check_dataset::<S>(data)?;
    check_len(
        "entropy coefficients",
        entropy,
        S::entropy_coefficient_count(),
    )?;
    check_finite("entropy coefficients", entropy)?;
    check_eta(options.eta)?;
    options.solver.validate()?;
    let tables = options.sos.tables::<S>();
    check_tables::<S>(&tables)?;

    let start = std::time::Instant::now();
    let regression = metric_regression::<S>(data, entropy);
    let theta_len = S::metric_coefficient_count();
    let (groups, gram_size) = sos_groups::<S>(&tables, options.eta, 0, theta_len);
    let build_seconds = start.elapsed().as_secs_f64();

    let svec_size = svec_len(gram_size);
    let outcome = solve_l1(
        &regression,
        2 * svec_size,
        &groups,
        options.formulation,
        &options.solver,
    )?;

    // Q₁ and Q₂ from the PSD-cone slacks (groups 1 and 2), which lie in the cone.
    let gram = unsvec(gram_size, &outcome.group_slacks[1]);
    let gram_upper = unsvec(gram_size, &outcome.group_slacks[2]);
    let coefficients = theta_from_gram::<S>(&tables, &gram);
    debug_assert_eq!(coefficients.len(), theta_len);
    let cost = Model::<S>::new(entropy.to_vec(), coefficients.clone())
        .ok()
        .and_then(|model| model_cost(&model, data).ok());
    Ok(MetricSearch {
        coefficients,
        gram_size,
        gram,
        gram_upper,
        sos_exponents: tables.exponents,
        report: SolveReport {
            status: outcome.status,
            iterations: outcome.iterations,
            assembly_seconds: build_seconds + outcome.assembly_seconds,
            solver_seconds: outcome.solver_seconds,
            cost,
        },
    })
}

/// θⱼₖ,α = Σ_{(β,γ) ∈ matching[α]} Q[(j,β),(k,γ)] for a row-major Gram matrix Q.
pub fn theta_from_gram<S: MetriplecticSystem>(tables: &SosTables, gram: &[f64]) -> Vec<f64> {
    let n = S::DIM;
    let basis = S::METRIC_EXPONENTS.len();
    let m = tables.exponents.len();
    let size = n * m;
    let mut theta = vec![0.0; S::metric_coefficient_count()];
    for j in 0..n {
        for k in j..n {
            let pair = metric_pair_index(n, j, k);
            for (alpha, pairs) in tables.matching.iter().enumerate() {
                theta[pair * basis + alpha] = pairs
                    .iter()
                    .map(|&(beta, gamma)| {
                        gram[(j * m + beta as usize) * size + k * m + gamma as usize]
                    })
                    .sum();
            }
        }
    }
    theta
}

/// Errors unless the tables fit the system's metric basis.
pub(crate) fn check_tables<S: MetriplecticSystem>(tables: &SosTables) -> Result<()> {
    let bad = |reason: String| Error::InvalidArgument {
        what: format!("SOS tables of system `{}`", S::NAME),
        reason,
    };
    if tables.matching.len() != S::METRIC_EXPONENTS.len() {
        return Err(bad(format!(
            "{} matching lists for {} metric monomials",
            tables.matching.len(),
            S::METRIC_EXPONENTS.len()
        )));
    }
    let m = tables.exponents.len();
    if let Some(&(beta, gamma)) = tables
        .matching
        .iter()
        .flat_map(|pairs| pairs.iter())
        .find(|&&(b, g)| b as usize >= m || g as usize >= m)
    {
        return Err(bad(format!(
            "pair ({beta}, {gamma}) indexes past the {m} SOS basis monomials"
        )));
    }
    if constant_monomial::<S>().is_none() {
        return Err(bad("the metric basis has no constant monomial".to_owned()));
    }
    Ok(())
}

fn constant_monomial<S: MetriplecticSystem>() -> Option<usize> {
    S::METRIC_EXPONENTS
        .iter()
        .position(|e| e.iter().all(|&d| d == 0))
}

/// The zero-cone matching rows and the two PSD cones (groups 0, 1, 2), with
/// θ in the columns from `theta_column` and `[svec Q₁ | svec Q₂]` from
/// `gram_column`. Also returns the Gram side N.
pub(crate) fn sos_groups<S: MetriplecticSystem>(
    tables: &SosTables,
    eta: f64,
    theta_column: usize,
    gram_column: usize,
) -> (Vec<ConstraintGroup>, usize) {
    let n = S::DIM;
    let basis = S::METRIC_EXPONENTS.len();
    let m = tables.exponents.len();
    let size = n * m;
    let theta_len = S::metric_coefficient_count();
    let svec_size = svec_len(size);
    let q1 = gram_column;
    let q2 = gram_column + svec_size;
    let constant = constant_monomial::<S>().unwrap_or(0);

    // Rows 2t: θ_t − Σ Q₁ = 0 ; rows 2t+1: θ_t + Σ Q₂ = η[j=k][α=0].
    let mut entries = Vec::new();
    let mut rhs = vec![0.0; 2 * theta_len];
    for j in 0..n {
        for k in j..n {
            let pair = metric_pair_index(n, j, k);
            for (alpha, pairs) in tables.matching.iter().enumerate() {
                let t = pair * basis + alpha;
                entries.push((2 * t, theta_column + t, 1.0));
                entries.push((2 * t + 1, theta_column + t, 1.0));
                for &(beta, gamma) in pairs.iter() {
                    let a = j * m + beta as usize;
                    let b = k * m + gamma as usize;
                    // svec stores √2·Q_ab off the diagonal.
                    let weight = if a == b { 1.0 } else { 1.0 / SQRT_2 };
                    let index = svec_index(a, b);
                    entries.push((2 * t, q1 + index, -weight));
                    entries.push((2 * t + 1, q2 + index, weight));
                }
                if j == k && alpha == constant {
                    rhs[2 * t + 1] = eta;
                }
            }
        }
    }
    let matching = ConstraintGroup {
        cone: SupportedConeT::ZeroConeT(2 * theta_len),
        entries,
        rhs,
    };
    let psd = |offset: usize| ConstraintGroup {
        cone: SupportedConeT::PSDTriangleConeT(size),
        entries: (0..svec_size).map(|i| (i, offset + i, -1.0)).collect(),
        rhs: vec![0.0; svec_size],
    };
    (vec![matching, psd(q1), psd(q2)], size)
}

/// The dense rows of θ ↦ K(x; θ) g and targets ẋ − Π g of every sample.
pub(crate) fn metric_regression<S: MetriplecticSystem>(
    data: &Dataset,
    entropy: &[f64],
) -> Regression {
    let n = S::DIM;
    let width = S::metric_coefficient_count();
    let mut rows = vec![0.0; data.len() * n * width];
    let mut target = vec![0.0; data.len() * n];
    let mut gradient = vec![0.0; n];
    let mut grad_h = vec![0.0; n];
    let mut drift = vec![0.0; n];
    for (i, (x, xdot)) in data.iter().enumerate() {
        S::entropy_gradient(x, entropy, &mut gradient);
        S::hamiltonian_gradient(x, &mut grad_h);
        gradient.iter_mut().zip(&grad_h).for_each(|(g, h)| *g += h);
        S::metric_block(
            x,
            &gradient,
            &mut rows[i * n * width..(i + 1) * n * width],
            &mut drift,
        );
        for j in 0..n {
            target[i * n + j] = xdot[j] - drift[j];
        }
    }
    Regression {
        width,
        rows,
        target,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conic::SolveStatus;
    use crate::model::identity_metric;
    use crate::test_system::{reference_data, Quadratic2d};

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
        let fit =
            metric_search::<Quadratic2d>(&data, entropy, &MetricSearchOptions::default()).unwrap();
        assert_eq!(fit.report.status, SolveStatus::Solved);
        let error = max_error(&fit.coefficients, &identity_metric::<Quadratic2d>(1.0));
        assert!(error < 1e-7, "max θ error {error}");
        assert!(fit.report.cost.unwrap().per_component < 1e-7);
        assert_eq!(fit.gram_size, 2);
    }

    #[test]
    fn full_tables_reach_the_same_metric() {
        let data = reference_data(40, 5);
        let entropy = Quadratic2d::REFERENCE_ENTROPY.unwrap();
        let options = MetricSearchOptions {
            sos: SosBasis::Full,
            ..MetricSearchOptions::default()
        };
        let fit = metric_search::<Quadratic2d>(&data, entropy, &options).unwrap();
        let error = max_error(&fit.coefficients, &identity_metric::<Quadratic2d>(1.0));
        eprintln!(
            "full SOS tables: status {:?}, {} iterations, max θ error {error:.2e}",
            fit.report.status, fit.report.iterations
        );
        assert!(fit.report.status.is_usable());
        assert!(error < 1e-6, "max θ error {error}");
        assert_eq!(fit.gram_size, 6);
    }

    #[test]
    fn theta_from_gram_matches_the_sos_form() {
        // K(x) = Z(x)ᵀ Q Z(x) for a random symmetric Q over the full basis.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let size = 6;
        let mut q = vec![0.0; size * size];
        for a in 0..size {
            for b in a..size {
                let v: f64 = rng.random_range(-1.0..1.0);
                q[a * size + b] = v;
                q[b * size + a] = v;
            }
        }
        let tables = Quadratic2d::SOS_FULL;
        let theta = theta_from_gram::<Quadratic2d>(&tables, &q);
        let x = [0.7, -1.3];
        let z = [1.0, x[0], x[1]];
        let mut k = [0.0; 4];
        Quadratic2d::metric_value(&x, &theta, &mut k);
        for j in 0..2 {
            for l in 0..2 {
                let direct: f64 = (0..3)
                    .flat_map(|b| (0..3).map(move |g| (b, g)))
                    .map(|(b, g)| z[b] * q[(j * 3 + b) * size + l * 3 + g] * z[g])
                    .sum();
                assert!((direct - k[j * 2 + l]).abs() < 1e-12);
            }
        }
    }
}
