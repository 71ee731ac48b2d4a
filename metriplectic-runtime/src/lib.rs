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
//! sum-of-squares semidefinite program (metric search). Both run on the
//! runtime's own dense interior-point method (the L1 auxiliaries eliminated,
//! one small dense factorisation per iteration); Clarabel is available as a
//! second backend with the cargo feature `clarabel`.
//!
//! A system is declared once with the [`metriplectic!`] macro, which checks it
//! symbolically at compile time and generates the monomial tables and
//! analytic gradients as an implementation of [`MetriplecticSystem`].
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
//!
//! # The public API
//!
//! Everything is exported at the crate root; [`prelude`] holds what most
//! programs need. By layer:
//!
//! | layer | items |
//! | --- | --- |
//! | system | [`metriplectic!`], [`MetriplecticSystem`], [`SosTables`], [`JacobianTerm`]; a region certificate: [`RegionCertificate`], [`Region`], [`CertificateMode`], [`GramBlock`]; the classical form: [`Classical`] |
//! | model | [`Model`] (evaluation, JSON files), [`WriteMode`]; its metric's proof: [`GramCertificate`], [`GramMatrix`], [`CertificateCheck`] |
//! | data | [`Dataset`], [`WeakDataset`] (the weak form: states only), [`IdentificationData`], [`Trajectory`], [`read_trajectories`], [`write_trajectories`] (CSV), [`DerivativeMethod`], [`estimate_derivatives`], [`fit_smoothing_spline`] |
//! | identify | [`identify`] and its variants, [`IdentifyConfig`], [`IterationScheme`], [`TrustRegion`], [`CheckpointConfig`], [`Identification`], [`History`], [`StopReason`], [`Cost`], [`model_cost`] |
//! | analysis | [`identifiability`] (flat directions, the scale symmetry), [`Gauge`], [`Support`] (degree caps), [`select_degrees`], [`sparsify`], [`bootstrap`] |
//! | searches | [`entropy_search`], [`metric_search`], [`joint_step`] with [`SearchOptions`] and [`SearchReport`] |
//! | solve | [`L1Problem`], [`Regression`], [`Cone`], [`solve_l1`], [`L1Solution`], [`SolverSettings`], [`SolverBackend`], [`SolveStatus`] |
//! | simulate | [`simulate`] with DOPRI5 or the structure-preserving discrete gradient ([`Method`]), [`integrate`], [`synthesize`], [`free_energy_diagnostics`] and their options |
//! | plot (feature `plot`) | `phase_portrait_2d`, `trajectories_3d`, `loss_curves`, `free_energy_curves`, `trajectory_overlay`, `log_axis_ticks`, `integer_axis_ticks` |
//! | errors | [`Error`], [`Result`] and the per-layer error enums |
//!
//! # Cargo features
//!
//! * `plot` (off): PNG/SVG figures of trajectories, losses and free energy.
//! * `clarabel` (off): Clarabel as [`SolverBackend::Clarabel`]. It links
//!   BLAS/LAPACK (Debian's OpenBLAS, `libopenblas-dev`) for Clarabel's PSD
//!   cone; without it the crate needs no system library.

#![cfg_attr(docsrs, feature(doc_cfg))]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used))]

// Link Debian's OpenBLAS for Clarabel's PSD cone (feature `clarabel`).
#[cfg(feature = "clarabel")]
extern crate blas_src as _;
#[cfg(feature = "clarabel")]
extern crate lapack_src as _;
#[cfg(feature = "clarabel")]
extern crate openblas_src as _;

// Lets the macro's `::metriplectic_runtime::…` paths resolve inside this crate's own tests.
extern crate self as metriplectic_runtime;

mod analysis;
mod data;
mod error;
mod identify;
mod io;
mod model;
#[cfg(feature = "plot")]
mod plot;
mod simulate;
mod solve;
mod system;
#[cfg(test)]
mod test_system;

