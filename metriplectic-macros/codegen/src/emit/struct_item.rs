//! The system's unit struct: the user's attributes, generated docs, and the
//! derives the trait needs.

use proc_macro2::{Ident, TokenStream};
use quote::quote;
use syn::punctuated::Punctuated;
use syn::{Attribute, Meta, Token, Visibility};

use super::attributes;
use super::bindings;
use super::certificate;
use super::literals::doc;
use crate::analysis::System;
use crate::parse::Mode;
use crate::polynomial::Polynomial;

/// The derives the struct gets: `MetriplecticSystem` needs `Debug`, `Copy`
/// (so `Clone`) and `Default`; the comparisons come free for a unit struct.
/// Path-qualified, so that a user item named `Debug` changes nothing.
const DERIVES: [(&str, &str); 7] = [
    ("Debug", "::core::fmt::Debug"),
    ("Clone", "::core::clone::Clone"),
    ("Copy", "::core::marker::Copy"),
    ("Default", "::core::default::Default"),
    ("PartialEq", "::core::cmp::PartialEq"),
    ("Eq", "::core::cmp::Eq"),
    ("Hash", "::core::hash::Hash"),
];

/// The traits the user's attributes derive, by name (last path segment:
/// `Clone` for `#[derive(std::clone::Clone)]`), each with the condition of
/// the `cfg_attr` it is derived under (`None`: always).
fn derived_by_user(attrs: &[Attribute]) -> Vec<(String, Option<TokenStream>)> {
    let mut derived = Vec::new();
    for attr in attributes::effective(attrs)
        .iter()
        .filter(|a| a.is("derive"))
    {
        // A malformed derive is rustc's to report, on the user's tokens.
        let Meta::List(list) = &attr.meta else {
            continue;
        };
        if let Ok(paths) =
            list.parse_args_with(Punctuated::<syn::Path, Token![,]>::parse_terminated)
        {
            derived.extend(paths.iter().filter_map(|p| {
                let name = p.segments.last()?.ident.to_string();
                Some((name, attr.condition()))
            }));
        }
    }
    derived
}

/// A trait of `DERIVES` the macro derives.
struct Missing {
    name: &'static str,
    path: &'static str,
    /// The conditions of the user's `cfg_attr`s that derive it: the macro
    /// derives it where none holds (always, if there is none).
    user_conditions: Vec<TokenStream>,
}

