//! An identification restricted to a support, scored on validation data:
//! the step that sparse refits and degree selection repeat.

use crate::data::IdentificationData;
use crate::error::Result;
use crate::identify::{
    identify, model_cost, Cost, IdentifyConfig, IdentifyWarning, StopReason, Support,
};
use crate::model::{check_entropy, Model};
use crate::system::MetriplecticSystem;

/// A model fitted on a support and its validation cost.
pub(crate) struct Refit<S: MetriplecticSystem> {
    pub model: Model<S>,
    pub validation: Cost,
    /// The identification's warnings.
    pub warnings: Vec<IdentifyWarning>,
    /// Why the identification stopped.
    pub stop_reason: StopReason,
}

/// Identifies on `train` with `config` restricted to `support` (joined with
/// the config's own), from `start` (`None`: the config's start) with the
/// coefficients outside the support set to zero, and scores the result on
/// `validation`.
pub(crate) fn refit<S: MetriplecticSystem>(
    train: &impl IdentificationData,
    validation: &impl IdentificationData,
    config: &IdentifyConfig,
    support: &Support,
    start: Option<&Model<S>>,
) -> Result<Refit<S>> {
    let support = config
        .search
        .support
        .clone()
        .with_zeros(support.entropy_zeros(), support.metric_zeros());
    let mut restricted = config.clone();
    // A refit is one of many runs: it must not replace the checkpoint of
    // the user's own run at `config.checkpoint`.
    restricted.checkpoint = None;
    let (entropy, metric) = match start {
        Some(start) => (
            Some(start.entropy_coefficients()),
            Some(start.metric_coefficients()),
        ),
        None => (
            config.initial_entropy.as_deref(),
            config.initial_metric.as_deref(),
        ),
    };
    // The start must lie in the support: entropy coefficients outside it
    // are zeroed, but only where that keeps S admissible (a classical
    // system's Casimir rows tie terms together); a metric is kept only if
    // it already is zero there (zeroing could make it indefinite).
    // Otherwise the search starts from the library's default.
    restricted.initial_entropy = entropy.and_then(|entropy| {
        let mut entropy = entropy.to_vec();
        for &k in support.entropy_zeros() {
            if let Some(c) = entropy.get_mut(k) {
                *c = 0.0;
            }
        }
        check_entropy::<S>("refit start", &entropy)
            .is_ok()
            .then_some(entropy)
    });
    restricted.initial_metric = metric
        .filter(|metric| support.check_model("refit start", &[], metric).is_ok())
        .map(<[f64]>::to_vec);
    restricted.search.support = support;
    let fit = identify::<S>(train, &restricted)?;
    let validation = model_cost(&fit.model, validation)?;
    Ok(Refit {
        model: fit.model,
        validation,
        warnings: fit.warnings,
        stop_reason: fit.stop_reason,
    })
}

/// The index of the preferred candidate: the simplest (fewest free
/// coefficients, first on ties) whose validation cost is at most
/// `(1 + parsimony)` times the best plus `floor` (the cost that counts as
/// an exact fit).
pub(crate) fn preferred(candidates: &[(usize, f64)], parsimony: f64, floor: f64) -> Option<usize> {
    let best = candidates
        .iter()
        .map(|&(_, cost)| cost)
        .fold(f64::INFINITY, f64::min);
    let bound = best * (1.0 + parsimony) + floor;
    candidates
        .iter()
        .enumerate()
        .filter(|(_, &(_, cost))| cost <= bound)
        .min_by_key(|(i, &(size, _))| (size, *i))
        .map(|(i, _)| i)
}
