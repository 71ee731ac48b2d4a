//! State variables named as the user likes, `E` and `P`, need the
//! generated code to allow `non_snake_case`: it must, as only the lints a
//! system needs are allowed (`struct_attributes.rs`).
#![deny(warnings)]

use metriplectic_runtime::{metriplectic, MetriplecticSystem};

metriplectic! {
    pub struct Upper;
    state (E, P);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * E^2 + 0.5 * P^2;
    entropy degree 3;
    metric degree 0;
}

fn main() {
    assert_eq!(Upper::hamiltonian(&[2.0, 0.0]), 2.0);
}
