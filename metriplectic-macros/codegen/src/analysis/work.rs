//! Work budgets of the exact checks that multiply whole polynomials (the
//! Jacobi identity, the classical form's constraints).
//!
//! Each expression is capped on its own (`scope`), but these checks
//! multiply entries with each other, n³ or more times: entries that pass
//! their own caps can still ask for 10¹⁰ products of terms, hours of
//! compile time. The work is counted before a check starts, from the
//! entries' term counts alone, so such an input is an error at its span.

use crate::polynomial::Polynomial;

/// Products of two terms a check may make: milliseconds for the paper's
/// systems, a few seconds at the cap.
pub const MAX_TERM_PRODUCTS: u64 = 20_000_000;

/// Term products of `a · b`.
pub fn product(a: &Polynomial, b: &Polynomial) -> u64 {
    a.term_count() as u64 * b.term_count() as u64
}

/// At most this many terms of a polynomial are shown in an error message.
pub const SHOWN_TERMS: usize = 24;
