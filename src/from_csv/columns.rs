//! Which system a CSV holds, from its header's column names.

use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use super::{io_error, FromCsvError, SystemName};

/// The column names of the CSV's header line (trimmed, quotes removed).
pub(super) fn header_columns(path: &Path) -> Result<Vec<String>, FromCsvError> {
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
pub(super) fn infer_system(path: &Path) -> Result<SystemName, FromCsvError> {
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
