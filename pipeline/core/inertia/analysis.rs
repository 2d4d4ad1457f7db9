//! A parsed session -> result rows and per-run errors.
//!
//! In: a [`Session`] and a reader for its run files. Out: [`SessionOutcome`]: [`InertiaResult`]
//! rows (per-run measurements such as acceleration, period and first moment, then the combined
//! results: vehicle inertia per rig, CG position, table inertia and friction) each with a
//! propagated standard uncertainty, plus one [`RunError`] per failed run. A failed run never
//! stops the others; a result that needs a failed or absent run (e.g. a vehicle swing without a
//! platform tare) is reported as an error of the dependent run. Deliberately no I/O beyond the
//! reader closure and no output formatting.

use super::encoder;
use super::pendulum::{self, TiltConfig, ZeroOffset};
use super::session::{
    AmplitudeCorrection, CsvTable, FrictionMethod, PendulumKind, Rig, Role, RunSpec, Session,
    SessionError, TiltOffset, YawModel,
};
use super::swing::{self, PeriodMethod, SignalKind, SwingOptions, SwingPeriod};
use super::trifilar::TrifilarRig;
use super::uncertainty::{Propagation, propagate};
use super::yaw::{self, AccelerationFit, DropRun};
use super::{InertiaResult, Measured, MethodError, RunError, diag};
use crate::numerics::period::pendulum_period_ratio;

/// Everything one session produced.
#[derive(Debug, Clone)]
pub struct SessionOutcome {
    /// Session id.
    pub session: String,
    /// Result rows.
    pub results: Vec<InertiaResult>,
    /// One error per failed run.
    pub errors: Vec<RunError>,
    /// Runs declared in the session.
    pub runs: usize,
}

/// One static-tilt configuration as read: added masses and the reading.
#[derive(Debug, Clone)]
struct StaticConfig {
    /// (mass kg, x m, y m) of each added mass.
    masses: Vec<(f64, f64, f64)>,
    reading_rad: f64,
    u_reading_rad: f64,
}

#[derive(Debug, Clone)]
enum Measurement {
    Yaw(AccelerationFit),
    Swing(SwingPeriod),
    Static(Vec<StaticConfig>),
}

struct Ctx<'a> {
    s: &'a Session,
    results: Vec<InertiaResult>,
    errors: Vec<RunError>,
    mc_counter: u64,
}

impl Ctx<'_> {
    fn fail(&mut self, run: &str, message: impl std::fmt::Display) {
        self.errors.push(RunError {
            session: self.s.id.clone(),
            run: run.into(),
            message: message.to_string(),
        });
    }

    #[allow(clippy::too_many_arguments)]
    fn row(
        &mut self,
        run: &str,
        object: &str,
        axis: &str,
        quantity: &str,
        method: &str,
        value: (f64, f64),
        units: &str,
        diagnostics: String,
    ) {
        self.results.push(InertiaResult {
            session: self.s.id.clone(),
            run: run.into(),
            object: object.into(),
            axis: axis.into(),
            quantity: quantity.into(),
            method: method.into(),
            value: value.0,
            uncertainty: value.1,
            units: units.into(),
            diagnostics,
        });
    }

    fn propagation(&mut self) -> Propagation {
        match self.s.analysis.propagation {
            Propagation::Linear => Propagation::Linear,
            Propagation::MonteCarlo { samples, seed } => {
                self.mc_counter += 1;
                Propagation::MonteCarlo {
                    samples,
                    seed: seed.wrapping_add(self.mc_counter),
                }
            }
        }
    }

    fn propagation_name(&self) -> &'static str {
        match self.s.analysis.propagation {
            Propagation::Linear => "linear",
            Propagation::MonteCarlo { .. } => "monte_carlo",
        }
    }

    fn object(&self, spec: &RunSpec) -> String {
        match spec.role {
            Role::Vehicle => spec
                .object
                .clone()
                .unwrap_or_else(|| self.s.vehicle_id.clone()),
            Role::Calibration => spec.calibration_body.clone().unwrap_or_default(),
            Role::Tare if spec.rig == Rig::YawTable => "table".into(),
            Role::Tare => "platform".into(),
        }
    }
}

/// Analyses every run of a session and combines them per rig.
pub fn analyze_session(
    session: &Session,
    read: &dyn Fn(&str) -> Result<String, SessionError>,
) -> SessionOutcome {
    let mut ctx = Ctx {
        s: session,
        results: Vec::new(),
        errors: Vec::new(),
        mc_counter: 0,
    };
    let mut measured: Vec<(RunSpec, Measurement)> = Vec::new();
    for (id, spec) in &session.runs {
        match spec {
            Err(e) => ctx.fail(id, e),
            Ok(spec) => match measure_run(&mut ctx, spec, read) {
                Ok(m) => measured.push((spec.clone(), m)),
                Err(message) => ctx.fail(id, message),
            },
        }
    }
    combine_yaw(&mut ctx, &measured);
    combine_trifilar(&mut ctx, &measured);
    combine_pendulum(&mut ctx, &measured);
    SessionOutcome {
        session: session.id.clone(),
        results: ctx.results,
        errors: ctx.errors,
        runs: session.runs.len(),
    }
}

