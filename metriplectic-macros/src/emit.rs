//! Code generation: an analysed system → readable Rust.
//!
//! The generated code is meant to be read under `cargo expand`: the known
//! parts (H, ∇H, Π) are short analytic expressions; monomials are computed in
//! graded-lex order, each as its parent monomial times one variable (one
//! multiplication per monomial, powers shared), and each function computes
//! only the degrees it reads (the metric stops at the metric degree, the
//! entropy's derivatives at r − 1); the entropy Jacobian is one
//! multiplication of an already computed monomial per non-zero entry and the
//! entropy gradient is straight-line sums per variable; the assembly
//! functions are short loops over compile-time tables.

use std::collections::{HashMap, HashSet};

use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{format_ident, quote};

use crate::analysis::System;
use crate::monomials;
use crate::polynomial::{Polynomial, Rational};

/// An `f64` literal with a separate minus sign (negative literals do not
/// round-trip through token streams).
fn float(value: f64) -> TokenStream {
    let literal = Literal::f64_unsuffixed(value.abs());
    if value.is_sign_negative() && value != 0.0 {
        quote!(-#literal)
    } else {
        quote!(#literal)
    }
}

fn rational(value: Rational) -> TokenStream {
    float(value.to_f64())
}

fn usize_lit(value: usize) -> Literal {
    Literal::usize_unsuffixed(value)
}

fn doc(text: impl AsRef<str>) -> TokenStream {
    let text = format!(" {}", text.as_ref());
    quote!(#[doc = #text])
}

/// A polynomial as a Rust expression over the state variables.
fn expression(poly: &Polynomial, state: &[Ident]) -> TokenStream {
    if poly.is_zero() {
        return quote!(0.0);
    }
    let mut terms: Vec<_> = poly.terms().collect();
    terms.sort_by(|(a, _), (b, _)| monomials::graded_lex_cmp(a, b));
    let mut out = TokenStream::new();
    for (i, (exponents, coefficient)) in terms.into_iter().enumerate() {
        let negative = coefficient.numerator() < 0;
        let magnitude = coefficient.to_f64().abs();
        let mut factors: Vec<TokenStream> = Vec::new();
        for (var, &k) in state.iter().zip(exponents.iter()) {
            match k {
                0 => {}
                1 => factors.push(quote!(#var)),
                2 => factors.push(quote!(#var * #var)),
                _ => {
                    let k = Literal::i32_unsuffixed(k as i32);
                    factors.push(quote!(#var.powi(#k)));
                }
            }
        }
        let body = if factors.is_empty() {
            float(magnitude)
        } else if magnitude == 1.0 {
            join_product(&factors)
        } else {
            let m = float(magnitude);
            let product = join_product(&factors);
            quote!(#m * #product)
        };
        out.extend(match (i, negative) {
            (0, false) => body,
            (0, true) => quote!(-#body),
            (_, false) => quote!(+ #body),
            (_, true) => quote!(- #body),
        });
    }
    out
}

/// A polynomial as an array element: parenthesised unless it is a number or
/// a lone (possibly negated) variable, because clippy's
/// `possible_missing_comma` misreads binary expressions in macro-generated arrays.
fn array_entry(poly: &Polynomial, state: &[Ident]) -> TokenStream {
    let simple = poly.term_count() <= 1
        && poly.terms().all(|(e, c)| {
            let degree: u32 = e.iter().sum();
            degree == 0 || (degree == 1 && c.to_f64().abs() == 1.0)
        });
    let expr = expression(poly, state);
    if simple {
        expr
    } else {
        quote!((#expr))
    }
}

fn join_product(factors: &[TokenStream]) -> TokenStream {
    let mut out = TokenStream::new();
    for (i, f) in factors.iter().enumerate() {
        if i > 0 {
            out.extend(quote!(*));
        }
        out.extend(f.clone());
    }
    out
}

/// `let &[q, p] = x else { panic!(…) };` with `_` for unused variables.
fn destructure(system: &System, used: &[bool]) -> TokenStream {
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
        system.name,
        system.state_names.join(", ")
    );
    quote! {
        let &[#(#pattern),*] = x else {
            panic!(#message, x.len())
        };
    }
}

fn uses(polys: &[&Polynomial], n: usize) -> Vec<bool> {
    (0..n)
        .map(|j| polys.iter().any(|p| p.uses_variable(j)))
        .collect()
}

/// Names of the local bindings of the monomials: `q2_p` for q²p when these
/// are distinct valid identifiers unlike any state variable, else
/// `monomial_17`-style names.
fn monomial_names(system: &System) -> Vec<Ident> {
    let names = &system.state_names;
    let readable: Vec<String> = system
        .monomials
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
    // Degree-1 monomials are the state variables themselves.
    let ok = readable
        .iter()
        .zip(&system.monomials)
        .skip(1)
        .all(|(name, e)| {
            let degree: u32 = e.iter().sum();
            (degree == 1
                || (!states.contains(name.as_str()) && syn::parse_str::<Ident>(name).is_ok()))
                && seen.insert(name.clone())
        });
    let mut fallback_prefix = "monomial_".to_string();
    while names.iter().any(|n| n.starts_with(&fallback_prefix)) {
        fallback_prefix.push('_');
    }
    system
        .monomials
        .iter()
        .enumerate()
        .map(|(i, e)| {
            let degree: u32 = e.iter().sum();
            if degree == 1 {
                let j = e.iter().position(|&k| k == 1).unwrap_or(0);
                system.state[j].clone()
            } else if ok && i > 0 {
                Ident::new(&readable[i], Span::call_site())
            } else {
                format_ident!("{}{}", fallback_prefix, i)
            }
        })
        .collect()
}

/// The body of a function returning the monomials of degree ≤ `max_degree`
/// (a prefix of the graded-lex basis) at `x`, and its length.
///
/// One `let (..) = (..);` per degree: thousands of separate `let`s nest
/// thousands of scopes, which overflows rustc's stack (measured: 3003 lets).
fn monomial_body(
    system: &System,
    binding: &[Ident],
    index: &HashMap<&[u32], usize>,
    max_degree: u32,
) -> (TokenStream, usize) {
    let count = system
        .monomials
        .iter()
        .take_while(|e| e.iter().sum::<u32>() <= max_degree)
        .count();
    let mut lets = Vec::new();
    for degree in 2..=max_degree {
        let mut names = Vec::new();
        let mut products = Vec::new();
        for (i, e) in system.monomials[..count].iter().enumerate() {
            if e.iter().sum::<u32>() != degree {
                continue;
            }
            let Some((parent, j)) = monomials::parent(e) else {
                continue;
            };
            let parent_name = &binding[index[parent.as_slice()]];
            let var = &system.state[j];
            names.push(&binding[i]);
            products.push(quote!(#parent_name * #var));
        }
        // A tuple, not an array: clippy's `possible_missing_comma` misreads
        // products inside macro-generated arrays.
        lets.push(quote!(let (#(#names,)*) = (#(#products,)*);));
    }
    let values = system.monomials[..count].iter().enumerate().map(|(i, e)| {
        if e.iter().all(|&k| k == 0) {
            quote!(1.0)
        } else {
            let b = &binding[i];
            quote!(#b)
        }
    });
    // Degree 0 alone reads no variable; from degree 1 on, every one.
    let used = vec![max_degree > 0; system.state.len()];
    let destructure = destructure(system, &used);
    (
        quote! {
            #destructure
            #(#lets)*
            [#(#values),*]
        },
        count,
    )
}

/// Sums of at most this many terms per statement: long chains of `+` nest
/// as deeply as they are long in rustc's expression tree.
const TERMS_PER_SUM: usize = 16;

fn exponent_table(rows: &[Vec<u32>]) -> TokenStream {
    let rows = rows.iter().map(|e| {
        let entries = e.iter().map(|&k| Literal::u32_unsuffixed(k));
        quote!(&[#(#entries),*])
    });
    quote!(&[#(#rows),*])
}

fn matching_table(table: &[Vec<(usize, usize)>]) -> TokenStream {
    let rows = table.iter().map(|pairs| {
        let pairs = pairs.iter().map(|&(b, g)| {
            let (b, g) = (
                Literal::u16_unsuffixed(b as u16),
                Literal::u16_unsuffixed(g as u16),
            );
            quote!((#b, #g))
        });
        quote!(&[#(#pairs),*])
    });
    quote!(&[#(#rows),*])
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

/// The generated items for an analysed system.
pub fn emit(system: &System) -> TokenStream {
    let name = &system.name;
    let vis = &system.vis;
    let attrs = &system.attrs;
    let names = &system.state_names;
    let state = &system.state;
    let n = state.len();
    let p = system.entropy_len;
    let m = system.metric_len;
    let d = system.monomials.len();
    let pairs = n * (n + 1) / 2;
    let name_str = name.to_string();

    let n_lit = usize_lit(n);
    let p_lit = usize_lit(p);
    let m_lit = usize_lit(m);
    let d_lit = usize_lit(d);
    let nn_lit = usize_lit(n * n);
    let np_lit = usize_lit(n * p);
    let r_lit = Literal::u32_unsuffixed(system.entropy_degree);
    let s_lit = Literal::u32_unsuffixed(system.metric_degree);
    let entropy_end = usize_lit(p + 1);

    // ---- struct docs -------------------------------------------------------
    let mut struct_docs = vec![
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
        struct_docs.push(format!("* Constant `{c}` = {value}."));
    }
    struct_docs.extend([
        format!(
            "* Entropy basis: the {p} monomials of degree 1..={} (graded lexicographic, no constant).",
            system.entropy_degree
        ),
        format!(
            "* Metric basis: the {m} monomials of degree 0..={} per entry, {} coefficients θ in all.",
            system.metric_degree,
            pairs * m
        ),
        format!(
            "* SOS certificate: full half-degree basis of {} monomials; facially reduced to the constant monomial.",
            system.sos_full.len()
        ),
    ]);
    if let Some(reference) = &system.reference {
        struct_docs.push(format!(
            "* Reference entropy S(x) = `{}`.",
            reference.entropy.display(names)
        ));
        struct_docs.push(format!(
            "* Reference metric K(x) = `{}`.",
            matrix_text(&reference.metric, n, names)
        ));
    }
    let struct_docs = struct_docs.iter().map(doc);

    // ---- monomials ---------------------------------------------------------
    let binding = monomial_names(system);
    let index = monomials::index_of(&system.monomials);
    let max_degree = system.entropy_degree.max(system.metric_degree);
    let (monomials_body, _) = monomial_body(system, &binding, &index, max_degree);
    let (metric_monomials_body, _) = monomial_body(system, &binding, &index, system.metric_degree);
    // The entropy's derivatives only read monomials of degree < r.
    let derivative_degree = system.entropy_degree.saturating_sub(1);
    let (derivative_body, derivative_len) =
        monomial_body(system, &binding, &index, derivative_degree);
    let derivative_lit = usize_lit(derivative_len);
    let monomials_doc = [
        format!(
            "All {d} monomials of degree ≤ {} at `x`, graded lexicographic, starting with 1.",
            system.entropy_degree.max(system.metric_degree)
        ),
        String::new(),
        format!(
            "The entropy features are entries `1..={p}`, the metric features entries `..{m}`. \
             Each monomial is its parent (itself divided by its first variable) times one variable."
        ),
        String::new(),
        "# Panics".to_string(),
        String::new(),
        format!("If `x.len() != {n}`."),
    ]
    .map(doc);

    // ---- entropy Jacobian --------------------------------------------------
    let mut jacobian_terms = Vec::new();
    let mut jacobian_writes = Vec::new();
    for (row, e) in system.monomials[1..=p].iter().enumerate() {
        for (j, &k) in e.iter().enumerate() {
            if k == 0 {
                continue;
            }
            let mut lower = e.clone();
            lower[j] -= 1;
            let source = index[lower.as_slice()];
            let at = usize_lit(row * n + j);
            let src = usize_lit(source);
            jacobian_writes.push(if k == 1 {
                quote!(jacobian[#at] = all[#src];)
            } else {
                let c = float(f64::from(k));
                quote!(jacobian[#at] = #c * all[#src];)
            });
            let (row_lit, j_lit, src_lit) = (
                Literal::u32_unsuffixed(row as u32),
                Literal::u32_unsuffixed(j as u32),
                Literal::u32_unsuffixed(source as u32),
            );
            let k_lit = Literal::u32_unsuffixed(k);
            jacobian_terms.push(quote!((#row_lit, #j_lit, #k_lit, #src_lit)));
        }
    }
    // ∇S = J(x)ᵀψ, one sum per variable j of ψ_k · α_kj · x^(α_k − e_j),
    // in chunks of `TERMS_PER_SUM` terms.
    let mut gradient_terms: Vec<Vec<TokenStream>> = vec![Vec::new(); n];
    for (row, e) in system.monomials[1..=p].iter().enumerate() {
        for (j, &k) in e.iter().enumerate() {
            if k == 0 {
                continue;
            }
            let mut lower = e.clone();
            lower[j] -= 1;
            let source = index[lower.as_slice()];
            let feature = usize_lit(row);
            let derivative = if source == 0 {
                quote!(psi[#feature])
            } else {
                let src = usize_lit(source);
                quote!(psi[#feature] * all[#src])
            };
            gradient_terms[j].push(if k == 1 {
                derivative
            } else {
                let c = float(f64::from(k));
                quote!(#c * #derivative)
            });
        }
    }
    let gradient_sums = gradient_terms.iter().enumerate().map(|(j, terms)| {
        let j = usize_lit(j);
        let chunks = terms.chunks(TERMS_PER_SUM).map(|chunk| {
            let mut sum = TokenStream::new();
            for (i, term) in chunk.iter().enumerate() {
                if i > 0 {
                    sum.extend(quote!(+));
                }
                sum.extend(term.clone());
            }
            quote!(gradient[#j] += #sum;)
        });
        quote!(#(#chunks)*)
    });
    let metric_monomials_doc = [
        format!(
            "The {m} metric monomials φ_s of degree ≤ {} at `x` (`Self::monomials(x)[..{m}]`), \
             computed like [`Self::monomials`] but stopping at the metric degree.",
            system.metric_degree
        ),
        String::new(),
        "# Panics".to_string(),
        String::new(),
        format!("If `x.len() != {n}`."),
    ]
    .map(doc);
    let derivative_monomials_doc = [
        format!(
            "The {derivative_len} monomials of degree ≤ {derivative_degree} at `x` \
             (`Self::monomials(x)[..{derivative_len}]`): all that the entropy's derivatives read, \
             see [`Self::ENTROPY_JACOBIAN_TERMS`]."
        ),
        String::new(),
        "# Panics".to_string(),
        String::new(),
        format!("If `x.len() != {n}`."),
    ]
    .map(doc);
    let jacobian_terms_doc = [
        "The non-zero entries of the entropy Jacobian, as",
        "`(feature k, variable j, exponent α_kj, monomial index of x^(α_k − e_j))`:",
        "∂φ_k/∂x_j = α_kj · `Self::monomials(x)[index]`, where `index` is also within",
        "[`Self::entropy_derivative_monomials`] (degree < r).",
    ]
    .map(doc);

    // ---- H, ∇H, Π ----------------------------------------------------------
    let h_used = uses(&[&system.hamiltonian], n);
    let h_destructure = destructure(system, &h_used);
    let h_expr = expression(&system.hamiltonian, state);
    let grad_refs: Vec<&Polynomial> = system.hamiltonian_gradient.iter().collect();
    let grad_destructure = destructure(system, &uses(&grad_refs, n));
    let grad_exprs = system
        .hamiltonian_gradient
        .iter()
        .map(|g| array_entry(g, state));
    let poisson_refs: Vec<&Polynomial> = system.poisson.iter().collect();
    let poisson_destructure = destructure(system, &uses(&poisson_refs, n));
    let poisson_exprs = system.poisson.iter().map(|e| array_entry(e, state));

    // ---- reference ---------------------------------------------------------
    let (reference_entropy, reference_metric, reference_fn) = match &system.reference {
        Some(reference) => {
            let psi = reference.psi.iter().map(|&c| rational(c));
            let theta = reference.theta.iter().map(|&c| rational(c));
            let dropped = format!(
                "Entropy coefficients ψ of the declared reference model; its constant term ({}) is dropped.",
                reference.dropped_constant
            );
            let dropped = doc(dropped);
            (
                quote!(#dropped const REFERENCE_ENTROPY: ::core::option::Option<&'static [f64]> = ::core::option::Option::Some(&[#(#psi),*]);),
                quote!(
                    /// Metric coefficients θ of the declared reference model.
                    const REFERENCE_METRIC: ::core::option::Option<&'static [f64]> = ::core::option::Option::Some(&[#(#theta),*]);
                ),
                quote!(
                    /// The reference model declared in the `reference { … }` section.
                    pub fn reference_model(
                    ) -> ::metriplectic_runtime::Result<::metriplectic_runtime::Model<Self>>
                    {
                        ::metriplectic_runtime::Model::<Self>::reference()
                    }
                ),
            )
        }
        None => (
            quote!(
                /// No reference model is declared.
                const REFERENCE_ENTROPY: ::core::option::Option<&'static [f64]> =
                    ::core::option::Option::None;
            ),
            quote!(
                /// No reference model is declared.
                const REFERENCE_METRIC: ::core::option::Option<&'static [f64]> =
                    ::core::option::Option::None;
            ),
            TokenStream::new(),
        ),
    };

    let state_names = names.iter();
    let entropy_exponents = exponent_table(&system.monomials[1..=p]);
    let metric_exponents = exponent_table(&system.monomials[..m]);
    let sos_full_exponents = exponent_table(&system.sos_full);
    let sos_full_matching = matching_table(&system.sos_full_matching);
    let sos_reduced_exponents = exponent_table(&[vec![0; n]]);
    let sos_reduced_matching = matching_table(&system.sos_reduced_matching);
    let len_message =
        |what: &str, len: &str| format!("{name_str}: {what} must have length {len}, got {{}}");
    let jacobian_message = len_message("the entropy Jacobian", &(n * p).to_string());
    let psi_message = len_message("the entropy coefficients", &p.to_string());
    let theta_message = len_message("the metric coefficients", &(pairs * m).to_string());
    let metric_message = len_message("the metric", &(n * n).to_string());
    let gradient_message = len_message("the gradient", &n.to_string());
    let theta_len = usize_lit(pairs * m);

    quote! {
        #(#attrs)*
        #(#struct_docs)*
        #[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
        #vis struct #name;

        impl #name {
            /// Number of monomials of degree ≤ max(entropy degree, metric degree),
            /// the length of [`Self::monomials`].
            pub const MONOMIAL_COUNT: usize = #d_lit;

            #(#jacobian_terms_doc)*
            pub const ENTROPY_JACOBIAN_TERMS: &'static [(u32, u32, u32, u32)] = &[#(#jacobian_terms),*];

            #(#monomials_doc)*
            pub fn monomials(x: &[f64]) -> [f64; #d_lit] {
                #monomials_body
            }

            #(#metric_monomials_doc)*
            pub fn metric_monomials(x: &[f64]) -> [f64; #m_lit] {
                #metric_monomials_body
            }

            #(#derivative_monomials_doc)*
            pub fn entropy_derivative_monomials(x: &[f64]) -> [f64; #derivative_lit] {
                #derivative_body
            }

            #reference_fn
        }

        impl ::metriplectic_runtime::MetriplecticSystem for #name {
            const NAME: &'static str = #name_str;
            const DIM: usize = #n_lit;
            const STATE_NAMES: &'static [&'static str] = &[#(#state_names),*];
            const ENTROPY_DEGREE: u32 = #r_lit;
            const METRIC_DEGREE: u32 = #s_lit;
            /// Exponents of the entropy monomials φ_r (degree 1..=r, graded lexicographic).
            const ENTROPY_EXPONENTS: &'static [&'static [u32]] = #entropy_exponents;
            /// Exponents of the metric monomials φ_s (degree 0..=s, graded lexicographic).
            const METRIC_EXPONENTS: &'static [&'static [u32]] = #metric_exponents;
            /// SOS tables over the full half-degree basis (degree ≤ s/2):
            /// `matching[α]` lists the Gram pairs (β, γ) with β + γ = α.
            const SOS_FULL: ::metriplectic_runtime::SosTables = ::metriplectic_runtime::SosTables {
                exponents: #sos_full_exponents,
                matching: #sos_full_matching,
            };
            /// SOS tables after facial reduction. For the two-sided global
            /// certificate 0 ⪯ K(x) ⪯ ηI the Gram matrices of K and ηI − K sum
            /// to a constant, which forces the row of every non-constant
            /// monomial to zero in both: the basis is the constant monomial,
            /// only the constant metric coefficient is matched (by the pair
            /// (0, 0)) and every other metric coefficient is forced to zero.
            const SOS_REDUCED: ::metriplectic_runtime::SosTables = ::metriplectic_runtime::SosTables {
                exponents: #sos_reduced_exponents,
                matching: #sos_reduced_matching,
            };
            #reference_entropy
            #reference_metric

            fn hamiltonian(x: &[f64]) -> f64 {
                #h_destructure
                #h_expr
            }

            fn hamiltonian_gradient(x: &[f64], grad: &mut [f64]) {
                let value: [f64; #n_lit] = {
                    #grad_destructure
                    [#(#grad_exprs),*]
                };
                grad.copy_from_slice(&value);
            }

            fn poisson(x: &[f64], poisson: &mut [f64]) {
                let value: [f64; #nn_lit] = {
                    #poisson_destructure
                    [#(#poisson_exprs),*]
                };
                poisson.copy_from_slice(&value);
            }

            const ENTROPY_JACOBIAN: &'static [(u32, u32, u32, u32)] = Self::ENTROPY_JACOBIAN_TERMS;

            fn monomials(x: &[f64], out: &mut [f64]) {
                let all = Self::monomials(x);
                let len = out.len();
                out.copy_from_slice(&all[..len]);
            }

            fn entropy_features(x: &[f64], features: &mut [f64]) {
                features.copy_from_slice(&Self::monomials(x)[1..#entropy_end]);
            }

            fn entropy_jacobian(x: &[f64], jacobian: &mut [f64]) {
                let all = Self::entropy_derivative_monomials(x);
                let length = jacobian.len();
                let jacobian: &mut [f64; #np_lit] = jacobian
                    .try_into()
                    .unwrap_or_else(|_| panic!(#jacobian_message, length));
                jacobian.fill(0.0);
                #(#jacobian_writes)*
            }

            fn metric_features(x: &[f64], features: &mut [f64]) {
                features.copy_from_slice(&Self::metric_monomials(x));
            }

            fn entropy_value(x: &[f64], coefficients: &[f64]) -> f64 {
                assert_eq!(coefficients.len(), #p_lit, #psi_message, coefficients.len());
                let all = Self::monomials(x);
                all[1..#entropy_end]
                    .iter()
                    .zip(coefficients)
                    .map(|(feature, coefficient)| feature * coefficient)
                    .sum()
            }

            fn entropy_gradient(x: &[f64], coefficients: &[f64], grad: &mut [f64]) {
                assert_eq!(coefficients.len(), #p_lit, #psi_message, coefficients.len());
                assert_eq!(grad.len(), #n_lit, #gradient_message, grad.len());
                let psi: &[f64; #p_lit] = coefficients
                    .try_into()
                    .unwrap_or_else(|_| panic!(#psi_message, coefficients.len()));
                let all = Self::entropy_derivative_monomials(x);
                let mut gradient = [0.0; #n_lit];
                #(#gradient_sums)*
                grad.copy_from_slice(&gradient);
            }

            fn metric_value(x: &[f64], coefficients: &[f64], metric: &mut [f64]) {
                assert_eq!(coefficients.len(), #theta_len, #theta_message, coefficients.len());
                assert_eq!(metric.len(), #nn_lit, #metric_message, metric.len());
                let features = Self::metric_monomials(x);
                for row in 0..#n_lit {
                    for column in row..#n_lit {
                        let pair: usize = row * #n_lit - row * (row as usize).saturating_sub(1) / 2 + (column - row);
                        let theta = &coefficients[pair * #m_lit..(pair + 1) * #m_lit];
                        let value: f64 = theta.iter().zip(&features).map(|(t, f)| t * f).sum();
                        metric[row * #n_lit + column] = value;
                        metric[column * #n_lit + row] = value;
                    }
                }
            }

            fn entropy_block(x: &[f64], metric: &[f64], block: &mut [f64], drift: &mut [f64]) {
                assert_eq!(metric.len(), #nn_lit, #metric_message, metric.len());
                assert_eq!(block.len(), #np_lit, "{}: the entropy block must have length {}, got {}", #name_str, #np_lit, block.len());
                assert_eq!(drift.len(), #n_lit, "{}: the drift must have length {}, got {}", #name_str, #n_lit, drift.len());
                // M = Π(x) + K(x)
                let mut operator = [0.0; #nn_lit];
                Self::poisson(x, &mut operator);
                for (entry, k) in operator.iter_mut().zip(metric) {
                    *entry += k;
                }
                let mut grad_h = [0.0; #n_lit];
                Self::hamiltonian_gradient(x, &mut grad_h);
                for (row, out) in drift.iter_mut().enumerate() {
                    *out = (0..#n_lit).map(|l| operator[row * #n_lit + l] * grad_h[l]).sum();
                }
                // block = M J(x)ᵀ, one sparse Jacobian entry at a time.
                let all = Self::entropy_derivative_monomials(x);
                block.fill(0.0);
                for &(feature, variable, exponent, lower) in Self::ENTROPY_JACOBIAN_TERMS {
                    let derivative = f64::from(exponent) * all[lower as usize];
                    for row in 0..#n_lit {
                        block[row * #p_lit + feature as usize] +=
                            operator[row * #n_lit + variable as usize] * derivative;
                    }
                }
            }

            fn metric_block(x: &[f64], gradient: &[f64], block: &mut [f64], drift: &mut [f64]) {
                assert_eq!(gradient.len(), #n_lit, #gradient_message, gradient.len());
                assert_eq!(block.len(), #n_lit * #theta_len, "{}: the metric block must have length {}, got {}", #name_str, #n_lit * #theta_len, block.len());
                assert_eq!(drift.len(), #n_lit, "{}: the drift must have length {}, got {}", #name_str, #n_lit, drift.len());
                let mut poisson = [0.0; #nn_lit];
                Self::poisson(x, &mut poisson);
                for (row, out) in drift.iter_mut().enumerate() {
                    *out = (0..#n_lit).map(|l| poisson[row * #n_lit + l] * gradient[l]).sum();
                }
                // K(x; θ) g: θ_jk,a multiplies φ_a g_k in row j and φ_a g_j in row k.
                let features = Self::metric_monomials(x);
                block.fill(0.0);
                for row in 0..#n_lit {
                    for column in row..#n_lit {
                        let pair: usize = row * #n_lit - row * (row as usize).saturating_sub(1) / 2 + (column - row);
                        for (a, feature) in features.iter().enumerate() {
                            let coefficient = pair * #m_lit + a;
                            block[row * #theta_len + coefficient] += feature * gradient[column];
                            if row != column {
                                block[column * #theta_len + coefficient] += feature * gradient[row];
                            }
                        }
                    }
                }
            }
        }
    }
}
