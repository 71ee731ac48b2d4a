//! Free-energy checks: along a simulated trajectory (against the
//! integrator's tolerance) and along measured trajectories.
//!
//! For any model with K ⪰ 0 the free energy E = H + S is non-decreasing along
//! its own flow (dE/dt = ∇Eᵀ K ∇E ≥ 0). Evaluated along *measured*
//! trajectories, E of an identified model should therefore not fall either:
//! the fraction of steps where it does is a check of the identification that
//! needs no derivatives.

use super::dopri::IntegratorOptions;
use crate::data::Trajectory;
use crate::error::{Error, Result};
use crate::model::Model;
use crate::system::{CertificateMode, MetriplecticSystem};

/// How often E decreased along a set of trajectories.
///
/// ```
/// # use metriplectic_runtime::prelude::*;
/// # use metriplectic_runtime::{free_energy_diagnostics, Trajectory};
/// # metriplectic! {
/// #     pub struct Decay;
/// #     state (x, y);
/// #     poisson = [[0, 1], [-1, 0]];
/// #     hamiltonian = 0.5 * x^2 + 0.5 * y^2;
/// #     entropy degree 2;
/// #     metric degree 0;
/// #     reference { entropy = -(x^2 + y^2); metric = [[1, 0], [0, 1]]; }
/// # }
/// let model = Model::<Decay>::reference().unwrap();
/// // E = −(x² + y²)/2 rises as the state shrinks towards 0.
/// let traj = Trajectory::new(vec!["x".into(), "y".into()], vec![0.0, 1.0, 2.0],
///                            vec![1.0, 0.0, 0.5, 0.0, 0.7, 0.0], None).unwrap();
/// let report = free_energy_diagnostics(&model, &[traj], 1e-12).unwrap();
/// assert_eq!(report.steps, 2);
/// assert_eq!(report.decreasing_steps, 1);
/// assert_eq!(report.fraction_decreasing(), 0.5);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct FreeEnergyReport {
    /// Consecutive sample pairs examined (samples − 1 per trajectory).
    pub steps: usize,
    /// Pairs where E decreased by more than the tolerance.
    pub decreasing_steps: usize,
    /// Largest decrease E(xₖ) − E(xₖ₊₁) seen (0 if E never decreased).
    pub largest_decrease: f64,
    /// (trajectory, sample k) of the largest decrease, if any.
    pub worst: Option<(usize, usize)>,
}

impl FreeEnergyReport {
    /// Fraction of steps where E decreased beyond the tolerance (0 when there
    /// are no steps).
    pub fn fraction_decreasing(&self) -> f64 {
        if self.steps == 0 {
            0.0
        } else {
            self.decreasing_steps as f64 / self.steps as f64
        }
    }
}

/// Counts the steps along `trajectories` where the model's free energy fell
/// by more than `tolerance` (absolute, ≥ 0).
///
/// Trajectories must have the system's state variables in its order.
pub fn free_energy_diagnostics<S: MetriplecticSystem>(
    model: &Model<S>,
    trajectories: &[Trajectory],
    tolerance: f64,
) -> Result<FreeEnergyReport> {
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err(Error::InvalidArgument {
            what: "free-energy tolerance".to_owned(),
            reason: format!("{}: must be finite and ≥ 0", crate::error::Num(tolerance)),
        });
    }
    let mut report = FreeEnergyReport {
        steps: 0,
        decreasing_steps: 0,
        largest_decrease: 0.0,
        worst: None,
    };
    for (index, traj) in trajectories.iter().enumerate() {
        traj.check_names(S::STATE_NAMES)?;
        let energy: Vec<f64> = (0..traj.len())
            .map(|k| model.free_energy(traj.state(k)))
            .collect::<Result<_>>()?;
        for (k, pair) in energy.windows(2).enumerate() {
            report.steps += 1;
            let decrease = pair[0] - pair[1];
            if decrease > tolerance {
                report.decreasing_steps += 1;
            }
            if decrease > report.largest_decrease {
                report.largest_decrease = decrease;
                report.worst = Some((index, k));
            }
        }
    }
    Ok(report)
}

/// Result of the free-energy monotonicity check of one simulated trajectory
/// (see the [`simulate`](crate::simulate) documentation for the tolerance).
///
/// ```
/// use metriplectic_runtime::EnergyCheck;
///
/// let check = EnergyCheck { steps: 10, violations: 0, largest_decrease: 0.0,
///                           largest_decrease_ratio: 0.0, worst_step: None };
/// assert!(check.is_non_decreasing());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct EnergyCheck {
    /// Number of consecutive output pairs checked.
    pub steps: usize,
    /// Pairs where E decreased by more than the tolerance τₖ.
    pub violations: usize,
    /// Largest decrease E(xₖ) − E(xₖ₊₁) seen (0 if E never decreased).
    pub largest_decrease: f64,
    /// Largest ratio of a decrease to its tolerance τₖ (0 if E never decreased).
    pub largest_decrease_ratio: f64,
    /// Output index k of the worst pair, if E ever decreased.
    pub worst_step: Option<usize>,
}

impl EnergyCheck {
    /// `true` if E was non-decreasing within the tolerance everywhere.
    pub fn is_non_decreasing(&self) -> bool {
        self.violations == 0
    }
}

