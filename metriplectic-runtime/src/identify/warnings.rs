//! What the data cannot determine, and what a run left unsettled: typed
//! warnings an identification returns instead of silence when the samples
//! are too few or too alike for the coefficients sought, or when the run hit
//! its iteration cap while still improving.

use serde::{Deserialize, Serialize};

use super::config::IdentifyConfig;
use super::history::{History, StepOutcome};
use super::search::{
    centred_entropy_regression, centred_metric_regression, entropy_regression, entropy_shift,
    metric_regression,
};
use crate::analysis::identifiability::{
    data_states, free_energy_variation, hamiltonian_coefficients,
};
use crate::data::IdentificationData;
use crate::error::Num;
use crate::error::Result;
use crate::model::classical::{self, Equalities};
use crate::model::{Layout, Model};
use crate::solve::linalg::{
    column_scales, full_rank_on_rows, row_by_row, singular_values, strided_rows,
    symmetric_eigenvalues, triangular_factor,
};
use crate::solve::Regression;
use crate::system::{CertificateMode, MetriplecticSystem};

/// Singular values of the column-normalised block at most this fraction of
/// the largest count as zero: the default tolerance of
/// [`identifiability`](crate::identifiability), so that the warning and the
/// report agree on what the data determine. A run from S = 0 that stopped
/// with K off by 1e-7 lifted two flat Casimir directions of an entropy
/// block to 7e-10 and 3e-9 of the largest; with 1e-12 on raw columns the
/// warning missed them and ∇S came back 28% wrong without a word.
const RANK_TOLERANCE: f64 = crate::analysis::identifiability::DEFAULT_TOLERANCE;

/// An entropy coefficient within this fraction of η of ±η is at the bound
/// (an interior-point solution stops a few digits short of an active bound).
const BOUND_TOLERANCE: f64 = 1e-6;

/// The metric's largest eigenvalue within this fraction of η is at the
/// bound K ⪯ ηI: looser than [`BOUND_TOLERANCE`], since for a state-dependent
/// metric the bound may bind at a state between the data's.
const METRIC_BOUND_TOLERANCE: f64 = 1e-3;

/// A fit whose misfit is above this says nothing about Π∇E = 0: the
/// symmetry test's tolerance grows with the misfit only up to it (a probe's
/// fit at held-out error 0.73 was told Π∇E = 0 on the data).
const MAX_SYMMETRY_MISFIT: f64 = 0.1;

/// Iterations over which [`IdentifyWarning::StillImproving`] measures the
/// rate when the run has no stagnation window.
const DEFAULT_RATE_WINDOW: usize = 5;

/// Below this fall per iteration, [`IdentifyWarning::StillImproving`]'s
/// message mentions a curved valley (the crawls measured in
/// `docs/method.md` §3 fell 0.1–1% per iteration).
const SLOW_RATE: f64 = 0.02;

/// A fall per iteration below this is no progress but a settled run's
/// rounding (a probe's run at a local minimum fell 1e-10 per iteration and
/// was told it would need 1.4e13 more); the slowest genuine crawls measured
/// fell 0.1% per iteration.
const NEGLIGIBLE_RATE: f64 = 1e-4;

/// A coefficient block of a model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CoefficientBlock {
    /// The entropy coefficients ψ.
    Entropy,
    /// The metric coefficients θ the certificate leaves free.
    Metric,
}

