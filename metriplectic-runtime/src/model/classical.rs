//! The classical (GENERIC) constraints at run time: S a Casimir of Π
//! (C_S ψ = 0) and K(x)∇H(x) ≡ 0 (C_K θ = 0), as the macro derived them
//! exactly ([`Classical`](crate::Classical)).
//!
//! Three uses: models of a classical system are checked against the rows
//! (so none that breaks them is built or loaded); the searches impose them
//! as equality rows over their free coefficients ([`Equalities`]), and
//! project their solutions onto them, so that the identified coefficients
//! satisfy them to rounding rather than to the solver's tolerance; and a
//! classical run needs a start that satisfies them
//! ([`degenerate_metric`]).

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{invalid, Error, Result};
use crate::system::{metric_pair_index, LinearForm, MetriplecticSystem, Region};

/// Largest residual of a constraint row (rows are scaled to max |c| = 1),
/// relative to the largest coefficient, that a model of a classical system
/// may have. Projected solutions are at ~1e-16; a model typed in decimals
/// is exact.
const TOLERANCE: f64 = 1e-9;

/// Singular values below this fraction of the largest are dependent rows.
const RANK_TOLERANCE: f64 = 1e-10;

/// The entropy rows C_S of system `S` (empty for the generalized form).
pub(crate) fn entropy_rows<S: MetriplecticSystem>() -> &'static [LinearForm] {
    S::CLASSICAL.map_or(&[], |c| c.entropy_constraints)
}

/// The metric rows C_K of system `S` (empty for the generalized form).
pub(crate) fn metric_rows<S: MetriplecticSystem>() -> &'static [LinearForm] {
    S::CLASSICAL.map_or(&[], |c| c.metric_constraints)
}

/// Errors unless entropy coefficients `psi` make S a Casimir of Π (for a
/// classical system; always Ok otherwise).
pub(crate) fn check_entropy<S: MetriplecticSystem>(what: &str, psi: &[f64]) -> Result<()> {
    check_rows(
        what,
        entropy_rows::<S>(),
        psi,
        "S must be a Casimir of Π (Π∇S ≡ 0)",
    )
}

/// Errors unless metric coefficients `theta` satisfy K(x)∇H(x) ≡ 0 (for a
/// classical system; always Ok otherwise).
pub(crate) fn check_metric<S: MetriplecticSystem>(what: &str, theta: &[f64]) -> Result<()> {
    check_rows(
        what,
        metric_rows::<S>(),
        theta,
        "the metric must be degenerate along ∇H (K(x)∇H(x) ≡ 0)",
    )
}

fn check_rows(what: &str, rows: &[LinearForm], values: &[f64], condition: &str) -> Result<()> {
    let scale = values.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = rows
        .iter()
        .enumerate()
        .map(|(i, row)| (i, evaluate(row, values)))
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
    match worst {
        Some((row, residual)) if residual.abs() > TOLERANCE * scale => Err(Error::NotClassical {
            what: what.to_owned(),
            condition: condition.to_owned(),
            row,
            residual,
            scale,
        }),
        _ => Ok(()),
    }
}

fn evaluate(row: LinearForm, values: &[f64]) -> f64 {
    row.iter().map(|&(i, c)| c * values[i as usize]).sum()
}

/// Linear equalities C x = 0 over a subset of the coefficients (the free
/// ones of a search), as orthonormal independent rows: restricting the
/// macro's independent rows to a subset can make them dependent, and
/// dependent equality rows would make the interior-point method's
/// equality system singular.
#[derive(Debug, Clone)]
pub(crate) struct Equalities {
    /// Orthonormal rows (rank × free.len()), in the free coordinates.
    rows: DMatrix<f64>,
    /// The coefficients the columns stand for.
    free: Vec<usize>,
}

impl Equalities {
    /// The rows `forms` restricted to the coefficients `free` (sorted
    /// indices); coefficients outside `free` are held at zero elsewhere.
    pub fn new(forms: &[LinearForm], free: &[usize]) -> Self {
        let width = free.len();
        let none = || Self {
            rows: DMatrix::zeros(0, width),
            free: free.to_vec(),
        };
        if forms.is_empty() || width == 0 {
            return none();
        }
        let mut c = DMatrix::zeros(forms.len(), width);
        for (r, form) in forms.iter().enumerate() {
            for &(i, v) in form.iter() {
                if let Ok(position) = free.binary_search(&(i as usize)) {
                    c[(r, position)] = v;
                }
            }
        }
        // The right singular vectors of the non-zero singular values span
        // the row space.
        let svd = c.svd(false, true);
        let largest = svd.singular_values.max();
        let Some(v_t) = svd.v_t else {
            return none();
        };
        let kept: Vec<usize> = (0..svd.singular_values.len())
            .filter(|&k| largest > 0.0 && svd.singular_values[k] > RANK_TOLERANCE * largest)
            .collect();
        let rows = DMatrix::from_fn(kept.len(), width, |r, j| v_t[(kept[r], j)]);
        Self {
            rows,
            free: free.to_vec(),
        }
    }

