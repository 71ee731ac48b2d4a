//! Bilevel identification (Algorithms 1 and 2) on the paper systems, and the
//! model file round trip.

use crate::common::*;
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    identify, identify_with_observer, metric_search, History, IdentifyConfig, IterationScheme,
    SearchOptions, StepOutcome, StopReason, TrustRegion,
};
use metriplectic_runtime::{synthesize, InitialStates, SampleTimes, SynthesisOptions};
use metriplectic_runtime::{Identification, SyntheticData};
use std::ops::ControlFlow;
use std::sync::OnceLock;

fn assert_non_increasing(history: &History) {
    let mut previous = f64::INFINITY;
    for r in &history.iterations {
        for cost in [
            Some(r.cost_before.sum),
            Some(r.metric.cost_after.sum),
            Some(r.entropy.cost_after.sum),
            r.joint.as_ref().map(|j| j.step.cost_after.sum),
        ]
        .into_iter()
        .flatten()
        {
            assert!(
                cost <= previous,
                "iteration {}: cost rose from {previous:e} to {cost:e}",
                r.iteration
            );
            previous = cost;
        }
    }
}

#[test]
fn algorithm1_full_batch_cost_is_non_increasing() {
    let data = linear2d_data(200, 21);
    let config = IdentifyConfig {
        max_iterations: 8,
        tolerance: 0.0,
        initial_entropy: Some(perturbed_reference_entropy::<Linear2d>(0.5, 21)),
        ..alternation()
    };
    let result = identify::<Linear2d>(&data, &config).unwrap();
    for r in &result.history.iterations {
        eprintln!(
            "iteration {}: {:.3e} -> metric {} {:?} {:.3e} -> entropy {} {:?} {:.3e}",
            r.iteration,
            r.cost_before.per_component,
            r.metric.report.status,
            r.metric.outcome,
            r.metric.cost_after.per_component,
            r.entropy.report.status,
            r.entropy.outcome,
            r.entropy.cost_after.per_component
        );
    }
    assert_eq!(result.history.iterations.len(), 8);
    assert_non_increasing(&result.history);
    let first = result.history.iterations[0].cost_before.sum;
    let last = result.history.iterations[7].entropy.cost_after.sum;
    assert!(last < first, "no progress: {first:e} -> {last:e}");
}

/// Algorithm 2 from the paper's start (truth + N(0, 0.5²) per coefficient).
///
/// Measured (see the report of issue 3): the held-out relative error falls
/// from ≈ 0.39 to ≈ 3e-3 within ~30 iterations and then crawls; the
/// alternation stalls at blockwise-optimal points with K ≠ I, far from the
/// paper's "loss ≈ 0". This test pins down the part that works (a > 100×
/// reduction, every solve `Solved`) and fails if it regresses.
#[test]
fn algorithm2_reduces_the_error_on_linear2d_from_the_paper_protocol() {
    let train = linear2d_data(2000, 22);
    let held_out = linear2d_data(500, 23);
    let start = perturbed_reference_entropy::<Linear2d>(0.5, 22);
    let truth = Linear2d::REFERENCE_ENTROPY.unwrap();
    let config = IdentifyConfig {
        batch_size: Some(200),
        max_iterations: 40,
        tolerance: 1e-10,
        seed: 22,
        initial_entropy: Some(start.clone()),
        ..alternation()
    };
    let initial = Model::<Linear2d>::with_identity_metric(start.clone()).unwrap();
    let initial_error = relative_error(&initial, &held_out);
    let result = identify_with_observer::<Linear2d, _>(&train, &config, |r, model| {
        eprintln!(
            "iteration {}: batch cost {:.3e} -> {:.3e}, held-out relative error {:.3e}, \
             max |ψ − ψ_true| {:.3e}",
            r.iteration,
            r.cost_before.per_component,
            r.entropy.cost_after.per_component,
            relative_error(model, &held_out),
            max_abs_difference(model.entropy_coefficients(), truth)
        );
        ControlFlow::Continue(())
    })
    .unwrap();
    let final_error = relative_error(&result.model, &held_out);
    eprintln!(
        "stopped: {:?} after {} iterations; held-out relative error {initial_error:.3e} -> {final_error:.3e}; \
         statuses {:?}",
        result.stop_reason,
        result.history.iterations.len(),
        result.history.status_counts()
    );
    assert!(
        final_error < 1e-2 * initial_error,
        "{initial_error:e} -> {final_error:e}"
    );
    assert!(
        final_error < 5e-3,
        "held-out relative error {final_error:e}"
    );
    for (status, metric, entropy) in result.history.status_counts() {
        assert_eq!(
            status,
            metriplectic_runtime::SolveStatus::Solved,
            "{metric} metric and {entropy} entropy solves ended {status}"
        );
    }
}

