//! The two systems of the paper's experiments (DESIGN.md §3), declared with
//! `metriplectic!`, and noise-free data generated from their reference models.

#![allow(dead_code)]

use metriplectic_runtime::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

metriplectic! {
    /// The linear 2-D example: canonical Π, figure-eight free energy.
    pub struct Linear2d;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 8;
    metric degree 2;
    reference {
        entropy = -0.5 * (p^2 + 4*q^4 - 4*q^2)^2 - (0.5*p^2 + 0.5*q^2);
        metric = [[1, 0], [0, 1]];
    }
}

metriplectic! {
    /// The SO(3) rigid body: Lie–Poisson Π(p) = p̂, H = ½ pᵀ J⁻¹ p, J = diag(0.1, 0.2, 0.15).
    pub struct RigidBody;
    state (px, py, pz);
    const j1 = 0.1;
    const j2 = 0.2;
    const j3 = 0.15;
    poisson = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]];
    hamiltonian = 0.5 * (px^2 / j1 + py^2 / j2 + pz^2 / j3);
    entropy degree 6;
    metric degree 2;
    reference {
        entropy = -0.5 * (px^2 + py^2 + pz^2 - 1)^2 - 0.5 * (px^2 / j1 + py^2 / j2 + pz^2 / j3);
        metric = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
    }
}

/// `count` states from `sample_state` with ẋ from the reference model of `S`.
fn reference_data<S: MetriplecticSystem>(
    count: usize,
    seed: u64,
    mut sample_state: impl FnMut(&mut ChaCha8Rng) -> Vec<f64>,
) -> Dataset {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let model = Model::<S>::reference().expect("paper systems declare a reference");
    let mut states = Vec::with_capacity(count * S::DIM);
    let mut derivatives = vec![0.0; count * S::DIM];
    for i in 0..count {
        let x = sample_state(&mut rng);
        model
            .vector_field(&x, &mut derivatives[i * S::DIM..(i + 1) * S::DIM])
            .expect("state has the system's dimension");
        states.extend(x);
    }
    Dataset::from_flat(S::DIM, states, derivatives).expect("finite reference data")
}

/// 2-D states uniform in [−1.5, 1.5]².
pub fn linear2d_data(count: usize, seed: u64) -> Dataset {
    reference_data::<Linear2d>(count, seed, |rng| {
        vec![rng.random_range(-1.5..1.5), rng.random_range(-1.5..1.5)]
    })
}

/// SO(3) states uniform in the ball of radius 1.5.
pub fn rigid_body_data(count: usize, seed: u64) -> Dataset {
    reference_data::<RigidBody>(count, seed, |rng| loop {
        let p: Vec<f64> = (0..3).map(|_| rng.random_range(-1.5..1.5)).collect();
        if p.iter().map(|v| v * v).sum::<f64>() <= 2.25 {
            return p;
        }
    })
}

/// The paper's initial entropy: the true coefficients plus N(0, σ²) noise.
pub fn perturbed_reference_entropy<S: MetriplecticSystem>(sigma: f64, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma).expect("σ is finite and positive");
    S::REFERENCE_ENTROPY
        .expect("paper systems declare a reference")
        .iter()
        .map(|c| c + noise.sample(&mut rng))
        .collect()
}

/// max |a − b|.
pub fn max_abs_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Σ|f(x) − ẋ| / Σ|ẋ| of `model` on `data`.
pub fn relative_error<S: MetriplecticSystem>(model: &Model<S>, data: &Dataset) -> f64 {
    let mut f = vec![0.0; S::DIM];
    let (mut num, mut den) = (0.0, 0.0);
    for (x, xdot) in data.iter() {
        model.vector_field(x, &mut f).expect("dimension checked");
        num += f.iter().zip(xdot).map(|(a, b)| (a - b).abs()).sum::<f64>();
        den += xdot.iter().map(|v| v.abs()).sum::<f64>();
    }
    num / den
}
