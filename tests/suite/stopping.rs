//! Runs stop by themselves once their model is final: on noisy data (which
//! never reaches the tolerance) and on data with gross outliers, the default
//! configuration stops by stagnation within a few iterations of its best
//! model, instead of spending the iteration budget.

use metriplectic::experiments;
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    synthesize, History, IdentifyWarning, IterationRecord, Noise, Outliers, SampleTimes,
    StopReason, SynthesisOptions,
};

use crate::common::Linear2d;

/// Paper-like 2-D data, reduced: 30 training and 10 held-out trajectories of
/// 30 log-uniform samples, with the given corruption.
fn data(noise: Noise, outliers: Option<Outliers>) -> (Dataset, Dataset) {
    let experiment = experiments::linear_2d();
    let truth = Model::<Linear2d>::reference().unwrap();
    let options = SynthesisOptions {
        trajectories: 40,
        held_out_trajectories: 10,
        duration: experiment.duration,
        seed: 3,
        noise,
        outliers,
        ..SynthesisOptions::new(
            experiment.initial_states,
            SampleTimes::LogUniform {
                count: 30,
                first: experiment.first_sample_time,
            },
        )
    };
    let data = synthesize(&truth, &options).unwrap();
    (data.train, data.held_out.unwrap())
}

/// Root mean square of the training derivatives.
fn derivative_rms(data: &Dataset) -> f64 {
    let d = data.derivatives();
    (d.iter().map(|v| v * v).sum::<f64>() / d.len() as f64).sqrt()
}

/// The cost that judges an iteration: on the validation samples when the
/// run scored them, else on its batch.
fn judged_cost(record: &IterationRecord) -> f64 {
    record.validation_cost.unwrap_or(record.cost_after()).sum
}

/// The iteration (1-based) after which the judged cost was lowest.
fn best_iteration(history: &History) -> usize {
    let mut best = (0, f64::INFINITY);
    for record in &history.iterations {
        let cost = judged_cost(record);
        if cost < best.1 {
            best = (record.iteration, cost);
        }
    }
    best.0
}

/// Identifies with the defaults (up to 100 iterations) and checks that the
/// run stopped by itself within the stagnation window of its best iteration.
fn run_stops_by_itself(train: &Dataset, held_out: &Dataset, what: &str) -> f64 {
    let config = IdentifyConfig {
        max_iterations: 100,
        ..IdentifyConfig::default()
    };
    let window = config.stagnation.map_or(0, |s| s.window);
    let fit = identify::<Linear2d>(train, &config).unwrap();
    let truth = Model::<Linear2d>::reference().unwrap();
    let error = fit.model.compare(&truth, held_out).unwrap().relative_error;
    let iterations = fit.history.iterations.len();
    let best = best_iteration(&fit.history);
    println!(
        "{what}: stop {:?} after {iterations} iterations, best cost at {best}, held-out error {error:.2e}",
        fit.stop_reason
    );
    for record in &fit.history.iterations {
        println!(
            "  iteration {:>2}: cost {:.6e}",
            record.iteration,
            judged_cost(record)
        );
    }
    assert!(
        matches!(
            fit.stop_reason,
            StopReason::Stagnated | StopReason::Converged
        ),
        "{what}: stopped by {:?}",
        fit.stop_reason
    );
    assert!(
        iterations <= best + window + 1,
        "{what}: {iterations} iterations, best at {best}"
    );
    error
}

#[test]
fn noisy_derivatives_stop_by_stagnation_near_the_best_model() {
    let (clean, _) = data(Noise::default(), None);
    let noise = Noise {
        state_std: 0.0,
        derivative_std: 0.01 * derivative_rms(&clean),
    };
    let (train, held_out) = data(noise, None);
    let error = run_stops_by_itself(&train, &held_out, "1% noise on ẋ");
    // The noise limits the fit, not the stopping rule: a percent-level error.
    assert!(error < 2e-2, "held-out error {error:e}");
}

#[test]
fn gross_outliers_stop_by_stagnation_after_the_l1_fit_recovers_the_field() {
    let (clean, _) = data(Noise::default(), None);
    let outliers = Outliers {
        fraction: 0.1,
        magnitude: 10.0 * derivative_rms(&clean),
    };
    let (train, held_out) = data(Noise::default(), Some(outliers));
    let error = run_stops_by_itself(&train, &held_out, "10% gross outliers");
    // The L1 fit ignores the outliers: the clean field is recovered.
    assert!(error < 1e-6, "held-out error {error:e}");
    // …and is not called poor for the outliers it ignores (their L2 share
    // of the residual is 0.95).
    let fit = identify::<Linear2d>(&train, &IdentifyConfig::default()).unwrap();
    assert!(
        !fit.warnings
            .iter()
            .any(|w| matches!(w, IdentifyWarning::PoorFit { .. })),
        "{:?}",
        fit.warnings
    );
}