/// Something the data cannot determine about the model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum IdentifyWarning {
    /// Fewer equations (samples × state components) than unknown
    /// coefficients: many models fit the data equally.
    Underdetermined {
        /// Samples × state components.
        equations: usize,
        /// Entropy coefficients plus the metric coefficients left free,
        /// less the combinations the classical form's equalities fix.
        unknowns: usize,
    },
    /// Each minibatch of `batch` samples gives fewer equations than the
    /// model has unknown coefficients, so every iteration's fit is
    /// underdetermined: the start and the bounds, not the data, decide
    /// what each batch leaves free. Raise
    /// [`IdentifyConfig::batch_size`](crate::IdentifyConfig::batch_size)
    /// to at least the unknowns over the state dimension.
    BatchUnderdetermined {
        /// The batch size q.
        batch: usize,
        /// q × state components.
        equations: usize,
        /// Unknown coefficients, as for [`IdentifyWarning::Underdetermined`].
        unknowns: usize,
    },
    /// The samples determine only `rank` independent combinations of a
    /// block's `coefficients` (the samples repeat, lie on a low-dimensional
    /// set, or are too small for the basis's degree).
    RankDeficient {
        /// Which coefficients.
        block: CoefficientBlock,
        /// Numerical rank of the block's regression on the data.
        rank: usize,
        /// Number of coefficients in the block.
        coefficients: usize,
    },
    /// `count` entropy coefficients of the returned model sit at the
    /// coefficient bound |ψₖ| ≤ η: the bound, not the data, decided them,
    /// and the model the data need may lie beyond it.
    AtCoefficientBound {
        /// Entropy coefficients at ±η.
        count: usize,
        /// The bound η the run used.
        eta: f64,
    },
    /// The bound η is below the Hamiltonian's largest coefficient
    /// ([`MetriplecticSystem::HAMILTONIAN_SCALE`]): no entropy within it can
    /// outweigh H, as the entropy of a system that comes to rest must, so
    /// the fit may be poor without any coefficient reaching the bound.
    BoundBelowHamiltonian {
        /// The bound η the run used.
        eta: f64,
        /// The Hamiltonian's largest non-constant coefficient.
        hamiltonian_scale: f64,
    },
    /// The run reached [`IdentifyConfig::max_iterations`] while its score
    /// was still falling (by at least 0.01% per iteration; less is a
    /// settled run's rounding): more iterations would fit better. A steady fall of
    /// a few per cent or less per iteration can also mean the iterates
    /// follow a curved valley of the bilinear cost, which they leave only
    /// slowly (`docs/method.md` §3); the message then says so.
    StillImproving {
        /// The last score (cost per component, on the validation samples or
        /// the full batch).
        cost: f64,
        /// The score the run would stop at: the tolerance times the data's
        /// scale.
        target: f64,
        /// Mean fraction by which the score fell per iteration over the last
        /// iterations (the stagnation window, 5 without one).
        rate: f64,
        /// Further iterations the target would take at that rate; `None`
        /// when the target is 0.
        projected_iterations: Option<u64>,
    },
    /// The data cannot tell the model from (cK, E/c) for any c > 0: Π∇E = 0
    /// on them (‖Π∇E‖ below 1e-8 of the field's size over the data, or
    /// below the fit's relative residual where that is larger), so the
    /// field is K∇E alone and the fit picked one scale of K and E; in the
    /// classical form (cK, S/c) fits any data as well as (K, S). Only the
    /// field and the product of the scales are determined. A
    /// [`Gauge`](crate::Gauge) fixes the scale. Not raised with a gauge, a
    /// zero metric or entropy, or when E/c − H lies outside the entropy
    /// basis or its support.
    ScaleSymmetry {
        /// Whether it is the classical form's (K, S) ↦ (cK, S/c).
        classical: bool,
    },
    /// `outside` of the data's `states` lie outside the region of a system
    /// declared with `certificate on region`: the model's dE/dt ≥ 0 is
    /// proved only inside the region, so nothing certifies it where those
    /// data are. Enlarge the region or drop `certificate on region` (the
    /// default mode proves K(x) ⪰ 0 for every state).
    DataOutsideRegion {
        /// Distinct data states outside the region.
        outside: usize,
        /// Distinct data states.
        states: usize,
    },
    /// The model explains little of the data: the typical relative
    /// residual of its fit, median |prediction − target| over the
    /// equations' components against their mean |target|, is at least 0.5,
    /// or the median of each component's |residual| against its own
    /// |target| (the median |target| where that is larger) is (0 is exact;
    /// medians, so that outliers the L1 fit ignores do not count; the
    /// second, because a few large targets lift the mean: pure noise whose
    /// sizes span two decades had a typical residual below 0.5). The data
    /// may not come from the declared system, be mostly noise, or need what
    /// the basis, the support or a gauge exclude.
    PoorFit {
        /// The fit's typical relative residual on the data.
        relative_residual: f64,
        /// The median of |residual| / max(|target|, median |target|) over
        /// the equations' components.
        per_target: f64,
    },
    /// Weak-form equations that may be off by about `spread`: their targets
    /// move by that fraction of their size between local polynomial
    /// degrees `degree` and `other` ([`WeakDataset::quadrature_spread`](crate::WeakDataset::quadrature_spread)),
    /// at least 3e-2 and ten times the fit's typical relative residual
    /// (noisy states move the targets too, but leave as large a residual).
    /// The samples are too sparse for the windows, and a model fitted to
    /// the equations can be that far from the true field however well it
    /// fits them.
    WeakQuadrature {
        /// Σ|Δy|/Σ|y| of the targets between the two degrees.
        spread: f64,
        /// `WeakForm::local_degree`.
        degree: usize,
        /// The neighbouring degree compared.
        other: usize,
    },
    /// A [`Gauge`](crate::Gauge) fixes the scale of K, but the data
    /// determine it already (Π∇E ≠ 0 on them): the gauge is then a
    /// constraint on the fit, which biases it unless its value is the true
    /// one. Not raised for the classical form, whose scale the data never
    /// determine.
    GaugeConstrainsFit {
        /// The gauge's value, tr K(0).
        trace: f64,
    },
    /// The metric's largest eigenvalue on the data states reaches the
    /// bound η of the metric search (K ⪯ ηI): the bound, not the data, may
    /// have set the metric's size (a probe's friction of 50 came back as 20
    /// = η without a word).
    MetricAtBound {
        /// The largest eigenvalue of K(x) over the fit's states.
        eigenvalue: f64,
        /// The bound η the run used.
        eta: f64,
    },
    /// Each block's coefficients are determined at the other's value, but
    /// `directions` combinations of the two blocks together are not: the
    /// data cannot tell changes of S and K along them apart (a damped
    /// linear oscillator, for one, gives four equations, ẋ = Mx, for six
    /// unknowns: three quadratic terms of S and three entries of K). The field is determined; those combinations of S
    /// and K are not. [`identifiability`](crate::identifiability) names
    /// them. Counted as its `FlatKind::Data` directions, without the scale
    /// symmetry (its own warning) and without directions hidden only by
    /// the misfit; not raised when a block's own rank is already short.
    JointlyUndetermined {
        /// Undetermined combinations of entropy and metric coefficients.
        directions: usize,
        /// Unknown coefficients analysed.
        unknowns: usize,
    },
    /// Most solves of one subproblem failed (status not usable, or a result
    /// the model refused), so the coefficients it searches stayed near the
    /// start or an early iterate.
    FailedSolves {
        /// The subproblem.
        subproblem: Subproblem,
        /// Solves that failed.
        failed: usize,
        /// Solves attempted (skipped ones not counted).
        attempted: usize,
    },
    /// [`select_degrees`](crate::select_degrees) passed over simpler
    /// degree caps whose own identification
    /// [`failed`](crate::DegreeCandidate::failed) (most solves of a
    /// subproblem failed, or it stopped on solver failures): their
    /// validation cost may be the failed fit's rather than the degrees',
    /// so the data may need fewer degrees than chosen.
    SimplerDegreesFailed {
        /// The candidate's entropy degree cap.
        entropy_degree: u32,
        /// The candidate's metric degree cap.
        metric_degree: u32,
        /// Its validation cost per component.
        validation_cost: f64,
    },
}

/// One of an iteration's convex subproblems.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Subproblem {
    /// The metric search (entropy fixed).
    MetricSearch,
    /// The entropy search (metric fixed).
    EntropySearch,
    /// The joint step.
    JointStep,
}

