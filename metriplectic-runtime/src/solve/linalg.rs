//! Dense linear-algebra kernels on faer, for matrices held in nalgebra's
//! column-major storage (viewed without copying).
//!
//! Why faer: its blocked, multithreaded GEMM and Cholesky bring the normal
//! equations of the interior-point method near the machine's matrix rate on
//! every core, and its symmetric eigensolver is robust where nalgebra's
//! returned NaN on a valid, well-scaled 68×68 Gram matrix (met in a joint
//! step of the 2-D system). Parallel work runs on rayon's global pool, so
//! `RAYON_NUM_THREADS` sets the thread count.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::triangular::BlockStructure;
use faer::{Accum, MatMut, MatRef, Par, Side};
use nalgebra::{DMatrix, DVector};

/// Below this many multiply-adds a kernel runs on one thread: splitting
/// costs more than it saves.
const PARALLEL_WORK: f64 = 1e7;

/// The parallelism for a kernel of `work` multiply-adds.
fn parallelism(work: f64) -> Par {
    if work >= PARALLEL_WORK {
        Par::rayon(0)
    } else {
        Par::Seq
    }
}

fn view(m: &DMatrix<f64>) -> MatRef<'_, f64> {
    MatRef::from_column_major_slice(m.as_slice(), m.nrows(), m.ncols())
}

fn view_mut(m: &mut DMatrix<f64>) -> MatMut<'_, f64> {
    let (rows, columns) = m.shape();
    MatMut::from_column_major_slice_mut(m.as_mut_slice(), rows, columns)
}

/// AᵀA, symmetric (both triangles filled), from the lower triangle of a
/// blocked product.
pub(crate) fn gram(a: &DMatrix<f64>) -> DMatrix<f64> {
    let (rows, k) = a.shape();
    let mut out = DMatrix::zeros(k, k);
    let work = rows as f64 * (k * k) as f64 / 2.0;
    faer::linalg::matmul::triangular::matmul(
        view_mut(&mut out),
        BlockStructure::TriangularLower,
        Accum::Replace,
        view(a).transpose(),
        BlockStructure::Rectangular,
        view(a),
        BlockStructure::Rectangular,
        1.0,
        parallelism(work),
    );
    for j in 0..k {
        for i in 0..j {
            out[(i, j)] = out[(j, i)];
        }
    }
    out
}

/// A Cholesky factorisation L Lᵀ of a symmetric positive definite matrix.
pub(crate) struct Cholesky {
    l: DMatrix<f64>,
}

impl Cholesky {
    /// Factorises `m` (its lower triangle is read); `None` if a pivot is
    /// not positive.
    pub(crate) fn new(m: &DMatrix<f64>) -> Option<Self> {
        let n = m.nrows();
        let mut l = m.clone();
        let par = parallelism((n * n * n) as f64 / 3.0);
        let mut memory = MemBuffer::new(
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(
                n,
                par,
                Default::default(),
            ),
        );
        let factored = faer::linalg::cholesky::llt::factor::cholesky_in_place(
            view_mut(&mut l),
            Default::default(),
            par,
            MemStack::new(&mut memory),
            Default::default(),
        );
        if factored.is_err() || !l.iter().all(|v| v.is_finite()) {
            return None;
        }
        for j in 0..n {
            for i in 0..j {
                l[(i, j)] = 0.0;
            }
        }
        Some(Self { l })
    }

    /// The factor L.
    pub(crate) fn l(&self) -> &DMatrix<f64> {
        &self.l
    }

    /// x with L Lᵀ x = b.
    pub(crate) fn solve(&self, b: &DVector<f64>) -> DVector<f64> {
        let n = self.l.nrows();
        let mut x = b.clone();
        let par = parallelism((n * n) as f64);
        let mut memory = MemBuffer::new(
            faer::linalg::cholesky::llt::solve::solve_in_place_scratch::<f64>(n, 1, par),
        );
        faer::linalg::cholesky::llt::solve::solve_in_place_with_conj(
            view(&self.l),
            faer::Conj::No,
            MatMut::from_column_major_slice_mut(x.as_mut_slice(), n, 1),
            par,
            MemStack::new(&mut memory),
        );
        x
    }
}

/// Eigenvalues (ascending) and eigenvectors (columns) of a symmetric matrix;
/// `None` if the eigensolver fails or returns non-finite values.
pub(crate) fn symmetric_eigen(m: &DMatrix<f64>) -> Option<(Vec<f64>, DMatrix<f64>)> {
    let n = m.nrows();
    let eigen = view(m).self_adjoint_eigen(Side::Lower).ok()?;
    let values: Vec<f64> = (0..n).map(|i| eigen.S()[i]).collect();
    let u = eigen.U();
    let vectors = DMatrix::from_fn(n, n, |i, j| u[(i, j)]);
    (values.iter().all(|v| v.is_finite()) && vectors.iter().all(|v| v.is_finite()))
        .then_some((values, vectors))
}

/// The eigenvalues (ascending) of a symmetric matrix; `None` on failure.
pub(crate) fn symmetric_eigenvalues(m: &DMatrix<f64>) -> Option<Vec<f64>> {
    let values = view(m).self_adjoint_eigenvalues(Side::Lower).ok()?;
    values.iter().all(|v| v.is_finite()).then_some(values)
}

/// U, the singular values (descending) and V of a square matrix; `None` on
/// failure.
pub(crate) fn svd(m: &DMatrix<f64>) -> Option<(DMatrix<f64>, Vec<f64>, DMatrix<f64>)> {
    let n = m.nrows();
    let svd = view(m).svd().ok()?;
    let (u, s, v) = (svd.U(), svd.S(), svd.V());
    let values: Vec<f64> = (0..n).map(|i| s[i]).collect();
    let u = DMatrix::from_fn(n, n, |i, j| u[(i, j)]);
    let v = DMatrix::from_fn(n, n, |i, j| v[(i, j)]);
    let finite = values
        .iter()
        .chain(u.iter())
        .chain(v.iter())
        .all(|x| x.is_finite());
    finite.then_some((u, values, v))
}

/// The singular values (descending) of any matrix; `None` on failure.
pub(crate) fn singular_values(m: &DMatrix<f64>) -> Option<Vec<f64>> {
    view(m).singular_values().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gram_and_cholesky_solve() {
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let g = gram(&a);
        assert_eq!(g, a.transpose() * &a);
        let factor = Cholesky::new(&g).unwrap();
        let b = DVector::from_vec(vec![1.0, -1.0]);
        let x = factor.solve(&b);
        assert!((&g * &x - &b).amax() < 1e-12);
        assert!((factor.l() * factor.l().transpose() - &g).amax() < 1e-12);
        assert!(Cholesky::new(&DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0])).is_none());
    }

    #[test]
    fn eigen_and_svd() {
        let m = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        let (values, vectors) = symmetric_eigen(&m).unwrap();
        assert!((values[0] - 1.0).abs() < 1e-14 && (values[1] - 3.0).abs() < 1e-14);
        let v = vectors.column(0);
        assert!((&m * v - v * values[0]).amax() < 1e-14);
        assert_eq!(symmetric_eigenvalues(&m).unwrap().len(), 2);
        let (u, s, v) = svd(&m).unwrap();
        let back = u * DMatrix::from_diagonal(&DVector::from_vec(s)) * v.transpose();
        assert!((back - &m).amax() < 1e-14);
        assert!((singular_values(&m).unwrap()[0] - 3.0).abs() < 1e-14);
    }
}
