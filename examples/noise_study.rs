//! How identification from measured states degrades with state noise: the
//! weak form against derivative estimates, on the paper's 2-D and SO(3)
//! data (100 training and 20 held-out trajectories of 50 log-uniform
//! samples), every run from the default (fitted) start with the
//! default configuration.
//!
//! ```sh
//! cargo run --release --example noise_study -- --noise 0.01
//! ```
//!
//! Noise is Gaussian with σ = noise · RMS of the clean states (per run, all
//! components alike); the error is ‖f_fit − f_true‖ / ‖f_true‖ over the
//! held-out trajectories' clean states. The reference rows use the exact ẋ,
//! clean or with the same relative noise σ = noise · RMS(ẋ), on clean
//! states: what the same identification reaches when derivatives are
//! measured.

use std::process::ExitCode;
use std::time::Instant;

use clap::Parser;
use metriplectic::experiments;
use metriplectic::reproduction::Experiment;
use metriplectic::systems::{Linear2d, RigidBody};
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    synthesize, IdentificationData, Noise, SampleTimes, SynthesisOptions, SyntheticData,
};

/// Command-line options.
#[derive(Debug, Parser)]
#[command(about = "Weak form vs derivative estimates under state noise, on the paper's data")]
struct Options {
    /// Relative state noise σ / RMS(x) (0 for clean data).
    #[arg(long, default_value_t = 0.01)]
    noise: f64,
    /// Seed of the data and the noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Training trajectories.
    #[arg(long, default_value_t = 100)]
    train_trajectories: usize,
    /// Samples per trajectory (log-uniform in time, as in the paper).
    #[arg(long, default_value_t = 50)]
    samples_per_trajectory: usize,
    /// Only this system (`linear_2d` or `rigid_body_so3`); default: both.
    #[arg(long, value_parser = ["linear_2d", "rigid_body_so3"])]
    system: Option<String>,
    /// Only the rows whose label contains this text (e.g. `weak`).
    #[arg(long)]
    only: Option<String>,
}

/// The rows' labels, in the order they are printed (what `--only` matches).
const ROW_LABELS: [&str; 10] = [
    "exact ẋ, clean states",
    "exact ẋ + same relative noise on ẋ",
    "exact ẋ at the noisy states",
    "finite differences, order 2",
    "finite differences, order 4",
    "Savitzky–Golay, 7 samples, degree 2",
    "Savitzky–Golay, 11 samples, degree 3",
    "cubic smoothing spline, λ by GCV",
    "weak form (default)",
    "weak form, cubic local polynomials",
];

/// One row of the table.
struct Row {
    method: String,
    error: Result<f64>,
    iterations: usize,
    seconds: f64,
}

