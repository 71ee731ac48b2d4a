//! The Gram-matrix form of a metric certificate: which sum-of-squares blocks
//! make up K(x) and ηI − K(x), and the Gram matrices that prove both bounds.
//!
//! Without a declared region the certificate is one block per side over the
//! system's [`SosTables`] (0 ⪯ K ⪯ ηI everywhere, which forces K constant);
//! with a region it is the system's [`RegionCertificate`] (the matrix
//! S-procedure, `docs/method.md` §2). Both are described by the same
//! [`Layout`], so the searches, the model's checks and the model file treat
//! them alike: for every pair j ≤ k and target monomial α,
//!
//! ```text
//! Σ_lower  Σ_{(β,γ,c)} c·Qᵦ[(j,β),(k,γ)] = θⱼₖ,α          (0 above the metric basis)
//! Σ_upper  Σ_{(β,γ,c)} c·Qᵦ[(j,β),(k,γ)] = η[j=k][α=0] − θⱼₖ,α
//! ```
//!
//! (for a region far from the origin, on the monomials of y = x − c and
//! with θ the coefficients of K(c + y); see [`Layout`]).

use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use super::shift::{far_centre, Shift};

use crate::error::{invalid, Result};
use crate::solve::linalg::symmetric_eigenvalues;
use crate::system::{metric_pair_index, MetriplecticSystem, SosTables};

/// A block's coefficient-matching table: unit weights for the global
/// tables, weighted (multiplier products) for a region certificate, and
/// computed for a region certificate in centred coordinates.
#[derive(Debug, Clone)]
pub(crate) enum Matching {
    Unit(&'static [&'static [(u16, u16)]]),
    Weighted(&'static [&'static [(u16, u16, f64)]]),
    Centred(CentredTable),
}

/// A matching table computed at run time, per target the entries (β, γ, c).
pub(crate) type CentredTable = Arc<[Vec<(u16, u16, f64)>]>;

impl Matching {
    /// Number of target monomials the table covers.
    fn targets(&self) -> usize {
        match self {
            Self::Unit(rows) => rows.len(),
            Self::Weighted(rows) => rows.len(),
            Self::Centred(rows) => rows.len(),
        }
    }

    /// The entries (β, γ, c) of target `alpha`.
    pub fn entries(&self, alpha: usize) -> Box<dyn Iterator<Item = (usize, usize, f64)> + '_> {
        match self {
            Self::Unit(rows) => Box::new(
                rows[alpha]
                    .iter()
                    .map(|&(b, g)| (b as usize, g as usize, 1.0)),
            ),
            Self::Weighted(rows) => Box::new(
                rows[alpha]
                    .iter()
                    .map(|&(b, g, c)| (b as usize, g as usize, c)),
            ),
            Self::Centred(rows) => Box::new(
                rows[alpha]
                    .iter()
                    .map(|&(b, g, c)| (b as usize, g as usize, c)),
            ),
        }
    }
}

/// One sum-of-squares block g(x)·Z(x)ᵀQZ(x), Z = I ⊗ m(x).
#[derive(Debug, Clone)]
pub(crate) struct BlockLayout {
    /// The block's basis monomials m(x).
    pub basis: &'static [&'static [u32]],
    /// Per target monomial, the Gram entries that produce it.
    pub matching: Matching,
}

impl BlockLayout {
    /// Side n·|m| of the block's Gram matrix.
    pub fn size(&self, n: usize) -> usize {
        n * self.basis.len()
    }
}