impl std::fmt::Display for Subproblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::MetricSearch => "metric searches",
            Self::EntropySearch => "entropy searches",
            Self::JointStep => "joint steps",
        })
    }
}

impl std::fmt::Display for IdentifyWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Underdetermined {
                equations,
                unknowns,
            } => write!(
                f,
                "{equations} equations for {unknowns} unknown coefficients: the data cannot determine the model"
            ),
            Self::RankDeficient {
                block,
                rank,
                coefficients,
            } => write!(
                f,
                "the data determine only {rank} of the {coefficients} {} coefficients",
                match block {
                    CoefficientBlock::Entropy => "entropy",
                    CoefficientBlock::Metric => "free metric",
                }
            ),
            Self::AtCoefficientBound { count, eta } => write!(
                f,
                "{count} entropy coefficient{} at the bound |ψ| ≤ η = {eta:e}: the bound may cut off \
                 the model the data need; raise SearchOptions::eta",
                if *count == 1 { " is" } else { "s are" }
            ),
            Self::BoundBelowHamiltonian {
                eta,
                hamiltonian_scale,
            } => write!(
                f,
                "the coefficient bound η = {eta:e} is below the Hamiltonian's largest coefficient \
                 {hamiltonian_scale:e}: no entropy within it can outweigh H; raise \
                 SearchOptions::eta or leave it None (max(20, 4h, 4π))"
            ),
            Self::ScaleSymmetry { classical: true } => write!(
                f,
                "(cK, S/c) fits any data as well as (K, S) for every c > 0: the scale of the \
                 metric and the entropy is not determined, only the field; fix it with \
                 SearchOptions::gauge"
            ),
            Self::ScaleSymmetry { classical: false } => write!(
                f,
                "Π∇E = 0 on the data, so (cK, E/c) fits as well as (K, E) for every c > 0: the \
                 scale of the metric and the free energy is not determined, only the field; fix \
                 it with SearchOptions::gauge"
            ),
            Self::DataOutsideRegion { outside, states } => write!(
                f,
                "{outside} of the {states} data states lie outside the region the metric is \
                 certified on (`certificate on region`): dE/dt ≥ 0 is not proved where they are; \
                 enlarge the region or drop `certificate on region`"
            ),
            Self::PoorFit {
                relative_residual,
                per_target,
            } => write!(
                f,
                "the model explains little of the data: its typical residual is \
                 {relative_residual:.3} of the data's mean |ẋ|, and a typical component's is \
                 {per_target:.3} of its own (0 is exact); the data may not come from this system \
                 or be mostly noise, or the model they need lies outside the basis, the support \
                 or the gauge"
            ),
            Self::WeakQuadrature {
                spread,
                degree,
                other,
            } => write!(
                f,
                "the weak-form equations' targets move by {spread:.1e} of their size between \
                 local polynomial degrees {degree} and {other}, far more than the fit's \
                 residual: on these sample times the equations, and so a model fitted to them, \
                 may be off by about that much; sample more densely, shorten WeakForm::window, \
                 or compare WeakForm::local_degree {other}"
            ),
            Self::GaugeConstrainsFit { trace } => write!(
                f,
                "the data determine the scale of K and E (Π∇E ≠ 0 on them), so the gauge \
                 tr K(0) = {trace:e} constrains the fit and biases it unless that is the true \
                 trace; drop SearchOptions::gauge unless the trace is known"
            ),
            Self::MetricAtBound { eigenvalue, eta } => write!(
                f,
                "the metric's largest eigenvalue on the data, {eigenvalue:.4e}, is at the \
                 bound K ⪯ ηI, η = {}: the bound may have cut off the metric the data need; \
                 raise SearchOptions::eta",
                Num(*eta)
            ),
            Self::JointlyUndetermined {
                directions,
                unknowns,
            } => write!(
                f,
                "the data leave {directions} combination{} of entropy and metric coefficients \
                 undetermined (of {unknowns} unknowns; each block alone is determined at the \
                 other's value): the field is fitted, but S and K are not fixed along {}; \
                 `identifiability` names {}",
                if *directions == 1 { "" } else { "s" },
                if *directions == 1 { "it" } else { "them" },
                if *directions == 1 { "it" } else { "them" },
            ),
            Self::BatchUnderdetermined {
                batch,
                equations,
                unknowns,
            } => write!(
                f,
                "each minibatch of {batch} samples gives {equations} equations for {unknowns} \
                 unknown coefficients, so every iteration's fit is underdetermined; raise \
                 IdentifyConfig::batch_size (or use None for the full batch)"
            ),
            Self::FailedSolves {
                subproblem,
                failed,
                attempted,
            } => write!(
                f,
                "{failed} of {attempted} {subproblem} failed (the solver's status was not \
                 usable, or its result was refused), so what they search stayed near the start; \
                 the history's statuses say more. Common causes: badly scaled states or a \
                 region far from the origin (rescale or centre the state variables), or \
                 coefficients many orders apart, as of a fast and a slow mode (start from the \
                 default entropy, or try SolverBackend::Clarabel, cargo feature `clarabel`)"
            ),
            Self::SimplerDegreesFailed {
                entropy_degree,
                metric_degree,
                validation_cost,
            } => write!(
                f,
                "the simpler entropy degree {entropy_degree} with metric degree {metric_degree} \
                 was passed over, but its own fit failed (validation cost per component \
                 {validation_cost:.3e}; its candidate's warnings say how): the data may need \
                 fewer degrees than chosen; refit at those caps with other settings (e.g. \
                 SolverBackend::Clarabel) to compare"
            ),
            Self::StillImproving {
                cost,
                target,
                rate,
                projected_iterations,
            } => {
                write!(
                    f,
                    "the run reached max_iterations while still improving: cost per component \
                     {cost:.3e}, falling {:.3}% per iteration",
                    rate * 100.0
                )?;
                if let Some(more) = projected_iterations {
                    write!(
                        f,
                        "; at that rate the tolerance ({target:.3e}) takes about {more} more \
                         iterations"
                    )?;
                }
                write!(f, "; raise IdentifyConfig::max_iterations")?;
                if *rate < SLOW_RATE {
                    write!(
                        f,
                        ", or accept the model as it is: a fall this slow and steady can be a \
                         curved valley of the cost that more iterations leave only slowly"
                    )?;
                }
                Ok(())
            }
        }
    }
}

