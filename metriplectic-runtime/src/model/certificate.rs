//! Certificates that a metric is positive semidefinite for every state, the
//! condition under which the free energy never decreases.
//!
//! The metric's sparsity splits K(x) into independent diagonal blocks (the
//! connected components of its non-zero entries). A constant block is PSD
//! iff its smallest eigenvalue is ≥ 0. A state-dependent block is certified
//! by a sum-of-squares Gram matrix: K_C(x) = Z(x)ᵀ Q Z(x) with Q ⪰ 0 over
//! the monomials of half the block's degree in the variables it depends on
//! (a certificate in fewer variables is no loss: evaluating any certificate
//! at zero in the absent variables gives one). The Gram matrix is found by
//! the solver layer as the semidefinite program
//!
//! ```text
//! min |s|   s.t.   T(Q) = θ_C,   Q + s·I ⪰ 0,
//! ```
//!
//! which is strictly feasible for any θ_C the basis can represent: its optimum
//! is 0 exactly when a certificate exists, and otherwise measures how far
//! from one the metric is. When no certificate is found, states are probed
//! for a negative eigenvalue so that the error can name one.

use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::gram::{monomial_scale, region_coordinates, state_scale, Layout};
use super::shift::Shift;
use crate::error::{Error, Result};
use crate::solve::linalg::symmetric_eigen;
use crate::solve::svec::{smat, svec_diagonal, svec_index, svec_len, SQRT_2};
use crate::solve::{solve_l1, Cone, L1Problem, Regression, SolveStatus, SolverSettings};
use crate::system::{
    metric_pair_index, CertificateMode, MetriplecticSystem, Region, RegionCertificate,
};

/// Relative tolerance of a constant block's smallest eigenvalue (after
/// Jacobi scaling, see `check_constant_block`) and of the witnesses of
/// state-dependent ones: rounding in a metric search's Gram matrix is ~1e-16
/// of its scale.
const EIGENVALUE_TOLERANCE: f64 = 1e-10;
/// A constant block's smallest eigenvalue above −this times its size
/// times its largest entry is rounding whatever the direction: a
/// backward-stable eigensolve's own error is a few n·ε of the largest
/// entry. At 1e-12 (500 times that) [[1e12, 1.4e6], [1.4e6, 1]], whose
/// eigenvalue −0.96 is all of the second axis's own scale, passed, and
/// E fell at 0.96·|∇E|² along (1.4e-6, −1).
const ROUNDING_TOLERANCE: f64 = 4.0 * f64::EPSILON;
/// Relative tolerance of the certificate program's optimum |s| (the program
/// itself runs at the far tighter `certificate_settings`).
const CERTIFICATE_TOLERANCE: f64 = 1e-8;
/// The certificate program's solver settings: tolerances far below
/// `CERTIFICATE_TOLERANCE`. A metric from a search sits on the boundary of
/// the SOS cone (its Gram matrices are singular), so the program's optimum
/// is s = 0 and only the solver's accuracy separates it from the tolerance.
fn certificate_settings() -> SolverSettings {
    SolverSettings {
        tol_gap_abs: 1e-12,
        tol_gap_rel: 1e-12,
        tol_feas: 1e-12,
        ..SolverSettings::default()
    }
}

/// Largest Gram matrix side the certificate program is set up for.
const MAX_GRAM_SIDE: usize = 64;

/// Checks that the metric with coefficients `theta` is positive
/// semidefinite for every state — or, for a system whose region
/// certificate holds only on its region ([`CertificateMode::OnRegion`]),
/// for every state in the region; `what` names it in errors.
pub(crate) fn check_metric<S: MetriplecticSystem>(what: &str, theta: &[f64]) -> Result<()> {
    if let Some(certificate) = S::REGION_CERTIFICATE {
        if certificate.mode == CertificateMode::OnRegion {
            return check_on_region::<S>(what, theta, &certificate);
        }
        // A region only bounds K from above by default: say so when the
        // witness lies outside the region (or there is none), where it is
        // otherwise puzzling.
        return check_everywhere::<S>(what, theta).map_err(|error| match error {
            Error::MetricNotPositive {
                what,
                eigenvalue,
                direction,
                state,
            } if state
                .as_ref()
                .is_some_and(|x| !certificate.region.contains(x)) =>
            {
                Error::MetricNotPositive {
                    what: outside_region_too(&what),
                    eigenvalue,
                    direction,
                    state,
                }
            }
            Error::MetricNotCertified { what, reason } => Error::MetricNotCertified {
                what: outside_region_too(&what),
                reason,
            },
            other => other,
        });
    }
    check_everywhere::<S>(what, theta).map_err(|error| match error {
        Error::MetricNotCertified { what, reason } => Error::MetricNotCertified {
            what,
            reason: format!("{reason}; K(x) ⪰ 0 is required for every x"),
        },
        other => other,
    })
}

/// `what`, saying that the default mode needs K(x) ⪰ 0 beyond the region.
fn outside_region_too(what: &str) -> String {
    format!(
        "{what} (K(x) ⪰ 0 is required for every x, outside the region too, unless the \
         system declares `certificate on region;`)"
    )
}

/// K(x) ⪰ 0 for every x, block by block.
fn check_everywhere<S: MetriplecticSystem>(what: &str, theta: &[f64]) -> Result<()> {
    for block in blocks::<S>(theta) {
        if is_constant::<S>(theta, &block) {
            check_constant_block::<S>(what, theta, &block)?;
        } else if let Some(balanced) = Balanced::of::<S>(theta, &block, false) {
            check_state_dependent_block::<S>(what, (&balanced.theta, theta), &block)
                .map_err(|error| balanced.restore::<S>(theta, &block, error))?;
        } else {
            check_state_dependent_block::<S>(what, (theta, theta), &block)?;
        }
    }
    Ok(())
}

/// K(x) ⪰ 0 for every x on one block whose entries are not all constant:
/// certified on `theta` (K's own θ or its [`Balanced`] form), and judged
/// at states on K's own θ, `own` (balancing amplifies a zero row's
/// rounding-level coupling beyond [`EVALUATION_TOLERANCE`]).
fn check_state_dependent_block<S: MetriplecticSystem>(
    what: &str,
    (theta, own): (&[f64], &[f64]),
    block: &[usize],
) -> Result<()> {
    let scale = block_scale::<S>(theta, block);
    let Certification {
        shift, suspects, ..
    } = certify_block::<S>(theta, block, scale);
    // A suspect where K is clearly positive (its scaled smallest
    // eigenvalue above `SUSPECT_MARGIN`) is not descended from: searched
    // metrics' suspects mostly are, and each descent costs hundreds of
    // eigensolves.
    let suspects: Vec<Vec<f64>> = {
        let mut judge = Judge::new::<S>(own, block);
        suspects
            .into_iter()
            .filter(|x| !judge.clear::<S>(x, SUSPECT_MARGIN))
            .collect()
    };
    // Judged against K's own terms, first where the Gram matrix points
    // (cheap, and where K is lowest against the certificate's unit), then
    // along the rays.
    let strict_witness = || {
        descent_witness::<S>(what, own, block, None, suspects.clone())
            .or_else(|| far_witness::<S>(what, own, block))
    };
    let shift = match shift {
        Ok(shift) => shift,
        // A state that shows it, near the origin or far out.
        Err(reason) => {
            return Err(strict_witness()
                .or_else(|| witness::<S>(what, theta, block, scale))
                .or_else(|| vertex_witness::<S>(what, theta, block, scale))
                .or_else(|| ray_witness::<S>(what, theta, block, scale))
                .or_else(|| descent_witness::<S>(what, own, block, None, descent_starts::<S>()))
                .unwrap_or(Error::MetricNotCertified {
                    what: what.to_owned(),
                    reason,
                }))
        }
    };
    // The certificate's tolerance allows K(x) ⪰ −s‖Z(x)‖²I, which far out
    // can exceed K itself, where K's terms cancel (K = (q − 1000)² − 1 has
    // a shift of 1e-12 of its largest coefficient), and in a narrow band
    // anywhere: a state where it does is refused. The Gram matrix's own
    // suspects are always tried; the seeded descent (a third of the drag
    // examples' time) only above `DESCENT_SHIFT`: searched metrics sit at
    // shifts near 1e-12.
    match strict_witness()
        .or_else(|| vertex_witness::<S>(what, theta, block, scale))
        .or_else(|| ray_witness::<S>(what, theta, block, scale))
        .or_else(|| {
            (shift > DESCENT_SHIFT)
                .then(|| descent_witness::<S>(what, own, block, None, descent_starts::<S>()))
                .flatten()
        }) {
        Some(error) => Err(error),
        None => Ok(()),
    }
}

/// Largest ratio of two diagonal entries' sizes within a block that its
/// checks take as they are; beyond it the block is checked as
/// [`Balanced`].
const BALANCE_RATIO: f64 = 1e3;

/// Size, relative to the block's largest diagonal entry, below which a
/// diagonal entry counts as that size when balancing: a zero row coupled
/// at the searches' rounding (1e-9 of the scale) stays acceptable, its
/// eigenvalue −(1e-9)²/1e-6 = −1e-12 of the scale.
const BALANCE_FLOOR: f64 = 1e-6;

/// A metric with the state axes of one block rescaled, K̃(x) = D K(x) D
/// with D constant, diagonal and positive, so that the block's diagonal
/// entries have comparable sizes. K̃(x) ⪰ 0 exactly where K(x) ⪰ 0, but
/// the checks' tolerances, relative to the largest coefficient, then
/// apply to every axis alike: [[1e12 + q², 1.4e6], [1.4e6, 1]], negative
/// along (1.4e-6, −1) at 0.96·|∇E|², passed within 1e-8 of 1e12.
struct Balanced {
    /// θ of K̃.
    theta: Vec<f64>,
    /// D's diagonal, one factor per state variable (1 outside the block).
    factors: Vec<f64>,
}

