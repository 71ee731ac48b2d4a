//! The `from_csv` example's pipeline (`metriplectic::from_csv`) in-process
//! at reduced size: a CSV of noisy measured states synthesised from a
//! reference model, identified, validated on held-out trajectories and
//! written out; bad input refused with errors that say what is wrong.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use clap::Parser;
use metriplectic::from_csv::{run_until, simulated_relative_error, FromCsvError, Options, Summary};
use metriplectic::systems::{Duffing, Linear2d};
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    synthesize, write_trajectories, InitialStates, Noise, SampleTimes, SynthesisOptions,
};

/// A fresh path under the test target's temporary directory.
fn scratch(name: &str) -> PathBuf {
    crate::common::scratch_path("from_csv", name)
}

/// `trajectories` measured trajectories of `S`'s reference model from
/// initial states uniform in [−`half_width`, `half_width`]ⁿ, sampled at
/// `times` over [0, `duration`], states with Gaussian noise of σ = `noise`,
/// no derivatives, written as CSV to `path`.
fn write_csv<S: MetriplecticSystem>(
    path: &Path,
    trajectories: usize,
    times: SampleTimes,
    duration: f64,
    half_width: f64,
    noise: f64,
) {
    let truth = Model::<S>::reference().unwrap();
    let data = synthesize(
        &truth,
        &SynthesisOptions {
            trajectories,
            duration,
            noise: Noise {
                state_std: noise,
                derivative_std: 0.0,
            },
            seed: 11,
            ..SynthesisOptions::new(InitialStates::cube(S::DIM, half_width), times)
        },
    )
    .unwrap();
    assert!(data.measured.iter().all(|t| t.derivatives().is_none()));
    write_trajectories(path, &data.measured, WriteMode::CreateNew).unwrap();
}

/// A small clean CSV of `S` for tests that are not about accuracy.
fn small_csv<S: MetriplecticSystem>(path: &Path) {
    write_csv::<S>(
        path,
        4,
        SampleTimes::Uniform { interval: 0.1 },
        1.9,
        1.0,
        0.0,
    );
}

fn quiet_options(data: &Path, out: &Path) -> Options {
    Options {
        quiet: true,
        ..Options::new(data, out)
    }
}

fn run(options: &Options) -> Result<Summary, FromCsvError> {
    run_until(options, &AtomicBool::new(false))
}

