//! What an identification run does: batch, iteration scheme, stopping,
//! starting point, checkpoints.

use serde::{Deserialize, Serialize};

use super::checkpoint::CheckpointConfig;
use super::search::SearchOptions;
use crate::error::{invalid, Result};
use crate::model::{check_entropy, check_metric_coefficients};
use crate::system::MetriplecticSystem;

/// Configuration of [`identify`](crate::identify). Build with
/// struct-update syntax from [`Default`] (the recommended method: the joint
/// scheme with stopping rules) or from [`IdentifyConfig::paper`] (the
/// paper's Algorithm 2 exactly); [`identify`](crate::identify) validates it.
///
/// ```
/// use metriplectic_runtime::{IdentifyConfig, IterationScheme};
///
/// let config = IdentifyConfig { batch_size: Some(500), max_iterations: 50, ..IdentifyConfig::default() };
/// assert!(matches!(config.scheme, IterationScheme::AlternatingThenJoint(_)));
/// assert!(matches!(IdentifyConfig::paper().scheme, IterationScheme::Alternating));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IdentifyConfig {
    /// `None` (the default): Algorithm 1 on the full data. `Some(q)`:
    /// Algorithm 2, a fresh minibatch of q distinct samples each iteration.
    /// q must be between 1 and the number of samples available for batches
    /// (a larger q is an error, not a clamp, so a typo does not silently
    /// turn Algorithm 2 into Algorithm 1).
    pub batch_size: Option<usize>,
    /// Iteration cap. Default 100.
    pub max_iterations: usize,
    /// Converged ([`StopReason::Converged`](crate::StopReason::Converged))
    /// when the mean absolute residual per component on the validation
    /// samples (without validation: the iteration's batch, and then all
    /// the samples batches are drawn from, since a small batch can be
    /// fitted exactly by a wrong model) is at most `tolerance` times their
    /// scale, their mean |ẋ| per component (1 if every ẋ is zero).
    /// Relative, so that data in any units are judged alike; in [0, 1).
    /// Default 1e-9.
    pub tolerance: f64,
    /// Stop when the run no longer improves
    /// ([`StopReason::Stagnated`](crate::StopReason::Stagnated)): noisy data
    /// never reach the tolerance. `None` runs to the cap. It is judged on
    /// the [`validation`](Self::validation) scores, so a minibatch run with
    /// [`Validation::None`], which scores nothing (as the paper's
    /// Algorithm 2), never stagnates and runs to the tolerance or the cap
    /// whatever this is. Default
    /// [`Stagnation::default`].
    pub stagnation: Option<Stagnation>,
    /// Which samples score the model after each iteration of a minibatch run
    /// (and decide stagnation): the run returns the best-scoring model, not
    /// the last accepted one. Full-batch runs score on the full data.
    /// Default [`Validation::AllData`].
    pub validation: Validation,
    /// Minibatch runs only: end with one full-batch iteration from the best
    /// model (its steps accepted under the usual rule). Default `true`.
    pub polish: bool,
    /// Seed of the minibatch generator (ChaCha8): equal seeds give equal
    /// runs. Default 0.
    pub seed: u64,
    /// Initial entropy coefficients ψ⁽⁰⁾ (zero outside the support of
    /// [`search`](Self::search)). Default `None`: fitted, the
    /// entropy search's solution with the initial metric (on the full data,
    /// or on q samples of a minibatch run, at most
    /// [`start_samples`](Self::start_samples)), zeros if that solve fails.
    pub initial_entropy: Option<Vec<f64>>,
    /// The most samples the fitted start (no `initial_entropy`) is fitted
    /// on: a larger pool, or a larger minibatch, is subsampled at random
    /// (from a stream of its own, seeded by [`seed`](Self::seed)), but never
    /// below ten equations per entropy coefficient. The start only sets
    /// where the iteration begins, and on all of a large dataset its fit
    /// is the run's costliest solve: an entropy search with a metric far
    /// from the truth, whose interior-point iterations grow with the data.
    /// `usize::MAX` fits it on every sample. Default 2000.
    pub start_samples: usize,
    /// Full-batch runs on at least twice the start's subsample
    /// ([`start_samples`](Self::start_samples)) first iterate on that
    /// subsample, while each iteration at least halves its cost (or until
    /// it fits to [`tolerance`](Self::tolerance)), then on all the data from
    /// the model reached. The first iterations, whose metric is still far
    /// from the truth, solve the degenerate programs whose interior-point
    /// iterations grow with the data; on the subsample they cost a fixed
    /// amount, and the iterations on all the data start near their
    /// optimum. The warm-up's iterations are in the history
    /// ([`IterationRecord::warm_up`](crate::IterationRecord::warm_up)), seen
    /// by the observer and counted by
    /// [`max_iterations`](Self::max_iterations), which always leaves one
    /// iteration on all the data. It writes no checkpoints: a run stopped
    /// in its warm-up starts again from the beginning. Default `true`.
    pub warm_up: bool,
    /// Initial metric coefficients θ⁽⁰⁾ (checked positive semidefinite, and
    /// against the support and gauge of [`search`](Self::search); not
    /// against the searches' upper bound η: a start above it stays the
    /// model until a metric search, which keeps K ⪯ ηI, replaces it).
    /// Default `None`: the identity metric, scaled to the gauge if one is
    /// set; with no gauge and no [`initial_entropy`](Self::initial_entropy)
    /// either, the identity times the scale of 1, 0.1, …, 1e-6 (walking
    /// down while no scale fits worse than the best, keeping one only if it
    /// fits 10% better), or else of 10 and 100 likewise
    /// (scales up to the bound η; a start that already fits to
    /// [`tolerance`](Self::tolerance) is kept; `docs/method.md` §3, "The
    /// start's metric scale").
    pub initial_metric: Option<Vec<f64>>,
    /// Options of every search: the coefficient bound η, the SOS tables and
    /// the solver. Default [`SearchOptions::default`] (η = max(20, 4h, 4π), see
    /// [`SearchOptions::eta_for`]).
    pub search: SearchOptions,
    /// Give up after this many consecutive iterations in which both solves
    /// failed. Default 3.
    pub max_failed_iterations: usize,
    /// Which steps each iteration takes. Default
    /// [`IterationScheme::AlternatingThenJoint`] with [`TrustRegion::default`].
    pub scheme: IterationScheme,
    /// Periodic checkpoints of the run's full state, from which
    /// [`identify_resume`](crate::identify_resume) continues it. Default
    /// `None`: no checkpoints.
    pub checkpoint: Option<CheckpointConfig>,
    /// Whether a run that stagnated tries a second start: the cost is
    /// bilinear and has local minima, and those measured held a metric
    /// smaller than the truth's. A short trial (at most 20 iterations on
    /// the start's subsample, unrecorded, ended once it beats the
    /// stagnated model there or stops improving) starts from the stagnated metric
    /// times 10 (less where η bounds it) with the entropy fitted at it;
    /// if its model scores at most 0.9 of the stagnated one's (on the
    /// validation samples, or all the data), the run continues from it,
    /// its iterations marked [`IterationRecord::restart`](crate::IterationRecord::restart). At most once per
    /// run; not with a [`Gauge`](crate::Gauge), which fixes the metric's
    /// scale. On data fitted to their noise floor the trial does not win,
    /// and costs its iterations. Default `true`.
    pub restart_on_stagnation: bool,
}