impl Balanced {
    /// The balanced metric of `block`, or `None` when its diagonal entries'
    /// sizes are within [`BALANCE_RATIO`] of each other. An entry's size is
    /// its largest coefficient in the coordinates its certificate uses:
    /// centred on a region far from the origin, each monomial x^α weighted
    /// by ρ^α (the region's half-widths; at least 1 where K ⪰ 0 is needed
    /// everywhere, `on_region` false), so that 1 − 4·10⁶q² on |q| ≤ 5e-4
    /// is as large as a constant 1.
    fn of<S: MetriplecticSystem>(theta: &[f64], block: &[usize], on_region: bool) -> Option<Self> {
        let (centre, rho) = region_coordinates::<S>();
        let centred = centre
            .and_then(|c| Shift::new(S::METRIC_EXPONENTS, c))
            .map(|shift| shift.to_centred(theta));
        let rho: Vec<f64> = match (&centred, on_region) {
            (Some(_), true) => rho,
            (Some(_), false) => rho.into_iter().map(|r| r.max(1.0)).collect(),
            (None, true) => state_scale::<S>(),
            (None, false) => state_scale::<S>().into_iter().map(|r| r.max(1.0)).collect(),
        };
        let weights: Vec<f64> = S::METRIC_EXPONENTS
            .iter()
            .map(|e| monomial_scale(&rho, e))
            .collect();
        let coefficients = centred.as_deref().unwrap_or(theta);
        let size = |j: usize| {
            entry::<S>(coefficients, j, j)
                .iter()
                .zip(&weights)
                .fold(0.0_f64, |m, (c, w)| m.max((c * w).abs()))
        };
        let largest = block.iter().map(|&j| size(j)).fold(0.0_f64, f64::max);
        if !(largest.is_normal() && largest.is_finite()) {
            return None;
        }
        let floor = BALANCE_FLOOR * largest;
        let sizes: Vec<f64> = block.iter().map(|&j| size(j).max(floor)).collect();
        let smallest = sizes.iter().copied().fold(f64::INFINITY, f64::min);
        if largest <= BALANCE_RATIO * smallest {
            return None;
        }
        let mut factors = vec![1.0; S::DIM];
        for (&j, size) in block.iter().zip(&sizes) {
            factors[j] = (largest / size).sqrt();
        }
        if factors.iter().any(|f| !f.is_finite()) {
            return None;
        }
        let mut balanced = theta.to_vec();
        let m = S::METRIC_EXPONENTS.len();
        for (_, _, j, k) in block_pairs(block) {
            let pair = metric_pair_index(S::DIM, j, k);
            balanced[pair * m..(pair + 1) * m]
                .iter_mut()
                .for_each(|c| *c *= factors[j] * factors[k]);
        }
        Some(Self {
            theta: balanced,
            factors,
        })
    }

    /// An error found on K̃ in K's own terms: a witness K̃'s direction u
    /// becomes D u, with K's Rayleigh quotient there, unless K's own
    /// smallest eigenvalue at that state is lower.
    fn restore<S: MetriplecticSystem>(
        &self,
        theta: &[f64],
        block: &[usize],
        error: Error,
    ) -> Error {
        let (what, direction, x) = match error {
            Error::MetricNotPositive {
                what,
                direction,
                state: Some(x),
                ..
            } => (what, direction, x),
            other => return other,
        };
        let n = S::DIM;
        let v: Vec<f64> = block
            .iter()
            .map(|&j| direction[j] * self.factors[j])
            .collect();
        let mut metric = vec![0.0; n * n];
        S::metric_value(&x, theta, &mut metric);
        let (eigenvalue, local) = lowest_along(block_matrix(&metric, n, block), v);
        not_positive(&what, eigenvalue, (n, block, &local), Some(x))
    }
}

/// The coefficients θ of entry (j, k).
fn entry<S: MetriplecticSystem>(theta: &[f64], j: usize, k: usize) -> &[f64] {
    let m = S::METRIC_EXPONENTS.len();
    let pair = metric_pair_index(S::DIM, j, k);
    &theta[pair * m..(pair + 1) * m]
}

/// The state indices of each diagonal block: connected components of the
/// graph with an edge j–k for every non-zero entry K_jk.
fn blocks<S: MetriplecticSystem>(theta: &[f64]) -> Vec<Vec<usize>> {
    let n = S::DIM;
    let mut component: Vec<usize> = (0..n).collect();
    fn root(component: &mut [usize], mut i: usize) -> usize {
        while component[i] != i {
            component[i] = component[component[i]];
            i = component[i];
        }
        i
    }
    for j in 0..n {
        for k in j + 1..n {
            if entry::<S>(theta, j, k).iter().any(|&c| c != 0.0) {
                let (a, b) = (root(&mut component, j), root(&mut component, k));
                component[a.max(b)] = a.min(b);
            }
        }
    }
    let mut blocks: Vec<Vec<usize>> = Vec::new();
    let mut roots: Vec<usize> = Vec::new();
    for i in 0..n {
        let r = root(&mut component, i);
        match roots.iter().position(|&x| x == r) {
            Some(b) => blocks[b].push(i),
            None => {
                roots.push(r);
                blocks.push(vec![i]);
            }
        }
    }
    blocks
}

/// The pairs (j ≤ k) of a block.
fn block_pairs(block: &[usize]) -> impl Iterator<Item = (usize, usize, usize, usize)> + '_ {
    block.iter().enumerate().flat_map(move |(a, &j)| {
        block[a..]
            .iter()
            .enumerate()
            .map(move |(offset, &k)| (a, a + offset, j, k))
    })
}

fn block_scale<S: MetriplecticSystem>(theta: &[f64], block: &[usize]) -> f64 {
    block_pairs(block)
        .flat_map(|(_, _, j, k)| entry::<S>(theta, j, k).iter())
        .fold(0.0_f64, |m, c| m.max(c.abs()))
}

/// Whether every entry of the block has only a constant term (the metric
/// basis starts with the constant monomial).
fn is_constant<S: MetriplecticSystem>(theta: &[f64], block: &[usize]) -> bool {
    block_pairs(block).all(|(_, _, j, k)| entry::<S>(theta, j, k)[1..].iter().all(|&c| c == 0.0))
}

/// The block's constant matrix (local indices).
fn constant_block<S: MetriplecticSystem>(theta: &[f64], block: &[usize]) -> DMatrix<f64> {
    let size = block.len();
    let mut k0 = DMatrix::zeros(size, size);
    for (a, b, j, k) in block_pairs(block) {
        let value = entry::<S>(theta, j, k)[0];
        k0[(a, b)] = value;
        k0[(b, a)] = value;
    }
    k0
}

/// The smallest eigenvalue of a symmetric matrix and its eigenvector (NaN
/// if the eigensolver fails, which the callers treat as not positive).
fn smallest_eigen(matrix: DMatrix<f64>) -> (f64, Vec<f64>) {
    match symmetric_eigen(&matrix) {
        Some((values, vectors)) if !values.is_empty() => {
            (values[0], vectors.column(0).iter().copied().collect())
        }
        Some(_) => (0.0, Vec::new()),
        None => (f64::NAN, vec![f64::NAN; matrix.nrows()]),
    }
}

/// K's smallest eigenvalue and its direction, or K's Rayleigh quotient
/// along `v` (normalised here) and v where that is lower: `v` was found on
/// a rescaled form of K, and K's own eigensolve loses what is below its
/// rounding (−1e-3 next to 1e15 comes back as 0).
fn lowest_along(k: DMatrix<f64>, mut v: Vec<f64>) -> (f64, Vec<f64>) {
    let length = v.iter().map(|c| c * c).sum::<f64>().sqrt();
    v.iter_mut().for_each(|c| *c /= length);
    let u = DVector::from_column_slice(&v);
    let quotient = (&k * &u).dot(&u);
    match smallest_eigen(k) {
        (value, vector) if value <= quotient => (value, vector),
        _ => (quotient, v),
    }
}

/// The block's part of an n×n row-major metric value (local indices).
fn block_matrix(metric: &[f64], n: usize, block: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(block.len(), block.len(), |a, b| {
        metric[block[a] * n + block[b]]
    })
}

/// K(`state`) (K₀ with `None`) has `eigenvalue` < 0 along `local`, a
/// direction within `block` of an n-state system.
fn not_positive(
    what: &str,
    eigenvalue: f64,
    (n, block, local): (usize, &[usize], &[f64]),
    state: Option<Vec<f64>>,
) -> Error {
    Error::MetricNotPositive {
        what: what.to_owned(),
        eigenvalue,
        direction: embed(n, block, local),
        state,
    }
}

/// The block's eigenvector as a full n-vector.
fn embed(n: usize, block: &[usize], local: &[f64]) -> Vec<f64> {
    let mut full = vec![0.0; n];
    for (&i, &v) in block.iter().zip(local) {
        full[i] = v;
    }
    full
}

/// A constant block with a negative diagonal entry fails. Otherwise it
/// passes when its smallest eigenvalue is at rounding level, above
/// −[`ROUNDING_TOLERANCE`] times its size times its largest entry, or when its
/// Jacobi-scaled form D^-½ K D^-½ has no eigenvalue below
/// −[`EIGENVALUE_TOLERANCE`], D_i = max(K_ii, 0) plus that tolerance times the
/// largest entry. Beyond rounding the tolerance is then per direction: a
/// large entry elsewhere cannot hide a negative one (a probe's
/// K = [[1e15, 1e-300], [1e-300, −1e5]] loaded while the tolerance was
/// 1e-10 of the largest entry, and E fell at 1e5·|∇E|² along the second
/// axis). The scaling is a congruence, so K itself has a negative
/// eigenvalue whenever the scaled form does: that one is reported.
fn check_constant_block<S: MetriplecticSystem>(
    what: &str,
    theta: &[f64],
    block: &[usize],
) -> Result<()> {
    let k0 = constant_block::<S>(theta, block);
    let spread = k0.amax();
    if spread == 0.0 {
        return Ok(());
    }
    let size = k0.nrows();
    // A negative diagonal entry is an exact witness, eᵢᵀ K eᵢ < 0, with no
    // rounding to allow for; an eigensolve would lose it next to a large
    // entry (−1e-3 next to 1e15 comes back as 0).
    if let Some(i) = (0..size)
        .filter(|&i| k0[(i, i)] < 0.0)
        .min_by(|&a, &b| k0[(a, a)].total_cmp(&k0[(b, b)]))
    {
        let mut direction = vec![0.0; size];
        direction[i] = 1.0;
        return Err(not_positive(
            what,
            k0[(i, i)],
            (S::DIM, block, &direction),
            None,
        ));
    }
    let (eigenvalue, _) = smallest_eigen(k0.clone());
    if eigenvalue >= -ROUNDING_TOLERANCE * size as f64 * spread {
        return Ok(());
    }
    let floor = EIGENVALUE_TOLERANCE * spread;
    let root: Vec<f64> = (0..size)
        .map(|i| (k0[(i, i)].max(0.0) + floor).sqrt())
        .collect();
    let scaled = DMatrix::from_fn(size, size, |a, b| k0[(a, b)] / (root[a] * root[b]));
    let (scaled_eigenvalue, u) = smallest_eigen(scaled);
    if scaled_eigenvalue.is_nan() || scaled_eigenvalue < -EIGENVALUE_TOLERANCE {
        // The scaled direction taken back, D^-½ u.
        let v: Vec<f64> = u.iter().zip(&root).map(|(u, r)| u / r).collect();
        let (eigenvalue, direction) = lowest_along(k0, v);
        return Err(not_positive(
            what,
            eigenvalue,
            (S::DIM, block, &direction),
            None,
        ));
    }
    Ok(())
}

