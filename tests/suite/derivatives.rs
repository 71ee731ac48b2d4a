//! Derivative estimation on known smooth signals: error bounds, convergence
//! order of the finite differences (ends included, uniform and non-uniform
//! steps), and the noise suppression of the Savitzky–Golay differentiator
//! against its predicted noise level.

use crate::common::Linear2d;
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::Trajectory;
use metriplectic_runtime::{differentiate, estimate_derivatives, DerivativeMethod};
use metriplectic_runtime::{simulate, OutputTimes, SimulationOptions};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

fn uniform(h: f64, end: f64) -> Vec<f64> {
    let n = (end / h).round() as usize;
    (0..=n).map(|k| k as f64 * h).collect()
}

/// A smooth non-uniform grid: t = u + 0.3 sin u on a uniform grid in u.
fn stretched(h: f64, end: f64) -> Vec<f64> {
    uniform(h, end)
        .into_iter()
        .map(|u| u + 0.3 * u.sin())
        .collect()
}

fn max_error(t: &[f64], method: DerivativeMethod) -> f64 {
    let x: Vec<f64> = t.iter().map(|t| t.sin()).collect();
    let d = differentiate(t, &x, &method).unwrap();
    d.iter()
        .zip(t)
        .map(|(d, t)| (d - t.cos()).abs())
        .fold(0.0, f64::max)
}

#[test]
fn finite_differences_meet_their_truncation_bounds() {
    // Worst truncation constants of the (p+1)-point stencils, reached by the
    // fully one-sided ones at the ends: h²/3, h⁴/5, h⁶/7 times max|x⁽ᵖ⁺¹⁾| = 1.
    let h = 0.05;
    let t = uniform(h, 6.0);
    for (order, bound) in [
        (2, h.powi(2) / 3.0),
        (4, h.powi(4) / 5.0),
        (6, h.powi(6) / 7.0),
    ] {
        let err = max_error(&t, DerivativeMethod::FiniteDifference { order });
        println!("order {order}, h = {h}: max error {err:.3e} (bound {bound:.3e})");
        // 1e-13: rounding of the stencil sums, far below the truncation error.
        assert!(err <= bound + 1e-13, "order {order}: {err} > {bound}");
    }
}

#[test]
fn finite_differences_converge_at_their_order_including_the_ends() {
    for (grid, name) in [
        (uniform as fn(f64, f64) -> Vec<f64>, "uniform"),
        (stretched as fn(f64, f64) -> Vec<f64>, "non-uniform"),
    ] {
        for order in [2usize, 4, 6] {
            let method = DerivativeMethod::FiniteDifference { order };
            let coarse = max_error(&grid(0.08, 6.0), method);
            let fine = max_error(&grid(0.04, 6.0), method);
            let rate = (coarse / fine).log2();
            println!("{name} order {order}: max error {coarse:.3e} → {fine:.3e}, observed order {rate:.2}");
            assert!(
                (rate - order as f64).abs() < 0.35,
                "{name} order {order}: observed {rate}"
            );
        }
    }
}

#[test]
fn savitzky_golay_is_accurate_on_clean_data_including_the_ends() {
    let t = stretched(0.02, 6.0);
    // Bounds: the measured maxima (3.5e-6, 6.0e-5, 1.3e-2 on this grid) with a
    // ×2.5 margin, to catch regressions; the order check below is the theory.
    let mut overall = Vec::new();
    for (window, degree, bound) in [(11, 4, 1e-5), (21, 4, 1.5e-4), (15, 2, 3e-2)] {
        let method = DerivativeMethod::SavitzkyGolay { window, degree };
        let x: Vec<f64> = t.iter().map(|t| t.sin()).collect();
        let d = differentiate(&t, &x, &method).unwrap();
        let errors: Vec<f64> = d.iter().zip(&t).map(|(d, t)| (d - t.cos()).abs()).collect();
        let interior = errors[window..errors.len() - window]
            .iter()
            .copied()
            .fold(0.0, f64::max);
        let ends = errors.iter().copied().fold(0.0, f64::max);
        println!("SG w={window} d={degree}: interior max {interior:.2e}, overall max {ends:.2e}");
        assert!(ends < bound, "w={window} d={degree}: {ends}");
        overall.push(ends);
        // Sliding windows keep the end error within a modest factor of the interior.
        assert!(
            ends < 50.0 * interior.max(1e-12),
            "ends {ends} vs interior {interior}"
        );
    }
    // Bias of a degree-d fit grows like (window span)^d: doubling the span
    // (11 → 21 samples) at d = 4 multiplies the error by about 2⁴ = 16.
    let growth = overall[1] / overall[0];
    println!("error growth when doubling the window at degree 4: {growth:.1}");
    assert!((8.0..32.0).contains(&growth), "{growth}");
}

