//! Where a run begins: the start's subsample, the default start metric, and
//! the entropy fitted at it, walked over the metric's scale.
//!
//! Nothing of the truth is used: the start is the entropy search's fit at a
//! metric of the right kind (the identity, or for a classical system a
//! metric with K∇H ≡ 0), on at most
//! [`start_samples`](IdentifyConfig::start_samples) samples.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::config::IdentifyConfig;
use super::cost::{data_scale, Cost};
use super::search::{entropy_search, SearchOptions};
use crate::data::IdentificationData;
use crate::error::{invalid, Result};
use crate::model::classical::{self, degenerate_metric, Equalities};
use crate::model::{check_metric_coefficients, identity_metric};
use crate::system::MetriplecticSystem;

/// The run's first (entropy, metric): the configuration's own where it
/// gives both; the default start metric with a given entropy; the entropy
/// fitted at a given metric; or, given neither, [`scaled_start`]. Fitted
/// on `batch`, the start's subsample of the pool ([`start_sample`]).
pub(super) fn initial_coefficients<S: MetriplecticSystem>(
    batch: &impl IdentificationData,
    config: &IdentifyConfig,
) -> Result<(Vec<f64>, Vec<f64>)> {
    Ok(match (&config.initial_entropy, &config.initial_metric) {
        (Some(entropy), Some(metric)) => (entropy.clone(), metric.clone()),
        (Some(entropy), None) => (entropy.clone(), default_start_metric::<S>(&config.search)?),
        (None, Some(metric)) => (fitted_start::<S>(batch, config, metric)?, metric.clone()),
        (None, None) => scaled_start::<S>(batch, config)?,
    })
}

/// The default start metric: the identity with the terms the support
/// removes at zero, or for a classical system (where the identity breaks
/// K∇H ≡ 0) the degenerate metric |∇H|² I − ∇H ∇Hᵀ with largest eigenvalue
/// 1 on the region, or, where the metric basis or the support cannot hold
/// that, that identity projected onto K∇H ≡ 0 if the projection is a
/// non-zero metric the certificate accepts; scaled to the gauge if one is
/// set. Always within the support, or an error.
pub(crate) fn default_start_metric<S: MetriplecticSystem>(
    options: &SearchOptions,
) -> Result<Vec<f64>> {
    // The identity within the support: zeroing diagonal entries of a
    // diagonal metric keeps it positive semidefinite.
    let mut identity = identity_metric::<S>(1.0);
    for &k in options.support.metric_zeros() {
        if let Some(t) = identity.get_mut(k) {
            *t = 0.0;
        }
    }
    let within_support = |metric: &[f64]| {
        options
            .support
            .check_model("default start metric", &[], metric)
            .is_ok()
    };
    let mut metric = if S::CLASSICAL.is_some() {
        match degenerate_metric::<S>(1.0) {
            Ok(degenerate) if within_support(&degenerate) => degenerate,
            degenerate => {
                let mut projected = identity;
                let free = options.support.free_metric::<S>(options.sos);
                Equalities::new(classical::metric_rows::<S>(), &free)
                    .project_coefficients(&mut projected);
                let nonzero = projected.iter().any(|t| t.abs() > 1e-12);
                match check_metric_coefficients::<S>("initial metric coefficients", &projected) {
                    Ok(()) if nonzero => projected,
                    _ => {
                        return Err(degenerate.err().unwrap_or_else(|| {
                            invalid(
                                "initial metric",
                                "the default start metric (|∇H|²I − ∇H∇Hᵀ) has terms the \
                                 support holds at zero, and no projection of the identity \
                                 within it is a metric; pass an initial_metric within the \
                                 support",
                            )
                        }))
                    }
                }
            }
        }
    } else {
        identity
    };
    // A start outside the support would be returned as it is if no metric
    // step were ever accepted.
    if !within_support(&metric) {
        return Err(invalid(
            "initial metric",
            "the default start metric has terms the support holds at zero; pass an \
             initial_metric within the support",
        ));
    }
    let gauge = options.gauge;
    if let Some(gauge) = gauge {
        let (value, wanted) = (gauge.value_at::<S>(&metric), gauge.row::<S>().1);
        if value > 0.0 {
            metric.iter_mut().for_each(|t| *t *= wanted / value);
        } else if S::CLASSICAL.is_none() {
            // Only the support can have removed every term the gauge reads,
            // and then no admissible metric meets it.
            return Err(invalid(
                "gauge",
                format!(
                    "{gauge:?} fixes tr K(0), but the support holds every constant diagonal \
                     term of K at zero; free some of them or drop the gauge"
                ),
            ));
        }
    }
    Ok(metric)
}

