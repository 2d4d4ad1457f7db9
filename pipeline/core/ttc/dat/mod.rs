//! Calspan TIRF `.dat` (ASCII) -> [`RunTable`] (and, in `write.rs`, the inverse for tests and
//! the virtual test machine).
//!
//! In: the bytes of a `.dat` file (three header lines, then tab-separated numeric rows) and a
//! source name for messages. Out: the run, or a one-line [`TtcError`] naming the line (and
//! column). Handles every variant in `shared/docs/ttc-format.md`: round 4/8/9 line 1, names in
//! any case and order (21, 22 or more columns; unknown ones kept as extras), every unit spelling
//! per column, CRLF or LF, a missing final newline, spreadsheet damage (tab-padded header lines,
//! `0` for `0.000`). Rows are parsed in one pass straight into the column vectors: no allocation
//! per row or cell ([`super::float`] parses cells exactly like `str::parse::<f64>`). A body of
//! 1 MiB or more is parsed in two halves on two threads (split at a line end); if either half
//! finds a problem or warns, the whole body is parsed again on one thread, so every message
//! names the line it would name without the split.
//! Deliberately not here: reading files (the caller's) and unit conversion (shared
//! with the `.mat` reader in `build.rs`).

mod write;

use std::io::Read;

pub use write::{DatColumn, Line1, RoundStyle, push_fixed, render_dat};

use super::build::{SourceColumn, build};
use super::error::{excerpt, printable};
use super::float::{parse_f64, scan_fixed_decimal};
use super::{ColumnInfo, RunMeta, RunTable, SourceFormat, TtcChannel, TtcError, Unit};

/// Line 1 must start with this (case-insensitive).
const LINE1_PREFIX: &str = "TIRF Data File";

/// Longest excerpt of a cell or header line quoted in an error.
const EXCERPT_CHARS: usize = 40;

/// Parse a whole `.dat` file held in memory.
pub fn read_dat(bytes: &[u8], source_name: &str) -> Result<RunTable, TtcError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(TtcError::Empty {
            source_name: source_name.to_string(),
        });
    }
    let mut meta = RunMeta::new(source_name, SourceFormat::Dat);
    let line1_end = find_byte(bytes, 0, b'\n').unwrap_or(bytes.len());
    parse_line1(strip_cr(&bytes[..line1_end]), &mut meta)?;
    let lines = HeaderLines::split(bytes, source_name)?;
    let names = parse_names(lines.line2, source_name)?;
    check_required(&names, source_name)?;
    let infos = parse_units(lines.line3, &names, source_name)?;
    let body = &bytes[lines.data_start..];
    let columns = parse_rows_split(body, &names, source_name, &mut meta.warnings)?;
    if columns.first().is_none_or(Vec::is_empty) {
        return Err(TtcError::NoRows {
            source_name: source_name.to_string(),
            after_line: 3,
        });
    }
    let columns = infos
        .into_iter()
        .zip(columns)
        .map(|(info, values)| SourceColumn { info, values })
        .collect();
    build(meta, columns, "line 2")
}

/// Read everything from `reader`, then [`read_dat`].
pub fn read_dat_from(mut reader: impl Read, source_name: &str) -> Result<RunTable, TtcError> {
    let mut bytes = Vec::new();
    reader.read_to_end(&mut bytes).map_err(|e| TtcError::Io {
        source_name: source_name.to_string(),
        message: e.to_string(),
    })?;
    read_dat(&bytes, source_name)
}

/// Header lines 2 and 3 (without line endings) and where the data rows start. Line 1 is
/// parsed first, on its own, so a wrong file says "line 1" even when it is short.
struct HeaderLines<'a> {
    line2: &'a [u8],
    line3: &'a [u8],
    data_start: usize,
}

impl<'a> HeaderLines<'a> {
    fn split(bytes: &'a [u8], source_name: &str) -> Result<Self, TtcError> {
        let mut start = 0;
        let mut lines = [&bytes[..0]; 3];
        for (index, slot) in lines.iter_mut().enumerate() {
            if start >= bytes.len() {
                return Err(TtcError::Header {
                    source_name: source_name.to_string(),
                    line: index + 1,
                    message: "file ends inside the 3-line header".to_string(),
                });
            }
            let end = find_byte(bytes, start, b'\n').unwrap_or(bytes.len());
            *slot = strip_cr(&bytes[start..end]);
            start = (end + 1).min(bytes.len());
        }
        Ok(HeaderLines {
            line2: lines[1],
            line3: lines[2],
            data_start: start,
        })
    }
}

