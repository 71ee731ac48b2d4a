//! Semantic analysis: syntax tree → exact polynomials, with every check the
//! macro makes.
//!
//! Independent parts are checked independently and all their errors are
//! recorded: the names (`names`), the degrees and basis sizes (`degrees`),
//! Π (`poisson`), H, and the reference model (`reference`, with the exact
//! definiteness check in `definiteness`). Expressions become polynomials in
//! `scope`. A part that depends on a broken one is skipped, not reported
//! again.

mod classical;
mod definiteness;
mod degrees;
mod elimination;
mod names;
mod poisson;
mod reference;
mod region;
mod scope;
mod work;

use proc_macro2::Ident;
use syn::{Attribute, Visibility};

pub use classical::ClassicalModel;
pub use reference::ReferenceModel;
pub use region::{Block, CertificateModel, RegionModel};

use crate::bases::Bases;
use crate::diagnostics::Diagnostics;
use crate::parse::SystemDef;
use crate::polynomial::{Polynomial, Rational};
use scope::{exact, name_of, Context, Scope};

/// A system that passed every check, as exact polynomials and bases.
#[derive(Debug)]
pub struct System {
    /// Outer attributes of the struct (doc comments and others).
    pub attrs: Vec<Attribute>,
    /// Visibility of the struct.
    pub vis: Visibility,
    /// The struct's name.
    pub name: Ident,
    /// State variables as written (raw identifiers keep their `r#`),
    /// spanned at the macro call.
    pub state: Vec<Ident>,
    /// State variable names (raw-identifier prefix removed).
    pub state_names: Vec<String>,
    /// Named constants and their exact values, in declaration order.
    pub consts: Vec<(String, Rational)>,
    /// H(x).
    pub hamiltonian: Polynomial,
    /// ∇H(x).
    pub hamiltonian_gradient: Vec<Polynomial>,
    /// Π(x), row-major.
    pub poisson: Vec<Polynomial>,
    /// The entropy and metric bases and the SOS tables.
    pub bases: Bases,
    /// The reference model, if declared.
    pub reference: Option<ReferenceModel>,
    /// The region certificate, if a region is declared.
    pub certificate: Option<CertificateModel>,
    /// The classical constraints, if declared `classical;`.
    pub classical: Option<ClassicalModel>,
}

