//! The `metriplectic!` macro (placeholder while the pipeline is built).
use proc_macro::TokenStream;

/// Declares a generalized metriplectic system.
#[proc_macro]
pub fn metriplectic(input: TokenStream) -> TokenStream {
    let _ = input;
    TokenStream::new()
}
