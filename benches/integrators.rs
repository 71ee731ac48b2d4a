//! DOPRI5 against the discrete gradient: cost per unit time, and what each
//! keeps of the structure.
//!
//! Each case simulates a reference model over 10³ time units from one
//! initial state: the paper's `Linear2d` and `RigidBody` (generalized
//! form), and a rigid body in the classical form declared here, whose
//! Hamiltonian the classical discrete gradient conserves. Methods: DOPRI5
//! at its default tolerances (rtol 1e-6, atol 1e-9), capped at steps of 0.5
//! where the defaults stop with "stiff" (both paper systems), or at
//! rtol 1e-3; the discrete gradient at a step chosen for an error
//! comparable to DOPRI5's, and at one larger step.
//!
//! Before timing, one run of each case with every step as an output
//! prints (once, to stderr) a Markdown table: steps, evaluations per step,
//! the steps where the free energy fell beyond rounding (E(xₖ) − E(xₖ₊₁)
//! above the rounding bound ρ(xₖ) + ρ(xₖ₊₁) of evaluating E, the bound
//! `simulate` documents) and the largest fall, the relative drift
//! max |H(xₖ) − H(x₀)|/|H(x₀)| of the classical body (conserved there; in
//! the generalized systems H is not conserved, nor is the rigid body's
//! Casimir |p|², which K = I dissipates), and the errors at t = 10 (in the
//! transient) and at t = 10³ against DOPRI5 at rtol 1e-12 with steps
//! ≤ 0.01. Criterion then times one simulation of 10³ time units per case
//! (only the final state as output).
//!
//! `cargo bench --bench integrators` (under a minute once built);
//! `-- --quick` shortens the timing, `-- --scan` prints the table for a
//! range of steps and DOPRI5 settings instead, without timing.

use std::time::Duration;

use criterion::Criterion;
use metriplectic::systems::{Linear2d, RigidBody};
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{IntegratorOptions, Method, OutputTimes};

metriplectic! {
    /// A rigid body in the classical form: H = x²/2 + y²/4 + z²/8, the
    /// Casimir entropy S = −|p|² and K = |∇H|² I − ∇H ∇Hᵀ (K∇H ≡ 0), so H is
    /// conserved while |p| relaxes to the x axis (a steady rotation).
    pub struct ClassicalRigidBody;
    state (x, y, z);
    poisson = [[0, -z, y], [z, 0, -x], [-y, x, 0]];
    hamiltonian = 0.5 * x^2 + 0.25 * y^2 + 0.125 * z^2;
    entropy degree 2;
    metric degree 2;
    region ball(radius = 2);
    classical;
    reference {
        entropy = -(x^2 + y^2 + z^2);
        metric = [[0.25 * y^2 + 0.0625 * z^2, -0.5 * x * y, -0.25 * x * z],
                  [-0.5 * x * y, x^2 + 0.0625 * z^2, -0.125 * y * z],
                  [-0.25 * x * z, -0.125 * y * z, x^2 + 0.25 * y^2]];
    }
}

/// Simulated time of every case.
const DURATION: f64 = 1000.0;

/// DOPRI5's default rtol (atol 1e-9 = 1e-3·rtol).
const DEFAULT_RTOL: f64 = 1e-6;

/// One integrator setting of a case.
#[derive(Debug, Clone, Copy)]
enum Integrator {
    /// DOPRI5 at this rtol (atol = 1e-3·rtol) and an optional largest step.
    Dopri5(f64, Option<f64>),
    /// The discrete gradient with this step.
    DiscreteGradient(f64),
}

impl Integrator {
    fn options(self, output: OutputTimes) -> SimulationOptions {
        let mut integrator = IntegratorOptions {
            max_steps: 100_000_000,
            ..IntegratorOptions::default()
        };
        let method = match self {
            Self::Dopri5(rtol, max_step) => {
                integrator.rtol = rtol;
                integrator.atol = 1e-3 * rtol;
                integrator.max_step = max_step;
                Method::Dopri5
            }
            Self::DiscreteGradient(step) => Method::DiscreteGradient { step },
        };
        SimulationOptions {
            method,
            output,
            integrator,
            ..SimulationOptions::default()
        }
    }