impl Missing {
    /// `not(P)` or `not(any(P, Q))`; `None` to derive it always.
    fn condition(&self) -> Option<TokenStream> {
        match self.user_conditions.as_slice() {
            [] => None,
            [one] => Some(quote!(not(#one))),
            many => Some(quote!(not(any(#(#many),*)))),
        }
    }
}

/// The derive attributes for the traits the user does not derive, and
/// their names for the docs (`None` if there is none). Deriving one twice
/// would be a conflict, so a trait the user derives is left out, and one the
/// user derives under a `cfg_attr` condition P is derived here under
/// `not(P)`, `#[cfg_attr(not(P), derive(…))]`: either way the struct has it
/// exactly once.
pub fn derives(attrs: &[Attribute]) -> (TokenStream, Option<String>) {
    let user = derived_by_user(attrs);
    let missing: Vec<Missing> = DERIVES
        .into_iter()
        .filter_map(|(name, path)| {
            let mut user_conditions = Vec::new();
            for (_, condition) in user.iter().filter(|(u, _)| u == name) {
                // Derived by the user in every configuration.
                user_conditions.push(condition.clone()?);
            }
            Some(Missing {
                name,
                path,
                user_conditions,
            })
        })
        .collect();
    // One attribute per condition, the unconditional one first, each in the
    // order of `DERIVES`.
    let mut groups: Vec<(String, Option<TokenStream>, Vec<syn::Path>)> = Vec::new();
    for trait_ in &missing {
        let condition = trait_.condition();
        let key = condition
            .as_ref()
            .map(ToString::to_string)
            .unwrap_or_default();
        let Ok(path) = syn::parse_str::<syn::Path>(trait_.path) else {
            continue;
        };
        match groups.iter_mut().find(|(k, _, _)| *k == key) {
            Some((_, _, paths)) => paths.push(path),
            None => groups.push((key, condition, vec![path])),
        }
    }
    groups.sort_by_key(|(key, _, _)| !key.is_empty());
    let tokens = groups
        .into_iter()
        .map(|(_, condition, paths)| {
            attributes::conditional(condition, quote!(derive(#(#paths),*)))
        })
        .collect();
    let names = |conditional: bool| {
        missing
            .iter()
            .filter(|t| t.user_conditions.is_empty() != conditional)
            .map(|t| format!("`{}`", t.name))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let (always, unless_user) = (names(false), names(true));
    let docs = match (always.is_empty(), unless_user.is_empty()) {
        (true, true) => None,
        (false, true) => Some(always),
        (true, false) => Some(format!(
            "where your `cfg_attr`s do not derive them, {unless_user}"
        )),
        (false, false) => Some(format!(
            "{always} and, where your `cfg_attr`s do not derive them, {unless_user}"
        )),
    };
    (tokens, docs)
}

/// The struct item with the user's attributes and visibility.
pub fn struct_item(
    attrs: &[Attribute],
    vis: &Visibility,
    name: &Ident,
    docs: &[String],
) -> TokenStream {
    let (derive, _) = derives(attrs);
    let docs = docs.iter().map(doc);
    quote! {
        #(#attrs)*
        #(#docs)*
        #derive
        #vis struct #name;
    }
}

/// The generated part of the struct's docs: what the macro checked and
/// generated, below the user's own doc comments.
pub fn docs(system: &System) -> Vec<String> {
    let names = &system.state_names;
    let n = names.len();
    let bases = &system.bases;
    let pairs = n * (n + 1) / 2;
    let mut docs = vec![
        String::new(),
        "# Generated by `metriplectic!`".to_string(),
        String::new(),
        format!("* State x = ({}), n = {n}.", names.join(", ")),
        format!(
            "* Hamiltonian H(x) = `{}`.",
            system.hamiltonian.display(names)
        ),
        format!(
            "* Poisson tensor Π(x) = `{}` (checked skew-symmetric and Jacobi, exactly).",
            matrix_text(&system.poisson, n, names)
        ),
    ];
    for (c, value) in &system.consts {
        docs.push(format!("* Constant `{c}` = {value}."));
    }
    docs.extend([
        format!(
            "* Entropy basis: the {} monomials of degree 1..={} (graded lexicographic, no constant).",
            bases.entropy_len, bases.entropy_degree
        ),
        format!(
            "* Metric basis: the {} monomials of degree 0..={} per entry, {} coefficients θ in all.",
            bases.metric_len,
            bases.metric_degree,
            pairs * bases.metric_len
        ),
    ]);
    if let Some(reference) = &system.reference {
        docs.push(format!(
            "* Reference entropy S(x) = `{}`.",
            reference.entropy.display(names)
        ));
        docs.push(format!(
            "* Reference metric K(x) = `{}`.",
            matrix_text(&reference.metric, n, names)
        ));
    }
    docs.extend(certificate_docs(system));
    if let (_, Some(derived)) = derives(&system.attrs) {
        docs.push(format!(
            "* Derives {derived} (the trait needs `Debug`, `Copy` and `Default`)."
        ));
    }
    docs.push(format!(
        "* Implements `MetriplecticSystem`; the evaluation code is in the hidden module `{}`.",
        bindings::module_name(&system.name)
    ));
    docs
}

/// The region, the certificate's mode and the classical form, if declared.
fn certificate_docs(system: &System) -> Vec<String> {
    let names = &system.state_names;
    let mut docs = Vec::new();
    if let Some(certificate) = &system.certificate {
        let constraints: Vec<String> = certificate
            .constraints
            .iter()
            .map(|g| format!("`{}` ≥ 0", g.display(names)))
            .collect();
        docs.push(format!(
            "* Region R: {}, i.e. {}.",
            certificate.region.describe(names),
            constraints.join(", ")
        ));
        docs.push(format!(
            "* Metric certificate (`REGION_CERTIFICATE`): {} Relaxation order {}; {} + {} Gram \
             blocks matched on the {} monomials of degree ≤ {}.",
            certificate::mode_text(certificate.mode),
            certificate.relaxation_order,
            certificate.lower.len(),
            certificate.upper.len(),
            certificate.targets.len(),
            certificate.target_degree
        ));
        if certificate.mode == Mode::OnRegion {
            docs.push(
                "* **Warning:** with `certificate on region;` the metric is certified positive \
                 semidefinite only on R, so dE/dt = ∇Eᵀ K ∇E ≥ 0 (the free energy never \
                 decreasing) is certified only on R, not for states outside it."
                    .to_string(),
            );
        }
    }
    if let Some(classical) = &system.classical {
        const SHOWN: usize = 8;
        let mut casimirs: Vec<String> = classical
            .casimirs
            .iter()
            .take(SHOWN)
            .map(|c| format!("`{}`", c.display(names)))
            .collect();
        if classical.casimirs.len() > SHOWN {
            casimirs.push(format!("… ({} in all)", classical.casimirs.len()));
        }
        docs.push(format!(
            "* Classical (GENERIC) form (`CLASSICAL`): S is a Casimir of Π (Π∇S ≡ 0) and \
             K∇H ≡ 0, so H is conserved and S produced. Casimirs of Π in the entropy \
             basis: {}; {} independent constraints on ψ, {} on θ.",
            casimirs.join(", "),
            classical.entropy_constraints.len(),
            classical.metric_constraints.len()
        ));
    }
    docs
}

fn matrix_text(entries: &[Polynomial], n: usize, names: &[String]) -> String {
    let rows: Vec<String> = (0..n)
        .map(|i| {
            let row: Vec<String> = (0..n)
                .map(|j| entries[i * n + j].display(names).to_string())
                .collect();
            format!("[{}]", row.join(", "))
        })
        .collect();
    format!("[{}]", rows.join(", "))
}
