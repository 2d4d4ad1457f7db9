//! Rig session files: `session.toml` plus one CSV per run -> a validated [`Session`].
//!
//! In: the text of `session.toml` and, per run, the text of its CSV (read through a closure so
//! synthetic sessions can be analysed in memory; [`load_dir_reader`] is the file-system one).
//! Out: [`Session`] with SI values and uncertainties; each rig section and each run is validated
//! separately, so a bad `[trifilar]` table or a bad run only fails the runs that need it. The
//! format is specified in `schemas/inertia_session.md`: keys carry their unit as a suffix
//! (`_m`, `_kg`, `_s`, `_deg`, `_kg_m2`, `_n_m`, `_m_s2`); a measured value is a number or
//! `{ v = .., u = .. }` (standard uncertainty, same unit). Unknown keys (including a wrong unit
//! suffix) are errors. Deliberately no unit conversion: a wrong unit is an error, not a guess.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::Measured;
use super::swing::{CorrectionScope, PeriodMethod, SignalKind};
use super::uncertainty::Propagation;

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

const SESSION_FILE: &str = "session.toml";

fn field(key: impl Into<String>, message: impl Into<String>) -> SessionError {
    SessionError::Field {
        path: SESSION_FILE.into(),
        key: key.into(),
        message: message.into(),
    }
}

