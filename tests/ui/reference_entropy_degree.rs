use metriplectic_runtime::metriplectic;

metriplectic! {
    pub struct Oscillator;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 6;
    metric degree 2;
    reference {
        entropy = -0.5 * (p^2 + 4*q^4 - 4*q^2)^2;
        metric = [[1, 0], [0, 1]];
    }
}

fn main() {}
