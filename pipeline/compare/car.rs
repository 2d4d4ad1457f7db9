//! The car a comparison is for: `car.toml` in, validated [`Car`] out.
//!
//! `config/car.toml` documents every key and *is* the built-in default (embedded at build time),
//! so the reference cannot drift from what runs. Units in the file: N, km/h, deg, kPa; the
//! [`Car`] holds SI [`Conditions`] for the figures plus the allowed pressure range in kPa.
//!
//! Deliberately not here: evaluating anything.

use std::path::Path;

use serde::Deserialize;
use tirebase_core::compare::Conditions;

use crate::config::{TomlFileError, parse_toml, read_toml_text};

/// The built-in car (`config/car.toml`).
pub const DEFAULT_CAR_TOML: &str = include_str!("../../config/car.toml");

/// Where the built-in car comes from, for messages.
pub const DEFAULT_CAR_ORIGIN: &str = "config/car.toml (built in)";

/// Car-file errors; each names the file and the key or line.
#[derive(Debug, thiserror::Error)]
pub enum CarError {
    /// The file could not be read or parsed.
    #[error(transparent)]
    File(#[from] TomlFileError),
    /// A value out of range.
    #[error("{path}: car.{key}: {reason}")]
    Invalid {
        /// The file.
        path: String,
        /// The key under `[car]`.
        key: &'static str,
        /// Why.
        reason: String,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CarFile {
    car: RawCar,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCar {
    name: String,
    loads_n: toml::Value,
    nominal_load_n: f64,
    speed_kph: f64,
    camber_deg: Range,
    pressure_kpa: Range,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Range {
    min: f64,
    max: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LoadRange {
    min: f64,
    max: f64,
    step: f64,
}

/// A validated car.
#[derive(Clone, Debug, PartialEq)]
pub struct Car {
    /// Its name.
    pub name: String,
    /// Where it was read from.
    pub origin: String,
    /// The conditions the figures are evaluated at (SI).
    pub conditions: Conditions,
    /// Allowed nominal inflation pressures, kPa `(min, max)`.
    pub pressure_kpa: (f64, f64),
}

impl Car {
    /// The built-in car.
    pub fn builtin() -> Car {
        Car::parse(DEFAULT_CAR_TOML, DEFAULT_CAR_ORIGIN).expect("config/car.toml is valid")
    }

    /// The car of `path`, or the built-in one.
    pub fn load(path: Option<&Path>) -> Result<Car, CarError> {
        let Some(path) = path else {
            return Ok(Car::builtin());
        };
        let (text, name) = read_toml_text(path)?;
        Car::parse(&text, &name)
    }

    /// Parse and validate `text` (`origin` names it in errors).
    pub fn parse(text: &str, origin: &str) -> Result<Car, CarError> {
        let file: CarFile = parse_toml(text, origin)?;
        let raw = file.car;
        let invalid = |key: &'static str, reason: String| CarError::Invalid {
            path: origin.to_string(),
            key,
            reason,
        };
        let loads_n = loads(&raw.loads_n).map_err(|r| invalid("loads_n", r.to_string()))?;
        let mut whole: Vec<i64> = loads_n.iter().map(|f| f.round() as i64).collect();
        whole.dedup();
        if whole.len() != loads_n.len() {
            return Err(invalid(
                "loads_n",
                format!("loads must differ by at least 1 N: {loads_n:?}"),
            ));
        }
        let positive = |key: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(invalid(key, format!("must be > 0, got {v}")))
            }
        };
        let nominal_load_n = positive("nominal_load_n", raw.nominal_load_n)?;
        let speed_kph = positive("speed_kph", raw.speed_kph)?;
        let ordered = |key: &'static str, r: &Range, lo: f64, hi: f64| {
            if r.min.is_finite()
                && r.max.is_finite()
                && lo <= r.min
                && r.min <= r.max
                && r.max <= hi
            {
                Ok((r.min, r.max))
            } else {
                Err(invalid(
                    key,
                    format!(
                        "need {lo} <= min <= max <= {hi}, got min = {}, max = {}",
                        r.min, r.max
                    ),
                ))
            }
        };
        let camber = ordered("camber_deg", &raw.camber_deg, 0.0, 15.0)?;
        let pressure_kpa = ordered("pressure_kpa", &raw.pressure_kpa, 0.0, 1000.0)?;
        let conditions = Conditions {
            loads_n,
            nominal_load_n,
            speed_mps: speed_kph / 3.6,
            camber_rad: (camber.0.to_radians(), camber.1.to_radians()),
        };
        conditions
            .validate()
            .map_err(|e| invalid("loads_n", e.to_string()))?;
        Ok(Car {
            name: raw.name,
            origin: origin.to_string(),
            conditions,
            pressure_kpa,
        })
    }

    /// The corner loads in whole newtons (the per-load column names).
    pub fn loads_whole_n(&self) -> Vec<i64> {
        self.conditions
            .loads_n
            .iter()
            .map(|f| f.round() as i64)
            .collect()
    }

    /// One line describing the conditions.
    pub fn describe(&self) -> String {
        let c = &self.conditions;
        let loads: Vec<String> = self.loads_whole_n().iter().map(|l| l.to_string()).collect();
        format!(
            "{}: corner loads {} N, nominal {:.0} N, {:.0} km/h, camber {:.1}..{:.1} deg, pressures {:.0}..{:.0} kPa ({})",
            self.name,
            loads.join(", "),
            c.nominal_load_n,
            c.speed_mps * 3.6,
            c.camber_rad.0.to_degrees(),
            c.camber_rad.1.to_degrees(),
            self.pressure_kpa.0,
            self.pressure_kpa.1,
            self.origin
        )
    }
}

/// Why `loads_n` is not a list of loads.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum LoadsError {
    #[error("not a number: {0}")]
    NotANumber(String),
    #[error("{0}")]
    Range(String),
    #[error("range needs min <= max and step > 0, got min = {min}, max = {max}, step = {step}")]
    BadRange { min: f64, max: f64, step: f64 },
    #[error("{0} loads: at most 50")]
    TooMany(usize),
    #[error("a list of loads or {{ min, max, step }}, got {0}")]
    NotLoads(String),
    #[error("no load given")]
    Empty,
}

/// `loads_n` as a list or a `{ min, max, step }` range (max included when a step lands on it).
fn loads(value: &toml::Value) -> Result<Vec<f64>, LoadsError> {
    let loads = match value {
        toml::Value::Array(items) => items
            .iter()
            .map(|v| match v {
                toml::Value::Float(f) => Ok(*f),
                toml::Value::Integer(i) => Ok(*i as f64),
                other => Err(LoadsError::NotANumber(other.to_string())),
            })
            .collect::<Result<Vec<f64>, LoadsError>>()?,
        toml::Value::Table(_) => {
            let r: LoadRange = value
                .clone()
                .try_into()
                .map_err(|e: toml::de::Error| LoadsError::Range(e.message().to_string()))?;
            if !(r.min.is_finite() && r.max >= r.min && r.step > 0.0) {
                return Err(LoadsError::BadRange {
                    min: r.min,
                    max: r.max,
                    step: r.step,
                });
            }
            let n = ((r.max - r.min) / r.step + 1e-9).floor() as usize + 1;
            if n > 50 {
                return Err(LoadsError::TooMany(n));
            }
            (0..n).map(|i| r.min + i as f64 * r.step).collect()
        }
        other => return Err(LoadsError::NotLoads(other.to_string())),
    };
    if loads.is_empty() {
        return Err(LoadsError::Empty);
    }
    Ok(loads)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_car_is_the_documented_one() {
        let car = Car::builtin();
        assert_eq!(car.loads_whole_n(), vec![350, 700, 1050]);
        assert_eq!(car.conditions.nominal_load_n, 700.0);
        assert!((car.conditions.speed_mps - 40.0 / 3.6).abs() < 1e-12);
        assert_eq!(car.pressure_kpa, (55.0, 97.0));
        assert!((car.conditions.camber_rad.1 - 4f64.to_radians()).abs() < 1e-12);
    }

    fn with(key_line: &str) -> String {
        DEFAULT_CAR_TOML
            .lines()
            .map(|l| {
                let key = key_line.split('=').next().unwrap().trim();
                if l.starts_with(&format!("{key} ")) {
                    key_line.to_string()
                } else {
                    l.to_string()
                }
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    #[test]
    fn a_load_range_expands_with_its_end() {
        let car = Car::parse(
            &with("loads_n = { min = 300.0, max = 1100.0, step = 200.0 }"),
            "x",
        )
        .unwrap();
        assert_eq!(car.loads_whole_n(), vec![300, 500, 700, 900, 1100]);
    }

    #[test]
    fn bad_values_name_the_key_and_file() {
        for (line, key) in [
            ("loads_n = [700.0, 350.0]", "loads_n"),
            ("loads_n = [350.0, 350.4]", "loads_n"),
            (
                "loads_n = { min = 300.0, max = 100.0, step = 200.0 }",
                "loads_n",
            ),
            ("nominal_load_n = -1.0", "nominal_load_n"),
            ("speed_kph = 0.0", "speed_kph"),
            ("camber_deg = { min = 3.0, max = 1.0 }", "camber_deg"),
            ("pressure_kpa = { min = 90.0, max = 60.0 }", "pressure_kpa"),
        ] {
            let err = Car::parse(&with(line), "my_car.toml")
                .unwrap_err()
                .to_string();
            assert!(
                err.starts_with("my_car.toml: ") && err.contains(key),
                "{line}: {err}"
            );
        }
        let err = Car::parse(&format!("{DEFAULT_CAR_TOML}\nmass_kg = 3\n"), "c.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("c.toml") && err.contains("mass_kg"), "{err}");
        let err = Car::parse("[car]\nname = \"x\"\n", "c.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("missing field"), "{err}");
    }
}