#[test]
fn noisy_duffing_states_identify_a_model_that_predicts_held_out_trajectories() {
    // 24 trajectories × 30 samples, 1% state noise (σ = 0.01 on states of
    // spread ≈ 0.8), no derivatives.
    let csv = scratch("duffing.csv");
    let times = SampleTimes::Uniform { interval: 0.2 };
    write_csv::<Duffing>(&csv, 24, times, 5.8, 2.0, 0.01);
    let out = scratch("duffing_out");
    // Through the command line, as the example parses it.
    let options = Options::parse_from([
        "from_csv",
        "--data",
        csv.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--seed",
        "3",
        "--quiet",
    ]);
    let summary = run(&options).unwrap();
    eprintln!("{summary:#?}");

    assert_eq!(summary.system, "duffing", "inferred from the columns");
    assert!(
        summary.data_method.starts_with("weak form"),
        "no derivatives: the weak form"
    );
    assert_eq!(summary.trajectories, 24);
    assert_eq!(summary.samples, 24 * 30);
    assert_eq!(summary.validation_trajectories, 5, "20% of 24, rounded");
    assert_eq!(summary.train_trajectories, 19);
    assert_eq!(summary.validation_simulated, 5);
    assert!(summary.validation_not_simulated.is_empty());
    assert_eq!(summary.free_energy_decrease_fraction, 0.0);
    // Measured: 3.5e-2, the noise floor (the true model's error on the same
    // trajectories is 3.6e-2; it starts from a noisy state too).
    let error = summary.validation_relative_error.unwrap();
    let floor = summary.reference_validation_relative_error.unwrap();
    assert!(error < 0.1, "validation relative error {error}");
    assert!(error < 2.0 * floor, "error {error}, true model's {floor}");

    for file in ["model.json", "equations.txt", "history.csv", "summary.json"] {
        assert!(out.join(file).is_file(), "{file} missing");
        assert!(summary.files.iter().any(|f| f == file), "{file} not listed");
    }
    for figure in [
        "validation_1.png",
        "validation_4.png",
        "validation_overlay.png",
        "loss.png",
        "free_energy.png",
    ] {
        let bytes = std::fs::read(out.join(figure)).unwrap();
        assert!(
            bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
            "{figure} is not a PNG"
        );
        assert!(
            summary.files.iter().any(|f| f == figure),
            "{figure} not listed"
        );
    }
    let model = Model::<Duffing>::load(out.join("model.json")).unwrap();
    let equations = std::fs::read_to_string(out.join("equations.txt")).unwrap();
    assert_eq!(equations, format!("{model}\n"));

    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in [
        "validation_relative_error",
        "iterations",
        "stop_reason",
        "seconds_total",
        "system",
        "data_method",
        "trajectories",
        "train_trajectories",
        "validation_trajectories",
    ] {
        assert!(value.get(key).is_some(), "summary.json lacks `{key}`");
    }
    assert_eq!(value["validation_relative_error"].as_f64(), Some(error));
    let parsed: Summary = serde_json::from_str(&text).unwrap();
    assert_eq!(parsed, summary);

    // The saved model gives the reported error again, and a model without
    // the friction (K = 0, the true entropy) is far worse: the bound above
    // means something.
    let all = read_trajectories::<Duffing>(&csv).unwrap();
    let validation: Vec<Trajectory> = all
        .into_iter()
        .filter(|t| {
            summary
                .validation_trajectory_ids
                .iter()
                .any(|id| Some(id.as_str()) == t.id())
        })
        .collect();
    assert_eq!(simulated_relative_error(&model, &validation), Some(error));
    let frictionless =
        Model::<Duffing>::new(Duffing::REFERENCE_ENTROPY.unwrap().to_vec(), vec![0.0; 3]).unwrap();
    let frictionless_error = simulated_relative_error(&frictionless, &validation).unwrap();
    eprintln!("frictionless model's error {frictionless_error}");
    assert!(frictionless_error > 0.5, "{frictionless_error}"); // measured 1.3
}

/// The paper's 2-D system from log-uniform samples (as the reproduction
/// samples it) with 1% noise is much harder: its transient is fast (|ẋ| up
/// to 10³) and its states then rest on a curve of equilibria, and its
/// entropy has degree 8. Measured: validation error 0.25 against the true
/// model's 0.03 (the weak form's early windows span milliseconds, where the
/// noise over the window's length swamps the targets; estimated
/// derivatives do no better). With 100 trajectories × 50 samples the
/// example reaches about 0.05 (see the README). This pins the number so that
/// a change of the pipeline or the method that moves it shows up.
#[test]
fn noisy_linear2d_states_give_a_usable_but_inexact_model() {
    let csv = scratch("linear_2d.csv");
    let times = SampleTimes::LogUniform {
        count: 30,
        first: 1e-3,
    };
    write_csv::<Linear2d>(&csv, 24, times, 5.0, 1.5, 0.01);
    let out = scratch("linear_2d_out");
    let options = Options {
        seed: 3,
        ..quiet_options(&csv, &out)
    };
    let summary = run(&options).unwrap();
    eprintln!("{summary:#?}");
    assert_eq!(summary.system, "linear_2d");
    let error = summary.validation_relative_error.unwrap();
    let floor = summary.reference_validation_relative_error.unwrap();
    assert!(floor < 0.05, "true model's error {floor}");
    assert!(error < 0.4, "validation relative error {error}");
    assert_eq!(summary.free_energy_decrease_fraction, 0.0);
}