fn measure_run(
    ctx: &mut Ctx,
    spec: &RunSpec,
    read: &dyn Fn(&str) -> Result<String, SessionError>,
) -> Result<Measurement, String> {
    let s = ctx.s;
    // the rig's constants must be valid before the file is worth reading
    match spec.rig {
        Rig::YawTable => {
            s.yaw_table.as_ref().map_err(|e| e.to_string())?;
            s.encoder.as_ref().map_err(|e| e.to_string())?;
        }
        Rig::Trifilar => {
            s.trifilar.as_ref().map_err(|e| e.to_string())?;
        }
        Rig::Pendulum => {
            s.pendulum.as_ref().map_err(|e| e.to_string())?;
            if spec.kind == Some(PendulumKind::Static) {
                s.tilt.as_ref().map_err(|e| e.to_string())?;
            }
        }
    }
    if let Some(body) = &spec.calibration_body {
        match s.calibration_bodies.get(body) {
            None => {
                return Err(format!(
                    "calibration_body {body:?} is not declared in [[calibration_body]]"
                ));
            }
            Some(Err(e)) => return Err(e.to_string()),
            Some(Ok(_)) => {}
        }
    }
    let text = read(&spec.file).map_err(|e| e.to_string())?;
    let table = CsvTable::parse(&spec.file, &text).map_err(|e| e.to_string())?;
    match (spec.rig, spec.kind) {
        (Rig::YawTable, _) => measure_yaw(ctx, spec, &table),
        (Rig::Pendulum, Some(PendulumKind::Static)) => measure_static(ctx, spec, &table),
        _ => measure_swing(ctx, spec, &table),
    }
}

fn measure_yaw(ctx: &mut Ctx, spec: &RunSpec, table: &CsvTable) -> Result<Measurement, String> {
    let s = ctx.s;
    let yaw = s.yaw_table.as_ref().expect("checked");
    let &(spacing, min_events) = s.encoder.as_ref().expect("checked");
    let e = |e: SessionError| e.to_string();
    let t = table.time("t_s").map_err(e)?;
    let (times, index, bounces, missed) = if table.has("signal_v") {
        let v = table.numeric("signal_v").map_err(e)?;
        let edges = encoder::rising_edges(&t, &v).map_err(|e| e.to_string())?;
        let ev = encoder::index_events(&edges, min_events).map_err(|e| e.to_string())?;
        (ev.times_s, ev.index, ev.bounces_removed, ev.missed_edges)
    } else if table.has("index") {
        let idx: Vec<i64> = table
            .numeric("index")
            .map_err(e)?
            .iter()
            .map(|v| v.round() as i64)
            .collect();
        if idx.windows(2).any(|w| w[1] <= w[0]) {
            return Err(format!(
                "{}: column index must increase strictly",
                spec.file
            ));
        }
        (t, idx, 0, 0)
    } else {
        let ev = encoder::index_events(&t, min_events).map_err(|e| e.to_string())?;
        (ev.times_s, ev.index, ev.bounces_removed, ev.missed_edges)
    };
    let mut angles = yaw::event_angles(&index, spacing);
    let mut times = times;
    if let Some(drop) = yaw.max_drop_m {
        let theta_max = drop / yaw.radius_m.value;
        let keep = angles.partition_point(|&a| a <= theta_max + 1e-9);
        angles.truncate(keep);
        times.truncate(keep);
    }
    if times.len() < min_events {
        return Err(MethodError::TooFewEdges {
            found: times.len(),
            needed: min_events,
        }
        .to_string());
    }
    let quad = yaw::fit_constant_alpha(&times, &angles).map_err(|e| e.to_string())?;
    if quad.alpha_rad_s2 <= 0.0 {
        return Err(MethodError::NonPhysical {
            reason: format!(
                "fitted acceleration {:.3e} rad/s^2 is not positive",
                quad.alpha_rad_s2
            ),
        }
        .to_string());
    }
    let fit = match s.analysis.yaw_model {
        YawModel::ConstAlpha => quad,
        YawModel::AeroLnCosh => yaw::fit_lncosh(&times, &angles).map_err(|e| e.to_string())?,
        YawModel::Auto => match yaw::fit_lncosh(&times, &angles) {
            Ok(f)
                if f.drag_c_per_rad > 5.0 * f.u_drag_c_per_rad
                    && f.drag_c_per_rad * angles[angles.len() - 1] > 1e-4 =>
            {
                f
            }
            _ => quad,
        },
    };
    let method = if fit.drag_c_per_rad > 0.0 {
        "ln_cosh"
    } else {
        "quadratic"
    };
    let object = ctx.object(spec);
    let d = diag(&[
        ("events", fit.events.to_string()),
        ("bounces_removed", bounces.to_string()),
        ("missed_edges", missed.to_string()),
        ("residual_rms_rad", format!("{:.3e}", fit.residual_rms_rad)),
        ("peak_omega_rad_s", format!("{:.4}", fit.peak_omega_rad_s)),
        (
            "alpha_slope_vs_omega2_per_rad",
            format!("{:.3e}", fit.alpha_slope_vs_omega2),
        ),
        ("drag_c_per_rad", format!("{:.4e}", fit.drag_c_per_rad)),
    ]);
    ctx.row(
        &spec.id,
        &object,
        "yaw",
        "angular_acceleration",
        method,
        (fit.alpha_rad_s2, fit.u_alpha_rad_s2),
        "rad/s^2",
        d,
    );
    Ok(Measurement::Yaw(fit))
}

fn swing_signal(spec: &RunSpec, table: &CsvTable) -> Result<(Vec<f64>, Vec<f64>), String> {
    let t = table.time("t_s").map_err(|e| e.to_string())?;
    let column = match spec.signal {
        SignalKind::Angle => "angle_deg",
        SignalKind::Rate => "rate_deg_s",
    };
    let x: Vec<f64> = table
        .numeric(column)
        .map_err(|e| e.to_string())?
        .into_iter()
        .map(f64::to_radians)
        .collect();
    Ok((t, x))
}

fn swing_options(s: &Session, correction: AmplitudeCorrection) -> SwingOptions {
    SwingOptions {
        method: s.analysis.period_method,
        correction: correction.scope(),
        window_cycles: s.analysis.window_cycles,
        discard_initial_cycles: s.analysis.discard_initial_cycles,
        min_cycles: s.analysis.min_cycles,
    }
}

