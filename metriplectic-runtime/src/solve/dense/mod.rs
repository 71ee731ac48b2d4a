//! A dense primal–dual interior-point method for L1 regressions with side
//! cones, the default [`SolverBackend`](crate::SolverBackend).
//!
//! Why not only Clarabel: every subproblem couples r ≈ n·q residuals to a
//! few dozen dense coefficient columns. A general sparse solver factorises
//! its KKT matrix with a scalar LDLᵀ, and eliminating each residual updates
//! the dense coefficient block one entry at a time. Here the L1 auxiliaries
//! are eliminated analytically, so an iteration factorises one k×k matrix
//! Aᵀ D̃ A + (cone part), formed with a dense matrix product.
//!
//! The problem, with x = (c, e) and the side constraints of the blocks:
//!
//! ```text
//! min  w·Σᵢ eᵢ   s.t.  eᵢ ≥ ±(tᵢ − aᵢᵀ c),   E c = f,   h − G c ∈ K,
//! ```
//!
//! K a product of nonnegative orthants and PSD cones (svec layout). The
//! equalities are eliminated first ([`equalities`]), so the iteration works
//! on y alone; [`iteration`] is the standard infeasible path-following
//! scheme with Nesterov–Todd scaling ([`cones`]) and Mehrotra's
//! predictor–corrector, as in CVXOPT's `coneqp` without equalities (on
//! LPs with Gondzio's centrality correctors added), solving its Newton
//! systems through the normal equations ([`newton`]). It has no
//! homogeneous embedding and so no infeasibility certificate: the L1
//! objective is bounded below and the searches' cones (box, SOS Gram
//! matrices) are never empty, but a joint step from a metric outside the
//! SOS tables can be infeasible, and then ends not usable (stall guard,
//! iteration limit). Inconsistent equalities are reported as primal
//! infeasible before iterating.

mod cones;
mod equalities;
mod equilibrate;
mod iteration;
mod newton;
mod side_rows;

use std::time::Instant;

use nalgebra::{DMatrix, DVector};

use cones::Segment;
use equalities::Elimination;
use side_rows::SideRows;

use crate::error::Result;
use crate::solve::linalg::{congruence, RowMajor};
use crate::solve::{Cone, L1Problem, L1Solution, Regression, SolveStatus, SolverSettings};

/// Problem data after the equalities are eliminated.
struct Reduced {
    /// r × k regression block on y, by rows.
    a: RowMajor,
    /// A Z as a product, when forming its Gram matrix through it is cheaper.
    narrow: Option<Narrow>,
    /// Targets t − A c₀.
    t: DVector<f64>,
    /// Side-cone rows on y: h − G y ∈ K (dense, m × k).
    g: DMatrix<f64>,
    h: DVector<f64>,
    segments: Vec<Segment>,
    /// How the side-cone rows enter the Schur complement.
    side_rows: SideRows,
    /// Objective weight w of Σ e.
    weight: f64,
}

/// The regression block A Z kept as the product of the regression's own
/// columns and the map Z_w from y to them (the first `width` rows of Z).
/// A metric search reads its w metric coefficients, but y has a coordinate
/// for every free Gram entry as well (k ≈ 2w on a six-state region
/// certificate), so Zᵀ_w (Aᵀ D̃ A) Z_w costs r·w²/2 + w²·k + w·k²/2
/// multiply-adds where (A Z)ᵀ D̃ (A Z) costs r·k²/2.
struct Narrow {
    /// A, r × w, by rows.
    a: RowMajor,
    /// Z_w, w × k.
    map: DMatrix<f64>,
}

impl Narrow {
    /// Keeps A's rows and the map when the Gram product through them takes
    /// at most `NARROW_GAIN` of the multiply-adds of the reduced block's.
    fn worthwhile(rows: usize, width: usize, k: usize) -> bool {
        let (r, w, k) = (rows as f64, width as f64, k as f64);
        r * w * w / 2.0 + w * w * k + w * k * k / 2.0 <= NARROW_GAIN * r * k * k / 2.0
    }

    /// (A Z)ᵀ diag(d) (A Z).
    fn weighted_gram(&self, d: &DVector<f64>, buffer: &mut Vec<f64>) -> DMatrix<f64> {
        congruence(&self.a.weighted_gram(d, buffer), &self.map)
    }
}

