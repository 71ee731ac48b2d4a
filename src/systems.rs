//! The paper's two systems, declared once for the examples, the tests and
//! the benchmarks, noise-free samples of their reference models, and a
//! third system beyond the paper ([`Duffing`]) for the `from_csv` example.
//!
//! Both come from the authors' MATLAB code. The 2-D free energy printed in
//! the paper, −½(p² + 4p⁴ − 4q⁴)², is a typo: the code and the paper's
//! figure use E = −½(p² + 4q⁴ − 4q²)², whose zero set is the figure eight
//! (q, p) = (cos t, sin 2t). The rigid body's inertia J = diag(0.1, 0.2, 0.15)
//! appears only in the code. In both, S = E − H and K = I.

use metriplectic_runtime::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

metriplectic! {
    /// The paper's 2-D example: a canonical oscillator whose free energy
    /// E = −½(p² + 4q⁴ − 4q²)² vanishes on a figure eight.
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
    /// [`Linear2d`] with its entropy basis declared at degree 10, above the
    /// truth's 8: the input of degree selection, which must find 8.
    pub struct Linear2dDegree10;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 10;
    metric degree 0;
    reference {
        entropy = -0.5 * (p^2 + 4*q^4 - 4*q^2)^2 - (0.5*p^2 + 0.5*q^2);
        metric = [[1, 0], [0, 1]];
    }
}

metriplectic! {
    /// The paper's SO(3) example: a free rigid body on so(3)* (Lie–Poisson
    /// Π(p) = p̂, H = ½ pᵀ J⁻¹ p) whose free energy E = −½(|p|² − 1)²
    /// vanishes on the unit sphere. Since p̂∇E = 0 the true flow is radial.
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

metriplectic! {
    /// A relaxing rigid body in the classical (GENERIC) form (not from the
    /// paper): the free body on so(3)* with inertias 1, 2, 4
    /// (H = ½ pᵀ J⁻¹ p, conserved) whose entropy S = −½|p|² − ⅛|p|⁴ is a
    /// Casimir, produced by the metric K(p) = [v]ₓᵀ A [v]ₓ, v = ∇H, A ≻ 0:
    /// degenerate along ∇H and a sum of squares, so K∇H ≡ 0 and
    /// dS/dt = ∇Sᵀ K ∇S ≥ 0. The body keeps its energy and loses angular
    /// momentum |p| until it spins about its axis of largest inertia.
    pub struct ClassicalRigidBody;
    state (px, py, pz);
    poisson = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]];
    hamiltonian = 0.5 * px^2 + 0.25 * py^2 + 0.125 * pz^2;
    entropy degree 4;
    metric degree 2;
    region ball(radius = 2);
    classical;
    reference {
        entropy = -0.5 * (px^2 + py^2 + pz^2) - 0.125 * (px^2 + py^2 + pz^2)^2;
        metric = [
            [0.2*py^2 - 0.025*py*pz + 0.03125*pz^2, -0.4*px*py + 0.025*px*pz - 0.0125*pz^2, 0.05*px*py - 0.125*px*pz + 0.025*py*pz],
            [-0.4*px*py + 0.025*px*pz - 0.0125*pz^2, 0.8*px^2 + 0.0625*pz^2, -0.1*px^2 + 0.05*px*pz - 0.125*py*pz],
            [0.05*px*py - 0.125*px*pz + 0.025*py*pz, -0.1*px^2 + 0.05*px*pz - 0.125*py*pz, 0.5*px^2 - 0.2*px*py + 0.25*py^2]
        ];
    }
}

metriplectic! {
    /// A damped Duffing oscillator in a double well (not from the paper):
    /// ẍ = x − x³ − γẋ with γ = 0.5, as ẋ = v, v̇ = x − x³ − γv.
    ///
    /// H = ½v² + ¼x⁴ − ½x² is the oscillator's mechanical energy and the free
    /// energy is E = −H, largest (¼) at the wells' bottoms (±1, 0), where
    /// every trajectory ends. With Π = [[0, −1], [1, 0]], Π∇E is the
    /// undamped motion and K∇E with K = diag(0, γ) ⪰ 0 the friction on v,
    /// so dE/dt = γv² ≥ 0 and the entropy is S = E − H = −2H. The pair
    /// (S, K) is the only one with a constant K ⪰ 0 that gives this flow,
    /// so identification recovers it, not only the vector field.
    pub struct Duffing;
    state (x, v);
    const gamma = 0.5;
    poisson = [[0, -1], [1, 0]];
    hamiltonian = 0.5 * v^2 + 0.25 * x^4 - 0.5 * x^2;
    entropy degree 4;
    metric degree 0;
    reference {
        entropy = -(v^2 + 0.5 * x^4 - x^2);
        metric = [[0, 0], [0, gamma]];
    }
}

