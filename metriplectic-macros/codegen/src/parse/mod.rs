//! Parsing the DSL: token stream → syntax tree with spans.
//!
//! `bounds` limits the input before anything recursive sees it, `sections`
//! parses the section structure with error recovery, `expr` parses
//! expressions with mathematical precedence, and `syntax` is the tree they
//! build.

mod bounds;
mod certificate;
mod expr;
mod sections;
mod syntax;

use proc_macro2::TokenStream;

use crate::diagnostics::Diagnostics;

#[cfg(test)]
pub use expr::parse_expression;
pub use syntax::{
    BinaryOp, ConstDef, Degree, Expr, Interval, Matrix, Mode, Reference, RegionDecl, RegionShape,
    SpanRange, StateDecl, SystemDef, Vector,
};

/// Parses one invocation as far as it goes, recording every error.
///
/// An input beyond the size bounds is only searched for the struct's name
/// (for the stand-in items emitted with the errors).
pub fn parse(input: TokenStream, diagnostics: &mut Diagnostics) -> SystemDef {
    let scope = match bounds::check_input_bounds(&input) {
        Ok(()) => sections::Scope::Full,
        Err(error) => {
            diagnostics.push(error);
            sections::Scope::HeaderOnly
        }
    };
    sections::parse_system(input, scope, diagnostics)
}