/// [`IdentifyWarning::StillImproving`] for a run that stopped at its
/// iteration cap with `history`, if its score fell over the last iterations
/// and is still above `target`. Scores are the validation costs, or the
/// batch costs of a full-batch run (a minibatch run without validation
/// samples scores a different batch every iteration, so it gets none);
/// warm-up and polish iterations are left out.
pub(crate) fn progress_warning(
    history: &History,
    config: &IdentifyConfig,
    target: f64,
) -> Option<IdentifyWarning> {
    let full_batch = config.batch_size.is_none();
    let scores: Vec<f64> = history
        .iterations
        .iter()
        .filter(|record| !record.warm_up && !record.polish)
        .map(|record| match record.validation_cost {
            Some(score) => Some(score.per_component),
            None if full_batch => Some(record.cost_after().per_component),
            None => None,
        })
        .collect::<Option<_>>()?;
    let window = config
        .stagnation
        .map_or(DEFAULT_RATE_WINDOW, |stagnation| stagnation.window);
    let (rate, projected_iterations) = fall_rate(&scores, window, target)?;
    Some(IdentifyWarning::StillImproving {
        cost: scores[scores.len() - 1],
        target,
        rate,
        projected_iterations,
    })
}

/// The mean fraction by which `scores` fell per iteration over their last
/// `window` iterations, and the iterations `target` would take at that
/// rate (`None` for a target of 0); `None` if there are fewer than two
/// scores, they fell by less than [`NEGLIGIBLE_RATE`] per iteration, or the
/// last is already at the target.
fn fall_rate(scores: &[f64], window: usize, target: f64) -> Option<(f64, Option<u64>)> {
    let span = window.min(scores.len().checked_sub(1)?);
    let (last, earlier) = (scores[scores.len() - 1], scores[scores.len() - 1 - span]);
    if span == 0 || !(last > 0.0 && last < earlier && last > target) || !last.is_finite() {
        return None;
    }
    let per_iteration = (last / earlier).powf(1.0 / span as f64);
    if 1.0 - per_iteration < NEGLIGIBLE_RATE {
        return None;
    }
    let projected = (target > 0.0).then(|| {
        let more = (last / target).ln() / -per_iteration.ln();
        // Saturates for a fall too slow to count.
        more.ceil().min(u64::MAX as f64) as u64
    });
    Some((1.0 - per_iteration, projected))
}

