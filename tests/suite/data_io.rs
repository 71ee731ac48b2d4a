//! Data in and out: trajectory CSV (exact round trip, every malformed-input
//! class rejected with line, column and wording) and seeded synthesis
//! (reproducibility, exact derivatives, noise and outliers as documented,
//! held-out split by trajectory).

use std::path::PathBuf;

use crate::common::{scratch_path, Linear2d, RigidBody};
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::Trajectory;
use metriplectic_runtime::{
    read_trajectories, read_trajectories_from, write_trajectories, write_trajectories_to, CsvError,
    WriteMode,
};
use metriplectic_runtime::{
    synthesize, InitialStates, Noise, Outliers, SampleTimes, SynthesisOptions,
};

const NAMES: &[&str] = &["q", "p"];

fn read(text: &str) -> Result<Vec<Trajectory>> {
    read_trajectories_from(text.as_bytes(), NAMES)
}

fn csv_error(text: &str) -> (CsvError, String) {
    match read(text) {
        Err(Error::Csv(e)) => {
            let msg = e.to_string();
            (e, msg)
        }
        other => panic!("expected a CSV error for {text:?}, got {other:?}"),
    }
}

fn scratch(name: &str) -> PathBuf {
    scratch_path("data_io", name)
}

fn awkward_trajectory(id: &str, with_derivatives: bool) -> Trajectory {
    // Values whose decimal forms are long or extreme: the round trip must keep every bit.
    let times = vec![
        0.0,
        0.1 + 0.2,
        1.0 / 3.0,
        1.0 + f64::EPSILON,
        12345.678901234567,
    ];
    let states = vec![
        0.1,
        -0.0,
        1.0 / 3.0,
        -2.0 / 3.0,
        f64::MIN_POSITIVE,
        5e-324,
        f64::MAX,
        -f64::MAX,
        std::f64::consts::PI,
        -1e-17,
    ];
    let derivatives = with_derivatives.then(|| states.iter().map(|v| v / 7.0).collect());
    Trajectory::new(
        NAMES.iter().map(|s| (*s).to_owned()).collect(),
        times,
        states,
        derivatives,
    )
    .unwrap()
    .with_id(id)
}

fn bits(t: &Trajectory) -> Vec<u64> {
    t.times()
        .iter()
        .chain(t.states())
        .chain(t.derivatives().unwrap_or(&[]))
        .map(|v| v.to_bits())
        .collect()
}

#[test]
fn round_trip_is_bit_exact() {
    for with_derivatives in [true, false] {
        let trajs = vec![
            awkward_trajectory("run-a", with_derivatives),
            awkward_trajectory("run b, quoted", with_derivatives),
        ];
        let path = scratch(&format!("round_trip_{with_derivatives}.csv"));
        write_trajectories(&path, &trajs, WriteMode::CreateNew).unwrap();
        let back = read_trajectories::<Linear2d>(&path).unwrap();
        assert_eq!(back.len(), 2);
        for (a, b) in trajs.iter().zip(&back) {
            assert_eq!(a.id(), b.id());
            assert_eq!(bits(a), bits(b), "bits changed in the round trip");
        }
        // Writing never overwrites unless asked.
        let err = write_trajectories(&path, &trajs, WriteMode::CreateNew).unwrap_err();
        assert!(matches!(err, Error::FileExists { .. }), "{err}");
        assert!(err.to_string().contains("refusing to overwrite"), "{err}");
        assert_eq!(read_trajectories::<Linear2d>(&path).unwrap(), back);
        write_trajectories(&path, &trajs[..1], WriteMode::Overwrite).unwrap();
        assert_eq!(read_trajectories::<Linear2d>(&path).unwrap().len(), 1);
    }
}