/// Line 1: `TIRF Data File: Project 2356; Run 004; Date ...; Tire_Name=...; ISO False; ID ...`.
fn parse_line1(line: &[u8], meta: &mut RunMeta) -> Result<(), TtcError> {
    let (text, legacy) = crate::ttc::text::decode_text(line);
    if legacy {
        meta.warnings
            .push("line 1: not UTF-8; read as Windows-1252 (Latin-1)".to_string());
    }
    let text = text.replace('\t', " ");
    let text = text.trim();
    let header_error = |message: String| TtcError::Header {
        source_name: meta.source_name.clone(),
        line: 1,
        message,
    };
    let rest = text
        .get(..LINE1_PREFIX.len())
        .filter(|p| p.eq_ignore_ascii_case(LINE1_PREFIX))
        .map(|_| &text[LINE1_PREFIX.len()..])
        .ok_or_else(|| {
            header_error(format!(
                "expected \"{LINE1_PREFIX}: Project <p>; Run <n>\", found {:?}",
                excerpt(text.as_bytes(), EXCERPT_CHARS)
            ))
        })?;
    let rest = rest.trim_start().strip_prefix(':').unwrap_or(rest);
    for field in rest.split(';').map(str::trim).filter(|f| !f.is_empty()) {
        let (key, value) = split_field(field);
        apply_line1_field(meta, key, value, field);
    }
    Ok(())
}

/// `Key value` or `Key=value`.
fn split_field(field: &str) -> (&str, &str) {
    let eq = field.find('=');
    let space = field.find(char::is_whitespace);
    let at = match (eq, space) {
        (Some(e), Some(s)) => e.min(s),
        (e, s) => e.or(s).unwrap_or(field.len()),
    };
    let (key, value) = field.split_at(at);
    let value = value.trim_start();
    let value = value.strip_prefix('=').unwrap_or(value).trim();
    (key.trim(), value)
}

fn apply_line1_field(meta: &mut RunMeta, key: &str, value: &str, field: &str) {
    let mut unreadable = |what: &str| {
        meta.warnings
            .push(format!("line 1: unreadable {what} {value:?} ignored"));
    };
    match key.to_ascii_lowercase().as_str() {
        "project" => match value.parse() {
            Ok(p) => meta.project = Some(p),
            Err(_) => unreadable("project number"),
        },
        "run" => match value.parse() {
            Ok(r) => meta.run = Some(r),
            Err(_) => unreadable("run number"),
        },
        "rim_width" => match value.parse() {
            Ok(w) => meta.rim_width_in = Some(w),
            Err(_) => unreadable("rim width"),
        },
        "iso" => match value.to_ascii_lowercase().as_str() {
            "true" => meta.iso_flag = Some(true),
            "false" => meta.iso_flag = Some(false),
            _ => unreadable("ISO flag"),
        },
        "date" => meta.date = Some(value.to_string()),
        "time" => meta.time = Some(value.to_string()),
        "tire_name" => meta.tire_name = Some(value.to_string()),
        "id" => meta.id = Some(value.to_string()),
        _ => meta
            .warnings
            .push(format!("line 1: unknown field {field:?} ignored")),
    }
}

/// Line 2: channel names, tab separated; trailing empty cells (spreadsheet padding) dropped.
fn parse_names(line: &[u8], source_name: &str) -> Result<Vec<String>, TtcError> {
    let names = cells_without_padding(line);
    let header_error = |message: String| TtcError::Header {
        source_name: source_name.to_string(),
        line: 2,
        message,
    };
    if names.is_empty() {
        return Err(header_error("no channel names".to_string()));
    }
    for (index, name) in names.iter().enumerate() {
        if name.is_empty() {
            return Err(header_error(format!(
                "column {} has no channel name",
                index + 1
            )));
        }
        if let Some(first) = names[..index]
            .iter()
            .position(|n| n.eq_ignore_ascii_case(name))
        {
            return Err(TtcError::DuplicateChannel {
                source_name: source_name.to_string(),
                name: name.clone(),
                first: first + 1,
                second: index + 1,
            });
        }
    }
    Ok(names)
}

