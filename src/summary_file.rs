//! The `summary.json` of the analysis examples (`what_the_data_determine`,
//! `classical`): refused before any work if it exists and overwriting was
//! not asked for, written with its directory at the end (whole or not at
//! all).

use std::path::Path;

use metriplectic_runtime::{write_file, Error, Result, WriteMode};
use serde::Serialize;

/// Errors if `path` exists and `force` is not set, if it is a directory,
/// or if its directory cannot be made because a file stands where one of
/// its ancestors should be: all found before the run, not after it.
pub(crate) fn check_writable(path: &Path, force: bool) -> Result<()> {
    let refuse = |reason: String| Error::InvalidArgument {
        what: "output".into(),
        reason,
    };
    if path.is_dir() {
        return Err(refuse(format!("{} is a directory", path.display())));
    }
    if path.exists() && !force {
        return Err(refuse(format!(
            "{} exists; pass --force to overwrite it",
            path.display()
        )));
    }
    // The nearest ancestor that exists is where the directories will be
    // made, so it must be a directory itself.
    let mut ancestors = path.ancestors().skip(1);
    if let Some(existing) = ancestors.find(|a| a.as_os_str().is_empty() || a.exists()) {
        if !existing.as_os_str().is_empty() && !existing.is_dir() {
            return Err(refuse(format!(
                "{} is a file, so the directory for {} cannot be made",
                existing.display(),
                path.display()
            )));
        }
    }
    Ok(())
}

/// Writes `value` as pretty JSON to `path` (whole or not at all), creating
/// its directory.
pub(crate) fn write<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| io_error(dir, e))?;
    }
    let json = serde_json::to_string_pretty(value).map_err(|e| Error::InvalidArgument {
        what: "summary".into(),
        reason: e.to_string(),
    })?;
    write_file(path, json.as_bytes(), WriteMode::Overwrite)
}

fn io_error(path: &Path, err: std::io::Error) -> Error {
    Error::InvalidArgument {
        what: path.display().to_string(),
        reason: err.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unwritable_summaries_are_refused_before_the_run() {
        let dir = std::env::temp_dir().join(format!("summary-file-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("a-file");
        std::fs::write(&file, "x").unwrap();
        // A file where a directory should be, at any depth.
        for path in [file.join("summary.json"), file.join("sub/summary.json")] {
            let err = check_writable(&path, true).unwrap_err().to_string();
            assert!(err.contains("is a file"), "{err}");
        }
        // The summary's own name taken by a directory.
        let err = check_writable(&dir, true).unwrap_err().to_string();
        assert!(err.contains("is a directory"), "{err}");
        // An existing summary without --force, and with it.
        assert!(check_writable(&file, false).is_err());
        check_writable(&file, true).unwrap();
        check_writable(&dir.join("new/deeper/summary.json"), false).unwrap();
        write(&dir.join("new/summary.json"), &[1, 2]).unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.join("new/summary.json")).unwrap(),
            "[\n  1,\n  2\n]"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
