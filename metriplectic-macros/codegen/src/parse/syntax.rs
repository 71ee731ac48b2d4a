//! The syntax tree of one invocation, with the spans errors point at.
//!
//! Sections that were missing or failed to parse are `None`: their errors
//! are already recorded, and the analysis skips whatever depends on them.

use proc_macro2::{Ident, Punct, Spacing, Span, TokenStream, TokenTree};
use quote::ToTokens;
use syn::{Attribute, Visibility};

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

/// One row `[a, b, …]` of a matrix literal.
#[derive(Debug, Clone)]
pub struct Row {
    /// Span of the row's brackets.
    pub span: Span,
    /// The entries; `None` where an entry failed to parse (already reported).
    pub entries: Vec<Option<Expr>>,
}

/// A matrix literal `[[a, b], [c, d]]`.
#[derive(Debug, Clone)]
pub struct Matrix {
    /// Span of the outer brackets.
    pub span: Span,
    /// The rows, in order.
    pub rows: Vec<Row>,
}

impl Matrix {
    /// The source range of entry (i, j), or of the whole matrix if there is
    /// no such entry.
    pub fn entry_span(&self, i: usize, j: usize) -> SpanRange {
        self.rows
            .get(i)
            .and_then(|row| row.entries.get(j))
            .and_then(Option::as_ref)
            .map_or(SpanRange::single(self.span), Expr::span)
    }
}

/// `state (a, b, …);`
#[derive(Debug, Clone)]
pub struct StateDecl {
    /// Span of the `state` keyword.
    pub keyword: Span,
    /// The variables, in state order, as written (raw identifiers keep
    /// their `r#`).
    pub names: Vec<Ident>,
}

/// `const name = expr;`
#[derive(Debug, Clone)]
pub struct ConstDef {
    /// The constant's name.
    pub name: Ident,
    /// Its defining expression; `None` if it failed to parse.
    pub value: Option<Expr>,
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
    /// `entropy = expr;`
    pub entropy: Option<Expr>,
    /// `metric = matrix;`
    pub metric: Option<Matrix>,
}

/// A list of constant expressions in brackets, `[0, 1/2]`.
#[derive(Debug, Clone)]
pub struct Vector {
    /// Span of the brackets.
    pub span: Span,
    /// The entries; `None` where an entry failed to parse (already reported).
    pub entries: Vec<Option<Expr>>,
}

/// `name in [lower, upper]`: one side of a box region.
#[derive(Debug, Clone)]
pub struct Interval {
    /// The state variable it bounds, as written.
    pub name: Ident,
    /// Span of the brackets.
    pub span: Span,
    /// The lower bound; `None` if it failed to parse (already reported).
    pub lower: Option<Expr>,
    /// The upper bound; `None` if it failed to parse (already reported).
    pub upper: Option<Expr>,
}

/// The shape after `region`.
#[derive(Debug, Clone)]
pub enum RegionShape {
    /// `ball(center = [c₁, …], radius = ρ)`; the centre defaults to the origin.
    Ball {
        /// `center = […]`, if written.
        center: Option<Vector>,
        /// `radius = …`; `None` if missing or broken (already reported).
        radius: Option<Expr>,
    },
    /// `box(q in [l, u], …)`, one interval per state variable.
    Box {
        /// Span of `box`.
        keyword: Span,
        /// The intervals, in the order written.
        intervals: Vec<Interval>,
    },
}

/// `region …;`
#[derive(Debug, Clone)]
pub struct RegionDecl {
    /// Span of the `region` keyword.
    pub keyword: Span,
    /// The shape; `None` if it failed to parse (already reported).
    pub shape: Option<RegionShape>,
}

/// Which bounds of 0 ⪯ K(x) ⪯ ηI a region certificate proves where.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// `certificate global lower bound;` (the default): K(x) ⪰ 0 everywhere,
    /// K(x) ⪯ ηI on the region.
    GlobalLowerBound,
    /// `certificate on region;`: both bounds on the region only.
    OnRegion,
}

/// `certificate …;`
#[derive(Debug, Clone, Copy)]
pub struct CertificateDecl {
    /// Span of the `certificate` keyword.
    pub keyword: Span,
    /// The mode; `None` if it failed to parse (already reported).
    pub mode: Option<Mode>,
}

/// `relaxation order N;`
#[derive(Debug, Clone, Copy)]
pub struct RelaxationDecl {
    /// Span of the `relaxation` keyword.
    pub keyword: Span,
    /// The order; `None` if it failed to parse (already reported).
    pub order: Option<Degree>,
}

/// A whole `metriplectic! { … }` invocation, as far as it parsed.
#[derive(Debug, Clone)]
pub struct SystemDef {
    /// Outer attributes of the struct (doc comments and others).
    pub attrs: Vec<Attribute>,
    /// Visibility of the struct.
    pub vis: Visibility,
    /// The struct's name.
    pub name: Option<Ident>,
    /// The state variables.
    pub state: Option<StateDecl>,
    /// Named constants, in declaration order.
    pub consts: Vec<ConstDef>,
    /// Π(x).
    pub poisson: Option<Matrix>,
    /// H(x).
    pub hamiltonian: Option<Expr>,
    /// Entropy degree r.
    pub entropy_degree: Option<Degree>,
    /// Metric degree s.
    pub metric_degree: Option<Degree>,
    /// The reference model, if declared.
    pub reference: Option<Reference>,
    /// The region of the metric certificate, if declared (even if broken).
    pub region: Option<RegionDecl>,
    /// The certificate mode, if declared.
    pub certificate: Option<CertificateDecl>,
    /// The relaxation order, if declared.
    pub relaxation: Option<RelaxationDecl>,
    /// Span of the `classical` keyword, if declared.
    pub classical: Option<Span>,
}
