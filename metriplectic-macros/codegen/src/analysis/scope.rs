//! Names in scope and the conversion of expressions to exact polynomials.
//!
//! Conversion records every error it finds (both operands of a sum are
//! checked) and returns `None` for a failed expression. A name whose own
//! definition failed converts to `None` silently: its error is already
//! reported, and repeating it at every use would bury it.

use std::collections::HashMap;

use proc_macro2::Ident;
use syn::ext::IdentExt;

use crate::bases;
use crate::diagnostics::Diagnostics;
use crate::parse::{BinaryOp, Expr, Matrix, SpanRange};
use crate::polynomial::{Exact, Polynomial, Rational};

/// Largest exponent written after `^`.
const MAX_EXPONENT: i128 = 64;
/// Largest total degree of any intermediate expression.
const MAX_EXPRESSION_DEGREE: u32 = 64;
/// Largest number of terms of any intermediate expression.
const MAX_TERMS: usize = 100_000;

/// The name a DSL identifier is looked up by: `r#type` and `type` are the
/// same name, as in Rust.
pub fn name_of(ident: &Ident) -> String {
    ident.unraw().to_string()
}

/// What a name stands for.
#[derive(Debug, Clone, Copy)]
enum Symbol {
    /// State variable `index`.
    State(usize),
    /// A constant with its exact value.
    Const(Rational),
    /// A constant whose definition failed (already reported).
    Broken,
}

/// Where an expression appears: which names it may use, and what an error
/// about an unknown name should suggest.
#[derive(Debug, Clone, Copy)]
pub enum Context<'a> {
    /// The definition of the constant named here: numbers and constants
    /// declared before it only.
    Const(&'a str),
    /// H, Π or the reference: state variables and every constant, wherever
    /// it is declared.
    State,
    /// The numbers of a region: every constant, wherever it is declared,
    /// and no state variable.
    Region,
}

/// The state variables and constants of a system.
pub struct Scope {
    nvars: usize,
    state_names: Vec<String>,
    symbols: HashMap<String, Symbol>,
    /// Constants defined so far, in order.
    const_names: Vec<String>,
    /// Every constant the invocation declares, for "declared below" hints.
    declared_consts: Vec<String>,
}

impl Scope {
    /// A scope with the given state variables (the first of repeated names
    /// wins; repeats are reported elsewhere) and the names of every declared
    /// constant, none defined yet.
    pub fn new(state_names: &[String], declared_consts: Vec<String>) -> Scope {
        let mut symbols = HashMap::new();
        for (i, name) in state_names.iter().enumerate() {
            symbols.entry(name.clone()).or_insert(Symbol::State(i));
        }
        Scope {
            nvars: state_names.len(),
            state_names: state_names.to_vec(),
            symbols,
            const_names: Vec::new(),
            declared_consts,
        }
    }

    /// Number of state variables.
    pub fn nvars(&self) -> usize {
        self.nvars
    }

    /// The state variables' names.
    pub fn state_names(&self) -> &[String] {
        &self.state_names
    }

    /// Whether `name` is a state variable.
    pub fn is_state(&self, name: &str) -> bool {
        matches!(self.symbols.get(name), Some(Symbol::State(_)))
    }

    /// Whether `name` is an already defined (or broken) constant.
    pub fn is_const(&self, name: &str) -> bool {
        matches!(
            self.symbols.get(name),
            Some(Symbol::Const(_) | Symbol::Broken)
        )
    }

    /// Defines a constant; `None` marks a constant whose definition failed.
    pub fn define_const(&mut self, name: &str, value: Option<Rational>) {
        let symbol = value.map_or(Symbol::Broken, Symbol::Const);
        self.symbols.insert(name.to_string(), symbol);
        self.const_names.push(name.to_string());
    }

