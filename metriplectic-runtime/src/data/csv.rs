//! Trajectories as CSV files: measured or simulated states over time.

use std::collections::HashMap;
use std::fs::File;
use std::io::{Read, Write};
use std::path::Path;

use super::Trajectory;
use crate::error::{quoted, CsvError, Error, Result};
use crate::io::{write_file, WriteMode};
use crate::system::MetriplecticSystem;

/// Name of the time column.
pub(crate) const TIME_COLUMN: &str = "t";
/// Name of the optional trajectory-identifier column.
pub(crate) const TRAJECTORY_COLUMN: &str = "trajectory";
/// Prefix of derivative columns: the derivative of `q` is `dq`.
pub(crate) const DERIVATIVE_PREFIX: &str = "d";

/// The largest CSV input [`read_trajectories`] and [`read_trajectories_from`]
/// read: 4 GiB (about 10⁸ samples of a few states). An endless stream
/// (`/dev/zero`, a runaway pipe) is refused with
/// [`CsvError::TooLarge`] instead of exhausting memory.
pub const MAX_CSV_BYTES: u64 = 1 << 32;

/// Reads the trajectories of system `S` from a CSV file.
///
/// # Format
///
/// Comma-separated, one header line, then one row per sample:
///
/// ```text
/// trajectory,t,q,p,dq,dp
/// run1,0,1.2,0,0.3,-1.1
/// run1,0.05,1.21,-0.06,0.28,-1.12
/// run2,0,-0.4,0.9,…
/// ```
///
/// * `t` — the time stamp (required). Within a trajectory, times must
///   strictly increase.
/// * one column per state variable, named exactly as the system's
///   [`STATE_NAMES`](crate::MetriplecticSystem::STATE_NAMES) (required).
/// * `d<name>` for each state variable — its time derivative (optional: all
///   of them or none). Without them, estimate derivatives with
///   [`estimate_derivatives`](crate::estimate_derivatives).
/// * `trajectory` — an identifier (any non-empty text) when the file holds
///   several trajectories (optional; without it the file is one trajectory).
///   The rows of one trajectory must be contiguous.
///
/// Columns may come in any order. Cells are trimmed of surrounding spaces.
/// Numbers use Rust's `f64` syntax (`1`, `-2.5`, `1e-3`); NaN and infinities
/// are rejected. Every error names the line (1-based, the header is line 1)
/// and, for a cell, the column (1-based) and its header name.
///
/// Writing uses the shortest text that reads back to the identical `f64`
/// (Rust's `{}` formatting), so a write–read round trip is exact. Existing
/// files are only replaced with [`WriteMode::Overwrite`](crate::WriteMode::Overwrite).
pub fn read_trajectories<S: MetriplecticSystem>(path: impl AsRef<Path>) -> Result<Vec<Trajectory>> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|source| Error::Io {
        path: path.to_owned(),
        source,
    })?;
    // A directory opens and fails on reading: name it, not "<reader>".
    read_trajectories_from(file, S::STATE_NAMES).map_err(|error| match error {
        Error::Io { source, .. } => Error::Io {
            path: path.to_owned(),
            source,
        },
        other => other,
    })
}

/// All of `reader`, refused with [`CsvError::TooLarge`] beyond `limit` bytes.
fn read_at_most(reader: &mut impl Read, limit: u64) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    reader
        .take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|source| Error::Io {
            path: "<reader>".into(),
            source,
        })?;
    if bytes.len() as u64 > limit {
        return Err(CsvError::TooLarge { limit }.into());
    }
    Ok(bytes)
}

