//! The region of a metric certificate and the S-procedure blocks on it
//! (`docs/method.md` §2; Putinar, Scherer–Hol for the matrix case).
//!
//! Bounded on all of Rⁿ, 0 ⪯ K(x) ⪯ ηI forces K constant (the facially
//! reduced tables). On a region R = {x : gₖ(x) ≥ 0} a state-dependent metric
//! is certified by sum-of-squares matrices Σ(x) = Z(x)ᵀQZ(x), Q ⪰ 0,
//! Z(x) = I ⊗ m(x):
//!
//! * global lower bound (default): K = Σ₀ (basis degree s/2, never raised:
//!   a globally PSD matrix polynomial of degree s has no strictly feasible
//!   Gram matrix over more monomials) and ηI − K = Σ₁ + Σₖ gₖΣ₁ₖ;
//! * on region: K = Σ₀ + Σₖ gₖΣ₀ₖ and ηI − K as above.
//!
//! A block with multiplier g of degree d has basis degree (s − d)/2 + t
//! (t the relaxation order) and is left out if that is negative.

use proc_macro2::Span;

use super::scope::{list, Context, Scope};
use crate::bases::{self, Bases};
use crate::diagnostics::Diagnostics;
use crate::parse::{Degree, Interval, Mode, RegionDecl, RegionShape, SpanRange, SystemDef, Vector};
use crate::polynomial::{Exact, Overflow, Polynomial, Rational};

/// Largest number of (β, γ, c) entries over all blocks of a certificate:
/// each is a tuple of the expansion.
pub const MAX_CERTIFICATE_ENTRIES: u128 = 1_000_000;
/// Block bases are indexed by `u16` in the tables.
const MAX_BLOCK_BASIS: u128 = u16::MAX as u128 + 1;

/// A checked region, exactly.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RegionModel {
    /// ‖x − center‖ ≤ radius.
    Ball {
        /// One coordinate per state variable.
        center: Vec<Rational>,
        /// Positive.
        radius: Rational,
    },
    /// lowerⱼ ≤ xⱼ ≤ upperⱼ.
    Box {
        /// In state order.
        lower: Vec<Rational>,
        /// In state order, each above its lower bound.
        upper: Vec<Rational>,
    },
}

impl RegionModel {
    /// The constraints gₖ(x) ≥ 0 that define the region: ρ² − ‖x − c‖² for
    /// a ball, (uⱼ − xⱼ)(xⱼ − lⱼ) for each side of a box.
    pub fn constraints(&self, n: usize) -> Exact<Vec<Polynomial>> {
        let constant = |c: Rational| Polynomial::constant(n, c);
        match self {
            RegionModel::Ball { center, radius } => {
                let mut g = constant(radius.mul(*radius)?);
                for (j, c) in center.iter().enumerate() {
                    let offset = Polynomial::variable(n, j).sub(&constant(*c))?;
                    g = g.sub(&offset.mul(&offset)?)?;
                }
                Ok(vec![g])
            }
            RegionModel::Box { lower, upper } => lower
                .iter()
                .zip(upper)
                .enumerate()
                .map(|(j, (l, u))| {
                    let x = Polynomial::variable(n, j);
                    constant(*u).sub(&x)?.mul(&x.sub(&constant(*l))?)
                })
                .collect(),
        }
    }

    /// Exact points of the region to spot-check a reference metric at: the
    /// centre, the ends of the ball's axes (or the box's corners, up to 8
    /// variables). `Err` if a coordinate overflows.
    pub fn spot_points(&self) -> Exact<Vec<Vec<Rational>>> {
        let two = Rational::integer(2);
        match self {
            RegionModel::Ball { center, radius } => {
                let mut points = vec![center.clone()];
                for j in 0..center.len() {
                    for side in [radius.neg()?, *radius] {
                        let mut point = center.clone();
                        point[j] = point[j].add(side)?;
                        points.push(point);
                    }
                }
                Ok(points)
            }
            RegionModel::Box { lower, upper } => {
                let centre = lower
                    .iter()
                    .zip(upper)
                    .map(|(l, u)| l.add(*u)?.div(two)?.ok_or(Overflow))
                    .collect::<Exact<Vec<_>>>()?;
                let mut points = vec![centre];
                let n = lower.len();
                if n <= 8 {
                    for corner in 0..1_usize << n {
                        let point = (0..n)
                            .map(|j| {
                                if corner >> j & 1 == 0 {
                                    lower[j]
                                } else {
                                    upper[j]
                                }
                            })
                            .collect();
                        points.push(point);
                    }
                }
                Ok(points)
            }
        }
    }