metriplectic! {
    /// The damped double well of [`Duffing`] with drag that grows with speed
    /// (not from the paper): ẋ = v, v̇ = x − x³ − (0.1 + 0.2v²)v.
    ///
    /// As for [`Duffing`], E = −H and S = −2H, now with the state-dependent
    /// metric K(x) = diag(0, 0.1 + 0.2v²): friction on the velocity whose
    /// coefficient rises with the speed, as drag in a fluid does. K is a sum
    /// of squares for every state, and on the ball of radius 3 its largest
    /// eigenvalue is 1.9, so the certificate's upper bound needs η ≥ 1.9.
    ///
    /// Why no friction on x as well: with K = diag(k₀, k(v)), k₀ > 0, the
    /// flow is not identifiable. Because E is a sum of a function of x and
    /// one of v, rescaling its two parts by a and b with 1/a + 1/b = 2 and
    /// taking K′ = (Π + K)·diag(1/a, 1/b) − Π gives the same vector field
    /// with another symmetric K′, PSD for a near 1 (measured: an exact fit,
    /// error 1.8e-10, with K′₀₁ = 0.055). With k₀ = 0, K′ ⪰ 0 forces
    /// K′₀₁ = 1 − 1/b = 0, so a = b = 1.
    pub struct DragDuffing;
    state (x, v);
    poisson = [[0, -1], [1, 0]];
    hamiltonian = 0.5 * v^2 + 0.25 * x^4 - 0.5 * x^2;
    entropy degree 4;
    metric degree 2;
    region ball(radius = 3);
    reference {
        entropy = -(v^2 + 0.5 * x^4 - x^2);
        metric = [[0, 0], [0, 0.1 + 0.2 * v^2]];
    }
}

metriplectic! {
    /// A rigid body in a fluid (not from the paper): the free rigid body of
    /// [`RigidBody`] (Π(p) = p̂, the same inertia) with an isotropic drag
    /// that grows with the angular momentum, K(x) = (0.1 + 0.2|p|²) I, and
    /// the free energy E = −½(|p|² − 1)² − ¼(px⁴ + py⁴ + pz⁴).
    ///
    /// Unlike the paper's radial E, this one makes p̂∇E ≠ 0, which removes
    /// the scaling symmetry (K, E) ↦ (cK, E/c), and its gradient's
    /// components share no factor, so no degree-2 change of K leaves K∇E
    /// unchanged: (S, K) is identifiable. On the ball of radius 2.5 the
    /// largest eigenvalue of K is 1.35.
    pub struct DragRigidBody;
    state (px, py, pz);
    const j1 = 0.1;
    const j2 = 0.2;
    const j3 = 0.15;
    poisson = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]];
    hamiltonian = 0.5 * (px^2 / j1 + py^2 / j2 + pz^2 / j3);
    entropy degree 4;
    metric degree 2;
    region ball(radius = 2.5);
    reference {
        entropy = -0.5 * (px^2 + py^2 + pz^2 - 1)^2 - 0.25 * (px^4 + py^4 + pz^4)
            - 0.5 * (px^2 / j1 + py^2 / j2 + pz^2 / j3);
        metric = [[0.1 + 0.2 * (px^2 + py^2 + pz^2), 0, 0],
                  [0, 0.1 + 0.2 * (px^2 + py^2 + pz^2), 0],
                  [0, 0, 0.1 + 0.2 * (px^2 + py^2 + pz^2)]];
    }
}

/// `count` states drawn by `sample_state`, with ẋ from the reference model
/// of `S` (exact, no noise).
///
/// # Panics
///
/// If `S` declares no reference model or `sample_state` returns states of
/// the wrong dimension (these are fixtures for tests and benchmarks).
pub fn reference_samples<S: MetriplecticSystem>(
    count: usize,
    seed: u64,
    mut sample_state: impl FnMut(&mut ChaCha8Rng) -> Vec<f64>,
) -> Dataset {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let model = Model::<S>::reference().expect("the system declares a reference");
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

/// 2-D states uniform in [−1.5, 1.5]² with ẋ from [`Linear2d`]'s reference.
pub fn linear2d_data(count: usize, seed: u64) -> Dataset {
    reference_samples::<Linear2d>(count, seed, |rng| {
        vec![rng.random_range(-1.5..1.5), rng.random_range(-1.5..1.5)]
    })
}

/// States uniform in the ball of radius 1.5 with ẋ from [`RigidBody`]'s reference.
pub fn rigid_body_data(count: usize, seed: u64) -> Dataset {
    reference_samples::<RigidBody>(count, seed, |rng| loop {
        let p: Vec<f64> = (0..3).map(|_| rng.random_range(-1.5..1.5)).collect();
        if p.iter().map(|v| v * v).sum::<f64>() <= 2.25 {
            return p;
        }
    })
}

/// States uniform in the ball of radius 1.5 with ẋ from
/// [`ClassicalRigidBody`]'s reference.
pub fn classical_rigid_body_data(count: usize, seed: u64) -> Dataset {
    reference_samples::<ClassicalRigidBody>(count, seed, |rng| loop {
        let p: Vec<f64> = (0..3).map(|_| rng.random_range(-1.5..1.5)).collect();
        if p.iter().map(|v| v * v).sum::<f64>() <= 2.25 {
            return p;
        }
    })
}

/// The paper's initial entropy: the true coefficients plus N(0, σ²) noise on
/// each, from a generator seeded with `seed`.
///
/// # Panics
///
/// If `S` declares no reference or σ is not finite and non-negative.
pub fn perturbed_reference_entropy<S: MetriplecticSystem>(sigma: f64, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, sigma).expect("σ is finite and non-negative");
    S::REFERENCE_ENTROPY
        .expect("the system declares a reference")
        .iter()
        .map(|c| c + noise.sample(&mut rng))
        .collect()
}
