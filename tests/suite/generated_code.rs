//! The code `metriplectic!` generates for the two paper systems, evaluated
//! at random points against independent hand-written formulas.

use metriplectic_runtime::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::common::{metric_pair_index, Linear2d, RigidBody};

const POINTS: usize = 200;

fn random_points(dim: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..POINTS)
        .map(|_| (0..dim).map(|_| rng.random_range(-1.5..1.5)).collect())
        .collect()
}

fn random_vector(len: usize, rng: &mut ChaCha8Rng) -> Vec<f64> {
    (0..len).map(|_| rng.random_range(-1.0..1.0)).collect()
}

/// |a − b| ≤ tol · max(1, |b|), with a message naming the quantity.
fn assert_close(what: &str, a: f64, b: f64, tol: f64) {
    assert!(
        (a - b).abs() <= tol * b.abs().max(1.0),
        "{what}: generated {a} vs hand-written {b}"
    );
}

fn assert_all_close(what: &str, a: &[f64], b: &[f64], tol: f64) {
    assert_eq!(a.len(), b.len(), "{what}: lengths differ");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert_close(&format!("{what}[{i}]"), *x, *y, tol);
    }
}

fn mat_vec(m: &[f64], v: &[f64]) -> Vec<f64> {
    let n = v.len();
    (0..m.len() / n)
        .map(|i| (0..n).map(|j| m[i * n + j] * v[j]).sum())
        .collect()
}

// ---- hand-written formulas --------------------------------------------------

struct Formulas {
    hamiltonian: fn(&[f64]) -> f64,
    hamiltonian_gradient: fn(&[f64]) -> Vec<f64>,
    poisson: fn(&[f64]) -> Vec<f64>,
    free_energy: fn(&[f64]) -> f64,
    free_energy_gradient: fn(&[f64]) -> Vec<f64>,
}

const LINEAR_2D: Formulas = Formulas {
    hamiltonian: |x| 0.5 * (x[0] * x[0] + x[1] * x[1]),
    hamiltonian_gradient: |x| vec![x[0], x[1]],
    poisson: |_| vec![0.0, 1.0, -1.0, 0.0],
    free_energy: |x| {
        let (q, p) = (x[0], x[1]);
        let u = p * p + 4.0 * q.powi(4) - 4.0 * q * q;
        -0.5 * u * u
    },
    free_energy_gradient: |x| {
        let (q, p) = (x[0], x[1]);
        let u = p * p + 4.0 * q.powi(4) - 4.0 * q * q;
        vec![-u * (16.0 * q.powi(3) - 8.0 * q), -u * 2.0 * p]
    },
};

const INERTIA: [f64; 3] = [0.1, 0.2, 0.15];

const RIGID_BODY: Formulas = Formulas {
    hamiltonian: |x| 0.5 * (0..3).map(|i| x[i] * x[i] / INERTIA[i]).sum::<f64>(),
    hamiltonian_gradient: |x| (0..3).map(|i| x[i] / INERTIA[i]).collect(),
    poisson: |x| {
        let (a, b, c) = (x[0], x[1], x[2]);
        vec![0.0, -c, b, c, 0.0, -a, -b, a, 0.0]
    },
    free_energy: |x| {
        let r = x.iter().map(|v| v * v).sum::<f64>() - 1.0;
        -0.5 * r * r
    },
    free_energy_gradient: |x| {
        let r = x.iter().map(|v| v * v).sum::<f64>() - 1.0;
        x.iter().map(|v| -2.0 * r * v).collect()
    },
};

// ---- checks shared by both systems -----------------------------------------

fn check_known_parts<S: MetriplecticSystem>(f: &Formulas, seed: u64) {
    let n = S::DIM;
    for x in random_points(n, seed) {
        assert_close("H", S::hamiltonian(&x), (f.hamiltonian)(&x), 1e-13);
        let mut grad = vec![0.0; n];
        S::hamiltonian_gradient(&x, &mut grad);
        assert_all_close("∇H", &grad, &(f.hamiltonian_gradient)(&x), 1e-13);
        let mut poisson = vec![0.0; n * n];
        S::poisson(&x, &mut poisson);
        assert_all_close("Π", &poisson, &(f.poisson)(&x), 0.0);
    }
}

