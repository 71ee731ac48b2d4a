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
                "its columns ({}) are not the state variables of any system this example knows{}",
                columns.join(", "),
                header_hint(&columns)
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

/// What a header that names no system most likely is: a first line of
/// numbers (no header), or one column holding `;` or tabs (another
/// delimiter); empty if neither.
fn header_hint(columns: &[String]) -> &'static str {
    if columns.iter().all(|c| c.parse::<f64>().is_ok()) {
        " (the first line holds numbers only: the file needs a header line naming its columns, e.g. `trajectory,t,q,p`)"
    } else if columns.len() == 1 && columns[0].contains([';', '\t']) {
        " (one column holding `;` or tabs: the file must be comma-separated)"
    } else {
        ""
    }
}

#[cfg(test)]
mod tests {
    use super::header_hint;

    #[test]
    fn headers_that_are_data_or_another_delimiter_get_a_hint() {
        let cells = |line: &str| line.split(',').map(str::to_owned).collect::<Vec<_>>();
        assert!(header_hint(&cells("0,0.0109,1.5")).contains("needs a header line"));
        assert!(header_hint(&cells("t;q;p")).contains("comma-separated"));
        assert!(header_hint(&cells("t\tq\tp")).contains("comma-separated"));
        assert_eq!(header_hint(&cells("t,x,speed")), "");
    }
}