    /// `‖(q, p) − (0, 0)‖ ≤ 2` or `q ∈ [-2, 2], p ∈ [-1, 1]`.
    pub fn describe(&self, names: &[String]) -> String {
        match self {
            RegionModel::Ball { center, radius } => {
                let center: Vec<String> = center.iter().map(Rational::to_string).collect();
                format!(
                    "the ball ‖({}) − ({})‖ ≤ {radius}",
                    names.join(", "),
                    center.join(", ")
                )
            }
            RegionModel::Box { lower, upper } => {
                let sides: Vec<String> = names
                    .iter()
                    .zip(lower.iter().zip(upper))
                    .map(|(name, (l, u))| format!("{name} ∈ [{l}, {u}]"))
                    .collect();
                format!("the box {}", sides.join(", "))
            }
        }
    }
}

/// One Gram block of a certificate.
#[derive(Debug, Clone)]
pub struct Block {
    /// Index of its multiplier among the region's constraints; `None` for
    /// the plain block (multiplier 1).
    pub constraint: Option<usize>,
    /// The multiplier's terms (coefficient, exponents), graded-lex; `[]`
    /// for the plain block.
    pub multiplier: Vec<(Rational, Vec<u32>)>,
    /// Degree of the basis m(x).
    pub degree: u32,
    /// The basis m(x): all monomials of degree ≤ `degree`.
    pub exponents: Vec<Vec<u32>>,
    /// For each target α: (β, γ, c), c the coefficient of x^α in g·x^β·x^γ.
    pub matching: Vec<Vec<(usize, usize, Rational)>>,
}

/// A region certificate, ready to emit.
#[derive(Debug, Clone)]
pub struct CertificateModel {
    /// The region.
    pub region: RegionModel,
    /// Its constraints gₖ.
    pub constraints: Vec<Polynomial>,
    /// Which bounds hold where.
    pub mode: Mode,
    /// The relaxation order t.
    pub relaxation_order: u32,
    /// D: the largest degree any block produces.
    pub target_degree: u32,
    /// All monomials of degree ≤ D, graded-lex (the metric basis first).
    pub targets: Vec<Vec<u32>>,
    /// Blocks whose sum is K.
    pub lower: Vec<Block>,
    /// Blocks whose sum is ηI − K.
    pub upper: Vec<Block>,
}

/// The blocks' (constraint, basis degree) for a metric of degree `s`,
/// relaxation order `t` and constraints of the given degrees: the lower
/// bound's, then the upper bound's.
pub type Plan = (Vec<(Option<usize>, u32)>, Vec<(Option<usize>, u32)>);

/// Which blocks a certificate has and their basis degrees.
pub fn plan(s: u32, t: u32, mode: Mode, constraint_degrees: &[u32]) -> Plan {
    let (s, t) = (i64::from(s), i64::from(t));
    // (s − d)/2 + t, or nothing if negative; d is even for every region.
    let degree = |d: u32, raised: bool| {
        let d = i64::from(d);
        let twice = s - d + if raised { 2 * t } else { 0 };
        (twice >= 0).then(|| u32::try_from(twice / 2).unwrap_or(u32::MAX))
    };
    let with_multipliers = |raised_plain: bool| {
        let mut blocks: Vec<(Option<usize>, u32)> = Vec::new();
        blocks.extend(degree(0, raised_plain).map(|k| (None, k)));
        for (k, &d) in constraint_degrees.iter().enumerate() {
            blocks.extend(degree(d, true).map(|m| (Some(k), m)));
        }
        blocks
    };
    let lower = match mode {
        Mode::GlobalLowerBound => degree(0, false).map(|k| (None, k)).into_iter().collect(),
        Mode::OnRegion => with_multipliers(true),
    };
    (lower, with_multipliers(true))
}

