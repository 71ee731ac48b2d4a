//! The names generated code binds, and why they cannot clash.
//!
//! * State variables are bound with their own identifiers (spanned at the
//!   macro call) inside the `#[no_implicit_prelude]` evaluation module,
//!   where no item of the caller's scope, no import and no prelude name is
//!   visible: `E`, `None` or a constant's name always binds a variable.
//! * The generated locals (`x`, `out`, `psi`, `grad`, `sink`) and the
//!   monomial bindings are spanned `Span::mixed_site()`: macro_rules-style
//!   hygiene, so a state variable of the same name is a different variable.
//! * The trait impl lives outside the module (so that the macro works inside
//!   a function body, where `super::Type` would not resolve) and forwards to
//!   it with `__`-prefixed parameters, which no state variable reaches.

use std::collections::HashSet;

use proc_macro2::{Ident, Span, TokenStream};
use quote::quote;
use syn::ext::IdentExt;

use crate::analysis::System;

/// A generated local variable: invisible to, and unaffected by, user names.
pub fn local(name: &str) -> Ident {
    Ident::new(name, Span::mixed_site())
}

/// `__metriplectic_Oscillator`: the hidden module with the evaluation code.
///
/// Spanned at the macro call (located at the type's name, where errors
/// about it point): not being the user's token, its camel-case part is not
/// linted as a module name, so crates that forbid `non_snake_case` can use
/// the macro.
pub fn module_name(system: &Ident) -> Ident {
    Ident::new(
        &format!("__metriplectic_{}", system.unraw()),
        Span::call_site().located_at(system.span()),
    )
}

/// Whether rustc's `non_snake_case` lint accepts `name` as the name of a
/// variable (its `is_snake_case`): no upper-case letter, and no `__` once
/// leading and trailing underscores are trimmed.
pub fn is_snake_case(name: &str) -> bool {
    let name = name.trim_matches('_');
    !name.contains("__") && !name.chars().any(char::is_uppercase)
}

/// `let &[q, _] = x else { panic!(…) };` with `_` for unused variables:
/// checks the state's length and binds its entries.
pub fn destructure(system: &System, used: &[bool]) -> TokenStream {
    let x = local("x");
    let n = system.state.len();
    let pattern = system.state.iter().zip(used).map(
        |(ident, &used)| {
            if used {
                quote!(#ident)
            } else {
                quote!(_)
            }
        },
    );
    let message = format!(
        "{}: the state has {n} entries ({}), got {{}}",
        system.name.unraw(),
        system.state_names.join(", ")
    );
    quote! {
        let &[#(#pattern),*] = #x else {
            ::core::panic!(#message, #x.len())
        };
    }
}

/// Names of the monomial bindings, one per monomial of the bases: the state
/// variables themselves at degree 1, readable names at higher degrees
/// (`q2_p` for q²p) when these are distinct valid identifiers unlike any
/// state variable, else `monomial_17`-style names. (Hygiene already keeps
/// them apart from the state variables; the fallback keeps the expansion
/// unambiguous to a reader.) The constant monomial's entry is never read.
pub fn monomials(system: &System) -> Vec<Ident> {
    let names = &system.state_names;
    let all = &system.bases.monomials;
    let readable: Vec<String> = all
        .iter()
        .map(|e| {
            e.iter()
                .zip(names)
                .filter(|(k, _)| **k > 0)
                .map(|(k, name)| {
                    if *k == 1 {
                        name.clone()
                    } else {
                        format!("{name}{k}")
                    }
                })
                .collect::<Vec<_>>()
                .join("_")
        })
        .collect();
    let states: HashSet<&str> = names.iter().map(String::as_str).collect();
    let mut seen = HashSet::new();
    let usable = readable.iter().zip(all).all(|(name, e)| {
        let degree: u32 = e.iter().sum();
        degree < 2
            || (!states.contains(name.as_str())
                && syn::parse_str::<Ident>(name).is_ok()
                && seen.insert(name.clone()))
    });
    let mut fallback = "monomial_".to_string();
    while names.iter().any(|n| n.starts_with(&fallback)) {
        fallback.push('_');
    }
    all.iter()
        .enumerate()
        .map(|(i, e)| match e.iter().sum::<u32>() {
            0 => local("one"),
            1 => {
                let j = e.iter().position(|&k| k == 1).unwrap_or(0);
                system.state[j].clone()
            }
            _ if usable => local(&readable[i]),
            _ => local(&format!("{fallback}{i}")),
        })
        .collect()
}
