//! The paper reproductions' shared pipeline: synthesise data from a reference
//! model, identify S and K with Algorithm 2, evaluate on held-out data,
//! simulate the identified model and write figures and a summary.
//!
//! `examples/linear_2d.rs` and `examples/rigid_body_so3.rs` each declare their
//! system with `metriplectic!` and describe the experiment as an
//! [`Experiment`]; everything else happens here, so the examples and the
//! end-to-end tests in `tests/` run exactly the same code.

use std::fmt::Write as _;
use std::fs;
use std::io::IsTerminal;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    identifiability, identify_resume_with_observer, identify_with_observer, simulate, synthesize,
    write_file, CheckpointConfig, FlatDirection, Gauge, History, Identifiability,
    IdentifiabilityOptions, InitialStates, IterationRecord, IterationScheme, L1Formulation,
    OutputTimes, SampleTimes, SearchOptions, Simulation, SimulationOptions, SolveStatus,
    SolverBackend, SolverSettings, StopReason, SynthesisOptions, SyntheticData, TrustRegion,
    WriteMode,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Command-line options shared by both reproductions.
#[derive(Debug, Clone, clap::Parser)]
#[command(about = "Reproduce an experiment of the generalized metriplectic paper")]
pub struct Options {
    /// Seed of every random draw (data, initial entropy, minibatches, plots).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1)]
    pub seed: u64,
    /// Minibatch size q of Algorithm 2 (the paper uses 2000).
    #[arg(long, allow_negative_numbers = true, default_value_t = 2000)]
    pub batch_size: usize,
    /// Iteration cap [default: the paper's count for the experiment].
    #[arg(long, allow_negative_numbers = true)]
    pub iterations: Option<usize>,
    /// Stop when the mean absolute residual per component on the training
    /// data reaches this times their mean |ẋ| (a relative tolerance).
    #[arg(long, allow_negative_numbers = true, default_value_t = 1e-9)]
    pub tolerance: f64,
    /// Output directory (default: `target/paper/<experiment>`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Overwrite a non-empty output directory.
    #[arg(long)]
    pub force: bool,
    /// Trajectories simulated for the phase-portrait figure.
    #[arg(long, allow_negative_numbers = true, default_value_t = 200)]
    pub plot_trajectories: usize,
    /// Training trajectories synthesised from the reference model.
    #[arg(long, allow_negative_numbers = true, default_value_t = 100)]
    pub train_trajectories: usize,
    /// Held-out trajectories (never seen by the identifier).
    #[arg(long, allow_negative_numbers = true, default_value_t = 20)]
    pub heldout_trajectories: usize,
    /// Samples per trajectory (log-uniform in time).
    #[arg(long, allow_negative_numbers = true, default_value_t = 50)]
    pub samples_per_trajectory: usize,
    /// Iteration scheme: `joint` adds a joint linearised trust-region step to
    /// each iteration of Algorithm 2 (our addition; it keeps the cost
    /// non-increasing); `alternating` is the paper's alternation of Algorithm
    /// 2 without it (the stopping rules and the choice of the best-scoring
    /// model stay this toolkit's).
    #[arg(long, value_enum, default_value_t = Scheme::Joint)]
    pub scheme: Scheme,
    /// Solver of the subproblems: the runtime's dense interior-point method,
    /// or Clarabel (about 10x slower on these problems; for comparison).
    #[arg(long, value_enum, default_value_t = Solver::Dense)]
    pub solver: Solver,
    /// No progress bar and no summary on stdout.
    #[arg(long)]
    pub quiet: bool,
    /// Continue the run saved in `<out>/checkpoint.json` (same seed and
    /// options) instead of starting afresh.
    #[arg(long)]
    pub resume: bool,
    /// Save `<out>/checkpoint.json` every this many iterations (and on stop).
    #[arg(long, allow_negative_numbers = true, default_value_t = 10)]
    pub checkpoint_every: usize,
    /// Start cold, from the library's default start (the entropy fitted at
    /// the default metric; nothing of the truth used), whatever the
    /// experiment's default start.
    #[arg(long)]
    pub cold_start: bool,
    /// Fix the gauge tr K(0) = this value (e.g. the state dimension), for
    /// systems whose data fix K only up to scale.
    #[arg(long, allow_negative_numbers = true)]
    pub gauge_trace: Option<f64>,
}