/// The warnings for `model` identified from `data`.
pub(crate) fn data_warnings<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    model: &Model<S>,
    config: &IdentifyConfig,
) -> Result<Vec<IdentifyWarning>> {
    // The unknowns: what the certificate and the support leave free.
    let support = &config.search.support;
    let free = support.free_metric::<S>(config.search.sos);
    let free_entropy = support.free_entropy::<S>();
    let p = free_entropy.len();
    // A classical system's equalities (S a Casimir, K∇H ≡ 0) fix some
    // combinations whatever the data: only the rest are unknowns (their
    // rows are orthonormal, so each fixes one).
    let entropy_rows = Equalities::new(classical::entropy_rows::<S>(), &free_entropy).dense_rows();
    let metric_rows = Equalities::new(classical::metric_rows::<S>(), &free).dense_rows();
    let equations = data.equation_count() * S::DIM;
    let all_unknowns = (p + free.len()).saturating_sub(entropy_rows.len() + metric_rows.len());
    let mut warnings = Vec::new();
    if equations < all_unknowns {
        warnings.push(IdentifyWarning::Underdetermined {
            equations,
            unknowns: all_unknowns,
        });
    }
    // Each minibatch fit is then underdetermined too, whatever the data: a
    // probe's batch of 1 on 610 samples ended 19 times off on held-out
    // data, with no warning.
    if let Some(batch) = config.batch_size {
        let batch_equations = batch.saturating_mul(S::DIM);
        if batch < data.equation_count()
            && equations >= all_unknowns
            && batch_equations < all_unknowns
        {
            warnings.push(IdentifyWarning::BatchUnderdetermined {
                batch,
                equations: batch_equations,
                unknowns: all_unknowns,
            });
        }
    }
    // On states far from the origin the rank is taken in centred
    // coordinates, as the searches fit (the same rank exactly; in x the
    // monomial columns are collinear to rounding). A classical system's
    // rows stay in x, where they are orthonormal.
    let centre = if entropy_rows.is_empty() {
        entropy_shift::<S>(data, &free_entropy)
    } else {
        None
    };
    let entropy = match &centre {
        Some(shift) => centred_entropy_regression::<S>(shift, data, model.metric_coefficients())?,
        None => entropy_regression::<S>(data, model.metric_coefficients())?,
    };
    let unknowns = p.saturating_sub(entropy_rows.len());
    if let Some(rank) = numerical_rank(&entropy, &free_entropy, &entropy_rows) {
        if rank < unknowns {
            warnings.push(IdentifyWarning::RankDeficient {
                block: CoefficientBlock::Entropy,
                rank,
                coefficients: unknowns,
            });
        }
    }
    let eta = config.search.eta_for::<S>();
    let psi = model.entropy_coefficients();
    let at_bound = free_entropy
        .iter()
        .filter(|&&k| psi[k].abs() >= (1.0 - BOUND_TOLERANCE) * eta)
        .count();
    if at_bound > 0 {
        warnings.push(IdentifyWarning::AtCoefficientBound {
            count: at_bound,
            eta,
        });
    }
    if eta < S::HAMILTONIAN_SCALE {
        warnings.push(IdentifyWarning::BoundBelowHamiltonian {
            eta,
            hamiltonian_scale: S::HAMILTONIAN_SCALE,
        });
    }
    if let Some(eigenvalue) = largest_metric_eigenvalue(data, model) {
        // Above the bound is no search's doing (a start beyond it).
        let band = (1.0 - METRIC_BOUND_TOLERANCE) * eta..=(1.0 + METRIC_BOUND_TOLERANCE) * eta;
        if band.contains(&eigenvalue) {
            warnings.push(IdentifyWarning::MetricAtBound { eigenvalue, eta });
        }
    }
    // A region far from the origin: θ's columns as the searches read them.
    let layout = Layout::of::<S>(config.search.sos.tables::<S>());
    let metric = match layout.shift() {
        // Not with a support or classical rows, which are on θ in x.
        Some(shift) if metric_rows.is_empty() && free.len() == S::metric_coefficient_count() => {
            centred_metric_regression::<S>(shift, data, psi)?
        }
        _ => metric_regression::<S>(data, psi)?,
    };
    let unknowns = free.len().saturating_sub(metric_rows.len());
    // Where S cancels H on the data, K∇E is rounding whatever K: no metric
    // direction is determined (the report's rule).
    let cancelled = free_energy_variation::<S>(data, psi).is_some_and(|v| v < RANK_TOLERANCE);
    let metric_rank = if cancelled {
        Some(0)
    } else {
        numerical_rank(&metric, &free, &metric_rows)
    };
    if let Some(rank) = metric_rank {
        if rank < unknowns {
            warnings.push(IdentifyWarning::RankDeficient {
                block: CoefficientBlock::Metric,
                rank,
                coefficients: unknowns,
            });
        }
    }
    if let Some(certificate) = S::REGION_CERTIFICATE {
        if certificate.mode == CertificateMode::OnRegion {
            let states = data_states(data);
            let outside = states
                .iter()
                .filter(|x| !certificate.region.contains(x))
                .count();
            if outside > 0 {
                warnings.push(IdentifyWarning::DataOutsideRegion {
                    outside,
                    states: states.len(),
                });
            }
        }
    }
    // The entropy rows are in the coordinates the searches fit.
    let searched = match &centre {
        Some(centre) => centre.to_centred(psi),
        None => psi.to_vec(),
    };
    let misfit = relative_residual(data, &entropy, &searched);
    // Judged by medians, as the L1 fit is: outliers the fit rightly ignores
    // leave large residuals that say nothing about the rest.
    let (typical, per_target) = typical_relative_residuals(data, &entropy, &searched);
    // Equations far less certain than the fit's residual: the fit follows
    // the quadrature's error. Noisy states move the targets too, but then
    // the residual is as large (noise cannot be fitted), and no warning.
    if let Some((spread, degree, other)) = data.quadrature_spread() {
        if spread >= QUADRATURE_SPREAD && typical * QUADRATURE_MARGIN <= spread {
            warnings.push(IdentifyWarning::WeakQuadrature {
                spread,
                degree,
                other,
            });
        }
    }
    if typical >= POOR_FIT || per_target >= POOR_FIT {
        // A fit this poor says nothing about symmetries of the data.
        warnings.push(IdentifyWarning::PoorFit {
            relative_residual: typical,
            per_target,
        });
        return Ok(warnings);
    }
    // The classical form's scale is never determined by data.
    let poisson_is_zero = if S::CLASSICAL.is_none() {
        poisson_part_vanishes(data, model, misfit)
    } else {
        None
    };
    if let Some(crate::Gauge::MetricTrace(trace)) = config.search.gauge {
        if poisson_is_zero == Some(false) {
            warnings.push(IdentifyWarning::GaugeConstrainsFit { trace });
        }
    }
    let symmetric = S::CLASSICAL.is_some() || poisson_is_zero == Some(true);
    let scale_free = symmetric && scale_is_free(data, model, config);
    if scale_free {
        warnings.push(IdentifyWarning::ScaleSymmetry {
            classical: S::CLASSICAL.is_some(),
        });
    }
    let blocks_short = warnings.iter().any(|w| {
        matches!(
            w,
            IdentifyWarning::Underdetermined { .. } | IdentifyWarning::RankDeficient { .. }
        )
    });
    if !blocks_short {
        if let Some(warning) = joint_warning(data, model, config, scale_free) {
            warnings.push(warning);
        }
    }
    Ok(warnings)
}

/// [`IdentifyWarning::JointlyUndetermined`] from the identifiability
/// report of `model` on `data`, if it names directions the data do not
/// determine beyond the scale symmetry (`scale_free`: already warned of).
/// The report is made only where a subset of the rows does not show that
/// the data determine everything (its QR over every row costs seconds at
/// 10⁵ rows). A report that cannot be made (its SVD failed) gives none: the
/// warnings never fail a run.
fn joint_warning<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    model: &Model<S>,
    config: &IdentifyConfig,
    scale_free: bool,
) -> Option<IdentifyWarning> {
    use crate::analysis::identifiability::{
        report_unless_determined, FlatKind, IdentifiabilityOptions,
    };
    let options = IdentifiabilityOptions {
        search: config.search.clone(),
        ..IdentifiabilityOptions::default()
    };
    let report = report_unless_determined(model, data, &options).ok()??;
    let named_scale = report
        .flat_directions
        .iter()
        .any(|d| d.kind == FlatKind::ScaleSymmetry);
    let data_directions = report
        .flat_directions
        .iter()
        .filter(|d| d.kind == FlatKind::Data)
        .count();
    // The scale direction, when the report did not recognise it as such,
    // is among its data directions: it has its own warning.
    let directions = if scale_free && !named_scale {
        data_directions.saturating_sub(1)
    } else {
        data_directions
    };
    (directions > 0).then_some(IdentifyWarning::JointlyUndetermined {
        directions,
        unknowns: report.unknowns,
    })
}

