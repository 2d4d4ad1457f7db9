//! Step 3, yaw table: the measured drops -> table inertia and friction, then vehicle inertia.
//!
//! In: the session's successful yaw drops (tare, calibration, vehicle). Out: rows for the
//! table (identified inertia and friction, or the thesis calibration factor) and per vehicle
//! drop the exact torque balance, the thesis's simplified formula and, with an `ln cosh` fit,
//! the aerodynamic drag coefficient. Three named steps:
//! 1. [`identification`]: what the friction method needs (values from `[yaw_table]`, runs) as
//!    named propagation inputs, or why it cannot run;
//! 2. [`table_rows`]: the table's identified values with their uncertainties;
//! 3. [`vehicle_rows`]: each vehicle drop against the identified table.
//!
//! Equations: `shared/docs/inertia-methods.md` section 2; uncertainties propagate through the
//! whole computation, so the table's uncertainty reaches every vehicle result.

use super::measure::{Measurement, YawDrop};
use super::row::{Axis, Method, Quantity, Row};
use super::{AnalysisError, Ctx, join_ids};
use crate::inertia::session::{CalibrationBody, FrictionMethod, RunSpec, YawLoad, YawTableSpec};
use crate::inertia::uncertainty::{Input, Inputs, propagate_each};
use crate::inertia::yaw::{self, DropRun};
use crate::inertia::{Measured, MethodError, diag};

/// The session's successful drops by what was on the table.
struct Drops<'m, 's> {
    tares: Vec<&'m YawDrop<'s>>,
    /// Calibration drops with their body.
    calibrations: Vec<(&'m YawDrop<'s>, &'s CalibrationBody)>,
    vehicles: Vec<&'m YawDrop<'s>>,
}

impl<'m, 's> Drops<'m, 's> {
    fn pick(measured: &'m [Measurement<'s>]) -> Self {
        let mut drops = Drops {
            tares: Vec::new(),
            calibrations: Vec::new(),
            vehicles: Vec::new(),
        };
        for m in measured {
            if let Measurement::Yaw(drop) = m {
                match drop.load {
                    YawLoad::Tare => drops.tares.push(drop),
                    YawLoad::Calibration(body) => drops.calibrations.push((drop, body)),
                    YawLoad::Vehicle => drops.vehicles.push(drop),
                }
            }
        }
        drops
    }

    fn is_empty(&self) -> bool {
        self.tares.is_empty() && self.calibrations.is_empty() && self.vehicles.is_empty()
    }
}

/// The rig constants every yaw result uses, as inputs.
struct RigInputs {
    g: Input,
    radius: Input,
    i_eq: Input,
}

/// The rig constants at one set of input values.
struct Rig {
    g: f64,
    radius_m: f64,
    i_eq: f64,
}

impl RigInputs {
    fn at(&self, x: &[f64]) -> Rig {
        Rig {
            g: self.g.of(x),
            radius_m: self.radius.of(x),
            i_eq: self.i_eq.of(x),
        }
    }
}

/// A drop's falling mass and acceleration, as inputs.
struct DropInputs {
    mass: Input,
    alpha: Input,
}

impl DropInputs {
    fn add(inputs: &mut Inputs, drop: &YawDrop) -> Self {
        DropInputs {
            mass: inputs.add(drop.falling_mass_kg),
            alpha: inputs.add(drop.alpha()),
        }
    }

    fn at(&self, x: &[f64]) -> DropRun {
        DropRun {
            mass_kg: self.mass.of(x),
            alpha_rad_s2: self.alpha.of(x),
        }
    }
}

/// How the friction method identifies the table, with the inputs it reads.
enum Identification {
    /// Friction torque and table inertia as given.
    Given { friction: Input, table: Input },
    /// Friction torque given, table inertia from an empty-table drop.
    GivenWithTare { friction: Input, tare: DropInputs },
    /// Table inertia and friction from an empty-table drop and a calibration-body drop.
    TareCalibration {
        tare: DropInputs,
        calibration: DropInputs,
        body_inertia: Input,
    },
    /// Friction from a regression over vehicle drops with several masses; table inertia given.
    MultiMass {
        table: Input,
        drops: Vec<DropInputs>,
    },
    /// The thesis's multiplicative factor from a calibration body; table inertia given.
    CalibrationFactor {
        table: Input,
        calibration: DropInputs,
        body_inertia: Input,
    },
}

