//! Solver settings and the choice of backend.

use serde::{Deserialize, Serialize};

use crate::error::{invalid, Result};

/// Which interior-point solver runs an [`L1Problem`](crate::L1Problem).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum SolverBackend {
    /// The runtime's dense interior-point method (the default): the L1
    /// auxiliaries are eliminated analytically and each iteration factorises
    /// one small dense matrix. About an order of magnitude faster than
    /// Clarabel on the paper's problems.
    #[default]
    Dense,
    /// Clarabel on a sparse conic form of the problem (cargo feature
    /// `clarabel`, which links BLAS/LAPACK for its PSD cone).
    #[cfg(feature = "clarabel")]
    #[cfg_attr(docsrs, doc(cfg(feature = "clarabel")))]
    Clarabel(crate::L1Formulation),
}

/// Settings of one solve.
///
/// The defaults are Clarabel's own tolerances (both backends apply the same
/// termination tests): at most 200 iterations, no time limit, gaps and
/// feasibility to 1e-8, no log, objective scale 1, the dense backend.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverSettings {
    /// Interior-point iteration limit per solve. Default 200.
    pub max_iter: u32,
    /// Wall-clock limit per solve in seconds, finite and positive. Default
    /// `None` (unlimited).
    pub time_limit: Option<f64>,
    /// Absolute duality-gap tolerance. Default 1e-8.
    pub tol_gap_abs: f64,
    /// Relative duality-gap tolerance, below 1. Default 1e-8.
    pub tol_gap_rel: f64,
    /// Primal/dual feasibility tolerance, below 1. Default 1e-8.
    pub tol_feas: f64,
    /// Print the solver's iteration log to standard error. Default `false`.
    pub verbose: bool,
    /// Factor multiplying the L1 objective before solving (the paper's code
    /// uses 10⁴), in [1e-4, 1e8]; reported costs are always recomputed
    /// unscaled. Default 1.
    pub objective_scale: f64,
    /// Which solver runs. Default [`SolverBackend::Dense`].
    pub backend: SolverBackend,
}

impl Default for SolverSettings {
    fn default() -> Self {
        Self {
            max_iter: 200,
            time_limit: None,
            tol_gap_abs: 1e-8,
            tol_gap_rel: 1e-8,
            tol_feas: 1e-8,
            verbose: false,
            objective_scale: 1.0,
            backend: SolverBackend::default(),
        }
    }
}

/// The objective scales [`SolverSettings::validate`] accepts: measured on a
/// 2-D system, 1e-4 to 1e8 all converged.
const OBJECTIVE_SCALES: (f64, f64) = (1e-4, 1e8);

impl SolverSettings {
    /// Checks that every value is finite and positive where it must be.
    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("solver tol_gap_abs", self.tol_gap_abs),
            ("solver tol_gap_rel", self.tol_gap_rel),
            ("solver tol_feas", self.tol_feas),
            ("solver objective_scale", self.objective_scale),
        ];
        for (what, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(invalid(
                    what,
                    format!("{value} is not a finite positive number"),
                ));
            }
        }
        // Relative tolerances of 100% accept any point, and an objective
        // scaled far from 1 meets the absolute gap test at once (a probe's
        // 1e-300 and its tolerances of 1e10 returned poor fits silently).
        for (what, value) in [
            ("solver tol_gap_rel", self.tol_gap_rel),
            ("solver tol_feas", self.tol_feas),
        ] {
            if value >= 1.0 {
                return Err(invalid(
                    what,
                    format!(
                        "{value:e} is not below 1: a relative tolerance of 100% accepts any point"
                    ),
                ));
            }
        }
        if !(OBJECTIVE_SCALES.0..=OBJECTIVE_SCALES.1).contains(&self.objective_scale) {
            return Err(invalid(
                "solver objective_scale",
                format!(
                    "{:e} is outside [{:e}, {:e}], the range in which the solver's absolute \
                     tolerances keep their meaning",
                    self.objective_scale, OBJECTIVE_SCALES.0, OBJECTIVE_SCALES.1
                ),
            ));
        }
        if let Some(limit) = self.time_limit {
            // Infinity too: JSON has no infinity, so a checkpoint would read
            // it back as `None` and no longer match the run.
            if !(limit.is_finite() && limit > 0.0) {
                return Err(invalid(
                    "solver time_limit",
                    format!(
                        "{limit} is not a finite positive number of seconds (`None` is no limit)"
                    ),
                ));
            }
        }
        if self.max_iter == 0 {
            return Err(invalid("solver max_iter", "must be at least 1"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_validation_names_the_field() {
        let settings = SolverSettings {
            tol_feas: f64::NAN,
            ..SolverSettings::default()
        };
        let err = settings.validate().unwrap_err().to_string();
        assert!(err.contains("tol_feas"), "{err}");
        for (settings, expected) in [
            (
                SolverSettings {
                    tol_gap_rel: 1e10,
                    ..SolverSettings::default()
                },
                "tol_gap_rel: 1e10 is not below 1",
            ),
            (
                SolverSettings {
                    objective_scale: 1e-300,
                    ..SolverSettings::default()
                },
                "objective_scale: 1e-300 is outside [1e-4, 1e8]",
            ),
        ] {
            let err = settings.validate().unwrap_err().to_string();
            assert!(err.contains(expected), "{err}");
        }
        // The paper's scale is inside the range.
        SolverSettings {
            objective_scale: 1e4,
            ..SolverSettings::default()
        }
        .validate()
        .unwrap();
    }

    #[cfg(feature = "clarabel")]
    #[test]
    fn defaults_are_clarabels() {
        let theirs = clarabel::solver::DefaultSettings::<f64>::default();
        let ours = SolverSettings::default();
        assert_eq!(ours.max_iter, theirs.max_iter);
        assert_eq!(ours.tol_gap_abs, theirs.tol_gap_abs);
        assert_eq!(ours.tol_gap_rel, theirs.tol_gap_rel);
        assert_eq!(ours.tol_feas, theirs.tol_feas);
    }

    /// An infinite limit would be written to a checkpoint as `null` and
    /// read back as `None`, so that the run no longer matched its own file.
    #[test]
    fn time_limits_must_be_finite_and_positive() {
        for limit in [f64::INFINITY, f64::NAN, 0.0, -1.0] {
            let settings = SolverSettings {
                time_limit: Some(limit),
                ..SolverSettings::default()
            };
            let error = settings.validate().unwrap_err().to_string();
            assert!(error.contains("time_limit"), "{limit}: {error}");
        }
        let settings = SolverSettings {
            time_limit: Some(1e9),
            ..SolverSettings::default()
        };
        settings.validate().unwrap();
    }
}
