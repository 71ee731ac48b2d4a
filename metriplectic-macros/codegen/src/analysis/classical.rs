//! The classical (GENERIC) form, `classical;`: S is a Casimir of Π
//! (Π∇S ≡ 0) and the metric is degenerate along ∇H (K∇H ≡ 0). Both are
//! polynomial identities, linear in the coefficients, derived here exactly:
//!
//! * Π(x)J(x)ᵀψ ≡ 0: for each component i and monomial α, the coefficient
//!   of x^α in Σₖ ψₖ (Π∇φₖ)ᵢ vanishes, one linear equation in ψ;
//! * K(x; θ)∇H(x) ≡ 0: for each component i and monomial α, the coefficient
//!   of x^α in Σⱼ Kᵢⱼ ∂ⱼH vanishes, one linear equation in θ.
//!
//! The equations are reduced to an independent set (RREF); the null space
//! of the entropy's is a basis of the polynomial Casimirs of Π in the
//! entropy basis.

use std::collections::BTreeMap;

use proc_macro2::Span;

use super::elimination::{self, Echelon, Failure, Row};
use super::reference::ReferenceModel;
use super::region::ball_example;
use super::work::{product, MAX_TERM_PRODUCTS, SHOWN_TERMS};
use crate::bases::Bases;
use crate::diagnostics::Diagnostics;
use crate::parse::{Expr, Reference, SpanRange};
use crate::polynomial::{Polynomial, Rational};

/// Rational operations the eliminations may spend: milliseconds for the
/// paper's systems, about a second at the cap.
const BUDGET: u64 = 20_000_000;

/// The classical constraints, ready to emit.
#[derive(Debug, Clone)]
pub struct ClassicalModel {
    /// Independent rows of C_S ψ = 0, each scaled to max |c| = 1.
    pub entropy_constraints: Vec<Vec<(usize, Rational)>>,
    /// A basis of the Casimirs in the entropy basis, as coprime integers.
    pub casimir_basis: Vec<Vec<(usize, Rational)>>,
    /// The same Casimirs as polynomials (for the docs).
    pub casimirs: Vec<Polynomial>,
    /// Independent rows of C_K θ = 0, each scaled to max |c| = 1.
    pub metric_constraints: Vec<Vec<(usize, Rational)>>,
}

/// What the derivation needs from the checked system.
pub struct Inputs<'a> {
    /// Π(x), row-major.
    pub poisson: &'a [Polynomial],
    /// ∇H(x).
    pub hamiltonian_gradient: &'a [Polynomial],
    /// The bases.
    pub bases: &'a Bases,
    /// The state variables' names.
    pub names: &'a [String],
    /// Whether a region is declared (else the metric is effectively constant).
    pub region: bool,
}

/// Derives the classical constraints, recording an error (spanned at
/// `classical`) if S or K would have to vanish or the derivation cannot be
/// done exactly.
pub fn derive(
    inputs: &Inputs,
    keyword: Span,
    diagnostics: &mut Diagnostics,
) -> Option<ClassicalModel> {
    let failed = |failure: Failure| {
        let why = match failure {
            Failure::Overflow => {
                "128-bit rational arithmetic overflowed; use smaller coefficients or fewer \
                 decimal digits in Π and H"
                    .to_string()
            }
            Failure::TooLarge => format!(
                "it needs more than {BUDGET} rational operations or {MAX_TERM_PRODUCTS} products \
                 of terms; lower the entropy or the metric degree, or write Π and H with fewer \
                 terms"
            ),
        };
        syn::Error::new(
            keyword,
            format!("the classical constraints could not be computed exactly: {why}"),
        )
    };
    let entropy = entropy_constraints(inputs).map_err(failed);
    let entropy = diagnostics.record(entropy);
    let metric = metric_constraints(inputs).map_err(failed);
    let metric = diagnostics.record(metric);
    let mut valid = true;
    if let Some(entropy) = &entropy {
        if entropy.casimirs.is_empty() {
            valid = false;
            let r = inputs.bases.entropy_degree;
            diagnostics.push(syn::Error::new(
                keyword,
                format!(
                    "S must be a Casimir of Π (Π∇S ≡ 0) in the classical form, and Π has none up \
                     to degree {r}, the entropy degree: {}",
                    no_casimir_reason(inputs)
                ),
            ));
        }
    }
    if let Some(metric) = &metric {
        if !metric.admissible {
            valid = false;
            diagnostics.push(syn::Error::new(
                keyword,
                format!(
                    "the classical form needs K∇H ≡ 0, and no non-zero metric of the declared \
                     basis satisfies it: {}",
                    no_metric_reason(inputs)
                ),
            ));
        }
    }
    let (entropy, metric) = (entropy?, metric?);
    valid.then_some(ClassicalModel {
        entropy_constraints: entropy.constraints,
        casimir_basis: entropy.basis,
        casimirs: entropy.casimirs,
        metric_constraints: metric.constraints,
    })
}

