use metriplectic_runtime::prelude::*;

// Only the declaration's error is reported: the type still exists, with a
// stand-in trait impl, so its uses below add no errors.
metriplectic! {
    pub struct Broken;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + cos(q);
    entropy degree 4;
    metric degree 2;
}

fn dimension<S: MetriplecticSystem>() -> usize {
    S::DIM
}

fn main() {
    let _ = Model::<Broken>::reference();
    let _ = Broken::DIM;
    let _ = dimension::<Broken>();
    let _ = Broken::hamiltonian(&[0.0, 0.0]);
}
