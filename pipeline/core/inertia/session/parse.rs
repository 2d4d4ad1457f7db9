//! Parsing: the text of `session.toml` and of run CSV files into raw records, before any check.
//!
//! In: file text. Out: [`RawSession`] (the TOML tables as typed records: every key and its type,
//! unknown keys refused, no range or consistency checks) and [`CsvTable`] (header and cells of a
//! run file, with source line numbers). Deliberately no validation: ranges, units, defaults and
//! cross-references are [`super::validate`]'s.

use serde::Deserialize;

use super::{SESSION_FILE, SessionError, field};

/// A number, or `{ v, u }`.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(untagged)]
pub(super) enum RawMeasured {
    Bare(f64),
    Full(ValueU),
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ValueU {
    pub(super) v: f64,
    pub(super) u: f64,
}

/// A measured value or a keyword (`"from_runs"`, `"estimate"`).
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub(super) enum ValueOrKeyword {
    Keyword(String),
    Value(RawMeasured),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSession {
    pub(super) format: String,
    pub(super) format_version: u32,
    pub(super) session: RawInfo,
    pub(super) site: toml::Value,
    pub(super) vehicle: Option<toml::Value>,
    pub(super) sensors: Option<RawSensors>,
    #[serde(default)]
    pub(super) calibration_body: Vec<toml::Value>,
    pub(super) yaw_table: Option<toml::Value>,
    pub(super) trifilar: Option<toml::Value>,
    pub(super) pendulum: Option<toml::Value>,
    pub(super) analysis: Option<toml::Value>,
    #[serde(default)]
    pub(super) run: Vec<toml::Value>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawInfo {
    pub(super) id: String,
    pub(super) date: Option<toml::value::Datetime>,
    pub(super) operator: Option<String>,
    pub(super) vehicle_id: Option<String>,
    pub(super) vehicle_config: Option<String>,
    pub(super) notes: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSite {
    pub(super) g_m_s2: RawMeasured,
    pub(super) latitude_deg: Option<f64>,
    pub(super) altitude_m: Option<f64>,
    pub(super) air_temperature_c: Option<f64>,
    pub(super) air_pressure_pa: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawVehicle {
    pub(super) mass_kg: RawMeasured,
    pub(super) mass_source: Option<String>,
    pub(super) wheelbase_m: Option<f64>,
    pub(super) track_front_m: Option<f64>,
    pub(super) track_rear_m: Option<f64>,
    pub(super) suspension_locked: Option<bool>,
    pub(super) reference: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSensors {
    pub(super) encoder: Option<toml::Value>,
    pub(super) tilt: Option<toml::Value>,
    pub(super) rate: Option<toml::Value>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawEncoder {
    pub(super) event_spacing_deg: f64,
    pub(super) band_width_deg: Option<f64>,
    pub(super) edges: Option<String>,
    pub(super) timer_resolution_s: Option<f64>,
    pub(super) min_events: Option<usize>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTilt {
    pub(super) kind: Option<String>,
    pub(super) scale: Option<f64>,
    pub(super) offset_deg: Option<ValueOrKeyword>,
    pub(super) noise_deg: Option<f64>,
    pub(super) mount_below_pivot_m: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRate {
    pub(super) kind: Option<String>,
    pub(super) scale: Option<f64>,
    pub(super) bias_deg_s: Option<ValueOrKeyword>,
    pub(super) sample_rate_hz: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCalibrationBody {
    pub(super) id: String,
    pub(super) mass_kg: RawMeasured,
    pub(super) inertia_kg_m2: RawMeasured,
    pub(super) shape: Option<String>,
    pub(super) radius_m: Option<f64>,
    pub(super) thickness_m: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawYaw {
    pub(super) drum_radius_m: RawMeasured,
    pub(super) radius_includes_string: Option<bool>,
    pub(super) string_diameter_m: Option<f64>,
    pub(super) idler_pulley_inertia_kg_m2: Option<RawMeasured>,
    pub(super) idler_pulley_radius_m: Option<f64>,
    pub(super) table_inertia_kg_m2: ValueOrKeyword,
    pub(super) friction_torque_n_m: Option<ValueOrKeyword>,
    pub(super) drag_mass_kg: Option<RawMeasured>,
    pub(super) max_drop_m: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTrifilar {
    pub(super) attach_radius_top_m: RawMeasured,
    pub(super) attach_radius_bottom_m: RawMeasured,
    pub(super) vertical_length_m: RawMeasured,
    pub(super) platform_mass_kg: RawMeasured,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPendulum {
    pub(super) axis: String,
    pub(super) pivot: Option<String>,
    pub(super) knife_tip_radius_m: Option<RawMeasured>,
    pub(super) pivot_to_deck_m: RawMeasured,
    pub(super) platform_mass_kg: Option<RawMeasured>,
    pub(super) added_mass_u_kg: Option<f64>,
    pub(super) added_position_u_m: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawAnalysis {
    pub(super) period_method: Option<String>,
    pub(super) amplitude_correction: Option<String>,
    pub(super) window_cycles: Option<f64>,
    pub(super) discard_initial_cycles: Option<f64>,
    pub(super) min_cycles: Option<f64>,
    pub(super) yaw_model: Option<String>,
    pub(super) friction_method: Option<String>,
    pub(super) uncertainty: Option<String>,
    pub(super) monte_carlo_samples: Option<usize>,
    pub(super) seed: Option<u64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRun {
    pub(super) id: String,
    pub(super) rig: String,
    pub(super) role: String,
    pub(super) file: String,
    pub(super) kind: Option<String>,
    pub(super) falling_mass_kg: Option<RawMeasured>,
    pub(super) calibration_body: Option<String>,
    pub(super) started_from_rest: Option<bool>,
    pub(super) signal: Option<String>,
    pub(super) release_amplitude_deg: Option<f64>,
    pub(super) object: Option<String>,
    pub(super) object_mass_kg: Option<RawMeasured>,
}

impl RawSession {
    /// Parses `session.toml` text; the error names the file and the TOML problem on one line.
    pub(super) fn from_toml(text: &str) -> Result<RawSession, SessionError> {
        toml::from_str(text).map_err(|e| SessionError::Toml {
            path: SESSION_FILE.into(),
            message: e.to_string().trim().replace('\n', " "),
        })
    }
}

/// Deserialises a section table, naming it in the error.
pub(super) fn section<T: serde::de::DeserializeOwned>(
    value: &toml::Value,
    name: &str,
) -> Result<T, SessionError> {
    T::deserialize(value.clone())
        .map_err(|e| field(format!("[{name}]"), e.to_string().trim().replace('\n', " ")))
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
