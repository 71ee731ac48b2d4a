use metriplectic_runtime::metriplectic;

// `Model::reference()` would refuse coefficients beyond ±1e15 at run time.
metriplectic! {
    pub struct Oscillator;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 2;
    metric degree 0;
    reference {
        entropy = -1e16 * q^2 - p^2;
        metric = [[1e20, 0], [0, 1]];
    }
}

fn main() {}