/// Which solver runs the subproblems (see [`SolverBackend`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Solver {
    /// The runtime's dense interior-point method.
    Dense,
    /// Clarabel, in its default formulation.
    Clarabel,
}

impl Solver {
    fn to_backend(self) -> SolverBackend {
        match self {
            Self::Dense => SolverBackend::Dense,
            Self::Clarabel => SolverBackend::Clarabel(L1Formulation::default()),
        }
    }
}

/// Which iteration scheme the identifier runs (see [`IterationScheme`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Scheme {
    /// Metric search, entropy search, then a joint step in both blocks.
    Joint,
    /// The paper's Algorithm 2: metric search, then entropy search.
    Alternating,
}

impl Scheme {
    fn to_config(self) -> IterationScheme {
        match self {
            Self::Joint => IterationScheme::AlternatingThenJoint(TrustRegion::default()),
            Self::Alternating => IterationScheme::Alternating,
        }
    }
}

/// What is true of the reference system's long-time behaviour, drawn in the
/// trajectory figure.
#[derive(Debug, Clone, PartialEq)]
pub enum ZeroSet {
    /// A closed curve in the plane, as points.
    Curve(Vec<(f64, f64)>),
    /// The sphere of this radius around the origin.
    Sphere(f64),
    /// Nothing drawn besides the trajectories.
    None,
}

/// The experiment-specific part of a reproduction.
#[derive(Debug, Clone)]
pub struct Experiment {
    /// Short name, used for the default output directory.
    pub name: &'static str,
    /// Distribution of the initial states of the training, held-out and plotted trajectories.
    pub initial_states: InitialStates,
    /// Duration of each synthesised trajectory.
    pub duration: f64,
    /// Earliest log-uniform sample time.
    pub first_sample_time: f64,
    /// Standard deviation of the Gaussian perturbation of the true entropy
    /// coefficients that gives the initial entropy.
    pub initial_entropy_std: f64,
    /// Start cold instead, from the library's default start
    /// ([`IdentifyConfig::initial_entropy`] `None`: the entropy fitted at the
    /// default metric; nothing of the truth is used); `initial_entropy_std`
    /// is then unused.
    pub cold_start: bool,
    /// Coefficient bound η.
    pub eta: f64,
    /// Default iteration cap: the paper's iteration count.
    pub iterations: usize,
    /// Duration of the simulated trajectories in the figures.
    pub plot_duration: f64,
    /// The set the reference trajectories converge to.
    pub zero_set: ZeroSet,
}

/// `summary.json`: the reproduction's headline numbers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Summary {
    /// The system's name.
    pub system: String,
    /// The seed of the run.
    pub seed: u64,
    /// Training samples.
    pub samples_train: usize,
    /// Held-out samples.
    pub samples_heldout: usize,
    /// Minibatch size q.
    pub batch_size: usize,
    /// Iterations run (minibatch iterations; the final full-batch polish
    /// is not counted).
    pub iterations: usize,
    /// Whether a final full-batch iteration polished the best model.
    pub polished: bool,
    /// Why the identification stopped (`Converged`, `Stagnated`, …).
    pub stop_reason: String,
    /// Metric-search cost (mean absolute residual per component) of the last iteration.
    pub final_metric_cost: f64,
    /// Cost (mean absolute residual per component) on the last minibatch at
    /// the end of the last iteration: after the entropy search, or after the
    /// joint step when the joint scheme runs.
    pub final_entropy_cost: f64,
    /// ‖f_fit − f_true‖ / ‖f_true‖ over all held-out states.
    pub heldout_relative_error: f64,
    /// Mean |ẋ − f_fit(x)| per component over the held-out samples.
    pub heldout_mean_abs_residual: f64,
    /// max over held-out states of ‖K_fit(x) − K_true(x)‖ / ‖K_true(x)‖
    /// (Frobenius norms).
    pub heldout_metric_error: f64,
    /// How much the true metric varies over the held-out states: max of
    /// ‖K(x) − K(x̄)‖ / ‖K(x̄)‖ with x̄ their mean (0 for a constant metric).
    pub metric_variation: f64,
    /// Fraction of integration steps of the identified model's simulated
    /// trajectories where E decreased beyond the integrator's tolerance.
    pub free_energy_decrease_fraction: f64,
    /// Subproblem solves that did not end with the status `Solved`.
    pub nonoptimal_solves: usize,
    /// Wall time of the whole run.
    pub seconds_total: f64,
    /// Wall time inside the solver (either backend).
    pub seconds_solver: f64,
    /// The gauge tr K(0) fixed during the run, if any.
    pub gauge_trace: Option<f64>,
    /// Whether the training data determine every coefficient of the
    /// identified model (see `identifiability`).
    pub identifiable: bool,
    /// The smallest singular value of the column-normalised Jacobian of the
    /// field with respect to the coefficients, relative to the largest.
    pub smallest_singular_value: f64,
    /// The coefficient combinations the training data cannot determine.
    pub unidentifiable_directions: Vec<FlatDirection>,
}