#[test]
fn wrong_state_names_are_refused_naming_the_columns_and_the_system() {
    let csv = scratch("duffing_states.csv");
    small_csv::<Duffing>(&csv);
    let out = scratch("wrong_names_out");
    let options = Options {
        system: Some(metriplectic::from_csv::SystemName::Linear2d),
        ..quiet_options(&csv, &out)
    };
    let err = run(&options).unwrap_err();
    let message = err.to_string();
    eprintln!("{message}");
    assert!(matches!(err, FromCsvError::StateNames { .. }), "{err:?}");
    for part in [
        csv.to_str().unwrap(),
        "linear_2d",
        "(q, p)",
        "`q`",
        "`p`",
        "duffing (x, v)",
    ] {
        assert!(message.contains(part), "`{part}` not in: {message}");
    }
    assert!(!out.exists(), "a refused input leaves no output directory");

    // Without --system the columns choose Duffing.
    let options = Options {
        max_iterations: Some(2),
        plot_trajectories: 1,
        ..quiet_options(&csv, &out)
    };
    let summary = run(&options).unwrap();
    assert_eq!(summary.system, "duffing");
}

#[test]
fn bad_input_and_options_give_errors_that_say_what_is_wrong() {
    let out = scratch("bad_input_out");
    let cases: [(&str, &str, &str); 4] = [
        ("no_such.csv", "", "no_such.csv"),
        (
            "unknown_columns.csv",
            "trajectory,t,a,b\n0,0,1,2\n0,1,1,2\n1,0,1,2\n1,1,1,2\n",
            "not the state variables of any system",
        ),
        (
            "bad_cell.csv",
            "trajectory,t,q,p\n0,0,1,2\n0,1,oops,2\n1,0,1,2\n1,1,1,2\n",
            "line 3, column 3 (`q`): `oops` is not a number",
        ),
        (
            "one_trajectory.csv",
            "t,q,p\n0,1,2\n1,1,2\n",
            "at least two are needed",
        ),
    ];
    for (name, content, expected) in cases {
        let csv = scratch(name);
        if !content.is_empty() {
            std::fs::write(&csv, content).unwrap();
        }
        let err = run(&quiet_options(&csv, &out)).unwrap_err().to_string();
        assert!(err.contains(expected), "{name}: `{expected}` not in: {err}");
        assert!(
            err.contains(name),
            "{name}: the file is not named in: {err}"
        );
    }

    let csv = scratch("short.csv");
    write_csv::<Linear2d>(
        &csv,
        3,
        SampleTimes::Uniform { interval: 0.1 },
        0.9,
        1.0,
        0.0,
    );
    let err = run(&quiet_options(&csv, &out)).unwrap_err().to_string();
    for part in [
        "short.csv",
        "no trajectory is that long (the longest has 10)",
        "--window N",
        "--derivatives",
    ] {
        assert!(err.contains(part), "`{part}` not in: {err}");
    }
    // …which a shorter window follows.
    let options = Options::try_parse_from([
        "from_csv",
        "--data",
        csv.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--window",
        "5",
        "--max-iterations",
        "2",
        "--plot-trajectories",
        "0",
        "--quiet",
    ])
    .unwrap();
    let summary = run(&options).unwrap();
    assert!(
        summary.data_method.starts_with("weak form (window 5,"),
        "{}",
        summary.data_method
    );
    std::fs::remove_dir_all(&out).unwrap();

    let csv = scratch("states_only.csv");
    small_csv::<Linear2d>(&csv);
    let options = Options::try_parse_from([
        "from_csv",
        "--data",
        csv.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--derivatives",
        "exact",
    ])
    .unwrap();
    let err = run(&options).unwrap_err().to_string();
    assert!(err.contains("no derivative columns (dq, dp)"), "{err}");
    let options = Options {
        validation_fraction: 1.0,
        ..quiet_options(&csv, &out)
    };
    let err = run(&options).unwrap_err().to_string();
    assert!(err.contains("--validation-fraction 1"), "{err}");

    // The command line rejects what it can before anything runs.
    for args in [
        vec!["--weak", "--derivatives", "fd4"],
        vec!["--derivatives", "fd3"],
        vec!["--derivatives", "sg:7:x"],
        vec!["--system", "pendulum"],
    ] {
        let mut argv = vec!["from_csv", "--data", "a.csv", "--out", "o"];
        argv.extend(args.iter().copied());
        assert!(Options::try_parse_from(&argv).is_err(), "{args:?} accepted");
    }
    let argv = [
        "from_csv",
        "--data",
        "a.csv",
        "--out",
        "o",
        "--derivatives",
        "spline",
    ];
    assert!(Options::try_parse_from(argv).is_ok(), "spline refused");
    assert!(!out.exists(), "failed runs leave no output directory");
}

