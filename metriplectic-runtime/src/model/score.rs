//! How well a model fits data, or another model.

use serde::{Deserialize, Serialize};

use super::Model;
use crate::data::check_dataset;
use crate::data::IdentificationData;
use crate::error::Result;
use crate::system::MetriplecticSystem;

/// Agreement of a model's predictions with targets (measured ẋ, weak-form
/// targets, or another model's predictions), pooled over every component.
///
/// ```
/// # use metriplectic_runtime::prelude::*;
/// # metriplectic! {
/// #     pub struct Decay;
/// #     state (x, y);
/// #     poisson = [[0, 1], [-1, 0]];
/// #     hamiltonian = 0.5 * x^2 + 0.5 * y^2;
/// #     entropy degree 2;
/// #     metric degree 0;
/// #     reference { entropy = -(x^2 + y^2); metric = [[1, 0], [0, 1]]; }
/// # }
/// let truth = Model::<Decay>::reference()?;
/// // f(x, y) = (Π + I)∇E = (−x − y, x − y).
/// let data = Dataset::from_rows(2, &[[1.0, 0.0], [0.0, 1.0]], &[[-1.0, 1.0], [-1.0, -1.0]])?;
/// let score = truth.score(&data)?;
/// assert!(score.relative_error < 1e-15 && (score.r_squared - 1.0).abs() < 1e-15);
/// # Ok::<(), metriplectic_runtime::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Score {
    /// ‖prediction − target‖₂ / ‖target‖₂. Undefined when every target
    /// is zero: NaN for an exact fit there, +∞ otherwise.
    pub relative_error: f64,
    /// Mean |prediction − target| per component.
    pub mean_abs_residual: f64,
    /// 1 − Σ(target − prediction)² / Σ(target − mean target)², the mean
    /// taken per state component (1 is a perfect fit). Undefined when the
    /// targets do not vary beyond rounding (a single equation, or copies of
    /// one): NaN for a fit exact to rounding there, −∞ otherwise.
    pub r_squared: f64,
    /// Number of equations (samples or weak-form windows) scored.
    pub equations: usize,
}

impl std::fmt::Display for Score {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "relative error {:.3e}, mean |residual| {:.3e}, R² {:.6} over {} equations",
            self.relative_error, self.mean_abs_residual, self.r_squared, self.equations
        )
    }
}

impl<S: MetriplecticSystem> Model<S> {
    /// Scores the model's predictions against `data`'s targets: its vector
    /// field against measured ẋ, or its weak-form integrals against the
    /// weak-form targets.
    pub fn score(&self, data: &impl IdentificationData) -> Result<Score> {
        let predictions = self.predictions(data)?;
        let equations = data.equations();
        Ok(score(S::DIM, &predictions, equations.targets))
    }

    /// Scores the model against `reference` on the states of `data`
    /// (e.g. an identified model against the true one on held-out states):
    /// the targets are `reference`'s predictions, not `data`'s targets.
    pub fn compare(&self, reference: &Model<S>, data: &impl IdentificationData) -> Result<Score> {
        let predictions = self.predictions(data)?;
        let targets = reference.predictions(data)?;
        Ok(score(S::DIM, &predictions, &targets))
    }

    /// The model's prediction of every equation's target: f at each sample
    /// (weighted and summed for weak-form equations).
    fn predictions(&self, data: &impl IdentificationData) -> Result<Vec<f64>> {
        check_dataset::<S>(data)?;
        let equations = data.equations();
        let n = S::DIM;
        let mut fields = vec![0.0; equations.sample_count() * n];
        for (j, out) in fields.chunks_exact_mut(n).enumerate() {
            self.vector_field(equations.state(j), out)?;
        }
        let mut predictions = vec![0.0; equations.len() * n];
        for (e, out) in predictions.chunks_exact_mut(n).enumerate() {
            for (j, w) in equations.terms_of(e) {
                out.iter_mut()
                    .zip(&fields[j * n..(j + 1) * n])
                    .for_each(|(p, f)| *p += w * f);
            }
        }
        Ok(predictions)
    }
}

fn score(n: usize, predictions: &[f64], targets: &[f64]) -> Score {
    let count = targets.len() / n.max(1);
    // Everything in units of the largest magnitude, so that the squares of
    // finite values beyond 1e154 do not overflow into ∞/∞ = NaN.
    let unit = predictions
        .iter()
        .chain(targets)
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    let unit = if unit > 0.0 && unit.is_finite() {
        unit
    } else {
        1.0
    };
    let mut means = vec![0.0; n];
    for row in targets.chunks_exact(n) {
        means
            .iter_mut()
            .zip(row)
            .for_each(|(m, t)| *m += t / unit / count as f64);
    }
    let (mut residual2, mut target2, mut spread2, mut absolute) = (0.0, 0.0, 0.0, 0.0);
    for (prediction, target) in predictions.chunks_exact(n).zip(targets.chunks_exact(n)) {
        let (prediction, target) = (
            prediction.iter().map(|p| p / unit),
            target.iter().map(|t| t / unit),
        );
        for (j, (prediction, target)) in prediction.zip(target).enumerate() {
            let r = prediction - target;
            residual2 += r * r;
            absolute += r.abs();
            target2 += target * target;
            spread2 += (target - means[j]).powi(2);
        }
    }
    // Targets that vary only by the rounding of their mean do not vary: R²
    // is then undefined, not a ratio of two roundings (a probe's 50 copies
    // of one sample scored R² = −184.6 for a residual of 8e-16).
    let rounding2 = (ROUNDING_ULPS * f64::EPSILON).powi(2) * target2;
    let r_squared = if spread2 > rounding2 {
        1.0 - residual2 / spread2
    } else if residual2 <= rounding2 {
        f64::NAN
    } else {
        f64::NEG_INFINITY
    };
    Score {
        relative_error: (residual2 / target2).sqrt(),
        mean_abs_residual: absolute / targets.len().max(1) as f64 * unit,
        r_squared,
        equations: count,
    }
}

/// Spreads and residuals within this many ulps of the targets' size are
/// rounding.
const ROUNDING_ULPS: f64 = 64.0;

#[cfg(test)]
mod tests {
    use super::score;

    #[test]
    fn scores_of_values_whose_squares_overflow_are_finite() {
        // Residuals (1, 0) against targets (1, 1), in units of 1e200.
        let huge = score(1, &[2e200, 1e200], &[1e200, 1e200]);
        assert!((huge.relative_error - 0.5_f64.sqrt()).abs() < 1e-15);
        assert!((huge.mean_abs_residual - 0.5e200).abs() < 1e185);
        // The targets do not vary: R² is -∞ for an inexact fit, not NaN.
        assert_eq!(huge.r_squared, f64::NEG_INFINITY);
        // Copies of one target whose mean rounds: still no variation, and
        // a residual of rounding size is an exact fit.
        let copies = vec![0.1; 50];
        let rounded: Vec<f64> = copies.iter().map(|t| t + 1e-17).collect();
        assert!(score(1, &rounded, &copies).r_squared.is_nan());
        assert_eq!(
            score(1, &vec![0.2; 50], &copies).r_squared,
            f64::NEG_INFINITY
        );
        // The same numbers at ordinary size give the same score.
        let small = score(1, &[2.0, 1.0], &[1.0, 1.0]);
        assert_eq!(small.relative_error, huge.relative_error);
        assert_eq!(small.mean_abs_residual, 0.5);
    }
}