/// Reads trajectories with state variables `names` (in state order) from CSV
/// text (at most [`MAX_CSV_BYTES`]).
///
/// ```
/// use metriplectic_runtime::read_trajectories_from;
///
/// let text = "p,t,q\n0.5,0,1\n0.25,0.1,0.9\n";
/// let trajs = read_trajectories_from(text.as_bytes(), &["q", "p"]).unwrap();
/// assert_eq!(trajs[0].state(1), &[0.9, 0.25]);
///
/// let err = read_trajectories_from("t,q\n0,1\n".as_bytes(), &["q", "p"]).unwrap_err();
/// assert!(err.to_string().contains("missing column(s) `p`"));
/// ```
pub fn read_trajectories_from(mut reader: impl Read, names: &[&str]) -> Result<Vec<Trajectory>> {
    check_names(names)?;
    // Read whole so that errors can name physical lines whatever the line
    // endings (the CSV parser counts only `\n` and reports a record after
    // blank lines at the first blank line).
    let bytes = read_at_most(&mut reader, MAX_CSV_BYTES)?;
    let lines = LineIndex::new(&bytes);
    let malformed = |error: csv::Error| malformed(&lines, error);
    let mut csv = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(bytes.as_slice());
    let mut records = csv.records();
    let header = match records.next() {
        Some(record) => record.map_err(malformed)?,
        None => csv::StringRecord::new(),
    };
    if header.iter().all(str::is_empty) {
        return Err(CsvError::NoHeader {
            expected: expected_columns(names),
        }
        .into());
    }
    // The parser skips blank lines, so the header may come after some.
    let header_line = header.position().map_or(1, |p| lines.line_of(p.byte()));
    let layout = Layout::from_header(&header, names, header_line)?;
    let n = names.len();

    let mut builder = Builder::default();
    let mut seen_ids: HashMap<String, u64> = HashMap::new();
    let mut state = vec![0.0; n];
    let mut derivative = vec![0.0; n];
    for record in records {
        let record = record.map_err(malformed)?;
        let line = record.position().map_or(0, |p| lines.line_of(p.byte()));
        if record.iter().any(|cell| cell.contains(['\n', '\r'])) {
            // No cell of this format spans lines: a quote opened on this
            // line was never closed.
            return Err(CsvError::UnclosedQuote { line }.into());
        }
        if record.len() != header.len() {
            return Err(CsvError::FieldCount {
                line,
                expected: header.len(),
                found: record.len(),
            }
            .into());
        }
        let id = match layout.trajectory {
            Some(col) => {
                let text = &record[col];
                if text.is_empty() {
                    return Err(CsvError::EmptyTrajectoryId {
                        line,
                        column: col + 1,
                    }
                    .into());
                }
                Some(text.to_owned())
            }
            None => None,
        };
        let cell = |col: usize| parse_cell(&record[col], line, col, &header[col]);
        let time = cell(layout.time)?;
        for j in 0..n {
            state[j] = cell(layout.states[j])?;
            if let Some(cols) = &layout.derivatives {
                derivative[j] = cell(cols[j])?;
            }
        }

        let new_trajectory = builder.current.as_ref().is_none_or(|c| c.id != id);
        if new_trajectory {
            if let Some(id) = &id {
                if let Some(&first_line) = seen_ids.get(id) {
                    return Err(CsvError::SplitTrajectory {
                        line,
                        id: id.clone(),
                        first_line,
                    }
                    .into());
                }
                seen_ids.insert(id.clone(), line);
            }
            builder.finish(names)?;
            builder.current = Some(Pending::new(id));
        }
        let current = builder.current.get_or_insert_with(|| Pending::new(None));
        if let (Some(&previous), Some(&previous_line)) =
            (current.times.last(), current.lines.last())
        {
            if time <= previous {
                return Err(CsvError::NonIncreasingTime {
                    line,
                    column: layout.time + 1,
                    trajectory: current.id.clone(),
                    previous,
                    previous_line,
                    time,
                }
                .into());
            }
        }
        current.times.push(time);
        current.lines.push(line);
        current.states.extend_from_slice(&state);
        if layout.derivatives.is_some() {
            current.derivatives.extend_from_slice(&derivative);
        }
    }
    builder.finish(names)?;
    if builder.done.is_empty() {
        return Err(CsvError::NoRows { line: header_line }.into());
    }
    Ok(builder.done)
}