#[test]
fn single_trajectory_without_id_round_trips_without_id_column() {
    let traj = awkward_trajectory("x", true);
    let plain = Trajectory::new(
        traj.names().to_vec(),
        traj.times().to_vec(),
        traj.states().to_vec(),
        traj.derivatives().map(<[f64]>::to_vec),
    )
    .unwrap();
    let mut text = Vec::new();
    write_trajectories_to(&mut text, std::slice::from_ref(&plain)).unwrap();
    let text = String::from_utf8(text).unwrap();
    assert!(text.starts_with("t,q,p,dq,dp\n"), "{text}");
    let back = read(&text).unwrap();
    assert_eq!(back, vec![plain]);
}

#[test]
fn columns_in_any_order_with_spaces_and_ids() {
    let text = "dp, p ,trajectory,t,q,dq\n\
                1,2,a,0,3,4\n\
                5,6,a,0.5,7,8\n\
                9,10,b,-1,11,12\n";
    let trajs = read(text).unwrap();
    assert_eq!(trajs.len(), 2);
    assert_eq!(trajs[0].id(), Some("a"));
    assert_eq!(trajs[0].times(), &[0.0, 0.5]);
    assert_eq!(trajs[0].state(1), &[7.0, 6.0]);
    assert_eq!(trajs[0].derivative(1).unwrap(), &[8.0, 5.0]);
    assert_eq!(trajs[1].state(0), &[11.0, 10.0]);
    // Time may restart in a new trajectory.
    assert_eq!(trajs[1].times(), &[-1.0]);
}

#[test]
fn header_errors_name_the_columns() {
    let (e, msg) = csv_error("");
    assert!(matches!(e, CsvError::NoHeader { .. }));
    assert!(
        msg.contains("empty input") && msg.contains("`t`, `q`, `p`"),
        "{msg}"
    );

    let (e, msg) = csv_error("t,q\n0,1\n");
    assert_eq!(
        e,
        CsvError::MissingColumns {
            line: 1,
            missing: vec!["p".into()],
            expected: match &e {
                CsvError::MissingColumns { expected, .. } => expected.clone(),
                _ => unreachable!(),
            }
        }
    );
    assert!(msg.starts_with("line 1: missing column(s) `p`; expected columns: `t`, `q`, `p` (required); `dq`, `dp` (optional, all or none); `trajectory` (optional)"), "{msg}");

    let (_, msg) = csv_error("q,p\n0,1\n");
    assert!(msg.contains("missing column(s) `t`"), "{msg}");

    let (e, msg) = csv_error("t,q,p,x,speed\n0,1,2,3,4\n");
    assert!(matches!(&e, CsvError::UnknownColumns { unknown, .. } if unknown == &["x", "speed"]));
    assert!(
        msg.contains("unknown column(s) `x`, `speed`; expected columns:"),
        "{msg}"
    );

    let (e, msg) = csv_error("t,q,p,q\n0,1,2,3\n");
    assert_eq!(
        e,
        CsvError::DuplicateColumn {
            line: 1,
            name: "q".into(),
            first: 2,
            second: 4
        }
    );
    assert!(
        msg.contains("column `q` appears twice (columns 2 and 4)"),
        "{msg}"
    );

    let (e, msg) = csv_error("t,q,p,dq\n0,1,2,3\n");
    assert!(matches!(e, CsvError::PartialDerivatives { .. }));
    assert!(msg.contains("found `dq`, missing `dp`"), "{msg}");

    let (e, msg) = csv_error("t,q,p\n");
    assert_eq!(e, CsvError::NoRows { line: 1 });
    assert!(msg.contains("no data rows"), "{msg}");
}