/// Why a reproduction could not run or finish.
#[derive(Debug, thiserror::Error)]
pub enum ReproductionError {
    /// The output directory has files and `--force` was not given.
    #[error("output directory {0} is not empty; pass --force to overwrite it or --out to choose another")]
    OutputNotEmpty(PathBuf),
    /// Reading or writing an output file failed.
    #[error("{path}: {source}")]
    Io {
        /// The path involved.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The runtime reported an error.
    #[error(transparent)]
    Runtime(#[from] metriplectic_runtime::Error),
    /// Every simulation of the identified model failed.
    #[error("the identified model could not be simulated from any initial state: {0}")]
    Simulation(String),
    /// An option is out of range.
    #[error("invalid option: {0}")]
    Option(String),
    /// The run was stopped (Ctrl-C) after an iteration; its checkpoint,
    /// current model and history were written.
    #[error("interrupted after {iterations} iteration(s); the current model and history are in {}, continue with --resume", out.display())]
    Interrupted {
        /// Iterations completed (including those before a resume).
        iterations: usize,
        /// The output directory.
        out: PathBuf,
    },
}

/// Set by the Ctrl-C handler [`run`] (and `from_csv::run`) installs; the
/// identifier's observer checks it after every iteration.
pub(crate) static STOP_REQUESTED: AtomicBool = AtomicBool::new(false);

/// Asks a running [`run`] to stop after its current iteration, as Ctrl-C does.
pub fn request_stop() {
    STOP_REQUESTED.store(true, Ordering::SeqCst);
}

/// Installs the Ctrl-C handler once per process; a failure to install it
/// (e.g. another handler exists) only costs the clean stop, so it is reported
/// and the run goes on.
pub(crate) fn install_ctrlc_handler(quiet: bool) {
    static INSTALLED: OnceLock<()> = OnceLock::new();
    INSTALLED.get_or_init(|| {
        if let Err(err) = ctrlc::set_handler(request_stop) {
            if !quiet {
                eprintln!("warning: Ctrl-C will not stop cleanly: {err}");
            }
        }
    });
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> ReproductionError + '_ {
    move |source| ReproductionError::Io {
        path: path.to_owned(),
        source,
    }
}

/// Runs the reproduction of `experiment` for system `S` and returns its summary.
///
/// Ctrl-C (or [`request_stop`]) stops the identification after the current
/// iteration: the checkpoint, the current model (`model.json`) and the
/// history are written, and the result is [`ReproductionError::Interrupted`].
pub fn run<S: MetriplecticSystem>(
    experiment: &Experiment,
    options: &Options,
) -> Result<Summary, ReproductionError> {
    install_ctrlc_handler(options.quiet);
    STOP_REQUESTED.store(false, Ordering::SeqCst);
    run_until::<S>(experiment, options, &STOP_REQUESTED)
}

/// [`run`] without a signal handler: the identification stops after the
/// iteration during which `stop` became `true`.
pub fn run_until<S: MetriplecticSystem>(
    experiment: &Experiment,
    options: &Options,
    stop: &AtomicBool,
) -> Result<Summary, ReproductionError> {
    let started = Instant::now();
    check_counts(options)?;
    let out = options
        .out
        .clone()
        .unwrap_or_else(|| Path::new("target").join("paper").join(experiment.name));
    let checkpoint = out.join("checkpoint.json");
    if options.resume {
        let path = checkpoint.display();
        let refusal = match fs::metadata(&checkpoint) {
            Ok(meta) if meta.is_file() => None,
            Ok(meta) if meta.is_dir() => Some(format!(
                "{path} is a directory, not a checkpoint to continue from"
            )),
            Ok(_) => Some(format!(
                "{path} is not a regular file, so not a checkpoint to continue from"
            )),
            Err(err) if err.kind() == std::io::ErrorKind::NotFound => {
                Some(format!("there is no {path} to continue from"))
            }
            Err(err) => Some(format!("{path} cannot be read: {err}")),
        };
        if let Some(reason) = refusal {
            return Err(ReproductionError::Option(format!("--resume: {reason}")));
        }
    } else {
        prepare_output_dir(&out, options.force)?;
    }

    let iterations = options.iterations.unwrap_or(experiment.iterations);
    let truth = Model::<S>::reference()?;
    let data = synthesize_data(&truth, experiment, options)?;
    let train = &data.train;
    let held_out = data.held_out.as_ref().ok_or_else(|| {
        ReproductionError::Option("--heldout-trajectories must be at least 1".into())
    })?;
    if options.batch_size > train.len() {
        return Err(ReproductionError::Option(format!(
            "--batch-size {} exceeds the {} training samples; raise --train-trajectories or --samples-per-trajectory",
            options.batch_size,
            train.len()
        )));
    }

    let config = IdentifyConfig {
        batch_size: Some(options.batch_size),
        max_iterations: iterations,
        tolerance: options.tolerance,
        seed: options.seed,
        // A cold start is the library's own default start (None): nothing
        // of the truth is used.
        initial_entropy: if experiment.cold_start || options.cold_start {
            None
        } else {
            Some(perturbed_entropy::<S>(
                &truth,
                experiment.initial_entropy_std,
                options.seed,
            )?)
        },
        scheme: options.scheme.to_config(),
        search: SearchOptions {
            eta: Some(experiment.eta),
            solver: SolverSettings {
                backend: options.solver.to_backend(),
                ..SolverSettings::default()
            },
            gauge: options.gauge_trace.map(Gauge::MetricTrace),
            ..SearchOptions::default()
        },
        checkpoint: Some(CheckpointConfig {
            path: checkpoint.clone(),
            every: options.checkpoint_every,
        }),
        ..IdentifyConfig::default()
    };
    let progress = progress_bar(options.quiet, iterations as u64);
    let observer = |record: &IterationRecord, _: &Model<S>| {
        progress.set_position(record.iteration as u64);
        progress.set_message(format!(
            "loss: metric {:.3e}  entropy {:.3e}  after iteration {:.3e}",
            record.metric.cost_after.per_component,
            record.entropy.cost_after.per_component,
            record.cost_after().per_component
        ));
        if stop.load(Ordering::SeqCst) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    };
    let identification = if options.resume {
        identify_resume_with_observer::<S, _>(&checkpoint, train, &config, observer)?
    } else {
        identify_with_observer::<S, _>(train, &config, observer)?
    };
    progress.finish_and_clear();
    let model = &identification.model;
    let history = &identification.history;
    if identification.stop_reason == StopReason::Interrupted {
        write_model_and_history(&out, model, history)?;
        return Err(ReproductionError::Interrupted {
            iterations: history.iterations.len(),
            out,
        });
    }

    let (heldout_relative_error, heldout_mean_abs_residual) =
        held_out_errors(model, &truth, held_out)?;
    let (heldout_metric_error, metric_variation) = held_out_metric(model, &truth, held_out)?;
    let report = identifiability(
        model,
        train,
        &IdentifiabilityOptions {
            search: config.search.clone(),
            ..IdentifiabilityOptions::default()
        },
    )?;
    let (simulations, failed_simulations) = simulate_for_plots(model, experiment, options)?;
    let steps: usize = simulations.iter().map(|s| s.energy.steps).sum();
    let violations: usize = simulations.iter().map(|s| s.energy.violations).sum();

    write_outputs(&out, model, history, &simulations, experiment)?;

    let last = history.iterations.last();
    let nonoptimal_solves = history
        .iterations
        .iter()
        .flat_map(|r| {
            [&r.metric, &r.entropy]
                .into_iter()
                .chain(r.joint.as_ref().map(|j| &j.step))
                .map(|step| step.report.status)
        })
        .filter(|s| *s != SolveStatus::Solved)
        .count();
    let summary = Summary {
        system: S::NAME.to_owned(),
        seed: options.seed,
        samples_train: train.len(),
        samples_heldout: held_out.len(),
        batch_size: options.batch_size,
        iterations: history.iterations.iter().filter(|r| !r.polish).count(),
        polished: history.iterations.iter().any(|r| r.polish),
        stop_reason: format!("{:?}", identification.stop_reason),
        final_metric_cost: last.map_or(f64::NAN, |r| r.metric.cost_after.per_component),
        final_entropy_cost: last.map_or(f64::NAN, |r| r.cost_after().per_component),
        heldout_relative_error,
        heldout_mean_abs_residual,
        heldout_metric_error,
        metric_variation,
        free_energy_decrease_fraction: if steps == 0 {
            0.0
        } else {
            violations as f64 / steps as f64
        },
        nonoptimal_solves,
        seconds_total: started.elapsed().as_secs_f64(),
        seconds_solver: history
            .iterations
            .iter()
            .map(|r| {
                r.metric.report.solver_seconds
                    + r.entropy.report.solver_seconds
                    + r.joint
                        .as_ref()
                        .map_or(0.0, |j| j.step.report.solver_seconds)
            })
            .sum(),
        gauge_trace: options.gauge_trace,
        identifiable: report.is_identifiable(),
        smallest_singular_value: report.singular_values.last().copied().unwrap_or(0.0),
        unidentifiable_directions: report.flat_directions.clone(),
    };
    write_json(&out.join("summary.json"), &summary)?;
    if !options.quiet {
        println!(
            "{}",
            human_summary(
                model,
                options.scheme,
                options.solver,
                &summary,
                identification.stop_reason,
                &report,
                &out
            )
        );
        if !failed_simulations.is_empty() {
            println!(
                "warning: {} of {} simulations of the identified model failed and are not plotted; first: {}",
                failed_simulations.len(),
                failed_simulations.len() + simulations.len(),
                failed_simulations[0]
            );
        }
    }
    Ok(summary)
}

/// Refuses counts of zero by their option's name before any work: they
/// were refused later under the library's names ("invalid max_iterations",
/// "invalid log-uniform sample count"), or as another option's error
/// (`--train-trajectories 0` as "held-out trajectories: 20 of 20"), or
/// silently raised (`--plot-trajectories 0` plotted one); a probe.
fn check_counts(options: &Options) -> Result<(), ReproductionError> {
    let counts = [
        ("--iterations", options.iterations.unwrap_or(1)),
        ("--batch-size", options.batch_size),
        ("--plot-trajectories", options.plot_trajectories),
        ("--train-trajectories", options.train_trajectories),
        ("--heldout-trajectories", options.heldout_trajectories),
        ("--samples-per-trajectory", options.samples_per_trajectory),
        ("--checkpoint-every", options.checkpoint_every),
    ];
    for (option, count) in counts {
        if count == 0 {
            return Err(ReproductionError::Option(format!(
                "{option} 0: at least 1 is needed"
            )));
        }
    }
    if let Some(trace) = options.gauge_trace {
        if !(trace.is_finite() && trace > 0.0) {
            return Err(ReproductionError::Option(format!(
                "--gauge-trace {trace:e}: must be a finite positive number"
            )));
        }
    }
    Ok(())
}

/// The files a run writes into its output directory.
const OUTPUTS: [&str; 8] = [
    "trajectories.png",
    "trajectories.svg",
    "loss.png",
    "free_energy.png",
    "history.csv",
    "model.json",
    "checkpoint.json",
    "summary.json",
];

/// Refuses a non-empty directory unless `force`; creates it otherwise.
/// With `force`, the previous run's outputs (regular files of the names in
/// `OUTPUTS`, nothing else) are removed first: a forced run stopped by
/// Ctrl-C left its new model beside the old run's summary and figures (a
/// probe).
fn prepare_output_dir(out: &Path, force: bool) -> Result<(), ReproductionError> {
    match fs::read_dir(out) {
        Ok(mut entries) => {
            if entries.next().is_some() && !force {
                return Err(ReproductionError::OutputNotEmpty(out.to_owned()));
            }
            for name in OUTPUTS {
                let path = out.join(name);
                if fs::symlink_metadata(&path).is_ok_and(|meta| meta.is_file()) {
                    fs::remove_file(&path).map_err(io_error(&path))?;
                }
            }
        }
        Err(error) if error.kind() == std::io::ErrorKind::NotFound => {}
        // A directory that cannot be listed may hold files the run would
        // overwrite: say so rather than treat it as empty.
        Err(error) => return Err(io_error(out)(error)),
    }
    fs::create_dir_all(out).map_err(io_error(out))
}

fn synthesize_data<S: MetriplecticSystem>(
    truth: &Model<S>,
    experiment: &Experiment,
    options: &Options,
) -> Result<SyntheticData, ReproductionError> {
    let trajectories = options
        .train_trajectories
        .checked_add(options.heldout_trajectories)
        .ok_or_else(|| {
            ReproductionError::Option(
                "--train-trajectories plus --heldout-trajectories overflows".into(),
            )
        })?;
    let synthesis = SynthesisOptions {
        trajectories,
        held_out_trajectories: options.heldout_trajectories,
        duration: experiment.duration,
        seed: options.seed,
        ..SynthesisOptions::new(
            experiment.initial_states.clone(),
            SampleTimes::LogUniform {
                count: options.samples_per_trajectory,
                first: experiment.first_sample_time,
            },
        )
    };
    Ok(synthesize(truth, &synthesis)?)
}

/// The paper's initial entropy: the true coefficients plus N(0, σ²) noise on each.
pub fn perturbed_entropy<S: MetriplecticSystem>(
    truth: &Model<S>,
    std: f64,
    seed: u64,
) -> Result<Vec<f64>, ReproductionError> {
    let normal = Normal::new(0.0, std)
        .map_err(|e| ReproductionError::Option(format!("initial entropy noise {std}: {e}")))?;
    // A stream of its own, so changing the data size does not change the start.
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5EED_0FE7_A0A0);
    Ok(truth
        .entropy_coefficients()
        .iter()
        .map(|c| c + normal.sample(&mut rng))
        .collect())
}

/// (‖f_fit − f_true‖ / ‖f_true‖, mean |ẋ − f_fit|) over the held-out samples.
pub fn held_out_errors<S: MetriplecticSystem>(
    model: &Model<S>,
    truth: &Model<S>,
    held_out: &Dataset,
) -> Result<(f64, f64), ReproductionError> {
    let n = S::DIM;
    let (mut fit, mut reference) = (vec![0.0; n], vec![0.0; n]);
    let (mut diff2, mut true2, mut abs_residual) = (0.0, 0.0, 0.0);
    for (x, measured) in held_out.iter() {
        model.vector_field(x, &mut fit)?;
        truth.vector_field(x, &mut reference)?;
        for j in 0..n {
            diff2 += (fit[j] - reference[j]).powi(2);
            true2 += reference[j].powi(2);
            abs_residual += (measured[j] - fit[j]).abs();
        }
    }
    Ok((
        (diff2 / true2).sqrt(),
        abs_residual / (held_out.len() * n) as f64,
    ))
}

/// (max ‖K_fit(x) − K_true(x)‖ / ‖K_true(x)‖, max ‖K_true(x) − K_true(x̄)‖ /
/// ‖K_true(x̄)‖) over the held-out states x, x̄ their mean; Frobenius norms.
pub fn held_out_metric<S: MetriplecticSystem>(
    model: &Model<S>,
    truth: &Model<S>,
    held_out: &Dataset,
) -> Result<(f64, f64), ReproductionError> {
    let n = S::DIM;
    let norm = |a: &[f64]| a.iter().map(|v| v * v).sum::<f64>().sqrt();
    let distance = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let mut mean = vec![0.0; n];
    for (x, _) in held_out.iter() {
        mean.iter_mut()
            .zip(x)
            .for_each(|(m, v)| *m += v / held_out.len() as f64);
    }
    let (mut fit, mut reference, mut at_mean) =
        (vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n * n]);
    truth.metric(&mean, &mut at_mean)?;
    let (mut error, mut variation) = (0.0_f64, 0.0_f64);
    for (x, _) in held_out.iter() {
        model.metric(x, &mut fit)?;
        truth.metric(x, &mut reference)?;
        error = error.max(distance(&fit, &reference) / norm(&reference));
        variation = variation.max(distance(&reference, &at_mean) / norm(&at_mean));
    }
    Ok((error, variation))
}

