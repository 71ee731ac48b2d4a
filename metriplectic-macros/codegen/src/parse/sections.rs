//! The section structure of an invocation (`pub struct Name;`, `state (…);`,
//! `poisson = …;`, …), parsed with recovery.
//!
//! The parser walks the invocation's token trees itself rather than through
//! `syn`'s `ParseStream`, so that after an error it can skip to the next
//! section and keep going: every section's errors are reported in one
//! compile. Recovery skips to the next top-level `;`, past a braced group
//! (`reference { … }`, or a struct body written by mistake), or up to the
//! next token that can only start a section (`hamiltonian =`, `state (`,
//! `entropy degree`, …): such a token never occurs inside a valid section,
//! so stopping there never cuts a valid section short, and a forgotten `;`
//! costs one error, not the next section.

use proc_macro2::{Delimiter, Group, Ident, Span, TokenStream, TokenTree};
use syn::{Attribute, Visibility};

use super::certificate;
use super::expr::{split_commas, ExprParser};
use super::syntax::{
    CertificateDecl, ConstDef, Degree, Expr, Matrix, Reference, RegionDecl, RelaxationDecl, Row,
    SpanRange, StateDecl, SystemDef,
};
use crate::diagnostics::Diagnostics;

const SECTIONS: &str = "`state (…);`, `const NAME = …;`, `poisson = [[…]];`, \
    `hamiltonian = …;`, `entropy degree N;`, `metric degree N;`, `reference { … }`, \
    `region ball(…);` or `region box(…);`, `certificate on region;`, `relaxation order N;` \
    or `classical;`";

const MATRIX_HINT: &str = "a matrix is written row by row, e.g. `[[0, 1], [-1, 0]]`";

/// How much of the input to parse.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scope {
    /// Everything.
    Full,
    /// Only the struct's name, skipping attributes unparsed: for inputs that
    /// failed the bounds check, where `syn` must not see the attributes and
    /// every other error would repeat the bounds error.
    HeaderOnly,
}

/// Parses an invocation as far as possible, recording every error.
pub fn parse_system(input: TokenStream, scope: Scope, diagnostics: &mut Diagnostics) -> SystemDef {
    let mut cursor = Cursor::new(input, Level::Top);
    let (attrs, vis, name) = header(&mut cursor, scope, diagnostics);
    let mut def = SystemDef {
        attrs,
        vis,
        name,
        state: None,
        consts: Vec::new(),
        poisson: None,
        hamiltonian: None,
        entropy_degree: None,
        metric_degree: None,
        reference: None,
        region: None,
        certificate: None,
        relaxation: None,
        classical: None,
    };
    if scope == Scope::HeaderOnly {
        return def;
    }
    let mut seen = Seen::default();
    while let Some(token) = cursor.peek().cloned() {
        let before = cursor.position;
        if let Err(error) = section(&mut cursor, &token, &mut def, &mut seen, diagnostics) {
            diagnostics.push(error);
            cursor.skip_section();
        }
        if cursor.position == before {
            // Cannot happen (every section consumes its keyword); kept so
            // that the loop provably ends.
            cursor.position += 1;
        }
    }
    report_missing(&def, &seen, cursor.end_span(), diagnostics);
    def
}

/// The sections seen so far (present, even if they failed to parse).
#[derive(Default)]
struct Seen {
    state: bool,
    poisson: bool,
    hamiltonian: bool,
    entropy: bool,
    metric: bool,
    reference: bool,
    region: bool,
    certificate: bool,
    relaxation: bool,
    classical: bool,
}

fn report_missing(def: &SystemDef, seen: &Seen, end: Span, diagnostics: &mut Diagnostics) {
    let (span, name) = match &def.name {
        Some(name) => (name.span(), format!("`{name}`")),
        None => (end, "the system".to_string()),
    };
    let missing = [
        (seen.state, "state", "state (q, p);"),
        (
            seen.poisson,
            "Poisson tensor",
            "poisson = [[0, 1], [-1, 0]];",
        ),
        (
            seen.hamiltonian,
            "Hamiltonian",
            "hamiltonian = 0.5 * p^2 + 0.5 * q^2;",
        ),
        (seen.entropy, "entropy basis", "entropy degree 4;"),
        (seen.metric, "metric basis", "metric degree 2;"),
    ];
    for (_, section, example) in missing.iter().filter(|(seen, _, _)| !seen) {
        diagnostics.push(syn::Error::new(
            span,
            format!("{name} has no {section} section; add one, e.g. `{example}`"),
        ));
    }
}

