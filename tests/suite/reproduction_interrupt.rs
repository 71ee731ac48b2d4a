//! Ctrl-C in the paper reproductions: the run stops after the current
//! iteration, keeps its checkpoint and writes the current model and history;
//! `--resume` continues it to the same result as an uninterrupted run.
//! The signal is simulated with the stop flag the Ctrl-C handler sets.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use metriplectic::experiments;
use metriplectic::reproduction::{run_until, Options, ReproductionError, Scheme, Solver};
use metriplectic::systems::Linear2d;
use metriplectic_runtime::prelude::*;

fn output_dir(name: &str) -> PathBuf {
    crate::common::scratch_path("reproduction_interrupt", name)
}

fn tiny_options(out: &Path) -> Options {
    Options {
        seed: 5,
        batch_size: 40,
        iterations: Some(3),
        tolerance: 0.0,
        out: Some(out.to_owned()),
        force: false,
        plot_trajectories: 2,
        train_trajectories: 8,
        heldout_trajectories: 2,
        samples_per_trajectory: 15,
        scheme: Scheme::Joint,
        solver: Solver::Dense,
        quiet: true,
        resume: false,
        checkpoint_every: 2,
        cold_start: false,
        gauge_trace: None,
    }
}

#[test]
fn interrupted_reproduction_keeps_its_state_and_resumes_to_the_same_model() {
    let experiment = experiments::linear_2d();

    let straight = output_dir("interrupt-straight");
    let summary = run_until::<Linear2d>(
        &experiment,
        &tiny_options(&straight),
        &AtomicBool::new(false),
    )
    .unwrap();
    assert_eq!(summary.iterations, 3);

    // "Ctrl-C" before the first iteration ends: it stops after iteration 1.
    let out = output_dir("interrupt-resumed");
    let err = run_until::<Linear2d>(&experiment, &tiny_options(&out), &AtomicBool::new(true))
        .unwrap_err();
    assert!(
        matches!(err, ReproductionError::Interrupted { iterations: 1, .. }),
        "{err}"
    );
    let interrupted_model = Model::<Linear2d>::load(out.join("model.json")).unwrap();
    assert!(interrupted_model
        .entropy_coefficients()
        .iter()
        .all(|c| c.is_finite()));
    let history = std::fs::read_to_string(out.join("history.csv")).unwrap();
    assert_eq!(history.lines().count(), 2, "header and one iteration");
    assert!(out.join("checkpoint.json").is_file());
    assert!(!out.join("summary.json").exists());

    // A fresh run refuses the non-empty directory; --resume continues it.
    let err = run_until::<Linear2d>(&experiment, &tiny_options(&out), &AtomicBool::new(false))
        .unwrap_err();
    assert!(matches!(err, ReproductionError::OutputNotEmpty(_)), "{err}");
    let resumed = run_until::<Linear2d>(
        &experiment,
        &Options {
            resume: true,
            ..tiny_options(&out)
        },
        &AtomicBool::new(false),
    )
    .unwrap();
    assert_eq!(resumed.iterations, 3);
    assert_eq!(resumed.final_entropy_cost, summary.final_entropy_cost);
    assert_eq!(
        resumed.heldout_relative_error,
        summary.heldout_relative_error
    );
    let read = |dir: &Path| std::fs::read_to_string(dir.join("model.json")).unwrap();
    assert_eq!(read(&out), read(&straight), "same model, bit for bit");

    // A forced run over the finished one, interrupted, leaves its own
    // outputs only: the old summary and figures are removed first (they
    // stayed beside the new model; a probe), the user's other files stay.
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    assert!(out.join("summary.json").is_file() && out.join("loss.png").is_file());
    let err = run_until::<Linear2d>(
        &experiment,
        &Options {
            force: true,
            ..tiny_options(&out)
        },
        &AtomicBool::new(true),
    )
    .unwrap_err();
    assert!(
        matches!(err, ReproductionError::Interrupted { .. }),
        "{err}"
    );
    assert!(out.join("model.json").is_file() && out.join("checkpoint.json").is_file());
    assert!(!out.join("summary.json").exists() && !out.join("loss.png").exists());
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "mine"
    );

    // --resume without a checkpoint is an option error, not a fresh run.
    let empty = output_dir("interrupt-nothing");
    let err = run_until::<Linear2d>(
        &experiment,
        &Options {
            resume: true,
            ..tiny_options(&empty)
        },
        &AtomicBool::new(false),
    )
    .unwrap_err();
    assert!(matches!(err, ReproductionError::Option(_)), "{err}");
}

/// Counts of zero are refused by their option's name before any work
/// (they were named by the library's fields, blamed on another option, or
/// silently raised to one; a probe), and so is a gauge trace that is not
/// a finite positive number, in the number format.
#[test]
fn zero_counts_are_refused_by_their_options_name() {
    let experiment = experiments::linear_2d();
    let out = output_dir("zero-counts");
    let base = tiny_options(&out);
    let cases = [
        (
            "--iterations 0",
            Options {
                iterations: Some(0),
                ..base.clone()
            },
        ),
        (
            "--batch-size 0",
            Options {
                batch_size: 0,
                ..base.clone()
            },
        ),
        (
            "--plot-trajectories 0",
            Options {
                plot_trajectories: 0,
                ..base.clone()
            },
        ),
        (
            "--train-trajectories 0",
            Options {
                train_trajectories: 0,
                ..base.clone()
            },
        ),
        (
            "--heldout-trajectories 0",
            Options {
                heldout_trajectories: 0,
                ..base.clone()
            },
        ),
        (
            "--samples-per-trajectory 0",
            Options {
                samples_per_trajectory: 0,
                ..base.clone()
            },
        ),
        (
            "--checkpoint-every 0",
            Options {
                checkpoint_every: 0,
                ..base.clone()
            },
        ),
        (
            "--gauge-trace inf",
            Options {
                gauge_trace: Some(f64::INFINITY),
                ..base.clone()
            },
        ),
    ];
    for (named, options) in cases {
        let err =
            run_until::<Linear2d>(&experiment, &options, &AtomicBool::new(false)).unwrap_err();
        let text = err.to_string();
        assert!(text.contains(named), "{named}: {text}");
        assert!(!out.exists(), "{named}: nothing is made before the check");
    }
}