/// States whose basis functions overflow are named by trajectory and
/// time, not by their index among the equations ("sample 0 (x = …)",
/// which the CSV does not show).
#[test]
fn an_overflowing_state_is_named_by_its_trajectory_and_time() {
    let csv = scratch("huge_states.csv");
    let mut content = String::from("trajectory,t,q,p\n");
    for trajectory in 0..4 {
        for k in 0..20 {
            let q = 1e150 * (1.0 + 0.01 * k as f64);
            content.push_str(&format!("{trajectory},{},{q:e},1e150\n", 0.1 * k as f64));
        }
    }
    std::fs::write(&csv, content).unwrap();
    let options = Options {
        system: Some(metriplectic::from_csv::SystemName::Linear2d),
        ..quiet_options(&csv, &scratch("huge_states_out"))
    };
    let err = run(&options).unwrap_err().to_string();
    println!("{err}");
    for part in [
        "huge_states.csv: trajectory `",
        "sample 1 (t = 0)",
        "overflow",
    ] {
        assert!(err.contains(part), "`{part}` not in: {err}");
    }

    // A cell near f64::MAX overflows the weak form's target: that is named,
    // without the hint for trajectories shorter than a window (a probe's
    // run suggested --derivatives for it).
    let csv = scratch("max_cell.csv");
    let mut content = String::from("trajectory,t,q,p\n");
    for trajectory in 0..4 {
        for k in 0..20 {
            // Large enough for Σ φ′ⱼ qⱼ to overflow before any basis function.
            let q = if k < 10 { 1.7e308 } else { -1.7e308 };
            content.push_str(&format!("{trajectory},{},{q:e},1\n", 1e-3 * k as f64));
        }
    }
    std::fs::write(&csv, content).unwrap();
    let options = Options {
        system: Some(metriplectic::from_csv::SystemName::Linear2d),
        ..quiet_options(&csv, &scratch("max_cell_out"))
    };
    let err = run(&options).unwrap_err().to_string();
    println!("{err}");
    assert!(err.contains("max_cell.csv"), "{err}");
    assert!(err.contains("weak-form target"), "{err}");
    assert!(!err.contains("--derivatives"), "{err}");
}

#[test]
fn a_non_empty_output_directory_is_refused_and_its_files_kept() {
    let csv = scratch("keep.csv");
    small_csv::<Linear2d>(&csv);
    let out = scratch("keep_out");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "precious").unwrap();
    let err = run(&quiet_options(&csv, &out)).unwrap_err();
    assert!(matches!(err, FromCsvError::OutputNotEmpty(_)), "{err:?}");
    assert!(err.to_string().contains("--overwrite"), "{err}");

    let file = scratch("a_file");
    std::fs::write(&file, "x").unwrap();
    let err = run(&quiet_options(&csv, &file)).unwrap_err();
    assert!(err.to_string().contains("not a directory"), "{err}");

    // --overwrite writes next to the user's files and leaves them alone,
    // but removes an earlier run's figures first (a probe's new run sat
    // beside another system's validation_2..4.png).
    std::fs::write(out.join("validation_9.png"), "stale").unwrap();
    std::fs::write(out.join("my_plot.png"), "mine").unwrap();
    let options = Options {
        overwrite: true,
        max_iterations: Some(2),
        plot_trajectories: 1,
        ..quiet_options(&csv, &out)
    };
    run(&options).unwrap();
    assert!(out.join("model.json").is_file());
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "precious"
    );
    assert!(!out.join("validation_9.png").exists());
    assert_eq!(
        std::fs::read_to_string(out.join("my_plot.png")).unwrap(),
        "mine"
    );

    // …but not over its own input: a probe's `--data fit/history.csv
    // --out fit --overwrite` replaced the data by the iteration history.
    let input = out.join("history.csv");
    std::fs::copy(&csv, &input).unwrap();
    let data = std::fs::read(&input).unwrap();
    let err = run(&Options {
        data: input.clone(),
        ..options.clone()
    })
    .unwrap_err();
    assert!(matches!(err, FromCsvError::InputIsAnOutput(_)), "{err:?}");
    assert!(err.to_string().contains("choose another --out"), "{err}");
    assert_eq!(std::fs::read(&input).unwrap(), data);

    // Nor through a link named like an output: outputs are written through
    // links, so `summary.json -> ../keep.csv` would replace the input.
    #[cfg(unix)]
    {
        std::fs::remove_file(&input).unwrap();
        let link = out.join("summary.json");
        std::fs::remove_file(&link).unwrap();
        std::os::unix::fs::symlink(std::fs::canonicalize(&csv).unwrap(), &link).unwrap();
        let data = std::fs::read(&csv).unwrap();
        let err = run(&options).unwrap_err();
        assert!(matches!(err, FromCsvError::InputIsAnOutput(_)), "{err:?}");
        assert!(err.to_string().contains("link to it"), "{err}");
        assert_eq!(std::fs::read(&csv).unwrap(), data);
    }
}