/// The table as identified at one set of input values.
struct Table {
    /// The table's own inertia (kg m^2).
    inertia_kg_m2: f64,
    /// Bearing friction torque (N m).
    friction_n_m: f64,
    /// The thesis's calibration factor (1 for every other method).
    factor: f64,
    /// Table plus load from the multi-mass regression (NaN for the other methods).
    loaded_kg_m2: f64,
}

impl Identification {
    fn at(&self, rig: &Rig, x: &[f64]) -> Result<Table, MethodError> {
        let table = |inertia_kg_m2, friction_n_m| Table {
            inertia_kg_m2,
            friction_n_m,
            factor: 1.0,
            loaded_kg_m2: f64::NAN,
        };
        Ok(match self {
            Identification::Given { friction, table: t } => table(t.of(x), friction.of(x)),
            Identification::GivenWithTare { friction, tare } => {
                let tare = tare.at(x);
                let inertia = yaw::rotating_inertia_exact(
                    tare.mass_kg,
                    rig.radius_m,
                    rig.g,
                    tare.alpha_rad_s2,
                    friction.of(x),
                    rig.i_eq,
                );
                table(inertia, friction.of(x))
            }
            Identification::TareCalibration {
                tare,
                calibration,
                body_inertia,
            } => {
                let (inertia, friction) = yaw::tare_and_friction(
                    tare.at(x),
                    calibration.at(x),
                    body_inertia.of(x),
                    rig.radius_m,
                    rig.g,
                    rig.i_eq,
                )?;
                table(inertia, friction)
            }
            Identification::MultiMass { table: t, drops } => {
                let runs: Vec<DropRun> = drops.iter().map(|d| d.at(x)).collect();
                let (loaded, friction) = yaw::multi_mass(&runs, rig.radius_m, rig.g, rig.i_eq)?;
                Table {
                    loaded_kg_m2: loaded,
                    ..table(t.of(x), friction)
                }
            }
            Identification::CalibrationFactor {
                table: t,
                calibration,
                body_inertia,
            } => {
                let factor = yaw::calibration_factor(
                    calibration.at(x),
                    body_inertia.of(x),
                    t.of(x),
                    rig.radius_m,
                    rig.g,
                    rig.i_eq,
                );
                Table {
                    factor,
                    ..table(t.of(x), 0.0)
                }
            }
        })
    }
}

/// The identification's inputs (rig constants first, then what the method reads) and the runs
/// it uses.
struct Identified<'m, 's> {
    inputs: Inputs,
    rig: RigInputs,
    identification: Identification,
    runs: Vec<&'m YawDrop<'s>>,
}

/// Table inertia and friction, then every vehicle drop.
pub(super) fn combine(ctx: &mut Ctx, measured: &[Measurement]) {
    let Ok(yaw_table) = ctx.s.yaw_table.as_ref() else {
        return;
    };
    let drops = Drops::pick(measured);
    if drops.is_empty() {
        return;
    }
    let method = ctx.s.friction_method();
    let identified = match identification(ctx, yaw_table, method, &drops) {
        Ok(identified) => identified,
        Err(error) => return fail_vehicles(ctx, &drops, &error),
    };
    if !identified.runs.is_empty() && !table_rows(ctx, method, &identified) {
        let runs = drop_ids(&identified.runs);
        let error = AnalysisError::IdentificationFailed { runs };
        return fail_vehicles(ctx, &drops, &error);
    }
    for drop in &drops.vehicles {
        vehicle_rows(ctx, method, &identified, drop);
    }
}

fn fail_vehicles(ctx: &mut Ctx, drops: &Drops, error: &AnalysisError) {
    for drop in &drops.vehicles {
        ctx.fail(&drop.spec.id, error.clone());
    }
}

fn drop_ids(drops: &[&YawDrop]) -> String {
    let specs: Vec<&RunSpec> = drops.iter().map(|d| d.spec).collect();
    join_ids(&specs)
}

