//! Step 3, trifilar pendulum: platform swings and object swings -> platform and object inertia.
//!
//! In: the session's successful trifilar swings. Out: the platform's inertia (from the mean
//! period of its swings) and per object swing the object's inertia about the rig axis, the
//! platform tare subtracted inside one propagated computation (methods section 3).

use super::measure::Measurement;
use super::row::{Axis, Method, Quantity, Row};
use super::{AnalysisError, Ctx, join_ids, mean_period, swings};
use crate::inertia::session::{Rig, Role, RunSpec};
use crate::inertia::trifilar::TrifilarRig;
use crate::inertia::uncertainty::{Input, Inputs, propagate_each};
use crate::inertia::{Measured, MethodError, diag};

/// The rig constants and the platform, as inputs.
struct PlatformInputs {
    g: Input,
    radius_top: Input,
    radius_bottom: Input,
    length: Input,
    platform_mass: Input,
    platform_period: Input,
}

impl PlatformInputs {
    fn rig(&self, x: &[f64]) -> TrifilarRig {
        TrifilarRig {
            g_m_s2: self.g.of(x),
            radius_top_m: self.radius_top.of(x),
            radius_bottom_m: self.radius_bottom.of(x),
            length_m: self.length.of(x),
        }
    }
}

/// Platform inertia, then each object.
pub(super) fn combine(ctx: &mut Ctx, measured: &[Measurement]) {
    let s = ctx.s;
    let tares = swings(measured, Rig::Trifilar, Role::Tare);
    let objects = swings(measured, Rig::Trifilar, Role::Vehicle);
    if tares.is_empty() && objects.is_empty() {
        return;
    }
    let Ok(spec_t) = s.trifilar.as_ref() else {
        return;
    };
    if tares.is_empty() {
        for (spec, _) in &objects {
            ctx.fail(&spec.id, AnalysisError::TrifilarNeedsPlatform);
        }
        return;
    }
    let mut inputs = Inputs::new();
    let platform = PlatformInputs {
        g: inputs.add(s.g_m_s2),
        radius_top: inputs.add(spec_t.radius_top_m),
        radius_bottom: inputs.add(spec_t.radius_bottom_m),
        length: inputs.add(spec_t.length_m),
        platform_mass: inputs.add(spec_t.platform_mass_kg),
        platform_period: inputs.add(mean_period(&tares)),
    };
    let tare_specs: Vec<&RunSpec> = tares.iter().map(|(s, _)| *s).collect();
    let tare_ids = join_ids(&tare_specs);
    let prop = ctx.propagation_name();
    let platform_inertia = |x: &[f64]| -> Result<[f64; 1], MethodError> {
        let rig = platform.rig(x);
        Ok([rig.system_inertia(platform.platform_mass.of(x), platform.platform_period.of(x))])
    };
    let how = ctx.propagation();
    if let Ok([inertia]) = propagate_each(&inputs, &platform_inertia, how) {
        ctx.push(Row {
            run: &tare_ids,
            object: "platform",
            axis: Axis::Yaw,
            quantity: Quantity::Inertia,
            method: Method::Trifilar,
            value: inertia,
            diagnostics: diag(&[("uncertainty", prop.into())]),
        });
    }
    for (spec, period) in &objects {
        let object_mass = match spec
            .object_mass_kg
            .map(Ok)
            .unwrap_or_else(|| s.vehicle_mass_kg.clone())
        {
            Ok(m) => m,
            Err(e) => {
                ctx.fail(&spec.id, AnalysisError::ObjectMass(e));
                continue;
            }
        };
        let mut inputs = inputs.clone();
        let mass = inputs.add(object_mass);
        let object_period = inputs.add(Measured::new(period.period_s, period.u_period_s));
        let object_inertia = |x: &[f64]| -> Result<[f64; 2], MethodError> {
            let rig = platform.rig(x);
            let (m_p, t_p) = (platform.platform_mass.of(x), platform.platform_period.of(x));
            let (m_o, t_o) = (mass.of(x), object_period.of(x));
            let object = rig.object_inertia(m_p, t_p, m_p + m_o, t_o);
            Ok([object, rig.system_inertia(m_p + m_o, t_o)])
        };
        let how = ctx.propagation();
        match propagate_each(&inputs, &object_inertia, how) {
            Ok([object, system]) if object.0 > 0.0 => {
                let name = ctx.object(spec);
                let diagnostics = diag(&[
                    ("tare_runs", tare_ids.clone()),
                    ("system_inertia_kg_m2", format!("{:.6}", system.0)),
                    ("tare_amplification", format!("{:.3}", system.0 / object.0)),
                    ("uncertainty", prop.into()),
                ]);
                ctx.push(Row {
                    run: &spec.id,
                    object: &name,
                    axis: Axis::Yaw,
                    quantity: Quantity::Inertia,
                    method: Method::Trifilar,
                    value: object,
                    diagnostics,
                });
            }
            Ok([object, _]) => ctx.fail(
                &spec.id,
                MethodError::NonPhysical {
                    reason: format!("object inertia {:.4} kg m^2 <= 0", object.0),
                },
            ),
            Err(e) => ctx.fail(&spec.id, e),
        }
    }
}