/// Parses the section starting at `token`, storing it in `def`. Errors of
/// its parts that do not stop the section (a bad matrix entry) are recorded
/// directly; an `Err` means the rest of the section must be skipped.
fn section(
    cursor: &mut Cursor,
    token: &TokenTree,
    def: &mut SystemDef,
    seen: &mut Seen,
    diagnostics: &mut Diagnostics,
) -> syn::Result<()> {
    let TokenTree::Ident(keyword) = token else {
        return Err(syn::Error::new(
            token.span(),
            format!("expected a section: {SECTIONS}"),
        ));
    };
    let word = keyword.to_string();
    let slot = match word.as_str() {
        "state" => &mut seen.state,
        "poisson" => &mut seen.poisson,
        "hamiltonian" => &mut seen.hamiltonian,
        "entropy" => &mut seen.entropy,
        "metric" => &mut seen.metric,
        "reference" => &mut seen.reference,
        "region" => &mut seen.region,
        "certificate" => &mut seen.certificate,
        "relaxation" => &mut seen.relaxation,
        "classical" => &mut seen.classical,
        "const" => {
            cursor.next();
            def.consts.push(const_section(cursor, diagnostics)?);
            return Ok(());
        }
        other => {
            return Err(syn::Error::new(
                keyword.span(),
                format!("unknown section `{other}`; expected {SECTIONS}"),
            ))
        }
    };
    // `entropy = …` at the top level is a reference entropy out of place,
    // not a second entropy section.
    if matches!(word.as_str(), "entropy" | "metric") && cursor.peek_punct_at(1, '=') {
        cursor.next();
        return Err(syn::Error::new(
            keyword.span(),
            format!(
                "`{word} = …` belongs inside `reference {{ … }}`; the {word} basis is declared \
                 with `{word} degree N;`"
            ),
        ));
    }
    let first = !*slot;
    if !first {
        diagnostics.push(syn::Error::new(
            keyword.span(),
            format!("`{word}` is declared twice; keep a single `{word}` section"),
        ));
    }
    *slot = true;
    cursor.next();
    // A repeated section is still parsed, for its own errors, but not kept.
    match word.as_str() {
        "state" => {
            let state = state_section(cursor, keyword, diagnostics)?;
            if first {
                def.state = state;
            }
        }
        "poisson" => {
            let matrix = matrix_section(cursor, keyword, diagnostics)?;
            if first {
                def.poisson = matrix;
            }
        }
        "hamiltonian" => {
            let expr = expression_section(cursor, keyword, diagnostics)?;
            if first {
                def.hamiltonian = expr;
            }
        }
        "entropy" | "metric" => {
            let degree = number_section(cursor, keyword, "degree", "the degree", diagnostics)?;
            if first {
                if word == "entropy" {
                    def.entropy_degree = Some(degree);
                } else {
                    def.metric_degree = Some(degree);
                }
            }
        }
        // The optional sections of a certificate count as declared even when
        // they fail to parse: their own error is enough, and `certificate`
        // after a broken `region` is not "without a region".
        "region" => {
            if first {
                def.region = Some(RegionDecl {
                    keyword: keyword.span(),
                    shape: None,
                });
            }
            let shape = certificate::region_section(cursor, keyword, diagnostics)?;
            if let (true, Some(region)) = (first, def.region.as_mut()) {
                region.shape = shape;
            }
        }
        "certificate" => {
            if first {
                def.certificate = Some(CertificateDecl {
                    keyword: keyword.span(),
                    mode: None,
                });
            }
            let mode = certificate::mode_section(cursor, keyword, diagnostics)?;
            if let (true, Some(certificate)) = (first, def.certificate.as_mut()) {
                certificate.mode = Some(mode);
            }
        }
        "relaxation" => {
            if first {
                def.relaxation = Some(RelaxationDecl {
                    keyword: keyword.span(),
                    order: None,
                });
            }
            let order = number_section(
                cursor,
                keyword,
                "order",
                "the relaxation order",
                diagnostics,
            )?;
            if let (true, Some(relaxation)) = (first, def.relaxation.as_mut()) {
                relaxation.order = Some(order);
            }
        }
        "classical" => {
            if first {
                def.classical = Some(keyword.span());
            }
            cursor.semicolon_after(keyword.span(), "`classical`", diagnostics);
        }
        _ => {
            let reference = reference_section(cursor, diagnostics)?;
            if first {
                def.reference = Some(reference);
            }
        }
    }
    Ok(())
}

