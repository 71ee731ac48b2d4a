//! Checks on the names a system declares: its state variables and constants.
//!
//! The generated code binds state variables inside a `#[no_implicit_prelude]`
//! module, where nothing of the caller's scope is visible, and gives its own
//! locals `Span::mixed_site()`; so any identifier works as a state variable
//! there (`E`, `None`, `x`, `r#type`, even the name of the generated
//! module). What remains unsupported is what the data formats reserve.

use proc_macro2::{Ident, Span};

use super::scope::{name_of, Context, Scope};
use crate::diagnostics::Diagnostics;
use crate::parse::{ConstDef, StateDecl};
use crate::polynomial::Rational;

/// Largest number of state variables.
pub const MAX_STATES: usize = 64;

/// Column names of trajectory CSV files other than the state variables':
/// a state variable of that name would make the header ambiguous.
const CSV_COLUMNS: [(&str, &str); 2] = [
    ("t", "the time column"),
    ("trajectory", "the trajectory-identifier column"),
];
/// In trajectory CSV files, the derivative of state variable `q` is column `dq`.
const DERIVATIVE_PREFIX: &str = "d";

/// The state variables of a system.
#[derive(Debug)]
pub struct States {
    /// As written (raw identifiers keep their `r#`), spanned at the macro
    /// call: generated code is then macro output, not user code, for lints.
    pub idents: Vec<Ident>,
    /// The names they are looked up by (`type` for `r#type`).
    pub names: Vec<String>,
}

/// Checks the state variables; `None` if there are too many to analyse
/// anything else. Reserved and repeated names are reported, but the rest of
/// the system is still checked.
pub fn check_states(decl: &StateDecl, diagnostics: &mut Diagnostics) -> Option<States> {
    let n = decl.names.len();
    if n > MAX_STATES {
        diagnostics.push(syn::Error::new(
            decl.keyword,
            format!("{n} state variables; at most {MAX_STATES} are supported"),
        ));
        return None;
    }
    let names: Vec<String> = decl.names.iter().map(name_of).collect();
    for (i, ident) in decl.names.iter().enumerate() {
        let name = &names[i];
        if names[..i].contains(name) {
            diagnostics.push(syn::Error::new(
                ident.span(),
                format!(
                    "state variable `{name}` is listed twice; give every state variable its own name"
                ),
            ));
            continue;
        }
        if let Some((_, column)) = CSV_COLUMNS.iter().find(|(column, _)| column == name) {
            diagnostics.push(syn::Error::new(
                ident.span(),
                format!(
                    "a state variable cannot be named `{name}`: trajectory CSV files use `{name}` \
                     for {column}, next to one column per state variable; rename it, e.g. \
                     `{name}_0`"
                ),
            ));
        }
        if let Some(base) = name.strip_prefix(DERIVATIVE_PREFIX) {
            if names.iter().any(|other| other == base) {
                diagnostics.push(syn::Error::new(
                    ident.span(),
                    format!(
                        "state variables `{base}` and `{name}` cannot both exist: in trajectory \
                         CSV files the column `{name}` holds the derivative of `{base}`, so it \
                         would be ambiguous; rename one of them"
                    ),
                ));
            }
        }
    }
    let idents = decl
        .names
        .iter()
        .map(|ident| {
            let mut ident = ident.clone();
            ident.set_span(Span::call_site());
            ident
        })
        .collect();
    Some(States { idents, names })
}

/// Defines the constants in `scope`, in declaration order, and returns their
/// values (for the docs). Each is checked on its own: a failed constant is
/// reported once and its uses are skipped.
pub fn define_consts(
    consts: &[ConstDef],
    scope: &mut Scope,
    diagnostics: &mut Diagnostics,
) -> Vec<(String, Rational)> {
    let mut values = Vec::new();
    for constant in consts {
        let name = name_of(&constant.name);
        if scope.is_state(&name) {
            diagnostics.push(syn::Error::new(
                constant.name.span(),
                format!(
                    "constant `{name}` has the name of a state variable; rename the constant, \
                     e.g. `{name}_0`"
                ),
            ));
            continue;
        }
        if scope.is_const(&name) {
            diagnostics.push(syn::Error::new(
                constant.name.span(),
                format!("constant `{name}` is declared twice; give it a new name or remove one"),
            ));
            continue;
        }
        let value = constant.value.as_ref().and_then(|expr| {
            scope
                .polynomial(expr, Context::Const(&name), diagnostics)
                .map(|p| p.as_constant().unwrap_or(Rational::ZERO))
        });
        scope.define_const(&name, value);
        if let Some(value) = value {
            values.push((name, value));
        }
    }
    values
}
