//! The weak (integral) form: identification from measured states alone.
//!
//! Differentiating noisy samples amplifies their noise (σ/h). Integrating
//! does the opposite. Over a window [a, b] of consecutive samples of one
//! trajectory, with a test function φ that vanishes at both ends,
//! integration by parts turns ẋ = f(x) into
//!
//! ```text
//! −∫ φ′(t) x(t) dt = ∫ φ(t) f(x(t)) dt,
//! ```
//!
//! which needs no derivative, and whose both sides average the noise of
//! many samples. Interpolating x and f(x) linearly between the window's
//! (possibly non-uniform) sample times and integrating φ and φ′ exactly
//! against the interpolants gives one equation Σⱼ wⱼ f(xⱼ) = −Σⱼ vⱼ xⱼ
//! with wⱼ = ∫φ ℓⱼ, vⱼ = ∫φ′ ℓⱼ (ℓⱼ the hat functions): linear in the model's coefficients
//! whenever f is, so the entropy search, the metric search and the joint
//! step all run on it unchanged. φ(t) = ((t − a)(b − t))^p, normalised to
//! unit integral, so that an equation's target is a weighted mean of ẋ over
//! the window and weak and pointwise data have comparable scales.

use serde::{Deserialize, Serialize};

use super::equations::{sealed, Equations, IdentificationData, Terms};
use super::Trajectory;
use crate::error::{invalid, Result};

/// Nodes and weights of 5-point Gauss–Legendre quadrature on [−1, 1].
const GAUSS_LEGENDRE_5: [(f64, f64); 5] = [
    (-0.906_179_845_938_664, 0.236_926_885_056_189_1),
    (-0.538_469_310_105_683, 0.478_628_670_499_366_5),
    (0.0, 0.568_888_888_888_888_9),
    (0.538_469_310_105_683, 0.478_628_670_499_366_5),
    (0.906_179_845_938_664, 0.236_926_885_056_189_1),
];

/// How trajectories are cut into weak-form windows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct WeakForm {
    /// Samples per window (≥ 3; the test function vanishes at both ends).
    /// Default 15.
    pub window: usize,
    /// Samples between the starts of consecutive windows (≥ 1). Default 5.
    pub stride: usize,
    /// Exponent p of the test function ((t − a)(b − t))^p (≥ 2, so that φ
    /// and φ′ vanish at both ends). Default 4.
    pub power: u32,
}

impl Default for WeakForm {
    fn default() -> Self {
        Self {
            window: 15,
            stride: 5,
            power: 4,
        }
    }
}

impl WeakForm {
    /// Checks the window, stride and power.
    pub fn validate(&self) -> Result<()> {
        if self.window < 3 {
            return Err(invalid(
                "weak-form window",
                format!("{} samples: a window needs at least 3", self.window),
            ));
        }
        if self.stride == 0 {
            return Err(invalid("weak-form stride", "must be at least 1"));
        }
        if self.power < 2 {
            return Err(invalid(
                "weak-form power",
                format!(
                    "{}: the test function and its derivative must vanish at the window's ends; use 2 or more",
                    self.power
                ),
            ));
        }
        Ok(())
    }
}

/// Weak-form identification data: one equation per window of each
/// trajectory (see the module documentation of the method in
/// [`WeakDataset::from_trajectories`]).
///
/// ```
/// use metriplectic_runtime::{Trajectory, WeakDataset, WeakForm, IdentificationData};
///
/// let t: Vec<f64> = (0..40).map(|k| 0.05 * k as f64).collect();
/// let x: Vec<f64> = t.iter().flat_map(|t| [t.cos(), -t.sin()]).collect();
/// let traj = Trajectory::new(vec!["q".into(), "p".into()], t, x, None).unwrap();
/// let data = WeakDataset::from_trajectories(&[traj], &WeakForm::default()).unwrap();
/// assert_eq!(data.equation_count(), 6); // windows starting at samples 0, 5, …, 25
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct WeakDataset {
    dim: usize,
    states: Vec<f64>,
    targets: Vec<f64>,
    offsets: Vec<usize>,
    samples: Vec<usize>,
    weights: Vec<f64>,
}

