//! Clarabel glue shared by the entropy and metric searches.
//!
//! Both subproblems are *L1 regressions with side constraints*: minimise
//! Σᵢ |tᵢ − aᵢᵀ c| over coefficients c, subject to cones on c and on extra
//! variables (the box |ψ| ≤ η, or the SOS Gram matrices). This module turns
//! such a problem into Clarabel's standard form
//!
//! ```text
//! min qᵀx   s.t.  A x + s = b,  s ∈ K,
//! ```
//!
//! assembling A column by column straight into compressed sparse column (CSC)
//! storage, and maps Clarabel's result to the runtime's [`SolveStatus`].
//!
//! Variables are laid out as `[coefficients | extra | L1 auxiliaries]`; rows as
//! `[regression rows | constraint groups in order]`.

use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// √2, the svec scaling of off-diagonal entries in Clarabel's PSD cone.
pub const SQRT_2: f64 = std::f64::consts::SQRT_2;

/// How a subproblem's solve ended, mapped from Clarabel's status.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[non_exhaustive]
pub enum SolveStatus {
    /// Solved to the requested tolerances.
    Solved,
    /// Solved to Clarabel's reduced ("almost") tolerances.
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

impl From<SolverStatus> for SolveStatus {
    fn from(status: SolverStatus) -> Self {
        match status {
            SolverStatus::Solved => Self::Solved,
            SolverStatus::AlmostSolved => Self::AlmostSolved,
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                Self::PrimalInfeasible
            }
            SolverStatus::DualInfeasible | SolverStatus::AlmostDualInfeasible => {
                Self::DualInfeasible
            }
            SolverStatus::MaxIterations => Self::MaxIterations,
            SolverStatus::MaxTime => Self::MaxTime,
            SolverStatus::NumericalError => Self::NumericalError,
            SolverStatus::InsufficientProgress => Self::InsufficientProgress,
            SolverStatus::Unsolved | SolverStatus::CallbackTerminated => Self::NotRun,
        }
    }
}

/// Which interior-point solver runs the subproblems.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum SolverBackend {
    /// The runtime's dense interior-point method (`dense_ipm`): the L1
    /// auxiliaries are eliminated analytically and each iteration factorises
    /// one small dense matrix. About an order of magnitude faster than
    /// Clarabel on the paper's problems (BENCHMARKS.md §5).
    #[default]
    Dense,
    /// Clarabel on the sparse conic form chosen by [`L1Formulation`].
    Clarabel,
}

/// The solver settings that matter for the subproblems.
///
/// Tolerances default to Clarabel's own (the dense backend applies the same
/// tests); solver output is off.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SolverSettings {
    /// Interior-point iteration limit per solve.
    pub max_iter: u32,
    /// Wall-clock limit per solve in seconds (`None`: unlimited).
    pub time_limit: Option<f64>,
    /// Absolute duality-gap tolerance.
    pub tol_gap_abs: f64,
    /// Relative duality-gap tolerance.
    pub tol_gap_rel: f64,
    /// Primal/dual feasibility tolerance.
    pub tol_feas: f64,
    /// Print the solver's iteration log (to standard error).
    pub verbose: bool,
    /// Factor multiplying the L1 objective before solving (the paper's code
    /// uses 10⁴). Reported costs are always recomputed unscaled.
    pub objective_scale: f64,
    /// Which solver runs the subproblems.
    pub backend: SolverBackend,
}

impl Default for SolverSettings {
    fn default() -> Self {
        let base = DefaultSettings::<f64>::default();
        Self {
            max_iter: base.max_iter,
            time_limit: None,
            tol_gap_abs: base.tol_gap_abs,
            tol_gap_rel: base.tol_gap_rel,
            tol_feas: base.tol_feas,
            verbose: false,
            objective_scale: 1.0,
            backend: SolverBackend::default(),
        }
    }
}

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
                return Err(Error::InvalidArgument {
                    what: what.to_owned(),
                    reason: format!("{value} is not a finite positive number"),
                });
            }
        }
        if let Some(limit) = self.time_limit {
            if limit.is_nan() || limit <= 0.0 {
                return Err(Error::InvalidArgument {
                    what: "solver time_limit".to_owned(),
                    reason: format!("{limit} is not a positive number of seconds"),
                });
            }
        }
        if self.max_iter == 0 {
            return Err(Error::InvalidArgument {
                what: "solver max_iter".to_owned(),
                reason: "must be at least 1".to_owned(),
            });
        }
        Ok(())
    }

    pub(crate) fn to_clarabel(&self) -> DefaultSettings<f64> {
        DefaultSettings {
            max_iter: self.max_iter,
            time_limit: self.time_limit.unwrap_or(f64::INFINITY),
            tol_gap_abs: self.tol_gap_abs,
            tol_gap_rel: self.tol_gap_rel,
            tol_feas: self.tol_feas,
            verbose: self.verbose,
            ..DefaultSettings::default()
        }
    }
}