/// Every required channel must be on line 2 (checked before any row is parsed).
fn check_required(names: &[String], source_name: &str) -> Result<(), TtcError> {
    if let [only] = names
        && (only.contains(',') || only.contains(';'))
    {
        return Err(TtcError::Header {
            source_name: source_name.to_string(),
            line: 2,
            message: format!(
                "a single column {:?}: the file is not tab-separated",
                excerpt(only.as_bytes(), EXCERPT_CHARS)
            ),
        });
    }
    let missing = TtcChannel::REQUIRED
        .into_iter()
        .find(|c| !names.iter().any(|n| TtcChannel::from_name(n) == Some(*c)));
    match missing {
        Some(channel) => Err(TtcError::MissingChannel {
            source_name: source_name.to_string(),
            location: "line 2".to_string(),
            channel: channel.name().to_string(),
        }),
        None => Ok(()),
    }
}

/// Line 3: one unit per channel. Known channels need a known unit of the right quantity;
/// extra channels keep whatever they say.
fn parse_units(
    line: &[u8],
    names: &[String],
    source_name: &str,
) -> Result<Vec<ColumnInfo>, TtcError> {
    let units = cells_without_padding(line);
    if units.len() != names.len() {
        return Err(TtcError::Header {
            source_name: source_name.to_string(),
            line: 3,
            message: format!(
                "expected {} unit cells (one per channel on line 2), found {}",
                names.len(),
                units.len()
            ),
        });
    }
    names
        .iter()
        .zip(units)
        .enumerate()
        .map(|(index, (name, unit_raw))| {
            let channel = TtcChannel::from_name(name);
            let unit = match channel {
                Some(channel) => {
                    Some(
                        channel
                            .parse_unit(&unit_raw)
                            .map_err(|message| TtcError::Unit {
                                source_name: source_name.to_string(),
                                location: format!("line 3, column {}", index + 1),
                                channel: printable(name),
                                message: Box::new(message),
                            })?,
                    )
                }
                None => Unit::parse(&unit_raw),
            };
            Ok(ColumnInfo {
                name: name.clone(),
                channel,
                unit_raw,
                unit,
                system: unit.map(Unit::system),
                unit_from_file: true,
            })
        })
        .collect()
}

/// Tab-separated cells of a header line, trimmed, without trailing empty cells.
fn cells_without_padding(line: &[u8]) -> Vec<String> {
    let mut cells: Vec<String> = line
        .split(|b| *b == b'\t')
        .map(|c| String::from_utf8_lossy(c).trim().to_string())
        .collect();
    while cells.last().is_some_and(String::is_empty) {
        cells.pop();
    }
    cells
}

/// Bodies at least this long are parsed in two halves on two threads.
const SPLIT_MIN_BYTES: usize = 1 << 20;

/// [`parse_rows`] over the whole body, in two halves on two threads when it is large. Any
/// problem or warning in a half means the body is parsed again on one thread, for the exact
/// line numbers (problems are rare; a good file pays nothing).
fn parse_rows_split(
    body: &[u8],
    names: &[String],
    source_name: &str,
    warnings: &mut Vec<String>,
) -> Result<Vec<Vec<f64>>, TtcError> {
    let split = match find_byte(body, body.len() / 2, b'\n') {
        Some(nl) if body.len() >= SPLIT_MIN_BYTES && nl + 1 < body.len() => nl + 1,
        _ => return parse_rows(body, names, source_name, true, warnings),
    };
    let (mut first_warnings, mut second_warnings) = (Vec::new(), Vec::new());
    let (first, second) = std::thread::scope(|s| {
        let first = s.spawn(|| {
            parse_rows(
                &body[..split],
                names,
                source_name,
                false,
                &mut first_warnings,
            )
        });
        let second = parse_rows(
            &body[split..],
            names,
            source_name,
            true,
            &mut second_warnings,
        );
        let first = first
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (first, second)
    });
    match (first, second) {
        (Ok(mut columns), Ok(rest)) if first_warnings.is_empty() && second_warnings.is_empty() => {
            for (column, tail) in columns.iter_mut().zip(rest) {
                column.extend_from_slice(&tail);
            }
            Ok(columns)
        }
        _ => parse_rows(body, names, source_name, true, warnings),
    }
}