/// Checks a parsed system and converts it to exact polynomials and bases.
/// `None` if anything failed (every error is in `diagnostics`) or an earlier
/// stage already failed.
pub fn analyse(def: &SystemDef, diagnostics: &mut Diagnostics) -> Option<System> {
    let errors_before = diagnostics.count();
    let states = def
        .state
        .as_ref()
        .and_then(|decl| names::check_states(decl, diagnostics));
    let nvars = states.as_ref().map(|s| s.names.len());
    // Checked in the usual order of the sections, so that errors read top
    // to bottom.
    let scope = states.as_ref().map(|states| {
        let declared = def.consts.iter().map(|c| name_of(&c.name)).collect();
        let mut scope = Scope::new(&states.names, declared);
        let consts = names::define_consts(&def.consts, &mut scope, diagnostics);
        (scope, consts)
    });

    let poisson = def
        .poisson
        .as_ref()
        .zip(scope.as_ref())
        .and_then(|(matrix, (scope, _))| {
            let poisson = scope.matrix(matrix, "the Poisson tensor Π", diagnostics)?;
            if !poisson::check_skew(&poisson, matrix, scope.state_names(), diagnostics) {
                return None;
            }
            poisson::check_jacobi(&poisson, matrix, scope.state_names(), diagnostics);
            Some(poisson)
        });

    let hamiltonian =
        def.hamiltonian
            .as_ref()
            .zip(scope.as_ref())
            .and_then(|(expr, (scope, _))| {
                let hamiltonian = scope.polynomial(expr, Context::State, diagnostics)?;
                let gradient = (0..scope.nvars())
                    .map(|j| hamiltonian.derivative(j))
                    .collect::<Result<Vec<_>, _>>();
                let gradient = exact(gradient, expr.span(), diagnostics)?;
                Some((hamiltonian, gradient))
            });

    // Degrees do not depend on names: checked even without a valid state.
    let entropy_degree = def
        .entropy_degree
        .and_then(|d| degrees::entropy_degree(d, nvars, diagnostics));
    let metric_degree = def
        .metric_degree
        .and_then(|d| degrees::metric_degree(d, nvars, diagnostics));
    // Without the state, every name would be unknown: nothing else is checkable.
    let (states, (scope, consts)) = (states?, scope?);
    let n = states.names.len();

    let bases = degrees::bases(n, entropy_degree, metric_degree);
    // The region and the certificate's options, in the order written in the
    // docs: region, certificate, relaxation.
    let region = def
        .region
        .as_ref()
        .and_then(|decl| region::check_region(decl, &scope, diagnostics));
    let options = region::options(def, n, diagnostics);
    // Where a state-dependent reference metric is spot-checked.
    let spots = region
        .as_ref()
        .map(|(model, _)| model.spot_points().unwrap_or_default());
    let certificate = match (region, options, bases.as_ref(), def.region.as_ref()) {
        (Some((region, constraints)), Some(options), Some(bases), Some(decl)) => {
            let order = def.relaxation.and_then(|r| r.order);
            region::certificate(
                region,
                constraints,
                options,
                bases,
                n,
                (decl.keyword, order),
                diagnostics,
            )
        }
        _ => None,
    };
    let reference = def.reference.as_ref().map(|reference| {
        reference::check_reference(
            &scope,
            reference,
            entropy_degree,
            metric_degree,
            bases.as_ref(),
            (def.region.is_some(), spots.as_deref().unwrap_or_default()),
            diagnostics,
        )
    });
    let classical = def.classical.and_then(|keyword| {
        let (poisson, (_, gradient), bases) =
            (poisson.as_ref()?, hamiltonian.as_ref()?, bases.as_ref()?);
        let inputs = classical::Inputs {
            poisson,
            hamiltonian_gradient: gradient,
            bases,
            names: &states.names,
            region: def.region.is_some(),
        };
        let model = classical::derive(&inputs, keyword, diagnostics);
        if let (Some(Some(reference)), Some(syntax)) = (&reference, &def.reference) {
            classical::check_reference(&inputs, reference, syntax, keyword, diagnostics);
        }
        model
    });

    if diagnostics.count() > errors_before {
        return None;
    }
    let (hamiltonian, hamiltonian_gradient) = hamiltonian?;
    let reference = match reference {
        Some(model) => Some(model?),
        None => None,
    };
    Some(System {
        attrs: def.attrs.clone(),
        vis: def.vis.clone(),
        name: def.name.clone()?,
        state: states.idents,
        state_names: states.names,
        consts,
        hamiltonian,
        hamiltonian_gradient,
        poisson: poisson?,
        bases: bases?,
        reference,
        certificate,
        classical,
    })
}

#[cfg(test)]
mod tests {
    use proc_macro2::{Delimiter, Group, TokenStream, TokenTree};
    use quote::quote;

    use super::*;

    fn messages(tokens: proc_macro2::TokenStream) -> Vec<String> {
        crate::try_expand(tokens)
            .expect_err("the system is rejected")
            .messages()
    }

    fn message(tokens: proc_macro2::TokenStream) -> String {
        messages(tokens).join("\n")
    }

    #[test]
    fn system_level_checks() {
        let jacobi = message(quote! {
            struct S; state (x, y, z);
            poisson = [[0, 1, -x], [-1, 0, 0], [x, 0, 0]];
            hamiltonian = x^2; entropy degree 2; metric degree 0;
        });
        assert!(
            jacobi.contains("Jacobi identity") && jacobi.contains("(x, y, z)"),
            "{jacobi}"
        );
        let skew = message(quote! {
            struct S; state (q, p);
            poisson = [[0, q], [q, 0]];
            hamiltonian = q^2; entropy degree 2; metric degree 0;
        });
        assert!(skew.contains("write Π[1][0] = `-q`"), "{skew}");
        let odd = message(quote! {
            struct S; state (q, p);
            poisson = [[0, 1], [-1, 0]];
            hamiltonian = q^2; entropy degree 2; metric degree 3;
        });
        assert!(odd.contains("odd"), "{odd}");
        let big = message(quote! {
            struct S; state (a, b, c, d, e, f, g, h);
            poisson = [[0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0],
                       [0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0]];
            hamiltonian = a^2; entropy degree 12; metric degree 0;
        });
        assert!(big.contains("at most 20000"), "{big}");
    }

