//! Code generation: an analysed system → readable Rust.
//!
//! Three items: the struct (`struct_item`), a hidden evaluation module with
//! straight-line code for H, ∇H, Π, the monomials and the entropy gradient
//! (`evaluation`), and the trait impl with the tables (`trait_impl`,
//! `tables`). Everything that is the same for all systems — features,
//! Jacobian, metric value, the rows of the searches — is a provided method
//! of `MetriplecticSystem` and is not generated. `bindings` explains why no
//! name in the generated code can clash with a user's name.

mod bindings;
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
/// Measured (release, 2-core EPYC, per call; compile time of a test crate
/// with only that system): the straight-line gradient is 2.0× faster than
/// the table walk at 72 entries (2-D paper system), 2.3× at 168 (SO(3)),
/// 2.9× at 504, 1.9× at 1320, 1.55× at 2310 (+0.55 s to compile) and 1.4×
/// at 10296 (the 6-state, degree-8 system of `tests/large_system.rs`, where
/// it costs +5 s of a 7.5 s release build and 400 KB of machine code). The
/// gain shrinks as the code outgrows the instruction cache while its
/// compile time grows linearly, so it stops a little below the 2310 point.
pub const STRAIGHT_GRADIENT_MAX_TERMS: usize = 2048;

/// The generated items for an analysed system.
pub fn emit(system: &System) -> TokenStream {
    let jacobian = tables::jacobian_terms(system);
    let straight_gradient = jacobian.len() <= STRAIGHT_GRADIENT_MAX_TERMS;
    let docs = struct_item::docs(system);
    let item = struct_item::struct_item(&system.attrs, &system.vis, &system.name, &docs);
    let module = evaluation::module(system, &jacobian, straight_gradient);
    let implementation = trait_impl::trait_impl(system, &jacobian, straight_gradient);
    quote! {
        #item
        #module
        #implementation
    }
}
