//! The sum-of-squares certificate of the metric as conic constraints,
//! shared by the metric search and the joint step.
//!
//! With Z(x) = I ⊗ m(x) over the SOS basis m, the constraints are
//!
//! ```text
//! θⱼₖ,α                  = Σ_{(β,γ) ∈ matching[α]} Q₁[(j,β),(k,γ)],   Q₁ ⪰ 0,
//! η·[j=k]·[α=0] − θⱼₖ,α  = Σ_{(β,γ) ∈ matching[α]} Q₂[(j,β),(k,γ)],   Q₂ ⪰ 0,
//! ```
//!
//! so that K(x) = Z(x)ᵀ Q₁ Z(x) ⪰ 0 and ηI − K(x) = Z(x)ᵀ Q₂ Z(x) ⪰ 0.
//! A system that declares a region uses its region certificate instead:
//! several blocks per side, each multiplied by a region constraint, matched
//! on more target monomials (see [`crate::model::Layout`]).

use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::identify::search::SearchOptions;
use crate::model::classical::{self, Equalities};
use crate::model::{GramCertificate, GramMatrix, Layout};
use crate::solve::svec::{svec_index, svec_len, unsvec, SQRT_2};
use crate::solve::{Cone, ConstraintId, L1Problem, L1Solution};
use crate::system::{metric_pair_index, MetriplecticSystem, SosTables};

/// Which global SOS coefficient-matching tables the metric search uses
/// (ignored for a system that declares a region: its region certificate is
/// used).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum SosBasis {
    /// [`MetriplecticSystem::SOS_REDUCED`] (the default): facially reduced,
    /// strictly feasible.
    #[default]
    Reduced,
    /// [`MetriplecticSystem::SOS_FULL`]: the full half-degree basis. The
    /// two-sided program then has no strictly feasible point.
    Full,
}

impl SosBasis {
    /// The tables of system `S` this choice selects.
    pub fn tables<S: MetriplecticSystem>(self) -> SosTables {
        match self {
            Self::Reduced => S::SOS_REDUCED,
            Self::Full => S::SOS_FULL,
        }
    }
}

/// The certificate's constraint blocks in an [`L1Problem`].
pub(crate) struct SosConstraints {
    eta: f64,
    /// Each lower block's PSD cone, side and scaling W (Q = W Q′ W).
    lower: Vec<(ConstraintId, usize, Vec<f64>)>,
    /// Each upper block's PSD cone, side and scaling W.
    upper: Vec<(ConstraintId, usize, Vec<f64>)>,
}

impl SosConstraints {
    /// Number of extra variables the Gram matrices of `layout` take (the
    /// svec of each block's Gram matrix).
    pub fn variables<S: MetriplecticSystem>(layout: &Layout) -> usize {
        layout
            .lower
            .iter()
            .chain(&layout.upper)
            .map(|block| svec_len(block.size(S::DIM)))
            .sum()
    }

    /// The Gram matrices Q = W Q′ W from their scaled cone slacks Q′, which
    /// lie in the PSD cones, so that each block is PSD up to rounding
    /// whatever the solver's feasibility tolerance.
    pub fn certificate(&self, solution: &L1Solution) -> GramCertificate {
        let grams = |blocks: &[(ConstraintId, usize, Vec<f64>)]| {
            blocks
                .iter()
                .map(|(id, size, weights)| {
                    let mut values = unsvec(*size, solution.slack(*id));
                    for (a, row) in values.chunks_exact_mut(*size).enumerate() {
                        for (b, v) in row.iter_mut().enumerate() {
                            *v *= weights[a] * weights[b];
                        }
                    }
                    GramMatrix {
                        size: *size,
                        values,
                    }
                })
                .collect()
        };
        GramCertificate {
            eta: self.eta,
            lower: grams(&self.lower),
            upper: grams(&self.upper),
        }
    }
}

/// The certificate layout a search uses: the region certificate of `S` if
/// it declares one, else the global tables `basis` selects.
pub(crate) fn layout<S: MetriplecticSystem>(basis: SosBasis) -> Result<Layout> {
    let layout = Layout::of::<S>(basis.tables::<S>());
    layout.check::<S>()?;
    Ok(layout)
}