impl WeakDataset {
    /// The weak-form equations of `trajectories` (same state names, states
    /// only; derivatives, if present, are ignored).
    ///
    /// Each trajectory of at least `form.window` samples gives a window
    /// starting at samples 0, stride, 2·stride, … while it fits. With
    /// φ(t) = ((t − a)(b − t))^p / ∫((t − a)(b − t))^p dt on the window
    /// [a, b] and the hat functions ℓⱼ of its sample times, the equation is
    /// Σⱼ (∫φℓⱼ) f(xⱼ) = −Σⱼ (∫φ′ℓⱼ) xⱼ — the weak form of ẋ = f(x) with x
    /// and f(x) interpolated linearly, no derivative estimate, both sides
    /// averaging the states' noise.
    ///
    /// Errors if there is no trajectory, the trajectories' dimensions differ,
    /// the form is invalid, or no trajectory is long enough for a window.
    pub fn from_trajectories(trajectories: &[Trajectory], form: &WeakForm) -> Result<Self> {
        form.validate()?;
        let first = trajectories
            .first()
            .ok_or_else(|| invalid("trajectories", "at least one trajectory is required"))?;
        let dim = first.dim();
        let mut data = Self {
            dim,
            states: Vec::new(),
            targets: Vec::new(),
            offsets: vec![0],
            samples: Vec::new(),
            weights: Vec::new(),
        };
        for (index, trajectory) in trajectories.iter().enumerate() {
            if trajectory.dim() != dim {
                return Err(invalid(
                    "trajectories",
                    format!(
                        "trajectory {index} has {} state variables, trajectory 0 has {dim}",
                        trajectory.dim()
                    ),
                ));
            }
            let base = data.states.len() / dim;
            data.states.extend_from_slice(trajectory.states());
            let times = trajectory.times();
            let mut start = 0;
            while start + form.window <= times.len() {
                data.push_window(trajectory, base, start, form)?;
                start += form.stride;
            }
        }
        if data.targets.is_empty() {
            return Err(invalid(
                "weak-form window",
                format!(
                    "{} samples, but no trajectory is that long (the longest has {})",
                    form.window,
                    trajectories.iter().map(Trajectory::len).max().unwrap_or(0)
                ),
            ));
        }
        data.drop_unused_samples();
        Ok(data)
    }

    /// Appends the equation of the window of `trajectory` starting at
    /// sample `start` (its samples stored from `base`).
    fn push_window(
        &mut self,
        trajectory: &Trajectory,
        base: usize,
        start: usize,
        form: &WeakForm,
    ) -> Result<()> {
        let n = self.dim;
        let times = &trajectory.times()[start..start + form.window];
        let (a, b) = (times[0], times[times.len() - 1]);
        let p = form.power as i32;
        // φ(t) = ((t − a)(b − t))^p and φ′, before normalisation.
        let phi = |t: f64| ((t - a) * (b - t)).powi(p);
        let dphi =
            |t: f64| f64::from(form.power) * ((t - a) * (b - t)).powi(p - 1) * (a + b - 2.0 * t);
        // Product integration: x and f(x) are interpolated linearly between
        // samples, φ and φ′ are integrated exactly against the hat functions
        // (5-point Gauss–Legendre on each interval is exact for these
        // polynomials of degree ≤ 2p + 1 ≤ 9), so the only error is the
        // interpolation's, O(h²), however uneven the sample times.
        let mut weights = vec![0.0; times.len()];
        let mut slopes = vec![0.0; times.len()];
        let mut integral = 0.0;
        for k in 0..times.len() - 1 {
            let (left, right) = (times[k], times[k + 1]);
            let h = right - left;
            for (node, weight) in GAUSS_LEGENDRE_5 {
                let t = left + 0.5 * h * (node + 1.0);
                let w = 0.5 * h * weight;
                let (rise, fall) = ((t - left) / h, (right - t) / h);
                weights[k] += w * phi(t) * fall;
                weights[k + 1] += w * phi(t) * rise;
                slopes[k] += w * dphi(t) * fall;
                slopes[k + 1] += w * dphi(t) * rise;
                integral += w * phi(t);
            }
        }
        if !(integral.is_finite() && integral > 0.0) {
            return Err(invalid(
                "time spacing",
                format!(
                    "the weak-form window of samples {start}..={} (t = {a:e} … {b:e}) has no usable \
                     test-function integral ({integral:e}); the times are too close together or too far apart",
                    start + form.window - 1
                ),
            ));
        }
        let mut target = vec![0.0; n];
        for (j, (weight, slope)) in weights.iter().zip(&slopes).enumerate() {
            let x = trajectory.state(start + j);
            let slope = -slope / integral;
            target.iter_mut().zip(x).for_each(|(y, v)| *y += slope * v);
            let weight = weight / integral;
            if weight != 0.0 {
                self.samples.push(base + start + j);
                self.weights.push(weight);
            }
        }
        self.targets.extend(target);
        self.offsets.push(self.samples.len());
        Ok(())
    }

