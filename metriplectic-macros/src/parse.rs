//! Parsing the DSL: token stream → syntax tree with spans.
//!
//! The section structure (`state (…);`, `poisson = …;`, …) is parsed with
//! `syn`. Expressions use the crate's own precedence parser over
//! `proc_macro2` token trees, because Rust's `^` binds looser than `*` and the
//! DSL needs mathematical precedence: `^` binds tighter than unary minus and
//! `*`, and is right-associative.

use proc_macro2::{Delimiter, Group, Ident, Punct, Spacing, Span, TokenStream, TokenTree};
use quote::ToTokens;
use syn::parse::{Parse, ParseStream};
use syn::{Attribute, Token, Visibility};

use crate::polynomial::Rational;

/// A source range for error reporting: the first and last token of a
/// construct (stable Rust cannot join spans, but `syn::Error::new_spanned`
/// underlines from the first to the last token).
#[derive(Debug, Clone, Copy)]
pub struct SpanRange {
    /// Span of the first token.
    pub first: Span,
    /// Span of the last token.
    pub last: Span,
}

impl SpanRange {
    /// A range of a single token.
    pub fn single(span: Span) -> SpanRange {
        SpanRange {
            first: span,
            last: span,
        }
    }

    /// From the start of `self` to the end of `other`.
    pub fn to(self, other: SpanRange) -> SpanRange {
        SpanRange {
            first: self.first,
            last: other.last,
        }
    }

    /// A compile error underlining this range.
    pub fn error(self, message: impl std::fmt::Display) -> syn::Error {
        syn::Error::new_spanned(self, message)
    }
}

impl ToTokens for SpanRange {
    fn to_tokens(&self, tokens: &mut TokenStream) {
        for span in [self.first, self.last] {
            let mut punct = Punct::new('.', Spacing::Alone);
            punct.set_span(span);
            tokens.extend([TokenTree::Punct(punct)]);
        }
    }
}

/// Binary operators of the expression language.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinaryOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
}

/// An expression of the DSL.
#[derive(Debug, Clone)]
pub enum Expr {
    /// A numeric literal, as an exact rational.
    Number {
        /// The value.
        value: Rational,
        /// The literal's span.
        span: Span,
    },
    /// A state variable or a named constant.
    Name(Ident),
    /// `-operand` or `+operand`.
    Unary {
        /// Whether it is a negation.
        negate: bool,
        /// Span of the sign.
        sign: Span,
        /// The operand.
        operand: Box<Expr>,
    },
    /// `left op right`.
    Binary {
        /// The operator.
        op: BinaryOp,
        /// Left operand.
        left: Box<Expr>,
        /// Right operand.
        right: Box<Expr>,
    },
    /// `base ^ exponent`.
    Power {
        /// The base.
        base: Box<Expr>,
        /// The exponent (must evaluate to a non-negative integer constant).
        exponent: Box<Expr>,
    },
    /// `( inner )`.
    Paren {
        /// Span of the parentheses.
        span: Span,
        /// The inner expression.
        inner: Box<Expr>,
    },
}

impl Expr {
    /// The source range of the whole expression.
    pub fn span(&self) -> SpanRange {
        match self {
            Expr::Number { span, .. } | Expr::Paren { span, .. } => SpanRange::single(*span),
            Expr::Name(ident) => SpanRange::single(ident.span()),
            Expr::Unary { sign, operand, .. } => SpanRange::single(*sign).to(operand.span()),
            Expr::Binary { left, right, .. } => left.span().to(right.span()),
            Expr::Power { base, exponent } => base.span().to(exponent.span()),
        }
    }
}

/// A matrix literal `[[a, b], [c, d]]`.
#[derive(Debug, Clone)]
pub struct Matrix {
    /// Span of the outer brackets.
    pub span: Span,
    /// Rows: the span of each row's brackets and its entries.
    pub rows: Vec<(Span, Vec<Expr>)>,
}

/// `const name = expr;`
#[derive(Debug, Clone)]
pub struct ConstDef {
    /// The constant's name.
    pub name: Ident,
    /// Its defining expression.
    pub value: Expr,
}

/// A declared degree with the span of its literal.
#[derive(Debug, Clone, Copy)]
pub struct Degree {
    /// The value.
    pub value: u32,
    /// Span of the literal.
    pub span: Span,
}

