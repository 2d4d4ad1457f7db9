//! Rig inertia: vehicle yaw, pitch and roll inertia and CG position from rig sessions.
//!
//! Three rigs, one module each, all pure functions on numbers:
//! - [`yaw`]: air-bearing table driven by a falling mass (encoder events from [`encoder`]),
//!   exact torque balance, friction and tare identification, the thesis's simplified formula;
//! - [`trifilar`]: three-wire torsional pendulum with its own amplitude correction;
//! - [`pendulum`]: compound (stable) pendulum on a knife edge, static tilt for the first moment
//!   and CG, swing period for the inertia.
//!
//! [`swing`] turns an oscillation record into a small-amplitude natural period (damped-sine fits,
//! windowed amplitude correction); [`uncertainty`] propagates declared input uncertainties
//! (linearised or seeded Monte Carlo). [`session`] reads a session directory (`session.toml`
//! plus one CSV per run; the only file-system code here), validates it and plans each run, and
//! [`analysis`] measures the planned runs and combines them per rig into [`InertiaResult`] rows
//! and one [`InertiaRunError`] per failed run. Equations and validation cases:
//! `shared/docs/inertia-methods.md`; the file format: `schemas/inertia_session.md`.
//! Deliberately not here: Parquet output and the command line (root crate).

pub mod analysis;
pub mod encoder;
pub mod pendulum;
pub mod session;
pub mod swing;
pub mod trifilar;
pub mod uncertainty;
pub mod yaw;

#[cfg(test)]
mod validation;

use crate::numerics::NumericsError;

/// A measured input: value and standard uncertainty (k = 1) in the same unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// Best estimate.
    pub value: f64,
    /// Standard uncertainty (k = 1), >= 0.
    pub u: f64,
}

impl Measured {
    /// A value with uncertainty.
    pub const fn new(value: f64, u: f64) -> Self {
        Self { value, u }
    }
    /// A value taken as exact.
    pub const fn exact(value: f64) -> Self {
        Self { value, u: 0.0 }
    }
}

/// One output row: a quantity for an object from one run (or a combination of runs).
#[derive(Debug, Clone, PartialEq)]
pub struct InertiaResult {
    /// Session id.
    pub session: String,
    /// Run id, or several joined with `+` for results combining runs.
    pub run: String,
    /// What was measured: vehicle id, `table`, `platform`, a calibration body id.
    pub object: String,
    /// `yaw`, `pitch` or `roll` (inertia axis; for CG rows the pendulum axis of the test).
    pub axis: String,
    /// Quantity name, e.g. `inertia_cg`, `cg_height`, `friction_torque`.
    pub quantity: String,
    /// Estimation method, e.g. `falling_mass_exact`, `thesis_simplified`, `trifilar`.
    pub method: String,
    /// Value in `units`.
    pub value: f64,
    /// Standard uncertainty (k = 1) in `units`; NaN when it could not be evaluated.
    pub uncertainty: f64,
    /// SI unit of `value` and `uncertainty`.
    pub units: String,
    /// `key=value` pairs separated by `; `.
    pub diagnostics: String,
}

/// A physics or signal-processing failure of one run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MethodError {
    /// The encoder signal gave too few usable events.
    #[error("too few encoder edges: found {found}, need at least {needed}")]
    TooFewEdges { found: usize, needed: usize },
    /// Encoder events could not be assigned consistent band indices.
    #[error("encoder events are inconsistent: {reason}")]
    InconsistentEvents { reason: String },
    /// No usable oscillation period in a swing record.
    #[error("period not found: {reason}")]
    PeriodNotFound { reason: String },
    /// The static tilt configurations do not determine the first moment.
    #[error("static tilt test is underdetermined: {reason}")]
    StaticUnderdetermined { reason: String },
    /// A derived quantity is non-physical (e.g. negative inertia).
    #[error("non-physical result: {reason}")]
    NonPhysical { reason: String },
    /// A numerical routine rejected its input.
    #[error(transparent)]
    Numerics(#[from] NumericsError),
}

/// One failed run (or session), with a one-line message naming the session and run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{session}: run {run}: {message}")]
pub struct InertiaRunError {
    /// Session id (or directory name when the session could not be read).
    pub session: String,
    /// Run id, or `session.toml` for a session-level failure.
    pub run: String,
    /// What went wrong.
    pub message: String,
}

/// Formats diagnostics as `key=value; key=value`.
pub(crate) fn diag(pairs: &[(&str, String)]) -> String {
    pairs
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join("; ")
}