/// The region with its exact numbers, recording every error. `None` if
/// anything failed.
pub fn check_region(
    decl: &RegionDecl,
    scope: &Scope,
    diagnostics: &mut Diagnostics,
) -> Option<(RegionModel, Vec<Polynomial>)> {
    let n = scope.nvars();
    let model = match decl.shape.as_ref()? {
        RegionShape::Ball { center, radius, .. } => {
            let center = match center {
                Some(vector) => check_center(vector, scope, diagnostics),
                None => Some(vec![Rational::ZERO; n]),
            };
            let radius = radius
                .as_ref()
                .and_then(|expr| {
                    let value = constant(expr, scope, diagnostics)?;
                    Some((expr, value))
                })
                .and_then(|(expr, value)| {
                    if value.numerator() > 0 {
                        Some(value)
                    } else {
                        diagnostics.push(expr.span().error(format!(
                            "the ball's radius must be positive, but it is {value}; write e.g. \
                             `radius = 2`"
                        )));
                        None
                    }
                });
            RegionModel::Ball {
                center: center?,
                radius: radius?,
            }
        }
        RegionShape::Box {
            keyword, intervals, ..
        } => {
            let (lower, upper) = check_box(*keyword, intervals, scope, diagnostics)?;
            RegionModel::Box { lower, upper }
        }
    };
    let constraints = model.constraints(n);
    let span = SpanRange::single(decl.keyword);
    let constraints = super::scope::exact(constraints, span, diagnostics)?;
    if let Some(reason) = rounding_problem(&model, &constraints) {
        diagnostics.push(span.error(reason));
        return None;
    }
    Some((model, constraints))
}

/// Why the region's constraints cannot be used in `f64`, if they cannot.
///
/// The certificate tables carry gₖ's coefficients rounded to `f64`, so the
/// runtime certifies K on {g′ₖ ≥ 0}, not on {gₖ ≥ 0}. Each coefficient
/// moves by at most a few units in its last place, so over the region g′ₖ
/// differs from gₖ by at most B = 4ε Σ_α |c_α| max|x^α|. That must be small
/// against gₖ's largest value on the region, or the certified set is
/// another one: a ball of radius 1 at 10⁸ rounds to g′ = −(q − 10⁸)² ≤ 0,
/// on which any K is certified.
fn rounding_problem(model: &RegionModel, constraints: &[Polynomial]) -> Option<String> {
    // Largest |xⱼ| on the region and each constraint's largest value.
    let (reach, peaks): (Vec<f64>, Vec<f64>) = match model {
        RegionModel::Ball { center, radius } => {
            let r = radius.to_f64();
            let reach = center.iter().map(|c| c.to_f64().abs() + r).collect();
            (reach, vec![r * r])
        }
        RegionModel::Box { lower, upper } => {
            let reach = lower
                .iter()
                .zip(upper)
                .map(|(l, u)| l.to_f64().abs().max(u.to_f64().abs()))
                .collect();
            let peaks = lower
                .iter()
                .zip(upper)
                .map(|(l, u)| (0.5 * (u.to_f64() - l.to_f64())).powi(2))
                .collect();
            (reach, peaks)
        }
    };
    for (k, (g, peak)) in constraints.iter().zip(peaks).enumerate() {
        let size: f64 = g
            .terms()
            .map(|(e, c)| {
                e.iter()
                    .zip(&reach)
                    .fold(c.to_f64().abs(), |m, (&a, r)| m * r.powi(a as i32))
            })
            .sum();
        let moved = 4.0 * f64::EPSILON * size;
        // NaN (a region beyond f64) counts as too large.
        if moved.is_nan() || moved > REGION_ROUNDING * peak {
            return Some(format!(
                "the region cannot be certified in floating point: its constraint g{k}(x) ≥ 0 \
                 peaks at {peak:e} on the region, but rounding its coefficients to f64 moves it \
                 by up to {moved:e} there, so the certificate would hold on another set; \
                 shift or rescale the state variables so that the region lies near the origin \
                 and is not tiny against its distance from it"
            ));
        }
    }
    None
}

