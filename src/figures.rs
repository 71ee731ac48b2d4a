//! The reproduction's figures: the paper's trajectory and loss plots, plus
//! the free energy along simulated trajectories.

use std::path::Path;

use metriplectic_runtime::{
    free_energy_curves, loss_curves, phase_portrait_2d, trajectories_3d, History, Labels,
    Simulation,
};

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
    let joint: Vec<f64> = history
        .iterations
        .iter()
        .filter_map(|r| r.joint.as_ref().map(|j| j.step.cost_after.per_component))
        .collect();
    let mut series: Vec<(&str, &[f64])> =
        vec![("metric search", &metric), ("entropy search", &entropy)];
    if joint.len() == history.iterations.len() && !joint.is_empty() {
        series.push(("joint step", &joint));
    }
    loss_curves(
        out.join("loss.png"),
        &series,
        &Labels {
            title: "Minibatch loss (mean |residual| per component)",
            x: "iteration",
            y: "loss",
            ..Labels::default()
        },
    )?;
    // S, and so E, is identified up to an additive constant (the constant
    // monomial has zero gradient). Anchor E at the largest value any
    // trajectory reaches: for an exact model that is E = 0 on the zero set,
    // so the curve is the paper's −E.
    let top = simulations
        .iter()
        .flat_map(|s| s.free_energy.iter().copied())
        .fold(f64::NEG_INFINITY, f64::max);
    let curves: Vec<(&[f64], Vec<f64>)> = simulations
        .iter()
        .map(|s| {
            let shifted = s.free_energy.iter().map(|e| e - top).collect();
            (s.trajectory.times(), shifted)
        })
        .collect();
    free_energy_curves(
        out.join("free_energy.png"),
        &curves,
        &Labels {
            title: "Free energy along simulated trajectories (E* = largest E reached)",
            x: "t",
            y: "−(E − E*)",
            ..Labels::default()
        },
    )?;
    Ok(())
}
