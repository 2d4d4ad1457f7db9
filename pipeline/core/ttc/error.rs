//! The TTC readers' error type: one enum, one line per error, always naming the source and the
//! place (line and column for `.dat`, element and byte offset for `.mat`).
//!
//! In: nothing (other modules construct these). Out: [`TtcError`]. Deliberately not here:
//! warnings (recoverable oddities are recorded in `RunMeta::warnings`, not raised).

use thiserror::Error;

use super::channel::UnitError;
use super::mat::ElementProblem;

/// Everything that makes a TTC run file unreadable.
///
/// `Display` is a single line starting with the source name given to the reader, so a batch can
/// print it as is. Cell and header excerpts are quoted with `{:?}` and cut to a few dozen
/// characters, so even binary garbage stays on one short line.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TtcError {
    /// The bytes could not be read at all (only from `read_dat_from`'s reader).
    #[error("{source_name}: cannot read: {message}")]
    Io {
        source_name: String,
        message: String,
    },

    /// Zero bytes, or nothing but whitespace.
    #[error("{source_name}: empty file")]
    Empty { source_name: String },

    /// A header line (1, 2 or 3 of a `.dat`) is missing or not what a TIRF file has.
    #[error("{source_name}: line {line}: {message}")]
    Header {
        source_name: String,
        line: usize,
        message: String,
    },

    /// A channel name appears twice on line 2 (names compare case-insensitively).
    #[error("{source_name}: line 2: channel {name:?} appears twice (columns {first} and {second})")]
    DuplicateChannel {
        source_name: String,
        name: String,
        first: usize,
        second: usize,
    },

    /// A unit string the readers do not know, or one that does not fit the channel.
    #[error("{source_name}: {location}: channel {channel}: {message}")]
    Unit {
        source_name: String,
        /// `line 3, column 11` (`.dat`) or `variable channel, units{11}` (`.mat`).
        location: String,
        channel: String,
        message: Box<UnitError>,
    },

    /// A channel every run needs is absent.
    #[error("{source_name}: {location}: required channel {channel} is missing")]
    MissingChannel {
        source_name: String,
        /// `line 2` (`.dat`) or `variables` (`.mat`).
        location: String,
        channel: String,
    },

    /// The header is fine but there is not a single data row.
    #[error("{source_name}: no data rows after the header (line {after_line})")]
    NoRows {
        source_name: String,
        after_line: usize,
    },

    /// A data row with the wrong number of cells (not the last line of the file).
    #[error("{source_name}: line {line}: expected {expected} cells, found {found}")]
    RowLength {
        source_name: String,
        line: usize,
        expected: usize,
        found: usize,
    },

    /// A data cell that is not a decimal number.
    #[error("{source_name}: line {line}, column {column} ({channel}): not a number: {cell:?}")]
    NotANumber {
        source_name: String,
        line: usize,
        column: usize,
        channel: String,
        cell: String,
    },

    /// A data cell that parses to NaN or an infinity (TIRF files never contain those).
    #[error("{source_name}: line {line}, column {column} ({channel}): non-finite value {cell:?}")]
    NonFinite {
        source_name: String,
        line: usize,
        column: usize,
        channel: String,
        cell: String,
    },

    /// A MATLAB v7.3 file: HDF5 inside, which tirebase does not read.
    #[error(
        "{source_name}: MATLAB v7.3 (HDF5) files are not supported; re-save with save(..., '-v7')"
    )]
    MatV73 { source_name: String },

    /// The 128-byte MAT-file header is missing or wrong.
    #[error("{source_name}: not a MATLAB level 5 MAT-file: {message}")]
    MatHeader {
        source_name: String,
        message: String,
    },

    /// A data element that cannot be decoded (truncated, corrupt, inconsistent).
    #[error("{source_name}: element {element} at byte {offset}: {problem}")]
    MatElement {
        source_name: String,
        /// The variable name when it was already read, otherwise `#<index>` (0-based).
        element: String,
        /// Byte offset of the top-level element's tag in the file.
        offset: usize,
        problem: ElementProblem,
    },

    /// A decoded variable that cannot be a run channel (wrong shape, wrong length, wrong class).
    #[error("{source_name}: variable {name}: {message}")]
    MatVariable {
        source_name: String,
        name: String,
        message: String,
    },
}

/// Quote-ready excerpt of raw bytes for an error message: lossy UTF-8, at most `max` chars.
pub(crate) fn excerpt(bytes: &[u8], max: usize) -> String {
    let text = String::from_utf8_lossy(bytes);
    let mut out: String = text.chars().take(max).collect();
    if text.chars().count() > max {
        out.push_str("...");
    }
    out
}

/// A name from the file made safe for a one-line message: control characters escaped, at most
/// 40 characters.
pub(crate) fn printable(text: &str) -> String {
    let escaped: String = text.chars().flat_map(char::escape_debug).collect();
    excerpt(escaped.as_bytes(), 40)
}