#[test]
fn model_file_round_trips_and_rejects_the_wrong_system() {
    let model = Model::<RigidBody>::reference().unwrap();
    let json = model.to_json().unwrap();
    assert_eq!(Model::<RigidBody>::from_json(&json).unwrap(), model);
    let err = Model::<Linear2d>::from_json(&json).unwrap_err();
    let message = err.to_string();
    assert!(matches!(err, Error::WrongSystem { .. }), "{message}");
    assert!(
        message.contains("Linear2d") && message.contains("RigidBody"),
        "{message}"
    );
}

/// The data protocol at reduced size: noise-free trajectories of the
/// reference 2-D model from initial states uniform in [−1.5, 1.5]², sampled
/// at log-uniform times in [1e-3, 5]; (training, held-out).
fn linear2d_trajectories(
    train: usize,
    held_out: usize,
    per: usize,
    seed: u64,
) -> (Dataset, Dataset) {
    let truth = Model::<Linear2d>::reference().unwrap();
    let options = SynthesisOptions {
        trajectories: train + held_out,
        held_out_trajectories: held_out,
        duration: 5.0,
        seed,
        ..SynthesisOptions::new(
            InitialStates::cube(2, 1.5),
            SampleTimes::LogUniform {
                count: per,
                first: 1e-3,
            },
        )
    };
    let data = synthesize(&truth, &options).unwrap();
    (data.train, data.held_out.unwrap())
}

/// ‖f_fit − f_true‖ / ‖f_true‖ (Euclidean, over all held-out states).
fn vector_field_error<S: MetriplecticSystem>(model: &Model<S>, held_out: &Dataset) -> f64 {
    let truth = Model::<S>::reference().unwrap();
    let (mut fit, mut reference) = (vec![0.0; S::DIM], vec![0.0; S::DIM]);
    let (mut diff2, mut true2) = (0.0, 0.0);
    for (x, _) in held_out.iter() {
        model.vector_field(x, &mut fit).unwrap();
        truth.vector_field(x, &mut reference).unwrap();
        for (f, t) in fit.iter().zip(&reference) {
            diff2 += (f - t).powi(2);
            true2 += t.powi(2);
        }
    }
    (diff2 / true2).sqrt()
}

fn with_joint_steps(config: IdentifyConfig) -> IdentifyConfig {
    IdentifyConfig {
        scheme: IterationScheme::AlternatingThenJoint(TrustRegion::default()),
        ..config
    }
}

/// Theorem 1 with the joint step: on the full batch every step (metric,
/// entropy, joint) leaves the cost non-increasing, and joint steps are taken.
#[test]
fn joint_scheme_full_batch_cost_is_non_increasing() {
    let (data, _) = linear2d_trajectories(8, 1, 30, 31);
    let config = with_joint_steps(IdentifyConfig {
        max_iterations: 8,
        tolerance: 0.0,
        initial_entropy: Some(perturbed_reference_entropy::<Linear2d>(0.5, 31)),
        ..alternation()
    });
    let result = identify::<Linear2d>(&data, &config).unwrap();
    assert_eq!(result.history.iterations.len(), 8);
    assert_non_increasing(&result.history);
    let joints: Vec<_> = result
        .history
        .iterations
        .iter()
        .map(|r| r.joint.as_ref().expect("the scheme takes a joint step"))
        .collect();
    let accepted = joints
        .iter()
        .filter(|j| j.step.outcome == StepOutcome::Accepted)
        .count();
    eprintln!(
        "full batch: cost {:.3e} -> {:.3e}, {accepted}/8 joint steps accepted, radii {:?}",
        result.history.iterations[0].cost_before.per_component,
        result.history.iterations[7].cost_after().per_component,
        joints.iter().map(|j| j.radius).collect::<Vec<_>>()
    );
    assert!(accepted >= 1, "no joint step was ever accepted");
    assert_eq!(
        result.history.joint_status_counts(),
        vec![(metriplectic_runtime::SolveStatus::Solved, 8)]
    );
}

