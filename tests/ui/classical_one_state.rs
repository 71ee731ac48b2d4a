use metriplectic_runtime::metriplectic;

// In one variable K∇H = k(q)·H′(q) ≡ 0 forces k ≡ 0: no region or metric
// degree helps (c(|∇H|²I − ∇H∇Hᵀ) vanishes in 1-D), and none is suggested.
metriplectic! {
    pub struct Line;
    state (q);
    poisson = [[0]];
    hamiltonian = 0.5 * q^2;
    entropy degree 2;
    metric degree 2;
    region ball(radius = 1);
    classical;
}

fn main() {}