/// Finds a Gram certificate of a state-dependent block, or says why not.
fn certify_block<S: MetriplecticSystem>(
    theta: &[f64],
    block: &[usize],
    scale: f64,
) -> Certification {
    // In y = x − c for a region far from the origin, as the searches'
    // certificates (`Layout`): K(x) ⪰ 0 for every x exactly when
    // K(c + y) ⪰ 0 for every y.
    let (centre, rho) = region_coordinates::<S>();
    let shift = centre
        .as_ref()
        .and_then(|c| Shift::new(S::METRIC_EXPONENTS, c.clone()));
    let (theta, rho): (&[f64], Vec<f64>) = match &shift {
        Some(shift) => (&shift.to_centred(theta), rho),
        None => (theta, state_scale::<S>()),
    };
    let mut certification = certify_block_centred::<S>(theta, block, scale, &rho);
    if let Some(c) = centre.filter(|_| shift.is_some()) {
        for y in &mut certification.suspects {
            y.iter_mut().zip(&c).for_each(|(y, c)| *y += c);
        }
    }
    certification
}

/// [`certify_block`] on θ in the certificate's coordinates.
fn certify_block_centred<S: MetriplecticSystem>(
    theta: &[f64],
    block: &[usize],
    scale: f64,
    rho: &[f64],
) -> Certification {
    let exponents = S::METRIC_EXPONENTS;
    let degree_of = |e: &[u32]| e.iter().sum::<u32>();
    // The variables and the degree the block's entries use.
    let mut used = vec![false; S::DIM];
    let mut degree = 0;
    for (_, _, j, k) in block_pairs(block) {
        for (c, e) in entry::<S>(theta, j, k).iter().zip(exponents) {
            if *c != 0.0 {
                degree = degree.max(degree_of(e));
                e.iter().enumerate().for_each(|(v, &p)| used[v] |= p > 0);
            }
        }
    }
    if degree % 2 == 1 {
        return Certification {
            shift: Err(format!(
                "an entry has odd degree {degree}, and a matrix polynomial of odd degree cannot \
                 be positive semidefinite everywhere"
            )),
            suspects: Vec::new(),
            conclusive: true,
        };
    }
    let half: Vec<&[u32]> = exponents
        .iter()
        .copied()
        .filter(|e| 2 * degree_of(e) <= degree && e.iter().zip(&used).all(|(&p, &u)| p == 0 || u))
        .collect();
    // First on the Gram rows that can be non-zero (facial reduction by
    // diagonal consistency): where most must vanish, the program on all
    // rows has no interior point and may end short of its tolerance. If
    // that fails, on all rows: never stricter, and it also allows the
    // shift's tolerance for terms no kept row produces (a search's rounding).
    let all: Vec<(usize, usize)> = (0..block.len())
        .flat_map(|a| (0..half.len()).map(move |beta| (a, beta)))
        .collect();
    let reduced = consistent_rows::<S>(theta, block, &half);
    let mut suspects = Vec::new();
    if reduced.len() < all.len() {
        let on_reduced = certify_on_rows::<S>(theta, block, &half, &reduced, rho, scale);
        // A term beyond rounding that only dropped rows could produce: no
        // Gram matrix is PSD, and all rows would allow it the tolerance
        // (1 + a⁶b² + 1e-3·a, negative for a < −1000, passed that way).
        if on_reduced.shift.is_ok() || on_reduced.conclusive {
            return on_reduced;
        }
        suspects = on_reduced.suspects;
    }
    let mut on_all = certify_on_rows::<S>(theta, block, &half, &all, rho, scale);
    on_all.suspects.extend(suspects);
    on_all
}

/// What a block's certificate program found.
struct Certification {
    /// `Ok` with the optimal shift relative to the block's scaled size if
    /// it is within tolerance, else why not.
    shift: std::result::Result<f64, String>,
    /// States (in the certificate's coordinates y = x − c) where K is
    /// lowest relative to the certificate's unit, read off its Gram matrix
    /// ([`gram_suspects`]).
    suspects: Vec<Vec<f64>>,
    /// Whether the refusal holds with no tolerance: a term beyond the
    /// searches' rounding that no pair of the Gram rows can produce.
    conclusive: bool,
}

/// A term no kept Gram row produces, up to this fraction of a block's
/// scaled size, is allowed the certificate's tolerance on all rows: a
/// pair of rows whose diagonal must vanish produces a term c only with a
/// shift of about c², so up to √`CERTIFICATE_TOLERANCE` it is within the
/// tolerance anyway (a zero row coupled at the searches' rounding, 1e-9
/// of the scale, stays acceptable). Beyond it the refusal is final.
const SEARCH_ROUNDING: f64 = 1e-4;

/// A suspect of [`gram_suspects`] where K's scaled smallest eigenvalue is
/// above this is not descended from.
const SUSPECT_MARGIN: f64 = 1e-3;

/// Eigenvectors of a Gram matrix taken as suspects: at most this many, the
/// lowest.
const GRAM_SUSPECT_VECTORS: usize = 4;

/// The states a block's Gram matrix Q′ (over `gram_rows`, in u = y/ρ)
/// points at. At the program's optimum Q′ + sI is singular, and where the
/// metric is lowest against the certificate's unit, at y*, its null space
/// holds Z(u*) ⊗ w for K's lowest direction w (complementary slackness
/// with a moment matrix of one point). So each of Q′'s lowest eigenvectors
/// v is read as such a vector: u*ᵢ = v(a, eᵢ) / v(a, 0) on a block row a,
/// and yᵢ = ρᵢ u*ᵢ. A probe's K = (q − 1000)² − 1, certified within the
/// tolerance (its shift is 1e-12 of its largest coefficient, 1e6), is
/// found at q = 1000 this way, where no fixed or seeded state falls.
fn gram_suspects(
    gram: &DMatrix<f64>,
    rows: usize,
    half: &[&[u32]],
    gram_rows: &[(usize, usize)],
    rho: &[f64],
) -> Vec<Vec<f64>> {
    let Some((_, vectors)) = symmetric_eigen(gram) else {
        return Vec::new();
    };
    let n = rho.len();
    let constant = half.iter().position(|e| e.iter().all(|&p| p == 0));
    let linear: Vec<Option<usize>> = (0..n)
        .map(|i| {
            half.iter()
                .position(|e| e.iter().enumerate().all(|(v, &p)| p == u32::from(v == i)))
        })
        .collect();
    let position = |a: usize, beta: usize| gram_rows.iter().position(|&r| r == (a, beta));
    let mut suspects: Vec<Vec<f64>> = Vec::new();
    for v in vectors.column_iter().take(GRAM_SUSPECT_VECTORS) {
        let norm = v.norm();
        for a in 0..rows {
            let Some(zero) = constant.and_then(|beta| position(a, beta)) else {
                continue;
            };
            let readable = v[zero].abs() > 1e-8 * norm;
            if !readable {
                continue;
            }
            let y: Vec<f64> = (0..n)
                .map(|i| {
                    linear[i]
                        .and_then(|beta| position(a, beta))
                        .map_or(0.0, |p| rho[i] * v[p] / v[zero])
                })
                .collect();
            if y.iter().all(|c| c.is_finite()) && !suspects.contains(&y) {
                suspects.push(y);
            }
        }
    }
    suspects
}

/// min |s| s.t. T(Q) = θ_C, Q + s·I ⪰ 0 for a block's certificate with Q
/// over the Gram rows `gram_rows` ((a, β): the block's a-th row and the
/// monomial `half[β]`), in the coordinates of [`certify_block`]; `Ok`
/// with the optimal shift relative to the block's scaled size if it is
/// within tolerance.
fn certify_on_rows<S: MetriplecticSystem>(
    theta: &[f64],
    block: &[usize],
    half: &[&[u32]],
    gram_rows: &[(usize, usize)],
    rho: &[f64],
    scale: f64,
) -> Certification {
    let (mut suspects, mut conclusive) = (Vec::new(), false);
    let shift = certify_on_rows_into::<S>(
        theta,
        block,
        (half, gram_rows),
        rho,
        scale,
        (&mut suspects, &mut conclusive),
    );
    Certification {
        shift,
        suspects,
        conclusive,
    }
}

