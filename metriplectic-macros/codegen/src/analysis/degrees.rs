//! Checks on the declared degrees and the sizes of the bases they give.

use crate::bases::{self, Bases};
use crate::diagnostics::Diagnostics;
use crate::parse::Degree;

/// Largest basis (entropy or metric) the macro generates code for.
pub const MAX_BASIS: u128 = 20_000;
/// Largest declared entropy or metric degree.
pub const MAX_DEGREE: u32 = 32;
/// Largest number of ordered Gram pairs in the full SOS matching table.
const MAX_GRAM_PAIRS: u128 = 1_000_000;

/// The entropy degree if it is valid, and, with `nvars` known, its basis
/// within bounds.
pub fn entropy_degree(
    degree: Degree,
    nvars: Option<usize>,
    diagnostics: &mut Diagnostics,
) -> Option<u32> {
    let r = degree.value;
    if r == 0 || r > MAX_DEGREE {
        diagnostics.push(syn::Error::new(
            degree.span,
            format!(
                "entropy degree must be between 1 and {MAX_DEGREE} (the entropy basis is the \
                 monomials of degree 1..=r); write e.g. `entropy degree 4;`"
            ),
        ));
        return None;
    }
    let n = nvars?;
    let count = basis_size(n, r).saturating_sub(1);
    if count > MAX_BASIS {
        diagnostics.push(syn::Error::new(
            degree.span,
            format!(
                "entropy degree {r} in {n} variables gives {count} monomials; at most \
                 {MAX_BASIS} are supported, lower the degree"
            ),
        ));
        return None;
    }
    Some(r)
}

/// The metric degree if it is valid (even), and, with `nvars` known, its
/// basis and SOS tables within bounds.
pub fn metric_degree(
    degree: Degree,
    nvars: Option<usize>,
    diagnostics: &mut Diagnostics,
) -> Option<u32> {
    let s = degree.value;
    if s > MAX_DEGREE {
        diagnostics.push(syn::Error::new(
            degree.span,
            format!("metric degree must be at most {MAX_DEGREE}; write e.g. `metric degree 2;`"),
        ));
        return None;
    }
    if s % 2 == 1 {
        diagnostics.push(syn::Error::new(
            degree.span,
            format!(
                "metric degree {s} is odd, but a matrix polynomial of odd degree cannot be \
                 positive semidefinite everywhere; use an even degree such as {} or {}",
                s - 1,
                s + 1
            ),
        ));
        return None;
    }
    let n = nvars?;
    let count = basis_size(n, s);
    if count > MAX_BASIS {
        diagnostics.push(syn::Error::new(
            degree.span,
            format!(
                "metric degree {s} in {n} variables gives {count} monomials per entry; at most \
                 {MAX_BASIS} are supported, lower the degree"
            ),
        ));
        return None;
    }
    let half = basis_size(n, s / 2);
    if half.saturating_mul(half) > MAX_GRAM_PAIRS {
        diagnostics.push(syn::Error::new(
            degree.span,
            format!(
                "metric degree {s} in {n} variables needs an SOS Gram basis of {half} monomials, \
                 too many to tabulate; lower the degree"
            ),
        ));
        return None;
    }
    Some(s)
}

fn basis_size(nvars: usize, degree: u32) -> u128 {
    bases::count_up_to(nvars, degree).unwrap_or(u128::MAX)
}

/// The bases, when both degrees and the state are valid.
pub fn bases(nvars: usize, entropy: Option<u32>, metric: Option<u32>) -> Option<Bases> {
    Some(Bases::new(nvars, entropy?, metric?))
}
