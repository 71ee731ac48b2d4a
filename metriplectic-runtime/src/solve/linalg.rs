//! Dense linear-algebra kernels on faer, for matrices held in nalgebra's
//! column-major storage (viewed without copying).
//!
//! Why faer: its blocked, multithreaded GEMM and Cholesky bring the normal
//! equations of the interior-point method near the machine's matrix rate on
//! every core, and its symmetric eigensolver is robust where nalgebra's
//! returned NaN on a valid, well-scaled 68×68 Gram matrix (met in a joint
//! step of the 2-D system). Parallel work runs on rayon's global pool, so
//! `RAYON_NUM_THREADS` sets the thread count.
//!
//! Results do not depend on the thread count: the products with the
//! regression block ([`RowMajor`]) split their rows into fixed blocks and
//! add the blocks' partial sums in a fixed order, faer's matrix product
//! and Cholesky split only the output, never a sum, across threads, and
//! its decompositions (QR, SVD, eigendecomposition), whose arithmetic
//! follows the number of tasks they split into, are given a fixed one
//! (checked bit for bit in the tests below and in `tests/suite/determinism.rs`).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::triangular::BlockStructure;
use faer::{Accum, MatMut, MatRef, Par};
use nalgebra::{DMatrix, DMatrixViewMut, DVector};
use rayon::prelude::*;

/// Below this many multiply-adds a kernel runs on one thread: splitting
/// costs more than it saves.
#[cfg(not(test))]
const PARALLEL_WORK: f64 = 1e7;
/// Small in unit tests, so that they run the parallel paths.
#[cfg(test)]
const PARALLEL_WORK: f64 = 1e4;

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
    symmetrise_lower(&mut out);
    out
}

/// Zᵀ M Z for a symmetric M (both triangles read), symmetric (both
/// triangles filled): M Z, then the lower triangle of Zᵀ(M Z).
pub(crate) fn congruence(m: &DMatrix<f64>, z: &DMatrix<f64>) -> DMatrix<f64> {
    let (w, k) = z.shape();
    let mut mz = DMatrix::zeros(w, k);
    faer::linalg::matmul::matmul(
        view_mut(&mut mz),
        Accum::Replace,
        view(m),
        view(z),
        1.0,
        parallelism((w * w * k) as f64),
    );
    let mut out = DMatrix::zeros(k, k);
    faer::linalg::matmul::triangular::matmul(
        view_mut(&mut out),
        BlockStructure::TriangularLower,
        Accum::Replace,
        view(z).transpose(),
        BlockStructure::Rectangular,
        view(&mz),
        BlockStructure::Rectangular,
        1.0,
        parallelism(w as f64 * (k * k) as f64 / 2.0),
    );
    symmetrise_lower(&mut out);
    out
}

/// Rows per block of the products with a [`RowMajor`] matrix: a block of a
/// thousand columns (8 MB) stays in the last-level cache while it is scaled
/// and multiplied, and a few blocks give every core work.
const ROW_BLOCK: usize = 1024;

/// Rows per block of a wide Aᵀ D A: each block is scaled into one reused
/// buffer (30 MB at a thousand columns) and multiplied on every core.
/// Longer blocks than `ROW_BLOCK` give faer's product more work per call:
/// at p = 923 an entropy solve took 4–5% less time than with 1024 rows,
/// and 8192 rows were slower again. Narrow products keep `ROW_BLOCK`
/// rows (see [`RowMajor::gram_block`]).
const GRAM_BLOCK: usize = 4096;

/// Rows per slice of the fused pass [`RowMajor::mul_then_tr_mul`]: a slice
/// of a thousand columns (256 KB) stays in the core's own cache between
/// its two uses.
const FUSED_ROWS: usize = 32;

/// A dense r × k matrix stored by rows: the regression block of an L1
/// problem, kept in the layout the searches assemble it in (one row per
/// sample and component), so the solver needs no transposed copy.
///
/// Its products are the memory-bound half of an interior-point iteration
/// (A v and Aᵀ w read the whole matrix once each) and the compute-bound
/// half (Aᵀ D A, blocked so that no scaled copy of A is ever formed).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct RowMajor {
    rows: usize,
    columns: usize,
    data: Vec<f64>,
}

impl RowMajor {
    /// `rows` × `columns` from row-major `data` (`rows · columns` values).
    pub(crate) fn from_rows(rows: usize, columns: usize, data: Vec<f64>) -> Self {
        assert_eq!(data.len(), rows * columns, "row-major data of the shape");
        Self {
            rows,
            columns,
            data,
        }
    }

    /// The row-major copy of a column-major matrix.
    #[cfg(test)]
    pub(crate) fn from_matrix(m: &DMatrix<f64>) -> Self {
        let (rows, columns) = m.shape();
        let data = (0..rows)
            .flat_map(|i| (0..columns).map(move |j| m[(i, j)]))
            .collect();
        Self::from_rows(rows, columns, data)
    }

    /// The row-major values, moved out.
    pub(crate) fn into_data(self) -> Vec<f64> {
        self.data
    }

    /// Number of columns.
    pub(crate) fn ncols(&self) -> usize {
        self.columns
    }

    /// Row i.
    pub(crate) fn row(&self, i: usize) -> &[f64] {
        &self.data[i * self.columns..(i + 1) * self.columns]
    }

