//! A parsed session -> result rows and per-run errors.
//!
//! In: a [`Session`] and a reader for its run files. Out: [`SessionOutcome`]: [`InertiaResult`]
//! rows (per-run measurements such as acceleration, period and first moment, then the combined
//! results: vehicle inertia per rig, CG position, table inertia and friction) each with a
//! propagated standard uncertainty, plus one [`InertiaRunError`] per failed run. Three steps:
//! 1. plan every run ([`Session::plan`]: the sections it needs are valid),
//! 2. measure it (`measure`: read its file, one row per run),
//! 3. combine the measured runs per rig (`combine_yaw`, `combine_trifilar`,
//!    `combine_pendulum`).
//!
//! A failed run never stops the others; a result that needs a failed or absent run (e.g. a
//! vehicle swing without a platform tare) is reported as an error of the dependent run.
//! Deliberately no I/O beyond the reader closure and no output formatting.

mod combine_pendulum;
mod combine_trifilar;
mod combine_yaw;
mod measure;
mod row;
mod statics;

use super::session::{FrictionMethod, PlanError, Rig, Role, RunSpec, Session, SessionError};
use super::swing::SwingPeriod;
use super::uncertainty::Propagation;
use super::{InertiaResult, InertiaRunError, MethodError};
use measure::Measurement;
use row::Row;

/// Everything one session produced.
#[derive(Debug, Clone)]
pub struct SessionOutcome {
    /// Session id.
    pub session: String,
    /// Result rows.
    pub results: Vec<InertiaResult>,
    /// One error per failed run.
    pub errors: Vec<InertiaRunError>,
    /// Runs declared in the session.
    pub runs: usize,
}

/// Why a run (or a combination of runs) gave no result.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AnalysisError {
    /// A section the run needs is absent or invalid, or its calibration body is.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The run's entry, file or CSV is unusable.
    #[error(transparent)]
    Session(#[from] SessionError),
    /// The physics or signal processing failed.
    #[error(transparent)]
    Method(#[from] MethodError),
    /// A yaw file's `index` column does not increase.
    #[error("{file}: column index must increase strictly")]
    IndexNotIncreasing { file: String },
    /// A static tilt row adds a negative mass.
    #[error("{file}: row {row} (config {config}): added_mass_kg = {mass_kg} is negative")]
    NegativeAddedMass {
        file: String,
        row: usize,
        config: String,
        mass_kg: f64,
    },
    /// The rows of one static tilt configuration disagree on the reading.
    #[error("{file}: config {config} has rows with different tilt_deg")]
    InconsistentTilt { file: String, config: String },
    /// `amplitude_correction = "trifilar"` on a pendulum swing.
    #[error("analysis.amplitude_correction = \"trifilar\" applies to trifilar runs only")]
    TrifilarCorrectionOnPendulum,
    /// The yaw friction method lacks a value or a run.
    #[error("friction method {method:?} needs {needs}")]
    FrictionMethodNeeds {
        method: FrictionMethod,
        needs: &'static str,
    },
    /// The yaw table identification the vehicle runs depend on failed.
    #[error("yaw identification from {runs} failed")]
    IdentificationFailed { runs: String },
    /// A trifilar vehicle run without a platform run.
    #[error("trifilar vehicle run needs a successful platform (role = \"tare\") run")]
    TrifilarNeedsPlatform,
    /// A trifilar object without a mass.
    #[error("object mass: set run object_mass_kg or [vehicle] mass_kg ({0})")]
    ObjectMass(SessionError),
    /// Pendulum vehicle results without the runs or values they combine.
    #[error("pendulum results need {}", .0.join(", "))]
    PendulumNeeds(Vec<&'static str>),
    /// A pendulum vehicle swing without a platform swing.
    #[error("pendulum vehicle swing needs a successful platform swing run")]
    PendulumSwingNeedsPlatform,
}

/// The session being analysed and what it has produced so far.
struct Ctx<'s> {
    s: &'s Session,
    results: Vec<InertiaResult>,
    errors: Vec<InertiaRunError>,
    /// Propagations so far: each Monte Carlo propagation gets its own seed.
    mc_counter: u64,
}

impl Ctx<'_> {
    fn fail(&mut self, run: &str, error: impl Into<AnalysisError>) {
        self.errors.push(InertiaRunError {
            session: self.s.id.clone(),
            run: run.into(),
            message: error.into().to_string(),
        });
    }

    fn push(&mut self, row: Row) {
        self.results.push(row.into_result(&self.s.id));
    }

    /// The propagation of the next computation (a fresh Monte Carlo seed each time).
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

    /// The object column of a run's rows.
    fn object(&self, spec: &RunSpec) -> String {
        match spec.role {
            Role::Vehicle => spec
                .object
                .clone()
                .unwrap_or_else(|| self.s.vehicle_id.clone()),
            Role::Calibration => spec.calibration_body.clone().unwrap_or_default(),
            Role::Tare if spec.rig() == Rig::YawTable => "table".into(),
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
    let mut measured: Vec<Measurement> = Vec::new();
    for (id, spec) in &session.runs {
        match plan_and_measure(&mut ctx, spec, read) {
            Ok(m) => measured.push(m),
            Err(e) => ctx.fail(id, e),
        }
    }
    combine_yaw::combine(&mut ctx, &measured);
    combine_trifilar::combine(&mut ctx, &measured);
    combine_pendulum::combine(&mut ctx, &measured);
    SessionOutcome {
        session: session.id.clone(),
        results: ctx.results,
        errors: ctx.errors,
        runs: session.runs.len(),
    }
}

/// Steps 1 and 2 for one run: its plan, then its measurement.
fn plan_and_measure<'s>(
    ctx: &mut Ctx<'s>,
    spec: &'s Result<RunSpec, SessionError>,
    read: &dyn Fn(&str) -> Result<String, SessionError>,
) -> Result<Measurement<'s>, AnalysisError> {
    let spec = spec.as_ref().map_err(Clone::clone)?;
    let plan = ctx.s.plan(spec)?;
    measure::measure(ctx, plan, read)
}

/// The successful swings of one rig and role.
fn swings<'m, 's>(
    measured: &'m [Measurement<'s>],
    rig: Rig,
    role: Role,
) -> Vec<(&'s RunSpec, &'m SwingPeriod)> {
    measured
        .iter()
        .filter_map(|m| match m {
            Measurement::Swing { spec, period } if spec.rig() == rig && spec.role == role => {
                Some((*spec, period))
            }
            _ => None,
        })
        .collect()
}

/// Mean period of several tare swings with the uncertainty of the mean of independent runs.
fn mean_period(runs: &[(&RunSpec, &SwingPeriod)]) -> super::Measured {
    let n = runs.len() as f64;
    let mean = runs.iter().map(|(_, p)| p.period_s).sum::<f64>() / n;
    let u = runs
        .iter()
        .map(|(_, p)| p.u_period_s.powi(2))
        .sum::<f64>()
        .sqrt()
        / n;
    super::Measured::new(mean, u)
}

/// Run ids joined with `+`: the run column of a result combining runs.
fn join_ids(specs: &[&RunSpec]) -> String {
    specs
        .iter()
        .map(|s| s.id.as_str())
        .collect::<Vec<_>>()
        .join("+")
}
