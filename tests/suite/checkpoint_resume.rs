//! Long runs: periodic atomic checkpoints, and resuming a run so that it
//! continues exactly as if it had never stopped.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use crate::common::*;
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    identify, identify_resume, identify_with_observer, CheckpointConfig, IdentifyConfig,
    IterationScheme, SearchOptions, Stagnation, StopReason, TrustRegion, Validation,
};

/// A fresh scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    scratch_dir("checkpoint", name)
}

/// Algorithm 2 with joint steps (so the trust radius and the minibatch
/// generator both carry state across iterations) on the 2-D paper system.
fn config(checkpoint: Option<&Path>) -> IdentifyConfig {
    IdentifyConfig {
        batch_size: Some(25),
        max_iterations: 6,
        tolerance: 0.0,
        seed: 42,
        initial_entropy: Some(perturbed_reference_entropy::<Linear2d>(0.5, 42)),
        scheme: IterationScheme::AlternatingThenJoint(TrustRegion::default()),
        checkpoint: checkpoint.map(|path| CheckpointConfig {
            path: path.to_owned(),
            every: 2,
        }),
        ..alternation()
    }
}

/// Number of iterations saved in the checkpoint at `path`.
fn saved_iterations(path: &Path) -> Option<usize> {
    let text = std::fs::read_to_string(path).ok()?;
    let value: serde_json::Value = serde_json::from_str(&text).ok()?;
    value["history"]["iterations"].as_array().map(Vec::len)
}

