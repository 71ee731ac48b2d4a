//! A hand-written [`MetriplecticSystem`] for the solvers' unit tests, so they
//! do not depend on the macro: a 2-D canonical oscillator with a quadratic
//! entropy (degree 2) and a degree-2 metric basis. Generic (slow) table-driven
//! evaluation; generated code is straight-line instead.

use crate::system::{metric_pair_index, MetriplecticSystem, SosTables};

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

fn monomial(x: &[f64], e: &[u32]) -> f64 {
    x.iter().zip(e).map(|(v, &d)| v.powi(d as i32)).product()
}

fn monomial_derivative(x: &[f64], e: &[u32], var: usize) -> f64 {
    if e[var] == 0 {
        return 0.0;
    }
    let mut lowered = e.to_vec();
    lowered[var] -= 1;
    f64::from(e[var]) * monomial(x, &lowered)
}

impl MetriplecticSystem for Quadratic2d {
    const NAME: &'static str = "Quadratic2d";
    const DIM: usize = 2;
    const STATE_NAMES: &'static [&'static str] = &["q", "p"];
    const ENTROPY_DEGREE: u32 = 2;
    const METRIC_DEGREE: u32 = 2;
    const ENTROPY_EXPONENTS: &'static [&'static [u32]] = &[E1, E2, E11, E12, E22];
    const METRIC_EXPONENTS: &'static [&'static [u32]] = &[E0, E1, E2, E11, E12, E22];
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
    fn entropy_features(x: &[f64], features: &mut [f64]) {
        for (f, e) in features.iter_mut().zip(Self::ENTROPY_EXPONENTS) {
            *f = monomial(x, e);
        }
    }
    fn entropy_jacobian(x: &[f64], jacobian: &mut [f64]) {
        for (k, e) in Self::ENTROPY_EXPONENTS.iter().enumerate() {
            for v in 0..Self::DIM {
                jacobian[k * Self::DIM + v] = monomial_derivative(x, e, v);
            }
        }
    }
    fn metric_features(x: &[f64], features: &mut [f64]) {
        for (f, e) in features.iter_mut().zip(Self::METRIC_EXPONENTS) {
            *f = monomial(x, e);
        }
    }
    fn entropy_value(x: &[f64], coefficients: &[f64]) -> f64 {
        Self::ENTROPY_EXPONENTS
            .iter()
            .zip(coefficients)
            .map(|(e, c)| c * monomial(x, e))
            .sum()
    }
    fn entropy_gradient(x: &[f64], coefficients: &[f64], grad: &mut [f64]) {
        for (v, g) in grad.iter_mut().enumerate() {
            *g = Self::ENTROPY_EXPONENTS
                .iter()
                .zip(coefficients)
                .map(|(e, c)| c * monomial_derivative(x, e, v))
                .sum();
        }
    }
    fn metric_value(x: &[f64], coefficients: &[f64], metric: &mut [f64]) {
        let n = Self::DIM;
        let basis = Self::METRIC_EXPONENTS.len();
        let mut features = [0.0; 6];
        Self::metric_features(x, &mut features);
        for j in 0..n {
            for k in 0..n {
                let pair = metric_pair_index(n, j, k);
                metric[j * n + k] = (0..basis)
                    .map(|a| coefficients[pair * basis + a] * features[a])
                    .sum();
            }
        }
    }
    fn entropy_block(x: &[f64], metric: &[f64], block: &mut [f64], drift: &mut [f64]) {
        let n = Self::DIM;
        let p = Self::ENTROPY_EXPONENTS.len();
        let mut op = [0.0; 4];
        Self::poisson(x, &mut op);
        op.iter_mut().zip(metric).for_each(|(o, k)| *o += k);
        let mut jac = [0.0; 10];
        Self::entropy_jacobian(x, &mut jac);
        for j in 0..n {
            for k in 0..p {
                block[j * p + k] = (0..n).map(|v| op[j * n + v] * jac[k * n + v]).sum();
            }
            drift[j] = (0..n).map(|v| op[j * n + v] * x[v]).sum();
        }
    }
    fn metric_block(x: &[f64], gradient: &[f64], block: &mut [f64], drift: &mut [f64]) {
        let n = Self::DIM;
        let basis = Self::METRIC_EXPONENTS.len();
        let width = Self::metric_coefficient_count();
        let mut features = [0.0; 6];
        Self::metric_features(x, &mut features);
        block.iter_mut().for_each(|b| *b = 0.0);
        for j in 0..n {
            for (k, g) in gradient.iter().enumerate() {
                let pair = metric_pair_index(n, j, k);
                for (a, f) in features.iter().enumerate().take(basis) {
                    block[j * width + pair * basis + a] += f * g;
                }
            }
        }
        let mut op = [0.0; 4];
        Self::poisson(x, &mut op);
        for j in 0..n {
            drift[j] = (0..n).map(|v| op[j * n + v] * gradient[v]).sum();
        }
    }
}

/// `count` states uniform in [−1.5, 1.5]² with ẋ from the reference model.
pub(crate) fn reference_data(count: usize, seed: u64) -> crate::dataset::Dataset {
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
    crate::dataset::Dataset::from_flat(2, states, derivatives).unwrap()
}
