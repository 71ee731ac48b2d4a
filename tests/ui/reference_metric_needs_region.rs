use metriplectic_runtime::metriplectic;

// Bounded on all of Rⁿ (0 ⪯ K(x) ⪯ ηI) a metric is constant: a metric that
// depends on the state needs the region where the data live.
metriplectic! {
    pub struct Oscillator;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 2;
    metric degree 2;
    reference {
        entropy = -0.5 * (q^2 + p^2);
        metric = [[1 + p^2, -q * p], [-q * p, 1 + q^2]];
    }
}

fn main() {}