    fn unknown(&self, ident: &Ident, context: Context) -> syn::Error {
        let name = name_of(ident);
        let close = {
            let lower = name.to_lowercase();
            self.state_names
                .iter()
                .chain(&self.const_names)
                .find(|n| n.to_lowercase() == lower)
        };
        let message = match context {
            Context::Const(current) if name == current => {
                format!("constant `{name}` cannot be defined in terms of itself")
            }
            Context::Const(current) if self.declared_consts.contains(&name) => format!(
                "constant `{name}` is declared after `{current}`, and a constant may only use \
                 numbers and constants declared before it; move `const {name} = …;` above \
                 `const {current} = …;`"
            ),
            Context::Const(current) => {
                let mut message = format!(
                    "unknown name `{name}`; a constant may only use numbers and constants \
                     declared before it"
                );
                if !self.const_names.is_empty() {
                    message += &format!(" (here: {})", list(&self.const_names));
                }
                match close {
                    Some(close) => message += &format!("; did you mean `{close}`?"),
                    None => {
                        message +=
                            &format!("; declare `const {name} = …;` above `const {current} = …;`")
                    }
                }
                message
            }
            Context::Region => {
                let mut message = format!(
                    "unknown name `{name}`; the region is given by constant expressions, which \
                     may use numbers and constants"
                );
                if !self.const_names.is_empty() {
                    message += &format!(" (here: {})", list(&self.const_names));
                }
                match close {
                    Some(close) => message += &format!("; did you mean `{close}`?"),
                    None => {
                        message += &format!(
                            "; to use a named constant, declare it with `const {name} = …;` \
                             anywhere in the invocation"
                        )
                    }
                }
                message
            }
            Context::State => {
                let mut message = format!(
                    "unknown name `{name}`; the state variables are {}",
                    list(&self.state_names)
                );
                if !self.const_names.is_empty() {
                    message += &format!(" and the constants are {}", list(&self.const_names));
                }
                match close {
                    Some(close) => message += &format!("; did you mean `{close}`?"),
                    None => {
                        message += &format!(
                            "; to use a named constant, declare it with `const {name} = …;` \
                             anywhere in the invocation"
                        )
                    }
                }
                message
            }
        };
        syn::Error::new(ident.span(), message)
    }

    /// Converts an expression to an exact polynomial, recording its errors.
    pub fn polynomial(
        &self,
        expr: &Expr,
        context: Context,
        diagnostics: &mut Diagnostics,
    ) -> Option<Polynomial> {
        let span = expr.span();
        let n = self.nvars;
        match expr {
            Expr::Number { value, .. } => Some(Polynomial::constant(n, *value)),
            Expr::Name(ident) => {
                let name = name_of(ident);
                match (self.symbols.get(&name), context) {
                    (Some(Symbol::State(i)), Context::State) => Some(Polynomial::variable(n, *i)),
                    (Some(Symbol::State(_)), Context::Region) => {
                        diagnostics.push(syn::Error::new(
                            ident.span(),
                            format!(
                                "the region is fixed, so its numbers cannot depend on the state \
                                 variable `{name}`; write a number or a constant"
                            ),
                        ));
                        None
                    }
                    (Some(Symbol::State(_)), Context::Const(_)) => {
                        diagnostics.push(syn::Error::new(
                            ident.span(),
                            format!(
                                "constants cannot depend on the state variable `{name}`; \
                                 use it in `hamiltonian`, `poisson` or the reference instead"
                            ),
                        ));
                        None
                    }
                    (Some(Symbol::Const(value)), _) => Some(Polynomial::constant(n, *value)),
                    (Some(Symbol::Broken), _) => None,
                    (None, _) => {
                        diagnostics.push(self.unknown(ident, context));
                        None
                    }
                }
            }
            Expr::Unary {
                negate, operand, ..
            } => {
                let inner = self.polynomial(operand, context, diagnostics)?;
                if *negate {
                    exact(inner.neg(), span, diagnostics)
                } else {
                    Some(inner)
                }
            }
            Expr::Paren { inner, .. } => self.polynomial(inner, context, diagnostics),
            Expr::Binary {
                op, left, right, ..
            } => {
                // Both sides first, so that both report their errors.
                let a = self.polynomial(left, context, diagnostics);
                let b = self.polynomial(right, context, diagnostics);
                let (a, b) = (a?, b?);
                match op {
                    BinaryOp::Add => exact(a.add(&b), span, diagnostics),
                    BinaryOp::Sub => exact(a.sub(&b), span, diagnostics),
                    BinaryOp::Mul => {
                        let size = check_size(
                            span,
                            a.degree() + b.degree(),
                            a.term_count().saturating_mul(b.term_count()),
                        );
                        diagnostics.record(size)?;
                        exact(a.mul(&b), span, diagnostics)
                    }
                    BinaryOp::Div => {
                        let Some(divisor) = b.as_constant() else {
                            diagnostics.push(right.span().error(format!(
                                "dividing by `{}`, which depends on the state, is not polynomial; \
                                 only constant denominators are allowed (multiply through, \
                                 or write a constant like `1/m`)",
                                b.display_at_most(&self.state_names, super::work::SHOWN_TERMS)
                            )));
                            return None;
                        };
                        let Some(inverse) = exact(Rational::ONE.div(divisor), span, diagnostics)?
                        else {
                            diagnostics.push(right.span().error(
                                "division by zero; the denominator must be a non-zero constant",
                            ));
                            return None;
                        };
                        exact(a.scale(inverse), span, diagnostics)
                    }
                }
            }
            Expr::Power { base, exponent } => {
                let k = self.exponent(exponent, context, diagnostics);
                let b = self.polynomial(base, context, diagnostics);
                let (k, b) = (k?, b?);
                // A negative power of a constant is a constant: `2^-1` = 1/2.
                let (b, k) = match u32::try_from(k) {
                    Ok(k) => (b, k),
                    Err(_) => {
                        let inverse = reciprocal(&b, k, base, exponent, diagnostics)?;
                        (Polynomial::constant(n, inverse), k.unsigned_abs())
                    }
                };
                let degree = b.degree().saturating_mul(k);
                let terms_bound = if b.term_count() <= 1 {
                    1
                } else {
                    // Number of monomials of the result's degree: a safe upper bound.
                    bases::count_up_to(n, degree)
                        .map_or(usize::MAX, |c| usize::try_from(c).unwrap_or(usize::MAX))
                };
                let size = check_size(
                    span,
                    degree,
                    terms_bound.min(b.term_count().saturating_pow(k)),
                );
                diagnostics.record(size)?;
                exact(b.pow(k), span, diagnostics)
            }
        }
    }

