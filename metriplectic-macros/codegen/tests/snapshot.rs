//! The expansion users see under `cargo expand`, and the readable monomial
//! names of the generated code.

use std::path::PathBuf;

use quote::quote;

/// The paper's 2-D system (as in `src/systems.rs`), as a user would write it.
fn linear_2d() -> proc_macro2::TokenStream {
    quote! {
        /// Canonical oscillator whose free energy has a figure-eight zero set.
        pub struct Oscillator;
        state (q, p);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = 0.5 * p^2 + 0.5 * q^2;
        entropy degree 8;
        metric degree 2;
        reference {
            entropy = -0.5 * (p^2 + 4*q^4 - 4*q^2)^2 - (0.5*p^2 + 0.5*q^2);
            metric = [[1, 0], [0, 1]];
        }
    }
}

fn pretty(tokens: proc_macro2::TokenStream) -> String {
    let file: syn::File = syn::parse2(tokens).expect("generated code parses as a file");
    prettyplease::unparse(&file)
}

fn expand(tokens: proc_macro2::TokenStream) -> String {
    pretty(metriplectic_codegen::try_expand(tokens).expect("valid system"))
}

/// A state named like a readable monomial name (`x2` for x²) switches
/// every monomial binding to collision-free fallback names.
#[test]
fn colliding_monomial_names_fall_back() {
    let text = expand(quote! {
        struct Awkward;
        state (x, x2);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = x^2;
        entropy degree 2;
        metric degree 0;
    });
    assert!(
        text.contains("let (monomial_3, monomial_4, monomial_5) = (x * x, x * x2, x2 * x2);"),
        "{text}"
    );
    let text = expand(quote! {
        struct Plain;
        state (x, y);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = x^2;
        entropy degree 2;
        metric degree 0;
    });
    assert!(
        text.contains("let (x2, x_y, y2) = (x * x, x * y, y * y);"),
        "{text}"
    );
}

/// Small systems get a straight-line `entropy_gradient`; past the Jacobian
/// size where compile time outgrows the gain, the trait's table walk stays.
#[test]
fn straight_line_gradient_only_below_the_threshold() {
    let small = expand(linear_2d());
    assert!(small.contains("fn entropy_gradient("), "{small}");
    // 5 variables, degree 8: 3960 Jacobian entries.
    let large = expand(quote! {
        struct Large;
        state (a, b, c, d, e);
        poisson = [[0, 0, 0, 0, 0], [0, 0, 0, 0, 0], [0, 0, 0, 0, 0], [0, 0, 0, 0, 0],
                   [0, 0, 0, 0, 0]];
        hamiltonian = a^2;
        entropy degree 8;
        metric degree 0;
    });
    assert!(!large.contains("fn entropy_gradient("));
    assert!(large.contains("fn monomials("));
}

/// What users see under `cargo expand`; `UPDATE_SNAPSHOTS=1` rewrites it.
#[test]
fn linear_2d_expansion_matches_snapshot() {
    let expanded = expand(linear_2d());
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("snapshots/linear_2d.expanded.rs");
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
        std::fs::create_dir_all(path.parent().expect("snapshot dir")).expect("create snapshots/");
        std::fs::write(&path, &expanded).expect("write snapshot");
    }
    let stored = std::fs::read_to_string(&path)
        .expect("snapshot missing: run with UPDATE_SNAPSHOTS=1 and review the file");
    assert!(
        stored == expanded,
        "expansion changed; review and rerun with UPDATE_SNAPSHOTS=1\n{expanded}"
    );
}

/// The 2-D oscillator with the given attributes.
fn with_attributes(attributes: proc_macro2::TokenStream) -> proc_macro2::TokenStream {
    quote! {
        #attributes
        pub struct Attributed;
        state (q, p);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = 0.5 * q^2 + 0.5 * p^2;
        entropy degree 2;
        metric degree 0;
    }
}

/// The attributes just before `item` in the pretty-printed `text` (the
/// lines starting with `#[`, or continuing one, directly above it).
fn attributes_before(text: &str, item: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.starts_with(item))
        .unwrap_or_else(|| panic!("no `{item}` in\n{text}"));
    let mut start = at;
    while start > 0 && !lines[start - 1].starts_with("///") && !lines[start - 1].starts_with('}') {
        start -= 1;
    }
    lines[start..at].join("\n")
}