/// When a run that no longer improves stops.
///
/// After every iteration the run scores its model (on the validation
/// samples, or the batch for full-batch runs). It stops when the best score
/// has not fallen by more than `relative_improvement` (relative) for
/// `window` consecutive iterations — which includes iterations whose steps
/// were all rejected.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Stagnation {
    /// Iterations without improvement before stopping. Default 5.
    pub window: usize,
    /// Smallest relative decrease of the best score that counts as an
    /// improvement. Default 1e-4.
    pub relative_improvement: f64,
}

impl Default for Stagnation {
    fn default() -> Self {
        Self {
            window: 5,
            relative_improvement: 1e-4,
        }
    }
}

/// Which samples score a minibatch run's model after every iteration.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum Validation {
    /// All samples (the default): the run returns the model that fits the
    /// whole dataset best.
    #[default]
    AllData,
    /// A held-out part of the samples, drawn at random (seeded by
    /// [`IdentifyConfig::seed`]) and never used in a batch. Minibatch runs
    /// only: a full-batch run with it is refused.
    HeldOut {
        /// Fraction of the samples held out, in (0, 1).
        fraction: f64,
    },
    /// No scoring: the run returns the last accepted iterate, as the
    /// paper's Algorithm 2 does.
    None,
}

/// The steps of one iteration of [`identify`](crate::identify).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum IterationScheme {
    /// The paper's Algorithms 1 and 2: metric search, then entropy search.
    Alternating,
    /// Metric search, entropy search, then a joint linearised step in both
    /// blocks ([`joint_step`](crate::joint_step)) on the same batch, in a
    /// trust region that adapts from step to step (the default). Every step
    /// is accepted only if the batch cost does not increase, so the paper's
    /// Theorem 1 still holds. The alternation alone can crawl (each block
    /// optimal, the pair not jointly stationary); the joint step removes that.
    AlternatingThenJoint(TrustRegion),
}