/// The Gram product goes through [`Narrow`] when that takes at most this
/// fraction of the multiply-adds (a margin for its two extra products).
const NARROW_GAIN: f64 = 0.6;

/// Solves `problem` (see the module docs).
pub(crate) fn solve(problem: &L1Problem, settings: &SolverSettings) -> Result<L1Solution> {
    let start = Instant::now();
    let n_vars = problem.variables();
    let mut split = split_constraints(problem);
    let (scaling, regression) = equilibrate::Scaling::equilibrate(&problem.regression, &mut split);
    let elimination = match equalities::eliminate(&split.e, &split.f, n_vars) {
        Ok(elimination) => elimination,
        Err(failure) => {
            return Ok(L1Solution {
                variables: vec![f64::NAN; n_vars],
                width: problem.regression.width,
                slacks: problem
                    .constraints
                    .iter()
                    .map(|c| vec![0.0; c.rhs.len()])
                    .collect(),
                status: match failure {
                    equalities::Failure::Inconsistent => SolveStatus::PrimalInfeasible,
                    equalities::Failure::Numerical => SolveStatus::NumericalError,
                },
                iterations: 0,
                setup_seconds: start.elapsed().as_secs_f64(),
                solve_seconds: 0.0,
            })
        }
    };
    let reduced = reduce(regression, split, &elimination, settings.objective_scale);
    let setup_seconds = start.elapsed().as_secs_f64();

    let start = Instant::now();
    let (point, status, iterations) = iteration::iterate(&reduced, settings);
    let solve_seconds = start.elapsed().as_secs_f64();

    let x = elimination.expand(&point.y);
    let mut slacks: Vec<Vec<f64>> = problem
        .constraints
        .iter()
        .map(|c| vec![0.0; c.rhs.len()])
        .collect();
    for segment in &reduced.segments {
        slacks[segment.block] =
            scaling.unscale_side(&point.sc.as_slice()[segment.range()], segment.offset);
    }
    Ok(L1Solution {
        variables: scaling.unscale_variables(&x),
        width: problem.regression.width,
        slacks,
        status,
        iterations,
        setup_seconds,
        solve_seconds,
    })
}

/// The constraint blocks as dense rows: equalities (E, f) and side cones
/// (G, h) with their segments.
pub(super) struct Split {
    e: DMatrix<f64>,
    f: DVector<f64>,
    g: DMatrix<f64>,
    h: DVector<f64>,
    segments: Vec<Segment>,
}

fn split_constraints(problem: &L1Problem) -> Split {
    let n_vars = problem.variables();
    let mut eq_rows = 0;
    let mut side_rows = 0;
    let mut segments = Vec::new();
    let mut offsets = Vec::with_capacity(problem.constraints.len());
    for (index, constraint) in problem.constraints.iter().enumerate() {
        let len = constraint.cone.rows();
        let psd = match constraint.cone {
            Cone::Zero(_) => {
                offsets.push(eq_rows);
                eq_rows += len;
                continue;
            }
            Cone::Nonnegative(_) => None,
            Cone::Psd(n) => Some(n),
        };
        offsets.push(side_rows);
        segments.push(Segment {
            block: index,
            offset: side_rows,
            psd,
            len,
        });
        side_rows += len;
    }
    let mut split = Split {
        e: DMatrix::zeros(eq_rows, n_vars),
        f: DVector::zeros(eq_rows),
        g: DMatrix::zeros(side_rows, n_vars),
        h: DVector::zeros(side_rows),
        segments,
    };
    for (constraint, &offset) in problem.constraints.iter().zip(&offsets) {
        let (matrix, rhs) = match constraint.cone {
            Cone::Zero(_) => (&mut split.e, &mut split.f),
            _ => (&mut split.g, &mut split.h),
        };
        for &(row, col, value) in &constraint.entries {
            // Rows read A x + s = b; an entry is +A.
            matrix[(offset + row, col)] += value;
        }
        rhs.rows_mut(offset, constraint.rhs.len())
            .copy_from_slice(&constraint.rhs);
    }
    split
}

