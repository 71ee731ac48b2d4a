//! What noisy measured data determine about the paper's 2-D system: a dense
//! fit, its identifiability report, the sparse equations chosen on
//! validation trajectories, bootstrap intervals over trajectories, and the
//! degrees the data need from a basis declared larger than the truth.
//!
//! The pipeline of `examples/what_the_data_determine.rs`; the suite runs it
//! too, so the example and the tests run exactly the same code.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    bootstrap, identifiability, select_degrees, sparsify, synthesize, BootstrapOptions,
    DegreeOptions, IdentifiabilityOptions, Noise, SampleTimes, SparseOptions, SynthesisOptions,
};
use serde::{Deserialize, Serialize};

use crate::experiments;
use crate::reproduction::polynomial_to_string;
use crate::summary_file;
use crate::systems::{Linear2d, Linear2dDegree10};

/// Command-line options.
#[derive(Debug, Clone, clap::Parser)]
#[command(about = "What noisy measured states determine about the paper's 2-D system")]
pub struct Options {
    /// State noise, as a fraction of the states' RMS.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.01)]
    pub noise: f64,
    /// Seed of the data and the resampling.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Training trajectories (also the bootstrap's resampling units).
    #[arg(long, default_value_t = 100)]
    pub train_trajectories: usize,
    /// Validation trajectories: they choose the sparse threshold and the degrees.
    #[arg(long, default_value_t = 20)]
    pub validation_trajectories: usize,
    /// Held-out trajectories: they score the models against the truth.
    #[arg(long, default_value_t = 20)]
    pub heldout_trajectories: usize,
    /// Bootstrap replicates.
    #[arg(long, default_value_t = 40)]
    pub replicates: usize,
    /// Output directory for `summary.json`.
    #[arg(long, default_value = "target/what_the_data_determine")]
    pub out: PathBuf,
    /// Overwrite an existing `summary.json`.
    #[arg(long)]
    pub force: bool,
    /// No report on stdout.
    #[arg(long)]
    pub quiet: bool,
}

/// `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// State noise as a fraction of the states' RMS.
    pub noise: f64,
    /// Whether the data determine every coefficient of the dense fit.
    pub identifiable: bool,
    /// The smallest relative singular value of the dense fit's Jacobian.
    pub smallest_singular_value: f64,
    /// The dense fit's misfit: relative singular values up to it count as
    /// undetermined ([`Identifiability::misfit`](metriplectic_runtime::Identifiability::misfit)).
    pub misfit: f64,
    /// The combinations the data cannot determine (descriptions).
    pub unidentifiable_directions: Vec<String>,
    /// Entropy terms of the dense fit with |ψ| above 1e-3 of the largest.
    pub dense_terms: usize,
    /// Entropy terms of the sparse model.
    pub sparse_terms: usize,
    /// Whether the sparse support is exactly the true one.
    pub sparse_support_is_true: bool,
    /// ‖f_fit − f_true‖/‖f_true‖ on the held-out states, dense fit.
    pub heldout_relative_error_dense: f64,
    /// The same for the sparse model.
    pub heldout_relative_error: f64,
    /// Bootstrap replicates that succeeded.
    pub bootstrap_replicates: usize,
    /// Interval coverage.
    pub bootstrap_level: f64,
    /// True (non-zero) coefficients inside their bootstrap interval.
    pub true_coefficients_covered: usize,
    /// True coefficients in all.
    pub true_coefficients: usize,
    /// Width of the vector field's band at (0.5, 0.5), relative to |f|.
    pub field_band_relative_width: f64,
    /// The entropy degree chosen on validation data (declared 10, true 8).
    pub selected_entropy_degree: u32,
    /// Wall time of the whole study.
    pub seconds_total: f64,
}

