//! The reference model: it must fit the declared bases, and its metric must
//! be symmetric and positive semidefinite (else the free energy it defines
//! decreases somewhere: dE/dt = ∇Eᵀ K ∇E).

use super::definiteness::{self, Definiteness};
use super::scope::{Context, Scope};
use super::work::SHOWN_TERMS;
use crate::bases::Bases;
use crate::diagnostics::Diagnostics;
use crate::parse::{Matrix, Reference, SpanRange};
use crate::polynomial::{Polynomial, Rational};

/// The largest |coefficient| of a reference model (after rounding to the
/// `f64` the tables hold): `Model::reference()` refuses coefficients beyond
/// `metriplectic_runtime::Model::MAX_COEFFICIENT`, 1e15, at run time, so
/// they are refused here at compile time instead. The runtime depends on
/// this crate, not the other way round, so the bound is repeated here; keep
/// the two equal (`tests/suite/generated_code.rs`,
/// `reference_coefficients_up_to_the_bound_are_accepted`, checks that the
/// runtime accepts this bound).
pub const MAX_COEFFICIENT: f64 = 1e15;

/// The declared reference model in the system's bases.
#[derive(Debug)]
pub struct ReferenceModel {
    /// The reference entropy as a polynomial (for the docs).
    pub entropy: Polynomial,
    /// Its constant term, dropped from ψ because it does not affect the dynamics.
    pub dropped_constant: Rational,
    /// ψ, one coefficient per entropy monomial.
    pub psi: Vec<Rational>,
    /// θ, laid out by `metric_pair_index`.
    pub theta: Vec<Rational>,
    /// The reference metric, row-major (for the docs).
    pub metric: Vec<Polynomial>,
}

/// Checks the reference entropy and metric independently; the model when
/// both are valid and the bases are known.
pub fn check_reference(
    scope: &Scope,
    reference: &Reference,
    entropy_degree: Option<u32>,
    metric_degree: Option<u32>,
    bases: Option<&Bases>,
    region: (bool, &[Vec<Rational>]),
    diagnostics: &mut Diagnostics,
) -> Option<ReferenceModel> {
    let entropy = reference.entropy.as_ref().and_then(|expr| {
        let entropy = scope.polynomial(expr, Context::State, diagnostics)?;
        match entropy_degree {
            Some(r) if entropy.degree() > r => {
                diagnostics.push(expr.span().error(format!(
                    "the reference entropy has degree {} but the entropy basis stops at \
                         degree {r}; raise it with `entropy degree {};` or lower the reference",
                    entropy.degree(),
                    entropy.degree()
                )));
                None
            }
            // The constant term is dropped from ψ: only the others count.
            _ => coefficients_within_bound(
                &entropy,
                |e| e.iter().any(|&k| k > 0),
                expr.span(),
                "the reference entropy",
                scope.state_names(),
                diagnostics,
            )
            .then_some(entropy),
        }
    });
    let metric = reference
        .metric
        .as_ref()
        .and_then(|matrix| check_metric(scope, matrix, metric_degree, region, diagnostics));
    let (entropy, metric, bases) = (entropy?, metric?, bases?);

    let n = scope.nvars();
    let dropped_constant = entropy.coefficient(&vec![0; n]);
    let psi = bases.monomials[1..=bases.entropy_len]
        .iter()
        .map(|e| entropy.coefficient(e))
        .collect();
    let mut theta = Vec::with_capacity(n * (n + 1) / 2 * bases.metric_len);
    for j in 0..n {
        for k in j..n {
            let entry = &metric[j * n + k];
            theta.extend(
                bases.monomials[..bases.metric_len]
                    .iter()
                    .map(|e| entry.coefficient(e)),
            );
        }
    }
    Some(ReferenceModel {
        entropy,
        dropped_constant,
        psi,
        theta,
        metric,
    })
}

/// The reference metric: n×n, entries within the metric degree, symmetric,
/// and positive semidefinite where that can be decided at compile time.
fn check_metric(
    scope: &Scope,
    matrix: &Matrix,
    metric_degree: Option<u32>,
    region: (bool, &[Vec<Rational>]),
    diagnostics: &mut Diagnostics,
) -> Option<Vec<Polynomial>> {
    let metric = scope.matrix(matrix, "the reference metric K", diagnostics)?;
    let names = scope.state_names();
    let n = scope.nvars();
    let mut valid = true;
    for i in 0..n {
        for j in 0..n {
            let entry = &metric[i * n + j];
            if let Some(s) = metric_degree {
                if entry.degree() > s {
                    valid = false;
                    diagnostics.push(matrix.entry_span(i, j).error(format!(
                        "reference metric entry K[{i}][{j}] has degree {} but the metric basis \
                         stops at degree {s}; raise it with `metric degree {};` or lower the entry",
                        entry.degree(),
                        entry.degree() + entry.degree() % 2
                    )));
                }
            }
            // θ holds the upper triangle (a symmetric metric's other half
            // is the same).
            if j >= i
                && !coefficients_within_bound(
                    entry,
                    |_| true,
                    matrix.entry_span(i, j),
                    &format!("reference metric entry K[{i}][{j}]"),
                    names,
                    diagnostics,
                )
            {
                valid = false;
            }
            if j > i && *entry != metric[j * n + i] {
                valid = false;
                diagnostics.push(matrix.entry_span(i, j).to(matrix.entry_span(j, i)).error(
                    format!(
                        "the reference metric must be symmetric, but K[{i}][{j}] (row `{}`, \
                         column `{}`) is `{}` and K[{j}][{i}] is `{}`; write the same polynomial \
                         in both",
                        names[i],
                        names[j],
                        entry.display_at_most(names, SHOWN_TERMS),
                        metric[j * n + i].display_at_most(names, SHOWN_TERMS)
                    ),
                ));
            }
        }
    }
    if valid {
        valid = check_definiteness(&metric, matrix, names, region, diagnostics);
    }
    valid.then_some(metric)
}