/// Writes trajectories to a CSV file; refuses to replace an existing file
/// unless `mode` is [`WriteMode::Overwrite`](crate::WriteMode::Overwrite). The
/// write is atomic, like [`Model::save`](crate::Model::save).
///
/// All trajectories must have the same state names and either all or none
/// must carry derivatives. A `trajectory` column is written when there is
/// more than one trajectory or any has an [`id`](Trajectory::id); unnamed
/// trajectories are numbered by their position from 0. Identifiers must
/// differ (also from those numbers) and read back as written (no
/// surrounding spaces, no line breaks), so that reading the file gives back
/// the same trajectories.
pub fn write_trajectories(
    path: impl AsRef<Path>,
    trajectories: &[Trajectory],
    mode: WriteMode,
) -> Result<()> {
    let path = path.as_ref();
    // Written in memory first: the file appears complete or not at all.
    let mut text = Vec::new();
    write_trajectories_to(&mut text, trajectories)?;
    write_file(path, &text, mode)
}

/// Writes trajectories as CSV text to any writer (see [`write_trajectories`]).
///
/// ```
/// use metriplectic_runtime::{write_trajectories_to, Trajectory};
///
/// let traj = Trajectory::new(vec!["x".into()], vec![0.0, 0.1], vec![1.0, 0.9], None).unwrap();
/// let mut text = Vec::new();
/// write_trajectories_to(&mut text, &[traj]).unwrap();
/// assert_eq!(String::from_utf8(text).unwrap(), "t,x\n0,1\n0.1,0.9\n");
/// ```
///
/// I/O failures are [`Error::Io`] with the path `<writer>`.
pub fn write_trajectories_to(writer: impl Write, trajectories: &[Trajectory]) -> Result<()> {
    check_writable(trajectories)?;
    let Some(first) = trajectories.first() else {
        return Ok(());
    };
    let with_ids = trajectories.len() > 1 || trajectories.iter().any(|t| t.id().is_some());
    let with_derivatives = first.derivatives().is_some();
    let mut csv = csv::WriterBuilder::new().from_writer(writer);
    let mut header: Vec<String> = Vec::new();
    if with_ids {
        header.push(TRAJECTORY_COLUMN.to_owned());
    }
    header.push(TIME_COLUMN.to_owned());
    header.extend(first.names().iter().cloned());
    if with_derivatives {
        header.extend(
            first
                .names()
                .iter()
                .map(|n| format!("{DERIVATIVE_PREFIX}{n}")),
        );
    }
    csv.write_record(&header).map_err(writer_error)?;
    let mut row: Vec<String> = Vec::with_capacity(header.len());
    for (index, traj) in trajectories.iter().enumerate() {
        let id = written_id((index, traj));
        for k in 0..traj.len() {
            row.clear();
            if with_ids {
                row.push(id.clone());
            }
            // `{}` prints the shortest decimal that parses back to the same f64.
            row.push(format!("{}", traj.times()[k]));
            row.extend(traj.state(k).iter().map(|v| format!("{v}")));
            if let Some(d) = traj.derivative(k) {
                row.extend(d.iter().map(|v| format!("{v}")));
            }
            csv.write_record(&row).map_err(writer_error)?;
        }
    }
    csv.flush().map_err(|source| writer_error(source.into()))?;
    Ok(())
}

fn writer_error(error: csv::Error) -> Error {
    let source = match error.into_kind() {
        csv::ErrorKind::Io(source) => source,
        other => std::io::Error::other(format!("{other:?}")),
    };
    Error::Io {
        path: "<writer>".into(),
        source,
    }
}