fn trifilar_rig(s: &Session) -> Result<(TrifilarRig, &super::session::TrifilarSpec), String> {
    let t = s.trifilar.as_ref().map_err(|e| e.to_string())?;
    Ok((
        TrifilarRig {
            radius_top_m: t.radius_top_m.value,
            radius_bottom_m: t.radius_bottom_m.value,
            length_m: t.length_m.value,
            g_m_s2: s.g_m_s2.value,
        },
        t,
    ))
}

fn measure_swing(ctx: &mut Ctx, spec: &RunSpec, table: &CsvTable) -> Result<Measurement, String> {
    let s = ctx.s;
    let (t, x) = swing_signal(spec, table)?;
    let correction = match (spec.rig, s.analysis.amplitude_correction) {
        (Rig::Trifilar, AmplitudeCorrection::Auto) => AmplitudeCorrection::Trifilar,
        (Rig::Pendulum, AmplitudeCorrection::Auto) => AmplitudeCorrection::AgmWindowed,
        (Rig::Pendulum, AmplitudeCorrection::Trifilar) => {
            return Err(
                "analysis.amplitude_correction = \"trifilar\" applies to trifilar runs only".into(),
            );
        }
        (_, c) => c,
    };
    let opts = swing_options(s, correction);
    let period = if correction == AmplitudeCorrection::Trifilar {
        let (rig, _) = trifilar_rig(s)?;
        swing::analyze(&t, &x, spec.signal, &opts, &|a, t0| rig.period_ratio(a, t0))
    } else {
        swing::analyze(&t, &x, spec.signal, &opts, &|a, _| pendulum_period_ratio(a))
    }
    .map_err(|e| e.to_string())?;
    let method = match s.analysis.period_method {
        PeriodMethod::Nls => "damped_sine_nls",
        PeriodMethod::ZeroCrossing => "zero_crossing",
    };
    let axis = match spec.rig {
        Rig::Pendulum => s
            .pendulum
            .as_ref()
            .map(|p| p.axis.name())
            .unwrap_or("pitch"),
        _ => "yaw",
    };
    let correction_name = match correction {
        AmplitudeCorrection::None => "none",
        AmplitudeCorrection::AgmWhole => "agm_whole",
        AmplitudeCorrection::AgmWindowed | AmplitudeCorrection::Auto => "agm_windowed",
        AmplitudeCorrection::Trifilar => "trifilar",
    };
    let d = diag(&[
        ("amplitude_correction", correction_name.into()),
        (
            "period_uncorrected_s",
            format!("{:.9}", period.period_uncorrected_s),
        ),
        ("cycles", format!("{:.1}", period.cycles)),
        ("windows", period.windows.to_string()),
        (
            "amplitude_start_deg",
            format!("{:.3}", period.amplitude_start_rad.to_degrees()),
        ),
        (
            "amplitude_end_deg",
            format!("{:.3}", period.amplitude_end_rad.to_degrees()),
        ),
        ("zeta", format!("{:.5}", period.zeta)),
        (
            "backbone_slope_per_rad2",
            format!("{:.4}", period.backbone_slope_per_rad2),
        ),
        (
            "residual_rms_deg",
            format!("{:.2e}", period.residual_rms.to_degrees()),
        ),
    ]);
    let object = ctx.object(spec);
    ctx.row(
        &spec.id,
        &object,
        axis,
        "period_natural",
        method,
        (period.period_s, period.u_period_s),
        "s",
        d,
    );
    Ok(Measurement::Swing(period))
}

