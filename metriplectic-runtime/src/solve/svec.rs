//! Symmetric matrices in svec layout, the PSD cone's vector form: the upper
//! triangle stacked column by column, off-diagonal entries scaled by √2 so
//! that ⟨svec A, svec B⟩ = tr(AB).

use nalgebra::DMatrix;

/// √2, the svec scaling of off-diagonal entries.
pub(crate) const SQRT_2: f64 = std::f64::consts::SQRT_2;

/// Index of entry (i, j) of a symmetric matrix in svec layout.
pub(crate) fn svec_index(i: usize, j: usize) -> usize {
    let (i, j) = if i <= j { (i, j) } else { (j, i) };
    j * (j + 1) / 2 + i
}

/// Length n(n+1)/2 of the svec of an n×n symmetric matrix.
pub(crate) fn svec_len(n: usize) -> usize {
    n * (n + 1) / 2
}

/// Index of diagonal entry (j, j).
pub(crate) fn svec_diagonal(j: usize) -> usize {
    j * (j + 1) / 2 + j
}

/// The row-major symmetric n×n matrix of an svec vector.
pub(crate) fn unsvec(n: usize, packed: &[f64]) -> Vec<f64> {
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

/// The symmetric matrix of an svec vector.
pub(crate) fn smat(n: usize, v: &[f64]) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(n, n);
    let mut k = 0;
    for j in 0..n {
        for i in 0..=j {
            let value = if i == j { v[k] } else { v[k] / SQRT_2 };
            m[(i, j)] = value;
            m[(j, i)] = value;
            k += 1;
        }
    }
    m
}

/// svec of the symmetric part of `m` into `out`.
pub(crate) fn svec_into(m: &DMatrix<f64>, out: &mut [f64]) {
    let n = m.nrows();
    let mut k = 0;
    for j in 0..n {
        for i in 0..=j {
            out[k] = if i == j {
                m[(i, j)]
            } else {
                SQRT_2 * 0.5 * (m[(i, j)] + m[(j, i)])
            };
            k += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svec_round_trips_and_preserves_inner_products() {
        let a = DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 3.0, 2.0, 5.0, 6.0, 3.0, 6.0, 9.0]);
        let b = DMatrix::from_row_slice(3, 3, &[4.0, -1.0, 0.5, -1.0, 2.0, 7.0, 0.5, 7.0, -3.0]);
        let (mut sa, mut sb) = ([0.0; 6], [0.0; 6]);
        svec_into(&a, &mut sa);
        svec_into(&b, &mut sb);
        // Upper triangle by columns: (0,0) (0,1) (1,1) (0,2) (1,2) (2,2).
        assert_eq!(sa[0], 1.0);
        assert!((sa[1] - 2.0 * SQRT_2).abs() < 1e-15);
        assert_eq!(sa[2], 5.0);
        assert!((sa[3] - 3.0 * SQRT_2).abs() < 1e-15);
        assert_eq!(sa[5], 9.0);
        assert_eq!(svec_diagonal(2), svec_index(2, 2));
        let back = smat(3, &sa);
        assert!((back - &a).amax() < 1e-15);
        let trace = (&a * &b).trace();
        let inner: f64 = sa.iter().zip(&sb).map(|(x, y)| x * y).sum();
        assert!((trace - inner).abs() < 1e-12);
    }
}