/// [`certify_on_rows`], pushing the states its Gram matrix points at
/// ([`gram_suspects`], in the certificate's y = x − c) onto `suspects` and
/// setting `conclusive` where [`Certification::conclusive`] holds.
fn certify_on_rows_into<S: MetriplecticSystem>(
    theta: &[f64],
    block: &[usize],
    (half, gram_rows): (&[&[u32]], &[(usize, usize)]),
    rho: &[f64],
    scale: f64,
    (suspects, conclusive): (&mut Vec<Vec<f64>>, &mut bool),
) -> std::result::Result<f64, String> {
    let exponents = S::METRIC_EXPONENTS;
    let size = gram_rows.len();
    if size > MAX_GRAM_SIDE {
        return Err(format!(
            "its sum-of-squares certificate needs a {size}×{size} Gram matrix, more than the \
             {MAX_GRAM_SIDE} supported"
        ));
    }
    let position = |e: &[u32]| exponents.iter().position(|x| *x == e);
    // In the region's unit-scaled states, as the searches' certificates
    // (`Layout`): Q = W Q′ W with W = diag(ρ^−β), the identities of x^α
    // multiplied by ρ^α, and the block normalised by its largest scaled
    // coefficient. For every x, ρ is at least 1: the tolerance allows
    // K(x) ⪰ −s‖Z(x/ρ)‖², which a ρ below 1 would loosen far out.
    let rho: Vec<f64> = rho.iter().map(|r| r.max(1.0)).collect();
    let weights: Vec<f64> = half.iter().map(|e| 1.0 / monomial_scale(&rho, e)).collect();
    let target_scale: Vec<f64> = exponents.iter().map(|e| monomial_scale(&rho, e)).collect();
    let scaled_size = block_pairs(block)
        .flat_map(|(_, _, j, k)| entry::<S>(theta, j, k).iter().zip(&target_scale))
        .map(|(c, r)| (c * r).abs())
        .fold(0.0_f64, f64::max);
    let scale = if scaled_size.is_normal() && scaled_size.is_finite() {
        scaled_size
    } else {
        scale
    };

    // Variables [s | svec Q′]; the objective |s| is the one regression row.
    let svec_size = svec_len(size);
    let objective = Regression {
        width: 1,
        rows: vec![1.0],
        target: vec![0.0],
    };
    let mut problem = L1Problem::new(objective, svec_size);
    let basis = exponents.len();
    let pairs: Vec<_> = block_pairs(block).collect();
    let mut entries = Vec::new();
    let mut rhs = vec![0.0; pairs.len() * basis];
    let mut sum = vec![0_u32; S::DIM];
    for (row_block, &(a, b, j, k)) in pairs.iter().enumerate() {
        let row = |alpha: usize| row_block * basis + alpha;
        // Normalised, so that the solver's absolute tolerances are relative.
        for ((target, &c), r) in rhs[row_block * basis..(row_block + 1) * basis]
            .iter_mut()
            .zip(entry::<S>(theta, j, k))
            .zip(&target_scale)
        {
            *target = c * r / scale;
        }
        let of_row = |row: usize| {
            gram_rows
                .iter()
                .enumerate()
                .filter(move |(_, &(r, _))| r == row)
                .map(|(p, &(_, beta))| (p, beta))
        };
        for (p, beta) in of_row(a) {
            for (q, gamma) in of_row(b) {
                let (e_beta, e_gamma) = (half[beta], half[gamma]);
                sum.iter_mut()
                    .zip(e_beta.iter().zip(e_gamma.iter()))
                    .for_each(|(s, (x, y))| *s = x + y);
                let Some(alpha) = position(&sum) else {
                    continue;
                };
                let c = weights[beta] * weights[gamma] * target_scale[alpha];
                // svec stores √2·Q_pq off the diagonal.
                let weight = if p == q { c } else { c / SQRT_2 };
                entries.push((row(alpha), 1 + svec_index(p, q), weight));
            }
        }
    }
    // A term no kept pair of rows produces: no Gram matrix has it.
    let mut reached = vec![false; rhs.len()];
    entries.iter().for_each(|&(row, _, _)| reached[row] = true);
    if let Some(row) = (0..rhs.len()).find(|&row| rhs[row] != 0.0 && !reached[row]) {
        let (_, _, j, k) = pairs[row / basis];
        *conclusive = rhs[row].abs() > SEARCH_ROUNDING;
        return Err(format!(
            "K[{j}][{k}] has a term of exponents {:?} that no sum of squares with these \
             diagonal entries can have",
            exponents[row % basis]
        ));
    }
    let matching = (entries.clone(), rhs.clone());
    let built = problem
        .constrain(Cone::Zero(rhs.len()), entries, rhs)
        .and_then(|_| {
            let mut psd: Vec<(usize, usize, f64)> =
                (0..svec_size).map(|i| (i, 1 + i, -1.0)).collect();
            psd.extend((0..size).map(|p| (svec_diagonal(p), 0, -1.0)));
            problem.constrain(Cone::Psd(size), psd, vec![0.0; svec_size])
        });
    if let Err(error) = built {
        return Err(format!(
            "the certificate program could not be built: {error}"
        ));
    }
    let solution = solve_l1(&problem, &certificate_settings())
        .map_err(|error| format!("the certificate program failed: {error}"))?;
    let gram = smat(size, &solution.variables()[1..]);
    suspects.extend(gram_suspects(&gram, block.len(), half, gram_rows, &rho));
    let s = solution.coefficients()[0] * scale;
    let verified = solution.status == SolveStatus::Solved
        || verify(&matching, &[(1, size)], solution.variables());
    if solution.status.is_usable() && verified && s <= CERTIFICATE_TOLERANCE * scale {
        Ok(solution.coefficients()[0])
    } else {
        Err(format!(
            "the best sum-of-squares Gram matrix of side {size} needs a shift s = {s:e} to be \
             positive semidefinite (solver status {}{})",
            solution.status,
            if verified {
                ""
            } else {
                ", and its Gram matrix does not check to 1e-8"
            }
        ))
    }
}

/// The Gram rows (a, β) of a block's certificate that can be non-zero:
/// row a's monomial x^β, as an index into `half`. Z(x)ᵀQZ(x) gives the
/// diagonal entry K_jj its coefficient of x^{2β} from Q's diagonal entry
/// at (a, β) and from pairs (a, β′), (a, β″) with β′ + β″ = 2β. Where no
/// such pair remains and K_jj has no x^{2β}, that diagonal entry is 0,
/// and in a PSD Q so is its whole row: it is dropped, until no more can
/// be (Löfberg's diagonal inconsistency, a facial reduction). A
/// certificate exists on the rows kept exactly when it does on all, but
/// on all the program has no interior point: [[1 + a⁶b², 0], [0, 1]]
/// over the 15 monomials of degree ≤ 4 ended `AlmostSolved` with Gram
/// matrices that did not check, and the metric was refused (a probe).
fn consistent_rows<S: MetriplecticSystem>(
    theta: &[f64],
    block: &[usize],
    half: &[&[u32]],
) -> Vec<(usize, usize)> {
    let exponents = S::METRIC_EXPONENTS;
    let doubled = |e: &[u32]| e.iter().map(|p| 2 * p).collect::<Vec<u32>>();
    let mut rows = Vec::new();
    for (a, &j) in block.iter().enumerate() {
        let diagonal = entry::<S>(theta, j, j);
        let present = |target: &[u32]| {
            exponents
                .iter()
                .zip(diagonal)
                .any(|(e, c)| *c != 0.0 && *e == target)
        };
        let mut kept = vec![true; half.len()];
        let mut changed = true;
        while changed {
            changed = false;
            for beta in 0..half.len() {
                if !kept[beta] {
                    continue;
                }
                let target = doubled(half[beta]);
                if present(&target) {
                    continue;
                }
                let paired = (0..half.len()).any(|b1| {
                    (b1 + 1..half.len()).any(|b2| {
                        kept[b1]
                            && kept[b2]
                            && half[b1]
                                .iter()
                                .zip(half[b2])
                                .map(|(x, y)| x + y)
                                .eq(target.iter().copied())
                    })
                });
                if !paired {
                    kept[beta] = false;
                    changed = true;
                }
            }
        }
        rows.extend(
            (0..half.len())
                .filter(|&beta| kept[beta])
                .map(|beta| (a, beta)),
        );
    }
    rows
}

/// A state where the block has a negative eigenvalue, probed on spheres of
/// growing radius, as the error to report; `None` if none was found.
fn witness<S: MetriplecticSystem>(
    what: &str,
    theta: &[f64],
    block: &[usize],
    scale: f64,
) -> Option<Error> {
    let n = S::DIM;
    let mut rng = ChaCha8Rng::seed_from_u64(0x5eed);
    let mut metric = vec![0.0; n * n];
    let mut worst: Option<(f64, Vec<f64>, Vec<f64>)> = None;
    for radius in [0.5, 1.0, 2.0, 5.0, 10.0, 100.0] {
        for _ in 0..200 {
            let x: Vec<f64> = (0..n)
                .map(|_| radius * rng.random_range(-1.0..1.0))
                .collect();
            S::metric_value(&x, theta, &mut metric);
            let (eigenvalue, direction) = smallest_eigen(block_matrix(&metric, n, block));
            if eigenvalue < -EIGENVALUE_TOLERANCE * scale
                && worst.as_ref().is_none_or(|(w, _, _)| eigenvalue < *w)
            {
                worst = Some((eigenvalue, direction, x));
            }
        }
        if worst.is_some() {
            break;
        }
    }
    worst.map(|(eigenvalue, direction, x)| {
        not_positive(what, eigenvalue, (n, block, &direction), Some(x))
    })
}

/// The metric basis's largest total degree (at least 1).
fn metric_degree<S: MetriplecticSystem>() -> u32 {
    S::METRIC_EXPONENTS
        .iter()
        .map(|e| e.iter().sum::<u32>())
        .max()
        .unwrap_or(0)
        .max(1)
}

/// ±e_v for every state variable, then ±(1, …, 1): the directions every
/// witness search tries before its random ones.
fn axes_and_diagonals(n: usize) -> Vec<Vec<f64>> {
    let mut directions: Vec<Vec<f64>> = (0..n)
        .flat_map(|v| [1.0, -1.0].map(|sign| embed(n, &[v], &[sign])))
        .collect();
    directions.push(vec![1.0; n]);
    directions.push(vec![-1.0; n]);
    directions
}

/// Largest state component `vertex_witness` tries: the metric's monomials
/// stay within f64 (|x|^degree ≤ 1e200) and far from any data.
const WITNESS_MAGNITUDE_EXPONENT: f64 = 200.0;

