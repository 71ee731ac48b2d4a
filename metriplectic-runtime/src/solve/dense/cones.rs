//! The side cones of the dense method (nonnegative orthants and PSD cones in
//! svec layout): Nesterov–Todd scaling, the Jordan product and division,
//! step limits and the shift into the interior.

use nalgebra::{DMatrix, DVector};

use crate::solve::linalg::{svd, symmetric_eigenvalues, Cholesky};

use crate::solve::svec::{smat, svec_diagonal, svec_into};

/// One segment of the side-cone vector (the non-equality blocks, in order).
#[derive(Debug, Clone)]
pub(super) struct Segment {
    /// Index of the constraint block this segment holds.
    pub block: usize,
    /// Offset in the side-cone vector.
    pub offset: usize,
    /// `None` for a nonnegative orthant, `Some(n)` for an n×n PSD cone.
    pub psd: Option<usize>,
    /// Length in the side-cone vector.
    pub len: usize,
}

impl Segment {
    pub fn range(&self) -> std::ops::Range<usize> {
        self.offset..self.offset + self.len
    }
}

/// Nesterov–Todd scaling of one PSD segment: W(Z) = Rᵀ Z R, W⁻ᵀ(S) = R⁻¹ S R⁻ᵀ,
/// both equal to diag(λ) at the current point. Only R⁻ᵀ is kept: the
/// Newton system works in the scaled space and needs W⁻ᵀ and W⁻¹ alone.
pub(super) struct PsdScaling {
    r_inv_t: DMatrix<f64>,
    lambda: Vec<f64>,
}

impl PsdScaling {
    fn identity(n: usize) -> Self {
        Self {
            r_inv_t: DMatrix::identity(n, n),
            lambda: vec![1.0; n],
        }
    }
}

/// Scaling of the whole side-cone vector.
pub(super) struct SideScaling {
    /// Per component: √(s/z) on nonnegative segments (unused on PSD ones).
    w: Vec<f64>,
    /// λ in the scaled space: √(s z) on nonnegative segments, the diagonal on
    /// PSD segments (svec, so off-diagonal entries are 0).
    pub lambda: Vec<f64>,
    psd: Vec<Option<PsdScaling>>,
}

impl SideScaling {
    /// W = I, the scaling `coneqp`'s starting point uses.
    pub fn identity(segments: &[Segment], m: usize) -> Self {
        Self {
            w: vec![1.0; m],
            lambda: vec![1.0; m],
            psd: segments
                .iter()
                .map(|segment| segment.psd.map(PsdScaling::identity))
                .collect(),
        }
    }

    /// NT scaling of the side cones at (s, z); `None` if a PSD block is not
    /// positive definite (numerical breakdown).
    pub fn new(segments: &[Segment], s: &DVector<f64>, z: &DVector<f64>) -> Option<Self> {
        let m = s.len();
        let mut w = vec![0.0; m];
        let mut lambda = vec![0.0; m];
        let mut psd = Vec::with_capacity(segments.len());
        for segment in segments {
            let range = segment.range();
            match segment.psd {
                None => {
                    for i in range {
                        w[i] = (s[i] / z[i]).sqrt();
                        lambda[i] = (s[i] * z[i]).sqrt();
                    }
                    psd.push(None);
                }
                Some(n) => {
                    let scaling = psd_scaling(
                        n,
                        &s.as_slice()[range.clone()],
                        &z.as_slice()[range.clone()],
                    )?;
                    let mut k = 0;
                    for j in 0..n {
                        for i in 0..=j {
                            lambda[segment.offset + k] =
                                if i == j { scaling.lambda[j] } else { 0.0 };
                            k += 1;
                        }
                    }
                    psd.push(Some(scaling));
                }
            }
        }
        Some(Self { w, lambda, psd })
    }

    /// v ↦ W⁻ᵀ v: a primal-space vector (a slack or a residual of the
    /// cone rows) into the scaled space, where the Newton system's cone
    /// block is the identity.
    pub fn apply_inverse_wt(&self, segments: &[Segment], v: &DVector<f64>) -> DVector<f64> {
        self.apply(
            segments,
            v,
            |i, x| x / self.w[i],
            |sc, m| sc.r_inv_t.transpose() * m * &sc.r_inv_t,
        )
    }

