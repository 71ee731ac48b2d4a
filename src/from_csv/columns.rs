//! Which system a CSV holds, from its header's column names.
//!
//! The header is checked by the CSV reader itself, once per system, so that
//! what is wrong with it (an empty column name, a column twice, an empty
//! file) is said in the reader's words, with its line and column, and a
//! header that nearly fits a system is named with that system's complaint.

use std::path::Path;

use metriplectic_runtime::{read_trajectories_from, CsvError, Error};

use super::{FromCsvError, SystemName};

/// The beginning of the CSV text up to the end of its header line: blank
/// lines (which the reader skips) and the header, whose line ends are those
/// outside quotes. A UTF-8 byte-order mark stays (the reader drops it).
pub(super) fn header_prefix(bytes: &[u8]) -> &[u8] {
    const BOM: &[u8] = b"\xef\xbb\xbf";
    let skipped = if bytes.starts_with(BOM) { BOM.len() } else { 0 };
    let is_end = |b: &u8| *b == b'\n' || *b == b'\r';
    let Some(start) = bytes[skipped..].iter().position(|b| !is_end(b)) else {
        return bytes;
    };
    let mut quoted = false;
    for (at, byte) in bytes.iter().enumerate().skip(skipped + start) {
        if *byte == b'"' {
            quoted = !quoted;
        } else if !quoted && is_end(byte) {
            // Keep `\r\n` whole.
            let end = if bytes[at..].starts_with(b"\r\n") {
                at + 2
            } else {
                at + 1
            };
            return &bytes[..end];
        }
    }
    bytes
}

/// What the reader says of the header for a system's state variables:
/// `Ok` if it would read the file's columns.
fn check_header(header: &[u8], system: SystemName) -> Result<(), Error> {
    match read_trajectories_from(header, system.state_names()) {
        Ok(_) | Err(Error::Csv(CsvError::NoRows { .. })) => Ok(()),
        Err(error) => Err(error),
    }
}

/// Whether the reader refused the header for its columns (names another
/// system has or lacks), as opposed to something wrong whatever the system.
fn is_column_mismatch(error: &Error) -> bool {
    matches!(
        error,
        Error::Csv(
            CsvError::MissingColumns { .. }
                | CsvError::UnknownColumns { .. }
                | CsvError::PartialDerivatives { .. }
        )
    )
}

/// The column names of the header line (trimmed, quotes removed), for
/// messages and for telling which system a header nearly fits.
fn header_columns(header: &[u8]) -> Vec<String> {
    let text = String::from_utf8_lossy(header);
    let line = text
        .trim_start_matches('\u{feff}')
        .trim_matches(['\r', '\n']);
    line.split(',')
        .map(|cell| cell.trim().trim_matches('"').trim().to_owned())
        .collect()
}