/// The default start: the entropy search's fit with the initial metric, on
/// the batch pool (a minibatch run: q of its equations), subsampled to
/// [`start_samples`](IdentifyConfig::start_samples) (the samples drawn from
/// a stream of their own), or zeros if that solve fails.
///
/// Starting from S = 0 instead misleads the first metric search: it fits
/// (Π + K)∇H to the data, where the best K is often near 0, and with K ≈ 0
/// the entropy search has nothing to act on.
pub(super) fn fitted_start<S: MetriplecticSystem>(
    batch: &impl IdentificationData,
    config: &IdentifyConfig,
    metric: &[f64],
) -> Result<Vec<f64>> {
    Ok(start_fit::<S>(batch, config, metric)?
        .map(|(entropy, _)| entropy)
        .unwrap_or_else(|| vec![0.0; S::entropy_coefficient_count()]))
}

/// The entropy search's fit with `metric` and its cost on `batch`, if the
/// solve ended usable with finite coefficients.
fn start_fit<S: MetriplecticSystem>(
    batch: &impl IdentificationData,
    config: &IdentifyConfig,
    metric: &[f64],
) -> Result<Option<(Vec<f64>, Option<Cost>)>> {
    let search = entropy_search::<S>(batch, metric, &config.search)?;
    let usable =
        search.report.status.is_usable() && search.coefficients.iter().all(|c| c.is_finite());
    Ok(usable.then_some((search.coefficients, search.report.cost)))
}

/// Scales of the default start metric that [`scaled_start`] walks to from
/// the unit, downwards and upwards, a decade apart: only the order of
/// magnitude matters for where the iteration begins.
const SCALES_DOWN: [f64; 6] = [0.1, 0.01, 1e-3, 1e-4, 1e-5, 1e-6];
const SCALES_UP: [f64; 2] = [10.0, 100.0];
/// A scale replaces the best so far only if its start fits at least this
/// much better (a cost below this fraction of the best): where the scale
/// is free (Π∇E = 0, every scale fits alike) the unit metric stays.
const START_MARGIN: f64 = 0.9;

/// A fitted start: its cost on the batch, the entropy and the metric.
type Start = (Cost, Vec<f64>, Vec<f64>);

