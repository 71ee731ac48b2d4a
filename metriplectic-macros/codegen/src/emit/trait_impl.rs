//! `impl MetriplecticSystem`: the tables as associated consts, and methods
//! forwarding to the evaluation module.
//!
//! The impl stays outside the module so that the macro also works inside a
//! function body. Types are spelled `::core::primitive::f64` here because,
//! unlike inside the module, the caller's scope is visible: a user type
//! named `f64` would otherwise change the signatures.

use proc_macro2::{Ident, TokenStream};
use quote::{format_ident, quote};
use syn::ext::IdentExt;

use super::bindings;
use super::literals::int;
use super::tables::{self, JacobianTerm};
use crate::analysis::System;

/// The trait impl; `entropy_gradient` is overridden only when
/// `straight_gradient` (else the trait's table walk runs).
pub fn trait_impl(
    system: &System,
    jacobian: &[JacobianTerm],
    straight_gradient: bool,
) -> TokenStream {
    let name = &system.name;
    let name_str = name.unraw().to_string();
    let bases = &system.bases;
    let n = int(system.state.len());
    let state_names = &system.state_names;
    let r = proc_macro2::Literal::u32_unsuffixed(bases.entropy_degree);
    let s = proc_macro2::Literal::u32_unsuffixed(bases.metric_degree);
    let entropy_exponents = tables::exponents(&bases.monomials[1..=bases.entropy_len]);
    let metric_exponents = tables::exponents(&bases.monomials[..bases.metric_len]);
    let jacobian = tables::jacobian(jacobian);
    let sos_full = tables::sos(&bases.sos_full, &bases.sos_full_matching);
    let sos_reduced = tables::sos(&[vec![0; system.state.len()]], &bases.sos_reduced_matching);
    let reference = tables::reference(system.reference.as_ref());
    let hamiltonian_scale = tables::hamiltonian_scale(system);
    let poisson_scale = tables::poisson_scale(system);
    let certificate = super::certificate::trait_consts(system, &bindings::module_name(name));
    let module = bindings::module_name(name);
    let f64 = quote!(::core::primitive::f64);
    let u32 = quote!(::core::primitive::u32);
    let mut methods = vec![
        forward(&module, "hamiltonian", &["x"], quote!(-> #f64)),
        forward(&module, "hamiltonian_gradient", &["x", "grad"], quote!()),
        forward(&module, "poisson", &["x", "out"], quote!()),
        forward(&module, "monomials", &["x", "out"], quote!()),
    ];
    if straight_gradient {
        methods.push(forward(
            &module,
            "entropy_gradient",
            &["x", "psi", "grad"],
            quote!(),
        ));
    }
    quote! {
        impl ::metriplectic_runtime::MetriplecticSystem for #name {
            const NAME: &'static ::core::primitive::str = #name_str;
            const DIM: ::core::primitive::usize = #n;
            const STATE_NAMES: &'static [&'static ::core::primitive::str] = &[#(#state_names),*];
            const ENTROPY_DEGREE: #u32 = #r;
            const METRIC_DEGREE: #u32 = #s;
            const ENTROPY_EXPONENTS: &'static [&'static [#u32]] = #entropy_exponents;
            const METRIC_EXPONENTS: &'static [&'static [#u32]] = #metric_exponents;
            /// (k, j, a, i): ∂φ_k/∂x_j = a · monomial i.
            const ENTROPY_JACOBIAN: &'static [::metriplectic_runtime::JacobianTerm] = #jacobian;
            const SOS_FULL: ::metriplectic_runtime::SosTables = #sos_full;
            const SOS_REDUCED: ::metriplectic_runtime::SosTables = #sos_reduced;
            #reference
            #hamiltonian_scale
            #poisson_scale
            #certificate
            #(#methods)*
        }
    }
}

/// `fn name(__x: &[f64], …) { module::name(__x, …) }`: the first parameter
/// is the state, the others are outputs except `psi`.
fn forward(module: &Ident, method: &str, params: &[&str], output: TokenStream) -> TokenStream {
    let method = format_ident!("{method}");
    let names: Vec<Ident> = params.iter().map(|p| format_ident!("__{p}")).collect();
    let declared = names.iter().zip(params).map(|(name, param)| {
        if matches!(*param, "x" | "psi") {
            quote!(#name: &[::core::primitive::f64])
        } else {
            quote!(#name: &mut [::core::primitive::f64])
        }
    });
    quote! {
        #[inline]
        fn #method(#(#declared),*) #output {
            #module::#method(#(#names),*)
        }
    }
}