impl Default for IterationScheme {
    fn default() -> Self {
        Self::AlternatingThenJoint(TrustRegion::default())
    }
}

impl Default for IdentifyConfig {
    fn default() -> Self {
        Self {
            batch_size: None,
            max_iterations: 100,
            tolerance: 1e-9,
            stagnation: Some(Stagnation::default()),
            validation: Validation::AllData,
            polish: true,
            seed: 0,
            initial_entropy: None,
            start_samples: 2000,
            warm_up: true,
            initial_metric: None,
            search: SearchOptions::default(),
            max_failed_iterations: 3,
            scheme: IterationScheme::default(),
            checkpoint: None,
            restart_on_stagnation: true,
        }
    }
}

impl IdentifyConfig {
    /// The paper's Algorithm 2 exactly: alternating metric and entropy
    /// searches on minibatches of q = 2000, no joint step, no stopping rule
    /// but the tolerance and the cap of 100 iterations, and the last
    /// accepted iterate returned (no validation, no polish). The start is
    /// still the default fitted one unless `initial_entropy` is given: the
    /// paper starts from its experiments' own initial entropy (the truth
    /// plus noise), which the reproductions pass in.
    pub fn paper() -> Self {
        Self {
            batch_size: Some(2000),
            stagnation: None,
            validation: Validation::None,
            polish: false,
            scheme: IterationScheme::Alternating,
            ..Self::default()
        }
    }

