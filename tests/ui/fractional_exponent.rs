use metriplectic_runtime::metriplectic;

metriplectic! {
    pub struct Oscillator;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + (q^2 + 1)^0.5;
    entropy degree 4;
    metric degree 2;
}

fn main() {}
