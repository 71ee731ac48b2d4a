//! The reproduction's figures: the paper's trajectory and loss plots, plus
//! the free energy along simulated trajectories. The loss and free-energy
//! figures are also drawn by [`crate::from_csv`].

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
            ZeroSet::None if state_names.len() == 2 => phase_portrait_2d(
                &path,
                &trajectories,
                &[],
                &Labels {
                    title: "Identified model: trajectories from random initial states",
                    x: name(0),
                    y: name(1),
                    ..Labels::default()
                },
            )?,
            ZeroSet::None => trajectories_3d(
                &path,
                &trajectories,
                None,
                &Labels {
                    title: "Identified model: trajectories from random initial states",
                    x: name(0),
                    y: name(1),
                    z: name(2),
                    reference: "",
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
    loss_figure(
        &out.join("loss.png"),
        history,
        "Minibatch loss (mean |residual| per component)",
    )?;
    let simulations: Vec<&Simulation> = simulations.iter().collect();
    free_energy_figure(
        &out.join("free_energy.png"),
        &simulations,
        "Free energy along simulated trajectories",
    )?;
    Ok(())
}

/// The metric-search, entropy-search and (when every iteration took one)
/// joint-step cost per iteration, log scale.
pub fn loss_figure(
    path: &Path,
    history: &History,
    title: &str,
) -> metriplectic_runtime::Result<()> {
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
        path,
        &series,
        &Labels {
            title,
            x: "iteration",
            y: "loss",
            ..Labels::default()
        },
    )
}

/// E_lim − E(t) along each simulated trajectory, log scale, E_lim that
/// trajectory's own limit of E (see `free_energy_curves`).
///
/// S, and so E, is identified up to an additive constant (the constant
/// monomial has zero gradient), which the difference cancels; trajectories
/// settling at different levels (e.g. on different Casimir levels) are each
/// measured from their own. For an exact model of the paper's systems,
/// E_lim = 0 on the zero set and the curve is the paper's −E.
pub fn free_energy_figure(
    path: &Path,
    simulations: &[&Simulation],
    title: &str,
) -> metriplectic_runtime::Result<()> {
    let curves: Vec<(&[f64], &[f64])> = simulations
        .iter()
        .map(|s| (s.trajectory.times(), &s.free_energy[..]))
        .collect();
    free_energy_curves(
        path,
        &curves,
        &Labels {
            title,
            x: "t",
            y: "E_lim − E",
            ..Labels::default()
        },
    )
}
