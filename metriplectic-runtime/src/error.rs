//! The runtime's typed errors.
//!
//! Every fallible public function in this crate returns [`Result`]. Variants
//! name the offending quantity precisely (which sample, which column, which
//! coefficient) so that a user can fix their input without reading our code.

use std::path::PathBuf;

/// Errors of the metriplectic runtime.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A vector or matrix has the wrong length for the system.
    #[error("{what}: expected length {expected}, got {found}")]
    DimensionMismatch {
        /// What was being checked (e.g. "state", "entropy coefficients").
        what: String,
        /// The length the system requires.
        expected: usize,
        /// The length that was given.
        found: usize,
    },
    /// A value is NaN or infinite.
    #[error("{what}: non-finite value {value} at index {index}")]
    NonFinite {
        /// What was being checked.
        what: String,
        /// Position of the offending value.
        index: usize,
        /// The value itself (NaN or ±inf).
        value: f64,
    },
    /// A metric that is not positive semidefinite: the free energy could
    /// decrease along ẋ, which no model may allow.
    #[error(
        "{what}: K(x) is not positive semidefinite: eigenvalue {eigenvalue:e} in direction {direction:?}{}; the free energy would decrease there (dE/dt = ∇Eᵀ K ∇E < 0; for a classical system, the entropy: dS/dt = ∇Sᵀ K ∇S < 0)",
        state.as_ref().map(|x| format!(" at x = {x:?}")).unwrap_or_else(|| " (for every x: the metric is constant)".to_owned())
    )]
    MetricNotPositive {
        /// Which metric (e.g. "metric coefficients", "initial metric coefficients").
        what: String,
        /// The most negative eigenvalue found.
        eigenvalue: f64,
        /// Its eigenvector y: yᵀ K y < 0.
        direction: Vec<f64>,
        /// A state where K(x) has that eigenvalue (`None` for a constant metric).
        state: Option<Vec<f64>>,
    },
    /// A state-dependent metric for which no certificate of K(x) ⪰ 0 was
    /// found, although no state with a negative eigenvalue was found either;
    /// the reason ends by saying where K(x) ⪰ 0 is required (for every x, or
    /// on the region only for `certificate on region;`).
    #[error("{what}: could not certify K(x) ⪰ 0: {reason}")]
    MetricNotCertified {
        /// Which metric.
        what: String,
        /// What the certificate search found.
        reason: String,
    },
    /// Coefficients of a classical system (`classical;`) that break one of
    /// its constraints: the entropy is not a Casimir of Π, or the metric
    /// is not degenerate along ∇H, so H would not be conserved or S would
    /// not be produced.
    #[error("{what}: {condition}, and constraint row {row} has residual {residual:e} (coefficients up to {scale:e})")]
    NotClassical {
        /// Which coefficients.
        what: String,
        /// The condition broken, in words.
        condition: String,
        /// The constraint row (of `Classical::entropy_constraints` or
        /// `metric_constraints`) with the largest residual.
        row: usize,
        /// Its residual.
        residual: f64,
        /// The largest coefficient magnitude, the residual's scale.
        scale: f64,
    },
    /// The system declares no reference model.
    #[error("system `{system}` declares no reference model (add a `reference {{ … }}` section to its `metriplectic!` block)")]
    NoReference {
        /// The system's name.
        system: &'static str,
    },
    /// An I/O error, with the path involved.
    #[error("{path}: {source}")]
    Io {
        /// The file that could not be read or written.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// Malformed JSON.
    #[error("invalid JSON{}: {source}", context.as_ref().map(|c| format!(" in {c}")).unwrap_or_default())]
    Json {
        /// The file or item being parsed, when known.
        context: Option<String>,
        /// The underlying error.
        #[source]
        source: serde_json::Error,
    },
    /// A saved model belongs to another system or other bases.
    #[error("model is for {found}, not for {expected}")]
    WrongSystem {
        /// Description of the system it was loaded into.
        expected: String,
        /// Description of the system it was saved from.
        found: String,
    },
    /// Malformed identification data.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// A simulation stopped early (step size, step budget, stiffness, NaN).
    #[error(transparent)]
    Simulation(#[from] SimulationError),
    /// Malformed trajectory CSV, with line and column.
    #[error(transparent)]
    Csv(#[from] CsvError),
    /// Invalid configuration or argument.
    #[error("invalid {what}: {reason}")]
    InvalidArgument {
        /// The parameter.
        what: String,
        /// Why it was rejected and what is accepted.
        reason: String,
    },
    /// A problem could not be handed to the solver.
    #[error("solver setup failed: {reason}")]
    Solver {
        /// What went wrong.
        reason: String,
    },
    /// Identification could not make any progress (every solve failed).
    #[error("identification failed after {iterations} iteration(s): {reason}")]
    IdentificationFailed {
        /// Iterations run before giving up.
        iterations: usize,
        /// What failed (solver statuses).
        reason: String,
    },
    /// Refused to overwrite an existing file.
    #[error("{path}: file exists; refusing to overwrite it (ask for overwrite explicitly)")]
    FileExists {
        /// The existing file.
        path: PathBuf,
    },
    /// A file is larger than the reader accepts (guards against exhausting
    /// memory on a corrupt or hostile file).
    #[error("{path}: file has {size} bytes, more than the {limit} accepted for {what}")]
    FileTooLarge {
        /// The file.
        path: PathBuf,
        /// What the file was read as (e.g. "a model file").
        what: String,
        /// Its size in bytes.
        size: u64,
        /// The largest size accepted.
        limit: u64,
    },
    /// A checkpoint does not belong to the run it was asked to resume
    /// (another system, other data or another configuration).
    #[error("checkpoint {path} cannot resume this run: {reason}")]
    CheckpointMismatch {
        /// The checkpoint file.
        path: PathBuf,
        /// What differs.
        reason: String,
    },
    /// A figure could not be made (feature `plot`).
    #[cfg(feature = "plot")]
    #[error(transparent)]
    Plot(#[from] PlotError),
}

/// Errors specific to dataset construction, reported with the sample index and
/// state column of the first offending value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DatasetError {
    /// No samples were given.
    #[error("dataset is empty: at least one sample (x, ẋ) is required")]
    Empty,
    /// The state dimension is zero.
    #[error("state dimension must be at least 1")]
    ZeroDimension,
    /// A flat buffer's length is not a multiple of the dimension.
    #[error("{what} buffer has {len} values, not a multiple of the state dimension {dim}")]
    RaggedBuffer {
        /// "states" or "derivatives".
        what: &'static str,
        /// Length of the buffer.
        len: usize,
        /// State dimension.
        dim: usize,
    },
    /// States and derivatives disagree in sample count.
    #[error("{states} states but {derivatives} derivatives: every state needs its derivative")]
    CountMismatch {
        /// Number of states.
        states: usize,
        /// Number of derivatives.
        derivatives: usize,
    },
    /// One sample has the wrong number of columns.
    #[error("sample {sample}: {what} has {found} columns, the system has {expected}")]
    WrongWidth {
        /// Sample index (0-based).
        sample: usize,
        /// "state" or "derivative".
        what: &'static str,
        /// Columns expected.
        expected: usize,
        /// Columns found.
        found: usize,
    },
    /// A NaN or infinite value.
    #[error("sample {sample}, {what} column {column}: non-finite value {value}")]
    NonFinite {
        /// Sample index (0-based).
        sample: usize,
        /// "state" or "derivative".
        what: &'static str,
        /// State column (0-based).
        column: usize,
        /// The offending value.
        value: f64,
    },
}

/// Malformed trajectory CSV. Lines are 1-based with the header on line 1;
/// columns are 1-based.
///
/// ```
/// use metriplectic_runtime::{read_trajectories_from, CsvError};
/// use metriplectic_runtime::Error;
///
/// let err = read_trajectories_from("t,x\n0,1\n0.1,oops\n".as_bytes(), &["x"]).unwrap_err();
/// assert!(matches!(err, Error::Csv(CsvError::NotANumber { line: 3, column: 2, .. })));
/// assert_eq!(err.to_string(), "line 3, column 2 (`x`): `oops` is not a number");
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CsvError {
    /// The input has no header line (it is empty or blank).
    #[error("empty input or blank first line: expected a header line with the columns {expected}")]
    NoHeader {
        /// The columns the system expects.
        expected: String,
    },
    /// The input is longer than [`MAX_CSV_BYTES`](crate::MAX_CSV_BYTES).
    #[error("the input is longer than {limit} bytes, the most a CSV is read into memory (an endless stream such as /dev/zero, or a file to split into several)")]
    TooLarge {
        /// The limit in bytes.
        limit: u64,
    },
    /// The header has no data rows after it.
    #[error("no data rows after the header (line {line})")]
    NoRows {
        /// The header's line number (1-based; blank lines before it count).
        line: u64,
    },
    /// Required columns are absent.
    #[error(
        "line {line}: missing column(s) {}; expected columns: {expected}",
        quoted(missing)
    )]
    MissingColumns {
        /// The header's line number.
        line: u64,
        /// The missing names.
        missing: Vec<String>,
        /// The columns the system expects.
        expected: String,
    },
    /// Columns the system does not know.
    #[error(
        "line {line}: unknown column(s) {}; expected columns: {expected}",
        quoted(unknown)
    )]
    UnknownColumns {
        /// The header's line number.
        line: u64,
        /// The unknown names.
        unknown: Vec<String>,
        /// The columns the system expects.
        expected: String,
    },
    /// A column name appears twice.
    #[error("line {line}: column `{name}` appears twice (columns {first} and {second})")]
    DuplicateColumn {
        /// The header's line number.
        line: u64,
        /// The repeated name.
        name: String,
        /// First position (1-based).
        first: usize,
        /// Second position (1-based).
        second: usize,
    },
    /// Some but not all derivative columns are present.
    #[error(
        "line {line}: derivative columns must be all present or all absent; found {}, missing {}",
        quoted(present),
        quoted(missing)
    )]
    PartialDerivatives {
        /// The header's line number.
        line: u64,
        /// Derivative columns found.
        present: Vec<String>,
        /// Derivative columns missing.
        missing: Vec<String>,
    },
    /// A state name collides with a reserved or derived column name.
    #[error("state variable `{name}` clashes with the column name `{name}` this format reserves for {reserved_for}; rename the variable")]
    ReservedName {
        /// The state name.
        name: String,
        /// What the column name is used for.
        reserved_for: String,
    },
    /// A row has the wrong number of cells.
    #[error("line {line}: {found} cell(s), but the header has {expected} columns")]
    FieldCount {
        /// Line number.
        line: u64,
        /// Columns in the header.
        expected: usize,
        /// Cells found.
        found: usize,
    },
    /// A cell is not a number.
    #[error("line {line}, column {column} (`{name}`): `{text}` is not a number")]
    NotANumber {
        /// Line number.
        line: u64,
        /// Column number (1-based).
        column: usize,
        /// Column name.
        name: String,
        /// The cell's text.
        text: String,
    },
    /// A cell is NaN or infinite.
    #[error("line {line}, column {column} (`{name}`): non-finite value `{text}` (NaN and infinities are not allowed)")]
    NonFinite {
        /// Line number.
        line: u64,
        /// Column number (1-based).
        column: usize,
        /// Column name.
        name: String,
        /// The cell's text.
        text: String,
    },
    /// A header cell is empty (often a trailing comma).
    #[error("line {line}, column {column}: the column has no name (a trailing comma?)")]
    EmptyColumnName {
        /// The header's line number.
        line: u64,
        /// Column number (1-based).
        column: usize,
    },
    /// A quoted cell is never closed: it swallows the line ends after it.
    #[error("line {line}: a quote (`\"`) opens a cell that is never closed")]
    UnclosedQuote {
        /// Line where the unclosed cell starts.
        line: u64,
    },
    /// A trajectory identifier cell is empty.
    #[error("line {line}, column {column} (`trajectory`): empty trajectory identifier")]
    EmptyTrajectoryId {
        /// Line number.
        line: u64,
        /// Column number (1-based).
        column: usize,
    },
    /// Time did not strictly increase within a trajectory.
    #[error("line {line}, column {column} (`t`): time {} does not come after {} on line {previous_line}{}{}: times must strictly increase within a trajectory{}", Num(*time), Num(*previous), if time == previous { " (the same number once read as a 64-bit float)" } else { "" }, trajectory.as_ref().map(|t| format!(" in trajectory `{t}`")).unwrap_or_default(), if trajectory.is_none() { " (a file of several trajectories needs a `trajectory` column)" } else { "" })]
    NonIncreasingTime {
        /// Line number.
        line: u64,
        /// Column number of `t` (1-based).
        column: usize,
        /// The trajectory, when the file has a `trajectory` column.
        trajectory: Option<String>,
        /// The earlier time.
        previous: f64,
        /// Its line.
        previous_line: u64,
        /// The offending time.
        time: f64,
    },
    /// A trajectory's rows are split by rows of another trajectory.
    #[error("line {line}: trajectory `{id}` resumes after other trajectories (its rows began on line {first_line}); the rows of a trajectory must be contiguous")]
    SplitTrajectory {
        /// Line number.
        line: u64,
        /// The trajectory.
        id: String,
        /// Where its rows began.
        first_line: u64,
    },
    /// The CSV syntax itself is broken (e.g. invalid UTF-8, unclosed quote).
    #[error("line {line}: malformed CSV: {message}")]
    Malformed {
        /// Line number.
        line: u64,
        /// The parser's message.
        message: String,
    },
    /// Trajectories handed to the writer do not share a column layout.
    #[error("cannot write trajectory {index}: {reason}")]
    Inconsistent {
        /// Index of the offending trajectory.
        index: usize,
        /// What differs.
        reason: String,
    },
}