/// Largest change of a region constraint by rounding, relative to its peak.
const REGION_ROUNDING: f64 = 1e-6;

/// A constant expression's exact value.
fn constant(
    expr: &crate::parse::Expr,
    scope: &Scope,
    diagnostics: &mut Diagnostics,
) -> Option<Rational> {
    scope
        .polynomial(expr, Context::Region, diagnostics)
        .map(|p| p.as_constant().unwrap_or(Rational::ZERO))
}

fn check_center(
    vector: &Vector,
    scope: &Scope,
    diagnostics: &mut Diagnostics,
) -> Option<Vec<Rational>> {
    let n = scope.nvars();
    let mut valid = true;
    if vector.entries.len() != n {
        valid = false;
        diagnostics.push(syn::Error::new(
            vector.span,
            format!(
                "the ball's centre has {} coordinates, but the state has {n} ({}); write one per \
                 state variable, e.g. `center = [{}]`",
                vector.entries.len(),
                list(scope.state_names()),
                vec!["0"; n].join(", ")
            ),
        ));
    }
    let mut center = Vec::with_capacity(n);
    for entry in &vector.entries {
        match entry.as_ref().and_then(|e| constant(e, scope, diagnostics)) {
            Some(value) => center.push(value),
            None => valid = false,
        }
    }
    valid.then_some(center)
}

fn check_box(
    keyword: Span,
    intervals: &[Interval],
    scope: &Scope,
    diagnostics: &mut Diagnostics,
) -> Option<(Vec<Rational>, Vec<Rational>)> {
    let n = scope.nvars();
    let names = scope.state_names();
    let mut bounds: Vec<Option<(Rational, Rational)>> = vec![None; n];
    let mut seen = vec![false; n];
    let mut valid = true;
    for interval in intervals {
        let name = super::scope::name_of(&interval.name);
        let Some(j) = names.iter().position(|s| *s == name) else {
            valid = false;
            diagnostics.push(syn::Error::new(
                interval.name.span(),
                format!(
                    "`{name}` is not a state variable; the box gives one interval to each of {}",
                    list(names)
                ),
            ));
            continue;
        };
        if seen[j] {
            valid = false;
            diagnostics.push(syn::Error::new(
                interval.name.span(),
                format!(
                    "`{name}` has two intervals; give each state variable exactly one, e.g. \
                     `{name} in [-2, 2]`"
                ),
            ));
            continue;
        }
        seen[j] = true;
        let lower = interval
            .lower
            .as_ref()
            .and_then(|e| constant(e, scope, diagnostics));
        let upper = interval
            .upper
            .as_ref()
            .and_then(|e| constant(e, scope, diagnostics));
        let (Some(lower), Some(upper)) = (lower, upper) else {
            valid = false;
            continue;
        };
        let gap = lower
            .mul(Rational::integer(-1))
            .and_then(|negated| upper.add(negated));
        let Some(gap) = super::scope::exact(gap, SpanRange::single(interval.span), diagnostics)
        else {
            valid = false;
            continue;
        };
        if gap.numerator() <= 0 {
            valid = false;
            let message = if gap.numerator() == 0 {
                // One point: no room for a certificate, and no order to fix.
                format!(
                    "the interval of `{name}` is the single point {lower}: a region needs an \
                     interval of positive width, e.g. `{name} in [-2, 2]`"
                )
            } else {
                format!(
                    "the interval of `{name}` is empty: its lower bound {lower} is not below its \
                     upper bound {upper}; write the lower bound first, e.g. `{name} in [-2, 2]`"
                )
            };
            diagnostics.push(syn::Error::new(interval.span, message));
            continue;
        }
        bounds[j] = Some((lower, upper));
    }
    let missing: Vec<String> = names
        .iter()
        .zip(&seen)
        .filter(|(_, seen)| !**seen)
        .map(|(name, _)| name.clone())
        .collect();
    if !missing.is_empty() {
        valid = false;
        let example: Vec<String> = missing.iter().map(|m| format!("{m} in [-1, 1]")).collect();
        diagnostics.push(syn::Error::new(
            keyword,
            format!(
                "the box gives no interval for {}; every state variable needs exactly one, add \
                 e.g. `{}`",
                list(&missing),
                example.join(", ")
            ),
        ));
    }
    if !valid {
        return None;
    }
    let (lower, upper) = bounds
        .into_iter()
        .collect::<Option<Vec<_>>>()?
        .into_iter()
        .unzip();
    Some((lower, upper))
}

