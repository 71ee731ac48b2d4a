//! The macro never panics: random and mutated DSL inputs, fed to
//! [`metriplectic_codegen::try_expand`] as `proc_macro2` token streams, end in `Ok(_)` or a
//! spanned `syn::Error`, never in a panic or a stack overflow.
//!
//! Three generators:
//! * token soups from a grammar of DSL-ish tokens (names, keywords, odd and
//!   huge literals, operators, balanced groups), alone or in place of one
//!   section of a valid system;
//! * the paper systems with 1–4 random mutations (delete, duplicate, swap or
//!   replace tokens, extreme numbers, huge exponents and degrees, deep
//!   nesting, a dropped bracket);
//! * random valid polynomial systems, which must expand to code that parses.
//!
//! Each runs `PROPTEST_CASES` cases (default [`DEFAULT_CASES`]) and prints
//! what it saw (`--nocapture`): how many inputs were accepted, rejected with
//! an error, or not lexable as Rust tokens at all (rustc rejects those before
//! the macro runs).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicUsize, Ordering};

use proc_macro2::{Delimiter, TokenStream, TokenTree};
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, TestCaseError, TestRunner};

/// Cases per generator when `PROPTEST_CASES` is unset.
const DEFAULT_CASES: u32 = 3000;

fn config() -> Config {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(DEFAULT_CASES);
    Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    }
}

/// What happened to the inputs of one generator.
#[derive(Default)]
struct Tally {
    accepted: AtomicUsize,
    rejected: AtomicUsize,
    /// Rejected with the span of the whole macro call (no finer location).
    call_site: AtomicUsize,
    unlexable: AtomicUsize,
}

impl Tally {
    fn report(&self, name: &str) {
        println!(
            "{name}: {} accepted, {} rejected with a compile error ({} of them spanned at the \
             macro call), {} not lexable as Rust tokens",
            self.accepted.load(Ordering::Relaxed),
            self.rejected.load(Ordering::Relaxed),
            self.call_site.load(Ordering::Relaxed),
            self.unlexable.load(Ordering::Relaxed),
        );
    }
}

/// Runs the macro on source text; a panic or an error without a message is
/// a test failure. Returns whether the input was accepted.
fn check_text(text: &str, tally: &Tally) -> Result<Option<bool>, TestCaseError> {
    let Ok(tokens) = text.parse::<TokenStream>() else {
        tally.unlexable.fetch_add(1, Ordering::Relaxed);
        return Ok(None);
    };
    check_tokens(tokens, text, tally).map(Some)
}

fn check_tokens(tokens: TokenStream, text: &str, tally: &Tally) -> Result<bool, TestCaseError> {
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        metriplectic_codegen::try_expand(tokens)
    }));
    match outcome {
        Err(payload) => {
            let message = payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(TestCaseError::fail(format!(
                "the macro panicked ({message}) on:\n{text}"
            )))
        }
        Ok(Ok(_)) => {
            tally.accepted.fetch_add(1, Ordering::Relaxed);
            Ok(true)
        }
        Ok(Err(failure)) => {
            tally.rejected.fetch_add(1, Ordering::Relaxed);
            let error = failure.errors();
            // Only the macro call itself has byte range 0..0 in proc_macro2's
            // fallback source map; every parsed token has a real position.
            if error.span().byte_range() == (0..0) {
                tally.call_site.fetch_add(1, Ordering::Relaxed);
            }
            for part in error.clone() {
                if part.to_string().trim().is_empty() {
                    return Err(TestCaseError::fail(format!(
                        "empty error message on:\n{text}"
                    )));
                }
            }
            // The errors and the stand-in items are valid Rust items.
            let output = failure.into_tokens();
            if let Err(e) = syn::parse2::<syn::File>(output) {
                return Err(TestCaseError::fail(format!(
                    "the output with errors does not parse ({e}) on:\n{text}"
                )));
            }
            Ok(false)
        }
    }
}

// ---- generator (a): token soups ---------------------------------------------