#[test]
fn interrupted_and_resumed_run_equals_an_uninterrupted_run() {
    let dir = scratch("resume");
    let data = linear2d_data(120, 7);
    let uninterrupted = identify::<Linear2d>(&data, &config(None)).unwrap();
    assert_eq!(uninterrupted.stop_reason, StopReason::MaxIterations);
    assert_eq!(uninterrupted.history.iterations.len(), 6);

    // Interrupt after iteration 3; on the way, keep a copy of the periodic
    // checkpoint of iteration 2 (the observer runs before iteration 3's save).
    let path = dir.join("checkpoint.json");
    let periodic = dir.join("after-2.json");
    let mut seen_in_file = Vec::new();
    let interrupted =
        identify_with_observer::<Linear2d, _>(&data, &config(Some(&path)), |record, _| {
            seen_in_file.push(saved_iterations(&path));
            if record.iteration == 3 {
                std::fs::copy(&path, &periodic).unwrap();
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .unwrap();
    assert_eq!(interrupted.stop_reason, StopReason::Interrupted);
    assert_eq!(seen_in_file, vec![None, None, Some(2)]);
    // The stop itself saves: the file now holds all three iterations.
    assert_eq!(saved_iterations(&path), Some(3));
    assert_eq!(saved_iterations(&periodic), Some(2));
    // Only the checkpoint and our copy: no temporary file is left behind.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);

    for (name, from) in [("stop", &path), ("periodic", &periodic)] {
        let resumed = identify_resume::<Linear2d>(from, &data, &config(None)).unwrap();
        assert_eq!(resumed.stop_reason, StopReason::MaxIterations, "{name}");
        assert_eq!(
            without_timings(&resumed.history),
            without_timings(&uninterrupted.history),
            "resumed from the {name} checkpoint"
        );
        // Bit for bit: same arithmetic, exact JSON round trip.
        let bits = |m: &Model<Linear2d>| -> Vec<u64> {
            m.entropy_coefficients()
                .iter()
                .chain(m.metric_coefficients())
                .map(|v| v.to_bits())
                .collect()
        };
        assert_eq!(bits(&resumed.model), bits(&uninterrupted.model), "{name}");
    }

    // The iteration cap may be raised to extend a finished run.
    let extended = identify_resume::<Linear2d>(
        &path,
        &data,
        &IdentifyConfig {
            max_iterations: 4,
            ..config(None)
        },
    )
    .unwrap();
    assert_eq!(extended.history.iterations.len(), 4);
    assert_eq!(
        without_timings(&extended.history).iterations[..],
        without_timings(&uninterrupted.history).iterations[..4]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A full-batch run that warms up on the start's subsample writes its
/// checkpoints in the run on all the data, with the warm-up's iterations in
/// their history; resumed from one, it equals an uninterrupted run and
/// does not warm up again.
#[test]
fn a_run_resumed_after_its_warm_up_equals_an_uninterrupted_run() {
    let dir = scratch("warm-up");
    // The start's subsample: 220 samples, ten equations per coefficient.
    let data = linear2d_data(500, 9);
    let config = |checkpoint: Option<&Path>| IdentifyConfig {
        start_samples: 200,
        max_iterations: 6,
        tolerance: 0.0,
        initial_entropy: Some(perturbed_reference_entropy::<Linear2d>(0.5, 9)),
        scheme: IterationScheme::AlternatingThenJoint(TrustRegion::default()),
        checkpoint: checkpoint.map(|path| CheckpointConfig {
            path: path.to_owned(),
            every: 1,
        }),
        ..alternation()
    };
    let uninterrupted = identify::<Linear2d>(&data, &config(None)).unwrap();
    let iterations = &uninterrupted.history.iterations;
    let warm = iterations.iter().take_while(|r| r.warm_up).count();
    assert!((1..6).contains(&warm), "{warm} warm-up iterations");
    assert!(iterations[..warm].iter().all(|r| r.batch_size == 220));
    assert!(iterations[warm..]
        .iter()
        .all(|r| !r.warm_up && r.batch_size == 500));

    // Stopped at the first iteration on all the data: the warm-up saved
    // nothing, the stop saves everything so far.
    let path = dir.join("checkpoint.json");
    let mut saved_in_warm_up = Vec::new();
    let stopped =
        identify_with_observer::<Linear2d, _>(&data, &config(Some(&path)), |record, _| {
            if record.warm_up {
                saved_in_warm_up.push(saved_iterations(&path));
                ControlFlow::Continue(())
            } else {
                ControlFlow::Break(())
            }
        })
        .unwrap();
    assert_eq!(stopped.stop_reason, StopReason::Interrupted);
    assert!(saved_in_warm_up.iter().all(Option::is_none));
    assert_eq!(saved_iterations(&path), Some(warm + 1));

    let resumed = identify_resume::<Linear2d>(&path, &data, &config(None)).unwrap();
    assert_eq!(resumed.stop_reason, StopReason::MaxIterations);
    assert_eq!(
        without_timings(&resumed.history),
        without_timings(&uninterrupted.history)
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn resuming_with_other_data_configuration_or_system_is_refused() {
    let dir = scratch("mismatch");
    let data = linear2d_data(60, 8);
    let path = dir.join("checkpoint.json");
    let short = IdentifyConfig {
        max_iterations: 1,
        ..config(Some(&path))
    };
    identify::<Linear2d>(&data, &short).unwrap();

    // One value changed by one ulp is other data.
    let mut states = data.states().to_vec();
    states[17] = f64::from_bits(states[17].to_bits() + 1);
    let nudged = Dataset::from_flat(2, states, data.derivatives().to_vec()).unwrap();
    let err = identify_resume::<Linear2d>(&path, &nudged, &config(None)).unwrap_err();
    assert!(
        matches!(err, Error::CheckpointMismatch { ref reason, .. } if reason.contains("other data")),
        "{err}"
    );
    let fewer = data.select(&(0..59).collect::<Vec<_>>()).unwrap();
    let err = identify_resume::<Linear2d>(&path, &fewer, &config(None)).unwrap_err();
    assert!(matches!(err, Error::CheckpointMismatch { .. }), "{err}");

    let other_eta = IdentifyConfig {
        search: SearchOptions {
            eta: Some(25.0),
            ..SearchOptions::default()
        },
        ..config(None)
    };
    let err = identify_resume::<Linear2d>(&path, &data, &other_eta).unwrap_err();
    assert!(
        matches!(err, Error::CheckpointMismatch { ref reason, .. } if reason.contains("`search`") && reason.contains("25")),
        "{err}"
    );
    let other_seed = IdentifyConfig {
        seed: 43,
        ..config(None)
    };
    let err = identify_resume::<Linear2d>(&path, &data, &other_seed).unwrap_err();
    assert!(
        matches!(err, Error::CheckpointMismatch { ref reason, .. } if reason.contains("`seed`")),
        "{err}"
    );

    let body = rigid_body_data(60, 8);
    let body_config = IdentifyConfig {
        initial_entropy: None,
        ..config(None)
    };
    let err = identify_resume::<RigidBody>(&path, &body, &body_config).unwrap_err();
    assert!(
        matches!(err, Error::CheckpointMismatch { ref reason, .. } if reason.contains("Linear2d")),
        "{err}"
    );

    // A truncated checkpoint (a crash mid-write cannot produce one, since
    // writes are atomic, but a copy can) is a JSON error, not a panic.
    let text = std::fs::read_to_string(&path).unwrap();
    let truncated = dir.join("truncated.json");
    std::fs::write(&truncated, &text[..text.len() / 2]).unwrap();
    let err = identify_resume::<Linear2d>(&truncated, &data, &config(None)).unwrap_err();
    assert!(matches!(err, Error::Json { .. }), "{err}");

    // Any edit is refused by the checkpoint's digest: an edited stop
    // reason resumed as "Converged" at held-out error 8e-3, and an edited
    // best model or generator position resumed as given (a probe).
    let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
    let edited = dir.join("edited.json");
    for (field, replacement) in [
        ("stopped", serde_json::json!("Converged")),
        ("rng_word_position", serde_json::json!("1")),
        ("since_improvement", serde_json::json!(7)),
    ] {
        let mut changed = value.clone();
        changed[field] = replacement;
        assert_ne!(changed, value, "{field}");
        std::fs::write(&edited, changed.to_string()).unwrap();
        let err = identify_resume::<Linear2d>(&edited, &data, &config(None)).unwrap_err();
        assert!(
            matches!(err, Error::CheckpointMismatch { ref reason, .. } if reason.contains("does not match the digest it was saved with")),
            "{field}: {err}"
        );
    }
    // The file as written, re-serialised, still resumes.
    std::fs::write(&edited, value.to_string()).unwrap();
    identify_resume::<Linear2d>(&edited, &data, &config(None)).unwrap();

    // Without a digest (checkpoints of earlier versions) the fields are
    // checked one by one: an edited trust radius outside the
    // configuration's bounds is named as such, not met later as a failed
    // joint step.
    value["digest"] = serde_json::Value::Null;
    value["radius"] = serde_json::json!(0.0);
    std::fs::write(&edited, value.to_string()).unwrap();
    let err = identify_resume::<Linear2d>(&edited, &data, &config(None)).unwrap_err();
    assert!(
        matches!(err, Error::CheckpointMismatch { ref reason, .. } if reason.contains("trust radius 0e0 is outside")),
        "{err}"
    );

    // An absurdly large file is refused before it is read (sparse: no disk).
    let huge = dir.join("huge.json");
    std::fs::File::create(&huge)
        .unwrap()
        .set_len(10 << 30)
        .unwrap();
    let err = identify_resume::<Linear2d>(&huge, &data, &config(None)).unwrap_err();
    assert!(matches!(err, Error::FileTooLarge { .. }), "{err}");

    let err =
        identify_resume::<Linear2d>(dir.join("missing.json"), &data, &config(None)).unwrap_err();
    assert!(matches!(err, Error::Io { .. }), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn checkpoint_settings_are_validated_before_any_work() {
    let data = linear2d_data(10, 9);
    for checkpoint in [
        CheckpointConfig {
            path: std::env::temp_dir().join("no-such-directory-metriplectic/c.json"),
            every: 1,
        },
        CheckpointConfig {
            path: std::env::temp_dir().join("c.json"),
            every: 0,
        },
        CheckpointConfig {
            path: PathBuf::from("/"),
            every: 1,
        },
    ] {
        let config = IdentifyConfig {
            checkpoint: Some(checkpoint.clone()),
            ..alternation()
        };
        let err = identify::<Linear2d>(&data, &config).unwrap_err();
        assert!(
            matches!(err, Error::InvalidArgument { ref what, .. } if what == "checkpoint"),
            "{checkpoint:?}: {err}"
        );
    }
}

/// A checkpoint path that names the user's data or model is refused, not
/// overwritten (a probe's checkpoint replaced its CSV); a checkpoint of an
/// earlier run at the path is the run's own kind of file and is replaced.
#[test]
fn a_checkpoint_never_overwrites_a_file_that_is_not_one() {
    let dir = scratch("not_a_checkpoint");
    let data = linear2d_data(10, 9);
    let with = |path: &Path| IdentifyConfig {
        checkpoint: Some(CheckpointConfig {
            path: path.to_owned(),
            every: 1,
        }),
        max_iterations: 2,
        ..alternation()
    };
    let csv = dir.join("runs.csv");
    let contents = "trajectory,t,q,p\n0,0,1,2\n";
    std::fs::write(&csv, contents).unwrap();
    let err = identify::<Linear2d>(&data, &with(&csv)).unwrap_err();
    assert!(
        err.to_string()
            .contains("exists and is not a checkpoint (it starts with \"trajectory,t,q,p"),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&csv).unwrap(), contents);
    let model = dir.join("model.json");
    Model::<Linear2d>::reference()
        .unwrap()
        .save(&model, WriteMode::CreateNew)
        .unwrap();
    let saved = std::fs::read(&model).unwrap();
    assert!(identify::<Linear2d>(&data, &with(&model)).is_err());
    assert_eq!(std::fs::read(&model).unwrap(), saved);
    assert!(identify::<Linear2d>(&data, &with(&dir)).is_err());
    // An empty file made in advance is no one's data.
    let empty = dir.join("made_in_advance.json");
    std::fs::write(&empty, "").unwrap();
    identify::<Linear2d>(&data, &with(&empty)).unwrap();
    assert!(std::fs::metadata(&empty).unwrap().len() > 0);

    let checkpoint = dir.join("checkpoint.json");
    identify::<Linear2d>(&data, &with(&checkpoint)).unwrap();
    let first = std::fs::read(&checkpoint).unwrap();
    let again = IdentifyConfig {
        max_iterations: 3,
        ..with(&checkpoint)
    };
    identify::<Linear2d>(&data, &again).unwrap();
    assert_ne!(std::fs::read(&checkpoint).unwrap(), first);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A checkpoint records H and Π: resuming into a system whose known parts
/// changed under the same name and bases is refused, naming the change.
#[test]
fn a_checkpoint_of_another_hamiltonian_does_not_resume() {
    let dir = scratch("another_hamiltonian");
    let data = linear2d_data(40, 14);
    let path = dir.join("checkpoint.json");
    let config = IdentifyConfig {
        max_iterations: 1,
        ..config(Some(&path))
    };
    identify::<Linear2d>(&data, &config).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
    let h = value["known_parts"]["hamiltonian"][0].as_f64().unwrap();
    value["known_parts"]["hamiltonian"][0] = serde_json::json!(2.0 * h + 1.0);
    std::fs::write(&path, value.to_string()).unwrap();
    let err = identify_resume::<Linear2d>(&path, &data, &config).unwrap_err();
    assert!(
        matches!(err, Error::CheckpointMismatch { .. })
            && err.to_string().contains("with another Hamiltonian: H = "),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_converged_checkpoint_resumes_as_converged_without_iterating() {
    let dir = scratch("converged");
    let data = linear2d_data(30, 10);
    let path = dir.join("checkpoint.json");
    // From the truth the first iteration already meets a loose tolerance.
    let config = IdentifyConfig {
        tolerance: 1e-6,
        max_iterations: 5,
        initial_entropy: Some(Linear2d::REFERENCE_ENTROPY.unwrap().to_vec()),
        checkpoint: Some(CheckpointConfig {
            path: path.clone(),
            every: 100,
        }),
        ..alternation()
    };
    let first = identify::<Linear2d>(&data, &config).unwrap();
    assert_eq!(first.stop_reason, StopReason::Converged);
    let mut calls = 0;
    let resumed = metriplectic_runtime::identify_resume_with_observer::<Linear2d, _>(
        &path,
        &data,
        &config,
        |_, _| {
            calls += 1;
            ControlFlow::Continue(())
        },
    )
    .unwrap();
    assert_eq!(calls, 0);
    assert_eq!(resumed.stop_reason, StopReason::Converged);
    assert_eq!(resumed.history, first.history);
    assert_eq!(resumed.model, first.model);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A scoring minibatch run that stopped by itself: the checkpoint holds the
/// state before the run's end, so resuming it must end it the same way,
/// with the best model, the polish iteration and their certificate.
#[test]
fn a_stopped_scoring_run_resumes_to_the_same_polished_result() {
    let dir = scratch("stopped-scoring");
    let data = linear2d_data(40, 11);
    let path = dir.join("checkpoint.json");
    let config = IdentifyConfig {
        validation: Validation::AllData,
        polish: true,
        // Demands a 90% gain every two iterations: stops within the cap.
        stagnation: Some(Stagnation {
            window: 2,
            relative_improvement: 0.9,
        }),
        max_iterations: 8,
        ..config(Some(&path))
    };
    let first = identify::<Linear2d>(&data, &config).unwrap();
    assert_eq!(first.stop_reason, StopReason::Stagnated);
    let last = first.history.iterations.last().unwrap();
    assert!(last.polish, "the run ends with its polish");
    let resumed = identify_resume::<Linear2d>(&path, &data, &config).unwrap();
    assert_eq!(resumed.stop_reason, StopReason::Stagnated);
    assert_eq!(
        without_timings(&resumed.history),
        without_timings(&first.history)
    );
    assert_eq!(resumed.model, first.model);
    assert_eq!(resumed.model.certificate(), first.model.certificate());
    assert!(first.model.certificate().is_some());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A run resumed mid-way keeps the Gram certificate its model had.
#[test]
fn a_resumed_model_keeps_its_gram_certificate() {
    let dir = scratch("certificate");
    let data = linear2d_data(40, 12);
    let path = dir.join("checkpoint.json");
    let config = config(Some(&path));
    let stopped = identify_with_observer::<Linear2d, _>(&data, &config, |record, _| {
        if record.iteration == 3 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    assert_eq!(stopped.stop_reason, StopReason::Interrupted);
    let resumed = identify_resume::<Linear2d>(
        &path,
        &data,
        &IdentifyConfig {
            max_iterations: 3,
            ..config.clone()
        },
    )
    .unwrap();
    assert_eq!(resumed.model, stopped.model);
    assert!(stopped.model.certificate().is_some());
    assert_eq!(resumed.model.certificate(), stopped.model.certificate());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A stop asked for during a warm-up whose solves all fail still stops the
/// run: it used to start over on all the data, calling the observer again.
#[test]
fn a_stop_asked_for_in_a_failed_warm_up_is_honoured() {
    let data = linear2d_data(500, 13);
    let config = IdentifyConfig {
        start_samples: 200,
        max_iterations: 6,
        max_failed_iterations: 1,
        search: SearchOptions {
            solver: metriplectic_runtime::SolverSettings {
                max_iter: 1,
                ..Default::default()
            },
            ..SearchOptions::default()
        },
        ..alternation()
    };
    let mut calls = 0;
    let result = identify_with_observer::<Linear2d, _>(&data, &config, |record, _| {
        calls += 1;
        assert!(record.warm_up, "only the warm-up runs");
        ControlFlow::Break(())
    })
    .unwrap();
    assert_eq!(calls, 1);
    assert_eq!(result.stop_reason, StopReason::Interrupted);
}

/// A history cost that overflowed is saved and loaded: JSON has no
/// infinities, and the `null` serde_json wrote for one used to make the
/// whole checkpoint unloadable.
#[test]
fn a_checkpoint_with_a_non_finite_cost_in_its_history_resumes() {
    let dir = scratch("non-finite-cost");
    let data = linear2d_data(40, 14);
    let path = dir.join("checkpoint.json");
    let config = config(Some(&path));
    identify_with_observer::<Linear2d, _>(&data, &config, |record, _| {
        if record.iteration == 2 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
    // Edited here, as an earlier version without a digest would be read.
    value["digest"] = serde_json::Value::Null;
    for (field, written) in [("inf", "inf"), ("null", "NaN")] {
        let cost = &mut value["history"]["iterations"][0]["metric"]["report"]["cost"];
        cost["sum"] = match field {
            "null" => serde_json::Value::Null,
            text => serde_json::json!(text),
        };
        std::fs::write(&path, value.to_string()).unwrap();
        let resumed = identify_resume::<Linear2d>(
            &path,
            &data,
            &IdentifyConfig {
                max_iterations: 4,
                ..config.clone()
            },
        )
        .unwrap_or_else(|err| panic!("cost {field}: {err}"));
        assert_eq!(resumed.history.iterations.len(), 4);
        let sum = resumed.history.iterations[0]
            .metric
            .report
            .cost
            .unwrap()
            .sum;
        assert_eq!(sum.to_string(), written);
        // Iteration 4 saved a checkpoint with the value as text.
        let saved = std::fs::read_to_string(&path).unwrap();
        assert!(saved.contains(&format!("\"sum\":\"{written}\"")), "{field}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A checkpoint that a crash of a copy or a hand edit damaged declares the
/// checkpoint format but does not parse: it was called "not a checkpoint
/// (it starts with "{\"format\": \"metriplectic-checkpoint\"…)". It is
/// named as damaged, with the parser's line and column, and kept: neither
/// a new run nor a resumed one replaces it.
#[test]
fn a_damaged_checkpoint_is_named_as_such_and_kept() {
    let dir = scratch("damaged");
    let data = linear2d_data(40, 15);
    let path = dir.join("checkpoint.json");
    let short = IdentifyConfig {
        max_iterations: 1,
        ..config(Some(&path))
    };
    identify::<Linear2d>(&data, &short).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    // A hand edit that breaks a line and drops a comma: `"version":3`
    // alone on line 2, `"fingerprint"…` on line 3.
    let edited = text.replacen(",\"version\":3,", ",\n\"version\":3\n", 1);
    assert_ne!(edited, text);
    let damaged: [(&str, String, &str); 3] = [
        (
            "truncated.json",
            text[..text.len() / 2].to_owned(),
            "EOF while parsing",
        ),
        (
            "edited.json",
            edited,
            "expected `,` or `}` at line 3 column 1",
        ),
        (
            "wrong_type.json",
            text.replacen("\"radius\":", "\"radius\":\"wide\",\"was\":", 1),
            "invalid type: string \"wide\", expected f64",
        ),
    ];
    for (name, contents, expected) in damaged {
        let file = dir.join(name);
        std::fs::write(&file, &contents).unwrap();
        // A new run that would write its checkpoint there.
        let fresh = IdentifyConfig {
            max_iterations: 1,
            ..config(Some(&file))
        };
        let err = identify::<Linear2d>(&data, &fresh).unwrap_err();
        let message = err.to_string();
        assert!(
            matches!(err, Error::InvalidArgument { ref what, .. } if what == "checkpoint"),
            "{name}: {err}"
        );
        for part in [
            file.to_str().unwrap(),
            "is a damaged checkpoint",
            expected,
            "move or delete it",
        ] {
            assert!(message.contains(part), "{name}: `{part}` not in {message}");
        }
        assert!(!message.contains("is not a checkpoint"), "{message}");
        // Resuming it, saving to it again or elsewhere.
        let err = identify_resume::<Linear2d>(&file, &data, &fresh).unwrap_err();
        assert!(err.to_string().contains("is a damaged checkpoint"), "{err}");
        let err = identify_resume::<Linear2d>(&file, &data, &config(None)).unwrap_err();
        assert!(matches!(err, Error::Json { .. }), "{name}: {err}");
        let message = err.to_string();
        for part in [file.to_str().unwrap(), "damaged or edited", expected] {
            assert!(message.contains(part), "{name}: `{part}` not in {message}");
        }
        assert_eq!(std::fs::read_to_string(&file).unwrap(), contents, "{name}");
    }
    // A whole checkpoint of an earlier run is still replaced.
    identify::<Linear2d>(&data, &short).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A checkpoint whose model an edit made invalid said only "metric
/// coefficients: K(x) is not positive semidefinite …": neither the file
/// nor which of its two models.
#[test]
fn a_checkpoint_model_that_does_not_load_names_the_file_and_the_model() {
    let dir = scratch("invalid-models");
    let data = linear2d_data(40, 16);
    let path = dir.join("checkpoint.json");
    let scoring = IdentifyConfig {
        validation: Validation::AllData,
        max_iterations: 2,
        ..config(Some(&path))
    };
    identify::<Linear2d>(&data, &scoring).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let value: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(
        value["best"].is_array(),
        "a scoring run keeps its best model"
    );
    for (which, pointer) in [("best", "/best/1/0"), ("current", "/metric/0")] {
        let mut edited = value.clone();
        *edited.pointer_mut(pointer).unwrap() = serde_json::json!(-5.0);
        // The certificates prove the old metric; without them the edit is
        // judged as a metric.
        edited["certificate"] = serde_json::Value::Null;
        edited["best_certificate"] = serde_json::Value::Null;
        // Judged field by field, as a checkpoint without a digest is.
        edited["digest"] = serde_json::Value::Null;
        let file = dir.join(format!("{which}.json"));
        std::fs::write(&file, edited.to_string()).unwrap();
        let resume = IdentifyConfig {
            checkpoint: None,
            ..scoring.clone()
        };
        let err = identify_resume::<Linear2d>(&file, &data, &resume).unwrap_err();
        assert!(matches!(err, Error::MetricNotPositive { .. }), "{err}");
        let message = err.to_string();
        let place = format!(
            "metric coefficients in the {which} model of checkpoint {}: K(x) is not positive semidefinite",
            file.display()
        );
        assert!(message.contains(&place), "`{place}` not in {message}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--resume` of a reproduction whose `checkpoint.json` is a directory said
/// "there is no …/checkpoint.json".
#[test]
fn resuming_from_a_directory_says_it_is_one() {
    use clap::Parser;
    use metriplectic::reproduction::{run_until, Options, ReproductionError};

    let out = scratch("resume-directory");
    std::fs::create_dir_all(out.join("checkpoint.json")).unwrap();
    let options = Options::parse_from(["linear_2d", "--out", out.to_str().unwrap(), "--resume"]);
    let experiment = metriplectic::experiments::linear_2d();
    let err = run_until::<Linear2d>(
        &experiment,
        &options,
        &std::sync::atomic::AtomicBool::new(false),
    )
    .unwrap_err();
    assert!(matches!(err, ReproductionError::Option(_)), "{err}");
    let message = err.to_string();
    assert!(
        message.contains("checkpoint.json is a directory, not a checkpoint to continue from"),
        "{message}"
    );
    std::fs::remove_dir_all(&out).unwrap();
    // A missing one is still called missing.
    let err = run_until::<Linear2d>(
        &experiment,
        &options,
        &std::sync::atomic::AtomicBool::new(false),
    )
    .unwrap_err();
    assert!(err.to_string().contains("there is no"), "{err}");
}