    /// v ↦ W⁻¹ v: a scaled multiplier direction back to the dual space.
    pub fn apply_inverse_w(&self, segments: &[Segment], v: &DVector<f64>) -> DVector<f64> {
        self.apply(
            segments,
            v,
            |i, x| x / self.w[i],
            |sc, m| &sc.r_inv_t * m * sc.r_inv_t.transpose(),
        )
    }

    /// w of orthant row `i` (W is diagonal there: W⁻ᵀ divides by it).
    pub fn orthant_scale(&self, i: usize) -> f64 {
        self.w[i]
    }

    /// The rows `rows` of W⁻ᵀ G, in that order, for a matrix G of side-cone
    /// rows: the Newton system's G̃ where it is stored. `rows` must be
    /// ascending and hold every row of each PSD segment it touches (the
    /// congruence mixes a segment's rows). Orthant rows are divided by w;
    /// a PSD segment's congruence is applied only to the columns that are
    /// non-zero on it.
    pub fn apply_inverse_wt_rows(
        &self,
        segments: &[Segment],
        g: &DMatrix<f64>,
        rows: &[usize],
    ) -> DMatrix<f64> {
        let k = g.ncols();
        let m = rows.len();
        let mut out = DMatrix::zeros(m, k);
        let mut position = 0;
        for (segment, scaling) in segments.iter().zip(&self.psd) {
            let range = segment.range();
            match (segment.psd, scaling) {
                (Some(n), Some(sc)) => {
                    if rows.get(position) != Some(&range.start) {
                        continue;
                    }
                    debug_assert!(rows[position..]
                        .iter()
                        .take(segment.len)
                        .copied()
                        .eq(range.clone()));
                    for j in 0..k {
                        let part: Vec<f64> = range.clone().map(|i| g[(i, j)]).collect();
                        if part.iter().all(|x| *x == 0.0) {
                            continue;
                        }
                        let mapped = sc.r_inv_t.transpose() * smat(n, &part) * &sc.r_inv_t;
                        let start = j * m + position;
                        svec_into(&mapped, &mut out.as_mut_slice()[start..start + segment.len]);
                    }
                    position += segment.len;
                }
                _ => {
                    while let Some(&i) = rows.get(position).filter(|i| range.contains(i)) {
                        for j in 0..k {
                            out[(position, j)] = g[(i, j)] / self.w[i];
                        }
                        position += 1;
                    }
                }
            }
        }
        debug_assert_eq!(position, m, "rows must be ascending side-cone rows");
        out
    }

    /// The scaling of `v`, segment by segment.
    fn apply(
        &self,
        segments: &[Segment],
        v: &DVector<f64>,
        orthant: impl Fn(usize, f64) -> f64,
        cone: impl Fn(&PsdScaling, &DMatrix<f64>) -> DMatrix<f64>,
    ) -> DVector<f64> {
        let mut out = DVector::zeros(v.len());
        for (segment, scaling) in segments.iter().zip(&self.psd) {
            let range = segment.range();
            match (segment.psd, scaling) {
                (Some(n), Some(sc)) => {
                    let part = smat(n, &v.as_slice()[range.clone()]);
                    svec_into(&cone(sc, &part), &mut out.as_mut_slice()[range]);
                }
                _ => {
                    for i in range {
                        out[i] = orthant(i, v[i]);
                    }
                }
            }
        }
        out
    }
}

/// R⁻ᵀ = L_z U Λ^{-1/2} from L_zᵀ L_s = U Λ Vᵀ (and R = L_s V Λ^{-1/2}).
fn psd_scaling(n: usize, s: &[f64], z: &[f64]) -> Option<PsdScaling> {
    let ls = Cholesky::new(&smat(n, s))?.l().clone();
    let lz = Cholesky::new(&smat(n, z))?.l().clone();
    let (u, lambda, _) = svd(&(lz.transpose() * &ls))?;
    if lambda
        .iter()
        .any(|&l| l.is_nan() || l <= 0.0 || !l.is_finite())
    {
        return None;
    }
    let inv_sqrt = DMatrix::from_diagonal(&DVector::from_iterator(
        n,
        lambda.iter().map(|l| 1.0 / l.sqrt()),
    ));
    Some(PsdScaling {
        r_inv_t: lz * u * inv_sqrt,
        lambda,
    })
}