/// The optional `reference { … }` section.
#[derive(Debug, Clone)]
pub struct Reference {
    /// Span of the `reference` keyword.
    pub keyword: Span,
    /// `entropy = expr;`
    pub entropy: Expr,
    /// `metric = matrix;`
    pub metric: Matrix,
}

/// A whole `metriplectic! { … }` invocation.
#[derive(Debug, Clone)]
pub struct SystemDef {
    /// Outer attributes of the struct (doc comments and others).
    pub attrs: Vec<Attribute>,
    /// Visibility of the struct.
    pub vis: Visibility,
    /// The struct's name.
    pub name: Ident,
    /// State variables, in order, with the span of the `state` keyword.
    pub state: (Span, Vec<Ident>),
    /// Named constants, in declaration order.
    pub consts: Vec<ConstDef>,
    /// Π(x) with the span of the `poisson` keyword.
    pub poisson: (Span, Matrix),
    /// H(x) with the span of the `hamiltonian` keyword.
    pub hamiltonian: (Span, Expr),
    /// Entropy degree r.
    pub entropy_degree: Degree,
    /// Metric degree s.
    pub metric_degree: Degree,
    /// Optional reference model.
    pub reference: Option<Reference>,
}

const SECTIONS: &str = "`state (…);`, `const NAME = …;`, `poisson = [[…]];`, \
    `hamiltonian = …;`, `entropy degree N;`, `metric degree N;` or `reference { … }`";

/// Stores a section value, rejecting a second occurrence.
fn set_once<T>(slot: &mut Option<(Span, T)>, keyword: &Ident, value: T) -> syn::Result<()> {
    if slot.is_some() {
        return Err(syn::Error::new(
            keyword.span(),
            format!("`{keyword}` is declared twice; keep a single `{keyword}` section"),
        ));
    }
    *slot = Some((keyword.span(), value));
    Ok(())
}

fn missing(name: &Ident, section: &str, example: &str) -> syn::Error {
    syn::Error::new(
        name.span(),
        format!("`{name}` has no {section} section; add one, e.g. `{example}`"),
    )
}

impl Parse for SystemDef {
    fn parse(input: ParseStream) -> syn::Result<Self> {
        let attrs = input.call(Attribute::parse_outer)?;
        let vis: Visibility = input.parse()?;
        if !input.peek(Token![struct]) {
            return Err(input.error(
                "a system starts with its type, e.g. `pub struct Oscillator;` (doc comments may precede it)",
            ));
        }
        input.parse::<Token![struct]>()?;
        let name: Ident = input.parse()?;
        if !input.peek(Token![;]) {
            return Err(input.error(format!(
                "the system type is a unit struct: write `struct {name};`"
            )));
        }
        input.parse::<Token![;]>()?;

        let mut state = None;
        let mut consts = Vec::new();
        let mut poisson = None;
        let mut hamiltonian = None;
        let mut entropy = None;
        let mut metric = None;
        let mut reference = None;

        while !input.is_empty() {
            if input.peek(Token![const]) {
                input.parse::<Token![const]>()?;
                let const_name: Ident = input.parse()?;
                expect_eq(input, &const_name)?;
                let value = parse_expr(input, const_name.span())?;
                input.parse::<Token![;]>()?;
                consts.push(ConstDef {
                    name: const_name,
                    value,
                });
                continue;
            }
            let keyword: Ident = input.parse().map_err(|e| {
                syn::Error::new(e.span(), format!("expected a section: {SECTIONS}"))
            })?;
            match keyword.to_string().as_str() {
                "state" => {
                    let content;
                    syn::parenthesized!(content in input);
                    let names = content.parse_terminated(Ident::parse, Token![,])?;
                    let names: Vec<Ident> = names.into_iter().collect();
                    if names.is_empty() {
                        return Err(syn::Error::new(
                            keyword.span(),
                            "the state needs at least one variable, e.g. `state (q, p);`",
                        ));
                    }
                    input.parse::<Token![;]>()?;
                    set_once(&mut state, &keyword, names)?;
                }
                "poisson" => {
                    expect_eq(input, &keyword)?;
                    let matrix = parse_matrix(input, keyword.span())?;
                    input.parse::<Token![;]>()?;
                    set_once(&mut poisson, &keyword, matrix)?;
                }
                "hamiltonian" => {
                    expect_eq(input, &keyword)?;
                    let expr = parse_expr(input, keyword.span())?;
                    input.parse::<Token![;]>()?;
                    set_once(&mut hamiltonian, &keyword, expr)?;
                }
                "entropy" | "metric" => {
                    let degree = parse_degree(input, &keyword)?;
                    let slot = if keyword == "entropy" {
                        &mut entropy
                    } else {
                        &mut metric
                    };
                    set_once(slot, &keyword, degree)?;
                }
                "reference" => {
                    let parsed = parse_reference(input, &keyword)?;
                    set_once(&mut reference, &keyword, parsed)?;
                }
                other => {
                    return Err(syn::Error::new(
                        keyword.span(),
                        format!("unknown section `{other}`; expected {SECTIONS}"),
                    ))
                }
            }
        }

        let state = state.ok_or_else(|| missing(&name, "state", "state (q, p);"))?;
        let poisson = poisson
            .ok_or_else(|| missing(&name, "Poisson tensor", "poisson = [[0, 1], [-1, 0]];"))?;
        let hamiltonian = hamiltonian
            .ok_or_else(|| missing(&name, "Hamiltonian", "hamiltonian = 0.5 * p^2 + 0.5 * q^2;"))?;
        let entropy_degree =
            entropy.ok_or_else(|| missing(&name, "entropy basis", "entropy degree 4;"))?;
        let metric_degree =
            metric.ok_or_else(|| missing(&name, "metric basis", "metric degree 2;"))?;
        Ok(SystemDef {
            attrs,
            vis,
            name,
            state,
            consts,
            poisson,
            hamiltonian,
            entropy_degree: entropy_degree.1,
            metric_degree: metric_degree.1,
            reference: reference.map(|(_, r)| r),
        })
    }
}

