//! Eliminating the equality constraints: c = c₀ + Z y parametrises
//! {c : E c = f} with an orthonormal null-space basis Z, so the iteration
//! works on y alone.
//!
//! Most variables of a subproblem often appear in no equality (the entropy
//! coefficients of a joint step, whose equalities tie only the metric to
//! its Gram matrices). Those stay coordinates of y, and only the columns of
//! E that are not zero are factorised, with an SVD of that block. Z then
//! keeps the problem's sparsity (a box on a free coefficient stays one
//! non-zero per row), A Z is a copy of A's free columns plus a narrow
//! product, and the factorisation is as small as the equalities. An
//! eigendecomposition of the whole EᵀE would square E's condition number,
//! and faer's did not converge on a joint step's (986 columns, 923 of them
//! zero; `docs/method.md` §4, item 6).

use nalgebra::{DMatrix, DVector};

use crate::solve::linalg::svd;

/// Singular values at most this fraction of the largest count as zero.
const RANK_TOLERANCE: f64 = 1e-7;
/// E c₀ = f must hold to this much, relative to 1 + |f|∞, or the
/// equalities are inconsistent.
const CONSISTENCY_TOLERANCE: f64 = 1e-9;

/// c = c₀ + Z y, with y = (c restricted to the free variables, coordinates
/// of the null space on the constrained ones).
pub(super) struct Elimination {
    /// The least-norm solution of E c = f (zero on the free variables).
    pub c0: DVector<f64>,
    /// The variables no equality reads, ascending: y's first coordinates.
    pub free: Vec<usize>,
    /// The variables some equality reads, ascending.
    pub constrained: Vec<usize>,
    /// An orthonormal basis (`constrained.len()` × the rest of y) of the
    /// null space of E restricted to the constrained variables.
    pub null: DMatrix<f64>,
}

/// Why the equalities could not be eliminated.
pub(super) enum Failure {
    /// E c = f has no solution.
    Inconsistent,
    /// The SVD failed.
    Numerical,
}

impl Elimination {
    /// The number of coordinates of y.
    pub fn dimension(&self) -> usize {
        self.free.len() + self.null.ncols()
    }

    /// `true` if there are no equalities (Z = I, c = y).
    pub fn is_identity(&self) -> bool {
        self.constrained.is_empty()
    }

    /// c = c₀ + Z y.
    pub fn expand(&self, y: &DVector<f64>) -> DVector<f64> {
        let mut c = self.c0.clone();
        let (free, rest) = y.as_slice().split_at(self.free.len());
        for (&j, &value) in self.free.iter().zip(free) {
            c[j] += value;
        }
        let constrained = &self.null * DVector::from_column_slice(rest);
        for (&j, value) in self.constrained.iter().zip(constrained.iter()) {
            c[j] += value;
        }
        c
    }

    /// The first `rows` rows of Z (c = c₀ + Z y), dense: the map from y to
    /// the variables a regression of that width reads.
    pub fn basis(&self, rows: usize) -> DMatrix<f64> {
        let mut z = DMatrix::zeros(rows, self.dimension());
        for (column, &j) in self.free.iter().enumerate() {
            if j < rows {
                z[(j, column)] = 1.0;
            }
        }
        let offset = self.free.len();
        for (row, &j) in self.constrained.iter().enumerate() {
            if j < rows {
                for c in 0..self.null.ncols() {
                    z[(j, offset + c)] = self.null[(row, c)];
                }
            }
        }
        z
    }

    /// M Z for a dense M with one column per variable: M's free columns,
    /// then its constrained columns times the null-space basis.
    pub fn reduce_columns(&self, m: &DMatrix<f64>) -> DMatrix<f64> {
        let mut out = DMatrix::zeros(m.nrows(), self.dimension());
        for (index, &j) in self.free.iter().enumerate() {
            out.set_column(index, &m.column(j));
        }
        if !self.constrained.is_empty() {
            let product = m.select_columns(&self.constrained) * &self.null;
            out.columns_mut(self.free.len(), self.null.ncols())
                .copy_from(&product);
        }
        out
    }
}