/// The data rows: one column vector per channel on line 2. `body` starts at line 4 (the line
/// numbers of errors count from there). `ends_file`: the body's last line is the file's, where
/// a blank or cut-off line is dropped with a warning rather than refused.
fn parse_rows(
    body: &[u8],
    names: &[String],
    source_name: &str,
    ends_file: bool,
    warnings: &mut Vec<String>,
) -> Result<Vec<Vec<f64>>, TtcError> {
    let width = names.len();
    let first_line_len = find_byte(body, 0, b'\n').unwrap_or(body.len()) + 1;
    let estimated_rows = body.len() / first_line_len + 2;
    let mut columns: Vec<Vec<f64>> = (0..width)
        .map(|_| Vec::with_capacity(estimated_rows))
        .collect();

    let mut pos = 0;
    let mut line_no = 3;
    while pos < body.len() {
        line_no += 1;
        match parse_row(body, pos, &mut columns) {
            Ok(line_end) => pos = line_end + 1,
            Err(problem) => {
                let end = find_byte(body, pos, b'\n').unwrap_or(body.len());
                let line = strip_cr(&body[pos..end]);
                let rest = body.get(end + 1..).unwrap_or_default();
                let is_last = ends_file && rest.iter().all(u8::is_ascii_whitespace);
                match problem {
                    RowProblem::Blank if is_last => break,
                    problem if is_last && problem.looks_truncated(line, width) => {
                        let cells = line.split(|b| *b == b'\t').count();
                        warnings.push(format!(
                            "line {line_no}: truncated last line ({cells} of {width} cells) dropped"
                        ));
                        break;
                    }
                    problem => return Err(problem.into_error(source_name, line_no, line, names)),
                }
            }
        }
    }
    Ok(columns)
}

/// Why a row could not be taken. A row that fails pushes nothing (partial pushes are undone).
enum RowProblem {
    /// Nothing but blanks and tabs.
    Blank,
    /// Fewer cells than channels, or an empty cell: what a cut-off last line looks like.
    Truncated { cells: usize },
    /// More non-empty cells than channels.
    TooLong { cells: usize },
    /// Cell `column` (0-based) is not a number.
    NotANumber { column: usize },
    /// Cell `column` (0-based) is NaN or infinite.
    NonFinite { column: usize },
}

/// Parse the row starting at `body[start]` into the columns and return the index of its line
/// end (the LF, or `body.len()`). One pass: cells are parsed while they are scanned. On any
/// problem the columns are left as they were.
#[inline]
fn parse_row(body: &[u8], start: usize, columns: &mut [Vec<f64>]) -> Result<usize, RowProblem> {
    let width = columns.len();
    let mut column = 0;
    let mut pos = start;
    let result = loop {
        let (mut end, fast) = scan_fixed_decimal(body, pos);
        let value = match fast {
            Some(value) if !is_lone_cr(body, end) => Ok(value),
            _ => {
                end = cell_end(body, end);
                slow_cell(&body[pos..end])
            }
        };
        if column >= width {
            // Only empty padding cells may follow the last channel.
            if !matches!(value, Err(SlowCell::Empty)) {
                break Err(RowProblem::TooLong {
                    cells: width + 1 + count_cells_after(body, end),
                });
            }
        } else {
            match value {
                Ok(value) => {
                    columns[column].push(value);
                    column += 1;
                }
                Err(SlowCell::Empty) if column == 0 && is_blank_line(body, pos) => {
                    break Err(RowProblem::Blank);
                }
                Err(SlowCell::Empty) => break Err(RowProblem::Truncated { cells: column }),
                Err(SlowCell::NonFinite) => break Err(RowProblem::NonFinite { column }),
                Err(SlowCell::NotANumber) => break Err(RowProblem::NotANumber { column }),
            }
        }
        match body.get(end) {
            Some(b'\t') => pos = end + 1,
            Some(b'\r') => break finish_row(column, width, end + 1),
            _ => break finish_row(column, width, end),
        }
    };
    if result.is_err() {
        for pushed in &mut columns[..column.min(width)] {
            pushed.pop();
        }
    }
    result
}

fn finish_row(column: usize, width: usize, line_end: usize) -> Result<usize, RowProblem> {
    if column == width {
        Ok(line_end)
    } else {
        Err(RowProblem::Truncated { cells: column })
    }
}

/// What the slow path found in a cell the scanner could not take.
enum SlowCell {
    Empty,
    NotANumber,
    NonFinite,
}