/// Step 1: the friction method's inputs, or what it lacks.
fn identification<'m, 's>(
    ctx: &Ctx,
    yaw_table: &YawTableSpec,
    method: FrictionMethod,
    drops: &Drops<'m, 's>,
) -> Result<Identified<'m, 's>, AnalysisError> {
    let needs = |needs: &'static str| AnalysisError::FrictionMethodNeeds { method, needs };
    let g = ctx.s.g_m_s2;
    let mut inputs = Inputs::new();
    let rig = RigInputs {
        g: inputs.add(g),
        radius: inputs.add(yaw_table.radius_m),
        i_eq: inputs.add(yaw_table.i_eq_kg_m2),
    };
    let (identification, runs) = match method {
        FrictionMethod::Given => {
            let friction = match (yaw_table.friction_n_m, yaw_table.drag_mass_kg) {
                (Some(t), _) => t,
                (None, Some(m)) => Measured::new(
                    m.value * g.value * yaw_table.radius_m.value,
                    m.u * g.value * yaw_table.radius_m.value,
                ),
                (None, None) => {
                    return Err(needs("yaw_table.friction_torque_n_m or drag_mass_kg"));
                }
            };
            let friction = inputs.add(friction);
            match yaw_table.table_inertia_kg_m2 {
                Some(table) => {
                    let table = inputs.add(table);
                    (Identification::Given { friction, table }, Vec::new())
                }
                None => {
                    let Some(&tare) = drops.tares.first() else {
                        return Err(needs(
                            "a successful yaw tare run or yaw_table.table_inertia_kg_m2",
                        ));
                    };
                    let chosen = Identification::GivenWithTare {
                        friction,
                        tare: DropInputs::add(&mut inputs, tare),
                    };
                    (chosen, vec![tare])
                }
            }
        }
        FrictionMethod::TareCalibration => {
            let (Some(&tare), Some(&(calibration, body))) =
                (drops.tares.first(), drops.calibrations.first())
            else {
                return Err(needs(
                    "a successful tare run and a successful calibration run",
                ));
            };
            let chosen = Identification::TareCalibration {
                tare: DropInputs::add(&mut inputs, tare),
                calibration: DropInputs::add(&mut inputs, calibration),
                body_inertia: inputs.add(body.inertia_kg_m2),
            };
            (chosen, vec![tare, calibration])
        }
        FrictionMethod::MultiMass => {
            let Some(table) = yaw_table.table_inertia_kg_m2 else {
                return Err(needs("yaw_table.table_inertia_kg_m2 (a value)"));
            };
            if drops.vehicles.len() < 2 {
                return Err(needs(
                    "at least 2 successful vehicle runs with different masses",
                ));
            }
            let table = inputs.add(table);
            let vehicle_inputs = drops
                .vehicles
                .iter()
                .map(|drop| DropInputs::add(&mut inputs, drop))
                .collect();
            let chosen = Identification::MultiMass {
                table,
                drops: vehicle_inputs,
            };
            (chosen, drops.vehicles.clone())
        }
        FrictionMethod::CalibrationFactor => {
            let (Some(table), Some(&(calibration, body))) =
                (yaw_table.table_inertia_kg_m2, drops.calibrations.first())
            else {
                return Err(needs(
                    "yaw_table.table_inertia_kg_m2 and a successful calibration run",
                ));
            };
            let chosen = Identification::CalibrationFactor {
                table: inputs.add(table),
                calibration: DropInputs::add(&mut inputs, calibration),
                body_inertia: inputs.add(body.inertia_kg_m2),
            };
            (chosen, vec![calibration])
        }
    };
    Ok(Identified {
        inputs,
        rig,
        identification,
        runs,
    })
}

/// The config name of a friction method (as in `[analysis] friction_method`).
fn method_name(method: FrictionMethod) -> &'static str {
    match method {
        FrictionMethod::Given => "given",
        FrictionMethod::TareCalibration => "tare_calibration",
        FrictionMethod::MultiMass => "multi_mass",
        FrictionMethod::CalibrationFactor => "calibration_factor",
    }
}

