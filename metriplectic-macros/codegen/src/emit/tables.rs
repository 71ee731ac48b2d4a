//! The compile-time tables of the trait: exponents, the entropy Jacobian,
//! the SOS matching tables and the reference coefficients.

use std::collections::HashMap;

use proc_macro2::{Literal, TokenStream};
use quote::quote;

use super::literals::{doc, rational};
use crate::analysis::{ReferenceModel, System};
use crate::bases;

/// `&[&[1, 0], &[0, 1], …]`
pub fn exponents(rows: &[Vec<u32>]) -> TokenStream {
    let rows = rows.iter().map(|e| {
        let entries = e.iter().map(|&k| Literal::u32_unsuffixed(k));
        quote!(&[#(#entries),*])
    });
    quote!(&[#(#rows),*])
}

/// One non-zero entry of the entropy Jacobian: ∂φ_feature/∂x_variable =
/// exponent · μ_monomial, μ indexing the graded-lex monomials (degree < r).
#[derive(Debug, Clone, Copy)]
pub struct JacobianTerm {
    /// Entropy feature k (row of the Jacobian).
    pub feature: usize,
    /// Variable j (column).
    pub variable: usize,
    /// The exponent of x_j in φ_k.
    pub exponent: u32,
    /// Index of x^(α_k − e_j) among all monomials.
    pub monomial: usize,
}

/// The entropy Jacobian's non-zero entries, row by row.
pub fn jacobian_terms(system: &System) -> Vec<JacobianTerm> {
    let bases = &system.bases;
    let index: HashMap<&[u32], usize> = bases::index_of(&bases.monomials);
    let mut terms = Vec::new();
    for (feature, e) in bases.monomials[1..=bases.entropy_len].iter().enumerate() {
        for (variable, &exponent) in e.iter().enumerate() {
            if exponent == 0 {
                continue;
            }
            let mut lower = e.clone();
            lower[variable] -= 1;
            // Every monomial of lower degree is in the list; 0 is never wrong
            // for the constant either.
            let monomial = index.get(lower.as_slice()).copied().unwrap_or(0);
            terms.push(JacobianTerm {
                feature,
                variable,
                exponent,
                monomial,
            });
        }
    }
    terms
}

/// `&[(0, 0, 1, 0), …]`: the `ENTROPY_JACOBIAN` table.
pub fn jacobian(terms: &[JacobianTerm]) -> TokenStream {
    let entries = terms.iter().map(|t| {
        let (k, j, a, i) = (
            Literal::usize_unsuffixed(t.feature),
            Literal::usize_unsuffixed(t.variable),
            Literal::u32_unsuffixed(t.exponent),
            Literal::usize_unsuffixed(t.monomial),
        );
        quote!((#k, #j, #a, #i))
    });
    quote!(&[#(#entries),*])
}

/// `::metriplectic_runtime::SosTables { exponents: …, matching: … }`
pub fn sos(exponent_rows: &[Vec<u32>], matching: &[Vec<(usize, usize)>]) -> TokenStream {
    let exponents = exponents(exponent_rows);
    let rows = matching.iter().map(|pairs| {
        let pairs = pairs.iter().map(|&(b, g)| {
            let (b, g) = (Literal::usize_unsuffixed(b), Literal::usize_unsuffixed(g));
            quote!((#b, #g))
        });
        quote!(&[#(#pairs),*])
    });
    quote! {
        ::metriplectic_runtime::SosTables {
            exponents: #exponents,
            matching: &[#(#rows),*],
        }
    }
}

/// `REFERENCE_ENTROPY` and `REFERENCE_METRIC`.
pub fn reference(reference: Option<&ReferenceModel>) -> TokenStream {
    let ty = quote!(::core::option::Option<&'static [::core::primitive::f64]>);
    match reference {
        Some(reference) => {
            let psi = reference.psi.iter().map(|&c| rational(c));
            let theta = reference.theta.iter().map(|&c| rational(c));
            let dropped = doc(format!(
                "ψ of the declared reference entropy (its constant term, {}, is dropped: it \
                 does not affect the dynamics).",
                reference.dropped_constant
            ));
            quote! {
                #dropped
                const REFERENCE_ENTROPY: #ty = ::core::option::Option::Some(&[#(#psi),*]);
                /// θ of the declared reference metric.
                const REFERENCE_METRIC: #ty = ::core::option::Option::Some(&[#(#theta),*]);
            }
        }
        None => quote! {
            const REFERENCE_ENTROPY: #ty = ::core::option::Option::None;
            const REFERENCE_METRIC: #ty = ::core::option::Option::None;
        },
    }
}

/// `HAMILTONIAN_SCALE`: the largest |coefficient| of H's non-constant terms
/// (the constant does not affect the dynamics), exact until rounded here.
pub fn hamiltonian_scale(system: &System) -> TokenStream {
    let scale = system
        .hamiltonian
        .terms()
        .filter(|(e, _)| e.iter().any(|&k| k > 0))
        .map(|(_, c)| c.to_f64().abs())
        .fold(0.0, f64::max);
    let value = super::literals::float(scale);
    quote! {
        /// The largest |coefficient| of the Hamiltonian's non-constant terms.
        const HAMILTONIAN_SCALE: ::core::primitive::f64 = #value;
    }
}

/// `POISSON_SCALE`: the largest |coefficient| of Π's entries, exact until
/// rounded here.
pub fn poisson_scale(system: &System) -> TokenStream {
    let scale = system
        .poisson
        .iter()
        .flat_map(|entry| entry.terms())
        .map(|(_, c)| c.to_f64().abs())
        .fold(0.0, f64::max);
    let value = super::literals::float(scale);
    quote! {
        /// The largest |coefficient| of the Poisson tensor's entries.
        const POISSON_SCALE: ::core::primitive::f64 = #value;
    }
}
