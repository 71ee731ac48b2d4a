//! Expressions: a precedence-climbing parser over `proc_macro2` token trees.
//!
//! Rust's `^` binds looser than `*`, and the DSL needs mathematical
//! precedence: `^` binds tighter than unary minus and `*`, and is
//! right-associative. So expressions are not parsed by `syn` but here.

use proc_macro2::{Delimiter, Group, Span, TokenTree};

use super::syntax::{BinaryOp, Expr, SpanRange};
use crate::polynomial::{DecimalRange, Rational};

/// One comma-separated piece of a delimited group.
pub struct Piece {
    /// Its tokens (empty between two commas).
    pub tokens: Vec<TokenTree>,
    /// The comma that ends it, or the group's closing delimiter: where an
    /// empty piece is reported.
    pub end: Span,
}

/// Splits a group's tokens at top-level commas; a trailing comma is allowed.
/// Empty pieces between two commas are reported by the expression parser.
pub fn split_commas(group: &Group) -> Vec<Piece> {
    let mut pieces = Vec::new();
    let mut current = Vec::new();
    for token in group.stream() {
        match &token {
            TokenTree::Punct(p) if p.as_char() == ',' => pieces.push(Piece {
                tokens: std::mem::take(&mut current),
                end: p.span(),
            }),
            _ => current.push(token),
        }
    }
    if !current.is_empty() {
        pieces.push(Piece {
            tokens: current,
            end: group.span_close(),
        });
    }
    pieces
}

/// Precedence-climbing parser over a flat list of token trees.
///
/// ```text
/// sum      := product (('+' | '-') product)*
/// product  := unary (('*' | '/') unary)*
/// unary    := ('-' | '+') unary | power
/// power    := atom ('^' exponent)?
/// exponent := ('-' | '+') exponent | power        (right-associative)
/// atom     := number | name | '(' sum ')'
/// ```
pub struct ExprParser {
    tokens: Vec<TokenTree>,
    position: usize,
    /// Where the expression ends (the `;`, `,` or closing delimiter after
    /// it): errors about a missing operand point here.
    end: Span,
}

pub const OPERATORS_HINT: &str =
    "expressions are polynomials built from numbers, state variables, \
    constants, `+ - * /`, `^` with an integer exponent, and parentheses";

impl ExprParser {
    /// A parser over the tokens of one expression, followed by the token
    /// spanned `end`.
    pub fn new(tokens: Vec<TokenTree>, end: Span) -> Self {
        Self {
            tokens,
            position: 0,
            end,
        }
    }

    /// Parses the whole token list as one expression.
    pub fn parse_all(mut self) -> syn::Result<Expr> {
        if self.tokens.is_empty() {
            return Err(syn::Error::new(
                self.end,
                "expected an expression before this",
            ));
        }
        check_complexity(&self.tokens)?;
        let expr = self.sum()?;
        if let Some(token) = self.peek() {
            return Err(self.unexpected(&token.clone(), "expected an operator"));
        }
        Ok(expr)
    }

    fn peek(&self) -> Option<&TokenTree> {
        self.tokens.get(self.position)
    }

    fn peek_punct(&self) -> Option<(char, Span)> {
        match self.peek() {
            Some(TokenTree::Punct(p)) => Some((p.as_char(), p.span())),
            _ => None,
        }
    }

    fn end_span(&self) -> Span {
        self.tokens.last().map_or(self.end, TokenTree::span)
    }

    fn sum(&mut self) -> syn::Result<Expr> {
        let mut left = self.product()?;
        while let Some((c @ ('+' | '-'), _)) = self.peek_punct() {
            self.position += 1;
            let right = self.product()?;
            let op = if c == '+' {
                BinaryOp::Add
            } else {
                BinaryOp::Sub
            };
            left = Expr::Binary {
                op,
                left: Box::new(left),
                right: Box::new(right),
            };
        }
        Ok(left)
    }

    fn product(&mut self) -> syn::Result<Expr> {
        let mut left = self.unary()?;
        while let Some((c @ ('*' | '/'), op_span)) = self.peek_punct() {
            self.position += 1;
            if c == '*' {
                if let Some(('*', second)) = self.peek_punct() {
                    return Err(SpanRange::single(op_span)
                        .to(SpanRange::single(second))
                        .error("`**` is not an operator here; write powers with `^`, e.g. `q^2`"));
                }
            }
            let right = self.unary()?;
            let op = if c == '*' {
                BinaryOp::Mul
            } else {
                BinaryOp::Div
            };
            left = Expr::Binary {
                op,
                left: Box::new(left),
                right: Box::new(right),
            };
        }
        Ok(left)
    }