pub use analysis::{
    bootstrap, identifiability, select_degrees, sparsify, Bootstrap, BootstrapOptions,
    DegreeCandidate, DegreeOptions, DegreeSelection, FlatDirection, FlatKind, Identifiability,
    IdentifiabilityOptions, Interval, SparseCandidate, SparseOptions, Sparsification,
};
pub use data::split_by_trajectory;
pub use data::{
    dataset_from_trajectories, differentiate, estimate_all, estimate_derivatives,
    fit_smoothing_spline, read_trajectories, read_trajectories_from, write_trajectories,
    write_trajectories_to, Dataset, DerivativeMethod, IdentificationData, SmoothingSplineFit,
    Trajectory, WeakDataset, WeakForm, MAX_CSV_BYTES,
};
#[cfg(feature = "plot")]
pub use error::PlotError;
pub use error::{CsvError, DatasetError, Error, Result, SimulationError};
pub use identify::{
    entropy_search, identify, identify_resume, identify_resume_with_observer,
    identify_with_observer, joint_step, metric_search, model_cost, CheckpointConfig,
    CoefficientBlock, Cost, EntropySearch, Gauge, History, Identification, IdentifyConfig,
    IdentifyWarning, IterationRecord, IterationScheme, JointStep, JointStepRecord, MetricSearch,
    SearchOptions, SearchReport, SosBasis, Stagnation, StepOutcome, StepRecord, StopReason,
    Subproblem, Support, TrustRegion, Validation,
};
pub use io::{write_file, WriteMode};
pub use metriplectic_macros::metriplectic;
pub use model::{CertificateCheck, GramCertificate, GramMatrix, Model, Score};
#[cfg(feature = "plot")]
#[cfg_attr(docsrs, doc(cfg(feature = "plot")))]
pub use plot::{
    free_energy_curves, integer_axis_ticks, log_axis_ticks, loss_curves, phase_portrait_2d,
    trajectories_3d, trajectory_overlay, AxisTick, Labels,
};
pub use simulate::{
    free_energy_diagnostics, integrate, simulate, simulate_many, synthesize, EnergyCheck,
    FreeEnergyReport, InitialStates, Integration, IntegrationStats, IntegratorOptions, Method,
    Noise, Outliers, OutputTimes, OutsideRegion, SampleTimes, Simulation, SimulationOptions,
    SynthesisOptions, SyntheticData,
};
#[cfg(feature = "clarabel")]
pub use solve::L1Formulation;
pub use solve::{
    solve_l1, Cone, ConstraintId, L1Problem, L1Solution, Regression, SolveStatus, SolverBackend,
    SolverSettings,
};
pub use system::{
    CertificateMode, Classical, GramBlock, JacobianTerm, LinearForm, MetriplecticSystem,
    PolynomialTerms, Region, RegionCertificate, SosTables,
};

/// The names most programs need: `use metriplectic_runtime::prelude::*;`.
///
/// It covers the workflow from measured trajectories to a trusted model:
/// declare the system, read trajectories, split them, build identification
/// data (with derivatives or in the weak form), identify, score, print and
/// simulate.
pub mod prelude {
    pub use crate::{
        identify, metriplectic, read_trajectories, simulate, simulate_many, split_by_trajectory,
        Dataset, DerivativeMethod, Error, IdentificationData, IdentifyConfig, MetriplecticSystem,
        Model, Result, Score, SimulationOptions, Trajectory, WeakDataset, WeakForm, WriteMode,
    };
}

/// What code generated by `metriplectic!` needs beyond the public API. Not
/// part of the API: it may change in any release.
#[doc(hidden)]
pub mod __private {
    /// Collects the monomials of a system degree by degree into a prefix of
    /// the graded-lex sequence (see `MetriplecticSystem::monomials`).
    pub struct MonomialSink<'a> {
        out: &'a mut [f64],
        filled: usize,
    }

    impl<'a> MonomialSink<'a> {
        /// A sink writing into `out`, which it fills from the start.
        pub fn new(out: &'a mut [f64]) -> Self {
            Self { out, filled: 0 }
        }

        /// Appends the monomials of the next degree, as many as fit; `true`
        /// once `out` is full, so the caller can stop computing.
        #[inline(always)]
        pub fn push(&mut self, values: &[f64]) -> bool {
            let take = values.len().min(self.out.len() - self.filled);
            self.out[self.filled..self.filled + take].copy_from_slice(&values[..take]);
            self.filled += take;
            self.filled == self.out.len()
        }
    }
}