    /// Keeps only the samples some equation reads, renumbered in order.
    fn drop_unused_samples(&mut self) {
        let n = self.dim;
        let count = self.states.len() / n;
        let mut used = vec![usize::MAX; count];
        let mut states = Vec::new();
        for sample in &mut self.samples {
            if used[*sample] == usize::MAX {
                used[*sample] = states.len() / n;
                states.extend_from_slice(&self.states[*sample * n..(*sample + 1) * n]);
            }
            *sample = used[*sample];
        }
        self.states = states;
    }

    /// The states the equations read, row-major.
    pub fn states(&self) -> &[f64] {
        &self.states
    }

    /// The targets −Σⱼ ωⱼ φ′(tⱼ) xⱼ, n per equation.
    pub fn targets(&self) -> &[f64] {
        &self.targets
    }
}

impl sealed::Sealed for WeakDataset {
    fn equations(&self) -> Equations<'_> {
        Equations {
            dim: self.dim,
            states: &self.states,
            targets: &self.targets,
            terms: Some(Terms {
                offsets: &self.offsets,
                samples: &self.samples,
                weights: &self.weights,
            }),
        }
    }

    fn select(&self, indices: &[usize]) -> Result<Self> {
        let count = self.targets.len() / self.dim;
        if let Some(&bad) = indices.iter().find(|&&e| e >= count) {
            return Err(invalid(
                "equation index",
                format!("{bad} is out of range for {count} weak-form equations"),
            ));
        }
        let n = self.dim;
        let mut out = Self {
            dim: n,
            states: self.states.clone(),
            targets: Vec::with_capacity(indices.len() * n),
            offsets: vec![0],
            samples: Vec::new(),
            weights: Vec::new(),
        };
        for &e in indices {
            out.targets
                .extend_from_slice(&self.targets[e * n..(e + 1) * n]);
            let range = self.offsets[e]..self.offsets[e + 1];
            out.samples.extend_from_slice(&self.samples[range.clone()]);
            out.weights.extend_from_slice(&self.weights[range]);
            out.offsets.push(out.samples.len());
        }
        out.drop_unused_samples();
        Ok(out)
    }
}

impl IdentificationData for WeakDataset {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::equations::sealed::Sealed;

    /// x(t) = (cos t, −sin t) solves ẋ = (x₂, −x₁): every weak equation
    /// holds for f(x) = (x₂, −x₁) up to quadrature error.
    #[test]
    fn weak_equations_hold_for_the_true_field() {
        // Non-uniform times.
        let t: Vec<f64> = (0..60)
            .map(|k| 0.05 * k as f64 + 0.01 * (k as f64).sin())
            .collect();
        let x: Vec<f64> = t.iter().flat_map(|t| [t.cos(), -t.sin()]).collect();
        let traj = Trajectory::new(vec!["q".into(), "p".into()], t, x, None).unwrap();
        let data = WeakDataset::from_trajectories(&[traj], &WeakForm::default()).unwrap();
        let equations = data.equations();
        assert!(equations.len() >= 9);
        for e in 0..equations.len() {
            let mut lhs = [0.0; 2];
            for (j, w) in equations.terms_of(e) {
                let x = equations.state(j);
                lhs[0] += w * x[1];
                lhs[1] -= w * x[0];
            }
            let target = equations.target(e);
            for k in 0..2 {
                assert!(
                    (lhs[k] - target[k]).abs() < 1e-3,
                    "equation {e}: {lhs:?} vs {target:?}"
                );
            }
        }
        let picked = data.select(&[2, 0]).unwrap();
        assert_eq!(picked.equations().target(1), equations.target(0));
        assert!(data.select(&[99]).is_err());
    }

    #[test]
    fn bad_forms_and_short_trajectories_are_errors() {
        let traj = Trajectory::new(vec!["x".into()], vec![0.0, 1.0], vec![1.0, 2.0], None).unwrap();
        assert!(
            WeakDataset::from_trajectories(std::slice::from_ref(&traj), &WeakForm::default())
                .is_err()
        );
        for form in [
            WeakForm {
                window: 2,
                ..WeakForm::default()
            },
            WeakForm {
                stride: 0,
                ..WeakForm::default()
            },
            WeakForm {
                power: 1,
                ..WeakForm::default()
            },
        ] {
            assert!(WeakDataset::from_trajectories(std::slice::from_ref(&traj), &form).is_err());
        }
        assert!(WeakDataset::from_trajectories(&[], &WeakForm::default()).is_err());
    }
}
