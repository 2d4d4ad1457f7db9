//! Step 2 of the analysis: one planned run -> its measurement and its own result row.
//!
//! In: a [`RunPlan`] and the reader of run files. Out: a [`Measurement`] (yaw drop: the fitted
//! acceleration; swing: the natural period; static tilt: the configurations) that the combine
//! steps use, plus one row per run (`angular_acceleration`, `period_natural`, or the first
//! moments and inclinometer offset of a static test).

use super::row::{Axis, Method, Quantity, Row};
use super::statics::{self, StaticConfig};
use super::{AnalysisError, Ctx};
use crate::inertia::pendulum;
use crate::inertia::session::{
    AmplitudeCorrection, CsvTable, EncoderSpec, PendulumSpec, RigPlan, RunPlan, RunSpec,
    SessionError, TiltSensor, TrifilarSpec, YawLoad, YawModel, YawTableSpec,
};
use crate::inertia::swing::{self, PeriodMethod, SignalKind, SwingOptions, SwingPeriod};
use crate::inertia::trifilar::TrifilarRig;
use crate::inertia::uncertainty::{Inputs, propagate_each};
use crate::inertia::yaw::{self, AccelerationFit};
use crate::inertia::{Measured, MethodError, diag, encoder};
use crate::numerics::period::pendulum_period_ratio;

/// A yaw drop as the combine step needs it.
#[derive(Debug, Clone)]
pub(super) struct YawDrop<'s> {
    pub spec: &'s RunSpec,
    pub falling_mass_kg: Measured,
    pub load: YawLoad<'s>,
    pub fit: AccelerationFit,
}

impl YawDrop<'_> {
    /// The measured acceleration as an input.
    pub fn alpha(&self) -> Measured {
        Measured::new(self.fit.alpha_rad_s2, self.fit.u_alpha_rad_s2)
    }
}

/// What one run measured.
#[derive(Debug, Clone)]
pub(super) enum Measurement<'s> {
    /// A yaw-table drop.
    Yaw(YawDrop<'s>),
    /// A trifilar or pendulum swing.
    Swing {
        spec: &'s RunSpec,
        period: SwingPeriod,
    },
    /// A pendulum static tilt test.
    Static {
        spec: &'s RunSpec,
        configs: Vec<StaticConfig>,
    },
}

impl<'s> Measurement<'s> {
    /// The run measured.
    pub fn spec(&self) -> &'s RunSpec {
        match self {
            Measurement::Yaw(drop) => drop.spec,
            Measurement::Swing { spec, .. } | Measurement::Static { spec, .. } => spec,
        }
    }
}

/// Reads the run's file and measures it by its rig.
pub(super) fn measure<'s>(
    ctx: &mut Ctx,
    plan: RunPlan<'s>,
    read: &dyn Fn(&str) -> Result<String, SessionError>,
) -> Result<Measurement<'s>, AnalysisError> {
    let spec = plan.spec;
    let text = read(&spec.file)?;
    let table = CsvTable::parse(&spec.file, &text)?;
    Ok(match plan.rig {
        RigPlan::Yaw {
            table: rig,
            encoder,
            falling_mass_kg,
            load,
        } => Measurement::Yaw(YawDrop {
            spec,
            falling_mass_kg,
            load,
            fit: yaw_drop(ctx, spec, rig, encoder, &table)?,
        }),
        RigPlan::TrifilarSwing { rig, signal } => Measurement::Swing {
            spec,
            period: swing_period(ctx, spec, SwingRig::Trifilar(rig), signal, &table)?,
        },
        RigPlan::PendulumSwing { pendulum, signal } => Measurement::Swing {
            spec,
            period: swing_period(ctx, spec, SwingRig::Pendulum(pendulum), signal, &table)?,
        },
        RigPlan::PendulumStatic { pendulum, tilt } => Measurement::Static {
            spec,
            configs: static_test(ctx, spec, pendulum, tilt, &table)?,
        },
    })
}

/// Encoder events of a drop: times, band indices, and what the edge detection cleaned up.
struct EncoderEvents {
    times_s: Vec<f64>,
    index: Vec<i64>,
    bounces_removed: usize,
    missed_edges: usize,
}

