//! A hand-written [`MetriplecticSystem`] for the unit tests, so they do not
//! depend on the macro: a 2-D canonical oscillator with a quadratic entropy
//! (degree 2) and a degree-2 metric basis. Only the system-specific items are
//! written out; every other method is the trait's provided one.

use crate::system::{JacobianTerm, MetriplecticSystem, SosTables};

/// x = (q, p), Π = [[0, 1], [−1, 0]], H = (q² + p²)/2, K = I,
/// S = 0.3 q − 0.2 p − 0.8 q² + 0.25 q p − 0.6 p².
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Quadratic2d;

const E1: &[u32] = &[1, 0];
const E2: &[u32] = &[0, 1];
const E11: &[u32] = &[2, 0];
const E12: &[u32] = &[1, 1];
const E22: &[u32] = &[0, 2];
const E0: &[u32] = &[0, 0];

impl MetriplecticSystem for Quadratic2d {
    const NAME: &'static str = "Quadratic2d";
    const DIM: usize = 2;
    const STATE_NAMES: &'static [&'static str] = &["q", "p"];
    const ENTROPY_DEGREE: u32 = 2;
    const METRIC_DEGREE: u32 = 2;
    const ENTROPY_EXPONENTS: &'static [&'static [u32]] = &[E1, E2, E11, E12, E22];
    const METRIC_EXPONENTS: &'static [&'static [u32]] = &[E0, E1, E2, E11, E12, E22];
    // ∂q/∂q = 1, ∂p/∂p = 1, ∂q²/∂q = 2q, ∂qp/∂q = p, ∂qp/∂p = q, ∂p²/∂p = 2p.
    const ENTROPY_JACOBIAN: &'static [JacobianTerm] = &[
        (0, 0, 1, 0),
        (1, 1, 1, 0),
        (2, 0, 2, 1),
        (3, 0, 1, 2),
        (3, 1, 1, 1),
        (4, 1, 2, 2),
    ];
    const SOS_FULL: SosTables = SosTables {
        exponents: &[E0, E1, E2],
        matching: &[
            &[(0, 0)],
            &[(0, 1), (1, 0)],
            &[(0, 2), (2, 0)],
            &[(1, 1)],
            &[(1, 2), (2, 1)],
            &[(2, 2)],
        ],
    };
    const SOS_REDUCED: SosTables = SosTables {
        exponents: &[E0],
        matching: &[&[(0, 0)], &[], &[], &[], &[], &[]],
    };
    const REFERENCE_ENTROPY: Option<&'static [f64]> = Some(&[0.3, -0.2, -0.8, 0.25, -0.6]);
    const REFERENCE_METRIC: Option<&'static [f64]> = Some(&[
        1.0, 0.0, 0.0, 0.0, 0.0, 0.0, // (0, 0)
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, // (0, 1)
        1.0, 0.0, 0.0, 0.0, 0.0, 0.0, // (1, 1)
    ]);

    fn hamiltonian(x: &[f64]) -> f64 {
        0.5 * (x[0] * x[0] + x[1] * x[1])
    }
    fn hamiltonian_gradient(x: &[f64], grad: &mut [f64]) {
        grad.copy_from_slice(x);
    }
    fn poisson(_x: &[f64], poisson: &mut [f64]) {
        poisson.copy_from_slice(&[0.0, 1.0, -1.0, 0.0]);
    }
    fn monomials(x: &[f64], out: &mut [f64]) {
        let (q, p) = (x[0], x[1]);
        let all = [1.0, q, p, q * q, q * p, p * p];
        let len = out.len();
        out.copy_from_slice(&all[..len]);
    }
}

/// `count` states uniform in [−1.5, 1.5]² with ẋ from the reference model.
pub(crate) fn reference_data(count: usize, seed: u64) -> crate::data::Dataset {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let model = crate::model::Model::<Quadratic2d>::reference().unwrap();
    let mut states = Vec::with_capacity(2 * count);
    let mut derivatives = vec![0.0; 2 * count];
    for _ in 0..2 * count {
        states.push(rng.random_range(-1.5..1.5));
    }
    for i in 0..count {
        model
            .vector_field(
                &states[2 * i..2 * i + 2],
                &mut derivatives[2 * i..2 * i + 2],
            )
            .unwrap();
    }
    crate::data::Dataset::from_flat(2, states, derivatives).unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The provided methods against the direct formulas of this system.
    #[test]
    fn provided_methods_match_direct_formulas() {
        let x = [0.7, -1.3];
        let (q, p) = (x[0], x[1]);
        let psi = [0.3, -0.2, -0.8, 0.25, -0.6];
        let mut grad = [0.0; 2];
        Quadratic2d::entropy_gradient(&x, &psi, &mut grad);
        let expected = [0.3 - 1.6 * q + 0.25 * p, -0.2 + 0.25 * q - 1.2 * p];
        assert!((grad[0] - expected[0]).abs() < 1e-14 && (grad[1] - expected[1]).abs() < 1e-14);
        let value = Quadratic2d::entropy_value(&x, &psi);
        let direct = 0.3 * q - 0.2 * p - 0.8 * q * q + 0.25 * q * p - 0.6 * p * p;
        assert!((value - direct).abs() < 1e-14);
        let mut jacobian = [0.0; 10];
        Quadratic2d::entropy_jacobian(&x, &mut jacobian);
        assert_eq!(
            jacobian,
            [1.0, 0.0, 0.0, 1.0, 2.0 * q, 0.0, p, q, 0.0, 2.0 * p]
        );
        // K = [[1 + q, 2p], [2p, 3 q p]] from θ.
        let mut theta = [0.0; 18];
        theta[0] = 1.0;
        theta[1] = 1.0;
        theta[6 + 2] = 2.0;
        theta[12 + 4] = 3.0;
        let mut k = [0.0; 4];
        Quadratic2d::metric_value(&x, &theta, &mut k);
        assert_eq!(k, [1.0 + q, 2.0 * p, 2.0 * p, 3.0 * q * p]);
        // Metric rows: K(x; θ) g for g = (1, 2) equals block · θ.
        let g = [1.0, 2.0];
        let (mut block, mut drift) = ([0.0; 36], [0.0; 2]);
        Quadratic2d::metric_block(&x, &g, &mut block, &mut drift);
        for row in 0..2 {
            let from_block: f64 = (0..18).map(|c| block[row * 18 + c] * theta[c]).sum();
            let direct = k[row * 2] * g[0] + k[row * 2 + 1] * g[1];
            assert!((from_block - direct).abs() < 1e-14);
        }
        assert_eq!(drift, [g[1], -g[0]]);
        // Entropy rows: M J ψ + M ∇H is the vector field with metric K.
        let (mut block, mut drift) = ([0.0; 10], [0.0; 2]);
        Quadratic2d::entropy_block(&x, &k, &mut block, &mut drift);
        let m = [k[0], 1.0 + k[1], -1.0 + k[2], k[3]];
        for row in 0..2 {
            let field: f64 = (0..2).map(|l| m[row * 2 + l] * (x[l] + grad[l])).sum();
            let rows: f64 = drift[row] + (0..5).map(|c| block[row * 5 + c] * psi[c]).sum::<f64>();
            assert!((field - rows).abs() < 1e-13);
        }
        assert_eq!(Quadratic2d::derivative_monomial_count(), 3);
        assert_eq!(Quadratic2d::monomial_count(), 6);
    }
}
