//! Validation: raw session records into a [`Session`] with SI values and uncertainties.
//!
//! In: a [`RawSession`] from [`super::parse`]. Out: [`Session`], or an error for the problems
//! that affect every run (format tag and version, `[site]`, `[analysis]`, `[sensors.rate]`,
//! duplicate run ids). Each rig section, sensor, calibration body and run keeps its own result,
//! so a bad `[trifilar]` table or a bad run only fails the runs that need it. Ranges are checked
//! here (positive lengths and masses, finite values, `u >= 0`, terrestrial `g`); degrees become
//! radians. Deliberately no file access and no unit conversion (a wrong unit is an error).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use super::parse::{
    RawAnalysis, RawCalibrationBody, RawEncoder, RawMeasured, RawPendulum, RawRate, RawRun,
    RawSession, RawSite, RawTilt, RawTrifilar, RawVehicle, RawYaw, ValueOrKeyword, ValueU, section,
};
use super::{
    AmplitudeCorrection, AnalysisSpec, CalibrationBody, EncoderSpec, FrictionMethod, PendulumAxis,
    PendulumKind, PendulumSpec, Rig, Role, RunSetup, RunSpec, Session, SessionError, TiltOffset,
    TiltSensor, TrifilarSpec, YawModel, YawTableSpec, field,
};
use crate::inertia::Measured;
use crate::inertia::swing::{PeriodMethod, SignalKind};
use crate::inertia::uncertainty::Propagation;

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

/// The error of a rig section or sensor that a run needs but the session does not have.
fn missing(name: &str) -> SessionError {
    field(
        format!("[{name}]"),
        "section is required by this run but absent",
    )
}

/// The option named `value` (or `default` when absent); an unknown name lists the valid ones.
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

/// A whole session: the checks that fail every run first, then each section on its own.
pub(super) fn session(raw: RawSession) -> Result<Session, SessionError> {
    format_tag(&raw)?;
    let _ = (
        &raw.session.date,
        &raw.session.operator,
        &raw.session.vehicle_config,
        &raw.session.notes,
    );
    let g_m_s2 = gravity(&raw.site)?;
    let analysis = analysis(raw.analysis.as_ref())?;
    let vehicle_mass_kg = raw
        .vehicle
        .as_ref()
        .map_or(Err(missing("vehicle")), vehicle_mass);
    let sensors = raw.sensors.as_ref();
    let encoder = sensors
        .and_then(|s| s.encoder.as_ref())
        .map_or(Err(missing("sensors.encoder")), encoder);
    let tilt = tilt(sensors.and_then(|s| s.tilt.as_ref()));
    if let Some(value) = sensors.and_then(|s| s.rate.as_ref()) {
        rate_sensor(value)?;
    }
    let calibration_bodies = calibration_bodies(&raw.calibration_body);
    let runs = runs(&raw.run)?;
    Ok(Session {
        id: raw.session.id.clone(),
        vehicle_id: raw
            .session
            .vehicle_id
            .clone()
            .unwrap_or_else(|| "vehicle".into()),
        g_m_s2,
        vehicle_mass_kg,
        encoder,
        tilt,
        calibration_bodies,
        yaw_table: raw
            .yaw_table
            .as_ref()
            .map_or(Err(missing("yaw_table")), yaw_table),
        trifilar: raw
            .trifilar
            .as_ref()
            .map_or(Err(missing("trifilar")), trifilar),
        pendulum: raw
            .pendulum
            .as_ref()
            .map_or(Err(missing("pendulum")), pendulum),
        analysis,
        runs,
    })
}

/// `format = "rig-inertia-session"`, `format_version = 1`.
fn format_tag(raw: &RawSession) -> Result<(), SessionError> {
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
    Ok(())
}

/// `[site] g_m_s2`: positive and terrestrial (a value in other units is refused).
fn gravity(value: &toml::Value) -> Result<Measured, SessionError> {
    let site: RawSite = section(value, "site")?;
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
    Ok(g)
}

/// `[vehicle] mass_kg`.
fn vehicle_mass(value: &toml::Value) -> Result<Measured, SessionError> {
    let v: RawVehicle = section(value, "vehicle")?;
    let _ = (
        &v.mass_source,
        v.wheelbase_m,
        v.track_front_m,
        v.track_rear_m,
        v.suspension_locked,
        &v.reference,
    );
    v.mass_kg.positive("vehicle.mass_kg")
}

/// `[sensors.encoder]`: rising edges only, spacing in (0, 90) degrees, at least 4 events.
fn encoder(value: &toml::Value) -> Result<EncoderSpec, SessionError> {
    let e: RawEncoder = section(value, "sensors.encoder")?;
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
    Ok(EncoderSpec {
        spacing_rad: e.event_spacing_deg.to_radians(),
        min_events: e.min_events.unwrap_or(10).max(4),
    })
}