/// Events from a raw `signal_v` column, a logged `index` column, or plain event times.
fn encoder_events(
    spec: &RunSpec,
    table: &CsvTable,
    encoder: &EncoderSpec,
) -> Result<EncoderEvents, AnalysisError> {
    let t = table.time("t_s")?;
    if table.has("signal_v") {
        let v = table.numeric("signal_v")?;
        let edges = encoder::rising_edges(&t, &v)?;
        let ev = encoder::index_events(&edges, encoder.min_events)?;
        Ok(EncoderEvents {
            times_s: ev.times_s,
            index: ev.index,
            bounces_removed: ev.bounces_removed,
            missed_edges: ev.missed_edges,
        })
    } else if table.has("index") {
        let index: Vec<i64> = table
            .numeric("index")?
            .iter()
            .map(|v| v.round() as i64)
            .collect();
        if index.windows(2).any(|w| w[1] <= w[0]) {
            return Err(AnalysisError::IndexNotIncreasing {
                file: spec.file.clone(),
            });
        }
        Ok(EncoderEvents {
            times_s: t,
            index,
            bounces_removed: 0,
            missed_edges: 0,
        })
    } else {
        let ev = encoder::index_events(&t, encoder.min_events)?;
        Ok(EncoderEvents {
            times_s: ev.times_s,
            index: ev.index,
            bounces_removed: ev.bounces_removed,
            missed_edges: ev.missed_edges,
        })
    }
}

/// The acceleration model of a drop: quadratic, `ln cosh`, or `ln cosh` only when its drag is
/// significant (`c > 5 u(c)` and `c theta_max > 1e-4`).
fn acceleration_fit(
    model: YawModel,
    times_s: &[f64],
    angles_rad: &[f64],
) -> Result<AccelerationFit, AnalysisError> {
    let quad = yaw::fit_constant_alpha(times_s, angles_rad)?;
    if quad.alpha_rad_s2 <= 0.0 {
        return Err(MethodError::NonPhysical {
            reason: format!(
                "fitted acceleration {:.3e} rad/s^2 is not positive",
                quad.alpha_rad_s2
            ),
        }
        .into());
    }
    Ok(match model {
        YawModel::ConstAlpha => quad,
        YawModel::AeroLnCosh => yaw::fit_lncosh(times_s, angles_rad)?,
        YawModel::Auto => match yaw::fit_lncosh(times_s, angles_rad) {
            Ok(f)
                if f.drag_c_per_rad > 5.0 * f.u_drag_c_per_rad
                    && f.drag_c_per_rad * angles_rad[angles_rad.len() - 1] > 1e-4 =>
            {
                f
            }
            _ => quad,
        },
    })
}

/// A yaw drop: encoder events up to the drop height, the acceleration fit, its row.
fn yaw_drop(
    ctx: &mut Ctx,
    spec: &RunSpec,
    rig: &YawTableSpec,
    encoder: &EncoderSpec,
    table: &CsvTable,
) -> Result<AccelerationFit, AnalysisError> {
    let events = encoder_events(spec, table, encoder)?;
    let mut angles = yaw::event_angles(&events.index, encoder.spacing_rad);
    let mut times = events.times_s;
    if let Some(drop) = rig.max_drop_m {
        let theta_max = drop / rig.radius_m.value;
        let keep = angles.partition_point(|&a| a <= theta_max + 1e-9);
        angles.truncate(keep);
        times.truncate(keep);
    }
    if times.len() < encoder.min_events {
        return Err(MethodError::TooFewEdges {
            found: times.len(),
            needed: encoder.min_events,
        }
        .into());
    }
    let fit = acceleration_fit(ctx.s.analysis.yaw_model, &times, &angles)?;
    let method = if fit.drag_c_per_rad > 0.0 {
        Method::LnCosh
    } else {
        Method::Quadratic
    };
    let object = ctx.object(spec);
    let diagnostics = diag(&[
        ("events", fit.events.to_string()),
        ("bounces_removed", events.bounces_removed.to_string()),
        ("missed_edges", events.missed_edges.to_string()),
        ("residual_rms_rad", format!("{:.3e}", fit.residual_rms_rad)),
        ("peak_omega_rad_s", format!("{:.4}", fit.peak_omega_rad_s)),
        (
            "alpha_slope_vs_omega2_per_rad",
            format!("{:.3e}", fit.alpha_slope_vs_omega2),
        ),
        ("drag_c_per_rad", format!("{:.4e}", fit.drag_c_per_rad)),
    ]);
    ctx.push(Row {
        run: &spec.id,
        object: &object,
        axis: Axis::Yaw,
        quantity: Quantity::AngularAcceleration,
        method,
        value: (fit.alpha_rad_s2, fit.u_alpha_rad_s2),
        diagnostics,
    });
    Ok(fit)
}

