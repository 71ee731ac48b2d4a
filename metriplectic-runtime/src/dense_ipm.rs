//! A dense primal–dual interior-point method for the runtime's L1
//! regressions with side cones, the default [`SolverBackend`](crate::conic::SolverBackend).
//!
//! Why not only Clarabel: every subproblem couples r ≈ n·q residuals to a
//! few dozen dense coefficient columns. Clarabel factorises its sparse KKT
//! matrix with QDLDL, a scalar LDL, and eliminating each residual updates
//! the dense coefficient block one entry at a time: ~r·k² multiply-adds at a
//! few hundred MFLOP/s (BENCHMARKS.md §5). Here the L1 auxiliaries are
//! eliminated analytically, so an iteration factorises one k×k matrix
//! Aᵀ D̃ A + (cone part), formed with a dense matrix product.
//!
//! The problem, with x = (c, e) and the side constraints of the groups:
//!
//! ```text
//! min  w·Σᵢ eᵢ   s.t.  eᵢ ≥ ±(tᵢ − aᵢᵀ c),   E c = f,   h − G c ∈ K,
//! ```
//!
//! K a product of nonnegative orthants and PSD cones (svec layout). The
//! equalities are eliminated first with an orthonormal null-space basis
//! (c = c₀ + Z y), so the iteration works on y alone. The method is the
//! standard infeasible path-following scheme with Nesterov–Todd scaling and
//! Mehrotra's predictor–corrector (as in CVXOPT's `coneqp` without
//! equalities). It has no homogeneous embedding and so no infeasibility
//! certificate: the L1 objective is bounded below and the searches' cones
//! (box, SOS Gram matrices) are never empty, but a joint step from a metric
//! outside the SOS tables can be infeasible, and then ends not usable (stall
//! guard, iteration limit). Inconsistent equalities are reported as primal
//! infeasible before iterating.

use std::time::Instant;

use clarabel::solver::SupportedConeT;
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

use crate::conic::{
    svec_len, ConicOutcome, ConstraintGroup, Regression, SolveStatus, SolverSettings, SQRT_2,
};
use crate::error::{Error, Result};

/// Step to this fraction of the distance to the cone boundary.
const STEP_FRACTION: f64 = 0.99;
/// Stop after this many iterations without the merit (the largest of the
/// relative gap and the two relative residuals) falling below
/// `STALL_FACTOR` times its best value.
const STALL_ITERATIONS: usize = 15;
const STALL_FACTOR: f64 = 0.9;
/// Clarabel's reduced tolerances, for [`SolveStatus::AlmostSolved`].
const REDUCED_GAP: f64 = 5e-5;
const REDUCED_FEAS: f64 = 1e-4;

/// One segment of the side-cone vector (the non-equality groups, in order).
#[derive(Debug, Clone)]
struct Segment {
    /// Index of the group this segment holds.
    group: usize,
    /// Offset in the side-cone vector.
    offset: usize,
    /// `None` for a nonnegative orthant, `Some(n)` for an n×n PSD cone.
    psd: Option<usize>,
    /// Length in the side-cone vector.
    len: usize,
}

/// Nesterov–Todd scaling of one PSD segment: W(Z) = Rᵀ Z R, W⁻ᵀ(S) = R⁻¹ S R⁻ᵀ,
/// both equal to diag(λ) at the current point.
struct PsdScaling {
    r: DMatrix<f64>,
    r_inv_t: DMatrix<f64>,
    lambda: Vec<f64>,
}

/// Scaling of the whole side-cone vector.
struct SideScaling {
    /// Per component: √(s/z) on nonnegative segments (unused on PSD ones).
    w: Vec<f64>,
    /// λ in the scaled space: √(s z) on nonnegative segments, the diagonal on
    /// PSD segments (svec, so off-diagonal entries are 0).
    lambda: Vec<f64>,
    psd: Vec<Option<PsdScaling>>,
}

/// Problem data after the equalities are eliminated.
struct Reduced {
    /// r × k regression block on y.
    a: DMatrix<f64>,
    /// Targets t − A c₀.
    t: DVector<f64>,
    /// Side-cone rows on y: h − G y ∈ K (dense, m × k).
    g: DMatrix<f64>,
    h: DVector<f64>,
    segments: Vec<Segment>,
    /// Objective weight w of Σ e.
    weight: f64,
}

/// The iterate.
#[derive(Clone)]
struct Point {
    y: DVector<f64>,
    e: DVector<f64>,
    s1: DVector<f64>,
    s2: DVector<f64>,
    sc: DVector<f64>,
    z1: DVector<f64>,
    z2: DVector<f64>,
    zc: DVector<f64>,
}

/// A direction in (y, e, s, z).
struct Direction {
    y: DVector<f64>,
    e: DVector<f64>,
    z1: DVector<f64>,
    z2: DVector<f64>,
    zc: DVector<f64>,
    /// Scaled directions W⁻ᵀ ds and W dz of the three cone blocks.
    s1_scaled: DVector<f64>,
    s2_scaled: DVector<f64>,
    sc_scaled: DVector<f64>,
    z1_scaled: DVector<f64>,
    z2_scaled: DVector<f64>,
    zc_scaled: DVector<f64>,
}

/// Solves min Σ|t − A c| subject to the constraint groups (see the module docs).
pub(crate) fn solve(
    regression: &Regression,
    extra: usize,
    groups: &[ConstraintGroup],
    settings: &SolverSettings,
) -> Result<ConicOutcome> {
    let start = Instant::now();
    let width = regression.width;
    let n_vars = width + extra;
    let (equalities, side, segments) = split_groups(groups, n_vars)?;
    let elimination = match eliminate_equalities(&equalities, n_vars) {
        Some(elimination) => elimination,
        None => {
            return Ok(ConicOutcome {
                x: vec![f64::NAN; n_vars],
                group_slacks: groups.iter().map(|g| vec![0.0; g.rhs.len()]).collect(),
                status: SolveStatus::PrimalInfeasible,
                iterations: 0,
                assembly_seconds: start.elapsed().as_secs_f64(),
                solver_seconds: 0.0,
            })
        }
    };
    let reduced = reduce(
        regression,
        &side,
        segments,
        &elimination,
        settings.objective_scale,
    );
    let assembly_seconds = start.elapsed().as_secs_f64();

    let start = Instant::now();
    let (point, status, iterations) = iterate(&reduced, settings);
    let solver_seconds = start.elapsed().as_secs_f64();

    let x = elimination.c0.clone() + &elimination.basis * &point.y;
    let mut group_slacks: Vec<Vec<f64>> = groups.iter().map(|g| vec![0.0; g.rhs.len()]).collect();
    for segment in &reduced.segments {
        group_slacks[segment.group] =
            point.sc.as_slice()[segment.offset..segment.offset + segment.len].to_vec();
    }
    Ok(ConicOutcome {
        x: x.as_slice().to_vec(),
        group_slacks,
        status,
        iterations,
        assembly_seconds,
        solver_seconds,
    })
}