/// Single tokens, each lexable on its own.
const WORDS: &[&str] = &[
    "q",
    "p",
    "x",
    "y",
    "z",
    "px",
    "S",
    "Self",
    "self",
    "crate",
    "r#type",
    "_",
    "sin",
    "m",
    "state",
    "poisson",
    "hamiltonian",
    "entropy",
    "metric",
    "degree",
    "reference",
    "const",
    "region",
    "ball",
    "box",
    "center",
    "radius",
    "certificate",
    "on",
    "global",
    "lower",
    "bound",
    "relaxation",
    "order",
    "classical",
    "pub",
    "struct",
    "fn",
    "let",
    "in",
];
const NUMBERS: &[&str] = &[
    "0",
    "1",
    "2",
    "8",
    "64",
    "65",
    "0.5",
    "1.",
    "1e308",
    "1e-308",
    "1e400",
    "1E-99999999999999999999",
    "0e99999",
    "4294967296",
    "18446744073709551616",
    "170141183460469231731687303715884105727",
    "170141183460469231731687303715884105728",
    "340282366920938463463374607431768211456",
    "0.000000000000000000000000000000000000000001",
    "123456789.123456789123456789123456789",
    "1_000",
    "0x1F",
    "0b101",
    "0o7",
    "1u8",
    "2.5f64",
    "1e10i32",
    "\"text\"",
    "'c'",
    "b'x'",
    "true",
];
const PUNCTS: &[&str] = &[
    "+", "-", "*", "/", "^", ";", ",", "=", ".", "!", "#", ":", "&", "**", "->", "..", "::", "<",
    ">", "%", "@", "?", "$",
];

fn word() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => prop::sample::select(WORDS).prop_map(str::to_string),
        3 => prop::sample::select(NUMBERS).prop_map(str::to_string),
        4 => prop::sample::select(PUNCTS).prop_map(str::to_string),
        1 => any::<u64>().prop_map(|k| k.to_string()),
        1 => (any::<u32>(), any::<i16>()).prop_map(|(m, e)| format!("{m}e{e}")),
    ]
}

/// Balanced token soup: words and nested `()`, `[]`, `{}` groups.
fn soup() -> impl Strategy<Value = String> {
    let leaf = prop::collection::vec(word(), 0..6).prop_map(|w| w.join(" "));
    leaf.prop_recursive(5, 96, 6, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 1..6).prop_map(|w| w.join(" ")),
            (inner, 0..3usize).prop_map(|(s, d)| {
                let (open, close) = [("(", ")"), ("[", "]"), ("{", "}")][d];
                format!("{open}{s}{close}")
            }),
        ]
    })
}

/// A valid system with `{}` holes, one per section, for soup insertion.
const SECTIONS: [&str; 11] = [
    "pub struct S;",
    "state (q, p);",
    "const m = 2;",
    "poisson = [[0, 1], [-1, 0]];",
    "hamiltonian = 0.5 * p^2 + 0.5 * m * q^2;",
    "entropy degree 4;",
    "metric degree 2;",
    "reference { entropy = -q^4 + p^2; metric = [[1, 0], [0, 1]]; }",
    "region ball(center = [0, 0], radius = 2);",
    "certificate on region;",
    "relaxation order 1;",
];

/// Replaces the right-hand side (or the whole) of one section with soup.
fn framed_soup() -> impl Strategy<Value = String> {
    (soup(), any::<Index>(), any::<bool>()).prop_map(|(soup, which, keep_head)| {
        let k = which.index(SECTIONS.len());
        let mut sections: Vec<String> = SECTIONS.iter().map(|s| s.to_string()).collect();
        let section = SECTIONS[k];
        sections[k] = if keep_head {
            // Keep the keyword (and `=`), replace what follows.
            let head = section
                .find('=')
                .map(|at| &section[..=at])
                .unwrap_or_else(|| section.split(' ').next().unwrap_or(""));
            format!("{head} {soup};")
        } else {
            soup
        };
        sections.join("\n")
    })
}