/// A number, or `{ v, u }`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(untagged)]
enum RawMeasured {
    Bare(f64),
    Full(ValueU),
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
struct ValueU {
    v: f64,
    u: f64,
}

impl RawMeasured {
    fn resolve(self, key: &str) -> Result<Measured, SessionError> {
        let m = match self {
            RawMeasured::Bare(v) => Measured::exact(v),
            RawMeasured::Full(ValueU { v, u }) => Measured::new(v, u),
        };
        if !m.value.is_finite() || !m.u.is_finite() || m.u < 0.0 {
            return Err(field(
                key,
                format!(
                    "value {} with uncertainty {} is not a finite value with u >= 0",
                    m.value, m.u
                ),
            ));
        }
        Ok(m)
    }
    fn positive(self, key: &str) -> Result<Measured, SessionError> {
        let m = self.resolve(key)?;
        if m.value <= 0.0 {
            return Err(field(key, format!("must be > 0, got {}", m.value)));
        }
        Ok(m)
    }
    fn non_negative(self, key: &str) -> Result<Measured, SessionError> {
        let m = self.resolve(key)?;
        if m.value < 0.0 {
            return Err(field(key, format!("must be >= 0, got {}", m.value)));
        }
        Ok(m)
    }
}

/// A measured value or a keyword (`"from_runs"`, `"estimate"`).
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
enum ValueOrKeyword {
    Keyword(String),
    Value(RawMeasured),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSession {
    format: String,
    format_version: u32,
    session: RawInfo,
    site: toml::Value,
    vehicle: Option<toml::Value>,
    sensors: Option<RawSensors>,
    #[serde(default)]
    calibration_body: Vec<toml::Value>,
    yaw_table: Option<toml::Value>,
    trifilar: Option<toml::Value>,
    pendulum: Option<toml::Value>,
    analysis: Option<toml::Value>,
    #[serde(default)]
    run: Vec<toml::Value>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInfo {
    id: String,
    date: Option<toml::value::Datetime>,
    operator: Option<String>,
    vehicle_id: Option<String>,
    vehicle_config: Option<String>,
    notes: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSite {
    g_m_s2: RawMeasured,
    latitude_deg: Option<f64>,
    altitude_m: Option<f64>,
    air_temperature_c: Option<f64>,
    air_pressure_pa: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawVehicle {
    mass_kg: RawMeasured,
    mass_source: Option<String>,
    wheelbase_m: Option<f64>,
    track_front_m: Option<f64>,
    track_rear_m: Option<f64>,
    suspension_locked: Option<bool>,
    reference: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSensors {
    encoder: Option<toml::Value>,
    tilt: Option<toml::Value>,
    rate: Option<toml::Value>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEncoder {
    event_spacing_deg: f64,
    band_width_deg: Option<f64>,
    edges: Option<String>,
    timer_resolution_s: Option<f64>,
    min_events: Option<usize>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTilt {
    kind: Option<String>,
    scale: Option<f64>,
    offset_deg: Option<ValueOrKeyword>,
    noise_deg: Option<f64>,
    mount_below_pivot_m: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRate {
    kind: Option<String>,
    scale: Option<f64>,
    bias_deg_s: Option<ValueOrKeyword>,
    sample_rate_hz: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCalibrationBody {
    id: String,
    mass_kg: RawMeasured,
    inertia_kg_m2: RawMeasured,
    shape: Option<String>,
    radius_m: Option<f64>,
    thickness_m: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawYaw {
    drum_radius_m: RawMeasured,
    radius_includes_string: Option<bool>,
    string_diameter_m: Option<f64>,
    idler_pulley_inertia_kg_m2: Option<RawMeasured>,
    idler_pulley_radius_m: Option<f64>,
    table_inertia_kg_m2: ValueOrKeyword,
    friction_torque_n_m: Option<ValueOrKeyword>,
    drag_mass_kg: Option<RawMeasured>,
    max_drop_m: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTrifilar {
    attach_radius_top_m: RawMeasured,
    attach_radius_bottom_m: RawMeasured,
    vertical_length_m: RawMeasured,
    platform_mass_kg: RawMeasured,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPendulum {
    axis: String,
    pivot: Option<String>,
    knife_tip_radius_m: Option<RawMeasured>,
    pivot_to_deck_m: RawMeasured,
    platform_mass_kg: Option<RawMeasured>,
    added_mass_u_kg: Option<f64>,
    added_position_u_m: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAnalysis {
    period_method: Option<String>,
    amplitude_correction: Option<String>,
    window_cycles: Option<f64>,
    discard_initial_cycles: Option<f64>,
    min_cycles: Option<f64>,
    yaw_model: Option<String>,
    friction_method: Option<String>,
    uncertainty: Option<String>,
    monte_carlo_samples: Option<usize>,
    seed: Option<u64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRun {
    id: String,
    rig: String,
    role: String,
    file: String,
    kind: Option<String>,
    falling_mass_kg: Option<RawMeasured>,
    calibration_body: Option<String>,
    started_from_rest: Option<bool>,
    signal: Option<String>,
    release_amplitude_deg: Option<f64>,
    object: Option<String>,
    object_mass_kg: Option<RawMeasured>,
}

/// Deserialises a section table, naming it in the error.
fn section<T: serde::de::DeserializeOwned>(
    value: &toml::Value,
    name: &str,
) -> Result<T, SessionError> {
    T::deserialize(value.clone())
        .map_err(|e| field(format!("[{name}]"), e.to_string().trim().replace('\n', " ")))
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

/// A validated run entry.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSpec {
    /// Run id.
    pub id: String,
    /// Rig.
    pub rig: Rig,
    /// Role.
    pub role: Role,
    /// CSV path relative to the session directory.
    pub file: String,
    /// Pendulum kind (pendulum runs only).
    pub kind: Option<PendulumKind>,
    /// Falling mass (yaw runs).
    pub falling_mass_kg: Option<Measured>,
    /// Calibration body id (calibration runs).
    pub calibration_body: Option<String>,
    /// Swing signal column.
    pub signal: SignalKind,
    /// Object name for results (default: the session's vehicle id).
    pub object: Option<String>,
    /// Object mass (trifilar vehicle runs; default: `[vehicle] mass_kg`).
    pub object_mass_kg: Option<Measured>,
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
    /// Encoder event spacing (rad) and minimum usable events.
    pub encoder: Result<(f64, usize), SessionError>,
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

fn missing(name: &str) -> SessionError {
    field(
        format!("[{name}]"),
        "section is required by this run but absent",
    )
}

fn choose<T: Copy>(
    key: &str,
    value: Option<&str>,
    default: T,
    options: &[(&str, T)],
) -> Result<T, SessionError> {
    let Some(v) = value else { return Ok(default) };
    options
        .iter()
        .find(|(name, _)| *name == v)
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            let names: Vec<&str> = options.iter().map(|(n, _)| *n).collect();
            field(
                key,
                format!("unknown value {v:?}, expected one of {names:?}"),
            )
        })
}

impl Session {
    /// Parses and validates `session.toml` text. Errors only for problems that affect every run
    /// (syntax, format tag, `[session]`, `[site]`, `[analysis]`); others are kept per section.
    pub fn parse(text: &str) -> Result<Session, SessionError> {
        let raw: RawSession = toml::from_str(text).map_err(|e| SessionError::Toml {
            path: SESSION_FILE.into(),
            message: e.to_string().trim().replace('\n', " "),
        })?;
        if raw.format != "rig-inertia-session" {
            return Err(field(
                "format",
                format!("expected \"rig-inertia-session\", got {:?}", raw.format),
            ));
        }
        if raw.format_version != 1 {
            return Err(field(
                "format_version",
                format!(
                    "unsupported version {} (this tool reads 1)",
                    raw.format_version
                ),
            ));
        }
        let _ = (
            &raw.session.date,
            &raw.session.operator,
            &raw.session.vehicle_config,
            &raw.session.notes,
        );
        let site: RawSite = section(&raw.site, "site")?;
        let _ = (
            site.latitude_deg,
            site.altitude_m,
            site.air_temperature_c,
            site.air_pressure_pa,
        );
        let g = site.g_m_s2.positive("site.g_m_s2")?;
        if !(9.7..=9.9).contains(&g.value) {
            return Err(field(
                "site.g_m_s2",
                format!(
                    "{} m/s^2 is not a terrestrial gravity value (units are m/s^2)",
                    g.value
                ),
            ));
        }
        let analysis = parse_analysis(raw.analysis.as_ref())?;
        let vehicle_mass_kg = match &raw.vehicle {
            None => Err(missing("vehicle")),
            Some(v) => section::<RawVehicle>(v, "vehicle").and_then(|v| {
                let _ = (
                    &v.mass_source,
                    v.wheelbase_m,
                    v.track_front_m,
                    v.track_rear_m,
                    v.suspension_locked,
                    &v.reference,
                );
                v.mass_kg.positive("vehicle.mass_kg")
            }),
        };
        let sensors = raw.sensors.as_ref();
        let encoder = match sensors.and_then(|s| s.encoder.as_ref()) {
            None => Err(missing("sensors.encoder")),
            Some(v) => section::<RawEncoder>(v, "sensors.encoder").and_then(|e| {
                let _ = (e.band_width_deg, e.timer_resolution_s);
                if let Some(edges) = e.edges.as_deref().filter(|s| *s != "rising") {
                    return Err(field(
                        "sensors.encoder.edges",
                        format!("{edges:?} is not supported; only \"rising\" edges are used"),
                    ));
                }
                if !(e.event_spacing_deg > 0.0 && e.event_spacing_deg < 90.0) {
                    return Err(field(
                        "sensors.encoder.event_spacing_deg",
                        format!("must be in (0, 90) degrees, got {}", e.event_spacing_deg),
                    ));
                }
                Ok((
                    e.event_spacing_deg.to_radians(),
                    e.min_events.unwrap_or(10).max(4),
                ))
            }),
        };
        let tilt = parse_tilt(sensors.and_then(|s| s.tilt.as_ref()));
        if let Some(rate) = sensors.and_then(|s| s.rate.as_ref()) {
            let r: RawRate = section(rate, "sensors.rate")?;
            let _ = (&r.kind, r.sample_rate_hz, &r.bias_deg_s);
            if r.scale.is_some_and(|s| (s - 1.0).abs() > 0.0) {
                return Err(field(
                    "sensors.rate.scale",
                    "only scale = 1.0 is supported: store rate_deg_s already scaled",
                ));
            }
        }
        let mut calibration_bodies = BTreeMap::new();
        for (i, body) in raw.calibration_body.iter().enumerate() {
            let parsed = section::<RawCalibrationBody>(body, &format!("calibration_body[{i}]"));
            let id = match &parsed {
                Ok(b) => b.id.clone(),
                Err(_) => format!("calibration_body[{i}]"),
            };
            let value = parsed.and_then(|b| {
                let _ = (&b.shape, b.radius_m, b.thickness_m);
                Ok(CalibrationBody {
                    id: b.id.clone(),
                    mass_kg: b
                        .mass_kg
                        .positive(&format!("calibration_body.{}.mass_kg", b.id))?,
                    inertia_kg_m2: b
                        .inertia_kg_m2
                        .positive(&format!("calibration_body.{}.inertia_kg_m2", b.id))?,
                })
            });
            calibration_bodies.insert(id, value);
        }
        let runs = raw
            .run
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let id = r
                    .get("id")
                    .and_then(|v| v.as_str())
                    .map(str::to_owned)
                    .unwrap_or_else(|| format!("run[{i}]"));
                let spec = section::<RawRun>(r, &format!("run {id}")).and_then(parse_run);
                (id, spec)
            })
            .collect::<Vec<_>>();
        let mut seen = std::collections::BTreeSet::new();
        for (id, _) in &runs {
            if !seen.insert(id.clone()) {
                return Err(field("run.id", format!("duplicate run id {id:?}")));
            }
        }
        Ok(Session {
            id: raw.session.id.clone(),
            vehicle_id: raw
                .session
                .vehicle_id
                .clone()
                .unwrap_or_else(|| "vehicle".into()),
            g_m_s2: g,
            vehicle_mass_kg,
            encoder,
            tilt,
            calibration_bodies,
            yaw_table: raw
                .yaw_table
                .as_ref()
                .map_or(Err(missing("yaw_table")), parse_yaw),
            trifilar: raw
                .trifilar
                .as_ref()
                .map_or(Err(missing("trifilar")), parse_trifilar),
            pendulum: raw
                .pendulum
                .as_ref()
                .map_or(Err(missing("pendulum")), parse_pendulum),
            analysis,
            runs,
        })
    }
}

fn parse_analysis(value: Option<&toml::Value>) -> Result<AnalysisSpec, SessionError> {
    let a: RawAnalysis = match value {
        Some(v) => section(v, "analysis")?,
        None => RawAnalysis::default(),
    };
    let period_method = choose(
        "analysis.period_method",
        a.period_method.as_deref(),
        PeriodMethod::Nls,
        &[
            ("nls", PeriodMethod::Nls),
            ("zero_crossing", PeriodMethod::ZeroCrossing),
        ],
    )?;
    let amplitude_correction = choose(
        "analysis.amplitude_correction",
        a.amplitude_correction.as_deref(),
        AmplitudeCorrection::Auto,
        &[
            ("auto", AmplitudeCorrection::Auto),
            ("none", AmplitudeCorrection::None),
            ("agm_whole", AmplitudeCorrection::AgmWhole),
            ("agm_windowed", AmplitudeCorrection::AgmWindowed),
            ("trifilar", AmplitudeCorrection::Trifilar),
        ],
    )?;
    let yaw_model = choose(
        "analysis.yaw_model",
        a.yaw_model.as_deref(),
        YawModel::Auto,
        &[
            ("const_alpha", YawModel::ConstAlpha),
            ("aero_lncosh", YawModel::AeroLnCosh),
            ("auto", YawModel::Auto),
        ],
    )?;
    let friction_method: Option<FrictionMethod> = choose(
        "analysis.friction_method",
        a.friction_method.as_deref(),
        None,
        &[
            ("auto", None),
            ("given", Some(FrictionMethod::Given)),
            ("drag_mass", Some(FrictionMethod::Given)),
            ("tare_calibration", Some(FrictionMethod::TareCalibration)),
            ("multi_mass", Some(FrictionMethod::MultiMass)),
            (
                "calibration_factor",
                Some(FrictionMethod::CalibrationFactor),
            ),
        ],
    )?;
    let propagation = match a.uncertainty.as_deref() {
        None | Some("linear") => Propagation::Linear,
        Some("monte_carlo") => Propagation::MonteCarlo {
            samples: a.monte_carlo_samples.unwrap_or(2000).max(10),
            seed: a.seed.unwrap_or(0),
        },
        Some(other) => {
            return Err(field(
                "analysis.uncertainty",
                format!("unknown value {other:?}, expected \"linear\" or \"monte_carlo\""),
            ));
        }
    };
    let window_cycles = a.window_cycles.unwrap_or(3.0);
    let min_cycles = a.min_cycles.unwrap_or(10.0);
    let discard = a.discard_initial_cycles.unwrap_or(1.0);
    let below = |v: f64, min: f64| v.is_nan() || v < min;
    if below(window_cycles, 1.0) || below(min_cycles, 2.0) || below(discard, 0.0) {
        return Err(field(
            "analysis",
            "window_cycles >= 1, min_cycles >= 2 and discard_initial_cycles >= 0 are required",
        ));
    }
    Ok(AnalysisSpec {
        period_method,
        amplitude_correction,
        window_cycles,
        discard_initial_cycles: discard,
        min_cycles,
        yaw_model,
        friction_method,
        propagation,
    })
}

impl Session {
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

fn parse_tilt(value: Option<&toml::Value>) -> Result<TiltSensor, SessionError> {
    let t: RawTilt = match value {
        Some(v) => section(v, "sensors.tilt")?,
        None => RawTilt {
            kind: None,
            scale: None,
            offset_deg: None,
            noise_deg: None,
            mount_below_pivot_m: None,
        },
    };
    let _ = (&t.kind, t.mount_below_pivot_m);
    let offset = match t.offset_deg {
        None => TiltOffset::Estimate,
        Some(ValueOrKeyword::Keyword(k)) if k == "estimate" => TiltOffset::Estimate,
        Some(ValueOrKeyword::Keyword(k)) => {
            return Err(field(
                "sensors.tilt.offset_deg",
                format!("unknown keyword {k:?}, expected \"estimate\" or a value"),
            ));
        }
        Some(ValueOrKeyword::Value(v)) => {
            let m = v.resolve("sensors.tilt.offset_deg")?;
            TiltOffset::Known(Measured::new(m.value.to_radians(), m.u.to_radians()))
        }
    };
    let noise = t.noise_deg.unwrap_or(0.0);
    if noise.is_nan() || noise < 0.0 {
        return Err(field(
            "sensors.tilt.noise_deg",
            format!("must be >= 0, got {noise}"),
        ));
    }
    Ok(TiltSensor {
        scale: t.scale.unwrap_or(1.0),
        offset,
        noise_rad: noise.to_radians(),
    })
}

fn keyword_or_value(
    v: ValueOrKeyword,
    key: &str,
    keyword: &str,
) -> Result<Option<Measured>, SessionError> {
    match v {
        ValueOrKeyword::Keyword(k) if k == keyword => Ok(None),
        ValueOrKeyword::Keyword(k) => Err(field(
            key,
            format!("unknown keyword {k:?}, expected {keyword:?} or a value"),
        )),
        ValueOrKeyword::Value(m) => m.non_negative(key).map(Some),
    }
}

fn parse_yaw(value: &toml::Value) -> Result<YawTableSpec, SessionError> {
    let y: RawYaw = section(value, "yaw_table")?;
    let _ = (y.radius_includes_string, y.string_diameter_m);
    let radius = y.drum_radius_m.positive("yaw_table.drum_radius_m")?;
    let i_pu = y
        .idler_pulley_inertia_kg_m2
        .map(|m| m.non_negative("yaw_table.idler_pulley_inertia_kg_m2"))
        .transpose()?;
    let i_eq = match (i_pu, y.idler_pulley_radius_m) {
        (Some(i), Some(r_pu)) if i.value > 0.0 => {
            if r_pu <= 0.0 {
                return Err(field(
                    "yaw_table.idler_pulley_radius_m",
                    "must be > 0 when a pulley inertia is given",
                ));
            }
            let s = (radius.value / r_pu).powi(2);
            Measured::new(i.value * s, i.u * s)
        }
        (Some(i), None) if i.value > 0.0 => {
            return Err(field(
                "yaw_table.idler_pulley_radius_m",
                "required with idler_pulley_inertia_kg_m2",
            ));
        }
        _ => Measured::exact(0.0),
    };
    let table = keyword_or_value(
        y.table_inertia_kg_m2,
        "yaw_table.table_inertia_kg_m2",
        "from_runs",
    )?;
    let drag_mass = y
        .drag_mass_kg
        .map(|m| m.non_negative("yaw_table.drag_mass_kg"))
        .transpose()?;
    let friction = match (y.friction_torque_n_m, y.drag_mass_kg) {
        (Some(_), Some(_)) => {
            return Err(field(
                "yaw_table.drag_mass_kg",
                "give either friction_torque_n_m or drag_mass_kg, not both",
            ));
        }
        (Some(f), None) => keyword_or_value(f, "yaw_table.friction_torque_n_m", "from_runs")?,
        (None, Some(_)) => None,
        (None, None) => None,
    };
    if let Some(d) = y.max_drop_m
        && (d.is_nan() || d <= 0.0)
    {
        {
            return Err(field(
                "yaw_table.max_drop_m",
                format!("must be > 0, got {d}"),
            ));
        }
    }
    Ok(YawTableSpec {
        radius_m: radius,
        i_eq_kg_m2: i_eq,
        table_inertia_kg_m2: table,
        friction_n_m: friction,
        drag_mass_kg: drag_mass,
        max_drop_m: y.max_drop_m,
    })
}

fn parse_trifilar(value: &toml::Value) -> Result<TrifilarSpec, SessionError> {
    let t: RawTrifilar = section(value, "trifilar")?;
    Ok(TrifilarSpec {
        radius_top_m: t
            .attach_radius_top_m
            .positive("trifilar.attach_radius_top_m")?,
        radius_bottom_m: t
            .attach_radius_bottom_m
            .positive("trifilar.attach_radius_bottom_m")?,
        length_m: t.vertical_length_m.positive("trifilar.vertical_length_m")?,
        platform_mass_kg: t.platform_mass_kg.positive("trifilar.platform_mass_kg")?,
    })
}

fn parse_pendulum(value: &toml::Value) -> Result<PendulumSpec, SessionError> {
    let p: RawPendulum = section(value, "pendulum")?;
    let axis = choose(
        "pendulum.axis",
        Some(p.axis.as_str()),
        PendulumAxis::Pitch,
        &[("pitch", PendulumAxis::Pitch), ("roll", PendulumAxis::Roll)],
    )?;
    if let Some(pivot) = p.pivot.as_deref() {
        choose(
            "pendulum.pivot",
            Some(pivot),
            (),
            &[("knife_edge", ()), ("bearing", ()), ("flexure", ())],
        )?;
    }
    if let Some(m) = p.platform_mass_kg {
        m.positive("pendulum.platform_mass_kg")?;
    }
    let u_m = p.added_mass_u_kg.unwrap_or(0.0);
    let u_x = p.added_position_u_m.unwrap_or(0.0);
    if !(u_m >= 0.0 && u_x >= 0.0) {
        return Err(field(
            "pendulum.added_mass_u_kg",
            "uncertainties must be >= 0",
        ));
    }
    Ok(PendulumSpec {
        axis,
        knife_tip_radius_m: p
            .knife_tip_radius_m
            .map(|m| m.non_negative("pendulum.knife_tip_radius_m"))
            .transpose()?
            .unwrap_or(Measured::exact(0.0)),
        pivot_to_deck_m: p.pivot_to_deck_m.positive("pendulum.pivot_to_deck_m")?,
        added_mass_u_kg: u_m,
        added_position_u_m: u_x,
    })
}

fn parse_run(r: RawRun) -> Result<RunSpec, SessionError> {
    // the run id is named by the RunError that carries this message
    let key = |k: &str| k.to_string();
    let rig = choose(
        &key("rig"),
        Some(r.rig.as_str()),
        Rig::YawTable,
        &[
            ("yaw_table", Rig::YawTable),
            ("trifilar", Rig::Trifilar),
            ("pendulum", Rig::Pendulum),
        ],
    )?;
    let role = choose(
        &key("role"),
        Some(r.role.as_str()),
        Role::Tare,
        &[
            ("tare", Role::Tare),
            ("calibration", Role::Calibration),
            ("vehicle", Role::Vehicle),
        ],
    )?;
    let kind = r
        .kind
        .as_deref()
        .map(|k| {
            choose(
                &key("kind"),
                Some(k),
                PendulumKind::Swing,
                &[
                    ("static", PendulumKind::Static),
                    ("swing", PendulumKind::Swing),
                ],
            )
        })
        .transpose()?;
    let signal = choose(
        &key("signal"),
        r.signal.as_deref(),
        SignalKind::Angle,
        &[
            ("angle_deg", SignalKind::Angle),
            ("rate_deg_s", SignalKind::Rate),
        ],
    )?;
    let _ = (r.started_from_rest, r.release_amplitude_deg);
    let falling = r
        .falling_mass_kg
        .map(|m| m.positive(&key("falling_mass_kg")))
        .transpose()?;
    let object_mass = r
        .object_mass_kg
        .map(|m| m.positive(&key("object_mass_kg")))
        .transpose()?;
    match rig {
        Rig::YawTable if falling.is_none() => {
            return Err(field(key("falling_mass_kg"), "required for yaw_table runs"));
        }
        Rig::Pendulum if kind.is_none() => {
            return Err(field(
                key("kind"),
                "required for pendulum runs (\"static\" or \"swing\")",
            ));
        }
        Rig::YawTable | Rig::Trifilar if kind.is_some() => {
            return Err(field(key("kind"), "only pendulum runs have a kind"));
        }
        _ => {}
    }
    if role == Role::Calibration && rig != Rig::YawTable {
        return Err(field(
            key("role"),
            "calibration runs are supported on the yaw table only",
        ));
    }
    if role == Role::Calibration && r.calibration_body.is_none() {
        return Err(field(
            key("calibration_body"),
            "required for calibration runs",
        ));
    }
    if r.file.is_empty() || Path::new(&r.file).is_absolute() || r.file.contains("..") {
        return Err(field(
            key("file"),
            format!(
                "{:?} must be a relative path inside the session directory",
                r.file
            ),
        ));
    }
    Ok(RunSpec {
        id: r.id.clone(),
        rig,
        role,
        file: r.file.clone(),
        kind,
        falling_mass_kg: falling,
        calibration_body: r.calibration_body.clone(),
        signal,
        object: r.object.clone(),
        object_mass_kg: object_mass,
    })
}

/// A CSV table: header plus string cells, with source line numbers for messages.
#[derive(Debug, Clone)]
pub struct CsvTable {
    path: String,
    headers: Vec<String>,
    rows: Vec<(usize, Vec<String>)>,
}

impl CsvTable {
    /// Parses comma-separated text: `#` lines and blank lines are skipped, the first other line
    /// is the header, cells are trimmed; quoted fields are not supported.
    pub fn parse(path: &str, text: &str) -> Result<CsvTable, SessionError> {
        let mut headers: Option<Vec<String>> = None;
        let mut rows = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let trimmed = line.trim();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            let cells: Vec<String> = trimmed.split(',').map(|c| c.trim().to_owned()).collect();
            match &headers {
                None => headers = Some(cells),
                Some(h) if h.len() != cells.len() => {
                    return Err(SessionError::Csv {
                        path: path.into(),
                        line: i + 1,
                        message: format!("expected {} columns, found {}", h.len(), cells.len()),
                    });
                }
                Some(_) => rows.push((i + 1, cells)),
            }
        }
        let headers = headers.ok_or_else(|| SessionError::Csv {
            path: path.into(),
            line: 1,
            message: "no header row".into(),
        })?;
        Ok(CsvTable {
            path: path.into(),
            headers,
            rows,
        })
    }

    /// True when the column exists.
    pub fn has(&self, column: &str) -> bool {
        self.headers.iter().any(|h| h == column)
    }

    /// Number of data rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// True when there are no data rows.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    fn column_index(&self, column: &str) -> Result<usize, SessionError> {
        self.headers
            .iter()
            .position(|h| h == column)
            .ok_or_else(|| SessionError::MissingColumn {
                path: self.path.clone(),
                column: column.into(),
                found: self.headers.join(", "),
            })
    }

    /// A numeric column; errors name the line of a non-numeric or non-finite cell.
    pub fn numeric(&self, column: &str) -> Result<Vec<f64>, SessionError> {
        let k = self.column_index(column)?;
        self.rows
            .iter()
            .map(|(line, cells)| {
                cells[k]
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| SessionError::Csv {
                        path: self.path.clone(),
                        line: *line,
                        message: format!("column {column}: {:?} is not a finite number", cells[k]),
                    })
            })
            .collect()
    }

    /// A text column.
    pub fn text(&self, column: &str) -> Result<Vec<String>, SessionError> {
        let k = self.column_index(column)?;
        Ok(self.rows.iter().map(|(_, c)| c[k].clone()).collect())
    }

    /// A time column that must be strictly increasing.
    pub fn time(&self, column: &str) -> Result<Vec<f64>, SessionError> {
        let t = self.numeric(column)?;
        for (k, w) in t.windows(2).enumerate() {
            if w[1] <= w[0] {
                return Err(SessionError::Csv {
                    path: self.path.clone(),
                    line: self.rows[k + 1].0,
                    message: format!(
                        "{column} is not strictly increasing ({} after {})",
                        w[1], w[0]
                    ),
                });
            }
        }
        Ok(t)
    }

    /// The file label used in messages.
    pub fn path(&self) -> &str {
        &self.path
    }
}

/// A reader of run files relative to a session directory.
pub fn load_dir_reader(dir: &Path) -> impl Fn(&str) -> Result<String, SessionError> + Sync + '_ {
    move |rel: &str| {
        let path: PathBuf = dir.join(rel);
        std::fs::read_to_string(&path).map_err(|e| SessionError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }
}

/// Reads and parses `DIR/session.toml`.
pub fn load_session(dir: &Path) -> Result<Session, SessionError> {
    let path = dir.join(SESSION_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| SessionError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    Session::parse(&text)
}