#[test]
fn a_csv_with_derivatives_is_identified_from_them_unless_told_otherwise() {
    use metriplectic::from_csv::SystemName;
    use metriplectic::synthetic_csv::{synthesize_csv, SynthesizeOptions};

    let csv = scratch("rigid_body_with_derivatives.csv");
    let rows = synthesize_csv(&SynthesizeOptions {
        system: SystemName::RigidBodySo3,
        out: csv.clone(),
        trajectories: 40,
        samples: 20,
        noise: 0.0,
        derivatives: true,
        seed: 2,
        overwrite: false,
    })
    .unwrap();
    assert_eq!(rows, 800);
    let header = std::fs::read_to_string(&csv).unwrap();
    assert!(
        header.starts_with("trajectory,t,px,py,pz,dpx,dpy,dpz\n"),
        "{header:.60}"
    );

    let out = scratch("rigid_body_exact_out");
    let summary = run(&quiet_options(&csv, &out)).unwrap();
    assert_eq!(summary.system, "rigid_body_so3");
    assert_eq!(summary.data_method, "derivatives from the CSV");
    assert_eq!(summary.train_equations, 32 * 20, "one equation per sample");
    // Exact derivatives and states: the vector field is recovered. Measured:
    // 1.9e-9, as for the true model (the integrator's tolerance).
    let error = summary.validation_relative_error.unwrap();
    assert!(error < 1e-6, "validation relative error {error}");
    for figure in [
        "validation_1_px_py.png",
        "validation_overlay.png",
        "model_trajectories_3d.png",
    ] {
        assert!(out.join(figure).is_file(), "{figure} missing");
    }

    // The same file in the weak form, at its default only without derivatives.
    let out = scratch("rigid_body_weak_out");
    let options = Options {
        weak: true,
        max_iterations: Some(3),
        plot_trajectories: 0,
        ..quiet_options(&csv, &out)
    };
    let summary = run(&options).unwrap();
    assert!(summary.data_method.starts_with("weak form"));
    let form = metriplectic_runtime::WeakForm::default();
    let windows = (20 - form.window) / form.stride + 1;
    assert_eq!(
        summary.train_equations,
        32 * windows,
        "windows per trajectory"
    );
}

