use metriplectic_runtime::metriplectic;

// Skew-symmetric, but Π_ij = ε_ijk v_k with v = (0, x, 1) and v·curl v = 1 ≠ 0.
metriplectic! {
    pub struct NotPoisson;
    state (x, y, z);
    poisson = [[0, 1, -x], [-1, 0, 0], [x, 0, 0]];
    hamiltonian = x^2 + y^2 + z^2;
    entropy degree 4;
    metric degree 2;
}

fn main() {}
