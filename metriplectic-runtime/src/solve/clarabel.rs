//! Clarabel as a second backend (cargo feature `clarabel`): the L1 problem
//! written in Clarabel's standard conic form
//!
//! ```text
//! min qᵀx   s.t.  A x + s = b,  s ∈ K,
//! ```
//!
//! with A assembled column by column straight into compressed sparse column
//! (CSC) storage. Variables are laid out as `[coefficients | extra | L1
//! auxiliaries]`; rows as `[regression rows | constraint blocks in order]`.
//! Kept beside the dense backend so that every problem the runtime solves
//! can be cross-checked against an independent, well-tested solver.

use std::time::Instant;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::solve::{Cone, L1Problem, L1Solution, SolveStatus, SolverSettings};

/// How the L1 objective Σ|r| is written as a conic program for Clarabel
/// (the dense backend eliminates the auxiliaries itself). Default
/// [`Split`](Self::Split).
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

fn to_clarabel(settings: &SolverSettings) -> DefaultSettings<f64> {
    DefaultSettings {
        max_iter: settings.max_iter,
        time_limit: settings.time_limit.unwrap_or(f64::INFINITY),
        tol_gap_abs: settings.tol_gap_abs,
        tol_gap_rel: settings.tol_gap_rel,
        tol_feas: settings.tol_feas,
        verbose: settings.verbose,
        ..DefaultSettings::default()
    }
}

fn clarabel_cone(cone: Cone) -> SupportedConeT<f64> {
    match cone {
        Cone::Zero(d) => SupportedConeT::ZeroConeT(d),
        Cone::Nonnegative(d) => SupportedConeT::NonnegativeConeT(d),
        Cone::Psd(n) => SupportedConeT::PSDTriangleConeT(n),
    }
}

/// Solves `problem` with Clarabel in the given formulation.
pub(crate) fn solve(
    problem: &L1Problem,
    formulation: L1Formulation,
    settings: &SolverSettings,
) -> Result<L1Solution> {
    let start = Instant::now();
    let conic = assemble(problem, formulation, settings.objective_scale);
    let setup_seconds = start.elapsed().as_secs_f64();

    let start = Instant::now();
    let p = CscMatrix::zeros((conic.q.len(), conic.q.len()));
    let mut solver = DefaultSolver::new(
        &p,
        &conic.q,
        &conic.a,
        &conic.b,
        &conic.cones,
        to_clarabel(settings),
    )
    .map_err(|e| Error::Solver {
        reason: format!("Clarabel rejected the problem: {e}"),
    })?;
    solver.solve();
    let solve_seconds = start.elapsed().as_secs_f64();
    let solution = &solver.solution;
    Ok(L1Solution {
        variables: solution.x[..problem.variables()].to_vec(),
        width: problem.regression.width,
        slacks: conic
            .block_rows
            .iter()
            .map(|range| solution.s[range.clone()].to_vec())
            .collect(),
        status: solution.status.into(),
        iterations: solution.iterations,
        setup_seconds,
        solve_seconds,
    })
}

/// Clarabel's (q, A, b, cones), and the rows of each constraint block.
pub(crate) struct ConicProblem {
    pub q: Vec<f64>,
    pub a: CscMatrix<f64>,
    pub b: Vec<f64>,
    pub cones: Vec<SupportedConeT<f64>>,
    pub block_rows: Vec<std::ops::Range<usize>>,
}