    fn label(self) -> String {
        match self {
            Self::Dopri5(rtol, max_step) => {
                let mut label = "DOPRI5".to_owned();
                if rtol != DEFAULT_RTOL {
                    label += &format!(", rtol {rtol:e}");
                }
                if let Some(h) = max_step {
                    label += &format!(", steps ≤ {h}");
                }
                label
            }
            Self::DiscreteGradient(step) => format!("discrete gradient, h = {step}"),
        }
    }
}

/// The rounding bound of evaluating E at x, (p + r)·ε·(|H| + Σ|ψₖφₖ|).
fn rounding<S: MetriplecticSystem>(model: &Model<S>, x: &[f64]) -> f64 {
    let mut features = vec![0.0; S::entropy_coefficient_count()];
    S::entropy_features(x, &mut features);
    let magnitude: f64 = features
        .iter()
        .zip(model.entropy_coefficients())
        .map(|(f, c)| (f * c).abs())
        .sum();
    let terms = (S::entropy_coefficient_count() + S::ENTROPY_DEGREE as usize) as f64;
    terms * f64::EPSILON * (S::hamiltonian(x).abs() + magnitude)
}

/// One row of the structure table.
fn report<S: MetriplecticSystem>(
    name: &str,
    model: &Model<S>,
    x0: &[f64],
    method: Integrator,
    exact: &[f64],
) {
    let sim = match simulate(
        model,
        x0,
        0.0,
        DURATION,
        &method.options(OutputTimes::Steps),
    ) {
        Ok(sim) => sim,
        Err(err) => {
            eprintln!("| {name} | {} | fails: {err} | | | | | | |", method.label());
            return;
        }
    };
    let traj = &sim.trajectory;
    let mut falls = 0;
    let mut largest_fall = 0.0f64;
    let mut previous_rounding = rounding(model, traj.state(0));
    for k in 0..traj.len() - 1 {
        let next_rounding = rounding(model, traj.state(k + 1));
        let fall = sim.free_energy[k] - sim.free_energy[k + 1];
        if fall > previous_rounding + next_rounding {
            falls += 1;
        }
        largest_fall = largest_fall.max(fall);
        previous_rounding = next_rounding;
    }
    let drift = if S::CLASSICAL.is_some() {
        let h0 = S::hamiltonian(x0);
        let worst = (0..traj.len())
            .map(|k| (S::hamiltonian(traj.state(k)) - h0).abs() / h0.abs())
            .fold(0.0, f64::max);
        format!("{worst:.1e}")
    } else {
        "n/a".to_owned()
    };
    // The errors at t = 10 (in the transient) and at the end.
    let errors = simulate(model, x0, 0.0, DURATION, &method.options(checkpoints()))
        .map(|sim| {
            let states = sim.trajectory.states().chunks_exact(S::DIM);
            states
                .zip(exact.chunks_exact(S::DIM))
                .map(|(a, b)| {
                    let error = a.iter().zip(b).map(|(u, v)| (u - v) * (u - v)).sum::<f64>();
                    format!("{:.1e}", error.sqrt())
                })
                .collect::<Vec<_>>()
                .join(" | ")
        })
        .unwrap_or_else(|err| format!("{err} |"));
    eprintln!(
        "| {name} | {} | {} | {:.1} | {falls} | {largest_fall:.1e} | {drift} | {errors} |",
        method.label(),
        sim.stats.accepted_steps,
        f64::from(sim.stats.evaluations) / f64::from(sim.stats.accepted_steps),
    );
}

/// Where the errors are measured: in the transient and at the end.
fn checkpoints() -> OutputTimes {
    OutputTimes::Times(vec![10.0, DURATION])
}

/// The states at the checkpoints of a DOPRI5 run at rtol 1e-12,
/// atol 1e-14, with steps of at most 0.01 so that its stiffness test cannot
/// stop it near the attractor (h·|λ| ≤ 0.64 for Linear2d's largest
/// |λ| = 64 there).
fn reference<S: MetriplecticSystem>(model: &Model<S>, x0: &[f64]) -> Vec<f64> {
    let mut tight = Integrator::Dopri5(1e-12, Some(0.01)).options(checkpoints());
    tight.integrator.atol = 1e-14;
    simulate(model, x0, 0.0, DURATION, &tight)
        .expect("the reference run succeeds")
        .trajectory
        .states()
        .to_vec()
}

