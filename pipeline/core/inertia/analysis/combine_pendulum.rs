//! Step 3, compound pendulum: static tilt tests and swings -> CG position and vehicle inertia.
//!
//! In: the session's successful pendulum static tests and swings (platform and vehicle). Out:
//! the platform's inertia about the pivot; the vehicle's CG height and offset from the two
//! static tests alone; per vehicle swing the vehicle's inertia about its CG. The platform and
//! vehicle first moments, periods and geometry enter one propagated computation, so shared
//! inputs (g, the pivot-to-deck distance, the inclinometer offset) are correlated by
//! construction (methods section 4).

use super::measure::Measurement;
use super::row::{Method, Quantity, Row};
use super::statics::{self, ConfigInputs, StaticConfig};
use super::{AnalysisError, Ctx, join_ids, mean_period, swings};
use crate::inertia::pendulum::{self, ZeroOffset};
use crate::inertia::session::{PendulumSpec, Rig, Role, RunSpec};
use crate::inertia::uncertainty::{Input, Inputs, propagate_each};
use crate::inertia::{Measured, MethodError, diag};

/// The successful static tests of one role.
fn static_tests<'m, 's>(
    measured: &'m [Measurement<'s>],
    role: Role,
) -> Vec<(&'s RunSpec, &'m [StaticConfig])> {
    measured
        .iter()
        .filter_map(|m| match m {
            Measurement::Static { spec, configs } if spec.role == role => {
                Some((*spec, configs.as_slice()))
            }
            _ => None,
        })
        .collect()
}

/// Platform pivot inertia, then the vehicle's CG and inertia.
pub(super) fn combine(ctx: &mut Ctx, measured: &[Measurement]) {
    let s = ctx.s;
    let Ok(pend) = s.pendulum.as_ref() else {
        return;
    };
    let (platform_static, vehicle_static) = (
        static_tests(measured, Role::Tare),
        static_tests(measured, Role::Vehicle),
    );
    let (platform_swings, vehicle_swings) = (
        swings(measured, Rig::Pendulum, Role::Tare),
        swings(measured, Rig::Pendulum, Role::Vehicle),
    );
    let offset = statics::zero_offset(s.tilt.as_ref().ok());
    if let (Some(&(ps, pc)), false) = (platform_static.first(), platform_swings.is_empty()) {
        let mut runs = vec![ps];
        runs.extend(platform_swings.iter().map(|(s, _)| *s));
        platform_row(ctx, pend, offset, mean_period(&platform_swings), pc, &runs);
    }
    let vehicle_runs: Vec<&RunSpec> = measured
        .iter()
        .map(|m| m.spec())
        .filter(|r| r.rig() == Rig::Pendulum && r.role == Role::Vehicle)
        .collect();
    if vehicle_runs.is_empty() {
        return;
    }
    let mut missing = Vec::new();
    if platform_static.is_empty() {
        missing.push("a successful platform static run");
    }
    if vehicle_static.is_empty() {
        missing.push("a successful vehicle static run");
    }
    let vehicle_mass = s.vehicle_mass_kg.as_ref().ok().copied();
    if vehicle_mass.is_none() {
        missing.push("[vehicle] mass_kg");
    }
    let (Some(&platform), Some(&vehicle), Some(vehicle_mass)) = (
        platform_static.first(),
        vehicle_static.first(),
        vehicle_mass,
    ) else {
        for r in &vehicle_runs {
            ctx.fail(&r.id, AnalysisError::PendulumNeeds(missing.clone()));
        }
        return;
    };
    let statics = Statics {
        platform,
        vehicle,
        vehicle_mass,
        offset,
    };
    cg_rows(ctx, pend, &statics);
    if vehicle_swings.is_empty() {
        return;
    }
    if platform_swings.is_empty() {
        for (spec, _) in &vehicle_swings {
            ctx.fail(&spec.id, AnalysisError::PendulumSwingNeedsPlatform);
        }
        return;
    }
    let platform_period = mean_period(&platform_swings);
    let platform_swing_runs: Vec<&RunSpec> = platform_swings.iter().map(|(s, _)| *s).collect();
    for (spec, period) in &vehicle_swings {
        let vehicle_period = Measured::new(period.period_s, period.u_period_s);
        let periods = (platform_period, vehicle_period);
        inertia_row(ctx, pend, &statics, periods, spec, &platform_swing_runs);
    }
}