pub(crate) fn quoted(names: &[String]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Why an integration stopped early.
///
/// ```
/// use metriplectic_runtime::{integrate, IntegratorOptions, OutputTimes, SimulationError};
/// use metriplectic_runtime::Error;
///
/// // ẋ = x² from 1 blows up at t = 1.
/// let err = integrate(|_t, x, dx| dx[0] = x[0] * x[0], &[1.0], 0.0, 2.0,
///                     &IntegratorOptions::default(), &OutputTimes::Steps).unwrap_err();
/// assert!(matches!(err, Error::Simulation(SimulationError::StepSizeUnderflow { .. }
///                                        | SimulationError::NonFinite { .. })));
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SimulationError {
    /// The step size became too small for the time in floating point.
    #[error("integration failed at t = {}: step size underflow (the solution may blow up or be too stiff for an explicit method)", Num(*.t))]
    StepSizeUnderflow {
        /// Time reached.
        t: f64,
    },
    /// The step budget was exhausted.
    #[error("integration stopped at t = {}: more than {max_steps} steps needed (raise `max_steps`, loosen the tolerances or shorten the interval)", Num(*.t))]
    TooManySteps {
        /// Time reached.
        t: f64,
        /// The step budget.
        max_steps: u32,
    },
    /// DOPRI5's stiffness test fired repeatedly.
    #[error("integration stopped at t = {}: the problem became stiff (an explicit method needs tiny steps here; start closer to the attractor or shorten the interval)", Num(*.t))]
    Stiff {
        /// Time reached.
        t: f64,
    },
    /// The implicit equation of a discrete-gradient step
    /// ([`Method::DiscreteGradient`](crate::Method::DiscreteGradient)) was
    /// not solved to rounding: its iteration diverged, or stalled above a
    /// few ulps of the state.
    #[error("discrete-gradient step {step} from t = {} with step size {} at |x| = {} did not converge: the last update (or residual) of its implicit equation was {update:e} after {iterations} iterations, above rounding (take a smaller step; if |x| grows without bound along the trajectory, the solution may blow up in finite time)", Num(*.t), Num(*.h), Num(*.state_norm))]
    StepNotConverged {
        /// Index of the step (0 for the first).
        step: usize,
        /// Time at the start of the step.
        t: f64,
        /// Its step size.
        h: f64,
        /// Norm of the last update of the iteration (may be non-finite), or
        /// of the residual ‖Φ(x′) − x′‖ when the update was small only
        /// through a Jacobian taken elsewhere.
        update: f64,
        /// Iterations done.
        iterations: u32,
        /// Euclidean norm of the state the step started from.
        state_norm: f64,
    },
    /// The vector field or the state became NaN or infinite.
    #[error("integration failed at t = {}: non-finite {what} in component {index}", Num(*.t))]
    NonFinite {
        /// Time where it was first seen.
        t: f64,
        /// "state" or "vector field".
        what: &'static str,
        /// State component.
        index: usize,
    },
}

/// Why a figure could not be made (feature `plot`).
#[cfg(feature = "plot")]
#[cfg_attr(docsrs, doc(cfg(feature = "plot")))]
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// The output path's extension is neither `.png` nor `.svg`.
    #[error("{}: unsupported figure format (use a .png or .svg file name)", path.display())]
    UnsupportedFormat {
        /// The rejected path.
        path: PathBuf,
    },
    /// There is nothing to draw.
    #[error("{what} is empty")]
    Empty {
        /// What was empty (e.g. "trajectory 3", "series `metric search`").
        what: String,
    },
    /// A state has the wrong number of components for the figure.
    #[error("trajectory {trajectory}, point {point}: expected {expected} components, got {found}")]
    PointDimension {
        /// Index of the trajectory.
        trajectory: usize,
        /// Index of the point within the trajectory.
        point: usize,
        /// Components the figure needs (2 or 3).
        expected: usize,
        /// Components the point has.
        found: usize,
    },
    /// A state of a time-series figure has the wrong number of components.
    #[error("{what}, sample {sample}: {found} components, but {expected} state names were given")]
    StateDimension {
        /// Which trajectory (e.g. "model trajectory 2").
        what: String,
        /// Index of the sample within the trajectory.
        sample: usize,
        /// Components expected: the number of state names.
        expected: usize,
        /// Components the state has.
        found: usize,
    },
    /// A value is NaN or infinite.
    #[error("{what}: non-finite value {value} at index {index}")]
    NonFinite {
        /// Where (e.g. "trajectory 3", "zero set", "series `entropy search`").
        what: String,
        /// Index of the offending point or value.
        index: usize,
        /// The value itself.
        value: f64,
    },
    /// Two sequences that must pair up have different lengths.
    #[error("{what}: {left} times but {right} values")]
    LengthMismatch {
        /// Which curve.
        what: String,
        /// Length of the first sequence (times).
        left: usize,
        /// Length of the second sequence (values).
        right: usize,
    },
    /// A log-scale figure has no positive value to show.
    #[error("{what}: no positive value, nothing can be drawn on a log scale")]
    NoPositiveValues {
        /// The figure's data.
        what: String,
    },
    /// An argument is out of range.
    #[error("invalid {what}: {reason}")]
    InvalidArgument {
        /// The parameter.
        what: String,
        /// Why it was rejected and what is accepted.
        reason: String,
    },
    /// The embedded font could not be loaded (a build defect, not user error).
    #[error("the embedded figure font could not be loaded")]
    Font,
    /// plotters failed while drawing.
    #[error("{}: drawing failed: {message}", path.display())]
    Drawing {
        /// The figure being drawn.
        path: PathBuf,
        /// plotters' message.
        message: String,
    },
    /// PNG encoding failed.
    #[error("{}: PNG encoding failed: {message}", path.display())]
    Encoding {
        /// The figure being written.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
    /// The file could not be written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The figure being written.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}

/// `Result` with the runtime's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// The same error, saying where its subject was found: `place` (e.g.
    /// "model file PATH", "the best model of checkpoint PATH") joins the
    /// quantity an error names ("metric coefficients in model file PATH:
    /// …"), so that an error raised while reading a file names the file.
    /// The variant stays the same; errors that name their path already
    /// (`Io`, `FileTooLarge`, …) and those about something else are
    /// returned unchanged.
    pub(crate) fn located(self, place: &str) -> Self {
        let at = |what: String| format!("{what} in {place}");
        match self {
            Self::DimensionMismatch {
                what,
                expected,
                found,
            } => Self::DimensionMismatch {
                what: at(what),
                expected,
                found,
            },
            Self::NonFinite { what, index, value } => Self::NonFinite {
                what: at(what),
                index,
                value,
            },
            Self::MetricNotPositive {
                what,
                eigenvalue,
                direction,
                state,
            } => Self::MetricNotPositive {
                what: at(what),
                eigenvalue,
                direction,
                state,
            },
            Self::MetricNotCertified { what, reason } => Self::MetricNotCertified {
                what: at(what),
                reason,
            },
            Self::NotClassical {
                what,
                condition,
                row,
                residual,
                scale,
            } => Self::NotClassical {
                what: at(what),
                condition,
                row,
                residual,
                scale,
            },
            Self::InvalidArgument { what, reason } => Self::InvalidArgument {
                what: at(what),
                reason,
            },
            Self::WrongSystem { expected, found } => Self::WrongSystem {
                expected,
                found: format!("{found} according to {place}"),
            },
            Self::Json { context, source } => Self::Json {
                context: Some(context.map_or_else(|| place.to_owned(), at)),
                source,
            },
            other => other,
        }
    }
}

/// Checks that `values` has length `expected`.
pub(crate) fn check_len(what: &str, values: &[f64], expected: usize) -> Result<()> {
    if values.len() == expected {
        Ok(())
    } else {
        Err(Error::DimensionMismatch {
            what: what.to_owned(),
            expected,
            found: values.len(),
        })
    }
}

/// Checks that every entry of `values` is finite.
pub(crate) fn check_finite(what: &str, values: &[f64]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(index) => Err(Error::NonFinite {
            what: what.to_owned(),
            index,
            value: values[index],
        }),
    }
}

