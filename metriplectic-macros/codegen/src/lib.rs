//! The stages behind the `metriplectic!` macro, as an ordinary library.
//!
//! * `parse`: tokens → syntax tree with spans, recovering after errors;
//! * `analysis`: syntax tree → exact polynomials (`polynomial`), with every
//!   check (names, polynomiality, shapes, skew-symmetry, the Jacobi
//!   identity, degrees, the reference model);
//! * `bases`: graded-lex monomial bases and SOS matching tables;
//! * `emit`: readable Rust for a valid system;
//! * `fallback`: stand-in items for an invalid one;
//! * `diagnostics`: every error of an invocation, reported together.
//!
//! `metriplectic-macros` is a thin proc-macro wrapper around [`expand`]; the
//! fuzz target and the tests call the same functions directly, which a
//! proc-macro crate does not allow.
#![warn(missing_docs)]

use proc_macro2::{Span, TokenStream};

mod analysis;
mod bases;
mod diagnostics;
mod emit;
mod fallback;
mod parse;
mod polynomial;

/// Expands one `metriplectic!` invocation (the tokens inside the braces):
/// the generated items, or every error as `compile_error!` together with
/// stand-in items that keep later uses of the type free of follow-on errors.
///
/// Never panics, whatever the input.
pub fn expand(input: TokenStream) -> TokenStream {
    match try_expand(input) {
        Ok(tokens) => tokens,
        Err(failure) => failure.into_tokens(),
    }
}

/// Like [`expand`], but keeps the errors apart from the stand-in items (for
/// tests and tools).
pub fn try_expand(input: TokenStream) -> Result<TokenStream, Failure> {
    let mut diagnostics = diagnostics::Diagnostics::new();
    let def = parse::parse(input, &mut diagnostics);
    let system = analysis::analyse(&def, &mut diagnostics);
    match (diagnostics.into_error(), system) {
        (None, Some(system)) => Ok(emit::emit(&system)),
        (errors, _) => Err(Failure {
            // Every failed step records an error; the fallback message only
            // keeps this total.
            errors: errors.unwrap_or_else(|| {
                syn::Error::new(Span::call_site(), "metriplectic!: the system is not valid")
            }),
            fallback: fallback::fallback(&def),
        }),
    }
}

/// The errors of an invocation that did not expand. Displays as its
/// messages, one per line.
#[derive(Debug)]
pub struct Failure {
    errors: syn::Error,
    fallback: TokenStream,
}

impl Failure {
    /// The errors, combined (iterate over it for each one with its span).
    pub fn errors(&self) -> &syn::Error {
        &self.errors
    }

    /// Each error's message, in the order they were found.
    pub fn messages(&self) -> Vec<String> {
        self.errors
            .clone()
            .into_iter()
            .map(|e| e.to_string())
            .collect()
    }

    /// The `compile_error!` invocations followed by the stand-in items.
    pub fn into_tokens(self) -> TokenStream {
        let mut tokens = self.errors.to_compile_error();
        tokens.extend(self.fallback);
        tokens
    }
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.messages().join("\n"))
    }
}
