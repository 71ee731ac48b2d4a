//! A rigid body in the classical (GENERIC) form: identified from a cold
//! start under its constraints (S a Casimir of Π, K∇H ≡ 0), then simulated
//! with the discrete-gradient integrator (H conserved to rounding, S never
//! decreasing) beside DOPRI5.
//!
//! ```sh
//! cargo run --release --example classical -- --help
//! ```
//!
//! The pipeline is `metriplectic::classical` (src/classical.rs).

use std::process::ExitCode;

use clap::Parser;
use metriplectic::classical::{run, Options};

fn main() -> ExitCode {
    match run(&Options::parse()) {
        Ok(_) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            ExitCode::FAILURE
        }
    }
}
