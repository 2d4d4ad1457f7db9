//! `.dat` writer: columns -> TIRF ASCII bytes (the inverse of the reader).
//!
//! In: line 1 (a [`Line1`] of round-style header fields, or the virtual test machine's own
//! header text) and [`DatColumn`]s (name, unit string, fixed decimals, values, in the file's own
//! units and axes). Out: the bytes of a `.dat` file: line 1, names, units, then one
//! tab-separated row per sample with LF endings, like Calspan's. Used by tests, benchmarks and
//! the virtual test machine. Deliberately not here: unit or axis
//! conversion (the caller writes what the file should contain) and spreadsheet damage (tests
//! apply that to the bytes).

use std::fmt::Display;

/// Which round's header line and unit spellings a file imitates (see
/// `shared/docs/ttc-format.md`).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum RoundStyle {
    /// Round 4: `Project 1320; Run 125`, `sec`, `AMBTMP`, `deg F`/`deg C`, 50 Hz.
    R4,
    /// Round 8: date, time, ISO flag and ID in line 1; `s`, `AmbTmp`, `deg f`/`deg c`, `SAE`,
    /// 100 Hz.
    R8,
    /// Round 9: as R8 plus `Tire_Name=` and `Rim_Width=`.
    R9,
}

impl RoundStyle {
    /// Sample rate: 50 Hz for round 4, 100 Hz for rounds 6-9.
    pub fn sample_rate_hz(self) -> f64 {
        match self {
            RoundStyle::R4 => 50.0,
            RoundStyle::R8 | RoundStyle::R9 => 100.0,
        }
    }

    /// `R4`, `R8` or `R9`.
    pub fn label(self) -> &'static str {
        match self {
            RoundStyle::R4 => "R4",
            RoundStyle::R8 => "R8",
            RoundStyle::R9 => "R9",
        }
    }
}

/// Line 1 fields. Which ones are `Some` decides the round style:
/// R4 `Project; Run`, R8 `+ Date; Time; ISO; ID`, R9 `+ Tire_Name=; Rim_Width=`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Line1 {
    pub project: u32,
    pub run: u32,
    pub date: Option<String>,
    pub time: Option<String>,
    pub tire_name: Option<String>,
    pub rim_width_in: Option<f64>,
    pub iso: Option<bool>,
    pub id: Option<String>,
}

impl std::fmt::Display for Line1 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "TIRF Data File: Project {}; Run {:03}",
            self.project, self.run
        )?;
        if let Some(date) = &self.date {
            write!(f, "; Date {date}")?;
        }
        if let Some(time) = &self.time {
            write!(f, "; Time {time}")?;
        }
        if let Some(tire) = &self.tire_name {
            write!(f, "; Tire_Name={tire}")?;
        }
        if let Some(rim) = self.rim_width_in {
            write!(f, "; Rim_Width={rim:.1}")?;
        }
        if let Some(iso) = self.iso {
            write!(f, "; ISO {}", if iso { "True" } else { "False" })?;
        }
        if let Some(id) = &self.id {
            write!(f, "; ID {id}")?;
        }
        Ok(())
    }
}

/// One column as it should appear in the file.
#[derive(Clone, Debug, PartialEq)]
pub struct DatColumn {
    /// Channel name as written on line 2 (`ET`, `AmbTmp`, ...).
    pub name: String,
    /// Unit string as written on line 3 (`s`, `deg f`, `N-m`, ...).
    pub unit: String,
    /// Digits after the decimal point (at most 9).
    pub decimals: u8,
    /// Values in the file's units and axes.
    pub values: Vec<f64>,
}

/// Append `x` with exactly `decimals` decimals (no exponent, no `-0`; `decimals <= 9`).
pub fn push_fixed(out: &mut Vec<u8>, x: f64, decimals: u8) {
    let scale = 10f64.powi(i32::from(decimals));
    let q = (x * scale).round();
    let neg = q < 0.0;
    let mut q = q.abs() as u64;
    if neg && q != 0 {
        out.push(b'-');
    }
    // Digits from the right into a stack buffer: fraction (zero-padded), point, integer part.
    let mut buf = [0u8; 32];
    let mut i = buf.len();
    for _ in 0..decimals {
        i -= 1;
        buf[i] = b'0' + (q % 10) as u8;
        q /= 10;
    }
    if decimals > 0 {
        i -= 1;
        buf[i] = b'.';
    }
    loop {
        i -= 1;
        buf[i] = b'0' + (q % 10) as u8;
        q /= 10;
        if q == 0 {
            break;
        }
    }
    out.extend_from_slice(&buf[i..]);
}

/// Render a `.dat` file: `line1`, channel names, units, then fixed-decimal rows ([`push_fixed`]);
/// TAB separated, LF line endings, a final newline. Every column must have the same length
/// (shorter columns are the caller's bug; debug builds assert it).
pub fn render_dat(line1: &impl Display, columns: &[DatColumn]) -> Vec<u8> {
    let rows = columns.first().map_or(0, |c| c.values.len());
    debug_assert!(columns.iter().all(|c| c.values.len() == rows));
    let mut out = Vec::with_capacity(rows * columns.len() * 9 + 512);
    out.extend_from_slice(line1.to_string().as_bytes());
    out.push(b'\n');
    let names: Vec<&str> = columns.iter().map(|c| c.name.as_str()).collect();
    out.extend_from_slice(names.join("\t").as_bytes());
    out.push(b'\n');
    let units: Vec<&str> = columns.iter().map(|c| c.unit.as_str()).collect();
    out.extend_from_slice(units.join("\t").as_bytes());
    out.push(b'\n');
    for r in 0..rows {
        for (j, c) in columns.iter().enumerate() {
            if j > 0 {
                out.push(b'\t');
            }
            push_fixed(&mut out, c.values[r], c.decimals);
        }
        out.push(b'\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_decimals() {
        let cases = [
            (0.0, 3, "0.000"),
            (-0.0001, 3, "0.000"),
            (-1.23456, 2, "-1.23"),
            (1234.5678, 3, "1234.568"),
            (0.05, 1, "0.1"),
            (-12.0, 0, "-12"),
            (0.00049, 4, "0.0005"),
        ];
        for (x, d, want) in cases {
            let mut out = Vec::new();
            push_fixed(&mut out, x, d);
            assert_eq!(String::from_utf8(out).unwrap(), want, "{x} with {d}");
        }
    }
}