    /// Number of independent rows.
    pub fn len(&self) -> usize {
        self.rows.nrows()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The rows as (row, j + `offset`, value) entries for the j-th free
    /// coefficient, with zero right-hand sides, for
    /// [`Cone::Zero`](crate::solve::Cone::Zero).
    pub fn entries(&self, offset: usize) -> Vec<(usize, usize, f64)> {
        let mut entries = Vec::new();
        for r in 0..self.rows.nrows() {
            for j in 0..self.rows.ncols() {
                let v = self.rows[(r, j)];
                if v != 0.0 {
                    entries.push((r, offset + j, v));
                }
            }
        }
        entries
    }

    /// The orthogonal projection of `values` (in the free coordinates)
    /// onto C x = 0: an interior-point solution meets the rows to the
    /// solver's tolerance, its projection to rounding.
    pub fn project(&self, values: &mut [f64]) {
        if self.is_empty() {
            return;
        }
        let x = nalgebra::DVectorView::from_slice(values, values.len());
        let correction = self.rows.tr_mul(&(&self.rows * x));
        for (v, c) in values.iter_mut().zip(correction.iter()) {
            *v -= c;
        }
    }

    /// [`project`](Self::project) on the free coefficients of `values`
    /// (all the coefficients, indexed as in the model).
    pub fn project_coefficients(&self, values: &mut [f64]) {
        if self.is_empty() {
            return;
        }
        let mut part: Vec<f64> = self.free.iter().map(|&k| values[k]).collect();
        self.project(&mut part);
        for (&k, v) in self.free.iter().zip(part) {
            values[k] = v;
        }
    }

    /// The coefficient index of free column j.
    pub fn coefficient(&self, j: usize) -> usize {
        self.free[j]
    }

    /// The rows, each dense over the free coefficients.
    pub fn dense_rows(&self) -> Vec<Vec<f64>> {
        self.rows
            .row_iter()
            .map(|row| row.iter().copied().collect())
            .collect()
    }

    /// The part of the linear form `row` (dense, in the free coordinates)
    /// that the rows leave free: zero if the equalities fix it.
    pub fn free_part(&self, row: &[f64]) -> f64 {
        let mut projected = row.to_vec();
        self.project(&mut projected);
        projected.iter().map(|v| v * v).sum::<f64>().sqrt()
    }
}

/// Projects the metric coefficients `theta` (full length) onto the
/// classical rows over all coefficients; no-op for the generalized form.
fn project_metric<S: MetriplecticSystem>(theta: &mut [f64]) {
    let all: Vec<usize> = (0..theta.len()).collect();
    Equalities::new(metric_rows::<S>(), &all).project_coefficients(theta);
}

/// Sample points at which a polynomial identity is fitted: the
/// certificate's region, or the cube [−1, 1]ⁿ without one.
fn sample_states<S: MetriplecticSystem>(count: usize) -> Vec<Vec<f64>> {
    let n = S::DIM;
    let (lower, upper): (Vec<f64>, Vec<f64>) = match S::REGION_CERTIFICATE.map(|c| c.region) {
        Some(Region::Ball { center, radius }) => (
            center.iter().map(|c| c - radius).collect(),
            center.iter().map(|c| c + radius).collect(),
        ),
        Some(Region::Box { lower, upper }) => (lower.to_vec(), upper.to_vec()),
        None => (vec![-1.0; n], vec![1.0; n]),
    };
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    (0..count)
        .map(|_| {
            (0..n)
                .map(|i| rng.random_range(lower[i]..=upper[i]))
                .collect()
        })
        .collect()
}

/// The metric K(x) = c·(|∇H(x)|² I − ∇H(x)∇H(x)ᵀ) in the metric basis of
/// classical system `S`, scaled so that its largest eigenvalue on the
/// region (on sample states) is `scale`: positive semidefinite (a sum of
/// squares, yᵀKy = c Σᵢ<ⱼ (∂ᵢH yⱼ − ∂ⱼH yᵢ)²) and degenerate along ∇H, it
/// is the default start of a classical run, where the identity metric
/// breaks K∇H ≡ 0.
///
/// Errors if the metric basis cannot hold it (the metric degree is below
/// twice the degree of ∇H) or ∇H vanishes on the samples.
pub(crate) fn degenerate_metric<S: MetriplecticSystem>(scale: f64) -> Result<Vec<f64>> {
    let n = S::DIM;
    let m = S::METRIC_EXPONENTS.len();
    let pairs = n * (n + 1) / 2;
    let states = sample_states::<S>(4 * m + 16);
    let mut design = DMatrix::zeros(states.len(), m);
    let mut targets = DMatrix::zeros(states.len(), pairs);
    let mut gradient = vec![0.0; n];
    let mut largest = 0.0f64;
    for (r, x) in states.iter().enumerate() {
        let mut monomials = vec![0.0; m];
        S::monomials(x, &mut monomials);
        for (a, v) in monomials.iter().enumerate() {
            design[(r, a)] = *v;
        }
        S::hamiltonian_gradient(x, &mut gradient);
        let norm2: f64 = gradient.iter().map(|g| g * g).sum();
        largest = largest.max(norm2);
        for j in 0..n {
            for k in j..n {
                let identity = if j == k { norm2 } else { 0.0 };
                targets[(r, metric_pair_index(n, j, k))] = identity - gradient[j] * gradient[k];
            }
        }
    }
    let refuse = |why: String| {
        invalid(
            "initial metric coefficients",
            format!(
                "no default start for the classical system `{}`: {why}; pass an initial \
                 metric that satisfies K(x)∇H(x) ≡ 0",
                S::NAME
            ),
        )
    };
    if !(largest.is_finite() && largest > 0.0) {
        return Err(refuse("∇H vanishes on the region".to_owned()));
    }
    let solution = design
        .clone()
        .svd(true, true)
        .solve(&targets, 1e-12)
        .map_err(|e| refuse(e.to_owned()))?;
    let misfit = (&design * &solution - &targets).amax();
    if misfit > 1e-8 * largest {
        return Err(refuse(format!(
            "|∇H|² I − ∇H ∇Hᵀ has degree 2·deg ∇H, above the metric degree {} (misfit \
             {misfit:e})",
            S::METRIC_DEGREE
        )));
    }
    let mut theta = vec![0.0; pairs * m];
    for pair in 0..pairs {
        for a in 0..m {
            theta[pair * m + a] = solution[(a, pair)] * scale / largest;
        }
    }
    project_metric::<S>(&mut theta);
    Ok(theta)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROWS: &[LinearForm] = &[
        &[(0, 1.0), (1, -1.0)],
        &[(1, 1.0), (2, -1.0)],
        &[(0, 1.0), (2, -1.0), (3, 0.5)],
    ];

    fn residual(x: &[f64]) -> f64 {
        ROWS.iter()
            .map(|row| evaluate(row, x).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn projection_meets_the_rows_to_rounding_and_keeps_admissible_points() {
        let all = [0, 1, 2, 3];
        let equalities = Equalities::new(ROWS, &all);
        assert_eq!(equalities.len(), 3);
        let mut x = vec![0.3, -1.2, 2.5, 0.7];
        assert!(residual(&x) > 0.1);
        equalities.project_coefficients(&mut x);
        assert!(residual(&x) < 1e-15, "{}", residual(&x));
        let before = x.clone();
        equalities.project_coefficients(&mut x);
        let moved = x
            .iter()
            .zip(&before)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(moved < 1e-15, "{moved}");
    }

    #[test]
    fn rows_restricted_to_a_support_become_dependent_and_are_reduced() {
        // With x₃ held at zero the third row is the sum of the first two.
        let free = [0, 1, 2];
        let equalities = Equalities::new(ROWS, &free);
        assert_eq!(equalities.len(), 2);
        let rows = equalities.dense_rows();
        for (a, row_a) in rows.iter().enumerate() {
            for (b, row_b) in rows.iter().enumerate() {
                let dot: f64 = row_a.iter().zip(row_b).map(|(u, v)| u * v).sum();
                let expected = if a == b { 1.0 } else { 0.0 };
                assert!((dot - expected).abs() < 1e-14, "{a} {b}: {dot}");
            }
        }
        // The entries index the free coefficients by position.
        assert!(equalities
            .entries(10)
            .iter()
            .all(|&(r, c, _)| r < 2 && (10..13).contains(&c)));
        assert_eq!(equalities.coefficient(2), 2);
        // The rows fix x₀ − x₂ (a combination) but not x₀ + x₁ + x₂.
        assert!(equalities.free_part(&[1.0, 0.0, -1.0]) < 1e-14);
        assert!(equalities.free_part(&[1.0, 1.0, 1.0]) > 1.0);
    }

    #[test]
    fn a_violated_row_is_named_with_its_residual() {
        assert!(check_rows("entropy coefficients", ROWS, &[1.0, 1.0, 1.0, 0.0], "c").is_ok());
        match check_rows("entropy coefficients", ROWS, &[1.0, 1.0, 1.0, 2.0], "c") {
            Err(Error::NotClassical {
                row,
                residual,
                scale,
                ..
            }) => {
                assert_eq!(row, 2);
                assert_eq!(residual, 1.0);
                assert_eq!(scale, 2.0);
            }
            other => panic!("{other:?}"),
        }
    }
}
