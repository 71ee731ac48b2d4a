//! How a solve ended.

use serde::{Deserialize, Serialize};

/// How a solve ended. The same statuses for every backend.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[non_exhaustive]
pub enum SolveStatus {
    /// Solved to the requested tolerances.
    Solved,
    /// Solved to reduced ("almost") tolerances.
    AlmostSolved,
    /// The problem was reported primal infeasible (possibly at reduced accuracy).
    PrimalInfeasible,
    /// The problem was reported dual infeasible (possibly at reduced accuracy).
    DualInfeasible,
    /// The iteration limit was reached.
    MaxIterations,
    /// The time limit was reached.
    MaxTime,
    /// The solver stopped on a numerical error.
    NumericalError,
    /// The solver stopped for lack of progress.
    InsufficientProgress,
    /// The solver did not run or was interrupted.
    NotRun,
}

impl SolveStatus {
    /// `true` for [`Solved`](Self::Solved) and [`AlmostSolved`](Self::AlmostSolved):
    /// the returned point is a usable (approximate) optimum.
    pub fn is_usable(self) -> bool {
        matches!(self, Self::Solved | Self::AlmostSolved)
    }

    /// A short lowercase name, e.g. for CSV output.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Solved => "solved",
            Self::AlmostSolved => "almost_solved",
            Self::PrimalInfeasible => "primal_infeasible",
            Self::DualInfeasible => "dual_infeasible",
            Self::MaxIterations => "max_iterations",
            Self::MaxTime => "max_time",
            Self::NumericalError => "numerical_error",
            Self::InsufficientProgress => "insufficient_progress",
            Self::NotRun => "not_run",
        }
    }
}

impl std::fmt::Display for SolveStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}
