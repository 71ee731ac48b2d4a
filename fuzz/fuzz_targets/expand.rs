//! Fuzzes the `metriplectic!` front end: any text that lexes as Rust tokens
//! must give generated code or a `syn::Error`, never a panic, a stack
//! overflow or a hang.
//!
//! The macro's stages are compiled here from their sources (a proc-macro crate
//! cannot be linked into a normal binary), so this exercises exactly the code
//! the macro runs.
#![no_main]

use std::str::FromStr;

use libfuzzer_sys::fuzz_target;
use proc_macro2::TokenStream;

#[path = "../../metriplectic-macros/src/analysis.rs"]
mod analysis;
#[path = "../../metriplectic-macros/src/emit.rs"]
mod emit;
#[path = "../../metriplectic-macros/src/monomials.rs"]
mod monomials;
#[path = "../../metriplectic-macros/src/parse.rs"]
mod parse;
#[path = "../../metriplectic-macros/src/pipeline.rs"]
mod pipeline;
#[path = "../../metriplectic-macros/src/polynomial.rs"]
mod polynomial;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // Text rustc's lexer rejects never reaches a macro.
    let Ok(tokens) = TokenStream::from_str(text) else {
        return;
    };
    let _ = pipeline::expand(tokens);
});