/// Runs the study and writes `summary.json` to `options.out`.
pub fn run(options: &Options) -> Result<Summary> {
    let started = Instant::now();
    let summary_path = options.out.join("summary.json");
    summary_file::check_writable(&summary_path, options.force)?;
    let truth = Model::<Linear2d>::reference()?;
    let data = measured_data(options)?;
    let config = IdentifyConfig::default();
    let mut report = String::new();

    // The dense fit and what its data determine.
    let dense = identify::<Linear2d>(&data.train, &config)?.model;
    let identifiable = identifiability(&dense, &data.train, &IdentifiabilityOptions::default())?;
    let dense_error = dense.compare(&truth, &data.held_out)?.relative_error;
    let largest = dense
        .entropy_coefficients()
        .iter()
        .fold(0.0_f64, |m, c| m.max(c.abs()));
    let dense_terms = dense
        .entropy_coefficients()
        .iter()
        .filter(|c| c.abs() > 1e-3 * largest)
        .count();
    let _ = writeln!(report, "dense fit: {dense_terms} entropy terms above 1e-3 of the largest, held-out error {dense_error:.3e}");
    let _ = writeln!(report, "{}", identifiable.to_string().trim_end());

    // Sparse equations, the threshold chosen on the validation trajectories.
    let sparse = sparsify(
        &dense,
        &data.train,
        &data.validation,
        &config,
        &SparseOptions::default(),
    )?;
    let sparse_error = sparse.model.compare(&truth, &data.held_out)?.relative_error;
    let true_terms: Vec<usize> = truth
        .entropy_coefficients()
        .iter()
        .enumerate()
        .filter(|(_, c)| **c != 0.0)
        .map(|(k, _)| k)
        .collect();
    let kept = sparse.support.free_entropy::<Linear2d>();
    let names = Linear2d::STATE_NAMES;
    let _ = writeln!(
        report,
        "sparse fit: {} terms (threshold {:?}), held-out error {sparse_error:.3e}\n  S = {}",
        kept.len(),
        sparse.candidates[sparse.chosen].threshold,
        polynomial_to_string(
            names,
            Linear2d::ENTROPY_EXPONENTS,
            sparse.model.entropy_coefficients(),
            f64::MIN_POSITIVE
        )
    );

    // Bootstrap over the training trajectories, on the sparse support.
    let groups = data
        .train_trajectories
        .iter()
        .map(|t| WeakDataset::from_trajectories(std::slice::from_ref(t), &WeakForm::default()))
        .collect::<Result<Vec<_>>>()?;
    let bootstrap_config = IdentifyConfig {
        initial_entropy: Some(sparse.model.entropy_coefficients().to_vec()),
        initial_metric: Some(sparse.model.metric_coefficients().to_vec()),
        search: metriplectic_runtime::SearchOptions {
            support: sparse.support.clone(),
            ..config.search.clone()
        },
        ..config.clone()
    };
    let ensemble = bootstrap::<Linear2d, _>(
        &groups,
        &bootstrap_config,
        &BootstrapOptions {
            replicates: options.replicates,
            seed: options.seed,
            ..BootstrapOptions::default()
        },
    )?;
    let covered = true_terms
        .iter()
        .filter(|&&k| ensemble.entropy[k].contains(truth.entropy_coefficients()[k]))
        .count();
    let point = [0.5, 0.5];
    let band = ensemble.field_band(&point)?;
    let mut field = [0.0; 2];
    truth.vector_field(&point, &mut field)?;
    let width = band
        .iter()
        .map(|i| (i.upper - i.lower).powi(2))
        .sum::<f64>()
        .sqrt()
        / field.iter().map(|f| f * f).sum::<f64>().sqrt();
    let _ = writeln!(
        report,
        "bootstrap: {} replicates, {covered} of {} true coefficients inside their {:.0}% intervals; field band at (0.5, 0.5) {:.2e} of |f|",
        ensemble.replicates.len(),
        true_terms.len(),
        100.0 * ensemble.level,
        width
    );
    for &k in &true_terms {
        let i = ensemble.entropy[k];
        let _ = writeln!(
            report,
            "  {:>8}: true {:>8.4}, interval [{:.4}, {:.4}]",
            monomial(names, Linear2d::ENTROPY_EXPONENTS[k]),
            truth.entropy_coefficients()[k],
            i.lower,
            i.upper
        );
    }

    // Degree selection from a basis declared at degree 10.
    let degrees = select_degrees::<Linear2dDegree10, _>(
        &data.train,
        &data.validation,
        &config,
        &DegreeOptions {
            entropy: Some((4..=10).collect()),
            ..DegreeOptions::default()
        },
    )?;
    let selected = degrees.candidates[degrees.chosen].entropy_degree;
    let _ = writeln!(
        report,
        "degree selection (declared 10, true 8): chose {selected}"
    );
    for candidate in &degrees.candidates {
        let _ = writeln!(
            report,
            "  degree {:>2}: {:>3} coefficients, validation cost {:.4e}",
            candidate.entropy_degree, candidate.coefficients, candidate.validation.per_component
        );
    }

    let summary = Summary {
        noise: options.noise,
        identifiable: identifiable.is_identifiable(),
        smallest_singular_value: identifiable.singular_values.last().copied().unwrap_or(0.0),
        misfit: identifiable.misfit,
        unidentifiable_directions: identifiable
            .flat_directions
            .iter()
            .map(|d| d.description.clone())
            .collect(),
        dense_terms,
        sparse_terms: kept.len(),
        sparse_support_is_true: kept == true_terms,
        heldout_relative_error_dense: dense_error,
        heldout_relative_error: sparse_error,
        bootstrap_replicates: ensemble.replicates.len(),
        bootstrap_level: ensemble.level,
        true_coefficients_covered: covered,
        true_coefficients: true_terms.len(),
        field_band_relative_width: width,
        selected_entropy_degree: selected,
        seconds_total: started.elapsed().as_secs_f64(),
    };
    summary_file::write(&summary_path, &summary)?;
    if !options.quiet {
        println!(
            "{report}wrote {} ({:.1} s)",
            summary_path.display(),
            summary.seconds_total
        );
    }
    Ok(summary)
}

