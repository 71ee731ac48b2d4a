//! Degree selection without recompiling: the macro's bases are ordered by
//! degree, so a lower-degree model is the declared one with the higher
//! monomials held at zero ([`Support::degree_caps`]). Each pair of caps is
//! identified on training data and scored on validation data.

use serde::{Deserialize, Serialize};

use super::refit::{preferred, refit};
use crate::data::IdentificationData;
use crate::error::{invalid, Result};
use crate::identify::start::default_start_metric;
use crate::identify::{Cost, IdentifyConfig, IdentifyWarning, SearchOptions, StopReason, Support};
use crate::model::Model;
use crate::system::MetriplecticSystem;

/// Options of [`select_degrees`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DegreeOptions {
    /// Entropy degrees tried. Default `None`: 1 to the declared degree.
    pub entropy: Option<Vec<u32>>,
    /// Metric degrees tried. Default `None`: the even degrees 0 to the
    /// declared one. Caps that leave the same metric coefficients free
    /// (the global certificate keeps only constants) are tried once.
    pub metric: Option<Vec<u32>>,
    /// A lower degree is preferred while its validation cost is at most
    /// (1 + `parsimony`) times the best, plus the run's tolerance times the
    /// data's scale (so that exact fits count as equal). Default 0.02.
    pub parsimony: f64,
}

impl Default for DegreeOptions {
    fn default() -> Self {
        Self {
            entropy: None,
            metric: None,
            parsimony: 0.02,
        }
    }
}

/// One pair of degree caps, identified and scored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DegreeCandidate {
    /// Entropy degree cap.
    pub entropy_degree: u32,
    /// Metric degree cap.
    pub metric_degree: u32,
    /// Free coefficients at these caps (entropy and metric).
    pub coefficients: usize,
    /// The identified model's cost on the validation data.
    pub validation: Cost,
    /// Why its identification stopped.
    pub stop_reason: StopReason,
    /// Its identification's warnings, e.g. [`IdentifyWarning::FailedSolves`]
    /// when its validation cost is a failed fit's rather than its degrees'.
    pub warnings: Vec<IdentifyWarning>,
}

impl DegreeCandidate {
    /// Whether its fit is in doubt: most solves of a subproblem failed, or
    /// the run stopped on solver failures.
    pub fn failed(&self) -> bool {
        self.stop_reason == StopReason::SolverFailures
            || self
                .warnings
                .iter()
                .any(|w| matches!(w, IdentifyWarning::FailedSolves { .. }))
    }
}

/// The result of [`select_degrees`].
#[derive(Debug, Clone)]
pub struct DegreeSelection<S: MetriplecticSystem> {
    /// The model at the chosen degrees.
    pub model: Model<S>,
    /// The chosen caps as a support, to pass on (e.g. to
    /// [`sparsify`](super::sparsify) or [`bootstrap`](super::bootstrap)).
    pub support: Support,
    /// Index of the chosen candidate in `candidates`.
    pub chosen: usize,
    /// Every candidate tried, by increasing entropy then metric degree.
    pub candidates: Vec<DegreeCandidate>,
    /// Metric degrees not tried because no non-zero metric of a classical
    /// system (K∇H ≡ 0) lies within their caps and the support, e.g. 0
    /// when ∇H is not constant. Empty for other systems.
    pub skipped_metric_degrees: Vec<u32>,
    /// The chosen refit's [`Identification::warnings`](crate::Identification::warnings):
    /// what its training data cannot determine at the chosen degrees; then
    /// an [`IdentifyWarning::SimplerDegreesFailed`] for each candidate with
    /// fewer coefficients that was passed over although its own fit
    /// [`failed`](DegreeCandidate::failed).
    pub warnings: Vec<IdentifyWarning>,
}