/// Noisy sin: Savitzky–Golay error matches its predicted noise level
/// σ·√(Σ wᵢ²) (weights measured by differentiating unit impulses) plus its
/// clean-data bias, and beats the finite differences by a wide margin.
#[test]
fn savitzky_golay_suppresses_noise_as_predicted() {
    let h = 0.02;
    let t = uniform(h, 3.0);
    let m = t.len();
    let sigma = 1e-3;
    let method = DerivativeMethod::SavitzkyGolay {
        window: 21,
        degree: 3,
    };
    // Predicted noise variance per sample from the linear weights.
    let mut variance = vec![0.0; m];
    for j in 0..m {
        let mut impulse = vec![0.0; m];
        impulse[j] = 1.0;
        let w = differentiate(&t, &impulse, &method).unwrap();
        for (v, wi) in variance.iter_mut().zip(&w) {
            *v += wi * wi;
        }
    }
    let clean: Vec<f64> = t.iter().map(|t| t.sin()).collect();
    let bias = differentiate(&t, &clean, &method).unwrap();
    let noise = Normal::new(0.0, sigma).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let (mut sg_sq, mut fd_sq, mut predicted_sq) = (0.0, 0.0, 0.0);
    let realisations = 40;
    for _ in 0..realisations {
        let x: Vec<f64> = clean.iter().map(|v| v + noise.sample(&mut rng)).collect();
        let sg = differentiate(&t, &x, &method).unwrap();
        let fd = differentiate(&t, &x, &DerivativeMethod::FiniteDifference { order: 2 }).unwrap();
        for i in 0..m {
            sg_sq += (sg[i] - t[i].cos()).powi(2);
            fd_sq += (fd[i] - t[i].cos()).powi(2);
            predicted_sq += (bias[i] - t[i].cos()).powi(2) + sigma * sigma * variance[i];
        }
    }
    let count = (realisations * m) as f64;
    let (sg_rms, fd_rms, predicted) = (
        (sg_sq / count).sqrt(),
        (fd_sq / count).sqrt(),
        (predicted_sq / count).sqrt(),
    );
    println!(
        "σ = {sigma}, h = {h}: SG rms error {sg_rms:.3e} (predicted {predicted:.3e}), FD2 rms error {fd_rms:.3e}"
    );
    assert!(
        (sg_rms / predicted - 1.0).abs() < 0.15,
        "{sg_rms} vs {predicted}"
    );
    assert!(sg_rms < fd_rms / 5.0, "SG {sg_rms} vs FD {fd_rms}");
    // Absolute bound for this setting: below 1 % of the signal's derivative amplitude.
    assert!(sg_rms < 1e-2, "{sg_rms}");
}

#[test]
fn estimated_derivatives_of_a_simulated_trajectory_match_the_vector_field() {
    let model = Model::<Linear2d>::reference().unwrap();
    let options = SimulationOptions {
        output: OutputTimes::Interval(0.002),
        integrator: metriplectic_runtime::IntegratorOptions {
            rtol: 1e-12,
            atol: 1e-14,
            ..Default::default()
        },
        ..SimulationOptions::default()
    };
    let sim = simulate(&model, &[0.3, 0.9], 0.0, 1.0, &options).unwrap();
    let exact = sim.trajectory.derivatives().unwrap().to_vec();
    let scale = exact.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let states_only: Trajectory = sim.trajectory.clone().without_derivatives();
    for (method, bound) in [
        (DerivativeMethod::FiniteDifference { order: 2 }, 1e-3),
        (DerivativeMethod::FiniteDifference { order: 6 }, 1e-7),
        (
            DerivativeMethod::SavitzkyGolay {
                window: 9,
                degree: 4,
            },
            1e-5,
        ),
    ] {
        let estimated = estimate_derivatives(&states_only, &method).unwrap();
        let err = estimated
            .derivatives()
            .unwrap()
            .iter()
            .zip(&exact)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
            / scale;
        println!("{method:?}: max relative error {err:.2e}");
        assert!(err < bound, "{method:?}: {err}");
        // Ready for identification.
        assert_eq!(estimated.to_dataset().unwrap().len(), sim.trajectory.len());
    }
}

/// Times so close that the stencil weights overflow: the error blames the
/// spacing (and where it is), instead of returning NaN derivatives.
#[test]
fn derivatives_that_would_be_nan_blame_the_time_spacing() {
    let times = vec![0.0, 1e-310, 1.0, 2.0, 3.0, 4.0];
    let values = vec![0.0, 0.0, 1.0, 2.0, 3.0, 4.0];
    let err = differentiate(
        &times,
        &values,
        &DerivativeMethod::FiniteDifference { order: 2 },
    )
    .unwrap_err();
    let message = err.to_string();
    assert!(
        message.contains("time spacing") && message.contains("samples 0..=2"),
        "{message}"
    );
}
