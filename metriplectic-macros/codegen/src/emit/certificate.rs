//! The region certificate and the classical constraints as named constants
//! with docs, in the module `tables` inside the hidden evaluation module, so
//! that `cargo expand` shows each table with what it means; the trait impl
//! refers to them (`REGION_CERTIFICATE`, `CLASSICAL`).
//!
//! `tables` is a module of its own so that its constants are not in scope
//! where state variables are bound: a state variable named like one of them
//! would otherwise be a pattern matching that constant.

use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use super::literals::{doc, rational};
use super::tables::exponents;
use crate::analysis::{Block, CertificateModel, ClassicalModel, RegionModel, System};
use crate::parse::Mode;
use crate::polynomial::Rational;

/// The name of the nested module.
pub fn module_name() -> Ident {
    format_ident!("tables")
}

/// `tables { … }` inside the evaluation module, or nothing if the system
/// declares neither a region nor the classical form.
pub fn tables_module(system: &System) -> TokenStream {
    if system.certificate.is_none() && system.classical.is_none() {
        return TokenStream::new();
    }
    let module = module_name();
    let certificate = system
        .certificate
        .as_ref()
        .map(|c| certificate_consts(c, system))
        .unwrap_or_default();
    let classical = system
        .classical
        .as_ref()
        .map(|c| classical_consts(c, system))
        .unwrap_or_default();
    let doc = doc(
        "The region certificate and classical tables, as named constants \
         (`MetriplecticSystem::REGION_CERTIFICATE` and `CLASSICAL` refer to them).",
    );
    quote! {
        #doc
        pub(super) mod #module {
            #certificate
            #classical
        }
    }
}