/// A state where the block is indefinite although its certificate passed
/// within tolerance, aimed where that can show: far out (or near zero)
/// along the directions in which a single term of uᵀK(x)u dominates.
///
/// For each u in {e_j, e_j ± e_k} of the block, p_u(x) = uᵀK(x)u must be a
/// non-negative polynomial, so every vertex of its Newton polytope (the
/// hull of its exponents) is an even monomial with a positive coefficient.
/// A vertex that is not — the maximiser of a generic linear form d·α over
/// the exponents, here ±e_v, ±(1, …, 1) and four random forms — dominates
/// p_u at x_i = ±exp(t·d_i) as t grows, and those states are tried. Only a
/// state where p_u is negative beyond rounding (1e-9 of Σ|c_α x^α|) is
/// reported, so no metric that is positive semidefinite is ever refused.
fn vertex_witness<S: MetriplecticSystem>(
    what: &str,
    theta: &[f64],
    block: &[usize],
    scale: f64,
) -> Option<Error> {
    let n = S::DIM;
    let exponents = S::METRIC_EXPONENTS;
    let degree = metric_degree::<S>();
    let largest_log = WITNESS_MAGNITUDE_EXPONENT / f64::from(degree) * std::f64::consts::LN_10;
    // Generic linear forms: a small seeded perturbation makes each
    // maximiser unique.
    let mut rng = ChaCha8Rng::seed_from_u64(0x7e47);
    let mut forms = axes_and_diagonals(n);
    for _ in 0..4 {
        forms.push((0..n).map(|_| rng.random_range(-1.0..1.0)).collect());
    }
    for form in &mut forms {
        form.iter_mut()
            .for_each(|d| *d += 1e-3 * rng.random_range(-1.0..1.0));
    }
    let mut directions: Vec<Vec<f64>> = Vec::new();
    for (a, &j) in block.iter().enumerate() {
        directions.push(embed(n, &[j], &[1.0]));
        for &k in &block[a + 1..] {
            directions.push(embed(n, &[j, k], &[1.0, 1.0]));
            directions.push(embed(n, &[j, k], &[1.0, -1.0]));
        }
    }
    let mut metric = vec![0.0; n * n];
    for u in &directions {
        // Coefficients of uᵀK(x)u.
        let p: Vec<f64> = (0..exponents.len())
            .map(|alpha| {
                block_pairs(block)
                    .map(|(_, _, j, k)| {
                        let weight = if j == k { 1.0 } else { 2.0 };
                        weight * u[j] * u[k] * entry::<S>(theta, j, k)[alpha]
                    })
                    .sum()
            })
            .collect();
        let support: Vec<usize> = (0..p.len())
            .filter(|&alpha| p[alpha].abs() > 1e-12 * scale)
            .collect();
        for form in &forms {
            let level = |alpha: usize| -> f64 {
                exponents[alpha]
                    .iter()
                    .zip(form)
                    .map(|(&e, d)| f64::from(e) * d)
                    .sum()
            };
            let Some(&vertex) = support
                .iter()
                .max_by(|&&a, &&b| level(a).total_cmp(&level(b)))
            else {
                continue;
            };
            let odd = exponents[vertex].iter().position(|e| e % 2 == 1);
            if p[vertex] > 0.0 && odd.is_none() {
                continue;
            }
            // Signs that make the vertex's term negative.
            let mut signs = vec![1.0; n];
            if p[vertex] > 0.0 {
                if let Some(v) = odd {
                    signs[v] = -1.0;
                }
            }
            let reach = form.iter().fold(0.0_f64, |m, d| m.max(d.abs()));
            for step in (0..=24).rev() {
                let t = largest_log / reach / f64::from(1_u32 << step);
                let x: Vec<f64> = (0..n).map(|i| signs[i] * (t * form[i]).exp()).collect();
                S::metric_value(&x, theta, &mut metric);
                let value: f64 = (0..n)
                    .flat_map(|j| (0..n).map(move |k| (j, k)))
                    .map(|(j, k)| u[j] * metric[j * n + k] * u[k])
                    .sum();
                let size: f64 = p
                    .iter()
                    .zip(exponents)
                    .map(|(c, e)| {
                        c.abs()
                            * x.iter()
                                .zip(e.iter())
                                .map(|(xi, &ei)| xi.abs().powi(ei as i32))
                                .product::<f64>()
                    })
                    .sum();
                if value.is_finite() && size.is_finite() && value < -1e-9 * size {
                    let (eigenvalue, direction) = smallest_eigen(block_matrix(&metric, n, block));
                    return Some(not_positive(
                        what,
                        eigenvalue,
                        (n, block, &direction),
                        Some(x),
                    ));
                }
            }
        }
    }
    None
}

/// Random directions `ray_witness` probes besides the axes and diagonals.
const RAY_DIRECTIONS: usize = 32;

/// A state where the block's smallest eigenvalue is below −1e-9 times
/// both the block's coefficient scale times ‖Z(x)‖² (Z the monomials of
/// half the metric's degree; the unit in which the certificate bounds the
/// shift) and the largest entry's Σ|c_α x^α| (its rounding), probed along
/// rays: ±e_v, ±(1, …, 1) and `RAY_DIRECTIONS` seeded random directions, at
/// radii from ½, a factor √10 apart (the band where such a violation shows
/// can be narrower than a decade), up to |x|^degree = 1e200.
///
/// A certified shift of s allows Gram entries off by √s: with s at its
/// tolerance of 1e-8, K = [[1 + q², 1.0001 q], [1.0001 q, 1]] passed
/// (shift 1e-8, Gram entry 1e-4 off) although it is indefinite for
/// |q| > 71, along (1, −q), which no fixed u of [`vertex_witness`] follows,
/// and a free energy could fall there. The smallest eigenvalue of the whole
/// block does follow it. Coefficients below 1e-12 of `scale` are left out,
/// as [`vertex_witness`] leaves them: they are the searches' rounding. A
/// fit's own residual (1e-12 of the scale, times ‖Z‖²) is a thousand times
/// below the threshold, so no searched metric is refused for it.
fn ray_witness<S: MetriplecticSystem>(
    what: &str,
    theta: &[f64],
    block: &[usize],
    scale: f64,
) -> Option<Error> {
    let n = S::DIM;
    let exponents = S::METRIC_EXPONENTS;
    let degree = metric_degree::<S>();
    // The block's coefficients above rounding, and their magnitudes.
    let m = exponents.len();
    let mut cleaned = vec![0.0; theta.len()];
    for (_, _, j, k) in block_pairs(block) {
        let pair = metric_pair_index(n, j, k);
        for alpha in 0..m {
            let c = theta[pair * m + alpha];
            if c.abs() > 1e-12 * scale {
                cleaned[pair * m + alpha] = c;
            }
        }
    }
    let magnitudes: Vec<f64> = cleaned.iter().map(|c| c.abs()).collect();
    let half: Vec<&[u32]> = exponents
        .iter()
        .copied()
        .filter(|e| 2 * e.iter().sum::<u32>() <= degree)
        .collect();
    let (mut metric, mut sizes) = (vec![0.0; n * n], vec![0.0; n * n]);
    let mut shifted = vec![0.0; block.len() * block.len()];
    for x in ray_states::<S>() {
        let magnitude: Vec<f64> = x.iter().map(|v| v.abs()).collect();
        S::metric_value(&x, &cleaned, &mut metric);
        S::metric_value(&magnitude, &magnitudes, &mut sizes);
        let rounding = largest_entry(&sizes, n, block);
        let gram_unit = scale
            * half
                .iter()
                .map(|e| monomial_scale(&magnitude, e).powi(2))
                .sum::<f64>();
        let threshold = 1e-9 * rounding.max(gram_unit);
        // A Cholesky factor of K + threshold·I rules the state out
        // cheaply (thousands of states per block); only where it fails
        // is the eigenvalue computed.
        let m = block.len();
        for (a, &j) in block.iter().enumerate() {
            for (b, &k) in block.iter().enumerate() {
                shifted[a * m + b] = metric[j * n + k];
            }
            shifted[a * m + a] += threshold;
        }
        if !threshold.is_finite() || has_cholesky_factor(&mut shifted[..m * m], m) {
            continue;
        }
        let (eigenvalue, local) = smallest_eigen(block_matrix(&metric, n, block));
        if eigenvalue.is_finite() && eigenvalue < -threshold {
            return Some(not_positive(what, eigenvalue, (n, block, &local), Some(x)));
        }
    }
    None
}

/// Relative certificate shift above which [`descent_witness`] runs on a
/// certified block: its threshold is 1e-9 of the same unit.
const DESCENT_SHIFT: f64 = 1e-9;

/// The smallest eigenvalue of K(x), each entry divided by the square root
/// of its rows' rounding (each row's largest Σ|c_α x^α|, at least
/// [`BALANCE_FLOOR`] of the largest row's), below −this is a violation: evaluating K rounds by about 1e-16 of that, so what is left
/// is the metric's, not the arithmetic's.
const EVALUATION_TOLERANCE: f64 = 1e-9;

/// Starting states of [`descent_witness`] besides the region's centre.
const DESCENT_STARTS: usize = 24;

/// The seeded starts of [`descent_witness`]: the region's centre (the
/// origin without one) and states in its box, twice and ten times as far.
fn descent_starts<S: MetriplecticSystem>() -> Vec<Vec<f64>> {
    let n = S::DIM;
    let (centre, rho) = region_coordinates::<S>();
    let rho: Vec<f64> = rho.iter().map(|r| r.max(1.0)).collect();
    let centre = centre.unwrap_or_else(|| vec![0.0; n]);
    let mut rng = ChaCha8Rng::seed_from_u64(0xde5c);
    let mut starts = vec![centre.clone()];
    for spread in [1.0, 2.0, 10.0] {
        for _ in 0..DESCENT_STARTS / 3 {
            starts.push(
                (0..n)
                    .map(|i| centre[i] + spread * rho[i] * rng.random_range(-1.0..1.0))
                    .collect(),
            );
        }
    }
    starts
}
/// Gradient steps from each start.
const DESCENT_STEPS: usize = 60;

/// K(x)'s smallest eigenvalue and direction where K is negative beyond
/// the rounding of evaluating it ([`Judge::at`]); `None` where it is not.
type Violation = Option<(f64, Vec<f64>)>;

/// Judges K at states against the rounding of evaluating it there.
struct Judge<'a> {
    theta: &'a [f64],
    magnitudes: Vec<f64>,
    block: &'a [usize],
    /// θ with each entry's non-zero coefficients replaced by
    /// [`SEARCH_NOISE`] times that entry's largest |θ|: evaluated at |x|,
    /// how far noise in the coefficients can move each entry.
    noise: Vec<f64>,
    metric: Vec<f64>,
    sizes: Vec<f64>,
    moved: Vec<f64>,
}

