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
    Dataset(#[from] crate::dataset::DatasetError),
    /// A simulation stopped early (step size, step budget, stiffness, NaN).
    #[error(transparent)]
    Simulation(#[from] crate::simulate::SimulationError),
    /// Malformed trajectory CSV, with line and column.
    #[error(transparent)]
    Csv(#[from] crate::csv_io::CsvError),
    /// Invalid configuration or argument.
    #[error("invalid {what}: {reason}")]
    InvalidArgument {
        /// The parameter.
        what: String,
        /// Why it was rejected and what is accepted.
        reason: String,
    },
    /// A conic problem could not be handed to Clarabel (malformed assembly).
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
    Plot(#[from] crate::plot::PlotError),
}

/// `Result` with the runtime's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

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
