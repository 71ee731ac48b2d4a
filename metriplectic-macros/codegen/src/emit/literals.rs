//! Numbers, polynomial expressions and doc attributes as tokens.

use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;

use super::bindings::local;
use crate::bases;
use crate::polynomial::{Polynomial, Rational};

/// An `f64` literal with a separate minus sign (negative literals do not
/// round-trip through token streams).
pub fn float(value: f64) -> TokenStream {
    let literal = Literal::f64_unsuffixed(value.abs());
    if value.is_sign_negative() && value != 0.0 {
        quote!(-#literal)
    } else {
        quote!(#literal)
    }
}

/// The nearest `f64` of an exact rational.
pub fn rational(value: Rational) -> TokenStream {
    float(value.to_f64())
}

/// An unsuffixed integer literal.
pub fn int(value: usize) -> Literal {
    Literal::usize_unsuffixed(value)
}

/// `#[doc = " text"]`
pub fn doc(text: impl AsRef<str>) -> TokenStream {
    let text = format!(" {}", text.as_ref());
    quote!(#[doc = #text])
}

/// Terms per statement of a long polynomial (see [`expression`]).
const TERMS_PER_STATEMENT: usize = 16;

/// A polynomial as a Rust expression over the state variables, terms in
/// graded-lex order: `0.5 * q * q + 0.5 * p * p`.
///
/// A chain of `+` nests as deeply as it is long in rustc's expression tree,
/// and rustc overflowed its stack on an H of 11 628 terms. Longer
/// polynomials become a block of statements of at most
/// [`TERMS_PER_STATEMENT`] terms each, `let sum = sum + t₁₇ + … + t₃₂;`,
/// which adds in the same order as the single chain, so the value has the
/// same bits.
pub fn expression(poly: &Polynomial, state: &[Ident]) -> TokenStream {
    let terms = signed_terms(poly, state);
    if terms.len() <= TERMS_PER_STATEMENT {
        return terms.into_iter().collect();
    }
    let sum = local("sum");
    let mut chunks = terms.chunks(TERMS_PER_STATEMENT);
    let first: TokenStream = chunks.next().into_iter().flatten().cloned().collect();
    let rest = chunks.map(|chunk| {
        let chunk: TokenStream = chunk.iter().cloned().collect();
        quote!(let #sum = #sum #chunk;)
    });
    quote!({
        let #sum = #first;
        #(#rest)*
        #sum
    })
}

/// The terms of `poly` as tokens, each but the first with its sign as a
/// binary operator (`+ 0.5 * q`, `- p`); `0.0` for the zero polynomial.
fn signed_terms(poly: &Polynomial, state: &[Ident]) -> Vec<TokenStream> {
    if poly.is_zero() {
        return vec![quote!(0.0)];
    }
    let mut terms: Vec<_> = poly.terms().collect();
    terms.sort_by(|(a, _), (b, _)| bases::graded_lex_cmp(a, b));
    let mut out = Vec::with_capacity(terms.len());
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
                    let k = Literal::u32_unsuffixed(k);
                    factors.push(quote!(#var.powi(#k)));
                }
            }
        }
        let body = if factors.is_empty() {
            float(magnitude)
        } else if magnitude == 1.0 {
            join(&factors, quote!(*))
        } else {
            let m = float(magnitude);
            let product = join(&factors, quote!(*));
            quote!(#m * #product)
        };
        out.push(match (i, negative) {
            (0, false) => body,
            (0, true) => quote!(-#body),
            (_, false) => quote!(+ #body),
            (_, true) => quote!(- #body),
        });
    }
    out
}

/// Whether [`expression`] writes `poly` as a sum (or difference) with a
/// product among its terms, `a * b + c`: what clippy's `suboptimal_flops`
/// would rewrite with `mul_add`.
pub fn adds_products(poly: &Polynomial) -> bool {
    poly.term_count() > 1
        && poly.terms().any(|(exponents, coefficient)| {
            let factors: u32 = exponents
                .iter()
                .map(|&k| match k {
                    0 => 0,
                    // `q * q`
                    2 => 2,
                    // `q` or `q.powi(k)`
                    _ => 1,
                })
                .sum();
            let scaled = coefficient.to_f64().abs() != 1.0;
            factors > 1 || (factors == 1 && scaled)
        })
}

/// A polynomial as an array element: parenthesised unless it is a number, a
/// lone (possibly negated) variable or a block of statements, because clippy's
/// `possible_missing_comma` misreads binary expressions in macro-generated
/// arrays.
pub fn array_entry(poly: &Polynomial, state: &[Ident]) -> TokenStream {
    let simple = poly.term_count() <= 1
        && poly.terms().all(|(e, c)| {
            let degree: u32 = e.iter().sum();
            degree == 0 || (degree == 1 && c.to_f64().abs() == 1.0)
        });
    let expr = expression(poly, state);
    if simple || poly.term_count() > TERMS_PER_STATEMENT {
        expr
    } else {
        quote!((#expr))
    }
}

/// `a op b op c …`
pub fn join(items: &[TokenStream], op: TokenStream) -> TokenStream {
    let mut out = TokenStream::new();
    for (i, item) in items.iter().enumerate() {
        if i > 0 {
            out.extend(op.clone());
        }
        out.extend(item.clone());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proc_macro2::{Span, TokenTree};

    /// (1 + q + p)^k, expanded.
    fn power(k: u32) -> Polynomial {
        let sum = Polynomial::constant(2, Rational::ONE)
            .add(&Polynomial::variable(2, 0))
            .and_then(|s| s.add(&Polynomial::variable(2, 1)))
            .unwrap();
        sum.pow(k).unwrap()
    }

    /// Additive operators per `;`-separated statement of `tokens` (inside
    /// its outermost block, if any).
    fn operators_per_statement(tokens: TokenStream) -> Vec<usize> {
        let inner = match tokens.into_iter().collect::<Vec<_>>().as_slice() {
            [TokenTree::Group(group)] => group.stream(),
            other => other.iter().cloned().collect(),
        };
        let mut counts = vec![0];
        for token in inner {
            if let TokenTree::Punct(punct) = token {
                match punct.as_char() {
                    ';' => counts.push(0),
                    '+' | '-' => *counts.last_mut().unwrap() += 1,
                    _ => {}
                }
            }
        }
        counts
    }

    #[test]
    fn long_polynomials_become_short_statements_in_the_same_order() {
        let state = [
            Ident::new("q", Span::call_site()),
            Ident::new("p", Span::call_site()),
        ];
        // 10 terms: one expression, as before.
        let short = expression(&power(3), &state);
        assert!(!short.to_string().contains("let"), "{short}");
        // 91 terms: statements of at most 16 terms, so no statement nests
        // deeper than 16 in rustc's expression tree.
        let long = expression(&power(12), &state);
        let counts = operators_per_statement(long.clone());
        assert_eq!(
            counts.len(),
            91_usize.div_ceil(TERMS_PER_STATEMENT) + 1,
            "{long}"
        );
        assert!(
            counts.iter().all(|&c| c <= TERMS_PER_STATEMENT),
            "{counts:?}"
        );
        // The statements continue the single chain term by term: the same
        // terms in the same order once the `let sum = sum` prefixes go.
        let chain: TokenStream = signed_terms(&power(12), &state).into_iter().collect();
        let flattened = long
            .to_string()
            .replace("let sum = sum", "")
            .replace("let sum =", "")
            .replace(';', "");
        let flattened = flattened
            .trim()
            .trim_start_matches('{')
            .trim_end_matches('}');
        let flattened = flattened.trim().trim_end_matches("sum").trim();
        assert_eq!(
            flattened.split_whitespace().collect::<String>(),
            chain.to_string().split_whitespace().collect::<String>()
        );
    }
}