fn main() -> ExitCode {
    let options = Options::parse();
    if let Some(only) = &options.only {
        if !ROW_LABELS.iter().any(|label| label.contains(only.as_str())) {
            eprintln!(
                "error: --only {only:?} matches no row; the rows are:\n  {}",
                ROW_LABELS.join("\n  ")
            );
            return ExitCode::FAILURE;
        }
    }
    let mut ok = true;
    for (name, run) in [
        (
            "linear_2d",
            study::<Linear2d> as fn(&Experiment, &Options) -> Result<Vec<Row>>,
        ),
        ("rigid_body_so3", study::<RigidBody>),
    ] {
        if options.system.as_deref().is_some_and(|s| s != name) {
            continue;
        }
        let experiment = match name {
            "linear_2d" => experiments::linear_2d(),
            _ => experiments::rigid_body_so3(),
        };
        println!("\n{name}, state noise {} × RMS\n", options.noise);
        println!("| data | held-out error | iterations | seconds |");
        println!("| --- | --- | --- | --- |");
        match run(&experiment, &options) {
            Ok(rows) => {
                for row in rows {
                    let error = match row.error {
                        Ok(e) => format!("{e:.2e}"),
                        Err(err) => format!("failed: {err}"),
                    };
                    println!(
                        "| {} | {error} | {} | {:.1} |",
                        row.method, row.iterations, row.seconds
                    );
                }
            }
            Err(err) => {
                eprintln!("error: {err}");
                ok = false;
            }
        }
    }
    if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

fn study<S: MetriplecticSystem>(experiment: &Experiment, options: &Options) -> Result<Vec<Row>> {
    let truth = Model::<S>::reference()?;
    let synthesis = |noise: Noise| SynthesisOptions {
        trajectories: options.train_trajectories.saturating_add(20),
        held_out_trajectories: 20,
        duration: experiment.duration,
        seed: options.seed,
        noise,
        ..SynthesisOptions::new(
            experiment.initial_states.clone(),
            SampleTimes::LogUniform {
                count: options.samples_per_trajectory,
                first: experiment.first_sample_time,
            },
        )
    };
    let clean = synthesize(&truth, &synthesis(Noise::default()))?;
    let held_out = clean
        .held_out
        .clone()
        .ok_or_else(|| Error::InvalidArgument {
            what: "held-out trajectories".into(),
            reason: "none".into(),
        })?;
    let rms =
        |values: &[f64]| (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt();
    let state_std = options.noise * rms(clean.train.states());
    let derivative_std = options.noise * rms(clean.train.derivatives());
    let noisy_states = synthesize(
        &truth,
        &synthesis(Noise {
            state_std,
            derivative_std: 0.0,
        }),
    )?;
    let noisy_derivatives = synthesize(
        &truth,
        &synthesis(Noise {
            state_std: 0.0,
            derivative_std,
        }),
    )?;
    let training = |data: &SyntheticData| data.measured[..data.train_trajectories].to_vec();

    let measured = training(&noisy_states);
    let wanted = |label: &str| {
        debug_assert!(ROW_LABELS.contains(&label), "{label} is not in ROW_LABELS");
        options
            .only
            .as_ref()
            .is_none_or(|only| label.contains(only.as_str()))
    };
    let mut rows = Vec::new();
    for (label, data) in [
        ("exact ẋ, clean states", &clean.train),
        (
            "exact ẋ + same relative noise on ẋ",
            &noisy_derivatives.train,
        ),
        ("exact ẋ at the noisy states", &noisy_states.train),
    ] {
        if wanted(label) {
            rows.push(fit::<S>(label, data, &truth, &held_out));
        }
    }
    for (label, method) in [
        (
            "finite differences, order 2",
            DerivativeMethod::FiniteDifference { order: 2 },
        ),
        (
            "finite differences, order 4",
            DerivativeMethod::FiniteDifference { order: 4 },
        ),
        (
            "Savitzky–Golay, 7 samples, degree 2",
            DerivativeMethod::SavitzkyGolay {
                window: 7,
                degree: 2,
            },
        ),
        (
            "Savitzky–Golay, 11 samples, degree 3",
            DerivativeMethod::SavitzkyGolay {
                window: 11,
                degree: 3,
            },
        ),
        (
            "cubic smoothing spline, λ by GCV",
            DerivativeMethod::smoothing_spline(),
        ),
    ] {
        if wanted(label) {
            rows.push(match Dataset::from_trajectories(&measured, Some(&method)) {
                Ok(data) => fit::<S>(label, &data, &truth, &held_out),
                Err(err) => failed(label, err),
            });
        }
    }
    for (label, form) in [
        ("weak form (default)", WeakForm::default()),
        (
            "weak form, cubic local polynomials",
            WeakForm {
                local_degree: 3,
                ..WeakForm::default()
            },
        ),
    ] {
        if wanted(label) {
            rows.push(match WeakDataset::from_trajectories(&measured, &form) {
                Ok(data) => fit::<S>(label, &data, &truth, &held_out),
                Err(err) => failed(label, err),
            });
        }
    }
    Ok(rows)
}

/// A row for a method that could not build its data.
fn failed(label: &str, err: Error) -> Row {
    Row {
        method: label.into(),
        error: Err(err),
        iterations: 0,
        seconds: 0.0,
    }
}

fn fit<S: MetriplecticSystem>(
    label: &str,
    data: &impl IdentificationData,
    truth: &Model<S>,
    held_out: &Dataset,
) -> Row {
    let started = Instant::now();
    let result = identify::<S>(data, &IdentifyConfig::default());
    let seconds = started.elapsed().as_secs_f64();
    match result {
        Ok(fit) => Row {
            method: label.into(),
            error: fit.model.compare(truth, held_out).map(|s| s.relative_error),
            iterations: fit.history.iterations.len(),
            seconds,
        },
        Err(err) => Row {
            seconds,
            ..failed(label, err)
        },
    }
}