/// Simulations of the identified model from random initial states, and the
/// number of trajectories whose integration failed (an inexact model may blow
/// up; those are reported, not plotted).
fn simulate_for_plots<S: MetriplecticSystem>(
    model: &Model<S>,
    experiment: &Experiment,
    options: &Options,
) -> Result<(Vec<Simulation>, Vec<String>), ReproductionError> {
    let starts = synthesize(
        model,
        &SynthesisOptions {
            trajectories: options.plot_trajectories.max(1),
            duration: 1e-6,
            seed: options.seed.wrapping_add(1),
            ..SynthesisOptions::new(
                experiment.initial_states.clone(),
                SampleTimes::Uniform { interval: 1.0 },
            )
        },
    )?;
    let sim_options = SimulationOptions {
        output: OutputTimes::Steps,
        ..SimulationOptions::default()
    };
    let mut simulations = Vec::new();
    let mut failures = Vec::new();
    for start in &starts.trajectories {
        let x0 = start.state(0);
        match simulate(model, x0, 0.0, experiment.plot_duration, &sim_options) {
            Ok(simulation) => simulations.push(simulation),
            Err(err) => failures.push(format!("from {x0:?}: {err}")),
        }
    }
    if simulations.is_empty() {
        return Err(ReproductionError::Simulation(failures.join("; ")));
    }
    Ok((simulations, failures))
}