    /// Checks the configuration against system `S` and a dataset of
    /// `samples` samples.
    pub fn validate<S: MetriplecticSystem>(&self, samples: usize) -> Result<()> {
        let pool = samples - self.held_out(samples);
        match self.batch_size {
            Some(0) => {
                return Err(invalid(
                    "batch size",
                    "must be at least 1 (use None for the full batch)",
                ))
            }
            // A validation split that leaves no pool is its own error, named
            // below (this one blamed the batch size; a probe).
            Some(q) if q > pool && !(pool == 0 && self.held_out(samples) > 0) => {
                return Err(invalid(
                    "batch size",
                    format!(
                        "{q} exceeds the {pool} samples available for batches (of {samples}; \
                         use None for the full batch)"
                    ),
                ))
            }
            _ => {}
        }
        if self.start_samples == 0 {
            return Err(invalid(
                "start samples",
                "must be at least 1 (usize::MAX fits the start on every sample)",
            ));
        }
        // A residual as large as the data's own scale is no fit: a probe's
        // tolerance of 1e300 "converged" at a relative error of 0.17.
        if !(self.tolerance.is_finite() && (0.0..1.0).contains(&self.tolerance)) {
            return Err(invalid(
                "tolerance",
                format!(
                    "{} is not in [0, 1): it is relative to the data's mean |ẋ|, and 1 or \
                     more would accept any model",
                    crate::error::Num(self.tolerance)
                ),
            ));
        }
        if let Some(stagnation) = &self.stagnation {
            if stagnation.window == 0 {
                return Err(invalid("stagnation window", "must be at least 1"));
            }
            let delta = stagnation.relative_improvement;
            if !(delta.is_finite() && (0.0..1.0).contains(&delta)) {
                return Err(invalid(
                    "stagnation relative_improvement",
                    format!("{delta} is not in [0, 1)"),
                ));
            }
        }
        if let Validation::HeldOut { fraction } = self.validation {
            if !(fraction > 0.0 && fraction < 1.0) {
                return Err(invalid(
                    "validation fraction",
                    format!("{fraction} is not in (0, 1)"),
                ));
            }
            if self.batch_size.is_none() {
                return Err(invalid(
                    "validation",
                    "held-out validation scores minibatch runs only; this run is full-batch \
                     (batch_size is None) and scores on all the data: use Validation::AllData \
                     or set a batch size",
                ));
            }
            if self.held_out(samples) == 0 || self.held_out(samples) == samples {
                return Err(invalid(
                    "validation fraction",
                    format!(
                        "{fraction} of {samples} samples leaves no validation or no batch samples"
                    ),
                ));
            }
        }
        if self.max_iterations == 0 {
            return Err(invalid("max_iterations", "must be at least 1"));
        }
        if self.max_failed_iterations == 0 {
            return Err(invalid("max_failed_iterations", "must be at least 1"));
        }
        self.search.validate_for::<S>()?;
        let support = &self.search.support;
        if let Some(entropy) = &self.initial_entropy {
            check_entropy::<S>("initial entropy coefficients", entropy)?;
            support.check_model("initial entropy coefficients", entropy, &[])?;
            // Every search bounds |ψₖ| by η: a start beyond it leaves the
            // joint step an empty box and, if no step is accepted, would be
            // returned outside the documented bounds.
            let eta = self.search.eta_for::<S>();
            if let Some((k, c)) = entropy.iter().enumerate().find(|(_, c)| c.abs() > eta) {
                return Err(invalid(
                    "initial entropy coefficients",
                    format!(
                        "coefficient {k} is {c:e}, beyond the bound η = {eta:e} every search \
                         holds |ψ| to; raise SearchOptions::eta or scale the start"
                    ),
                ));
            }
        }
        if let Some(metric) = &self.initial_metric {
            check_metric_coefficients::<S>("initial metric coefficients", metric)?;
            support.check_model("initial metric coefficients", &[], metric)?;
            if let Some(gauge) = self.search.gauge {
                gauge.check_model::<S>("initial metric coefficients", metric)?;
            }
        }
        if let IterationScheme::AlternatingThenJoint(trust) = &self.scheme {
            trust.validate()?;
        }
        if let Some(checkpoint) = &self.checkpoint {
            checkpoint.validate()?;
        }
        self.search.validate()
    }

    /// Number of the `samples` held out for validation.
    pub(crate) fn held_out(&self, samples: usize) -> usize {
        match self.validation {
            Validation::HeldOut { fraction } if self.batch_size.is_some() => {
                ((fraction * samples as f64).round() as usize).min(samples)
            }
            _ => 0,
        }
    }
}

/// The trust region of the joint step and how it adapts.
///
/// The radius Δ bounds every coefficient change of a joint step
/// (|Δψₖ| ≤ Δ and |Δθₜ| ≤ Δ). After each step the ratio
/// ρ = (actual decrease) / (decrease predicted by the linearised cost)
/// adapts it: ρ ≥ `good_ratio` multiplies Δ by `grow` (up to `max_radius`),
/// ρ < `poor_ratio` (including a rejected or failed step) multiplies it by
/// `shrink` (down to `min_radius`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrustRegion {
    /// Δ of the first joint step. Default 0.1.
    pub initial_radius: f64,
    /// Upper limit of Δ. Default 10.
    pub max_radius: f64,
    /// Lower limit of Δ (a minibatch may reject a step that another accepts,
    /// so Δ is not allowed to collapse to zero). Default 1e-10.
    pub min_radius: f64,
    /// Factor applied to Δ after a good step (> 1). Default 2.
    pub grow: f64,
    /// Factor applied to Δ after a poor, rejected or failed step (in
    /// (0, 1)). Default 0.25.
    pub shrink: f64,
    /// ρ at or above which a step counts as good. Default 0.75.
    pub good_ratio: f64,
    /// ρ below which a step counts as poor. Default 0.25.
    pub poor_ratio: f64,
    /// Whether a step that gained less than `good_ratio` of its prediction
    /// is solved again with the second-order correction (the bilinear term
    /// the linearisation dropped, taken at the first candidate) and
    /// replaced if that fits the batch better (default `true`). It costs
    /// a solve each time it is tried; near an exact fit in a curved valley
    /// it takes many fewer iterations (`docs/method.md` §3).
    pub second_order: bool,
}