fn check_reference<S: MetriplecticSystem>(f: &Formulas, seed: u64) {
    let n = S::DIM;
    let model = Model::<S>::reference().expect("reference model");
    // The generated ψ drops the constant term of S_ref = E − H (it does not
    // affect the dynamics): the model's entropy is S_ref − S_ref(0).
    let origin = vec![0.0; n];
    let dropped = (f.free_energy)(&origin) - (f.hamiltonian)(&origin);
    for x in random_points(n, seed) {
        let h = (f.hamiltonian)(&x);
        let e = (f.free_energy)(&x);
        assert_close("S_ref", model.entropy(&x).unwrap(), e - h - dropped, 1e-11);
        assert_close("E_ref", model.free_energy(&x).unwrap(), e - dropped, 1e-11);

        let grad_e = (f.free_energy_gradient)(&x);
        let mut grad = vec![0.0; n];
        model.free_energy_gradient(&x, &mut grad).unwrap();
        assert_all_close("∇E_ref", &grad, &grad_e, 1e-11);
        let mut grad_s = vec![0.0; n];
        S::entropy_gradient(&x, model.entropy_coefficients(), &mut grad_s);
        let expected: Vec<f64> = grad_e
            .iter()
            .zip((f.hamiltonian_gradient)(&x))
            .map(|(e, h)| e - h)
            .collect();
        assert_all_close("∇S_ref", &grad_s, &expected, 1e-11);

        let mut metric = vec![0.0; n * n];
        model.metric(&x, &mut metric).unwrap();
        let identity: Vec<f64> = (0..n * n)
            .map(|i| if i % (n + 1) == 0 { 1.0 } else { 0.0 })
            .collect();
        assert_all_close("K_ref", &metric, &identity, 0.0);

        // f(x) = (Π + I) ∇E.
        let mut operator = (f.poisson)(&x);
        for j in 0..n {
            operator[j * n + j] += 1.0;
        }
        let mut xdot = vec![0.0; n];
        model.vector_field(&x, &mut xdot).unwrap();
        assert_all_close("f_ref", &xdot, &mat_vec(&operator, &grad_e), 1e-11);
        assert_close(
            "dE/dt",
            model.free_energy_rate(&x).unwrap(),
            grad_e.iter().map(|g| g * g).sum(),
            1e-11,
        );
    }
}

fn check_features<S: MetriplecticSystem>(seed: u64) {
    let n = S::DIM;
    let p = S::entropy_coefficient_count();
    let m = S::METRIC_EXPONENTS.len();
    let monomial = |e: &[u32], x: &[f64]| -> f64 {
        e.iter().zip(x).map(|(&k, &v)| v.powi(k as i32)).product()
    };
    for x in random_points(n, seed) {
        let mut features = vec![0.0; p];
        S::entropy_features(&x, &mut features);
        let direct: Vec<f64> = S::ENTROPY_EXPONENTS
            .iter()
            .map(|e| monomial(e, &x))
            .collect();
        assert_all_close("φ_r", &features, &direct, 1e-13);

        let mut metric_features = vec![0.0; m];
        S::metric_features(&x, &mut metric_features);
        let direct: Vec<f64> = S::METRIC_EXPONENTS
            .iter()
            .map(|e| monomial(e, &x))
            .collect();
        assert_all_close("φ_s", &metric_features, &direct, 1e-13);

        // Jacobian against central differences of the generated features.
        let mut jacobian = vec![0.0; p * n];
        S::entropy_jacobian(&x, &mut jacobian);
        let h = 1e-6;
        for j in 0..n {
            let (mut plus, mut minus) = (x.clone(), x.clone());
            plus[j] += h;
            minus[j] -= h;
            let (mut fp, mut fm) = (vec![0.0; p], vec![0.0; p]);
            S::entropy_features(&plus, &mut fp);
            S::entropy_features(&minus, &mut fm);
            for k in 0..p {
                let fd = (fp[k] - fm[k]) / (2.0 * h);
                assert_close(&format!("J[{k}][{j}]"), jacobian[k * n + j], fd, 1e-6);
            }
        }
    }
}

/// θ of a random state-dependent metric K(x) = Z(x)ᵀ Q Z(x) with
/// Q = A Aᵀ ⪰ 0 over the full half-degree SOS basis.
fn random_sos_metric<S: MetriplecticSystem>(rng: &mut ChaCha8Rng) -> Vec<f64> {
    let n = S::DIM;
    let tables = S::SOS_FULL;
    let half = tables.exponents.len();
    let size = n * half;
    let a: Vec<f64> = random_vector(size * size, rng);
    let gram =
        |r: usize, c: usize| -> f64 { (0..size).map(|k| a[r * size + k] * a[c * size + k]).sum() };
    let basis = S::METRIC_EXPONENTS.len();
    let mut theta = vec![0.0; S::metric_coefficient_count()];
    for j in 0..n {
        for k in j..n {
            let pair = metric_pair_index(n, j, k);
            for (alpha, pairs) in tables.matching.iter().enumerate() {
                theta[pair * basis + alpha] = pairs
                    .iter()
                    .map(|&(b, g)| gram(j * half + b as usize, k * half + g as usize))
                    .sum();
            }
        }
    }
    theta
}