/// Whether every coefficient of `poly` on the monomials `counted` selects
/// is within ±[`MAX_COEFFICIENT`]; records an error at `span`, naming the
/// largest one, if not.
fn coefficients_within_bound(
    poly: &Polynomial,
    counted: impl Fn(&[u32]) -> bool,
    span: SpanRange,
    what: &str,
    names: &[String],
    diagnostics: &mut Diagnostics,
) -> bool {
    let beyond: Vec<(&Vec<u32>, f64)> = poly
        .terms()
        .filter(|(e, _)| counted(e))
        .map(|(e, c)| (e, c.to_f64()))
        .filter(|(_, c)| c.abs() > MAX_COEFFICIENT)
        .collect();
    let Some(&(exponents, largest)) = beyond
        .iter()
        .max_by(|(_, a), (_, b)| a.abs().total_cmp(&b.abs()))
    else {
        return true;
    };
    let term = if exponents.iter().all(|&k| k == 0) {
        "constant term".to_string()
    } else {
        let monomial = Polynomial::monomial(exponents.clone(), Rational::ONE);
        format!("coefficient of `{}`", monomial.display(names))
    };
    let others = match beyond.len() {
        1 => String::new(),
        count => format!(" ({count} of its coefficients are beyond the bound)"),
    };
    diagnostics.push(span.error(format!(
        "the {term} in {what} is {largest:e}, beyond ±{MAX_COEFFICIENT:e}, the largest \
         coefficient a model accepts (`Model::MAX_COEFFICIENT`: beyond it the free energy and its \
         rate overflow `f64` at ordinary states), so `Model::reference()` would fail{others}; \
         write the model with smaller coefficients, e.g. in rescaled state variables"
    )));
    false
}

/// Whether the reference metric is positive semidefinite, as far as the
/// compiler can decide it.
///
/// A constant metric is decided exactly here. A non-constant one needs a
/// region: bounded on all of Rⁿ (0 ⪯ K(x) ⪯ ηI), a matrix polynomial is
/// constant, so without a region it is an error. With one it is checked
/// exactly at a few points of the region (`spots`: its centre, the ends of
/// a ball's axes, a box's corners), which can only refuse a metric that
/// is indefinite there; certifying it on the whole region is a
/// semidefinite program, a job for the runtime's solver
/// (`REGION_CERTIFICATE`) rather than for exact elimination.
fn check_definiteness(
    metric: &[Polynomial],
    matrix: &Matrix,
    names: &[String],
    (region, spots): (bool, &[Vec<Rational>]),
    diagnostics: &mut Diagnostics,
) -> bool {
    let span = SpanRange::single(matrix.span);
    let Some(constant) = metric
        .iter()
        .map(Polynomial::as_constant)
        .collect::<Option<Vec<Rational>>>()
    else {
        if region {
            let Some(message) = spot_check(metric, names, spots) else {
                return true;
            };
            diagnostics.push(span.error(message));
            return false;
        }
        let n = names.len();
        diagnostics.push(span.error(format!(
            "the reference metric depends on the state, but without a region the metric must be \
             constant: 0 ⪯ K(x) ⪯ ηI on all of Rⁿ, as the metric search certifies it, holds only \
             for constant K; declare the region where the data live, e.g. {}, or use a constant \
             metric",
            super::region::ball_example(n)
        )));
        return false;
    };
    match definiteness::semidefinite(&constant, names.len()) {
        Ok(Definiteness::Semidefinite) => true,
        Ok(Definiteness::Indefinite { witness, value }) => {
            let y: Vec<String> = witness.iter().map(Rational::to_string).collect();
            diagnostics.push(span.error(format!(
                "the reference metric is not positive semidefinite: yᵀKy = {value} < 0 for \
                 y = ({}) (components along {}), so wherever ∇E points along y the free energy \
                 would decrease (dE/dt = ∇Eᵀ K ∇E); use a positive semidefinite matrix, e.g. a \
                 diagonal one with non-negative entries",
                y.join(", "),
                names.join(", ")
            )));
            false
        }
        Err(overflow) => {
            diagnostics.push(span.error(format!(
                "could not verify exactly that the reference metric is positive semidefinite: \
                 {overflow}"
            )));
            false
        }
    }
}

/// Why K is not positive semidefinite at one of `spots`, if it is not at
/// one (points whose values overflow are skipped: the runtime checks them).
fn spot_check(metric: &[Polynomial], names: &[String], spots: &[Vec<Rational>]) -> Option<String> {
    let n = names.len();
    spots.iter().find_map(|x| {
        let values = metric
            .iter()
            .map(|entry| entry.value_at(x))
            .collect::<Result<Vec<_>, _>>()
            .ok()?;
        match definiteness::semidefinite(&values, n).ok()? {
            Definiteness::Semidefinite => None,
            Definiteness::Indefinite { witness, value } => {
                let text = |v: &[Rational]| {
                    v.iter()
                        .map(Rational::to_string)
                        .collect::<Vec<_>>()
                        .join(", ")
                };
                Some(format!(
                    "the reference metric is not positive semidefinite in the region: at \
                     ({}) = ({}), yᵀK(x)y = {value} < 0 for y = ({}), so wherever ∇E points \
                     along y there the free energy would decrease (dE/dt = ∇Eᵀ K ∇E); use a \
                     metric that is positive semidefinite on the region",
                    names.join(", "),
                    text(x),
                    text(&witness)
                ))
            }
        }
    })
}
