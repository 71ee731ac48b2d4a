//! The `summary.json` of the analysis examples (`what_the_data_determine`,
//! `classical`): refused before any work if it exists and overwriting was
//! not asked for, written with its directory at the end.

use std::path::Path;

use metriplectic_runtime::{Error, Result};
use serde::Serialize;

/// Errors if `path` exists and `force` is not set.
pub(crate) fn check_writable(path: &Path, force: bool) -> Result<()> {
    if path.exists() && !force {
        return Err(Error::InvalidArgument {
            what: "output".into(),
            reason: format!("{} exists; pass --force to overwrite it", path.display()),
        });
    }
    Ok(())
}

/// Writes `value` as pretty JSON to `path`, creating its directory.
pub(crate) fn write<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| io_error(dir, e))?;
    }
    let json = serde_json::to_string_pretty(value).map_err(|e| Error::InvalidArgument {
        what: "summary".into(),
        reason: e.to_string(),
    })?;
    std::fs::write(path, json).map_err(|e| io_error(path, e))
}

fn io_error(path: &Path, err: std::io::Error) -> Error {
    Error::InvalidArgument {
        what: path.display().to_string(),
        reason: err.to_string(),
    }
}