/// Dense rows (E, f) of the zero-cone groups; dense rows (G, h) of the other
/// groups with their segments.
#[allow(clippy::type_complexity)]
fn split_groups(
    groups: &[ConstraintGroup],
    n_vars: usize,
) -> Result<(
    (DMatrix<f64>, DVector<f64>),
    (DMatrix<f64>, DVector<f64>),
    Vec<Segment>,
)> {
    let mut eq_rows = 0;
    let mut side_rows = 0;
    let mut segments = Vec::new();
    for (index, group) in groups.iter().enumerate() {
        let (len, psd) = match group.cone {
            SupportedConeT::ZeroConeT(d) => {
                eq_rows += d;
                continue;
            }
            SupportedConeT::NonnegativeConeT(d) => (d, None),
            SupportedConeT::PSDTriangleConeT(n) => (svec_len(n), Some(n)),
            ref other => {
                return Err(Error::Solver {
                    reason: format!("the dense solver does not support the cone {other:?}"),
                })
            }
        };
        segments.push(Segment {
            group: index,
            offset: side_rows,
            psd,
            len,
        });
        side_rows += len;
    }
    let mut e = DMatrix::zeros(eq_rows, n_vars);
    let mut f = DVector::zeros(eq_rows);
    let mut g = DMatrix::zeros(side_rows, n_vars);
    let mut h = DVector::zeros(side_rows);
    let (mut eq_offset, mut segment_iter) = (0, segments.iter());
    for group in groups {
        let dim = group.rhs.len();
        let (matrix, rhs, offset) = if matches!(group.cone, SupportedConeT::ZeroConeT(_)) {
            let offset = eq_offset;
            eq_offset += dim;
            (&mut e, &mut f, offset)
        } else {
            let offset = segment_iter.next().map_or(0, |s| s.offset);
            (&mut g, &mut h, offset)
        };
        for &(row, col, value) in &group.entries {
            if row >= dim || col >= n_vars {
                return Err(Error::Solver {
                    reason: format!(
                        "constraint entry ({row}, {col}) outside a {dim} × {n_vars} group"
                    ),
                });
            }
            // Clarabel's rows read A x + s = b; a group entry is +A.
            matrix[(offset + row, col)] += value;
        }
        rhs.rows_mut(offset, dim).copy_from_slice(&group.rhs);
    }
    Ok(((e, f), (g, h), segments))
}

/// c = c₀ + Z y parametrises {c : E c = f}.
struct Elimination {
    c0: DVector<f64>,
    /// n_vars × k, orthonormal columns (the identity without equalities).
    basis: DMatrix<f64>,
    /// `true` if there were no equalities (c = y).
    identity: bool,
}

/// The null space of E from the eigenvectors of EᵀE, and the least-norm
/// solution c₀; `None` if E c = f has no solution.
fn eliminate_equalities(
    equalities: &(DMatrix<f64>, DVector<f64>),
    n_vars: usize,
) -> Option<Elimination> {
    let (e, f) = equalities;
    if e.nrows() == 0 {
        return Some(Elimination {
            c0: DVector::zeros(n_vars),
            basis: DMatrix::identity(n_vars, n_vars),
            identity: true,
        });
    }
    let gram = e.tr_mul(e);
    let eigen = gram.symmetric_eigen();
    let largest = eigen
        .eigenvalues
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    // σ ≤ 1e-7 σ_max counts as zero (EᵀE holds σ²).
    let threshold = 1e-14 * largest.max(f64::MIN_POSITIVE);
    let etf = e.tr_mul(f);
    let mut c0 = DVector::zeros(n_vars);
    let mut null = Vec::new();
    for (index, &value) in eigen.eigenvalues.iter().enumerate() {
        let v = eigen.eigenvectors.column(index);
        if value > threshold {
            c0 += v * (v.dot(&etf) / value);
        } else {
            null.push(v.into_owned());
        }
    }
    let residual = (e * &c0 - f).amax();
    if residual > 1e-9 * (1.0 + f.amax()) {
        return None;
    }
    let basis = if null.is_empty() {
        DMatrix::zeros(n_vars, 0)
    } else {
        DMatrix::from_columns(&null)
    };
    Some(Elimination {
        c0,
        basis,
        identity: false,
    })
}

fn reduce(
    regression: &Regression,
    side: &(DMatrix<f64>, DVector<f64>),
    segments: Vec<Segment>,
    elimination: &Elimination,
    weight: f64,
) -> Reduced {
    let width = regression.width;
    let r = regression.len();
    let a_full = DMatrix::from_row_slice(r, width, &regression.rows);
    let top = elimination.basis.rows(0, width);
    let a = if elimination.identity {
        let mut a = DMatrix::zeros(r, elimination.basis.ncols());
        a.columns_mut(0, width).copy_from(&a_full);
        a
    } else {
        &a_full * top
    };
    let t =
        DVector::from_column_slice(&regression.target) - &a_full * elimination.c0.rows(0, width);
    let (g_full, h_full) = side;
    let g = g_full * &elimination.basis;
    let h = h_full - g_full * &elimination.c0;
    Reduced {
        a,
        t,
        g,
        h,
        segments,
        weight,
    }
}

// ---------------------------------------------------------------------------
// Symmetric-matrix helpers in svec layout (see `crate::conic::svec`).

