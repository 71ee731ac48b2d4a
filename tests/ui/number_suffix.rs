use metriplectic_runtime::metriplectic;

// `2q` is the number 2 with the suffix `q`, not a product: removing the
// suffix would silently drop the factor. A type suffix is only a type.
metriplectic! {
    pub struct Oscillator;
    state (q, p);
    const k = 1.5f64;
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 2q;
    entropy degree 2;
    metric degree 0;
}

fn main() {}
