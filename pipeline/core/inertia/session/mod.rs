//! Rig session files: `session.toml` plus one CSV per run -> a validated [`Session`].
//!
//! In: the text of `session.toml` and, per run, the text of its CSV (read through a closure, so
//! synthetic sessions are analysed in memory; the pipeline's `inertia` module reads the files).
//! Out: [`Session`] with SI values and uncertainties, and per run a [`RunPlan`]. Three steps, one
//! module each: `parse` (text -> raw records, `CsvTable`), `validate` (raw records ->
//! [`Session`]; each rig section and each run keeps its own result, so a bad `[trifilar]` table
//! or a bad run only fails the runs that need it) and `plan` (a run -> the validated sections
//! it needs, or the reason it cannot be measured). The format is specified in
//! `schemas/inertia_session.md`: keys carry their unit as a suffix (`_m`, `_kg`, `_s`, `_deg`,
//! `_kg_m2`, `_n_m`, `_m_s2`); a measured value is a number or `{ v = .., u = .. }` (standard
//! uncertainty, same unit). Unknown keys (including a wrong unit suffix) are errors.
//! Deliberately no unit conversion: a wrong unit is an error, not a guess; and no file system.

mod parse;
mod plan;
mod validate;

use std::collections::BTreeMap;

use super::Measured;
use super::swing::{CorrectionScope, PeriodMethod, SignalKind};
use super::uncertainty::Propagation;

pub use parse::CsvTable;
pub use plan::{PlanError, RigPlan, RunPlan, YawLoad};

/// A problem with a session file or a run file, naming the file and the key, line or column.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SessionError {
    /// The file could not be read.
    #[error("{path}: cannot read: {message}")]
    Io { path: String, message: String },
    /// `session.toml` is not valid TOML or does not match the format.
    #[error("{path}: {message}")]
    Toml { path: String, message: String },
    /// A field is missing, out of range or inconsistent.
    #[error("{path}: {key}: {message}")]
    Field {
        path: String,
        key: String,
        message: String,
    },
    /// A CSV line is malformed.
    #[error("{path}: line {line}: {message}")]
    Csv {
        path: String,
        line: usize,
        message: String,
    },
    /// A required CSV column is absent (often a wrong unit suffix).
    #[error("{path}: missing column `{column}` (found: {found})")]
    MissingColumn {
        path: String,
        column: String,
        found: String,
    },
}

/// The session file's name in a session directory.
pub const SESSION_FILE: &str = "session.toml";

fn field(key: impl Into<String>, message: impl Into<String>) -> SessionError {
    SessionError::Field {
        path: SESSION_FILE.into(),
        key: key.into(),
        message: message.into(),
    }
}

/// Yaw-table constants.
#[derive(Debug, Clone, PartialEq)]
pub struct YawTableSpec {
    /// Effective drum radius to the string centreline (m).
    pub radius_m: Measured,
    /// Reflected idler-pulley inertia `I_pu (r / r_pu)^2` (kg m^2).
    pub i_eq_kg_m2: Measured,
    /// Table inertia, or `None` to identify it from tare + calibration runs.
    pub table_inertia_kg_m2: Option<Measured>,
    /// Friction torque as given, or `None` (drag mass or identification from runs).
    pub friction_n_m: Option<Measured>,
    /// Drag mass `m_drag` with `tau_f = m_drag g r` (kg).
    pub drag_mass_kg: Option<Measured>,
    /// Drop height hint: events beyond `max_drop / r` rad are not used (m).
    pub max_drop_m: Option<f64>,
}

/// Trifilar constants.
#[derive(Debug, Clone, PartialEq)]
pub struct TrifilarSpec {
    /// Top attachment radius (m).
    pub radius_top_m: Measured,
    /// Bottom attachment radius (m).
    pub radius_bottom_m: Measured,
    /// Vertical distance between attachment planes, loaded (m).
    pub length_m: Measured,
    /// Platform mass (kg).
    pub platform_mass_kg: Measured,
}

/// Pendulum axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PendulumAxis {
    /// Pitch (swing about the lateral axis): the result is I_yy.
    Pitch,
    /// Roll (swing about the longitudinal axis): the result is I_xx.
    Roll,
}

