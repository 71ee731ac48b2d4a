//! Paper reproductions for the `metriplectic` toolkit, and what the
//! examples, the end-to-end tests and the benchmarks share.
//!
//! The toolkit itself is [`metriplectic_runtime`] (which re-exports the
//! `metriplectic!` macro). This package holds the paper's systems, declared
//! once ([`systems`]), its experiments ([`experiments`]), and the pipeline the
//! reproductions in `examples/` run ([`reproduction`], [`figures`]), so that
//! the examples and the tests in `tests/` run the same code. [`from_csv`] is
//! the pipeline of the `from_csv` example: identification from a user's
//! trajectory CSV; [`synthetic_csv`] writes such CSVs from the reference
//! models (the `synthesize_csv` example). [`classical`] identifies and
//! simulates a system in the classical (GENERIC) form (the `classical`
//! example).

pub mod classical;
pub mod experiments;
pub mod figures;
pub mod from_csv;
pub mod reproduction;
mod summary_file;
pub mod synthetic_csv;
pub mod systems;
pub mod what_the_data_determine;

pub use metriplectic_runtime;

/// The README's Rust blocks, compiled (and run unless `no_run`) as doctests
/// so that they cannot drift from the API.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
