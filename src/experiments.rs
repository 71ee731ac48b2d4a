//! The paper's two experiments as the reproductions run them: where the
//! initial states come from, how long trajectories run, the initial entropy,
//! the coefficient bound and the paper's iteration counts; and two
//! experiments beyond the paper with state-dependent metrics.

use std::f64::consts::TAU;

use metriplectic_runtime::InitialStates;

use crate::reproduction::{Experiment, ZeroSet};

/// The 2-D experiment (the paper's Figs. 1 and 2) on [`crate::systems::Linear2d`].
pub fn linear_2d() -> Experiment {
    Experiment {
        name: "linear_2d",
        // Near the corners of [−2, 2]² |ẋ| reaches 10⁴ and the flow is stiff.
        initial_states: InitialStates::cube(2, 1.5),
        duration: 5.0,
        first_sample_time: 1e-3,
        initial_entropy_std: 0.5,
        cold_start: false,
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

/// The SO(3) experiment (the paper's Figs. 3 and 4) on [`crate::systems::RigidBody`].
pub fn rigid_body_so3() -> Experiment {
    Experiment {
        name: "rigid_body_so3",
        initial_states: InitialStates::Ball {
            center: vec![0.0; 3],
            radius: 1.5,
        },
        duration: 5.0,
        first_sample_time: 1e-3,
        initial_entropy_std: 1.0,
        cold_start: false,
        eta: 20.0,
        iterations: 350,
        plot_duration: 5.0,
        zero_set: ZeroSet::Sphere(1.0),
    }
}

/// Speed-dependent drag in a double well ([`crate::systems::DragDuffing`]),
/// identified from a cold start (the library's default start).
pub fn drag_duffing() -> Experiment {
    Experiment {
        name: "drag_duffing",
        // Inside the certificate's region (radius 3); energy only falls.
        initial_states: InitialStates::cube(2, 2.0),
        duration: 5.0,
        first_sample_time: 1e-3,
        initial_entropy_std: 0.0,
        cold_start: true,
        // λmax K = 1.9 on the region.
        eta: 20.0,
        iterations: 100,
        plot_duration: 20.0,
        zero_set: ZeroSet::None,
    }
}

/// A rigid body with drag growing with |p| ([`crate::systems::DragRigidBody`]),
/// identified from a cold start (the library's default start).
pub fn drag_rigid_body() -> Experiment {
    Experiment {
        name: "drag_rigid_body",
        initial_states: InitialStates::Ball {
            center: vec![0.0; 3],
            radius: 1.5,
        },
        duration: 5.0,
        first_sample_time: 1e-3,
        initial_entropy_std: 0.0,
        cold_start: true,
        eta: 20.0,
        iterations: 100,
        plot_duration: 5.0,
        zero_set: ZeroSet::None,
    }
}