/// Input from a pipe: without --system the header was read through a
/// separate buffered reader that swallowed the first 8 KiB, and the reader
/// proper started mid-row ("line 1: unknown column(s) `1226266491696`…"),
/// or found nothing left. The CSV is read once, so a FIFO works.
#[cfg(unix)]
#[test]
fn a_csv_from_a_pipe_is_read_once() {
    let csv = scratch("piped.csv");
    write_csv::<Linear2d>(
        &csv,
        6,
        SampleTimes::Uniform { interval: 0.1 },
        3.9,
        1.0,
        0.0,
    );
    assert!(
        std::fs::metadata(&csv).unwrap().len() > 8 << 10,
        "more than a buffer"
    );
    let fifo = scratch("piped.fifo");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success(), "mkfifo failed");
    // The writer blocks until the pipeline opens the FIFO.
    let mut writer = std::process::Command::new("sh")
        .arg("-c")
        .arg("exec cat \"$0\" > \"$1\"")
        .arg(&csv)
        .arg(&fifo)
        .spawn()
        .unwrap();
    let out = scratch("piped_out");
    let options = Options {
        max_iterations: Some(1),
        plot_trajectories: 0,
        ..quiet_options(&fifo, &out)
    };
    // Before the fix the second open of the FIFO waited for a writer that
    // had gone: run with a deadline, not forever.
    let (sender, receiver) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = sender.send(run(&options).map_err(|e| e.to_string()));
    });
    let result = receiver.recv_timeout(std::time::Duration::from_secs(180));
    if writer.try_wait().unwrap().is_none() {
        writer.kill().unwrap();
    }
    writer.wait().unwrap();
    let summary = result
        .expect("the pipeline waited on the FIFO")
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(summary.system, "linear_2d");
    assert_eq!(summary.trajectories, 6);
    assert_eq!(summary.samples, 6 * 40);
}

/// With --system a missing file was named twice ("nonexist.csv:
/// nonexist.csv: No such file or directory"); a header the reader refuses
/// gets the reader's words with and without --system.
#[test]
fn a_missing_file_is_named_once_and_headers_are_judged_by_the_reader() {
    use metriplectic::from_csv::SystemName;

    let out = scratch("named_once_out");
    let missing = scratch("nonexist.csv");
    for system in [None, Some(SystemName::Linear2d)] {
        let options = Options {
            system,
            ..quiet_options(&missing, &out)
        };
        let err = run(&options).unwrap_err().to_string();
        assert_eq!(err.matches("nonexist.csv").count(), 1, "{system:?}: {err}");
        assert!(err.contains("No such file or directory"), "{err}");
    }

    let trailing = scratch("trailing_comma.csv");
    std::fs::write(
        &trailing,
        "trajectory,t,x,v,dx,dv,\n0,0,1,2,3,4,\n1,0,1,2,3,4,\n",
    )
    .unwrap();
    for system in [None, Some(SystemName::Duffing)] {
        let options = Options {
            system,
            ..quiet_options(&trailing, &out)
        };
        let err = run(&options).unwrap_err().to_string();
        assert!(
            err.contains(
                "trailing_comma.csv: line 1, column 7: the column has no name (a trailing comma?)"
            ),
            "{system:?}: {err}"
        );
    }
    let empty = scratch("empty.csv");
    std::fs::write(&empty, "").unwrap();
    let err = run(&quiet_options(&empty, &out)).unwrap_err().to_string();
    assert!(
        err.contains("empty.csv: empty input or blank first line: expected a header line"),
        "{err}"
    );
    let extra = scratch("extra_column.csv");
    std::fs::write(&extra, "trajectory,time,x,v\n0,0,1,2\n1,0,1,2\n").unwrap();
    let err = run(&quiet_options(&extra, &out)).unwrap_err().to_string();
    assert!(
        err.contains("nearly fit system `duffing` (x, v), but line 1: unknown column(s) `time`"),
        "{err}"
    );
    assert!(!out.exists(), "refused inputs leave no output directory");
}