impl Default for TrustRegion {
    fn default() -> Self {
        Self {
            initial_radius: 0.1,
            max_radius: 10.0,
            min_radius: 1e-10,
            grow: 2.0,
            shrink: 0.25,
            good_ratio: 0.75,
            poor_ratio: 0.25,
            second_order: true,
        }
    }
}

impl TrustRegion {
    /// Checks that the radii are ordered and positive and the factors and
    /// ratios are in range.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: &str, reason: String| invalid(&format!("trust region {what}"), reason);
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !(positive(self.min_radius)
            && positive(self.max_radius)
            && positive(self.initial_radius)
            && self.min_radius <= self.initial_radius
            && self.initial_radius <= self.max_radius)
        {
            return Err(bad(
                "radii",
                format!(
                    "need 0 < min_radius ≤ initial_radius ≤ max_radius < ∞, got {} ≤ {} ≤ {}",
                    self.min_radius, self.initial_radius, self.max_radius
                ),
            ));
        }
        if !(self.grow.is_finite() && self.grow > 1.0) {
            return Err(bad(
                "grow",
                format!("{} is not a finite factor > 1", self.grow),
            ));
        }
        if !(self.shrink > 0.0 && self.shrink < 1.0) {
            return Err(bad("shrink", format!("{} is not in (0, 1)", self.shrink)));
        }
        if !(self.poor_ratio >= 0.0 && self.poor_ratio <= self.good_ratio && self.good_ratio <= 1.0)
        {
            return Err(bad(
                "ratios",
                format!(
                    "need 0 ≤ poor_ratio ≤ good_ratio ≤ 1, got {} and {}",
                    self.poor_ratio, self.good_ratio
                ),
            ));
        }
        Ok(())
    }

    /// The radius after a step with decrease ratio `ratio` (`None`: the
    /// step was rejected or failed).
    pub fn update(&self, radius: f64, ratio: Option<f64>) -> f64 {
        let next = match ratio {
            Some(rho) if rho >= self.good_ratio => radius * self.grow,
            Some(rho) if rho >= self.poor_ratio => radius,
            _ => radius * self.shrink,
        };
        next.clamp(self.min_radius, self.max_radius)
    }
}

#[cfg(test)]
mod tests {
    use super::IdentifyConfig;

    /// A configuration read from JSON: a misspelt field is an error naming
    /// it, not silently the default (a probe's `"etaa"` was dropped).
    #[test]
    fn unknown_fields_in_a_configuration_are_errors() {
        let text = r#"{"search": {"eta": 5, "etaa": 3}}"#;
        let err = serde_json::from_str::<IdentifyConfig>(text)
            .unwrap_err()
            .to_string();
        assert!(err.contains("unknown field `etaa`"), "{err}");
        let text = r#"{"max_iteration": 3}"#;
        assert!(serde_json::from_str::<IdentifyConfig>(text).is_err());
        // Omitted fields are still the defaults.
        let config: IdentifyConfig = serde_json::from_str(r#"{"max_iterations": 3}"#).unwrap();
        assert_eq!(
            config,
            IdentifyConfig {
                max_iterations: 3,
                ..IdentifyConfig::default()
            }
        );
    }

    /// A held-out fraction that leaves no batch samples is named, not the
    /// batch size (it said "1 exceeds the 0 samples available for
    /// batches"; a probe).
    #[test]
    fn a_split_that_leaves_no_pool_names_the_fraction() {
        let config = IdentifyConfig {
            batch_size: Some(1),
            validation: super::Validation::HeldOut { fraction: 0.999 },
            ..IdentifyConfig::default()
        };
        let err = config
            .validate::<crate::test_system::Quadratic2d>(200)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("invalid validation fraction: 0.999 of 200"),
            "{err}"
        );
    }
}
