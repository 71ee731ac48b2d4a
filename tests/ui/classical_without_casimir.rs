use metriplectic_runtime::metriplectic;

// A canonical Π is non-degenerate: only constants are Casimirs, so the
// classical form would leave no entropy.
metriplectic! {
    pub struct Oscillator;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 4;
    metric degree 2;
    region ball(radius = 2);
    classical;
}

fn main() {}
