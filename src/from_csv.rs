//! Identification from a user's trajectory CSV: the pipeline of
//! `examples/from_csv.rs`, in the library so that the tests run it
//! in-process.
//!
//! [`run`] reads the trajectories of one of the systems this package
//! declares ([`SystemName`]), holds whole trajectories out for validation,
//! identifies the entropy and metric on the rest (from the weak form or from
//! derivatives, [`DataMethod`]) with the default [`IdentifyConfig`], scores
//! the model on the held-out trajectories and writes the model, its
//! equations, a summary and figures into an output directory.
//!
//! # The validation error
//!
//! The headline number, [`Summary::validation_relative_error`], is what a
//! user of states-only data can check without knowing the truth: the model
//! is simulated from the first measured state of every validation trajectory
//! to its last sample time, and its states at the measured times are
//! compared with the measured states,
//!
//! ```text
//! √( Σₖ ‖x_model(tₖ) − x_measured(tₖ)‖² / Σₖ ‖x_measured(tₖ) − x̄‖² ),
//! ```
//!
//! summed over every validation sample but the first of each trajectory
//! (the model starts there), x̄ the mean of those measured states. 0 is a
//! perfect prediction, 1 is no better than always predicting x̄. It includes
//! the measurement noise twice over (in the start state and in the compared
//! states), so with noise of standard deviation σ per component it cannot
//! fall much below about σ divided by the states' spread, however good the
//! model. [`Summary::validation_equation_relative_error`] scores the
//! model instead on the validation trajectories' identification equations
//! built the same way as the training data (weak-form integrals or
//! derivatives): ‖prediction − target‖ / ‖target‖, as
//! [`Model::score`](metriplectic_runtime::Model::score) computes it.

use std::fmt::Write as _;
use std::fs::{self, File, OpenOptions};
use std::io::{BufRead, BufReader, Read, Write};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    identifiability, identify_with_observer, phase_portrait_2d, trajectories_3d,
    trajectory_overlay, CsvError, Identifiability, IdentifiabilityOptions, Identification,
    IntegratorOptions, IterationRecord, Labels, OutputTimes, Score, Simulation,
};
use serde::{Deserialize, Serialize};

use crate::systems::{Duffing, Linear2d, RigidBody};

/// Command-line options of the from_csv example.
#[derive(Debug, Clone, clap::Parser)]
#[command(
    about = "Identify the entropy and metric of a metriplectic system from measured trajectories (CSV)",
    long_about = "Identify the entropy S and metric K of a metriplectic system from measured \
trajectories in a CSV file, validate the model on held-out trajectories, and write the model, \
its equations, a summary and figures into an output directory.\n\n\
CSV format: a header line, then one row per sample. Columns: t (time), the system's state \
variables by name, optionally trajectory (an identifier; rows of one trajectory contiguous, \
times strictly increasing) and optionally d<name> for every state variable (measured \
derivatives). Columns may come in any order."
)]
pub struct Options {
    /// Trajectory CSV to identify from.
    #[arg(long, value_name = "FILE.csv")]
    pub data: PathBuf,
    /// Output directory; created if absent. An existing non-empty directory is
    /// refused unless --overwrite is given.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Which system the data come from. Default: the one whose state
    /// variables are the CSV's columns.
    #[arg(long, value_enum, value_name = "NAME")]
    pub system: Option<SystemName>,
    /// Identify from the weak (integral) form of the states alone: no
    /// derivative estimate; each equation averages a window of 15
    /// consecutive samples, so trajectories need at least 15 samples. The
    /// default when the CSV has no derivative columns.
    #[arg(long, conflicts_with = "derivatives")]
    pub weak: bool,
    /// Identify from derivatives: exact (the CSV's derivative columns dq, dp, ...; the
    /// default when it has them), fd2, fd4 or fd6 (finite differences of that
    /// order, for clean data), sg (Savitzky-Golay, window 7, degree 3),
    /// sg:W:D (window W, degree D) or spline (cubic smoothing spline, its
    /// smoothing chosen by cross-validation). Without a value: sg.
    #[arg(long, value_name = "METHOD", num_args = 0..=1, default_missing_value = "sg")]
    pub derivatives: Option<DerivativeChoice>,
    /// Fraction of the trajectories held out whole for validation (at least
    /// one is held out and at least one kept).
    #[arg(long, value_name = "F", default_value_t = 0.2)]
    pub validation_fraction: f64,
    /// Seed of the validation split and the identifier.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Iteration cap of the identification [default: 100].
    #[arg(long, value_name = "N")]
    pub max_iterations: Option<usize>,
    /// Write into a non-empty output directory, replacing files of the same
    /// names (other files are left alone).
    #[arg(long)]
    pub overwrite: bool,
    /// Validation trajectories drawn against the model's prediction.
    #[arg(long, value_name = "N", default_value_t = 4)]
    pub plot_trajectories: usize,
    /// No progress bar and no report on stdout (errors still go to stderr).
    #[arg(long)]
    pub quiet: bool,
}

