//! Planning: one run of a validated [`Session`] -> the validated sections it needs.
//!
//! In: a [`Session`] and one of its [`RunSpec`]s. Out: a [`RunPlan`] that holds, by rig, the
//! constants the run's measurement uses (yaw table and encoder, trifilar, pendulum and tilt
//! sensor) and for a calibration run its body; or a [`PlanError`] naming the section that is
//! absent or invalid. A run is planned before its file is read, so a session without
//! `[trifilar]` fails its trifilar runs and nothing else. Deliberately no file access and no
//! arithmetic: the analysis works on plans and never looks a section up again.

use super::{
    CalibrationBody, EncoderSpec, PendulumKind, PendulumSpec, Role, RunSetup, RunSpec, Session,
    SessionError, TiltSensor, TrifilarSpec, YawTableSpec,
};
use crate::inertia::Measured;
use crate::inertia::swing::SignalKind;

/// Why a run cannot be measured before its file is even read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    /// A section or sensor the run needs is absent or invalid.
    #[error(transparent)]
    Section(#[from] SessionError),
    /// The run names a calibration body the session does not declare.
    #[error("calibration_body {0:?} is not declared in [[calibration_body]]")]
    UndeclaredCalibrationBody(String),
    /// A calibration run without a calibration body.
    #[error("calibration_body: required for calibration runs")]
    NoCalibrationBody,
}

/// What was on the yaw table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum YawLoad<'s> {
    /// The empty table.
    Tare,
    /// The table with a calibration body of known inertia.
    Calibration(&'s CalibrationBody),
    /// The table with the vehicle (or object).
    Vehicle,
}

/// A run's rig with the validated constants its measurement needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RigPlan<'s> {
    /// A yaw-table drop.
    Yaw {
        /// Yaw-table constants.
        table: &'s YawTableSpec,
        /// Encoder settings.
        encoder: &'s EncoderSpec,
        /// Falling mass (kg).
        falling_mass_kg: Measured,
        /// What was on the table.
        load: YawLoad<'s>,
    },
    /// A trifilar swing.
    TrifilarSwing {
        /// Trifilar constants.
        rig: &'s TrifilarSpec,
        /// Swing signal column.
        signal: SignalKind,
    },
    /// A compound-pendulum swing.
    PendulumSwing {
        /// Pendulum constants.
        pendulum: &'s PendulumSpec,
        /// Swing signal column.
        signal: SignalKind,
    },
    /// A compound-pendulum static tilt test.
    PendulumStatic {
        /// Pendulum constants.
        pendulum: &'s PendulumSpec,
        /// Inclinometer settings.
        tilt: &'s TiltSensor,
    },
}

/// A run ready to be measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunPlan<'s> {
    /// The run as declared.
    pub spec: &'s RunSpec,
    /// Its rig and that rig's constants.
    pub rig: RigPlan<'s>,
}

impl Session {
    /// The plan of one run: its rig's sections first (yaw table and encoder; trifilar;
    /// pendulum, and the tilt sensor for a static test), then the calibration body it names.
    pub fn plan<'s>(&'s self, spec: &'s RunSpec) -> Result<RunPlan<'s>, PlanError> {
        let rig = match spec.setup {
            RunSetup::YawTable { falling_mass_kg } => {
                let table = section(&self.yaw_table)?;
                let encoder = section(&self.encoder)?;
                let body = self.calibration_body(spec)?;
                let load = match (spec.role, body) {
                    (Role::Tare, _) => YawLoad::Tare,
                    (Role::Vehicle, _) => YawLoad::Vehicle,
                    (Role::Calibration, Some(body)) => YawLoad::Calibration(body),
                    (Role::Calibration, None) => return Err(PlanError::NoCalibrationBody),
                };
                return Ok(RunPlan {
                    spec,
                    rig: RigPlan::Yaw {
                        table,
                        encoder,
                        falling_mass_kg,
                        load,
                    },
                });
            }
            RunSetup::Trifilar { signal } => RigPlan::TrifilarSwing {
                rig: section(&self.trifilar)?,
                signal,
            },
            RunSetup::Pendulum {
                kind: PendulumKind::Swing,
                signal,
            } => RigPlan::PendulumSwing {
                pendulum: section(&self.pendulum)?,
                signal,
            },
            RunSetup::Pendulum {
                kind: PendulumKind::Static,
                ..
            } => RigPlan::PendulumStatic {
                pendulum: section(&self.pendulum)?,
                tilt: section(&self.tilt)?,
            },
        };
        self.calibration_body(spec)?;
        Ok(RunPlan { spec, rig })
    }