/// How the L1 objective Σ|r| is written as a conic program for Clarabel
/// (the dense backend always eliminates the auxiliaries itself).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum L1Formulation {
    /// Variables (c, δ): −δ ≤ t − A c ≤ δ. The dense regression block
    /// appears twice in the constraint matrix.
    Slack,
    /// Variables (c, r, δ): A c + r = t as equalities, then −δ ≤ r ≤ δ.
    /// The dense block appears once.
    ExplicitResidual,
    /// Variables (c, u, v): A c + u − v = t, u, v ≥ 0, minimise Σ(u + v).
    /// The dense block appears once and there are fewer rows than
    /// [`ExplicitResidual`](Self::ExplicitResidual).
    #[default]
    Split,
}

/// Index of entry (i, j) of an n×n symmetric matrix in Clarabel's svec
/// layout: the upper triangle (i ≤ j) stacked column by column.
pub fn svec_index(i: usize, j: usize) -> usize {
    let (i, j) = if i <= j { (i, j) } else { (j, i) };
    j * (j + 1) / 2 + i
}

/// Length n(n+1)/2 of the svec of an n×n symmetric matrix.
pub fn svec_len(n: usize) -> usize {
    n * (n + 1) / 2
}

/// svec(Q) of a row-major symmetric n×n matrix: upper triangle by columns,
/// off-diagonal entries multiplied by √2 so that ⟨svec A, svec B⟩ = tr(AB).
pub fn svec(n: usize, matrix: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; svec_len(n)];
    for j in 0..n {
        for i in 0..=j {
            let scale = if i == j { 1.0 } else { SQRT_2 };
            out[svec_index(i, j)] = scale * matrix[i * n + j];
        }
    }
    out
}

/// The row-major symmetric n×n matrix of an svec vector (inverse of [`svec`]).
pub fn unsvec(n: usize, packed: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; n * n];
    for j in 0..n {
        for i in 0..=j {
            let scale = if i == j { 1.0 } else { 1.0 / SQRT_2 };
            let value = scale * packed[svec_index(i, j)];
            out[i * n + j] = value;
            out[j * n + i] = value;
        }
    }
    out
}

/// Sparse entries of one constraint group, in group-local row numbering.
#[derive(Debug, Clone)]
pub(crate) struct ConstraintGroup {
    /// The cone of the group's rows (its dimension fixes the row count).
    pub cone: SupportedConeT<f64>,
    /// (local row, variable, value), variables indexing `[coefficients | extra]`.
    pub entries: Vec<(usize, usize, f64)>,
    /// Right-hand side b of the group's rows.
    pub rhs: Vec<f64>,
}

/// Dense regression rows: residual i is `target[i] − Σ_c rows[i*width + c] x_c`.
#[derive(Debug, Clone, Default)]
pub(crate) struct Regression {
    /// Number of coefficient columns.
    pub width: usize,
    /// Row-major R × width.
    pub rows: Vec<f64>,
    /// R targets.
    pub target: Vec<f64>,
}

impl Regression {
    pub fn len(&self) -> usize {
        self.target.len()
    }

    /// The columns of `self` followed by those of `right`, on the same rows;
    /// the targets are `self`'s.
    pub fn with_columns_of(&self, right: &Regression) -> Regression {
        let (wl, wr) = (self.width, right.width);
        let mut rows = Vec::with_capacity(self.len() * (wl + wr));
        for i in 0..self.len() {
            rows.extend_from_slice(&self.rows[i * wl..(i + 1) * wl]);
            rows.extend_from_slice(&right.rows[i * wr..(i + 1) * wr]);
        }
        Regression {
            width: wl + wr,
            rows,
            target: self.target.clone(),
        }
    }

