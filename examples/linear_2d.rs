//! Reproduces the paper's 2-D experiment (its Figs. 1 and 2): identify the
//! entropy and metric of a canonical oscillator whose free energy has a
//! figure-eight zero set, from trajectories of the true model.
//!
//! ```sh
//! cargo run --release --example linear_2d -- --help
//! ```
//!
//! The system is declared in `src/systems.rs` (`Linear2d`), the experiment's
//! settings in `src/experiments.rs`.

use std::process::ExitCode;

use clap::Parser;
use metriplectic::reproduction::{run, Options};
use metriplectic::{experiments, systems::Linear2d};

fn main() -> ExitCode {
    let options = Options::parse();
    match run::<Linear2d>(&experiments::linear_2d(), &options) {
        Ok(_) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            ExitCode::FAILURE
        }
    }
}
