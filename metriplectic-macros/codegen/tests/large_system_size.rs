//! The size of the code generated for the 6-state system of the root
//! package's `tests/large_system.rs` (run with `--nocapture` to see it).

use quote::quote;

#[test]
fn large_system_expansion_size() {
    let tokens = quote! {
        pub struct Chain;
        state (q1, q2, q3, p1, p2, p3);
        poisson = [
            [0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1],
            [-1, 0, 0, 0, 0, 0], [0, -1, 0, 0, 0, 0], [0, 0, -1, 0, 0, 0],
        ];
        hamiltonian = 0.5 * (p1^2 + p2^2 + p3^2) + 0.5 * (q1^2 + q2^2 + q3^2);
        entropy degree 8;
        metric degree 4;
    };
    let expanded = metriplectic_codegen::try_expand(tokens).expect("valid system");
    let text = expanded.to_string();
    let file: syn::File = syn::parse2(expanded).expect("parses");
    let pretty = prettyplease::unparse(&file);
    println!(
        "large system: {} bytes of tokens, {} lines / {} bytes after prettyplease",
        text.len(),
        pretty.lines().count(),
        pretty.len()
    );
}
