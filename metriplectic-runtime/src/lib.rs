//! # metriplectic-runtime
//!
//! Identification and simulation of *generalized metriplectic systems*
//!
//! ```text
//! ẋ = (Π(x) + K(x)) (∇H(x) + ∇S(x)),   K(x) ⪰ 0,
//! ```
//!
//! Hamiltonian systems with dissipation whose free energy E = H + S never
//! decreases (dE/dt = ∇Eᵀ K ∇E ≥ 0). The Poisson tensor Π and Hamiltonian H
//! are known; the entropy S and the metric K are identified from measured
//! samples (x, ẋ) by alternating a linear program (entropy search) and a
//! sum-of-squares semidefinite program (metric search). Both are solved by
//! the runtime's dense interior-point method by default (the L1 auxiliaries
//! eliminated, one small dense factorisation per iteration) or by Clarabel
//! ([`SolverBackend`]).
//!
//! A system is declared once with the [`metriplectic!`] macro, which checks it
//! symbolically at compile time and generates the monomial tables, analytic
//! gradients and per-sample assembly code as an implementation of
//! [`MetriplecticSystem`].
//!
//! ```
//! use metriplectic_runtime::prelude::*;
//!
//! metriplectic! {
//!     /// Canonical oscillator whose free energy has a figure-eight zero set.
//!     pub struct Oscillator;
//!     state (q, p);
//!     poisson = [[0, 1], [-1, 0]];
//!     hamiltonian = 0.5 * p^2 + 0.5 * q^2;
//!     entropy degree 8;
//!     metric degree 2;
//!     reference {
//!         entropy = -0.5 * (p^2 + 4*q^4 - 4*q^2)^2 - (0.5*p^2 + 0.5*q^2);
//!         metric = [[1, 0], [0, 1]];
//!     }
//! }
//!
//! let model = Model::<Oscillator>::reference().unwrap();
//! let mut xdot = [0.0; 2];
//! model.vector_field(&[0.3, -0.2], &mut xdot).unwrap();
//! assert!(model.free_energy_rate(&[0.3, -0.2]).unwrap() >= 0.0);
//! ```

// Link Debian's OpenBLAS for Clarabel's PSD cone (see DESIGN.md, dependency recipe).
extern crate blas_src as _;
extern crate lapack_src as _;
extern crate openblas_src as _;

// Lets the macro's `::metriplectic_runtime::…` paths resolve inside this crate's own tests.
extern crate self as metriplectic_runtime;

pub mod checkpoint;
pub mod conic;
pub mod cost;
pub mod csv_io;
pub mod dataset;
mod dense_ipm;
pub mod derivative;
pub mod diagnostics;
pub mod entropy_search;
pub mod error;
mod file_io;
pub mod identify;
pub mod joint_step;
pub mod metric_search;
pub mod model;
mod model_io;
#[cfg(feature = "plot")]
pub mod plot;
pub mod simulate;
pub mod synthesize;
pub mod system;
#[cfg(test)]
mod test_system;
pub mod trajectory;

pub use checkpoint::CheckpointConfig;
pub use conic::{L1Formulation, SolveReport, SolveStatus, SolverBackend, SolverSettings};
pub use cost::{model_cost, Cost};
pub use csv_io::{read_trajectories, write_trajectories, CsvError, WriteMode};
pub use dataset::{Dataset, DatasetError};
pub use derivative::{estimate_derivatives, DerivativeMethod};
pub use diagnostics::{free_energy_diagnostics, FreeEnergyReport};
pub use entropy_search::{entropy_search, EntropySearch, EntropySearchOptions};
pub use error::{Error, Result};
pub use identify::{
    identify, identify_resume, identify_resume_with_observer, identify_with_observer, History,
    Identification, IdentifyConfig, IterationRecord, IterationScheme, JointStepRecord, StepOutcome,
    StepRecord, StopReason,
};
pub use joint_step::{joint_step, JointStep, TrustRegion};
pub use metric_search::{metric_search, MetricSearch, MetricSearchOptions, SosBasis};
pub use metriplectic_macros::metriplectic;
pub use model::Model;
pub use simulate::{simulate, OutputTimes, Simulation, SimulationError, SimulationOptions};
pub use synthesize::{synthesize, SynthesisOptions, SyntheticData};
pub use system::{MetriplecticSystem, SosTables};
pub use trajectory::Trajectory;

/// The names most programs need: `use metriplectic_runtime::prelude::*;`.
pub mod prelude {
    pub use crate::dataset::Dataset;
    pub use crate::error::{Error, Result};
    pub use crate::metriplectic;
    pub use crate::model::Model;
    pub use crate::system::MetriplecticSystem;
}
