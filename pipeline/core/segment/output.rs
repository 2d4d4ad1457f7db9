//! What segmentation hands out: one [`Segment`] per stretch of a run, and a [`RunSegmentation`]
//! report per run.
//!
//! In: nothing (plain data types). Out: the types the store, the fitting stages and the reports
//! read. Deliberately not here: column names and Parquet types of the `segments` table (those live
//! in `schemas/`, built from these fields by the command layer).

use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;

/// What a segment is. `as_str` gives the snake_case name used in tables and truth files.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SegmentKind {
    /// Load staircase at V ~ 0, SA ~ 0 (one per inclination angle).
    SpringRateStatic,
    /// Load staircase at road speed, SA ~ 0.
    SpringRateDynamic,
    /// One cycle of the first long block of fast repeated SA sweeps on a cold tire.
    ColdToWarm,
    /// One warm-up/conditioning cycle before the test matrix (repeated or off-matrix rate).
    Conditioning,
    /// One SA sweep cycle of the matrix at fixed P, IA, FZ, V.
    Cornering,
    /// One SL sweep cycle at SA ~ 0.
    DriveBrake,
    /// One SL sweep cycle at a held SA != 0.
    Combined,
    /// One fast SA step to a held level (and its rise).
    StepSteer,
    /// One monotonic IA ramp over a wide span at SA ~ 0.
    IaSweep,
    /// One sweep cycle (SA or SL) at a nominal speed other than the run's main speed.
    SpeedSweep,
    /// Everything else: dwells, transitions, accelerations, short or unclassifiable activity.
    Other,
}

impl SegmentKind {
    /// Every kind, in a fixed order.
    pub const ALL: [SegmentKind; 11] = [
        SegmentKind::SpringRateStatic,
        SegmentKind::SpringRateDynamic,
        SegmentKind::ColdToWarm,
        SegmentKind::Conditioning,
        SegmentKind::Cornering,
        SegmentKind::DriveBrake,
        SegmentKind::Combined,
        SegmentKind::StepSteer,
        SegmentKind::IaSweep,
        SegmentKind::SpeedSweep,
        SegmentKind::Other,
    ];

    /// The snake_case name used in tables (`spring_rate_static`, `cornering`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            SegmentKind::SpringRateStatic => "spring_rate_static",
            SegmentKind::SpringRateDynamic => "spring_rate_dynamic",
            SegmentKind::ColdToWarm => "cold_to_warm",
            SegmentKind::Conditioning => "conditioning",
            SegmentKind::Cornering => "cornering",
            SegmentKind::DriveBrake => "drive_brake",
            SegmentKind::Combined => "combined",
            SegmentKind::StepSteer => "step_steer",
            SegmentKind::IaSweep => "ia_sweep",
            SegmentKind::SpeedSweep => "speed_sweep",
            SegmentKind::Other => "other",
        }
    }

    /// Parse a snake_case name (the inverse of [`SegmentKind::as_str`]).
    pub fn parse(name: &str) -> Option<SegmentKind> {
        SegmentKind::ALL.into_iter().find(|k| k.as_str() == name)
    }

    /// Steady-state force data for PAC2002 fitting (matrix sweeps).
    pub fn is_matrix(self) -> bool {
        matches!(
            self,
            SegmentKind::Cornering | SegmentKind::DriveBrake | SegmentKind::Combined
        )
    }
}

impl fmt::Display for SegmentKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The variable a sweep segment moves.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SweepVariable {
    /// Slip angle (cornering, cold-to-warm, conditioning, step steers).
    SlipAngle,
    /// Longitudinal slip (drive/brake, combined).
    LongitudinalSlip,
    /// Inclination angle (IA sweeps).
    Inclination,
    /// Normal load (spring-rate staircases).
    Load,
}

