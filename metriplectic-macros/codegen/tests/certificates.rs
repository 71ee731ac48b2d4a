//! Region certificates and the classical form through the public entry
//! point: what each mistake reports, and what a valid declaration expands
//! to.

use proc_macro2::TokenStream;
use quote::quote;

fn messages(tokens: TokenStream) -> Vec<String> {
    metriplectic_codegen::try_expand(tokens)
        .expect_err("the system is rejected")
        .messages()
}

fn expand(tokens: TokenStream) -> String {
    let tokens = metriplectic_codegen::try_expand(tokens).expect("valid system");
    let file: syn::File = syn::parse2(tokens).expect("generated code parses");
    prettyplease::unparse(&file)
}

/// The 2-D oscillator with extra sections.
fn oscillator(extra: TokenStream) -> TokenStream {
    quote! {
        pub struct Oscillator;
        state (q, p);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = 0.5 * p^2 + 0.5 * q^2;
        entropy degree 4;
        metric degree 2;
        #extra
    }
}

/// Asserts that `all` has one message per expected fragment, in order.
fn assert_messages(all: &[String], expected: &[&str]) {
    assert_eq!(all.len(), expected.len(), "{all:#?}");
    for (message, fragment) in all.iter().zip(expected) {
        assert!(message.contains(fragment), "{fragment}: {all:#?}");
    }
}

#[test]
fn ball_mistakes() {
    let all = messages(oscillator(quote! {
        region ball(center = [0, 0, 1], radius = -2);
    }));
    assert_messages(
        &all,
        &[
            "the ball's centre has 3 coordinates, but the state has 2",
            "the ball's radius must be positive, but it is -2",
        ],
    );
    let all = messages(oscillator(quote! { region ball(center = [0, 0]); }));
    assert_messages(&all, &["the ball has no radius; add `radius = …`"]);
    let all = messages(oscillator(
        quote! { region ball(radius = 0, size = 2, radius = 1); },
    ));
    assert_messages(
        &all,
        &[
            "unknown parameter `size` of a ball",
            "the ball's `radius` is given twice",
            "the ball's radius must be positive, but it is 0",
        ],
    );
    let all = messages(oscillator(quote! { region ball(radius = q + 1); }));
    assert_messages(&all, &["cannot depend on the state variable `q`"]);
    let all = messages(oscillator(quote! { region ball(radius = rho); }));
    assert_messages(
        &all,
        &["unknown name `rho`; the region is given by constant"],
    );
    // Constants work, wherever they are declared.
    let text = expand(oscillator(quote! {
        region ball(center = [c, 0], radius = 2 * c);
        const c = 0.75;
    }));
    assert!(
        text.contains("center: &[0.75, 0.0]") && text.contains("radius: 1.5"),
        "{text}"
    );
}

/// A forgotten comma between a region's parameters is one error at the
/// parameter after it, and both parameters still count: no "the ball has
/// no radius" as well (as there was).
#[test]
fn missing_commas_between_region_parameters() {
    let all = messages(oscillator(quote! {
        region ball(center = [0, 0] radius = 1);
    }));
    assert_messages(
        &all,
        &["expected `,` before `radius`: the ball's parameters are separated by commas"],
    );
    let all = messages(oscillator(quote! {
        region ball(radius = 1 center = [0, 0, 0]);
    }));
    assert_messages(
        &all,
        &[
            "expected `,` before `center`",
            "the ball's centre has 3 coordinates, but the state has 2",
        ],
    );
    let all = messages(oscillator(quote! {
        region box(q in [-1, 1] p in [-2, 2]);
    }));
    assert_messages(
        &all,
        &["expected `,` before `p`: the intervals are separated by commas"],
    );
}

/// Regions whose constraints lose their meaning when their coefficients
/// are rounded to `f64` (the certificate tables carry them so): a ball of
/// radius 1 at 10⁸ rounds to g′ = −(q − 10⁸)², which certifies any K; a
/// box a billionth wide at 0.1 changes by more than it peaks. Ordinary
/// regions, far or near, are accepted.
#[test]
fn regions_that_rounding_would_change_are_refused() {
    let refused = "the region cannot be certified in floating point";
    let all = messages(oscillator(quote! {
        region ball(center = [100000000, 0], radius = 1);
    }));
    assert_messages(&all, &[refused]);
    let all = messages(oscillator(quote! {
        region box(q in [0.1, 0.1000000001], p in [-1, 1]);
    }));
    assert_messages(
        &all,
        &["the region cannot be certified in floating point: its constraint g0(x)"],
    );
    expand(oscillator(
        quote! { region ball(center = [1000, 0], radius = 1); },
    ));
    expand(oscillator(
        quote! { region box(q in [0.1, 0.1001], p in [-1, 1]); },
    ));
}