    /// The rows of `self` followed by those of `below` (same width).
    pub fn stacked(&self, below: &Regression) -> Regression {
        debug_assert_eq!(self.width, below.width);
        let mut rows = Vec::with_capacity(self.rows.len() + below.rows.len());
        rows.extend_from_slice(&self.rows);
        rows.extend_from_slice(&below.rows);
        let mut target = Vec::with_capacity(self.len() + below.len());
        target.extend_from_slice(&self.target);
        target.extend_from_slice(&below.target);
        Regression {
            width: self.width,
            rows,
            target,
        }
    }

    /// Σᵢ |aᵢₖ| for every column k: the largest rate at which the L1
    /// objective can change along coefficient k.
    pub fn column_l1_norms(&self) -> Vec<f64> {
        let mut norms = vec![0.0; self.width];
        for row in self.rows.chunks_exact(self.width.max(1)) {
            norms.iter_mut().zip(row).for_each(|(n, a)| *n += a.abs());
        }
        norms
    }

    /// Σᵢ |tᵢ − aᵢᵀ c|: the L1 objective at coefficients `c` (`width` long).
    pub fn l1_residual(&self, c: &[f64]) -> f64 {
        self.rows
            .chunks_exact(self.width.max(1))
            .zip(&self.target)
            .map(|(row, t)| (t - row.iter().zip(c).map(|(a, x)| a * x).sum::<f64>()).abs())
            .sum()
    }
}

/// A solved (or failed) conic problem.
#[derive(Debug, Clone)]
pub(crate) struct ConicOutcome {
    /// Values of `[coefficients | extra]` as returned by Clarabel.
    pub x: Vec<f64>,
    /// Clarabel's slacks s (in the cones) of each constraint group, in order.
    pub group_slacks: Vec<Vec<f64>>,
    pub status: SolveStatus,
    pub iterations: u32,
    pub assembly_seconds: f64,
    pub solver_seconds: f64,
}

/// Assembles and solves min Σ|t − A c| subject to the constraint groups.
///
/// `extra` is the number of non-coefficient variables the groups refer to.
pub(crate) fn solve_l1(
    regression: &Regression,
    extra: usize,
    groups: &[ConstraintGroup],
    formulation: L1Formulation,
    settings: &SolverSettings,
) -> Result<ConicOutcome> {
    if settings.backend == SolverBackend::Dense {
        return crate::dense_ipm::solve(regression, extra, groups, settings);
    }
    let start = Instant::now();
    let problem = assemble(
        regression,
        extra,
        groups,
        formulation,
        settings.objective_scale,
    )?;
    let assembly_seconds = start.elapsed().as_secs_f64();

    let start = Instant::now();
    let p = CscMatrix::zeros((problem.q.len(), problem.q.len()));
    let mut solver = DefaultSolver::new(
        &p,
        &problem.q,
        &problem.a,
        &problem.b,
        &problem.cones,
        settings.to_clarabel(),
    )
    .map_err(|e| Error::Solver {
        reason: format!("Clarabel rejected the problem: {e}"),
    })?;
    solver.solve();
    let solver_seconds = start.elapsed().as_secs_f64();
    let solution = &solver.solution;
    let keep = regression.width + extra;
    let group_slacks = problem
        .group_rows
        .iter()
        .map(|range| solution.s[range.clone()].to_vec())
        .collect();
    Ok(ConicOutcome {
        x: solution.x[..keep].to_vec(),
        group_slacks,
        status: solution.status.into(),
        iterations: solution.iterations,
        assembly_seconds,
        solver_seconds,
    })
}

pub(crate) struct ConicProblem {
    pub q: Vec<f64>,
    pub a: CscMatrix<f64>,
    pub b: Vec<f64>,
    pub cones: Vec<SupportedConeT<f64>>,
    /// Row range of each constraint group.
    pub group_rows: Vec<std::ops::Range<usize>>,
}

