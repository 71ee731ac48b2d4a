use metriplectic_runtime::metriplectic;

// Without a region the metric is constant, and a constant K with K∇H ≡ 0
// vanishes when ∇H spans every direction.
metriplectic! {
    pub struct RigidBody;
    state (x, y, z);
    poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
    hamiltonian = 0.5 * (x^2 + 2 * y^2 + 3 * z^2);
    entropy degree 2;
    metric degree 2;
    classical;
}

fn main() {}
