//! Checks that multiply whole polynomials (the Jacobi identity, the
//! classical form's constraints) count their work before they start:
//! entries that pass every per-expression cap but would take minutes to
//! hours of products are a compile error that says so, at once.

use proc_macro2::TokenStream;

fn messages(text: &str) -> Vec<String> {
    let tokens: TokenStream = text.parse().expect("lexable");
    metriplectic_codegen::try_expand(tokens)
        .expect_err("the system is rejected")
        .messages()
}

/// A skew 5×5 Π whose upper entries are all `entry`.
fn skew(entry: &str) -> String {
    let rows: Vec<String> = (0..5)
        .map(|i| {
            let row: Vec<String> = (0..5)
                .map(|j| match i.cmp(&j) {
                    std::cmp::Ordering::Equal => "0".to_owned(),
                    std::cmp::Ordering::Less => format!("({entry})"),
                    std::cmp::Ordering::Greater => format!("-({entry})"),
                })
                .collect();
            format!("[{}]", row.join(", "))
        })
        .collect();
    format!("[{}]", rows.join(", "))
}

/// A 5-state system with the skew Π of `entry` and nothing else to check.
fn five_states(name: &str, entry: &str) -> String {
    format!(
        "struct {name}; state (a, b, c, d, e); poisson = {}; hamiltonian = a^2; \
         entropy degree 2; metric degree 0;",
        skew(entry)
    )
}

/// Asserts that some message of `text`'s expansion contains every part.
fn reports(text: &str, parts: &[&str]) -> Vec<String> {
    let all = messages(text);
    assert!(
        all.iter()
            .any(|m| parts.iter().all(|part| m.contains(part))),
        "{all:?}"
    );
    all
}

#[test]
fn a_jacobi_check_beyond_the_budget_is_an_error_at_the_poisson_tensor() {
    // 792 terms per entry: 4.4·10⁷ products of terms.
    reports(
        &five_states("Slow", "1 + a + b + c + d + e)^7 + (0"),
        &["checking the Jacobi identity exactly would take 43908480 products of terms"],
    );
    // A smaller Π of the same shape is checked (and is not Poisson); its
    // message shows a readable prefix of the Jacobiator, not all of it.
    let all = reports(
        &five_states("Fine", "1 + a + b + c + d + e)^2 + (0"),
        &["violates the Jacobi identity"],
    );
    assert!(all.iter().all(|m| m.len() < 4000), "{all:?}");
}

#[test]
fn classical_constraints_beyond_the_budget_are_an_error_at_the_keyword() {
    let too_large = [
        "classical constraints could not be computed exactly",
        "products of terms",
    ];
    // ∇H has 6 435 terms per component and the metric basis 12 870
    // monomials: 5·10⁹ products before any elimination.
    let zero_rows = ["[0, 0, 0, 0, 0, 0, 0, 0]"; 8].join(", ");
    reports(
        &format!(
            "struct Oom; state (a, b, c, d, e, f, g, h); poisson = [{zero_rows}]; \
             hamiltonian = (1 + a + b + c + d + e + f + g + h)^8; entropy degree 2; \
             metric degree 8; region ball(radius = 1); classical;"
        ),
        &too_large,
    );
    // The entropy side: Π's entries of 5 456 terms against 6 544 features.
    reports(
        "struct Wide; state (x, y, z); \
         poisson = [[0, (1 + x + y + z)^30, 0], [-(1 + x + y + z)^30, 0, 0], [0, 0, 0]]; \
         hamiltonian = z^2; entropy degree 32; metric degree 0; classical;",
        &too_large,
    );
}
