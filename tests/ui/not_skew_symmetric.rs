use metriplectic_runtime::metriplectic;

metriplectic! {
    pub struct RigidBody;
    state (x, y, z);
    poisson = [[0, -z, y], [z, 0, -x], [y, x, 0]];
    hamiltonian = x^2 + y^2 + z^2;
    entropy degree 4;
    metric degree 2;
}

fn main() {}
