//! The `metriplectic!` macro.
//!
//! Use it through `metriplectic_runtime`, which re-exports it and provides the
//! `MetriplecticSystem` trait the generated code implements. This crate is a
//! thin wrapper: the parser, the exact polynomial analysis and the code
//! generator are the ordinary library `metriplectic-codegen`, where they can
//! be tested, fuzzed and benchmarked like any other code.

use proc_macro::TokenStream;

/// Declares a generalized metriplectic system
/// ẋ = (Π(x) + K(x)) (∇H(x) + ∇S(x)) with known Poisson tensor Π and
/// Hamiltonian H, and polynomial bases for the unknown entropy S and metric K.
///
/// ```ignore
/// use metriplectic_runtime::prelude::*;
///
/// metriplectic! {
///     /// Docs carried to the generated type.
///     pub struct Oscillator;
///     state (q, p);                       // x = (q, p), in this order
///     const k = 1;                        // optional named constants
///     poisson = [[0, 1], [-1, 0]];        // Π(x): n×n polynomial entries
///     hamiltonian = 0.5 * p^2 + 0.5 * k * q^2;
///     entropy degree 8;                   // S spans monomials of degree 1..=8
///     metric degree 2;                    // K entries span degree 0..=2 (even)
///     reference {                         // optional known model
///         entropy = -0.5 * (p^2 + 4*q^4 - 4*q^2)^2 - (0.5*p^2 + 0.5*q^2);
///         metric  = [[1, 0], [0, 1]];
///     }
/// }
/// ```
///
/// # Sections
///
/// Sections may come in any order, each at most once; `const` may repeat.
///
/// * `pub struct Name;` first, with optional doc comments, attributes and
///   visibility. It becomes a unit struct implementing
///   `metriplectic_runtime::MetriplecticSystem`. Its `#[cfg(…)]`s (also
///   inside `#[cfg_attr(…)]`) apply to everything generated for it.
/// * `state (a, b, …);` the state variables, in state order.
/// * `const NAME = expr;` a named constant: a constant expression that may use
///   numbers and constants declared before it. Other sections may use every
///   constant, wherever it is declared.
/// * `poisson = [[…], …];` Π(x), an n×n matrix of polynomials. It must be
///   skew-symmetric and satisfy the Jacobi identity; both are checked exactly.
/// * `hamiltonian = expr;` H(x).
/// * `entropy degree r;` (1 ≤ r) the entropy basis: all monomials of degree
///   1..=r (the constant has zero gradient, so it is left out).
/// * `metric degree s;` (even) each entry of K spans the monomials of degree
///   0..=s (without a `region`, only the constant is certified: see below).
/// * `region …;`, `certificate …;`, `relaxation order t;` optional: the
///   region where a state-dependent metric is certified (below).
/// * `classical;` optional: the classical (GENERIC) form (below).
/// * `reference { entropy = expr; metric = [[…]]; }` optional: a known model
///   (for synthetic data and tests). It must fit the declared bases (a
///   constant term of the entropy is dropped, as the basis has none: it
///   changes neither ∇S nor the dynamics) and the metric must be symmetric; a constant metric must be positive
///   semidefinite (checked exactly). A metric that depends on the state
///   needs a `region` (below). Every coefficient is at most 1e15 in
///   magnitude, the bound `Model::MAX_COEFFICIENT` of the runtime.
///
/// ## Regions: state-dependent metrics
///
/// The metric search certifies 0 ⪯ K(x) ⪯ ηI with sums of squares. On all of
/// Rⁿ a matrix polynomial bounded on both sides is constant, so without a
/// region the metric is constant, whatever `metric degree` says. A region
/// R = {x : gₖ(x) ≥ 0} lets it depend on the state, certified by the matrix
/// S-procedure:
///
/// ```ignore
/// region ball(center = [0, 0], radius = 2);   // g = 4 − q² − p² ≥ 0
/// // or a box, gⱼ = (uⱼ − xⱼ)(xⱼ − lⱼ) ≥ 0:
/// // region box(q in [-2, 2], p in [-3, 1]);
/// certificate on region;                      // optional
/// relaxation order 1;                         // optional, 0 by default
/// ```
///
/// * `region ball(center = [c₁, …, cₙ], radius = ρ);` ‖x − c‖ ≤ ρ: one
///   centre coordinate per state variable (`center` may be left out for
///   the origin), ρ > 0. `region box(x₁ in [l₁, u₁], …);` lⱼ ≤ xⱼ ≤ uⱼ:
///   every state variable exactly once, in any order, lⱼ < uⱼ. The numbers
///   are constant expressions: numbers and constants, no state variable.
/// * `certificate global lower bound;` (the default): K(x) ⪰ 0 for every x
///   (a sum of squares Σ₀ with a basis of degree ≤ s/2) and ηI − K(x) =
///   Σ₁ + Σₖ gₖ Σ₁ₖ ⪰ 0 on R, so the free energy never decreases anywhere.
///   `certificate on region;`: also K(x) = Σ₀ + Σₖ gₖ Σ₀ₖ, so K ⪰ 0 and
///   dE/dt ≥ 0 are certified **only on R** (the generated docs say so).
/// * `relaxation order t;` raises the degree of every block except the
///   global lower bound's by t (more freedom, bigger programs); coefficients
///   above the metric degree must then cancel.
///
/// `certificate` or `relaxation` without a `region` is an error; with a
/// region the metric degree must still be even.
///
/// ## The classical form
///
/// `classical;` declares the GENERIC structure: S is a Casimir of Π
/// (Π∇S ≡ 0) and K∇H ≡ 0, so H is conserved and S produced. The macro
/// derives both identities exactly as linear constraints on the entropy
/// and metric coefficients, and a basis of Π's polynomial Casimirs in the
/// entropy basis (for so(3): |p|², |p|⁴, …), listed in the generated docs.
/// It is an error if Π has no Casimir up to the entropy degree (a canonical
/// Π has none), or if no non-zero metric of the basis satisfies K∇H ≡ 0
/// (without a region K is constant and usually must vanish: declare a
/// region and a metric degree of at least 2·deg ∇H, where
/// K(x) = c(|∇H|²I − ∇H∇Hᵀ) qualifies; with one state variable nothing
/// does, as k(x)·H′(x) ≡ 0 forces k ≡ 0). A reference model must satisfy both
/// identities, checked exactly. At run time every search imposes both, the
/// identified model meets them to rounding, and `Method::DiscreteGradient`
/// simulates it with H conserved and S non-decreasing.
///
/// # Expressions
///
/// Polynomials written with numbers (`2`, `0.5`, `1e-3`: all exact
/// rationals, without a type suffix: write `2 * q`, not `2q`), state
/// variables, constants, `+ - * /`, `^` and parentheses. `^` takes an
/// integer exponent, non-negative unless the base is a constant (`2^-1` is
/// exactly 1/2), binds tighter than unary minus and `*`, and is
/// right-associative: `-q^2` is −(q²), `2*q^3` is 2(q³), `2^3^2` is 2⁹.
/// Division is only by non-zero constant expressions. Anything else — a
/// variable in a denominator, `q^-1`, `q^0.5`, `sin(q)`, `q.powi(2)` — is a
/// compile error pointing at the offending tokens.
///
/// Every coefficient is the f64 nearest its exact rational value. H is
/// expanded into monomials and evaluated in that form, so a factored H
/// whose terms cancel loses the digits they share: `(q - p)^4` at
/// (10001, 10000) evaluates to 0 rather than 1, since its monomials there
/// are of order 1e16. Declare the state in coordinates where the terms are
/// moderate (here the difference itself), as the runtime's centred
/// coordinates do for the unknown parts.
///
/// # What it generates
///
/// View it with `cargo expand`; `metriplectic-macros/codegen/snapshots/`
/// holds a reviewed expansion of the 2-D paper system.
///
/// * The unit struct, with your attributes and visibility, your doc comments
///   followed by a generated summary (state, H, Π, bases, reference), and
///   `#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]` (path
///   qualified, `::core::fmt::Debug` and so on). A trait you derive yourself,
///   e.g. `#[derive(Clone)]`, is left out of the generated derive rather than
///   derived twice; one you derive under `#[cfg_attr(P, derive(…))]` is
///   derived by the macro under `#[cfg_attr(not(P), derive(…))]`. The trait
///   needs `Debug`, `Copy` and `Default`.
/// * A hidden module `__metriplectic_<Name>` with straight-line code for H,
///   ∇H, Π, the monomials (graded lexicographic, each one multiplication from
///   a lower one, computing only as many degrees as the caller asks for) and
///   the entropy gradient ∇S = J(x)ᵀψ as sums over named monomials. It
///   allows `non_snake_case` only if a state variable's name needs it, and
///   `clippy::suboptimal_flops` only if it adds products, so that a crate
///   forbidding these lints can use the macro.
/// * `impl metriplectic_runtime::MetriplecticSystem`: the exponent tables (by
///   degree, then larger exponents of earlier variables first), the entropy
///   Jacobian as a table, the SOS matching tables (full and facially
///   reduced), the reference coefficients, and methods forwarding to the
///   module; with `#[allow(deprecated)]` if the struct is `#[deprecated]`. Everything else (features, Jacobian, metric, the rows of the
///   searches) is the trait's provided code, shared by all systems.
/// * With a `region`, `REGION_CERTIFICATE`; with `classical;`, `CLASSICAL`.
///   Their tables are named constants with docs in the module
///   `__metriplectic_<Name>::tables` (`REGION_TARGETS`, one `GramBlock` per
///   block: `LOWER_SOS`, `LOWER_G1`, …, `UPPER_SOS`, `UPPER_G1`, …;
///   `ENTROPY_CONSTRAINTS`, `CASIMIR_BASIS`, `METRIC_CONSTRAINTS`).
///
/// # Names and hygiene
///
/// The generated code refers to the runtime as `::metriplectic_runtime`:
/// depend on it under that name (a dependency renamed in `Cargo.toml`,
/// `mr = { package = "metriplectic-runtime", … }`, is not found).
///
/// The generated code means the same whatever your scope holds: state
/// variables are bound inside the `#[no_implicit_prelude]` module, where no
/// import, constant or prelude item is visible, so a state named `E` next to
/// `use std::f64::consts::*;`, a state `q` next to a `const q`, or a state
/// named `None` are all ordinary variables; the generated locals use
/// `Span::mixed_site()` hygiene and cannot clash with state names. Raw
/// identifiers work: `state (r#type, p);` and `r#type` (or `type`) in
/// expressions. Reserved:
///
/// * the module name `__metriplectic_<Name>` in the scope of the invocation;
/// * state variables named `t` or `trajectory`, and pairs like `q` and `dq`:
///   trajectory CSV files use these columns for time, the trajectory
///   identifier and the derivative of `q`.
///
/// # Errors
///
/// Every mistake of an invocation is reported in one compile, each at the
/// tokens concerned (independent sections, constants and checks are checked
/// independently; what depends on a broken part is skipped, not reported
/// again). A constant reference metric is checked to be positive
/// semidefinite, exactly; a non-constant one needs a region. Regions,
/// certificate options and the classical form are checked the same way. With errors, the struct and a stand-in trait impl
/// are still emitted, so later uses of the type add no further errors.
#[proc_macro]
pub fn metriplectic(input: TokenStream) -> TokenStream {
    metriplectic_codegen::expand(input.into()).into()
}