fn expect_eq(input: ParseStream, keyword: &Ident) -> syn::Result<()> {
    if input.peek(Token![=]) {
        input.parse::<Token![=]>()?;
        Ok(())
    } else {
        Err(input.error(format!("expected `=` after `{keyword}`")))
    }
}

/// `degree N;` after `entropy` or `metric`.
fn parse_degree(input: ParseStream, keyword: &Ident) -> syn::Result<Degree> {
    let example = format!("write `{keyword} degree 4;`");
    let word: Ident = input
        .parse()
        .map_err(|e| syn::Error::new(e.span(), format!("expected `degree`: {example}")))?;
    if word != "degree" {
        return Err(syn::Error::new(
            word.span(),
            format!("expected `degree`: {example}"),
        ));
    }
    let literal: syn::LitInt = input.parse().map_err(|e| {
        syn::Error::new(
            e.span(),
            format!("the degree is a non-negative integer literal: {example}"),
        )
    })?;
    let value = literal.base10_parse::<u32>().map_err(|_| {
        syn::Error::new(
            literal.span(),
            format!("the degree is a small non-negative integer: {example}"),
        )
    })?;
    input.parse::<Token![;]>()?;
    Ok(Degree {
        value,
        span: literal.span(),
    })
}

fn parse_reference(input: ParseStream, keyword: &Ident) -> syn::Result<Reference> {
    let content;
    let braces = syn::braced!(content in input);
    let mut entropy = None;
    let mut metric = None;
    while !content.is_empty() {
        let item: Ident = content.parse().map_err(|e| {
            syn::Error::new(
                e.span(),
                "a reference holds `entropy = …;` and `metric = [[…]];`",
            )
        })?;
        match item.to_string().as_str() {
            "entropy" => {
                expect_eq(&content, &item)?;
                let expr = parse_expr(&content, item.span())?;
                content.parse::<Token![;]>()?;
                set_once(&mut entropy, &item, expr)?;
            }
            "metric" => {
                expect_eq(&content, &item)?;
                let matrix = parse_matrix(&content, item.span())?;
                content.parse::<Token![;]>()?;
                set_once(&mut metric, &item, matrix)?;
            }
            other => {
                return Err(syn::Error::new(
                    item.span(),
                    format!(
                        "unknown reference item `{other}`; a reference holds `entropy = …;` and `metric = [[…]];`"
                    ),
                ))
            }
        }
    }
    let close = braces.span.close();
    let entropy = entropy.ok_or_else(|| {
        syn::Error::new(
            close,
            "the reference has no entropy; add `entropy = …;` inside `reference { … }`",
        )
    })?;
    let metric = metric.ok_or_else(|| {
        syn::Error::new(
            close,
            "the reference has no metric; add e.g. `metric = [[1, 0], [0, 1]];` inside `reference { … }`",
        )
    })?;
    Ok(Reference {
        keyword: keyword.span(),
        entropy: entropy.1,
        metric: metric.1,
    })
}