/// Adds the matching equalities and the PSD cones of `layout` to `problem`,
/// with θ in the variables from `theta_column` and the svec of every Gram
/// matrix (lower blocks, then upper) from `gram_column`.
pub(crate) fn add_sos_constraints<S: MetriplecticSystem>(
    problem: &mut L1Problem,
    layout: &Layout,
    eta: f64,
    theta_column: usize,
    gram_column: usize,
) -> Result<SosConstraints> {
    let n = S::DIM;
    let basis = S::METRIC_EXPONENTS.len();
    let sizes: Vec<usize> = layout
        .lower
        .iter()
        .chain(&layout.upper)
        .map(|block| block.size(n))
        .collect();
    let mut offsets = Vec::with_capacity(sizes.len());
    let mut next = gram_column;
    for &size in &sizes {
        offsets.push(next);
        next += svec_len(size);
    }
    let (lower_offsets, upper_offsets) = offsets.split_at(layout.lower.len());

    // The Gram variables are the scaled Q′ (Q = W Q′ W) and each target's
    // rows are multiplied by ρ^α (`Layout`): exact, and of order one in
    // any units.
    let weights: Vec<Vec<f64>> = layout
        .lower
        .iter()
        .chain(&layout.upper)
        .map(|block| layout.gram_weights(block, n))
        .collect();
    let (lower_weights, upper_weights) = weights.split_at(layout.lower.len());

    // Per pair and target: a lower row θ − Σ_lower = 0 and an upper row
    // θ + Σ_upper = η[j=k][α=0] (θ only on the metric basis).
    let mut entries = Vec::new();
    let mut rhs = Vec::new();
    for j in 0..n {
        for k in j..n {
            let pair = metric_pair_index(n, j, k);
            for alpha in 0..layout.targets {
                let target_scale = layout.target_scale(alpha);
                let (lower_row, upper_row) = (rhs.len(), rhs.len() + 1);
                rhs.push(0.0);
                // ρ^α = 1 at α = 0.
                rhs.push(if j == k && alpha == 0 { eta } else { 0.0 });
                if alpha < basis {
                    let t = theta_column + pair * basis + alpha;
                    entries.push((lower_row, t, target_scale));
                    entries.push((upper_row, t, target_scale));
                }
                for (row, sign, blocks, offsets, weights) in [
                    (lower_row, -1.0, &layout.lower, lower_offsets, lower_weights),
                    (upper_row, 1.0, &layout.upper, upper_offsets, upper_weights),
                ] {
                    for ((block, &offset), w) in blocks.iter().zip(offsets).zip(weights) {
                        let m = block.basis.len();
                        for (beta, gamma, c) in block.matching.entries(alpha) {
                            let (a, b) = (j * m + beta, k * m + gamma);
                            let c = c * w[a] * w[b] * target_scale;
                            // svec stores √2·Q_ab off the diagonal.
                            let weight = if a == b { c } else { c / SQRT_2 };
                            entries.push((row, offset + svec_index(a, b), sign * weight));
                        }
                    }
                }
            }
        }
    }
    problem.constrain(Cone::Zero(rhs.len()), entries, rhs)?;
    let mut cones = Vec::with_capacity(sizes.len());
    for ((&size, &offset), w) in sizes.iter().zip(&offsets).zip(weights) {
        let svec_size = svec_len(size);
        let id = problem.constrain(
            Cone::Psd(size),
            (0..svec_size).map(|i| (i, offset + i, -1.0)).collect(),
            vec![0.0; svec_size],
        )?;
        cones.push((id, size, w));
    }
    let upper = cones.split_off(layout.lower.len());
    Ok(SosConstraints {
        eta,
        lower: cones,
        upper,
    })
}

/// The metric coefficients the certificate leaves free: all of them with a
/// region, those with a non-empty matching list with the global tables
/// (the others are zero by the certificate itself).
pub(crate) fn certificate_free_metric<S: MetriplecticSystem>(basis: SosBasis) -> Vec<usize> {
    let tables = basis.tables::<S>();
    let size = S::METRIC_EXPONENTS.len();
    (0..S::DIM * (S::DIM + 1) / 2)
        .flat_map(|pair| {
            tables
                .matching
                .iter()
                .enumerate()
                .filter(|(_, pairs)| S::REGION_CERTIFICATE.is_some() || !pairs.is_empty())
                .map(move |(alpha, _)| pair * size + alpha)
        })
        .collect()
}

/// Adds the support's zero metric coefficients, the gauge and, for a
/// classical system, K∇H ≡ 0 as equality rows on θ (in the variables from
/// `theta_column`, in the coordinates of `layout`), and returns the classical rows for projecting the
/// solution onto them. Coefficients the certificate already forces to
/// zero get no row, and the classical rows are restricted to the free
/// coefficients and made independent: a repeated equality would make the
/// constraint matrix rank-deficient.
pub(crate) fn add_metric_restrictions<S: MetriplecticSystem>(
    problem: &mut L1Problem,
    layout: &Layout,
    options: &SearchOptions,
    theta_column: usize,
) -> Result<Equalities> {
    let free = certificate_free_metric::<S>(options.sos);
    let zeros: Vec<usize> = options
        .support
        .metric_zeros()
        .iter()
        .copied()
        .filter(|t| free.binary_search(t).is_ok())
        .collect();
    let mut entries: Vec<(usize, usize, f64)> = zeros
        .iter()
        .enumerate()
        .map(|(row, &t)| (row, theta_column + t, 1.0))
        .collect();
    let mut rhs = vec![0.0; zeros.len()];
    if let Some(gauge) = options.gauge {
        let (row, value) = gauge.row::<S>();
        let at = rhs.len();
        entries.extend(row.into_iter().map(|(t, w)| (at, theta_column + t, w)));
        rhs.push(value);
    }
    let degenerate = Equalities::new(
        classical::metric_rows::<S>(),
        &options.support.free_metric::<S>(options.sos),
    );
    let at = rhs.len();
    entries.extend(
        degenerate
            .entries(0)
            .into_iter()
            .map(|(r, j, v)| (at + r, theta_column + degenerate.coefficient(j), v)),
    );
    rhs.resize(at + degenerate.len(), 0.0);
    // The rows are on θ in x; a centred layout's columns are in y.
    if let Some(shift) = layout.shift() {
        entries = shift.rows(entries, theta_column, S::metric_coefficient_count());
    }
    if !rhs.is_empty() {
        problem.constrain(Cone::Zero(rhs.len()), entries, rhs)?;
    }
    Ok(degenerate)
}
