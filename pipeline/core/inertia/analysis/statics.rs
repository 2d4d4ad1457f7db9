//! Static tilt tests of the compound pendulum: the configurations of a run file, and their
//! readings and added masses as propagation inputs.
//!
//! In: a static run's CSV (`config`, `added_mass_kg`, `x_m`, `y_m`, `tilt_deg`, optional
//! `tilt_sd_deg`) and the tilt sensor. Out: [`StaticConfig`]s (one per configuration name, in
//! file order), the [`TiltConfig`]s the first-moment solver takes, and the same as named
//! [`Inputs`] so a propagated computation can rebuild them from perturbed values.

use super::AnalysisError;
use crate::inertia::Measured;
use crate::inertia::pendulum::{TiltConfig, ZeroOffset};
use crate::inertia::session::{CsvTable, PendulumSpec, TiltOffset, TiltSensor};
use crate::inertia::uncertainty::{Input, Inputs};

/// A mass added to the platform for one configuration.
#[derive(Debug, Clone, Copy)]
pub(super) struct AddedMass {
    pub mass_kg: f64,
    pub x_m: f64,
    pub y_m: f64,
}

/// One static-tilt configuration as read: added masses and the reading.
#[derive(Debug, Clone)]
pub(super) struct StaticConfig {
    pub masses: Vec<AddedMass>,
    pub reading_rad: f64,
    pub u_reading_rad: f64,
}

/// The configurations of a static run file, in order of first appearance. Rows of one
/// configuration must agree on the reading; a row with zero added mass only names the reading.
pub(super) fn read_configs(
    file: &str,
    table: &CsvTable,
    tilt: &TiltSensor,
) -> Result<Vec<StaticConfig>, AnalysisError> {
    let names = table.text("config")?;
    let dm = table.numeric("added_mass_kg")?;
    let xs = table.numeric("x_m")?;
    let ys = table.numeric("y_m")?;
    let tilt_deg = table.numeric("tilt_deg")?;
    let sd = if table.has("tilt_sd_deg") {
        Some(table.numeric("tilt_sd_deg")?)
    } else {
        None
    };
    let mut order: Vec<String> = Vec::new();
    let mut configs: Vec<StaticConfig> = Vec::new();
    for i in 0..names.len() {
        if dm[i] < 0.0 {
            return Err(AnalysisError::NegativeAddedMass {
                file: file.into(),
                row: i + 1,
                config: names[i].clone(),
                mass_kg: dm[i],
            });
        }
        let reading = tilt.scale * tilt_deg[i].to_radians();
        let u = sd.as_ref().map_or(tilt.noise_rad, |s| s[i].to_radians());
        let k = match order.iter().position(|n| *n == names[i]) {
            Some(k) => {
                if (configs[k].reading_rad - reading).abs() > 1e-12 {
                    return Err(AnalysisError::InconsistentTilt {
                        file: file.into(),
                        config: names[i].clone(),
                    });
                }
                k
            }
            None => {
                order.push(names[i].clone());
                configs.push(StaticConfig {
                    masses: Vec::new(),
                    reading_rad: reading,
                    u_reading_rad: u,
                });
                configs.len() - 1
            }
        };
        if dm[i] > 0.0 {
            configs[k].masses.push(AddedMass {
                mass_kg: dm[i],
                x_m: xs[i],
                y_m: ys[i],
            });
        }
    }
    Ok(configs)
}

/// The solver's view of the configurations at their read values.
pub(super) fn tilt_configs(configs: &[StaticConfig]) -> Vec<TiltConfig> {
    configs
        .iter()
        .map(|c| TiltConfig {
            added_sx_kg_m: c.masses.iter().map(|m| m.mass_kg * m.x_m).sum(),
            added_sy_kg_m: c.masses.iter().map(|m| m.mass_kg * m.y_m).sum(),
            reading_rad: c.reading_rad,
        })
        .collect()
}

/// The inputs of one added mass.
struct MassInputs {
    mass: Input,
    x: Input,
    y: Input,
}

/// The inputs of one configuration: its reading, then each added mass.
pub(super) struct ConfigInputs {
    reading: Input,
    masses: Vec<MassInputs>,
}

/// Adds every configuration's reading and added masses (with the pendulum's declared mass and
/// position uncertainties) to `inputs`.
pub(super) fn add_inputs(
    inputs: &mut Inputs,
    configs: &[StaticConfig],
    pendulum: &PendulumSpec,
) -> Vec<ConfigInputs> {
    let (u_mass, u_pos) = (pendulum.added_mass_u_kg, pendulum.added_position_u_m);
    configs
        .iter()
        .map(|c| ConfigInputs {
            reading: inputs.add(Measured::new(c.reading_rad, c.u_reading_rad)),
            masses: c
                .masses
                .iter()
                .map(|m| MassInputs {
                    mass: inputs.add(Measured::new(m.mass_kg, u_mass)),
                    x: inputs.add(Measured::new(m.x_m, u_pos)),
                    y: inputs.add(Measured::new(m.y_m, u_pos)),
                })
                .collect(),
        })
        .collect()
}

/// The solver's view of the configurations at the input values `x`.
pub(super) fn tilt_configs_at(handles: &[ConfigInputs], x: &[f64]) -> Vec<TiltConfig> {
    handles
        .iter()
        .map(|c| {
            let (mut sx, mut sy) = (0.0, 0.0);
            for m in &c.masses {
                sx += m.mass.of(x) * m.x.of(x);
                sy += m.mass.of(x) * m.y.of(x);
            }
            TiltConfig {
                added_sx_kg_m: sx,
                added_sy_kg_m: sy,
                reading_rad: c.reading.of(x),
            }
        })
        .collect()
}

/// The inclinometer offset as an input: the known offset, or an exact 0 when it is estimated.
pub(super) fn offset_input(tilt: Option<&TiltSensor>) -> Measured {
    match tilt.map(|t| t.offset) {
        Some(TiltOffset::Known(m)) => m,
        _ => Measured::exact(0.0),
    }
}

/// How the solver treats the offset: known (at its read value) or estimated.
pub(super) fn zero_offset(tilt: Option<&TiltSensor>) -> ZeroOffset {
    match tilt.map(|t| t.offset) {
        Some(TiltOffset::Known(m)) => ZeroOffset::Known(m.value),
        _ => ZeroOffset::Estimate,
    }
}

/// `offset` with a known value replaced by `value` (an estimated offset stays estimated).
pub(super) fn zero_offset_at(offset: ZeroOffset, value: f64) -> ZeroOffset {
    match offset {
        ZeroOffset::Estimate => ZeroOffset::Estimate,
        ZeroOffset::Known(_) => ZeroOffset::Known(value),
    }
}
