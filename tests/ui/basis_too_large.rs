use metriplectic_runtime::metriplectic;

metriplectic! {
    pub struct Chain;
    state (a, b, c, d, e, f);
    poisson = [[0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1],
               [-1, 0, 0, 0, 0, 0], [0, -1, 0, 0, 0, 0], [0, 0, -1, 0, 0, 0]];
    hamiltonian = a^2 + b^2 + c^2 + d^2 + e^2 + f^2;
    entropy degree 14;
    metric degree 2;
}

fn main() {}
