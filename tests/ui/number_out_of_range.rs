use metriplectic_runtime::metriplectic;

// Exact 128-bit rationals hold neither: one has too many decimal places, the other is too
// large (not both "overflowed").
metriplectic! {
    pub struct Oscillator;
    state (q, p);
    const tiny = 1e-400;
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 1e400 * q^2;
    entropy degree 2;
    metric degree 0;
}

fn main() {}