/// Identifies `S` on `train` at every pair of degree caps of `options` and
/// returns the lowest whose validation cost is within the parsimony margin
/// of the best: the degrees the data need, from a declared maximum above them.
///
/// Errors on a cap above the declared degree, invalid data or options, or
/// an identification that fails outright. The refits write no checkpoint
/// (`config.checkpoint` is ignored), so that of the user's own run stays.
pub fn select_degrees<S: MetriplecticSystem, D: IdentificationData>(
    train: &D,
    validation: &D,
    config: &IdentifyConfig,
    options: &DegreeOptions,
) -> Result<DegreeSelection<S>> {
    if !(options.parsimony.is_finite() && options.parsimony >= 0.0) {
        return Err(invalid(
            "parsimony",
            format!("{} is not a finite non-negative number", options.parsimony),
        ));
    }
    // In increasing order, each once, whatever order the options give.
    let sorted = |mut degrees: Vec<u32>| {
        degrees.sort_unstable();
        degrees.dedup();
        degrees
    };
    let entropy_degrees = sorted(
        options
            .entropy
            .clone()
            .unwrap_or_else(|| (1..=S::ENTROPY_DEGREE).collect()),
    );
    let metric_degrees = sorted(
        options
            .metric
            .clone()
            .unwrap_or_else(|| (0..=S::METRIC_DEGREE).step_by(2).collect()),
    );
    if entropy_degrees.is_empty() || metric_degrees.is_empty() {
        return Err(invalid("degrees", "no entropy or no metric degree to try"));
    }
    let (metric_degrees, skipped_metric_degrees) =
        classical_metric_degrees::<S>(&metric_degrees, config)?;
    let mut candidates = Vec::new();
    let mut fits = Vec::new();
    let mut seen = Vec::new();
    for &r in &entropy_degrees {
        for &s in &metric_degrees {
            let caps = Support::degree_caps::<S>(r, s)?;
            let support = config
                .search
                .support
                .clone()
                .with_zeros(caps.entropy_zeros(), caps.metric_zeros());
            let free_metric = support.free_metric::<S>(config.search.sos);
            let key = (support.free_entropy::<S>(), free_metric.clone());
            if seen.contains(&key) {
                continue;
            }
            let fit = refit::<S>(train, validation, config, &caps, None)?;
            candidates.push(DegreeCandidate {
                entropy_degree: r,
                metric_degree: s,
                coefficients: key.0.len() + free_metric.len(),
                validation: fit.validation,
                stop_reason: fit.stop_reason,
                warnings: fit.warnings.clone(),
            });
            seen.push(key);
            fits.push((fit.model, support, fit.warnings));
        }
    }
    let floor = config.tolerance
        * validation.equations().scale()
        * (validation.equation_count() * S::DIM) as f64;
    let sizes: Vec<(usize, f64)> = candidates
        .iter()
        .map(|c| (c.coefficients, c.validation.sum))
        .collect();
    let chosen = preferred(&sizes, options.parsimony, floor).unwrap_or(0);
    let (model, support, mut warnings) = fits.swap_remove(chosen);
    warnings.extend(simpler_failures(&candidates, chosen));
    Ok(DegreeSelection {
        model,
        support,
        chosen,
        candidates,
        skipped_metric_degrees,
        warnings,
    })
}

/// A warning for each candidate simpler than `chosen` whose fit failed: it
/// may have lost on the failure rather than on its degrees (a probe's
/// degree-2 truth got metric degree 4 this way, the simpler refit having
/// failed 15 of 29 metric solves).
fn simpler_failures(candidates: &[DegreeCandidate], chosen: usize) -> Vec<IdentifyWarning> {
    let Some(chosen) = candidates.get(chosen) else {
        return Vec::new();
    };
    candidates
        .iter()
        .filter(|c| c.coefficients < chosen.coefficients && c.failed())
        .map(|c| IdentifyWarning::SimplerDegreesFailed {
            entropy_degree: c.entropy_degree,
            metric_degree: c.metric_degree,
            validation_cost: c.validation.per_component,
        })
        .collect()
}