    fn unary(&mut self) -> syn::Result<Expr> {
        if let Some((c @ ('+' | '-'), sign)) = self.peek_punct() {
            self.position += 1;
            let operand = self.unary()?;
            return Ok(Expr::Unary {
                negate: c == '-',
                sign,
                operand: Box::new(operand),
            });
        }
        self.power()
    }

    fn power(&mut self) -> syn::Result<Expr> {
        let base = self.atom()?;
        if let Some(('^', _)) = self.peek_punct() {
            self.position += 1;
            let exponent = self.exponent()?;
            return Ok(Expr::Power {
                base: Box::new(base),
                exponent: Box::new(exponent),
            });
        }
        Ok(base)
    }

    fn exponent(&mut self) -> syn::Result<Expr> {
        if let Some((c @ ('+' | '-'), sign)) = self.peek_punct() {
            self.position += 1;
            let operand = self.exponent()?;
            return Ok(Expr::Unary {
                negate: c == '-',
                sign,
                operand: Box::new(operand),
            });
        }
        self.power()
    }

    fn atom(&mut self) -> syn::Result<Expr> {
        let Some(token) = self.peek().cloned() else {
            return Err(syn::Error::new(
                self.end_span(),
                format!("expected an operand after this; {OPERATORS_HINT}"),
            ));
        };
        self.position += 1;
        match token {
            TokenTree::Literal(literal) => number(literal),
            TokenTree::Ident(ident) => {
                match self.peek() {
                    Some(TokenTree::Group(g)) if g.delimiter() == Delimiter::Parenthesis => {
                        let range = SpanRange::single(ident.span()).to(SpanRange::single(g.span()));
                        return Err(range.error(format!(
                            "`{ident}(…)` is a function call, which is not a polynomial; \
                             {OPERATORS_HINT} (expand it, e.g. as a truncated series, if you must)"
                        )));
                    }
                    Some(TokenTree::Punct(p)) if p.as_char() == '.' => {
                        let range = SpanRange::single(ident.span()).to(SpanRange::single(
                            self.tokens
                                .get(self.position + 1)
                                .map_or(p.span(), TokenTree::span),
                        ));
                        return Err(range.error(format!(
                            "method calls are not polynomial expressions; write powers as `{ident}^2`, \
                             products with `*`"
                        )));
                    }
                    Some(TokenTree::Punct(p)) if p.as_char() == '!' => {
                        return Err(SpanRange::single(ident.span())
                            .to(SpanRange::single(p.span()))
                            .error(format!("macros are not allowed in expressions; {OPERATORS_HINT}")));
                    }
                    _ => {}
                }
                Ok(Expr::Name(ident))
            }
            TokenTree::Group(group) => match group.delimiter() {
                Delimiter::Parenthesis => {
                    let inner: Vec<TokenTree> = group.stream().into_iter().collect();
                    if inner.is_empty() {
                        return Err(syn::Error::new(group.span(), "empty parentheses: expected an expression inside"));
                    }
                    let mut parser = ExprParser::new(inner, group.span_close());
                    let expr = parser.sum()?;
                    if let Some(token) = parser.peek() {
                        return Err(parser.unexpected(&token.clone(), "expected an operator or `)`"));
                    }
                    Ok(Expr::Paren {
                        span: group.span(),
                        inner: Box::new(expr),
                    })
                }
                Delimiter::None => {
                    // Invisible groups come from macro_rules! fragments: look through them.
                    let parser = ExprParser::new(group.stream().into_iter().collect(), group.span());
                    parser.parse_all()
                }
                Delimiter::Bracket => Err(syn::Error::new(
                    group.span(),
                    "a matrix is not allowed here; only `poisson` and a reference `metric` are matrices",
                )),
                Delimiter::Brace => Err(syn::Error::new(
                    group.span(),
                    format!("blocks are not allowed in expressions; {OPERATORS_HINT}"),
                )),
            },
            TokenTree::Punct(p) => match self.peek() {
                // `.5`: Rust has no such literal, so it is `.` then `5`.
                Some(TokenTree::Literal(digits)) if p.as_char() == '.' => {
                    let range = SpanRange::single(p.span()).to(SpanRange::single(digits.span()));
                    Err(range.error(format!(
                        "`.{digits}` is not a number: write it with a leading zero, `0.{digits}`"
                    )))
                }
                _ => Err(self.unexpected(
                    &TokenTree::Punct(p),
                    "expected a number, a variable, a constant or `(`",
                )),
            },
        }
    }

