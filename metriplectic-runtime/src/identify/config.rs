//! What an identification run does: batch, iteration scheme, stopping,
//! starting point, checkpoints.

use serde::{Deserialize, Serialize};

use super::checkpoint::CheckpointConfig;
use super::search::SearchOptions;
use crate::error::{invalid, Result};
use crate::model::{check_entropy, check_metric_coefficients};
use crate::system::MetriplecticSystem;

/// Configuration of [`identify`](crate::identify). Build with struct-update syntax from
/// [`Default`]; [`identify`](crate::identify) validates it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct IdentifyConfig {
    /// `None`: Algorithm 1 on the full data. `Some(q)`: Algorithm 2, a fresh
    /// minibatch of q distinct samples each iteration. q must be between 1
    /// and the number of samples (a larger q is an error, not a clamp, so a
    /// typo does not silently turn Algorithm 2 into Algorithm 1).
    pub batch_size: Option<usize>,
    /// Iteration cap (each iteration = one metric and one entropy search).
    pub max_iterations: usize,
    /// Stop when the per-component cost on the iteration's batch is ≤ this.
    pub tolerance: f64,
    /// Seed of the minibatch generator (ChaCha8): equal seeds give equal runs.
    pub seed: u64,
    /// Initial entropy coefficients ψ⁽⁰⁾ (`None`: zeros).
    pub initial_entropy: Option<Vec<f64>>,
    /// Initial metric coefficients θ⁽⁰⁾ (`None`: the identity metric).
    pub initial_metric: Option<Vec<f64>>,
    /// Options of every search: the coefficient bound η, the SOS tables and
    /// the solver. Default [`SearchOptions::default`] (η = 20).
    pub search: SearchOptions,
    /// Give up after this many consecutive iterations in which both solves failed.
    pub max_failed_iterations: usize,
    /// Which steps each iteration takes (default: the paper's alternation).
    pub scheme: IterationScheme,
    /// Periodic checkpoints of the run's full state, from which
    /// [`identify_resume`](crate::identify_resume) continues it (`None`: no checkpoints).
    pub checkpoint: Option<CheckpointConfig>,
}

/// The steps of one iteration of [`identify`](crate::identify).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[non_exhaustive]
pub enum IterationScheme {
    /// The paper's Algorithms 1 and 2: metric search, then entropy search.
    #[default]
    Alternating,
    /// Metric search, entropy search, then a joint linearised step in both
    /// blocks ([`joint_step`](crate::joint_step)) on the same batch, in a trust region
    /// that adapts from step to step. Every step is accepted only if the
    /// batch cost does not increase, so Theorem 1 still holds.
    AlternatingThenJoint(TrustRegion),
}

impl Default for IdentifyConfig {
    fn default() -> Self {
        Self {
            batch_size: None,
            max_iterations: 100,
            tolerance: 1e-9,
            seed: 0,
            initial_entropy: None,
            initial_metric: None,
            search: SearchOptions::default(),
            max_failed_iterations: 3,
            scheme: IterationScheme::Alternating,
            checkpoint: None,
        }
    }
}

impl IdentifyConfig {
    /// Checks the configuration against system `S` and a dataset of
    /// `samples` samples.
    pub fn validate<S: MetriplecticSystem>(&self, samples: usize) -> Result<()> {
        match self.batch_size {
            Some(0) => {
                return Err(invalid(
                    "batch size",
                    "must be at least 1 (use None for the full batch)".to_owned(),
                ))
            }
            Some(q) if q > samples => {
                return Err(invalid(
                    "batch size",
                    format!(
                        "{q} exceeds the {samples} samples of the dataset (use None for the full batch)"
                    ),
                ))
            }
            _ => {}
        }
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return Err(invalid(
                "tolerance",
                format!("{} is not a finite non-negative number", self.tolerance),
            ));
        }
        if self.max_iterations == 0 {
            return Err(invalid("max_iterations", "must be at least 1".to_owned()));
        }
        if self.max_failed_iterations == 0 {
            return Err(invalid(
                "max_failed_iterations",
                "must be at least 1".to_owned(),
            ));
        }
        if let Some(entropy) = &self.initial_entropy {
            check_entropy::<S>("initial entropy coefficients", entropy)?;
        }
        if let Some(metric) = &self.initial_metric {
            check_metric_coefficients::<S>("initial metric coefficients", metric)?;
        }
        if let IterationScheme::AlternatingThenJoint(trust) = &self.scheme {
            trust.validate()?;
        }
        if let Some(checkpoint) = &self.checkpoint {
            checkpoint.validate()?;
        }
        self.search.validate()
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
#[serde(default)]
pub struct TrustRegion {
    /// Δ of the first joint step.
    pub initial_radius: f64,
    /// Upper limit of Δ.
    pub max_radius: f64,
    /// Lower limit of Δ (a minibatch may reject a step that another accepts,
    /// so Δ is not allowed to collapse to zero).
    pub min_radius: f64,
    /// Factor applied to Δ after a good step (> 1).
    pub grow: f64,
    /// Factor applied to Δ after a poor, rejected or failed step (in (0, 1)).
    pub shrink: f64,
    /// ρ at or above which a step counts as good.
    pub good_ratio: f64,
    /// ρ below which a step counts as poor.
    pub poor_ratio: f64,
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
