//! A 6-state system with entropy degree 8 (3002 entropy monomials) and metric
//! degree 4 (210 metric monomials per entry): the generated code must stay
//! correct at this size. It also serves as the compile-time measurement of the
//! macro (`touch tests/large_system.rs && time cargo build --tests`),
//! including the tables of a region certificate over 6 states.

use metriplectic_runtime::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

metriplectic! {
    /// Three coupled oscillators: a chain with a constant canonical Poisson tensor.
    pub struct Chain;
    state (q1, q2, q3, p1, p2, p3);
    const c = 0.25;
    poisson = [
        [0, 0, 0, 1, 0, 0],
        [0, 0, 0, 0, 1, 0],
        [0, 0, 0, 0, 0, 1],
        [-1, 0, 0, 0, 0, 0],
        [0, -1, 0, 0, 0, 0],
        [0, 0, -1, 0, 0, 0],
    ];
    hamiltonian = 0.5 * (p1^2 + p2^2 + p3^2) + 0.5 * (q1^2 + q2^2 + q3^2)
        + c * ((q2 - q1)^2 + (q3 - q2)^2);
    entropy degree 8;
    metric degree 4;
    // The reference metric depends on p3: its certificate needs a region.
    region ball(radius = 2);
    reference {
        entropy = -(p1^2 + p2^2 + p3^2 + q1^2 + q2^2 + q3^2 - 1)^4;
        metric = [
            [1, 0, 0, 0, 0, 0],
            [0, 1, 0, 0, 0, 0],
            [0, 0, 1, 0, 0, 0],
            [0, 0, 0, 1, 0, 0],
            [0, 0, 0, 0, 1, 0],
            [0, 0, 0, 0, 0, 1 + p3^2],
        ];
    }
}

fn random_state(rng: &mut ChaCha8Rng) -> Vec<f64> {
    (0..6).map(|_| rng.random_range(-1.2..1.2)).collect()
}

#[test]
fn basis_sizes() {
    assert_eq!(Chain::ENTROPY_EXPONENTS.len(), 3002);
    assert_eq!(Chain::METRIC_EXPONENTS.len(), 210);
    assert_eq!(Chain::metric_coefficient_count(), 21 * 210);
    assert_eq!(Chain::SOS_FULL.exponents.len(), 28);
    assert_eq!(Chain::monomial_count(), 3003);
}

#[test]
fn hamiltonian_gradient_matches_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let h = 1e-6;
    for _ in 0..20 {
        let x = random_state(&mut rng);
        let mut grad = [0.0; 6];
        Chain::hamiltonian_gradient(&x, &mut grad);
        for j in 0..6 {
            let (mut plus, mut minus) = (x.clone(), x.clone());
            plus[j] += h;
            minus[j] -= h;
            let fd = (Chain::hamiltonian(&plus) - Chain::hamiltonian(&minus)) / (2.0 * h);
            assert!((grad[j] - fd).abs() < 1e-7, "∂H/∂x{j}: {} vs {fd}", grad[j]);
        }
    }
}

#[test]
fn entropy_gradient_matches_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    let psi: Vec<f64> = (0..3002).map(|_| rng.random_range(-1.0..1.0)).collect();
    let h = 1e-6;
    for _ in 0..10 {
        let x = random_state(&mut rng);
        let mut grad = [0.0; 6];
        Chain::entropy_gradient(&x, &psi, &mut grad);
        for j in 0..6 {
            let (mut plus, mut minus) = (x.clone(), x.clone());
            plus[j] += h;
            minus[j] -= h;
            let fd = (Chain::entropy_value(&plus, &psi) - Chain::entropy_value(&minus, &psi))
                / (2.0 * h);
            let scale = grad[j].abs().max(1.0);
            assert!(
                (grad[j] - fd).abs() < 1e-6 * scale,
                "∂S/∂x{j}: {} vs {fd}",
                grad[j]
            );
        }
        // The same gradient through the materialised Jacobian: ∇S = Jᵀψ.
        let mut jacobian = vec![0.0; 3002 * 6];
        Chain::entropy_jacobian(&x, &mut jacobian);
        for (j, g) in grad.iter().enumerate() {
            let via_jacobian: f64 = (0..3002).map(|k| jacobian[k * 6 + j] * psi[k]).sum();
            assert!((g - via_jacobian).abs() < 1e-9 * g.abs().max(1.0));
        }
    }
}

#[test]
fn reference_model_and_blocks() {
    let model = Model::<Chain>::reference().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    for _ in 0..10 {
        let x = random_state(&mut rng);
        let r: f64 = x.iter().map(|v| v * v).sum::<f64>() - 1.0;
        // −r⁴ without its constant term (−1), which the generated ψ drops.
        let expected = -r.powi(4) + 1.0;
        let s = model.entropy(&x).unwrap();
        assert!(
            (s - expected).abs() < 1e-10 * expected.abs().max(1.0),
            "{s} vs {expected}"
        );
        let mut metric = [0.0; 36];
        model.metric(&x, &mut metric).unwrap();
        assert_eq!(metric[35], 1.0 + x[5] * x[5]);
        assert_eq!(metric[0], 1.0);
        assert_eq!(metric[1], 0.0);

        // drift + block · ψ = (Π + K)(∇H + ∇S) = vector field.
        let mut xdot = [0.0; 6];
        model.vector_field(&x, &mut xdot).unwrap();
        let mut block = vec![0.0; 6 * 3002];
        let mut drift = [0.0; 6];
        Chain::entropy_block(&x, &metric, &mut block, &mut drift);
        let psi = model.entropy_coefficients();
        for row in 0..6 {
            let value = drift[row]
                + (0..3002)
                    .map(|k| block[row * 3002 + k] * psi[k])
                    .sum::<f64>();
            assert!((value - xdot[row]).abs() < 1e-9 * xdot[row].abs().max(1.0));
        }
    }
}
