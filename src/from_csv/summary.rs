//! `summary.json` and the report on stdout.

use std::fmt::Write as _;
use std::path::Path;

use metriplectic_runtime::prelude::*;
use serde::{Deserialize, Serialize};

/// `summary.json`: what was identified from what, and how well it predicts
/// the validation trajectories.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// The system's name (`linear_2d`, …).
    pub system: String,
    /// Its state variables.
    pub state_names: Vec<String>,
    /// The CSV read.
    pub data_file: String,
    /// How the identification equations were built (weak form or derivatives).
    pub data_method: String,
    /// Trajectories in the CSV.
    pub trajectories: usize,
    /// Trajectories identified from.
    pub train_trajectories: usize,
    /// Trajectories held out for validation.
    pub validation_trajectories: usize,
    /// Identifiers of the validation trajectories (their `trajectory` column).
    pub validation_trajectory_ids: Vec<String>,
    /// Samples (rows) in the CSV.
    pub samples: usize,
    /// Identification equations of the training trajectories (weak-form
    /// windows or samples).
    pub train_equations: usize,
    /// Seed of the split and the identifier.
    pub seed: u64,
    /// Iterations run, a full-batch run's warm-up on the start's subsample
    /// included (the final full-batch polish of a minibatch run is not
    /// counted).
    pub iterations: usize,
    /// Why the identification stopped (`Converged`, `Stagnated`, …).
    pub stop_reason: String,
    /// ‖prediction − target‖ / ‖target‖ on the training equations.
    pub train_relative_error: f64,
    /// The model's simulated states against the measured ones on the
    /// validation trajectories (see the module documentation); `null` if no
    /// validation trajectory could be simulated.
    pub validation_relative_error: Option<f64>,
    /// The same error of the reference model the system declares (`null`
    /// if it declares none or it cannot be simulated). On synthetic data it
    /// is the floor the measurement noise sets; on real data, how the
    /// identified model compares with the declared one.
    pub reference_validation_relative_error: Option<f64>,
    /// Validation trajectories simulated for that error.
    pub validation_simulated: usize,
    /// Validation trajectories whose simulation failed (or that have a
    /// single sample), with the reason.
    pub validation_not_simulated: Vec<String>,
    /// ‖prediction − target‖ / ‖target‖ on the validation trajectories'
    /// equations, built like the training ones; `null` if they give none
    /// (e.g. all shorter than a weak-form window).
    pub validation_equation_relative_error: Option<f64>,
    /// R² on those equations.
    pub validation_equation_r_squared: Option<f64>,
    /// Fraction of the simulated validation intervals on which the model's
    /// free energy decreased beyond the integrator's tolerance (0 for a
    /// model with K ⪰ 0).
    pub free_energy_decrease_fraction: f64,
    /// Whether the training data determine every coefficient (the
    /// identifiability report of the model on the training equations).
    pub identifiable: bool,
    /// The coefficient combinations the training data cannot determine,
    /// in words (e.g. the scale symmetry (K, E) ↦ (cK, E/c)).
    pub unidentifiable_directions: Vec<String>,
    /// What the data cannot determine, figures that could not be drawn, …
    pub warnings: Vec<String>,
    /// Wall time of the identification.
    pub seconds_identify: f64,
    /// Wall time of the whole run.
    pub seconds_total: f64,
    /// Files written into the output directory.
    pub files: Vec<String>,
}

/// What the run found and where it went, for stdout.
pub(super) fn report<S: MetriplecticSystem>(
    summary: &Summary,
    model: &Model<S>,
    out: &Path,
) -> String {
    let mut text = String::new();
    let number = |v: Option<f64>| v.map_or_else(|| "n/a".to_owned(), |v| format!("{v:.3e}"));
    let _ = writeln!(
        text,
        "{}: {} trajectories, {} samples from {}",
        summary.system, summary.trajectories, summary.samples, summary.data_file,
    );
    let _ = writeln!(
        text,
        "identified from the {} of {} trajectories ({} equations), {} held out: {} iterations ({}), {:.1} s ({:.1} s in all)",
        summary.data_method,
        summary.train_trajectories,
        summary.train_equations,
        summary.validation_trajectories,
        summary.iterations,
        summary.stop_reason,
        summary.seconds_identify,
        summary.seconds_total
    );
    let _ = writeln!(
        text,
        "validation, simulated from each held-out trajectory's first state against its measured states: relative error {} (the declared reference model: {})",
        number(summary.validation_relative_error),
        number(summary.reference_validation_relative_error),
    );
    let _ = writeln!(
        text,
        "identification equations: relative error {} on the held-out trajectories, {:.3e} on the training ones",
        number(summary.validation_equation_relative_error),
        summary.train_relative_error,
    );
    let _ = writeln!(text, "identified model:\n{model}");
    if summary.identifiable {
        let _ = writeln!(
            text,
            "identifiable: the training data determine every coefficient"
        );
    } else {
        let _ = writeln!(
            text,
            "not identifiable; the training data do not determine:"
        );
        for direction in &summary.unidentifiable_directions {
            let _ = writeln!(text, "  {direction}");
        }
    }
    for warning in &summary.warnings {
        let _ = writeln!(text, "warning: {warning}");
    }
    let _ = writeln!(text, "wrote into {}:", out.display());
    for file in &summary.files {
        let _ = writeln!(text, "  {}", out.join(file).display());
    }
    text.truncate(text.trim_end().len());
    text
}