#[test]
fn cell_errors_name_line_and_column() {
    let (e, msg) = csv_error("t,q,p\n0,1,2\n0.1,1\n");
    assert_eq!(
        e,
        CsvError::FieldCount {
            line: 3,
            expected: 3,
            found: 2
        }
    );
    assert_eq!(msg, "line 3: 2 cell(s), but the header has 3 columns");

    let (_, msg) = csv_error("t,q,p\n0,1,2,9\n");
    assert_eq!(msg, "line 2: 4 cell(s), but the header has 3 columns");

    let (e, msg) = csv_error("t,q,p\n0,1,2\n0.1,abc,2\n");
    assert_eq!(
        e,
        CsvError::NotANumber {
            line: 3,
            column: 2,
            name: "q".into(),
            text: "abc".into()
        }
    );
    assert_eq!(msg, "line 3, column 2 (`q`): `abc` is not a number");

    let (_, msg) = csv_error("t,q,p\n0,1,\n");
    assert_eq!(msg, "line 2, column 3 (`p`): `` is not a number");

    for bad in ["NaN", "inf", "-infinity", "1e999"] {
        let (e, msg) = csv_error(&format!("p,q,t\n1,2,0\n{bad},2,1\n"));
        assert!(
            matches!(
                e,
                CsvError::NonFinite {
                    line: 3,
                    column: 1,
                    ..
                }
            ),
            "{bad}: {e:?}"
        );
        assert_eq!(
            msg,
            format!("line 3, column 1 (`p`): non-finite value `{bad}` (NaN and infinities are not allowed)")
        );
    }

    let (e, msg) = csv_error("t,q,p\n0,1,2\n0.5,1,2\n0.5,1,2\n");
    assert!(matches!(
        e,
        CsvError::NonIncreasingTime {
            line: 4,
            column: 1,
            previous_line: 3,
            ..
        }
    ));
    assert_eq!(
        msg,
        "line 4, column 1 (`t`): time 0.5 does not come after 0.5 on line 3 (the same number once read as a 64-bit float): times must strictly increase within a trajectory (a file of several trajectories needs a `trajectory` column)"
    );
    // Times that differ in the file but not once read as floats.
    let (_, msg) = csv_error("t,q,p\n10000000000000000,1,2\n10000000000000001,1,2\n");
    assert!(
        msg.contains(
            "line 3, column 1 (`t`): time 1e16 does not come after 1e16 on line 2 (the same \
             number once read as a 64-bit float)"
        ),
        "{msg}"
    );
    let (_, msg) = csv_error("q,trajectory,p,t\n1,r1,2,0\n1,r1,2,1\n1,r1,2,0.5\n");
    assert_eq!(
        msg,
        "line 4, column 4 (`t`): time 0.5 does not come after 1 on line 3 in trajectory `r1`: times must strictly increase within a trajectory"
    );

    let (e, msg) = csv_error("trajectory,t,q,p\na,0,1,2\n,1,1,2\n");
    assert_eq!(e, CsvError::EmptyTrajectoryId { line: 3, column: 1 });
    assert!(
        msg.contains("line 3, column 1 (`trajectory`): empty trajectory identifier"),
        "{msg}"
    );

    let (e, msg) = csv_error("trajectory,t,q,p\na,0,1,2\nb,0,1,2\na,1,1,2\n");
    assert_eq!(
        e,
        CsvError::SplitTrajectory {
            line: 4,
            id: "a".into(),
            first_line: 2
        }
    );
    assert!(msg.contains("must be contiguous"), "{msg}");

    let mut bytes = b"t,q,p\n0,1,2\n1,".to_vec();
    bytes.extend_from_slice(&[0xff, 0xfe]);
    bytes.extend_from_slice(b",2\n");
    match read_trajectories_from(bytes.as_slice(), NAMES) {
        Err(Error::Csv(CsvError::Malformed { line, message })) => {
            assert_eq!(line, 3);
            assert!(message.contains("UTF-8"), "{message}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn reserved_state_names_and_writer_checks() {
    let err = read_trajectories_from("t,x,dx\n0,1,2\n".as_bytes(), &["x", "dx"]).unwrap_err();
    assert!(err.to_string().contains("`dx` clashes"), "{err}");
    let err = read_trajectories_from("t\n0\n".as_bytes(), &["t"]).unwrap_err();
    assert!(err.to_string().contains("reserves for the time"), "{err}");

    let a = awkward_trajectory("a", true);
    let b = awkward_trajectory("b", false);
    let err = write_trajectories_to(Vec::new(), &[a, b]).unwrap_err();
    assert!(
        err.to_string()
            .contains("all trajectories carry derivatives or none"),
        "{err}"
    );
    assert!(write_trajectories_to(Vec::new(), &[]).is_err());

    // Files the reader would split differently are not written: an
    // identifier repeated, or equal to an unnamed trajectory's number.
    let unnamed = || {
        let t = awkward_trajectory("x", true);
        let derivatives = t.derivatives().map(<[f64]>::to_vec);
        Trajectory::new(
            t.names().to_vec(),
            t.times().to_vec(),
            t.states().to_vec(),
            derivatives,
        )
        .unwrap()
    };
    for (trajectories, message) in [
        (
            vec![awkward_trajectory("a", true), awkward_trajectory("a", true)],
            "cannot write trajectory 1: its identifier `a` is also trajectory 0's",
        ),
        (
            vec![awkward_trajectory("1", true), unnamed()],
            "cannot write trajectory 1: its identifier `1` is also trajectory 0's",
        ),
        (
            vec![awkward_trajectory(" run", true)],
            "identifier \" run\" would not read back as written",
        ),
        (
            vec![awkward_trajectory("a\nb", true)],
            "would not read back as written",
        ),
    ] {
        let err = write_trajectories_to(Vec::new(), &trajectories).unwrap_err();
        assert!(err.to_string().contains(message), "{err}");
    }
    let mut text = Vec::new();
    write_trajectories_to(&mut text, &[unnamed(), awkward_trajectory("run", true)]).unwrap();
    let back = read_trajectories_from(text.as_slice(), &["q", "p"]).unwrap();
    assert_eq!(back.len(), 2);

    let missing = std::env::temp_dir().join("metriplectic-no-such-dir/x.csv");
    let err = read_trajectories::<Linear2d>(&missing).unwrap_err();
    assert!(matches!(err, Error::Io { .. }), "{err}");
    assert!(
        err.to_string().contains("metriplectic-no-such-dir"),
        "{err}"
    );
    // A directory opens and fails on reading: the error names it too
    // (it said "<reader>: Is a directory").
    let directory = std::env::temp_dir();
    let err = read_trajectories::<Linear2d>(&directory).unwrap_err();
    assert!(matches!(err, Error::Io { .. }), "{err}");
    assert!(
        err.to_string().contains(&*directory.to_string_lossy()),
        "{err}"
    );
}

fn synthesis_options(seed: u64) -> SynthesisOptions {
    SynthesisOptions {
        trajectories: 8,
        duration: 3.0,
        held_out_trajectories: 2,
        seed,
        ..SynthesisOptions::new(
            InitialStates::cube(2, 1.5),
            SampleTimes::LogUniform {
                count: 40,
                first: 1e-3,
            },
        )
    }
}

/// Noise or outliers that overflow name their option (a probe's σ = 1e308
/// gave "sample 3, state column 1: non-finite value -inf").
#[test]
fn synthesis_noise_that_overflows_names_the_option() {
    let model = Model::<Linear2d>::reference().unwrap();
    let noisy = SynthesisOptions {
        noise: Noise {
            state_std: 1e308,
            derivative_std: 0.0,
        },
        ..synthesis_options(13)
    };
    let err = synthesize(&model, &noisy).unwrap_err().to_string();
    assert!(
        err.contains("state noise σ: 1e308 makes samples overflow"),
        "{err}"
    );
    let wild = SynthesisOptions {
        outliers: Some(Outliers {
            fraction: 0.5,
            magnitude: 1e308,
        }),
        ..synthesis_options(13)
    };
    let err = synthesize(&model, &wild).unwrap_err().to_string();
    assert!(err.contains("outlier magnitude: 1e308"), "{err}");
}

#[test]
fn synthesis_is_reproducible_by_seed_and_exact() {
    let model = Model::<Linear2d>::reference().unwrap();
    let a = synthesize(&model, &synthesis_options(11)).unwrap();
    let b = synthesize(&model, &synthesis_options(11)).unwrap();
    let c = synthesize(&model, &synthesis_options(12)).unwrap();
    assert_eq!(a, b, "same seed, same data");
    assert_ne!(
        a.train.states(),
        c.train.states(),
        "different seed, different data"
    );

    assert_eq!(a.trajectories.len(), 8);
    assert_eq!(a.train_trajectories, 6);
    assert_eq!(a.train.len(), 6 * 40);
    assert_eq!(a.held_out.as_ref().unwrap().len(), 2 * 40);
    let mut f = [0.0; 2];
    for (x, xdot) in a.train.iter() {
        assert!(x.iter().all(|v| v.abs() <= 1.5 + 1e-12));
        model.vector_field(x, &mut f).unwrap();
        assert_eq!(xdot, &f, "ẋ must be the exact vector field");
    }
    for traj in &a.trajectories {
        let t = traj.times();
        assert!(t[0] >= 1e-3 && *t.last().unwrap() <= 3.0);
        // Log-uniform: about half the samples fall below the geometric midpoint √(1e-3·3) ≈ 0.055.
        let early = t.iter().filter(|&&t| t < (3e-3f64).sqrt()).count();
        assert!((8..=32).contains(&early), "{early} of 40 early samples");
    }
    // Held-out = the last trajectories, whole.
    let held = a.held_out.as_ref().unwrap();
    assert_eq!(held.state(0), a.trajectories[6].state(0));
    assert_eq!(held.state(79), a.trajectories[7].state(39));

    // Uniform sampling and a ball of initial states, for the rigid body.
    let rigid = Model::<RigidBody>::reference().unwrap();
    let options = SynthesisOptions {
        trajectories: 3,
        ..SynthesisOptions::new(
            InitialStates::Ball {
                center: vec![0.0; 3],
                radius: 1.5,
            },
            SampleTimes::Uniform { interval: 0.1 },
        )
    };
    let data = synthesize(&rigid, &options).unwrap();
    assert_eq!(data.train.len(), 3 * 11);
    assert!(data.trajectories.iter().all(|t| {
        let x = t.state(0);
        (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt() <= 1.5
    }));
}

#[test]
fn noise_and_outliers_are_as_documented() {
    let model = Model::<Linear2d>::reference().unwrap();
    let clean = synthesize(&model, &synthesis_options(5)).unwrap();
    let noisy_options = SynthesisOptions {
        noise: Noise {
            state_std: 0.01,
            derivative_std: 0.1,
        },
        outliers: Some(Outliers {
            fraction: 0.1,
            magnitude: 50.0,
        }),
        ..synthesis_options(5)
    };
    let noisy = synthesize(&model, &noisy_options).unwrap();
    // Noise and outlier settings do not change the trajectories (separate streams).
    assert_eq!(noisy.trajectories, clean.trajectories);

    let m = clean.train.len();
    let expected_outliers = (0.1 * m as f64).round() as usize;
    assert_eq!(noisy.outlier_samples.len(), expected_outliers);
    let std_of = |a: &[f64], b: &[f64]| {
        let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        (d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / d.len() as f64).sqrt()
    };
    let state_std = std_of(noisy.train.states(), clean.train.states());
    println!("measured state noise σ = {state_std:.4} (480 values, requested 0.01)");
    assert!((state_std / 0.01 - 1.0).abs() < 0.15, "{state_std}");

    // Derivative noise only where no outlier was added; outliers only where listed.
    let mut inliers_noisy = Vec::new();
    let mut inliers_clean = Vec::new();
    let mut outlier_offsets = Vec::new();
    for i in 0..m {
        let (dn, dc) = (noisy.train.derivative(i), clean.train.derivative(i));
        if noisy.outlier_samples.binary_search(&i).is_ok() {
            outlier_offsets.extend(dn.iter().zip(dc).map(|(a, b)| a - b));
        } else {
            inliers_noisy.extend_from_slice(dn);
            inliers_clean.extend_from_slice(dc);
        }
    }
    let derivative_std = std_of(&inliers_noisy, &inliers_clean);
    println!("measured derivative noise σ = {derivative_std:.4} (requested 0.1)");
    assert!(
        (derivative_std / 0.1 - 1.0).abs() < 0.15,
        "{derivative_std}"
    );
    let outlier_rms =
        (outlier_offsets.iter().map(|v| v * v).sum::<f64>() / outlier_offsets.len() as f64).sqrt();
    println!(
        "outlier offset rms = {outlier_rms:.2} over {} values (requested 50)",
        outlier_offsets.len()
    );
    assert!((outlier_rms / 50.0 - 1.0).abs() < 0.35, "{outlier_rms}");

    // Held-out samples are noisy but never corrupted.
    let held_noisy = noisy.held_out.as_ref().unwrap();
    let held_clean = clean.held_out.as_ref().unwrap();
    let held_max = held_noisy
        .derivatives()
        .iter()
        .zip(held_clean.derivatives())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(
        held_max > 0.0 && held_max < 1.0,
        "held-out derivative deviation {held_max}"
    );
}

#[test]
fn synthesis_rejects_bad_options() {
    let model = Model::<Linear2d>::reference().unwrap();
    let check = |options: SynthesisOptions, needle: &str| {
        let err = synthesize(&model, &options).unwrap_err().to_string();
        assert!(err.contains(needle), "{err} lacks {needle}");
    };
    check(
        SynthesisOptions {
            held_out_trajectories: 8,
            ..synthesis_options(0)
        },
        "at least one trajectory must remain",
    );
    check(
        SynthesisOptions {
            initial: InitialStates::cube(3, 1.0),
            ..synthesis_options(0)
        },
        "expected length 2",
    );
    check(
        SynthesisOptions {
            times: SampleTimes::LogUniform {
                count: 5,
                first: 10.0,
            },
            ..synthesis_options(0)
        },
        "must lie in (0, duration",
    );
    check(
        SynthesisOptions {
            outliers: Some(Outliers {
                fraction: 1.5,
                magnitude: 1.0,
            }),
            ..synthesis_options(0)
        },
        "outlier fraction",
    );
    check(
        SynthesisOptions {
            noise: Noise {
                state_std: -1.0,
                derivative_std: 0.0,
            },
            ..synthesis_options(0)
        },
        "state noise",
    );
}

#[test]
fn simulated_trajectories_round_trip_through_csv() {
    let model = Model::<Linear2d>::reference().unwrap();
    let data = synthesize(&model, &synthesis_options(3)).unwrap();
    let path = scratch("synthetic.csv");
    write_trajectories(&path, &data.trajectories, WriteMode::CreateNew).unwrap();
    let back = read_trajectories::<Linear2d>(&path).unwrap();
    assert_eq!(back, data.trajectories);
    let err = read_trajectories::<RigidBody>(&path).unwrap_err();
    assert!(
        err.to_string().contains(
            "unknown column(s) `q`, `p`, `dq`, `dp`; expected columns: `t`, `px`, `py`, `pz`"
        ),
        "{err}"
    );
}

/// Errors name the physical line whatever the line endings, and blank lines
/// before a bad row do not move it.
#[test]
fn line_numbers_are_right_for_every_line_ending_and_blank_lines() {
    for (ending, label) in [("\n", "LF"), ("\r\n", "CRLF"), ("\r", "CR")] {
        let text = ["t,q,p", "0,1,2", "0.1,oops,2", ""].join(ending);
        let (err, _) = csv_error(&text);
        assert!(
            matches!(
                err,
                CsvError::NotANumber {
                    line: 3,
                    column: 2,
                    ..
                }
            ),
            "{label}: {err:?}"
        );
        // An error in the first data row is on line 2, not the header's.
        let text = ["t,q,p", "0,x,2", ""].join(ending);
        let (err, _) = csv_error(&text);
        assert!(
            matches!(err, CsvError::NotANumber { line: 2, .. }),
            "{label}: {err:?}"
        );
        // Two blank lines, then the bad row on line 5.
        let text = ["t,q,p", "0,1,2", "", "", "0.1,1,bad", ""].join(ending);
        let (err, _) = csv_error(&text);
        assert!(
            matches!(
                err,
                CsvError::NotANumber {
                    line: 5,
                    column: 3,
                    ..
                }
            ),
            "{label}: {err:?}"
        );
        // Times out of order on line 4 after a blank line.
        let text = ["t,q,p", "0,1,2", "", "0,1,2", ""].join(ending);
        let (err, _) = csv_error(&text);
        assert!(
            matches!(
                err,
                CsvError::NonIncreasingTime {
                    line: 4,
                    previous_line: 2,
                    ..
                }
            ),
            "{label}: {err:?}"
        );
    }
}

#[test]
fn a_huge_bad_cell_is_not_echoed_whole() {
    let cell = "x".repeat(1 << 20);
    let text = format!("t,q,p\n0,{cell},2\n");
    let (_, message) = csv_error(&text);
    assert!(message.len() < 400, "{} bytes", message.len());
    assert!(message.contains("1048576 bytes"), "{message}");
}

#[test]
fn an_unclosed_quote_is_named() {
    let (err, message) = csv_error("t,q,p\n0,1,2\n0.1,\"1,2\n0.2,3,4\n");
    assert!(
        matches!(err, CsvError::UnclosedQuote { line: 3, .. }),
        "{err:?}"
    );
    assert!(message.contains("quote"), "{message}");
}

#[test]
fn blank_files_and_trailing_commas_are_named() {
    for blank in ["", "   \n", "\n\n"] {
        let (err, _) = csv_error(blank);
        assert!(
            matches!(err, CsvError::NoHeader { .. }),
            "{blank:?}: {err:?}"
        );
    }
    let (err, message) = csv_error("t,q,p,\n0,1,2,\n");
    assert!(
        matches!(err, CsvError::EmptyColumnName { column: 4, .. }),
        "{err:?}"
    );
    assert!(message.contains("trailing comma"), "{message}");
    // Blank lines before the header are skipped, and counted.
    let (err, message) = csv_error("\n\nt,q\n0,1\n");
    assert!(
        matches!(err, CsvError::MissingColumns { line: 3, .. }),
        "{err:?}"
    );
    assert!(
        message.starts_with("line 3: missing column(s) `p`"),
        "{message}"
    );
    let (err, _) = csv_error("\r\n\r\nt,q,p\n");
    assert_eq!(err, CsvError::NoRows { line: 3 });
}

#[test]
fn sizes_beyond_memory_and_overflowing_estimates_are_errors_not_aborts() {
    let model = Model::<Linear2d>::reference().unwrap();
    // Counts a user may type for "as many as possible": refused before any
    // allocation, naming the setting.
    for (options, setting) in [
        (
            SynthesisOptions {
                trajectories: usize::MAX,
                held_out_trajectories: 0,
                ..synthesis_options(1)
            },
            "number of trajectories",
        ),
        // 10⁸ samples in all, but as 10⁸ trajectories of one sample: each
        // is an integration and allocations of its own.
        (
            SynthesisOptions {
                trajectories: 100_000_000,
                held_out_trajectories: 0,
                times: SampleTimes::LogUniform {
                    count: 1,
                    first: 1e-3,
                },
                ..synthesis_options(1)
            },
            "must be between 1 and 10⁶",
        ),
        (
            SynthesisOptions {
                times: SampleTimes::LogUniform {
                    count: usize::MAX,
                    first: 1e-3,
                },
                ..synthesis_options(1)
            },
            "log-uniform sample count",
        ),
    ] {
        let error = synthesize(&model, &options).unwrap_err();
        assert!(error.to_string().contains(setting), "{error}");
    }
    // A wrong width is reported as such, whatever `dim` claims.
    let error = Dataset::from_rows(usize::MAX, &[[0.0]], &[[0.0]]).unwrap_err();
    assert!(error.to_string().contains("sample 0"), "{error}");
    // Finite values whose finite difference overflows: an error naming the
    // sample, not an infinite or NaN derivative.
    let error = metriplectic_runtime::differentiate(
        &[0.0, 0.1, 0.2],
        &[1e308, 0.0, -1e308],
        &DerivativeMethod::FiniteDifference { order: 2 },
    )
    .unwrap_err();
    assert!(error.to_string().contains("at sample 0"), "{error}");
    // The same through a trajectory list: which trajectory and variable.
    let names = vec!["q".to_owned(), "p".to_owned()];
    let overflowing = Trajectory::new(
        names,
        vec![0.0, 0.1, 0.2],
        vec![0.0, 1e308, 0.0, 0.0, 0.0, -1e308],
        None,
    )
    .unwrap()
    .with_id("run7");
    let error = metriplectic_runtime::estimate_all(
        &[overflowing],
        &DerivativeMethod::FiniteDifference { order: 2 },
    )
    .unwrap_err();
    assert!(
        error.to_string().contains(
            "invalid trajectory 0 (id \"run7\"): variable `p`: derivative estimate: at sample 0"
        ),
        "{error}"
    );
}

#[test]
fn a_state_name_given_twice_is_refused_before_reading() {
    let error = metriplectic_runtime::read_trajectories_from("t,q\n0,1\n".as_bytes(), &["q", "q"])
        .unwrap_err();
    assert!(
        error
            .to_string()
            .contains("`q` is both variable 0 and variable 1"),
        "{error}"
    );
}

/// Data are positional: trajectories naming the system's variables in
/// another order would fit a model with the variables swapped. Data built
/// from trajectories carry their names, and identification checks them.
#[test]
fn data_named_otherwise_than_the_system_are_refused() {
    let model = Model::<Linear2d>::reference().unwrap();
    let synthetic = synthesize(&model, &synthesis_options(21)).unwrap();
    let names = |t: &Trajectory| t.names().to_vec();
    assert_eq!(
        synthetic.train.state_names(),
        Some(&names(&synthetic.trajectories[0])[..])
    );
    let swapped: Vec<Trajectory> = synthetic
        .trajectories
        .iter()
        .map(|t| {
            let derivatives = t.derivatives().map(<[f64]>::to_vec);
            let names = vec!["p".to_owned(), "q".to_owned()];
            Trajectory::new(names, t.times().to_vec(), t.states().to_vec(), derivatives).unwrap()
        })
        .collect();
    let config = IdentifyConfig {
        max_iterations: 1,
        ..crate::common::alternation()
    };
    let pointwise = metriplectic_runtime::dataset_from_trajectories(&swapped).unwrap();
    let weak = WeakDataset::from_trajectories(&swapped, &WeakForm::default()).unwrap();
    let message = "the data's state variables are (p, q), system `Linear2d` has (q, p)";
    let err = identify::<Linear2d>(&pointwise, &config).unwrap_err();
    assert!(err.to_string().contains(message), "{err}");
    let err = identify::<Linear2d>(&weak, &config).unwrap_err();
    assert!(err.to_string().contains(message), "{err}");
    // The same numbers named as the system names them, or not named, fit.
    identify::<Linear2d>(&synthetic.train, &config).unwrap();
    let unnamed = Dataset::from_flat(
        2,
        pointwise.states().to_vec(),
        pointwise.derivatives().to_vec(),
    )
    .unwrap();
    assert_eq!(unnamed.state_names(), None);
    identify::<Linear2d>(&unnamed, &config).unwrap();

    // A trajectory that cannot give samples is named among many.
    let mut mixed = synthetic.trajectories.clone();
    mixed[3] = synthetic.measured[3].clone();
    let err = metriplectic_runtime::dataset_from_trajectories(&mixed).unwrap_err();
    assert!(
        err.to_string()
            .contains("trajectory 3 (id \"3\"): trajectory: it has no derivatives"),
        "{err}"
    );
    // Renaming a dataset checks the count and repeats.
    let err = unnamed
        .clone()
        .with_state_names(vec!["q".into()])
        .unwrap_err();
    assert!(
        err.to_string().contains("expected length 2, got 1"),
        "{err}"
    );
    let err = unnamed
        .with_state_names(vec!["q".into(), "q".into()])
        .unwrap_err();
    assert!(
        err.to_string()
            .contains("`q` is both variable 0 and variable 1"),
        "{err}"
    );
}