/// Weak-form targets that move by at least this fraction between two local
/// degrees make an [`IdentifyWarning::WeakQuadrature`]: on the paper's
/// data the spread is (measured below), and fits reach a few 1e-3.
const QUADRATURE_SPREAD: f64 = 3e-2;

/// How many times the fit's typical relative residual the spread must be
/// for [`IdentifyWarning::WeakQuadrature`].
const QUADRATURE_MARGIN: f64 = 10.0;

/// A fit with at least this typical relative residual explains little of
/// its data ([`IdentifyWarning::PoorFit`]).
const POOR_FIT: f64 = 0.5;

/// The median |r| of the entropy regression `entropy` at `psi` over the
/// equations' components, against the data's scale (their mean |y|, 1 if
/// all are zero): how well the fit explains a typical target, unmoved by a
/// minority of outliers the L1 fit ignores, and by components that never
/// move (a median of the targets would fall to them). Second, the median
/// of |rᵢ| / max(|yᵢ|, median |y|): the same per target, so that a few
/// large targets do not hide that the others are not explained (pure noise
/// with sizes spread over two decades had a typical residual of 0.3; a
/// probe); the floor keeps small targets, noise-dominated in good fits,
/// from counting as unexplained. Both 0 without equations.
fn typical_relative_residuals(
    data: &impl IdentificationData,
    entropy: &Regression,
    psi: &[f64],
) -> (f64, f64) {
    let residuals: Vec<f64> = entropy.residuals(psi).iter().map(|r| r.abs()).collect();
    if residuals.is_empty() {
        return (0.0, 0.0);
    }
    let scale = data.equations().scale();
    let targets: Vec<f64> = data.equations().targets.iter().map(|y| y.abs()).collect();
    if targets.len() != residuals.len() {
        return (median(residuals) / scale, 0.0);
    }
    let floor = match median(targets.clone()) {
        m if m > 0.0 && m.is_finite() => m,
        _ => scale,
    };
    let ratios: Vec<f64> = residuals
        .iter()
        .zip(&targets)
        .map(|(r, y)| r / y.max(floor))
        .collect();
    (median(residuals) / scale, median(ratios))
}

/// The upper median of `values` (not empty).
fn median(mut values: Vec<f64>) -> f64 {
    let middle = values.len() / 2;
    *values.select_nth_unstable_by(middle, f64::total_cmp).1
}

/// ‖r‖ / ‖y‖ of the entropy regression `entropy` at `psi`: the fit's
/// residual against its targets (weak-form equations are integrals); 0 for
/// targets that are all zero.
fn relative_residual(data: &impl IdentificationData, entropy: &Regression, psi: &[f64]) -> f64 {
    let residual = entropy.l2_residual(psi);
    let measured = data.equations().targets.iter().map(|y| y * y).sum::<f64>();
    if measured > 0.0 {
        residual / measured.sqrt()
    } else {
        0.0
    }
}

/// ‖Π∇E‖ over the data below this fraction of the field's, or below the
/// fit's relative residual if that is larger: the scale symmetry holds
/// (the identifiability report's tolerance).
const SCALE_TOLERANCE: f64 = 1e-8;

/// Whether the scale (K, E) ↦ (cK, E/c), or in the classical form
/// (K, S) ↦ (cK, S/c), is left free with no gauge to fix it, for data on
/// which Π∇E = 0 ([`poisson_part_vanishes`]; along c = 1 + ε the field
/// changes by −εΠ∇E, and classically by −εΠ∇S = 0): it is when E/c − H
/// stays in the entropy basis and its support (H's coefficients there
/// exist and ψ + h is zero where the support holds ψ at zero).
fn scale_is_free<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    model: &Model<S>,
    config: &IdentifyConfig,
) -> bool {
    let psi = model.entropy_coefficients();
    let some = |v: &[f64]| v.iter().any(|&c| c != 0.0);
    if config.search.gauge.is_some() || !some(model.metric_coefficients()) || !some(psi) {
        return false;
    }
    if S::CLASSICAL.is_some() {
        return true;
    }
    let Some(h) = hamiltonian_coefficients::<S>(data) else {
        return false;
    };
    let free = config.search.support.free_entropy::<S>();
    let shifted: Vec<f64> = psi.iter().zip(&h).map(|(a, b)| a + b).collect();
    let size = shifted.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let held = (0..shifted.len())
        .filter(|k| free.binary_search(k).is_err())
        .fold(0.0_f64, |m, k| m.max(shifted[k].abs()));
    size > 0.0 && held <= 1e-9 * size
}

/// Whether Π∇E vanishes on the data's states: ‖Π∇E‖ below
/// [`SCALE_TOLERANCE`] of the field's size, or below the fit's relative
/// residual `misfit` where that is larger (doubling K then changes the
/// field by less than the misfit does). `None` when the field is zero on
/// all of them (nothing to compare with).
fn poisson_part_vanishes<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    model: &Model<S>,
    misfit: f64,
) -> Option<bool> {
    let n = S::DIM;
    let (mut gradient, mut poisson, mut field) = (vec![0.0; n], vec![0.0; n * n], vec![0.0; n]);
    let (mut poisson_part, mut whole) = (0.0_f64, 0.0_f64);
    for x in data_states(data) {
        model.free_energy_gradient_unchecked(x, &mut gradient);
        model.vector_field_unchecked(x, &mut field);
        S::poisson(x, &mut poisson);
        for (row, f) in poisson.chunks_exact(n).zip(&field) {
            let value: f64 = row.iter().zip(&gradient).map(|(a, g)| a * g).sum();
            poisson_part += value * value;
            whole += f * f;
        }
    }
    // Relative sizes: the states' Π∇E against their field.
    let tolerance = SCALE_TOLERANCE.max(misfit.min(MAX_SYMMETRY_MISFIT));
    (whole > 0.0).then(|| poisson_part.sqrt() <= tolerance * whole.sqrt())
}

