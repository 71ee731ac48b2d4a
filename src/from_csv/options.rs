//! The command line: its options, the systems it knows, and how the
//! identification equations are built.

use std::path::PathBuf;
use std::str::FromStr;

use metriplectic_runtime::prelude::*;

use super::FromCsvError;
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
    /// Trajectory CSV to identify from; read once, so a pipe works too
    /// (`--data /dev/stdin`).
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
    /// derivative estimate; each equation averages a window of consecutive
    /// samples (--window), so every training trajectory needs at least that
    /// many samples. The default when the CSV has no derivative columns.
    #[arg(long, conflicts_with = "derivatives")]
    pub weak: bool,
    /// Samples per weak-form window (at least 3; implies --weak)
    /// [default: 15].
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "N",
        conflicts_with = "derivatives"
    )]
    pub window: Option<usize>,
    /// Identify from derivatives: exact (the CSV's derivative columns dq, dp, ...; the
    /// default when it has them), fd2, fd4 or fd6 (finite differences of that
    /// order, for clean data), sg (Savitzky-Golay, window 7, degree 3),
    /// sg:W:D (window W, degree D) or spline (cubic smoothing spline, its
    /// smoothing chosen by cross-validation). Without a value: sg.
    #[arg(long, value_name = "METHOD", num_args = 0..=1, default_missing_value = "sg")]
    pub derivatives: Option<DerivativeChoice>,
    /// Fraction of the trajectories held out whole for validation (at least
    /// one is held out and at least one kept).
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "F",
        default_value_t = 0.2
    )]
    pub validation_fraction: f64,
    /// Seed of the validation split and the identifier.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "N",
        default_value_t = 1
    )]
    pub seed: u64,
    /// Iteration cap of the identification [default: 100].
    #[arg(long, allow_negative_numbers = true, value_name = "N")]
    pub max_iterations: Option<usize>,
    /// Write into a non-empty output directory, replacing files of the same
    /// names (other files are left alone).
    #[arg(long)]
    pub overwrite: bool,
    /// Validation trajectories drawn against the model's prediction.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "N",
        default_value_t = 4
    )]
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
            window: None,
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
    pub(super) fn catalogue() -> String {
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
pub(super) fn describe_derivatives(method: &DerivativeMethod) -> String {
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

pub(super) fn check_options(options: &Options) -> Result<(), FromCsvError> {
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