/// The metric degrees of `wanted` whose caps hold a non-zero metric, and
/// those that do not. Only a classical system can lack one (K∇H ≡ 0 ties
/// the metric to H's gradient): a cap holds one if the run's start metric
/// lies within it, or the default start metric can be built there. Errors
/// if no degree is left.
fn classical_metric_degrees<S: MetriplecticSystem>(
    wanted: &[u32],
    config: &IdentifyConfig,
) -> Result<(Vec<u32>, Vec<u32>)> {
    if S::CLASSICAL.is_none() {
        return Ok((wanted.to_vec(), Vec::new()));
    }
    let (mut kept, mut skipped) = (Vec::new(), Vec::new());
    for &s in wanted {
        let caps = Support::degree_caps::<S>(S::ENTROPY_DEGREE, s)?;
        let search = SearchOptions {
            support: config
                .search
                .support
                .clone()
                .with_zeros(&[], caps.metric_zeros()),
            ..config.search.clone()
        };
        let given = config.initial_metric.as_deref().is_some_and(|metric| {
            metric.iter().any(|&t| t != 0.0)
                && search.support.check_model("start", &[], metric).is_ok()
        });
        if given || default_start_metric::<S>(&search).is_ok() {
            kept.push(s);
        } else {
            skipped.push(s);
        }
    }
    if kept.is_empty() {
        return Err(invalid(
            "metric degrees",
            format!(
                "no metric degree in {wanted:?} holds a non-zero classical metric (K∇H ≡ 0) \
                 within its cap and the support; try higher degrees, up to the declared {}",
                S::METRIC_DEGREE
            ),
        ));
    }
    Ok((kept, skipped))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::Subproblem;

    fn candidate(
        metric_degree: u32,
        coefficients: usize,
        stop_reason: StopReason,
        warnings: Vec<IdentifyWarning>,
    ) -> DegreeCandidate {
        DegreeCandidate {
            entropy_degree: 4,
            metric_degree,
            coefficients,
            validation: Cost::from_sum(1.0, 10),
            stop_reason,
            warnings,
        }
    }

    /// A misspelt field is an error naming it (a probe's `entropyy` was
    /// dropped, and every degree tried).
    #[test]
    fn unknown_fields_in_degree_options_are_errors() {
        for field in ["entropyy", "parsimonny"] {
            let err = serde_json::from_str::<DegreeOptions>(&format!(r#"{{"{field}": [2]}}"#))
                .unwrap_err()
                .to_string();
            assert!(err.contains(&format!("unknown field `{field}`")), "{err}");
        }
        let options: DegreeOptions = serde_json::from_str(r#"{"entropy": [2]}"#).unwrap();
        assert_eq!(options.entropy, Some(vec![2]));
    }

    /// Only simpler candidates whose fit failed are named; a failed
    /// candidate with more coefficients, or a simpler one that fitted, is not.
    #[test]
    fn simpler_candidates_passed_over_on_failed_fits_are_named() {
        let failed = IdentifyWarning::FailedSolves {
            subproblem: Subproblem::MetricSearch,
            failed: 15,
            attempted: 29,
        };
        let candidates = [
            candidate(0, 10, StopReason::Converged, Vec::new()),
            candidate(2, 13, StopReason::Stagnated, vec![failed.clone()]),
            candidate(4, 19, StopReason::Converged, Vec::new()),
            candidate(6, 25, StopReason::SolverFailures, Vec::new()),
        ];
        let warnings = simpler_failures(&candidates, 2);
        assert_eq!(
            warnings,
            [IdentifyWarning::SimplerDegreesFailed {
                entropy_degree: 4,
                metric_degree: 2,
                validation_cost: 0.1,
            }]
        );
        assert!(warnings[0].to_string().contains("metric degree 2"));
        assert!(simpler_failures(&candidates, 0).is_empty());
        assert_eq!(simpler_failures(&candidates, 3).len(), 1);
        let stopped = [
            candidate(0, 10, StopReason::SolverFailures, Vec::new()),
            candidate(2, 13, StopReason::Converged, Vec::new()),
        ];
        assert_eq!(simpler_failures(&stopped, 1).len(), 1);
    }
}
