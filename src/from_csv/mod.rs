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
//!
//! # Layout
//!
//! This module runs the pipeline; `options` is the command line, `columns`
//! tells the system from the header, `validation` simulates the held-out
//! trajectories, `output` checks and writes the output directory and draws
//! the figures, `summary` is `summary.json` and the report, `error` the
//! reasons the pipeline stops.

mod columns;
mod error;
mod options;
mod output;
mod summary;
mod validation;

use std::fs;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use metriplectic_runtime::prelude::*;
use metriplectic_runtime::{
    identifiability, identify_with_observer, read_trajectories_from, CsvError, Identifiability,
    IdentifiabilityOptions, Identification, IterationRecord, Score, MAX_CSV_BYTES,
};

use crate::systems::{Duffing, Linear2d, RigidBody};
use columns::infer_system;
use error::io_error;
use options::check_options;
use output::{check_input_is_not_an_output, check_output_dir, check_output_files, write_output};
use summary::report;
use validation::{trajectory_label, validate};

pub use error::FromCsvError;
pub use options::{DataMethod, DerivativeChoice, Options, SystemName};
pub use summary::Summary;
pub use validation::simulated_relative_error;

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
    check_input_is_not_an_output(&options.data, &options.out, options.overwrite)?;
    check_output_files(&options.out)?;
    // Read once, whole: the header and the rows come from the same bytes,
    // so a pipe or FIFO (`--data /dev/stdin`, `--data <(…)`) reads too.
    let data = read_capped(&options.data)?;
    let system = match options.system {
        Some(system) => system,
        None => infer_system(&options.data, &data)?,
    };
    let context = Context {
        options,
        data: &data,
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

/// The runtime names a state whose basis functions overflow by its index
/// in the equations, which the CSV does not show: the first such state of
/// `trajectories` is named by its trajectory and time, as the CSV reader's
/// own errors are. Other errors pass through.
fn name_overflowing_row<S: MetriplecticSystem>(
    error: FromCsvError,
    trajectories: &[Trajectory],
    path: &std::path::Path,
) -> FromCsvError {
    let FromCsvError::Runtime(Error::InvalidArgument { what, reason }) = &error else {
        return error;
    };
    if what != "dataset" || !reason.contains("overflow") {
        return error;
    }
    let n = S::DIM;
    let mut entropy = vec![0.0; S::entropy_coefficient_count() * n];
    let mut metric = vec![0.0; S::METRIC_EXPONENTS.len()];
    let (mut gradient, mut poisson) = (vec![0.0; n], vec![0.0; n * n]);
    for (index, trajectory) in trajectories.iter().enumerate() {
        for k in 0..trajectory.len() {
            let x = trajectory.state(k);
            S::entropy_jacobian(x, &mut entropy);
            S::metric_features(x, &mut metric);
            S::hamiltonian_gradient(x, &mut gradient);
            S::poisson(x, &mut poisson);
            let finite = [&entropy, &metric, &gradient, &poisson]
                .iter()
                .all(|values| values.iter().all(|v| v.is_finite()));
            if !finite {
                let name = trajectory.id().map_or_else(
                    || format!("training trajectory {index}"),
                    |id| format!("trajectory `{id}`"),
                );
                return FromCsvError::Option(format!(
                    "{}: {name}, sample {} (t = {}): the state {x:?} is too large for system \
                     `{}`: its basis functions overflow f64; rescale the states",
                    path.display(),
                    k + 1,
                    trajectory.times()[k],
                    S::NAME
                ));
            }
        }
    }
    error
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

/// The CSV's bytes, at most [`MAX_CSV_BYTES`] of them: `--data /dev/zero`
/// ran out of memory.
fn read_capped(path: &std::path::Path) -> Result<Vec<u8>, FromCsvError> {
    use std::io::Read;
    let mut data = Vec::new();
    fs::File::open(path)
        .and_then(|file| file.take(MAX_CSV_BYTES + 1).read_to_end(&mut data))
        .map_err(io_error(path))?;
    if data.len() as u64 > MAX_CSV_BYTES {
        return Err(FromCsvError::Data {
            path: path.to_owned(),
            source: CsvError::TooLarge {
                limit: MAX_CSV_BYTES,
            }
            .into(),
        });
    }
    Ok(data)
}

/// What one run needs besides the system type.
struct Context<'a> {
    options: &'a Options,
    /// The CSV's bytes, read from `options.data`.
    data: &'a [u8],
    system: SystemName,
    started: Instant,
    stop: &'a AtomicBool,
}

impl Context<'_> {
    fn run<S: MetriplecticSystem>(&self) -> Result<Summary, FromCsvError> {
        let options = self.options;
        let path = &options.data;
        let trajectories =
            read_trajectories_from(self.data, S::STATE_NAMES).map_err(|source| match source {
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
            // Only a window longer than the trajectories is helped by the
            // derivative route; other data errors name their own cause.
            let hint = match (&method, &source) {
                (DataMethod::Weak(_), Error::InvalidArgument { what, .. })
                    if what == "weak-form window" =>
                {
                    " (the window is --window N); shorter trajectories need --derivatives METHOD"
                }
                _ => "",
            };
            FromCsvError::Option(format!(
                "{}: the training trajectories cannot be used with the {}: {source}{hint}",
                path.display(),
                method.describe()
            ))
        })?;
        // Validation trajectories too short for a weak-form window still
        // count in the simulated error; only their equation score is missing.
        let window = match method {
            DataMethod::Weak(form) => form.window,
            _ => 0,
        };
        let long_enough: Vec<Trajectory> = validation
            .iter()
            .filter(|t| t.len() >= window)
            .cloned()
            .collect();
        let validation_equations = if long_enough.is_empty() {
            None
        } else {
            Equations::build(&long_enough, &method).ok()
        };

        fs::create_dir_all(&options.out).map_err(io_error(&options.out))?;
        let identify_started = Instant::now();
        let identification = self
            .identify::<S>(&train_equations)
            .map_err(|error| name_overflowing_row::<S>(error, &train, path))?;
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
        } else if long_enough.len() < validation.len() {
            warnings.push(format!(
                "{} of {} validation trajectories are shorter than the weak-form window ({window} samples): \
                 they count in validation_relative_error, not in validation_equation_relative_error",
                validation.len() - long_enough.len(),
                validation.len()
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
        if options.overwrite {
            output::remove_previous_outputs(out)?;
        }
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
        let weak = WeakForm {
            window: options.window.unwrap_or(WeakForm::default().window),
            ..WeakForm::default()
        };
        Ok(match options.derivatives {
            _ if options.weak || options.window.is_some() => DataMethod::Weak(weak),
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
            None => DataMethod::Weak(weak),
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
}
