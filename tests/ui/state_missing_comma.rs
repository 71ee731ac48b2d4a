use metriplectic_runtime::metriplectic;

metriplectic! {
    pub struct Oscillator;
    state (q p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 4;
    metric degree 0;
}

fn main() {}