fn check_writable(trajectories: &[Trajectory]) -> Result<()> {
    let Some(first) = trajectories.first() else {
        return Err(Error::InvalidArgument {
            what: "trajectories".to_owned(),
            reason: "nothing to write: the list is empty".to_owned(),
        });
    };
    let names: Vec<&str> = first.names().iter().map(String::as_str).collect();
    check_names(&names)?;
    for (index, traj) in trajectories.iter().enumerate() {
        if traj.names() != first.names() {
            return Err(CsvError::Inconsistent {
                index,
                reason: format!(
                    "state names ({}) differ from those of trajectory 0 ({})",
                    traj.names().join(", "),
                    first.names().join(", ")
                ),
            }
            .into());
        }
        if traj.derivatives().is_some() != first.derivatives().is_some() {
            return Err(CsvError::Inconsistent {
                index,
                reason: "either all trajectories carry derivatives or none does".to_owned(),
            }
            .into());
        }
        if let Some(id) = traj.id() {
            let reason = if id.is_empty() {
                Some("its identifier is empty".to_owned())
            } else if id.trim() != id || id.contains(['\n', '\r']) {
                // The reader trims cells and reads a record per line.
                Some(format!(
                    "its identifier {id:?} would not read back as written: it begins or ends \
                     with spaces or holds a line break"
                ))
            } else {
                None
            };
            if let Some(reason) = reason {
                return Err(CsvError::Inconsistent { index, reason }.into());
            }
        }
    }
    // The reader starts a trajectory where the identifier changes, so two
    // trajectories under one identifier would read back as one (or fail).
    let ids: Vec<String> = trajectories.iter().enumerate().map(written_id).collect();
    let mut seen = HashMap::with_capacity(ids.len());
    for (index, id) in ids.iter().enumerate() {
        if let Some(first) = seen.insert(id.as_str(), index) {
            return Err(CsvError::Inconsistent {
                index,
                reason: format!(
                    "its identifier `{id}` is also trajectory {first}'s (unnamed trajectories \
                     are written as their position); identifiers must differ"
                ),
            }
            .into());
        }
    }
    Ok(())
}

/// The `trajectory` cell of the trajectory at `index`: its identifier, or
/// its position when it has none.
fn written_id((index, traj): (usize, &Trajectory)) -> String {
    traj.id().map_or_else(|| index.to_string(), str::to_owned)
}

/// Column positions (0-based) found in the header.
struct Layout {
    time: usize,
    trajectory: Option<usize>,
    states: Vec<usize>,
    derivatives: Option<Vec<usize>>,
}

impl Layout {
    fn from_header(header: &csv::StringRecord, names: &[&str], line: u64) -> Result<Self> {
        let expected = expected_columns(names);
        let mut positions: HashMap<&str, usize> = HashMap::new();
        for (col, name) in header.iter().enumerate() {
            if name.is_empty() {
                return Err(CsvError::EmptyColumnName {
                    line,
                    column: col + 1,
                }
                .into());
            }
            if let Some(&first) = positions.get(name) {
                return Err(CsvError::DuplicateColumn {
                    line,
                    name: name.to_owned(),
                    first: first + 1,
                    second: col + 1,
                }
                .into());
            }
            positions.insert(name, col);
        }
        let derivative_names: Vec<String> = names
            .iter()
            .map(|n| format!("{DERIVATIVE_PREFIX}{n}"))
            .collect();
        let known = |name: &str| {
            name == TIME_COLUMN
                || name == TRAJECTORY_COLUMN
                || names.contains(&name)
                || derivative_names.iter().any(|d| d == name)
        };
        let unknown: Vec<String> = header
            .iter()
            .filter(|n| !known(n))
            .map(str::to_owned)
            .collect();
        if !unknown.is_empty() {
            return Err(CsvError::UnknownColumns {
                line,
                unknown,
                expected,
            }
            .into());
        }
        let missing: Vec<String> = std::iter::once(TIME_COLUMN)
            .chain(names.iter().copied())
            .filter(|n| !positions.contains_key(n))
            .map(str::to_owned)
            .collect();
        if !missing.is_empty() {
            return Err(CsvError::MissingColumns {
                line,
                missing,
                expected,
            }
            .into());
        }
        let (present, absent): (Vec<String>, Vec<String>) = derivative_names
            .iter()
            .cloned()
            .partition(|d| positions.contains_key(d.as_str()));
        let derivatives = if absent.is_empty() {
            Some(
                derivative_names
                    .iter()
                    .map(|d| positions[d.as_str()])
                    .collect(),
            )
        } else if present.is_empty() {
            None
        } else {
            return Err(CsvError::PartialDerivatives {
                line,
                present,
                missing: absent,
            }
            .into());
        };
        Ok(Self {
            time: positions[TIME_COLUMN],
            trajectory: positions.get(TRAJECTORY_COLUMN).copied(),
            states: names.iter().map(|n| positions[n]).collect(),
            derivatives,
        })
    }
}

