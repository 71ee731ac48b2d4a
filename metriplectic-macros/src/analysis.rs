//! Semantic analysis: syntax tree → exact polynomials, with every check the
//! macro makes (names, polynomiality, shapes, skew-symmetry, the Jacobi
//! identity, degrees, the reference model against the bases).

use std::collections::HashMap;

use proc_macro2::Ident;
use syn::{Attribute, Visibility};

use crate::monomials;
use crate::parse::{BinaryOp, Expr, Matrix, SpanRange, SystemDef};
use crate::polynomial::{Overflow, Polynomial, Rational};

/// Largest basis (entropy or metric) the macro generates code for.
pub const MAX_BASIS: u128 = 20_000;
/// Largest declared entropy or metric degree.
pub const MAX_DEGREE: u32 = 32;
/// Largest number of state variables.
pub const MAX_STATES: usize = 64;
/// Largest exponent written after `^`.
const MAX_EXPONENT: i128 = 64;
/// Largest total degree of any intermediate expression.
const MAX_EXPRESSION_DEGREE: u32 = 64;
/// Largest number of terms of any intermediate expression.
const MAX_TERMS: usize = 100_000;
/// Largest number of ordered Gram pairs in the full SOS matching table.
const MAX_GRAM_PAIRS: u128 = 1_000_000;

/// A system that passed every check, as exact polynomials and bases.
#[derive(Debug)]
pub struct System {
    /// Outer attributes of the struct (doc comments and others).
    pub attrs: Vec<Attribute>,
    /// Visibility of the struct.
    pub vis: Visibility,
    /// The struct's name.
    pub name: Ident,
    /// State variables as written, spanned at the macro call.
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
    /// Entropy degree r.
    pub entropy_degree: u32,
    /// Metric degree s (even).
    pub metric_degree: u32,
    /// All monomials of degree ≤ max(r, s), graded lexicographic; the entropy
    /// basis is `[1..=entropy_len]`, the metric basis `[..metric_len]`.
    pub monomials: Vec<Vec<u32>>,
    /// Number of entropy monomials (degree 1..=r).
    pub entropy_len: usize,
    /// Number of metric monomials (degree 0..=s).
    pub metric_len: usize,
    /// The full SOS half-degree basis (degree ≤ s/2).
    pub sos_full: Vec<Vec<u32>>,
    /// Its matching table over the metric basis.
    pub sos_full_matching: Vec<Vec<(usize, usize)>>,
    /// The facially reduced matching table.
    pub sos_reduced_matching: Vec<Vec<(usize, usize)>>,
    /// The reference model, if declared.
    pub reference: Option<ReferenceModel>,
}

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

#[derive(Clone, Copy)]
enum Symbol {
    State(usize),
    Const(Rational),
}

/// Names in scope while converting expressions.
struct Scope {
    nvars: usize,
    state_names: Vec<String>,
    symbols: HashMap<String, Symbol>,
    const_names: Vec<String>,
}

fn overflow(span: SpanRange) -> impl Fn(Overflow) -> syn::Error {
    move |o| span.error(o)
}

