//! Raw TTC run files (Calspan TIRF `.dat` ASCII and MATLAB level 5 `.mat`) -> typed runs.
//!
//! In: the bytes of one run file and a source name (used only in messages and metadata).
//! Out: a [`RunTable`]: every channel converted by its own unit string to SI (s, km/h, rpm, m,
//! kPa, N, N m, rad, degC), tire quantities in ISO-W axes as [`TireChannels<IsoW>`], plus
//! [`RunMeta`] (header fields, per-column original units, detected unit systems, estimated sample
//! rate, warnings). Also a MAT level 5 writer ([`mat::MatWriter`]) for the virtual test machine.
//!
//! ```text
//! .dat bytes --dat::parse--> columns + units --+
//!                                              +--build--> RunTable (SI, ISO-W)
//! .mat bytes --mat::read---> variables --------+
//! ```
//!
//! Deliberately not here: files on disk (the caller hands over the bytes), segmentation, QC
//! judgements (a P = 0 stretch parses fine; later stages flag it), filtering of any kind: the
//! measured channels stay as measured.
//!
//! # Decisions
//! - **Frame.** TIRF files are SAE unless line 1 says `ISO True`. For such a file (none seen so
//!   far) tirebase assumes FY, FZ, MZ and SA are already in ISO-W (z up, `Fz > 0` in compression)
//!   and does not flip them. `.mat` files carry no flag and are read as SAE. The only sign flip is
//!   [`TireChannels::into_iso_w`].
//! - **kappa.** `kappa` is SL (RE-based, the fitting slip) when the file has an SL column that is
//!   not all zero ([`KappaSource::Sl`]). Without it, a run that sweeps its slip ratio gets kappa
//!   derived as SL is defined, from N, V and the effective rolling radius where FX crosses zero
//!   ([`KappaSource::Derived`], not measured); any other run has kappa all zero and
//!   [`RunMeta::kappa_source`] says no longitudinal slip was measured
//!   ([`KappaSource::SlAllZero`] or [`KappaSource::NoSl`]). SR (Calspan's RL-based control
//!   slip, SR = 0 does not give FX = 0) is never used as kappa; it is kept as measured in
//!   [`RunTable::sr`].
//! - **Units are cross-checked** after conversion (`check.rs`): N against V, the radii against
//!   `V / (2 pi N / 60)`, ranges of pressure, load, speed and temperatures; a radius in a wrong
//!   length unit is rescaled, a channel without a consistent reading withheld (`None`), each with
//!   a [`RunMeta::unit_notes`] entry and a warning line.
//! - **Required channels.** ET, V, P, SA, IA, FX, FY, FZ, MX, MZ (what a stored sample needs);
//!   the others are `Option`s.
//! - **Extra channels** (unknown names, and `RUN` in `.mat`) are kept with their unit string and
//!   values as in the file, unconverted.
//! - **Truncated last line** of a `.dat` (fewer cells than line 2, or an empty cell): dropped with
//!   a warning. A short row anywhere else is an error.

mod build;
pub mod channel;
pub mod check;
pub mod dat;
pub mod error;
pub mod example;
pub mod float;
pub mod mat;
mod slip;
pub mod text;
pub mod units;

#[cfg(test)]
mod tests;

use crate::frame::{IsoW, TireChannels};

pub use channel::{TtcChannel, UnitError};
pub use dat::read_dat;
pub use error::TtcError;
pub use mat::read_mat;
pub use units::{Quantity, Unit, UnitSystem};

/// Which file format a run came from.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum SourceFormat {
    /// TIRF ASCII, tab separated, three header lines.
    Dat,
    /// MATLAB level 5 MAT-file.
    Mat,
}

/// Where [`TireChannels::kappa`] comes from.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum KappaSource {
    /// The SL column (RE-based longitudinal slip), converted as measured.
    Sl,
    /// The file has an SL column but it is all zero (cornering runs): kappa is 0, not measured.
    SlAllZero,
    /// The file has no SL column: kappa is 0, not measured.
    NoSl,
    /// No SL recorded (no column, or all zero), but the run sweeps its slip ratio: kappa derived
    /// from N and V as SL is defined (`slip.rs`); not measured.
    Derived,
}

impl KappaSource {
    /// Whether kappa holds a measured longitudinal slip (as opposed to a derived or an assumed
    /// zero).
    pub fn is_measured(self) -> bool {
        self == KappaSource::Sl
    }

    /// Whether kappa holds a longitudinal slip at all (measured or derived).
    pub fn is_available(self) -> bool {
        matches!(self, KappaSource::Sl | KappaSource::Derived)
    }
}