/// The entropy's side: constraints, Casimir basis and Casimirs.
struct EntropySide {
    constraints: Vec<Vec<(usize, Rational)>>,
    basis: Vec<Vec<(usize, Rational)>>,
    casimirs: Vec<Polynomial>,
}

/// Rows of Π(x)J(x)ᵀψ ≡ 0 and their null space.
fn entropy_constraints(inputs: &Inputs) -> Result<EntropySide, Failure> {
    let n = inputs.names.len();
    let bases = inputs.bases;
    let features = &bases.monomials[1..=bases.entropy_len];
    // ∂ⱼφₖ is one term, non-zero for the variables φₖ contains, and it
    // multiplies column j of Π: count the products before making them.
    let column_terms: Vec<u64> = (0..n)
        .map(|j| {
            (0..n)
                .map(|i| inputs.poisson[i * n + j].term_count() as u64)
                .sum()
        })
        .collect();
    let work = features.iter().fold(0_u64, |sum, e| {
        e.iter()
            .zip(&column_terms)
            .filter(|(k, _)| **k > 0)
            .fold(sum, |sum, (_, t)| sum.saturating_add(*t))
    });
    within_budget(work)?;
    // (component i, monomial α) → the equation's row over ψ.
    let mut equations: BTreeMap<(usize, Vec<u32>), Row> = BTreeMap::new();
    for (k, e) in features.iter().enumerate() {
        let feature = Polynomial::monomial(e.clone(), Rational::ONE);
        let gradient = (0..n)
            .map(|j| feature.derivative(j))
            .collect::<Result<Vec<_>, _>>()?;
        for i in 0..n {
            let mut component = Polynomial::zero(n);
            for (j, d) in gradient.iter().enumerate() {
                if d.is_zero() {
                    continue;
                }
                component = component.add(&inputs.poisson[i * n + j].mul(d)?)?;
            }
            for (alpha, c) in component.terms() {
                equations
                    .entry((i, alpha.clone()))
                    .or_default()
                    .insert(k, c);
            }
        }
    }
    let echelon = eliminate(equations.into_values())?;
    let constraints = echelon
        .rows()
        .map(elimination::scale_to_unit)
        .collect::<Result<Vec<_>, _>>()?;
    let basis = echelon
        .null_space(features.len())?
        .iter()
        .map(elimination::scale_to_integers)
        .collect::<Result<Vec<_>, _>>()?;
    let casimirs = basis
        .iter()
        .map(|vector| {
            vector.iter().try_fold(Polynomial::zero(n), |sum, &(k, c)| {
                sum.add(&Polynomial::monomial(features[k].clone(), c))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(EntropySide {
        constraints,
        basis,
        casimirs,
    })
}

/// The metric's side: constraints, and whether a non-zero admissible metric
/// exists.
struct MetricSide {
    constraints: Vec<Vec<(usize, Rational)>>,
    admissible: bool,
}

/// Rows of K(x; θ)∇H(x) ≡ 0 over the metric basis `[..len]` (θ laid out by
/// pairs j ≤ k, each a block of `stride` coefficients).
fn metric_rows(inputs: &Inputs, len: usize, stride: usize) -> Result<Vec<Row>, Failure> {
    let n = inputs.names.len();
    let monomials = &inputs.bases.monomials[..len];
    // Each θ coefficient inserts the terms of one or two components of ∇H.
    let gradient_terms: Vec<u64> = inputs
        .hamiltonian_gradient
        .iter()
        .map(|g| g.term_count() as u64)
        .collect();
    let per_monomial = (0..n).fold(0_u64, |sum, j| {
        (j..n).fold(sum, |sum, k| {
            let both = if j == k { 0 } else { gradient_terms[j] };
            sum.saturating_add(gradient_terms[k] + both)
        })
    });
    within_budget(per_monomial.saturating_mul(len as u64))?;
    let mut equations: BTreeMap<(usize, Vec<u32>), Row> = BTreeMap::new();
    let mut pair = 0;
    for j in 0..n {
        for k in j..n {
            for (a, phi) in monomials.iter().enumerate() {
                let column = pair * stride + a;
                // θ_jk,a multiplies φ_a ∂_k H in row j and φ_a ∂_j H in row k.
                let sides: &[(usize, usize)] = if j == k { &[(j, k)] } else { &[(j, k), (k, j)] };
                for &(row, derivative) in sides {
                    for (e, c) in inputs.hamiltonian_gradient[derivative].terms() {
                        let alpha: Vec<u32> = e.iter().zip(phi).map(|(x, y)| x + y).collect();
                        equations.entry((row, alpha)).or_default().insert(column, c);
                    }
                }
            }
            pair += 1;
        }
    }
    Ok(equations.into_values().collect())
}

/// `Failure::TooLarge` when assembling the equations would make more than
/// the budget's products of terms (checked before they are made).
fn within_budget(work: u64) -> Result<(), Failure> {
    if work > MAX_TERM_PRODUCTS {
        Err(Failure::TooLarge)
    } else {
        Ok(())
    }
}

fn metric_constraints(inputs: &Inputs) -> Result<MetricSide, Failure> {
    let n = inputs.names.len();
    let m = inputs.bases.metric_len;
    let pairs = n * (n + 1) / 2;
    let echelon = eliminate(metric_rows(inputs, m, m)?)?;
    let constraints = echelon
        .rows()
        .map(elimination::scale_to_unit)
        .collect::<Result<Vec<_>, _>>()?;
    // Without a region the certificate forces every non-constant
    // coefficient to zero (facial reduction): only constant metrics count.
    let admissible = if inputs.region {
        echelon.rank() < pairs * m
    } else {
        eliminate(metric_rows(inputs, 1.min(m), 1)?)?.rank() < pairs
    };
    Ok(MetricSide {
        constraints,
        admissible,
    })
}

fn eliminate(rows: impl IntoIterator<Item = Row>) -> Result<Echelon, Failure> {
    let mut echelon = Echelon::new(BUDGET);
    for row in rows {
        echelon.insert(row)?;
    }
    Ok(echelon)
}

/// Why Π has no Casimir in the entropy basis, and what to do.
fn no_casimir_reason(inputs: &Inputs) -> String {
    let n = inputs.names.len();
    let constant: Option<Vec<Rational>> =
        inputs.poisson.iter().map(Polynomial::as_constant).collect();
    let full_rank = constant.is_some_and(|entries| {
        let rows = (0..n).map(|i| {
            (0..n)
                .filter(|&j| !entries[i * n + j].is_zero())
                .map(|j| (j, entries[i * n + j]))
                .collect::<Row>()
        });
        eliminate(rows).is_ok_and(|e| e.rank() == n)
    });
    if full_rank {
        format!(
            "Π is constant and non-degenerate (rank {n}), so only constants are Casimirs and S \
             would have no effect; remove `classical;` for the generalized form"
        )
    } else {
        "raise the entropy degree if Π has Casimirs of higher degree (the Lie–Poisson tensor of \
         so(3) has |p|², of degree 2), or remove `classical;` for the generalized form"
            .to_string()
    }
}

/// Why no non-zero K satisfies K∇H ≡ 0, and what to do.
fn no_metric_reason(inputs: &Inputs) -> String {
    let n = inputs.names.len();
    let gradient_degree = inputs
        .hamiltonian_gradient
        .iter()
        .map(Polynomial::degree)
        .max()
        .unwrap_or(0);
    let needed = 2 * gradient_degree;
    let s = inputs.bases.metric_degree;
    let example = "K(x) = c(|∇H|²I − ∇H∇Hᵀ) is a sum of squares and satisfies K∇H ≡ 0";
    if n == 1 {
        // K is a polynomial k(x) and K∇H = k(x)·H′(x); polynomials have no
        // zero divisors, and H′ ≢ 0 (else every K would do). The example
        // above is identically zero in one variable: nothing helps.
        let name = &inputs.names[0];
        return format!(
            "with one state variable the metric is a single polynomial k({name}), and \
             K∇H = k({name})·dH/d{name} ≡ 0 forces k ≡ 0 because dH/d{name} is not zero; so a \
             one-state system in the classical form has no dissipation at all, whatever the \
             region and the metric degree; remove `classical;` for the generalized form"
        );
    }
    if !inputs.region {
        format!(
            "without a region the metric is constant (0 ⪯ K(x) ⪯ ηI on all of Rⁿ forces it), and \
             a constant K with K∇H ≡ 0 vanishes because ∇H spans every direction; declare a region \
             and a metric degree of at least 2·deg ∇H = {needed}, e.g. {} and `metric degree \
             {needed};`: then {example}",
            ball_example(n),
            needed = needed.max(2)
        )
    } else if s < needed {
        format!(
            "raise the metric degree to at least 2·deg ∇H = {needed}, e.g. `metric degree \
             {needed};`: {example}"
        )
    } else {
        format!(
            "in {n} variable(s) K∇H ≡ 0 forces K = 0 here; remove `classical;` for the \
             generalized form"
        )
    }
}

/// `(a, b, …)` with the polynomials in DSL syntax.
pub fn vector_text(polys: &[Polynomial], names: &[String]) -> String {
    let parts: Vec<String> = polys
        .iter()
        .map(|p| p.display_at_most(names, SHOWN_TERMS).to_string())
        .collect();
    format!("({})", parts.join(", "))
}

/// Π∇S for a reference entropy; `Ok(None)` if it vanishes.
pub fn casimir_defect(
    poisson: &[Polynomial],
    entropy: &Polynomial,
    n: usize,
) -> Result<Option<Vec<Polynomial>>, Failure> {
    let gradient = (0..n)
        .map(|j| entropy.derivative(j))
        .collect::<Result<Vec<_>, _>>()?;
    apply(poisson, &gradient, n)
}

/// K∇H for a reference metric; `Ok(None)` if it vanishes.
pub fn degeneracy_defect(
    metric: &[Polynomial],
    hamiltonian_gradient: &[Polynomial],
    n: usize,
) -> Result<Option<Vec<Polynomial>>, Failure> {
    apply(metric, hamiltonian_gradient, n)
}

/// M v for a row-major n×n polynomial matrix; `None` if it is zero.
fn apply(
    matrix: &[Polynomial],
    vector: &[Polynomial],
    n: usize,
) -> Result<Option<Vec<Polynomial>>, Failure> {
    let work = (0..n).fold(0_u64, |sum, i| {
        vector.iter().enumerate().fold(sum, |sum, (j, v)| {
            sum.saturating_add(product(&matrix[i * n + j], v))
        })
    });
    within_budget(work)?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut sum = Polynomial::zero(n);
        for (j, v) in vector.iter().enumerate() {
            sum = sum.add(&matrix[i * n + j].mul(v)?)?;
        }
        out.push(sum);
    }
    Ok((!out.iter().all(Polynomial::is_zero)).then_some(out))
}

/// With `classical;`, the reference model must satisfy both identities
/// exactly: its entropy a Casimir of Π, its metric degenerate along ∇H.
pub fn check_reference(
    inputs: &Inputs,
    reference: &ReferenceModel,
    syntax: &Reference,
    keyword: Span,
    diagnostics: &mut Diagnostics,
) {
    let n = inputs.names.len();
    let names = inputs.names;
    let entropy_span = syntax
        .entropy
        .as_ref()
        .map_or(SpanRange::single(keyword), Expr::span);
    let metric_span = syntax
        .metric
        .as_ref()
        .map_or(SpanRange::single(keyword), |m| SpanRange::single(m.span));
    let exactly = |span: SpanRange, what: &str, failure: Failure| {
        let why = match failure {
            Failure::Overflow => {
                "128-bit rational arithmetic overflowed; use smaller coefficients".to_string()
            }
            Failure::TooLarge => format!(
                "it needs more than {MAX_TERM_PRODUCTS} products of terms; write it with fewer \
                 terms"
            ),
        };
        span.error(format!(
            "could not check exactly that the reference {what} fits the classical form: {why}"
        ))
    };
    match casimir_defect(inputs.poisson, &reference.entropy, n) {
        Ok(None) => {}
        Ok(Some(defect)) => diagnostics.push(entropy_span.error(format!(
            "the reference entropy is not a Casimir of Π, which `classical;` requires: Π∇S = {} \
             instead of 0; use a Casimir (e.g. a function of {}), or remove `classical;`",
            vector_text(&defect, names),
            casimir_hint(inputs)
        ))),
        Err(failure) => diagnostics.push(exactly(entropy_span, "entropy", failure)),
    }
    match degeneracy_defect(&reference.metric, inputs.hamiltonian_gradient, n) {
        Ok(None) => {}
        Ok(Some(defect)) => diagnostics.push(metric_span.error(format!(
            "the reference metric does not satisfy K∇H ≡ 0, which `classical;` requires: K∇H = \
             {} instead of 0 for ∇H = {}; use e.g. K(x) = c(|∇H|²I − ∇H∇Hᵀ), or remove \
             `classical;`",
            vector_text(&defect, names),
            vector_text(inputs.hamiltonian_gradient, names)
        ))),
        Err(failure) => diagnostics.push(exactly(metric_span, "metric", failure)),
    }
}

/// "`x^2 + y^2 + z^2`" for the reference-entropy hint, from the lowest
/// degree Casimir of the basis when there is one.
fn casimir_hint(inputs: &Inputs) -> String {
    match entropy_constraints(inputs) {
        Ok(side) if !side.casimirs.is_empty() => {
            let shown: Vec<String> = side
                .casimirs
                .iter()
                .take(2)
                .map(|c| format!("`{}`", c.display_at_most(inputs.names, SHOWN_TERMS)))
                .collect();
            shown.join(", ")
        }
        _ => "the Casimirs of Π".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use proc_macro2::TokenStream;
    use quote::quote;

    use super::*;
    use crate::analysis::{analyse, System};

    /// The analysed system, or every error message.
    fn system(tokens: TokenStream) -> Result<System, Vec<String>> {
        let mut diagnostics = Diagnostics::new();
        let def = crate::parse::parse(tokens, &mut diagnostics);
        let system = analyse(&def, &mut diagnostics);
        match (diagnostics.into_error(), system) {
            (None, Some(system)) => Ok(system),
            (errors, _) => Err(errors
                .into_iter()
                .flatten()
                .map(|e| e.to_string())
                .collect()),
        }
    }

    fn so3(entropy_degree: u32) -> TokenStream {
        let r = proc_macro2::Literal::u32_unsuffixed(entropy_degree);
        quote! {
            struct RigidBody;
            state (x, y, z);
            poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
            hamiltonian = 0.5 * (x^2 / 0.1 + y^2 / 0.2 + z^2 / 0.15);
            entropy degree #r;
            metric degree 2;
            region ball(radius = 2);
            classical;
        }
    }

    /// A ψ (in the entropy basis of `system`) as a sparse row.
    fn psi_of(polynomial: &Polynomial, system: &System) -> Row {
        let bases = &system.bases;
        bases.monomials[1..=bases.entropy_len]
            .iter()
            .enumerate()
            .filter_map(|(k, e)| {
                let c = polynomial.coefficient(e);
                (!c.is_zero()).then_some((k, c))
            })
            .collect()
    }

    fn rank(rows: impl IntoIterator<Item = Row>) -> usize {
        eliminate(rows).unwrap().rank()
    }

    fn row(form: &[(usize, Rational)]) -> Row {
        form.iter().copied().collect()
    }

    fn dot(form: &[(usize, Rational)], v: &Row) -> Rational {
        form.iter().fold(Rational::ZERO, |sum, (i, c)| {
            let x = v.get(i).copied().unwrap_or(Rational::ZERO);
            sum.add(c.mul(x).unwrap()).unwrap()
        })
    }

    #[test]
    fn so3_casimirs_are_the_powers_of_the_squared_norm() {
        let system = system(so3(4)).expect("valid");
        let classical = system.classical.as_ref().expect("classical");
        assert_eq!(classical.casimir_basis.len(), 2);
        let names = &system.state_names;
        let shown: Vec<String> = classical
            .casimirs
            .iter()
            .map(|c| c.display(names).to_string())
            .collect();
        assert_eq!(shown[0], "x^2 + y^2 + z^2");
        // |p|² and |p|⁴ are in the span of the basis, and |p|² + z is not.
        let n = 3;
        let square = ["x", "y", "z"]
            .iter()
            .enumerate()
            .map(|(i, _)| Polynomial::variable(n, i).pow(2).unwrap())
            .try_fold(Polynomial::zero(n), |s, t| s.add(&t))
            .unwrap();
        let fourth = square.mul(&square).unwrap();
        let basis: Vec<Row> = classical.casimir_basis.iter().map(|v| row(v)).collect();
        for casimir in [&square, &fourth] {
            let mut with = basis.clone();
            with.push(psi_of(casimir, &system));
            assert_eq!(rank(with), 2, "{}", casimir.display(names));
            // And each satisfies every entropy constraint.
            for constraint in &classical.entropy_constraints {
                assert!(dot(constraint, &psi_of(casimir, &system)).is_zero());
            }
        }
        let not = square.add(&Polynomial::variable(n, 2)).unwrap();
        let mut with = basis.clone();
        with.push(psi_of(&not, &system));
        assert_eq!(rank(with), 3);
        // Every basis vector is a Casimir: Π∇C ≡ 0 exactly.
        for casimir in &classical.casimirs {
            assert_eq!(casimir_defect(&system.poisson, casimir, n).unwrap(), None);
        }
        // Rows scaled to max |c| = 1; constraints + Casimirs = the basis size.
        for constraint in &classical.entropy_constraints {
            let max = constraint
                .iter()
                .map(|(_, c)| c.to_f64().abs())
                .fold(0.0, f64::max);
            assert_eq!(max, 1.0);
        }
        assert_eq!(
            classical.entropy_constraints.len() + classical.casimir_basis.len(),
            system.bases.entropy_len
        );
    }

    #[test]
    fn so3_casimirs_up_to_degree_six() {
        let system = system(so3(6)).expect("valid");
        let classical = system.classical.as_ref().expect("classical");
        assert_eq!(classical.casimir_basis.len(), 3);
    }

    #[test]
    fn a_canonical_poisson_tensor_has_no_casimir() {
        let errors = system(quote! {
            struct Oscillator;
            state (q, p);
            poisson = [[0, 1], [-1, 0]];
            hamiltonian = 0.5 * q^2 + 0.5 * p^2;
            entropy degree 4;
            metric degree 2;
            region ball(radius = 2);
            classical;
        })
        .expect_err("no Casimir");
        assert_eq!(errors.len(), 1, "{errors:#?}");
        assert!(
            errors[0].contains("S must be a Casimir of Π")
                && errors[0].contains("none up to degree 4")
                && errors[0].contains("non-degenerate (rank 2)"),
            "{errors:#?}"
        );
    }

    /// θ of a 2×2 metric over the degree-2 basis (1, q, p, q², qp, p²).
    fn theta(system: &System, entries: [[&str; 2]; 2]) -> Row {
        let names = ["q", "p"];
        let m = system.bases.metric_len;
        let mut theta = Row::new();
        let mut pair = 0;
        for (j, row) in entries.iter().enumerate() {
            for text in &row[j..] {
                let entry = crate::analysis::scope::tests::poly(text, &names).unwrap();
                for (a, e) in system.bases.monomials[..m].iter().enumerate() {
                    let c = entry.coefficient(e);
                    if !c.is_zero() {
                        theta.insert(pair * m + a, c);
                    }
                }
                pair += 1;
            }
        }
        theta
    }

    #[test]
    fn metric_constraints_of_the_canonical_oscillator() {
        // The canonical Π has no Casimir, so `classical;` itself is rejected
        // (above); its metric side is derived here directly.
        let system = system(quote! {
            struct Oscillator;
            state (q, p);
            poisson = [[0, 1], [-1, 0]];
            hamiltonian = 0.5 * q^2 + 0.5 * p^2;
            entropy degree 2;
            metric degree 2;
            region ball(radius = 2);
        })
        .expect("valid");
        let inputs = Inputs {
            poisson: &system.poisson,
            hamiltonian_gradient: &system.hamiltonian_gradient,
            bases: &system.bases,
            names: &system.state_names,
            region: true,
        };
        let metric = metric_constraints(&inputs).expect("exact");
        assert!(metric.admissible);
        let degenerate = theta(&system, [["p^2", "-q*p"], ["-q*p", "q^2"]]);
        for constraint in &metric.constraints {
            assert!(dot(constraint, &degenerate).is_zero());
        }
        let identity = theta(&system, [["1", "0"], ["0", "1"]]);
        assert!(metric
            .constraints
            .iter()
            .any(|c| !dot(c, &identity).is_zero()));
        // Scaled rows over θ's 18 coefficients; the null space is that of
        // K∇H ≡ 0: K = c(p², −qp; −qp, q²) is the only degree-2 solution.
        assert_eq!(18 - metric.constraints.len(), 1);
        for constraint in &metric.constraints {
            assert!(constraint.iter().all(|(i, _)| *i < 18));
            let max = constraint
                .iter()
                .map(|(_, c)| c.to_f64().abs())
                .fold(0.0, f64::max);
            assert_eq!(max, 1.0);
        }
        // Without a region only constant metrics count, and none is left.
        let constant = metric_constraints(&Inputs {
            region: false,
            ..inputs
        })
        .expect("exact");
        assert!(!constant.admissible);
    }

    #[test]
    fn without_a_region_k_grad_h_forces_k_to_zero() {
        let errors = system(quote! {
            struct RigidBody;
            state (x, y, z);
            poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
            hamiltonian = 0.5 * (x^2 + 2 * y^2 + 3 * z^2);
            entropy degree 2;
            metric degree 2;
            classical;
        })
        .expect_err("K = 0");
        assert_eq!(errors.len(), 1, "{errors:#?}");
        assert!(
            errors[0].contains("declare a region")
                && errors[0].contains("2·deg ∇H = 2")
                && errors[0].contains("|∇H|²I − ∇H∇Hᵀ"),
            "{errors:#?}"
        );
        // With a region but too low a degree.
        let errors = system(quote! {
            struct RigidBody;
            state (x, y, z);
            poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
            hamiltonian = 0.5 * (x^2 + 2 * y^2 + 3 * z^2);
            entropy degree 2;
            metric degree 0;
            region ball(radius = 2);
            classical;
        })
        .expect_err("K = 0");
        assert!(errors[0].contains("raise the metric degree"), "{errors:#?}");
        // A Hamiltonian that leaves a direction free admits a constant K.
        let system = system(quote! {
            struct Free;
            state (x, y, z);
            poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
            hamiltonian = 0.5 * x^2;
            entropy degree 2;
            metric degree 0;
            classical;
        })
        .expect("valid");
        assert!(system.classical.is_some());
    }

    /// In one variable K∇H = k(x)·H′(x) ≡ 0 forces k ≡ 0: no region or
    /// metric degree helps, so none is suggested (the 1-D example
    /// c(|∇H|²I − ∇H∇Hᵀ) is identically 0).
    #[test]
    fn a_one_state_classical_system_has_no_metric() {
        for extra in [
            quote!(metric degree 0;),
            quote!(metric degree 4; region ball(radius = 1);),
        ] {
            let errors = system(quote! {
                struct Line;
                state (q);
                poisson = [[0]];
                hamiltonian = 0.5 * q^2;
                entropy degree 2;
                #extra
                classical;
            })
            .expect_err("K = 0");
            assert_eq!(errors.len(), 1, "{errors:#?}");
            assert!(
                errors[0].contains("with one state variable the metric is a single polynomial")
                    && errors[0].contains("no dissipation at all")
                    && !errors[0].contains("declare a region")
                    && !errors[0].contains("raise the metric degree"),
                "{errors:#?}"
            );
        }
        // A constant H leaves every metric admissible.
        let system = system(quote! {
            struct Still;
            state (q);
            poisson = [[0]];
            hamiltonian = 1;
            entropy degree 2;
            metric degree 0;
            classical;
        });
        assert!(system.is_ok(), "{system:?}");
    }

    #[test]
    fn a_classical_reference_must_satisfy_both_identities() {
        let errors = system(quote! {
            struct RigidBody;
            state (x, y, z);
            poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
            hamiltonian = 0.5 * (x^2 + y^2 + 2 * z^2);
            entropy degree 2;
            metric degree 2;
            region ball(radius = 2);
            classical;
            reference {
                entropy = -x^2;
                metric = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
            }
        })
        .expect_err("not classical");
        assert_eq!(errors.len(), 2, "{errors:#?}");
        assert!(
            errors[0].contains("not a Casimir") && errors[0].contains("x^2 + y^2 + z^2"),
            "{errors:#?}"
        );
        assert!(errors[1].contains("K∇H = (x, y, 2*z)"), "{errors:#?}");
        // A valid one: S = −|p|², K = |∇H|²I − ∇H∇Hᵀ for H = |p|²/2.
        let system = system(quote! {
            struct RigidBody;
            state (x, y, z);
            poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
            hamiltonian = 0.5 * (x^2 + y^2 + z^2);
            entropy degree 2;
            metric degree 2;
            region ball(radius = 2);
            classical;
            reference {
                entropy = -(x^2 + y^2 + z^2);
                metric = [[y^2 + z^2, -x*y, -x*z], [-x*y, x^2 + z^2, -y*z], [-x*z, -y*z, x^2 + y^2]];
            }
        });
        assert!(system.is_ok(), "{system:?}");
    }
}