/// Rows of the trajectory being read.
struct Pending {
    id: Option<String>,
    times: Vec<f64>,
    lines: Vec<u64>,
    states: Vec<f64>,
    derivatives: Vec<f64>,
}

impl Pending {
    fn new(id: Option<String>) -> Self {
        Self {
            id,
            times: Vec::new(),
            lines: Vec::new(),
            states: Vec::new(),
            derivatives: Vec::new(),
        }
    }
}

#[derive(Default)]
struct Builder {
    current: Option<Pending>,
    done: Vec<Trajectory>,
}

impl Builder {
    fn finish(&mut self, names: &[&str]) -> Result<()> {
        if let Some(p) = self.current.take() {
            let derivatives = (!p.derivatives.is_empty()).then_some(p.derivatives);
            let names = names.iter().map(|n| (*n).to_owned()).collect();
            let mut traj = Trajectory::new(names, p.times, p.states, derivatives)?;
            if let Some(id) = p.id {
                traj = traj.with_id(id);
            }
            self.done.push(traj);
        }
        Ok(())
    }
}

/// A cell's text as errors show it: at most 40 characters, and the size of
/// the rest, so that a corrupt 50 MB cell does not make a 50 MB message.
fn shortened(text: &str) -> String {
    const SHOWN: usize = 40;
    match text.char_indices().nth(SHOWN) {
        None => text.to_owned(),
        Some((cut, _)) => format!("{}… ({} bytes in all)", &text[..cut], text.len()),
    }
}

fn parse_cell(text: &str, line: u64, col: usize, name: &str) -> Result<f64> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(CsvError::NonFinite {
            line,
            column: col + 1,
            name: name.to_owned(),
            text: shortened(text),
        }
        .into()),
        Err(_) => Err(CsvError::NotANumber {
            line,
            column: col + 1,
            name: name.to_owned(),
            text: shortened(text),
        }
        .into()),
    }
}

/// Byte offsets where lines start; a line ends at `\n`, `\r\n` or a lone `\r`.
struct LineIndex<'a> {
    bytes: &'a [u8],
    starts: Vec<usize>,
}

impl<'a> LineIndex<'a> {
    fn new(bytes: &'a [u8]) -> Self {
        let mut starts = vec![0];
        let mut i = 0;
        while i < bytes.len() {
            match bytes[i] {
                b'\r' if bytes.get(i + 1) == Some(&b'\n') => {
                    starts.push(i + 2);
                    i += 2;
                }
                b'\r' | b'\n' => {
                    starts.push(i + 1);
                    i += 1;
                }
                _ => i += 1,
            }
        }
        Self { bytes, starts }
    }

    /// The 1-based line of the record that the parser says starts at byte
    /// `offset` (its offset may point at blank lines before it).
    fn line_of(&self, offset: u64) -> u64 {
        let mut offset = usize::try_from(offset)
            .unwrap_or(usize::MAX)
            .min(self.bytes.len());
        while offset < self.bytes.len() && matches!(self.bytes[offset], b'\r' | b'\n') {
            offset += 1;
        }
        self.starts.partition_point(|&start| start <= offset) as u64
    }
}

