//! The optional sections of a region certificate: `region ball(…);` or
//! `region box(…);`, `certificate on region;` and `relaxation order N;`
//! (parsed in `sections`, which shares the number syntax with the degrees).
//!
//! Errors inside a region's parentheses are recorded one by one and the
//! rest of the region is still parsed, as for matrix entries.

use proc_macro2::{Delimiter, Group, Ident, Span, TokenTree};

use super::expr::{split_commas, ExprParser, Piece};
use super::sections::Cursor;
use super::syntax::{Expr, Interval, Mode, RegionShape, SpanRange, Vector};
use crate::diagnostics::Diagnostics;

const BALL: &str = "`region ball(center = [0, 0], radius = 2);`";
const BOX: &str = "`region box(q in [-2, 2], p in [-1, 1]);`";

/// `ball(…);` or `box(…);` after `region`. `None` if the shape's structure
/// is broken (its errors are recorded).
pub fn region_section(
    cursor: &mut Cursor,
    keyword: &Ident,
    diagnostics: &mut Diagnostics,
) -> syn::Result<Option<RegionShape>> {
    let shape = match cursor.peek() {
        Some(TokenTree::Ident(shape)) if shape == "ball" || shape == "box" => shape.clone(),
        Some(TokenTree::Ident(shape)) => {
            return Err(syn::Error::new(
                shape.span(),
                format!("unknown region `{shape}`; a region is a ball, e.g. {BALL}, or a box, e.g. {BOX}"),
            ))
        }
        _ => {
            return Err(syn::Error::new(
                cursor.next_span(),
                format!("expected the region's shape after `{keyword}`: a ball, e.g. {BALL}, or a box, e.g. {BOX}"),
            ))
        }
    };
    cursor.next();
    let group = match cursor.peek() {
        Some(TokenTree::Group(g)) if g.delimiter() == Delimiter::Parenthesis => g.clone(),
        _ => {
            let example = if shape == "ball" { BALL } else { BOX };
            return Err(syn::Error::new(
                cursor.next_span(),
                format!("expected the {shape}'s parameters in parentheses, e.g. {example}"),
            ));
        }
    };
    cursor.next();
    let parsed = if shape == "ball" {
        ball(&group, diagnostics)
    } else {
        boxed(&shape, &group, diagnostics)
    };
    cursor.semicolon_after(group.span_close(), "the region", diagnostics);
    Ok(parsed)
}

/// The tokens of a piece from the first to the last, as an error range.
fn piece_range(piece: &Piece) -> SpanRange {
    match (piece.tokens.first(), piece.tokens.last()) {
        (Some(first), Some(last)) => {
            SpanRange::single(first.span()).to(SpanRange::single(last.span()))
        }
        _ => SpanRange::single(piece.end),
    }
}

/// The comma-separated pieces of `group`, also split before each token at
/// which `starts` says a new piece begins (a parameter's name and its `=`,
/// an interval's variable and its `in`): a missing comma costs one error
/// there, and both pieces are still parsed.
fn pieces(
    group: &Group,
    starts: impl Fn(&[TokenTree]) -> bool,
    what: &str,
    example: &str,
    diagnostics: &mut Diagnostics,
) -> Vec<Piece> {
    let mut out = Vec::new();
    for piece in split_commas(group) {
        let mut tokens = piece.tokens;
        while let Some(at) = (1..tokens.len()).find(|&i| starts(&tokens[i..])) {
            let rest = tokens.split_off(at);
            let next = rest[0].span();
            diagnostics.push(syn::Error::new(
                next,
                format!(
                    "expected `,` before `{}`: {what} are separated by commas, e.g. {example}",
                    rest[0]
                ),
            ));
            out.push(Piece { tokens, end: next });
            tokens = rest;
        }
        out.push(Piece {
            tokens,
            end: piece.end,
        });
    }
    out
}

/// An expression made of `tokens`, recording its error.
fn expression(tokens: &[TokenTree], end: Span, diagnostics: &mut Diagnostics) -> Option<Expr> {
    diagnostics.record(ExprParser::new(tokens.to_vec(), end).parse_all())
}

/// `center = [..], radius = ..`
fn ball(group: &Group, diagnostics: &mut Diagnostics) -> Option<RegionShape> {
    let mut center: Option<Option<Vector>> = None;
    let mut radius: Option<Option<Expr>> = None;
    let parameter = |tokens: &[TokenTree]| match tokens {
        [TokenTree::Ident(_), TokenTree::Punct(eq), ..] => eq.as_char() == '=',
        _ => false,
    };
    for piece in pieces(group, parameter, "the ball's parameters", BALL, diagnostics) {
        let (name, value) = match piece.tokens.as_slice() {
            [TokenTree::Ident(name), TokenTree::Punct(eq), value @ ..] if eq.as_char() == '=' => {
                (name, value)
            }
            [] => {
                diagnostics.push(syn::Error::new(
                    piece.end,
                    format!("expected `center = […]` or `radius = …` before this, e.g. {BALL}"),
                ));
                continue;
            }
            _ => {
                diagnostics.push(piece_range(&piece).error(format!(
                    "expected `center = […]` or `radius = …`, e.g. {BALL}"
                )));
                continue;
            }
        };
        let (slot_is_center, already) = match name.to_string().as_str() {
            "center" => (true, center.is_some()),
            "radius" => (false, radius.is_some()),
            other => {
                let hint = if other == "centre" {
                    "; write `center`".to_string()
                } else {
                    String::new()
                };
                diagnostics.push(syn::Error::new(
                    name.span(),
                    format!(
                        "unknown parameter `{other}` of a ball{hint}; a ball has `center = [...]` \
                         (optional, the origin by default) and `radius = …`, e.g. {BALL}"
                    ),
                ));
                continue;
            }
        };
        if already {
            diagnostics.push(syn::Error::new(
                name.span(),
                format!("the ball's `{name}` is given twice; keep one"),
            ));
            continue;
        }
        let value_end = piece.end;
        if slot_is_center {
            center = Some(vector(value, value_end, diagnostics));
        } else {
            radius = Some(expression(value, value_end, diagnostics));
        }
    }
    if radius.is_none() {
        diagnostics.push(syn::Error::new(
            group.span_close(),
            format!("the ball has no radius; add `radius = …`, e.g. {BALL}"),
        ));
    }
    // A centre that failed to parse leaves the whole centre unknown.
    if let Some(None) = center {
        return None;
    }
    Some(RegionShape::Ball {
        center: center.flatten(),
        radius: radius.flatten(),
    })
}