/// `[#[attr]…] [pub…] struct Name;`
fn header(
    cursor: &mut Cursor,
    scope: Scope,
    diagnostics: &mut Diagnostics,
) -> (Vec<Attribute>, Visibility, Option<Ident>) {
    let mut attribute_tokens = TokenStream::new();
    while let (Some(TokenTree::Punct(hash)), Some(TokenTree::Group(group))) =
        (cursor.peek_at(0), cursor.peek_at(1))
    {
        if hash.as_char() != '#' || group.delimiter() != Delimiter::Bracket {
            break;
        }
        attribute_tokens.extend(cursor.next());
        attribute_tokens.extend(cursor.next());
    }
    let attrs = if scope == Scope::Full {
        diagnostics
            .record(syn::parse::Parser::parse2(
                Attribute::parse_outer,
                attribute_tokens,
            ))
            .unwrap_or_default()
    } else {
        Vec::new()
    };

    let mut vis_tokens = TokenStream::new();
    let fragment = matches!(cursor.peek(), Some(TokenTree::Group(g))
        if g.delimiter() == Delimiter::None
            && matches!(g.stream().into_iter().next(), Some(TokenTree::Ident(i)) if i == "pub"));
    if fragment {
        // `pub(crate)` passed as a `$vis:vis` fragment.
        vis_tokens.extend(cursor.next());
    } else if cursor.peek_word("pub") {
        vis_tokens.extend(cursor.next());
        if let Some(TokenTree::Group(group)) = cursor.peek() {
            if group.delimiter() == Delimiter::Parenthesis {
                vis_tokens.extend(cursor.next());
            }
        }
    }
    let vis = diagnostics
        .record(syn::parse2::<Visibility>(vis_tokens))
        .unwrap_or(Visibility::Inherited);

    let name = match struct_name(cursor) {
        Ok(name) => name,
        Err(error) => {
            if scope == Scope::Full {
                diagnostics.push(error);
                cursor.skip_section();
            }
            return (attrs, vis, None);
        }
    };
    if cursor.peek_punct_at(0, ';') {
        cursor.next();
    } else if scope == Scope::Full {
        diagnostics.push(syn::Error::new(
            cursor.next_span(),
            format!("the system type is a unit struct: write `struct {name};`"),
        ));
        cursor.skip_section();
    }
    (attrs, vis, Some(name))
}

/// `struct Name` (without the `;`).
fn struct_name(cursor: &mut Cursor) -> syn::Result<Ident> {
    if !cursor.peek_word("struct") {
        return Err(syn::Error::new(
            cursor.next_span(),
            "a system starts with its type, e.g. `pub struct Oscillator;` (doc comments may \
             precede it)",
        ));
    }
    cursor.next();
    match cursor.peek() {
        Some(TokenTree::Ident(name)) if name == "Self" => Err(syn::Error::new(
            name.span(),
            "choose a type name other than `Self`",
        )),
        Some(TokenTree::Ident(name)) if is_identifier(name) => {
            let name = name.clone();
            cursor.next();
            Ok(name)
        }
        _ => Err(syn::Error::new(
            cursor.next_span(),
            "expected the system's name after `struct`, e.g. `pub struct Oscillator;`",
        )),
    }
}

/// Whether `ident` can name a variable or a type: not a keyword, not `_`.
fn is_identifier(ident: &Ident) -> bool {
    syn::parse2::<Ident>(TokenTree::Ident(ident.clone()).into()).is_ok()
}