/// One column of the source file as it was written.
#[derive(Clone, Debug, PartialEq)]
pub struct ColumnInfo {
    /// The name as written in the file (`AmbTmp`, `FZ`, `RUN`).
    pub name: String,
    /// The channel it was recognised as; `None` for extra channels.
    pub channel: Option<TtcChannel>,
    /// The unit string as written (`deg f`, `N-m`), or the fallback spelling for `.mat` files
    /// without a `channel` struct entry.
    pub unit_raw: String,
    /// The parsed unit; `None` for an extra channel whose unit string is not a known spelling.
    pub unit: Option<Unit>,
    /// The unit system of this column (`None` when `unit` is `None`).
    pub system: Option<UnitSystem>,
    /// Whether the unit was taken from the file (`false`: `.mat` fallback SI spelling).
    pub unit_from_file: bool,
}

/// Everything known about a run besides its samples.
#[derive(Clone, Debug, PartialEq)]
pub struct RunMeta {
    /// The name the caller gave the reader (usually the path).
    pub source_name: String,
    /// `.dat` or `.mat`.
    pub format: SourceFormat,
    /// Calspan project number (line 1 `Project`, else the file name `B1320run15`).
    pub project: Option<u32>,
    /// Run number (line 1 `Run`, else the file name).
    pub run: Option<u32>,
    /// `Date` field of line 1 as written (`08-01-2018`, month first).
    pub date: Option<String>,
    /// `Time` field of line 1 as written (`19:19`).
    pub time: Option<String>,
    /// `Tire_Name=` of line 1, else the tire part of `.mat` `tireid`.
    pub tire_name: Option<String>,
    /// `Rim_Width=` of line 1, else `<w> inch rim` in `.mat` `tireid`, in inches.
    pub rim_width_in: Option<f64>,
    /// `ISO True|False` of line 1 (`None`: not stated; read as SAE).
    pub iso_flag: Option<bool>,
    /// `ID` field of line 1.
    pub id: Option<String>,
    /// `.mat` `source` variable.
    pub source: Option<String>,
    /// `.mat` `testid` variable (`Cornering`, `Drive/Brake/Combined`).
    pub testid: Option<String>,
    /// `.mat` `tireid` variable as written.
    pub tireid: Option<String>,
    /// Parsed from the source name when it looks like `<A|B|C><project><run|raw><n>.<ext>`.
    pub file_name: Option<TtcFileName>,
    /// Every column of the source, in file order.
    pub columns: Vec<ColumnInfo>,
    /// Number of samples.
    pub rows: usize,
    /// `1 / median(positive ET steps)`, Hz; `None` with fewer than two distinct times.
    pub sample_rate_hz: Option<f64>,
    /// Where `kappa` comes from.
    pub kappa_source: KappaSource,
    /// Recoverable oddities, one line each (truncated last line dropped, ignored variables,
    /// assumed units, suspicious FZ sign, unit cross-check findings, derived kappa, ...).
    pub warnings: Vec<String>,
    /// What the unit cross-checks found and did (rescaled or withheld channels, values out of
    /// range); each is also a line of `warnings`.
    pub unit_notes: Vec<check::UnitNote>,
}

impl RunMeta {
    /// Metadata with nothing known yet but the source (what a reader starts from).
    pub fn new(source_name: &str, format: SourceFormat) -> RunMeta {
        RunMeta {
            source_name: source_name.to_string(),
            format,
            project: None,
            run: None,
            date: None,
            time: None,
            tire_name: None,
            rim_width_in: None,
            iso_flag: None,
            id: None,
            source: None,
            testid: None,
            tireid: None,
            file_name: None,
            columns: Vec::new(),
            rows: 0,
            sample_rate_hz: None,
            kappa_source: KappaSource::NoSl,
            warnings: Vec::new(),
            unit_notes: Vec::new(),
        }
    }

    /// The file's overall unit system: `Si` or `Uscs` when every unit-bearing column agrees
    /// (neutral columns ignored), `None` when columns mix systems (e.g. the round-4 SI files
    /// whose AMBTMP is in deg F report `None` here; see [`ColumnInfo::system`]).
    pub fn unit_system(&self) -> Option<UnitSystem> {
        let mut systems = self
            .columns
            .iter()
            .filter(|c| c.channel.is_some())
            .filter_map(|c| c.system)
            .filter(|s| *s != UnitSystem::Neutral);
        let first = systems.next().unwrap_or(UnitSystem::Neutral);
        systems.all(|s| s == first).then_some(first)
    }
}

/// What a TTC file name says: `B1320run15.mat` is SI (B), project 1320, run file 15.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TtcFileName {
    /// `A` (US customary), `B` (SI), `C` (mixed, round 6), or `None` without a prefix.
    pub prefix: Option<char>,
    pub project: u32,
    pub run: u32,
    /// `raw` file (dwells kept) rather than a `run` file (dwells cut).
    pub raw: bool,
}