#[test]
fn token_soups_never_panic() {
    let tally = Tally::default();
    let mut runner = TestRunner::new(config());
    let strategy = prop_oneof![soup(), framed_soup()];
    let result = runner.run(&strategy, |text| check_text(&text, &tally).map(|_| ()));
    tally.report("token soups");
    if let Err(failure) = result {
        panic!("{failure}");
    }
}

// ---- generator (b): mutated paper systems -----------------------------------

const PAPER_SYSTEMS: [&str; 5] = [
    "/// Canonical oscillator whose free energy has a figure-eight zero set.
     pub struct Oscillator;
     state (q, p);
     poisson = [[0, 1], [-1, 0]];
     hamiltonian = 0.5 * p^2 + 0.5 * q^2;
     entropy degree 8;
     metric degree 2;
     reference {
         entropy = -0.5 * (p^2 + 4*q^4 - 4*q^2)^2 - (0.5*p^2 + 0.5*q^2);
         metric = [[1, 0], [0, 1]];
     }",
    "pub struct RigidBody;
     state (px, py, pz);
     const j1 = 0.1;
     const j2 = 0.2;
     const j3 = 0.15;
     poisson = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]];
     hamiltonian = 0.5 * (px^2 / j1 + py^2 / j2 + pz^2 / j3);
     entropy degree 6;
     metric degree 2;
     reference {
         entropy = -0.5 * (px^2 + py^2 + pz^2 - 1)^2 - 0.5 * (px^2 / j1 + py^2 / j2 + pz^2 / j3);
         metric = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
     }",
    "struct Chain;
     state (q1, q2, p1, p2);
     const k = 3 / 2;
     poisson = [[0, 0, 1, 0], [0, 0, 0, 1], [-1, 0, 0, 0], [0, -1, 0, 0]];
     hamiltonian = 0.5 * (p1^2 + p2^2) + k * (q1 - q2)^2 + q1^4;
     metric degree 0;
     entropy degree 3;",
    // The rigid body in the classical form, certified on a box.
    "pub struct Classical;
     state (px, py, pz);
     const j1 = 0.1;
     const j2 = 0.2;
     const j3 = 0.15;
     poisson = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]];
     hamiltonian = 0.5 * (px^2 / j1 + py^2 / j2 + pz^2 / j3);
     entropy degree 4;
     metric degree 2;
     region box(px in [-2, 2], py in [-2, 2], pz in [-1.5, 1.5]);
     certificate on region;
     relaxation order 1;
     classical;
     reference {
         entropy = -0.5 * (px^2 + py^2 + pz^2 - 1)^2;
         metric = [[(py / j2)^2 + (pz / j3)^2, -px * py / (j1 * j2), -px * pz / (j1 * j3)],
                   [-px * py / (j1 * j2), (px / j1)^2 + (pz / j3)^2, -py * pz / (j2 * j3)],
                   [-px * pz / (j1 * j3), -py * pz / (j2 * j3), (px / j1)^2 + (py / j2)^2]];
     }",
    // A state-dependent reference metric on a ball.
    "pub struct Region;
     state (q, p);
     const rho = 3 / 2;
     poisson = [[0, 1], [-1, 0]];
     hamiltonian = 0.5 * p^2 + 0.5 * q^2;
     entropy degree 4;
     metric degree 2;
     region ball(center = [0.5, 0], radius = 2 * rho);
     reference {
         entropy = -q^2 - p^4;
         metric = [[1 + p^2, -q * p], [-q * p, 1 + q^2]];
     }",
];

