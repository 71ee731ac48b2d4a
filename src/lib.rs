//! Paper reproductions and end-to-end tests for the `metriplectic` toolkit.
//!
//! The toolkit itself is [`metriplectic_runtime`] (which re-exports the
//! `metriplectic!` macro). This package holds what the paper reproductions in
//! `examples/` share — [`reproduction`] (data, identification, evaluation,
//! outputs) and [`figures`] — so that the examples and the end-to-end tests in
//! `tests/` run the same code.

pub mod figures;
pub mod reproduction;

pub use metriplectic_runtime;