/// A cell with blanks, an exponent, a `+`, many digits, garbage, or nothing.
#[cold]
fn slow_cell(cell: &[u8]) -> Result<f64, SlowCell> {
    let cell = trim_blanks(cell);
    if cell.is_empty() {
        return Err(SlowCell::Empty);
    }
    match parse_f64(cell) {
        Some(v) if v.is_finite() => Ok(v),
        Some(_) => Err(SlowCell::NonFinite),
        None => Err(SlowCell::NotANumber),
    }
}

/// A CR that is not part of a CRLF line end (it belongs to the cell, which is then not a number).
fn is_lone_cr(body: &[u8], at: usize) -> bool {
    body.get(at) == Some(&b'\r') && !matches!(body.get(at + 1), None | Some(b'\n'))
}

/// End of the cell containing `from`: the next tab, LF, CR-before-LF/end, or the end of input.
fn cell_end(body: &[u8], from: usize) -> usize {
    let mut i = from;
    while i < body.len() {
        match body[i] {
            b'\t' | b'\n' => return i,
            b'\r' if matches!(body.get(i + 1), None | Some(b'\n')) => return i,
            _ => i += 1,
        }
    }
    i
}

/// Tabs after `from` up to the line end (cells beyond the current one).
fn count_cells_after(body: &[u8], from: usize) -> usize {
    let end = find_byte(body, from, b'\n').unwrap_or(body.len());
    body[from..end].iter().filter(|b| **b == b'\t').count()
}

fn is_blank_line(body: &[u8], from: usize) -> bool {
    body[from..]
        .iter()
        .take_while(|b| **b != b'\n')
        .all(|b| matches!(b, b' ' | b'\t' | b'\r'))
}

impl RowProblem {
    /// Whether this is what a cut-off line looks like: too few cells, or an empty cell.
    fn looks_truncated(&self, line: &[u8], width: usize) -> bool {
        match self {
            RowProblem::Truncated { .. } => true,
            RowProblem::NotANumber { .. } | RowProblem::NonFinite { .. } => {
                line.split(|b| *b == b'\t').count() < width
            }
            RowProblem::Blank | RowProblem::TooLong { .. } => false,
        }
    }

    fn into_error(
        self,
        source_name: &str,
        line_no: usize,
        line: &[u8],
        names: &[String],
    ) -> TtcError {
        let source_name = source_name.to_string();
        let cell_text = |column: usize| {
            let cell = line.split(|b| *b == b'\t').nth(column).unwrap_or_default();
            excerpt(trim_blanks(cell), EXCERPT_CHARS)
        };
        match self {
            RowProblem::Blank => TtcError::RowLength {
                source_name,
                line: line_no,
                expected: names.len(),
                found: 0,
            },
            RowProblem::Truncated { cells } => {
                let found = line.split(|b| *b == b'\t').count();
                if found >= names.len() {
                    TtcError::NotANumber {
                        source_name,
                        line: line_no,
                        column: cells + 1,
                        channel: printable(&names[cells]),
                        cell: String::new(),
                    }
                } else {
                    TtcError::RowLength {
                        source_name,
                        line: line_no,
                        expected: names.len(),
                        found,
                    }
                }
            }
            RowProblem::TooLong { cells } => TtcError::RowLength {
                source_name,
                line: line_no,
                expected: names.len(),
                found: cells,
            },
            RowProblem::NotANumber { column } => TtcError::NotANumber {
                source_name,
                line: line_no,
                column: column + 1,
                channel: printable(&names[column]),
                cell: cell_text(column),
            },
            RowProblem::NonFinite { column } => TtcError::NonFinite {
                source_name,
                line: line_no,
                column: column + 1,
                channel: printable(&names[column]),
                cell: cell_text(column),
            },
        }
    }
}

/// Position of `needle` in `haystack[from..]`, as an index into `haystack`.
#[inline]
fn find_byte(haystack: &[u8], from: usize, needle: u8) -> Option<usize> {
    haystack[from..]
        .iter()
        .position(|b| *b == needle)
        .map(|i| i + from)
}

fn strip_cr(line: &[u8]) -> &[u8] {
    line.strip_suffix(b"\r").unwrap_or(line)
}

#[inline]
fn trim_blanks(cell: &[u8]) -> &[u8] {
    let start = cell.iter().position(|b| *b != b' ').unwrap_or(cell.len());
    let end = cell
        .iter()
        .rposition(|b| *b != b' ')
        .map_or(start, |i| i + 1);
    &cell[start..end]
}
