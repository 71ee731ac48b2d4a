//! Entropy bases larger than the truth needs (what a user who does not know
//! the truth declares): the joint step stays Solved with the dense backend,
//! agrees with Clarabel, and identification converges.
//!
//! The dense method once returned a false `PrimalInfeasible` on every joint
//! step of such systems (double well at entropy degree 10: 540 of 540), and
//! the run fell back to plain alternation.

use metriplectic::systems::reference_samples;
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    joint_step, IdentifyConfig, SearchOptions, SolveStatus, SolverBackend, SolverSettings,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::common::relative_error;

metriplectic! {
    /// The damped double well of `systems::Duffing` (true entropy degree 4)
    /// with an entropy basis of degree 6.
    pub struct OversizedDuffing;
    state (x, v);
    poisson = [[0, -1], [1, 0]];
    hamiltonian = 0.5 * v^2 + 0.25 * x^4 - 0.5 * x^2;
    entropy degree 6;
    metric degree 0;
    reference {
        entropy = -(v^2 + 0.5 * x^4 - x^2);
        metric = [[0, 0], [0, 0.5]];
    }
}

metriplectic! {
    /// The paper's 2-D system (true entropy degree 8) with an entropy basis
    /// of degree 10.
    pub struct OversizedLinear2d;
    state (q, p);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2;
    entropy degree 10;
    metric degree 2;
    reference {
        entropy = -0.5 * (p^2 + 4*q^4 - 4*q^2)^2 - (0.5*p^2 + 0.5*q^2);
        metric = [[1, 0], [0, 1]];
    }
}

metriplectic! {
    /// Two coupled oscillators with a quartic spring and a coupled metric
    /// (true entropy degree 2) with an entropy basis of degree 6.
    pub struct OversizedPair;
    state (q1, q2, p1, p2);
    poisson = [[0, 0, 1, 0], [0, 0, 0, 1], [-1, 0, 0, 0], [0, -1, 0, 0]];
    hamiltonian = 0.5 * (p1^2 + p2^2) + 0.5 * (q1^2 + 2 * q2^2) + 0.1 * q1^4;
    entropy degree 6;
    metric degree 0;
    reference {
        entropy = -0.5 * (p1^2 + p2^2) - 0.2 * q1 * q2;
        metric = [[0.1, 0, 0, 0], [0, 0.1, 0, 0], [0, 0, 0.5, 0.1], [0, 0, 0.1, 0.4]];
    }
}

fn data<S: MetriplecticSystem>(count: usize, seed: u64) -> Dataset {
    reference_samples::<S>(count, seed, |rng| {
        (0..S::DIM).map(|_| rng.random_range(-1.5..1.5)).collect()
    })
}

/// Statuses of one identification run from the default start (40
/// iterations at most) and its held-out error.
struct Outcome {
    joint: Vec<(SolveStatus, usize)>,
    statuses: Vec<(SolveStatus, usize, usize)>,
    error: f64,
}

fn identify_from<S: MetriplecticSystem>(train: &Dataset, held_out: &Dataset) -> Outcome {
    let config = IdentifyConfig {
        max_iterations: 40,
        ..IdentifyConfig::default()
    };
    let run = identify::<S>(train, &config).unwrap();
    let outcome = Outcome {
        joint: run.history.joint_status_counts(),
        statuses: run.history.status_counts(),
        error: relative_error(&run.model, held_out),
    };
    eprintln!(
        "{}: {} iterations ({:?}), held-out error {:.2e}, joint steps {:?}, \
         (metric, entropy) {:?}",
        S::NAME,
        run.history.iterations.len(),
        run.stop_reason,
        outcome.error,
        outcome.joint,
        outcome.statuses
    );
    assert!(!outcome.joint.is_empty(), "the scheme takes joint steps");
    outcome
}

/// Identification from the default start: every joint step ends Solved and
/// the held-out error reaches 1e-8.
fn converges<S: MetriplecticSystem>() {
    let Outcome { joint, error, .. } = identify_from::<S>(&data::<S>(800, 1), &data::<S>(400, 2));
    assert!(
        joint
            .iter()
            .all(|(status, _)| *status == SolveStatus::Solved),
        "{joint:?}"
    );
    assert!(error <= 1e-8, "held-out error {error:e}");
}

