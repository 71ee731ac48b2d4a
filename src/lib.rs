//! Paper reproductions and end-to-end tests for the `metriplectic` toolkit.
//!
//! This package holds no library code of its own: the toolkit is
//! [`metriplectic_runtime`] (which re-exports the `metriplectic!` macro). The
//! examples live in `examples/` and the cross-crate tests in `tests/`.
pub use metriplectic_runtime;
