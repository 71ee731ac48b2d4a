//! An identification restricted to a support, scored on validation data:
//! the step that sparse refits and degree selection repeat.

use crate::data::IdentificationData;
use crate::error::Result;
use crate::identify::{identify, model_cost, Cost, IdentifyConfig, Support};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// A model fitted on a support and its validation cost.
pub(crate) struct Refit<S: MetriplecticSystem> {
    pub model: Model<S>,
    pub validation: Cost,
}

/// Identifies on `train` with `config` restricted to `support` (joined with
/// the config's own), from `start` with the coefficients outside the
/// support set to zero (`None`: the config's start), and scores the result
/// on `validation`.
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
    if let Some(start) = start {
        let mut entropy = start.entropy_coefficients().to_vec();
        support
            .entropy_zeros()
            .iter()
            .for_each(|&k| entropy[k] = 0.0);
        restricted.initial_entropy = Some(entropy);
        if support.metric_zeros().is_empty() {
            restricted.initial_metric = Some(start.metric_coefficients().to_vec());
        }
    }
    restricted.search.support = support;
    let model = identify::<S>(train, &restricted)?.model;
    let validation = model_cost(&model, validation)?;
    Ok(Refit { model, validation })
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