/// Where a simulation left the region of the system's on-region metric
/// certificate ([`CertificateMode::OnRegion`]): there K ⪰ 0, and so
/// dE/dt ≥ 0, is not certified, and the free energy may fall without any
/// error of the integrator. The integrator's steps are counted as well as
/// the outputs: outputs far apart can all lie inside while the trajectory
/// between them does not.
///
/// ```
/// use metriplectic_runtime::OutsideRegion;
///
/// let outside = OutsideRegion { outputs: 0, steps: 12, first_time: 3.5 };
/// assert!(outside.outputs == 0 && outside.steps > 0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutsideRegion {
    /// How many outputs lie outside the region (0 when only the trajectory
    /// between outputs left it).
    pub outputs: usize,
    /// How many of the integrator's states lay outside it: the start and
    /// the end of each step (DOPRI5's accepted steps; every
    /// discrete-gradient step).
    pub steps: usize,
    /// The earliest time at which an output or a step's end lay outside.
    pub first_time: f64,
}

/// Where the start `(t0, x0)`, the outputs and the step ends, each
/// `(times, states row-major)`,
/// lie outside the region of `S`'s on-region certificate; `None` if all
/// lie inside, or if the system's certificate (if any) bounds K from below
/// everywhere.
pub(super) fn outside_region<S: MetriplecticSystem>(
    start: (f64, &[f64]),
    outputs: (&[f64], &[f64]),
    steps: (&[f64], &[f64]),
) -> Option<OutsideRegion> {
    let certificate = S::REGION_CERTIFICATE.filter(|c| c.mode == CertificateMode::OnRegion)?;
    // (count outside, earliest time outside)
    let scan = |(times, states): (&[f64], &[f64])| {
        times
            .iter()
            .zip(states.chunks_exact(S::DIM))
            .filter(|(_, x)| !certificate.region.contains(x))
            .fold((0, f64::INFINITY), |(count, first), (&t, _)| {
                (count + 1, first.min(t))
            })
    };
    let (outputs, first_output) = scan(outputs);
    let (steps, first_step) = scan(steps);
    // The start counts with the steps (outputs need not include it).
    let (start_outside, first_start) = scan((&[start.0], start.1));
    let steps = steps + start_outside;
    let first_step = first_step.min(first_start);
    (outputs + steps > 0).then_some(OutsideRegion {
        outputs,
        steps,
        first_time: first_output.min(first_step),
    })
}

/// The tolerances τₖ of DOPRI5's outputs (see [`simulate`](crate::simulate)):
/// the change of E caused by a state error within the tolerances, plus the
/// rounding of E at both ends.
pub(super) fn integrator_tolerances(
    gradient_norms: &[f64],
    rounding: &[f64],
    states: &[f64],
    n: usize,
    options: &IntegratorOptions,
    factor: f64,
) -> Vec<f64> {
    let state_norms: Vec<f64> = states.chunks_exact(n).map(norm).collect();
    (0..state_norms.len().saturating_sub(1))
        .map(|k| {
            let error_scale = options.atol * (n as f64).sqrt()
                + options.rtol * state_norms[k].max(state_norms[k + 1]);
            factor * error_scale * gradient_norms[k].max(gradient_norms[k + 1])
                + rounding[k]
                + rounding[k + 1]
        })
        .collect()
}

/// Counts decreases of E between consecutive outputs beyond their
/// tolerances τₖ (`tolerances[k]` for outputs k and k + 1).
pub(super) fn check_energy(energy: &[f64], tolerances: &[f64]) -> EnergyCheck {
    let mut check = EnergyCheck {
        steps: energy.len().saturating_sub(1),
        violations: 0,
        largest_decrease: 0.0,
        largest_decrease_ratio: 0.0,
        worst_step: None,
    };
    for (k, &tolerance) in tolerances.iter().enumerate().take(check.steps) {
        let decrease = energy[k] - energy[k + 1];
        if decrease <= 0.0 {
            continue;
        }
        let ratio = if tolerance > 0.0 {
            decrease / tolerance
        } else {
            f64::INFINITY
        };
        if decrease > tolerance {
            check.violations += 1;
        }
        if decrease > check.largest_decrease {
            check.largest_decrease = decrease;
        }
        if ratio > check.largest_decrease_ratio {
            check.largest_decrease_ratio = ratio;
            check.worst_step = Some(k);
        }
    }
    check
}

pub(super) fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decreases_beyond_the_integrator_tolerance_are_violations() {
        // E falls by 1e-3 per step on a unit-norm state with a unit gradient:
        // far beyond rtol = 1e-6, so every step is a violation.
        let energy = [0.0, -1e-3, -2e-3, -3e-3];
        let states = [1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0];
        let options = IntegratorOptions::default();
        let tolerances = integrator_tolerances(&[1.0; 4], &[0.0; 4], &states, 2, &options, 10.0);
        let check = check_energy(&energy, &tolerances);
        assert_eq!((check.steps, check.violations), (3, 3));
        assert!(!check.is_non_decreasing());
        assert!((check.largest_decrease - 1e-3).abs() < 1e-15);
        // Decreases within the tolerance are not violations.
        let energy = [0.0, -1e-12, -2e-12];
        let tolerances =
            integrator_tolerances(&[1.0; 3], &[0.0; 3], &states[..6], 2, &options, 10.0);
        let check = check_energy(&energy, &tolerances);
        assert_eq!(check.violations, 0);
        assert!(check.is_non_decreasing());
    }
}