/// The assembly blocks reproduce the vector field of random models with
/// state-dependent metrics: drift + block · ψ and drift + block · θ both
/// equal (Π + K)(∇H + ∇S).
fn check_blocks<S: MetriplecticSystem>(seed: u64) {
    let n = S::DIM;
    let p = S::entropy_coefficient_count();
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0xb10c);
    let models: Vec<Model<S>> = (0..4)
        .map(|_| {
            let metric = random_sos_metric::<S>(&mut rng);
            Model::<S>::new(random_vector(p, &mut rng), metric).expect("random model")
        })
        .collect();
    for (i, x) in random_points(n, seed).into_iter().enumerate() {
        let model = &models[i % models.len()];
        let mut xdot = vec![0.0; n];
        model.vector_field(&x, &mut xdot).unwrap();
        let scale = xdot.iter().fold(1.0f64, |a, v| a.max(v.abs()));

        let mut metric = vec![0.0; n * n];
        model.metric(&x, &mut metric).unwrap();
        let mut block = vec![0.0; n * p];
        let mut drift = vec![0.0; n];
        S::entropy_block(&x, &metric, &mut block, &mut drift);
        let lhs: Vec<f64> = mat_vec(&block, model.entropy_coefficients())
            .iter()
            .zip(&drift)
            .map(|(a, b)| a + b)
            .collect();
        for j in 0..n {
            assert_close("entropy block row", lhs[j] / scale, xdot[j] / scale, 1e-11);
        }

        let mut gradient = vec![0.0; n];
        model.free_energy_gradient(&x, &mut gradient).unwrap();
        let mut block = vec![0.0; n * S::metric_coefficient_count()];
        S::metric_block(&x, &gradient, &mut block, &mut drift);
        let lhs: Vec<f64> = mat_vec(&block, model.metric_coefficients())
            .iter()
            .zip(&drift)
            .map(|(a, b)| a + b)
            .collect();
        for j in 0..n {
            assert_close("metric block row", lhs[j] / scale, xdot[j] / scale, 1e-11);
        }

        // K(x) from θ by hand: K_jk = Σ_a θ_(jk),a φ_a(x).
        let mut features = vec![0.0; S::METRIC_EXPONENTS.len()];
        S::metric_features(&x, &mut features);
        let m = features.len();
        for j in 0..n {
            for k in 0..n {
                let pair = metric_pair_index(n, j, k);
                let theta = &model.metric_coefficients()[pair * m..(pair + 1) * m];
                let value: f64 = theta.iter().zip(&features).map(|(a, b)| a * b).sum();
                assert_close("K(θ)", metric[j * n + k], value, 1e-13);
            }
        }
    }
}

fn check_tables<S: MetriplecticSystem>(entropy: usize, metric: usize, half: usize) {
    assert_eq!(S::ENTROPY_EXPONENTS.len(), entropy);
    assert_eq!(S::METRIC_EXPONENTS.len(), metric);
    assert!(S::METRIC_EXPONENTS[0].iter().all(|&k| k == 0));
    assert!(S::ENTROPY_EXPONENTS
        .iter()
        .all(|e| e.iter().sum::<u32>() >= 1));
    assert_eq!(S::SOS_FULL.exponents.len(), half);
    assert_eq!(S::SOS_FULL.matching.len(), metric);
    for (alpha, pairs) in S::SOS_FULL.matching.iter().enumerate() {
        assert!(
            !pairs.is_empty(),
            "metric monomial {alpha} has no Gram pair"
        );
        for &(b, g) in pairs.iter() {
            let sum: Vec<u32> = S::SOS_FULL.exponents[b as usize]
                .iter()
                .zip(S::SOS_FULL.exponents[g as usize])
                .map(|(x, y)| x + y)
                .collect();
            assert_eq!(sum.as_slice(), S::METRIC_EXPONENTS[alpha]);
        }
    }
    assert_eq!(S::SOS_REDUCED.exponents.len(), 1);
    assert_eq!(S::SOS_REDUCED.matching[0], &[(0, 0)]);
    assert!(S::SOS_REDUCED.matching[1..].iter().all(|p| p.is_empty()));
}

#[test]
fn linear_2d_known_parts() {
    check_known_parts::<Linear2d>(&LINEAR_2D, 1);
}