/// Step 2: rows of the identified table (named by the runs used); false when the
/// identification failed, which is then an error of those runs.
fn table_rows(ctx: &mut Ctx, method: FrictionMethod, identified: &Identified) -> bool {
    let how = ctx.propagation();
    let table = |x: &[f64]| -> Result<[f64; 4], MethodError> {
        let t = identified.identification.at(&identified.rig.at(x), x)?;
        Ok([t.inertia_kg_m2, t.friction_n_m, t.factor, t.loaded_kg_m2])
    };
    let run = drop_ids(&identified.runs);
    let [inertia, friction, factor, loaded] = match propagate_each(&identified.inputs, &table, how)
    {
        Ok(out) => out,
        Err(e) => {
            ctx.fail(&run, e);
            return false;
        }
    };
    let d = diag(&[
        ("friction_method", method_name(method).into()),
        ("uncertainty", ctx.propagation_name().into()),
    ]);
    let row = |object, quantity, method, value| Row {
        run: &run,
        object,
        axis: Axis::Yaw,
        quantity,
        method,
        value,
        diagnostics: d.clone(),
    };
    let falling_mass = Method::FallingMass(method);
    match method {
        FrictionMethod::MultiMass => {
            let vehicle = ctx.s.vehicle_id.clone();
            ctx.push(row(
                &vehicle,
                Quantity::RotatingInertia,
                falling_mass,
                loaded,
            ));
            let load = |x: &[f64]| -> Result<[f64; 1], MethodError> {
                let t = identified.identification.at(&identified.rig.at(x), x)?;
                Ok([t.loaded_kg_m2 - t.inertia_kg_m2])
            };
            let how = ctx.propagation();
            if let Ok([load]) = propagate_each(&identified.inputs, &load, how) {
                ctx.push(row(&vehicle, Quantity::Inertia, falling_mass, load));
            }
            ctx.push(row(
                "table",
                Quantity::FrictionTorque,
                falling_mass,
                friction,
            ));
        }
        FrictionMethod::Given | FrictionMethod::TareCalibration => {
            ctx.push(row("table", Quantity::Inertia, falling_mass, inertia));
            ctx.push(row(
                "table",
                Quantity::FrictionTorque,
                falling_mass,
                friction,
            ));
        }
        FrictionMethod::CalibrationFactor => {
            let method = Method::ThesisCalibrationFactor;
            ctx.push(row("table", Quantity::CalibrationFactor, method, factor));
        }
    }
    true
}

/// Step 3: one vehicle drop against the identified table: the exact torque balance (times the
/// calibration factor for that method), the thesis's formula, and the drag coefficient of an
/// `ln cosh` fit.
fn vehicle_rows(ctx: &mut Ctx, method: FrictionMethod, identified: &Identified, drop: &YawDrop) {
    let mut inputs = identified.inputs.clone();
    let vehicle = DropInputs::add(&mut inputs, drop);
    let c = drop.fit.drag_c_per_rad;
    let results = |x: &[f64]| -> Result<[f64; 3], MethodError> {
        let rig = identified.rig.at(x);
        let table = identified.identification.at(&rig, x)?;
        let (g, r) = (rig.g, rig.radius_m);
        let DropRun {
            mass_kg: m,
            alpha_rad_s2: a,
        } = vehicle.at(x);
        let tau = table.friction_n_m;
        let loaded = yaw::rotating_inertia_exact(m, r, g, a, tau, rig.i_eq);
        let exact = table.factor * (loaded - table.inertia_kg_m2);
        let thesis = yaw::rotating_inertia_thesis(m, tau / (g * r), r, g, a) - table.inertia_kg_m2;
        let rotating = (m * g * r - tau) / a;
        Ok([exact, thesis, c * rotating])
    };
    let how = ctx.propagation();
    let [exact, thesis, aero] = match propagate_each(&inputs, &results, how) {
        Ok(out) => out,
        Err(e) => return ctx.fail(&drop.spec.id, e),
    };
    let object = ctx.object(drop.spec);
    let mut pairs = vec![
        ("friction_method", method_name(method).to_string()),
        (
            "acceleration_model",
            if c > 0.0 { "ln_cosh" } else { "quadratic" }.to_string(),
        ),
        ("uncertainty", ctx.propagation_name().to_string()),
    ];
    if method == FrictionMethod::CalibrationFactor {
        pairs.push((
            "warning",
            "multiplicative calibration factor is biased when the vehicle's acceleration \
             differs from the calibration body's (methods 2.4)"
                .into(),
        ));
    }
    if exact.0 <= 0.0 {
        pairs.push((
            "warning",
            "non-positive inertia: check tare, friction and units".into(),
        ));
    }
    let d = diag(&pairs);
    let row = |method, quantity, value, diagnostics| Row {
        run: &drop.spec.id,
        object: &object,
        axis: Axis::Yaw,
        quantity,
        method,
        value,
        diagnostics,
    };
    let exact_method = if method == FrictionMethod::CalibrationFactor {
        Method::ThesisCalibrationFactor
    } else {
        Method::FallingMassExact
    };
    let note = "r g (m - m_drag)/alpha - I_table: string tension taken as m g (high by m r^2)";
    ctx.push(row(exact_method, Quantity::Inertia, exact, d.clone()));
    ctx.push(row(
        Method::ThesisSimplified,
        Quantity::Inertia,
        thesis,
        diag(&[("note", note.into())]),
    ));
    if c > 0.0 {
        ctx.push(row(Method::LnCosh, Quantity::AeroDragCoefficient, aero, d));
    }
}
