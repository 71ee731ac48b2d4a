//! Code generation: an analysed system → readable Rust.
//!
//! Three items: the struct (`struct_item`), a hidden evaluation module with
//! straight-line code for H, ∇H, Π, the monomials and the entropy gradient
//! (`evaluation`), and the trait impl with the tables (`trait_impl`,
//! `tables`); the struct's `#[cfg]`s go on all three (`attributes`).
//! Everything that is the same for all systems — features, Jacobian, metric
//! value, the rows of the searches — is a provided method of
//! `MetriplecticSystem` and is not generated. `bindings` explains why no
//! name in the generated code can clash with a user's name.

pub(crate) mod attributes;
mod bindings;
mod certificate;
mod evaluation;
mod literals;
mod struct_item;
mod tables;
mod trait_impl;

use proc_macro2::TokenStream;
use quote::quote;

pub use struct_item::derives;

use crate::analysis::System;

/// Largest entropy Jacobian (non-zero entries) that gets a straight-line
/// `entropy_gradient`; larger systems keep the trait's provided table walk
/// over `ENTROPY_JACOBIAN`.
///
/// Measured against the table walk (release, per call, on a 2-core EPYC
/// shared with other builds, so ranges over repeated runs): 4.7–7.4× faster
/// at 72 entries (2-D paper system), 3.3–3.7× at 168 (SO(3)), 2.8–4.4× at
/// 504, 1.6–2.8× from 1260 to 1980 entries; at 2310 anywhere from 0.7× to
/// 2.2×, and at 10296 (the 6-state, degree-8 system of
/// `tests/large_system.rs`) 0.5–0.9×, slower than the walk, as thousands of
/// live monomials spill out of the registers. Its compile time grows
/// linearly meanwhile: +0.5 s of release build at 2310 entries, +5 s of
/// 7.5 s at 10296. So the straight line stops where its gain stops being
/// reliable.
pub const STRAIGHT_GRADIENT_MAX_TERMS: usize = 2048;

/// The generated items for an analysed system.
pub fn emit(system: &System) -> TokenStream {
    let jacobian = tables::jacobian_terms(system);
    let straight_gradient = jacobian.len() <= STRAIGHT_GRADIENT_MAX_TERMS;
    let docs = struct_item::docs(system);
    let item = struct_item::struct_item(&system.attrs, &system.vis, &system.name, &docs);
    // The module does not name the type; the impl does.
    let module_attrs = attributes::outer(&system.attrs, false);
    let impl_attrs = attributes::outer(&system.attrs, true);
    let module = evaluation::module(system, &jacobian, straight_gradient, &module_attrs);
    let implementation = trait_impl::trait_impl(system, &jacobian, straight_gradient);
    quote! {
        #item
        #module
        #impl_attrs
        #implementation
    }
}