/// A negative number after a numeric option was taken for an option:
/// `--validation-fraction -0.5` gave "unexpected argument '-0' found" and
/// `--noise -1` "unexpected argument '-1'", not the range each option has.
#[test]
fn negative_numbers_reach_the_options_range_checks() {
    use metriplectic::synthetic_csv::{synthesize_csv, SynthesizeOptions};

    let csv = scratch("negative.csv");
    small_csv::<Linear2d>(&csv);
    let out = scratch("negative_out");
    let parse = |flag: &str, value: &str| {
        Options::try_parse_from([
            "from_csv",
            "--data",
            csv.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            flag,
            value,
        ])
    };
    let options = parse("--validation-fraction", "-0.5").unwrap();
    let err = run(&options).unwrap_err().to_string();
    assert!(
        err.contains("--validation-fraction -0.5 is not between 0 and 1"),
        "{err}"
    );
    for flag in [
        "--seed",
        "--window",
        "--max-iterations",
        "--plot-trajectories",
    ] {
        let err = parse(flag, "-1").unwrap_err().to_string();
        assert!(
            err.contains(&format!("invalid value '-1' for '{flag}")),
            "{flag}: {err}"
        );
    }

    let synthesize = |args: &[&str]| {
        let mut argv = vec!["synthesize_csv", "--system", "duffing", "--out"];
        let path = scratch("negative_noise.csv");
        let path = path.to_str().unwrap().to_owned();
        argv.push(&path);
        argv.extend(args);
        SynthesizeOptions::try_parse_from(argv).map(|o| synthesize_csv(&o))
    };
    let err = synthesize(&["--noise", "-1"])
        .unwrap()
        .unwrap_err()
        .to_string();
    assert!(err.contains("invalid state noise σ: -1"), "{err}");
    for flag in ["--trajectories", "--samples", "--seed"] {
        let err = synthesize(&[flag, "-3"]).unwrap_err().to_string();
        assert!(err.contains("invalid value '-3'"), "{flag}: {err}");
    }

    let reproduction = |flag: &str, value: &str| {
        metriplectic::reproduction::Options::try_parse_from(["linear_2d", flag, value])
    };
    let options = reproduction("--tolerance", "-1").unwrap();
    assert_eq!(options.tolerance, -1.0);
    let options = reproduction("--gauge-trace", "-2").unwrap();
    assert_eq!(options.gauge_trace, Some(-2.0));
    for flag in [
        "--seed",
        "--batch-size",
        "--iterations",
        "--plot-trajectories",
        "--train-trajectories",
        "--heldout-trajectories",
        "--samples-per-trajectory",
        "--checkpoint-every",
    ] {
        let err = reproduction(flag, "-1").unwrap_err().to_string();
        assert!(err.contains("invalid value '-1'"), "{flag}: {err}");
    }
}

/// An output that cannot be written was found only after the whole
/// identification (`model.json` a directory, a read-only `summary.json`):
/// it is refused before the run, leaving everything as it was.
#[test]
fn outputs_that_cannot_be_written_are_refused_before_the_run() {
    let csv = scratch("unwritable.csv");
    small_csv::<Linear2d>(&csv);
    let out = scratch("unwritable_out");
    std::fs::create_dir_all(out.join("model.json")).unwrap();
    let options = Options {
        overwrite: true,
        max_iterations: Some(1),
        plot_trajectories: 0,
        ..quiet_options(&csv, &out)
    };
    let err = run(&options).unwrap_err();
    assert!(
        matches!(err, FromCsvError::OutputNotWritable { .. }),
        "{err:?}"
    );
    let message = err.to_string();
    assert!(
        message.contains("model.json: it is a directory, where this run writes a file"),
        "{message}"
    );
    let names = |dir: &Path| {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    };
    assert_eq!(
        names(&out),
        ["model.json"],
        "nothing written, no probe left"
    );

    std::fs::remove_dir(out.join("model.json")).unwrap();
    let summary = out.join("summary.json");
    std::fs::write(&summary, "{}").unwrap();
    let mut permissions = std::fs::metadata(&summary).unwrap().permissions();
    permissions.set_readonly(true);
    std::fs::set_permissions(&summary, permissions).unwrap();
    let err = run(&options).unwrap_err().to_string();
    assert!(err.contains("summary.json: the file is read-only"), "{err}");
    assert_eq!(names(&out), ["summary.json"]);

    // A directory no file can be made in (not testable as root, who can).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let locked = scratch("locked_out");
        std::fs::create_dir_all(&locked).unwrap();
        std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o555)).unwrap();
        if std::fs::write(locked.join("probe"), "").is_err() {
            let err = run(&quiet_options(&csv, &locked)).unwrap_err().to_string();
            assert!(
                err.contains("the output directory is not writable"),
                "{err}"
            );
        }
        std::fs::set_permissions(&locked, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
}