/// The blocks of a system's metric certificate.
///
/// States in other units (millimetres, kilometres) make a certificate's
/// entries span many orders of magnitude: on a region of extent ρ the
/// monomial x^β is of size ρ^|β|, and a Gram entry of a degree-4 target
/// 1e12 times smaller than a constant one. Every program over the blocks
/// is therefore set up in the scaled coordinates u = x/ρ (ρ the region's
/// extent in each variable, [`state_scale`]): a Gram matrix Q = W Q′ W with
/// W diagonal ([`gram_weights`](Self::gram_weights)), which is PSD exactly
/// when Q′ is, and each identity of target α multiplied by ρ^α
/// ([`target_scale`](Self::target_scale)). Both are exact changes of
/// variables: the certificate is the same, its numbers are of order one.
///
/// A region far from the origin against its extent (a temperature box
/// [280, 320] K) is moreover centred: every program is set up in
/// y = x − c, c the region's centre ([`Shift`]), where its monomials are
/// not nearly collinear. The metric's coefficients are then those of
/// K(c + y) ([`shift`](Self::shift)), the multipliers are g(c + y), the
/// Gram matrices (and a [`GramCertificate`]'s) are over the monomials of
/// y, and ρ is the region's extent around c.
#[derive(Debug, Clone)]
pub(crate) struct Layout {
    /// Number of target monomials; the metric basis is their prefix.
    pub targets: usize,
    /// Blocks summing to K(x).
    pub lower: Vec<BlockLayout>,
    /// Blocks summing to ηI − K(x).
    pub upper: Vec<BlockLayout>,
    /// The target monomials' exponents.
    target_exponents: &'static [&'static [u32]],
    /// ρ: each state variable's extent on the region (1 without one).
    scale: Vec<f64>,
    /// The metric coefficients' change to y = x − c, for a region far
    /// from the origin.
    shift: Option<Shift>,
}

