//! What an invocation with errors expands to besides the errors: the struct
//! and a stand-in trait impl, so that later uses of the type
//! (`Model::<Broken>::reference()`, `Broken::DIM`, `S: MetriplecticSystem`
//! bounds) compile and add no follow-on errors to the real ones (the
//! pattern of thiserror-impl's `fallback.rs`).

use proc_macro2::TokenStream;
use quote::quote;
use syn::ext::IdentExt;

use crate::emit::{attributes, derives};
use crate::parse::SystemDef;

/// The stand-in items, or nothing if the struct's name did not parse.
pub fn fallback(def: &SystemDef) -> TokenStream {
    let Some(name) = &def.name else {
        return TokenStream::new();
    };
    let (attrs, vis) = (&def.attrs, &def.vis);
    let (derive, _) = derives(attrs);
    // The impl exists where the struct does, and may name a deprecated one.
    let impl_attrs = attributes::outer(attrs, true);
    let name_str = name.unraw().to_string();
    let state_names: Vec<String> = def
        .state
        .iter()
        .flat_map(|s| s.names.iter().map(|i| i.unraw().to_string()))
        .collect();
    let n = state_names.len();
    let message =
        format!("`{name_str}` was not generated: its `metriplectic!` invocation has errors");
    let f64 = quote!(::core::primitive::f64);
    let u32 = quote!(::core::primitive::u32);
    let empty_sos = quote!(::metriplectic_runtime::SosTables {
        exponents: &[],
        matching: &[]
    });
    let none = quote!(::core::option::Option::None);
    quote! {
        #(#attrs)*
        #derive
        #vis struct #name;

        #impl_attrs
        impl ::metriplectic_runtime::MetriplecticSystem for #name {
            const NAME: &'static ::core::primitive::str = #name_str;
            const DIM: ::core::primitive::usize = #n;
            const STATE_NAMES: &'static [&'static ::core::primitive::str] = &[#(#state_names),*];
            const ENTROPY_DEGREE: #u32 = 0;
            const METRIC_DEGREE: #u32 = 0;
            const ENTROPY_EXPONENTS: &'static [&'static [#u32]] = &[];
            const METRIC_EXPONENTS: &'static [&'static [#u32]] = &[];
            const ENTROPY_JACOBIAN: &'static [::metriplectic_runtime::JacobianTerm] = &[];
            const SOS_FULL: ::metriplectic_runtime::SosTables = #empty_sos;
            const SOS_REDUCED: ::metriplectic_runtime::SosTables = #empty_sos;
            const REFERENCE_ENTROPY: ::core::option::Option<&'static [#f64]> = #none;
            const REFERENCE_METRIC: ::core::option::Option<&'static [#f64]> = #none;
            fn hamiltonian(_: &[#f64]) -> #f64 {
                ::core::unreachable!(#message)
            }
            fn hamiltonian_gradient(_: &[#f64], _: &mut [#f64]) {
                ::core::unreachable!(#message)
            }
            fn poisson(_: &[#f64], _: &mut [#f64]) {
                ::core::unreachable!(#message)
            }
            fn monomials(_: &[#f64], _: &mut [#f64]) {
                ::core::unreachable!(#message)
            }
        }
    }
}
