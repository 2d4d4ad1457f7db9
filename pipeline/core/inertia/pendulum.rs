//! Compound (stable) pendulum on a knife edge: first moment and CG from static tilt, inertia from
//! the swing period, platform tare and the parallel-axis step (methods section 4).
//!
//! Body frame: origin on the pivot axis, x along the platform, y downward when level; tilt
//! positive when the +x end rises. In: static configurations (added first moment and inclinometer
//! reading each), the swing periods, masses and the pivot-to-deck distance. Out: the first
//! moment `S = (S_x, S_y)` (kg m) and inclinometer zero offset, pivot inertia
//! `g |S| T^2 / (4 pi^2)`, and the vehicle's CG (`x_cg = S_x,veh / m`, `z_cg = d_deck - S_y,veh / m`)
//! and inertia about its CG `I_p,veh - |S_veh|^2 / m_veh`. Deliberately no air added-mass model.

use nalgebra::{DMatrix, DVector};

use super::MethodError;
use crate::numerics::least_squares;
use crate::numerics::nonlinear_least_squares::{Bounds, LeastSquaresProblem, Options, minimize};

/// One static configuration: the summed first moment of the masses added in it and the tilt read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TiltConfig {
    /// Added first moment along x, `sum dm x` (kg m).
    pub added_sx_kg_m: f64,
    /// Added first moment along y (down), `sum dm y` (kg m).
    pub added_sy_kg_m: f64,
    /// Inclinometer reading (rad), including its unknown zero offset.
    pub reading_rad: f64,
}

/// How the inclinometer zero is treated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ZeroOffset {
    /// Fit it as a third unknown (needs >= 3 configurations).
    Estimate,
    /// Known offset (rad), subtracted from every reading.
    Known(f64),
}

/// First moment of the swinging body from a static test.
#[derive(Debug, Clone, PartialEq)]
pub struct FirstMoment {
    /// `S_x` (kg m).
    pub sx_kg_m: f64,
    /// `S_y` (kg m), positive when the CG is below the pivot.
    pub sy_kg_m: f64,
    /// Inclinometer zero offset (rad), fitted or as given.
    pub offset_rad: f64,
    /// RMS tilt residual (rad).
    pub residual_rms_rad: f64,
    /// Configurations used.
    pub configs: usize,
}

impl FirstMoment {
    /// `|S|` (kg m).
    pub fn magnitude(&self) -> f64 {
        self.sx_kg_m.hypot(self.sy_kg_m)
    }
}

/// Predicted reading of a configuration: `atan2(-(S_x + s_x), S_y + s_y) + offset`.
pub fn predicted_reading(sx: f64, sy: f64, offset: f64, c: &TiltConfig) -> f64 {
    (-(sx + c.added_sx_kg_m)).atan2(sy + c.added_sy_kg_m) + offset
}

struct Static<'a> {
    configs: &'a [TiltConfig],
    known_offset: Option<f64>,
}

impl Static<'_> {
    fn unpack(&self, p: &[f64]) -> (f64, f64, f64) {
        (p[0], p[1], self.known_offset.unwrap_or_else(|| p[2]))
    }
}

impl LeastSquaresProblem for Static<'_> {
    fn n_params(&self) -> usize {
        if self.known_offset.is_some() { 2 } else { 3 }
    }
    fn n_residuals(&self) -> usize {
        self.configs.len()
    }
    fn residuals(&self, p: &[f64], r: &mut [f64]) {
        let (sx, sy, off) = self.unpack(p);
        for (ri, c) in r.iter_mut().zip(self.configs) {
            *ri = predicted_reading(sx, sy, off, c) - c.reading_rad;
        }
    }
    fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
        self.residuals(p, r);
        let (sx, sy, _) = self.unpack(p);
        for (c, row) in self.configs.iter().zip(jac.chunks_exact_mut(p.len())) {
            let (x, y) = (sx + c.added_sx_kg_m, sy + c.added_sy_kg_m);
            let r2 = x * x + y * y;
            row[0] = -y / r2;
            row[1] = x / r2;
            if let Some(offset) = row.get_mut(2) {
                *offset = 1.0;
            }
        }
    }
}

/// Least-squares first moment (and zero offset) from static tilt configurations: linear LS with
/// the offset at its start value seeds a Gauss-Newton/LM refinement (2 to 3 iterations).
pub fn solve_first_moment(
    configs: &[TiltConfig],
    offset: ZeroOffset,
) -> Result<FirstMoment, MethodError> {
    let needed = if matches!(offset, ZeroOffset::Estimate) {
        3
    } else {
        2
    };
    if configs.len() < needed {
        return Err(MethodError::StaticUnderdetermined {
            reason: format!("{} configurations, need at least {needed}", configs.len()),
        });
    }
    let distinct = configs
        .iter()
        .filter(|c| (c.added_sx_kg_m - configs[0].added_sx_kg_m).abs() > 1e-9)
        .count();
    if distinct == 0 {
        return Err(MethodError::StaticUnderdetermined {
            reason: "every configuration adds the same x first moment".into(),
        });
    }
    let off0 = match offset {
        ZeroOffset::Known(o) => o,
        ZeroOffset::Estimate => 0.0,
    };
    // (S_x + s_x) cos th + (S_y + s_y) sin th = 0, th = reading - offset
    let design = DMatrix::from_fn(configs.len(), 2, |i, k| {
        let th = configs[i].reading_rad - off0;
        if k == 0 { th.cos() } else { th.sin() }
    });
    let rhs = DVector::from_iterator(
        configs.len(),
        configs.iter().map(|c| {
            let th = c.reading_rad - off0;
            -(c.added_sx_kg_m * th.cos() + c.added_sy_kg_m * th.sin())
        }),
    );
    let lin = least_squares::solve(&design, &rhs)?;
    let known_offset = match offset {
        ZeroOffset::Known(o) => Some(o),
        ZeroOffset::Estimate => None,
    };
    let mut p0 = vec![lin.params[0], lin.params[1]];
    if known_offset.is_none() {
        p0.push(off0);
    }
    let model = Static {
        configs,
        known_offset,
    };
    let out = minimize(
        &model,
        &p0,
        &Bounds::unbounded(p0.len()),
        &Options::default(),
    );
    let (sx, sy, off) = model.unpack(&out.params);
    if sy.is_nan() || sy <= 0.0 {
        return Err(MethodError::NonPhysical {
            reason: format!("first moment S_y = {sy:.4} kg m: CG not below the pivot"),
        });
    }
    Ok(FirstMoment {
        sx_kg_m: sx,
        sy_kg_m: sy,
        offset_rad: off,
        residual_rms_rad: out.rmse,
        configs: configs.len(),
    })
}

