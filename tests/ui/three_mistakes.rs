use metriplectic_runtime::metriplectic;

// Three independent mistakes, all reported in one compile.
metriplectic! {
    pub struct Oscillator;
    state (q, p);
    poisson = [[0, 1], [1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * x^2;
    entropy degree 4;
    metric degree 3;
}

fn main() {}
