//! Reproduces the paper's SO(3) experiment (its Figs. 3 and 4): identify the
//! entropy and metric of a rigid body whose free energy vanishes on the unit
//! sphere of angular momenta, from trajectories of the true model.
//!
//! ```sh
//! cargo run --release --example rigid_body_so3 -- --help
//! ```
//!
//! The system is declared in `src/systems.rs` (`RigidBody`), the experiment's
//! settings in `src/experiments.rs`. Since p̂∇E = 0 the true flow is radial
//! and only the vector field is identifiable: (K = cI, S = E/c − H) fits
//! equally for every c.

use std::process::ExitCode;

use clap::Parser;
use metriplectic::reproduction::{run, Options};
use metriplectic::{experiments, systems::RigidBody};

fn main() -> ExitCode {
    let options = Options::parse();
    match run::<RigidBody>(&experiments::rigid_body_so3(), &options) {
        Ok(_) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            ExitCode::FAILURE
        }
    }
}
