//! The macro's pipeline, stage after stage: bound the input, parse, analyse,
//! emit. Kept in its own module so the fuzz target (`fuzz/`) compiles exactly
//! the code the macro runs.

use proc_macro2::TokenStream;

use crate::{analysis, emit, parse};

/// Parses, checks and generates code for one `metriplectic!` invocation.
///
/// Every failure is a spanned [`syn::Error`]; this function never panics on
/// any input.
pub fn expand(input: TokenStream) -> syn::Result<TokenStream> {
    // Bounded before syn, whose recursive parsers can overflow the stack.
    parse::check_input_bounds(&input)?;
    let def: parse::SystemDef = syn::parse2(input)?;
    let system = analysis::analyse(def)?;
    Ok(emit::emit(&system))
}
