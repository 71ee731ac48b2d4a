//! Generated against interpreted per-sample evaluation.
//!
//! For both paper systems this times, per sample, the entropy feature
//! Jacobian, the metric features and the vector field f(x) = (Π + K)(∇H + ∇S)
//! twice: with the straight-line code `metriplectic!` generated, and with a
//! generic evaluator written here that walks the same exponent tables
//! (`ENTROPY_EXPONENTS`, `METRIC_EXPONENTS`) at run time, one `powi` per
//! variable per monomial, derivatives by the exponent rule. Before timing,
//! both are checked to give the same numbers on random states, so a wrong
//! fast path cannot win.
//!
//! Π(x) and ∇H(x) have no exponent tables in the trait (they are known, not
//! fitted), so the interpreted vector field uses the generated Π and ∇H and
//! interprets the fitted parts, ∇S = J(x)ᵀψ and K(x; θ).
//!
//! `cargo bench --bench evaluation` runs criterion (10 samples, short
//! measurement) and then prints a ratio table measured by interleaved timing
//! in the same process. `-- --quick` shortens both.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::Criterion;
use metriplectic::systems::{Linear2d, RigidBody};
use metriplectic_runtime::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Position of the upper-triangle pair (j, k) among the n(n+1)/2 pairs of θ.
fn metric_pair_index(dim: usize, j: usize, k: usize) -> usize {
    let (j, k) = (j.min(k), j.max(k));
    j * dim - j * j.saturating_sub(1) / 2 + (k - j)
}

/// Largest state dimension the fixed-size scratch arrays below allow.
const MAX_DIM: usize = 8;

/// The interpreter: evaluates a system's bases by walking its exponent
/// tables at run time.
struct Interpreted<S>(std::marker::PhantomData<S>);

impl<S: MetriplecticSystem> Interpreted<S> {
    fn monomial(x: &[f64], exponents: &[u32]) -> f64 {
        exponents
            .iter()
            .zip(x)
            .map(|(&e, &v)| v.powi(e as i32))
            .product()
    }

    fn metric_features(x: &[f64], features: &mut [f64]) {
        for (out, exponents) in features.iter_mut().zip(S::METRIC_EXPONENTS) {
            *out = Self::monomial(x, exponents);
        }
    }

    /// Row k is ∇φₖ(x): ∂/∂xⱼ x^α = αⱼ xⱼ^(αⱼ−1) Π_{l≠j} x_l^(α_l).
    fn entropy_jacobian(x: &[f64], jacobian: &mut [f64]) {
        let n = S::DIM;
        for (row, exponents) in jacobian.chunks_exact_mut(n).zip(S::ENTROPY_EXPONENTS) {
            for (j, out) in row.iter_mut().enumerate() {
                let ej = exponents[j];
                *out = if ej == 0 {
                    0.0
                } else {
                    let mut value = f64::from(ej) * x[j].powi(ej as i32 - 1);
                    for (l, (&el, &xl)) in exponents.iter().zip(x).enumerate() {
                        if l != j {
                            value *= xl.powi(el as i32);
                        }
                    }
                    value
                };
            }
        }
    }

    /// f(x) with ∇S and K interpreted; `jacobian` and `features` are scratch.
    fn vector_field(
        x: &[f64],
        psi: &[f64],
        theta: &[f64],
        jacobian: &mut [f64],
        features: &mut [f64],
        xdot: &mut [f64],
    ) {
        let n = S::DIM;
        let basis = S::METRIC_EXPONENTS.len();
        Self::entropy_jacobian(x, jacobian);
        Self::metric_features(x, features);
        let mut grad = [0.0; MAX_DIM];
        S::hamiltonian_gradient(x, &mut grad[..n]);
        for (row, c) in jacobian.chunks_exact(n).zip(psi) {
            for (g, d) in grad.iter_mut().zip(row) {
                *g += c * d;
            }
        }
        let mut operator = [0.0; MAX_DIM * MAX_DIM];
        S::poisson(x, &mut operator[..n * n]);
        for j in 0..n {
            for k in 0..n {
                let pair = metric_pair_index(n, j, k);
                let coefficients = &theta[pair * basis..(pair + 1) * basis];
                operator[j * n + k] += coefficients
                    .iter()
                    .zip(&*features)
                    .map(|(t, f)| t * f)
                    .sum::<f64>();
            }
        }
        for (j, out) in xdot.iter_mut().enumerate() {
            *out = (0..n).map(|k| operator[j * n + k] * grad[k]).sum();
        }
    }
}