    /// Block b: rows [b·`ROW_BLOCK`, (b + 1)·`ROW_BLOCK`) ∩ [0, r).
    fn block(&self, b: usize) -> MatRef<'_, f64> {
        let first = b * ROW_BLOCK;
        let rows = ROW_BLOCK.min(self.rows - first);
        let data = &self.data[first * self.columns..(first + rows) * self.columns];
        MatRef::from_row_major_slice(data, rows, self.columns)
    }

    /// `f` of every block, in block order; in parallel when the matrix is
    /// large enough. Each block's arithmetic is the same either way.
    fn map_blocks<T: Send>(&self, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
        let blocks = self.rows.div_ceil(ROW_BLOCK);
        if self.data.len() as f64 >= PARALLEL_WORK && rayon::current_num_threads() > 1 {
            (0..blocks).into_par_iter().map(f).collect()
        } else {
            (0..blocks).map(f).collect()
        }
    }

    /// A v: each entry is one row's dot product, so no sum crosses blocks.
    pub(crate) fn mul(&self, v: &DVector<f64>) -> DVector<f64> {
        assert_eq!(v.len(), self.columns, "A v with v of A's width");
        let v = MatRef::from_column_major_slice(v.as_slice(), self.columns, 1);
        let parts = self.map_blocks(|b| {
            let block = self.block(b);
            let mut out = vec![0.0; block.nrows()];
            faer::linalg::matmul::matmul(
                MatMut::from_column_major_slice_mut(&mut out, block.nrows(), 1),
                Accum::Replace,
                block,
                v,
                1.0,
                Par::Seq,
            );
            out
        });
        DVector::from_iterator(self.rows, parts.into_iter().flatten())
    }

    /// Aᵀ w: the blocks' partial sums, added in block order.
    pub(crate) fn tr_mul(&self, w: &DVector<f64>) -> DVector<f64> {
        assert_eq!(w.len(), self.rows, "Aᵀ w with w of A's height");
        let columns = self.columns;
        let parts = self.map_blocks(|b| {
            let block = self.block(b);
            let first = b * ROW_BLOCK;
            let w = &w.as_slice()[first..first + block.nrows()];
            let mut out = vec![0.0; columns];
            faer::linalg::matmul::matmul(
                MatMut::from_column_major_slice_mut(&mut out, columns, 1),
                Accum::Replace,
                block.transpose(),
                MatRef::from_column_major_slice(w, w.len(), 1),
                1.0,
                Par::Seq,
            );
            out
        });
        let mut out = DVector::zeros(columns);
        for part in parts {
            out.iter_mut().zip(part).for_each(|(o, p)| *o += p);
        }
        out
    }

    /// Aᵀ w for a w that is zero outside a few rows: the sum of those rows,
    /// scaled, in row order. Reads only those rows of A.
    pub(crate) fn tr_mul_sparse(&self, w: &DVector<f64>) -> DVector<f64> {
        assert_eq!(w.len(), self.rows, "Aᵀ w with w of A's height");
        let mut out = DVector::zeros(self.columns);
        for (i, &wi) in w.iter().enumerate() {
            if wi != 0.0 {
                out.iter_mut()
                    .zip(self.row(i))
                    .for_each(|(o, a)| *o += wi * a);
            }
        }
        out
    }

    /// (A v, Aᵀ w) in one pass over A when w depends on A v row by row:
    /// wᵢ = `weight`(i, (A v)ᵢ). A Newton solve needs A dy to recover the
    /// multipliers' directions, and Aᵀ of those directions to check the
    /// solve: this reads A once for both.
    pub(crate) fn mul_then_tr_mul(
        &self,
        v: &DVector<f64>,
        weight: impl Fn(usize, f64) -> f64 + Sync,
    ) -> (DVector<f64>, DVector<f64>) {
        let (product, [sum]) = self.mul_then_tr_mul_many(v, |i, av| [weight(i, av)]);
        (product, sum)
    }

    /// (A v, Aᵀ w₁, …, Aᵀ w_N) in one pass over A, where row i of every wₙ
    /// depends on (A v)ᵢ: `weights`(i, (A v)ᵢ) = (w₁ᵢ, …, w_Nᵢ). Each slice
    /// of `FUSED_ROWS` rows is multiplied by v, its weights formed, and
    /// multiplied back while it is still in the cache. The products with A
    /// are the memory-bound part of an iteration, so every right-hand side
    /// that can be formed row by row in a pass shares it.
    pub(crate) fn mul_then_tr_mul_many<const N: usize>(
        &self,
        v: &DVector<f64>,
        weights: impl Fn(usize, f64) -> [f64; N] + Sync,
    ) -> (DVector<f64>, [DVector<f64>; N]) {
        assert_eq!(v.len(), self.columns, "A v with v of A's width");
        let columns = self.columns;
        let v = MatRef::from_column_major_slice(v.as_slice(), columns, 1);
        let parts = self.map_blocks(|b| {
            let block = self.block(b);
            let first = b * ROW_BLOCK;
            let mut product = vec![0.0; block.nrows()];
            let slice_rows = FUSED_ROWS.min(block.nrows());
            // Column-major: the slice's n-th weight vector is column n.
            let mut slice_weights = vec![0.0; slice_rows * N];
            let mut partial = vec![0.0; columns * N];
            let mut start = 0;
            while start < block.nrows() {
                let rows = FUSED_ROWS.min(block.nrows() - start);
                let slice = block.subrows(start, rows);
                let slice_product = &mut product[start..start + rows];
                faer::linalg::matmul::matmul(
                    MatMut::from_column_major_slice_mut(slice_product, rows, 1),
                    Accum::Replace,
                    slice,
                    v,
                    1.0,
                    Par::Seq,
                );
                let slice_weights = &mut slice_weights[..rows * N];
                for (j, av) in slice_product.iter().enumerate() {
                    for (n, w) in weights(first + start + j, *av).into_iter().enumerate() {
                        slice_weights[n * rows + j] = w;
                    }
                }
                faer::linalg::matmul::matmul(
                    MatMut::from_column_major_slice_mut(&mut partial, columns, N),
                    if start == 0 {
                        Accum::Replace
                    } else {
                        Accum::Add
                    },
                    slice.transpose(),
                    MatRef::from_column_major_slice(slice_weights, rows, N),
                    1.0,
                    Par::Seq,
                );
                start += rows;
            }
            (product, partial)
        });
        let mut product = Vec::with_capacity(self.rows);
        let mut sums = std::array::from_fn(|_| DVector::zeros(columns));
        for (part, partial) in parts {
            product.extend(part);
            for (sum, partial) in sums.iter_mut().zip(partial.chunks_exact(columns.max(1))) {
                sum.iter_mut().zip(partial).for_each(|(o, p)| *o += p);
            }
        }
        (DVector::from_vec(product), sums)
    }

    /// Rows per block of [`RowMajor::weighted_gram`]: `GRAM_BLOCK` where a
    /// block of `ROW_BLOCK` rows is already multiplied in parallel, else
    /// `ROW_BLOCK`. Longer blocks would move narrow products (the paper's
    /// systems, tens of columns) onto the parallel path, which is slower
    /// at that size: Linear2d's solver time went from 0.6 to 0.8 s.
    fn gram_block(&self) -> usize {
        let work = ROW_BLOCK as f64 * (self.columns * self.columns) as f64 / 2.0;
        match parallelism(work) {
            Par::Seq => ROW_BLOCK,
            _ => GRAM_BLOCK,
        }
    }

    /// Aᵀ diag(d) A for d ≥ 0, symmetric (both triangles filled): each block
    /// of rows ([`RowMajor::gram_block`]) is scaled by √d into `buffer`
    /// and its Gram product added to the lower triangle, in block order.
    /// The buffer is grown to a block's size if it is shorter; an
    /// interior-point method passes the same one at every iteration, since
    /// zeroing a fresh one (30 MB at a thousand columns) costs 1–2% of an
    /// iteration.
    pub(crate) fn weighted_gram(&self, d: &DVector<f64>, buffer: &mut Vec<f64>) -> DMatrix<f64> {
        assert_eq!(d.len(), self.rows, "one weight per row");
        let k = self.columns;
        let mut out = DMatrix::zeros(k, k);
        let block_rows = self.gram_block();
        let needed = block_rows.min(self.rows) * k;
        if buffer.len() < needed {
            buffer.resize(needed, 0.0);
        }
        for (index, block) in self.data.chunks(block_rows * k.max(1)).enumerate() {
            let rows = block.len() / k.max(1);
            let scaled = &mut buffer[..rows * k];
            let weights = &d.as_slice()[index * block_rows..index * block_rows + rows];
            // Scaling is memory-bound; on one thread it would leave the
            // other cores idle between the products.
            let scale = |((target, row), weight): ((&mut [f64], &[f64]), &f64)| {
                let root = weight.sqrt();
                target.iter_mut().zip(row).for_each(|(t, a)| *t = root * a);
            };
            if matches!(parallelism((rows * k) as f64 * 64.0), Par::Seq) {
                scaled
                    .chunks_exact_mut(k.max(1))
                    .zip(block.chunks_exact(k.max(1)))
                    .zip(weights)
                    .for_each(scale);
            } else {
                scaled
                    .par_chunks_exact_mut(k.max(1))
                    .zip(block.par_chunks_exact(k.max(1)))
                    .zip(weights)
                    .for_each(scale);
            }
            let scaled = MatRef::from_row_major_slice(scaled, rows, k);
            faer::linalg::matmul::triangular::matmul(
                view_mut(&mut out),
                BlockStructure::TriangularLower,
                if index == 0 {
                    Accum::Replace
                } else {
                    Accum::Add
                },
                scaled.transpose(),
                BlockStructure::Rectangular,
                scaled,
                BlockStructure::Rectangular,
                1.0,
                parallelism(rows as f64 * (k * k) as f64 / 2.0),
            );
        }
        symmetrise_lower(&mut out);
        out
    }
}