impl<'a> Judge<'a> {
    fn new<S: MetriplecticSystem>(theta: &'a [f64], block: &'a [usize]) -> Self {
        let n = S::DIM;
        let m = S::METRIC_EXPONENTS.len();
        let mut noise = vec![0.0; theta.len()];
        for (_, _, j, k) in block_pairs(block) {
            let range = metric_pair_index(n, j, k) * m..(metric_pair_index(n, j, k) + 1) * m;
            let largest = theta[range.clone()]
                .iter()
                .fold(0.0_f64, |l, c| l.max(c.abs()));
            for (out, c) in noise[range.clone()].iter_mut().zip(&theta[range]) {
                if *c != 0.0 {
                    *out = SEARCH_NOISE * largest;
                }
            }
        }
        Self {
            theta,
            magnitudes: theta.iter().map(|c| c.abs()).collect(),
            block,
            noise,
            metric: vec![0.0; n * n],
            sizes: vec![0.0; n * n],
            moved: vec![0.0; n * n],
        }
    }

    /// The smallest eigenvalue of K(x) with each entry divided by the
    /// square root of its rows' rounding (scale-free), and K's own where
    /// that is below −[`EVALUATION_TOLERANCE`] (K then is negative too:
    /// the scaling is a congruence) and K's is below what
    /// [`SEARCH_NOISE`] in the coefficients can do; `None` where K is not
    /// finite.
    fn at<S: MetriplecticSystem>(&mut self, x: &[f64]) -> Option<(f64, Violation)> {
        let (n, block) = (S::DIM, self.block);
        let scaled = self.scaled::<S>(x);
        let k = block_matrix(&self.metric, n, block);
        let (scaled_lowest, _) = smallest_eigen(scaled);
        if !scaled_lowest.is_finite() {
            return None;
        }
        if scaled_lowest >= -EVALUATION_TOLERANCE {
            return Some((scaled_lowest, None));
        }
        // Also beyond what noise in the coefficients could do there: K
        // plus each row's largest possible move on its diagonal is still
        // indefinite. A classical metric, singular everywhere, has
        // coefficients of 1e-17 where it has none, and its zero rows read
        // them as their own terms.
        let magnitude: Vec<f64> = x.iter().map(|v| v.abs()).collect();
        S::metric_value(&magnitude, &self.noise, &mut self.moved);
        let mut robust = k.clone();
        for (a, &j) in block.iter().enumerate() {
            robust[(a, a)] += block.iter().map(|&k| self.moved[j * n + k]).sum::<f64>();
        }
        let robust_lowest = smallest_eigen(robust).0;
        if robust_lowest.is_nan() || robust_lowest >= 0.0 {
            return Some((scaled_lowest, None));
        }
        let (lowest, direction) = smallest_eigen(k);
        let violation = (lowest.is_finite() && lowest < 0.0).then_some((lowest, direction));
        Some((scaled_lowest, violation))
    }
}

impl Judge<'_> {
    /// K(x) with entry (a, b) divided by √(D_a D_b), D_a row a's rounding;
    /// leaves K(x) in `metric` and the entries' sizes in `sizes`.
    fn scaled<S: MetriplecticSystem>(&mut self, x: &[f64]) -> DMatrix<f64> {
        let (n, block) = (S::DIM, self.block);
        S::metric_value(x, self.theta, &mut self.metric);
        let magnitude: Vec<f64> = x.iter().map(|v| v.abs()).collect();
        S::metric_value(&magnitude, &self.magnitudes, &mut self.sizes);
        // Each row's rounding: its largest entry's Σ|c_α x^α|, so that an
        // entry's own rounding is at most ε after the scaling; at least
        // `BALANCE_FLOOR` of the largest row's, as when balancing, so that
        // a zero row coupled at the searches' rounding stays acceptable.
        let mut root: Vec<f64> = block
            .iter()
            .map(|&j| {
                block
                    .iter()
                    .map(|&k| self.sizes[j * n + k])
                    .fold(f64::MIN_POSITIVE, f64::max)
            })
            .collect();
        let floor = BALANCE_FLOOR * root.iter().copied().fold(0.0_f64, f64::max);
        root.iter_mut().for_each(|r| *r = r.max(floor).sqrt());
        let metric = &self.metric;
        DMatrix::from_fn(block.len(), block.len(), |a, b| {
            metric[block[a] * n + block[b]] / (root[a] * root[b])
        })
    }

    /// Whether the scaled K(x) minus `margin`·I has a Cholesky factor (is
    /// positive definite): a cheap test that rules a state out before any
    /// eigenvalue is computed (an eigensolve per ray state doubled the
    /// rigid-body drag example's time).
    fn clear<S: MetriplecticSystem>(&mut self, x: &[f64], margin: f64) -> bool {
        let mut scaled = self.scaled::<S>(x);
        let m = scaled.nrows();
        for a in 0..m {
            scaled[(a, a)] -= margin;
        }
        let mut packed: Vec<f64> = scaled.transpose().iter().copied().collect();
        packed.iter().all(|v| v.is_finite()) && has_cholesky_factor(&mut packed, m)
    }
}

/// A searched metric's coefficients are off by up to about this fraction
/// of each entry's largest (measured at 1e-17 to 1e-16 on the classical
/// body's searched metric): a state is a violation only if K is still
/// indefinite with each diagonal entry raised by what that noise in the
/// row's non-zero coefficients can add there.
const SEARCH_NOISE: f64 = 1e-14;

/// [`Judge::at`] along the rays of [`ray_witness`]: a state far out where
/// K is negative beyond the rounding of evaluating it, though within the
/// certificate's unit there. 1 + 10⁻³a + a⁶b² is negative for a < −1000
/// on b = 0, where it grows more slowly than ‖Z‖² ~ a⁸, and its
/// certificate on all Gram rows needs a shift of 1e-20.
fn far_witness<S: MetriplecticSystem>(what: &str, theta: &[f64], block: &[usize]) -> Option<Error> {
    let n = S::DIM;
    let mut judge = Judge::new::<S>(theta, block);
    for x in ray_states::<S>() {
        if judge.clear::<S>(&x, -EVALUATION_TOLERANCE) {
            continue;
        }
        if let Some((_, Some((eigenvalue, direction)))) = judge.at::<S>(&x) {
            return Some(not_positive(
                what,
                eigenvalue,
                (n, block, &direction),
                Some(x),
            ));
        }
    }
    None
}

/// The states [`ray_witness`] probes: along ±e_v, ±(1, …, 1) and
/// `RAY_DIRECTIONS` seeded directions, at radii from ½, a factor √10
/// apart, up to |x|^degree = 1e200.
fn ray_states<S: MetriplecticSystem>() -> impl Iterator<Item = Vec<f64>> {
    let n = S::DIM;
    let mut rng = ChaCha8Rng::seed_from_u64(0x4a75);
    let mut directions = axes_and_diagonals(n);
    for _ in 0..RAY_DIRECTIONS {
        directions.push((0..n).map(|_| rng.random_range(-1.0..1.0)).collect());
    }
    let largest_radius = 10_f64.powf(WITNESS_MAGNITUDE_EXPONENT / f64::from(metric_degree::<S>()));
    directions.into_iter().flat_map(move |direction| {
        let length = direction.iter().map(|d| d * d).sum::<f64>().sqrt();
        let unit: Vec<f64> = direction.iter().map(|d| d / length).collect();
        std::iter::successors(Some(0.5), |r| Some(r * 10_f64.sqrt()))
            .take_while(move |&r| r <= largest_radius && length > 0.0)
            .map(move |r| unit.iter().map(|u| u * r).collect())
    })
}

/// A state where K is negative beyond the rounding of evaluating it: its
/// smallest eigenvalue with each entry divided by the square root of its
/// rows' rounding (each row's largest Σ|c_α x^α|) below
/// −[`EVALUATION_TOLERANCE`], found by descent from `starts`.
///
/// The certificate's tolerance also allows a narrow band where K is
/// negative: with K₀₀ = (x − 1000)² − 0.05 on a region of radius 3000,
/// negative only for |x − 1000| < 0.22, E fell at 0.05·|∇E|² there, and
/// no fixed set of states sees a band that narrow (a probe). From each
/// start (the Gram matrix's suspects, or [`descent_starts`]), gradient
/// steps with a backtracking line search lower that scaled eigenvalue:
/// scale-free, so that the descent follows a small entry's dip rather than
/// a large one's growth. The threshold was 1e-9 of the certificate's unit
/// too (its largest coefficient times ‖Z((x − c)/ρ)‖²), which far from the
/// centre exceeds K's own terms: K = (q − 1000)² − δ passed at q = 1000
/// for δ up to 2000 (a probe); now only negativity within 1e-9 of the
/// terms K is evaluated from passes. With `within`, only states of that
/// region are evaluated (a certificate on the region says nothing beyond).
fn descent_witness<S: MetriplecticSystem>(
    what: &str,
    theta: &[f64],
    block: &[usize],
    within: Option<&Region>,
    starts: Vec<Vec<f64>>,
) -> Option<Error> {
    let n = S::DIM;
    let (_, rho) = region_coordinates::<S>();
    let rho: Vec<f64> = rho.iter().map(|r| r.max(1.0)).collect();
    let mut judge = Judge::new::<S>(theta, block);
    let mut evaluate = |x: &[f64]| -> Option<(f64, Violation)> {
        if within.is_some_and(|region| !region.contains(x)) {
            return None;
        }
        judge.at::<S>(x)
    };
    for start in starts {
        let mut x = start;
        let Some(mut current) = evaluate(&x) else {
            continue;
        };
        // Each line search starts at 4 times the last accepted step.
        let mut last_step: f64 = 0.25;
        for _ in 0..DESCENT_STEPS {
            if current.1.is_some() {
                break;
            }
            // Central differences, each on its variable's own scale.
            let gradient: Vec<f64> = (0..n)
                .map(|i| {
                    let h = 1e-6 * (x[i].abs() + rho[i]);
                    let mut probe = x.clone();
                    probe[i] = x[i] + h;
                    let up = evaluate(&probe).map_or(f64::NAN, |e| e.0);
                    probe[i] = x[i] - h;
                    let down = evaluate(&probe).map_or(f64::NAN, |e| e.0);
                    (up - down) / (2.0 * h)
                })
                .collect();
            if gradient.iter().any(|g| !g.is_finite()) {
                break;
            }
            // In units of ρ, so that a step moves every axis alike.
            let length = gradient
                .iter()
                .zip(&rho)
                .map(|(g, r)| (g * r).powi(2))
                .sum::<f64>()
                .sqrt();
            if length == 0.0 {
                break;
            }
            let mut step = (4.0 * last_step).min(1.0);
            let mut accepted = None;
            while step > 1e-12 {
                let trial: Vec<f64> = (0..n)
                    .map(|i| x[i] - step * rho[i] * rho[i] * gradient[i] / length)
                    .collect();
                if let Some(next) = evaluate(&trial).filter(|next| next.0 < current.0) {
                    accepted = Some((trial, next));
                    break;
                }
                step *= 0.5;
            }
            let Some((trial, next)) = accepted else {
                break;
            };
            // Settled: the scale-free value no longer moves.
            let settled = current.0 - next.0 <= 1e-12 * (1.0 + current.0.abs());
            (x, current, last_step) = (trial, next, step);
            if settled {
                break;
            }
        }
        if let Some((eigenvalue, direction)) = current.1 {
            return Some(not_positive(
                what,
                eigenvalue,
                (n, block, &direction),
                Some(x),
            ));
        }
    }
    None
}