impl PendulumAxis {
    /// `pitch` or `roll`.
    pub fn name(self) -> &'static str {
        match self {
            PendulumAxis::Pitch => "pitch",
            PendulumAxis::Roll => "roll",
        }
    }
}

/// Compound-pendulum constants.
#[derive(Debug, Clone, PartialEq)]
pub struct PendulumSpec {
    /// Swing axis.
    pub axis: PendulumAxis,
    /// Knife-edge tip radius (m); 0 for a bearing or flexure.
    pub knife_tip_radius_m: Measured,
    /// Vertical pivot-to-deck distance with the platform level (m).
    pub pivot_to_deck_m: Measured,
    /// Standard uncertainty of each added mass (kg).
    pub added_mass_u_kg: f64,
    /// Standard uncertainty of each added-mass position coordinate (m).
    pub added_position_u_m: f64,
}

/// Inclinometer zero-offset treatment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TiltOffset {
    /// Fit the offset from the configurations.
    Estimate,
    /// Known offset (rad).
    Known(Measured),
}

/// Static inclinometer settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TiltSensor {
    /// `reading = scale * raw + offset`.
    pub scale: f64,
    /// Zero offset.
    pub offset: TiltOffset,
    /// Per-reading standard uncertainty (rad).
    pub noise_rad: f64,
}

/// A calibration body of known inertia.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationBody {
    /// Identifier referenced by runs.
    pub id: String,
    /// Mass (kg).
    pub mass_kg: Measured,
    /// Inertia about the rig axis (kg m^2).
    pub inertia_kg_m2: Measured,
}

/// Yaw acceleration model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum YawModel {
    /// Constant acceleration (quadratic).
    ConstAlpha,
    /// Aerodynamic drag `ln cosh` model.
    AeroLnCosh,
    /// `ln cosh` when the fitted drag is significant (c > 5 u(c) and c theta_max > 1e-4).
    Auto,
}

/// Yaw friction/tare identification.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrictionMethod {
    /// Friction torque and table inertia as given in `[yaw_table]`.
    Given,
    /// Empty-table tare run plus calibration-body run (recommended).
    TareCalibration,
    /// Regression over vehicle runs with several falling masses (table inertia given).
    MultiMass,
    /// The thesis's multiplicative factor from a calibration body: biased, comparison only.
    CalibrationFactor,
}

/// Analysis choices.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AnalysisSpec {
    /// Period estimator.
    pub period_method: PeriodMethod,
    /// Amplitude-correction scope for swings; `None` in the option means "rig default".
    pub amplitude_correction: AmplitudeCorrection,
    /// Window length (cycles).
    pub window_cycles: f64,
    /// Cycles skipped after release.
    pub discard_initial_cycles: f64,
    /// Minimum cycles per swing.
    pub min_cycles: f64,
    /// Yaw acceleration model.
    pub yaw_model: YawModel,
    /// Yaw friction method; `None` = decided by [`Session::friction_method`].
    pub friction_method: Option<FrictionMethod>,
    /// Uncertainty propagation.
    pub propagation: Propagation,
}

/// Amplitude-correction choice.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AmplitudeCorrection {
    /// Trifilar formula for trifilar runs, windowed AGM for pendulum runs.
    Auto,
    /// No correction.
    None,
    /// Pendulum AGM at the record RMS amplitude.
    AgmWhole,
    /// Pendulum AGM per window.
    AgmWindowed,
    /// Trifilar formula per window.
    Trifilar,
}

impl AmplitudeCorrection {
    /// Scope used for swings.
    pub fn scope(self) -> CorrectionScope {
        match self {
            AmplitudeCorrection::None => CorrectionScope::None,
            AmplitudeCorrection::AgmWhole => CorrectionScope::Whole,
            _ => CorrectionScope::Windowed,
        }
    }
}

/// Which rig a run was recorded on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rig {
    /// Air-bearing yaw table.
    YawTable,
    /// Trifilar pendulum.
    Trifilar,
    /// Compound pendulum.
    Pendulum,
}

