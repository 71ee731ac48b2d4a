//! The classical (GENERIC) form end to end: a cold start identifies the
//! relaxing rigid body and a thermal oscillator under their constraints
//! (S a Casimir, K∇H ≡ 0) so that H is conserved and S produced by the
//! identified field; models that break the constraints are refused, and
//! model files record the form.

use metriplectic::classical::residuals;
use metriplectic::systems::{classical_rigid_body_data, ClassicalRigidBody};
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    identifiability, select_degrees, DegreeOptions, FlatKind, Gauge, IdentifiabilityOptions,
    IdentifyConfig, IdentifyWarning, SearchOptions,
};

#[test]
fn a_cold_start_identifies_the_classical_body_under_its_constraints() {
    let train = classical_rigid_body_data(400, 1);
    let held_out = classical_rigid_body_data(200, 2);
    let fit = identify::<ClassicalRigidBody>(&train, &IdentifyConfig::default()).unwrap();
    let truth = Model::<ClassicalRigidBody>::reference().unwrap();
    let score = fit.model.compare(&truth, &held_out).unwrap();
    assert!(score.relative_error <= 1e-6, "{score:?}");
    assert_classical_structure(&fit.model, &held_out);

    // The data fix everything but the scale (K, S) ↦ (cK, S/c).
    let report = identifiability(&fit.model, &train, &IdentifiabilityOptions::default()).unwrap();
    // Two Casimirs (|p|², |p|⁴) and the six metrics [v]ₓᵀ A [v]ₓ.
    assert_eq!(report.unknowns, 8, "{report}");
    assert_eq!(report.flat_directions.len(), 1, "{report}");
    assert_eq!(
        report.flat_directions[0].kind,
        FlatKind::ScaleSymmetry,
        "{report}"
    );
    // The run says so itself: (cK, S/c) fits any data as well.
    assert!(
        fit.warnings
            .contains(&IdentifyWarning::ScaleSymmetry { classical: true }),
        "{:?}",
        fit.warnings
    );
}