/// The trait's `REGION_CERTIFICATE` and `CLASSICAL`, for what is declared.
pub fn trait_consts(system: &System, evaluation: &Ident) -> TokenStream {
    let module = module_name();
    let mut out = TokenStream::new();
    if system.certificate.is_some() {
        out.extend(quote! {
            /// The metric certificate on the declared region (`tables::REGION_CERTIFICATE`).
            const REGION_CERTIFICATE: ::core::option::Option<::metriplectic_runtime::RegionCertificate> =
                ::core::option::Option::Some(#evaluation::#module::REGION_CERTIFICATE);
        });
    }
    if system.classical.is_some() {
        out.extend(quote! {
            /// The classical (GENERIC) constraints (`tables::CLASSICAL`).
            const CLASSICAL: ::core::option::Option<::metriplectic_runtime::Classical> =
                ::core::option::Option::Some(#evaluation::#module::CLASSICAL);
        });
    }
    out
}

/// `g₁`, `g₂`, … (1-based, as in the docs).
fn constraint_name(k: usize) -> String {
    format!("g{}", subscript(k + 1))
}

/// `12` as `₁₂`.
fn subscript(k: usize) -> String {
    const DIGITS: [char; 10] = ['₀', '₁', '₂', '₃', '₄', '₅', '₆', '₇', '₈', '₉'];
    k.to_string()
        .chars()
        .map(|c| c.to_digit(10).map_or(c, |d| DIGITS[d as usize]))
        .collect()
}

fn block_ident(side: &str, block: &Block) -> Ident {
    match block.constraint {
        None => format_ident!("{side}_SOS"),
        Some(k) => format_ident!("{side}_G{}", k + 1),
    }
}

fn monomials_text(count: usize, degree: u32) -> String {
    if count == 1 {
        format!("the monomial of degree {degree}")
    } else {
        format!("the {count} monomials of degree ≤ {degree}")
    }
}

fn certificate_consts(certificate: &CertificateModel, system: &System) -> TokenStream {
    let names = &system.state_names;
    let n = names.len();
    let metric_len = system.bases.metric_len;
    let targets = exponents(&certificate.targets);
    let targets_doc = doc(if certificate.targets.len() == metric_len {
        format!(
            "Target monomials: the metric basis, {}, graded lexicographic; the blocks match θ \
             on them.",
            monomials_text(metric_len, system.bases.metric_degree)
        )
    } else {
        format!(
            "Target monomials: {}, graded lexicographic. The first {metric_len} (degree ≤ {}) \
             are the metric basis, matched to θ; the coefficients of the others must cancel.",
            monomials_text(certificate.targets.len(), certificate.target_degree),
            system.bases.metric_degree
        )
    });
    let mut items = vec![quote! {
        #targets_doc
        const REGION_TARGETS: &[&[u32]] = #targets;
    }];
    let mut sides: Vec<Vec<Ident>> = Vec::new();
    for (side, what, blocks) in [
        ("LOWER", "K(x)", &certificate.lower),
        ("UPPER", "ηI − K(x)", &certificate.upper),
    ] {
        let mut idents = Vec::new();
        for (i, block) in blocks.iter().enumerate() {
            let ident = block_ident(side, block);
            let basis = monomials_text(block.exponents.len(), block.degree);
            let text = match block.constraint {
                None => format!(
                    "{what}, block {} of {}: Z(x)ᵀQZ(x), Z(x) = I{} ⊗ m(x), m(x) {basis}; no \
                     multiplier.",
                    i + 1,
                    blocks.len(),
                    subscript(n),
                ),
                Some(k) => format!(
                    "{what}, block {} of {}: {g}(x)·Z(x)ᵀQZ(x), {g}(x) = `{}` ≥ 0 on the region, \
                     Z(x) = I{} ⊗ m(x), m(x) {basis}.",
                    i + 1,
                    blocks.len(),
                    certificate
                        .constraints
                        .get(k)
                        .map(|g| g.display(names).to_string())
                        .unwrap_or_default(),
                    subscript(n),
                    g = constraint_name(k),
                ),
            };
            let doc = doc(text);
            let value = gram_block(block);
            items.push(quote! {
                #doc
                const #ident: ::metriplectic_runtime::GramBlock = #value;
            });
            idents.push(ident);
        }
        sides.push(idents);
    }
    let (lower, upper) = (&sides[0], &sides[1]);
    let region = region(&certificate.region);
    let mode = match certificate.mode {
        Mode::GlobalLowerBound => quote!(::metriplectic_runtime::CertificateMode::GlobalLowerBound),
        Mode::OnRegion => quote!(::metriplectic_runtime::CertificateMode::OnRegion),
    };
    let order = Literal::u32_unsuffixed(certificate.relaxation_order);
    let certificate_doc = doc(format!(
        "The metric certificate on {}: {}",
        certificate.region.describe(names),
        mode_text(certificate.mode)
    ));
    items.push(quote! {
        #certificate_doc
        pub(in super::super) const REGION_CERTIFICATE: ::metriplectic_runtime::RegionCertificate =
            ::metriplectic_runtime::RegionCertificate {
                region: #region,
                mode: #mode,
                relaxation_order: #order,
                targets: REGION_TARGETS,
                lower: &[#(#lower),*],
                upper: &[#(#upper),*],
            };
    });
    quote!(#(#items)*)
}

/// What a mode certifies where, for the docs.
pub fn mode_text(mode: Mode) -> &'static str {
    match mode {
        Mode::GlobalLowerBound => {
            "K(x) ⪰ 0 for every x (a sum of squares) and K(x) ⪯ ηI on the region (S-procedure)."
        }
        Mode::OnRegion => {
            "0 ⪯ K(x) ⪯ ηI on the region only (S-procedure): dE/dt ≥ 0 is certified only for \
             states in the region."
        }
    }
}

fn floats(values: &[Rational]) -> TokenStream {
    let values = values.iter().map(|&v| rational(v));
    quote!(&[#(#values),*])
}

fn region(region: &RegionModel) -> TokenStream {
    match region {
        RegionModel::Ball { center, radius } => {
            let (center, radius) = (floats(center), rational(*radius));
            quote!(::metriplectic_runtime::Region::Ball { center: #center, radius: #radius })
        }
        RegionModel::Box { lower, upper } => {
            let (lower, upper) = (floats(lower), floats(upper));
            quote!(::metriplectic_runtime::Region::Box { lower: #lower, upper: #upper })
        }
    }
}

fn gram_block(block: &Block) -> TokenStream {
    let multiplier = block.multiplier.iter().map(|(c, e)| {
        let c = rational(*c);
        let e = e.iter().map(|&k| Literal::u32_unsuffixed(k));
        quote!((#c, &[#(#e),*]))
    });
    let basis = exponents(&block.exponents);
    let rows = block.matching.iter().map(|entries| {
        let entries = entries.iter().map(|&(b, g, c)| {
            let (b, g) = (Literal::usize_unsuffixed(b), Literal::usize_unsuffixed(g));
            let c = rational(c);
            quote!((#b, #g, #c))
        });
        quote!(&[#(#entries),*])
    });
    quote! {
        ::metriplectic_runtime::GramBlock {
            multiplier: &[#(#multiplier),*],
            exponents: #basis,
            matching: &[#(#rows),*],
        }
    }
}

fn linear_forms(forms: &[Vec<(usize, Rational)>]) -> TokenStream {
    let forms = forms.iter().map(|form| {
        let entries = form.iter().map(|&(i, c)| {
            let i = Literal::usize_unsuffixed(i);
            let c = rational(c);
            quote!((#i, #c))
        });
        quote!(&[#(#entries),*])
    });
    quote!(&[#(#forms),*])
}

fn classical_consts(classical: &ClassicalModel, system: &System) -> TokenStream {
    let names = &system.state_names;
    let entropy = linear_forms(&classical.entropy_constraints);
    let basis = linear_forms(&classical.casimir_basis);
    let metric = linear_forms(&classical.metric_constraints);
    let entropy_doc = doc(format!(
        "The {} independent rows of C_S ψ = 0 (Π(x)J(x)ᵀψ ≡ 0: S is a Casimir of Π), each a \
         sparse linear form (index into ψ, coefficient) scaled to max |c| = 1.",
        classical.entropy_constraints.len()
    ));
    let casimirs: Vec<String> = classical
        .casimirs
        .iter()
        .map(|c| format!("`{}`", c.display(names)))
        .collect();
    let basis_doc = doc(format!(
        "A basis of the polynomial Casimirs of Π in the entropy basis, as ψ vectors: {}.",
        casimirs.join(", ")
    ));
    let metric_doc = doc(format!(
        "The {} independent rows of C_K θ = 0 (K(x)∇H(x) ≡ 0), each a sparse linear form (index \
         into θ, coefficient) scaled to max |c| = 1.",
        classical.metric_constraints.len()
    ));
    quote! {
        #entropy_doc
        const ENTROPY_CONSTRAINTS: &[::metriplectic_runtime::LinearForm] = #entropy;
        #basis_doc
        const CASIMIR_BASIS: &[::metriplectic_runtime::LinearForm] = #basis;
        #metric_doc
        const METRIC_CONSTRAINTS: &[::metriplectic_runtime::LinearForm] = #metric;
        /// The classical (GENERIC) form: S a Casimir of Π, K degenerate along ∇H.
        pub(in super::super) const CLASSICAL: ::metriplectic_runtime::Classical = ::metriplectic_runtime::Classical {
            entropy_constraints: ENTROPY_CONSTRAINTS,
            casimir_basis: CASIMIR_BASIS,
            metric_constraints: METRIC_CONSTRAINTS,
        };
    }
}