/// The default start with neither an initial entropy nor an initial metric:
/// [`fitted_start`] with the default start metric, then with it times 0.1,
/// 0.01, … down to 1e-6 while no scale fits worse than the best so far, or
/// else times 10 and 100 likewise (scales within the bound η), keeping the
/// pair whose entropy fits the batch best; with a
/// gauge, which fixes the scale, the default metric alone. A start that
/// already fits to the run's tolerance ends the walk: below it, "better"
/// would compare rounding errors. Returns (entropy, metric).
///
/// The identity metric is a guess of the metric's size in the data's
/// units. When the truth is ten times smaller, the entropy fitted at the
/// identity absorbs the difference, and the alternation can settle in a
/// local minimum of the biconvex cost: on a 4-state Lie–Poisson system
/// with K of size 0.1–0.4, two of three datasets stalled at a held-out
/// error of 6e-2 from the identity and converged to 1e-12 from 0.1·I,
/// whose start fitted the data three times better. The walk costs two
/// more entropy searches on the start's subsample where the first step
/// down and the first step up fit worse, up to eight on a plateau.
///
/// A plateau is walked across, not taken as the end: in mixed units the
/// fit can stay flat for decades before it falls (a spring declared in
/// grams with SI states fitted 24.8 per component at 1, 0.1 and 0.01 times
/// the identity and 0.49 at 1e-4, its true K₁₁ being 0.05 beside
/// Π = 5e-3; stopping at 0.1 left the run stagnated at a held-out error
/// of 4.3e-2, without a warning).
fn scaled_start<S: MetriplecticSystem>(
    batch: &impl IdentificationData,
    config: &IdentifyConfig,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let unit = default_start_metric::<S>(&config.search)?;
    if config.search.gauge.is_some() {
        return Ok((fitted_start::<S>(batch, config, &unit)?, unit));
    }
    let fit = |scale: f64| -> Result<Option<Start>> {
        let metric: Vec<f64> = unit.iter().map(|t| t * scale).collect();
        Ok(start_fit::<S>(batch, config, &metric)?
            .and_then(|(entropy, cost)| cost.map(|cost| (cost, entropy, metric))))
    };
    let fitted = |cost: &Cost| cost.per_component <= config.tolerance * data_scale(batch);
    // The default metric's largest eigenvalue is 1: c·metric ⪯ ηI for c ≤ η.
    let eta = config.search.eta_for::<S>();
    // Walks along `scales` while each fits better than the best so far.
    let walk = |scales: &[f64], best: &mut Option<Start>| -> Result<bool> {
        let mut moved = false;
        for &scale in scales.iter().filter(|&&c| c <= eta) {
            if best
                .as_ref()
                .is_some_and(|(incumbent, _, _)| fitted(incumbent))
            {
                break;
            }
            let Some(start) = fit(scale)? else { break };
            match best.as_ref().map(|(incumbent, _, _)| incumbent.sum) {
                Some(incumbent) if start.0.sum >= START_MARGIN * incumbent => {
                    // A plateau is walked across (in mixed units the cost can
                    // stay flat for decades before it falls); a rise ends
                    // the walk.
                    if start.0.sum > incumbent {
                        break;
                    }
                }
                _ => {
                    *best = Some(start);
                    moved = true;
                }
            }
        }
        Ok(moved)
    };
    let mut best = fit(1.0)?;
    if !walk(&SCALES_DOWN, &mut best)? {
        walk(&SCALES_UP, &mut best)?;
    }
    Ok(match best {
        Some((_, entropy, metric)) => (entropy, metric),
        None => (vec![0.0; S::entropy_coefficient_count()], unit),
    })
}

/// The start's subsample of the batch pool: at most
/// [`start_samples`](IdentifyConfig::start_samples) of its samples (a
/// minibatch run: at most q), but never fewer than ten equations per
/// entropy coefficient, drawn from a stream of their own; `None` when that
/// is the whole pool.
pub(super) fn start_sample<S: MetriplecticSystem, D: IdentificationData>(
    pool: &D,
    config: &IdentifyConfig,
) -> Result<Option<D>> {
    let available = pool.equation_count();
    // Ten equations per coefficient keep the start's L1 fit overdetermined.
    let enough = (10 * S::entropy_coefficient_count()).div_ceil(S::DIM);
    // Never below `enough`, even for a smaller minibatch (a probe's batch
    // of 1 fitted the start to one sample).
    let wanted = config
        .batch_size
        .unwrap_or(available)
        .min(config.start_samples)
        .max(enough);
    if wanted >= available {
        return Ok(None);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(config.seed ^ 0x57a7_0f5e_a7c4_0000);
    let indices = rand::seq::index::sample(&mut rng, available, wanted).into_vec();
    Ok(Some(pool.select(&indices)?))
}
