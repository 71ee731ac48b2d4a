//! Why the pipeline could not run.

use std::path::{Path, PathBuf};

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
    /// An output could not be written where it goes (found before the
    /// run): a directory or other non-file under an output's name, a
    /// read-only file to be replaced, or an output directory that is not
    /// writable.
    #[error("cannot write {path}: {reason}; choose another --out or fix this before the run")]
    OutputNotWritable {
        /// The output file or directory.
        path: PathBuf,
        /// Why it cannot be written.
        reason: String,
    },
    /// The input CSV has the name of an output in the output directory, or
    /// such a name there links to it, and `--overwrite` would replace it.
    #[error("{0} is a file this run writes into --out, and it is the input CSV (or a link to it); with --overwrite the input would be replaced: choose another --out or move the input")]
    InputIsAnOutput(PathBuf),
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
    #[error("{path}: {reason}\nsystems this example knows: {known}")]
    UnknownSystem {
        /// The CSV.
        path: PathBuf,
        /// What the columns matched, and what to do.
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

pub(super) fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> FromCsvError + '_ {
    move |source| FromCsvError::Io {
        path: path.to_owned(),
        source,
    }
}
