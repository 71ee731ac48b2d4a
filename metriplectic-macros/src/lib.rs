//! The `metriplectic!` macro: DSL parser, exact polynomial engine and code
//! generator.
//!
//! Use it through `metriplectic_runtime`, which re-exports it and provides the
//! `MetriplecticSystem` trait the generated code implements. The pipeline is
//! one module per stage: `parse` (tokens → syntax tree with
//! spans), `analysis` (syntax tree → exact polynomials, every check),
//! `monomials` (graded-lex bases and SOS tables), `emit` (readable Rust).

use pipeline::expand;
use proc_macro::TokenStream;

mod analysis;
mod emit;
mod monomials;
mod parse;
mod pipeline;
mod polynomial;
#[cfg(test)]
mod robustness_tests;

/// Declares a generalized metriplectic system
/// ẋ = (Π(x) + K(x)) (∇H(x) + ∇S(x)) with known Poisson tensor Π and
/// Hamiltonian H, and polynomial bases for the unknown entropy S and metric K.
///
/// ```ignore
/// use metriplectic_runtime::prelude::*;
///
/// metriplectic! {
///     /// Docs carried to the generated type.
///     pub struct Oscillator;
///     state (q, p);                       // x = (q, p), in this order
///     const k = 1;                        // optional named constants
///     poisson = [[0, 1], [-1, 0]];        // Π(x): n×n polynomial entries
///     hamiltonian = 0.5 * p^2 + 0.5 * k * q^2;
///     entropy degree 8;                   // S spans monomials of degree 1..=8
///     metric degree 2;                    // K entries span degree 0..=2 (even)
///     reference {                         // optional known model
///         entropy = -0.5 * (p^2 + 4*q^4 - 4*q^2)^2 - (0.5*p^2 + 0.5*q^2);
///         metric  = [[1, 0], [0, 1]];
///     }
/// }
/// ```
///
/// # Sections
///
/// Sections may come in any order, each at most once; `const` may repeat.
///
/// * `pub struct Name;` first, with optional doc comments, attributes and
///   visibility. It becomes a unit struct implementing
///   `metriplectic_runtime::MetriplecticSystem`.
/// * `state (a, b, …);` the state variables, in state order.
/// * `const NAME = expr;` a named constant: a constant expression that may use
///   numbers and earlier constants.
/// * `poisson = [[…], …];` Π(x), an n×n matrix of polynomials. It must be
///   skew-symmetric and satisfy the Jacobi identity; both are checked exactly.
/// * `hamiltonian = expr;` H(x).
/// * `entropy degree r;` (1 ≤ r) the entropy basis: all monomials of degree
///   1..=r (the constant has zero gradient, so it is left out).
/// * `metric degree s;` (even) each entry of K spans the monomials of degree
///   0..=s.
/// * `reference { entropy = expr; metric = [[…]]; }` optional: a known model
///   (for synthetic data and tests). It must fit the declared bases and the
///   metric must be symmetric.
///
/// # Expressions
///
/// Polynomials written with numbers (`2`, `0.5`, `1e-3`: all exact
/// rationals), state variables, constants, `+ - * /`, `^` and parentheses.
/// `^` takes a non-negative integer exponent, binds tighter than unary minus
/// and `*`, and is right-associative: `-q^2` is −(q²), `2*q^3` is 2(q³),
/// `2^3^2` is 2⁹. Division is only by non-zero constant expressions. Anything
/// else — a variable in a denominator, `q^-1`, `q^0.5`, `sin(q)`, `q.powi(2)` —
/// is a compile error pointing at the offending tokens.
///
/// # What it generates
///
/// The struct, inherent items (`MONOMIAL_COUNT`, `ENTROPY_JACOBIAN_TERMS`,
/// `monomials(x)`, and `reference_model()` when a reference is declared) and
/// the trait impl: exponent tables in graded lexicographic order (by degree,
/// then larger exponents of earlier variables first), SOS matching tables (full
/// and facially reduced), straight-line code for H, ∇H, Π and every monomial
/// (each one multiplication from a lower one), and the per-sample assembly
/// blocks of the entropy and metric searches. View it with `cargo expand`.
#[proc_macro]
pub fn metriplectic(input: TokenStream) -> TokenStream {
    match expand(input.into()) {
        Ok(tokens) => tokens.into(),
        Err(error) => error.to_compile_error().into(),
    }
}