/// One system's cases: the table rows, then the criterion timings.
fn system<S: MetriplecticSystem>(
    name: &str,
    x0: &[f64],
    methods: &[Integrator],
    criterion: Option<&mut Criterion>,
) {
    let model = Model::<S>::reference().expect("the system declares a reference");
    let exact = reference(&model, x0);
    for &method in methods {
        report(name, &model, x0, method, &exact);
    }
    if let Some(criterion) = criterion {
        let mut group = criterion.benchmark_group(format!("integrators/{name}"));
        for &method in methods {
            let options = method.options(OutputTimes::Times(vec![DURATION]));
            if simulate(&model, x0, 0.0, DURATION, &options).is_err() {
                continue;
            }
            group.bench_function(method.label(), |b| {
                b.iter(|| simulate(&model, x0, 0.0, DURATION, &options))
            });
        }
        group.finish();
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let scan = args.iter().any(|a| a == "--scan");
    use Integrator::{DiscreteGradient as Dg, Dopri5};
    let linear_x0 = [0.4, 0.3];
    let body_x0 = [0.9, 0.5, -0.6];
    let classical_x0 = [0.3, 1.0, 0.6];
    eprintln!(
        "\n| system | method | steps | evaluations per step | E falls beyond rounding | \
         largest fall of E | H drift | error at t = 10 | final error |\n\
         |---|---|---|---|---|---|---|---|---|"
    );
    if scan {
        let steps: Vec<Integrator> = [0.5, 0.1, 0.05, 0.02, 0.01, 0.005, 0.002, 0.001]
            .into_iter()
            .map(Dg)
            .chain([
                Dopri5(DEFAULT_RTOL, None),
                Dopri5(DEFAULT_RTOL, Some(0.04)),
                Dopri5(DEFAULT_RTOL, Some(0.5)),
                Dopri5(1e-3, Some(0.5)),
                Dopri5(1e-3, None),
            ])
            .collect();
        system::<Linear2d>("Linear2d", &linear_x0, &steps, None);
        system::<RigidBody>("RigidBody", &body_x0, &steps, None);
        system::<ClassicalRigidBody>("classical rigid body", &classical_x0, &steps, None);
        return;
    }
    let mut criterion = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(if quick { 100 } else { 500 }))
        .measurement_time(Duration::from_secs(if quick { 1 } else { 3 }))
        .configure_from_args();
    // DOPRI5 at its defaults stops with "stiff" on both paper systems
    // before t = 10³ (its steps grow to the stability limit near the
    // attractor); capped at 0.5 it finishes. The discrete gradient's first
    // step is the one with DOPRI5's error (Linear2d: 9e-8 against 1e-7;
    // RigidBody: every step lands on p₀/|p₀| to rounding, the flow being
    // radial; the classical body: 2.2e-7 at t = 10 against 1.7e-7).
    system::<Linear2d>(
        "Linear2d",
        &linear_x0,
        &[
            Dopri5(DEFAULT_RTOL, None),
            Dopri5(DEFAULT_RTOL, Some(0.5)),
            Dg(0.001),
            Dg(0.1),
        ],
        Some(&mut criterion),
    );
    system::<RigidBody>(
        "RigidBody",
        &body_x0,
        &[
            Dopri5(DEFAULT_RTOL, None),
            Dopri5(DEFAULT_RTOL, Some(0.5)),
            Dg(0.01),
            Dg(0.5),
        ],
        Some(&mut criterion),
    );
    system::<ClassicalRigidBody>(
        "classical rigid body",
        &classical_x0,
        &[
            Dopri5(DEFAULT_RTOL, None),
            Dopri5(1e-3, None),
            Dg(0.02),
            Dg(0.5),
        ],
        Some(&mut criterion),
    );
    criterion.final_summary();
}
