//! The problem language: an L1 regression with side constraints in cones.

use crate::error::{invalid, Result};

/// The cone of a block of constraint rows.
///
/// A block's rows read `b − A x ∈ K` (Clarabel's `A x + s = b, s ∈ K`).
/// PSD blocks hold a symmetric n×n matrix in *svec* layout: the upper
/// triangle stacked column by column, off-diagonal entries multiplied by √2,
/// so that the Euclidean inner product of two svec vectors is the trace
/// inner product of the matrices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Cone {
    /// `b − A x = 0`: equalities, with this many rows.
    Zero(usize),
    /// `b − A x ≥ 0` componentwise, with this many rows.
    Nonnegative(usize),
    /// `b − A x` is the svec of a positive semidefinite n×n matrix; the
    /// value is n, the block has n(n+1)/2 rows.
    Psd(usize),
}

/// Most entries of the dense solver's largest matrix, max(rows, variables)
/// × variables: 16 GiB of `f64`.
pub(crate) const MAX_DENSE_ENTRIES: usize = 1 << 31;

impl Cone {
    /// Number of constraint rows the cone occupies (`usize::MAX` when
    /// n(n+1)/2 does not fit, which no right-hand side can match).
    pub fn rows(self) -> usize {
        match self {
            Self::Zero(d) | Self::Nonnegative(d) => d,
            Self::Psd(n) => n
                .checked_add(1)
                .and_then(|m| n.checked_mul(m))
                .map_or(usize::MAX, |v| v / 2),
        }
    }
}

/// Dense regression rows: residual i is `target[i] − Σ_c rows[i·width + c]·x_c`.
///
/// ```
/// use metriplectic_runtime::Regression;
///
/// let regression = Regression::new(2, vec![1.0, 0.0, 0.0, 2.0], vec![1.0, 4.0]).unwrap();
/// assert_eq!(regression.l1_residual(&[1.0, 2.0]), 0.0);
/// ```
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Regression {
    pub(crate) width: usize,
    /// Row-major R × width.
    pub(crate) rows: Vec<f64>,
    /// R targets.
    pub(crate) target: Vec<f64>,
}

impl Regression {
    /// Rows (row-major, `target.len() × width`) and targets.
    ///
    /// Errors if the lengths disagree or a value is not finite.
    pub fn new(width: usize, rows: Vec<f64>, target: Vec<f64>) -> Result<Self> {
        if target.len().checked_mul(width) != Some(rows.len()) {
            return Err(invalid(
                "regression rows",
                format!(
                    "{} entries for {} targets × {width} columns",
                    rows.len(),
                    target.len()
                ),
            ));
        }
        crate::error::check_finite("regression rows", &rows)?;
        crate::error::check_finite("regression targets", &target)?;
        Ok(Self {
            width,
            rows,
            target,
        })
    }

    /// Number of coefficient columns.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows (residuals).
    pub fn len(&self) -> usize {
        self.target.len()
    }

    /// `true` without rows.
    pub fn is_empty(&self) -> bool {
        self.target.is_empty()
    }

    /// The rows, row-major.
    pub fn rows(&self) -> &[f64] {
        &self.rows
    }

    /// The targets.
    pub fn target(&self) -> &[f64] {
        &self.target
    }

    /// The columns of `self` followed by those of `right`, on the same rows;
    /// the targets are `self`'s.
    pub(crate) fn with_columns_of(&self, right: &Regression) -> Regression {
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

    /// The regression on `columns` only (indices in range, in the order given).
    pub(crate) fn select_columns(&self, columns: &[usize]) -> Regression {
        let mut rows = Vec::with_capacity(self.len() * columns.len());
        for row in self.rows.chunks_exact(self.width.max(1)) {
            rows.extend(columns.iter().map(|&c| row[c]));
        }
        Regression {
            width: columns.len(),
            rows,
            target: self.target.clone(),
        }
    }

    /// The rows of `self` followed by those of `below` (same width), in
    /// `self`'s storage: a large regression is not copied.
    pub(crate) fn stacked(mut self, below: &Regression) -> Regression {
        debug_assert_eq!(self.width, below.width);
        self.rows.extend_from_slice(&below.rows);
        self.target.extend_from_slice(&below.target);
        self
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
        self.l1_residual_of_first(self.len(), c)
    }

    /// ‖t − A c‖₂: the residual's Euclidean norm at coefficients `c`.
    pub(crate) fn l2_residual(&self, c: &[f64]) -> f64 {
        self.residuals(c).iter().map(|r| r * r).sum::<f64>().sqrt()
    }

    /// t − A c, row by row, at coefficients `c`.
    pub(crate) fn residuals(&self, c: &[f64]) -> Vec<f64> {
        self.rows
            .chunks_exact(self.width.max(1))
            .zip(&self.target)
            .map(|(row, t)| t - row.iter().zip(c).map(|(a, x)| a * x).sum::<f64>())
            .collect()
    }

    /// [`l1_residual`](Self::l1_residual) over the first `rows` rows only.
    pub(crate) fn l1_residual_of_first(&self, rows: usize, c: &[f64]) -> f64 {
        self.rows
            .chunks_exact(self.width.max(1))
            .zip(&self.target)
            .take(rows)
            .map(|(row, t)| (t - row.iter().zip(c).map(|(a, x)| a * x).sum::<f64>()).abs())
            .sum()
    }
}

/// A handle to a block of constraints of an [`L1Problem`], for reading its
/// slack back from the [`L1Solution`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ConstraintId(pub(crate) usize);

/// One block of constraint rows: `rhs − A x ∈ cone`, A given by its
/// non-zero entries.
#[derive(Debug, Clone)]
pub(crate) struct Constraint {
    pub cone: Cone,
    /// (local row, variable, value); entries on the same position add up.
    pub entries: Vec<(usize, usize, f64)>,
    pub rhs: Vec<f64>,
}

/// minimise Σᵢ |tᵢ − aᵢᵀ c| over the coefficients c of a [`Regression`] and
/// `extra` further variables e, subject to blocks of conic constraints on
/// x = (c, e).
///
/// ```
/// use metriplectic_runtime::{solve_l1, Cone, L1Problem, Regression, SolverSettings};
///
/// // The median of 1, 2, 3, 100, 4 subject to c ≤ 2.5.
/// let regression = Regression::new(1, vec![1.0; 5], vec![1.0, 2.0, 3.0, 100.0, 4.0]).unwrap();
/// let mut problem = L1Problem::new(regression, 0);
/// let bound = problem.constrain(Cone::Nonnegative(1), vec![(0, 0, 1.0)], vec![2.5]).unwrap();
/// let solution = solve_l1(&problem, &SolverSettings::default()).unwrap();
/// assert!((solution.coefficients()[0] - 2.5).abs() < 1e-6);
/// assert!(solution.slack(bound)[0].abs() < 1e-6);
/// ```
#[derive(Debug, Clone)]
pub struct L1Problem {
    pub(crate) regression: Regression,
    pub(crate) extra: usize,
    pub(crate) constraints: Vec<Constraint>,
}

impl L1Problem {
    /// The problem of fitting `regression`, with `extra` variables after its
    /// coefficients that only constraints refer to.
    pub fn new(regression: Regression, extra: usize) -> Self {
        Self {
            regression,
            extra,
            constraints: Vec::new(),
        }
    }