/// Algorithm 2 on the 2-D system at reduced size (q = 300, 600 samples from
/// 20 trajectories, start = truth + N(0, 0.5²)). Measured in release: the
/// paper's alternation alone is still at a held-out error of 0.23 after 40
/// iterations (it crawls: each block is optimal, the pair is not jointly
/// stationary); with the joint step the error is ≤ 1e-6 within 5–14
/// iterations over seeds 1–7 and reaches ~1e-11 (rounding level) shortly
/// after. The test asserts 1e-8 within 30 iterations, and that the
/// alternation alone is far from it with the same budget.
#[test]
fn joint_scheme_identifies_linear2d_far_below_the_alternating_crawl() {
    let (train, held_out) = linear2d_trajectories(20, 20, 30, 32);
    let start = perturbed_reference_entropy::<Linear2d>(0.5, 32);
    let alternating = IdentifyConfig {
        batch_size: Some(300),
        max_iterations: 30,
        tolerance: 1e-10,
        seed: 32,
        initial_entropy: Some(start),
        ..alternation()
    };
    let joint = with_joint_steps(alternating.clone());

    let result = identify_with_observer::<Linear2d, _>(&train, &joint, |r, model| {
        let j = r.joint.as_ref().expect("the scheme takes a joint step");
        eprintln!(
            "joint scheme, iteration {}: batch cost {:.3e} -> {:.3e}, joint {:?} at radius {:.2e}, \
             held-out error {:.3e}, statuses {} {} {}",
            r.iteration,
            r.cost_before.per_component,
            r.cost_after().per_component,
            j.step.outcome,
            j.radius,
            vector_field_error(model, &held_out),
            r.metric.report.status,
            r.entropy.report.status,
            j.step.report.status
        );
        ControlFlow::Continue(())
    })
    .unwrap();
    let joint_error = vector_field_error(&result.model, &held_out);
    let iterations = result.history.iterations.len();
    let alternating_result = identify::<Linear2d>(&train, &alternating).unwrap();
    let alternating_error = vector_field_error(&alternating_result.model, &held_out);
    eprintln!(
        "after {iterations} iterations ({:?}) the joint scheme's held-out error is {joint_error:.3e}; \
         the alternation alone after {} is {alternating_error:.3e}",
        result.stop_reason,
        alternating_result.history.iterations.len()
    );
    assert!(joint_error <= 1e-8, "held-out error {joint_error:e}");
    assert!(
        alternating_error > 1e-3,
        "the alternation alone reached {alternating_error:e}: this test no longer shows the joint step's effect"
    );
    // Joint solves end Solved; the alternating subproblems are usable
    // (measured with this seed: one entropy search of 7 ended AlmostSolved,
    // at iteration 3; the q = 2000 runs had none).
    eprintln!(
        "statuses (metric, entropy): {:?}",
        result.history.status_counts()
    );
    for r in &result.history.iterations {
        let statuses = [r.metric.report.status, r.entropy.report.status];
        assert!(
            statuses.iter().all(|s| s.is_usable()),
            "iteration {}: {statuses:?}",
            r.iteration
        );
    }
    assert_eq!(
        result.history.joint_status_counts(),
        vec![(metriplectic_runtime::SolveStatus::Solved, iterations)]
    );
}

/// The `from_csv` example's third system: from noisy measured states of the
/// damped Duffing oscillator (weak form, default configuration, zero start)
/// identification recovers the reference entropy and metric themselves, not
/// only the vector field (the pair is unique for this system; see its docs).
///
/// Measured (seed 4, σ = 1e-3): largest coefficient errors 2.7e-3 (entropy)
/// and 5.4e-3 (metric: K₁₂, which K ⪰ 0 confines to |K₁₂| ≤ √(K₁₁K₂₂)
/// while K₁₁ = 0 sits on the boundary); stops on stagnation in under 1 s.
#[test]
fn duffing_reference_is_recovered_from_noisy_states() {
    use metriplectic::systems::Duffing;
    use metriplectic_runtime::{Noise, WeakDataset, WeakForm};

    let truth = Model::<Duffing>::reference().unwrap();
    let data = synthesize(
        &truth,
        &SynthesisOptions {
            trajectories: 16,
            duration: 8.0,
            noise: Noise {
                state_std: 1e-3,
                derivative_std: 0.0,
            },
            seed: 4,
            ..SynthesisOptions::new(
                InitialStates::cube(2, 2.0),
                SampleTimes::Uniform { interval: 0.05 },
            )
        },
    )
    .unwrap();
    let weak = WeakDataset::from_trajectories(&data.measured, &WeakForm::default()).unwrap();
    let fit = identify::<Duffing>(&weak, &IdentifyConfig::default()).unwrap();
    eprintln!("{}\n{:?}", fit.model, fit.stop_reason);
    let entropy_error = max_abs_difference(
        fit.model.entropy_coefficients(),
        truth.entropy_coefficients(),
    );
    let metric_error =
        max_abs_difference(fit.model.metric_coefficients(), truth.metric_coefficients());
    eprintln!("entropy error {entropy_error:.3e}, metric error {metric_error:.3e}");
    assert!(entropy_error < 2e-2, "entropy off by {entropy_error:e}");
    assert!(metric_error < 2e-2, "metric off by {metric_error:e}");
}