/// Copies the lower triangle of a square matrix onto its upper triangle.
fn symmetrise_lower(m: &mut DMatrix<f64>) {
    for j in 0..m.ncols() {
        for i in 0..j {
            m[(i, j)] = m[(j, i)];
        }
    }
}

/// A Cholesky factorisation L Lᵀ of a symmetric positive definite matrix.
pub(crate) struct Cholesky {
    l: DMatrix<f64>,
}

impl Cholesky {
    /// Factorises `m` (its lower triangle is read); `None` if a pivot is
    /// not positive.
    pub(crate) fn new(m: &DMatrix<f64>) -> Option<Self> {
        Self::in_place(m.clone()).ok()
    }

    /// Factorises `m` in its own storage (its lower triangle is read).
    /// If a pivot is not positive, `m` comes back overwritten (faer writes
    /// both triangles as it goes), to be refilled rather than reallocated.
    pub(crate) fn in_place(mut m: DMatrix<f64>) -> Result<Self, DMatrix<f64>> {
        let n = m.nrows();
        let par = parallelism((n * n * n) as f64 / 3.0);
        let mut memory = MemBuffer::new(
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(
                n,
                par,
                Default::default(),
            ),
        );
        let factored = faer::linalg::cholesky::llt::factor::cholesky_in_place(
            view_mut(&mut m),
            Default::default(),
            par,
            MemStack::new(&mut memory),
            Default::default(),
        );
        // Every entry of L's row i enters its pivot, d_i = m_ii − Σⱼ l_ij²,
        // and faer rejects a pivot that is not positive (NaN included), so
        // a finite diagonal means a finite factor.
        if factored.is_err() || !(0..n).all(|i| m[(i, i)].is_finite()) {
            return Err(m);
        }
        for j in 0..n {
            for i in 0..j {
                m[(i, j)] = 0.0;
            }
        }
        Ok(Self { l: m })
    }