/// x^α written with the state names, e.g. `q^4 p^2`.
fn monomial(names: &[&str], exponents: &[u32]) -> String {
    let factors: Vec<String> = names
        .iter()
        .zip(exponents)
        .filter(|(_, &e)| e > 0)
        .map(|(name, &e)| {
            if e == 1 {
                (*name).to_owned()
            } else {
                format!("{name}^{e}")
            }
        })
        .collect();
    factors.join(" ")
}

/// The weak-form training, validation and per-trajectory data, and clean
/// held-out states.
struct MeasuredData {
    train: WeakDataset,
    train_trajectories: Vec<Trajectory>,
    validation: WeakDataset,
    held_out: Dataset,
}

fn measured_data(options: &Options) -> Result<MeasuredData> {
    if !(options.noise.is_finite() && options.noise >= 0.0) {
        return Err(Error::InvalidArgument {
            what: "--noise".into(),
            reason: format!(
                "{}: the noise is a non-negative fraction of the states' RMS",
                options.noise
            ),
        });
    }
    for (option, count) in [
        ("--train-trajectories", options.train_trajectories),
        ("--validation-trajectories", options.validation_trajectories),
        ("--heldout-trajectories", options.heldout_trajectories),
    ] {
        if count == 0 {
            return Err(Error::InvalidArgument {
                what: option.into(),
                reason: "0 trajectories: at least one is needed".into(),
            });
        }
    }
    let experiment = experiments::linear_2d();
    let truth = Model::<Linear2d>::reference()?;
    let total = options
        .train_trajectories
        .checked_add(options.validation_trajectories)
        .and_then(|sum| sum.checked_add(options.heldout_trajectories))
        .ok_or_else(|| Error::InvalidArgument {
            what: "trajectory counts".to_owned(),
            reason: "--train-trajectories, --validation-trajectories and --heldout-trajectories \
                     add up beyond usize"
                .to_owned(),
        })?;
    let synthesis = |state_std| SynthesisOptions {
        trajectories: total,
        held_out_trajectories: options.heldout_trajectories,
        duration: experiment.duration,
        seed: options.seed,
        noise: Noise {
            state_std,
            derivative_std: 0.0,
        },
        ..SynthesisOptions::new(
            experiment.initial_states.clone(),
            SampleTimes::LogUniform {
                count: 50,
                first: experiment.first_sample_time,
            },
        )
    };
    let clean = synthesize(&truth, &synthesis(0.0))?;
    let states = clean.train.states();
    let rms = (states.iter().map(|v| v * v).sum::<f64>() / states.len() as f64).sqrt();
    let noisy = synthesize(&truth, &synthesis(options.noise * rms))?;
    let form = WeakForm::default();
    let train_trajectories = noisy.measured[..options.train_trajectories].to_vec();
    let validation = WeakDataset::from_trajectories(
        &noisy.measured[options.train_trajectories..noisy.train_trajectories],
        &form,
    )?;
    let held_out = clean.held_out.ok_or_else(|| Error::InvalidArgument {
        what: "held-out trajectories".into(),
        reason: "at least one is required".into(),
    })?;
    Ok(MeasuredData {
        train: WeakDataset::from_trajectories(&train_trajectories, &form)?,
        train_trajectories,
        validation,
        held_out,
    })
}
