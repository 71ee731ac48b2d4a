//! Generated code means the same whatever the caller's scope holds: state
//! variables named like constants, prelude items, glob imports or the
//! macro's own locals are ordinary variables, and raw identifiers work.
//!
//! Each system's reference vector field f(x) = (Π + K)(∇H + ∇S) is checked
//! against a hand-computed formula. Before the generated bindings moved into
//! a `#[no_implicit_prelude]` module with mixed-site locals, the first of
//! these panicked at run time (`let &[E, p] = x` matched against the
//! constant `E` of `std::f64::consts`), and the others did not compile.

use metriplectic_runtime::prelude::*;

/// f(x) of the reference model of `S`.
fn field<S: MetriplecticSystem>(x: &[f64]) -> Vec<f64> {
    let model = Model::<S>::reference().expect("the system declares a reference");
    let mut f = vec![0.0; S::DIM];
    model
        .vector_field(x, &mut f)
        .expect("x has the system's dimension");
    f
}

fn assert_close(what: &str, a: &[f64], b: &[f64]) {
    assert_eq!(a.len(), b.len(), "{what}");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= 1e-12 * y.abs().max(1.0),
            "{what}[{i}]: {x} vs {y}"
        );
    }
}

mod glob_constants {
    use metriplectic_runtime::prelude::*;
    // `E` (and `PI`, `LN_2`, …) are constants here.
    #[allow(unused_imports)]
    use std::f64::consts::*;

    metriplectic! {
        /// A state variable named like the constant `E` in scope.
        pub struct WithE;
        state (E, p);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = 0.5 * (E^2 + p^2);
        entropy degree 3;
        metric degree 0;
        reference {
            entropy = -E^2 + E * p;
            metric = [[1, 0], [0, 2]];
        }
    }
}

#[test]
fn state_named_like_a_glob_imported_constant() {
    use glob_constants::WithE;
    let (e, p) = (0.3, -0.7);
    // ∇H + ∇S = (E − 2E + p, p + E); Π + K = [[1, 1], [−1, 2]].
    let g = [-e + p, p + e];
    let expected = [g[0] + g[1], -g[0] + 2.0 * g[1]];
    assert_close("f", &field::<WithE>(&[e, p]), &expected);
    assert_eq!(WithE::STATE_NAMES, &["E", "p"]);
}

mod local_constant {
    use metriplectic_runtime::prelude::*;

    #[allow(non_upper_case_globals, dead_code)]
    const q: f64 = 3.0;

    metriplectic! {
        /// A state variable named like a constant of the enclosing module.
        pub struct WithQ;
        state (q, p);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = 0.5 * p^2 + 0.25 * q^4;
        entropy degree 2;
        metric degree 0;
        reference {
            entropy = -q^2;
            metric = [[1, 0], [0, 1]];
        }
    }
}

#[test]
fn state_named_like_a_constant_in_scope() {
    use local_constant::WithQ;
    let (q, p) = (0.5, -1.0);
    // ∇H + ∇S = (q³ − 2q, p); Π + I = [[1, 1], [−1, 1]].
    let g = [q * q * q - 2.0 * q, p];
    let expected = [g[0] + g[1], -g[0] + g[1]];
    assert_close("f", &field::<WithQ>(&[q, p]), &expected);
    assert_eq!(WithQ::hamiltonian(&[q, p]), 0.5 + 0.25 * q.powi(4));
}

metriplectic! {
    /// State variables named like the prelude's `None` and `Some`.
    pub struct WithNone;
    state (None, Some);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = None^2 + 3 * Some;
    entropy degree 2;
    metric degree 0;
    reference {
        entropy = -None * Some;
        metric = [[2, 0], [0, 1]];
    }
}

