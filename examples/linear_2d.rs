//! Reproduces the paper's 2-D experiment (its Figs. 1 and 2): identify the
//! entropy and metric of a canonical oscillator whose free energy has a
//! figure-eight zero set, from trajectories of the true model.
//!
//! ```sh
//! cargo run --release --example linear_2d -- --help
//! ```
//!
//! The paper prints the free energy as −½(p² + 4p⁴ − 4q⁴)²; that is a typo.
//! The authors' code (and their figure) use E = −½(p² + 4q⁴ − 4q²)², whose
//! zero set is the figure eight (q, p) = (cos t, sin 2t). S = E − H.

use std::f64::consts::TAU;
use std::process::ExitCode;

use clap::Parser;
use metriplectic::reproduction::{run, Experiment, Options, ZeroSet};
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::synthesize::InitialStates;

metriplectic! {
    /// Canonical oscillator whose free energy has a figure-eight zero set.
    pub struct Oscillator;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 8;
    metric degree 2;
    reference {
        entropy = -0.5 * (p^2 + 4*q^4 - 4*q^2)^2 - (0.5*p^2 + 0.5*q^2);
        metric = [[1, 0], [0, 1]];
    }
}

/// The experiment as the paper runs it (see DESIGN.md §3 for the settings).
pub fn experiment() -> Experiment {
    Experiment {
        name: "linear_2d",
        // Near the corners of [−2, 2]² |ẋ| reaches 10⁴ and the flow is stiff.
        initial_states: InitialStates::cube(2, 1.5),
        duration: 5.0,
        first_sample_time: 1e-3,
        initial_entropy_std: 0.5,
        // The largest true coefficient is 16 (q⁶); η must exceed it.
        eta: 20.0,
        iterations: 700,
        plot_duration: 5.0,
        zero_set: ZeroSet::Curve(
            (0..=400)
                .map(|k| {
                    let t = TAU * k as f64 / 400.0;
                    (t.cos(), (2.0 * t).sin())
                })
                .collect(),
        ),
    }
}

fn main() -> ExitCode {
    let options = Options::parse();
    match run::<Oscillator>(&experiment(), &options) {
        Ok(_) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            ExitCode::FAILURE
        }
    }
}