/// `[sensors.rate]`: only a rate already scaled is accepted.
fn rate_sensor(value: &toml::Value) -> Result<(), SessionError> {
    let r: RawRate = section(value, "sensors.rate")?;
    let _ = (&r.kind, r.sample_rate_hz, &r.bias_deg_s);
    if r.scale.is_some_and(|s| (s - 1.0).abs() > 0.0) {
        return Err(field(
            "sensors.rate.scale",
            "only scale = 1.0 is supported: store rate_deg_s already scaled",
        ));
    }
    Ok(())
}

/// Every `[[calibration_body]]` by id (`calibration_body[i]` when the table has no usable id).
fn calibration_bodies(
    values: &[toml::Value],
) -> BTreeMap<String, Result<CalibrationBody, SessionError>> {
    let mut bodies = BTreeMap::new();
    for (i, body) in values.iter().enumerate() {
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
        bodies.insert(id, value);
    }
    bodies
}

/// Every `[[run]]` in file order with its own result; a run id used twice fails the session.
#[allow(clippy::type_complexity)]
fn runs(
    values: &[toml::Value],
) -> Result<Vec<(String, Result<RunSpec, SessionError>)>, SessionError> {
    let runs = values
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let id = r
                .get("id")
                .and_then(|v| v.as_str())
                .map(str::to_owned)
                .unwrap_or_else(|| format!("run[{i}]"));
            let spec = section::<RawRun>(r, &format!("run {id}")).and_then(run);
            (id, spec)
        })
        .collect::<Vec<_>>();
    let mut seen = BTreeSet::new();
    for (id, _) in &runs {
        if !seen.insert(id.clone()) {
            return Err(field("run.id", format!("duplicate run id {id:?}")));
        }
    }
    Ok(runs)
}

/// `[analysis]`: estimator choices with their defaults, window settings in range.
fn analysis(value: Option<&toml::Value>) -> Result<AnalysisSpec, SessionError> {
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

/// `[sensors.tilt]` (defaults when absent: scale 1, offset estimated, no declared noise).
fn tilt(value: Option<&toml::Value>) -> Result<TiltSensor, SessionError> {
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

/// A value, or `None` for the keyword that asks for it to be identified.
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

/// `[yaw_table]`: drum radius, reflected idler-pulley inertia, table inertia and friction.
fn yaw_table(value: &toml::Value) -> Result<YawTableSpec, SessionError> {
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
        (None, _) => None,
    };
    if let Some(d) = y.max_drop_m
        && (d.is_nan() || d <= 0.0)
    {
        return Err(field(
            "yaw_table.max_drop_m",
            format!("must be > 0, got {d}"),
        ));
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

/// `[trifilar]`: attachment radii, wire length and platform mass, all positive.
fn trifilar(value: &toml::Value) -> Result<TrifilarSpec, SessionError> {
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

/// `[pendulum]`: axis, pivot geometry and the uncertainties of added masses.
fn pendulum(value: &toml::Value) -> Result<PendulumSpec, SessionError> {
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

/// One `[[run]]`. Its keys are named without the run id: the [`crate::inertia::InertiaRunError`] that
/// carries the message names the run.
fn run(r: RawRun) -> Result<RunSpec, SessionError> {
    let rig = choose(
        "rig",
        Some(r.rig.as_str()),
        Rig::YawTable,
        &[
            ("yaw_table", Rig::YawTable),
            ("trifilar", Rig::Trifilar),
            ("pendulum", Rig::Pendulum),
        ],
    )?;
    let role = choose(
        "role",
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
                "kind",
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
        "signal",
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
        .map(|m| m.positive("falling_mass_kg"))
        .transpose()?;
    let object_mass = r
        .object_mass_kg
        .map(|m| m.positive("object_mass_kg"))
        .transpose()?;
    let setup = match (rig, kind, falling) {
        (Rig::YawTable, None, Some(falling_mass_kg)) => RunSetup::YawTable { falling_mass_kg },
        (Rig::YawTable, _, None) => {
            return Err(field("falling_mass_kg", "required for yaw_table runs"));
        }
        (Rig::Pendulum, None, _) => {
            return Err(field(
                "kind",
                "required for pendulum runs (\"static\" or \"swing\")",
            ));
        }
        (Rig::YawTable | Rig::Trifilar, Some(_), _) => {
            return Err(field("kind", "only pendulum runs have a kind"));
        }
        (Rig::Trifilar, None, _) => RunSetup::Trifilar { signal },
        (Rig::Pendulum, Some(kind), _) => RunSetup::Pendulum { kind, signal },
    };
    if role == Role::Calibration && rig != Rig::YawTable {
        return Err(field(
            "role",
            "calibration runs are supported on the yaw table only",
        ));
    }
    if role == Role::Calibration && r.calibration_body.is_none() {
        return Err(field("calibration_body", "required for calibration runs"));
    }
    if r.file.is_empty() || Path::new(&r.file).is_absolute() || r.file.contains("..") {
        return Err(field(
            "file",
            format!(
                "{:?} must be a relative path inside the session directory",
                r.file
            ),
        ));
    }
    Ok(RunSpec {
        id: r.id,
        role,
        file: r.file,
        setup,
        calibration_body: r.calibration_body,
        object: r.object,
        object_mass_kg: object_mass,
    })
}