#[test]
fn box_mistakes() {
    let all = messages(oscillator(quote! { region box(q in [-2, 2]); }));
    assert_messages(
        &all,
        &["the box gives no interval for `p`; every state variable needs exactly one"],
    );
    let all = messages(oscillator(quote! {
        region box(q in [2, -2], q in [0, 1], z in [0, 1], p in [1]);
    }));
    assert_messages(&all, &["an interval has a lower and an upper bound"]);
    let all = messages(oscillator(quote! {
        region box(q in [2, -2], q in [0, 1], z in [0, 1], p in [1, 1]);
    }));
    assert_messages(
        &all,
        &[
            "the interval of `q` is empty: its lower bound 2 is not below its upper bound -2",
            "`q` has two intervals",
            "`z` is not a state variable",
            "the interval of `p` is the single point 1: a region needs an interval of positive width",
        ],
    );
    let all = messages(oscillator(quote! { region box(q = [0, 1], p in [0, 1]); }));
    assert_messages(
        &all,
        &["expected a state variable and its interval, like `q in [-2, 2]`"],
    );
    let all = messages(oscillator(quote! { region cube(q in [0, 1]); }));
    assert_messages(&all, &["unknown region `cube`"]);
}

#[test]
fn certificate_options_need_a_region() {
    let all = messages(oscillator(quote! {
        certificate on region;
        relaxation order 1;
    }));
    assert_messages(
        &all,
        &[
            "`certificate` chooses where the bounds of a region certificate hold, but the system \
             declares no region",
            "`relaxation order` raises the degrees of a region certificate, but the system \
             declares no region",
        ],
    );
    // A broken region is still a declared one: only its own error.
    let all = messages(oscillator(quote! {
        region ball(radius = 0);
        certificate on region;
    }));
    assert_messages(&all, &["radius must be positive"]);
    let all = messages(oscillator(quote! {
        region ball(radius = 2);
        certificate everywhere;
        relaxation degree 1;
    }));
    assert_messages(
        &all,
        &[
            "unknown certificate mode",
            "expected `order`: write `relaxation order 1;`",
        ],
    );
    let all = messages(oscillator(quote! {
        region ball(radius = 2);
        region ball(radius = 3);
    }));
    assert_messages(&all, &["`region` is declared twice"]);
}

/// A state-dependent reference metric is checked exactly at the region's
/// centre, axis ends or corners: 1 − 2q² is −1 at the box's corners and is
/// refused at compile time; 1 − q², PSD on the box (0 at its corners), is
/// accepted here and left to the runtime's certificate.
#[test]
fn reference_metrics_are_spot_checked_on_the_region() {
    let refused = messages(oscillator(quote! {
        region box(q in [-1, 1], p in [-1, 1]);
        reference { entropy = -q^2; metric = [[1 - 2*q^2, 0], [0, 1]]; }
    }));
    assert_messages(
        &refused,
        &["the reference metric is not positive semidefinite in the region: at (q, p) = (-1, -1), \
           yᵀK(x)y = -1 < 0 for y = (1, 0)"],
    );
    let refused = messages(oscillator(quote! {
        region ball(radius = 2);
        reference { entropy = -q^2; metric = [[1, q], [q, 1]]; }
    }));
    assert_messages(&refused, &["at (q, p) = (-2, 0)"]);
    expand(oscillator(quote! {
        region box(q in [-1, 1], p in [-1, 1]);
        reference { entropy = -q^2; metric = [[1 - q^2, 0], [0, 1]]; }
    }));
}

#[test]
fn non_constant_reference_metrics_need_a_region() {
    let reference = quote! {
        reference { entropy = -q^2; metric = [[1 + p^2, -q*p], [-q*p, 1 + q^2]]; }
    };
    let all = messages(oscillator(reference.clone()));
    assert_messages(
        &all,
        &[
            "the reference metric depends on the state, but without a region the metric must be \
           constant",
        ],
    );
    assert!(
        all[0].contains("`region ball(center = [0, 0], radius = 2);`"),
        "{all:#?}"
    );
    let text = expand(oscillator(quote! {
        region ball(radius = 2);
        #reference
    }));
    assert!(text.contains("const REGION_CERTIFICATE"), "{text}");
    // A constant one keeps its exact check, with or without a region.
    let all = messages(oscillator(quote! {
        region ball(radius = 2);
        reference { entropy = -q^2; metric = [[1, 2], [2, 1]]; }
    }));
    assert_messages(&all, &["not positive semidefinite"]);
}

#[test]
fn every_mistake_is_reported_together() {
    let all = messages(quote! {
        pub struct Oscillator;
        state (q, p);
        poisson = [[0, 1], [1, 0]];
        hamiltonian = 0.5 * p^2 + 0.5 * q^2;
        entropy degree 4;
        metric degree 3;
        region box(q in [1, 0]);
        relaxation order 1;
        reference { entropy = -q^2; metric = [[1, 0], [0, 1 + q^2]]; }
    });
    assert_messages(
        &all,
        &[
            "Π must be skew-symmetric",
            "metric degree 3 is odd",
            "the interval of `q` is empty",
            "the box gives no interval for `p`",
        ],
    );
}