/// Builds Clarabel's (q, A, b, cones) directly in CSC form.
pub(crate) fn assemble(
    regression: &Regression,
    extra: usize,
    groups: &[ConstraintGroup],
    formulation: L1Formulation,
    objective_scale: f64,
) -> Result<ConicProblem> {
    let width = regression.width;
    let r = regression.len();
    if regression.rows.len() != r * width {
        return Err(Error::Solver {
            reason: format!(
                "regression block has {} entries, expected {} rows × {} columns",
                regression.rows.len(),
                r,
                width
            ),
        });
    }
    let head_vars = width + extra;
    let (aux_vars, regression_rows) = match formulation {
        L1Formulation::Slack => (r, 2 * r),
        L1Formulation::ExplicitResidual => (2 * r, 3 * r),
        L1Formulation::Split => (2 * r, 3 * r),
    };
    let n_vars = head_vars + aux_vars;

    // Group rows follow the regression rows; bucket group entries by column.
    let mut group_offsets = Vec::with_capacity(groups.len());
    let mut total_rows = regression_rows;
    let mut by_column: Vec<Vec<(usize, f64)>> = vec![Vec::new(); head_vars];
    for group in groups {
        let dim = cone_dim(&group.cone);
        if group.rhs.len() != dim {
            return Err(Error::Solver {
                reason: format!(
                    "constraint group has {} right-hand sides for a cone of dimension {dim}",
                    group.rhs.len()
                ),
            });
        }
        for &(row, col, value) in &group.entries {
            if row >= dim || col >= head_vars {
                return Err(Error::Solver {
                    reason: format!(
                        "constraint entry ({row}, {col}) outside a {dim} × {head_vars} group"
                    ),
                });
            }
            by_column[col].push((total_rows + row, value));
        }
        group_offsets.push(total_rows);
        total_rows += dim;
    }
    for column in &mut by_column {
        column.sort_by_key(|&(row, _)| row);
    }

    let nnz_estimate = match formulation {
        L1Formulation::Slack => 2 * r * width + 2 * r,
        _ => r * width + 5 * r,
    } + by_column.iter().map(Vec::len).sum::<usize>();
    let mut colptr = Vec::with_capacity(n_vars + 1);
    let mut rowval = Vec::with_capacity(nnz_estimate);
    let mut nzval = Vec::with_capacity(nnz_estimate);
    colptr.push(0);

    // Coefficient columns: the dense regression block, then group entries.
    for (c, group_column) in by_column[..width].iter().enumerate() {
        for i in 0..r {
            let a = regression.rows[i * width + c];
            if a != 0.0 {
                rowval.push(i);
                nzval.push(a);
            }
        }
        if formulation == L1Formulation::Slack {
            for i in 0..r {
                let a = regression.rows[i * width + c];
                if a != 0.0 {
                    rowval.push(r + i);
                    nzval.push(-a);
                }
            }
        }
        push_group_column(group_column, &mut rowval, &mut nzval);
        colptr.push(rowval.len());
    }
    for column in &by_column[width..] {
        push_group_column(column, &mut rowval, &mut nzval);
        colptr.push(rowval.len());
    }

    // L1 auxiliaries. Rows: Slack [A c − δ ≤ t ; −A c − δ ≤ −t],
    // ExplicitResidual [A c + r = t ; r − δ ≤ 0 ; −r − δ ≤ 0],
    // Split [A c + u − v = t ; −u ≤ 0 ; −v ≤ 0].
    let weight = objective_scale;
    let mut q = vec![0.0; n_vars];
    let mut b = vec![0.0; total_rows];
    let mut cones = Vec::with_capacity(groups.len() + 2);
    match formulation {
        L1Formulation::Slack => {
            for i in 0..r {
                rowval.extend([i, r + i]);
                nzval.extend([-1.0, -1.0]);
                colptr.push(rowval.len());
                q[head_vars + i] = weight;
            }
            for (i, t) in regression.target.iter().enumerate() {
                b[i] = *t;
                b[r + i] = -t;
            }
            cones.push(SupportedConeT::NonnegativeConeT(2 * r));
        }
        L1Formulation::ExplicitResidual => {
            for i in 0..r {
                rowval.extend([i, r + i, 2 * r + i]);
                nzval.extend([1.0, 1.0, -1.0]);
                colptr.push(rowval.len());
            }
            b[..r].copy_from_slice(&regression.target);
            for i in 0..r {
                rowval.extend([r + i, 2 * r + i]);
                nzval.extend([-1.0, -1.0]);
                colptr.push(rowval.len());
                q[head_vars + r + i] = weight;
            }
            cones.push(SupportedConeT::ZeroConeT(r));
            cones.push(SupportedConeT::NonnegativeConeT(2 * r));
        }
        L1Formulation::Split => {
            for i in 0..r {
                rowval.extend([i, r + i]);
                nzval.extend([1.0, -1.0]);
                colptr.push(rowval.len());
                q[head_vars + i] = weight;
            }
            b[..r].copy_from_slice(&regression.target);
            for i in 0..r {
                rowval.extend([i, 2 * r + i]);
                nzval.extend([-1.0, -1.0]);
                colptr.push(rowval.len());
                q[head_vars + r + i] = weight;
            }
            cones.push(SupportedConeT::ZeroConeT(r));
            cones.push(SupportedConeT::NonnegativeConeT(2 * r));
        }
    }
    for (group, &offset) in groups.iter().zip(&group_offsets) {
        b[offset..offset + group.rhs.len()].copy_from_slice(&group.rhs);
        cones.push(group.cone.clone());
    }
    // Clarabel rejects zero-dimensional cones.
    cones.retain(|cone| cone_dim(cone) > 0);

    let a = CscMatrix::new(total_rows, n_vars, colptr, rowval, nzval);
    let group_rows = groups
        .iter()
        .zip(&group_offsets)
        .map(|(group, &offset)| offset..offset + group.rhs.len())
        .collect();
    Ok(ConicProblem {
        q,
        a,
        b,
        cones,
        group_rows,
    })
}

