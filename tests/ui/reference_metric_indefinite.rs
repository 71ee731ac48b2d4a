use metriplectic_runtime::metriplectic;

// K = [[1, 2], [2, 1]] is symmetric but indefinite: with it the free energy
// would decrease, e.g. dE/dt = -2 where ∇E = (1, -1).
metriplectic! {
    pub struct Oscillator;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 2;
    metric degree 0;
    reference {
        entropy = -0.5 * (q^2 + p^2);
        metric = [[1, 2], [2, 1]];
    }
}

fn main() {}