metriplectic! {
    /// An anharmonic oscillator with friction growing with the position,
    /// certified on a ball: a curved valley of the bilinear cost, where the
    /// joint step's linearised metric is spoilt and the run crawled.
    pub struct PositionFriction;
    state (x, v);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * v^2 + 0.5 * x^2 + 0.1 * x^4;
    entropy degree 4;
    metric degree 2;
    region ball(radius = 2.5);
    reference {
        entropy = -(x^2 + v^2) - 0.2 * x^4;
        metric = [[0.05, 0], [0, 0.1 + 0.1 * x^2]];
    }
}

/// The friction system's dataset, its default identification (run once for
/// the tests that read it) and that run's held-out error.
fn friction_run() -> &'static (SyntheticData, Identification<PositionFriction>, f64) {
    static RUN: OnceLock<(SyntheticData, Identification<PositionFriction>, f64)> = OnceLock::new();
    RUN.get_or_init(|| {
        let data = reference_trajectories::<PositionFriction>(1.5, 3);
        let run = identify::<PositionFriction>(&data.train, &IdentifyConfig::default())
            .expect("the identification runs");
        let held_out = data.held_out.as_ref().expect("five held-out trajectories");
        let error = relative_error(&run.model, held_out);
        (data, run, error)
    })
}

/// The joint step's metric refit (variable projection): on this dataset the
/// run without it ended at the 100-iteration cap with held-out error 1.6e-6,
/// its trust radius at 1e-3 and each step moving one entropy coefficient by
/// 1e-4 (`docs/method.md` §3, "The metric refit"); with it the run converges.
#[test]
fn the_metric_refit_gets_a_state_dependent_metric_out_of_a_curved_valley() {
    let (_, run, error) = friction_run();
    let error = *error;
    let refits = run
        .history
        .iterations
        .iter()
        .filter(|r| r.joint.as_ref().is_some_and(|j| j.metric_refit))
        .count();
    eprintln!(
        "{} iterations, {refits} metric refits, held-out error {error:e}",
        run.history.iterations.len()
    );
    assert_eq!(
        run.stop_reason,
        StopReason::Converged,
        "held-out error {error:e}"
    );
    assert!(error < 1e-9, "held-out error {error:e}");
    assert!(refits > 0, "no joint step refitted its metric");
}

/// The joint step's second-order correction: in the same curved valley the
/// runs with the metric refit alone took 77–93 iterations, each joint step
/// moving the same few coefficients by the same short, trust-region-bound
/// amount (a linear step leaves the curved set of exact fits by a
/// second-order amount); the corrected steps follow it, and the run
/// converges in 30 at most, where without the correction it does not.
#[test]
fn the_second_order_correction_follows_a_curved_valley() {
    let (data, run, error) = friction_run();
    let error = *error;
    let corrected = run
        .history
        .iterations
        .iter()
        .filter(|r| {
            r.joint
                .as_ref()
                .is_some_and(|j| j.second_order && j.step.outcome == StepOutcome::Accepted)
        })
        .count();
    let iterations = run.history.iterations.len();
    eprintln!(
        "{iterations} iterations, {corrected} corrected steps kept, held-out error {error:e}"
    );
    assert_eq!(
        run.stop_reason,
        StopReason::Converged,
        "held-out error {error:e}"
    );
    assert!(error < 1e-9, "held-out error {error:e}");
    assert!(corrected > 0, "no corrected joint step was kept");
    assert!(iterations <= 30, "{iterations} iterations");

    // Without it the same data do not converge in those 30 iterations.
    let without = IdentifyConfig {
        max_iterations: 30,
        scheme: IterationScheme::AlternatingThenJoint(TrustRegion {
            second_order: false,
            ..TrustRegion::default()
        }),
        ..IdentifyConfig::default()
    };
    let crawl =
        identify::<PositionFriction>(&data.train, &without).expect("the identification runs");
    assert_eq!(crawl.stop_reason, StopReason::MaxIterations);
    assert!(crawl
        .history
        .iterations
        .iter()
        .all(|r| r.joint.as_ref().is_some_and(|j| !j.second_order)));
}