/// The largest eigenvalue of K(x) over the data's states and the origin
/// (where the bound's constant term acts), for a system with a region only
/// those in it (the bound holds there); `None` without states or if an
/// eigensolve fails.
fn largest_metric_eigenvalue<S: MetriplecticSystem>(
    data: &impl IdentificationData,
    model: &Model<S>,
) -> Option<f64> {
    let n = S::DIM;
    let origin = vec![0.0; n];
    let mut metric = vec![0.0; n * n];
    let mut largest: Option<f64> = None;
    let in_region =
        |x: &&[f64]| S::REGION_CERTIFICATE.is_none_or(|certificate| certificate.region.contains(x));
    for x in data_states(data)
        .into_iter()
        .chain([origin.as_slice()])
        .filter(in_region)
    {
        S::metric_value(x, model.metric_coefficients(), &mut metric);
        let matrix = nalgebra::DMatrix::from_row_slice(n, n, &metric);
        let values = symmetric_eigenvalues(&matrix)?;
        let top = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        largest = Some(largest.map_or(top, |l| l.max(top)));
    }
    largest
}

/// [`IdentifyWarning::FailedSolves`] for each subproblem most of whose
/// solves in `history` failed.
pub(crate) fn failed_solves(history: &History) -> Vec<IdentifyWarning> {
    let mut counts = [
        (Subproblem::MetricSearch, 0, 0),
        (Subproblem::EntropySearch, 0, 0),
        (Subproblem::JointStep, 0, 0),
    ];
    for record in &history.iterations {
        let joint = record.joint.as_ref().map(|joint| &joint.step);
        for (count, step) in
            counts
                .iter_mut()
                .zip([Some(&record.metric), Some(&record.entropy), joint])
        {
            match step.map(|step| step.outcome) {
                None | Some(StepOutcome::Skipped) => {}
                Some(outcome) => {
                    count.2 += 1;
                    count.1 += usize::from(outcome == StepOutcome::RejectedFailed);
                }
            }
        }
    }
    counts
        .into_iter()
        .filter(|&(_, failed, attempted)| failed > 0 && 2 * failed > attempted)
        .map(
            |(subproblem, failed, attempted)| IdentifyWarning::FailedSolves {
                subproblem,
                failed,
                attempted,
            },
        )
        .collect()
}

