//! Identifies the entropy and metric of a metriplectic system from a
//! trajectory CSV (measured states, optionally derivatives), validates the
//! model on held-out trajectories and writes the model, its equations, a
//! summary and figures:
//!
//! ```sh
//! cargo run --release --example from_csv -- --data runs.csv --out fit/
//! cargo run --release --example from_csv -- --help
//! ```
//!
//! The pipeline is `metriplectic::from_csv` (src/from_csv/); the systems it
//! knows are declared in src/systems.rs.

use std::process::ExitCode;

use clap::Parser;
use metriplectic::from_csv::{run, Options};

fn main() -> ExitCode {
    let options = Options::parse();
    match run(&options) {
        Ok(summary) if summary.stop_reason == "Interrupted" => {
            eprintln!(
                "interrupted after {} iteration(s); the best model so far and its outputs are in {}",
                summary.iterations,
                options.out.display()
            );
            ExitCode::from(130)
        }
        Ok(_) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            ExitCode::FAILURE
        }
    }
}