/// The problem on y after c = c₀ + Z y. The regression's rows are moved,
/// not copied, and with equalities A Z is built in their storage.
fn reduce(regression: Regression, split: Split, elimination: &Elimination, weight: f64) -> Reduced {
    let width = regression.width;
    let r = regression.len();
    let k = elimination.dimension();
    let a_full = RowMajor::from_rows(r, width, regression.rows);
    let c0 = elimination.c0.rows(0, width).into_owned();
    let t = DVector::from_vec(regression.target) - a_full.mul(&c0);
    let narrow = (!elimination.is_identity() && Narrow::worthwhile(r, width, k)).then(|| Narrow {
        a: a_full.clone(),
        map: elimination.basis(width),
    });
    let a = if elimination.is_identity() && k == width {
        a_full
    } else {
        reduce_regression(a_full.into_data(), r, width, elimination)
    };
    let h = &split.h - &split.g * &elimination.c0;
    let g = if elimination.is_identity() {
        split.g
    } else {
        elimination.reduce_columns(&split.g)
    };
    let side_rows = SideRows::new(&g, &split.segments);
    Reduced {
        a,
        narrow,
        t,
        g,
        h,
        segments: split.segments,
        side_rows,
        weight,
    }
}

/// A Z for the regression block (whose width may be below the number of
/// variables: the variables it does not read have zero columns): its free
/// columns copied, its constrained ones times the null-space basis. Built
/// in A's own storage, a block of rows at a time (forwards when Z is no
/// wider than A, backwards after growing it when it is wider, so no row is
/// overwritten before it is read): at q = 16000 samples of a 6-state system
/// with 923 entropy coefficients a second copy took 725 MB.
fn reduce_regression(
    mut data: Vec<f64>,
    r: usize,
    width: usize,
    elimination: &Elimination,
) -> RowMajor {
    const BLOCK: usize = 256;
    let (k, free) = (elimination.dimension(), elimination.free.len());
    let read: Vec<(usize, usize)> = elimination
        .constrained
        .iter()
        .enumerate()
        .filter(|&(_, &j)| j < width)
        .map(|(row, &j)| (row, j))
        .collect();
    let null = elimination
        .null
        .select_rows(read.iter().map(|(row, _)| row));
    let mut block = vec![0.0; BLOCK * k];
    let mut reduce_rows = |data: &mut Vec<f64>, first: usize, last: usize| {
        let count = last - first;
        let old = |i: usize, j: usize| data[(first + i) * width + j];
        for (i, row) in block.chunks_exact_mut(k.max(1)).take(count).enumerate() {
            for (target, &j) in row.iter_mut().zip(&elimination.free) {
                *target = if j < width { old(i, j) } else { 0.0 };
            }
            row[free..].fill(0.0);
        }
        if !read.is_empty() && free < k {
            let gathered = DMatrix::from_fn(count, read.len(), |i, m| old(i, read[m].1));
            let product = gathered * &null;
            for (i, row) in block.chunks_exact_mut(k).take(count).enumerate() {
                for (c, target) in row[free..].iter_mut().enumerate() {
                    *target = product[(i, c)];
                }
            }
        }
        data[first * k..last * k].copy_from_slice(&block[..count * k]);
    };
    let starts: Vec<usize> = (0..r).step_by(BLOCK).collect();
    if k <= width {
        for &first in &starts {
            reduce_rows(&mut data, first, (first + BLOCK).min(r));
        }
        data.truncate(r * k);
        data.shrink_to_fit();
    } else {
        data.resize(r * k, 0.0);
        for &first in starts.iter().rev() {
            reduce_rows(&mut data, first, (first + BLOCK).min(r));
        }
    }
    RowMajor::from_rows(r, k, data)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A pseudo-random regression (a fixed linear congruential sequence).
    pub(crate) fn random_regression(rows: usize, width: usize, seed: u64) -> Regression {
        let mut state = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let rows_data: Vec<f64> = (0..rows * width).map(|_| next()).collect();
        let target = (0..rows).map(|_| 3.0 * next()).collect();
        Regression {
            width,
            rows: rows_data,
            target,
        }
    }

    /// |cₖ| ≤ bound for every coefficient.
    pub(crate) fn box_problem(regression: Regression, bound: f64) -> L1Problem {
        let width = regression.width;
        let mut problem = L1Problem::new(regression, 0);
        let mut entries = Vec::new();
        for k in 0..width {
            entries.push((k, k, 1.0));
            entries.push((width + k, k, -1.0));
        }
        problem
            .constrain(
                Cone::Nonnegative(2 * width),
                entries,
                vec![bound; 2 * width],
            )
            .unwrap();
        problem
    }

    /// `problem` reduced as `solve` reduces it, without equilibration.
    pub(super) fn reduced(problem: &L1Problem) -> Reduced {
        let split = split_constraints(problem);
        let elimination = equalities::eliminate(&split.e, &split.f, problem.variables())
            .unwrap_or_else(|_| panic!("consistent equalities"));
        reduce(problem.regression.clone(), split, &elimination, 1.0)
    }

    /// A Z built in A's storage equals the dense product, whether Z is
    /// narrower than A (an equality on three of its columns) or wider
    /// (one on two variables A does not read), over several row blocks.
    #[test]
    fn reduced_regression_in_place_matches_the_dense_product() {
        let (r, width) = (600, 6);
        let regression = random_regression(r, width, 4);
        let a = DMatrix::from_row_slice(r, width, &regression.rows);
        for (n_vars, read) in [(6, vec![0, 1, 2]), (10, vec![6, 7])] {
            let mut e = DMatrix::zeros(1, n_vars);
            read.iter().for_each(|&j| e[(0, j)] = 1.0);
            let elimination = equalities::eliminate(&e, &DVector::from_element(1, 1.0), n_vars)
                .unwrap_or_else(|_| panic!("consistent equalities"));
            let k = elimination.dimension();
            let expected = &a * elimination.basis(width);
            let reduced = reduce_regression(regression.rows.clone(), r, width, &elimination);
            assert_eq!((reduced.ncols(), k > width), (k, n_vars > width));
            let got = DMatrix::from_fn(r, k, |i, j| reduced.row(i)[j]);
            assert!((got - expected).amax() < 1e-14, "{n_vars} variables");
        }
    }

    /// A metric search's shape: the regression reads the first 8 of 30
    /// variables and equalities tie them to the other 22, so y is wider
    /// than the regression and the Gram product goes through its columns.
    #[test]
    fn the_gram_product_through_the_regression_columns_matches_the_reduced_one() {
        let (r, width, n_vars) = (300, 8, 30);
        let mut problem = L1Problem::new(random_regression(r, width, 7), n_vars - width);
        let e = random_regression(6, n_vars, 11).rows;
        let entries: Vec<(usize, usize, f64)> = (0..6)
            .flat_map(|row| (0..n_vars).map(move |j| (row, j)))
            .zip(e)
            .map(|((row, j), value)| (row, j, value))
            .collect();
        problem
            .constrain(Cone::Zero(6), entries, vec![0.5; 6])
            .unwrap_or_else(|e| panic!("{e}"));
        let reduced = reduced(&problem);
        let narrow = reduced
            .narrow
            .as_ref()
            .unwrap_or_else(|| panic!("y has 24 coordinates for 8 regression columns"));
        let weights = DVector::from_fn(r, |i, _| 10f64.powi((i % 7) as i32 - 3));
        let mut buffer = Vec::new();
        let through = narrow.weighted_gram(&weights, &mut buffer);
        let direct = reduced.a.weighted_gram(&weights, &mut buffer);
        assert_eq!(through.shape(), (24, 24));
        let error = (&through - &direct).amax() / direct.amax();
        assert!(error < 1e-13, "relative difference {error:.1e}");
        assert_eq!(through, through.transpose());
    }

    #[test]
    fn side_row_products_match_the_dense_ones() {
        // A box on 40 coefficients (sparse rows) and one dense orthant row.
        let width = 40;
        let mut problem = box_problem(random_regression(60, width, 2), 5.0);
        let dense_row: Vec<(usize, usize, f64)> =
            (0..width).map(|k| (0, k, 1.0 + k as f64)).collect();
        problem
            .constrain(Cone::Nonnegative(1), dense_row, vec![1.0])
            .unwrap();
        let p = reduced(&problem);
        assert_eq!(p.side_rows.sparse.len(), 2 * width);
        assert_eq!(p.side_rows.dense, vec![2 * width]);
        let v = DVector::from_fn(width, |k, _| (k as f64 * 0.37).sin());
        let w = DVector::from_fn(2 * width + 1, |i, _| (i as f64 * 0.91).cos());
        assert!((p.side_rows.mul(&p.g, &v) - &p.g * &v).amax() < 1e-13);
        assert!((p.side_rows.tr_mul(&p.g, &w) - p.g.tr_mul(&w)).amax() < 1e-13);
    }

    #[test]
    fn inconsistent_equalities_are_primal_infeasible() {
        // c₀ = 1 and c₀ = 2.
        let mut problem = L1Problem::new(random_regression(5, 1, 3), 0);
        problem
            .constrain(
                Cone::Zero(2),
                vec![(0, 0, 1.0), (1, 0, 1.0)],
                vec![1.0, 2.0],
            )
            .unwrap();
        let out = solve(&problem, &SolverSettings::default()).unwrap();
        assert_eq!(out.status, SolveStatus::PrimalInfeasible);
        assert_eq!(out.iterations, 0);
    }

    #[test]
    fn consistent_equalities_fix_the_coefficients() {
        // c₀ + c₁ = 1 (twice, redundantly) and c₀ − c₁ = 0.5.
        let mut problem = L1Problem::new(random_regression(30, 2, 4), 0);
        let entries = vec![
            (0, 0, 1.0),
            (0, 1, 1.0),
            (1, 0, 2.0),
            (1, 1, 2.0),
            (2, 0, 1.0),
            (2, 1, -1.0),
        ];
        problem
            .constrain(Cone::Zero(3), entries, vec![1.0, 2.0, 0.5])
            .unwrap();
        let out = solve(&problem, &SolverSettings::default()).unwrap();
        assert_eq!(out.status, SolveStatus::Solved);
        let x = out.coefficients();
        assert!(
            (x[0] - 0.75).abs() < 1e-12 && (x[1] - 0.25).abs() < 1e-12,
            "{x:?}"
        );
    }

    #[test]
    fn unconstrained_rank_deficient_regression_still_solves() {
        // Two identical columns and no cone: the Schur complement is singular.
        let base = random_regression(50, 1, 6);
        let rows = base.rows.iter().flat_map(|&a| [a, a]).collect();
        let regression = Regression {
            width: 2,
            rows,
            target: base.target.clone(),
        };
        let out = solve(
            &L1Problem::new(regression.clone(), 0),
            &SolverSettings::default(),
        )
        .unwrap();
        assert!(out.status.is_usable(), "{:?}", out.status);
        let single = solve(&L1Problem::new(base.clone(), 0), &SolverSettings::default()).unwrap();
        let (a, b) = (
            regression.l1_residual(out.coefficients()),
            base.l1_residual(single.coefficients()),
        );
        assert!((a - b).abs() <= 1e-7 * b, "{a} vs {b}");
    }

    #[test]
    fn iteration_limit_is_reported() {
        let limited = SolverSettings {
            max_iter: 2,
            ..SolverSettings::default()
        };
        let out = solve(&box_problem(random_regression(200, 7, 8), 10.0), &limited).unwrap();
        assert_eq!(out.status, SolveStatus::MaxIterations);
        assert_eq!(out.iterations, 2);
        assert!(out.variables().iter().all(|v| v.is_finite()));
    }

    #[test]
    fn no_rows_is_not_a_panic() {
        let regression = Regression {
            width: 2,
            rows: Vec::new(),
            target: Vec::new(),
        };
        let out = solve(&box_problem(regression, 1.0), &SolverSettings::default()).unwrap();
        assert_eq!(out.status, SolveStatus::Solved);
        assert!(out.coefficients().iter().all(|v| v.abs() <= 1.0));
    }

    #[test]
    fn box_slacks_lie_in_the_orthant() {
        let problem = box_problem(random_regression(200, 7, 7), 0.05);
        let out = solve(&problem, &SolverSettings::default()).unwrap();
        assert_eq!(out.status, SolveStatus::Solved);
        assert!(out
            .coefficients()
            .iter()
            .all(|v| v.abs() <= 0.05 * (1.0 + 1e-8)));
        // The box slacks are η ∓ c.
        assert!(out
            .slack(crate::solve::ConstraintId(0))
            .iter()
            .all(|&s| s >= 0.0));
    }
}