/// `region ball(center = [0, 0], radius = 2);` for `n` variables.
pub fn ball_example(n: usize) -> String {
    format!(
        "`region ball(center = [{}], radius = 2);`",
        vec!["0"; n.max(1)].join(", ")
    )
}

/// The certificate's options, checked against the region: `certificate` and
/// `relaxation` without a region are errors. `(mode, order)`, with the
/// defaults for what is not declared; `None` if a declared one is broken.
pub fn options(def: &SystemDef, n: usize, diagnostics: &mut Diagnostics) -> Option<(Mode, u32)> {
    if def.region.is_none() {
        let example = ball_example(n);
        if let Some(certificate) = &def.certificate {
            diagnostics.push(syn::Error::new(
                certificate.keyword,
                format!(
                    "`certificate` chooses where the bounds of a region certificate hold, but the \
                     system declares no region; declare the region where the data live, e.g. \
                     {example}, or remove this line"
                ),
            ));
        }
        if let Some(relaxation) = &def.relaxation {
            diagnostics.push(syn::Error::new(
                relaxation.keyword,
                format!(
                    "`relaxation order` raises the degrees of a region certificate, but the \
                     system declares no region; declare the region where the data live, e.g. \
                     {example}, or remove this line"
                ),
            ));
        }
    }
    let mode = match &def.certificate {
        Some(certificate) => certificate.mode?,
        None => Mode::GlobalLowerBound,
    };
    let order = match &def.relaxation {
        Some(relaxation) => relaxation.order?.value,
        None => 0,
    };
    Some((mode, order))
}

