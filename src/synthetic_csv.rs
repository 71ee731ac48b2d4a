//! Trajectory CSVs synthesised from the reference models of the systems this
//! package declares, as an instrument would record them: the input of the
//! `from_csv` example when there are no measurements at hand, and of its
//! timing runs. The pipeline of `examples/synthesize_csv.rs`.

use std::path::PathBuf;

use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    synthesize, write_trajectories, InitialStates, Noise, SampleTimes, SynthesisOptions,
};

use crate::experiments;
use crate::from_csv::{FromCsvError, SystemName};
use crate::systems::{Duffing, Linear2d, RigidBody};

/// Command-line options of the synthesize_csv example.
#[derive(Debug, Clone, clap::Parser)]
#[command(
    about = "Write a trajectory CSV simulated from a system's reference model, with measurement noise",
    long_about = "Write a trajectory CSV simulated from a system's reference model, with Gaussian \
noise on the states: the input the from_csv example expects. Initial states and durations are \
the paper's for linear_2d (uniform in [-1.5, 1.5]^2, 5 s) and rigid_body_so3 (ball of radius \
1.5, 5 s); duffing starts uniform in [-2, 2]^2 and runs 6 s. Samples are log-uniform in time \
(dense early, sparse late), as in the paper."
)]
pub struct SynthesizeOptions {
    /// The system whose reference model is simulated.
    #[arg(long, value_enum, value_name = "NAME")]
    pub system: SystemName,
    /// CSV file to write.
    #[arg(long, value_name = "FILE.csv")]
    pub out: PathBuf,
    /// Number of trajectories.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "N",
        default_value_t = 100
    )]
    pub trajectories: usize,
    /// Samples per trajectory (log-uniform in time).
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "N",
        default_value_t = 50
    )]
    pub samples: usize,
    /// Standard deviation of the Gaussian noise added to every state value.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "SIGMA",
        default_value_t = 0.01
    )]
    pub noise: f64,
    /// Also write the exact (noise-free) derivatives, as columns dq, dp, ...
    #[arg(long)]
    pub derivatives: bool,
    /// Seed of the initial states, sample times and noise.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "N",
        default_value_t = 1
    )]
    pub seed: u64,
    /// Replace an existing file.
    #[arg(long)]
    pub overwrite: bool,
}

/// Writes the CSV `options` describe and returns the number of rows.
pub fn synthesize_csv(options: &SynthesizeOptions) -> Result<usize, FromCsvError> {
    match options.system {
        SystemName::Linear2d => {
            let experiment = experiments::linear_2d();
            write::<Linear2d>(
                options,
                experiment.initial_states,
                experiment.duration,
                experiment.first_sample_time,
            )
        }
        SystemName::RigidBodySo3 => {
            let experiment = experiments::rigid_body_so3();
            write::<RigidBody>(
                options,
                experiment.initial_states,
                experiment.duration,
                experiment.first_sample_time,
            )
        }
        SystemName::Duffing => write::<Duffing>(options, InitialStates::cube(2, 2.0), 6.0, 1e-2),
    }
}

fn write<S: MetriplecticSystem>(
    options: &SynthesizeOptions,
    initial: InitialStates,
    duration: f64,
    first: f64,
) -> Result<usize, FromCsvError> {
    let truth = Model::<S>::reference()?;
    let data = synthesize(
        &truth,
        &SynthesisOptions {
            trajectories: options.trajectories,
            duration,
            noise: Noise {
                state_std: options.noise,
                derivative_std: 0.0,
            },
            seed: options.seed,
            ..SynthesisOptions::new(
                initial,
                SampleTimes::LogUniform {
                    count: options.samples,
                    first,
                },
            )
        },
    )?;
    let trajectories = if options.derivatives {
        // The measured (noisy) states with the exact derivatives at the
        // true states: what a sensor of both would give.
        data.measured
            .into_iter()
            .zip(&data.trajectories)
            .map(|(measured, clean)| {
                let derivatives = clean.derivatives().map(<[f64]>::to_vec).unwrap_or_default();
                measured.with_derivatives(derivatives)
            })
            .collect::<metriplectic_runtime::Result<Vec<_>>>()?
    } else {
        data.measured
    };
    let mode = if options.overwrite {
        WriteMode::Overwrite
    } else {
        WriteMode::CreateNew
    };
    write_trajectories(&options.out, &trajectories, mode)?;
    Ok(trajectories.iter().map(Trajectory::len).sum())
}