/// Numerical rank of the regression's `columns` on the subspace where the
/// orthonormal `constraints` (dense over `columns`) vanish: the rank of A
/// stacked over the constraints, less theirs. Columns are divided by their
/// norms first (a column without data by 1), as the identifiability
/// report's are, so that a basis whose monomials differ in size by many
/// orders does not read as rank-deficient, and the constraints are
/// rewritten in those units, each of norm one. Full rank shown on a strided
/// subset of the rows ([`full_rank_on_rows`]) ends there; otherwise from
/// the singular values of the triangular factor formed from blocks of all
/// the rows: the work is at most linear in the number of samples, so every
/// run is checked, however large. `None` if the SVD fails.
fn numerical_rank(
    regression: &Regression,
    columns: &[usize],
    constraints: &[Vec<f64>],
) -> Option<usize> {
    let k = columns.len();
    if k == 0 {
        return Some(0);
    }
    let width = regression.width;
    let rows = regression.len();
    let (scale, frobenius_squared) =
        column_scales(rows, k, |i, c| regression.rows[i * width + columns[c]]);
    // A constraint g·c = 0 reads (g / D)·(D c) = 0 on the scaled columns;
    // orthonormalised again there (modified Gram–Schmidt), so that each
    // counts once whatever D does to the angles between them.
    let mut scaled_constraints: Vec<Vec<f64>> = Vec::with_capacity(constraints.len());
    for g in constraints {
        let mut row: Vec<f64> = g.iter().zip(&scale).map(|(w, d)| w / d).collect();
        let before = row.iter().map(|w| w * w).sum::<f64>().sqrt();
        for q in &scaled_constraints {
            let dot: f64 = row.iter().zip(q).map(|(a, b)| a * b).sum();
            row.iter_mut().zip(q).for_each(|(a, b)| *a -= dot * b);
        }
        let size = row.iter().map(|w| w * w).sum::<f64>().sqrt();
        if size > 1e-12 * before {
            row.iter_mut().for_each(|w| *w /= size);
            scaled_constraints.push(row);
        }
    }
    let fill_row = |i: usize, row: &mut [f64]| {
        if i < rows {
            for ((target, &j), d) in row.iter_mut().zip(columns).zip(&scale) {
                *target = regression.rows[i * width + j] / d;
            }
        } else {
            row.copy_from_slice(&scaled_constraints[i - rows]);
        }
    };
    // Full rank shown on a subset of the rows, every constraint row among
    // them (each of norm 1), needs no QR of all of them.
    if let Some(mut subset) = strided_rows(rows, k) {
        subset.extend(rows..rows + scaled_constraints.len());
        let bound = frobenius_squared + scaled_constraints.len() as f64;
        let fill = row_by_row(|i, row| fill_row(subset[i], row));
        if full_rank_on_rows(subset.len(), k, bound, RANK_TOLERANCE, fill) {
            return Some(k.saturating_sub(scaled_constraints.len()));
        }
    }
    let r = triangular_factor(rows + scaled_constraints.len(), k, fill_row);
    let singular = singular_values(&r)?;
    let largest = singular.first().copied().unwrap_or(0.0);
    if largest <= 0.0 {
        return Some(0);
    }
    let stacked = singular
        .iter()
        .filter(|&&s| s > RANK_TOLERANCE * largest)
        .count();
    Some(stacked.saturating_sub(scaled_constraints.len()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_system::{reference_data, Quadratic2d};

    /// Π∇E is judged against the misfit only up to [`MAX_SYMMETRY_MISFIT`]:
    /// with K = I, ‖Π∇E‖ is 1/√2 of the field, which a misfit of 0.9 used
    /// to count as vanishing.
    #[test]
    fn a_poor_fit_does_not_make_the_poisson_part_vanish() {
        let data = reference_data(50, 3);
        let truth = Model::<Quadratic2d>::reference().unwrap();
        assert_eq!(poisson_part_vanishes(&data, &truth, 0.9), Some(false));
        // K = 100·I: ‖Π∇E‖ is 1/√10001 ≈ 0.01 of the field, within a
        // misfit of 0.05 but not of an exact fit's.
        let strong: Vec<f64> = truth
            .metric_coefficients()
            .iter()
            .map(|c| 100.0 * c)
            .collect();
        let strong =
            Model::<Quadratic2d>::new(truth.entropy_coefficients().to_vec(), strong).unwrap();
        assert_eq!(poisson_part_vanishes(&data, &strong, 0.05), Some(true));
        assert_eq!(poisson_part_vanishes(&data, &strong, 1e-12), Some(false));
    }

    #[test]
    fn the_fall_rate_is_the_mean_over_the_window() {
        // Halving every iteration: 1/2 per iteration, and 0.25 → 0.01 takes
        // ln 25 / ln 2 = 4.6, so 5 more iterations.
        let (rate, more) = fall_rate(&[1.0, 0.5, 0.25], 5, 0.01).unwrap();
        assert!((rate - 0.5).abs() < 1e-15, "{rate}");
        assert_eq!(more, Some(5));
        // Only the window counts: the first fall (×1e-3) is outside it.
        let (rate, _) = fall_rate(&[1.0, 1e-3, 0.9e-3, 0.81e-3], 2, 1e-9).unwrap();
        assert!((rate - 0.1).abs() < 1e-12, "{rate}");
        // A target of 0 has no projection.
        assert_eq!(fall_rate(&[1.0, 0.5], 5, 0.0).unwrap().1, None);
        // Nothing to project: one score, no fall, at the target.
        assert_eq!(fall_rate(&[1.0], 5, 0.01), None);
        assert_eq!(fall_rate(&[], 5, 0.01), None);
        assert_eq!(fall_rate(&[0.5, 0.5], 5, 0.01), None);
        assert_eq!(fall_rate(&[0.5, 0.6], 5, 0.01), None);
        assert_eq!(fall_rate(&[0.5, 0.01], 5, 0.01), None);
        // A settled run's rounding is not a fall: 1e-10 per iteration.
        assert_eq!(fall_rate(&[1.0, 1.0 - 1e-10, 1.0 - 2e-10], 5, 1e-9), None);
        assert!(fall_rate(&[1.0, 0.999, 0.998], 5, 1e-9).is_some());
    }

    /// Above 2·10⁹ rows × columns² (where a direct SVD used to be skipped,
    /// leaving large runs unchecked) the rank is still computed: a column
    /// that is the sum of two others costs one.
    #[test]
    fn rank_of_a_large_regression_counts_a_dependent_column() {
        let (rows, width) = (20_000, 320);
        let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let mut data = Vec::with_capacity(rows * width);
        for _ in 0..rows {
            let row: Vec<f64> = (0..width - 1).map(|_| next()).collect();
            let dependent = row[0] + row[1];
            data.extend(row);
            data.push(dependent);
        }
        let regression = Regression {
            width,
            rows: data,
            target: vec![0.0; rows],
        };
        let all: Vec<usize> = (0..width).collect();
        assert!(rows as f64 * (width * width) as f64 > 2e9);
        assert_eq!(numerical_rank(&regression, &all, &[]), Some(width - 1));
        assert_eq!(numerical_rank(&regression, &all[2..], &[]), Some(width - 2));
    }

    /// Columns are compared in their own units: a column a billion times
    /// smaller than the others is no dependence, but a column that is
    /// another's multiple up to 1e-10 of it is.
    #[test]
    fn the_rank_reads_normalised_columns() {
        let (rows, width) = (200, 3);
        let mut data = Vec::with_capacity(rows * width);
        for i in 0..rows {
            let t = i as f64 / rows as f64;
            data.extend([1.0 + t, 1e-9 * t * t, 2.0 * (1.0 + t) + 1e-10 * t.sin()]);
        }
        let regression = Regression {
            width,
            rows: data,
            target: vec![0.0; rows],
        };
        assert_eq!(numerical_rank(&regression, &[0, 1], &[]), Some(2));
        assert_eq!(numerical_rank(&regression, &[0, 1, 2], &[]), Some(2));
    }

    /// Equalities fix combinations whatever the data: the rank is counted
    /// on the subspace they leave, against that many unknowns. A column
    /// that repeats another is dependent, unless an equality ties the two.
    #[test]
    fn the_rank_is_counted_where_the_equalities_leave_room() {
        let rows: Vec<f64> = [
            [1.0, 2.0, 2.0],
            [3.0, -1.0, -1.0],
            [0.5, 4.0, 4.0],
            [2.0, 1.0, 1.0],
        ]
        .concat();
        let regression = Regression {
            width: 3,
            rows,
            target: vec![0.0; 4],
        };
        let all = [0, 1, 2];
        assert_eq!(numerical_rank(&regression, &all, &[]), Some(2));
        // c₁ = c₂ removes the dependent direction: 2 unknowns, rank 2.
        let tie = vec![0.0, 1.0 / 2_f64.sqrt(), -1.0 / 2_f64.sqrt()];
        assert_eq!(numerical_rank(&regression, &all, &[tie]), Some(2));
        // c₀ = 0 leaves the dependent direction: 2 unknowns, rank 1.
        let zero = vec![1.0, 0.0, 0.0];
        assert_eq!(numerical_rank(&regression, &all, &[zero]), Some(1));
    }
}