/// The certificate's blocks and tables, after checking their sizes (errors
/// at the relaxation order if one is declared, else at `region`).
pub fn certificate(
    region: RegionModel,
    constraints: Vec<Polynomial>,
    (mode, order): (Mode, u32),
    bases: &Bases,
    n: usize,
    at: (Span, Option<Degree>),
    diagnostics: &mut Diagnostics,
) -> Option<CertificateModel> {
    let s = bases.metric_degree;
    let span = at.1.map_or(at.0, |d| d.span);
    let fix = if at.1.is_some() {
        "lower the relaxation order or the metric degree"
    } else {
        "lower the metric degree"
    };
    let degrees: Vec<u32> = constraints.iter().map(Polynomial::degree).collect();
    let (lower_plan, upper_plan) = plan(s, order, mode, &degrees);
    let produced = |&(k, m): &(Option<usize>, u32)| {
        let d = k.and_then(|k| degrees.get(k).copied()).unwrap_or(0);
        u64::from(d) + 2 * u64::from(m)
    };
    let target_degree = lower_plan
        .iter()
        .chain(&upper_plan)
        .map(produced)
        .max()
        .unwrap_or(0)
        .max(u64::from(s));
    let max_degree = u64::from(super::degrees::MAX_DEGREE);
    if target_degree > max_degree {
        diagnostics.push(syn::Error::new(
            span,
            format!(
                "with metric degree {s} and relaxation order {order} the certificate's blocks \
                 reach degree {target_degree}; at most {max_degree} is supported, {fix}"
            ),
        ));
        return None;
    }
    let target_degree = u32::try_from(target_degree).unwrap_or(u32::MAX);
    let targets_count = bases::count_up_to(n, target_degree).unwrap_or(u128::MAX);
    let mut entries: u128 = 0;
    let mut largest: u128 = 0;
    for (k, m) in lower_plan.iter().chain(&upper_plan) {
        let size = bases::count_up_to(n, *m).unwrap_or(u128::MAX);
        let terms = k
            .and_then(|k| constraints.get(k))
            .map_or(1, |g| g.term_count() as u128);
        largest = largest.max(size);
        entries = entries.saturating_add(size.saturating_mul(size).saturating_mul(terms));
    }
    if targets_count > super::degrees::MAX_BASIS
        || largest > MAX_BLOCK_BASIS
        || entries > MAX_CERTIFICATE_ENTRIES
    {
        diagnostics.push(syn::Error::new(
            span,
            format!(
                "the region certificate of metric degree {s} with relaxation order {order} in {n} \
                 variables needs Gram blocks of up to {largest} monomials and {entries} \
                 coefficient-matching entries over {targets_count} monomials; at most \
                 {MAX_CERTIFICATE_ENTRIES} entries over {} monomials are supported, {fix}",
                super::degrees::MAX_BASIS
            ),
        ));
        return None;
    }
    let targets = bases::up_to_degree(n, target_degree);
    let build = |plan: &[(Option<usize>, u32)]| -> Exact<Vec<Block>> {
        plan.iter()
            .map(|&(constraint, degree)| {
                let mut multiplier: Vec<(Rational, Vec<u32>)> = match constraint {
                    Some(k) => constraints
                        .get(k)
                        .map(|g| g.terms().map(|(e, c)| (c, e.clone())).collect())
                        .unwrap_or_default(),
                    None => Vec::new(),
                };
                multiplier.sort_by(|(_, a), (_, b)| bases::graded_lex_cmp(a, b));
                let one = [(Rational::ONE, vec![0; n])];
                let terms: &[(Rational, Vec<u32>)] = if constraint.is_some() {
                    &multiplier
                } else {
                    &one
                };
                let exponents = bases::up_to_degree(n, degree);
                let matching = bases::block_matching(terms, &exponents, &targets)?;
                Ok(Block {
                    constraint,
                    multiplier,
                    degree,
                    exponents,
                    matching,
                })
            })
            .collect()
    };
    let blocks = build(&lower_plan).and_then(|lower| Ok((lower, build(&upper_plan)?)));
    let (lower, upper) = super::scope::exact(blocks, SpanRange::single(span), diagnostics)?;
    Some(CertificateModel {
        region,
        constraints,
        mode,
        relaxation_order: order,
        target_degree,
        targets,
        lower,
        upper,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn r(n: i128, d: i128) -> Rational {
        Rational::new(n, d).unwrap().unwrap()
    }

    fn build(region: RegionModel, n: usize, s: u32, t: u32, mode: Mode) -> CertificateModel {
        let constraints = region.constraints(n).unwrap();
        let bases = Bases::new(n, 1, s);
        let mut diagnostics = Diagnostics::new();
        let model = certificate(
            region,
            constraints,
            (mode, t),
            &bases,
            n,
            (Span::call_site(), None),
            &mut diagnostics,
        );
        assert_eq!(diagnostics.count(), 0, "{:?}", diagnostics.into_error());
        model.expect("a certificate")
    }

    #[test]
    fn block_degrees_follow_the_mode_and_the_relaxation_order() {
        // s = 2, t = 1, one constraint of degree 2.
        let (lower, upper) = plan(2, 1, Mode::GlobalLowerBound, &[2]);
        // The global lower bound is never raised.
        assert_eq!(lower, vec![(None, 1)]);
        assert_eq!(upper, vec![(None, 2), (Some(0), 1)]);
        let (lower, upper) = plan(2, 1, Mode::OnRegion, &[2]);
        assert_eq!(lower, vec![(None, 2), (Some(0), 1)]);
        assert_eq!(upper, lower);
        // s = 0, t = 0: the multiplier blocks would have degree −1.
        let (lower, upper) = plan(0, 0, Mode::OnRegion, &[2, 2]);
        assert_eq!(lower, vec![(None, 0)]);
        assert_eq!(upper, vec![(None, 0)]);
        // A box in two variables, s = 4: one block per side.
        let (lower, upper) = plan(4, 0, Mode::OnRegion, &[2, 2]);
        assert_eq!(lower, vec![(None, 2), (Some(0), 1), (Some(1), 1)]);
        assert_eq!(upper, lower);
    }

    #[test]
    fn ball_and_box_constraints() {
        let names = ["q".to_string(), "p".to_string()];
        let ball = RegionModel::Ball {
            center: vec![Rational::ONE, Rational::ZERO],
            radius: Rational::integer(2),
        };
        let g = ball.constraints(2).unwrap();
        assert_eq!(g.len(), 1);
        assert_eq!(g[0].display(&names).to_string(), "3 + 2*q - q^2 - p^2");
        let cube = RegionModel::Box {
            lower: vec![Rational::integer(-2), r(-1, 2)],
            upper: vec![Rational::integer(2), Rational::integer(3)],
        };
        let g = cube.constraints(2).unwrap();
        assert_eq!(g[0].display(&names).to_string(), "4 - q^2");
        assert_eq!(g[1].display(&names).to_string(), "1.5 + 2.5*p - p^2");
        assert_eq!(cube.describe(&names), "the box q ∈ [-2, 2], p ∈ [-0.5, 3]");
    }

    #[test]
    fn targets_extend_the_metric_basis() {
        let ball = RegionModel::Ball {
            center: vec![Rational::ZERO; 2],
            radius: Rational::integer(2),
        };
        let model = build(ball, 2, 2, 1, Mode::GlobalLowerBound);
        assert_eq!(model.target_degree, 4);
        assert_eq!(model.targets.len(), 15);
        assert_eq!(&model.targets[..6], &bases::up_to_degree(2, 2)[..]);
        // Plain lower block of degree 1; the upper blocks of degree 2 and 1.
        let degrees: Vec<u32> = model.lower.iter().map(|b| b.degree).collect();
        assert_eq!(degrees, [1]);
        let degrees: Vec<u32> = model.upper.iter().map(|b| b.degree).collect();
        assert_eq!(degrees, [2, 1]);
        assert!(model.upper[0].multiplier.is_empty());
        // g = 4 − q² − p², graded-lex.
        let multiplier: Vec<(f64, Vec<u32>)> = model.upper[1]
            .multiplier
            .iter()
            .map(|(c, e)| (c.to_f64(), e.clone()))
            .collect();
        assert_eq!(
            multiplier,
            [(4.0, vec![0, 0]), (-1.0, vec![2, 0]), (-1.0, vec![0, 2])]
        );
    }

    #[test]
    fn oversized_certificates_are_errors() {
        let ball = RegionModel::Ball {
            center: vec![Rational::ZERO; 6],
            radius: Rational::ONE,
        };
        let constraints = ball.constraints(6).unwrap();
        let bases = Bases::new(6, 1, 4);
        let mut diagnostics = Diagnostics::new();
        let order = Degree {
            value: 4,
            span: Span::call_site(),
        };
        let model = certificate(
            ball,
            constraints,
            (Mode::OnRegion, 4),
            &bases,
            6,
            (Span::call_site(), Some(order)),
            &mut diagnostics,
        );
        assert!(model.is_none());
        let message = diagnostics.into_error().unwrap().to_string();
        assert!(message.contains("lower the relaxation order"), "{message}");
    }

    /// Σ_blocks g(x)·Z(x)ᵀQZ(x), computed directly.
    fn direct(
        blocks: &[Block],
        constraints: &[Polynomial],
        gram: &[Vec<f64>],
        n: usize,
        x: &[f64],
    ) -> Vec<f64> {
        let mut out = vec![0.0; n * n];
        for (block, q) in blocks.iter().zip(gram) {
            let g = block.constraint.map_or(1.0, |k| constraints[k].evaluate(x));
            let m: Vec<f64> = block
                .exponents
                .iter()
                .map(|e| Polynomial::monomial(e.clone(), Rational::ONE).evaluate(x))
                .collect();
            let size = n * m.len();
            for j in 0..n {
                for k in 0..n {
                    for (b, mb) in m.iter().enumerate() {
                        for (c, mc) in m.iter().enumerate() {
                            let entry = q[(j * m.len() + b) * size + k * m.len() + c];
                            out[j * n + k] += g * mb * mc * entry;
                        }
                    }
                }
            }
        }
        out
    }

    /// Σ_α x^α Σ_blocks Σ_{(β, γ, c) ∈ matching[α]} c·Q[(j, β), (k, γ)].
    fn through_tables(
        blocks: &[Block],
        targets: &[Vec<u32>],
        gram: &[Vec<f64>],
        n: usize,
        x: &[f64],
    ) -> Vec<f64> {
        let mut out = vec![0.0; n * n];
        for (alpha, e) in targets.iter().enumerate() {
            let monomial = Polynomial::monomial(e.clone(), Rational::ONE).evaluate(x);
            for (block, q) in blocks.iter().zip(gram) {
                let len = block.exponents.len();
                let size = n * len;
                for &(b, g, c) in &block.matching[alpha] {
                    for j in 0..n {
                        for k in 0..n {
                            let entry = q[(j * len + b) * size + k * len + g];
                            out[j * n + k] += monomial * c.to_f64() * entry;
                        }
                    }
                }
            }
        }
        out
    }

    fn region_strategy(n: usize) -> impl Strategy<Value = RegionModel> {
        let small = || (-6i128..=6, 1i128..=4).prop_map(|(a, b)| r(a, b));
        prop_oneof![
            (prop::collection::vec(small(), n), 1i128..=5, 1i128..=3).prop_map(|(center, a, b)| {
                RegionModel::Ball {
                    center,
                    radius: r(a, b),
                }
            }),
            (prop::collection::vec((small(), 1i128..=8), n)).prop_map(|sides| {
                let lower: Vec<Rational> = sides.iter().map(|(l, _)| *l).collect();
                let upper = sides
                    .iter()
                    .map(|(l, w)| l.add(r(*w, 2)).unwrap())
                    .collect();
                RegionModel::Box { lower, upper }
            }),
        ]
    }

    fn case() -> impl Strategy<Value = (usize, RegionModel, u32, u32, bool, u64)> {
        (1usize..=3).prop_flat_map(|n| {
            (
                Just(n),
                region_strategy(n),
                prop_oneof![Just(0u32), Just(2), Just(4)],
                0u32..=2,
                any::<bool>(),
                any::<u64>(),
            )
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The matching tables are exact: for random symmetric Gram
        /// matrices and a random x, the blocks evaluated directly and
        /// through the tables agree, on both sides of the certificate.
        #[test]
        fn matching_tables_are_exact((n, region, s, t, on_region, seed) in case()) {
            use rand_like::Lcg;
            let mode = if on_region { Mode::OnRegion } else { Mode::GlobalLowerBound };
            let model = build(region, n, s, t, mode);
            let mut rng = Lcg(seed | 1);
            // Metric basis is a prefix; every block's products are targets.
            let metric = bases::up_to_degree(n, s);
            prop_assert_eq!(&model.targets[..metric.len()], &metric[..]);
            for blocks in [&model.lower, &model.upper] {
                let gram: Vec<Vec<f64>> = blocks
                    .iter()
                    .map(|b| {
                        let size = n * b.exponents.len();
                        let mut q = vec![0.0; size * size];
                        for i in 0..size {
                            for j in i..size {
                                let v = rng.uniform();
                                q[i * size + j] = v;
                                q[j * size + i] = v;
                            }
                        }
                        q
                    })
                    .collect();
                let x: Vec<f64> = (0..n).map(|_| 1.5 * rng.uniform()).collect();
                let a = direct(blocks, &model.constraints, &gram, n, &x);
                let b = through_tables(blocks, &model.targets, &gram, n, &x);
                for (u, v) in a.iter().zip(&b) {
                    prop_assert!((u - v).abs() <= 1e-9 * u.abs().max(1.0), "{u} vs {v}");
                }
                // Every ordered pair of a block meets every multiplier term once.
                for block in blocks.iter() {
                    let terms = block.multiplier.len().max(1);
                    let entries: usize = block.matching.iter().map(Vec::len).sum();
                    let len = block.exponents.len();
                    prop_assert_eq!(entries, len * len * terms);
                    for row in &block.matching {
                        for &(b, g, c) in row {
                            prop_assert!(row.contains(&(g, b, c)), "ordered pairs come in both orders");
                        }
                    }
                }
            }
        }
    }

    /// A tiny deterministic generator: the tests need reproducible floats,
    /// not `rand`.
    mod rand_like {
        pub struct Lcg(pub u64);

        impl Lcg {
            /// Uniform in [−1, 1).
            pub fn uniform(&mut self) -> f64 {
                self.0 = self
                    .0
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
            }
        }
    }
}