/// `state (a, b, …);` after the keyword. `None` if a name is invalid.
fn state_section(
    cursor: &mut Cursor,
    keyword: &Ident,
    diagnostics: &mut Diagnostics,
) -> syn::Result<Option<StateDecl>> {
    let example = "e.g. `state (q, p);`";
    let group = match cursor.peek() {
        Some(TokenTree::Group(g)) if g.delimiter() == Delimiter::Parenthesis => g.clone(),
        _ => {
            return Err(syn::Error::new(
                cursor.next_span(),
                format!("expected the state variables in parentheses, {example}"),
            ))
        }
    };
    cursor.next();
    let mut names = Vec::new();
    let mut valid = true;
    for piece in split_commas(&group) {
        match piece.tokens.as_slice() {
            [TokenTree::Ident(name)] if is_identifier(name) => names.push(name.clone()),
            [] => {
                valid = false;
                diagnostics.push(syn::Error::new(
                    piece.end,
                    "expected a state variable name before this",
                ));
            }
            // `state (q p)`: names without the comma between them.
            [_, second, ..]
                if piece
                    .tokens
                    .iter()
                    .all(|t| matches!(t, TokenTree::Ident(name) if is_identifier(name))) =>
            {
                valid = false;
                diagnostics.push(syn::Error::new(
                    second.span(),
                    format!(
                        "expected `,` before `{second}`: state variables are separated by \
                         commas, {example}"
                    ),
                ));
            }
            [first, ..] => {
                valid = false;
                let last = piece.tokens.last().map_or(first.span(), TokenTree::span);
                diagnostics.push(
                    SpanRange::single(first.span())
                        .to(SpanRange::single(last))
                        .error(format!(
                            "expected a state variable name (an identifier that is not a \
                             keyword), {example}"
                        )),
                );
            }
        }
    }
    if valid && names.is_empty() {
        valid = false;
        diagnostics.push(syn::Error::new(
            keyword.span(),
            format!("the state needs at least one variable, {example}"),
        ));
    }
    cursor.semicolon_after(group.span_close(), "`state (…)`", diagnostics);
    Ok(valid.then(|| StateDecl {
        keyword: keyword.span(),
        names,
    }))
}

/// `const name = expr;` after `const`.
fn const_section(cursor: &mut Cursor, diagnostics: &mut Diagnostics) -> syn::Result<ConstDef> {
    let name = match cursor.peek() {
        Some(TokenTree::Ident(name)) if is_identifier(name) => name.clone(),
        _ => {
            return Err(syn::Error::new(
                cursor.next_span(),
                "expected the constant's name, e.g. `const k = 2;`",
            ))
        }
    };
    cursor.next();
    let value = expression_section(cursor, &name, diagnostics)?;
    Ok(ConstDef { name, value })
}

/// `= expr;` after `keyword`.
fn expression_section(
    cursor: &mut Cursor,
    keyword: &Ident,
    diagnostics: &mut Diagnostics,
) -> syn::Result<Option<Expr>> {
    cursor.expect_eq(keyword)?;
    let body = cursor.body(keyword.span(), "the expression", diagnostics);
    Ok(diagnostics.record(ExprParser::new(body.tokens, body.end).parse_all()))
}

/// `= [[…], …];` after `keyword`.
fn matrix_section(
    cursor: &mut Cursor,
    keyword: &Ident,
    diagnostics: &mut Diagnostics,
) -> syn::Result<Option<Matrix>> {
    cursor.expect_eq(keyword)?;
    let body = cursor.body(keyword.span(), "the matrix", diagnostics);
    Ok(matrix(&body.tokens, body.end, diagnostics))
}