impl Options {
    /// The defaults of the command line for `data` and `out`.
    pub fn new(data: impl Into<PathBuf>, out: impl Into<PathBuf>) -> Self {
        Self {
            data: data.into(),
            out: out.into(),
            system: None,
            weak: false,
            derivatives: None,
            validation_fraction: 0.2,
            seed: 1,
            max_iterations: None,
            overwrite: false,
            plot_trajectories: 4,
            quiet: false,
        }
    }
}

/// The systems the example can identify (declared in [`crate::systems`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SystemName {
    /// The paper's 2-D oscillator, state (q, p).
    #[value(name = "linear_2d")]
    Linear2d,
    /// The paper's rigid body on so(3)*, state (px, py, pz).
    #[value(name = "rigid_body_so3")]
    RigidBodySo3,
    /// A damped double-well Duffing oscillator, state (x, v).
    #[value(name = "duffing")]
    Duffing,
}

impl SystemName {
    /// Every system, in the order the help lists them.
    pub const ALL: [Self; 3] = [Self::Linear2d, Self::RigidBodySo3, Self::Duffing];

    /// The name on the command line and in `summary.json`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Linear2d => "linear_2d",
            Self::RigidBodySo3 => "rigid_body_so3",
            Self::Duffing => "duffing",
        }
    }

    /// The state variables, in state order (the CSV's column names).
    pub fn state_names(self) -> &'static [&'static str] {
        match self {
            Self::Linear2d => Linear2d::STATE_NAMES,
            Self::RigidBodySo3 => RigidBody::STATE_NAMES,
            Self::Duffing => Duffing::STATE_NAMES,
        }
    }

    /// `linear_2d (q, p), rigid_body_so3 (px, py, pz), …`.
    fn catalogue() -> String {
        Self::ALL
            .iter()
            .map(|s| format!("{} ({})", s.as_str(), s.state_names().join(", ")))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// A `--derivatives` value: the CSV's own derivatives or an estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DerivativeChoice {
    /// The CSV's `d<name>` columns.
    Exact,
    /// Derivatives estimated from the states with this method.
    Estimate(DerivativeMethod),
}

impl FromStr for DerivativeChoice {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let estimate = |method| Ok(Self::Estimate(method));
        match text {
            "exact" => Ok(Self::Exact),
            "fd2" => estimate(DerivativeMethod::FiniteDifference { order: 2 }),
            "fd4" => estimate(DerivativeMethod::FiniteDifference { order: 4 }),
            "fd6" => estimate(DerivativeMethod::FiniteDifference { order: 6 }),
            "sg" => estimate(DerivativeMethod::SavitzkyGolay {
                window: 7,
                degree: 3,
            }),
            "spline" => estimate(DerivativeMethod::smoothing_spline()),
            _ => {
                let parts: Vec<&str> = text.split(':').collect();
                match parts.as_slice() {
                    ["sg", window, degree] => {
                        let number = |s: &str, what: &str| {
                            s.parse::<usize>().map_err(|_| {
                                format!("`{text}`: the {what} `{s}` is not a whole number")
                            })
                        };
                        estimate(DerivativeMethod::SavitzkyGolay {
                            window: number(window, "window")?,
                            degree: number(degree, "degree")?,
                        })
                    }
                    _ => Err(format!(
                        "`{text}` is not a derivative method; use exact, fd2, fd4, fd6, sg, sg:WINDOW:DEGREE or spline"
                    )),
                }
            }
        }
    }
}

/// How the identification equations are built from the trajectories.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DataMethod {
    /// The weak form of the states alone.
    Weak(WeakForm),
    /// The CSV's derivatives.
    ExactDerivatives,
    /// Derivatives estimated from the states.
    EstimatedDerivatives(DerivativeMethod),
}

impl DataMethod {
    /// A short description, e.g. `weak form (window 15, stride 1, power 4, local degree 2)`.
    pub fn describe(&self) -> String {
        match self {
            Self::Weak(form) => format!(
                "weak form (window {}, stride {}, power {}, local degree {})",
                form.window, form.stride, form.power, form.local_degree
            ),
            Self::ExactDerivatives => "derivatives from the CSV".to_owned(),
            Self::EstimatedDerivatives(method) => {
                format!("derivatives estimated by {}", describe_derivatives(method))
            }
        }
    }
}

/// How the derivatives were estimated, in words for the summary.
fn describe_derivatives(method: &DerivativeMethod) -> String {
    match method {
        DerivativeMethod::FiniteDifference { order } => {
            format!("finite differences of order {order}")
        }
        DerivativeMethod::SavitzkyGolay { window, degree } => {
            format!("Savitzky-Golay (window {window}, degree {degree})")
        }
        DerivativeMethod::SmoothingSpline { lambda: None } => {
            "cubic smoothing spline, smoothing by cross-validation".into()
        }
        DerivativeMethod::SmoothingSpline {
            lambda: Some(lambda),
        } => format!("cubic smoothing spline, smoothing {lambda:e}"),
    }
}