/// Degree selection with its default caps: metric degree 0 holds no
/// classical metric of the rigid body (K∇H ≡ 0 needs K to vary with the
/// state), so it is skipped and said to be, not an error for the whole
/// selection (a probe found "the default start metric has terms the support
/// holds at zero" there).
#[test]
fn degree_selection_skips_metric_caps_without_a_classical_metric() {
    let train = classical_rigid_body_data(300, 11);
    let validation = classical_rigid_body_data(150, 12);
    let selection = select_degrees::<ClassicalRigidBody, _>(
        &train,
        &validation,
        &IdentifyConfig::default(),
        &DegreeOptions::default(),
    )
    .unwrap();
    assert_eq!(selection.skipped_metric_degrees, vec![0]);
    let chosen = &selection.candidates[selection.chosen];
    assert_eq!(chosen.metric_degree, 2, "{:#?}", selection.candidates);
    assert_eq!(chosen.entropy_degree, 4, "{:#?}", selection.candidates);
    assert!(
        chosen.validation.per_component < 1e-8,
        "{:#?}",
        selection.candidates
    );
    // Only degree 0 asked for: nothing to try, and the error says why.
    let error = select_degrees::<ClassicalRigidBody, _>(
        &train,
        &validation,
        &IdentifyConfig::default(),
        &DegreeOptions {
            metric: Some(vec![0]),
            ..DegreeOptions::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(error.contains("K∇H ≡ 0"), "{error}");
}

/// The model meets its classical rows to rounding, and its field conserves
/// H and produces S at every state of `data`, to rounding relative to
/// |f|·|∇H|.
fn assert_classical_structure<S: MetriplecticSystem>(model: &Model<S>, data: &Dataset) {
    let (entropy, metric) = residuals(model);
    assert!(
        entropy <= 1e-12 && metric <= 1e-12,
        "{entropy:e} {metric:e}"
    );
    let n = S::DIM;
    let (mut f, mut grad_h, mut grad_s) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(u, v)| u * v).sum::<f64>();
    for x in data.states().chunks_exact(n) {
        model.vector_field(x, &mut f).unwrap();
        S::hamiltonian_gradient(x, &mut grad_h);
        S::entropy_gradient(x, model.entropy_coefficients(), &mut grad_s);
        let size = dot(&f, &f).sqrt() * dot(&grad_h, &grad_h).sqrt();
        assert!(
            dot(&grad_h, &f).abs() <= 1e-12 * size.max(1e-300),
            "dH/dt at {x:?}"
        );
        assert!(
            dot(&grad_s, &f) >= -1e-12 * size.max(1e-300),
            "dS/dt at {x:?}"
        );
    }
}

/// `count` states uniform in [−half, half]ⁿ with ẋ from `S`'s reference.
fn cube_samples<S: MetriplecticSystem>(count: usize, seed: u64, half: f64) -> Dataset {
    use rand::Rng;
    metriplectic::systems::reference_samples::<S>(count, seed, |rng| {
        (0..S::DIM).map(|_| rng.random_range(-half..half)).collect()
    })
}

#[test]
fn models_that_break_the_classical_constraints_are_refused() {
    let truth = Model::<ClassicalRigidBody>::reference().unwrap();
    let psi = truth.entropy_coefficients().to_vec();
    let theta = truth.metric_coefficients().to_vec();

    // The identity metric dissipates H.
    let mut identity = vec![0.0; theta.len()];
    let m = ClassicalRigidBody::METRIC_EXPONENTS.len();
    for pair in [0, 3, 5] {
        identity[pair * m] = 1.0;
    }
    let error = Model::<ClassicalRigidBody>::new(psi.clone(), identity.clone()).unwrap_err();
    assert!(matches!(error, Error::NotClassical { .. }), "{error}");
    assert!(error.to_string().contains("K(x)∇H(x) ≡ 0"), "{error}");

    // H itself (coefficients 0.5, 0.25, 0.125 on px², py², pz²) is no Casimir.
    let mut not_casimir = psi.clone();
    not_casimir[3] += 0.1;
    let error = Model::<ClassicalRigidBody>::new(not_casimir, theta.clone()).unwrap_err();
    assert!(error.to_string().contains("Casimir"), "{error}");

    // A run refuses such a start instead of identifying from it.
    let data = classical_rigid_body_data(50, 3);
    let config = IdentifyConfig {
        initial_metric: Some(identity),
        ..IdentifyConfig::default()
    };
    let error = identify::<ClassicalRigidBody>(&data, &config).unwrap_err();
    assert!(matches!(error, Error::NotClassical { .. }), "{error}");

    // tr K(0) is zero for every metric with K∇H ≡ 0 here: no gauge on it.
    let config = IdentifyConfig {
        search: SearchOptions {
            gauge: Some(Gauge::MetricTrace(3.0)),
            ..SearchOptions::default()
        },
        ..IdentifyConfig::default()
    };
    let error = identify::<ClassicalRigidBody>(&data, &config).unwrap_err();
    assert!(error.to_string().contains("classical"), "{error}");
}

#[test]
fn model_files_record_the_formalism() {
    let truth = Model::<ClassicalRigidBody>::reference().unwrap();
    let json = truth.to_json().unwrap();
    assert!(json.contains("\"formalism\": \"classical\""), "{json}");
    assert_eq!(
        Model::<ClassicalRigidBody>::from_json(&json).unwrap(),
        truth
    );
    let edited = json.replace(
        "\"formalism\": \"classical\"",
        "\"formalism\": \"generalized\"",
    );
    let error = Model::<ClassicalRigidBody>::from_json(&edited).unwrap_err();
    assert!(matches!(error, Error::WrongSystem { .. }), "{error}");
    assert!(error.to_string().contains("generalized form"), "{error}");
}

/// The `classical` example's pipeline: a cold start, then 10⁴
/// discrete-gradient steps per trajectory of the identified model.
#[test]
fn the_classical_example_conserves_h_and_never_lets_s_fall() {
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("classical");
    let summary = metriplectic::classical::run(&metriplectic::classical::Options {
        seed: 1,
        train_samples: 400,
        heldout_samples: 200,
        trajectories: 2,
        steps: 10_000,
        step: 0.01,
        out: out.clone(),
        force: true,
        quiet: true,
    })
    .unwrap();
    assert!(summary.heldout_relative_error <= 1e-6, "{summary:?}");
    assert!(summary.casimir_residual <= 1e-12 && summary.degeneracy_residual <= 1e-12);
    assert_eq!(summary.steps, 20_000);
    assert!(summary.max_energy_drift <= 1e-12, "{summary:?}");
    assert_eq!(summary.entropy_decrease_fraction, 0.0, "{summary:?}");
    // DOPRI5 conserves H only to its tolerance: the contrast is real.
    let dopri5 = summary
        .max_energy_drift_dopri5
        .expect("DOPRI5 integrates at step 0.01");
    assert!(dopri5 > 100.0 * summary.max_energy_drift.max(1e-16));
    assert_eq!(summary.dopri5_failure, None);
    assert_eq!(summary.unidentifiable_directions.len(), 1);
    // The run's warnings reach the summary (they were dropped): here the
    // scale the classical form never determines.
    assert!(
        summary.warnings.iter().any(|w| w.contains("(cK, S/c)")),
        "{:?}",
        summary.warnings
    );
    let written: metriplectic::classical::Summary =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(written, summary);
    // No samples is an error that names the option (it panicked), and so
    // are no trajectories (a vacuous report of 0 steps before).
    for (train, held_out, trajectories, option) in [
        (0, 200, 2, "--train-samples"),
        (400, 0, 2, "--heldout-samples"),
        (400, 200, 0, "--trajectories"),
    ] {
        let error = metriplectic::classical::run(&metriplectic::classical::Options {
            seed: 1,
            train_samples: train,
            heldout_samples: held_out,
            trajectories,
            steps: 10,
            step: 0.01,
            out: out.clone(),
            force: true,
            quiet: true,
        })
        .unwrap_err();
        assert!(error.to_string().contains(option), "{error}");
    }
    // A step DOPRI5 cannot take is reported in the summary, and the
    // discrete gradient's results are kept (the whole run failed).
    let summary = metriplectic::classical::run(&metriplectic::classical::Options {
        seed: 1,
        train_samples: 400,
        heldout_samples: 200,
        trajectories: 8,
        steps: 3000,
        step: 10.0,
        out: out.clone(),
        force: true,
        quiet: true,
    })
    .unwrap();
    assert_eq!(summary.steps, 24_000);
    assert_eq!(summary.entropy_decrease_fraction, 0.0, "{summary:?}");
    assert!(
        summary.max_energy_drift_dopri5.is_none() && summary.dopri5_failure.is_some(),
        "{summary:?}"
    );
}

metriplectic! {
    /// An oscillator beside a relaxing internal variable, in the classical
    /// form without a region: Π acts on (q, p) only, so the Casimirs are
    /// the functions of s, and a constant K with K∇H ≡ 0 acts on s only.
    struct OscillatorAndInternalVariable;
    state (q, p, s);
    poisson = [[0, 1, 0], [-1, 0, 0], [0, 0, 0]];
    hamiltonian = 0.5 * q^2 + 0.5 * p^2;
    entropy degree 4;
    metric degree 0;
    classical;
    reference {
        entropy = -0.5 * s^2 - 0.25 * s^4;
        metric = [[0, 0, 0], [0, 0, 0], [0, 0, 0.7]];
    }
}

/// Where |∇H|²I − ∇H∇Hᵀ is not in the (constant) metric basis, a cold
/// start begins at the identity projected onto K∇H ≡ 0.
#[test]
fn a_classical_system_without_a_region_starts_from_the_projected_identity() {
    let sample = cube_samples::<OscillatorAndInternalVariable>;
    let (train, held_out) = (sample(300, 1, 1.5), sample(100, 2, 1.5));
    let fit =
        identify::<OscillatorAndInternalVariable>(&train, &IdentifyConfig::default()).unwrap();
    let truth = Model::<OscillatorAndInternalVariable>::reference().unwrap();
    let score = fit.model.compare(&truth, &held_out).unwrap();
    assert!(score.relative_error <= 1e-6, "{score:?}");
    // K acts on s alone.
    let theta = fit.model.metric_coefficients();
    assert!(
        theta[..5].iter().all(|t| t.abs() < 1e-12) && theta[5] > 0.0,
        "{theta:?}"
    );
}

metriplectic! {
    /// A thermal oscillator: friction on p heats the internal variable s
    /// (temperature T = ∂H/∂s = s). K = γ w wᵀ with w = (0, s, −p), so
    /// K∇H = γ w (sp − ps) ≡ 0 and ṡ = γp² ≥ 0: GENERIC with a singular,
    /// state-dependent metric of degree 2.
    struct ThermalOscillator;
    state (q, p, s);
    poisson = [[0, 1, 0], [-1, 0, 0], [0, 0, 0]];
    hamiltonian = 0.5 * q^2 + 0.5 * p^2 + 0.5 * s^2;
    entropy degree 2;
    metric degree 2;
    region box(q in [-3, 3], p in [-3, 3], s in [-3, 3]);
    classical;
    reference {
        entropy = s;
        metric = [[0, 0, 0], [0, 0.2 * s^2, -0.2 * p * s], [0, -0.2 * p * s, 0.2 * p^2]];
    }
}

/// A thermodynamic system nobody declared before: the classical form
/// recovers its field from a cold start, and the identified field conserves
/// H and produces S. (The same system declared without `classical;` creeps
/// along a valley of the generalized fit: docs/method.md §3.)
#[test]
fn a_thermal_oscillator_is_identified_in_the_classical_form() {
    let sample = cube_samples::<ThermalOscillator>;
    let (train, held_out) = (sample(600, 1, 1.0), sample(200, 2, 1.0));
    let fit = identify::<ThermalOscillator>(&train, &IdentifyConfig::default()).unwrap();
    let truth = Model::<ThermalOscillator>::reference().unwrap();
    let score = fit.model.compare(&truth, &held_out).unwrap();
    assert!(score.relative_error <= 1e-9, "{score:?}");
    assert_classical_structure(&fit.model, &held_out);
    // Ranks are counted where the classical equalities leave room. The
    // degree-2 metrics with K(x)x ≡ 0 are [x]ₓ C [x]ₓᵀ for a symmetric
    // constant C: 6 unknowns, not the free coefficients. With S = s the
    // data see only K's last column, which fixes 5 of them; C = e_s e_sᵀ,
    // adding (p, −q, 0)(p, −q, 0)ᵀ, is truly undetermined.
    let metric_warning = fit.warnings.iter().find_map(|w| match w {
        metriplectic_runtime::IdentifyWarning::RankDeficient {
            block: metriplectic_runtime::CoefficientBlock::Metric,
            rank,
            coefficients,
        } => Some((*rank, *coefficients)),
        _ => None,
    });
    assert_eq!(metric_warning, Some((5, 6)), "{:?}", fit.warnings);
}

/// The equations are counted against the unknowns the classical form's
/// equalities leave (8 of the rigid body's 94 coefficients): 4 samples
/// determine the model, and the run said "12 equations for 94 unknown
/// coefficients: the data cannot determine the model" (a probe); 2
/// samples (6 equations) do not, and say so with the right count.
#[test]
fn the_equations_are_counted_against_what_the_equalities_leave() {
    let held_out = classical_rigid_body_data(100, 2);
    let truth = Model::<ClassicalRigidBody>::reference().unwrap();
    let fit = identify::<ClassicalRigidBody>(
        &classical_rigid_body_data(4, 5),
        &IdentifyConfig::default(),
    )
    .unwrap();
    let score = fit.model.compare(&truth, &held_out).unwrap();
    println!("4 samples: {score:?}, {:?}", fit.warnings);
    assert!(score.relative_error <= 1e-6, "{score:?}");
    assert!(
        !fit.warnings
            .iter()
            .any(|w| matches!(w, IdentifyWarning::Underdetermined { .. })),
        "{:?}",
        fit.warnings
    );
    let fit = identify::<ClassicalRigidBody>(
        &classical_rigid_body_data(2, 5),
        &IdentifyConfig::default(),
    )
    .unwrap();
    assert!(
        fit.warnings.iter().any(|w| matches!(
            w,
            IdentifyWarning::Underdetermined {
                equations: 6,
                unknowns: 8
            }
        )),
        "{:?}",
        fit.warnings
    );
}