impl Layout {
    /// The region certificate of `S` if it declares one, else one block per
    /// side over `tables` (the global certificate).
    pub fn of<S: MetriplecticSystem>(tables: SosTables) -> Self {
        match S::REGION_CERTIFICATE {
            Some(certificate) => {
                let (centre, scale) = region_coordinates::<S>();
                let shift = centre.and_then(|c| {
                    centred_tables(&certificate, &c)
                        .and_then(|tables| Some((Shift::new(S::METRIC_EXPONENTS, c)?, tables)))
                });
                let blocks = |blocks: &'static [crate::system::GramBlock], first: usize| {
                    blocks
                        .iter()
                        .enumerate()
                        .map(|(i, b)| BlockLayout {
                            basis: b.exponents,
                            matching: match &shift {
                                Some((_, tables)) => Matching::Centred(tables[first + i].clone()),
                                None => Matching::Weighted(b.matching),
                            },
                        })
                        .collect()
                };
                let (lower, upper) = (
                    blocks(certificate.lower, 0),
                    blocks(certificate.upper, certificate.lower.len()),
                );
                let shift = shift.map(|(shift, _)| shift);
                Self {
                    targets: certificate.targets.len(),
                    lower,
                    upper,
                    target_exponents: certificate.targets,
                    // Without a centre, ρ is the extent around the origin.
                    scale: if shift.is_some() {
                        scale
                    } else {
                        state_scale::<S>()
                    },
                    shift,
                }
            }
            None => {
                let block = BlockLayout {
                    basis: tables.exponents,
                    matching: Matching::Unit(tables.matching),
                };
                Self {
                    targets: tables.matching.len(),
                    lower: vec![block.clone()],
                    upper: vec![block],
                    target_exponents: S::METRIC_EXPONENTS,
                    scale: state_scale::<S>(),
                    shift: None,
                }
            }
        }
    }

    /// The change of the metric coefficients to the centred coordinates
    /// the programs use, for a region far from the origin: the θ columns of
    /// a program over this layout are K(c + y)'s coefficients.
    pub fn shift(&self) -> Option<&Shift> {
        self.shift.as_ref()
    }

    /// θ in the coordinates of the layout's identities (`theta` itself
    /// without a centre).
    pub fn centred_metric<'a>(&self, theta: &'a [f64]) -> std::borrow::Cow<'a, [f64]> {
        match &self.shift {
            Some(shift) => std::borrow::Cow::Owned(shift.to_centred(theta)),
            None => std::borrow::Cow::Borrowed(theta),
        }
    }

    /// ρ^α, the factor target α's identities are multiplied by (1 for a
    /// target the tables do not describe).
    pub fn target_scale(&self, alpha: usize) -> f64 {
        self.target_exponents
            .get(alpha)
            .map_or(1.0, |e| monomial_scale(&self.scale, e))
    }

    /// The diagonal of W in Q = W Q′ W for `block`, per Gram index
    /// (j, β) ↦ j·|m| + β: ρ^−β / √s, with s the size of the block's
    /// multiplier g(ρ u) on the unit-scaled states (the largest
    /// |c|·ρ^(α−β−γ) of its matching entries; 1 for the plain block), so
    /// that every scaled matching coefficient is at most 1.
    pub fn gram_weights(&self, block: &BlockLayout, n: usize) -> Vec<f64> {
        let monomial: Vec<f64> = block
            .basis
            .iter()
            .map(|e| monomial_scale(&self.scale, e))
            .collect();
        let mut multiplier = 0.0_f64;
        for alpha in 0..self.targets.min(self.target_exponents.len()) {
            let target = self.target_scale(alpha);
            for (b, g, c) in block.matching.entries(alpha) {
                if let (Some(sb), Some(sg)) = (monomial.get(b), monomial.get(g)) {
                    multiplier = multiplier.max(c.abs() * target / (sb * sg));
                }
            }
        }
        let normaliser = if multiplier.is_normal() && multiplier.is_finite() {
            multiplier.sqrt()
        } else {
            1.0
        };
        (0..n)
            .flat_map(|_| monomial.iter().map(|s| 1.0 / (s * normaliser)))
            .collect()
    }

    /// Errors unless every table fits the metric basis of `S` and its own
    /// block basis (tables come from the macro, but a hand-written
    /// implementation of the trait could disagree).
    pub fn check<S: MetriplecticSystem>(&self) -> Result<()> {
        let what = format!("metric certificate tables of system `{}`", S::NAME);
        let basis = S::METRIC_EXPONENTS.len();
        if self.targets < basis {
            return Err(invalid(
                &what,
                format!(
                    "{} target monomials for {basis} metric monomials",
                    self.targets
                ),
            ));
        }
        if !S::METRIC_EXPONENTS
            .first()
            .is_some_and(|e| e.iter().all(|&d| d == 0))
        {
            return Err(invalid(
                &what,
                "the metric basis does not start with the constant monomial",
            ));
        }
        for block in self.lower.iter().chain(&self.upper) {
            let m = block.basis.len();
            if block.matching.targets() != self.targets {
                return Err(invalid(
                    &what,
                    format!(
                        "a block matches {} target monomials, not {}",
                        block.matching.targets(),
                        self.targets
                    ),
                ));
            }
            for alpha in 0..self.targets {
                if let Some((b, g, _)) = block
                    .matching
                    .entries(alpha)
                    .find(|&(b, g, c)| b >= m || g >= m || !c.is_finite())
                {
                    return Err(invalid(
                        &what,
                        format!("entry ({b}, {g}) of target {alpha} is outside the {m} basis monomials or not finite"),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// ρ: each state variable's extent on the region of `S` (the larger
/// |bound| of its bounding box), 1 without a region; all 1 when a monomial
/// of the certificate would overflow or underflow at that scale, where the
/// scaling cannot help.
pub(crate) fn state_scale<S: MetriplecticSystem>() -> Vec<f64> {
    let Some(certificate) = S::REGION_CERTIFICATE else {
        return vec![1.0; S::DIM];
    };
    let (low, high) = certificate.region.bounding_box();
    let scale: Vec<f64> = low
        .iter()
        .zip(&high)
        .map(|(l, h)| l.abs().max(h.abs()))
        .map(|r| {
            if r.is_normal() && r.is_finite() {
                r
            } else {
                1.0
            }
        })
        .collect();
    let representable = scale.len() == S::DIM
        && certificate.targets.iter().all(|e| {
            let size = monomial_scale(&scale, e);
            size.is_normal() && size.is_finite() && (1.0 / size).is_normal()
        });
    if representable {
        scale
    } else {
        vec![1.0; S::DIM]
    }
}

/// The centred coordinates of the region of `S`: c, the centre of each
/// variable's interval on the region that lies farther from zero than its
/// width (0 in the others; `None` if no interval does), and ρ, each
/// variable's extent around c. Both are `None` and [`state_scale`] where
/// ρ would not be representable.
pub(crate) fn region_coordinates<S: MetriplecticSystem>() -> (Option<Vec<f64>>, Vec<f64>) {
    let Some(certificate) = S::REGION_CERTIFICATE else {
        return (None, vec![1.0; S::DIM]);
    };
    let (low, high) = certificate.region.bounding_box();
    let Some(centre) = far_centre(&low, &high).filter(|c| c.len() == S::DIM) else {
        return (None, state_scale::<S>());
    };
    let scale: Vec<f64> = low
        .iter()
        .zip(&high)
        .zip(&centre)
        .map(|((l, h), c)| (l - c).abs().max((h - c).abs()))
        .collect();
    let representable = scale.iter().all(|r| r.is_normal() && r.is_finite())
        && certificate.targets.iter().all(|e| {
            let size = monomial_scale(&scale, e);
            size.is_normal() && size.is_finite() && (1.0 / size).is_normal()
        });
    if representable {
        (Some(centre), scale)
    } else {
        (None, state_scale::<S>())
    }
}

/// Every block's matching table in y = x − c, its multiplier g(c + y)
/// expanded (the plain block's unchanged): lower blocks, then upper.
/// `None` if a product leaves the targets (it cannot for the macro's
/// tables, whose targets are all monomials up to their degree).
fn centred_tables(
    certificate: &crate::system::RegionCertificate,
    centre: &[f64],
) -> Option<Vec<CentredTable>> {
    let targets: HashMap<&[u32], usize> = certificate
        .targets
        .iter()
        .enumerate()
        .map(|(k, e)| (*e, k))
        .collect();
    let mut tables = Vec::new();
    for block in certificate.lower.iter().chain(certificate.upper) {
        // g(c + y), term by term; the plain block's multiplier is 1.
        let mut multiplier: BTreeMap<Vec<u32>, f64> = BTreeMap::new();
        if block.multiplier.is_empty() {
            multiplier.insert(vec![0; centre.len()], 1.0);
        }
        for &(coefficient, exponent) in block.multiplier {
            for (gamma, weight) in super::shift::expansion(exponent, centre)? {
                *multiplier.entry(gamma).or_insert(0.0) += coefficient * weight;
            }
        }
        let mut rows = vec![Vec::new(); certificate.targets.len()];
        let mut sum = vec![0_u32; centre.len()];
        for (b, beta) in block.exponents.iter().enumerate() {
            for (g, gamma) in block.exponents.iter().enumerate() {
                for (delta, &c) in multiplier.iter().filter(|(_, c)| **c != 0.0) {
                    for (((s, x), y), z) in sum.iter_mut().zip(*beta).zip(*gamma).zip(delta) {
                        *s = x + y + z;
                    }
                    let alpha = *targets.get(sum.as_slice())?;
                    rows[alpha].push((u16::try_from(b).ok()?, u16::try_from(g).ok()?, c));
                }
            }
        }
        tables.push(Arc::from(rows));
    }
    Some(tables)
}

/// ρ^e = Π ρᵢ^eᵢ.
pub(crate) fn monomial_scale(scale: &[f64], exponent: &[u32]) -> f64 {
    scale
        .iter()
        .zip(exponent)
        .map(|(r, &e)| r.powi(e as i32))
        .product()
}

/// The Gram matrix Q ⪰ 0 of one sum-of-squares block, row-major, with rows
/// and columns indexed by (j, β) ↦ j·|m| + β (state index j, basis monomial β).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GramMatrix {
    /// Side n·|m|.
    pub size: usize,
    /// The size² entries, row-major.
    pub values: Vec<f64>,
}

impl GramMatrix {
    fn entry(&self, a: usize, b: usize) -> f64 {
        self.values[a * self.size + b]
    }
}

/// The Gram matrices that prove a metric's bounds, one per block of the
/// system's certificate, in the order of its tables: the `lower` blocks sum
/// to K(x), the `upper` blocks to ηI − K(x) (each block multiplied by its
/// region constraint, if any; see [`RegionCertificate`](crate::RegionCertificate)).
///
/// Identification keeps the certificate of the metric search or joint step
/// that produced a model's metric ([`Model::certificate`](crate::Model::certificate)),
/// and model files carry it, so anyone can re-check it with
/// [`GramCertificate::check`].
///
/// For a region far from the origin against its extent in some variable
/// (a temperature box [280, 320]), Z is over the monomials of y = x − c,
/// c the region's centre in those variables (0 in the others): the blocks
/// sum to K(c + y) and ηI − K(c + y), whose monomials are not nearly
/// collinear there (`docs/method.md` §2, "States far from the origin").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GramCertificate {
    /// The bound η of ηI − K(x).
    pub eta: f64,
    /// The Gram matrices of the blocks whose sum is K(x).
    pub lower: Vec<GramMatrix>,
    /// The Gram matrices of the blocks whose sum is ηI − K(x).
    pub upper: Vec<GramMatrix>,
}

/// How well a [`GramCertificate`] proves a metric's bounds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CertificateCheck {
    /// The largest violation of a coefficient identity, relative to
    /// max(η, the largest |Gram entry|): 0 for an exact certificate. Both
    /// are taken in the region's centred coordinates (see
    /// [`GramCertificate`]) scaled by its extent ρ (the
    /// identity of x^α multiplied by ρ^α, each Gram matrix's row and column
    /// of x^β by ρ^β and the block by the size of its multiplier on the
    /// scaled states), so that the numbers mean the same in any units;
    /// without a region ρ = 1.
    pub identity_residual: f64,
    /// The smallest eigenvalue over all Gram matrices (scaled as above),
    /// relative to the same scale: ≥ 0 for a valid certificate.
    pub smallest_eigenvalue: f64,
}

impl CertificateCheck {
    /// Whether both numbers are within `tolerance` (identities off by at
    /// most it, eigenvalues at least −it).
    pub fn holds(&self, tolerance: f64) -> bool {
        self.identity_residual <= tolerance && self.smallest_eigenvalue >= -tolerance
    }
}

impl GramCertificate {
    /// Checks the certificate against metric coefficients `theta` of
    /// system `S`: every Gram matrix's smallest eigenvalue and every
    /// coefficient identity of the system's certificate (its region
    /// certificate if it declares one, else the global tables — the
    /// facially reduced ones, or the full ones if the Gram matrices have
    /// their size).
    ///
    /// Errors if the number or sizes of the Gram matrices do not fit the
    /// system's blocks or `theta` has the wrong length.
    pub fn check<S: MetriplecticSystem>(&self, theta: &[f64]) -> Result<CertificateCheck> {
        let reduced = Layout::of::<S>(S::SOS_REDUCED);
        let full = Layout::of::<S>(S::SOS_FULL);
        let layout = if self.check_shape(&reduced, S::DIM).is_err()
            && self.check_shape(&full, S::DIM).is_ok()
        {
            full
        } else {
            reduced
        };
        self.check_with::<S>(&layout, theta)
    }

    pub(crate) fn check_with<S: MetriplecticSystem>(
        &self,
        layout: &Layout,
        theta: &[f64],
    ) -> Result<CertificateCheck> {
        let n = S::DIM;
        crate::error::check_len("metric coefficients", theta, S::metric_coefficient_count())?;
        self.check_shape(layout, n)?;
        // NaN would pass every comparison below (f64::min and max skip it).
        let values = self.lower.iter().chain(&self.upper).flat_map(|q| &q.values);
        if !(self.eta.is_finite() && values.clone().all(|v| v.is_finite())) {
            return Ok(CertificateCheck {
                identity_residual: f64::INFINITY,
                smallest_eigenvalue: f64::NEG_INFINITY,
            });
        }
        // Judged in the region's unit-scaled states (`Layout`): Q′ = W⁻¹QW⁻¹
        // and the identities multiplied by ρ^α, so that the tolerance
        // means the same in any units.
        let scaled: Vec<GramMatrix> = layout
            .lower
            .iter()
            .chain(&layout.upper)
            .zip(self.lower.iter().chain(&self.upper))
            .map(|(block, q)| {
                let w = layout.gram_weights(block, n);
                let mut values = q.values.clone();
                for (a, row) in values.chunks_exact_mut(q.size).enumerate() {
                    for (b, v) in row.iter_mut().enumerate() {
                        *v /= w[a] * w[b];
                    }
                }
                GramMatrix {
                    size: q.size,
                    values,
                }
            })
            .collect();
        let scale = scaled
            .iter()
            .flat_map(|q| q.values.iter())
            .fold(self.eta.abs(), |m, v| m.max(v.abs()))
            .max(f64::MIN_POSITIVE);
        // Finite entries can overflow when scaled: no certificate then.
        if !scale.is_finite() {
            return Ok(CertificateCheck {
                identity_residual: f64::INFINITY,
                smallest_eigenvalue: f64::NEG_INFINITY,
            });
        }
        let mut smallest = f64::INFINITY;
        for q in &scaled {
            let matrix = DMatrix::from_row_slice(q.size, q.size, &q.values);
            let symmetric = (&matrix + matrix.transpose()) * 0.5;
            let asymmetry = (&matrix - &symmetric).amax();
            let low = symmetric_eigenvalues(&symmetric)
                .and_then(|values| values.first().copied())
                .unwrap_or(f64::NAN);
            // An asymmetric "Gram matrix" is no certificate: count it as a
            // violation; so is one whose eigenvalues are not numbers
            // (f64::min would skip NaN).
            let low = low - asymmetry;
            smallest = smallest.min(if low.is_nan() { f64::NEG_INFINITY } else { low });
        }
        let residual = identity_residuals::<S>(layout, self, theta)
            .into_iter()
            .fold(0.0_f64, |m, r| {
                if r.is_nan() {
                    f64::INFINITY
                } else {
                    m.max(r.abs())
                }
            });
        Ok(CertificateCheck {
            identity_residual: residual / scale,
            smallest_eigenvalue: if smallest.is_finite() {
                smallest / scale
            } else {
                f64::NEG_INFINITY
            },
        })
    }

    fn check_shape(&self, layout: &Layout, n: usize) -> Result<()> {
        for (side, grams, blocks) in [
            ("lower", &self.lower, &layout.lower),
            ("upper", &self.upper, &layout.upper),
        ] {
            if grams.len() != blocks.len() {
                return Err(invalid(
                    "Gram certificate",
                    format!(
                        "{} {side} Gram matrices for the system's {} {side} blocks",
                        grams.len(),
                        blocks.len()
                    ),
                ));
            }
            for (i, (q, block)) in grams.iter().zip(blocks).enumerate() {
                let size = block.size(n);
                if q.size != size || q.values.len() != size * size {
                    return Err(invalid(
                        "Gram certificate",
                        format!(
                            "{side} block {}: a {}×{} matrix with {} entries where the system's \
                             block is {size}×{size}",
                            i + 1,
                            q.size,
                            q.size,
                            q.values.len()
                        ),
                    ));
                }
            }
        }
        if !self.eta.is_finite() {
            return Err(invalid("Gram certificate", format!("η = {}", self.eta)));
        }
        Ok(())
    }
}

/// Σ over `blocks` of [g Zᵀ Q Z]ⱼₖ,α.
fn block_sum(
    blocks: &[BlockLayout],
    grams: &[GramMatrix],
    (j, k): (usize, usize),
    alpha: usize,
) -> f64 {
    blocks
        .iter()
        .zip(grams)
        .map(|(block, q)| {
            let m = block.basis.len();
            block
                .matching
                .entries(alpha)
                .map(|(b, g, c)| c * q.entry(j * m + b, k * m + g))
                .sum::<f64>()
        })
        .sum()
}

/// Every coefficient identity's residual (target α's multiplied by ρ^α),
/// lower then upper side.
fn identity_residuals<S: MetriplecticSystem>(
    layout: &Layout,
    certificate: &GramCertificate,
    theta: &[f64],
) -> Vec<f64> {
    let n = S::DIM;
    let basis = S::METRIC_EXPONENTS.len();
    let theta = layout.centred_metric(theta);
    let mut residuals = Vec::new();
    for j in 0..n {
        for k in j..n {
            let pair = metric_pair_index(n, j, k);
            for alpha in 0..layout.targets {
                let value = if alpha < basis {
                    theta[pair * basis + alpha]
                } else {
                    0.0
                };
                let bound = if j == k && alpha == 0 {
                    certificate.eta
                } else {
                    0.0
                };
                let target_scale = layout.target_scale(alpha);
                residuals.push(
                    (value - block_sum(&layout.lower, &certificate.lower, (j, k), alpha))
                        * target_scale,
                );
                residuals.push(
                    (bound - value - block_sum(&layout.upper, &certificate.upper, (j, k), alpha))
                        * target_scale,
                );
            }
        }
    }
    residuals
}

/// θⱼₖ,α = Σ_lower [g Zᵀ Q Z]ⱼₖ,α on the metric basis: the metric the lower
/// Gram matrices prove, so that its lower bound holds up to rounding
/// whatever the solver's feasibility tolerance. In x: a centred layout's
/// sums are K(c + y)'s coefficients, converted back.
pub(crate) fn theta_from_gram<S: MetriplecticSystem>(
    layout: &Layout,
    lower: &[GramMatrix],
) -> Vec<f64> {
    let n = S::DIM;
    let basis = S::METRIC_EXPONENTS.len();
    let mut theta = vec![0.0; S::metric_coefficient_count()];
    for j in 0..n {
        for k in j..n {
            let pair = metric_pair_index(n, j, k);
            for alpha in 0..basis {
                theta[pair * basis + alpha] = block_sum(&layout.lower, lower, (j, k), alpha);
            }
        }
    }
    match layout.shift() {
        Some(shift) => shift.to_original(&theta),
        None => theta,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_system::Quadratic2d;

    #[test]
    fn theta_from_gram_matches_the_sos_form() {
        // K(x) = Z(x)ᵀ Q Z(x) for a random symmetric Q over the full basis.
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let size = 6;
        let mut q = vec![0.0; size * size];
        for a in 0..size {
            for b in a..size {
                let v: f64 = rng.random_range(-1.0..1.0);
                q[a * size + b] = v;
                q[b * size + a] = v;
            }
        }
        let tables = Quadratic2d::SOS_FULL;
        let layout = Layout::of::<Quadratic2d>(tables);
        let theta = theta_from_gram::<Quadratic2d>(
            &layout,
            &[GramMatrix {
                size,
                values: q.clone(),
            }],
        );
        let x = [0.7, -1.3];
        let z = [1.0, x[0], x[1]];
        let mut k = [0.0; 4];
        Quadratic2d::metric_value(&x, &theta, &mut k);
        for j in 0..2 {
            for l in 0..2 {
                let direct: f64 = (0..3)
                    .flat_map(|b| (0..3).map(move |g| (b, g)))
                    .map(|(b, g)| z[b] * q[(j * 3 + b) * size + l * 3 + g] * z[g])
                    .sum();
                assert!((direct - k[j * 2 + l]).abs() < 1e-12);
            }
        }
    }

    /// A Gram matrix of NaN used to drop out of both checks (f64::min and
    /// max skip NaN), so the certificate "held".
    #[test]
    fn a_certificate_with_nan_entries_never_holds() {
        let layout = Layout::of::<Quadratic2d>(Quadratic2d::SOS_FULL);
        let identity = |block: &BlockLayout| {
            let size = block.size(2);
            let mut values = vec![0.0; size * size];
            (0..size).for_each(|i| values[i * size + i] = 1.0);
            GramMatrix { size, values }
        };
        let lower: Vec<GramMatrix> = layout.lower.iter().map(identity).collect();
        let upper: Vec<GramMatrix> = layout.upper.iter().map(identity).collect();
        let theta = theta_from_gram::<Quadratic2d>(&layout, &lower);
        let valid = GramCertificate {
            eta: 1.0,
            lower: lower.clone(),
            upper,
        };
        assert!(
            valid
                .check_with::<Quadratic2d>(&layout, &theta)
                .unwrap()
                .smallest_eigenvalue
                >= 0.0
        );
        let mut broken = valid.clone();
        broken.lower[0]
            .values
            .iter_mut()
            .for_each(|v| *v = f64::NAN);
        let check = broken.check_with::<Quadratic2d>(&layout, &theta).unwrap();
        assert!(!check.holds(1e-8), "{check:?}");
    }
}
