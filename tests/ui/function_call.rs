use metriplectic_runtime::metriplectic;

metriplectic! {
    pub struct Pendulum;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 - cos(q);
    entropy degree 4;
    metric degree 2;
}

fn main() {}