/// What was on the rig.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Empty table / platform only.
    Tare,
    /// Table plus a calibration body.
    Calibration,
    /// Table plus the vehicle (or object).
    Vehicle,
}

/// Static or swing pendulum run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PendulumKind {
    /// Static tilt with added masses.
    Static,
    /// Free swing.
    Swing,
}

/// Yaw-table encoder settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EncoderSpec {
    /// Angle between two encoder events (rad).
    pub spacing_rad: f64,
    /// Fewest usable events a drop needs (at least 4).
    pub min_events: usize,
}

/// The rig-specific part of a run: what each rig needs, and only that.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RunSetup {
    /// A yaw-table drop with its falling mass.
    YawTable {
        /// Falling mass (kg).
        falling_mass_kg: Measured,
    },
    /// A trifilar swing.
    Trifilar {
        /// Swing signal column.
        signal: SignalKind,
    },
    /// A compound-pendulum static tilt test or swing.
    Pendulum {
        /// Static or swing.
        kind: PendulumKind,
        /// Swing signal column (swing runs).
        signal: SignalKind,
    },
}

/// A validated run entry.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSpec {
    /// Run id.
    pub id: String,
    /// Role.
    pub role: Role,
    /// CSV path relative to the session directory.
    pub file: String,
    /// Rig and what that rig needs of the run.
    pub setup: RunSetup,
    /// Calibration body id (required for calibration runs; checked wherever given).
    pub calibration_body: Option<String>,
    /// Object name for results (default: the session's vehicle id).
    pub object: Option<String>,
    /// Object mass (trifilar vehicle runs; default: `[vehicle] mass_kg`).
    pub object_mass_kg: Option<Measured>,
}

impl RunSpec {
    /// The rig the run was recorded on.
    pub fn rig(&self) -> Rig {
        match self.setup {
            RunSetup::YawTable { .. } => Rig::YawTable,
            RunSetup::Trifilar { .. } => Rig::Trifilar,
            RunSetup::Pendulum { .. } => Rig::Pendulum,
        }
    }
}

/// A parsed session. Rig sections and runs keep their own validation result.
#[derive(Debug, Clone)]
pub struct Session {
    /// Session id.
    pub id: String,
    /// Vehicle id used as the object name (default `vehicle`).
    pub vehicle_id: String,
    /// Local gravitational acceleration (m/s^2).
    pub g_m_s2: Measured,
    /// Vehicle mass as tested.
    pub vehicle_mass_kg: Result<Measured, SessionError>,
    /// Yaw-table encoder.
    pub encoder: Result<EncoderSpec, SessionError>,
    /// Static inclinometer.
    pub tilt: Result<TiltSensor, SessionError>,
    /// Calibration bodies by id.
    pub calibration_bodies: BTreeMap<String, Result<CalibrationBody, SessionError>>,
    /// Yaw table section.
    pub yaw_table: Result<YawTableSpec, SessionError>,
    /// Trifilar section.
    pub trifilar: Result<TrifilarSpec, SessionError>,
    /// Pendulum section.
    pub pendulum: Result<PendulumSpec, SessionError>,
    /// Analysis options.
    pub analysis: AnalysisSpec,
    /// Runs in file order: id (or `run[i]`) and validated spec.
    pub runs: Vec<(String, Result<RunSpec, SessionError>)>,
}

impl Session {
    /// Parses and validates `session.toml` text. Errors only for problems that affect every run
    /// (syntax, format tag, `[session]`, `[site]`, `[analysis]`); others are kept per section.
    pub fn parse(text: &str) -> Result<Session, SessionError> {
        validate::session(parse::RawSession::from_toml(text)?)
    }

    /// The friction method in force: as given in `[analysis]`, else `given` when `[yaw_table]`
    /// states a friction torque or drag mass, else `tare_calibration`.
    pub fn friction_method(&self) -> FrictionMethod {
        if let Some(m) = self.analysis.friction_method {
            return m;
        }
        match &self.yaw_table {
            Ok(y) if y.friction_n_m.is_some() || y.drag_mass_kg.is_some() => FrictionMethod::Given,
            _ => FrictionMethod::TareCalibration,
        }
    }
}