impl TtcFileName {
    /// Parse the last path component of `source_name`.
    ///
    /// ```
    /// use tirebase_core::ttc::TtcFileName;
    /// let name = TtcFileName::parse("data/B1965raw4.dat").unwrap();
    /// assert_eq!((name.prefix, name.project, name.run, name.raw), (Some('B'), 1965, 4, true));
    /// assert!(TtcFileName::parse("notes.txt").is_none());
    /// ```
    pub fn parse(source_name: &str) -> Option<TtcFileName> {
        let base = source_name.rsplit(['/', '\\']).next()?;
        let stem = base.split('.').next()?;
        let (prefix, rest) = match stem.chars().next()? {
            c if c.is_ascii_alphabetic() => (Some(c.to_ascii_uppercase()), &stem[1..]),
            _ => (None, stem),
        };
        let digits_end = rest.find(|c: char| !c.is_ascii_digit())?;
        let (project, rest) = rest.split_at(digits_end);
        let lower = rest.to_ascii_lowercase();
        let (raw, run) = if let Some(run) = lower.strip_prefix("run") {
            (false, run)
        } else {
            (true, lower.strip_prefix("raw")?)
        };
        if run.is_empty() || !run.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        Some(TtcFileName {
            prefix,
            project: project.parse().ok()?,
            run: run.parse().ok()?,
            raw,
        })
    }
}

/// A channel the readers do not know, kept as written.
#[derive(Clone, Debug, PartialEq)]
pub struct ExtraChannel {
    /// Name as in the file.
    pub name: String,
    /// Unit string as in the file (empty when none was given).
    pub unit: String,
    /// Values as in the file, not converted.
    pub values: Vec<f64>,
}

/// One run: every sample of one TTC file, SI units, tire quantities in ISO-W.
///
/// All columns have `meta.rows` values; `Option` columns are `None` when the file lacks the
/// channel. `tire.my_nm` is always empty (TIRF does not record My).
#[derive(Clone, Debug, PartialEq)]
pub struct RunTable {
    pub meta: RunMeta,
    /// ET: elapsed time, s, as recorded (may jump, repeat or step back).
    pub et_s: Vec<f64>,
    /// V: road speed, km/h.
    pub speed_kph: Vec<f64>,
    /// N: wheel speed, rpm.
    pub wheel_speed_rpm: Option<Vec<f64>>,
    /// RL: loaded radius, m.
    pub loaded_radius_m: Option<Vec<f64>>,
    /// RE: effective rolling radius, m (meaningless at V ~ 0).
    pub effective_radius_m: Option<Vec<f64>>,
    /// P: inflation pressure, kPa (gauge).
    pub pressure_kpa: Vec<f64>,
    /// FX FY FZ MX MZ, alpha = -SA, gamma = IA (rad), kappa (see [`KappaSource`]); ISO-W.
    pub tire: TireChannels<IsoW>,
    /// NFX as recorded (FX/FZ in the file's own frame, not re-signed).
    pub nfx: Option<Vec<f64>>,
    /// NFY as recorded (FY/FZ in the file's own frame, not re-signed).
    pub nfy: Option<Vec<f64>>,
    /// RST: road surface temperature, degC.
    pub road_temp_c: Option<Vec<f64>>,
    /// TSTI: tread surface temperature, inner, degC.
    pub tread_inner_temp_c: Option<Vec<f64>>,
    /// TSTC: tread surface temperature, centre, degC.
    pub tread_centre_temp_c: Option<Vec<f64>>,
    /// TSTO: tread surface temperature, outer, degC.
    pub tread_outer_temp_c: Option<Vec<f64>>,
    /// AMBTMP: ambient temperature, degC (converted from deg F where the file says so).
    pub ambient_temp_c: Option<Vec<f64>>,
    /// SR: Calspan's RL-based control slip ratio, as measured.
    pub sr: Option<Vec<f64>>,
    /// SL: RE-based longitudinal slip, as measured.
    pub sl: Option<Vec<f64>>,
    /// Unknown channels (and `.mat` `RUN`), as written.
    pub extras: Vec<ExtraChannel>,
}

impl RunTable {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.meta.rows
    }

    /// Whether the run has no samples (never true for a table a reader returned).
    pub fn is_empty(&self) -> bool {
        self.meta.rows == 0
    }
}

/// Read a run from bytes, choosing the format by content: a MAT-file header (`MATLAB` text or
/// an HDF5 signature) means `.mat`, anything else `.dat`. A `.mat` source name also selects the
/// MAT reader, so a damaged MAT-file gets a MAT error rather than a `.dat` header error.
pub fn read_run(bytes: &[u8], source_name: &str) -> Result<RunTable, TtcError> {
    let mat_named = source_name.to_ascii_lowercase().ends_with(".mat");
    if mat_named || mat::looks_like_mat(bytes) {
        read_mat(bytes, source_name)
    } else {
        read_dat(bytes, source_name)
    }
}