/// The system whose state variables, and nothing else the format does not
/// know, are the columns of the CSV text `bytes` (read from `path`).
pub(super) fn infer_system(path: &Path, bytes: &[u8]) -> Result<SystemName, FromCsvError> {
    let header = header_prefix(bytes);
    let verdicts: Vec<(SystemName, Result<(), Error>)> = SystemName::ALL
        .into_iter()
        .map(|system| (system, check_header(header, system)))
        .collect();
    let matching: Vec<SystemName> = verdicts
        .iter()
        .filter(|(_, verdict)| verdict.is_ok())
        .map(|(system, _)| *system)
        .collect();
    match matching.as_slice() {
        [system] => Ok(*system),
        [] => Err(no_system_fits(path, header, verdicts)),
        several => Err(FromCsvError::UnknownSystem {
            path: path.to_owned(),
            reason: format!(
                "its columns fit several systems ({}); pass --system NAME",
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

/// Why no system reads the header: the reader's own complaint when it is
/// not about the columns' names (an empty file, an unnamed or repeated
/// column), the nearest systems' complaints when some of the columns are a
/// system's, and the columns themselves otherwise.
fn no_system_fits(
    path: &Path,
    header: &[u8],
    verdicts: Vec<(SystemName, Result<(), Error>)>,
) -> FromCsvError {
    let mut refusals: Vec<(SystemName, Error)> = verdicts
        .into_iter()
        .filter_map(|(system, verdict)| verdict.err().map(|error| (system, error)))
        .collect();
    if let Some(at) = refusals
        .iter()
        .position(|(_, error)| !is_column_mismatch(error))
    {
        // The same for every system (the reader checks these first).
        let source = match refusals.swap_remove(at).1 {
            Error::Csv(CsvError::NoHeader { .. }) => CsvError::NoHeader {
                expected: any_system_columns(),
            }
            .into(),
            other => other,
        };
        return FromCsvError::Data {
            path: path.to_owned(),
            source,
        };
    }
    let columns = header_columns(header);
    // How many columns are the system's state variables or their derivatives.
    let overlap = |system: SystemName| {
        let names = system.state_names();
        columns
            .iter()
            .filter(|column| {
                names.contains(&column.as_str())
                    || column
                        .strip_prefix('d')
                        .is_some_and(|rest| names.contains(&rest))
            })
            .count()
    };
    let best = refusals
        .iter()
        .map(|(system, _)| overlap(*system))
        .max()
        .unwrap_or(0);
    let reason = if best == 0 {
        format!(
            "its columns ({}) are not the state variables of any system this example knows{}; pass --system NAME",
            columns.join(", "),
            header_hint(&columns)
        )
    } else {
        let nearest: Vec<String> = refusals
            .iter()
            .filter(|(system, _)| overlap(*system) == best)
            .map(|(system, error)| {
                format!(
                    "system `{}` ({}), but {error}",
                    system.as_str(),
                    system.state_names().join(", ")
                )
            })
            .collect();
        format!(
            "its columns ({}) nearly fit {}",
            columns.join(", "),
            nearest.join("; or ")
        )
    };
    FromCsvError::UnknownSystem {
        path: path.to_owned(),
        reason,
        known: SystemName::catalogue(),
    }
}

/// The columns a header needs when the system is not known yet, in the
/// words of the reader's "expected columns".
fn any_system_columns() -> String {
    let states: Vec<String> = SystemName::ALL
        .iter()
        .map(|system| {
            let names: Vec<String> = system
                .state_names()
                .iter()
                .map(|n| format!("`{n}`"))
                .collect();
            format!("{} for {}", names.join(", "), system.as_str())
        })
        .collect();
    format!(
        "`t` and the state variables of one system ({}) (required); `d` and each state variable's name, \
         e.g. `dq` (optional, all or none); `trajectory` (optional)",
        states.join("; ")
    )
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
    use std::path::Path;

    use super::{header_hint, header_prefix, infer_system};
    use crate::from_csv::{FromCsvError, SystemName};

    #[test]
    fn headers_that_are_data_or_another_delimiter_get_a_hint() {
        let cells = |line: &str| line.split(',').map(str::to_owned).collect::<Vec<_>>();
        assert!(header_hint(&cells("0,0.0109,1.5")).contains("needs a header line"));
        assert!(header_hint(&cells("t;q;p")).contains("comma-separated"));
        assert!(header_hint(&cells("t\tq\tp")).contains("comma-separated"));
        assert_eq!(header_hint(&cells("t,x,speed")), "");
    }

    #[test]
    fn the_header_prefix_ends_with_the_header_line() {
        assert_eq!(header_prefix(b"t,q,p\n0,1,2\n"), b"t,q,p\n");
        assert_eq!(
            header_prefix(b"\n\r\n t,q,p\r\n0,1,2\r\n"),
            b"\n\r\n t,q,p\r\n"
        );
        assert_eq!(
            header_prefix(b"\xef\xbb\xbf\nt,q\n1,2"),
            b"\xef\xbb\xbf\nt,q\n"
        );
        assert_eq!(header_prefix(b"t,\"a\nb\",p\n1"), b"t,\"a\nb\",p\n");
        assert_eq!(header_prefix(b"t,q,p"), b"t,q,p");
        assert_eq!(header_prefix(b""), b"");
        assert_eq!(header_prefix(b"\n\n"), b"\n\n");
    }

    /// Without --system the header was split by hand: a trailing comma, an
    /// extra column, `time` for `t` all got "its columns (…) are not the
    /// state variables of any system", blank lines before the header
    /// "its columns ()", and an empty file the same; the reader's own
    /// messages say what is wrong.
    #[test]
    fn a_header_that_fits_no_system_gets_the_readers_reason() {
        let infer = |text: &str| infer_system(Path::new("in.csv"), text.as_bytes());
        let message = |text: &str| match infer(text) {
            Ok(system) => panic!("{text:?} read as {system:?}"),
            Err(error) => error.to_string(),
        };
        assert_eq!(
            infer("\n\n\ntrajectory,t,x,v\n0,0,1,2\n").unwrap(),
            SystemName::Duffing
        );
        assert_eq!(
            infer("\u{feff}t,q,p\r\n0,1,2\r\n").unwrap(),
            SystemName::Linear2d
        );

        let trailing = message("trajectory,t,x,v,dx,dv,\n0,0,1,2,3,4,\n");
        assert!(
            trailing.starts_with(
                "in.csv: line 1, column 7: the column has no name (a trailing comma?)"
            ),
            "{trailing}"
        );
        let extra = message("trajectory,t,x,v,temperature\n0,0,1,2,3\n");
        assert!(
            extra.contains(
                "nearly fit system `duffing` (x, v), but line 1: unknown column(s) `temperature`"
            ),
            "{extra}"
        );
        let time = message("\ntime,q,p\n0,1,2\n");
        assert!(
            time.contains("nearly fit system `linear_2d` (q, p), but line 2: unknown column(s) `time`; expected columns: `t`"),
            "{time}"
        );
        let missing = message("t,px,py\n0,1,2\n");
        assert!(
            missing.contains(
                "system `rigid_body_so3` (px, py, pz), but line 1: missing column(s) `pz`"
            ),
            "{missing}"
        );
        let partial = message("t,q,p,dq\n0,1,2,3\n");
        assert!(partial.contains("found `dq`, missing `dp`"), "{partial}");
        let twice = message("t,q,p,q\n0,1,2,3\n");
        assert!(
            twice.contains("line 1: column `q` appears twice (columns 2 and 4)"),
            "{twice}"
        );
        for empty in ["", "\n\n", " \n0,1,2\n"] {
            let error = infer(empty).unwrap_err();
            assert!(matches!(error, FromCsvError::Data { .. }), "{error:?}");
            let text = error.to_string();
            assert!(
                text.starts_with("in.csv: empty input or blank first line: expected a header line")
                    && text.contains("`q`, `p` for linear_2d"),
                "{text}"
            );
        }
        // Columns of no system still get the list and the hints.
        let none = message("trajectory,t,a,b\n0,0,1,2\n");
        assert!(
            none.contains("its columns (trajectory, t, a, b) are not the state variables of any system this example knows; pass --system NAME"),
            "{none}"
        );
        let numbers = message("0,0.0109,1.5\n");
        assert!(numbers.contains("needs a header line"), "{numbers}");
    }
}
