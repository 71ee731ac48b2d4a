//! Free-energy diagnostics of a model along trajectories.
//!
//! For any model with K ⪰ 0 the free energy E = H + S is non-decreasing along
//! its own flow (dE/dt = ∇Eᵀ K ∇E ≥ 0). Evaluated along *measured*
//! trajectories, E of an identified model should therefore not fall either:
//! the fraction of steps where it does is a check of the identification that
//! needs no derivatives.

use crate::error::{Error, Result};
use crate::model::Model;
use crate::system::MetriplecticSystem;
use crate::trajectory::Trajectory;

/// How often E decreased along a set of trajectories.
///
/// ```
/// # use metriplectic_runtime::prelude::*;
/// # use metriplectic_runtime::{diagnostics::free_energy_diagnostics, Trajectory};
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
            reason: format!("{tolerance}: must be finite and ≥ 0"),
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