    fn unexpected(&self, token: &TokenTree, expected: &str) -> syn::Error {
        let shown = match token {
            TokenTree::Group(g) => match g.delimiter() {
                Delimiter::Parenthesis => "(…)".to_string(),
                Delimiter::Bracket => "[…]".to_string(),
                Delimiter::Brace => "{…}".to_string(),
                Delimiter::None => token.to_string(),
            },
            _ => token.to_string(),
        };
        let hint = match token {
            TokenTree::Punct(p) if p.as_char() == '.' => {
                " (method calls are not allowed; write powers with `^`)".to_string()
            }
            _ => format!("; {OPERATORS_HINT}"),
        };
        syn::Error::new(
            token.span(),
            format!("unexpected `{shown}`: {expected}{hint}"),
        )
    }
}

/// Largest number of tokens in one expression.
const MAX_TOKENS: usize = 2_000;
/// Deepest nesting of parentheses in one expression.
pub const MAX_NESTING: usize = 64;

/// Bounds the size and nesting of an expression so that the recursive parser
/// and the analysis stay far from the compiler's stack limit.
fn check_complexity(tokens: &[TokenTree]) -> syn::Result<()> {
    fn walk(
        tokens: &mut dyn Iterator<Item = TokenTree>,
        depth: usize,
        count: &mut usize,
    ) -> syn::Result<()> {
        for token in tokens {
            *count += 1;
            if *count > MAX_TOKENS {
                return Err(syn::Error::new(
                    token.span(),
                    format!("expression too long (more than {MAX_TOKENS} tokens); simplify it"),
                ));
            }
            if let TokenTree::Group(group) = &token {
                if depth >= MAX_NESTING {
                    return Err(syn::Error::new(
                        group.span(),
                        format!("parentheses nested more than {MAX_NESTING} deep; simplify the expression"),
                    ));
                }
                walk(&mut group.stream().into_iter(), depth + 1, count)?;
            }
        }
        Ok(())
    }
    let mut count = 0;
    walk(&mut tokens.iter().cloned(), 0, &mut count)
}

/// A numeric literal as an exact rational.
fn number(literal: proc_macro2::Literal) -> syn::Result<Expr> {
    let span = literal.span();
    let text = literal.to_string();
    let parsed = syn::Lit::new(literal);
    let (digits, suffix) = match &parsed {
        syn::Lit::Int(i) => (i.base10_digits().to_string(), i.suffix().to_string()),
        syn::Lit::Float(f) => (f.base10_digits().to_string(), f.suffix().to_string()),
        _ => {
            return Err(syn::Error::new(
                span,
                format!("expected a number, a variable or a constant; {OPERATORS_HINT}"),
            ))
        }
    };
    if !suffix.is_empty() {
        return Err(syn::Error::new(span, suffix_message(&text, &suffix)));
    }
    match Rational::parse_decimal(&digits) {
        Ok(Some(value)) => Ok(Expr::Number { value, span }),
        Ok(None) => Err(syn::Error::new(span, "malformed number")),
        Err(range) => Err(syn::Error::new(span, range_message(&text, range))),
    }
}

/// Rust's numeric type suffixes (`1.5f32`).
const TYPE_SUFFIXES: [&str; 16] = [
    "i8", "i16", "i32", "i64", "i128", "isize", "u8", "u16", "u32", "u64", "u128", "usize", "f16",
    "f32", "f64", "f128",
];

/// What to write instead of the literal `text` with its `suffix`. Rust
/// lexes a name written right after a number, `2q`, as the number's suffix:
/// that is a product, not a type, and dropping the suffix would silently
/// drop the factor.
fn suffix_message(text: &str, suffix: &str) -> String {
    if TYPE_SUFFIXES.contains(&suffix) {
        return format!("numbers are exact and untyped: remove the `{suffix}` suffix");
    }
    let number = text.strip_suffix(suffix).unwrap_or(text);
    format!(
        "`{text}` is not a number: a name written right after a number is read as its suffix; \
         to multiply, write `{number} * {suffix}`"
    )
}

/// Why the literal `text` is not an exact 128-bit rational, and what to do.
fn range_message(text: &str, range: DecimalRange) -> String {
    let why = match range {
        DecimalRange::Large => {
            "is too large: exact 128-bit rationals hold magnitudes up to about 1.7e38; rescale \
             the state variables so that the coefficients are moderate"
        }
        DecimalRange::Small { places } => {
            // A count of places, not "too small": 1.054571817e-34 is far
            // above 1e-38 and still has 43.
            let places = match places {
                Some(places) => format!("has {places} decimal places"),
                None => "has too many decimal places".to_owned(),
            };
            return format!(
                "the number `{text}` {places}: exact 128-bit rationals hold at most 38 (a step \
                 of 1e-38); round it to 38 places, drop the term, or rescale the state variables \
                 so that the coefficients are moderate"
            );
        }
        DecimalRange::Digits => {
            "has too many significant digits: exact 128-bit rationals hold at most 38; round it"
        }
    };
    format!("the number `{text}` {why}")
}