    /// Independent mistakes are all reported, each once.
    #[test]
    fn independent_errors_are_all_reported() {
        let all = messages(quote! {
            struct S; state (q, p);
            const k = 2 * z;
            poisson = [[0, 1], [1, 0]];
            hamiltonian = 0.5 * p^2 + k * q^2 + w;
            entropy degree 0;
            metric degree 3;
            reference { entropy = -q^2; metric = [[1, 2], [2, 1]]; }
        });
        let expected = [
            "unknown name `z`",
            "Π must be skew-symmetric",
            "unknown name `w`",
            "entropy degree must be between 1",
            "metric degree 3 is odd",
            "not positive semidefinite",
        ];
        for e in expected {
            assert_eq!(
                all.iter().filter(|m| m.contains(e)).count(),
                1,
                "{e}: {all:#?}"
            );
        }
        // `k` failed; its use in H is not reported again.
        assert_eq!(all.len(), expected.len(), "{all:#?}");
    }

    #[test]
    fn parse_errors_recover_at_the_next_section() {
        let all = messages(quote! {
            struct S;
            state (q, p)
            poisson = [[0, 1], [-1, 0]];
            hamiltonian = q^2 +;
            entropy degree four;
            metric degree 2;
            refrence { entropy = q; }
        });
        let expected = [
            "expected `;` after `state (…)`",
            "expected an operand",
            "the degree is a non-negative integer literal",
            "unknown section `refrence`",
        ];
        assert_eq!(all.len(), expected.len(), "{all:#?}");
        for (message, e) in all.iter().zip(expected) {
            assert!(message.contains(e), "{e}: {all:#?}");
        }
        // Missing sections are reported together.
        let missing = messages(quote! { struct S; state (q); });
        assert_eq!(missing.len(), 4, "{missing:#?}");
        assert!(missing.iter().all(|m| m.starts_with("`S` has no")));
    }

    /// `state (q p)` names the missing comma, not the names (both valid).
    #[test]
    fn a_missing_comma_between_state_names_is_named() {
        let all = messages(quote! {
            struct S;
            state (q p);
            poisson = [[0, 1], [-1, 0]];
            hamiltonian = q^2;
            entropy degree 2;
            metric degree 0;
        });
        assert_eq!(all.len(), 1, "{all:#?}");
        assert!(
            all[0].starts_with("expected `,` before `p`: state variables are separated by commas"),
            "{all:#?}"
        );
    }

    #[test]
    fn reserved_state_names() {
        let all = messages(quote! {
            struct S; state (t, q, dq, trajectory);
            poisson = [[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]];
            hamiltonian = q^2; entropy degree 2; metric degree 0;
        });
        assert_eq!(all.len(), 3, "{all:#?}");
        assert!(all[0].contains("cannot be named `t`"), "{all:#?}");
        assert!(
            all[1].contains("`q` and `dq` cannot both exist"),
            "{all:#?}"
        );
        assert!(all[2].contains("cannot be named `trajectory`"), "{all:#?}");
    }