#[test]
fn linear_2d_reference_model() {
    check_reference::<Linear2d>(&LINEAR_2D, 2);
    // The reference entropy's true coefficients: −8 q⁸ is the largest in
    // magnitude besides 16 q⁶ (docs/method.md §5: η ≥ 16).
    let psi = Linear2d::REFERENCE_ENTROPY.unwrap();
    let max = psi.iter().fold(0.0f64, |a, c| a.max(c.abs()));
    assert_eq!(max, 16.0);
}

#[test]
fn linear_2d_features_and_jacobian() {
    check_features::<Linear2d>(3);
}

#[test]
fn linear_2d_assembly_blocks() {
    check_blocks::<Linear2d>(4);
}

#[test]
fn linear_2d_tables() {
    // 44 entropy monomials (degree 1..=8), 6 metric monomials, m(x) = (1, q, p).
    check_tables::<Linear2d>(44, 6, 3);
    assert_eq!(Linear2d::STATE_NAMES, &["q", "p"]);
    assert_eq!(Linear2d::NAME, "Linear2d");
}

#[test]
fn rigid_body_known_parts() {
    check_known_parts::<RigidBody>(&RIGID_BODY, 5);
}

#[test]
fn rigid_body_reference_model() {
    check_reference::<RigidBody>(&RIGID_BODY, 6);
    // p̂ ∇E = 0: the true flow is radial (docs/method.md §3).
    let model = Model::<RigidBody>::reference().unwrap();
    for x in random_points(3, 7) {
        let mut xdot = [0.0; 3];
        model.vector_field(&x, &mut xdot).unwrap();
        let grad_e = (RIGID_BODY.free_energy_gradient)(&x);
        assert_all_close("radial flow", &xdot, &grad_e, 1e-11);
    }
}

#[test]
fn rigid_body_features_and_jacobian() {
    check_features::<RigidBody>(8);
}

#[test]
fn rigid_body_assembly_blocks() {
    check_blocks::<RigidBody>(9);
}

#[test]
fn rigid_body_tables() {
    // 83 entropy monomials (degree 1..=6 in 3 variables), 10 metric monomials.
    check_tables::<RigidBody>(83, 10, 4);
}

metriplectic! {
    /// State names that collide with generated names: `x` (the state
    /// parameter), `value` (a generated local) and `x2` (the readable name of
    /// the monomial x², which forces the fallback names).
    struct Awkward;
    state (x, x2, value);
    const half = 1 / 2;
    poisson = [[0, value, -x2], [-value, 0, x], [x2, -x, 0]];
    hamiltonian = half * (x^2 + x2^2 + value^2) + x * x2 * value;
    entropy degree 3;
    metric degree 2;
}

#[test]
fn colliding_state_names_generate_correct_code() {
    let point = [0.3, -0.7, 1.1];
    let (x, x2, value) = (point[0], point[1], point[2]);
    assert_close(
        "H",
        Awkward::hamiltonian(&point),
        0.5 * (x * x + x2 * x2 + value * value) + x * x2 * value,
        1e-15,
    );
    let mut grad = [0.0; 3];
    Awkward::hamiltonian_gradient(&point, &mut grad);
    assert_all_close(
        "∇H",
        &grad,
        &[x + x2 * value, x2 + x * value, value + x * x2],
        1e-15,
    );
    let mut poisson = [0.0; 9];
    Awkward::poisson(&point, &mut poisson);
    assert_all_close(
        "Π",
        &poisson,
        &[0.0, value, -x2, -value, 0.0, x, x2, -x, 0.0],
        0.0,
    );
    check_features::<Awkward>(10);
    check_blocks::<Awkward>(11);
}

metriplectic! {
    /// A reference model whose coefficients reach the bound the macro
    /// checks them against at compile time (`MAX_COEFFICIENT` in
    /// `metriplectic-macros/codegen/src/analysis/reference.rs`).
    struct AtTheBound;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * (q^2 + p^2);
    entropy degree 2;
    metric degree 0;
    reference {
        entropy = -1e15 * q^2 + 1e15 * q * p - 1e15 * p^2;
        metric = [[1e15, 0], [0, 1e15]];
    }
}

/// The macro refuses reference coefficients beyond ±1e15 at compile time
/// (`tests/ui/reference_coefficient_too_large.rs`) because
/// `Model::reference()` refuses them at run time; the runtime must accept
/// everything up to that bound, so that the two agree.
#[test]
fn reference_coefficients_up_to_the_bound_are_accepted() {
    assert_eq!(Model::<AtTheBound>::MAX_COEFFICIENT, 1e15);
    let model = Model::<AtTheBound>::reference().expect("coefficients at the bound");
    assert_eq!(
        model.entropy_coefficients(),
        &[0.0, 0.0, -1e15, 1e15, -1e15]
    );
    assert_eq!(model.metric_coefficients(), &[1e15, 0.0, 1e15]);
}
