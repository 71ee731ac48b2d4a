//! Eliminating the equality constraints: c = c₀ + Z y parametrises
//! {c : E c = f} with an orthonormal null-space basis Z, so the iteration
//! works on y alone.

use nalgebra::{DMatrix, DVector};

use crate::solve::linalg::{gram, symmetric_eigen};

/// c = c₀ + Z y.
pub(super) struct Elimination {
    pub c0: DVector<f64>,
    /// n_vars × k, orthonormal columns (the identity without equalities).
    pub basis: DMatrix<f64>,
    /// `true` if there were no equalities (c = y).
    pub identity: bool,
}

/// Why the equalities could not be eliminated.
pub(super) enum Failure {
    /// E c = f has no solution.
    Inconsistent,
    /// The eigensolver failed.
    Numerical,
}

/// The null space of E from the eigenvectors of EᵀE, and the least-norm
/// solution c₀.
pub(super) fn eliminate(
    e: &DMatrix<f64>,
    f: &DVector<f64>,
    n_vars: usize,
) -> Result<Elimination, Failure> {
    if e.nrows() == 0 {
        return Ok(Elimination {
            c0: DVector::zeros(n_vars),
            basis: DMatrix::identity(n_vars, n_vars),
            identity: true,
        });
    }
    let (eigenvalues, eigenvectors) = symmetric_eigen(&gram(e)).ok_or(Failure::Numerical)?;
    let largest = eigenvalues.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    // σ ≤ 1e-7 σ_max counts as zero (EᵀE holds σ²).
    let threshold = 1e-14 * largest.max(f64::MIN_POSITIVE);
    let etf = e.tr_mul(f);
    let mut c0 = DVector::zeros(n_vars);
    let mut null = Vec::new();
    for (index, &value) in eigenvalues.iter().enumerate() {
        let v = eigenvectors.column(index);
        if value > threshold {
            c0 += v * (v.dot(&etf) / value);
        } else {
            null.push(v.into_owned());
        }
    }
    let residual = (e * &c0 - f).amax();
    if residual > 1e-9 * (1.0 + f.amax()) {
        return Err(Failure::Inconsistent);
    }
    let basis = if null.is_empty() {
        DMatrix::zeros(n_vars, 0)
    } else {
        DMatrix::from_columns(&null)
    };
    Ok(Elimination {
        c0,
        basis,
        identity: false,
    })
}