/// A configured-out struct takes its module and impl along (they named a
/// type that did not exist: E0425), also on a broken invocation's
/// stand-in impl; a deprecated one's impl allows the deprecation it uses.
#[test]
fn cfg_and_deprecation_reach_every_generated_item() {
    let text = expand(with_attributes(quote! {
            #[cfg(any())]
            #[cfg_attr(unix, cfg(feature = "x"), derive(Clone))]
            #[deprecated(note = "old")]
    }));
    let module = attributes_before(&text, "mod __metriplectic_Attributed");
    let implementation = attributes_before(&text, "impl ::metriplectic_runtime");
    for attributes in [&module, &implementation] {
        assert!(
            attributes.contains("#[cfg(any())]")
                && attributes.contains("#[cfg_attr(unix, cfg(feature = \"x\"))]")
                && !attributes.contains("derive"),
            "{text}"
        );
    }
    assert!(
        implementation.contains("#[allow(deprecated)]") && !module.contains("deprecated"),
        "{text}"
    );
    // Without `deprecated`, no `allow(deprecated)`: a crate may forbid it.
    let plain = expand(with_attributes(quote!()));
    assert!(!plain.contains("deprecated"), "{plain}");
    // The stand-in items of a broken invocation.
    let broken = metriplectic_codegen::try_expand(quote! {
        #[cfg(any())]
        #[deprecated]
        pub struct Broken;
        state (q, p);
    })
    .expect_err("missing sections")
    .into_tokens()
    .to_string();
    assert!(
        broken.contains("# [cfg (any ())] # [allow (deprecated)] impl"),
        "{broken}"
    );
}

/// `#[cfg_attr(P, derive(Debug))]` derives `Debug` where P holds, so the
/// macro derives it under `not(P)`: once either way (E0119 otherwise).
#[test]
fn traits_derived_under_cfg_attr_are_derived_under_the_negation() {
    let text = expand(with_attributes(quote! {
            #[cfg_attr(all(), derive(Debug))]
            #[cfg_attr(unix, cfg_attr(test, derive(Clone, Hash)))]
            #[cfg_attr(windows, derive(Hash))]
            #[derive(PartialEq)]
    }));
    let derives = attributes_before(&text, "pub struct Attributed");
    let expected = [
        "#[derive(::core::marker::Copy, ::core::default::Default, ::core::cmp::Eq)]",
        "#[cfg_attr(not(all()), derive(::core::fmt::Debug))]",
        "#[cfg_attr(not(all(unix, test)), derive(::core::clone::Clone))]",
        "#[cfg_attr(not(any(all(unix, test), windows)), derive(::core::hash::Hash))]",
    ];
    let flat = derives.split_whitespace().collect::<String>();
    for attribute in expected {
        let attribute: String = attribute.split_whitespace().collect();
        assert!(flat.contains(&attribute), "{attribute}:\n{derives}");
    }
    assert!(!flat.contains("PartialEq)"), "{derives}");
    assert!(
        text.contains(
            "Derives `Copy`, `Default`, `Eq` and, where your `cfg_attr`s do not derive them, \
             `Debug`, `Clone`, `Hash`"
        ),
        "{text}"
    );
}

/// `#[allow(…)]` of a lint the crate forbids is an error (E0453), so the
/// module allows `non_snake_case` only for state names that need it and
/// `clippy::suboptimal_flops` only for sums of products.
#[test]
fn lints_are_allowed_only_where_needed() {
    let allow = |text: &str| attributes_before(text, "mod __metriplectic_");
    let lower = expand(linear_2d());
    assert!(
        allow(&lower).contains("#[allow(clippy::suboptimal_flops)]"),
        "{lower}"
    );
    let upper = expand(quote! {
        struct Upper;
        state (q, P);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = q^2 + P^2;
        entropy degree 2;
        metric degree 0;
    });
    assert!(
        allow(&upper).contains("#[allow(non_snake_case, clippy::suboptimal_flops)]"),
        "{upper}"
    );
    // Snake case, but `q_` times `p` would be the binding `q__p`.
    let underscores = expand(quote! {
        struct Underscores;
        state (q_, p);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = q_^2 + p^2;
        entropy degree 3;
        metric degree 0;
    });
    assert!(
        allow(&underscores).contains("non_snake_case"),
        "{underscores}"
    );
    // No sum with a product anywhere: H = q², ∇H = (2q, 0), Π and the
    // entropy gradient's terms ψ₀, ψ₁ alone.
    let none = expand(quote! {
        struct Plain;
        state (q, p);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = q^2;
        entropy degree 1;
        metric degree 0;
    });
    assert!(!allow(&none).contains("allow"), "{none}");
}