fn measure_static(ctx: &mut Ctx, spec: &RunSpec, table: &CsvTable) -> Result<Measurement, String> {
    let s = ctx.s;
    let tilt = s.tilt.as_ref().expect("checked");
    let e = |e: SessionError| e.to_string();
    let names = table.text("config").map_err(e)?;
    let dm = table.numeric("added_mass_kg").map_err(e)?;
    let xs = table.numeric("x_m").map_err(e)?;
    let ys = table.numeric("y_m").map_err(e)?;
    let tilt_deg = table.numeric("tilt_deg").map_err(e)?;
    let sd = if table.has("tilt_sd_deg") {
        Some(table.numeric("tilt_sd_deg").map_err(e)?)
    } else {
        None
    };
    let mut order: Vec<String> = Vec::new();
    let mut configs: Vec<StaticConfig> = Vec::new();
    for i in 0..names.len() {
        if dm[i] < 0.0 {
            return Err(format!(
                "{}: row {} (config {}): added_mass_kg = {} is negative",
                spec.file,
                i + 1,
                names[i],
                dm[i]
            ));
        }
        let reading = tilt.scale * tilt_deg[i].to_radians();
        let u = sd.as_ref().map_or(tilt.noise_rad, |s| s[i].to_radians());
        let k = match order.iter().position(|n| *n == names[i]) {
            Some(k) => {
                if (configs[k].reading_rad - reading).abs() > 1e-12 {
                    return Err(format!(
                        "{}: config {} has rows with different tilt_deg",
                        spec.file, names[i]
                    ));
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
            configs[k].masses.push((dm[i], xs[i], ys[i]));
        }
    }
    let offset = match tilt.offset {
        TiltOffset::Estimate => ZeroOffset::Estimate,
        TiltOffset::Known(m) => ZeroOffset::Known(m.value),
    };
    let solution =
        pendulum::solve_first_moment(&tilt_configs(&configs), offset).map_err(|e| e.to_string())?;
    let object = ctx.object(spec);
    let axis = s
        .pendulum
        .as_ref()
        .map(|p| p.axis.name())
        .unwrap_or("pitch");
    let d = diag(&[
        ("configs", solution.configs.to_string()),
        (
            "residual_rms_deg",
            format!("{:.2e}", solution.residual_rms_rad.to_degrees()),
        ),
        (
            "offset_deg",
            format!("{:.5}", solution.offset_rad.to_degrees()),
        ),
    ]);
    let inputs = static_inputs(
        &configs,
        s.pendulum
            .as_ref()
            .map_or((0.0, 0.0), |p| (p.added_mass_u_kg, p.added_position_u_m)),
    );
    let offset_input = offset_measured(s);
    let mut all = inputs.clone();
    all.push(offset_input);
    let shape = configs.clone();
    let f = move |x: &[f64]| -> Result<Vec<f64>, MethodError> {
        let (cfgs, rest) = rebuild_configs(&shape, x);
        let sol = pendulum::solve_first_moment(&cfgs, offset_from(offset, rest[0]))?;
        Ok(vec![sol.sx_kg_m, sol.sy_kg_m, sol.offset_rad])
    };
    let how = ctx.propagation();
    let out = propagate(&all, &f, how).map_err(|e| e.to_string())?;
    ctx.row(
        &spec.id,
        &object,
        axis,
        "first_moment_x",
        "static_tilt_ls",
        out[0],
        "kg*m",
        d.clone(),
    );
    ctx.row(
        &spec.id,
        &object,
        axis,
        "first_moment_y",
        "static_tilt_ls",
        out[1],
        "kg*m",
        d.clone(),
    );
    ctx.row(
        &spec.id,
        &object,
        axis,
        "inclinometer_offset",
        "static_tilt_ls",
        out[2],
        "rad",
        d,
    );
    Ok(Measurement::Static(configs))
}

fn offset_measured(s: &Session) -> Measured {
    match s.tilt.as_ref().map(|t| t.offset) {
        Ok(TiltOffset::Known(m)) => m,
        _ => Measured::exact(0.0),
    }
}

fn offset_from(offset: ZeroOffset, value: f64) -> ZeroOffset {
    match offset {
        ZeroOffset::Estimate => ZeroOffset::Estimate,
        ZeroOffset::Known(_) => ZeroOffset::Known(value),
    }
}

fn tilt_configs(configs: &[StaticConfig]) -> Vec<TiltConfig> {
    configs
        .iter()
        .map(|c| TiltConfig {
            added_sx_kg_m: c.masses.iter().map(|(m, x, _)| m * x).sum(),
            added_sy_kg_m: c.masses.iter().map(|(m, _, y)| m * y).sum(),
            reading_rad: c.reading_rad,
        })
        .collect()
}

/// Inputs of a static test: per config the reading, then per added mass (m, x, y).
fn static_inputs(configs: &[StaticConfig], (u_mass, u_pos): (f64, f64)) -> Vec<Measured> {
    let mut v = Vec::new();
    for c in configs {
        v.push(Measured::new(c.reading_rad, c.u_reading_rad));
        for &(m, x, y) in &c.masses {
            v.push(Measured::new(m, u_mass));
            v.push(Measured::new(x, u_pos));
            v.push(Measured::new(y, u_pos));
        }
    }
    v
}

/// Inverse of [`static_inputs`]: configs from an input vector, and the remaining inputs.
fn rebuild_configs<'x>(shape: &[StaticConfig], x: &'x [f64]) -> (Vec<TiltConfig>, &'x [f64]) {
    let mut k = 0;
    let mut out = Vec::with_capacity(shape.len());
    for c in shape {
        let reading = x[k];
        k += 1;
        let (mut sx, mut sy) = (0.0, 0.0);
        for _ in &c.masses {
            sx += x[k] * x[k + 1];
            sy += x[k] * x[k + 2];
            k += 3;
        }
        out.push(TiltConfig {
            added_sx_kg_m: sx,
            added_sy_kg_m: sy,
            reading_rad: reading,
        });
    }
    (out, &x[k..])
}

fn join_ids(specs: &[&RunSpec]) -> String {
    specs
        .iter()
        .map(|s| s.id.as_str())
        .collect::<Vec<_>>()
        .join("+")
}

/// Rig-level yaw identification from the base inputs: `(I_table, tau_f, extra)` where extra is
/// the multi-mass `I_tot` or the calibration factor.
type Identification = dyn Fn(&[f64]) -> Result<(f64, f64, f64), MethodError>;

fn combine_yaw(ctx: &mut Ctx, measured: &[(RunSpec, Measurement)]) {
    let s = ctx.s;
    let Ok(yaw) = s.yaw_table.as_ref() else {
        return;
    };
    let pick = |role: Role| -> Vec<(&RunSpec, &AccelerationFit)> {
        measured
            .iter()
            .filter_map(|(spec, m)| match m {
                Measurement::Yaw(f) if spec.role == role => Some((spec, f)),
                _ => None,
            })
            .collect()
    };
    let (tares, cals, vehicles) = (
        pick(Role::Tare),
        pick(Role::Calibration),
        pick(Role::Vehicle),
    );
    let vehicle_ids: Vec<String> = s
        .runs
        .iter()
        .filter_map(|(_, r)| r.as_ref().ok())
        .filter(|r| r.rig == Rig::YawTable && r.role == Role::Vehicle)
        .map(|r| r.id.clone())
        .collect();
    if vehicles.is_empty() && tares.is_empty() && cals.is_empty() {
        return;
    }
    let method = s.friction_method();
    let g = s.g_m_s2;
    let m_of = |spec: &RunSpec| spec.falling_mass_kg.expect("validated");
    let alpha_of = |f: &AccelerationFit| Measured::new(f.alpha_rad_s2, f.u_alpha_rad_s2);
    // Common inputs: g, r, i_eq; then the identification inputs; run inputs are appended last.
    let mut base = vec![g, yaw.radius_m, yaw.i_eq_kg_m2];
    let ident_runs: Vec<&RunSpec>;
    let ident: Box<Identification>;
    // returns (I_table, tau_f, factor) from base inputs
    let need = |what: &str| format!("friction method {method:?} needs {what}");
    let fail_all = |ctx: &mut Ctx, msg: String| {
        for id in &vehicle_ids {
            if measured.iter().any(|(s, _)| &s.id == id) {
                ctx.fail(id, &msg);
            }
        }
    };
    match method {
        FrictionMethod::Given => {
            let tau = match (yaw.friction_n_m, yaw.drag_mass_kg) {
                (Some(t), _) => t,
                (None, Some(m)) => Measured::new(
                    m.value * g.value * yaw.radius_m.value,
                    m.u * g.value * yaw.radius_m.value,
                ),
                (None, None) => {
                    return fail_all(ctx, need("yaw_table.friction_torque_n_m or drag_mass_kg"));
                }
            };
            base.push(tau);
            match yaw.table_inertia_kg_m2 {
                Some(it) => {
                    base.push(it);
                    ident_runs = Vec::new();
                    ident = Box::new(|x: &[f64]| Ok((x[4], x[3], 1.0)));
                }
                None => {
                    let Some((spec, fit)) = tares.first() else {
                        return fail_all(
                            ctx,
                            need("a successful yaw tare run or yaw_table.table_inertia_kg_m2"),
                        );
                    };
                    base.push(m_of(spec));
                    base.push(alpha_of(fit));
                    ident_runs = vec![spec];
                    ident = Box::new(|x: &[f64]| {
                        Ok((
                            yaw::rotating_inertia_exact(x[4], x[1], x[0], x[5], x[3], x[2]),
                            x[3],
                            1.0,
                        ))
                    });
                }
            }
        }
        FrictionMethod::TareCalibration => {
            let (Some((ts, tf)), Some((cs, cf))) = (tares.first(), cals.first()) else {
                return fail_all(
                    ctx,
                    need("a successful tare run and a successful calibration run"),
                );
            };
            let body = s.calibration_bodies[cs.calibration_body.as_ref().expect("validated")]
                .as_ref()
                .expect("checked")
                .clone();
            base.extend([
                m_of(ts),
                alpha_of(tf),
                m_of(cs),
                alpha_of(cf),
                body.inertia_kg_m2,
            ]);
            ident_runs = vec![ts, cs];
            ident = Box::new(|x: &[f64]| {
                let (it, tau) = yaw::tare_and_friction(
                    DropRun {
                        mass_kg: x[3],
                        alpha_rad_s2: x[4],
                    },
                    DropRun {
                        mass_kg: x[5],
                        alpha_rad_s2: x[6],
                    },
                    x[7],
                    x[1],
                    x[0],
                    x[2],
                )?;
                Ok((it, tau, 1.0))
            });
        }
        FrictionMethod::MultiMass => {
            let Some(it) = yaw.table_inertia_kg_m2 else {
                return fail_all(ctx, need("yaw_table.table_inertia_kg_m2 (a value)"));
            };
            if vehicles.len() < 2 {
                return fail_all(
                    ctx,
                    need("at least 2 successful vehicle runs with different masses"),
                );
            }
            base.push(it);
            for (spec, fit) in &vehicles {
                base.push(m_of(spec));
                base.push(alpha_of(fit));
            }
            ident_runs = vehicles.iter().map(|(s, _)| *s).collect();
            let n = vehicles.len();
            ident = Box::new(move |x: &[f64]| {
                let runs: Vec<DropRun> = (0..n)
                    .map(|j| DropRun {
                        mass_kg: x[4 + 2 * j],
                        alpha_rad_s2: x[5 + 2 * j],
                    })
                    .collect();
                let (itot, tau) = yaw::multi_mass(&runs, x[1], x[0], x[2])?;
                Ok((x[3], tau, itot))
            });
        }
        FrictionMethod::CalibrationFactor => {
            let (Some(it), Some((cs, cf))) = (yaw.table_inertia_kg_m2, cals.first()) else {
                return fail_all(
                    ctx,
                    need("yaw_table.table_inertia_kg_m2 and a successful calibration run"),
                );
            };
            let body = s.calibration_bodies[cs.calibration_body.as_ref().expect("validated")]
                .as_ref()
                .expect("checked")
                .clone();
            base.extend([it, m_of(cs), alpha_of(cf), body.inertia_kg_m2]);
            ident_runs = vec![cs];
            ident = Box::new(|x: &[f64]| {
                let k = yaw::calibration_factor(
                    DropRun {
                        mass_kg: x[4],
                        alpha_rad_s2: x[5],
                    },
                    x[6],
                    x[3],
                    x[1],
                    x[0],
                    x[2],
                );
                Ok((x[3], 0.0, k))
            });
        }
    }
    let nb = base.len();
    let method_name = match method {
        FrictionMethod::Given => "given",
        FrictionMethod::TareCalibration => "tare_calibration",
        FrictionMethod::MultiMass => "multi_mass",
        FrictionMethod::CalibrationFactor => "calibration_factor",
    };
    let prop = ctx.propagation_name();
    // Rig-level rows: identified table inertia and friction.
    if !ident_runs.is_empty() {
        let how = ctx.propagation();
        let f = |x: &[f64]| ident(x).map(|(it, tau, k)| vec![it, tau, k]);
        match propagate(&base, &f, how) {
            Ok(out) => {
                let run = join_ids(&ident_runs);
                let d = diag(&[
                    ("friction_method", method_name.into()),
                    ("uncertainty", prop.into()),
                ]);
                if method == FrictionMethod::MultiMass {
                    ctx.row(
                        &run,
                        &s.vehicle_id,
                        "yaw",
                        "rotating_inertia",
                        "falling_mass_multi_mass",
                        out[2],
                        "kg*m^2",
                        d.clone(),
                    );
                    let fv = |x: &[f64]| ident(x).map(|(it, _, itot)| vec![itot - it]);
                    if let Ok(v) = propagate(&base, &fv, ctx.propagation()) {
                        ctx.row(
                            &run,
                            &s.vehicle_id,
                            "yaw",
                            "inertia",
                            "falling_mass_multi_mass",
                            v[0],
                            "kg*m^2",
                            d.clone(),
                        );
                    }
                } else if method != FrictionMethod::CalibrationFactor {
                    ctx.row(
                        &run,
                        "table",
                        "yaw",
                        "inertia",
                        &format!("falling_mass_{method_name}"),
                        out[0],
                        "kg*m^2",
                        d.clone(),
                    );
                }
                if method != FrictionMethod::CalibrationFactor {
                    ctx.row(
                        &run,
                        "table",
                        "yaw",
                        "friction_torque",
                        &format!("falling_mass_{method_name}"),
                        out[1],
                        "N*m",
                        d,
                    );
                } else {
                    ctx.row(
                        &run,
                        "table",
                        "yaw",
                        "calibration_factor",
                        "thesis_calibration_factor",
                        out[2],
                        "1",
                        d,
                    );
                }
            }
            Err(e) => {
                let run = join_ids(&ident_runs);
                ctx.fail(&run, e);
                return fail_all(ctx, format!("yaw identification from {run} failed"));
            }
        }
    }
    // Per vehicle run: exact torque balance and the thesis formula.
    for (spec, fit) in &vehicles {
        let mut inputs = base.clone();
        inputs.push(m_of(spec));
        inputs.push(alpha_of(fit));
        let c = fit.drag_c_per_rad;
        let f = |x: &[f64]| -> Result<Vec<f64>, MethodError> {
            let (it, tau, k) = ident(&x[..nb])?;
            let (g, r, ieq, m, a) = (x[0], x[1], x[2], x[nb], x[nb + 1]);
            let loaded = yaw::rotating_inertia_exact(m, r, g, a, tau, ieq);
            let exact = if method == FrictionMethod::CalibrationFactor {
                k * (loaded - it)
            } else {
                loaded - it
            };
            let thesis = yaw::rotating_inertia_thesis(m, tau / (g * r), r, g, a) - it;
            let j = (m * g * r - tau) / a;
            Ok(vec![exact, thesis, c * j])
        };
        let how = ctx.propagation();
        match propagate(&inputs, &f, how) {
            Ok(out) => {
                let object = ctx.object(spec);
                let mut pairs = vec![
                    ("friction_method", method_name.to_string()),
                    (
                        "acceleration_model",
                        if c > 0.0 { "ln_cosh" } else { "quadratic" }.to_string(),
                    ),
                    ("uncertainty", prop.to_string()),
                ];
                if method == FrictionMethod::CalibrationFactor {
                    pairs.push(("warning", "multiplicative calibration factor is biased when the vehicle's acceleration differs from the calibration body's (methods 2.4)".into()));
                }
                if out[0].0 <= 0.0 {
                    pairs.push((
                        "warning",
                        "non-positive inertia: check tare, friction and units".into(),
                    ));
                }
                let d = diag(&pairs);
                let exact_method = if method == FrictionMethod::CalibrationFactor {
                    "thesis_calibration_factor"
                } else {
                    "falling_mass_exact"
                };
                ctx.row(
                    &spec.id,
                    &object,
                    "yaw",
                    "inertia",
                    exact_method,
                    out[0],
                    "kg*m^2",
                    d.clone(),
                );
                ctx.row(&spec.id, &object, "yaw", "inertia", "thesis_simplified", out[1], "kg*m^2", diag(&[("note", "r g (m - m_drag)/alpha - I_table: string tension taken as m g (high by m r^2)".into())]));
                if c > 0.0 {
                    ctx.row(
                        &spec.id,
                        &object,
                        "yaw",
                        "aero_drag_coefficient",
                        "ln_cosh",
                        out[2],
                        "N*m*s^2",
                        d,
                    );
                }
            }
            Err(e) => ctx.fail(&spec.id, e),
        }
    }
}

fn pick_swings(
    measured: &[(RunSpec, Measurement)],
    rig: Rig,
    role: Role,
) -> Vec<(&RunSpec, &SwingPeriod)> {
    measured
        .iter()
        .filter_map(|(spec, m)| match m {
            Measurement::Swing(p) if spec.rig == rig && spec.role == role => Some((spec, p)),
            _ => None,
        })
        .collect()
}

/// Mean period of several tare swings with the uncertainty of the mean of independent runs.
fn mean_period(runs: &[(&RunSpec, &SwingPeriod)]) -> Measured {
    let n = runs.len() as f64;
    let mean = runs.iter().map(|(_, p)| p.period_s).sum::<f64>() / n;
    let u = runs
        .iter()
        .map(|(_, p)| p.u_period_s.powi(2))
        .sum::<f64>()
        .sqrt()
        / n;
    Measured::new(mean, u)
}

fn combine_trifilar(ctx: &mut Ctx, measured: &[(RunSpec, Measurement)]) {
    let s = ctx.s;
    let (tares, vehicles) = (
        pick_swings(measured, Rig::Trifilar, Role::Tare),
        pick_swings(measured, Rig::Trifilar, Role::Vehicle),
    );
    if tares.is_empty() && vehicles.is_empty() {
        return;
    }
    let Ok((_, spec_t)) = trifilar_rig(s) else {
        return;
    };
    let prop = ctx.propagation_name();
    let base = vec![
        s.g_m_s2,
        spec_t.radius_top_m,
        spec_t.radius_bottom_m,
        spec_t.length_m,
        spec_t.platform_mass_kg,
    ];
    let k = |x: &[f64]| TrifilarRig {
        g_m_s2: x[0],
        radius_top_m: x[1],
        radius_bottom_m: x[2],
        length_m: x[3],
    };
    if tares.is_empty() {
        for (spec, _) in &vehicles {
            ctx.fail(
                &spec.id,
                "trifilar vehicle run needs a successful platform (role = \"tare\") run",
            );
        }
        return;
    }
    let tp = mean_period(&tares);
    let tare_ids: Vec<&RunSpec> = tares.iter().map(|(s, _)| *s).collect();
    let mut inputs = base.clone();
    inputs.push(tp);
    let how = ctx.propagation();
    if let Ok(out) = propagate(
        &inputs,
        &|x: &[f64]| -> Result<Vec<f64>, MethodError> { Ok(vec![k(x).system_inertia(x[4], x[5])]) },
        how,
    ) {
        ctx.row(
            &join_ids(&tare_ids),
            "platform",
            "yaw",
            "inertia",
            "trifilar",
            out[0],
            "kg*m^2",
            diag(&[("uncertainty", prop.into())]),
        );
    }
    for (spec, period) in &vehicles {
        let m_o = match spec
            .object_mass_kg
            .map(Ok)
            .unwrap_or_else(|| s.vehicle_mass_kg.clone())
        {
            Ok(m) => m,
            Err(e) => {
                ctx.fail(
                    &spec.id,
                    format!("object mass: set run object_mass_kg or [vehicle] mass_kg ({e})"),
                );
                continue;
            }
        };
        let mut inputs = inputs.clone();
        inputs.push(m_o);
        inputs.push(Measured::new(period.period_s, period.u_period_s));
        let f = |x: &[f64]| -> Result<Vec<f64>, MethodError> {
            let rig = k(x);
            let i = rig.object_inertia(x[4], x[5], x[4] + x[6], x[7]);
            Ok(vec![i, rig.system_inertia(x[4] + x[6], x[7])])
        };
        let how = ctx.propagation();
        match propagate(&inputs, &f, how) {
            Ok(out) if out[0].0 > 0.0 => {
                let object = ctx.object(spec);
                let d = diag(&[
                    ("tare_runs", join_ids(&tare_ids)),
                    ("system_inertia_kg_m2", format!("{:.6}", out[1].0)),
                    ("tare_amplification", format!("{:.3}", out[1].0 / out[0].0)),
                    ("uncertainty", prop.into()),
                ]);
                ctx.row(
                    &spec.id, &object, "yaw", "inertia", "trifilar", out[0], "kg*m^2", d,
                );
            }
            Ok(out) => ctx.fail(
                &spec.id,
                MethodError::NonPhysical {
                    reason: format!("object inertia {:.4} kg m^2 <= 0", out[0].0),
                },
            ),
            Err(e) => ctx.fail(&spec.id, e),
        }
    }
}

fn combine_pendulum(ctx: &mut Ctx, measured: &[(RunSpec, Measurement)]) {
    let s = ctx.s;
    let Ok(pend) = s.pendulum.as_ref() else {
        return;
    };
    let statics = |role: Role| -> Vec<(&RunSpec, &Vec<StaticConfig>)> {
        measured
            .iter()
            .filter_map(|(spec, m)| match m {
                Measurement::Static(c) if spec.role == role => Some((spec, c)),
                _ => None,
            })
            .collect()
    };
    let (plat_static, veh_static) = (statics(Role::Tare), statics(Role::Vehicle));
    let (plat_swing, veh_swing) = (
        pick_swings(measured, Rig::Pendulum, Role::Tare),
        pick_swings(measured, Rig::Pendulum, Role::Vehicle),
    );
    let axis = pend.axis.name();
    let prop = ctx.propagation_name();
    let offset = match s.tilt.as_ref().map(|t| t.offset) {
        Ok(TiltOffset::Known(m)) => ZeroOffset::Known(m.value),
        _ => ZeroOffset::Estimate,
    };
    let u_added = (pend.added_mass_u_kg, pend.added_position_u_m);
    // Platform pivot inertia.
    if let (Some((ps, pc)), false) = (plat_static.first(), plat_swing.is_empty()) {
        let tp = mean_period(&plat_swing);
        let mut inputs = vec![s.g_m_s2, tp, offset_measured(s)];
        inputs.extend(static_inputs(pc, u_added));
        let shape = (*pc).clone();
        let f = move |x: &[f64]| -> Result<Vec<f64>, MethodError> {
            let (cfgs, _) = rebuild_configs(&shape, &x[3..]);
            let sp = pendulum::solve_first_moment(&cfgs, offset_from(offset, x[2]))?;
            Ok(vec![pendulum::pivot_inertia(x[0], sp.magnitude(), x[1])])
        };
        let how = ctx.propagation();
        if let Ok(out) = propagate(&inputs, &f, how) {
            let mut ids: Vec<&RunSpec> = vec![ps];
            ids.extend(plat_swing.iter().map(|(s, _)| *s));
            ctx.row(
                &join_ids(&ids),
                "platform",
                axis,
                "inertia_pivot",
                "compound_pendulum",
                out[0],
                "kg*m^2",
                diag(&[("uncertainty", prop.into())]),
            );
        }
    }
    let vehicle_runs: Vec<&RunSpec> = s
        .runs
        .iter()
        .filter_map(|(_, r)| r.as_ref().ok())
        .filter(|r| {
            r.rig == Rig::Pendulum
                && r.role == Role::Vehicle
                && measured.iter().any(|(m, _)| m.id == r.id)
        })
        .collect();
    if vehicle_runs.is_empty() {
        return;
    }
    let mut missing = Vec::new();
    if plat_static.is_empty() {
        missing.push("a successful platform static run");
    }
    if veh_static.is_empty() {
        missing.push("a successful vehicle static run");
    }
    let m_v = match &s.vehicle_mass_kg {
        Ok(m) => Some(*m),
        Err(_) => {
            missing.push("[vehicle] mass_kg");
            None
        }
    };
    if !missing.is_empty() {
        for r in &vehicle_runs {
            ctx.fail(
                &r.id,
                format!("pendulum results need {}", missing.join(", ")),
            );
        }
        return;
    }
    let m_v = m_v.expect("checked");
    let (ps, pc) = plat_static[0];
    let (vs, vc) = veh_static[0];
    // inputs: g, m_v, d_deck, rho, offset, T_p, T_v, then platform static, then vehicle static
    let np = static_inputs(pc, u_added).len();
    let (shape_p, shape_v) = ((*pc).clone(), (*vc).clone());
    let f = move |x: &[f64]| -> Result<Vec<f64>, MethodError> {
        let (cp, _) = rebuild_configs(&shape_p, &x[7..7 + np]);
        let (cv, _) = rebuild_configs(&shape_v, &x[7 + np..]);
        let sp = pendulum::solve_first_moment(&cp, offset_from(offset, x[4]))?;
        let sv = pendulum::solve_first_moment(&cv, offset_from(offset, x[4]))?;
        let ip_p = pendulum::pivot_inertia(x[0], sp.magnitude(), x[5]);
        let ip_t = pendulum::pivot_inertia(x[0], sv.magnitude(), x[6]);
        let v = pendulum::vehicle_properties(
            (sv.sx_kg_m, sv.sy_kg_m),
            (sp.sx_kg_m, sp.sy_kg_m),
            ip_t,
            ip_p,
            x[1],
            x[2],
            x[3],
        );
        Ok(vec![
            v.x_cg_m,
            v.z_cg_m,
            v.inertia_cg_kg_m2,
            v.inertia_pivot_kg_m2,
            ip_t,
        ])
    };
    let mut base = vec![
        s.g_m_s2,
        m_v,
        pend.pivot_to_deck_m,
        pend.knife_tip_radius_m,
        offset_measured(s),
    ];
    // CG from statics alone (periods irrelevant: fixed at 1 s).
    {
        let mut inputs = base.clone();
        inputs.extend([Measured::exact(1.0), Measured::exact(1.0)]);
        inputs.extend(static_inputs(pc, u_added));
        inputs.extend(static_inputs(vc, u_added));
        let how = ctx.propagation();
        match propagate(&inputs, &f, how) {
            Ok(out) => {
                let run = join_ids(&[ps, vs]);
                let object = ctx.object(vs);
                let d = diag(&[
                    ("uncertainty", prop.into()),
                    (
                        "x_axis",
                        "platform x from the pivot plane (forward for pitch, lateral for roll)"
                            .into(),
                    ),
                ]);
                ctx.row(
                    &run,
                    &object,
                    axis,
                    "cg_height",
                    "static_tilt_ls",
                    out[1],
                    "m",
                    d.clone(),
                );
                ctx.row(
                    &run,
                    &object,
                    axis,
                    "cg_offset_x",
                    "static_tilt_ls",
                    out[0],
                    "m",
                    d,
                );
            }
            Err(e) => ctx.fail(&vs.id, e),
        }
    }
    if veh_swing.is_empty() {
        return;
    }
    if plat_swing.is_empty() {
        for (spec, _) in &veh_swing {
            ctx.fail(
                &spec.id,
                "pendulum vehicle swing needs a successful platform swing run",
            );
        }
        return;
    }
    let tp = mean_period(&plat_swing);
    base.push(tp);
    for (spec, period) in &veh_swing {
        let mut inputs = base.clone();
        inputs.push(Measured::new(period.period_s, period.u_period_s));
        inputs.extend(static_inputs(pc, u_added));
        inputs.extend(static_inputs(vc, u_added));
        let how = ctx.propagation();
        match propagate(&inputs, &f, how) {
            Ok(out) if out[2].0 > 0.0 => {
                let i_cg = out[2].0;
                // sensitivity dI_cg/dh = m (k^2 - h^2)/h, as % per mm
                let h_pivot = pend.pivot_to_deck_m.value - out[1].0;
                let k2 = i_cg / m_v.value;
                let sens = m_v.value * (k2 - h_pivot * h_pivot) / h_pivot / i_cg * 1e-3 * 100.0;
                let object = ctx.object(spec);
                let mut ids: Vec<&RunSpec> = vec![ps, vs];
                ids.extend(plat_swing.iter().map(|(s, _)| *s));
                let d = diag(&[
                    ("combined_with", join_ids(&ids)),
                    ("inertia_pivot_kg_m2", format!("{:.5}", out[3].0)),
                    ("inertia_pivot_system_kg_m2", format!("{:.5}", out[4].0)),
                    ("dI_dh_pct_per_mm", format!("{sens:.3}")),
                    ("uncertainty", prop.into()),
                ]);
                ctx.row(
                    &spec.id,
                    &object,
                    axis,
                    "inertia_cg",
                    "compound_pendulum",
                    out[2],
                    "kg*m^2",
                    d,
                );
            }
            Ok(out) => ctx.fail(
                &spec.id,
                MethodError::NonPhysical {
                    reason: format!("inertia about the CG {:.4} kg m^2 <= 0", out[2].0),
                },
            ),
            Err(e) => ctx.fail(&spec.id, e),
        }
    }
}
