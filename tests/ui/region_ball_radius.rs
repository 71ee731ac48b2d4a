use metriplectic_runtime::metriplectic;

metriplectic! {
    pub struct Oscillator;
    state (q, p);
    const r = 1;
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 2;
    metric degree 2;
    region ball(center = [0, 0], radius = r - 2);
}

fn main() {}
