use metriplectic_runtime::metriplectic;

// One error at the parameter after the missing comma; the radius still
// counts (no "the ball has no radius").
metriplectic! {
    pub struct Oscillator;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 2;
    metric degree 2;
    region ball(center = [0, 0] radius = 1);
}

fn main() {}
