//! Defects a real round has, injected on purpose and recorded in the truth.
//!
//! In: a run file's [`ChannelTable`] (or its rendered `.dat` bytes) and a [`DefectKind`]. Out:
//! the damaged table or bytes and a [`DefectRecord`] (file, kind, channel, ET range, data rows)
//! for `truth/defects.csv`. Rows are 1-based data rows (the first line after the three header
//! lines is row 1). Deliberately not here: choosing which file gets which defect (`round.rs`).

use super::dat::ChannelTable;

/// The defect kinds (`docs/ttc-format.md`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum DefectKind {
    /// A stretch of rows repeats the previous ET.
    DuplicatedEt,
    /// One row's ET steps backwards.
    NonMonotonicEt,
    /// Pressure reads 0 over a stretch.
    ZeroPressure,
    /// A channel reads 0 over a stretch.
    ZeroedChannel,
    /// The last line is cut mid-row, without a final newline.
    TruncatedLastLine,
    /// Re-saved by a spreadsheet: line 1 padded with tabs, trailing zeros of numbers dropped.
    SpreadsheetResaved,
}

impl DefectKind {
    /// Every kind, in the order files receive them.
    pub const ALL: [DefectKind; 6] = [
        DefectKind::DuplicatedEt,
        DefectKind::NonMonotonicEt,
        DefectKind::ZeroPressure,
        DefectKind::ZeroedChannel,
        DefectKind::TruncatedLastLine,
        DefectKind::SpreadsheetResaved,
    ];

    /// Name in `defects.csv`.
    pub const fn as_str(self) -> &'static str {
        match self {
            DefectKind::DuplicatedEt => "duplicated_et",
            DefectKind::NonMonotonicEt => "non_monotonic_et",
            DefectKind::ZeroPressure => "zero_pressure",
            DefectKind::ZeroedChannel => "zeroed_channel",
            DefectKind::TruncatedLastLine => "truncated_last_line",
            DefectKind::SpreadsheetResaved => "spreadsheet_resaved",
        }
    }

    /// Applied to the table (`true`) or to the rendered text (`false`).
    pub const fn on_table(self) -> bool {
        !matches!(
            self,
            DefectKind::TruncatedLastLine | DefectKind::SpreadsheetResaved
        )
    }
}

/// One injected defect.
#[derive(Clone, Debug, PartialEq)]
pub struct DefectRecord {
    pub file: String,
    pub kind: DefectKind,
    /// Affected channel (empty for whole-row or whole-file defects).
    pub channel: String,
    pub et_start_s: f64,
    pub et_end_s: f64,
    /// First and last affected data row, 1-based.
    pub row_first: usize,
    pub row_last: usize,
}

/// Damage the table at data row `at` (0-based, chosen by the caller inside a test segment).
pub fn apply_to_table(
    table: &mut ChannelTable,
    kind: DefectKind,
    at: usize,
    file: &str,
) -> DefectRecord {
    let rows = table.rows();
    let et = table.column("ET").expect("ET").values.clone();
    let dt = if rows > 1 { et[1] - et[0] } else { 0.01 };
    let stretch = |len_s: f64| {
        let len = ((len_s / dt).round() as usize).max(1);
        let first = at.min(rows.saturating_sub(len + 1));
        (first, (first + len - 1).min(rows - 1))
    };
    let (first, last, channel) = match kind {
        DefectKind::DuplicatedEt => {
            let (a, b) = stretch(0.05);
            let a = a.max(1);
            let col = table.column_mut("ET").expect("ET");
            for r in a..=b {
                col.values[r] = col.values[a - 1];
            }
            (a, b, "ET")
        }
        DefectKind::NonMonotonicEt => {
            let a = at.max(1);
            let col = table.column_mut("ET").expect("ET");
            col.values[a] = col.values[a - 1] - 0.5 * dt;
            (a, a, "ET")
        }
        DefectKind::ZeroPressure => {
            let (a, b) = stretch(2.0);
            let col = table.column_mut("P").expect("P");
            col.values[a..=b].iter_mut().for_each(|v| *v = 0.0);
            (a, b, "P")
        }
        DefectKind::ZeroedChannel => {
            let (a, b) = stretch(3.0);
            let col = table.column_mut("MZ").expect("MZ");
            col.values[a..=b].iter_mut().for_each(|v| *v = 0.0);
            (a, b, "MZ")
        }
        DefectKind::TruncatedLastLine | DefectKind::SpreadsheetResaved => {
            unreachable!("text defect")
        }
    };
    DefectRecord {
        file: file.to_string(),
        kind,
        channel: channel.to_string(),
        et_start_s: et[first],
        et_end_s: et[last],
        row_first: first + 1,
        row_last: last + 1,
    }
}

/// Damage the rendered `.dat` bytes.
pub fn apply_to_text(
    bytes: &mut Vec<u8>,
    kind: DefectKind,
    table: &ChannelTable,
    file: &str,
) -> DefectRecord {
    let rows = table.rows();
    let et = &table.column("ET").expect("ET").values;
    match kind {
        DefectKind::TruncatedLastLine => {
            // Drop the final newline and the last ~40 % of the last row.
            bytes.pop();
            let start = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |p| p + 1);
            let keep = start + (bytes.len() - start) * 3 / 5;
            bytes.truncate(keep);
            DefectRecord {
                file: file.to_string(),
                kind,
                channel: String::new(),
                et_start_s: et[rows - 1],
                et_end_s: et[rows - 1],
                row_first: rows,
                row_last: rows,
            }
        }
        DefectKind::SpreadsheetResaved => {
            *bytes = spreadsheet_resave(bytes, table.columns.len());
            DefectRecord {
                file: file.to_string(),
                kind,
                channel: String::new(),
                et_start_s: et[0],
                et_end_s: et[rows - 1],
                row_first: 1,
                row_last: rows,
            }
        }
        _ => unreachable!("table defect"),
    }
}

/// What a spreadsheet does to a `.dat`: line 1 padded with tabs to the column count, numbers
/// written without trailing zeros (`0.000` -> `0`, `1.500` -> `1.5`).
pub fn spreadsheet_resave(bytes: &[u8], n_columns: usize) -> Vec<u8> {
    let text = String::from_utf8_lossy(bytes);
    let mut out = String::with_capacity(text.len());
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let (body, nl) = match line.strip_suffix('\n') {
            Some(b) => (b, "\n"),
            None => (line, ""),
        };
        if i == 0 {
            out.push_str(body);
            for _ in 1..n_columns {
                out.push('\t');
            }
        } else if i < 3 {
            out.push_str(body);
        } else {
            for (j, cell) in body.split('\t').enumerate() {
                if j > 0 {
                    out.push('\t');
                }
                out.push_str(trim_number(cell));
            }
        }
        out.push_str(nl);
    }
    out.into_bytes()
}

fn trim_number(cell: &str) -> &str {
    if !cell.contains('.') {
        return cell;
    }
    let t = cell.trim_end_matches('0').trim_end_matches('.');
    match t {
        "" | "-" => "0",
        "-0" => "0",
        _ => t,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resave_trims_and_pads() {
        let dat = b"TIRF Data File: Project 1; Run 2\nET\tFX\ns\tN\n0.000\t-0.50\n1.250\t10.00";
        let out = String::from_utf8(spreadsheet_resave(dat, 2)).unwrap();
        assert_eq!(
            out,
            "TIRF Data File: Project 1; Run 2\t\nET\tFX\ns\tN\n0\t-0.5\n1.25\t10"
        );
    }
}