#[test]
fn oversized_duffing_is_identified_with_solved_joint_steps() {
    converges::<OversizedDuffing>();
}

#[test]
fn oversized_linear2d_is_identified_with_solved_joint_steps() {
    converges::<OversizedLinear2d>();
}

/// Near the exact fit (cost ≤ 2e-3 from the fourth iteration) the
/// weights of the normal equations span many orders of magnitude; with
/// only the formed Schur complement's factor, 6 of the 9 joint steps once
/// ended `InsufficientProgress` or `AlmostSolved`. The orthogonal factor
/// (`docs/method.md` §4) refines them: 4 iterations, all Solved, as with
/// Clarabel.
#[test]
fn oversized_pair_is_identified_with_solved_joint_steps() {
    converges::<OversizedPair>();
}

/// Exactly collinear features: every state on the unit sphere of R⁴, so
/// q₁² + q₂² + p₁² + p₂² − 1 vanishes on the data and the degree-6 basis
/// has columns that are dependent there (the data cannot tell S from
/// S + f·(|x|² − 1)). No step of any kind may end infeasible or fail,
/// every joint step ends usable, and the model fits held-out states on the
/// same sphere. Measured: 5 iterations, held-out error 5–6e-10, one joint
/// and one metric step `AlmostSolved` (a KKT residual floor of ~1e-7 from
/// rounding D̃ ∘ (A v) on those columns, with D̃ up to 1e12); Clarabel
/// ends none of the 10 entropy steps of the same run Solved (7 with a
/// numerical error).
#[test]
fn collinear_features_on_a_sphere_give_no_failed_step() {
    let on_sphere = |count, seed| {
        reference_samples::<OversizedPair>(count, seed, |rng| {
            let v: Vec<f64> = (0..4).map(|_| rng.random_range(-1.5..1.5)).collect();
            let norm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            v.iter().map(|a| a / norm).collect()
        })
    };
    let Outcome {
        joint,
        statuses,
        error,
    } = identify_from::<OversizedPair>(&on_sphere(800, 1), &on_sphere(400, 2));
    assert!(
        joint.iter().all(|(status, _)| status.is_usable()),
        "{joint:?}"
    );
    assert!(
        statuses.iter().all(|(status, _, _)| status.is_usable()),
        "{statuses:?}"
    );
    assert!(error <= 1e-8, "held-out error {error:e}");
}

/// The joint step off the truth (the entropy perturbed by N(0, 0.05²), a
/// trust region too small to reach it):
/// both backends end Solved at the same predicted cost.
fn backends_agree<S: MetriplecticSystem>() {
    let train = data::<S>(600, 3);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let noise = Normal::new(0.0, 0.05).unwrap();
    let entropy: Vec<f64> = S::REFERENCE_ENTROPY
        .unwrap()
        .iter()
        .map(|c| c + noise.sample(&mut rng))
        .collect();
    let model = Model::<S>::new(entropy, S::REFERENCE_METRIC.unwrap().to_vec()).unwrap();
    let step = |backend| {
        let options = SearchOptions {
            solver: SolverSettings {
                backend,
                ..SolverSettings::default()
            },
            ..SearchOptions::default()
        };
        joint_step::<S>(&train, &model, 0.01, &options).unwrap()
    };
    let dense = step(SolverBackend::Dense);
    let clarabel = step(SolverBackend::Clarabel(Default::default()));
    assert_eq!(dense.report.status, SolveStatus::Solved);
    assert_eq!(clarabel.report.status, SolveStatus::Solved);
    let (a, b) = (
        dense.predicted.unwrap().sum,
        clarabel.predicted.unwrap().sum,
    );
    eprintln!("{}: predicted cost dense {a:e}, Clarabel {b:e}", S::NAME);
    assert!(a > 1e-3, "the step is not trivially at the truth");
    assert!((a - b).abs() <= 1e-6 * b, "dense {a} vs Clarabel {b}");
}

#[test]
fn backends_agree_on_the_oversized_duffing_joint_step() {
    backends_agree::<OversizedDuffing>();
}

#[test]
fn backends_agree_on_the_oversized_linear2d_joint_step() {
    backends_agree::<OversizedLinear2d>();
}