/// After a joint step whose refitted metric was kept, on the full batch the
/// next metric search would solve the refit's very problem again, so it is
/// skipped (`StepOutcome::Skipped`); and only then. Solving it anyway gives
/// the model's metric to the bit.
#[test]
fn the_metric_search_after_a_kept_refit_is_skipped_and_would_change_nothing() {
    let data = reference_trajectories::<PositionFriction>(1.5, 3);
    let mut models = Vec::new();
    let config = IdentifyConfig {
        max_iterations: 6,
        ..IdentifyConfig::default()
    };
    let run = identify_with_observer::<PositionFriction, _>(&data.train, &config, |_, model| {
        models.push(model.clone());
        ControlFlow::Continue(())
    })
    .expect("the identification runs");
    let iterations = &run.history.iterations;
    assert_ne!(iterations[0].metric.outcome, StepOutcome::Skipped);
    let mut skipped = 0;
    for i in 1..iterations.len() {
        let refit_kept = iterations[i - 1]
            .joint
            .as_ref()
            .is_some_and(|j| j.metric_refit && j.step.outcome == StepOutcome::Accepted);
        let record = &iterations[i];
        assert_eq!(
            record.metric.outcome == StepOutcome::Skipped,
            refit_kept,
            "iteration {}",
            record.iteration
        );
        if refit_kept {
            skipped += 1;
            assert_eq!(record.metric.report.iterations, 0);
            assert_eq!(record.metric.cost_after, record.cost_before);
            let model = &models[i - 1];
            let search = metric_search::<PositionFriction>(
                &data.train,
                model.entropy_coefficients(),
                &SearchOptions::default(),
            )
            .expect("the metric search runs");
            assert_eq!(search.coefficients, model.metric_coefficients());
        }
    }
    assert!(
        skipped > 0,
        "no refit was kept in {} iterations",
        iterations.len()
    );
}

metriplectic! {
    /// An anharmonic oscillator with a coupled metric, for weak-form data
    /// sampled too sparsely for the windows.
    pub struct SparselySampled;
    state (x, y);
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * y^2 + 0.5 * x^2 + 0.1 * x^4;
    entropy degree 4;
    metric degree 0;
    reference {
        entropy = -0.8 * x^2 - 0.8 * y^2 - 0.1 * x^4 - 0.2 * x^2 * y^2;
        metric = [[0.2, 0.05], [0.05, 0.4]];
    }
}

/// Clean states 1.4 time units apart (15 over 20, about 4.5 samples per
/// oscillation): the weak-form equations are off by tens of per cent, the
/// fit follows them (held-out error 0.3 in a probe) and used to stop with
/// no warning. Their targets move by 0.4 between local degrees 2 and 3,
/// which the run now reports; with 60 samples over 5 time units it does
/// not (spread 1e-4, held-out error 1e-4).
#[test]
fn weak_form_equations_off_by_their_quadrature_are_reported() {
    use metriplectic_runtime::{IdentifyWarning, WeakDataset, WeakForm};
    let truth = Model::<SparselySampled>::reference().unwrap();
    let weak = |duration: f64, count: usize| {
        let data = synthesize(
            &truth,
            &SynthesisOptions {
                trajectories: 24,
                duration,
                seed: 9,
                ..SynthesisOptions::new(
                    InitialStates::cube(2, 2.0),
                    SampleTimes::Uniform {
                        interval: duration / (count as f64 - 1.0) * 0.999999,
                    },
                )
            },
        )
        .unwrap();
        WeakDataset::from_trajectories(&data.measured, &WeakForm::default()).unwrap()
    };
    let reported = |data: &WeakDataset| {
        let fit = identify::<SparselySampled>(data, &IdentifyConfig::default()).unwrap();
        let spread = data.quadrature_spread().unwrap();
        println!("spread {spread:?}: {:?}", fit.warnings);
        fit.warnings.iter().any(|w| {
            matches!(
                w,
                IdentifyWarning::WeakQuadrature {
                    degree: 2,
                    other: 3,
                    ..
                }
            )
        })
    };
    let sparse = weak(20.0, 15);
    assert!(sparse.quadrature_spread().unwrap().0 > 0.1);
    assert!(reported(&sparse), "sparse samples are not reported");
    let dense = weak(5.0, 60);
    assert!(dense.quadrature_spread().unwrap().0 < 1e-3);
    assert!(!reported(&dense), "dense samples are reported");
}
