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