fn smat(n: usize, v: &[f64]) -> DMatrix<f64> {
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

fn svec_into(m: &DMatrix<f64>, out: &mut [f64]) {
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

/// Largest α with λ + α d in the cone, for λ = diag(λ) in svec form: the
/// smallest eigenvalue of Λ^{-1/2} D Λ^{-1/2}.
fn psd_step_limit(lambda: &[f64], d: &[f64]) -> f64 {
    let n = lambda.len();
    let mut m = smat(n, d);
    for i in 0..n {
        for j in 0..n {
            m[(i, j)] /= (lambda[i] * lambda[j]).sqrt();
        }
    }
    let smallest = m.symmetric_eigenvalues().min();
    if smallest < 0.0 {
        -1.0 / smallest
    } else {
        f64::INFINITY
    }
}

/// Smallest eigenvalue of smat(v) (for the initial shift).
fn psd_min_eigenvalue(n: usize, v: &[f64]) -> f64 {
    smat(n, v).symmetric_eigenvalues().min()
}

impl SideScaling {
    /// NT scaling of the side cones at (s, z); `None` if a PSD block is not
    /// positive definite (numerical breakdown).
    fn new(segments: &[Segment], s: &DVector<f64>, z: &DVector<f64>) -> Option<Self> {
        let m = s.len();
        let mut w = vec![0.0; m];
        let mut lambda = vec![0.0; m];
        let mut psd = Vec::with_capacity(segments.len());
        for segment in segments {
            let range = segment.offset..segment.offset + segment.len;
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

    /// v ↦ W v on the side cones (a dual-space vector to the scaled space).
    fn apply_w(&self, segments: &[Segment], v: &DVector<f64>) -> DVector<f64> {
        self.apply(
            segments,
            v,
            |i, x| x * self.w[i],
            |sc, m| sc.r.transpose() * m * &sc.r,
        )
    }

    /// v ↦ Wᵀ v (the scaled space back to the primal space).
    fn apply_wt(&self, segments: &[Segment], v: &DVector<f64>) -> DVector<f64> {
        self.apply(
            segments,
            v,
            |i, x| x * self.w[i],
            |sc, m| &sc.r * m * sc.r.transpose(),
        )
    }

    /// v ↦ (WᵀW)⁻¹ v.
    fn apply_inverse_wtw(&self, segments: &[Segment], v: &DVector<f64>) -> DVector<f64> {
        self.apply(
            segments,
            v,
            |i, x| x / (self.w[i] * self.w[i]),
            |sc, m| {
                let b = &sc.r_inv_t * sc.r_inv_t.transpose();
                &b * m * &b
            },
        )
    }

    fn apply(
        &self,
        segments: &[Segment],
        v: &DVector<f64>,
        orthant: impl Fn(usize, f64) -> f64,
        cone: impl Fn(&PsdScaling, &DMatrix<f64>) -> DMatrix<f64>,
    ) -> DVector<f64> {
        let mut out = DVector::zeros(v.len());
        for (segment, scaling) in segments.iter().zip(&self.psd) {
            let range = segment.offset..segment.offset + segment.len;
            match (segment.psd, scaling) {
                (Some(n), Some(sc)) => {
                    let m = smat(n, &v.as_slice()[range.clone()]);
                    svec_into(&cone(sc, &m), &mut out.as_mut_slice()[range]);
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

/// R = L_s V Λ^{-1/2} and R⁻ᵀ = L_z U Λ^{-1/2} from L_zᵀ L_s = U Λ Vᵀ.
fn psd_scaling(n: usize, s: &[f64], z: &[f64]) -> Option<PsdScaling> {
    let ls = Cholesky::new(smat(n, s))?.l();
    let lz = Cholesky::new(smat(n, z))?.l();
    let svd = (lz.transpose() * &ls).svd(true, true);
    let u = svd.u?;
    let v = svd.v_t?.transpose();
    let lambda: Vec<f64> = svd.singular_values.iter().copied().collect();
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
        r: ls * v * &inv_sqrt,
        r_inv_t: lz * u * inv_sqrt,
        lambda,
    })
}

/// a ∘ b on the side cones (the symmetrised product on PSD segments).
fn jordan_product(segments: &[Segment], a: &DVector<f64>, b: &DVector<f64>) -> DVector<f64> {
    let mut out = a.component_mul(b);
    for segment in segments {
        if let Some(n) = segment.psd {
            let range = segment.offset..segment.offset + segment.len;
            let ma = smat(n, &a.as_slice()[range.clone()]);
            let mb = smat(n, &b.as_slice()[range.clone()]);
            let product = (&ma * &mb + &mb * &ma) * 0.5;
            svec_into(&product, &mut out.as_mut_slice()[range]);
        }
    }
    out
}

/// ξ with λ ∘ ξ = v, for λ diagonal on PSD segments.
fn jordan_divide(segments: &[Segment], lambda: &[f64], v: &DVector<f64>) -> DVector<f64> {
    let mut out = DVector::from_iterator(v.len(), v.iter().zip(lambda).map(|(v, l)| v / l));
    for segment in segments {
        if let Some(n) = segment.psd {
            let diagonal: Vec<f64> = (0..n)
                .map(|j| lambda[segment.offset + svec_diag(j)])
                .collect();
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

fn svec_diag(j: usize) -> usize {
    j * (j + 1) / 2 + j
}

/// The identity of the side cones (1 on orthants, I on PSD segments).
fn cone_identity(segments: &[Segment], m: usize) -> DVector<f64> {
    let mut e = DVector::from_element(m, 1.0);
    for segment in segments {
        if let Some(n) = segment.psd {
            e.rows_mut(segment.offset, segment.len).fill(0.0);
            for j in 0..n {
                e[segment.offset + svec_diag(j)] = 1.0;
            }
        }
    }
    e
}

/// Shifts v into the interior of the side cones if it is not already
/// (v + (1 + t) e with t the largest violation), as in `coneqp`.
fn shift_into_cones(segments: &[Segment], v: &mut DVector<f64>) {
    let mut violation = f64::NEG_INFINITY;
    for segment in segments {
        let range = segment.offset..segment.offset + segment.len;
        let smallest = match segment.psd {
            Some(n) => psd_min_eigenvalue(n, &v.as_slice()[range]),
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

fn shift_orthant(v: &mut DVector<f64>, other: &mut DVector<f64>) {
    // The L1 pairs are orthants; shift them together (one cone of 2r).
    let smallest = v.min().min(other.min());
    if -smallest >= -1e-8 {
        let shift = 1.0 + (-smallest).max(0.0);
        v.add_scalar_mut(shift);
        other.add_scalar_mut(shift);
    }
}

// ---------------------------------------------------------------------------
// The Newton system.

/// Factorised reduced KKT system at one scaling.
struct Newton<'a> {
    problem: &'a Reduced,
    scaling: &'a SideScaling,
    /// z/s of the two L1 orthants.
    d1: DVector<f64>,
    d2: DVector<f64>,
    schur: Cholesky<f64, Dyn>,
}

impl<'a> Newton<'a> {
    /// Forms and factorises Aᵀ D̃ A + Gᵀ (WᵀW)⁻¹ G, with D̃ = 4 d₁d₂/(d₁ + d₂).
    fn new(
        problem: &'a Reduced,
        scaling: &'a SideScaling,
        d1: DVector<f64>,
        d2: DVector<f64>,
    ) -> Option<Self> {
        let k = problem.a.ncols();
        let weights = DVector::from_iterator(
            d1.len(),
            d1.iter()
                .zip(d2.iter())
                .map(|(a, b)| (4.0 * a * b / (a + b)).sqrt()),
        );
        let mut scaled = problem.a.clone();
        for mut column in scaled.column_iter_mut() {
            column.component_mul_assign(&weights);
        }
        let mut schur = scaled.tr_mul(&scaled);
        if problem.g.nrows() > 0 {
            let mut hg = DMatrix::zeros(problem.g.nrows(), k);
            for (j, column) in problem.g.column_iter().enumerate() {
                let mapped = scaling.apply_inverse_wtw(&problem.segments, &column.into_owned());
                hg.set_column(j, &mapped);
            }
            schur += problem.g.tr_mul(&hg);
        }
        // Symmetrise, then factorise; on breakdown retry with a small diagonal
        // shift (rank-deficient regression with an unconstrained direction).
        let schur = (&schur + schur.transpose()) * 0.5;
        let scale = schur.diagonal().amax().max(f64::MIN_POSITIVE);
        let mut shift = 0.0;
        for _ in 0..4 {
            let mut shifted = schur.clone();
            for i in 0..k {
                shifted[(i, i)] += shift;
            }
            if let Some(schur) = Cholesky::new(shifted) {
                return Some(Self {
                    problem,
                    scaling,
                    d1,
                    d2,
                    schur,
                });
            }
            shift = if shift == 0.0 {
                1e-13 * scale
            } else {
                shift * 1e3
            };
        }
        None
    }

    /// Solves [0 Gᵀ; G −WᵀW][dx; dz] = [bx; bz] for x = (y, e), z = (z₁, z₂, z_c),
    /// with two steps of iterative refinement on the unreduced system (the
    /// reduction squares the condition number near the optimum).
    fn solve(&self, rhs: &Kkt) -> Kkt {
        let mut solution = self.solve_reduced(rhs);
        for _ in 0..2 {
            let residual = rhs.minus(&self.apply(&solution));
            solution = solution.plus(&self.solve_reduced(&residual));
        }
        solution
    }

    /// The unreduced KKT operator [0 Gᵀ; G −WᵀW] applied to (dx, dz).
    fn apply(&self, v: &Kkt) -> Kkt {
        let p = self.problem;
        let ay = &p.a * &v.y;
        let mut y = p.a.tr_mul(&(&v.z2 - &v.z1));
        if p.g.nrows() > 0 {
            y += p.g.tr_mul(&v.zc);
        }
        let wtw_zc = self
            .scaling
            .apply_wt(&p.segments, &self.scaling.apply_w(&p.segments, &v.zc));
        Kkt {
            y,
            e: -&v.z1 - &v.z2,
            z1: -&ay - &v.e - v.z1.component_div(&self.d1),
            z2: &ay - &v.e - v.z2.component_div(&self.d2),
            zc: &p.g * &v.y - wtw_zc,
        }
    }

    /// One solve through the Schur complement on y.
    fn solve_reduced(&self, b: &Kkt) -> Kkt {
        let p = self.problem;
        let d1b = self.d1.component_mul(&b.z1);
        let d2b = self.d2.component_mul(&b.z2);
        let dcb = self.scaling.apply_inverse_wtw(&p.segments, &b.zc);
        let sum = &self.d1 + &self.d2;
        let diff = &self.d1 - &self.d2;
        let rhs_e = &b.e - &d1b - &d2b;
        let ratio = diff.component_div(&sum);
        let mut rhs_y =
            &b.y + p.a.tr_mul(&(&d2b - &d1b)) - p.a.tr_mul(&ratio.component_mul(&rhs_e));
        if p.g.nrows() > 0 {
            rhs_y += p.g.tr_mul(&dcb);
        }
        let dy = self.schur.solve(&rhs_y);
        let ady = &p.a * &dy;
        let de = (&rhs_e - diff.component_mul(&ady)).component_div(&sum);
        // dz = (WᵀW)⁻¹ (G dx − bz) with G = [[−A, −I]; [A, −I]; [G_c, 0]].
        let z1 = self.d1.component_mul(&(-&ady - &de - &b.z1));
        let z2 = self.d2.component_mul(&(&ady - &de - &b.z2));
        let zc = if p.g.nrows() > 0 {
            self.scaling
                .apply_inverse_wtw(&p.segments, &(&p.g * &dy - &b.zc))
        } else {
            DVector::zeros(0)
        };
        Kkt {
            y: dy,
            e: de,
            z1,
            z2,
            zc,
        }
    }
}

/// A right-hand side or solution of the KKT system: the x part (y, e) and
/// the z part (z₁, z₂, z_c).
#[derive(Clone)]
struct Kkt {
    y: DVector<f64>,
    e: DVector<f64>,
    z1: DVector<f64>,
    z2: DVector<f64>,
    zc: DVector<f64>,
}

impl Kkt {
    fn plus(&self, other: &Kkt) -> Kkt {
        Kkt {
            y: &self.y + &other.y,
            e: &self.e + &other.e,
            z1: &self.z1 + &other.z1,
            z2: &self.z2 + &other.z2,
            zc: &self.zc + &other.zc,
        }
    }

    fn minus(&self, other: &Kkt) -> Kkt {
        Kkt {
            y: &self.y - &other.y,
            e: &self.e - &other.e,
            z1: &self.z1 - &other.z1,
            z2: &self.z2 - &other.z2,
            zc: &self.zc - &other.zc,
        }
    }
}

// ---------------------------------------------------------------------------
// The iteration.

struct Residuals {
    rx_y: DVector<f64>,
    rx_e: DVector<f64>,
    rz1: DVector<f64>,
    rz2: DVector<f64>,
    rzc: DVector<f64>,
    primal_cost: f64,
    dual_cost: f64,
    gap: f64,
    primal_ok_at: f64,
    dual_ok_at: f64,
}

impl Residuals {
    /// r_x = Gᵀz + c, r_z = G x + s − h and the objectives.
    fn new(p: &Reduced, x: &Point) -> Self {
        let ay = &p.a * &x.y;
        let mut rx_y = p.a.tr_mul(&(&x.z2 - &x.z1));
        if p.g.nrows() > 0 {
            rx_y += p.g.tr_mul(&x.zc);
        }
        let rx_e = (-&x.z1 - &x.z2).add_scalar(p.weight);
        let rz1 = -&ay - &x.e + &x.s1 + &p.t;
        let rz2 = &ay - &x.e + &x.s2 - &p.t;
        let rzc = &p.g * &x.y + &x.sc - &p.h;
        let primal_cost = p.weight * x.e.sum();
        let dual_cost = p.t.dot(&x.z1) - p.t.dot(&x.z2) - p.h.dot(&x.zc);
        let gap = x.s1.dot(&x.z1) + x.s2.dot(&x.z2) + x.sc.dot(&x.zc);
        let x_norm = x.y.amax().max(x.e.amax());
        let s_norm = x.s1.amax().max(x.s2.amax()).max(amax(&x.sc));
        let z_norm = x.z1.amax().max(x.z2.amax()).max(amax(&x.zc));
        let h_norm = p.t.amax().max(amax(&p.h));
        Self {
            rx_y,
            rx_e,
            rz1,
            rz2,
            rzc,
            primal_cost,
            dual_cost,
            gap,
            primal_ok_at: (h_norm + x_norm + s_norm).max(1.0),
            dual_ok_at: (p.weight + x_norm + z_norm).max(1.0),
        }
    }

    fn primal_infeasibility(&self) -> f64 {
        self.rz1.amax().max(self.rz2.amax()).max(amax(&self.rzc)) / self.primal_ok_at
    }

    fn dual_infeasibility(&self) -> f64 {
        self.rx_y.amax().max(self.rx_e.amax()) / self.dual_ok_at
    }

    /// The largest of the relative gap and the two relative residuals.
    fn merit(&self) -> f64 {
        let gap = (self.primal_cost - self.dual_cost).abs()
            / self.primal_cost.abs().min(self.dual_cost.abs()).max(1.0);
        gap.max(self.primal_infeasibility())
            .max(self.dual_infeasibility())
    }

    /// Clarabel's tests: absolute or relative gap, and both residuals.
    fn converged(&self, gap_abs: f64, gap_rel: f64, feas: f64) -> bool {
        let gap = (self.primal_cost - self.dual_cost).abs();
        let scale = self.primal_cost.abs().min(self.dual_cost.abs());
        (gap <= gap_abs || gap <= gap_rel * scale)
            && self.primal_infeasibility() <= feas
            && self.dual_infeasibility() <= feas
    }
}

fn amax(v: &DVector<f64>) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.amax()
    }
}

fn iterate(p: &Reduced, settings: &SolverSettings) -> (Point, SolveStatus, u32) {
    let start = Instant::now();
    let (r, m) = (p.t.len(), p.h.len());
    // ν: the barrier degree (one per orthant component, n per n×n PSD cone).
    let degree = (2 * r) as f64
        + p.segments
            .iter()
            .map(|s| s.psd.unwrap_or(s.len) as f64)
            .sum::<f64>();

    let Some(mut x) = initial_point(p) else {
        return (empty_point(p), SolveStatus::NumericalError, 0);
    };
    // The iterate with the smallest merit among those meeting the reduced
    // tolerances, and how long the merit has not improved.
    let mut best: Option<(f64, Point)> = None;
    let (mut best_merit, mut stalled) = (f64::INFINITY, 0);
    for iteration in 0..=settings.max_iter {
        let residuals = Residuals::new(p, &x);
        if settings.verbose {
            eprintln!(
                "dense ipm {iteration:>3}: pcost {:+.8e} dcost {:+.8e} gap {:.2e} pres {:.2e} dres {:.2e}",
                residuals.primal_cost,
                residuals.dual_cost,
                residuals.gap,
                residuals.primal_infeasibility(),
                residuals.dual_infeasibility()
            );
        }
        if residuals.converged(
            settings.tol_gap_abs,
            settings.tol_gap_rel,
            settings.tol_feas,
        ) {
            return (x, SolveStatus::Solved, iteration);
        }
        let merit = residuals.merit();
        if residuals.converged(REDUCED_GAP, REDUCED_GAP, REDUCED_FEAS)
            && best.as_ref().is_none_or(|(m, _)| merit < *m)
        {
            best = Some((merit, x.clone()));
        }
        if merit < STALL_FACTOR * best_merit {
            (best_merit, stalled) = (merit, 0);
        } else {
            stalled += 1;
        }
        // Stopping early: the best iterate that met the reduced tolerances, if any.
        let stop = |x: &Point, status: SolveStatus| match &best {
            Some((_, point)) => (point.clone(), SolveStatus::AlmostSolved, iteration),
            None => (x.clone(), status, iteration),
        };
        // Without a strictly feasible point (e.g. the full SOS tables) the
        // iterates can stall near the optimum and then diverge.
        if stalled >= STALL_ITERATIONS {
            return stop(&x, SolveStatus::InsufficientProgress);
        }
        if iteration == settings.max_iter {
            return stop(&x, SolveStatus::MaxIterations);
        }
        if let Some(limit) = settings.time_limit {
            if start.elapsed().as_secs_f64() > limit {
                return stop(&x, SolveStatus::MaxTime);
            }
        }
        let Some(scaling) = SideScaling::new(&p.segments, &x.sc, &x.zc) else {
            return stop(&x, SolveStatus::NumericalError);
        };
        let d1 = x.z1.component_div(&x.s1);
        let d2 = x.z2.component_div(&x.s2);
        let lambda1 = x.s1.component_mul(&x.z1).map(f64::sqrt);
        let lambda2 = x.s2.component_mul(&x.z2).map(f64::sqrt);
        let w1 = x.s1.component_div(&x.z1).map(f64::sqrt);
        let w2 = x.s2.component_div(&x.z2).map(f64::sqrt);
        let lambda_c = DVector::from_column_slice(&scaling.lambda);
        let Some(newton) = Newton::new(p, &scaling, d1, d2) else {
            return stop(&x, SolveStatus::NumericalError);
        };
        let mu = residuals.gap / degree;

        // One Newton direction for the complementarity target d_s (in the
        // scaled space): ξ = λ ⊘ d_s, bz = −r_z − Wᵀξ, ds = Wᵀ(ξ − W dz).
        let direction = |ds1: &DVector<f64>, ds2: &DVector<f64>, dsc: &DVector<f64>| {
            let xi1 = ds1.component_div(&lambda1);
            let xi2 = ds2.component_div(&lambda2);
            let xic = jordan_divide(&p.segments, &scaling.lambda, dsc);
            let bz1 = -&residuals.rz1 - w1.component_mul(&xi1);
            let bz2 = -&residuals.rz2 - w2.component_mul(&xi2);
            let bzc = -&residuals.rzc - scaling.apply_wt(&p.segments, &xic);
            let Kkt { y, e, z1, z2, zc } = newton.solve(&Kkt {
                y: -&residuals.rx_y,
                e: -&residuals.rx_e,
                z1: bz1,
                z2: bz2,
                zc: bzc,
            });
            let z1_scaled = w1.component_mul(&z1);
            let z2_scaled = w2.component_mul(&z2);
            let zc_scaled = scaling.apply_w(&p.segments, &zc);
            Direction {
                s1_scaled: &xi1 - &z1_scaled,
                s2_scaled: &xi2 - &z2_scaled,
                sc_scaled: &xic - &zc_scaled,
                y,
                e,
                z1,
                z2,
                zc,
                z1_scaled,
                z2_scaled,
                zc_scaled,
            }
        };
        let step_limit = |d: &Direction| {
            let mut alpha = f64::INFINITY;
            for (l, v) in [
                (&lambda1, &d.s1_scaled),
                (&lambda1, &d.z1_scaled),
                (&lambda2, &d.s2_scaled),
                (&lambda2, &d.z2_scaled),
            ] {
                for (l, v) in l.iter().zip(v.iter()) {
                    if *v < 0.0 {
                        alpha = alpha.min(-l / v);
                    }
                }
            }
            for segment in &p.segments {
                let range = segment.offset..segment.offset + segment.len;
                for v in [&d.sc_scaled, &d.zc_scaled] {
                    match segment.psd {
                        Some(n) => {
                            let diagonal: Vec<f64> = (0..n)
                                .map(|j| lambda_c[segment.offset + svec_diag(j)])
                                .collect();
                            alpha =
                                alpha.min(psd_step_limit(&diagonal, &v.as_slice()[range.clone()]));
                        }
                        None => {
                            for i in range.clone() {
                                if v[i] < 0.0 {
                                    alpha = alpha.min(-lambda_c[i] / v[i]);
                                }
                            }
                        }
                    }
                }
            }
            alpha
        };

        // Predictor: d_s = −λ∘λ.
        let lambda_sq_c = jordan_product(&p.segments, &lambda_c, &lambda_c);
        let affine = direction(
            &-lambda1.component_mul(&lambda1),
            &-lambda2.component_mul(&lambda2),
            &-&lambda_sq_c,
        );
        let alpha_affine = step_limit(&affine).min(1.0);
        let sigma = (1.0 - alpha_affine).powi(3);

        // Corrector: d_s = −λ∘λ − Δs̃∘Δz̃ + σμe.
        let target = sigma * mu;
        let ds1 = (-lambda1.component_mul(&lambda1)
            - affine.s1_scaled.component_mul(&affine.z1_scaled))
        .add_scalar(target);
        let ds2 = (-lambda2.component_mul(&lambda2)
            - affine.s2_scaled.component_mul(&affine.z2_scaled))
        .add_scalar(target);
        let dsc = -&lambda_sq_c - jordan_product(&p.segments, &affine.sc_scaled, &affine.zc_scaled)
            + cone_identity(&p.segments, m) * target;
        let combined = direction(&ds1, &ds2, &dsc);
        let alpha = (STEP_FRACTION * step_limit(&combined)).min(1.0);
        if alpha.is_nan() || alpha <= 1e-10 {
            return stop(&x, SolveStatus::InsufficientProgress);
        }

        // Back to the original space: ds = Wᵀ Δs̃.
        x.y += &combined.y * alpha;
        x.e += &combined.e * alpha;
        x.s1 += w1.component_mul(&combined.s1_scaled) * alpha;
        x.s2 += w2.component_mul(&combined.s2_scaled) * alpha;
        x.sc += scaling.apply_wt(&p.segments, &combined.sc_scaled) * alpha;
        x.z1 += &combined.z1 * alpha;
        x.z2 += &combined.z2 * alpha;
        x.zc += &combined.zc * alpha;
        if !x
            .y
            .iter()
            .chain(x.s1.iter())
            .chain(x.z1.iter())
            .all(|v| v.is_finite())
        {
            return stop(&x, SolveStatus::NumericalError);
        }
    }
    (x, SolveStatus::MaxIterations, settings.max_iter)
}

fn empty_point(p: &Reduced) -> Point {
    let (k, r, m) = (p.a.ncols(), p.t.len(), p.h.len());
    Point {
        y: DVector::from_element(k, f64::NAN),
        e: DVector::zeros(r),
        s1: DVector::zeros(r),
        s2: DVector::zeros(r),
        sc: DVector::zeros(m),
        z1: DVector::zeros(r),
        z2: DVector::zeros(r),
        zc: DVector::zeros(m),
    }
}

/// `coneqp`'s starting point: least-squares primal and least-norm dual
/// solutions of the KKT system with W = I, shifted into the cones.
fn initial_point(p: &Reduced) -> Option<Point> {
    let (k, r, m) = (p.a.ncols(), p.t.len(), p.h.len());
    let identity = SideScaling {
        w: vec![1.0; m],
        lambda: vec![1.0; m],
        psd: p
            .segments
            .iter()
            .map(|segment| {
                segment.psd.map(|n| PsdScaling {
                    r: DMatrix::identity(n, n),
                    r_inv_t: DMatrix::identity(n, n),
                    lambda: vec![1.0; n],
                })
            })
            .collect(),
    };
    let ones = DVector::from_element(r, 1.0);
    let newton = Newton::new(p, &identity, ones.clone(), ones)?;
    let zero_r = DVector::zeros(r);
    // Primal: bz = h gives dz = G x − h = −s.
    let Kkt { y, e, z1, z2, zc } = newton.solve(&Kkt {
        y: DVector::zeros(k),
        e: zero_r.clone(),
        z1: -&p.t,
        z2: p.t.clone(),
        zc: p.h.clone(),
    });
    let mut s1 = -z1;
    let mut s2 = -z2;
    let mut sc = -zc;
    shift_orthant(&mut s1, &mut s2);
    shift_into_cones(&p.segments, &mut sc);
    // Dual: bx = −c gives G x = z with Gᵀ z = −c.
    let Kkt {
        mut z1,
        mut z2,
        mut zc,
        ..
    } = newton.solve(&Kkt {
        y: DVector::zeros(k),
        e: DVector::from_element(r, -p.weight),
        z1: zero_r.clone(),
        z2: zero_r,
        zc: DVector::zeros(m),
    });
    shift_orthant(&mut z1, &mut z2);
    shift_into_cones(&p.segments, &mut zc);
    Some(Point {
        y,
        e,
        s1,
        s2,
        sc,
        z1,
        z2,
        zc,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conic::{solve_l1, svec_index, L1Formulation, SolverBackend};
    use crate::entropy_search::{entropy_search, EntropySearchOptions};
    use crate::joint_step::{joint_step, TrustRegion};
    use crate::metric_search::{metric_search, MetricSearchOptions, SosBasis};
    use crate::model::{identity_metric, Model};
    use crate::system::MetriplecticSystem;
    use crate::test_system::{reference_data, Quadratic2d};

    fn settings(backend: SolverBackend) -> SolverSettings {
        SolverSettings {
            backend,
            ..SolverSettings::default()
        }
    }

    /// A pseudo-random regression (a fixed linear congruential sequence).
    fn random_regression(rows: usize, width: usize, seed: u64) -> Regression {
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

    fn box_group(width: usize, bound: f64) -> ConstraintGroup {
        let mut entries = Vec::new();
        for k in 0..width {
            entries.push((k, k, 1.0));
            entries.push((width + k, k, -1.0));
        }
        ConstraintGroup {
            cone: SupportedConeT::NonnegativeConeT(2 * width),
            entries,
            rhs: vec![bound; 2 * width],
        }
    }

    #[test]
    fn box_constrained_l1_agrees_with_clarabel() {
        for (rows, width, bound) in [(200, 7, 10.0), (300, 12, 0.05), (40, 30, 1.0)] {
            let regression = random_regression(rows, width, rows as u64);
            let groups = [box_group(width, bound)];
            let dense = solve(&regression, 0, &groups, &settings(SolverBackend::Dense)).unwrap();
            let reference = solve_l1(
                &regression,
                0,
                &groups,
                L1Formulation::Split,
                &settings(SolverBackend::Clarabel),
            )
            .unwrap();
            assert_eq!(dense.status, SolveStatus::Solved);
            assert_eq!(reference.status, SolveStatus::Solved);
            let (ours, theirs) = (
                regression.l1_residual(&dense.x),
                regression.l1_residual(&reference.x),
            );
            assert!(
                (ours - theirs).abs() <= 1e-7 * theirs.max(1.0),
                "{rows}×{width}, η = {bound}: {ours} vs {theirs}"
            );
            assert!(dense.x.iter().all(|v| v.abs() <= bound * (1.0 + 1e-8)));
            // The box slacks are η ∓ c and lie in the orthant.
            assert!(dense.group_slacks[0].iter().all(|&s| s >= 0.0));
        }
    }

    #[test]
    fn searches_agree_with_clarabel_off_the_truth() {
        // A wrong metric for the entropy search and a wrong entropy for the
        // metric search and the joint step, so that no optimum is zero and
        // the SOS constraints are active.
        let data = reference_data(60, 5);
        // K = [[1.4, 0.3], [0.3, 1]]: constant, so the reduced SOS tables
        // (constant Gram basis) represent it and the joint step is feasible.
        let mut metric = identity_metric::<Quadratic2d>(1.0);
        metric[0] += 0.4;
        metric[6] += 0.3;
        let entropy: Vec<f64> = Quadratic2d::REFERENCE_ENTROPY
            .unwrap()
            .iter()
            .zip([0.3, -0.2, 0.1, 0.4, -0.3])
            .map(|(a, b)| a + b)
            .collect();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs().max(1e-9);
        let entropy_fit = |backend| {
            let options = EntropySearchOptions {
                solver: settings(backend),
                ..EntropySearchOptions::default()
            };
            entropy_search::<Quadratic2d>(&data, &metric, &options).unwrap()
        };
        let (ours, theirs) = (
            entropy_fit(SolverBackend::Dense),
            entropy_fit(SolverBackend::Clarabel),
        );
        assert_eq!(ours.report.status, SolveStatus::Solved);
        let (a, b) = (
            ours.report.cost.unwrap().sum,
            theirs.report.cost.unwrap().sum,
        );
        assert!(b > 1e-2 && close(a, b), "entropy search: {a} vs {b}");

        for sos in [SosBasis::Reduced, SosBasis::Full] {
            let metric_fit = |backend| {
                let options = MetricSearchOptions {
                    solver: settings(backend),
                    sos,
                    eta: 1.5,
                    ..MetricSearchOptions::default()
                };
                metric_search::<Quadratic2d>(&data, &entropy, &options).unwrap()
            };
            let (ours, theirs) = (
                metric_fit(SolverBackend::Dense),
                metric_fit(SolverBackend::Clarabel),
            );
            assert!(ours.report.status.is_usable(), "{sos:?}: {:?}", ours.report);
            let (a, b) = (
                ours.report.cost.unwrap().sum,
                theirs.report.cost.unwrap().sum,
            );
            // The full tables have no strictly feasible point: the dense
            // method stalls there (AlmostSolved, 3.7e-6 above Clarabel's
            // homogeneous embedding), so only the reduced default is held to 1e-6.
            let agrees = match sos {
                SosBasis::Reduced => close(a, b),
                _ => (a - b).abs() <= 1e-5 * b,
            };
            assert!(
                b > 1e-2 && agrees,
                "metric search {sos:?}: {a} ({:?}, {} iterations) vs {b} ({:?}, {} iterations)",
                ours.report.status,
                ours.report.iterations,
                theirs.report.status,
                theirs.report.iterations
            );
            // Q₁ and Q₂ come from the cone slacks: positive semidefinite.
            for gram in [&ours.gram, &ours.gram_upper] {
                let n = ours.gram_size;
                let smallest = DMatrix::from_row_slice(n, n, gram)
                    .symmetric_eigenvalues()
                    .min();
                assert!(smallest >= -1e-12, "{sos:?}: eigenvalue {smallest}");
            }
        }

        let model = Model::<Quadratic2d>::new(entropy.clone(), metric.clone()).unwrap();
        let step = |backend| {
            let options = MetricSearchOptions {
                solver: settings(backend),
                ..MetricSearchOptions::default()
            };
            joint_step::<Quadratic2d>(
                &data,
                &model,
                TrustRegion::default().initial_radius,
                &options,
            )
            .unwrap()
        };
        let (ours, theirs) = (step(SolverBackend::Dense), step(SolverBackend::Clarabel));
        assert_eq!(ours.report.status, SolveStatus::Solved);
        let (a, b) = (ours.predicted.unwrap().sum, theirs.predicted.unwrap().sum);
        assert!(close(a, b), "joint step prediction: {a} vs {b}");
    }

    #[test]
    fn an_infeasible_problem_is_not_reported_usable() {
        // A metric linear in q is outside the reduced (constant) SOS tables,
        // and the trust region keeps the step within 0.1 of it: infeasible.
        let data = reference_data(30, 9);
        let mut metric = identity_metric::<Quadratic2d>(1.0);
        metric[1] += 0.4;
        let entropy = Quadratic2d::REFERENCE_ENTROPY.unwrap().to_vec();
        let model = Model::<Quadratic2d>::new(entropy, metric).unwrap();
        let step =
            joint_step::<Quadratic2d>(&data, &model, 0.1, &MetricSearchOptions::default()).unwrap();
        assert!(!step.report.status.is_usable(), "{:?}", step.report);
    }

    #[test]
    fn inconsistent_equalities_are_primal_infeasible() {
        // c₀ = 1 and c₀ = 2.
        let regression = random_regression(5, 1, 3);
        let equalities = ConstraintGroup {
            cone: SupportedConeT::ZeroConeT(2),
            entries: vec![(0, 0, 1.0), (1, 0, 1.0)],
            rhs: vec![1.0, 2.0],
        };
        let out = solve(&regression, 0, &[equalities], &SolverSettings::default()).unwrap();
        assert_eq!(out.status, SolveStatus::PrimalInfeasible);
        assert_eq!(out.iterations, 0);
    }

    #[test]
    fn consistent_equalities_fix_the_coefficients() {
        // c₀ + c₁ = 1 (twice, redundantly) and c₀ − c₁ = 0.5.
        let regression = random_regression(30, 2, 4);
        let equalities = ConstraintGroup {
            cone: SupportedConeT::ZeroConeT(3),
            entries: vec![
                (0, 0, 1.0),
                (0, 1, 1.0),
                (1, 0, 2.0),
                (1, 1, 2.0),
                (2, 0, 1.0),
                (2, 1, -1.0),
            ],
            rhs: vec![1.0, 2.0, 0.5],
        };
        let out = solve(&regression, 0, &[equalities], &SolverSettings::default()).unwrap();
        assert_eq!(out.status, SolveStatus::Solved);
        assert!(
            (out.x[0] - 0.75).abs() < 1e-12 && (out.x[1] - 0.25).abs() < 1e-12,
            "{:?}",
            out.x
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
        let out = solve(&regression, 0, &[], &SolverSettings::default()).unwrap();
        assert!(out.status.is_usable(), "{:?}", out.status);
        let single = solve(&base, 0, &[], &SolverSettings::default()).unwrap();
        let (a, b) = (regression.l1_residual(&out.x), base.l1_residual(&single.x));
        assert!((a - b).abs() <= 1e-7 * b, "{a} vs {b}");
    }

    #[test]
    fn unsupported_cones_and_bad_entries_are_errors() {
        let regression = random_regression(5, 2, 7);
        let second_order = ConstraintGroup {
            cone: SupportedConeT::SecondOrderConeT(2),
            entries: vec![(0, 0, 1.0)],
            rhs: vec![1.0, 0.0],
        };
        assert!(matches!(
            solve(&regression, 0, &[second_order], &SolverSettings::default()),
            Err(Error::Solver { .. })
        ));
        let outside = ConstraintGroup {
            cone: SupportedConeT::NonnegativeConeT(1),
            entries: vec![(0, 5, 1.0)],
            rhs: vec![1.0],
        };
        assert!(matches!(
            solve(&regression, 0, &[outside], &SolverSettings::default()),
            Err(Error::Solver { .. })
        ));
    }

    #[test]
    fn iteration_limit_is_reported() {
        let regression = random_regression(200, 7, 8);
        let limited = SolverSettings {
            max_iter: 2,
            ..SolverSettings::default()
        };
        let out = solve(&regression, 0, &[box_group(7, 10.0)], &limited).unwrap();
        assert_eq!(out.status, SolveStatus::MaxIterations);
        assert_eq!(out.iterations, 2);
        assert!(out.x.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn no_rows_is_not_a_panic() {
        let regression = Regression {
            width: 2,
            rows: Vec::new(),
            target: Vec::new(),
        };
        let out = solve(
            &regression,
            0,
            &[box_group(2, 1.0)],
            &SolverSettings::default(),
        )
        .unwrap();
        assert_eq!(out.status, SolveStatus::Solved);
        assert!(out.x.iter().all(|v| v.abs() <= 1.0));
    }

    #[test]
    fn psd_helpers_invert_each_other() {
        let v = [1.0, 0.3 * SQRT_2, 2.0, -0.1 * SQRT_2, 0.5 * SQRT_2, 3.0];
        let m = smat(3, &v);
        assert_eq!(m[(0, 1)], m[(1, 0)]);
        assert!((m[(0, 1)] - 0.3).abs() < 1e-15);
        let mut back = [0.0; 6];
        svec_into(&m, &mut back);
        for (a, b) in back.iter().zip(&v) {
            assert!((a - b).abs() < 1e-15);
        }
        assert_eq!(svec_diag(2), svec_index(2, 2));
        // Step to the boundary of diag(1, 2) along −I is 1.
        let limit = psd_step_limit(&[1.0, 2.0], &[-1.0, 0.0, -1.0]);
        assert!((limit - 1.0).abs() < 1e-12, "{limit}");
    }
}