/// a ∘ b on the side cones (the symmetrised product on PSD segments).
pub(super) fn jordan_product(
    segments: &[Segment],
    a: &DVector<f64>,
    b: &DVector<f64>,
) -> DVector<f64> {
    let mut out = a.component_mul(b);
    for segment in segments {
        if let Some(n) = segment.psd {
            let range = segment.range();
            let ma = smat(n, &a.as_slice()[range.clone()]);
            let mb = smat(n, &b.as_slice()[range.clone()]);
            let product = (&ma * &mb + &mb * &ma) * 0.5;
            svec_into(&product, &mut out.as_mut_slice()[range]);
        }
    }
    out
}

/// ξ with λ ∘ ξ = v, for λ diagonal on PSD segments.
pub(super) fn jordan_divide(
    segments: &[Segment],
    lambda: &[f64],
    v: &DVector<f64>,
) -> DVector<f64> {
    let mut out = DVector::from_iterator(v.len(), v.iter().zip(lambda).map(|(v, l)| v / l));
    for segment in segments {
        if let Some(n) = segment.psd {
            let diagonal = psd_diagonal(segment, n, lambda);
            let mut k = 0;
            for j in 0..n {
                for i in 0..=j {
                    let idx = segment.offset + k;
                    out[idx] = 2.0 * v[idx] / (diagonal[i] + diagonal[j]);
                    k += 1;
                }
            }
        }
    }
    out
}

/// The diagonal of a PSD segment of a diagonal λ.
fn psd_diagonal(segment: &Segment, n: usize, lambda: &[f64]) -> Vec<f64> {
    (0..n)
        .map(|j| lambda[segment.offset + svec_diagonal(j)])
        .collect()
}

/// The identity of the side cones (1 on orthants, I on PSD segments).
pub(super) fn cone_identity(segments: &[Segment], m: usize) -> DVector<f64> {
    let mut e = DVector::from_element(m, 1.0);
    for segment in segments {
        if let Some(n) = segment.psd {
            e.rows_mut(segment.offset, segment.len).fill(0.0);
            for j in 0..n {
                e[segment.offset + svec_diagonal(j)] = 1.0;
            }
        }
    }
    e
}

/// Largest α ≤ ∞ with λ + α d ≥ 0 on an orthant (λ > 0): the smallest
/// −λᵢ/dᵢ over dᵢ < 0. Four independent minima let the scan run in SIMD
/// lanes instead of one compare chain; the minimum of a set does not
/// depend on the order, so the result is the same bits as a plain loop.
pub(super) fn orthant_step_limit(lambda: &[f64], d: &[f64]) -> f64 {
    const LANES: usize = 4;
    let ratio = |l: f64, v: f64| if v < 0.0 { -l / v } else { f64::INFINITY };
    let mut lanes = [f64::INFINITY; LANES];
    let (l_chunks, d_chunks) = (lambda.chunks_exact(LANES), d.chunks_exact(LANES));
    let (l_rest, d_rest) = (l_chunks.remainder(), d_chunks.remainder());
    for (l, v) in l_chunks.zip(d_chunks) {
        for lane in 0..LANES {
            lanes[lane] = lanes[lane].min(ratio(l[lane], v[lane]));
        }
    }
    let tail = l_rest
        .iter()
        .zip(d_rest)
        .fold(f64::INFINITY, |alpha, (&l, &v)| alpha.min(ratio(l, v)));
    lanes.into_iter().fold(tail, f64::min)
}

/// Largest α ≤ ∞ with λ + α d in the side cones, for a diagonal λ.
pub(super) fn side_step_limit(segments: &[Segment], lambda: &[f64], d: &DVector<f64>) -> f64 {
    let mut alpha = f64::INFINITY;
    for segment in segments {
        let range = segment.range();
        match segment.psd {
            Some(n) => {
                let diagonal = psd_diagonal(segment, n, lambda);
                alpha = alpha.min(psd_step_limit(&diagonal, &d.as_slice()[range]));
            }
            None => {
                alpha = alpha.min(orthant_step_limit(
                    &lambda[range.clone()],
                    &d.as_slice()[range],
                ));
            }
        }
    }
    alpha
}

