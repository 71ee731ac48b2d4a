//! Numbers, polynomial expressions and doc attributes as tokens.

use proc_macro2::{Ident, Literal, TokenStream};
use quote::quote;

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

/// A polynomial as a Rust expression over the state variables, terms in
/// graded-lex order: `0.5 * q * q + 0.5 * p * p`.
pub fn expression(poly: &Polynomial, state: &[Ident]) -> TokenStream {
    if poly.is_zero() {
        return quote!(0.0);
    }
    let mut terms: Vec<_> = poly.terms().collect();
    terms.sort_by(|(a, _), (b, _)| bases::graded_lex_cmp(a, b));
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
/// `possible_missing_comma` misreads binary expressions in macro-generated
/// arrays.
pub fn array_entry(poly: &Polynomial, state: &[Ident]) -> TokenStream {
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
