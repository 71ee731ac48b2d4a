//! Identifies two systems whose metric varies with the state, beyond the
//! paper: a double well with drag growing with speed (2-D) and a rigid body
//! with drag growing with its angular momentum (3-D). Both declare a region
//! (`region ball(…)`), so the metric search certifies K(x) ⪰ 0 for every
//! state and K(x) ⪯ ηI on the region, and both start cold, from the
//! library's default start (nothing of the truth is used).
//!
//! ```sh
//! cargo run --release --example speed_dependent_drag -- --help
//! cargo run --release --example speed_dependent_drag -- --system rigid-body
//! ```
//!
//! The systems are declared in `src/systems.rs` (`DragDuffing`,
//! `DragRigidBody`), the experiments' settings in `src/experiments.rs`.
//! Besides the reproductions' outputs, `summary.json` reports
//! `heldout_metric_error` (max ‖K_fit(x) − K(x)‖/‖K(x)‖ over held-out
//! states) and `metric_variation` (how much the true K varies there).

use std::process::ExitCode;

use clap::Parser;
use metriplectic::experiments;
use metriplectic::reproduction::{run, Options};
use metriplectic::systems::{DragDuffing, DragRigidBody};

/// Which of the two systems to identify.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum System {
    /// The double well with K(x) = diag(0, 0.1 + 0.2v²).
    Duffing,
    /// The rigid body with K(x) = (0.1 + 0.2|p|²) I.
    RigidBody,
}

#[derive(Debug, Parser)]
#[command(about = "Identify systems with speed-dependent drag (state-dependent metrics)")]
struct Arguments {
    /// The system to identify.
    #[arg(long, value_enum, default_value_t = System::Duffing)]
    system: System,
    #[command(flatten)]
    options: Options,
}

fn main() -> ExitCode {
    let Arguments { system, options } = Arguments::parse();
    let result = match system {
        System::Duffing => run::<DragDuffing>(&experiments::drag_duffing(), &options).map(drop),
        System::RigidBody => {
            run::<DragRigidBody>(&experiments::drag_rigid_body(), &options).map(drop)
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            ExitCode::FAILURE
        }
    }
}