/// The largest entry of the n × n `sizes` (row-major, each entry's
/// Σ|c_α x^α|) on `block`: the rounding of evaluating the block there.
fn largest_entry(sizes: &[f64], n: usize, block: &[usize]) -> f64 {
    block
        .iter()
        .flat_map(|&j| block.iter().map(move |&k| sizes[j * n + k]))
        .fold(0.0_f64, f64::max)
}

/// Whether the symmetric m × m matrix `a` (row-major) has a Cholesky
/// factor, i.e. is positive definite to rounding; overwrites its lower
/// triangle with the factor as far as it gets.
fn has_cholesky_factor(a: &mut [f64], m: usize) -> bool {
    for i in 0..m {
        for j in 0..=i {
            let sum = a[i * m + j] - (0..j).map(|k| a[i * m + k] * a[j * m + k]).sum::<f64>();
            if i == j {
                if sum.is_nan() || sum <= 0.0 {
                    return false;
                }
                a[i * m + i] = sum.sqrt();
            } else {
                a[i * m + j] = sum / a[j * m + j];
            }
        }
    }
    true
}

/// Checks that K(x) ⪰ 0 on the region of `certificate` by finding Gram
/// matrices of its lower blocks (the S-procedure), or says where it fails.
fn check_on_region<S: MetriplecticSystem>(
    what: &str,
    theta: &[f64],
    certificate: &RegionCertificate,
) -> Result<()> {
    let scale = theta.iter().fold(0.0_f64, |m, c| m.max(c.abs()));
    if scale == 0.0 {
        return Ok(());
    }
    // A constant metric is PSD on the region iff it is PSD: its error
    // names no state (a region witness would be an arbitrary one).
    if blocks::<S>(theta)
        .iter()
        .all(|block| is_constant::<S>(theta, block))
    {
        return check_everywhere::<S>(what, theta);
    }
    let layout = Layout::of::<S>(S::SOS_REDUCED);
    layout.check::<S>()?;
    let states: Vec<usize> = (0..S::DIM).collect();
    // Certified on `certified` (θ or its balanced form); states are judged
    // on K's own θ, as everywhere.
    let check = |certified: &[f64]| {
        let scale = certified.iter().fold(0.0_f64, |m, c| m.max(c.abs()));
        let region = Some(&certificate.region);
        match certify_on_region::<S>(certified, &layout, scale) {
            // The tolerance also allows a narrow band where K is negative.
            Ok(()) => {
                match descent_witness::<S>(what, theta, &states, region, descent_starts::<S>()) {
                    Some(error) => Err(error),
                    None => Ok(()),
                }
            }
            Err(reason) => Err(region_witness::<S>(what, certified, certificate, scale)
                .or_else(|| {
                    descent_witness::<S>(what, theta, &states, region, descent_starts::<S>())
                })
                .unwrap_or(Error::MetricNotCertified {
                    what: what.to_owned(),
                    reason: format!("{reason}; K(x) ⪰ 0 is required on the region only"),
                })),
        }
    };
    match Balanced::of::<S>(theta, &states, true) {
        Some(balanced) => {
            check(&balanced.theta).map_err(|error| balanced.restore::<S>(theta, &states, error))
        }
        None => check(theta),
    }
}

/// min |s| s.t. K(θ) = Σ_lower g·Zᵀ Q Z on the targets, Q + s·I ⪰ 0 for
/// every lower block: its optimum is 0 exactly when the lower certificate
/// exists.
fn certify_on_region<S: MetriplecticSystem>(
    theta: &[f64],
    layout: &Layout,
    scale: f64,
) -> std::result::Result<(), String> {
    let n = S::DIM;
    let basis = S::METRIC_EXPONENTS.len();
    // In the layout's coordinates (centred for a region far from the origin).
    let theta = layout.centred_metric(theta);
    let sizes: Vec<usize> = layout.lower.iter().map(|b| b.size(n)).collect();
    if let Some(&size) = sizes.iter().find(|&&size| size > MAX_GRAM_SIDE) {
        return Err(format!(
            "its region certificate needs a {size}×{size} Gram matrix, more than the \
             {MAX_GRAM_SIDE} supported"
        ));
    }
    let mut offsets = Vec::with_capacity(sizes.len());
    let mut next = 1;
    for &size in &sizes {
        offsets.push(next);
        next += svec_len(size);
    }
    // In the region's unit-scaled states (`Layout`): Gram variables Q′ with
    // Q = W Q′ W, target α's rows multiplied by ρ^α, and the metric
    // normalised by its largest scaled coefficient, so that the solver's
    // absolute tolerances are relative in any units.
    let weights: Vec<Vec<f64>> = layout
        .lower
        .iter()
        .map(|block| layout.gram_weights(block, n))
        .collect();
    let scaled_size = (0..n * (n + 1) / 2)
        .flat_map(|pair| (0..basis).map(move |alpha| (pair, alpha)))
        .map(|(pair, alpha)| (theta[pair * basis + alpha] * layout.target_scale(alpha)).abs())
        .fold(0.0_f64, f64::max);
    let scale = if scaled_size.is_normal() && scaled_size.is_finite() {
        scaled_size
    } else {
        scale
    };
    let objective = Regression {
        width: 1,
        rows: vec![1.0],
        target: vec![0.0],
    };
    let mut problem = L1Problem::new(objective, next - 1);
    let mut entries = Vec::new();
    let mut rhs = Vec::new();
    for j in 0..n {
        for k in j..n {
            let pair = metric_pair_index(n, j, k);
            for alpha in 0..layout.targets {
                let row = rhs.len();
                let target_scale = layout.target_scale(alpha);
                // Normalised, so that the solver's absolute tolerances are
                // relative: a tiny indefinite K must not pass as feasible.
                rhs.push(if alpha < basis {
                    theta[pair * basis + alpha] * target_scale / scale
                } else {
                    0.0
                });
                for ((block, &offset), w) in layout.lower.iter().zip(&offsets).zip(&weights) {
                    let m = block.basis.len();
                    for (beta, gamma, c) in block.matching.entries(alpha) {
                        let (a, b) = (j * m + beta, k * m + gamma);
                        let c = c * w[a] * w[b] * target_scale;
                        let weight = if a == b { c } else { c / SQRT_2 };
                        entries.push((row, offset + svec_index(a, b), weight));
                    }
                }
            }
        }
    }
    let matching = (entries.clone(), rhs.clone());
    let mut built = problem
        .constrain(Cone::Zero(rhs.len()), entries, rhs)
        .map(|_| ());
    for (&size, &offset) in sizes.iter().zip(&offsets) {
        built = built.and_then(|()| {
            let svec_size = svec_len(size);
            let mut psd: Vec<(usize, usize, f64)> =
                (0..svec_size).map(|i| (i, offset + i, -1.0)).collect();
            psd.extend((0..size).map(|p| (svec_diagonal(p), 0, -1.0)));
            problem
                .constrain(Cone::Psd(size), psd, vec![0.0; svec_size])
                .map(|_| ())
        });
    }
    if let Err(error) = built {
        return Err(format!(
            "the region certificate program could not be built: {error}"
        ));
    }
    let solution = solve_l1(&problem, &certificate_settings())
        .map_err(|error| format!("the region certificate program failed: {error}"))?;
    let s = solution.coefficients()[0] * scale;
    let grams: Vec<(usize, usize)> = offsets.iter().copied().zip(sizes.iter().copied()).collect();
    let verified =
        solution.status == SolveStatus::Solved || verify(&matching, &grams, solution.variables());
    if solution.status.is_usable() && verified && s <= CERTIFICATE_TOLERANCE * scale {
        Ok(())
    } else {
        Err(format!(
            "the best S-procedure certificate on the region needs a shift s = {s:e} to be \
             positive semidefinite (solver status {}{})",
            solution.status,
            if verified {
                ""
            } else {
                ", and its Gram matrices do not check to 1e-8"
            }
        ))
    }
}

/// Whether a certificate solution holds on its own, to
/// `CERTIFICATE_TOLERANCE` of the normalised metric: the matching rows
/// `rhs − A x` vanish and every Gram matrix (`(offset, side)` of its svec
/// in x) is positive semidefinite. `AlmostSolved` allows a feasibility
/// residual of 1e-4, which could hide an indefinite metric, so such a
/// solve counts only if its Gram matrices pass this check.
fn verify(
    (entries, rhs): &(Vec<(usize, usize, f64)>, Vec<f64>),
    grams: &[(usize, usize)],
    x: &[f64],
) -> bool {
    let mut residual = rhs.clone();
    for &(row, column, value) in entries {
        match (residual.get_mut(row), x.get(column)) {
            (Some(r), Some(v)) => *r -= value * v,
            _ => return false,
        }
    }
    if residual
        .iter()
        .any(|r| r.is_nan() || r.abs() > CERTIFICATE_TOLERANCE)
    {
        return false;
    }
    grams.iter().all(|&(offset, side)| {
        let Some(packed) = x.get(offset..offset + svec_len(side)) else {
            return false;
        };
        let smallest = smat(side, packed).symmetric_eigenvalues().min();
        smallest >= -CERTIFICATE_TOLERANCE
    })
}