    /// The value of an exponent: a constant integer, negative only for a
    /// constant base (checked by the caller).
    fn exponent(
        &self,
        expr: &Expr,
        context: Context,
        diagnostics: &mut Diagnostics,
    ) -> Option<i32> {
        let span = expr.span();
        if self.mentions_state(expr) {
            diagnostics.push(span.error(
                "an exponent that depends on the state is not polynomial; \
                 write a non-negative integer, e.g. `q^2`",
            ));
            return None;
        }
        let value = self
            .polynomial(expr, context, diagnostics)?
            .as_constant()
            .unwrap_or(Rational::ZERO);
        let result = match value.as_integer() {
            Some(k) if k > MAX_EXPONENT => Err(span.error(format!(
                "exponent {value} is too large; at most {MAX_EXPONENT} is supported"
            ))),
            Some(k) if k < -MAX_EXPONENT => Err(span.error(format!(
                "exponent {value} is too large in magnitude; at most {MAX_EXPONENT} is supported"
            ))),
            Some(k) => i32::try_from(k).map_err(|_| span.error("exponent out of range")),
            None => Err(span.error(format!(
                "fractional exponent {value} is not polynomial; only non-negative integer \
                 exponents are allowed, e.g. `q^2`"
            ))),
        };
        diagnostics.record(result)
    }