fn push_group_column(column: &[(usize, f64)], rowval: &mut Vec<usize>, nzval: &mut Vec<f64>) {
    // Entries sharing a row (e.g. the two orderings of a Gram pair) are summed;
    // `column` is sorted and its rows lie below every row already in this column.
    let mut previous = None;
    for &(row, value) in column {
        if previous == Some(row) {
            if let Some(last) = nzval.last_mut() {
                *last += value;
            }
            continue;
        }
        rowval.push(row);
        nzval.push(value);
        previous = Some(row);
    }
}

/// Number of rows a cone occupies.
pub(crate) fn cone_dim(cone: &SupportedConeT<f64>) -> usize {
    match cone {
        SupportedConeT::ZeroConeT(d)
        | SupportedConeT::NonnegativeConeT(d)
        | SupportedConeT::SecondOrderConeT(d) => *d,
        SupportedConeT::PSDTriangleConeT(n) => svec_len(*n),
        SupportedConeT::ExponentialConeT() | SupportedConeT::PowerConeT(_) => 3,
        SupportedConeT::GenPowerConeT(alpha, d) => alpha.len() + d,
    }
}

/// What a subproblem solve did, with the cost recomputed from its result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SolveReport {
    /// The solver's final status.
    pub status: SolveStatus,
    /// Interior-point iterations.
    pub iterations: u32,
    /// Seconds spent building the problem (per-sample blocks and CSC assembly).
    pub assembly_seconds: f64,
    /// Seconds spent in the solver (setup, factorisation and iterations).
    pub solver_seconds: f64,
    /// Cost of the returned coefficients on the subproblem's data, recomputed
    /// from the model (not the solver's objective). `None` if the solver
    /// returned non-finite coefficients.
    pub cost: Option<crate::cost::Cost>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Clarabel with each formulation, then the dense backend (which ignores
    /// the formulation).
    const SOLVERS: [(SolverBackend, L1Formulation); 4] = [
        (SolverBackend::Clarabel, L1Formulation::Slack),
        (SolverBackend::Clarabel, L1Formulation::ExplicitResidual),
        (SolverBackend::Clarabel, L1Formulation::Split),
        (SolverBackend::Dense, L1Formulation::Split),
    ];

    fn with_backend(backend: SolverBackend) -> SolverSettings {
        SolverSettings {
            backend,
            ..SolverSettings::default()
        }
    }

    fn dense(a: &CscMatrix<f64>) -> Vec<Vec<f64>> {
        let mut out = vec![vec![0.0; a.n]; a.m];
        for (col, bounds) in a.colptr.windows(2).enumerate() {
            for idx in bounds[0]..bounds[1] {
                out[a.rowval[idx]][col] += a.nzval[idx];
            }
        }
        out
    }

    #[test]
    fn svec_round_trips_and_preserves_inner_products() {
        let a = [1.0, 2.0, 3.0, 2.0, 5.0, 6.0, 3.0, 6.0, 9.0];
        let b = [4.0, -1.0, 0.5, -1.0, 2.0, 7.0, 0.5, 7.0, -3.0];
        let (sa, sb) = (svec(3, &a), svec(3, &b));
        // Upper triangle by columns: (0,0) (0,1) (1,1) (0,2) (1,2) (2,2).
        assert_eq!(sa[0], 1.0);
        assert!((sa[1] - 2.0 * SQRT_2).abs() < 1e-15);
        assert_eq!(sa[2], 5.0);
        assert!((sa[3] - 3.0 * SQRT_2).abs() < 1e-15);
        assert_eq!(sa[5], 9.0);
        assert_eq!(unsvec(3, &sa), a.to_vec());
        let trace: f64 = (0..9).map(|i| a[i] * b[i]).sum();
        let inner: f64 = sa.iter().zip(&sb).map(|(x, y)| x * y).sum();
        assert!((trace - inner).abs() < 1e-12);
    }

    #[test]
    fn clarabel_psd_cone_uses_scaled_upper_triangle() {
        // min tr(C X) s.t. tr X = 1, X ⪰ 0 has value λ_min(C) = 1 at
        // X = ½[[1, −1], [−1, 1]] for C = [[2, 1], [1, 2]].
        let c = svec(2, &[2.0, 1.0, 1.0, 2.0]);
        let a = CscMatrix::new(
            4,
            3,
            vec![0, 2, 3, 5],
            vec![0, 3, 1, 2, 3],
            vec![-1.0, 1.0, -1.0, -1.0, 1.0],
        );
        assert!(a.check_format().is_ok());
        let b = [0.0, 0.0, 0.0, 1.0];
        let cones = [
            SupportedConeT::PSDTriangleConeT(2),
            SupportedConeT::ZeroConeT(1),
        ];
        let p = CscMatrix::zeros((3, 3));
        let settings = SolverSettings::default().to_clarabel();
        let mut solver = DefaultSolver::new(&p, &c, &a, &b, &cones, settings).unwrap();
        solver.solve();
        assert_eq!(solver.solution.status, SolverStatus::Solved);
        let x = unsvec(2, &solver.solution.x);
        let expected = [0.5, -0.5, -0.5, 0.5];
        for (got, want) in x.iter().zip(&expected) {
            assert!((got - want).abs() < 1e-7, "X = {x:?}");
        }
        assert!((solver.solution.obj_val - 1.0).abs() < 1e-7);
    }

    /// Fit c ≈ 5 subject to c = Q₀₁ with Q = [[1, Q₀₁], [Q₀₁, 4]] ⪰ 0, so
    /// |Q₀₁| ≤ 2: the optimum is c = 2. A wrong svec scaling gives 2√2 or √2.
    fn psd_bounded_fit(backend: SolverBackend, formulation: L1Formulation) -> ConicOutcome {
        let regression = Regression {
            width: 1,
            rows: vec![1.0],
            target: vec![5.0],
        };
        let q = |i: usize| 1 + i;
        let equalities = ConstraintGroup {
            cone: SupportedConeT::ZeroConeT(3),
            entries: vec![
                (0, 0, 1.0),
                (0, q(svec_index(0, 1)), -1.0 / SQRT_2),
                (1, q(svec_index(0, 0)), 1.0),
                (2, q(svec_index(1, 1)), 1.0),
            ],
            rhs: vec![0.0, 1.0, 4.0],
        };
        let psd = ConstraintGroup {
            cone: SupportedConeT::PSDTriangleConeT(2),
            entries: (0..3).map(|i| (i, q(i), -1.0)).collect(),
            rhs: vec![0.0; 3],
        };
        solve_l1(
            &regression,
            3,
            &[equalities, psd],
            formulation,
            &with_backend(backend),
        )
        .unwrap()
    }

    #[test]
    fn l1_fit_with_psd_group_respects_svec_scaling() {
        for (backend, formulation) in SOLVERS {
            let out = psd_bounded_fit(backend, formulation);
            assert_eq!(
                out.status,
                SolveStatus::Solved,
                "{backend:?} {formulation:?}"
            );
            assert!(
                (out.x[0] - 2.0).abs() < 1e-6,
                "{backend:?} {formulation:?}: {:?}",
                out.x
            );
            let q = unsvec(2, &out.group_slacks[1]);
            assert!((q[1] - 2.0).abs() < 1e-6 && (q[0] - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn l1_regression_returns_the_median() {
        // min Σ|tᵢ − c| is the median; an outlier does not move it.
        let regression = Regression {
            width: 1,
            rows: vec![1.0; 5],
            target: vec![1.0, 2.0, 3.0, 100.0, 4.0],
        };
        for (backend, formulation) in SOLVERS {
            let out = solve_l1(&regression, 0, &[], formulation, &with_backend(backend)).unwrap();
            assert_eq!(out.status, SolveStatus::Solved);
            assert!(
                (out.x[0] - 3.0).abs() < 1e-6,
                "{backend:?} {formulation:?}: {}",
                out.x[0]
            );
        }
    }

    #[test]
    fn assembly_matches_the_dense_formulation() {
        let regression = Regression {
            width: 2,
            rows: vec![1.0, 2.0, 0.0, 3.0],
            target: vec![4.0, 5.0],
        };
        let group = ConstraintGroup {
            cone: SupportedConeT::NonnegativeConeT(1),
            // Two entries on one (row, column) are summed.
            entries: vec![(0, 2, 1.0), (0, 1, 0.5), (0, 2, 1.0)],
            rhs: vec![7.0],
        };
        let problem = assemble(&regression, 1, &[group], L1Formulation::Slack, 3.0).unwrap();
        assert!(problem.a.check_format().is_ok());
        // Columns: c0 c1 e0 δ0 δ1; rows: 2 upper, 2 lower, 1 group.
        let expected = vec![
            vec![1.0, 2.0, 0.0, -1.0, 0.0],
            vec![0.0, 3.0, 0.0, 0.0, -1.0],
            vec![-1.0, -2.0, 0.0, -1.0, 0.0],
            vec![0.0, -3.0, 0.0, 0.0, -1.0],
            vec![0.0, 0.5, 2.0, 0.0, 0.0],
        ];
        assert_eq!(dense(&problem.a), expected);
        assert_eq!(problem.b, vec![4.0, 5.0, -4.0, -5.0, 7.0]);
        assert_eq!(problem.q, vec![0.0, 0.0, 0.0, 3.0, 3.0]);
        assert_eq!(problem.group_rows, vec![4..5]);

        let regression = Regression {
            width: 1,
            rows: vec![2.0],
            target: vec![4.0],
        };
        let problem = assemble(&regression, 0, &[], L1Formulation::Split, 1.0).unwrap();
        assert!(problem.a.check_format().is_ok());
        // Columns c u v; rows: equality, −u ≤ 0, −v ≤ 0.
        let expected = vec![
            vec![2.0, 1.0, -1.0],
            vec![0.0, -1.0, 0.0],
            vec![0.0, 0.0, -1.0],
        ];
        assert_eq!(dense(&problem.a), expected);
        assert_eq!(problem.b, vec![4.0, 0.0, 0.0]);
        assert_eq!(problem.cones.len(), 2);
    }

    #[test]
    fn stacked_rows_and_column_norms() {
        let top = Regression {
            width: 2,
            rows: vec![1.0, -2.0],
            target: vec![3.0],
        };
        let below = Regression {
            width: 2,
            rows: vec![0.0, 4.0, -5.0, 0.5],
            target: vec![6.0, 7.0],
        };
        let both = top.stacked(&below);
        assert_eq!(both.rows, vec![1.0, -2.0, 0.0, 4.0, -5.0, 0.5]);
        assert_eq!(both.target, vec![3.0, 6.0, 7.0]);
        assert_eq!(both.column_l1_norms(), vec![6.0, 6.5]);
        // Σ|t − A c| at c = (1, 1): |3 + 1| + |6 − 4| + |7 + 4.5|.
        assert_eq!(both.l1_residual(&[1.0, 1.0]), 17.5);
    }

    #[test]
    fn malformed_groups_are_errors_not_panics() {
        let regression = Regression {
            width: 1,
            rows: vec![1.0],
            target: vec![1.0],
        };
        let group = ConstraintGroup {
            cone: SupportedConeT::NonnegativeConeT(1),
            entries: vec![(3, 0, 1.0)],
            rhs: vec![0.0],
        };
        assert!(matches!(
            assemble(&regression, 0, &[group], L1Formulation::Slack, 1.0),
            Err(Error::Solver { .. })
        ));
    }

    #[test]
    fn settings_validation_names_the_field() {
        let settings = SolverSettings {
            tol_feas: f64::NAN,
            ..SolverSettings::default()
        };
        let err = settings.validate().unwrap_err().to_string();
        assert!(err.contains("tol_feas"), "{err}");
    }
}