    #[test]
    fn constant_reference_metrics_must_be_semidefinite() {
        let system = |metric: proc_macro2::TokenStream| {
            crate::try_expand(quote! {
                struct S; state (q, p);
                poisson = [[0, 1], [-1, 0]];
                hamiltonian = q^2; entropy degree 2; metric degree 2;
                reference { entropy = -q^2; metric = #metric; }
            })
        };
        let indefinite = system(quote!([[1, 2], [2, 1]]))
            .expect_err("indefinite")
            .messages();
        assert!(
            indefinite[0].contains("yᵀKy = -2 < 0 for y = (1, -1)"),
            "{indefinite:?}"
        );
        assert!(system(quote!([[1, 0.5], [0.5, 2]])).is_ok());
        assert!(system(quote!([[0, 0], [0, 0]])).is_ok());
        let zero_pivot = system(quote!([[0, 1], [1, 3]]))
            .expect_err("indefinite")
            .messages();
        assert!(
            zero_pivot[0].contains("not positive semidefinite"),
            "{zero_pivot:?}"
        );
        // Without a region a metric must be constant (it is bounded on all
        // of Rⁿ); with one, non-constant metrics are not decided at compile
        // time.
        let varying = system(quote!([[1 + q ^ 2, 0], [0, 1]]))
            .expect_err("needs a region")
            .messages();
        assert!(
            varying.len() == 1 && varying[0].contains("declare the region where the data live"),
            "{varying:?}"
        );
        let on_region = crate::try_expand(quote! {
            struct S; state (q, p);
            poisson = [[0, 1], [-1, 0]];
            hamiltonian = q^2; entropy degree 2; metric degree 2;
            region box(q in [-1, 1], p in [-1, 1]);
            reference { entropy = -q^2; metric = [[1 + q^2, 0], [0, 1]]; }
        });
        assert!(on_region.is_ok());
        // Denominators of 13 digits overflow 128 bits within two pivots.
        let overflow = crate::try_expand(quote! {
            struct S; state (x, y, z);
            poisson = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
            hamiltonian = x^2; entropy degree 2; metric degree 0;
            reference {
                entropy = -x^2;
                metric = [[1, 1/1000000000039, 1/1000000000061],
                          [1/1000000000039, 1, 1/1000000000063],
                          [1/1000000000061, 1/1000000000063, 1]];
            }
        })
        .expect_err("not verifiable")
        .messages();
        assert!(
            overflow[0].contains("could not verify exactly"),
            "{overflow:?}"
        );
    }

    /// `Model::reference()` refuses coefficients beyond ±1e15 at run time;
    /// the macro refuses them at compile time, at the expression or entry,
    /// naming the coefficient. The bound itself and the dropped constant of
    /// the entropy are fine.
    #[test]
    fn reference_coefficients_are_bounded() {
        let system = |entropy: TokenStream, metric: TokenStream| {
            crate::try_expand(quote! {
                struct S; state (q, p);
                poisson = [[0, 1], [-1, 0]];
                hamiltonian = q^2; entropy degree 2; metric degree 0;
                reference { entropy = #entropy; metric = #metric; }
            })
        };
        let all = system(quote!(-1e16 * q ^ 2 + p ^ 2), quote!([[1e20, 0], [0, 1]]))
            .expect_err("too large")
            .messages();
        assert_eq!(all.len(), 2, "{all:#?}");
        assert!(
            all[0].starts_with(
                "the coefficient of `q^2` in the reference entropy is -1e16, beyond ±1e15"
            ),
            "{all:#?}"
        );
        assert!(
            all[1].starts_with(
                "the constant term in reference metric entry K[0][0] is 1e20, beyond ±1e15"
            ),
            "{all:#?}"
        );
        let off_diagonal = system(
            quote!(-q ^ 2),
            quote!([[1e16, -2e15 * 1.1], [-2.2e15, 1e16]]),
        )
        .expect_err("too large")
        .messages();
        assert_eq!(off_diagonal.len(), 3, "{off_diagonal:#?}");
        assert!(
            off_diagonal[1].contains("K[0][1] is -2.2e15"),
            "{off_diagonal:#?}"
        );
        assert!(system(quote!(-1e15 * q ^ 2 + 1e30), quote!([[1e15, 0], [0, 1]])).is_ok());
    }

    /// What `macro_rules!` forwards: `$vis:vis`, `$e:expr` and
    /// `$l:literal` fragments arrive in invisible groups.
    #[test]
    fn macro_rules_fragments() {
        let invisible = |tokens: TokenStream| TokenTree::Group(Group::new(Delimiter::None, tokens));
        let vis = invisible(quote!(pub(crate)));
        let sum = invisible(quote!(q + p));
        let degree = invisible(quote!(4));
        let matrix = invisible(quote!([[0, 1], [-1, 0]]));
        let tokens = quote! {
            #vis struct S;
            state (q, p);
            poisson = #matrix;
            hamiltonian = 2 * #sum;
            entropy degree #degree;
            metric degree 2;
        };
        let mut diagnostics = Diagnostics::new();
        let def = crate::parse::parse(tokens, &mut diagnostics);
        let system = analyse(&def, &mut diagnostics);
        assert_eq!(diagnostics.count(), 0, "{:?}", diagnostics.into_error());
        let system = system.expect("valid");
        let names = ["q".to_string(), "p".to_string()];
        // The fragment is one operand: 2(q + p), not 2q + p.
        assert_eq!(system.hamiltonian.display(&names).to_string(), "2*q + 2*p");
        assert_eq!(system.bases.entropy_degree, 4);
        assert!(matches!(system.vis, Visibility::Restricted(_)));
    }
}