/// f(x) from the generated functions, on stack scratch (what the runtime's
/// hot loops can do).
fn generated_vector_field<S: MetriplecticSystem>(
    x: &[f64],
    psi: &[f64],
    theta: &[f64],
    xdot: &mut [f64],
) {
    let n = S::DIM;
    let mut grad = [0.0; MAX_DIM];
    let mut grad_h = [0.0; MAX_DIM];
    S::entropy_gradient(x, psi, &mut grad[..n]);
    S::hamiltonian_gradient(x, &mut grad_h[..n]);
    let mut operator = [0.0; MAX_DIM * MAX_DIM];
    let mut metric = [0.0; MAX_DIM * MAX_DIM];
    S::poisson(x, &mut operator[..n * n]);
    S::metric_value(x, theta, &mut metric[..n * n]);
    for j in 0..n {
        xdot[j] = (0..n)
            .map(|k| (operator[j * n + k] + metric[j * n + k]) * (grad[k] + grad_h[k]))
            .sum();
    }
}

/// Random states in [−1.5, 1.5]ⁿ and random coefficients.
struct Inputs {
    states: Vec<Vec<f64>>,
    psi: Vec<f64>,
    theta: Vec<f64>,
}

fn inputs<S: MetriplecticSystem>(seed: u64) -> Inputs {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let states = (0..256)
        .map(|_| (0..S::DIM).map(|_| rng.random_range(-1.5..1.5)).collect())
        .collect();
    let psi = (0..S::entropy_coefficient_count())
        .map(|_| rng.random_range(-1.0..1.0))
        .collect();
    let theta = random_sos_metric::<S>(&mut rng);
    Inputs { states, psi, theta }
}

/// θ of a random state-dependent metric K(x) = Z(x)ᵀ A Aᵀ Z(x) over the
/// full SOS basis: positive semidefinite, so a valid model's, and with
/// every metric coefficient in use.
fn random_sos_metric<S: MetriplecticSystem>(rng: &mut ChaCha8Rng) -> Vec<f64> {
    let n = S::DIM;
    let tables = S::SOS_FULL;
    let half = tables.exponents.len();
    let size = n * half;
    let a: Vec<f64> = (0..size * size)
        .map(|_| rng.random_range(-1.0..1.0))
        .collect();
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

fn assert_close(what: &str, generated: &[f64], interpreted: &[f64]) {
    assert_eq!(generated.len(), interpreted.len(), "{what}: lengths");
    let scale = interpreted.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
    for (i, (g, r)) in generated.iter().zip(interpreted).enumerate() {
        assert!(
            (g - r).abs() <= 1e-12 * scale,
            "{what}[{i}]: generated {g} vs interpreted {r}"
        );
    }
}

/// Panics unless generated and interpreted agree on every state.
fn check_agreement<S: MetriplecticSystem>(input: &Inputs) {
    let (n, p, basis) = (
        S::DIM,
        S::entropy_coefficient_count(),
        S::METRIC_EXPONENTS.len(),
    );
    let model = Model::<S>::new(input.psi.clone(), input.theta.clone()).expect("valid model");
    let (mut jg, mut ji) = (vec![0.0; p * n], vec![0.0; p * n]);
    let (mut fg, mut fi) = (vec![0.0; basis], vec![0.0; basis]);
    let (mut vg, mut vi, mut vm) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for x in &input.states {
        S::entropy_jacobian(x, &mut jg);
        Interpreted::<S>::entropy_jacobian(x, &mut ji);
        assert_close("entropy Jacobian", &jg, &ji);
        S::metric_features(x, &mut fg);
        Interpreted::<S>::metric_features(x, &mut fi);
        assert_close("metric features", &fg, &fi);
        generated_vector_field::<S>(x, &input.psi, &input.theta, &mut vg);
        Interpreted::<S>::vector_field(x, &input.psi, &input.theta, &mut ji, &mut fi, &mut vi);
        assert_close("vector field", &vg, &vi);
        model.vector_field(x, &mut vm).expect("dimension");
        assert_close("Model::vector_field", &vm, &vi);
    }
}

/// The kernels timed for one system, each over all states of `Inputs`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kernel {
    Jacobian,
    MetricFeatures,
    VectorField,
}

const KERNELS: [Kernel; 3] = [
    Kernel::Jacobian,
    Kernel::MetricFeatures,
    Kernel::VectorField,
];

impl Kernel {
    fn name(self) -> &'static str {
        match self {
            Self::Jacobian => "entropy Jacobian",
            Self::MetricFeatures => "metric features",
            Self::VectorField => "vector field",
        }
    }
}

/// Which implementation runs a kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Implementation {
    Generated,
    Interpreted,
    /// `Model::vector_field`: the public API (length checks, heap scratch).
    Model,
}

