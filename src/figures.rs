//! The reproduction's figures: the paper's trajectory and loss plots, plus
//! the free energy along simulated trajectories.

use std::path::Path;

use metriplectic_runtime::identify::History;
use metriplectic_runtime::plot::{
    free_energy_curves, loss_curves, phase_portrait_2d, trajectories_3d, Labels,
};
use metriplectic_runtime::simulate::Simulation;

use crate::reproduction::{Experiment, ReproductionError, ZeroSet};

/// Writes `trajectories.png`/`.svg`, `loss.png` and `free_energy.png` into `out`.
pub fn write_all(
    out: &Path,
    history: &History,
    simulations: &[Simulation],
    experiment: &Experiment,
    state_names: &[&str],
) -> Result<(), ReproductionError> {
    let trajectories: Vec<Vec<&[f64]>> = simulations
        .iter()
        .map(|s| {
            let t = &s.trajectory;
            t.states().chunks_exact(t.dim()).collect()
        })
        .collect();
    let name = |j: usize| state_names.get(j).copied().unwrap_or("");
    for extension in ["png", "svg"] {
        let path = out.join(format!("trajectories.{extension}"));
        match &experiment.zero_set {
            ZeroSet::Curve(curve) => phase_portrait_2d(
                &path,
                &trajectories,
                curve,
                &Labels {
                    title: "Identified model: trajectories from random initial states",
                    x: name(0),
                    y: name(1),
                    reference: "true zero set of E",
                    ..Labels::default()
                },
            )?,
            ZeroSet::Sphere(radius) => trajectories_3d(
                &path,
                &trajectories,
                Some(*radius),
                &Labels {
                    title: "Identified model: trajectories from random initial states",
                    x: name(0),
                    y: name(1),
                    z: name(2),
                    reference: "true zero set of E (unit sphere)",
                },
            )?,
        }
    }
    let metric: Vec<f64> = history
        .iterations
        .iter()
        .map(|r| r.metric.cost_after.per_component)
        .collect();
    let entropy: Vec<f64> = history
        .iterations
        .iter()
        .map(|r| r.entropy.cost_after.per_component)
        .collect();
    loss_curves(
        out.join("loss.png"),
        &[("metric search", &metric), ("entropy search", &entropy)],
        &Labels {
            title: "Minibatch loss (mean |residual| per component)",
            x: "iteration",
            y: "loss",
            ..Labels::default()
        },
    )?;
    let curves: Vec<(&[f64], &[f64])> = simulations
        .iter()
        .map(|s| (s.trajectory.times(), s.free_energy.as_slice()))
        .collect();
    free_energy_curves(
        out.join("free_energy.png"),
        &curves,
        &Labels {
            title: "Free energy along simulated trajectories of the identified model",
            x: "t",
            y: "−E",
            ..Labels::default()
        },
    )?;
    Ok(())
}