#[cfg(test)]
mod snapshot_tests {
    use std::path::PathBuf;

    use quote::quote;

    /// The 2-D paper system (DESIGN.md §3), as a user would write it.
    fn linear_2d() -> proc_macro2::TokenStream {
        quote! {
            /// Canonical oscillator whose free energy has a figure-eight zero set.
            pub struct Oscillator;
            state (q, p);
            poisson = [[0, 1], [-1, 0]];
            hamiltonian = 0.5 * p^2 + 0.5 * q^2;
            entropy degree 8;
            metric degree 2;
            reference {
                entropy = -0.5 * (p^2 + 4*q^4 - 4*q^2)^2 - (0.5*p^2 + 0.5*q^2);
                metric = [[1, 0], [0, 1]];
            }
        }
    }

    fn pretty(tokens: proc_macro2::TokenStream) -> String {
        let file: syn::File = syn::parse2(tokens).expect("generated code parses as a file");
        prettyplease::unparse(&file)
    }

    /// A state named like a readable monomial name (`x2` for x²) switches
    /// every monomial binding to collision-free fallback names.
    #[test]
    fn colliding_monomial_names_fall_back() {
        let tokens = quote! {
            struct Awkward;
            state (x, x2);
            poisson = [[0, 1], [-1, 0]];
            hamiltonian = x^2;
            entropy degree 2;
            metric degree 0;
        };
        let text = pretty(super::expand(tokens).expect("valid system"));
        assert!(
            text.contains("let (monomial_3, monomial_4, monomial_5) = (x * x, x2 * x, x2 * x2);"),
            "{text}"
        );
        let plain = quote! {
            struct Plain;
            state (x, y);
            poisson = [[0, 1], [-1, 0]];
            hamiltonian = x^2;
            entropy degree 2;
            metric degree 0;
        };
        let text = pretty(super::expand(plain).expect("valid system"));
        assert!(
            text.contains("let (x2, x_y, y2) = (x * x, y * x, y * y);"),
            "{text}"
        );
    }

    /// What users see under `cargo expand`; `UPDATE_SNAPSHOTS=1` rewrites it.
    #[test]
    fn linear_2d_expansion_matches_snapshot() {
        let expanded = pretty(super::expand(linear_2d()).expect("the paper system is valid"));
        let path =
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("snapshots/linear_2d.expanded.rs");
        if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
            std::fs::create_dir_all(path.parent().expect("snapshot dir"))
                .expect("create snapshots/");
            std::fs::write(&path, &expanded).expect("write snapshot");
        }
        let stored = std::fs::read_to_string(&path)
            .expect("snapshot missing: run with UPDATE_SNAPSHOTS=1 and review the file");
        assert!(
            stored == expanded,
            "expansion changed; review and rerun with UPDATE_SNAPSHOTS=1\n{expanded}"
        );
    }
}

#[cfg(test)]
mod size_tests {
    use quote::quote;

    /// The 6-state system of `tests/large_system.rs`: reports the size of the
    /// generated code (run with `--nocapture` to see it).
    #[test]
    fn large_system_expansion_size() {
        let tokens = quote! {
            pub struct Chain;
            state (q1, q2, q3, p1, p2, p3);
            poisson = [
                [0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1],
                [-1, 0, 0, 0, 0, 0], [0, -1, 0, 0, 0, 0], [0, 0, -1, 0, 0, 0],
            ];
            hamiltonian = 0.5 * (p1^2 + p2^2 + p3^2) + 0.5 * (q1^2 + q2^2 + q3^2);
            entropy degree 8;
            metric degree 4;
        };
        let expanded = super::expand(tokens).expect("valid system");
        let text = expanded.to_string();
        let file: syn::File = syn::parse2(expanded).expect("parses");
        let pretty = prettyplease::unparse(&file);
        println!(
            "large system: {} bytes of tokens, {} lines / {} bytes after prettyplease",
            text.len(),
            pretty.lines().count(),
            pretty.len()
        );
    }
}
