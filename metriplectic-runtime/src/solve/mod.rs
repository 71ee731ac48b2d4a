//! The solver layer: L1 regressions with side cones ([`L1Problem`]) and the
//! backends that solve them. It knows nothing of systems, models or costs.
//!
//! Every subproblem of the identification is *an L1 regression with side
//! constraints*: minimise Σᵢ |tᵢ − aᵢᵀ c| over coefficients c, subject to
//! cones on c and on extra variables (the box |ψ| ≤ η, the SOS Gram
//! matrices). The default backend is the runtime's own dense interior-point
//! method ([`dense`]); Clarabel is the second, behind the cargo feature
//! `clarabel`.

#[cfg(feature = "clarabel")]
mod clarabel;
mod dense;
pub(crate) mod linalg;
mod problem;
mod settings;
mod status;
pub(crate) mod svec;

#[cfg(feature = "clarabel")]
pub use clarabel::L1Formulation;
pub use problem::{Cone, ConstraintId, L1Problem, L1Solution, Regression};
pub use settings::{SolverBackend, SolverSettings};
pub use status::SolveStatus;

use crate::error::Result;

/// Solves an [`L1Problem`] with the backend and tolerances of `settings`.
///
/// Errors only on invalid settings, a problem too large for dense matrices
/// (or, with Clarabel, a problem Clarabel rejects). Solver trouble —
/// infeasibility, the iteration limit, numerical breakdown — is reported in
/// [`L1Solution::status`], not as an error.
pub fn solve_l1(problem: &L1Problem, settings: &SolverSettings) -> Result<L1Solution> {
    settings.validate()?;
    problem.check_size(matches!(settings.backend, SolverBackend::Dense))?;
    match settings.backend {
        SolverBackend::Dense => dense::solve(problem, settings),
        #[cfg(feature = "clarabel")]
        SolverBackend::Clarabel(formulation) => clarabel::solve(problem, formulation, settings),
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::dense::tests::{box_problem, random_regression};
    use super::svec::{svec_index, unsvec, SQRT_2};
    use super::*;

    /// Every backend: the dense one, then Clarabel in each formulation.
    pub(crate) fn backends() -> Vec<SolverBackend> {
        #[allow(unused_mut)]
        let mut backends = vec![SolverBackend::Dense];
        #[cfg(feature = "clarabel")]
        backends.extend([
            SolverBackend::Clarabel(L1Formulation::Slack),
            SolverBackend::Clarabel(L1Formulation::ExplicitResidual),
            SolverBackend::Clarabel(L1Formulation::Split),
        ]);
        backends
    }

    fn with_backend(backend: SolverBackend) -> SolverSettings {
        SolverSettings {
            backend,
            ..SolverSettings::default()
        }
    }

    /// Fit c ≈ 5 subject to c = Q₀₁ with Q = [[1, Q₀₁], [Q₀₁, 4]] ⪰ 0, so
    /// |Q₀₁| ≤ 2: the optimum is c = 2. A wrong svec scaling gives 2√2 or √2.
    #[test]
    fn l1_fit_with_psd_block_respects_svec_scaling() {
        for backend in backends() {
            let regression = Regression::new(1, vec![1.0], vec![5.0]).unwrap();
            let mut problem = L1Problem::new(regression, 3);
            let q = |i: usize| 1 + i;
            problem
                .constrain(
                    Cone::Zero(3),
                    vec![
                        (0, 0, 1.0),
                        (0, q(svec_index(0, 1)), -1.0 / SQRT_2),
                        (1, q(svec_index(0, 0)), 1.0),
                        (2, q(svec_index(1, 1)), 1.0),
                    ],
                    vec![0.0, 1.0, 4.0],
                )
                .unwrap();
            let gram = problem
                .constrain(
                    Cone::Psd(2),
                    (0..3).map(|i| (i, q(i), -1.0)).collect(),
                    vec![0.0; 3],
                )
                .unwrap();
            let out = solve_l1(&problem, &with_backend(backend)).unwrap();
            assert_eq!(out.status, SolveStatus::Solved, "{backend:?}");
            assert!(
                (out.coefficients()[0] - 2.0).abs() < 1e-6,
                "{backend:?}: {:?}",
                out.variables()
            );
            let q = unsvec(2, out.slack(gram));
            assert!((q[1] - 2.0).abs() < 1e-6 && (q[0] - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn l1_regression_returns_the_median() {
        // min Σ|tᵢ − c| is the median; an outlier does not move it.
        let regression = Regression::new(1, vec![1.0; 5], vec![1.0, 2.0, 3.0, 100.0, 4.0]).unwrap();
        for backend in backends() {
            let out = solve_l1(
                &L1Problem::new(regression.clone(), 0),
                &with_backend(backend),
            )
            .unwrap();
            assert_eq!(out.status, SolveStatus::Solved);
            assert!(
                (out.coefficients()[0] - 3.0).abs() < 1e-6,
                "{backend:?}: {}",
                out.coefficients()[0]
            );
        }
    }

    #[test]
    fn backends_agree_on_box_constrained_fits() {
        for (rows, width, bound) in [(200, 7, 10.0), (300, 12, 0.05), (40, 30, 1.0)] {
            let regression = random_regression(rows, width, rows as u64);
            let problem = box_problem(regression.clone(), bound);
            let reference = solve_l1(&problem, &with_backend(SolverBackend::Dense)).unwrap();
            assert_eq!(reference.status, SolveStatus::Solved);
            let theirs = regression.l1_residual(reference.coefficients());
            for backend in backends() {
                let out = solve_l1(&problem, &with_backend(backend)).unwrap();
                assert_eq!(out.status, SolveStatus::Solved, "{backend:?}");
                let ours = regression.l1_residual(out.coefficients());
                assert!(
                    (ours - theirs).abs() <= 1e-7 * theirs.max(1.0),
                    "{backend:?} {rows}×{width}, η = {bound}: {ours} vs {theirs}"
                );
            }
            assert!(reference
                .coefficients()
                .iter()
                .all(|v| v.abs() <= bound * (1.0 + 1e-8)));
        }
    }

    #[test]
    fn malformed_constraints_are_errors_not_panics() {
        let regression = Regression::new(1, vec![1.0], vec![1.0]).unwrap();
        let mut problem = L1Problem::new(regression, 0);
        let outside_row = problem.constrain(Cone::Nonnegative(1), vec![(3, 0, 1.0)], vec![0.0]);
        assert!(outside_row.unwrap_err().to_string().contains("(3, 0)"));
        let outside_column = problem.constrain(Cone::Nonnegative(1), vec![(0, 5, 1.0)], vec![0.0]);
        assert!(outside_column.is_err());
        let short_rhs = problem.constrain(Cone::Psd(2), vec![], vec![0.0; 2]);
        assert!(short_rhs.unwrap_err().to_string().contains("3 rows"));
        let not_finite = problem.constrain(Cone::Zero(1), vec![(0, 0, f64::NAN)], vec![0.0]);
        assert!(not_finite.is_err());
        assert!(Regression::new(2, vec![1.0], vec![1.0]).is_err());
        let empty_psd = problem.constrain(Cone::Psd(0), vec![], vec![]);
        assert!(empty_psd.unwrap_err().to_string().contains("0×0"));
        // n(n + 1)/2 overflows: no right-hand side can match it.
        assert!(problem
            .constrain(Cone::Psd(usize::MAX), vec![], vec![])
            .is_err());
    }

    /// Sizes no machine can hold are refused by `solve_l1` before any
    /// allocation, for every backend: before, a width of 2⁶³ with no rows
    /// wrapped inside nalgebra, and `extra = usize::MAX` overflowed the
    /// variable count.
    #[test]
    fn problems_beyond_memory_are_errors_before_any_allocation() {
        for backend in backends() {
            let settings = with_backend(backend);
            let wide = Regression::new(1 << 63, vec![], vec![]).unwrap();
            let mut problem = L1Problem::new(wide, 0);
            problem
                .constrain(Cone::Nonnegative(2), vec![(1, 1, 1.0)], vec![0.0, 0.0])
                .unwrap();
            let error = solve_l1(&problem, &settings).unwrap_err();
            assert!(error.to_string().contains("problem size"), "{error}");
            let regression = Regression::new(1, vec![1.0], vec![1.0]).unwrap();
            let problem = L1Problem::new(regression, usize::MAX);
            assert_eq!(problem.variables(), usize::MAX);
            let error = solve_l1(&problem, &settings).unwrap_err();
            assert!(error.to_string().contains("problem size"), "{error}");
        }
    }
}
