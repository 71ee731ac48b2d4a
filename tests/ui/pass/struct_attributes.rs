//! The struct's attributes hold for everything the macro generates: a
//! configured-out system leaves nothing behind, a trait derived under
//! `cfg_attr` is derived once, a deprecated system's own impl does not
//! warn, and a crate that forbids `non_snake_case` can use the macro (with
//! snake-case state variables). `deny(warnings)`: any warning of the
//! generated code fails the test.
#![forbid(non_snake_case)]
#![deny(warnings)]

use metriplectic_runtime::{metriplectic, MetriplecticSystem};

metriplectic! {
    /// Configured out: its module and impl must go too (they named a
    /// missing type, E0425).
    #[cfg(any())]
    pub struct Gone;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * q^2 + p^2;
    entropy degree 2;
    metric degree 0;
}

metriplectic! {
    /// Configured out through `cfg_attr`.
    #[cfg_attr(all(), cfg(any()))]
    pub struct AlsoGone;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * q^2 + p^2;
    entropy degree 2;
    metric degree 0;
}

metriplectic! {
    /// `Debug` is derived by the user where `all()` holds, `Clone` where
    /// `any()` does (nowhere): the macro derives each where the user does
    /// not (E0119, conflicting impls, before).
    #[cfg_attr(all(), derive(Debug))]
    #[cfg_attr(any(), derive(Clone))]
    pub struct Conditional;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 2^-1 * p^2 + q^2;
    entropy degree 2;
    metric degree 0;
}

metriplectic! {
    /// Its impl uses the type, and must not warn about it.
    #[deprecated(note = "old")]
    pub struct Old;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * q^2 + p^2;
    entropy degree 2;
    metric degree 0;
}

fn dimension<S>() -> usize
where
    S: MetriplecticSystem + Clone + Copy + Default + PartialEq + Eq + std::hash::Hash,
{
    S::DIM
}

#[allow(deprecated)]
fn old_dimension() -> usize {
    dimension::<Old>()
}

fn main() {
    assert_eq!(format!("{:?}", Conditional), "Conditional");
    assert_eq!(dimension::<Conditional>(), 2);
    // 2^-1 is exactly one half.
    assert_eq!(Conditional::hamiltonian(&[1.0, 2.0]), 3.0);
    assert_eq!(old_dimension(), 2);
}