impl SweepVariable {
    /// Short name for tables: `sa`, `sl`, `ia`, `fz`.
    pub fn as_str(self) -> &'static str {
        match self {
            SweepVariable::SlipAngle => "sa",
            SweepVariable::LongitudinalSlip => "sl",
            SweepVariable::Inclination => "ia",
            SweepVariable::Load => "fz",
        }
    }
}

/// Commanded levels a segment was binned to, as the `segments` table stores them (its nullable
/// `i64` columns `*_nom`) and the fitting stages read them back
/// ([`MeasuredSegment::nominal`](crate::fit::segment_data::MeasuredSegment::nominal)); `None`
/// when not applicable (the level is swept or meaningless for the kind) or when the measured mean
/// was off every nominal level (then the segment carries [`QcFlag::OffNominal`]).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub struct NominalLevels {
    /// Inflation pressure, kPa.
    pub pressure_kpa: Option<i64>,
    /// Inclination angle, hundredths of a degree (`160` = 1.6 deg): the level's measured
    /// centre rounded to 0.1 deg ([`ia_cdeg_label`]), printed by [`ia_cdeg_text`].
    pub ia_cdeg: Option<i64>,
    /// Normal load, N (positive).
    pub fz_n: Option<i64>,
    /// Held slip angle, deg, ISO-W sign.
    pub alpha_deg: Option<i64>,
    /// Road speed, km/h.
    pub speed_kph: Option<i64>,
}

/// The inclination level label, hundredths of a degree, of a level whose measured centre is
/// `centre_deg`: the centre rounded to [`IA_LABEL_STEP_CDEG`].
///
/// ```
/// use tirebase_core::segment::ia_cdeg_label;
/// assert_eq!(ia_cdeg_label(1.565), 160);
/// assert_eq!(ia_cdeg_label(3.193), 320);
/// assert_eq!(ia_cdeg_label(-0.996), -100);
/// assert_eq!(ia_cdeg_label(-0.027), 0);
/// ```
pub fn ia_cdeg_label(centre_deg: f64) -> i64 {
    ((centre_deg * 100.0 / IA_LABEL_STEP_CDEG as f64).round() as i64) * IA_LABEL_STEP_CDEG
}

/// Resolution of an inclination level label, hundredths of a degree: 0.1 deg. Test plans set
/// camber in tenths (0, 1.6, 3.2 deg), while one run's measured centre of a level sits a few
/// hundredths off the set-point and another run's elsewhere, so a 0.01 deg label would key
/// one tested camber differently per run (and a flat tire as -0.03).
pub const IA_LABEL_STEP_CDEG: i64 = 10;

/// An inclination level in hundredths of a degree as degrees with the decimals it needs.
///
/// ```
/// use tirebase_core::segment::ia_cdeg_text;
/// assert_eq!(ia_cdeg_text(160), "1.6");
/// assert_eq!(ia_cdeg_text(-100), "-1");
/// assert_eq!(ia_cdeg_text(0), "0");
/// assert_eq!(ia_cdeg_text(-5), "-0.05");
/// ```
pub fn ia_cdeg_text(cdeg: i64) -> String {
    let sign = if cdeg < 0 { "-" } else { "" };
    let (whole, frac) = (cdeg.unsigned_abs() / 100, cdeg.unsigned_abs() % 100);
    match frac {
        0 => format!("{sign}{whole}"),
        f if f % 10 == 0 => format!("{sign}{whole}.{}", f / 10),
        f => format!("{sign}{whole}.{f:02}"),
    }
}

/// Mean and standard deviation of one channel over a segment (dropout samples excluded).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct ChannelStats {
    /// Mean, in the channel's unit.
    pub mean: f64,
    /// Population standard deviation, same unit.
    pub std: f64,
}

/// Measured means and spreads of the set-point channels over a segment.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct MeasuredLevels {
    /// Inflation pressure, kPa.
    pub pressure_kpa: ChannelStats,
    /// Inclination angle, deg.
    pub ia_deg: ChannelStats,
    /// Normal load, N (positive = compression).
    pub fz_n: ChannelStats,
    /// Road speed, km/h.
    pub speed_kph: ChannelStats,
    /// Slip angle, deg, ISO-W.
    pub alpha_deg: ChannelStats,
}

