//! `.dat` writer: columns -> TIRF ASCII bytes (the inverse of the reader).
//!
//! In: a [`Line1`] (round-style header fields) and [`DatColumn`]s (name, unit string, fixed
//! decimals, values, in the file's own units and axes). Out: the bytes of a `.dat` file: line 1,
//! names, units, then one tab-separated row per sample with LF endings, like Calspan's. Used by
//! tests, benchmarks and the virtual test machine. Deliberately not here: unit or axis
//! conversion (the caller writes what the file should contain) and spreadsheet damage (tests
//! apply that to the bytes).

use std::fmt::Write as _;

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
    /// Digits after the decimal point.
    pub decimals: usize,
    pub values: Vec<f64>,
}

/// Render a `.dat` file. Every column must have the same length (shorter columns end the rows
/// early, which is the caller's bug; debug builds assert it).
pub fn render_dat(line1: &Line1, columns: &[DatColumn]) -> Vec<u8> {
    let rows = columns.first().map_or(0, |c| c.values.len());
    debug_assert!(columns.iter().all(|c| c.values.len() == rows));
    let mut text = String::with_capacity(64 + rows * columns.len() * 9);
    let _ = writeln!(text, "{line1}");
    let names: Vec<&str> = columns.iter().map(|c| c.name.as_str()).collect();
    let units: Vec<&str> = columns.iter().map(|c| c.unit.as_str()).collect();
    text.push_str(&names.join("\t"));
    text.push('\n');
    text.push_str(&units.join("\t"));
    text.push('\n');
    for row in 0..rows {
        for (k, column) in columns.iter().enumerate() {
            if k > 0 {
                text.push('\t');
            }
            let _ = write!(text, "{:.*}", column.decimals, column.values[row]);
        }
        text.push('\n');
    }
    text.into_bytes()
}