/// Token trees up to (not including) the next top-level `;`.
fn tokens_until_semicolon(input: ParseStream) -> syn::Result<Vec<TokenTree>> {
    let mut tokens = Vec::new();
    while !input.is_empty() && !input.peek(Token![;]) {
        tokens.push(input.parse::<TokenTree>()?);
    }
    if input.is_empty() {
        return Err(input.error("expected `;` after the expression"));
    }
    Ok(tokens)
}

/// An expression up to the next `;`.
fn parse_expr(input: ParseStream, keyword: Span) -> syn::Result<Expr> {
    let tokens = tokens_until_semicolon(input)?;
    if tokens.is_empty() {
        return Err(syn::Error::new(
            input.span(),
            "expected an expression before `;`",
        ));
    }
    let _ = keyword;
    ExprParser::new(tokens).parse_all()
}

/// A matrix literal up to the next `;`.
fn parse_matrix(input: ParseStream, keyword: Span) -> syn::Result<Matrix> {
    let tokens = tokens_until_semicolon(input)?;
    let hint = "a matrix is written row by row, e.g. `[[0, 1], [-1, 0]]`";
    let group = match tokens.as_slice() {
        [TokenTree::Group(g)] if g.delimiter() == Delimiter::Bracket => g.clone(),
        [] => {
            return Err(syn::Error::new(
                keyword,
                format!("expected a matrix: {hint}"),
            ))
        }
        [first, ..] => {
            let range = SpanRange::single(first.span()).to(SpanRange::single(
                tokens.last().map_or(first.span(), TokenTree::span),
            ));
            return Err(range.error(format!("expected a matrix: {hint}")));
        }
    };
    let mut rows = Vec::new();
    for row_tokens in split_commas(group.stream()) {
        let row = match row_tokens.as_slice() {
            [TokenTree::Group(g)] if g.delimiter() == Delimiter::Bracket => g.clone(),
            [first, ..] => {
                return Err(SpanRange::single(first.span())
                    .error(format!("expected a row in brackets like `[0, 1]`: {hint}")))
            }
            [] => unreachable_empty(&group)?,
        };
        let mut entries = Vec::new();
        for entry in split_commas(row.stream()) {
            entries.push(ExprParser::new(entry).parse_all()?);
        }
        rows.push((row.span(), entries));
    }
    Ok(Matrix {
        span: group.span(),
        rows,
    })
}

/// `split_commas` never yields an empty piece; kept total instead of panicking.
fn unreachable_empty<T>(group: &Group) -> syn::Result<T> {
    Err(syn::Error::new(group.span(), "empty matrix row"))
}