/// A matrix literal. `None` if its row structure is broken; entries that
/// fail to parse are `None` inside an otherwise usable matrix.
fn matrix(tokens: &[TokenTree], end: Span, diagnostics: &mut Diagnostics) -> Option<Matrix> {
    let group = match tokens {
        [TokenTree::Group(g)] if g.delimiter() == Delimiter::Bracket => g,
        [] => {
            diagnostics.push(syn::Error::new(
                end,
                format!("expected a matrix before this: {MATRIX_HINT}"),
            ));
            return None;
        }
        [first, ..] => {
            let last = tokens.last().map_or(first.span(), TokenTree::span);
            diagnostics.push(
                SpanRange::single(first.span())
                    .to(SpanRange::single(last))
                    .error(format!("expected a matrix: {MATRIX_HINT}")),
            );
            return None;
        }
    };
    let mut rows = Vec::new();
    let mut valid = true;
    for piece in split_commas(group) {
        let row: &Group = match piece.tokens.as_slice() {
            [TokenTree::Group(g)] if g.delimiter() == Delimiter::Bracket => g,
            [] => {
                valid = false;
                diagnostics.push(syn::Error::new(
                    piece.end,
                    format!("expected a row before this: {MATRIX_HINT}"),
                ));
                continue;
            }
            [first, ..] => {
                valid = false;
                let last = piece.tokens.last().map_or(first.span(), TokenTree::span);
                diagnostics.push(
                    SpanRange::single(first.span())
                        .to(SpanRange::single(last))
                        .error(format!(
                            "expected a row in brackets like `[0, 1]`: {MATRIX_HINT}"
                        )),
                );
                continue;
            }
        };
        let entries = split_commas(row)
            .into_iter()
            .map(|entry| diagnostics.record(ExprParser::new(entry.tokens, entry.end).parse_all()))
            .collect();
        rows.push(Row {
            span: row.span(),
            entries,
        });
    }
    valid.then(|| Matrix {
        span: group.span(),
        rows,
    })
}

/// `degree N;` after `entropy` or `metric`, `order N;` after `relaxation`:
/// `word` is the word before the number, `what` names the number.
fn number_section(
    cursor: &mut Cursor,
    keyword: &Ident,
    word: &str,
    what: &str,
    diagnostics: &mut Diagnostics,
) -> syn::Result<Degree> {
    let example = if word == "degree" {
        format!("write `{keyword} degree 4;`")
    } else {
        format!("write `{keyword} {word} 1;`")
    };
    match cursor.peek() {
        Some(TokenTree::Ident(found)) if found == word => {
            cursor.next();
        }
        _ => {
            return Err(syn::Error::new(
                cursor.next_span(),
                format!("expected `{word}`: {example}"),
            ))
        }
    }
    let literal = match cursor.peek() {
        Some(TokenTree::Literal(literal)) => match syn::Lit::new(literal.clone()) {
            // As in expressions, numbers are untyped: `4u8` is refused.
            syn::Lit::Int(int) if !int.suffix().is_empty() => {
                return Err(syn::Error::new(
                    literal.span(),
                    format!(
                        "{what} is written without a type suffix: `{}`, not `{int}`",
                        int.base10_digits()
                    ),
                ))
            }
            syn::Lit::Int(int) => int,
            _ => {
                return Err(syn::Error::new(
                    literal.span(),
                    format!("{what} is a non-negative integer literal: {example}"),
                ))
            }
        },
        _ => {
            return Err(syn::Error::new(
                cursor.next_span(),
                format!("{what} is a non-negative integer literal: {example}"),
            ))
        }
    };
    cursor.next();
    let value = literal.base10_parse::<u32>().map_err(|_| {
        syn::Error::new(
            literal.span(),
            format!("{what} is a small non-negative integer: {example}"),
        )
    })?;
    cursor.semicolon_after(literal.span(), what, diagnostics);
    Ok(Degree {
        value,
        span: literal.span(),
    })
}