/// `[a, b, …]` (constant expressions); `None` if it is not a bracketed list.
fn vector(tokens: &[TokenTree], end: Span, diagnostics: &mut Diagnostics) -> Option<Vector> {
    let group = match tokens {
        [TokenTree::Group(g)] if g.delimiter() == Delimiter::Bracket => g,
        [] => {
            diagnostics.push(syn::Error::new(
                end,
                "expected the centre's coordinates in brackets before this, e.g. `center = [0, 0]`",
            ));
            return None;
        }
        [first, ..] => {
            let last = tokens.last().map_or(first.span(), TokenTree::span);
            diagnostics.push(
                SpanRange::single(first.span())
                    .to(SpanRange::single(last))
                    .error(
                        "expected the centre's coordinates in brackets, one per state variable, \
                         e.g. `center = [0, 0]`",
                    ),
            );
            return None;
        }
    };
    let entries = split_commas(group)
        .into_iter()
        .map(|entry| expression(&entry.tokens, entry.end, diagnostics))
        .collect();
    Some(Vector {
        span: group.span(),
        entries,
    })
}

/// `q in [l, u], …`
fn boxed(keyword: &Ident, group: &Group, diagnostics: &mut Diagnostics) -> Option<RegionShape> {
    let mut intervals = Vec::new();
    let mut valid = true;
    let interval = |tokens: &[TokenTree]| match tokens {
        [TokenTree::Ident(_), TokenTree::Ident(word), ..] => word == "in",
        _ => false,
    };
    for piece in pieces(group, interval, "the intervals", BOX, diagnostics) {
        let (name, bounds) = match piece.tokens.as_slice() {
            [TokenTree::Ident(name), TokenTree::Ident(word), TokenTree::Group(bounds)]
                if word == "in" && bounds.delimiter() == Delimiter::Bracket =>
            {
                (name.clone(), bounds.clone())
            }
            [] => {
                valid = false;
                diagnostics.push(syn::Error::new(
                    piece.end,
                    format!("expected an interval like `q in [-2, 2]` before this, e.g. {BOX}"),
                ));
                continue;
            }
            _ => {
                valid = false;
                diagnostics.push(piece_range(&piece).error(format!(
                    "expected a state variable and its interval, like `q in [-2, 2]`, e.g. {BOX}"
                )));
                continue;
            }
        };
        let parts = split_commas(&bounds);
        let [lower, upper] = parts.as_slice() else {
            valid = false;
            diagnostics.push(syn::Error::new(
                bounds.span(),
                format!(
                    "an interval has a lower and an upper bound, e.g. `{name} in [-2, 2]`; found \
                     {} entries",
                    parts.len()
                ),
            ));
            continue;
        };
        let lower = expression(&lower.tokens, lower.end, diagnostics);
        let upper = expression(&upper.tokens, upper.end, diagnostics);
        intervals.push(Interval {
            name,
            span: bounds.span(),
            lower,
            upper,
        });
    }
    valid.then(|| RegionShape::Box {
        keyword: keyword.span(),
        intervals,
    })
}

/// `on region;` or `global lower bound;` after `certificate`.
pub fn mode_section(
    cursor: &mut Cursor,
    keyword: &Ident,
    diagnostics: &mut Diagnostics,
) -> syn::Result<Mode> {
    let expected = format!(
        "write `{keyword} on region;` (0 ⪯ K(x) ⪯ ηI certified on the region only) or \
         `{keyword} global lower bound;` (the default: K(x) ⪰ 0 everywhere, K(x) ⪯ ηI on the \
         region)"
    );
    let mut words = Vec::new();
    while let Some(TokenTree::Ident(word)) = cursor.peek() {
        if cursor.at_section_start() {
            break;
        }
        words.push(word.clone());
        cursor.next();
    }
    let text: Vec<String> = words.iter().map(ToString::to_string).collect();
    let mode = match text
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>()
        .as_slice()
    {
        ["on", "region"] => Mode::OnRegion,
        ["global", "lower", "bound"] => Mode::GlobalLowerBound,
        _ => {
            let span = match (words.first(), words.last()) {
                (Some(first), Some(last)) => {
                    SpanRange::single(first.span()).to(SpanRange::single(last.span()))
                }
                _ => SpanRange::single(cursor.next_span()),
            };
            return Err(span.error(format!("unknown certificate mode; {expected}")));
        }
    };
    let last = words.last().map_or(keyword.span(), Ident::span);
    cursor.semicolon_after(last, "the certificate mode", diagnostics);
    Ok(mode)
}