/// The platform's inertia about the pivot from its static test and mean swing period.
fn platform_row(
    ctx: &mut Ctx,
    pend: &PendulumSpec,
    offset: ZeroOffset,
    period: Measured,
    configs: &[StaticConfig],
    runs: &[&RunSpec],
) {
    let mut inputs = Inputs::new();
    let g = inputs.add(ctx.s.g_m_s2);
    let period = inputs.add(period);
    let offset_input = inputs.add(statics::offset_input(ctx.s.tilt.as_ref().ok()));
    let config_inputs = statics::add_inputs(&mut inputs, configs, pend);
    let pivot_inertia = |x: &[f64]| -> Result<[f64; 1], MethodError> {
        let first_moment = pendulum::solve_first_moment(
            &statics::tilt_configs_at(&config_inputs, x),
            statics::zero_offset_at(offset, offset_input.of(x)),
        )?;
        Ok([pendulum::pivot_inertia(
            g.of(x),
            first_moment.magnitude(),
            period.of(x),
        )])
    };
    let how = ctx.propagation();
    if let Ok([inertia]) = propagate_each(&inputs, &pivot_inertia, how) {
        let run = join_ids(runs);
        let diagnostics = diag(&[("uncertainty", ctx.propagation_name().into())]);
        ctx.push(Row {
            run: &run,
            object: "platform",
            axis: pend.axis.into(),
            quantity: Quantity::InertiaPivot,
            method: Method::CompoundPendulum,
            value: inertia,
            diagnostics,
        });
    }
}

/// The static tests the vehicle results combine.
struct Statics<'m, 's> {
    platform: (&'s RunSpec, &'m [StaticConfig]),
    vehicle: (&'s RunSpec, &'m [StaticConfig]),
    vehicle_mass: Measured,
    offset: ZeroOffset,
}

/// The inputs of the vehicle computation.
struct VehicleInputs {
    g: Input,
    vehicle_mass: Input,
    pivot_to_deck: Input,
    knife_tip_radius: Input,
    offset: Input,
    platform_period: Input,
    vehicle_period: Input,
    platform_configs: Vec<ConfigInputs>,
    vehicle_configs: Vec<ConfigInputs>,
}

/// The vehicle's CG and inertia at one set of input values.
struct Vehicle {
    x_cg_m: f64,
    z_cg_m: f64,
    inertia_cg_kg_m2: f64,
    inertia_pivot_kg_m2: f64,
    /// Vehicle plus platform about the pivot.
    system_pivot_kg_m2: f64,
}

impl VehicleInputs {
    /// The inputs for the given platform and vehicle periods.
    fn new(
        ctx: &Ctx,
        pend: &PendulumSpec,
        statics: &Statics,
        (platform_period, vehicle_period): (Measured, Measured),
    ) -> (Inputs, Self) {
        let mut inputs = Inputs::new();
        let handles = VehicleInputs {
            g: inputs.add(ctx.s.g_m_s2),
            vehicle_mass: inputs.add(statics.vehicle_mass),
            pivot_to_deck: inputs.add(pend.pivot_to_deck_m),
            knife_tip_radius: inputs.add(pend.knife_tip_radius_m),
            offset: inputs.add(statics::offset_input(ctx.s.tilt.as_ref().ok())),
            platform_period: inputs.add(platform_period),
            vehicle_period: inputs.add(vehicle_period),
            platform_configs: statics::add_inputs(&mut inputs, statics.platform.1, pend),
            vehicle_configs: statics::add_inputs(&mut inputs, statics.vehicle.1, pend),
        };
        (inputs, handles)
    }

    fn at(&self, offset: ZeroOffset, x: &[f64]) -> Result<Vehicle, MethodError> {
        let offset = statics::zero_offset_at(offset, self.offset.of(x));
        let platform_configs = statics::tilt_configs_at(&self.platform_configs, x);
        let vehicle_configs = statics::tilt_configs_at(&self.vehicle_configs, x);
        let sp = pendulum::solve_first_moment(&platform_configs, offset)?;
        let sv = pendulum::solve_first_moment(&vehicle_configs, offset)?;
        let g = self.g.of(x);
        let platform_pivot = pendulum::pivot_inertia(g, sp.magnitude(), self.platform_period.of(x));
        let system_pivot = pendulum::pivot_inertia(g, sv.magnitude(), self.vehicle_period.of(x));
        let v = pendulum::vehicle_properties(
            (sv.sx_kg_m, sv.sy_kg_m),
            (sp.sx_kg_m, sp.sy_kg_m),
            system_pivot,
            platform_pivot,
            self.vehicle_mass.of(x),
            self.pivot_to_deck.of(x),
            self.knife_tip_radius.of(x),
        );
        Ok(Vehicle {
            x_cg_m: v.x_cg_m,
            z_cg_m: v.z_cg_m,
            inertia_cg_kg_m2: v.inertia_cg_kg_m2,
            inertia_pivot_kg_m2: v.inertia_pivot_kg_m2,
            system_pivot_kg_m2: system_pivot,
        })
    }
}