/// The rig a swing was recorded on.
#[derive(Clone, Copy)]
enum SwingRig<'s> {
    Trifilar(&'s TrifilarSpec),
    Pendulum(&'s PendulumSpec),
}

/// The amplitude correction of a swing: `auto` is the trifilar formula on the trifilar and the
/// windowed AGM on the pendulum; the trifilar formula on a pendulum is an error.
fn amplitude_correction(
    rig: SwingRig,
    chosen: AmplitudeCorrection,
) -> Result<AmplitudeCorrection, AnalysisError> {
    match (rig, chosen) {
        (SwingRig::Trifilar(_), AmplitudeCorrection::Auto) => Ok(AmplitudeCorrection::Trifilar),
        (SwingRig::Pendulum(_), AmplitudeCorrection::Auto) => Ok(AmplitudeCorrection::AgmWindowed),
        (SwingRig::Pendulum(_), AmplitudeCorrection::Trifilar) => {
            Err(AnalysisError::TrifilarCorrectionOnPendulum)
        }
        (_, c) => Ok(c),
    }
}

/// A swing: its signal, the natural period with the amplitude correction, its row.
fn swing_period(
    ctx: &mut Ctx,
    spec: &RunSpec,
    rig: SwingRig,
    signal: SignalKind,
    table: &CsvTable,
) -> Result<SwingPeriod, AnalysisError> {
    let s = ctx.s;
    let t = table.time("t_s")?;
    let column = match signal {
        SignalKind::Angle => "angle_deg",
        SignalKind::Rate => "rate_deg_s",
    };
    let x: Vec<f64> = table
        .numeric(column)?
        .into_iter()
        .map(f64::to_radians)
        .collect();
    let correction = amplitude_correction(rig, s.analysis.amplitude_correction)?;
    let opts = SwingOptions {
        method: s.analysis.period_method,
        correction: correction.scope(),
        window_cycles: s.analysis.window_cycles,
        discard_initial_cycles: s.analysis.discard_initial_cycles,
        min_cycles: s.analysis.min_cycles,
    };
    let period = match (rig, correction) {
        (SwingRig::Trifilar(spec_t), AmplitudeCorrection::Trifilar) => {
            let rig = TrifilarRig {
                radius_top_m: spec_t.radius_top_m.value,
                radius_bottom_m: spec_t.radius_bottom_m.value,
                length_m: spec_t.length_m.value,
                g_m_s2: s.g_m_s2.value,
            };
            swing::analyze(&t, &x, signal, &opts, &|a, t0| rig.period_ratio(a, t0))
        }
        _ => swing::analyze(&t, &x, signal, &opts, &|a, _| pendulum_period_ratio(a)),
    }?;
    let method = match s.analysis.period_method {
        PeriodMethod::Nls => Method::DampedSineNls,
        PeriodMethod::ZeroCrossing => Method::ZeroCrossing,
    };
    let axis = match rig {
        SwingRig::Pendulum(p) => p.axis.into(),
        SwingRig::Trifilar(_) => Axis::Yaw,
    };
    let correction_name = match correction {
        AmplitudeCorrection::None => "none",
        AmplitudeCorrection::AgmWhole => "agm_whole",
        AmplitudeCorrection::AgmWindowed | AmplitudeCorrection::Auto => "agm_windowed",
        AmplitudeCorrection::Trifilar => "trifilar",
    };
    let diagnostics = diag(&[
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
    ctx.push(Row {
        run: &spec.id,
        object: &object,
        axis,
        quantity: Quantity::PeriodNatural,
        method,
        value: (period.period_s, period.u_period_s),
        diagnostics,
    });
    Ok(period)
}

/// A static tilt test: its configurations, the first moment and offset with their
/// uncertainties, three rows.
fn static_test(
    ctx: &mut Ctx,
    spec: &RunSpec,
    pendulum: &PendulumSpec,
    tilt: &TiltSensor,
    table: &CsvTable,
) -> Result<Vec<StaticConfig>, AnalysisError> {
    let configs = statics::read_configs(&spec.file, table, tilt)?;
    let offset = statics::zero_offset(Some(tilt));
    let solution = pendulum::solve_first_moment(&statics::tilt_configs(&configs), offset)?;
    let object = ctx.object(spec);
    let axis = pendulum.axis.into();
    let diagnostics = diag(&[
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
    let mut inputs = Inputs::new();
    let config_inputs = statics::add_inputs(&mut inputs, &configs, pendulum);
    let offset_input = inputs.add(statics::offset_input(Some(tilt)));
    let first_moment = |x: &[f64]| -> Result<[f64; 3], MethodError> {
        let sol = pendulum::solve_first_moment(
            &statics::tilt_configs_at(&config_inputs, x),
            statics::zero_offset_at(offset, offset_input.of(x)),
        )?;
        Ok([sol.sx_kg_m, sol.sy_kg_m, sol.offset_rad])
    };
    let how = ctx.propagation();
    let [sx, sy, offset_rad] = propagate_each(&inputs, &first_moment, how)?;
    for (quantity, value) in [
        (Quantity::FirstMomentX, sx),
        (Quantity::FirstMomentY, sy),
        (Quantity::InclinometerOffset, offset_rad),
    ] {
        ctx.push(Row {
            run: &spec.id,
            object: &object,
            axis,
            quantity,
            method: Method::StaticTiltLs,
            value,
            diagnostics: diagnostics.clone(),
        });
    }
    Ok(configs)
}