/// Parses a lone expression (for the engine's tests).
#[cfg(test)]
pub fn parse_expression(tokens: proc_macro2::TokenStream) -> syn::Result<Expr> {
    ExprParser::new(tokens.into_iter().collect(), Span::call_site()).parse_all()
}

#[cfg(test)]
mod tests {
    use quote::quote;

    /// The messages of an invocation that must fail.
    fn errors(input: proc_macro2::TokenStream) -> Vec<String> {
        crate::try_expand(input).expect_err("must fail").messages()
    }

    #[test]
    fn a_decimal_without_its_leading_zero_gets_a_hint_to_write_it() {
        let messages = errors(quote! {
            struct S; state (q, p); poisson = [[0, 1], [-1, 0]];
            hamiltonian = .5 * p^2 + q^2; entropy degree 2; metric degree 0;
        });
        assert!(
            messages[0].contains("`.5` is not a number: write it with a leading zero, `0.5`"),
            "{messages:?}"
        );
        // A method call keeps its own message.
        let messages = errors(quote! {
            struct S; state (q, p); poisson = [[0, 1], [-1, 0]];
            hamiltonian = q.powi(2); entropy degree 2; metric degree 0;
        });
        assert!(messages[0].contains("method"), "{messages:?}");
    }

    /// `2q` lexes as the number 2 with the suffix `q`: the message asks for
    /// the product, as removing the suffix would silently drop the factor.
    #[test]
    fn a_name_right_after_a_number_gets_a_hint_to_multiply() {
        let system = |hamiltonian: proc_macro2::TokenStream| {
            errors(quote! {
                struct S; state (q, p); const k = 2; poisson = [[0, 1], [-1, 0]];
                hamiltonian = #hamiltonian; entropy degree 2; metric degree 0;
            })
        };
        let messages = system(quote!(0.5 * p ^ 2 + 2q));
        assert_eq!(
            messages,
            [
                "`2q` is not a number: a name written right after a number is read as its \
                 suffix; to multiply, write `2 * q`"
            ],
        );
        let messages = system(quote!(p ^ 2 + 1.5k * q ^ 2));
        assert!(messages[0].contains("write `1.5 * k`"), "{messages:?}");
        // A type suffix is still only a type.
        let messages = system(quote!(p ^ 2 + 1.5f64 * q ^ 2));
        assert!(
            messages[0].contains("numbers are exact and untyped: remove the `f64` suffix"),
            "{messages:?}"
        );
    }

    /// Literals beyond exact 128-bit rationals say which way they are out of
    /// range: `1e-400` is tiny, not an overflow to be fixed with smaller
    /// coefficients.
    #[test]
    fn literals_out_of_range_say_how() {
        let system = |hamiltonian: proc_macro2::TokenStream| {
            errors(quote! {
                struct S; state (q, p); poisson = [[0, 1], [-1, 0]];
                hamiltonian = #hamiltonian; entropy degree 2; metric degree 0;
            })
        };
        let messages = system(quote!(1e-400 * p ^ 2 + q ^ 2));
        assert!(
            messages[0].starts_with("the number `1e-400` has 400 decimal places"),
            "{messages:?}"
        );
        let messages = system(quote!(1.054571817e-34 * p ^ 2 + q ^ 2));
        assert!(
            messages[0].starts_with(
                "the number `1.054571817e-34` has 43 decimal places: exact 128-bit rationals \
                 hold at most 38"
            ),
            "{messages:?}"
        );
        let messages = system(quote!(1e400 * p ^ 2 + q ^ 2));
        assert!(
            messages[0].starts_with("the number `1e400` is too large"),
            "{messages:?}"
        );
        let digits: proc_macro2::TokenStream =
            format!("1.{}1 * p^2", "0".repeat(40)).parse().unwrap();
        let messages = system(digits);
        assert!(
            messages[0].contains("has too many significant digits"),
            "{messages:?}"
        );
    }

    #[test]
    fn degrees_are_untyped_numbers_like_those_in_expressions() {
        let messages = errors(quote! {
            struct S; state (q, p); poisson = [[0, 1], [-1, 0]];
            hamiltonian = q^2 + p^2; entropy degree 4u8; metric degree 0;
        });
        assert!(
            messages[0].contains("the degree is written without a type suffix: `4`, not `4u8`"),
            "{messages:?}"
        );
    }
}
