//! Writes a trajectory CSV simulated from a system's reference model with
//! measurement noise: data to try the `from_csv` example on.
//!
//! ```sh
//! cargo run --release --example synthesize_csv -- --system linear_2d --out runs.csv
//! cargo run --release --example from_csv -- --data runs.csv --out fit/
//! ```
//!
//! The pipeline is `metriplectic::synthetic_csv` (src/synthetic_csv.rs).

use std::process::ExitCode;

use clap::Parser;
use metriplectic::synthetic_csv::{synthesize_csv, SynthesizeOptions};

fn main() -> ExitCode {
    let options = SynthesizeOptions::parse();
    match synthesize_csv(&options) {
        Ok(rows) => {
            println!(
                "wrote {} trajectories ({rows} samples) of {} to {}",
                options.trajectories,
                options.system.as_str(),
                options.out.display()
            );
            ExitCode::SUCCESS
        }
        Err(err) => {
            eprintln!("error: {err}");
            ExitCode::FAILURE
        }
    }
}