    /// The calibration body a run names (`None` when it names none).
    fn calibration_body(&self, spec: &RunSpec) -> Result<Option<&CalibrationBody>, PlanError> {
        let Some(id) = &spec.calibration_body else {
            return Ok(None);
        };
        match self.calibration_bodies.get(id) {
            None => Err(PlanError::UndeclaredCalibrationBody(id.clone())),
            Some(Err(e)) => Err(e.clone().into()),
            Some(Ok(body)) => Ok(Some(body)),
        }
    }
}

/// A validated section, or its error for the run that needs it.
fn section<T>(value: &Result<T, SessionError>) -> Result<&T, SessionError> {
    value.as_ref().map_err(Clone::clone)
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "format = \"rig-inertia-session\"\nformat_version = 1\n\
        [session]\nid = \"s\"\n[site]\ng_m_s2 = 9.81\n\
        [sensors.encoder]\nevent_spacing_deg = 4\n\
        [yaw_table]\ndrum_radius_m = 0.15\ntable_inertia_kg_m2 = \"from_runs\"\n\
        [[calibration_body]]\nid = \"disc\"\nmass_kg = 10\ninertia_kg_m2 = -1\n";

    /// Each run's planning error (its message), `None` for a run that plans.
    fn plan_of(runs: &str) -> Vec<Option<String>> {
        let session = Session::parse(&format!("{HEAD}{runs}")).unwrap();
        session
            .runs
            .iter()
            .map(|(_, spec)| match spec {
                Ok(spec) => session.plan(spec).err().map(|e| e.to_string()),
                Err(e) => Some(e.to_string()),
            })
            .collect()
    }

    #[test]
    fn a_run_fails_on_the_first_section_it_needs() {
        let out = plan_of(
            "[[run]]\nid = \"t\"\nrig = \"trifilar\"\nrole = \"tare\"\nfile = \"t.csv\"\n\
             [[run]]\nid = \"p\"\nrig = \"pendulum\"\nrole = \"tare\"\nkind = \"static\"\nfile = \"p.csv\"\n\
             [[run]]\nid = \"y\"\nrig = \"yaw_table\"\nrole = \"tare\"\nfile = \"y.csv\"\nfalling_mass_kg = 5\n",
        );
        assert_eq!(
            out[0],
            Some("session.toml: [trifilar]: section is required by this run but absent".into())
        );
        assert_eq!(
            out[1],
            Some("session.toml: [pendulum]: section is required by this run but absent".into())
        );
        assert!(out[2].is_none(), "{:?}", out[2]);
    }

    #[test]
    fn calibration_bodies_are_resolved_or_named() {
        let out = plan_of(
            "[[run]]\nid = \"c\"\nrig = \"yaw_table\"\nrole = \"calibration\"\nfile = \"c.csv\"\n\
             falling_mass_kg = 5\ncalibration_body = \"disc\"\n\
             [[run]]\nid = \"v\"\nrig = \"yaw_table\"\nrole = \"vehicle\"\nfile = \"v.csv\"\n\
             falling_mass_kg = 5\ncalibration_body = \"ring\"\n",
        );
        assert_eq!(
            out[0],
            Some("session.toml: calibration_body.disc.inertia_kg_m2: must be > 0, got -1".into())
        );
        assert_eq!(
            out[1],
            Some("calibration_body \"ring\" is not declared in [[calibration_body]]".into())
        );
    }
}