/// Which nominal level a [`QcFlag::OffNominal`] is about.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Level {
    /// Inflation pressure.
    Pressure,
    /// Inclination angle.
    Inclination,
    /// Normal load.
    Load,
    /// Held slip angle.
    SlipAngle,
    /// Road speed.
    Speed,
}

impl Level {
    /// Short name: `pressure`, `ia`, `fz`, `alpha`, `speed`.
    pub fn as_str(self) -> &'static str {
        match self {
            Level::Pressure => "pressure",
            Level::Inclination => "ia",
            Level::Load => "fz",
            Level::SlipAngle => "alpha",
            Level::Speed => "speed",
        }
    }
}

/// A quality-control finding on a segment. `Display` gives the table spelling
/// (`zero_pressure`, `zeroed_channel:fy_n`, ...).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum QcFlag {
    /// Inflation pressure read ~0 over a stretch.
    ZeroPressure,
    /// A channel read exactly 0 over a stretch where its neighbours say it should not.
    ZeroedChannel(String),
    /// ET steps backwards inside the segment.
    NonMonotonicEt,
    /// ET repeats inside the segment.
    DuplicatedEt,
    /// Shorter than its kind should be (incomplete sweep, truncated file).
    TooShort,
    /// FZ changes persistently by more than the drift tolerance over a held-load segment
    /// (beyond the swing of loose load control).
    LoadDrift,
    /// A channel sat at its run extreme over a stretch (sensor or range clipping).
    SaturatedChannel(String),
    /// A level the kind needs did not bin to any nominal value.
    OffNominal(Level),
    /// A channel's median over the segment lies outside its physical range
    /// ([`crate::physical`]): a unit error or a broken channel (pressure: the group's pressure
    /// would be wrong).
    OutOfRange(String),
}

impl QcFlag {
    /// True when the flag says the segment's force/slip data cannot be trusted for fitting.
    /// Broken data spoil them (zero pressure, zeroed or clipped channels, ET out of order);
    /// a short or incomplete sweep, a load that moves within a sweep (every sample carries its
    /// own measured load) and an off-nominal level leave them usable: the stages judge whether
    /// such a segment is enough for them. Saturated temperature channels leave the forces usable.
    /// A pressure outside its physical range spoils them: the group they would be fitted in
    /// (tire, rim, pressure) is not the tire's.
    pub fn spoils_forces(&self) -> bool {
        match self {
            QcFlag::ZeroPressure | QcFlag::NonMonotonicEt | QcFlag::DuplicatedEt => true,
            QcFlag::OutOfRange(_) => true,
            QcFlag::ZeroedChannel(c) | QcFlag::SaturatedChannel(c) => !c.starts_with("tread"),
            QcFlag::TooShort | QcFlag::LoadDrift | QcFlag::OffNominal(_) => false,
        }
    }
}

impl fmt::Display for QcFlag {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            QcFlag::ZeroPressure => f.write_str("zero_pressure"),
            QcFlag::ZeroedChannel(c) => write!(f, "zeroed_channel:{c}"),
            QcFlag::NonMonotonicEt => f.write_str("non_monotonic_et"),
            QcFlag::DuplicatedEt => f.write_str("duplicated_et"),
            QcFlag::TooShort => f.write_str("too_short"),
            QcFlag::LoadDrift => f.write_str("load_drift"),
            QcFlag::SaturatedChannel(c) => write!(f, "saturated_channel:{c}"),
            QcFlag::OffNominal(level) => write!(f, "off_nominal:{}", level.as_str()),
            QcFlag::OutOfRange(c) => write!(f, "out_of_range:{c}"),
        }
    }
}