/// Builds Clarabel's (q, A, b, cones) directly in CSC form.
pub(crate) fn assemble(
    problem: &L1Problem,
    formulation: L1Formulation,
    objective_scale: f64,
) -> ConicProblem {
    let regression = &problem.regression;
    let width = regression.width;
    let r = regression.len();
    let extra = problem.extra;
    let head_vars = width + extra;
    let (aux_vars, regression_rows) = match formulation {
        L1Formulation::Slack => (r, 2 * r),
        L1Formulation::ExplicitResidual => (2 * r, 3 * r),
        L1Formulation::Split => (2 * r, 3 * r),
    };
    let n_vars = head_vars + aux_vars;

    // Group rows follow the regression rows; bucket group entries by column.
    let mut group_offsets = Vec::with_capacity(problem.constraints.len());
    let mut total_rows = regression_rows;
    let mut by_column: Vec<Vec<(usize, f64)>> = vec![Vec::new(); head_vars];
    for group in &problem.constraints {
        let dim = group.cone.rows();
        for &(row, col, value) in &group.entries {
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
    let mut cones = Vec::with_capacity(problem.constraints.len() + 2);
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
    for (group, &offset) in problem.constraints.iter().zip(&group_offsets) {
        b[offset..offset + group.rhs.len()].copy_from_slice(&group.rhs);
        cones.push(clarabel_cone(group.cone));
    }
    // Clarabel rejects zero-dimensional cones.
    cones.retain(|cone| rows(cone) > 0);

    let a = CscMatrix::new(total_rows, n_vars, colptr, rowval, nzval);
    let group_rows = problem
        .constraints
        .iter()
        .zip(&group_offsets)
        .map(|(group, &offset)| offset..offset + group.rhs.len())
        .collect();
    ConicProblem {
        q,
        a,
        b,
        cones,
        block_rows: group_rows,
    }
}

/// Number of rows a cone occupies.
fn rows(cone: &SupportedConeT<f64>) -> usize {
    match cone {
        SupportedConeT::ZeroConeT(d) | SupportedConeT::NonnegativeConeT(d) => *d,
        SupportedConeT::PSDTriangleConeT(n) => n * (n + 1) / 2,
        // The runtime only builds the three cones above.
        _ => 1,
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::Regression;

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
    fn clarabel_psd_cone_uses_scaled_upper_triangle() {
        // min tr(C X) s.t. tr X = 1, X ⪰ 0 has value λ_min(C) = 1 at
        // X = ½[[1, −1], [−1, 1]] for C = [[2, 1], [1, 2]].
        let s2 = std::f64::consts::SQRT_2;
        let c = [2.0, s2, 2.0];
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
        let settings = to_clarabel(&SolverSettings::default());
        let mut solver = DefaultSolver::new(&p, &c, &a, &b, &cones, settings).unwrap();
        solver.solve();
        assert_eq!(solver.solution.status, SolverStatus::Solved);
        let x = crate::solve::svec::unsvec(2, &solver.solution.x);
        let expected = [0.5, -0.5, -0.5, 0.5];
        for (got, want) in x.iter().zip(&expected) {
            assert!((got - want).abs() < 1e-7, "X = {x:?}");
        }
        assert!((solver.solution.obj_val - 1.0).abs() < 1e-7);
    }

    #[test]
    fn assembly_matches_the_dense_formulation() {
        let regression = Regression::new(2, vec![1.0, 2.0, 0.0, 3.0], vec![4.0, 5.0]).unwrap();
        let mut problem = L1Problem::new(regression, 1);
        // Two entries on one (row, column) are summed.
        problem
            .constrain(
                Cone::Nonnegative(1),
                vec![(0, 2, 1.0), (0, 1, 0.5), (0, 2, 1.0)],
                vec![7.0],
            )
            .unwrap();
        let conic = assemble(&problem, L1Formulation::Slack, 3.0);
        assert!(conic.a.check_format().is_ok());
        // Columns: c0 c1 e0 δ0 δ1; rows: 2 upper, 2 lower, 1 block.
        let expected = vec![
            vec![1.0, 2.0, 0.0, -1.0, 0.0],
            vec![0.0, 3.0, 0.0, 0.0, -1.0],
            vec![-1.0, -2.0, 0.0, -1.0, 0.0],
            vec![0.0, -3.0, 0.0, 0.0, -1.0],
            vec![0.0, 0.5, 2.0, 0.0, 0.0],
        ];
        assert_eq!(dense(&conic.a), expected);
        assert_eq!(conic.b, vec![4.0, 5.0, -4.0, -5.0, 7.0]);
        assert_eq!(conic.q, vec![0.0, 0.0, 0.0, 3.0, 3.0]);
        assert_eq!(conic.block_rows, vec![4..5]);

        let regression = Regression::new(1, vec![2.0], vec![4.0]).unwrap();
        let conic = assemble(&L1Problem::new(regression, 0), L1Formulation::Split, 1.0);
        assert!(conic.a.check_format().is_ok());
        // Columns c u v; rows: equality, −u ≤ 0, −v ≤ 0.
        let expected = vec![
            vec![2.0, 1.0, -1.0],
            vec![0.0, -1.0, 0.0],
            vec![0.0, 0.0, -1.0],
        ];
        assert_eq!(dense(&conic.a), expected);
        assert_eq!(conic.b, vec![4.0, 0.0, 0.0]);
        assert_eq!(conic.cones.len(), 2);
    }
}
