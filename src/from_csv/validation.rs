//! The model simulated from the validation trajectories' first states and
//! compared with their measured states.

use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{IntegratorOptions, OutputTimes, Simulation};

/// The model's prediction of the validation trajectories, and how far it is
/// from the measured states.
pub(super) struct Validation {
    /// (index among the validation trajectories, simulation at the measured times).
    pub(super) simulations: Vec<(usize, Simulation)>,
    pub(super) not_simulated: Vec<String>,
    pub(super) relative_error: Option<f64>,
    pub(super) free_energy_decrease_fraction: f64,
}

/// The validation error of the module documentation: `model` simulated from
/// the first state of each of `validation` at its sample times, against
/// the measured states. `None` if no trajectory could be simulated (or the
/// measured states do not vary).
pub fn simulated_relative_error<S: MetriplecticSystem>(
    model: &Model<S>,
    validation: &[Trajectory],
) -> Option<f64> {
    validate(model, validation).relative_error
}

/// Integrator tolerances of the validation simulations: well below any
/// measurement noise, so the error is the model's.
pub(super) fn validation_integrator() -> IntegratorOptions {
    IntegratorOptions {
        rtol: 1e-8,
        atol: 1e-10,
        ..IntegratorOptions::default()
    }
}

/// Simulates the model from each validation trajectory's first state at
/// its sample times and compares with the measured states.
pub(super) fn validate<S: MetriplecticSystem>(
    model: &Model<S>,
    validation: &[Trajectory],
) -> Validation {
    let n = S::DIM;
    let mut simulations = Vec::new();
    let mut not_simulated = Vec::new();
    for (index, measured) in validation.iter().enumerate() {
        let label = trajectory_label(measured);
        let times = measured.times();
        if times.len() < 2 {
            not_simulated.push(format!("{label}: a single sample, nothing to predict"));
            continue;
        }
        let options = SimulationOptions {
            integrator: validation_integrator(),
            output: OutputTimes::Times(times.to_vec()),
            ..SimulationOptions::default()
        };
        let (t0, t1) = (times[0], times[times.len() - 1]);
        match simulate(model, measured.state(0), t0, t1, &options) {
            Ok(simulation) if simulation.trajectory.len() == times.len() => {
                simulations.push((index, simulation));
            }
            Ok(_) => not_simulated.push(format!("{label}: the simulation missed sample times")),
            Err(err) => not_simulated.push(format!("{label}: {err}")),
        }
    }
    // Measured states compared (all but each trajectory's first), their mean,
    // then the two sums of squares.
    let compared = || {
        simulations.iter().flat_map(|(index, simulation)| {
            let measured = &validation[*index];
            (1..measured.len()).map(move |k| (measured.state(k), simulation.trajectory.state(k)))
        })
    };
    let count = compared().count();
    let mut mean = vec![0.0; n];
    for (measured, _) in compared() {
        mean.iter_mut().zip(measured).for_each(|(m, x)| *m += x);
    }
    mean.iter_mut().for_each(|m| *m /= count.max(1) as f64);
    let (mut error2, mut spread2) = (0.0, 0.0);
    for (measured, predicted) in compared() {
        for j in 0..n {
            error2 += (predicted[j] - measured[j]).powi(2);
            spread2 += (measured[j] - mean[j]).powi(2);
        }
    }
    let relative_error = (count > 0 && spread2 > 0.0).then(|| (error2 / spread2).sqrt());
    let (steps, violations) = simulations.iter().fold((0, 0), |(s, v), (_, sim)| {
        (s + sim.energy.steps, v + sim.energy.violations)
    });
    Validation {
        simulations,
        not_simulated,
        relative_error,
        free_energy_decrease_fraction: if steps == 0 {
            0.0
        } else {
            violations as f64 / steps as f64
        },
    }
}

/// The model from `measured`'s first state over its time span, at 500
/// evenly spaced times, for a smooth curve in the figures.
pub(super) fn smooth_simulation<S: MetriplecticSystem>(
    model: &Model<S>,
    measured: &Trajectory,
) -> Option<Simulation> {
    let times = measured.times();
    let (t0, t1) = (times[0], *times.last()?);
    let options = SimulationOptions {
        integrator: validation_integrator(),
        output: OutputTimes::Interval((t1 - t0) / 500.0),
        ..SimulationOptions::default()
    };
    simulate(model, measured.state(0), t0, t1, &options).ok()
}

/// The trajectory's identifier. A file of several trajectories has a
/// `trajectory` column, so every trajectory this pipeline sees has one.
pub(super) fn trajectory_label(trajectory: &Trajectory) -> String {
    trajectory.id().unwrap_or("(unnamed)").to_owned()
}