#[test]
fn certificate_sizes_are_capped() {
    let all = messages(quote! {
        struct Chain;
        state (a, b, c, d, e, f);
        poisson = [[0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1],
                   [-1, 0, 0, 0, 0, 0], [0, -1, 0, 0, 0, 0], [0, 0, -1, 0, 0, 0]];
        hamiltonian = a^2;
        entropy degree 2;
        metric degree 4;
        region ball(radius = 1);
        certificate on region;
        relaxation order 3;
    });
    assert_messages(&all, &["at most 1000000 entries"]);
    assert!(all[0].contains("lower the relaxation order"), "{all:#?}");
    let all = messages(oscillator(quote! {
        region ball(radius = 1);
        relaxation order 20;
    }));
    assert_messages(&all, &["reach degree 42; at most 32 is supported"]);
}

#[test]
fn names_that_look_like_sections() {
    // A state variable named `classical` at the end of an expression, and a
    // missing `;` before a real `classical;`.
    let text = expand(quote! {
        struct Named;
        state (classical, p);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = p^2 + classical;
        entropy degree 2;
        metric degree 0;
    });
    assert!(text.contains("struct Named"));
    let all = messages(quote! {
        struct Named;
        state (x, y, z);
        poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
        hamiltonian = x^2
        classical;
        entropy degree 2;
        metric degree 0;
    });
    assert_messages(&all, &["expected `;` after the expression"]);
}

#[test]
fn region_expansion() {
    let text = expand(oscillator(quote! {
        region box(q in [-2, 2], p in [-1, 1]);
        certificate on region;
        relaxation order 1;
        reference { entropy = -q^2; metric = [[1 + p^2, -q*p], [-q*p, 1 + q^2]]; }
    }));
    for expected in [
        "/// * Region R: the box q ∈ [-2, 2], p ∈ [-1, 1], i.e. `4 - q^2` ≥ 0, `1 - p^2` ≥ 0.",
        "0 ⪯ K(x) ⪯ ηI on the region only",
        "/// * **Warning:** with `certificate on region;`",
        "dE/dt = ∇Eᵀ K ∇E ≥ 0",
        "pub(super) mod tables {",
        "const REGION_TARGETS: &[&[u32]]",
        "const LOWER_SOS: ::metriplectic_runtime::GramBlock",
        "const LOWER_G1: ::metriplectic_runtime::GramBlock",
        "const LOWER_G2: ::metriplectic_runtime::GramBlock",
        "const UPPER_G2: ::metriplectic_runtime::GramBlock",
        "multiplier: &[(1.0, &[0, 0]), (-1.0, &[0, 2])]",
        "mode: ::metriplectic_runtime::CertificateMode::OnRegion",
        "region: ::metriplectic_runtime::Region::Box {",
        "relaxation_order: 1,",
        "lower: &[LOWER_SOS, LOWER_G1, LOWER_G2],",
        "__metriplectic_Oscillator::tables::REGION_CERTIFICATE",
    ] {
        assert!(text.contains(expected), "{expected}\n{text}");
    }
    assert!(!text.contains("const CLASSICAL"));
    // Without a region nothing is added: the trait's defaults stay.
    let text = expand(oscillator(TokenStream::new()));
    assert!(!text.contains("REGION_CERTIFICATE") && !text.contains("mod tables"));
}

#[test]
fn classical_expansion() {
    let text = expand(quote! {
        pub struct RigidBody;
        state (x, y, z);
        poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
        hamiltonian = 0.5 * (x^2 + y^2 + z^2);
        entropy degree 4;
        metric degree 2;
        region ball(radius = 2);
        classical;
    });
    for expected in [
        "/// * Classical (GENERIC) form (`CLASSICAL`)",
        "`x^2 + y^2 + z^2`, `x^4 + 2*x^2*y^2 + 2*x^2*z^2 + y^4 + 2*y^2*z^2 + z^4`",
        "const ENTROPY_CONSTRAINTS: &[::metriplectic_runtime::LinearForm]",
        "const CASIMIR_BASIS: &[::metriplectic_runtime::LinearForm]",
        "const METRIC_CONSTRAINTS: &[::metriplectic_runtime::LinearForm]",
        "__metriplectic_RigidBody::tables::CLASSICAL",
    ] {
        assert!(text.contains(expected), "{expected}\n{text}");
    }
    // |p|² = ψ at x², y², z² (indices 3, 6, 8 of the degree-≤4 basis).
    assert!(text.contains("&[(3, 1.0), (6, 1.0), (8, 1.0)]"), "{text}");
}
