//! Sparse equations: drop the entropy terms the data barely use and refit.
//!
//! A dense fit to noisy data spreads small coefficients over every monomial
//! of the basis. Each threshold τ keeps the terms whose effect on the data,
//! |ψₖ|·Σᵢ|Aᵢₖ| with A the entropy search's rows at the dense metric, is at
//! least τ times the largest; the kept support is refitted by the usual
//! convex searches (so the refitted model has its free-energy certificate),
//! and the threshold is chosen by the refits' cost on validation data.

use serde::{Deserialize, Serialize};

use super::refit::{preferred, refit};
use crate::data::IdentificationData;
use crate::error::{invalid, Num, Result};
use crate::identify::search::entropy_regression;
use crate::identify::{model_cost, Cost, IdentifyConfig, IdentifyWarning, Support};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// Options of [`sparsify`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SparseOptions {
    /// Relative thresholds τ tried, each in (0, 1). Default nine values
    /// from 1e-5 to 1e-1, two per decade (1 and 3 times a power of ten).
    pub thresholds: Vec<f64>,
    /// A sparser model is preferred while its validation cost is at most
    /// (1 + `parsimony`) times the best candidate's (the dense fit is a
    /// candidate). Default 0.02.
    pub parsimony: f64,
}

impl Default for SparseOptions {
    fn default() -> Self {
        Self {
            thresholds: vec![1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 1e-1],
            parsimony: 0.02,
        }
    }
}

/// One refitted support.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SparseCandidate {
    /// The smallest threshold that gave this support (`None`: the dense fit).
    pub threshold: Option<f64>,
    /// The entropy terms kept (indices into `ENTROPY_EXPONENTS`).
    pub terms: Vec<usize>,
    /// The refitted model's cost on the validation data.
    pub validation: Cost,
    /// The refit's [`Identification::warnings`](crate::Identification::warnings)
    /// (empty for the dense fit, whose own run gave its warnings).
    pub warnings: Vec<IdentifyWarning>,
}

/// The result of [`sparsify`].
#[derive(Debug, Clone)]
pub struct Sparsification<S: MetriplecticSystem> {
    /// The chosen model (the dense one if no sparser candidate validates as well).
    pub model: Model<S>,
    /// The chosen support: the entropy terms outside it are zero.
    pub support: Support,
    /// Index of the chosen candidate in `candidates`.
    pub chosen: usize,
    /// Every candidate, the dense fit first, then by increasing threshold.
    pub candidates: Vec<SparseCandidate>,
    /// The chosen candidate's warnings: what its training data cannot
    /// determine on the chosen support (empty when the dense fit is chosen).
    pub warnings: Vec<IdentifyWarning>,
}

/// Thresholds the entropy terms of `dense` (identified on `train` with
/// `config`), refits every distinct support on `train` from the dense
/// model, and returns the sparsest whose validation cost is within the
/// parsimony margin of the best.
///
/// Errors on invalid options or data, or if a refit fails outright (a refit
/// that ends early is still a candidate, judged by its validation cost).
/// The refits write no checkpoint (`config.checkpoint` is ignored), so that
/// of the user's own run stays.
pub fn sparsify<S: MetriplecticSystem, D: IdentificationData>(
    dense: &Model<S>,
    train: &D,
    validation: &D,
    config: &IdentifyConfig,
    options: &SparseOptions,
) -> Result<Sparsification<S>> {
    if let Some(bad) = options
        .thresholds
        .iter()
        .find(|t| !(t.is_finite() && **t > 0.0 && **t < 1.0))
    {
        return Err(invalid(
            "sparse threshold",
            format!("{} is not in (0, 1)", Num(*bad)),
        ));
    }
    if !(options.parsimony.is_finite() && options.parsimony >= 0.0) {
        return Err(invalid(
            "parsimony",
            format!(
                "{} is not a finite non-negative number",
                Num(options.parsimony)
            ),
        ));
    }
    // A dense model outside the support would be returned as the
    // candidate of no threshold under a support it breaks.
    config.search.support.check_model(
        "dense model",
        dense.entropy_coefficients(),
        dense.metric_coefficients(),
    )?;
    // Before the term effects evaluate the system on every sample.
    crate::data::check_dataset::<S>(train)?;
    crate::data::check_dataset::<S>(validation)?;
    let effects = term_effects(dense, train)?;
    let largest = effects.iter().fold(0.0_f64, |m, e| m.max(*e));
    let base = config.search.support.clone();
    let dense_terms = base.free_entropy::<S>();
    let mut candidates = vec![SparseCandidate {
        threshold: None,
        terms: dense_terms.clone(),
        validation: model_cost(dense, validation)?,
        warnings: Vec::new(),
    }];
    let mut models = vec![(dense.clone(), base.clone())];
    let mut thresholds = options.thresholds.clone();
    thresholds.sort_by(f64::total_cmp);
    for threshold in thresholds {
        let terms: Vec<usize> = dense_terms
            .iter()
            .copied()
            .filter(|&k| effects[k] >= threshold * largest)
            .collect();
        if terms.is_empty() || candidates.iter().any(|c| c.terms == terms) {
            continue;
        }
        let dropped: Vec<usize> = dense_terms
            .iter()
            .copied()
            .filter(|k| terms.binary_search(k).is_err())
            .collect();
        let support = base.clone().with_zeros(&dropped, &[]);
        let fit = refit(train, validation, config, &support, Some(dense))?;
        candidates.push(SparseCandidate {
            threshold: Some(threshold),
            terms,
            validation: fit.validation,
            warnings: fit.warnings,
        });
        models.push((fit.model, support));
    }
    let sizes: Vec<(usize, f64)> = candidates
        .iter()
        .map(|c| (c.terms.len(), c.validation.sum))
        .collect();
    let chosen = preferred(&sizes, options.parsimony, 0.0).unwrap_or(0);
    let (model, support) = models.swap_remove(chosen);
    let warnings = candidates[chosen].warnings.clone();
    Ok(Sparsification {
        model,
        support,
        chosen,
        candidates,
        warnings,
    })
}

/// |ψₖ|·Σᵢ|Aᵢₖ| for every entropy term: how much of the data term k accounts for.
fn term_effects<S: MetriplecticSystem>(
    model: &Model<S>,
    data: &impl IdentificationData,
) -> Result<Vec<f64>> {
    let rows = entropy_regression::<S>(data, model.metric_coefficients())?;
    Ok(rows
        .column_l1_norms()
        .iter()
        .zip(model.entropy_coefficients())
        .map(|(norm, c)| norm * c.abs())
        .collect())
}