#[test]
fn state_named_like_prelude_items() {
    let (a, b) = (1.25, 0.5);
    // ∇H + ∇S = (2a − b, 3 − a); Π + K = [[2, 1], [−1, 1]].
    let g = [2.0 * a - b, 3.0 - a];
    let expected = [2.0 * g[0] + g[1], -g[0] + g[1]];
    assert_close("f", &field::<WithNone>(&[a, b]), &expected);
    assert_eq!(WithNone::STATE_NAMES, &["None", "Some"]);
}

metriplectic! {
    /// A keyword as a state variable, written as a raw identifier.
    pub struct RawType;
    state (r#type, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * r#type^2 + 0.5 * p^2 + r#type * p;
    entropy degree 2;
    metric degree 0;
    reference {
        entropy = -r#type^2;
        metric = [[1, 0], [0, 1]];
    }
}

#[test]
fn raw_identifier_state() {
    let (t, p) = (0.4, 0.9);
    // ∇H + ∇S = (t + p − 2t, p + t); Π + I = [[1, 1], [−1, 1]].
    let g = [p - t, p + t];
    let expected = [g[0] + g[1], -g[0] + g[1]];
    assert_close("f", &field::<RawType>(&[t, p]), &expected);
    assert_eq!(RawType::STATE_NAMES, &["type", "p"]);
}

metriplectic! {
    /// State variables named like the generated code's locals and functions
    /// (`x`, `psi`, `mu`, `grad`, `out`, `sink`, `monomials`), the generated
    /// module, and a primitive type.
    #[derive(Clone)]
    pub struct Clash;
    state (x, psi, mu, grad, out, sink, monomials, __metriplectic_Clash, f64);
    poisson = [
        [0, 0, 0, 0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0, 0, 0, 0],
        [0, 0, 0, 0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0, 0, 0, 0],
    ];
    hamiltonian = 0.5 * (x^2 + psi^2 + mu^2 + grad^2 + out^2 + sink^2 + monomials^2
        + __metriplectic_Clash^2 + f64^2);
    entropy degree 3;
    metric degree 0;
    reference {
        entropy = -(x * psi + mu * grad + out * sink + monomials * __metriplectic_Clash * f64);
        metric = [
            [1, 0, 0, 0, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0, 0, 0, 0],
            [0, 0, 0, 1, 0, 0, 0, 0, 0], [0, 0, 0, 0, 1, 0, 0, 0, 0], [0, 0, 0, 0, 0, 1, 0, 0, 0],
            [0, 0, 0, 0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 0, 0, 0, 1],
        ];
    }
}

#[test]
fn states_named_like_generated_names() {
    let v = [0.1, -0.2, 0.3, 0.4, -0.5, 0.6, 0.7, -0.8, 0.9];
    // Π = 0, K = I: f = ∇H + ∇S = x − (pairs swapped) − (triple products).
    let expected = [
        v[0] - v[1],
        v[1] - v[0],
        v[2] - v[3],
        v[3] - v[2],
        v[4] - v[5],
        v[5] - v[4],
        v[6] - v[7] * v[8],
        v[7] - v[6] * v[8],
        v[8] - v[6] * v[7],
    ];
    assert_close("f", &field::<Clash>(&v), &expected);
    // The user's `#[derive(Clone)]` and the generated derives coexist.
    fn derives<T: Clone + Copy + Default + PartialEq + Eq + std::hash::Hash + std::fmt::Debug>() {}
    derives::<Clash>();
}

#[test]
fn declared_inside_a_function_body() {
    #[allow(unused_imports)]
    use std::f64::consts::*;

    metriplectic! {
        struct Local;
        state (E, PI);
        poisson = [[0, 1], [-1, 0]];
        hamiltonian = 0.5 * (E^2 + PI^2);
        entropy degree 2;
        metric degree 0;
        reference {
            entropy = -0.5 * E^2;
            metric = [[1, 0], [0, 1]];
        }
    }

    let (e, pi) = (2.0, -1.0);
    // ∇H + ∇S = (E − E, PI) = (0, PI); Π + I = [[1, 1], [−1, 1]].
    let expected = [pi, pi];
    assert_close("f", &field::<Local>(&[e, pi]), &expected);
}
