#![deny(deprecated)]

use metriplectic_runtime::metriplectic;

// Configured out and broken: only its error, no "cannot find type `Gone`"
// from the stand-in impl.
metriplectic! {
    #[cfg(any())]
    pub struct Gone;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + cos(q);
    entropy degree 2;
    metric degree 0;
}

// Deprecated and broken: only its error, no "use of deprecated struct
// `Old`" from the stand-in impl.
metriplectic! {
    #[deprecated(note = "old")]
    pub struct Old;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + sin(q);
    entropy degree 2;
    metric degree 0;
}

fn main() {}