/// One stretch of a run. Segments of a run are sorted, contiguous and cover every sample once.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// Position in the run's segment list (0-based).
    pub index: usize,
    /// Sample range, half-open, into the run's columns.
    pub samples: Range<usize>,
    /// What the segment is.
    pub kind: SegmentKind,
    /// The variable the segment sweeps, if any.
    pub sweep: Option<SweepVariable>,
    /// Commanded levels.
    pub nominal: NominalLevels,
    /// Measured levels.
    pub measured: MeasuredLevels,
    /// ET of the first sample, s.
    pub et_start_s: f64,
    /// ET of the last sample, s.
    pub et_end_s: f64,
    /// Number of samples (`samples.len()`).
    pub n_samples: usize,
    /// Median sweep rate of the swept variable while it moves: deg/s for SA and IA, 1/s for SL,
    /// N/s for load; `None` for kinds without a sweep.
    pub sweep_rate: Option<f64>,
    /// Sorted, deduplicated QC findings.
    pub qc: Vec<QcFlag>,
}

impl Segment {
    /// QC flags joined by commas (the `qc_flags` column), empty when clean.
    pub fn qc_string(&self) -> String {
        self.qc
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join(",")
    }
}

/// What the run as a whole was, judged from its segments.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum RunClass {
    /// Mostly slip-angle matrix sweeps.
    Cornering,
    /// Mostly drive/brake and combined sweeps.
    DriveBrake,
    /// Spring rates, cold-to-warm or conditioning only: no matrix.
    WarmUp,
    /// Step steers and no (or fewer) matrix sweeps.
    Transient,
    /// Nothing recognisable.
    Unknown,
}

impl RunClass {
    /// Name as in the run catalog: `cornering`, `drive_brake`, `warmup`, `transient`, `unknown`.
    pub fn as_str(self) -> &'static str {
        match self {
            RunClass::Cornering => "cornering",
            RunClass::DriveBrake => "drive_brake",
            RunClass::WarmUp => "warmup",
            RunClass::Transient => "transient",
            RunClass::Unknown => "unknown",
        }
    }
}

/// The per-run report of the segmentation stage.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSegmentation {
    /// Run-level classification.
    pub run_class: RunClass,
    /// Number of segments per kind (every kind present, zero counts included).
    pub counts: BTreeMap<SegmentKind, usize>,
    /// Median sample period, s.
    pub sample_period_s: f64,
    /// Number of gap-free blocks the run was split into.
    pub n_blocks: usize,
    /// The main test speed of the run, km/h (sweeps elsewhere are `speed_sweep`).
    pub main_speed_kph: Option<i64>,
    /// Things a person should look at (one line each).
    pub warnings: Vec<String>,
}

impl RunSegmentation {
    /// Count of one kind.
    pub fn count(&self, kind: SegmentKind) -> usize {
        self.counts.get(&kind).copied().unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kind_names_round_trip() {
        for kind in SegmentKind::ALL {
            assert_eq!(SegmentKind::parse(kind.as_str()), Some(kind));
        }
        assert_eq!(SegmentKind::parse("cornering_sweep"), None);
    }

    #[test]
    fn qc_flags_render_for_the_table() {
        let flags = [
            QcFlag::ZeroPressure,
            QcFlag::ZeroedChannel("fy_n".into()),
            QcFlag::OffNominal(Level::Load),
            QcFlag::OutOfRange("pressure_kpa".into()),
        ];
        let rendered: Vec<String> = flags.iter().map(ToString::to_string).collect();
        assert_eq!(
            rendered,
            [
                "zero_pressure",
                "zeroed_channel:fy_n",
                "off_nominal:fz",
                "out_of_range:pressure_kpa"
            ]
        );
        assert!(QcFlag::OutOfRange("pressure_kpa".into()).spoils_forces());
        assert!(!QcFlag::SaturatedChannel("tread_outer_c".into()).spoils_forces());
        assert!(QcFlag::SaturatedChannel("fy_n".into()).spoils_forces());
    }
}