/// Inertia about the pivot axis, `g |S| T0^2 / (4 pi^2)` (kg m^2).
pub fn pivot_inertia(g_m_s2: f64, first_moment_kg_m: f64, period_s: f64) -> f64 {
    g_m_s2 * first_moment_kg_m * period_s * period_s / (4.0 * std::f64::consts::PI.powi(2))
}

/// Vehicle results from the total and platform-only states.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VehicleProperties {
    /// CG offset along the platform x axis from the pivot plane (m).
    pub x_cg_m: f64,
    /// CG height above the deck (vehicle ground plane) (m).
    pub z_cg_m: f64,
    /// Inertia of the vehicle about the pivot (kg m^2).
    pub inertia_pivot_kg_m2: f64,
    /// Inertia of the vehicle about its CG, parallel to the pivot (kg m^2).
    pub inertia_cg_kg_m2: f64,
}

/// Combines the states: `S_veh = S_tot - S_plat`, `I_p,veh = I_p,tot - I_p,plat`,
/// `I_cg = I_p,veh - |S_veh|^2 / m + 2 |S_veh| rho` (knife tip radius `rho`, section 4.4).
#[allow(clippy::too_many_arguments)]
pub fn vehicle_properties(
    s_total: (f64, f64),
    s_platform: (f64, f64),
    inertia_pivot_total: f64,
    inertia_pivot_platform: f64,
    vehicle_mass_kg: f64,
    pivot_to_deck_m: f64,
    knife_tip_radius_m: f64,
) -> VehicleProperties {
    let (sx, sy) = (s_total.0 - s_platform.0, s_total.1 - s_platform.1);
    let s2 = sx * sx + sy * sy;
    let ip = inertia_pivot_total - inertia_pivot_platform;
    VehicleProperties {
        x_cg_m: sx / vehicle_mass_kg,
        z_cg_m: pivot_to_deck_m - sy / vehicle_mass_kg,
        inertia_pivot_kg_m2: ip,
        inertia_cg_kg_m2: ip - s2 / vehicle_mass_kg + 2.0 * s2.sqrt() * knife_tip_radius_m,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// V4 static readings of the methods document (degrees), platform then platform + vehicle.
    pub(crate) fn v4_configs(vehicle: bool) -> Vec<TiltConfig> {
        let (dm, readings) = if vehicle {
            (20.0, [-0.183288, -3.612279, 3.282397, -1.890756, 1.559705])
        } else {
            (5.0, [0.050000, -4.469911, 4.569911, -2.213477, 2.313477])
        };
        let xs = [0.0, 1.0, -1.0, 0.5, -0.5];
        xs.iter()
            .zip(readings)
            .enumerate()
            .map(|(i, (x, r))| TiltConfig {
                added_sx_kg_m: if i == 0 { 0.0 } else { dm * x },
                added_sy_kg_m: if i == 0 { 0.0 } else { dm * 1.25 },
                reading_rad: f64::to_radians(r),
            })
            .collect()
    }

    #[test]
    fn v4_static_tables_give_first_moments_and_cg() {
        let plat = solve_first_moment(&v4_configs(false), ZeroOffset::Estimate).unwrap();
        let tot = solve_first_moment(&v4_configs(true), ZeroOffset::Estimate).unwrap();
        // The table's readings are rounded to 1e-6 deg, so tolerances follow that rounding.
        assert!(
            (plat.sy_kg_m - 57.0).abs() < 2e-3 && plat.sx_kg_m.abs() < 2e-3,
            "{plat:?}"
        );
        assert!(
            (tot.sy_kg_m - 307.0).abs() < 5e-3 && (tot.sx_kg_m - 1.25).abs() < 2e-3,
            "{tot:?}"
        );
        assert!((plat.offset_rad.to_degrees() - 0.05).abs() < 1e-5);
        let v = vehicle_properties(
            (tot.sx_kg_m, tot.sy_kg_m),
            (plat.sx_kg_m, plat.sy_kg_m),
            424.15625,
            74.15,
            250.0,
            1.3,
            0.0,
        );
        assert!(
            (v.z_cg_m - 0.3).abs() < 2e-5 && (v.x_cg_m - 0.005).abs() < 1e-5,
            "{v:?}"
        );
    }

    #[test]
    fn v4_vehicle_inertia_from_pivot_inertias() {
        let v = vehicle_properties(
            (1.25, 307.0),
            (0.0, 57.0),
            424.15625,
            74.15,
            250.0,
            1.3,
            0.0,
        );
        assert!((v.inertia_cg_kg_m2 - 100.0).abs() < 1e-9, "{v:?}");
        let i_tot = pivot_inertia(9.80665, 1.25f64.hypot(307.0), 2.358367483);
        assert!((i_tot - 424.15625).abs() < 1e-5, "{i_tot}");
    }
}