/// A state in the region where K(x) has a negative eigenvalue, as the
/// error to report; `None` if none was found.
fn region_witness<S: MetriplecticSystem>(
    what: &str,
    theta: &[f64],
    certificate: &RegionCertificate,
    scale: f64,
) -> Option<Error> {
    let n = S::DIM;
    let (low, high) = certificate.region.bounding_box();
    let mut rng = ChaCha8Rng::seed_from_u64(0x5eed);
    let mut metric = vec![0.0; n * n];
    let mut worst: Option<(f64, Vec<f64>, Vec<f64>)> = None;
    for _ in 0..2000 {
        let x: Vec<f64> = low
            .iter()
            .zip(&high)
            .map(|(l, h)| l + (h - l) * rng.random::<f64>())
            .collect();
        if !certificate.region.contains(&x) {
            continue;
        }
        S::metric_value(&x, theta, &mut metric);
        let (eigenvalue, direction) = smallest_eigen(DMatrix::from_row_slice(n, n, &metric));
        if eigenvalue < -EIGENVALUE_TOLERANCE * scale
            && worst.as_ref().is_none_or(|(w, _, _)| eigenvalue < *w)
        {
            worst = Some((eigenvalue, direction, x));
        }
    }
    worst.map(|(eigenvalue, direction, x)| Error::MetricNotPositive {
        what: what.to_owned(),
        eigenvalue,
        direction,
        state: Some(x),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_system::Quadratic2d;

    fn theta(entries: &[(usize, f64)]) -> Vec<f64> {
        let mut theta = vec![0.0; Quadratic2d::metric_coefficient_count()];
        for &(i, v) in entries {
            theta[i] = v;
        }
        theta
    }

    // Pairs (0,0), (0,1), (1,1) at offsets 0, 6, 12; monomials 1, q, p, q², qp, p².

    /// The independent check of an `AlmostSolved` certificate: one matching
    /// row k = Q₀₀ + Q₁₁ over a 2×2 Gram matrix (svec at 1..4).
    #[test]
    fn an_almost_solved_certificate_counts_only_if_its_gram_matrices_check() {
        let matching = |k: f64| (vec![(0, 1, 1.0), (0, 3, 1.0)], vec![k]);
        // Q = diag(0.5, 0.5): matches k = 1 and is PSD.
        assert!(verify(&matching(1.0), &[(1, 2)], &[0.0, 0.5, 0.0, 0.5]));
        // Off by 1e-6 (within AlmostSolved's 1e-4, not within 1e-8).
        assert!(!verify(
            &matching(1.0),
            &[(1, 2)],
            &[0.0, 0.5, 0.0, 0.5 + 1e-6]
        ));
        // Matches k = 0 exactly, but Q = diag(1, −1) is indefinite.
        assert!(!verify(&matching(0.0), &[(1, 2)], &[0.0, 1.0, 0.0, -1.0]));
        // A Gram matrix beyond the solution is a failed check, not a panic.
        assert!(!verify(&matching(1.0), &[(1, 3)], &[0.0, 0.5, 0.0, 0.5]));
    }

    #[test]
    fn diagonal_blocks_are_separate() {
        let t = theta(&[(0, 1.0), (12, 1.0)]);
        assert_eq!(blocks::<Quadratic2d>(&t), vec![vec![0], vec![1]]);
        let t = theta(&[(0, 1.0), (6 + 1, 0.5), (12, 1.0)]);
        assert_eq!(blocks::<Quadratic2d>(&t), vec![vec![0, 1]]);
    }

    #[test]
    fn sum_of_squares_metrics_are_certified() {
        // [[1 + q², q p], [q p, 1 + p²]] = I + (q, p)(q, p)ᵀ.
        let t = theta(&[(0, 1.0), (3, 1.0), (6 + 4, 1.0), (12, 1.0), (12 + 5, 1.0)]);
        check_metric::<Quadratic2d>("test", &t).unwrap();
        // [[q², 0], [0, 0]]: PSD on a face (no strictly feasible Gram matrix).
        let t = theta(&[(3, 1.0)]);
        check_metric::<Quadratic2d>("test", &t).unwrap();
    }

    /// Within the certificate's shift tolerance (the shift is the square
    /// of the Gram entry's error) but indefinite for |q| > 1/√(k01² − 1)
    /// (71 for k01 = 1.0001): refused by
    /// the smallest eigenvalue along a ray; the same metric at the edge of
    /// the cone (K01 = q, det K = 1) is certified.
    #[test]
    fn a_metric_the_shift_tolerance_passes_is_refused_where_it_is_indefinite() {
        let metric = |k01: f64| theta(&[(0, 1.0), (3, 1.0), (6 + 1, k01), (12, 1.0)]);
        check_metric::<Quadratic2d>("m", &metric(1.0)).unwrap();
        // Indefinite beyond |q| = 2.2e6, by less than the rounding of
        // evaluating K there: accepted.
        check_metric::<Quadratic2d>("m", &metric(1.0 + 1e-13)).unwrap();
        // Indefinite beyond |q| = 224, never by more than 1e-9 of the
        // certificate's unit there, but by 3e-8 of K's own terms at
        // q = 500 (eigenvalue −1.6e-5): accepted before the judgement on
        // K's terms, refused now.
        for k01 in [1.00001, 1.0001, 1.001] {
            match check_metric::<Quadratic2d>("m", &metric(k01)) {
                Err(Error::MetricNotPositive {
                    eigenvalue,
                    state: Some(x),
                    ..
                }) => {
                    // Where K is indefinite: det K = 1 − (k01² − 1) q² < 0.
                    assert!(
                        eigenvalue < 0.0 && x[0].abs() > 1.0 / (k01 * k01 - 1.0).sqrt(),
                        "{eigenvalue} at {x:?}"
                    );
                }
                other => panic!("K01 = {k01} q: {other:?}"),
            }
        }
    }

    #[test]
    fn indefinite_metrics_are_refused() {
        // [[1, 2q], [2q, 1]] has eigenvalue 1 − 2|q| < 0 for |q| > ½.
        let t = theta(&[(0, 1.0), (6 + 1, 2.0), (12, 1.0)]);
        let err = check_metric::<Quadratic2d>("test", &t).unwrap_err();
        assert!(
            matches!(err, Error::MetricNotPositive { state: Some(ref x), eigenvalue, .. }
                if eigenvalue < 0.0 && x[0].abs() > 0.5),
            "{err}"
        );
        // [[q², 0], [0, −p²]].
        let t = theta(&[(3, 1.0), (12 + 5, -1.0)]);
        assert!(matches!(
            check_metric::<Quadratic2d>("test", &t),
            Err(Error::MetricNotPositive { .. })
        ));
    }

    /// The tolerance of a constant metric is per direction: a large entry
    /// coupled to a negative one (even by 1e-300) does not hide it, while
    /// singular metrics and rows at rounding level still pass.
    #[test]
    fn a_large_entry_does_not_hide_a_negative_one() {
        for negative in [-1e5, -1.0, -1e-3] {
            let t = theta(&[(0, 1e15), (6, 1e-300), (12, negative)]);
            let err = check_metric::<Quadratic2d>("test", &t).unwrap_err();
            println!("{err}");
            assert!(
                matches!(err, Error::MetricNotPositive { eigenvalue, state: None, .. }
                    if eigenvalue < 0.0),
                "{negative}: {err}"
            );
        }
        // [[1, 1e-6], [1e-6, −1e-12]]: eigenvalue −2e-12, 2e-12 of the
        // largest entry but all of the second axis's own scale.
        let t = theta(&[(0, 1.0), (6, 1e-6), (12, -1e-12)]);
        assert!(check_metric::<Quadratic2d>("test", &t).is_err());
        // Singular, PSD: v vᵀ with v = (1, 1e-8), and diag(0, 1).
        let t = theta(&[(0, 1.0), (6, 1e-8), (12, 1e-16)]);
        check_metric::<Quadratic2d>("test", &t).unwrap();
        let t = theta(&[(12, 1.0)]);
        check_metric::<Quadratic2d>("test", &t).unwrap();
        // A zero row coupled to a large one at rounding level stays
        // acceptable (eigenvalues −1e-30 and −1e-18).
        let t = theta(&[(6, 1e-15), (12, 1.0)]);
        check_metric::<Quadratic2d>("test", &t).unwrap();
        let t = theta(&[(0, 1.0), (6, 1e-9)]);
        check_metric::<Quadratic2d>("test", &t).unwrap();
        // Coupling far beyond rounding into a zero row: eigenvalue −1e-6.
        let t = theta(&[(0, 1.0), (6, 1e-3)]);
        assert!(check_metric::<Quadratic2d>("test", &t).is_err());
        // Axes of very different scales: eigenvalue −0.96 is 1e-12 and
        // 1e-14 of the largest entry, but all of the second axis's scale.
        for (large, coupling) in [(1e12, 1.4e6), (1e14, 1.4e7)] {
            let t = theta(&[(0, large), (6, coupling), (12, 1.0)]);
            let err = check_metric::<Quadratic2d>("test", &t).unwrap_err();
            println!("{err}");
            assert!(
                matches!(err, Error::MetricNotPositive { eigenvalue, .. } if eigenvalue < -0.5),
                "{large:e}: {err}"
            );
        }
        // The same scales, singular and PSD: v vᵀ with v = (1e6, 1).
        let t = theta(&[(0, 1e12), (6, 1e6), (12, 1.0)]);
        check_metric::<Quadratic2d>("test", &t).unwrap();
    }

    /// So is a state-dependent block's: its axes are balanced before the
    /// checks, whose tolerances are relative to the largest coefficient.
    #[test]
    fn a_large_state_dependent_entry_does_not_hide_a_negative_direction() {
        // [[1e12 + q², 1.4e6], [1.4e6, 1]]: eigenvalue −0.96 near q = 0.
        let t = theta(&[(0, 1e12), (3, 1.0), (6, 1.4e6), (12, 1.0)]);
        let err = check_metric::<Quadratic2d>("test", &t).unwrap_err();
        println!("{err}");
        assert!(
            matches!(err, Error::MetricNotPositive { eigenvalue, state: Some(ref x), .. }
                if eigenvalue < -0.5 && x[0].abs() < 1e3),
            "{err}"
        );
        // [[1e12 + q², 1e6], [1e6, 1 + p²]]: determinant 1e12·p² + q² + q²p².
        let t = theta(&[(0, 1e12), (3, 1.0), (6, 1e6), (12, 1.0), (17, 1.0)]);
        check_metric::<Quadratic2d>("test", &t).unwrap();
        // A zero row coupled at the searches' rounding stays acceptable.
        let t = theta(&[(0, 1.0), (3, 1.0), (6, 1e-9)]);
        check_metric::<Quadratic2d>("test", &t).unwrap();
    }
}
