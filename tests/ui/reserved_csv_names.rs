use metriplectic_runtime::metriplectic;

// `t` is the time column of trajectory CSV files, and `dq` the column of the
// derivative of `q`.
metriplectic! {
    pub struct Clock;
    state (t, q, dq);
    poisson = [[0, 0, 0], [0, 0, 1], [0, -1, 0]];
    hamiltonian = 0.5 * (t^2 + q^2 + dq^2);
    entropy degree 2;
    metric degree 0;
}

fn main() {}