/// Largest α with s + α·ds in every side cone, computed on the unscaled
/// slacks; `None` if a PSD slack is not numerically positive definite (the
/// caller then uses the scaled form). Near a face of a PSD cone the
/// Nesterov–Todd scaling W is so ill-conditioned that mapping a scaled
/// direction back (ds = WᵀΔs̃) loses every digit; the slack direction is
/// then taken from the linear residual equation instead, and its step
/// limit has to be found here.
pub(super) fn slack_step_limit(
    segments: &[Segment],
    s: &DVector<f64>,
    ds: &DVector<f64>,
) -> Option<f64> {
    let mut alpha = f64::INFINITY;
    for segment in segments {
        let range = segment.range();
        match segment.psd {
            Some(n) => {
                let slack = smat(n, &s.as_slice()[range.clone()]);
                let factor = Cholesky::new(&slack)?;
                let direction = smat(n, &ds.as_slice()[range]);
                let left = factor.l().solve_lower_triangular(&direction)?;
                let m = factor.l().solve_lower_triangular(&left.transpose())?;
                let m = (&m + m.transpose()) * 0.5;
                let smallest = symmetric_eigenvalues(&m)?.first().copied()?;
                if smallest < 0.0 {
                    alpha = alpha.min(-1.0 / smallest);
                }
            }
            None => {
                alpha = alpha.min(orthant_step_limit(
                    &s.as_slice()[range.clone()],
                    &ds.as_slice()[range],
                ));
            }
        }
    }
    Some(alpha)
}

/// Largest α with λ + α d in the cone, for λ = diag(λ) in svec form: the
/// smallest eigenvalue of Λ^{-1/2} D Λ^{-1/2}.
pub(super) fn psd_step_limit(lambda: &[f64], d: &[f64]) -> f64 {
    let n = lambda.len();
    let mut m = smat(n, d);
    for i in 0..n {
        for j in 0..n {
            m[(i, j)] /= (lambda[i] * lambda[j]).sqrt();
        }
    }
    // A failed eigensolver stops the step (NaN ends the iteration).
    let smallest = symmetric_eigenvalues(&m).map_or(f64::NAN, |values| {
        values.first().copied().unwrap_or(f64::INFINITY)
    });
    if smallest < 0.0 {
        -1.0 / smallest
    } else if smallest.is_nan() {
        f64::NAN
    } else {
        f64::INFINITY
    }
}

/// Shifts v into the interior of the side cones if it is not already
/// (v + (1 + t) e with t the largest violation), as in `coneqp`.
pub(super) fn shift_into_cones(segments: &[Segment], v: &mut DVector<f64>) {
    let mut violation = f64::NEG_INFINITY;
    for segment in segments {
        let range = segment.range();
        let smallest = match segment.psd {
            // An empty block (refused by `constrain`) has no eigenvalue.
            Some(n) => symmetric_eigenvalues(&smat(n, &v.as_slice()[range]))
                .map_or(f64::NAN, |values| {
                    values.first().copied().unwrap_or(f64::INFINITY)
                }),
            None => v.as_slice()[range]
                .iter()
                .copied()
                .fold(f64::INFINITY, f64::min),
        };
        violation = violation.max(-smallest);
    }
    if violation >= -1e-8 {
        let e = cone_identity(segments, v.len());
        *v += e * (1.0 + violation.max(0.0));
    }
}