/// The null space of E from an SVD of its non-zero columns, and the
/// least-norm solution c₀.
pub(super) fn eliminate(
    e: &DMatrix<f64>,
    f: &DVector<f64>,
    n_vars: usize,
) -> Result<Elimination, Failure> {
    let (constrained, free): (Vec<usize>, Vec<usize>) =
        (0..n_vars).partition(|&j| e.nrows() > 0 && e.column(j).iter().any(|&v| v != 0.0));
    let mut c0 = DVector::zeros(n_vars);
    if constrained.is_empty() {
        // No equality reads any variable: consistent only if f = 0.
        return if f.amax() > CONSISTENCY_TOLERANCE {
            Err(Failure::Inconsistent)
        } else {
            Ok(Elimination {
                c0,
                free,
                constrained,
                null: DMatrix::zeros(0, 0),
            })
        };
    }
    let block = e.select_columns(&constrained);
    let (u, singular, v) = svd(&block).ok_or(Failure::Numerical)?;
    let largest = singular.first().copied().unwrap_or(0.0);
    let rank = singular
        .iter()
        .take_while(|&&s| s > RANK_TOLERANCE * largest)
        .count();
    // c₀ = V_r Σ_r⁻¹ U_rᵀ f on the constrained variables.
    let mut least_norm = DVector::zeros(constrained.len());
    for (index, &value) in singular.iter().enumerate().take(rank) {
        least_norm += v.column(index) * (u.column(index).dot(f) / value);
    }
    for (&j, value) in constrained.iter().zip(least_norm.iter()) {
        c0[j] = *value;
    }
    let residual = (&block * &least_norm - f).amax();
    if residual > CONSISTENCY_TOLERANCE * (1.0 + f.amax()) {
        // The rank cut may have dropped the directions f needs: if every
        // singular value above rounding fits f, the equalities are
        // consistent but too ill-conditioned to eliminate, not infeasible.
        let mut full = least_norm;
        for (index, &value) in singular.iter().enumerate().skip(rank) {
            if value > f64::EPSILON * largest * singular.len() as f64 {
                full += v.column(index) * (u.column(index).dot(f) / value);
            }
        }
        let full_residual = (&block * &full - f).amax();
        return Err(
            if full_residual <= CONSISTENCY_TOLERANCE * (1.0 + f.amax()) {
                Failure::Numerical
            } else {
                Failure::Inconsistent
            },
        );
    }
    let null = v.columns(rank, constrained.len() - rank).into_owned();
    Ok(Elimination {
        c0,
        free,
        constrained,
        null,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// E reads variables 1, 3 and 4 of 6 (rank 2); the others stay free.
    fn sparse_equalities() -> (DMatrix<f64>, DVector<f64>) {
        let e = DMatrix::from_row_slice(
            3,
            6,
            &[
                0.0, 1.0, 0.0, 2.0, -1.0, 0.0, //
                0.0, 0.5, 0.0, 0.0, 3.0, 0.0, //
                0.0, 1.5, 0.0, 2.0, 2.0, 0.0, // the sum of the first two
            ],
        );
        let f = DVector::from_vec(vec![1.0, -2.0, -1.0]);
        (e, f)
    }

    #[test]
    fn the_null_space_keeps_free_variables_as_coordinates() {
        let (e, f) = sparse_equalities();
        let Ok(elimination) = eliminate(&e, &f, 6) else {
            panic!("consistent equalities")
        };
        assert_eq!(elimination.free, vec![0, 2, 5]);
        assert_eq!(elimination.constrained, vec![1, 3, 4]);
        assert_eq!(elimination.dimension(), 4);
        let null = &elimination.null;
        assert!((null.transpose() * null - DMatrix::identity(1, 1)).amax() < 1e-14);
        // Every y gives a solution, and the free coordinates are copied.
        let y = DVector::from_vec(vec![0.3, -1.1, 2.0, 0.7]);
        let c = elimination.expand(&y);
        assert!((&e * &c - &f).amax() < 1e-13);
        assert_eq!((c[0], c[2], c[5]), (0.3, -1.1, 2.0));
        // c₀ is the least-norm solution: orthogonal to the null space.
        assert!((null.transpose() * elimination.c0.select_rows(&[1, 3, 4])).amax() < 1e-14);
        // M Z is M applied to the expansion's linear part.
        let m = DMatrix::from_fn(2, 6, |i, j| (i * 6 + j) as f64 * 0.1 - 0.4);
        let linear = elimination.expand(&y) - &elimination.c0;
        assert!((elimination.reduce_columns(&m) * &y - &m * linear).amax() < 1e-13);
    }

    #[test]
    fn inconsistent_and_empty_equalities() {
        let (e, mut f) = sparse_equalities();
        f[2] += 1e-3;
        assert!(matches!(eliminate(&e, &f, 6), Err(Failure::Inconsistent)));
        // A zero row with a non-zero right-hand side.
        let zero = DMatrix::zeros(1, 3);
        let one = DVector::from_element(1, 1.0);
        assert!(matches!(
            eliminate(&zero, &one, 3),
            Err(Failure::Inconsistent)
        ));
        let Ok(none) = eliminate(&DMatrix::zeros(0, 3), &DVector::zeros(0), 3) else {
            panic!("no equalities")
        };
        assert!(none.is_identity());
        assert_eq!(none.free, vec![0, 1, 2]);
    }

    /// x₀ + x₁ = 0, x₀ + (1 + 1e-8) x₁ = 1e-8 holds at x = (−1, 1), but
    /// its second singular value (5e-9 of 2) is below the rank cut: too
    /// ill-conditioned to eliminate, and not a proof of infeasibility.
    #[test]
    fn consistent_but_ill_conditioned_equalities_are_not_called_inconsistent() {
        let e = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0 + 1e-8]);
        let f = DVector::from_row_slice(&[0.0, 1e-8]);
        assert!(matches!(eliminate(&e, &f, 2), Err(Failure::Numerical)));
        // Two equal rows with different right-hand sides are inconsistent.
        let e = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
        let f = DVector::from_row_slice(&[0.0, 1e-6]);
        assert!(matches!(eliminate(&e, &f, 2), Err(Failure::Inconsistent)));
    }

    /// The equalities of a joint step on a 6-state system with a constant
    /// metric (entropy degree 6, q = 4000, as equilibrated): θ = Q₁ and
    /// η I − K(θ) = Q₂ for the 21 entries of the metric, with the 923
    /// entropy coefficients between θ and the Gram matrices reading none.
    /// faer's eigendecomposition of the whole EᵀE (986 × 986, rank 42)
    /// does not converge on this matrix; the SVD of E's 63 non-zero
    /// columns is exact.
    #[test]
    fn wide_systems_factorise_only_the_columns_equalities_read() {
        let (a, b) = (0.9794963935642679, 0.6926085420370611);
        let (n, free) = (6, 923);
        let t = n * (n + 1) / 2;
        let vars = t + free + 2 * t;
        let mut e = DMatrix::zeros(2 * t, vars);
        let mut f = DVector::zeros(2 * t);
        let mut entry = 0;
        for i in 0..n {
            for j in i..n {
                let svec = j * (j + 1) / 2 + i;
                let scale = if i == j { a } else { b };
                e[(2 * entry, entry)] = a;
                e[(2 * entry, t + free + svec)] = -scale;
                e[(2 * entry + 1, entry)] = a;
                e[(2 * entry + 1, t + free + t + svec)] = scale;
                if i == j {
                    f[2 * entry + 1] = 163.09557294431198;
                }
                entry += 1;
            }
        }
        let Ok(elimination) = eliminate(&e, &f, vars) else {
            panic!("consistent equalities")
        };
        assert_eq!(elimination.free, (t..t + free).collect::<Vec<_>>());
        assert_eq!(elimination.null.shape(), (3 * t, t));
        let null = &elimination.null;
        assert!((null.transpose() * null - DMatrix::identity(t, t)).amax() < 1e-13);
        let y = DVector::from_fn(elimination.dimension(), |j, _| (j as f64 * 0.3).cos());
        assert!((&e * elimination.expand(&y) - &f).amax() < 1e-12);
    }
}