fn list(names: &[String]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl Scope {
    fn unknown(&self, ident: &Ident, allow_state: bool) -> syn::Error {
        let name = ident.to_string();
        let mut message = format!("unknown name `{name}`; ");
        if allow_state {
            message += &format!("the state variables are {}", list(&self.state_names));
        } else {
            message += "a constant may only use numbers and earlier constants";
        }
        if !self.const_names.is_empty() {
            message += &format!(" and the constants are {}", list(&self.const_names));
        }
        let lower = name.to_lowercase();
        if let Some(close) = self
            .state_names
            .iter()
            .chain(&self.const_names)
            .find(|n| n.to_lowercase() == lower)
        {
            message += &format!("; did you mean `{close}`?");
        } else {
            message += "; declare constants with `const NAME = …;` before using them";
        }
        syn::Error::new(ident.span(), message)
    }

    /// Converts an expression to an exact polynomial. With `allow_state`
    /// false, the expression must be constant (a `const` definition).
    fn polynomial(&self, expr: &Expr, allow_state: bool) -> syn::Result<Polynomial> {
        let span = expr.span();
        let n = self.nvars;
        let poly = match expr {
            Expr::Number { value, .. } => Polynomial::constant(n, *value),
            Expr::Name(ident) => {
                let name = ident.to_string();
                match self.symbols.get(&name) {
                    Some(Symbol::State(i)) if allow_state => Polynomial::variable(n, *i),
                    Some(Symbol::State(_)) => {
                        return Err(syn::Error::new(
                            ident.span(),
                            format!(
                                "constants cannot depend on the state variable `{name}`; \
                                 use it in `hamiltonian`, `poisson` or the reference instead"
                            ),
                        ))
                    }
                    Some(Symbol::Const(value)) => Polynomial::constant(n, *value),
                    None => return Err(self.unknown(ident, allow_state)),
                }
            }
            Expr::Unary {
                negate, operand, ..
            } => {
                let inner = self.polynomial(operand, allow_state)?;
                if *negate {
                    inner.neg().map_err(overflow(span))?
                } else {
                    inner
                }
            }
            Expr::Paren { inner, .. } => self.polynomial(inner, allow_state)?,
            Expr::Binary {
                op, left, right, ..
            } => {
                let a = self.polynomial(left, allow_state)?;
                let b = self.polynomial(right, allow_state)?;
                match op {
                    BinaryOp::Add => a.add(&b).map_err(overflow(span))?,
                    BinaryOp::Sub => a.sub(&b).map_err(overflow(span))?,
                    BinaryOp::Mul => {
                        check_size(
                            span,
                            a.degree() + b.degree(),
                            a.term_count().saturating_mul(b.term_count()),
                        )?;
                        a.mul(&b).map_err(overflow(span))?
                    }
                    BinaryOp::Div => {
                        let Some(divisor) = b.as_constant() else {
                            return Err(right.span().error(format!(
                                "dividing by `{}`, which depends on the state, is not polynomial; \
                                 only constant denominators are allowed (multiply through, \
                                 or write a constant like `1/m`)",
                                b.display(&self.state_names)
                            )));
                        };
                        let Some(inverse) = Rational::ONE.div(divisor).map_err(overflow(span))?
                        else {
                            return Err(right.span().error(
                                "division by zero; the denominator must be a non-zero constant",
                            ));
                        };
                        a.scale(inverse).map_err(overflow(span))?
                    }
                }
            }
            Expr::Power { base, exponent } => {
                let k = self.exponent(exponent)?;
                let b = self.polynomial(base, allow_state)?;
                let degree = b.degree().saturating_mul(k);
                let terms_bound = if b.term_count() <= 1 {
                    1
                } else {
                    // Number of monomials of the result's degree: a safe upper bound.
                    monomials::count_up_to(n, degree)
                        .map_or(usize::MAX, |c| usize::try_from(c).unwrap_or(usize::MAX))
                };
                check_size(
                    span,
                    degree,
                    terms_bound.min(b.term_count().saturating_pow(k)),
                )?;
                b.pow(k).map_err(overflow(span))?
            }
        };
        Ok(poly)
    }

    /// The value of an exponent: a constant non-negative integer.
    fn exponent(&self, expr: &Expr) -> syn::Result<u32> {
        let span = expr.span();
        let poly = match self.polynomial(expr, false) {
            Ok(p) => p,
            Err(_) if self.mentions_state(expr) => {
                return Err(span.error(
                    "an exponent that depends on the state is not polynomial; \
                     write a non-negative integer, e.g. `q^2`",
                ))
            }
            Err(e) => return Err(e),
        };
        let value = poly.as_constant().unwrap_or(Rational::ZERO);
        match value.as_integer() {
            Some(k) if k < 0 => Err(span.error(format!(
                "negative exponent {value} is not polynomial; only non-negative integer \
                 exponents are allowed (divide by a constant instead, or multiply through)"
            ))),
            Some(k) if k > MAX_EXPONENT => Err(span.error(format!(
                "exponent {value} is too large; at most {MAX_EXPONENT} is supported"
            ))),
            Some(k) => Ok(k as u32),
            None => Err(span.error(format!(
                "fractional exponent {value} is not polynomial; only non-negative integer \
                 exponents are allowed, e.g. `q^2`"
            ))),
        }
    }

    fn mentions_state(&self, expr: &Expr) -> bool {
        match expr {
            Expr::Number { .. } => false,
            Expr::Name(ident) => {
                matches!(self.symbols.get(&ident.to_string()), Some(Symbol::State(_)))
            }
            Expr::Unary { operand, .. } => self.mentions_state(operand),
            Expr::Paren { inner, .. } => self.mentions_state(inner),
            Expr::Binary { left, right, .. } => {
                self.mentions_state(left) || self.mentions_state(right)
            }
            Expr::Power { base, exponent } => {
                self.mentions_state(base) || self.mentions_state(exponent)
            }
        }
    }

    /// An n×n matrix of polynomials, row-major.
    fn matrix(&self, matrix: &Matrix, what: &str) -> syn::Result<Vec<Polynomial>> {
        let n = self.nvars;
        let shape = format!(
            "{what} must be {n}×{n}, one row and one column per state variable ({})",
            list(&self.state_names)
        );
        if matrix.rows.len() != n {
            return Err(syn::Error::new(
                matrix.span,
                format!("{shape}; found {} rows", matrix.rows.len()),
            ));
        }
        let mut out = Vec::with_capacity(n * n);
        for (i, (row_span, entries)) in matrix.rows.iter().enumerate() {
            if entries.len() != n {
                return Err(syn::Error::new(
                    *row_span,
                    format!(
                        "{shape}; row {i} ({}) has {} entries",
                        self.state_names[i],
                        entries.len()
                    ),
                ));
            }
            for entry in entries {
                out.push(self.polynomial(entry, true)?);
            }
        }
        Ok(out)
    }
}

fn check_size(span: SpanRange, degree: u32, terms: usize) -> syn::Result<()> {
    if degree > MAX_EXPRESSION_DEGREE {
        return Err(span.error(format!(
            "this expression has degree {degree}; at most {MAX_EXPRESSION_DEGREE} is supported"
        )));
    }
    if terms > MAX_TERMS {
        return Err(span.error(format!(
            "this expression expands to too many terms (more than {MAX_TERMS}); simplify it"
        )));
    }
    Ok(())
}

fn entry_span(matrix: &Matrix, i: usize, j: usize) -> SpanRange {
    matrix
        .rows
        .get(i)
        .and_then(|(_, entries)| entries.get(j))
        .map_or(SpanRange::single(matrix.span), Expr::span)
}

/// Checks a parsed system and converts it to exact polynomials and bases.
pub fn analyse(def: SystemDef) -> syn::Result<System> {
    let (state_keyword, state) = def.state;
    let n = state.len();
    if n > MAX_STATES {
        return Err(syn::Error::new(
            state_keyword,
            format!("{n} state variables; at most {MAX_STATES} are supported"),
        ));
    }
    let state_names: Vec<String> = state
        .iter()
        .map(|i| i.to_string().trim_start_matches("r#").to_string())
        .collect();

    let mut scope = Scope {
        nvars: n,
        state_names: state_names.clone(),
        symbols: HashMap::new(),
        const_names: Vec::new(),
    };
    for (i, ident) in state.iter().enumerate() {
        if scope
            .symbols
            .insert(state_names[i].clone(), Symbol::State(i))
            .is_some()
        {
            return Err(syn::Error::new(
                ident.span(),
                format!(
                    "state variable `{}` is listed twice; give every state variable its own name",
                    state_names[i]
                ),
            ));
        }
    }
    if def.name == "Self" {
        return Err(syn::Error::new(
            def.name.span(),
            "choose a type name other than `Self`",
        ));
    }

    let mut consts = Vec::new();
    for c in &def.consts {
        let name = c.name.to_string();
        let value = scope
            .polynomial(&c.value, false)?
            .as_constant()
            .unwrap_or(Rational::ZERO);
        match scope.symbols.get(&name) {
            Some(Symbol::State(_)) => {
                return Err(syn::Error::new(
                    c.name.span(),
                    format!(
                        "constant `{name}` has the name of a state variable; rename the constant, e.g. `{name}_0`"
                    ),
                ))
            }
            Some(Symbol::Const(_)) => {
                return Err(syn::Error::new(
                    c.name.span(),
                    format!("constant `{name}` is declared twice; give it a new name or remove one"),
                ))
            }
            None => {}
        }
        scope.symbols.insert(name.clone(), Symbol::Const(value));
        scope.const_names.push(name.clone());
        consts.push((name, value));
    }

    // Degrees and basis sizes first: they bound all generated code.
    let entropy_degree = def.entropy_degree.value;
    let metric_degree = def.metric_degree.value;
    if entropy_degree == 0 || entropy_degree > MAX_DEGREE {
        return Err(syn::Error::new(
            def.entropy_degree.span,
            format!(
                "entropy degree must be between 1 and {MAX_DEGREE} (the entropy basis is the \
                 monomials of degree 1..=r); write e.g. `entropy degree 4;`"
            ),
        ));
    }
    if metric_degree > MAX_DEGREE {
        return Err(syn::Error::new(
            def.metric_degree.span,
            format!("metric degree must be at most {MAX_DEGREE}; write e.g. `metric degree 2;`"),
        ));
    }
    if metric_degree % 2 == 1 {
        return Err(syn::Error::new(
            def.metric_degree.span,
            format!(
                "metric degree {metric_degree} is odd, but a matrix polynomial of odd degree cannot be \
                 positive semidefinite everywhere; use an even degree such as {} or {}",
                metric_degree - 1,
                metric_degree + 1
            ),
        ));
    }
    let basis_size = |degree: u32| monomials::count_up_to(n, degree).unwrap_or(u128::MAX);
    let entropy_count = basis_size(entropy_degree).saturating_sub(1);
    if entropy_count > MAX_BASIS {
        return Err(syn::Error::new(
            def.entropy_degree.span,
            format!(
                "entropy degree {entropy_degree} in {n} variables gives {entropy_count} monomials; \
                 at most {MAX_BASIS} are supported, lower the degree"
            ),
        ));
    }
    let metric_count = basis_size(metric_degree);
    if metric_count > MAX_BASIS {
        return Err(syn::Error::new(
            def.metric_degree.span,
            format!(
                "metric degree {metric_degree} in {n} variables gives {metric_count} monomials per \
                 entry; at most {MAX_BASIS} are supported, lower the degree"
            ),
        ));
    }
    let half_count = basis_size(metric_degree / 2);
    if half_count.saturating_mul(half_count) > MAX_GRAM_PAIRS {
        return Err(syn::Error::new(
            def.metric_degree.span,
            format!(
                "metric degree {metric_degree} in {n} variables needs an SOS Gram basis of \
                 {half_count} monomials, too many to tabulate; lower the degree"
            ),
        ));
    }

    // Π: shape, skew-symmetry, Jacobi identity.
    let (poisson_keyword, poisson_matrix) = &def.poisson;
    let _ = poisson_keyword;
    let poisson = scope.matrix(poisson_matrix, "the Poisson tensor Π")?;
    check_skew(&poisson, poisson_matrix, &state_names)?;
    check_jacobi(&poisson, poisson_matrix, &state_names)?;

    let (_, hamiltonian_expr) = &def.hamiltonian;
    let hamiltonian = scope.polynomial(hamiltonian_expr, true)?;
    let hamiltonian_gradient = (0..n)
        .map(|j| hamiltonian.derivative(j))
        .collect::<Result<Vec<_>, _>>()
        .map_err(overflow(hamiltonian_expr.span()))?;

    let monomials = monomials::up_to_degree(n, entropy_degree.max(metric_degree));
    let entropy_len = entropy_count as usize;
    let metric_len = metric_count as usize;
    let sos_full = monomials::up_to_degree(n, metric_degree / 2);
    let sos_full_matching = monomials::matching_table(&sos_full, &monomials[..metric_len]);
    let sos_reduced_matching = monomials::reduced_matching(metric_len);

    let reference = match &def.reference {
        None => None,
        Some(r) => Some(reference_model(
            &scope,
            r,
            &monomials,
            entropy_degree,
            metric_degree,
            entropy_len,
            metric_len,
        )?),
    };

    Ok(System {
        attrs: def.attrs,
        vis: def.vis,
        name: def.name,
        // Generated code is spanned at the macro call as a whole: lints such as
        // clippy's `possible_missing_comma` then treat it as macro output
        // instead of judging user-written tokens inside generated arrays.
        state: state
            .into_iter()
            .map(|mut ident| {
                ident.set_span(proc_macro2::Span::call_site());
                ident
            })
            .collect(),
        state_names,
        consts,
        hamiltonian,
        hamiltonian_gradient,
        poisson,
        entropy_degree,
        metric_degree,
        monomials,
        entropy_len,
        metric_len,
        sos_full,
        sos_full_matching,
        sos_reduced_matching,
        reference,
    })
}

fn check_skew(poisson: &[Polynomial], matrix: &Matrix, names: &[String]) -> syn::Result<()> {
    let n = names.len();
    for i in 0..n {
        let diagonal = &poisson[i * n + i];
        if !diagonal.is_zero() {
            return Err(entry_span(matrix, i, i).error(format!(
                "Π must be skew-symmetric, so its diagonal is zero: Π[{i}][{i}] (row and column `{}`) \
                 is `{}`; write 0",
                names[i],
                diagonal.display(names)
            )));
        }
        for j in i + 1..n {
            let upper = &poisson[i * n + j];
            let lower = &poisson[j * n + i];
            let sum = upper
                .add(lower)
                .map_err(overflow(entry_span(matrix, j, i)))?;
            if !sum.is_zero() {
                let negated = upper.neg().map_err(overflow(entry_span(matrix, i, j)))?;
                return Err(entry_span(matrix, i, j)
                    .to(entry_span(matrix, j, i))
                    .error(format!(
                    "Π must be skew-symmetric, but Π[{i}][{j}] (row `{}`, column `{}`) is `{}` and \
                     Π[{j}][{i}] is `{}`; write Π[{j}][{i}] = `{}`",
                    names[i],
                    names[j],
                    upper.display(names),
                    lower.display(names),
                    negated.display(names)
                )));
            }
        }
    }
    Ok(())
}

/// The Jacobiator Σ_l (Π_il ∂_l Π_jk + Π_jl ∂_l Π_ki + Π_kl ∂_l Π_ij).
pub fn jacobiator(
    poisson: &[Polynomial],
    n: usize,
    (i, j, k): (usize, usize, usize),
    derivatives: &[Vec<Polynomial>],
) -> Result<Polynomial, Overflow> {
    // derivatives[l][a * n + b] = ∂_l Π_ab
    let mut sum = Polynomial::zero(n);
    for (l, d) in derivatives.iter().enumerate() {
        for (a, b, c) in [(i, j, k), (j, k, i), (k, i, j)] {
            let term = poisson[a * n + l].mul(&d[b * n + c])?;
            sum = sum.add(&term)?;
        }
    }
    Ok(sum)
}

/// Checks the Jacobi identity exactly; Π is already known to be skew.
pub fn check_jacobi(poisson: &[Polynomial], matrix: &Matrix, names: &[String]) -> syn::Result<()> {
    let n = names.len();
    let span = SpanRange::single(matrix.span);
    let derivatives = (0..n)
        .map(|l| {
            poisson
                .iter()
                .map(|p| p.derivative(l))
                .collect::<Result<Vec<_>, _>>()
        })
        .collect::<Result<Vec<_>, _>>()
        .map_err(overflow(span))?;
    // For skew Π the Jacobiator is totally antisymmetric: i < j < k suffices.
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let value =
                    jacobiator(poisson, n, (i, j, k), &derivatives).map_err(overflow(span))?;
                if !value.is_zero() {
                    return Err(span.error(format!(
                        "Π is skew-symmetric but violates the Jacobi identity, so it is not a Poisson \
                         tensor: for (i, j, k) = ({}, {}, {}) (indices {i}, {j}, {k}), \
                         Σ_l (Π_il ∂_l Π_jk + Π_jl ∂_l Π_ki + Π_kl ∂_l Π_ij) = `{}`, not 0; \
                         use a Poisson tensor such as a constant skew matrix or a Lie–Poisson \
                         tensor (for so(3): [[0, -z, y], [z, 0, -x], [-y, x, 0]])",
                        names[i],
                        names[j],
                        names[k],
                        value.display(names)
                    )));
                }
            }
        }
    }
    Ok(())
}

