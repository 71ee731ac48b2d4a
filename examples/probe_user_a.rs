//! Scratch probe (not part of the project).
use std::time::Instant;

use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    synthesize, InitialStates, Noise, SampleTimes, SolveStatus, SynthesisOptions,
};

metriplectic! {
    /// A: Euler body with inertias 1, 2, 4 and a linear term in H; constant metric.
    pub struct EulerTilt;
    state (px, py, pz);
    const c = 0.5;
    poisson = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]];
    hamiltonian = 0.5 * px^2 + 0.25 * py^2 + 0.125 * pz^2 + c * pz;
    entropy degree 4;
    metric degree 2;
    reference {
        entropy = -(px^2 + 2*py^2 + 3*pz^2) + 0.5*px*py - 0.25*(px^4 + py^4 + pz^4)
            - (0.5 * px^2 + 0.25 * py^2 + 0.125 * pz^2 + c * pz);
        metric = [[0.3, 0.1, 0], [0.1, 0.2, 0], [0, 0, 0.25]];
    }
}

metriplectic! {
    /// B: asymmetric quartic well with position-dependent friction.
    pub struct QuarticFriction;
    state (q, p);
    const omega2 = 1.0;
    const alpha = 0.3;
    const beta = 0.5;
    const c0 = 0.2;
    const c1 = 0.3;
    poisson = [[0, 1], [-1, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * omega2 * q^2 + alpha * q^3 + 0.25 * beta * q^4;
    entropy degree 4;
    metric degree 2;
    region ball(radius = 3);
    reference {
        entropy = -2 * (0.5 * p^2 + 0.5 * omega2 * q^2 + alpha * q^3 + 0.25 * beta * q^4) - 0.1 * p^4;
        metric = [[0, 0], [0, c0 + c1 * q^2]];
    }
}

metriplectic! {
    /// C: two coupled oscillators, damping on the momenta, constant metric.
    pub struct Coupled2;
    state (q1, q2, p1, p2);
    const kappa = 0.5;
    poisson = [[0, 0, 1, 0], [0, 0, 0, 1], [-1, 0, 0, 0], [0, -1, 0, 0]];
    hamiltonian = 0.5 * (p1^2 + p2^2) + 0.5 * q1^2 + q2^2 + 0.5 * kappa * (q1 - q2)^2;
    entropy degree 4;
    metric degree 0;
    reference {
        entropy = -2 * (0.5 * (p1^2 + p2^2) + 0.5 * q1^2 + q2^2 + 0.5 * kappa * (q1 - q2)^2)
            - 0.1 * q1^4 - 0.1 * q2^4;
        metric = [[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0.3, 0.1], [0, 0, 0.1, 0.2]];
    }
}

metriplectic! {
    /// D: thermal anharmonic oscillator in the classical form.
    pub struct ThermalQuartic;
    state (q, p, s);
    const gamma = 0.3;
    poisson = [[0, 1, 0], [-1, 0, 0], [0, 0, 0]];
    hamiltonian = 0.5 * p^2 + 0.5 * q^2 + 0.25 * q^4 + s;
    entropy degree 2;
    metric degree 2;
    region ball(radius = 3);
    classical;
    reference {
        entropy = s - 0.1 * s^2;
        metric = [[0, 0, 0], [0, gamma, -gamma * p], [0, -gamma * p, gamma * p^2]];
    }
}

fn statuses<S: MetriplecticSystem>(fit: &metriplectic_runtime::Identification<S>) -> String {
    let mut bad = Vec::new();
    for r in &fit.history.iterations {
        for (name, step) in [
            ("metric", Some(&r.metric)),
            ("entropy", Some(&r.entropy)),
            ("joint", r.joint.as_ref().map(|j| &j.step)),
        ] {
            if let Some(step) = step {
                if step.report.status != SolveStatus::Solved {
                    bad.push(format!(
                        "it{} {name}: {:?} ({:?})",
                        r.iteration, step.report.status, step.outcome
                    ));
                }
            }
        }
    }
    if bad.is_empty() {
        "none".into()
    } else {
        bad.join("; ")
    }
}

fn report<S: MetriplecticSystem, D: IdentificationData>(
    label: &str,
    data: &D,
    truth: &Model<S>,
    held_out: &Dataset,
    starts: &[f64],
    duration: f64,
    config: &IdentifyConfig,
) {
    let t = Instant::now();
    let fit = match identify::<S>(data, config) {
        Ok(f) => f,
        Err(e) => {
            println!("  [{label}] identify ERROR: {e}");
            return;
        }
    };
    let secs = t.elapsed().as_secs_f64();
    let score = fit.model.compare(truth, held_out).unwrap();
    println!(
        "  [{label}] held-out rel err {:.3e}, stop {:?}, iterations {}, {:.2}s, non-Solved: {}",
        score.relative_error,
        fit.stop_reason,
        fit.history.iterations.len(),
        secs,
        statuses(&fit)
    );
    for w in &fit.warnings {
        println!("    warning: {w}");
    }
    let opts = SimulationOptions::default();
    let mut ok = 0;
    let n = S::DIM;
    for x0 in starts.chunks_exact(n) {
        match simulate(&fit.model, x0, 0.0, duration, &opts) {
            Ok(sim) => {
                if sim.energy.is_non_decreasing() {
                    ok += 1;
                } else {
                    println!(
                        "    simulate from {x0:?}: energy check FAILED {:?}",
                        sim.energy
                    );
                }
            }
            Err(e) => println!("    simulate from {x0:?}: ERROR {e}"),
        }
    }
    println!(
        "    energy non-decreasing on {ok}/{} held-out starts",
        starts.len() / n
    );
    match metriplectic_runtime::identifiability(&fit.model, data, &metriplectic_runtime::IdentifiabilityOptions::default()) {
        Ok(r) => println!("    identifiability: unknowns {}, rank {}, flat {}", r.unknowns, r.rank, r.flat_directions.len()),
        Err(e) => println!("    identifiability ERROR: {e}"),
    }
    if std::env::var("PROBE_PRINT").is_ok() {
        println!("{}", fit.model);
        println!("truth:\n{}", truth);
    }
}

fn run<S: MetriplecticSystem>(name: &str, initial: InitialStates, duration: f64) {
    println!("=== {name} ===");
    let truth = match Model::<S>::reference() {
        Ok(m) => m,
        Err(e) => {
            println!("  reference ERROR: {e}");
            return;
        }
    };
    let base = SynthesisOptions {
        trajectories: 120,
        duration,
        held_out_trajectories: 20,
        seed: 1,
        ..SynthesisOptions::new(
            initial,
            SampleTimes::LogUniform {
                count: 50,
                first: 1e-3,
            },
        )
    };
    let t = Instant::now();
    let clean = match synthesize(&truth, &base) {
        Ok(d) => d,
        Err(e) => {
            println!("  synthesize ERROR: {e}");
            return;
        }
    };
    println!("  synthesized in {:.2}s", t.elapsed().as_secs_f64());
    let held_out_clean =
        Dataset::from_trajectories(&clean.trajectories[clean.train_trajectories..], None).unwrap();
    let starts: Vec<f64> = clean.trajectories[clean.train_trajectories..]
        .iter()
        .take(5)
        .flat_map(|tr| tr.state(0).to_vec())
        .collect();
    let config = IdentifyConfig::default();
    report::<S, _>(
        "exact xdot",
        &clean.train,
        &truth,
        &held_out_clean,
        &starts,
        duration,
        &config,
    );

    let states = clean.train.states();
    let rms = (states.iter().map(|v| v * v).sum::<f64>() / states.len() as f64).sqrt();
    let noisy_opts = SynthesisOptions {
        noise: Noise {
            state_std: 0.01 * rms,
            derivative_std: 0.0,
        },
        ..base
    };
    let noisy = synthesize(&truth, &noisy_opts).unwrap();
    let form = WeakForm::default();
    let weak =
        match WeakDataset::from_trajectories(&noisy.measured[..noisy.train_trajectories], &form) {
            Ok(w) => w,
            Err(e) => {
                println!("  weak ERROR: {e}");
                return;
            }
        };
    report::<S, _>(
        "weak 1% noise",
        &weak,
        &truth,
        &held_out_clean,
        &starts,
        duration,
        &config,
    );
}

fn main() {
    let which = std::env::args().nth(1).unwrap_or_default();
    if which.is_empty() || which == "a" {
        run::<EulerTilt>(
            "A EulerTilt",
            InitialStates::Ball {
                center: vec![0.0; 3],
                radius: 1.5,
            },
            5.0,
        );
    }
    if which.is_empty() || which == "b" {
        run::<QuarticFriction>("B QuarticFriction", InitialStates::cube(2, 1.5), 5.0);
    }
    if which.is_empty() || which == "c" {
        run::<Coupled2>("C Coupled2", InitialStates::cube(4, 1.0), 5.0);
    }
    if which.is_empty() || which == "d" {
        run::<ThermalQuartic>(
            "D ThermalQuartic",
            InitialStates::Box {
                lower: vec![-1.5, -1.5, -1.0],
                upper: vec![1.5, 1.5, 1.0],
            },
            5.0,
        );
    }
}
