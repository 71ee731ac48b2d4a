//! Fuzzes the `metriplectic!` front end: any text that lexes as Rust tokens
//! must give generated code or compile errors, never a panic, a stack
//! overflow or a hang.
//!
//! `metriplectic-codegen` is the library the proc-macro crate wraps, so this
//! exercises exactly the code the macro runs.
#![no_main]

use std::str::FromStr;

use libfuzzer_sys::fuzz_target;
use proc_macro2::TokenStream;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // Text rustc's lexer rejects never reaches a macro.
    let Ok(tokens) = TokenStream::from_str(text) else {
        return;
    };
    let _ = metriplectic_codegen::expand(tokens);
});