/// `summary.json`: what was identified from what, and how well it predicts
/// the validation trajectories.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// The system's name (`linear_2d`, …).
    pub system: String,
    /// Its state variables.
    pub state_names: Vec<String>,
    /// The CSV read.
    pub data_file: String,
    /// How the identification equations were built (weak form or derivatives).
    pub data_method: String,
    /// Trajectories in the CSV.
    pub trajectories: usize,
    /// Trajectories identified from.
    pub train_trajectories: usize,
    /// Trajectories held out for validation.
    pub validation_trajectories: usize,
    /// Identifiers of the validation trajectories (their `trajectory` column).
    pub validation_trajectory_ids: Vec<String>,
    /// Samples (rows) in the CSV.
    pub samples: usize,
    /// Identification equations of the training trajectories (weak-form
    /// windows or samples).
    pub train_equations: usize,
    /// Seed of the split and the identifier.
    pub seed: u64,
    /// Iterations run, a full-batch run's warm-up on the start's subsample
    /// included (the final full-batch polish of a minibatch run is not
    /// counted).
    pub iterations: usize,
    /// Why the identification stopped (`Converged`, `Stagnated`, …).
    pub stop_reason: String,
    /// ‖prediction − target‖ / ‖target‖ on the training equations.
    pub train_relative_error: f64,
    /// The model's simulated states against the measured ones on the
    /// validation trajectories (see the module documentation); `null` if no
    /// validation trajectory could be simulated.
    pub validation_relative_error: Option<f64>,
    /// The same error of the reference model the system declares (`null`
    /// if it declares none or it cannot be simulated). On synthetic data it
    /// is the floor the measurement noise sets; on real data, how the
    /// identified model compares with the declared one.
    pub reference_validation_relative_error: Option<f64>,
    /// Validation trajectories simulated for that error.
    pub validation_simulated: usize,
    /// Validation trajectories whose simulation failed (or that have a
    /// single sample), with the reason.
    pub validation_not_simulated: Vec<String>,
    /// ‖prediction − target‖ / ‖target‖ on the validation trajectories'
    /// equations, built like the training ones; `null` if they give none
    /// (e.g. all shorter than a weak-form window).
    pub validation_equation_relative_error: Option<f64>,
    /// R² on those equations.
    pub validation_equation_r_squared: Option<f64>,
    /// Fraction of the simulated validation intervals on which the model's
    /// free energy decreased beyond the integrator's tolerance (0 for a
    /// model with K ⪰ 0).
    pub free_energy_decrease_fraction: f64,
    /// Whether the training data determine every coefficient (the
    /// identifiability report of the model on the training equations).
    pub identifiable: bool,
    /// The coefficient combinations the training data cannot determine,
    /// in words (e.g. the scale symmetry (K, E) ↦ (cK, E/c)).
    pub unidentifiable_directions: Vec<String>,
    /// What the data cannot determine, figures that could not be drawn, …
    pub warnings: Vec<String>,
    /// Wall time of the identification.
    pub seconds_identify: f64,
    /// Wall time of the whole run.
    pub seconds_total: f64,
    /// Files written into the output directory.
    pub files: Vec<String>,
}