    /// The factor of MᵀM for the `rows` × `n` matrix M whose row i
    /// `fill_row(i, row)` writes, L = Rᵀ from [`triangular_factor`]: the
    /// Gram product is never formed, so the factor keeps the singular
    /// values of M down to ε‖M‖, where a Cholesky of the formed MᵀM loses
    /// those below √ε‖M‖. `None` if a diagonal entry of R is zero or any
    /// entry is not finite.
    pub(crate) fn from_rows(
        rows: usize,
        n: usize,
        fill_row: impl Fn(usize, &mut [f64]),
    ) -> Option<Self> {
        let l = triangular_factor(rows, n, fill_row).transpose();
        let regular = (0..n).all(|i| l[(i, i)] != 0.0) && l.iter().all(|v| v.is_finite());
        regular.then_some(Self { l })
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

/// Rows per QR in [`Cholesky::from_rows`], in multiples of the width: the
/// QR of the stacked R costs as much as that of n new rows, so a block of
/// 4n rows spends a fifth of the work on it.
const QR_BLOCK: usize = 4;

/// Overwrites m's upper triangle with R of m = QR (Householder, blocked).
fn householder_qr_in_place(m: &mut DMatrix<f64>) {
    use faer::linalg::qr::no_pivoting::factor;
    let (rows, n) = m.shape();
    let size = rows.min(n);
    let par = decomposition_parallelism(rows as f64 * (n * n) as f64);
    let block = factor::recommended_blocksize::<f64>(rows, n);
    let mut coefficients = faer::Mat::<f64>::zeros(block, size);
    let mut memory = MemBuffer::new(factor::qr_in_place_scratch::<f64>(
        rows,
        n,
        block,
        par,
        Default::default(),
    ));
    factor::qr_in_place(
        view_mut(m),
        coefficients.as_mut(),
        par,
        MemStack::new(&mut memory),
        Default::default(),
    );
}

/// The Euclidean norm of each of the `columns` columns of a `rows`-row
/// matrix M (`entry(row, column)`), with 1 in place of a norm at most 1e-300
/// of the largest, and ‖M D⁻¹‖²_F for D those scales. Dividing by them makes
/// a rank decision read every column at unit size and leaves a column
/// without data at zero, where it counts as flat. The sum is the exact
/// squared norm of what is decided on (at most the number of columns), and
/// not finite when an entry or a norm is not, where every column keeps
/// scale 1.
pub(crate) fn column_scales(
    rows: usize,
    columns: usize,
    entry: impl Fn(usize, usize) -> f64,
) -> (Vec<f64>, f64) {
    let mut norms = vec![0.0_f64; columns];
    for row in 0..rows {
        for (c, norm) in norms.iter_mut().enumerate() {
            *norm += entry(row, c).powi(2);
        }
    }
    norms.iter_mut().for_each(|n| *n = n.sqrt());
    let largest = norms.iter().fold(0.0_f64, |m, n| m.max(*n));
    let scales: Vec<f64> = norms
        .iter()
        .map(|&n| {
            if n > 1e-300 * largest.max(1e-300) {
                n
            } else {
                1.0
            }
        })
        .collect();
    let frobenius_squared = norms
        .iter()
        .zip(&scales)
        .map(|(n, d)| (n / d).powi(2))
        .sum();
    (scales, frobenius_squared)
}

/// Rows in a subset that shows full rank ([`full_rank_on_rows`]), per
/// column: enough that the subset alone is well overdetermined, and one
/// block of [`triangular_factor_by_blocks`]'s QR.
const RANK_SUBSET: usize = 4;

/// About `RANK_SUBSET` · n rows, evenly spread, of a matrix with `rows` rows
/// and n columns, for [`full_rank_on_rows`]; `None` when the matrix has
/// fewer than twice as many, too few for a subset to save work.
pub(crate) fn strided_rows(rows: usize, n: usize) -> Option<Vec<usize>> {
    let count = RANK_SUBSET * n.max(1);
    (rows >= 2 * count).then(|| (0..count).map(|i| i * rows / count).collect())
}

/// Whether a matrix M with n columns certainly has every singular value
/// above `tolerance` times its largest, shown on `count` of its rows (the
/// subset M_S, whose rows `first..first + block.nrows()` `fill_block`
/// writes) and `frobenius_squared`, an upper bound on ‖M‖²_F. Rows added to
/// a matrix never lower any of its singular values, and
/// σ₁(M)² ≤ σ₁(M_S)² + ‖M‖²_F − ‖M_S‖²_F, so σ_n(M_S) above `tolerance`
/// times the square root of the right-hand side shows it. `false` means
/// "not shown" (also when the subset has fewer rows than columns, its SVD
/// fails or the bound is not finite), never "rank deficient".
pub(crate) fn full_rank_on_rows(
    count: usize,
    n: usize,
    frobenius_squared: f64,
    tolerance: f64,
    fill_block: impl FnMut(usize, DMatrixViewMut<'_, f64>),
) -> bool {
    if count < n {
        return false;
    }
    let r = triangular_factor_by_blocks(count, n, fill_block);
    let Some(singular) = singular_values(&r) else {
        return false;
    };
    let (Some(&largest), Some(&smallest)) = (singular.first(), singular.last()) else {
        return n == 0;
    };
    // ‖M_S‖_F = ‖R‖_F.
    let subset_squared: f64 = singular.iter().map(|s| s * s).sum();
    let bound = (largest * largest + (frobenius_squared - subset_squared).max(0.0)).sqrt();
    // Comparisons with NaN are false: not shown.
    smallest > tolerance * bound && bound.is_finite()
}

/// The block filler of [`triangular_factor_by_blocks`] from one that
/// writes a row at a time (`fill_row(i, row)` writes row i).
pub(crate) fn row_by_row(
    fill_row: impl Fn(usize, &mut [f64]),
) -> impl FnMut(usize, DMatrixViewMut<'_, f64>) {
    let mut row = Vec::new();
    move |first, mut block| {
        row.resize(block.ncols(), 0.0);
        for i in 0..block.nrows() {
            fill_row(first + i, &mut row);
            for (j, value) in row.iter().enumerate() {
                block[(i, j)] = *value;
            }
        }
    }
}

/// R (n × n, upper triangular) with RᵀR = MᵀM for the `rows` × `n` matrix M
/// whose row i `fill_row(i, row)` writes; see [`triangular_factor_by_blocks`].
pub(crate) fn triangular_factor(
    rows: usize,
    n: usize,
    fill_row: impl Fn(usize, &mut [f64]),
) -> DMatrix<f64> {
    triangular_factor_by_blocks(rows, n, row_by_row(fill_row))
}

/// R (n × n, upper triangular) with RᵀR = MᵀM for the `rows` × `n` matrix M
/// whose rows `first..first + block.nrows()` `fill_block(first, block)`
/// writes: Householder QRs of `QR_BLOCK` · n rows at a time, each on the
/// previous R stacked over the new rows, so the memory is a few n × n
/// matrices whatever the number of rows and the work is linear in it. R has
/// M's singular values down to ε‖M‖ (MᵀM formed would lose those below
/// √ε‖M‖).
pub(crate) fn triangular_factor_by_blocks(
    rows: usize,
    n: usize,
    mut fill_block: impl FnMut(usize, DMatrixViewMut<'_, f64>),
) -> DMatrix<f64> {
    let mut r = DMatrix::<f64>::zeros(n, n);
    if n == 0 {
        return r;
    }
    let block = QR_BLOCK * n;
    let mut start = 0;
    while start < rows {
        let end = (start + block).min(rows);
        let mut stacked = DMatrix::<f64>::zeros(n + end - start, n);
        stacked.view_mut((0, 0), (n, n)).copy_from(&r);
        fill_block(start, stacked.view_mut((n, 0), (end - start, n)));
        householder_qr_in_place(&mut stacked);
        r = DMatrix::from_fn(n, n, |i, j| if i <= j { stacked[(i, j)] } else { 0.0 });
        start = end;
    }
    r
}

/// Tasks faer's decompositions (QR, SVD, symmetric eigendecomposition)
/// split their work into when they run in parallel, whatever the number
/// of threads: their arithmetic follows the task count, so with the
/// pool's thread count (`Par::rayon(0)`) a QR of 1700 × 400 rows differed
/// in its last bits between one thread and two, and so did the joint
/// step's results (a probe).
const DECOMPOSITION_TASKS: usize = 4;

/// The parallelism of a decomposition of `work` multiply-adds.
fn decomposition_parallelism(work: f64) -> Par {
    match parallelism(work) {
        Par::Seq => Par::Seq,
        _ => Par::rayon(DECOMPOSITION_TASKS),
    }
}

/// Eigenvalues (ascending) of a symmetric matrix (its lower triangle is
/// read) and, if asked, its eigenvectors; `None` on failure.
fn faer_symmetric_eigen(
    m: &DMatrix<f64>,
    vectors: bool,
) -> Option<(Vec<f64>, Option<faer::Mat<f64>>)> {
    use faer::linalg::evd::{self_adjoint_evd, self_adjoint_evd_scratch, ComputeEigenvectors};
    let n = m.nrows();
    let par = decomposition_parallelism((n * n * n) as f64);
    let compute = if vectors {
        ComputeEigenvectors::Yes
    } else {
        ComputeEigenvectors::No
    };
    let mut values = faer::diag::Diag::<f64>::zeros(n);
    let mut u = vectors.then(|| faer::Mat::<f64>::zeros(n, n));
    let mut memory = MemBuffer::new(self_adjoint_evd_scratch::<f64>(
        n,
        compute,
        par,
        Default::default(),
    ));
    self_adjoint_evd(
        view(m),
        values.as_mut(),
        u.as_mut().map(|u| u.as_mut()),
        par,
        MemStack::new(&mut memory),
        Default::default(),
    )
    .ok()?;
    let values: Vec<f64> = (0..n).map(|i| values[i]).collect();
    Some((values, u))
}

/// U and V of a singular value decomposition.
type SingularVectors = (faer::Mat<f64>, faer::Mat<f64>);

/// The singular values (descending) of an m × n matrix and, if asked, its
/// singular vectors (thin or full); `None` on failure.
fn faer_svd(
    m: &DMatrix<f64>,
    vectors: faer::linalg::svd::ComputeSvdVectors,
) -> Option<(Vec<f64>, Option<SingularVectors>)> {
    use faer::linalg::svd::{svd, svd_scratch, ComputeSvdVectors};
    let (rows, columns) = m.shape();
    let size = rows.min(columns);
    let par = decomposition_parallelism(rows as f64 * columns as f64 * size as f64);
    let (u_columns, v_columns) = match vectors {
        ComputeSvdVectors::Full => (rows, columns),
        _ => (size, size),
    };
    let mut values = faer::diag::Diag::<f64>::zeros(size);
    let mut factors = (vectors != ComputeSvdVectors::No).then(|| {
        (
            faer::Mat::<f64>::zeros(rows, u_columns),
            faer::Mat::<f64>::zeros(columns, v_columns),
        )
    });
    let mut memory = MemBuffer::new(svd_scratch::<f64>(
        rows,
        columns,
        vectors,
        vectors,
        par,
        Default::default(),
    ));
    let (u, v) = match factors.as_mut() {
        Some((u, v)) => (Some(u.as_mut()), Some(v.as_mut())),
        None => (None, None),
    };
    svd(
        view(m),
        values.as_mut(),
        u,
        v,
        par,
        MemStack::new(&mut memory),
        Default::default(),
    )
    .ok()?;
    let values: Vec<f64> = (0..size).map(|i| values[i]).collect();
    Some((values, factors))
}

/// A faer matrix as an nalgebra one.
fn to_nalgebra(m: &faer::Mat<f64>) -> DMatrix<f64> {
    DMatrix::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)])
}

/// Eigenvalues (ascending) and eigenvectors (columns) of a symmetric matrix;
/// `None` if the eigensolver fails or returns non-finite values.
pub(crate) fn symmetric_eigen(m: &DMatrix<f64>) -> Option<(Vec<f64>, DMatrix<f64>)> {
    let (values, u) = faer_symmetric_eigen(m, true)?;
    let vectors = to_nalgebra(&u?);
    (values.iter().all(|v| v.is_finite()) && vectors.iter().all(|v| v.is_finite()))
        .then_some((values, vectors))
}

/// The eigenvalues (ascending) of a symmetric matrix; `None` on failure.
pub(crate) fn symmetric_eigenvalues(m: &DMatrix<f64>) -> Option<Vec<f64>> {
    let (values, _) = faer_symmetric_eigen(m, false)?;
    values.iter().all(|v| v.is_finite()).then_some(values)
}

/// The full SVD of an m × n matrix: U (m × m), the min(m, n) singular
/// values (descending) and V (n × n); `None` on failure.
pub(crate) fn svd(m: &DMatrix<f64>) -> Option<(DMatrix<f64>, Vec<f64>, DMatrix<f64>)> {
    let (values, factors) = faer_svd(m, faer::linalg::svd::ComputeSvdVectors::Full)?;
    let (u, v) = factors?;
    let (u, v) = (to_nalgebra(&u), to_nalgebra(&v));
    let finite = values
        .iter()
        .chain(u.iter())
        .chain(v.iter())
        .all(|x| x.is_finite());
    finite.then_some((u, values, v))
}

/// The minimum-norm least-squares solution of a x ≈ b from a thin SVD,
/// singular values at most `relative` times the largest counted as zero;
/// `None` on failure or a non-finite result.
pub(crate) fn least_squares(
    a: &DMatrix<f64>,
    b: &DVector<f64>,
    relative: f64,
) -> Option<DVector<f64>> {
    let (rows, columns) = a.shape();
    let (s, factors) = faer_svd(a, faer::linalg::svd::ComputeSvdVectors::Thin)?;
    let (u, v) = factors?;
    let rank = rows.min(columns);
    let largest = if rank > 0 { s[0] } else { 0.0 };
    let mut x = DVector::<f64>::zeros(columns);
    for j in (0..rank).filter(|&j| s[j] > relative * largest) {
        let coefficient = (0..rows).map(|i| u[(i, j)] * b[i]).sum::<f64>() / s[j];
        for i in 0..columns {
            x[i] += coefficient * v[(i, j)];
        }
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The singular values (descending) of any matrix; `None` on failure.
pub(crate) fn singular_values(m: &DMatrix<f64>) -> Option<Vec<f64>> {
    faer_svd(m, faer::linalg::svd::ComputeSvdVectors::No).map(|(values, _)| values)
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

    /// A factor is only returned finite, although only its diagonal is
    /// checked: a non-finite entry anywhere in the lower triangle reaches
    /// a pivot. Sizes above faer's recursion threshold take its blocked path.
    #[test]
    fn non_finite_entries_give_no_factor() {
        for n in [3, 150] {
            let base = DMatrix::from_fn(n, n, |i, j| if i == j { n as f64 } else { 0.5 });
            for value in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                for (i, j) in [
                    (n - 1, 0),
                    (n / 2, n / 3),
                    (n - 1, n - 2),
                    (0, 0),
                    (n - 1, n - 1),
                ] {
                    let mut m = base.clone();
                    m[(i, j)] = value;
                    assert!(
                        Cholesky::new(&m).is_none(),
                        "n = {n}, {value} at ({i}, {j})"
                    );
                }
            }
            assert!(Cholesky::new(&base).is_some());
        }
    }

    /// The minimum-norm solution where a's columns are dependent, the
    /// exact one where they are not.
    #[test]
    fn least_squares_takes_the_minimum_norm_solution() {
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 1.0, 1.0, 1.0, 0.0, 0.0]);
        let b = DVector::from_vec(vec![2.0, 2.0, 1.0]);
        let x = least_squares(&a, &b, 1e-14).unwrap();
        assert!((x[0] - 1.0).abs() < 1e-14 && (x[1] - 1.0).abs() < 1e-14);
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 1.0, 1.0, 1.0, 2.0]);
        let b = DVector::from_vec(vec![1.0, 2.0, 3.0]);
        let x = least_squares(&a, &b, 1e-14).unwrap();
        let normal = (a.transpose() * &a)
            .lu()
            .solve(&(a.transpose() * &b))
            .unwrap();
        assert!((x - normal).amax() < 1e-14);
    }

    /// The factor of MᵀM from blocked QRs of M's rows: L Lᵀ = MᵀM over
    /// several blocks, the same bits on one thread, and the smallest
    /// singular value of an M with condition number 1e10 kept to 1e-4
    /// (in the formed MᵀM it is below the rounding of the largest).
    #[test]
    fn factor_from_rows_keeps_the_small_singular_values() {
        let (rows, n) = (3 * QR_BLOCK * 40 + 13, 40);
        let m = pseudo_random(rows, n, 5);
        let factor = |m: &DMatrix<f64>| {
            Cholesky::from_rows(m.nrows(), m.ncols(), |i, row| {
                for (j, value) in row.iter_mut().enumerate() {
                    *value = m[(i, j)];
                }
            })
            .unwrap()
        };
        let l = factor(&m).l;
        let gram = m.transpose() * &m;
        let error = (&l * l.transpose() - &gram).amax() / gram.amax();
        assert!(error < 1e-13, "relative error {error}");
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| factor(&m).l);
        assert_eq!(one, l);

        // M = U Σ Vᵀ with σ from 1 down to 1e-10.
        let u = pseudo_random(rows, n, 6).qr().q();
        let v = pseudo_random(n, n, 7).qr().q();
        let sigma = DVector::from_fn(n, |i, _| 10f64.powf(-10.0 * i as f64 / (n - 1) as f64));
        let ill = &u * DMatrix::from_diagonal(&sigma) * v.transpose();
        let values = singular_values(&factor(&ill).l).unwrap();
        let smallest = values[n - 1];
        assert!(
            (smallest / 1e-10 - 1.0).abs() < 1e-4,
            "smallest singular value {smallest:e}, want 1e-10"
        );
        // No columns: an empty factor; no rows: singular.
        assert_eq!(Cholesky::from_rows(5, 0, |_, _| ()).unwrap().l.len(), 0);
        assert!(Cholesky::from_rows(0, 3, |_, _| ()).is_none());
    }

    /// A pseudo-random r × k matrix (a fixed linear congruential sequence).
    fn pseudo_random(rows: usize, columns: usize, seed: u64) -> DMatrix<f64> {
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
        DMatrix::from_fn(rows, columns, |_, _| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        })
    }

    /// Every product of a matrix spanning several row blocks, large enough
    /// to run in parallel.
    fn row_major_products(
        a: &RowMajor,
        v: &DVector<f64>,
        w: &DVector<f64>,
        d: &DVector<f64>,
    ) -> Vec<DMatrix<f64>> {
        // Two transposed products in one pass, one of them fixed weights.
        let (av, [atw, at_weighted]) = a.mul_then_tr_mul_many(v, |i, av| [w[i], weight_of(i, av)]);
        let (_, at_weighted_alone) = a.mul_then_tr_mul(v, weight_of);
        vec![
            DMatrix::from_column_slice(a.rows, 1, a.mul(v).as_slice()),
            DMatrix::from_column_slice(a.columns, 1, a.tr_mul(w).as_slice()),
            DMatrix::from_column_slice(a.rows, 1, av.as_slice()),
            DMatrix::from_column_slice(a.columns, 1, atw.as_slice()),
            DMatrix::from_column_slice(a.columns, 1, at_weighted.as_slice()),
            DMatrix::from_column_slice(a.columns, 1, at_weighted_alone.as_slice()),
            a.weighted_gram(d, &mut Vec::new()),
        ]
    }

    /// A weight that depends on the row and on (A v)ᵢ, for the fused pass.
    fn weight_of(i: usize, av: f64) -> f64 {
        (i % 3) as f64 * av - 0.5 * av * av
    }

    #[test]
    fn row_major_products_match_nalgebra_and_the_thread_count() {
        // Several blocks of the Gram product, and so many more of the others.
        let (rows, columns) = (2 * GRAM_BLOCK + 77, 90);
        let m = pseudo_random(rows, columns, 1);
        let a = RowMajor::from_matrix(&m);
        assert!(a.data.len() as f64 >= PARALLEL_WORK);
        let v = DVector::from_column_slice(pseudo_random(columns, 1, 2).as_slice());
        let w = DVector::from_column_slice(pseudo_random(rows, 1, 3).as_slice());
        let d = w.map(|x| x.abs() + 0.1);
        let products = row_major_products(&a, &v, &w, &d);
        let mut scaled = m.clone();
        for (mut row, weight) in scaled.row_iter_mut().zip(d.iter()) {
            row *= *weight;
        }
        let mv = &m * &v;
        let mtw = m.tr_mul(&w);
        let column = |v: &DVector<f64>| DMatrix::from_column_slice(v.len(), 1, v.as_slice());
        let expected = [
            column(&mv),
            column(&mtw),
            column(&mv),
            column(&mtw),
            column(&m.tr_mul(&DVector::from_fn(rows, |i, _| weight_of(i, mv[i])))),
            column(&m.tr_mul(&DVector::from_fn(rows, |i, _| weight_of(i, mv[i])))),
            m.transpose() * &scaled,
        ];
        assert_eq!(products.len(), expected.len());
        for (got, want) in products.iter().zip(expected.iter()) {
            let error = (got - want).amax() / want.amax();
            assert!(error < 1e-13, "relative error {error}");
        }
        // Same bits on one thread as on the global pool.
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| row_major_products(&a, &v, &w, &d));
        assert_eq!(one, products);
    }

    /// faer's kernels give the same bits on one thread as on the global
    /// pool: the Gram product, the congruence, the Cholesky factor and its
    /// solve, the factor from rows, the symmetric eigendecomposition and
    /// the SVD, at sizes where each runs in parallel.
    #[test]
    fn dense_kernels_match_the_thread_count() {
        let m = pseudo_random(1700, 400, 8);
        let z = pseudo_random(400, 300, 9);
        let b = DVector::from_column_slice(pseudo_random(400, 1, 10).as_slice());
        let kernels = || {
            let g = gram(&m);
            let c = congruence(&g, &z);
            let factor = Cholesky::new(&g).unwrap();
            let x = factor.solve(&b);
            let l = factor.l().clone();
            let r = Cholesky::from_rows(m.nrows(), m.ncols(), |i, row| {
                for (j, value) in row.iter_mut().enumerate() {
                    *value = m[(i, j)];
                }
            })
            .unwrap()
            .l;
            let eigen = symmetric_eigen(&c).unwrap();
            let singular = svd(&z).unwrap();
            (g, c, l, x, r, eigen, singular)
        };
        let all = kernels();
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(kernels);
        assert!(all.0 == one.0, "Gram product");
        assert!(all.1 == one.1, "congruence");
        assert!(all.2 == one.2, "Cholesky factor");
        assert!(all.3 == one.3, "Cholesky solve");
        assert!(all.4 == one.4, "factor from rows (blocked QR)");
        assert!(all.5 == one.5, "symmetric eigendecomposition");
        assert!(all.6 == one.6, "singular value decomposition");
    }

    #[test]
    fn sparse_transposed_product_matches_the_dense_one() {
        let m = pseudo_random(300, 17, 4);
        let a = RowMajor::from_matrix(&m);
        let mut w = DVector::zeros(300);
        for (i, v) in [(0, 1.5), (123, -0.25), (299, 2.0)] {
            w[i] = v;
        }
        let error = (a.tr_mul_sparse(&w) - m.tr_mul(&w)).amax();
        assert!(error < 1e-14, "{error}");
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
        // A wide matrix: U is 2 × 2, V is 3 × 3.
        let wide = DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 2.0, 0.0, 3.0, 0.0]);
        let (u, s, v) = svd(&wide).unwrap();
        assert_eq!((u.shape(), s.len(), v.shape()), ((2, 2), 2, (3, 3)));
        let mut sigma = DMatrix::zeros(2, 3);
        sigma.set_partial_diagonal(s.into_iter());
        assert!((u * sigma * v.transpose() - &wide).amax() < 1e-14);
    }

    /// Full rank on a subset of rows, tested against the rank of all rows:
    /// shown for a well-conditioned matrix; never shown when only rows
    /// outside the subset reach a column, or when those rows are so much
    /// larger that the whole matrix is ill-conditioned at the tolerance
    /// although the subset is not.
    #[test]
    fn a_subset_of_rows_shows_full_rank_only_where_all_rows_have_it() {
        let relative_smallest = |m: &DMatrix<f64>| {
            let s = singular_values(m).unwrap();
            s[s.len() - 1] / s[0]
        };
        let shown = |m: &DMatrix<f64>, tolerance: f64| {
            let subset = strided_rows(m.nrows(), m.ncols()).unwrap();
            full_rank_on_rows(
                subset.len(),
                m.ncols(),
                m.norm_squared(),
                tolerance,
                |first, mut block| {
                    for i in 0..block.nrows() {
                        block.row_mut(i).copy_from(&m.row(subset[first + i]));
                    }
                },
            )
        };
        let m = pseudo_random(400, 5, 7);
        assert!(relative_smallest(&m) > 1e-2);
        assert!(shown(&m, 1e-8));
        // Scaled to unit columns, the bound is the number of columns; an
        // entry that is not finite makes it not finite, and nothing shown.
        let (scales, frobenius_squared) = column_scales(400, 5, |i, j| m[(i, j)]);
        assert!((frobenius_squared - 5.0).abs() < 1e-12);
        assert!(scales.iter().all(|&d| d > 1.0));
        let mut broken = m.clone();
        broken[(399, 2)] = f64::INFINITY;
        let (_, frobenius_squared) = column_scales(400, 5, |i, j| broken[(i, j)]);
        assert!(!frobenius_squared.is_finite());
        let subset = strided_rows(400, 5).unwrap();
        assert!(!full_rank_on_rows(
            subset.len(),
            5,
            frobenius_squared,
            1e-8,
            row_by_row(|i, row| row.copy_from_slice(m.row(subset[i]).transpose().as_slice()))
        ));
        // Too few rows for a subset to save work.
        assert_eq!(strided_rows(39, 5), None);

        let subset = strided_rows(400, 2).unwrap();
        let mut outside = DMatrix::from_fn(400, 2, |_, j| if j == 0 { 1.0 } else { 0.0 });
        let mut huge = DMatrix::from_fn(400, 2, |_, j| if j == 0 { 1e5 } else { 0.0 });
        for (n, &i) in subset.iter().enumerate() {
            huge[(i, 0)] = f64::from(u8::from(n % 2 == 0));
            huge[(i, 1)] = f64::from(u8::from(n % 2 == 1));
        }
        for i in (0..400).filter(|i| subset.binary_search(i).is_err()) {
            outside[(i, 1)] = 1.0 + (i % 7) as f64;
        }
        assert!(relative_smallest(&outside) > 1e-3);
        assert!(!shown(&outside, 1e-8));
        assert!(relative_smallest(&huge) < 1e-3);
        assert!(!shown(&huge, 1e-3));
        // The subset alone is well-conditioned: only the bound on the
        // rows outside it keeps this from being shown.
        assert!(shown(&huge, 1e-7));
    }
}