fn malformed(lines: &LineIndex<'_>, error: csv::Error) -> Error {
    let line = error.position().map_or(0, |p| lines.line_of(p.byte()));
    let message = match error.kind() {
        csv::ErrorKind::Utf8 { err, .. } => format!("invalid UTF-8 in field {}", err.field() + 1),
        _ => error.to_string(),
    };
    CsvError::Malformed { line, message }.into()
}

/// Rejects state names that collide with the format's column names.
fn check_names(names: &[&str]) -> Result<()> {
    if names.is_empty() {
        return Err(Error::InvalidArgument {
            what: "state names".to_owned(),
            reason: "at least one state variable is required".to_owned(),
        });
    }
    if let Some(reason) = super::trajectory::repeated_name(names) {
        return Err(Error::InvalidArgument {
            what: "state names".to_owned(),
            reason,
        });
    }
    // The reader trims cells and reads a record per line: such a header
    // would not read back (a probe wrote `""`, `" q"` and `"q\n"`).
    if let Some(name) = names
        .iter()
        .find(|name| name.is_empty() || name.trim() != **name || name.contains(['\n', '\r']))
    {
        return Err(Error::InvalidArgument {
            what: "state names".to_owned(),
            reason: format!(
                "{name:?} would not read back as a CSV column name: it is empty, begins or ends \
                 with spaces, or holds a line break"
            ),
        });
    }
    for name in names {
        let reserved_for = if *name == TIME_COLUMN {
            Some("the time".to_owned())
        } else if *name == TRAJECTORY_COLUMN {
            Some("trajectory identifiers".to_owned())
        } else {
            names
                .iter()
                .find(|other| format!("{DERIVATIVE_PREFIX}{other}") == *name)
                .map(|other| format!("the derivative of `{other}`"))
        };
        if let Some(reserved_for) = reserved_for {
            return Err(CsvError::ReservedName {
                name: (*name).to_owned(),
                reserved_for,
            }
            .into());
        }
    }
    Ok(())
}

fn expected_columns(names: &[&str]) -> String {
    let derivatives: Vec<String> = names
        .iter()
        .map(|n| format!("{DERIVATIVE_PREFIX}{n}"))
        .collect();
    format!(
        "`{TIME_COLUMN}`, {} (required); {} (optional, all or none); `{TRAJECTORY_COLUMN}` (optional)",
        names
            .iter()
            .map(|n| format!("`{n}`"))
            .collect::<Vec<_>>()
            .join(", "),
        quoted(&derivatives)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--data /dev/zero` ran out of memory: an endless reader is refused
    /// at the limit (a small one here), and input at the limit is read.
    #[test]
    fn endless_input_is_refused_at_the_limit() {
        let err = read_at_most(&mut std::io::repeat(b'0'), 1000).unwrap_err();
        assert!(
            matches!(err, Error::Csv(CsvError::TooLarge { limit: 1000 })),
            "{err}"
        );
        assert!(err.to_string().contains("longer than 1000 bytes"), "{err}");
        let bytes = read_at_most(&mut std::io::repeat(b'0').take(1000), 1000).unwrap();
        assert_eq!(bytes.len(), 1000);
    }

    /// State names the reader would not read back are refused when writing.
    #[test]
    fn state_names_that_would_not_read_back_are_not_written() {
        for name in ["", " q", "q\n"] {
            let trajectory =
                Trajectory::new(vec![name.to_owned()], vec![0.0, 1.0], vec![1.0, 2.0], None)
                    .unwrap();
            let mut out = Vec::new();
            let err = write_trajectories_to(&mut out, &[trajectory])
                .unwrap_err()
                .to_string();
            assert!(err.contains("would not read back"), "{name:?}: {err}");
            assert!(out.is_empty(), "{name:?}: something was written");
        }
    }
}