/// Why the pipeline could not run.
#[derive(Debug, thiserror::Error)]
pub enum FromCsvError {
    /// The output directory has files and `--overwrite` was not given.
    #[error("output directory {0} is not empty; pass --overwrite to write into it anyway, or choose another --out")]
    OutputNotEmpty(PathBuf),
    /// The output path exists and is not a directory.
    #[error("output path {0} exists and is not a directory")]
    OutputNotADirectory(PathBuf),
    /// A file exists where an output goes and `--overwrite` was not given.
    #[error("{0} appeared while the run was going; refusing to replace it without --overwrite")]
    OutputExists(PathBuf),
    /// The CSV's columns are not the chosen system's.
    #[error("{path}: the columns do not match the state ({state}) of system `{system}`: {detail}\nsystems this example knows: {known}")]
    StateNames {
        /// The CSV.
        path: PathBuf,
        /// The system's name.
        system: &'static str,
        /// Its state variables.
        state: String,
        /// The reader's complaint (missing or unknown columns).
        detail: String,
        /// Every system with its state variables.
        known: String,
    },
    /// No system was named and the columns do not single one out.
    #[error("{path}: {reason}; pass --system NAME\nsystems this example knows: {known}")]
    UnknownSystem {
        /// The CSV.
        path: PathBuf,
        /// What the columns matched.
        reason: String,
        /// Every system with its state variables.
        known: String,
    },
    /// The CSV could not be read or its content is invalid.
    #[error("{path}: {source}")]
    Data {
        /// The CSV.
        path: PathBuf,
        /// The reader's error (it names the line and column).
        #[source]
        source: metriplectic_runtime::Error,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The path involved.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// An option is out of range or does not fit the data.
    #[error("{0}")]
    Option(String),
    /// The runtime reported an error (identification, scoring, saving).
    #[error(transparent)]
    Runtime(#[from] metriplectic_runtime::Error),
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> FromCsvError + '_ {
    move |source| FromCsvError::Io {
        path: path.to_owned(),
        source,
    }
}

/// Runs the pipeline and returns its summary. Ctrl-C stops the
/// identification after the current iteration; the outputs are then written
/// for the best model so far and the summary's stop reason is `Interrupted`.
pub fn run(options: &Options) -> Result<Summary, FromCsvError> {
    crate::reproduction::install_ctrlc_handler(options.quiet);
    crate::reproduction::STOP_REQUESTED.store(false, Ordering::SeqCst);
    run_until(options, &crate::reproduction::STOP_REQUESTED)
}

/// [`run`] without a signal handler: the identification stops after the
/// iteration during which `stop` became `true`.
pub fn run_until(options: &Options, stop: &AtomicBool) -> Result<Summary, FromCsvError> {
    let started = Instant::now();
    check_options(options)?;
    check_output_dir(&options.out, options.overwrite)?;
    let system = match options.system {
        Some(system) => system,
        None => infer_system(&options.data)?,
    };
    let context = Context {
        options,
        system,
        started,
        stop,
    };
    match system {
        SystemName::Linear2d => context.run::<Linear2d>(),
        SystemName::RigidBodySo3 => context.run::<RigidBody>(),
        SystemName::Duffing => context.run::<Duffing>(),
    }
}

fn check_options(options: &Options) -> Result<(), FromCsvError> {
    let fraction = options.validation_fraction;
    if !(fraction > 0.0 && fraction < 1.0) {
        return Err(FromCsvError::Option(format!(
            "--validation-fraction {fraction} is not between 0 and 1 (exclusive)"
        )));
    }
    if options.max_iterations == Some(0) {
        return Err(FromCsvError::Option(
            "--max-iterations must be at least 1".to_owned(),
        ));
    }
    Ok(())
}

/// Refuses an output path that is a file, or a non-empty directory without
/// `overwrite`. Creates nothing: the directory is made once the input has
/// been read, so a bad CSV leaves nothing behind.
fn check_output_dir(out: &Path, overwrite: bool) -> Result<(), FromCsvError> {
    match fs::metadata(out) {
        Ok(meta) if !meta.is_dir() => Err(FromCsvError::OutputNotADirectory(out.to_owned())),
        Ok(_) => {
            let mut entries = fs::read_dir(out).map_err(io_error(out))?;
            if entries.next().is_some() && !overwrite {
                Err(FromCsvError::OutputNotEmpty(out.to_owned()))
            } else {
                Ok(())
            }
        }
        Err(err) if err.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(err) => Err(io_error(out)(err)),
    }
}

/// The column names of the CSV's header line (trimmed, quotes removed).
fn header_columns(path: &Path) -> Result<Vec<String>, FromCsvError> {
    let file = File::open(path).map_err(io_error(path))?;
    let mut line = String::new();
    // A header is short; the cap keeps a file without line breaks from
    // being read whole here (the reader proper reports what is wrong).
    BufReader::new(file.take(1 << 20))
        .read_line(&mut line)
        .map_err(io_error(path))?;
    let line = line.trim_start_matches('\u{feff}');
    Ok(line
        .trim_end_matches(['\r', '\n'])
        .split(',')
        .map(|cell| cell.trim().trim_matches('"').trim().to_owned())
        .collect())
}

/// The system whose state variables, and nothing else the format does not
/// know, are the CSV's columns.
fn infer_system(path: &Path) -> Result<SystemName, FromCsvError> {
    let columns = header_columns(path)?;
    let fits = |system: SystemName| {
        let names = system.state_names();
        let known = |column: &str| {
            column == "t"
                || column == "trajectory"
                || names.contains(&column)
                || column
                    .strip_prefix('d')
                    .is_some_and(|rest| names.contains(&rest))
        };
        names.iter().all(|n| columns.iter().any(|c| c == n)) && columns.iter().all(|c| known(c))
    };
    let matching: Vec<SystemName> = SystemName::ALL.into_iter().filter(|s| fits(*s)).collect();
    match matching.as_slice() {
        [system] => Ok(*system),
        [] => Err(FromCsvError::UnknownSystem {
            path: path.to_owned(),
            reason: format!(
                "its columns ({}) are not the state variables of any system this example knows",
                columns.join(", ")
            ),
            known: SystemName::catalogue(),
        }),
        several => Err(FromCsvError::UnknownSystem {
            path: path.to_owned(),
            reason: format!(
                "its columns fit several systems ({})",
                several
                    .iter()
                    .map(|s| s.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            known: SystemName::catalogue(),
        }),
    }
}

/// The identification equations of a set of trajectories.
enum Equations {
    Weak(WeakDataset),
    Pointwise(Dataset),
}

impl Equations {
    fn build(
        trajectories: &[Trajectory],
        method: &DataMethod,
    ) -> metriplectic_runtime::Result<Self> {
        Ok(match method {
            DataMethod::Weak(form) => {
                Self::Weak(WeakDataset::from_trajectories(trajectories, form)?)
            }
            DataMethod::ExactDerivatives => {
                Self::Pointwise(Dataset::from_trajectories(trajectories, None)?)
            }
            DataMethod::EstimatedDerivatives(method) => {
                Self::Pointwise(Dataset::from_trajectories(trajectories, Some(method))?)
            }
        })
    }

    fn count(&self) -> usize {
        match self {
            Self::Weak(data) => data.equation_count(),
            Self::Pointwise(data) => data.equation_count(),
        }
    }

    fn score<S: MetriplecticSystem>(
        &self,
        model: &Model<S>,
    ) -> metriplectic_runtime::Result<Score> {
        match self {
            Self::Weak(data) => model.score(data),
            Self::Pointwise(data) => model.score(data),
        }
    }

    fn identifiability<S: MetriplecticSystem>(
        &self,
        model: &Model<S>,
    ) -> metriplectic_runtime::Result<Identifiability> {
        let options = IdentifiabilityOptions::default();
        match self {
            Self::Weak(data) => identifiability(model, data, &options),
            Self::Pointwise(data) => identifiability(model, data, &options),
        }
    }
}

/// What one run needs besides the system type.
struct Context<'a> {
    options: &'a Options,
    system: SystemName,
    started: Instant,
    stop: &'a AtomicBool,
}

/// The model's prediction of the validation trajectories, and how far it is
/// from the measured states.
struct Validation {
    /// (index among the validation trajectories, simulation at the measured times).
    simulations: Vec<(usize, Simulation)>,
    not_simulated: Vec<String>,
    relative_error: Option<f64>,
    free_energy_decrease_fraction: f64,
}

impl Context<'_> {
    fn run<S: MetriplecticSystem>(&self) -> Result<Summary, FromCsvError> {
        let options = self.options;
        let path = &options.data;
        let trajectories = read_trajectories::<S>(path).map_err(|source| match source {
            Error::Csv(CsvError::MissingColumns { .. } | CsvError::UnknownColumns { .. }) => {
                FromCsvError::StateNames {
                    path: path.clone(),
                    system: self.system.as_str(),
                    state: S::STATE_NAMES.join(", "),
                    detail: source.to_string(),
                    known: SystemName::catalogue(),
                }
            }
            source => FromCsvError::Data {
                path: path.clone(),
                source,
            },
        })?;
        if trajectories.len() < 2 {
            return Err(FromCsvError::Option(format!(
                "{}: holds {} trajectory; validation holds whole trajectories out, so at least two are needed (label them with a `trajectory` column)",
                path.display(),
                trajectories.len()
            )));
        }
        let method = self.data_method(&trajectories)?;
        let (train, validation) =
            split_by_trajectory(&trajectories, options.validation_fraction, options.seed)?;
        let train_equations = Equations::build(&train, &method).map_err(|source| {
            let hint = match method {
                DataMethod::Weak(_) => "; shorter trajectories need --derivatives METHOD",
                _ => "",
            };
            FromCsvError::Option(format!(
                "{}: the training trajectories give no identification data with the {}: {source}{hint}",
                path.display(),
                method.describe()
            ))
        })?;
        // Validation trajectories too short for a weak-form window still
        // count in the simulated error; only their equation score is missing.
        let validation_equations = Equations::build(&validation, &method).ok();

        fs::create_dir_all(&options.out).map_err(io_error(&options.out))?;
        let identify_started = Instant::now();
        let identification = self.identify::<S>(&train_equations)?;
        let seconds_identify = identify_started.elapsed().as_secs_f64();
        let model = &identification.model;

        let train_score = train_equations.score(model)?;
        let identifiable = train_equations.identifiability(model)?;
        let validation_score = validation_equations
            .as_ref()
            .map(|data| data.score(model))
            .transpose()?;
        let checked = validate(model, &validation);
        let reference = Model::<S>::reference()
            .ok()
            .and_then(|reference| validate(&reference, &validation).relative_error);

        let mut warnings: Vec<String> = identification
            .warnings
            .iter()
            .map(ToString::to_string)
            .collect();
        if validation_equations.is_none() {
            warnings.push(format!(
                "no validation trajectory is long enough for the {}; validation_equation_relative_error is null",
                method.describe()
            ));
        }
        if !checked.not_simulated.is_empty() {
            warnings.push(format!(
                "{} of {} validation trajectories could not be simulated and are not in validation_relative_error",
                checked.not_simulated.len(),
                validation.len()
            ));
        }

        let mut files = Vec::new();
        let out = &options.out;
        let write = |name: &str, bytes: &[u8], files: &mut Vec<String>| {
            write_output(out, name, bytes, options.overwrite)?;
            files.push(name.to_owned());
            Ok::<(), FromCsvError>(())
        };
        let model_path = out.join("model.json");
        model.save(
            &model_path,
            if options.overwrite {
                WriteMode::Overwrite
            } else {
                WriteMode::CreateNew
            },
        )?;
        files.push("model.json".to_owned());
        write("equations.txt", format!("{model}\n").as_bytes(), &mut files)?;
        let mut history = Vec::new();
        identification.history.write_csv(&mut history)?;
        write("history.csv", &history, &mut files)?;
        self.figures::<S>(
            &identification,
            &validation,
            &checked,
            &mut files,
            &mut warnings,
        )?;

        let validation_ids = validation.iter().map(trajectory_label).collect();
        files.push("summary.json".to_owned());
        let summary = Summary {
            system: self.system.as_str().to_owned(),
            state_names: S::STATE_NAMES.iter().map(|s| (*s).to_owned()).collect(),
            data_file: path.display().to_string(),
            data_method: method.describe(),
            trajectories: trajectories.len(),
            train_trajectories: train.len(),
            validation_trajectories: validation.len(),
            validation_trajectory_ids: validation_ids,
            samples: trajectories.iter().map(Trajectory::len).sum(),
            train_equations: train_equations.count(),
            seed: options.seed,
            iterations: identification
                .history
                .iterations
                .iter()
                .filter(|r| !r.polish)
                .count(),
            stop_reason: format!("{:?}", identification.stop_reason),
            train_relative_error: train_score.relative_error,
            validation_relative_error: checked.relative_error,
            reference_validation_relative_error: reference,
            validation_simulated: checked.simulations.len(),
            validation_not_simulated: checked.not_simulated.clone(),
            validation_equation_relative_error: validation_score.map(|s| s.relative_error),
            validation_equation_r_squared: validation_score
                .map(|s| s.r_squared)
                .filter(|r| r.is_finite()),
            free_energy_decrease_fraction: checked.free_energy_decrease_fraction,
            identifiable: identifiable.is_identifiable(),
            unidentifiable_directions: identifiable
                .flat_directions
                .iter()
                .map(|d| format!("{:?}: {}", d.kind, d.description))
                .collect(),
            warnings,
            seconds_identify,
            seconds_total: self.started.elapsed().as_secs_f64(),
            files,
        };
        let json = serde_json::to_string_pretty(&summary).map_err(|source| {
            FromCsvError::Runtime(Error::Json {
                context: Some("summary.json".to_owned()),
                source,
            })
        })? + "\n";
        write_output(out, "summary.json", json.as_bytes(), options.overwrite)?;
        if !options.quiet {
            println!("{}", report(&summary, model, out));
        }
        Ok(summary)
    }

    /// The data method the options ask for, checked against the CSV.
    fn data_method(&self, trajectories: &[Trajectory]) -> Result<DataMethod, FromCsvError> {
        let has_derivatives = trajectories.iter().all(|t| t.derivatives().is_some());
        let options = self.options;
        Ok(match options.derivatives {
            _ if options.weak => DataMethod::Weak(WeakForm::default()),
            Some(DerivativeChoice::Exact) if !has_derivatives => {
                return Err(FromCsvError::Option(format!(
                    "--derivatives exact: {} has no derivative columns ({}); estimate them (e.g. --derivatives sg) or use --weak",
                    options.data.display(),
                    self.system
                        .state_names()
                        .iter()
                        .map(|n| format!("d{n}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )))
            }
            Some(DerivativeChoice::Exact) => DataMethod::ExactDerivatives,
            Some(DerivativeChoice::Estimate(method)) => DataMethod::EstimatedDerivatives(method),
            None if has_derivatives => DataMethod::ExactDerivatives,
            None => DataMethod::Weak(WeakForm::default()),
        })
    }

    fn identify<S: MetriplecticSystem>(
        &self,
        data: &Equations,
    ) -> Result<Identification<S>, FromCsvError> {
        let options = self.options;
        let config = IdentifyConfig {
            seed: options.seed,
            max_iterations: options
                .max_iterations
                .unwrap_or(IdentifyConfig::default().max_iterations),
            ..IdentifyConfig::default()
        };
        let progress =
            crate::reproduction::progress_bar(options.quiet, config.max_iterations as u64);
        let observer = |record: &IterationRecord, _: &Model<S>| {
            progress.set_position(record.iteration as u64);
            progress.set_message(format!(
                "cost per component {:.3e}",
                record.cost_after().per_component
            ));
            if self.stop.load(Ordering::SeqCst) {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        };
        let result = match data {
            Equations::Weak(data) => identify_with_observer::<S, _>(data, &config, observer),
            Equations::Pointwise(data) => identify_with_observer::<S, _>(data, &config, observer),
        };
        progress.finish_and_clear();
        Ok(result?)
    }

    /// `validation_<k>.png` (or one per pair of state variables),
    /// `validation_overlay.png` (the same trajectories over time),
    /// `model_trajectories_3d.png` for 3-D systems, `loss.png` and
    /// `free_energy.png`. A figure that cannot be drawn (degenerate data)
    /// is a warning: the model and numbers are still worth having.
    fn figures<S: MetriplecticSystem>(
        &self,
        identification: &Identification<S>,
        validation: &[Trajectory],
        checked: &Validation,
        files: &mut Vec<String>,
        warnings: &mut Vec<String>,
    ) -> Result<(), FromCsvError> {
        let out = &self.options.out;
        let mut attempt =
            |name: String, draw: &dyn Fn(&Path) -> metriplectic_runtime::Result<()>| {
                let path = out.join(&name);
                if !self.options.overwrite && path.exists() {
                    return Err(FromCsvError::OutputExists(path));
                }
                match draw(&path) {
                    Ok(()) => files.push(name),
                    Err(err) => warnings.push(format!("{name} not drawn: {err}")),
                }
                Ok(())
            };
        let names = S::STATE_NAMES;
        let pairs: Vec<(usize, usize)> = (0..S::DIM)
            .flat_map(|a| (a + 1..S::DIM).map(move |b| (a, b)))
            .take(3)
            .collect();
        let shown = checked
            .simulations
            .iter()
            .take(self.options.plot_trajectories);
        // Measured against simulated states over time, for the overlay.
        type Series = (Vec<f64>, Vec<Vec<f64>>);
        let series = |trajectory: &Trajectory| -> Series {
            (
                trajectory.times().to_vec(),
                trajectory
                    .states()
                    .chunks_exact(S::DIM)
                    .map(<[f64]>::to_vec)
                    .collect(),
            )
        };
        let mut overlay_data: Vec<Series> = Vec::new();
        let mut overlay_model: Vec<Series> = Vec::new();
        for (number, (index, _)) in shown.enumerate() {
            let measured = &validation[*index];
            let Some(smooth) = smooth_simulation(&identification.model, measured) else {
                continue;
            };
            overlay_data.push(series(measured));
            overlay_model.push(series(&smooth.trajectory));
            let model_points: Vec<&[f64]> =
                smooth.trajectory.states().chunks_exact(S::DIM).collect();
            let title = format!(
                "Trajectory {}: model (blue) vs measured (black)",
                trajectory_label(measured)
            );
            for &(a, b) in &pairs {
                let name = if S::DIM == 2 {
                    format!("validation_{}.png", number + 1)
                } else {
                    format!("validation_{}_{}_{}.png", number + 1, names[a], names[b])
                };
                let model_xy: Vec<[f64; 2]> = model_points.iter().map(|x| [x[a], x[b]]).collect();
                let measured_xy: Vec<(f64, f64)> = measured
                    .states()
                    .chunks_exact(S::DIM)
                    .map(|x| (x[a], x[b]))
                    .collect();
                attempt(name, &|path| {
                    phase_portrait_2d(
                        path,
                        &[&model_xy],
                        &measured_xy,
                        &Labels {
                            title: &title,
                            x: names[a],
                            y: names[b],
                            reference: "measured states",
                            ..Labels::default()
                        },
                    )
                })?;
            }
        }
        if !overlay_data.is_empty() {
            attempt("validation_overlay.png".to_owned(), &|path| {
                trajectory_overlay(
                    path,
                    &overlay_data,
                    &overlay_model,
                    names,
                    &Labels {
                        title: "Validation trajectories: measured (markers) and model (lines)",
                        x: "t",
                        ..Labels::default()
                    },
                )
            })?;
        }
        if S::DIM == 3 && !checked.simulations.is_empty() {
            let trajectories: Vec<Vec<&[f64]>> = checked
                .simulations
                .iter()
                .map(|(_, s)| s.trajectory.states().chunks_exact(3).collect())
                .collect();
            attempt("model_trajectories_3d.png".to_owned(), &|path| {
                trajectories_3d(
                    path,
                    &trajectories,
                    None,
                    &Labels {
                        title: "Model from the validation trajectories' first states",
                        x: names[0],
                        y: names[1],
                        z: names[2],
                        ..Labels::default()
                    },
                )
            })?;
        }
        let history = &identification.history;
        if !history.iterations.is_empty() {
            attempt("loss.png".to_owned(), &|path| {
                crate::figures::loss_figure(
                    path,
                    history,
                    "Training loss (mean |residual| per component)",
                )
            })?;
        }
        if !checked.simulations.is_empty() {
            let simulations: Vec<&Simulation> =
                checked.simulations.iter().map(|(_, s)| s).collect();
            attempt("free_energy.png".to_owned(), &|path| {
                crate::figures::free_energy_figure(
                    path,
                    &simulations,
                    "Free energy along the model's validation trajectories",
                )
            })?;
        }
        Ok(())
    }
}

/// The validation error of the module documentation: `model` simulated from
/// the first state of each of `validation` at its sample times, against
/// the measured states. `None` if no trajectory could be simulated (or the
/// measured states do not vary).
pub fn simulated_relative_error<S: MetriplecticSystem>(
    model: &Model<S>,
    validation: &[Trajectory],
) -> Option<f64> {
    validate(model, validation).relative_error
}

/// Integrator tolerances of the validation simulations: well below any
/// measurement noise, so the error is the model's.
fn validation_integrator() -> IntegratorOptions {
    IntegratorOptions {
        rtol: 1e-8,
        atol: 1e-10,
        ..IntegratorOptions::default()
    }
}

/// Simulates the model from each validation trajectory's first state at
/// its sample times and compares with the measured states.
fn validate<S: MetriplecticSystem>(model: &Model<S>, validation: &[Trajectory]) -> Validation {
    let n = S::DIM;
    let mut simulations = Vec::new();
    let mut not_simulated = Vec::new();
    for (index, measured) in validation.iter().enumerate() {
        let label = trajectory_label(measured);
        let times = measured.times();
        if times.len() < 2 {
            not_simulated.push(format!("{label}: a single sample, nothing to predict"));
            continue;
        }
        let options = SimulationOptions {
            integrator: validation_integrator(),
            output: OutputTimes::Times(times.to_vec()),
            ..SimulationOptions::default()
        };
        let (t0, t1) = (times[0], times[times.len() - 1]);
        match simulate(model, measured.state(0), t0, t1, &options) {
            Ok(simulation) if simulation.trajectory.len() == times.len() => {
                simulations.push((index, simulation));
            }
            Ok(_) => not_simulated.push(format!("{label}: the simulation missed sample times")),
            Err(err) => not_simulated.push(format!("{label}: {err}")),
        }
    }
    // Measured states compared (all but each trajectory's first), their mean,
    // then the two sums of squares.
    let compared = || {
        simulations.iter().flat_map(|(index, simulation)| {
            let measured = &validation[*index];
            (1..measured.len()).map(move |k| (measured.state(k), simulation.trajectory.state(k)))
        })
    };
    let count = compared().count();
    let mut mean = vec![0.0; n];
    for (measured, _) in compared() {
        mean.iter_mut().zip(measured).for_each(|(m, x)| *m += x);
    }
    mean.iter_mut().for_each(|m| *m /= count.max(1) as f64);
    let (mut error2, mut spread2) = (0.0, 0.0);
    for (measured, predicted) in compared() {
        for j in 0..n {
            error2 += (predicted[j] - measured[j]).powi(2);
            spread2 += (measured[j] - mean[j]).powi(2);
        }
    }
    let relative_error = (count > 0 && spread2 > 0.0).then(|| (error2 / spread2).sqrt());
    let (steps, violations) = simulations.iter().fold((0, 0), |(s, v), (_, sim)| {
        (s + sim.energy.steps, v + sim.energy.violations)
    });
    Validation {
        simulations,
        not_simulated,
        relative_error,
        free_energy_decrease_fraction: if steps == 0 {
            0.0
        } else {
            violations as f64 / steps as f64
        },
    }
}

/// The model from `measured`'s first state over its time span, at 500
/// evenly spaced times, for a smooth curve in the figures.
fn smooth_simulation<S: MetriplecticSystem>(
    model: &Model<S>,
    measured: &Trajectory,
) -> Option<Simulation> {
    let times = measured.times();
    let (t0, t1) = (times[0], *times.last()?);
    let options = SimulationOptions {
        integrator: validation_integrator(),
        output: OutputTimes::Interval((t1 - t0) / 500.0),
        ..SimulationOptions::default()
    };
    simulate(model, measured.state(0), t0, t1, &options).ok()
}

/// The trajectory's identifier. A file of several trajectories has a
/// `trajectory` column, so every trajectory this pipeline sees has one.
fn trajectory_label(trajectory: &Trajectory) -> String {
    trajectory.id().unwrap_or("(unnamed)").to_owned()
}

/// Writes `out/name`, refusing to replace a file unless `overwrite`.
fn write_output(out: &Path, name: &str, bytes: &[u8], overwrite: bool) -> Result<(), FromCsvError> {
    let path = out.join(name);
    let mut open = OpenOptions::new();
    open.write(true);
    if overwrite {
        open.create(true).truncate(true);
    } else {
        open.create_new(true);
    }
    let mut file = open.open(&path).map_err(|err| {
        if err.kind() == std::io::ErrorKind::AlreadyExists {
            FromCsvError::OutputExists(path.clone())
        } else {
            io_error(&path)(err)
        }
    })?;
    file.write_all(bytes).map_err(io_error(&path))
}

/// What the run found and where it went, for stdout.
fn report<S: MetriplecticSystem>(summary: &Summary, model: &Model<S>, out: &Path) -> String {
    let mut text = String::new();
    let number = |v: Option<f64>| v.map_or_else(|| "n/a".to_owned(), |v| format!("{v:.3e}"));
    let _ = writeln!(
        text,
        "{}: {} trajectories, {} samples from {}",
        summary.system, summary.trajectories, summary.samples, summary.data_file,
    );
    let _ = writeln!(
        text,
        "identified from the {} of {} trajectories ({} equations), {} held out: {} iterations ({}), {:.1} s ({:.1} s in all)",
        summary.data_method,
        summary.train_trajectories,
        summary.train_equations,
        summary.validation_trajectories,
        summary.iterations,
        summary.stop_reason,
        summary.seconds_identify,
        summary.seconds_total
    );
    let _ = writeln!(
        text,
        "validation, simulated from each held-out trajectory's first state against its measured states: relative error {} (the declared reference model: {})",
        number(summary.validation_relative_error),
        number(summary.reference_validation_relative_error),
    );
    let _ = writeln!(
        text,
        "identification equations: relative error {} on the held-out trajectories, {:.3e} on the training ones",
        number(summary.validation_equation_relative_error),
        summary.train_relative_error,
    );
    let _ = writeln!(text, "identified model:\n{model}");
    if summary.identifiable {
        let _ = writeln!(
            text,
            "identifiable: the training data determine every coefficient"
        );
    } else {
        let _ = writeln!(
            text,
            "not identifiable; the training data do not determine:"
        );
        for direction in &summary.unidentifiable_directions {
            let _ = writeln!(text, "  {direction}");
        }
    }
    for warning in &summary.warnings {
        let _ = writeln!(text, "warning: {warning}");
    }
    let _ = writeln!(text, "wrote into {}:", out.display());
    for file in &summary.files {
        let _ = writeln!(text, "  {}", out.join(file).display());
    }
    text.truncate(text.trim_end().len());
    text
}
