//! The paper reproductions at reduced size: the same systems and pipeline as
//! `examples/linear_2d.rs` and `examples/rigid_body_so3.rs`,
//! with smaller data, minibatches and iteration caps so they run in CI.

use std::path::{Path, PathBuf};

use metriplectic::experiments;
use metriplectic::reproduction::{run, Options, Scheme, Solver, Summary};
use metriplectic::systems::{Linear2d, RigidBody};
use metriplectic_runtime::prelude::*;

fn output_dir(name: &str) -> PathBuf {
    crate::common::scratch_path("reproduction", name)
}

fn reduced_options(out: &Path, batch_size: usize, iterations: usize) -> Options {
    Options {
        seed: 3,
        batch_size,
        iterations: Some(iterations),
        tolerance: 1e-9,
        out: Some(out.to_owned()),
        force: false,
        plot_trajectories: 12,
        train_trajectories: 40,
        heldout_trajectories: 4,
        samples_per_trajectory: 30,
        scheme: Scheme::Joint,
        solver: Solver::Dense,
        quiet: true,
        resume: false,
        checkpoint_every: 10,
        cold_start: false,
        gauge_trace: None,
    }
}

/// Every output file exists and parses; returns the parsed summary.
fn check_outputs<S: MetriplecticSystem>(out: &Path, summary: &Summary) -> Summary {
    for figure in ["trajectories.png", "loss.png", "free_energy.png"] {
        let bytes = std::fs::read(out.join(figure)).unwrap();
        assert!(
            bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
            "{figure} is not a PNG"
        );
        assert!(bytes.len() > 10_000, "{figure} is suspiciously small");
    }
    let svg = std::fs::read_to_string(out.join("trajectories.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.trim_end().ends_with("</svg>"));

    let history = std::fs::read_to_string(out.join("history.csv")).unwrap();
    assert_eq!(
        history.lines().count(),
        summary.iterations + usize::from(summary.polished) + 1,
        "one row per iteration, the polish, and the header"
    );

    let model = Model::<S>::load(out.join("model.json")).unwrap();
    assert!(model.entropy_coefficients().iter().all(|c| c.is_finite()));

    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut keys: Vec<&str> = value
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    keys.sort_unstable();
    let mut expected = vec![
        "system",
        "seed",
        "samples_train",
        "samples_heldout",
        "batch_size",
        "iterations",
        "polished",
        "stop_reason",
        "final_metric_cost",
        "final_entropy_cost",
        "heldout_relative_error",
        "heldout_mean_abs_residual",
        "heldout_metric_error",
        "metric_variation",
        "free_energy_decrease_fraction",
        "nonoptimal_solves",
        "seconds_total",
        "seconds_solver",
        "gauge_trace",
        "identifiable",
        "smallest_singular_value",
        "unidentifiable_directions",
    ];
    expected.sort_unstable();
    assert_eq!(
        keys, expected,
        "summary.json must have exactly the documented keys"
    );
    let parsed: Summary = serde_json::from_str(&text).unwrap();
    assert_eq!(&parsed, summary);
    parsed
}

#[test]
fn rigid_body_so3_reduced_reproduction_converges() {
    let out = output_dir("repro_so3");
    let summary = run::<RigidBody>(
        &experiments::rigid_body_so3(),
        &reduced_options(&out, 300, 30),
    )
    .unwrap();
    check_outputs::<RigidBody>(&out, &summary);
    assert_eq!(summary.system, "RigidBody");
    assert_eq!(summary.samples_train, 40 * 30);
    assert_eq!(summary.samples_heldout, 4 * 30);
    assert!(
        summary.heldout_relative_error <= 1e-6,
        "held-out relative error {:e} after {} iterations",
        summary.heldout_relative_error,
        summary.iterations
    );
    assert_eq!(summary.free_energy_decrease_fraction, 0.0);
    assert_eq!(summary.nonoptimal_solves, 0);
}

#[test]
fn linear_2d_reduced_reproduction_converges() {
    let out = output_dir("repro_linear_2d");
    let summary =
        run::<Linear2d>(&experiments::linear_2d(), &reduced_options(&out, 300, 30)).unwrap();
    let parsed = check_outputs::<Linear2d>(&out, &summary);
    assert_eq!(parsed.system, "Linear2d");
    assert!(
        summary.heldout_relative_error <= 1e-6,
        "held-out relative error {:e} after {} iterations",
        summary.heldout_relative_error,
        summary.iterations
    );
    assert_eq!(summary.free_energy_decrease_fraction, 0.0);
    assert_eq!(summary.nonoptimal_solves, 0);
}

#[test]
fn reproduction_refuses_a_non_empty_output_directory() {
    let out = output_dir("repro_not_empty");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("keep.txt"), "precious").unwrap();
    let err =
        run::<Linear2d>(&experiments::linear_2d(), &reduced_options(&out, 50, 1)).unwrap_err();
    assert!(err.to_string().contains("--force"), "{err}");
    assert_eq!(
        std::fs::read_to_string(out.join("keep.txt")).unwrap(),
        "precious"
    );
}

#[test]
fn polynomial_printing_names_terms_and_skips_small_ones() {
    let text = metriplectic::reproduction::polynomial_to_string(
        &["q", "p"],
        &[&[2, 0], &[1, 1], &[0, 3]],
        &[-0.5, 1e-9, 4.0],
        1e-6,
    );
    assert_eq!(text, "-0.5 q^2 + 4 p^3");
}