/// An [`Error::InvalidArgument`] for parameter `what`.
/// A number for a message: plain between 1e-4 and 1e7 (`0.25`, `1500`),
/// in exponent form outside (`1e16`, `2.5e-300`) instead of Rust's hundreds
/// of digits.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let magnitude = self.0.abs();
        if magnitude == 0.0 || !magnitude.is_finite() || (1e-4..1e7).contains(&magnitude) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

pub(crate) fn invalid(what: &str, reason: impl Into<String>) -> Error {
    Error::InvalidArgument {
        what: what.to_owned(),
        reason: reason.into(),
    }
}

/// Checks that `times` are finite and strictly increasing, naming the first
/// offending entry.
pub(crate) fn check_strictly_increasing(what: &str, times: &[f64]) -> Result<()> {
    if let Some(k) = times.iter().position(|t| !t.is_finite()) {
        return Err(invalid(
            what,
            format!("entry {k} is {}; times must be finite", times[k]),
        ));
    }
    if let Some(k) = times.windows(2).position(|w| w[1] <= w[0]) {
        return Err(invalid(
            what,
            format!(
                "entry {} ({}) does not come after entry {k} ({}): times must strictly increase",
                k + 1,
                times[k + 1],
                times[k]
            ),
        ));
    }
    Ok(())
}
