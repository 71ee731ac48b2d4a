use metriplectic_runtime::metriplectic;

metriplectic! {
    pub struct Rotor;
    state (x, y, z);
    poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
    hamiltonian = 0.5 * (x^2 + 2 * y^2 + 3 * z^2);
    entropy degree 2;
    metric degree 2;
    region box(x in [-2, 2], z in [-1, 1]);
}

fn main() {}
