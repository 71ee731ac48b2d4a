//! What noisy measured states (1% noise, no derivatives) determine about the
//! paper's 2-D system: the identifiability report of a dense fit, sparse
//! equations with the threshold chosen on validation trajectories,
//! bootstrap intervals over trajectories, and the entropy degree the data
//! need from a basis declared at degree 10.
//!
//! ```sh
//! cargo run --release --example what_the_data_determine -- --help
//! ```
//!
//! The pipeline is `metriplectic::what_the_data_determine`
//! (src/what_the_data_determine.rs).

use std::process::ExitCode;

use clap::Parser;
use metriplectic::what_the_data_determine::{run, Options};

fn main() -> ExitCode {
    match run(&Options::parse()) {
        Ok(_) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            ExitCode::FAILURE
        }
    }
}