    fn mentions_state(&self, expr: &Expr) -> bool {
        match expr {
            Expr::Number { .. } => false,
            Expr::Name(ident) => self.is_state(&name_of(ident)),
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

    /// An n×n matrix of polynomials, row-major. Every entry is converted
    /// (and reports its errors) even when the shape is wrong; `None` if the
    /// shape or any entry is wrong.
    pub fn matrix(
        &self,
        matrix: &Matrix,
        what: &str,
        diagnostics: &mut Diagnostics,
    ) -> Option<Vec<Polynomial>> {
        let n = self.nvars;
        let shape = format!(
            "{what} must be {n}×{n}, one row and one column per state variable ({})",
            list(&self.state_names)
        );
        let mut valid = true;
        if matrix.rows.len() != n {
            valid = false;
            diagnostics.push(syn::Error::new(
                matrix.span,
                format!("{shape}; found {} rows", matrix.rows.len()),
            ));
        }
        for (i, row) in matrix.rows.iter().enumerate() {
            if row.entries.len() != n && i < n {
                valid = false;
                diagnostics.push(syn::Error::new(
                    row.span,
                    format!(
                        "{shape}; row {i} ({}) has {} entries",
                        self.state_names[i],
                        row.entries.len()
                    ),
                ));
            }
        }
        let mut out = Vec::with_capacity(n * n);
        for entry in matrix.rows.iter().flat_map(|row| &row.entries) {
            match entry {
                Some(expr) => match self.polynomial(expr, Context::State, diagnostics) {
                    Some(poly) => out.push(poly),
                    None => valid = false,
                },
                None => valid = false,
            }
        }
        valid.then_some(out)
    }
}

/// 1/b for `b^k` with a negative `k`: only a non-zero constant has a
/// polynomial (constant) negative power.
fn reciprocal(
    b: &Polynomial,
    k: i32,
    base: &Expr,
    exponent: &Expr,
    diagnostics: &mut Diagnostics,
) -> Option<Rational> {
    let Some(constant) = b.as_constant() else {
        diagnostics.push(exponent.span().error(format!(
            "negative exponent {k} is not polynomial; only non-negative integer \
             exponents are allowed (divide by a constant instead, or multiply through)"
        )));
        return None;
    };
    let inverse = exact(Rational::ONE.div(constant), base.span(), diagnostics)?;
    if inverse.is_none() {
        diagnostics.push(base.span().to(exponent.span()).error(format!(
            "0 cannot be raised to the negative power {k}: that divides by zero"
        )));
    }
    inverse
}

/// `value`, or `None` after recording its overflow at `span`.
pub fn exact<T>(value: Exact<T>, span: SpanRange, diagnostics: &mut Diagnostics) -> Option<T> {
    diagnostics.record(value.map_err(|overflow| span.error(overflow)))
}

/// `` `a`, `b`, `c` ``
pub fn list(names: &[String]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
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

#[cfg(test)]
pub mod tests {
    use super::*;
    use crate::parse::parse_expression;
    use proptest::prelude::*;

    /// A scope of the given state variables and no constants.
    pub fn scope(names: &[&str]) -> Scope {
        let state_names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
        Scope::new(&state_names, Vec::new())
    }

    /// An expression in the given state variables, as a polynomial or its errors.
    pub fn poly(text: &str, names: &[&str]) -> syn::Result<Polynomial> {
        let tokens: proc_macro2::TokenStream = text.parse().expect("tokens");
        let expr = parse_expression(tokens)?;
        let mut diagnostics = Diagnostics::new();
        match scope(names).polynomial(&expr, Context::State, &mut diagnostics) {
            Some(poly) => {
                assert_eq!(diagnostics.count(), 0, "a result and errors");
                Ok(poly)
            }
            None => Err(diagnostics
                .into_error()
                .expect("a failure records an error")),
        }
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
        // A constant base may have a negative exponent: exactly 1/2ᵏ.
        assert_eq!(value("2^-1 * q", 3.0), 1.5);
        assert_eq!(value("-2^-2", 0.0), -0.25);
        assert_eq!(value("(1/3)^-2", 0.0), 9.0);
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
        assert!(message("(q - q)^-1").contains("divides by zero"));
        assert!(message("2^-65").contains("too large in magnitude"));
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
    fn both_operands_report_their_errors() {
        let error = poly("x + y * 2", &["q"]).unwrap_err();
        let messages: Vec<String> = error.into_iter().map(|e| e.to_string()).collect();
        assert_eq!(messages.len(), 2, "{messages:?}");
        assert!(messages[0].contains("`x`") && messages[1].contains("`y`"));
    }

    #[test]
    fn raw_identifiers_name_the_same_variable() {
        let p = poly("r#type^2 + type", &["type"]).unwrap();
        assert_eq!(p.evaluate(&[3.0]), 12.0);
    }

    #[test]
    fn unknown_names_get_hints_for_their_context() {
        let mut scope = Scope::new(&["q".to_string()], vec!["a".into(), "b".into()]);
        scope.define_const("a", Some(Rational::ONE));
        let message = |scope: &Scope, text: &str, context: Context| {
            let expr = parse_expression(text.parse().expect("tokens")).expect("parses");
            let mut diagnostics = Diagnostics::new();
            assert!(scope.polynomial(&expr, context, &mut diagnostics).is_none());
            diagnostics.into_error().expect("an error").to_string()
        };
        // In H, Π or the reference, where a constant is declared does not matter.
        let m = message(&scope, "z", Context::State);
        assert!(m.contains("anywhere in the invocation"), "{m}");
        // In a constant, only earlier constants count.
        let m = message(&scope, "b", Context::Const("a2"));
        assert!(
            m.contains("declared after `a2`") && m.contains("move"),
            "{m}"
        );
        let m = message(&scope, "a2 + 1", Context::Const("a2"));
        assert!(m.contains("in terms of itself"), "{m}");
        let m = message(&scope, "z", Context::Const("a2"));
        assert!(
            m.contains("above `const a2 = …;`") && m.contains("(here: `a`)"),
            "{m}"
        );
        // A constant whose definition failed is not reported again.
        scope.define_const("b", None);
        let expr = parse_expression("b * q".parse().expect("tokens")).expect("parses");
        let mut diagnostics = Diagnostics::new();
        assert!(scope
            .polynomial(&expr, Context::State, &mut diagnostics)
            .is_none());
        assert_eq!(diagnostics.count(), 0);
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
            let expanded = poly(&text, &names).unwrap();
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
}