/// Lexes source text into a flat list of token texts, groups as separate
/// open and close delimiters, so that mutations can unbalance them.
fn flatten(text: &str) -> Vec<String> {
    fn walk(stream: TokenStream, out: &mut Vec<String>) {
        for token in stream {
            match token {
                TokenTree::Group(g) => {
                    let (open, close) = match g.delimiter() {
                        Delimiter::Parenthesis => ("(", ")"),
                        Delimiter::Bracket => ("[", "]"),
                        Delimiter::Brace => ("{", "}"),
                        Delimiter::None => ("", ""),
                    };
                    out.push(open.to_string());
                    walk(g.stream(), out);
                    out.push(close.to_string());
                }
                other => out.push(other.to_string()),
            }
        }
    }
    let mut out = Vec::new();
    walk(text.parse().unwrap_or_default(), &mut out);
    out.retain(|t| !t.is_empty());
    out
}

/// One edit of a flat token list.
#[derive(Debug, Clone)]
enum Mutation {
    Delete(Index),
    Duplicate(Index),
    Swap(Index, Index),
    Replace(Index, String),
    /// Replaces a number with an extreme or odd value.
    Number(Index, &'static str),
    /// Inserts `^ k` after a token (huge exponents, `q^1000000`).
    Exponent(Index, &'static str),
    /// Wraps the token in `depth` parentheses.
    Nest(Index, usize),
    /// Inserts a lone delimiter (never lexes: rustc rejects it first).
    Unbalance(Index, &'static str),
}

const EXTREME_NUMBERS: &[&str] = &[
    "0",
    "1",
    "2",
    "3",
    "31",
    "32",
    "33",
    "63",
    "64",
    "65",
    "100",
    "1000000",
    "4294967295",
    "4294967296",
    "99999999999999999999999999999999999999999",
    "0.5",
    "1e308",
    "1e-308",
    "1e38",
    "1e-38",
    "0.0",
    "1.5e3",
];

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        3 => any::<Index>().prop_map(Mutation::Delete),
        3 => any::<Index>().prop_map(Mutation::Duplicate),
        3 => (any::<Index>(), any::<Index>()).prop_map(|(a, b)| Mutation::Swap(a, b)),
        3 => (any::<Index>(), word()).prop_map(|(a, w)| Mutation::Replace(a, w)),
        4 => (any::<Index>(), prop::sample::select(EXTREME_NUMBERS))
            .prop_map(|(a, n)| Mutation::Number(a, n)),
        2 => (any::<Index>(), prop::sample::select(EXTREME_NUMBERS))
            .prop_map(|(a, n)| Mutation::Exponent(a, n)),
        2 => (any::<Index>(), prop_oneof![1..8usize, 60..70usize, 200..400usize])
            .prop_map(|(a, d)| Mutation::Nest(a, d)),
        1 => (any::<Index>(), prop::sample::select(&["(", ")", "[", "]", "{", "}"][..]))
            .prop_map(|(a, d)| Mutation::Unbalance(a, d)),
    ]
}

fn is_number(token: &str) -> bool {
    token.starts_with(|c: char| c.is_ascii_digit())
}

fn apply(tokens: &mut Vec<String>, mutation: &Mutation) {
    if tokens.is_empty() {
        return;
    }
    let len = tokens.len();
    match mutation {
        Mutation::Delete(i) => {
            tokens.remove(i.index(len));
        }
        Mutation::Duplicate(i) => {
            let i = i.index(len);
            tokens.insert(i, tokens[i].clone());
        }
        Mutation::Swap(a, b) => tokens.swap(a.index(len), b.index(len)),
        Mutation::Replace(i, word) => tokens[i.index(len)] = word.clone(),
        Mutation::Number(i, value) => {
            // The i-th number, cyclically: numbers are where extremes bite.
            let numbers: Vec<usize> = (0..len).filter(|&k| is_number(&tokens[k])).collect();
            if !numbers.is_empty() {
                tokens[numbers[i.index(numbers.len())]] = value.to_string();
            }
        }
        Mutation::Exponent(i, value) => {
            let i = i.index(len);
            tokens.insert(i + 1, "^".to_string());
            tokens.insert(i + 2, value.to_string());
        }
        Mutation::Nest(i, depth) => {
            let i = i.index(len);
            tokens.insert(i + 1, ")".repeat(*depth));
            tokens.insert(i, "(".repeat(*depth));
        }
        Mutation::Unbalance(i, delimiter) => tokens.insert(i.index(len), delimiter.to_string()),
    }
}

#[test]
fn mutated_paper_systems_never_panic() {
    let tally = Tally::default();
    let mut runner = TestRunner::new(config());
    let strategy = (
        prop::sample::select(&PAPER_SYSTEMS[..]),
        prop::collection::vec(mutation(), 1..5),
    );
    let result = runner.run(&strategy, |(system, mutations)| {
        let mut tokens = flatten(system);
        for m in &mutations {
            apply(&mut tokens, m);
        }
        check_text(&tokens.join(" "), &tally).map(|_| ())
    });
    tally.report("mutated paper systems");
    if let Err(failure) = result {
        panic!("{failure}");
    }
}

#[test]
fn unmutated_paper_systems_are_accepted() {
    let tally = Tally::default();
    for system in PAPER_SYSTEMS {
        // Also through the flat token list the mutations start from.
        for text in [system.to_string(), flatten(system).join(" ")] {
            assert!(
                matches!(check_text(&text, &tally), Ok(Some(true))),
                "{text}"
            );
        }
    }
}

// ---- generator (c): random valid systems ------------------------------------

const NAMES: [&str; 4] = ["q", "p", "r", "s"];

/// A random polynomial text in the first `n` state names, of degree at most
/// `max_degree`, as a sum of terms `c * a^i * b^j`.
fn polynomial_text(n: usize, max_degree: u32) -> impl Strategy<Value = String> {
    let term = (
        -20i32..=20,
        1u32..=4,
        prop::collection::vec(0..=max_degree, n),
    )
        .prop_map(move |(numerator, denominator, mut exponents)| {
            // Trim exponents to the degree budget, earliest variables first.
            let mut budget = max_degree;
            for e in &mut exponents {
                *e = (*e).min(budget);
                budget -= *e;
            }
            let mut factors = vec![format!("({numerator} / {denominator})")];
            for (name, &e) in NAMES.iter().zip(&exponents) {
                match e {
                    0 => {}
                    1 => factors.push(name.to_string()),
                    _ => factors.push(format!("{name}^{e}")),
                }
            }
            factors.join(" * ")
        });
    prop::collection::vec(term, 1..6).prop_map(|terms| terms.join(" + "))
}

/// A region over the first `n` names: a ball or a box with small integer
/// data, and optionally a certificate mode and a relaxation order.
fn region_text(n: usize) -> impl Strategy<Value = String> {
    (
        any::<bool>(),
        prop::collection::vec((-3i32..=3, 1i32..=4), n),
        1u32..=5,
        prop_oneof![
            Just(""),
            Just("certificate on region;\n"),
            Just("certificate global lower bound;\n")
        ],
        prop_oneof![
            Just(""),
            Just("relaxation order 0;\n"),
            Just("relaxation order 1;\n")
        ],
    )
        .prop_map(move |(ball, sides, radius, mode, order)| {
            let names = &NAMES[..n];
            let shape = if ball {
                let center: Vec<String> = sides.iter().map(|(c, _)| c.to_string()).collect();
                format!(
                    "ball(center = [{}], radius = {radius} / 2)",
                    center.join(", ")
                )
            } else {
                let intervals: Vec<String> = names
                    .iter()
                    .zip(&sides)
                    .map(|(name, (l, w))| format!("{name} in [{l}, {l} + {w}]"))
                    .collect();
                format!("box({})", intervals.join(", "))
            };
            format!("region {shape};\n{mode}{order}")
        })
}

/// A valid system: constant skew Π (always Poisson) or so(3) for n = 3,
/// polynomial H, entropy degree 1..=4, metric degree 0 or 2, optional
/// reference within the bases, a region whenever the reference metric may
/// depend on the state (and sometimes otherwise); for so(3) with a
/// quadratic H, sometimes the classical form with a classical reference.
fn valid_system() -> impl Strategy<Value = String> {
    (1usize..=4, 1u32..=4, prop_oneof![Just(0u32), Just(2u32)]).prop_flat_map(|(n, r, s)| {
        let pairs = n * (n - 1) / 2;
        (
            prop::collection::vec(-3i32..=3, pairs),
            any::<bool>(),
            polynomial_text(n, 4),
            prop::option::of((
                polynomial_text(n, r),
                prop::collection::vec(polynomial_text(n, s / 2), n),
            )),
            prop::option::of(region_text(n)),
            (any::<bool>(), prop::collection::vec(1i32..=5, 3)),
        )
            .prop_map(
                move |(
                    upper,
                    lie_poisson,
                    hamiltonian,
                    reference,
                    region,
                    (classical, inertia),
                )| {
                    let names = &NAMES[..n];
                    let mut pi = vec![vec!["0".to_string(); n]; n];
                    if n == 3 && lie_poisson {
                        let (q, p, r) = (names[0], names[1], names[2]);
                        pi = vec![
                            vec!["0".into(), format!("-{r}"), p.into()],
                            vec![r.into(), "0".into(), format!("-{q}")],
                            vec![format!("-{p}"), q.into(), "0".into()],
                        ];
                    } else {
                        let mut upper = upper.iter();
                        for (i, j) in (0..n).flat_map(|i| (i + 1..n).map(move |j| (i, j))) {
                            let value = upper.next().copied().unwrap_or(0);
                            pi[i][j] = value.to_string();
                            pi[j][i] = (-value).to_string();
                        }
                    }
                    let matrix = |m: &Vec<Vec<String>>| {
                        let rows: Vec<String> = m
                            .iter()
                            .map(|row| format!("[{}]", row.join(", ")))
                            .collect();
                        format!("[{}]", rows.join(", "))
                    };
                    // so(3) with H = ½ Σ aᵢxᵢ²: Casimirs from degree 2 on, and
                    // K = |∇H|²I − ∇H∇Hᵀ of degree 2 with K∇H ≡ 0.
                    let classical = classical && n == 3 && lie_poisson && r >= 2 && s == 2;
                    let hamiltonian = if classical {
                        let terms: Vec<String> = names
                            .iter()
                            .zip(&inertia)
                            .map(|(name, a)| format!("{a} * {name}^2"))
                            .collect();
                        format!("0.5 * ({})", terms.join(" + "))
                    } else {
                        hamiltonian
                    };
                    let region = match region {
                        None if classical || (reference.is_some() && s > 0) => {
                            Some("region ball(radius = 2);\n".to_string())
                        }
                        region => region,
                    };
                    let mut text = format!(
                    "pub struct Random;\nstate ({});\npoisson = {};\nhamiltonian = {hamiltonian};\n\
                     entropy degree {r};\nmetric degree {s};\n{}",
                    names.join(", "),
                    matrix(&pi),
                    region.unwrap_or_default()
                );
                    if classical {
                        text += "classical;\n";
                        let gradient: Vec<String> = names
                            .iter()
                            .zip(&inertia)
                            .map(|(name, a)| format!("{a} * {name}"))
                            .collect();
                        let mut metric = vec![vec![String::new(); 3]; 3];
                        for i in 0..3 {
                            for j in 0..3 {
                                metric[i][j] = if i == j {
                                    let others: Vec<String> = (0..3)
                                        .filter(|&k| k != i)
                                        .map(|k| format!("({})^2", gradient[k]))
                                        .collect();
                                    others.join(" + ")
                                } else {
                                    format!("-({}) * ({})", gradient[i], gradient[j])
                                };
                            }
                        }
                        let squared: Vec<String> = names.iter().map(|n| format!("{n}^2")).collect();
                        text += &format!(
                            "reference {{ entropy = -({}); metric = {}; }}\n",
                            squared.join(" + "),
                            matrix(&metric)
                        );
                    } else if let Some((entropy, diagonal)) = reference {
                        // A diagonal metric of squares: symmetric and positive
                        // semidefinite by construction (constant ones are checked).
                        let mut metric = vec![vec!["0".to_string(); n]; n];
                        for (i, d) in diagonal.into_iter().enumerate() {
                            metric[i][i] = format!("({d})^2");
                        }
                        text += &format!(
                            "reference {{ entropy = {entropy}; metric = {}; }}\n",
                            matrix(&metric)
                        );
                    }
                    text
                },
            )
    })
}

#[test]
fn random_valid_systems_expand_to_code_that_parses() {
    let tally = Tally::default();
    let mut runner = TestRunner::new(Config {
        // Each accepted system runs the whole code generator: fewer cases.
        cases: config().cases / 5,
        ..config()
    });
    let result = runner.run(&valid_system(), |text| {
        let tokens: TokenStream = text
            .parse()
            .map_err(|e| TestCaseError::fail(format!("generator bug: {e}")))?;
        let output = catch_unwind(AssertUnwindSafe(|| {
            metriplectic_codegen::try_expand(tokens)
        }))
        .map_err(|_| TestCaseError::fail(format!("the macro panicked on:\n{text}")))?;
        match output {
            Ok(code) => {
                tally.accepted.fetch_add(1, Ordering::Relaxed);
                syn::parse2::<syn::File>(code).map_err(|e| {
                    TestCaseError::fail(format!("generated code does not parse ({e}):\n{text}"))
                })?;
                Ok(())
            }
            Err(e) => Err(TestCaseError::fail(format!(
                "a valid system was rejected: {e}\n{text}"
            ))),
        }
    });
    tally.report("random valid systems");
    if let Err(failure) = result {
        panic!("{failure}");
    }
}

// ---- depth and size caps -----------------------------------------------------

/// The inputs closest to the size and nesting caps, run on a thread with a
/// quarter of rustc's 8 MiB main-thread stack, are errors or accepted, never
/// a stack overflow (which would abort this test binary).
#[test]
fn inputs_at_the_caps_fit_in_a_small_stack() {
    let system = |hamiltonian: &str| {
        format!(
            "struct S; state (q, p); poisson = [[0, 1], [-1, 0]]; hamiltonian = {hamiltonian}; \
             entropy degree 2; metric degree 0;"
        )
    };
    let mut cases = vec![
        // 64 parentheses: the deepest accepted nesting; 65 is an error.
        system(&format!("{}q{}", "(".repeat(63), ")".repeat(63))),
        system(&format!("{}q{}", "(".repeat(65), ")".repeat(65))),
        // Deep nesting far past the cap, of every delimiter.
        system(&format!("{}q{}", "(".repeat(5000), ")".repeat(5000))),
        system(&format!("{}q{}", "[".repeat(5000), "]".repeat(5000))),
        system(&format!("{}q{}", "{".repeat(5000), "}".repeat(5000))),
        // Long chains up to and past the token cap.
        system(&vec!["q"; 999].join(" + ")),
        system(&vec!["q"; 999].join(" * ")),
        system(&format!("{}q", "- ".repeat(1999))),
        system(&format!("q{}", " ^ 1".repeat(999))),
        system(&format!("2{}", " ^ 2".repeat(999))),
        system(&format!("q{}", " ^ -1".repeat(600))),
        system(&vec!["q"; 5000].join(" + ")),
        // Nesting inside the matrix and the state list.
        format!(
            "struct S; state ({}q{}); poisson = [[0]]; hamiltonian = q; entropy degree 1; \
             metric degree 0;",
            "(".repeat(3000),
            ")".repeat(3000)
        ),
        format!(
            "struct S; state (q); poisson = {}[[0]]{}; hamiltonian = q; entropy degree 1; \
             metric degree 0;",
            "[".repeat(3000),
            "]".repeat(3000)
        ),
        format!(
            "#[doc = {}1{}] struct S; state (q); poisson = [[0]]; hamiltonian = q; \
             entropy degree 1; metric degree 0;",
            "(".repeat(3000),
            ")".repeat(3000)
        ),
    ];
    // Attributes go to `syn`'s recursive expression and type parsers: the
    // worst recursion per token that fits under the attribute token cap.
    let attribute = |body: String| {
        format!(
            "#[doc = {body}] struct S; state (q); poisson = [[0]]; hamiltonian = q; \
             entropy degree 1; metric degree 0;"
        )
    };
    let fill = |unit: &str, tail: &str| {
        let per = unit
            .parse::<TokenStream>()
            .map_or(1, |t| count_tokens(&t))
            .max(1);
        format!("{}{tail}", unit.repeat(253 / per))
    };
    cases.extend([
        attribute(fill("- ", "1")),
        attribute(fill("! ", "1")),
        attribute(fill("&& ", "x")),
        attribute(fill("* ", "x")),
        attribute(fill("|| ", "1")),
        attribute(fill("return ", "1")),
        attribute(fill("x = ", "1")),
        attribute(fill("if a {} else ", "{}")),
        attribute(format!("1 as {}", fill("&& ", "u8"))),
        attribute(format!("1 as {}", fill("Vec < ", "u8"))),
        attribute(format!("1 as {}", fill("fn () -> ", "u8"))),
        attribute(fill("- ", "1") + " - 1"),
    ]);
    let handle = std::thread::Builder::new()
        .stack_size(2 << 20)
        .spawn(move || {
            let tally = Tally::default();
            for text in &cases {
                if let Err(e) = check_text(text, &tally) {
                    panic!("{e}");
                }
            }
            tally.report("inputs at the caps");
            tally.unlexable.load(Ordering::Relaxed)
        })
        .expect("spawn the small-stack thread");
    let unlexable = handle.join().expect("no panic, no stack overflow");
    assert_eq!(unlexable, 0, "every cap case is lexable Rust");
}

/// Counts token trees, groups included (test helper for sizing inputs).
fn count_tokens(stream: &TokenStream) -> usize {
    stream
        .clone()
        .into_iter()
        .map(|t| match t {
            TokenTree::Group(g) => 1 + count_tokens(&g.stream()),
            _ => 1,
        })
        .sum()
}

/// Regressions found by the tests above: each is now a spanned error.
#[test]
fn deep_or_long_attributes_are_errors_not_stack_overflows() {
    let message = |text: String| {
        metriplectic_codegen::try_expand(text.parse().expect("lexable"))
            .expect_err("rejected")
            .to_string()
    };
    let tail = "struct S; state (q); poisson = [[0]]; hamiltonian = q; entropy degree 1; \
                metric degree 0;";
    // Found by `inputs_at_the_caps_fit_in_a_small_stack`: `syn` parses
    // `#[doc = …]` as a Rust expression, recursively; 3000 parentheses
    // overflowed a 2 MiB stack.
    let deep = format!("#[doc = {}1{}] {tail}", "(".repeat(3000), ")".repeat(3000));
    assert!(message(deep).contains("nested more than 72 deep"));
    let long = format!("#[doc = {}1] {tail}", "- ".repeat(5000));
    assert!(message(long).contains("attribute too long (5003 tokens, at most 256)"));
    // Deep nesting anywhere, not only in attributes.
    let deep_state = format!(
        "struct S; state ({}q{}); poisson = [[0]]; hamiltonian = q; entropy degree 1; \
         metric degree 0;",
        "(".repeat(100),
        ")".repeat(100)
    );
    assert!(message(deep_state).contains("nested more than 72 deep"));
    // The deepest valid nesting is still accepted: 63 parentheses inside a
    // reference metric entry.
    let deepest = format!(
        "struct S; state (q); poisson = [[0]]; hamiltonian = q; entropy degree 1; \
         metric degree 0; reference {{ entropy = q; metric = [[{}1{}]]; }}",
        "(".repeat(63),
        ")".repeat(63)
    );
    assert!(metriplectic_codegen::try_expand(deepest.parse().expect("lexable")).is_ok());
}