/// Splits a token stream at top-level commas; a trailing comma is allowed.
/// Empty pieces between two commas are reported by the expression parser.
fn split_commas(stream: TokenStream) -> Vec<Vec<TokenTree>> {
    let mut pieces = vec![Vec::new()];
    for token in stream {
        match &token {
            TokenTree::Punct(p) if p.as_char() == ',' => pieces.push(Vec::new()),
            _ => {
                if let Some(last) = pieces.last_mut() {
                    last.push(token);
                }
            }
        }
    }
    if pieces.last().is_some_and(Vec::is_empty) {
        pieces.pop();
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
struct ExprParser {
    tokens: Vec<TokenTree>,
    position: usize,
}

const OPERATORS_HINT: &str = "expressions are polynomials built from numbers, state variables, \
    constants, `+ - * /`, `^` with an integer exponent, and parentheses";

impl ExprParser {
    fn new(tokens: Vec<TokenTree>) -> Self {
        Self {
            tokens,
            position: 0,
        }
    }

    fn parse_all(mut self) -> syn::Result<Expr> {
        if self.tokens.is_empty() {
            return Err(syn::Error::new(
                Span::call_site(),
                "expected an expression (two commas in a row?)",
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
        self.tokens
            .last()
            .map_or_else(Span::call_site, TokenTree::span)
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
                    let mut parser = ExprParser::new(inner);
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
                    let parser = ExprParser::new(group.stream().into_iter().collect());
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
            TokenTree::Punct(p) => Err(self.unexpected(
                &TokenTree::Punct(p),
                "expected a number, a variable, a constant or `(`",
            )),
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

/// Deepest nesting of delimited groups anywhere in the input: the deepest
/// valid input is an expression at [`MAX_NESTING`] inside a reference metric
/// (`reference { metric = [[…]]; }`, three more levels).
const MAX_INPUT_NESTING: usize = MAX_NESTING + 8;
/// Largest number of tokens inside one attribute's brackets: ample for doc
/// comments, `derive`, `allow` and `cfg_attr`, small enough that `syn`'s
/// recursive parsers stay shallow (`#[doc = return return …]` recurses once
/// per token, and 1000 levels overflowed a 2 MiB stack in the tests).
const MAX_ATTRIBUTE_TOKENS: usize = 256;

/// Bounds the whole input before `syn` sees it: `syn` builds its token
/// buffer and parses attribute expressions (`#[doc = …]`) by recursion, so
/// deep nesting or a long prefix-operator chain in an attribute would
/// overflow the compiler's stack instead of producing an error. Iterative,
/// so that it is safe on any input itself.
pub fn check_input_bounds(input: &TokenStream) -> syn::Result<()> {
    let mut stack = vec![input.clone().into_iter()];
    while let Some(tokens) = stack.last_mut() {
        let Some(token) = tokens.next() else {
            stack.pop();
            continue;
        };
        if let TokenTree::Group(group) = token {
            if stack.len() > MAX_INPUT_NESTING {
                return Err(syn::Error::new(
                    group.span(),
                    format!(
                        "brackets nested more than {MAX_INPUT_NESTING} deep; simplify the input"
                    ),
                ));
            }
            stack.push(group.stream().into_iter());
        }
    }
    // Attributes: `#` then a bracketed group, at the top level.
    let top: Vec<TokenTree> = input.clone().into_iter().collect();
    for pair in top.windows(2) {
        if let [TokenTree::Punct(hash), TokenTree::Group(group)] = pair {
            if hash.as_char() == '#' && group.delimiter() == Delimiter::Bracket {
                let count = count_tokens(&group.stream());
                if count > MAX_ATTRIBUTE_TOKENS {
                    return Err(syn::Error::new(
                        group.span(),
                        format!(
                            "attribute too long ({count} tokens, at most {MAX_ATTRIBUTE_TOKENS});                              shorten it"
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Number of token trees in a stream, groups included, counted iteratively.
fn count_tokens(stream: &TokenStream) -> usize {
    let mut count = 0;
    let mut stack = vec![stream.clone().into_iter()];
    while let Some(tokens) = stack.last_mut() {
        match tokens.next() {
            None => {
                stack.pop();
            }
            Some(TokenTree::Group(group)) => {
                count += 1;
                stack.push(group.stream().into_iter());
            }
            Some(_) => count += 1,
        }
    }
    count
}

/// Largest number of tokens in one expression.
const MAX_TOKENS: usize = 2_000;
/// Deepest nesting of parentheses in one expression.
const MAX_NESTING: usize = 64;

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
        return Err(syn::Error::new(
            span,
            format!("numbers are exact and untyped: remove the `{suffix}` suffix"),
        ));
    }
    match Rational::parse_decimal(&digits) {
        Ok(Some(value)) => Ok(Expr::Number { value, span }),
        Ok(None) => Err(syn::Error::new(span, "malformed number")),
        Err(overflow) => Err(syn::Error::new(span, overflow)),
    }
}

/// Parses a lone expression (for the engine's tests).
#[cfg(test)]
pub fn parse_expression(tokens: TokenStream) -> syn::Result<Expr> {
    ExprParser::new(tokens.into_iter().collect()).parse_all()
}