/// Runs `kernel` once over every state; returns a checksum.
fn run<S: MetriplecticSystem>(
    kernel: Kernel,
    implementation: Implementation,
    input: &Inputs,
    model: &Model<S>,
    scratch: &mut [Vec<f64>; 3],
) -> f64 {
    let [jacobian, features, out] = scratch;
    let mut sum = 0.0;
    for x in &input.states {
        let x = black_box(x.as_slice());
        match (kernel, implementation) {
            (Kernel::Jacobian, Implementation::Generated) => S::entropy_jacobian(x, jacobian),
            (Kernel::Jacobian, _) => Interpreted::<S>::entropy_jacobian(x, jacobian),
            (Kernel::MetricFeatures, Implementation::Generated) => S::metric_features(x, features),
            (Kernel::MetricFeatures, _) => Interpreted::<S>::metric_features(x, features),
            (Kernel::VectorField, Implementation::Generated) => {
                generated_vector_field::<S>(x, &input.psi, &input.theta, out)
            }
            (Kernel::VectorField, Implementation::Interpreted) => {
                Interpreted::<S>::vector_field(x, &input.psi, &input.theta, jacobian, features, out)
            }
            (Kernel::VectorField, Implementation::Model) => {
                model.vector_field(x, out).expect("dimension")
            }
        }
        sum += jacobian[0] + features[0] + out[0];
    }
    sum
}

fn scratch<S: MetriplecticSystem>() -> [Vec<f64>; 3] {
    [
        vec![0.0; S::entropy_coefficient_count() * S::DIM],
        vec![0.0; S::METRIC_EXPONENTS.len()],
        vec![0.0; S::DIM],
    ]
}

fn implementations(kernel: Kernel) -> &'static [Implementation] {
    if kernel == Kernel::VectorField {
        &[
            Implementation::Generated,
            Implementation::Interpreted,
            Implementation::Model,
        ]
    } else {
        &[Implementation::Generated, Implementation::Interpreted]
    }
}

fn criterion_benches<S: MetriplecticSystem>(c: &mut Criterion, input: &Inputs) {
    let model = Model::<S>::new(input.psi.clone(), input.theta.clone()).expect("valid model");
    let mut scratch = scratch::<S>();
    for kernel in KERNELS {
        let mut group = c.benchmark_group(format!("{}/{}", S::NAME, kernel.name()));
        for &implementation in implementations(kernel) {
            group.bench_function(format!("{implementation:?}"), |b| {
                b.iter(|| run::<S>(kernel, implementation, input, &model, &mut scratch))
            });
        }
        group.finish();
    }
}

/// Median nanoseconds per sample of each implementation, interleaved so
/// that machine noise hits all of them alike.
fn interleaved<S: MetriplecticSystem>(
    kernel: Kernel,
    input: &Inputs,
    rounds: usize,
) -> Vec<(Implementation, f64)> {
    let model = Model::<S>::new(input.psi.clone(), input.theta.clone()).expect("valid model");
    let mut scratch = scratch::<S>();
    let list = implementations(kernel);
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); list.len()];
    let repeats = 20;
    for _ in 0..rounds {
        for (slot, &implementation) in list.iter().enumerate() {
            let start = Instant::now();
            for _ in 0..repeats {
                black_box(run::<S>(
                    kernel,
                    implementation,
                    input,
                    &model,
                    &mut scratch,
                ));
            }
            let per_sample =
                start.elapsed().as_secs_f64() * 1e9 / (repeats * input.states.len()) as f64;
            times[slot].push(per_sample);
        }
    }
    list.iter()
        .zip(times)
        .map(|(&implementation, mut t)| {
            t.sort_by(f64::total_cmp);
            (implementation, t[t.len() / 2])
        })
        .collect()
}

fn summary<S: MetriplecticSystem>(input: &Inputs, rounds: usize) {
    for kernel in KERNELS {
        let times = interleaved::<S>(kernel, input, rounds);
        let generated = times[0].1;
        let interpreted = times[1].1;
        let model = times
            .get(2)
            .map(|(_, t)| format!("{t:.1} ({:.1}×)", *t / generated))
            .unwrap_or_else(|| "–".to_owned());
        println!(
            "| {} (n={}, p={}, |φ_s|={}) | {} | {generated:.1} | {interpreted:.1} | {:.1}× | {model} |",
            S::NAME,
            S::DIM,
            S::entropy_coefficient_count(),
            S::METRIC_EXPONENTS.len(),
            kernel.name(),
            interpreted / generated,
        );
    }
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let linear = inputs::<Linear2d>(1);
    let rigid = inputs::<RigidBody>(2);
    check_agreement::<Linear2d>(&linear);
    check_agreement::<RigidBody>(&rigid);
    println!("generated and interpreted agree on 256 random states of each system");

    let mut c = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(if quick { 100 } else { 300 }))
        .measurement_time(Duration::from_millis(if quick { 300 } else { 1000 }))
        .configure_from_args();
    criterion_benches::<Linear2d>(&mut c, &linear);
    criterion_benches::<RigidBody>(&mut c, &rigid);
    c.final_summary();

    let rounds = if quick { 5 } else { 21 };
    println!();
    println!("Interleaved medians, ns per sample (same process, {rounds} rounds):");
    println!();
    println!("| system | kernel | generated (ns) | interpreted (ns) | interpreted / generated | Model::vector_field (ns, / generated) |");
    println!("|---|---|---|---|---|---|");
    summary::<Linear2d>(&linear, rounds);
    summary::<RigidBody>(&rigid, rounds);
}