/// `{ entropy = …; metric = [[…]]; }` after `reference`.
fn reference_section(cursor: &mut Cursor, diagnostics: &mut Diagnostics) -> syn::Result<Reference> {
    let items = "a reference holds `entropy = …;` and `metric = [[…]];`";
    let group = match cursor.peek() {
        Some(TokenTree::Group(g)) if g.delimiter() == Delimiter::Brace => g.clone(),
        _ => {
            return Err(syn::Error::new(
                cursor.next_span(),
                format!("expected `{{` after `reference`: {items}, in braces"),
            ))
        }
    };
    cursor.next();
    let mut inner = Cursor::new(group.stream(), Level::Reference);
    let mut reference = Reference {
        entropy: None,
        metric: None,
    };
    let (mut seen_entropy, mut seen_metric) = (false, false);
    while let Some(token) = inner.peek().cloned() {
        let item = match &token {
            TokenTree::Ident(item) if item == "entropy" || item == "metric" => item.clone(),
            TokenTree::Ident(item) => {
                diagnostics.push(syn::Error::new(
                    item.span(),
                    format!("unknown reference item `{item}`; {items}"),
                ));
                inner.next();
                inner.skip_section();
                continue;
            }
            other => {
                diagnostics.push(syn::Error::new(
                    other.span(),
                    format!("expected `entropy` or `metric`: {items}"),
                ));
                inner.skip_section();
                continue;
            }
        };
        inner.next();
        let seen = if item == "entropy" {
            &mut seen_entropy
        } else {
            &mut seen_metric
        };
        let first = !*seen;
        *seen = true;
        if !first {
            diagnostics.push(syn::Error::new(
                item.span(),
                format!("the reference `{item}` is declared twice; keep one"),
            ));
        }
        let parsed = if item == "entropy" {
            expression_section(&mut inner, &item, diagnostics).map(|e| {
                if first {
                    reference.entropy = e;
                }
            })
        } else {
            matrix_section(&mut inner, &item, diagnostics).map(|m| {
                if first {
                    reference.metric = m;
                }
            })
        };
        if let Err(error) = parsed {
            diagnostics.push(error);
            inner.skip_section();
        }
    }
    let close = group.span_close();
    if !seen_entropy {
        diagnostics.push(syn::Error::new(
            close,
            "the reference has no entropy; add `entropy = …;` inside `reference { … }`",
        ));
    }
    if !seen_metric {
        diagnostics.push(syn::Error::new(
            close,
            "the reference has no metric; add e.g. `metric = [[1, 0], [0, 1]];` inside \
             `reference { … }`",
        ));
    }
    Ok(reference)
}

/// Which tokens start a section: the top level's or a reference's items.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Level {
    Top,
    Reference,
}

/// An invisible group (a `macro_rules!` fragment such as `$degree:literal`)
/// around a single token is that token. Invisible groups of several tokens
/// stay groups: an `$e:expr` fragment `q + p` is one operand, which the
/// expression parser treats like parentheses.
fn look_through(token: TokenTree) -> TokenTree {
    let mut token = token;
    loop {
        let TokenTree::Group(group) = &token else {
            return token;
        };
        if group.delimiter() != Delimiter::None {
            return token;
        }
        let mut inner = group.stream().into_iter();
        match (inner.next(), inner.next()) {
            (Some(only), None) => token = only,
            _ => return token,
        }
    }
}

/// The tokens of a section's right-hand side and what ended it.
pub(super) struct Body {
    pub(super) tokens: Vec<TokenTree>,
    /// The `;` after the body, or its last token: where "expected an
    /// operand" errors at its end point.
    pub(super) end: Span,
}

/// A position in a flat list of token trees.
pub(super) struct Cursor {
    tokens: Vec<TokenTree>,
    position: usize,
    level: Level,
}

impl Cursor {
    fn new(input: TokenStream, level: Level) -> Self {
        let tokens = input.into_iter().map(look_through).collect();
        Self {
            tokens,
            position: 0,
            level,
        }
    }

    pub(super) fn peek(&self) -> Option<&TokenTree> {
        self.peek_at(0)
    }

    pub(super) fn peek_at(&self, offset: usize) -> Option<&TokenTree> {
        self.tokens.get(self.position + offset)
    }

    pub(super) fn next(&mut self) -> Option<TokenTree> {
        let token = self.tokens.get(self.position).cloned();
        if token.is_some() {
            self.position += 1;
        }
        token
    }

    pub(super) fn peek_word(&self, word: &str) -> bool {
        matches!(self.peek(), Some(TokenTree::Ident(i)) if i == word)
    }

    pub(super) fn peek_punct_at(&self, offset: usize, c: char) -> bool {
        matches!(self.peek_at(offset), Some(TokenTree::Punct(p)) if p.as_char() == c)
    }

    /// The span of the next token, or of the last one at the end: where an
    /// error about what should come next points.
    pub(super) fn next_span(&self) -> Span {
        self.peek().map_or_else(|| self.end_span(), TokenTree::span)
    }