/// The same shift for the two L1 orthants together (one cone of 2r).
pub(super) fn shift_orthant(v: &mut DVector<f64>, other: &mut DVector<f64>) {
    let smallest = v.min().min(other.min());
    if -smallest >= -1e-8 {
        let shift = 1.0 + (-smallest).max(0.0);
        v.add_scalar_mut(shift);
        other.add_scalar_mut(shift);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nt_scaling_maps_slack_and_multiplier_to_lambda() {
        // s and z: two 2×2 positive definite matrices in svec form.
        let s = DVector::from_vec(vec![2.0, 0.3 * 2f64.sqrt(), 1.0]);
        let z = DVector::from_vec(vec![0.5, -0.1 * 2f64.sqrt(), 3.0]);
        let segments = [Segment {
            block: 0,
            offset: 0,
            psd: Some(2),
            len: 3,
        }];
        let scaling = SideScaling::new(&segments, &s, &z).unwrap();
        let lambda = DVector::from_column_slice(&scaling.lambda);
        // W⁻ᵀ s = λ = W z, so W⁻¹ λ = z.
        let scaled = scaling.apply_inverse_wt(&segments, &s);
        assert!((scaled - &lambda).amax() < 1e-12);
        let back = scaling.apply_inverse_w(&segments, &lambda);
        assert!((back - z).amax() < 1e-12);
    }

    #[test]
    fn scaled_rows_match_the_scaled_vectors() {
        // An orthant of two and a 2×2 PSD cone; G has a column that is zero
        // on the cone, which the row map skips.
        let segments = [
            Segment {
                block: 0,
                offset: 0,
                psd: None,
                len: 2,
            },
            Segment {
                block: 1,
                offset: 2,
                psd: Some(2),
                len: 3,
            },
        ];
        let s = DVector::from_vec(vec![0.5, 2.0, 2.0, 0.3 * 2f64.sqrt(), 1.0]);
        let z = DVector::from_vec(vec![3.0, 0.25, 0.5, -0.1 * 2f64.sqrt(), 3.0]);
        let scaling = SideScaling::new(&segments, &s, &z).unwrap();
        let g = DMatrix::from_row_slice(
            5,
            3,
            &[
                1.0, 0.0, -2.0, //
                0.0, 3.0, 0.5, //
                0.7, 0.0, 0.0, //
                -1.2, 0.0, 0.0, //
                0.4, 0.0, 1.5,
            ],
        );
        let columns: Vec<_> = (0..3)
            .map(|j| scaling.apply_inverse_wt(&segments, &g.column(j).into_owned()))
            .collect();
        // Every row, an orthant row and the cone, and the orthant alone.
        for rows in [vec![0, 1, 2, 3, 4], vec![1, 2, 3, 4], vec![0, 1]] {
            let scaled = scaling.apply_inverse_wt_rows(&segments, &g, &rows);
            assert_eq!(scaled.shape(), (rows.len(), 3));
            for (j, column) in columns.iter().enumerate() {
                for (t, &i) in rows.iter().enumerate() {
                    assert_eq!(scaled[(t, j)], column[i], "rows {rows:?}, ({i}, {j})");
                }
            }
        }
    }

    /// The lane-parallel scan is the plain loop's minimum to the bit, at
    /// every length's remainder, with no blocking component (∞), and with
    /// the smallest ratio in the remainder or in any lane.
    #[test]
    fn orthant_step_limit_is_the_plain_minimum() {
        let plain = |lambda: &[f64], d: &[f64]| {
            let mut alpha = f64::INFINITY;
            for (l, v) in lambda.iter().zip(d) {
                if *v < 0.0 {
                    alpha = alpha.min(-l / v);
                }
            }
            alpha
        };
        assert_eq!(orthant_step_limit(&[], &[]), f64::INFINITY);
        assert_eq!(orthant_step_limit(&[1.0; 9], &[0.5; 9]), f64::INFINITY);
        for n in 1..=13 {
            let lambda: Vec<f64> = (0..n).map(|i| 0.3 + 0.17 * i as f64).collect();
            for blocking in 0..n {
                // Some directions negative, the steepest at `blocking`.
                let d: Vec<f64> = (0..n)
                    .map(|i| match (i == blocking, i % 3) {
                        (true, _) => -7.0,
                        (false, 0) => 0.4,
                        (false, r) => -0.1 * r as f64,
                    })
                    .collect();
                let got = orthant_step_limit(&lambda, &d);
                assert_eq!(got.to_bits(), plain(&lambda, &d).to_bits(), "n {n}");
                assert_eq!(got, lambda[blocking] / 7.0, "n {n}, blocking {blocking}");
            }
        }
    }

    #[test]
    fn step_to_the_boundary() {
        // Step to the boundary of diag(1, 2) along −I is 1.
        let limit = psd_step_limit(&[1.0, 2.0], &[-1.0, 0.0, -1.0]);
        assert!((limit - 1.0).abs() < 1e-12, "{limit}");
    }
}