/// CG height and offset from the static tests alone (the periods do not enter: fixed at 1 s).
fn cg_rows(ctx: &mut Ctx, pend: &PendulumSpec, statics: &Statics) {
    let exact = Measured::exact(1.0);
    let (inputs, vehicle) = VehicleInputs::new(ctx, pend, statics, (exact, exact));
    let cg = |x: &[f64]| -> Result<[f64; 2], MethodError> {
        let v = vehicle.at(statics.offset, x)?;
        Ok([v.x_cg_m, v.z_cg_m])
    };
    let how = ctx.propagation();
    let (platform_run, vehicle_run) = (statics.platform.0, statics.vehicle.0);
    let [x_cg, z_cg] = match propagate_each(&inputs, &cg, how) {
        Ok(out) => out,
        Err(e) => return ctx.fail(&vehicle_run.id, e),
    };
    let run = join_ids(&[platform_run, vehicle_run]);
    let object = ctx.object(vehicle_run);
    let diagnostics = diag(&[
        ("uncertainty", ctx.propagation_name().into()),
        (
            "x_axis",
            "platform x from the pivot plane (forward for pitch, lateral for roll)".into(),
        ),
    ]);
    for (quantity, value) in [(Quantity::CgHeight, z_cg), (Quantity::CgOffsetX, x_cg)] {
        ctx.push(Row {
            run: &run,
            object: &object,
            axis: pend.axis.into(),
            quantity,
            method: Method::StaticTiltLs,
            value,
            diagnostics: diagnostics.clone(),
        });
    }
}

/// The vehicle's inertia about its CG from one vehicle swing.
fn inertia_row(
    ctx: &mut Ctx,
    pend: &PendulumSpec,
    statics: &Statics,
    periods: (Measured, Measured),
    spec: &RunSpec,
    platform_swings: &[&RunSpec],
) {
    let (inputs, vehicle) = VehicleInputs::new(ctx, pend, statics, periods);
    let inertia = |x: &[f64]| -> Result<[f64; 5], MethodError> {
        let v = vehicle.at(statics.offset, x)?;
        Ok([
            v.x_cg_m,
            v.z_cg_m,
            v.inertia_cg_kg_m2,
            v.inertia_pivot_kg_m2,
            v.system_pivot_kg_m2,
        ])
    };
    let how = ctx.propagation();
    let [_, z_cg, i_cg, i_pivot, system_pivot] = match propagate_each(&inputs, &inertia, how) {
        Ok(out) if out[2].0 > 0.0 => out,
        Ok([_, _, i_cg, ..]) => {
            let reason = format!("inertia about the CG {:.4} kg m^2 <= 0", i_cg.0);
            return ctx.fail(&spec.id, MethodError::NonPhysical { reason });
        }
        Err(e) => return ctx.fail(&spec.id, e),
    };
    // sensitivity dI_cg/dh = m (k^2 - h^2)/h, as % per mm
    let m_v = statics.vehicle_mass.value;
    let h_pivot = pend.pivot_to_deck_m.value - z_cg.0;
    let k2 = i_cg.0 / m_v;
    let sens = m_v * (k2 - h_pivot * h_pivot) / h_pivot / i_cg.0 * 1e-3 * 100.0;
    let object = ctx.object(spec);
    let mut runs = vec![statics.platform.0, statics.vehicle.0];
    runs.extend(platform_swings);
    let diagnostics = diag(&[
        ("combined_with", join_ids(&runs)),
        ("inertia_pivot_kg_m2", format!("{:.5}", i_pivot.0)),
        (
            "inertia_pivot_system_kg_m2",
            format!("{:.5}", system_pivot.0),
        ),
        ("dI_dh_pct_per_mm", format!("{sens:.3}")),
        ("uncertainty", ctx.propagation_name().into()),
    ]);
    ctx.push(Row {
        run: &spec.id,
        object: &object,
        axis: pend.axis.into(),
        quantity: Quantity::InertiaCg,
        method: Method::CompoundPendulum,
        value: i_cg,
        diagnostics,
    });
}