    /// The span of the last token of the input (the macro call if empty).
    fn end_span(&self) -> Span {
        self.tokens
            .last()
            .map_or_else(Span::call_site, TokenTree::span)
    }

    /// Whether the next tokens can only be the start of a section.
    pub(super) fn at_section_start(&self) -> bool {
        let Some(TokenTree::Ident(word)) = self.peek() else {
            return false;
        };
        let word = word.to_string();
        let next = self.peek_at(1);
        let group =
            |delimiter| matches!(next, Some(TokenTree::Group(g)) if g.delimiter() == delimiter);
        let eq = self.peek_punct_at(1, '=');
        let ident = matches!(next, Some(TokenTree::Ident(_)));
        match (self.level, word.as_str()) {
            (Level::Top, "const") => true,
            (Level::Top, "state") => group(Delimiter::Parenthesis),
            (Level::Top, "poisson" | "hamiltonian") => eq,
            (Level::Top, "entropy" | "metric") => {
                matches!(next, Some(TokenTree::Ident(d)) if d == "degree")
            }
            (Level::Top, "reference") => group(Delimiter::Brace),
            // Two names in a row never occur inside a valid section.
            (Level::Top, "region" | "certificate") => ident,
            (Level::Top, "relaxation") => {
                matches!(next, Some(TokenTree::Ident(o)) if o == "order")
            }
            // `classical;` could also end an expression that uses a variable
            // or constant named `classical` (`H = p + classical;`): there an
            // operator or `=` precedes it.
            (Level::Top, "classical") => {
                self.peek_punct_at(1, ';')
                    && !matches!(
                        self.position.checked_sub(1).and_then(|i| self.tokens.get(i)),
                        Some(TokenTree::Punct(p)) if p.as_char() != ';'
                    )
            }
            (Level::Reference, "entropy" | "metric") => eq,
            _ => false,
        }
    }

    /// Recovery after an error: skips past the next top-level `;` or braced
    /// group, or up to the next section start, whichever comes first.
    pub(super) fn skip_section(&mut self) {
        while let Some(token) = self.peek() {
            if self.at_section_start() {
                return;
            }
            let stop = match token {
                TokenTree::Punct(p) => p.as_char() == ';',
                TokenTree::Group(g) => g.delimiter() == Delimiter::Brace,
                _ => false,
            };
            self.position += 1;
            if stop {
                if self.peek_punct_at(0, ';') {
                    self.position += 1;
                }
                return;
            }
        }
    }

    /// Expects `=` after `keyword`.
    pub(super) fn expect_eq(&mut self, keyword: &Ident) -> syn::Result<()> {
        if self.peek_punct_at(0, '=') {
            self.next();
            Ok(())
        } else {
            Err(syn::Error::new(
                self.next_span(),
                format!("expected `=` after `{keyword}`"),
            ))
        }
    }

    /// The tokens up to the next top-level `;` (consumed) or section start.
    /// A missing `;` is recorded, and the body is still returned.
    pub(super) fn body(
        &mut self,
        keyword: Span,
        what: &str,
        diagnostics: &mut Diagnostics,
    ) -> Body {
        let mut tokens = Vec::new();
        while let Some(token) = self.peek() {
            if self.peek_punct_at(0, ';') {
                let end = token.span();
                self.position += 1;
                return Body { tokens, end };
            }
            if self.at_section_start() {
                break;
            }
            tokens.push(token.clone());
            self.position += 1;
        }
        let end = tokens.last().map_or(keyword, TokenTree::span);
        // An empty body is reported by its parser ("expected an expression");
        // a missing `;` after nothing would only repeat that.
        if !tokens.is_empty() {
            diagnostics.push(syn::Error::new(end, format!("expected `;` after {what}")));
        }
        Body { tokens, end }
    }

    /// Expects `;` after a construct ending at `after`; records its absence.
    pub(super) fn semicolon_after(
        &mut self,
        after: Span,
        what: &str,
        diagnostics: &mut Diagnostics,
    ) {
        if self.peek_punct_at(0, ';') {
            self.next();
        } else {
            diagnostics.push(syn::Error::new(after, format!("expected `;` after {what}")));
            if !self.at_section_start() {
                self.skip_section();
            }
        }
    }
}