    /// Number of variables: the regression's coefficients, then the extra
    /// ones (`usize::MAX` if that does not fit; [`solve_l1`](crate::solve_l1)
    /// refuses such a problem).
    pub fn variables(&self) -> usize {
        self.regression.width.saturating_add(self.extra)
    }

    /// Errors unless the problem's sizes can be represented, and, for the
    /// dense solver (`dense`), its matrices fit in memory: the constraint
    /// and regression rows and the Schur complement, max(rows, variables)
    /// × variables, at most [`MAX_DENSE_ENTRIES`]. So no size wraps around
    /// or fails to allocate deep inside a solver.
    pub(crate) fn check_size(&self, dense: bool) -> Result<()> {
        let rows = self
            .constraints
            .iter()
            .fold(self.regression.target.len(), |sum, c| {
                sum.saturating_add(c.rhs.len())
            });
        let variables = self.variables();
        let entries = rows.max(variables).saturating_mul(variables);
        let beyond = variables > MAX_DENSE_ENTRIES || rows > MAX_DENSE_ENTRIES;
        if beyond || (dense && entries > MAX_DENSE_ENTRIES) {
            return Err(invalid(
                "problem size",
                format!(
                    "{rows} rows × {variables} variables is beyond the dense solver's matrices \
                     (at most {MAX_DENSE_ENTRIES} entries in max(rows, variables) × variables)"
                ),
            ));
        }
        Ok(())
    }

    /// The regression part of the objective.
    pub fn regression(&self) -> &Regression {
        &self.regression
    }

    /// Adds the block `rhs − A x ∈ cone`, A given by (row, variable, value)
    /// entries (entries on the same position add up).
    ///
    /// Errors name the offending entry: a row or variable out of range, a
    /// right-hand side of the wrong length, or a non-finite value.
    pub fn constrain(
        &mut self,
        cone: Cone,
        entries: Vec<(usize, usize, f64)>,
        rhs: Vec<f64>,
    ) -> Result<ConstraintId> {
        if cone == Cone::Psd(0) {
            return Err(invalid(
                "constraint cone",
                "a PSD cone of a 0×0 matrix constrains nothing; leave it out",
            ));
        }
        let rows = cone.rows();
        if rhs.len() != rows {
            return Err(invalid(
                "constraint right-hand side",
                format!("{} values for a cone of {rows} rows ({cone:?})", rhs.len()),
            ));
        }
        crate::error::check_finite("constraint right-hand side", &rhs)?;
        let variables = self.variables();
        if let Some(&(row, column, value)) = entries
            .iter()
            .find(|&&(row, column, value)| row >= rows || column >= variables || !value.is_finite())
        {
            return Err(invalid(
                "constraint entry",
                format!(
                    "({row}, {column}) = {value} is outside a block of {rows} rows × {variables} variables or not finite"
                ),
            ));
        }
        self.constraints.push(Constraint { cone, entries, rhs });
        Ok(ConstraintId(self.constraints.len() - 1))
    }
}

/// The result of [`solve_l1`](crate::solve_l1).
#[derive(Debug, Clone)]
pub struct L1Solution {
    pub(crate) variables: Vec<f64>,
    pub(crate) width: usize,
    pub(crate) slacks: Vec<Vec<f64>>,
    /// How the solve ended.
    pub status: super::SolveStatus,
    /// Interior-point iterations.
    pub iterations: u32,
    /// Seconds spent setting the problem up (assembly, elimination).
    pub setup_seconds: f64,
    /// Seconds spent iterating.
    pub solve_seconds: f64,
}

impl L1Solution {
    /// All variables x = (c, e).
    pub fn variables(&self) -> &[f64] {
        &self.variables
    }

    /// The regression coefficients c.
    pub fn coefficients(&self) -> &[f64] {
        &self.variables[..self.width]
    }

    /// The slack `rhs − A x` of a constraint block, which lies in its cone.
    pub fn slack(&self, id: ConstraintId) -> &[f64] {
        self.slacks.get(id.0).map_or(&[], Vec::as_slice)
    }
}