fn reference_model(
    scope: &Scope,
    reference: &crate::parse::Reference,
    monomials: &[Vec<u32>],
    entropy_degree: u32,
    metric_degree: u32,
    entropy_len: usize,
    metric_len: usize,
) -> syn::Result<ReferenceModel> {
    let _ = reference.keyword;
    let names = &scope.state_names;
    let n = scope.nvars;
    let entropy = scope.polynomial(&reference.entropy, true)?;
    if entropy.degree() > entropy_degree {
        return Err(reference.entropy.span().error(format!(
            "the reference entropy has degree {} but the entropy basis stops at degree \
             {entropy_degree}; raise it with `entropy degree {};` or lower the reference",
            entropy.degree(),
            entropy.degree()
        )));
    }
    let dropped_constant = entropy.coefficient(&vec![0; n]);
    let psi = monomials[1..=entropy_len]
        .iter()
        .map(|e| entropy.coefficient(e))
        .collect();

    let metric = scope.matrix(&reference.metric, "the reference metric K")?;
    for i in 0..n {
        for j in 0..n {
            let entry = &metric[i * n + j];
            if entry.degree() > metric_degree {
                return Err(entry_span(&reference.metric, i, j).error(format!(
                    "reference metric entry K[{i}][{j}] has degree {} but the metric basis stops at \
                     degree {metric_degree}; raise it with `metric degree {};` or lower the entry",
                    entry.degree(),
                    entry.degree() + entry.degree() % 2
                )));
            }
            if j > i && *entry != metric[j * n + i] {
                return Err(entry_span(&reference.metric, i, j)
                    .to(entry_span(&reference.metric, j, i))
                    .error(format!(
                        "the reference metric must be symmetric, but K[{i}][{j}] (row `{}`, column `{}`) \
                         is `{}` and K[{j}][{i}] is `{}`; write the same polynomial in both",
                        names[i],
                        names[j],
                        entry.display(names),
                        metric[j * n + i].display(names)
                    )));
            }
        }
    }
    let mut theta = Vec::with_capacity(n * (n + 1) / 2 * metric_len);
    for j in 0..n {
        for k in j..n {
            let entry = &metric[j * n + k];
            theta.extend(monomials[..metric_len].iter().map(|e| entry.coefficient(e)));
        }
    }
    Ok(ReferenceModel {
        entropy,
        dropped_constant,
        psi,
        theta,
        metric,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parse::parse_expression;
    use proptest::prelude::*;
    use quote::quote;

    fn scope(names: &[&str]) -> Scope {
        let state_names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
        let symbols = state_names
            .iter()
            .enumerate()
            .map(|(i, n)| (n.clone(), Symbol::State(i)))
            .collect();
        Scope {
            nvars: names.len(),
            state_names,
            symbols,
            const_names: Vec::new(),
        }
    }

    fn poly(text: &str, names: &[&str]) -> syn::Result<Polynomial> {
        let tokens: proc_macro2::TokenStream = text.parse().expect("tokens");
        let expr = parse_expression(tokens)?;
        scope(names).polynomial(&expr, true)
    }

    /// Direct floating-point evaluation of the syntax tree, independent of
    /// the polynomial expansion.
    fn evaluate(expr: &Expr, names: &[&str], x: &[f64]) -> f64 {
        match expr {
            Expr::Number { value, .. } => value.to_f64(),
            Expr::Name(ident) => {
                let i = names.iter().position(|n| ident == n).expect("known name");
                x[i]
            }
            Expr::Unary {
                negate, operand, ..
            } => {
                let v = evaluate(operand, names, x);
                if *negate {
                    -v
                } else {
                    v
                }
            }
            Expr::Paren { inner, .. } => evaluate(inner, names, x),
            Expr::Binary {
                op, left, right, ..
            } => {
                let (a, b) = (evaluate(left, names, x), evaluate(right, names, x));
                match op {
                    BinaryOp::Add => a + b,
                    BinaryOp::Sub => a - b,
                    BinaryOp::Mul => a * b,
                    BinaryOp::Div => a / b,
                }
            }
            Expr::Power { base, exponent } => {
                evaluate(base, names, x).powf(evaluate(exponent, names, x))
            }
        }
    }

    #[test]
    fn power_binds_tighter_than_minus_and_times_and_is_right_associative() {
        let names = ["q"];
        let value = |t: &str, q: f64| poly(t, &names).unwrap().evaluate(&[q]);
        assert_eq!(value("-q^2", 3.0), -9.0);
        assert_eq!(value("2*q^3", 2.0), 16.0);
        assert_eq!(value("2^3^2", 0.0), 512.0);
        assert_eq!(value("(2^3)^2", 0.0), 64.0);
        assert_eq!(value("-2^2", 0.0), -4.0);
        assert_eq!(value("q^2^0", 5.0), 5.0);
        assert_eq!(value("1 - q - q", 1.0), -1.0);
        assert_eq!(value("12 / 3 / 2", 0.0), 2.0);
        assert_eq!(value("q^(1+1)", 3.0), 9.0);
    }

    #[test]
    fn exact_coefficients() {
        let p = poly("0.1 * q + 0.2 * q", &["q"]).unwrap();
        assert_eq!(p.coefficient(&[1]), Rational::new(3, 10).unwrap().unwrap());
        let p = poly("(q + 1/3)^3", &["q"]).unwrap();
        assert_eq!(p.coefficient(&[0]), Rational::new(1, 27).unwrap().unwrap());
        assert_eq!(p.coefficient(&[1]), Rational::new(1, 3).unwrap().unwrap());
        assert!(poly("(q - p)*(q + p) - q^2 + p^2", &["q", "p"])
            .unwrap()
            .is_zero());
    }

    #[test]
    fn non_polynomial_terms_are_rejected() {
        let names = ["q", "p"];
        let message = |t: &str| poly(t, &names).unwrap_err().to_string();
        assert!(message("1 / q").contains("only constant denominators"));
        assert!(message("q^-1").contains("negative exponent"));
        assert!(message("q^0.5").contains("fractional exponent"));
        assert!(message("q^(1/2)").contains("fractional exponent"));
        assert!(message("q^p").contains("depends on the state"));
        assert!(message("sin(q)").contains("function call"));
        assert!(message("q.powi(2)").contains("method calls"));
        assert!(message("q ** 2").contains("write powers with `^`"));
        assert!(message("1 / (q - q + 0)").contains("division by zero"));
        assert!(message("x + q").contains("unknown name `x`"));
        assert!(message("Q + 1").contains("did you mean `q`"));
        assert!(message("q^65").contains("too large"));
        assert!(message("(q + p)^40 * (q + p)^40").contains("degree"));
        assert!(message("q +").contains("expected an operand"));
        assert!(message("q p").contains("expected an operator"));
        assert!(message("1.5f32 * q").contains("suffix"));
    }

    #[test]
    fn pathological_sizes_are_errors_not_stack_overflows() {
        let long = vec!["q"; 900].join(" + ");
        assert!(poly(&long, &["q"]).is_ok());
        let too_long = vec!["q"; 1100].join(" - ");
        assert!(poly(&too_long, &["q"])
            .unwrap_err()
            .to_string()
            .contains("too long"));
        let deep = format!("{}q{}", "(".repeat(100), ")".repeat(100));
        assert!(poly(&deep, &["q"])
            .unwrap_err()
            .to_string()
            .contains("nested"));
        let minus = format!("{}q", "- ".repeat(900));
        assert!(poly(&minus, &["q"]).is_ok());
    }

    #[test]
    fn huge_numbers_overflow_into_errors_not_panics() {
        let message = poly("100000000000000000000^3", &["q"])
            .unwrap_err()
            .to_string();
        assert!(message.contains("overflowed"), "{message}");
        let message = poly("(q + 1000000000000)^8", &["q"])
            .unwrap_err()
            .to_string();
        assert!(message.contains("overflowed"), "{message}");
    }

    /// Random expression text over q, p with every operator of the DSL.
    fn expression_text() -> impl Strategy<Value = String> {
        let leaf = prop_oneof![
            Just("q".to_string()),
            Just("p".to_string()),
            (1u32..20).prop_map(|k| k.to_string()),
            (1u32..100).prop_map(|k| format!("{}.{}", k / 10, k % 10)),
        ];
        leaf.prop_recursive(4, 24, 2, |inner| {
            prop_oneof![
                (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("{a} + {b}")),
                (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("{a} - {b}")),
                (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("{a} * {b}")),
                (inner.clone(), 1u32..8).prop_map(|(a, d)| format!("({a}) / {d}")),
                (inner.clone(), 0u32..4).prop_map(|(a, k)| format!("({a})^{k}")),
                inner.clone().prop_map(|a| format!("-{a}")),
                inner.prop_map(|a| format!("({a})")),
            ]
        })
    }

    proptest! {
        #[test]
        fn expansion_matches_direct_evaluation(
            text in expression_text(),
            q in -2.0f64..2.0,
            p in -2.0f64..2.0,
        ) {
            let names = ["q", "p"];
            let tokens: proc_macro2::TokenStream = text.parse().unwrap();
            let expr = parse_expression(tokens).unwrap();
            let expanded = scope(&names).polynomial(&expr, true).unwrap();
            let direct = evaluate(&expr, &names, &[q, p]);
            let value = expanded.evaluate(&[q, p]);
            prop_assert!((value - direct).abs() <= 1e-9 * direct.abs().max(1.0),
                "{text}: expanded {value} vs direct {direct}");
        }

        #[test]
        fn derivatives_match_finite_differences(
            text in expression_text(),
            q in -2.0f64..2.0,
            p in -2.0f64..2.0,
        ) {
            let names = ["q", "p"];
            let f = poly(&text, &names).unwrap();
            let h = 1e-5;
            for j in 0..2 {
                let mut plus = [q, p];
                let mut minus = [q, p];
                plus[j] += h;
                minus[j] -= h;
                let fd = (f.evaluate(&plus) - f.evaluate(&minus)) / (2.0 * h);
                let exact = f.derivative(j).unwrap().evaluate(&[q, p]);
                // Central differences: error O(h² f''') plus rounding O(|f|/h).
                let scale = f.evaluate(&[q, p]).abs().max(exact.abs()).max(1.0);
                prop_assert!((fd - exact).abs() <= 1e-5 * scale,
                    "{text}: ∂_{j} exact {exact} vs fd {fd}");
            }
        }
    }

    /// Π from text rows, then whether every Jacobiator vanishes.
    fn is_poisson(rows: &[&str], names: &[&str]) -> bool {
        let n = names.len();
        let entries: Vec<Polynomial> = rows.iter().map(|t| poly(t, names).unwrap()).collect();
        assert_eq!(entries.len(), n * n);
        let derivatives: Vec<Vec<Polynomial>> = (0..n)
            .map(|l| entries.iter().map(|p| p.derivative(l).unwrap()).collect())
            .collect();
        let mut ok = true;
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    ok &= jacobiator(&entries, n, (i, j, k), &derivatives)
                        .unwrap()
                        .is_zero();
                }
            }
        }
        ok
    }

    #[test]
    fn jacobi_identity_on_known_tensors() {
        assert!(is_poisson(&["0", "1", "-1", "0"], &["q", "p"]));
        let canonical_4d = [
            "0", "0", "1", "0", //
            "0", "0", "0", "1", //
            "-1", "0", "0", "0", //
            "0", "-1", "0", "0",
        ];
        assert!(is_poisson(&canonical_4d, &["q1", "q2", "p1", "p2"]));
        let so3 = ["0", "-z", "y", "z", "0", "-x", "-y", "x", "0"];
        assert!(is_poisson(&so3, &["x", "y", "z"]));
        // Skew but not Poisson: Π_ij = ε_ijk v_k with v = (0, x, 1), v·curl v = 1.
        let not_poisson = ["0", "1", "-x", "-1", "0", "0", "x", "0", "0"];
        assert!(!is_poisson(&not_poisson, &["x", "y", "z"]));
        // [[0, z, 0], [-z, 0, x], [0, -x, 0]] looks suspicious but is Poisson:
        // v = (x, 0, z) is a gradient, so v·curl v = 0.
        let curl_free = ["0", "z", "0", "-z", "0", "x", "0", "-x", "0"];
        assert!(is_poisson(&curl_free, &["x", "y", "z"]));
    }

    fn expand_error(tokens: proc_macro2::TokenStream) -> String {
        crate::expand(tokens).unwrap_err().to_string()
    }

    #[test]
    fn system_level_checks() {
        let jacobi = expand_error(quote! {
            struct S; state (x, y, z);
            poisson = [[0, 1, -x], [-1, 0, 0], [x, 0, 0]];
            hamiltonian = x^2; entropy degree 2; metric degree 0;
        });
        assert!(
            jacobi.contains("Jacobi identity") && jacobi.contains("(x, y, z)"),
            "{jacobi}"
        );
        let skew = expand_error(quote! {
            struct S; state (q, p);
            poisson = [[0, q], [q, 0]];
            hamiltonian = q^2; entropy degree 2; metric degree 0;
        });
        assert!(skew.contains("write Π[1][0] = `-q`"), "{skew}");
        let odd = expand_error(quote! {
            struct S; state (q, p);
            poisson = [[0, 1], [-1, 0]];
            hamiltonian = q^2; entropy degree 2; metric degree 3;
        });
        assert!(odd.contains("odd"), "{odd}");
        let big = expand_error(quote! {
            struct S; state (a, b, c, d, e, f, g, h);
            poisson = [[0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0],
                       [0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0],[0,0,0,0,0,0,0,0]];
            hamiltonian = a^2; entropy degree 12; metric degree 0;
        });
        assert!(big.contains("at most 20000"), "{big}");
    }
}
