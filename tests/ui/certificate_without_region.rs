use metriplectic_runtime::metriplectic;

metriplectic! {
    pub struct Oscillator;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 2;
    metric degree 2;
    certificate on region;
}

fn main() {}