fn write_outputs<S: MetriplecticSystem>(
    out: &Path,
    model: &Model<S>,
    history: &History,
    simulations: &[Simulation],
    experiment: &Experiment,
) -> Result<(), ReproductionError> {
    write_model_and_history(out, model, history)?;
    crate::figures::write_all(out, history, simulations, experiment, S::STATE_NAMES)
}

/// `model.json` and `history.csv`.
fn write_model_and_history<S: MetriplecticSystem>(
    out: &Path,
    model: &Model<S>,
    history: &History,
) -> Result<(), ReproductionError> {
    let mut text = Vec::new();
    history.write_csv(&mut text)?;
    write_file(&out.join("history.csv"), &text, WriteMode::Overwrite)?;
    model.save(out.join("model.json"), WriteMode::Overwrite)?;
    Ok(())
}

fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), ReproductionError> {
    let text = serde_json::to_string_pretty(value).map_err(|e| {
        ReproductionError::Runtime(metriplectic_runtime::Error::Json {
            context: Some(path.display().to_string()),
            source: e,
        })
    })?;
    Ok(write_file(
        path,
        (text + "\n").as_bytes(),
        WriteMode::Overwrite,
    )?)
}

/// A progress bar over `iterations` on stderr, hidden when `quiet` or when
/// stderr is not a terminal (logs and CI get no control sequences).
pub(crate) fn progress_bar(quiet: bool, iterations: u64) -> ProgressBar {
    let bar = ProgressBar::new(iterations);
    if quiet || !std::io::stderr().is_terminal() {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    if let Ok(style) =
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

/// The polynomial Σ cₖ x^αₖ over `exponents`, terms with |c| below `threshold`
/// left out, e.g. `-0.5 q^2 + 4 q^2 p^2`.
pub fn polynomial_to_string(
    names: &[&str],
    exponents: &[&[u32]],
    coefficients: &[f64],
    threshold: f64,
) -> String {
    let mut text = String::new();
    for (alpha, &c) in exponents.iter().zip(coefficients) {
        if c.abs() < threshold {
            continue;
        }
        let sign = if c < 0.0 { "-" } else { "+" };
        if text.is_empty() {
            if c < 0.0 {
                text.push('-');
            }
        } else {
            let _ = write!(text, " {sign} ");
        }
        let _ = write!(text, "{}", format_coefficient(c.abs()));
        for (name, &power) in names.iter().zip(alpha.iter()) {
            match power {
                0 => {}
                1 => {
                    let _ = write!(text, " {name}");
                }
                _ => {
                    let _ = write!(text, " {name}^{power}");
                }
            }
        }
    }
    if text.is_empty() {
        text.push('0');
    }
    text
}

fn format_coefficient(c: f64) -> String {
    // Six significant digits, without trailing zeros.
    let text = format!("{c:.6}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    text.to_owned()
}

fn human_summary<S: MetriplecticSystem>(
    model: &Model<S>,
    scheme: Scheme,
    solver: Solver,
    summary: &Summary,
    stop_reason: StopReason,
    report: &Identifiability,
    out: &Path,
) -> String {
    let names = S::STATE_NAMES;
    let mut text = String::new();
    let _ = writeln!(
        text,
        "{} ({:?} scheme, {:?} solver): {} iterations ({:?}), {:.1} s ({:.1} s in the solver), {} non-optimal solves",
        summary.system,
        scheme,
        solver,
        summary.iterations,
        stop_reason,
        summary.seconds_total,
        summary.seconds_solver,
        summary.nonoptimal_solves
    );
    let _ = writeln!(
        text,
        "identified entropy:\n  S({}) = {}",
        names.join(", "),
        polynomial_to_string(
            names,
            S::ENTROPY_EXPONENTS,
            model.entropy_coefficients(),
            1e-6
        )
    );
    let _ = writeln!(text, "identified metric K(x):");
    let basis = S::METRIC_EXPONENTS.len();
    for j in 0..S::DIM {
        let row: Vec<String> = (0..S::DIM)
            .map(|k| {
                let (a, b) = (j.min(k), j.max(k));
                // Upper-triangle pairs (a ≤ b), row-major.
                let pair = a * S::DIM - a * a.saturating_sub(1) / 2 + (b - a);
                polynomial_to_string(
                    names,
                    S::METRIC_EXPONENTS,
                    &model.metric_coefficients()[pair * basis..(pair + 1) * basis],
                    1e-6,
                )
            })
            .collect();
        let _ = writeln!(text, "  [{}]", row.join(", "));
    }
    let _ = writeln!(
        text,
        "held-out relative error {:.3e}, mean |residual| {:.3e}, metric error {:.3e} (the true metric varies by {:.3e}); free energy decreased on {:.3}% of simulated steps",
        summary.heldout_relative_error,
        summary.heldout_mean_abs_residual,
        summary.heldout_metric_error,
        summary.metric_variation,
        100.0 * summary.free_energy_decrease_fraction
    );
    let _ = writeln!(text, "{}", report.to_string().trim_end());
    let _ = write!(
        text,
        "wrote trajectories.png/.svg, loss.png, free_energy.png, history.csv, model.json, checkpoint.json, summary.json to {}",
        out.display()
    );
    text
}
