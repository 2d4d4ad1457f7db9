//! One (tire, rim, nominal pressure) group through every fitting stage, in dependency order.
//!
//! In: the group's loaded segments, the resolved stage configurations and the stages to run.
//! Out: a [`GroupResult`]: each stage's output, the `.tir` coefficients (PAC2002 model with the
//! spring-rate and relaxation results written in), failures as data, wall time per stage.
//!
//! The order is data: [`plan`] lists the [`Step`]s once per group and [`run`] walks them. With
//! every stage and `[fit] delag` on (the default), for a group with relaxation segments:
//!
//! ```text
//! step                       reads                               gives
//! SpringRate                 holds, free-rolling sweep crossings Cz, R0 (fit input), RE law
//! Pac2002 forces only        cornering, drive/brake, combined    Fy, Fx model (not written)
//! Relaxation                 sweeps, cold-to-warm, speed sweeps, sigma by load = de-lag lengths
//!                            step steers; that model
//! Pac2002Delagged            the same sweeps de-lagged           every family, k-fold: written
//! RelaxationFinal            the written model                   PTY*/PTX* of the written model
//! Record                                                         relaxation table, PAC2002 fit
//! SpringRateAtFittedFnomin   (only if FNOMIN differs from the    RE law at the fitted FNOMIN
//!                            spring rate's estimate)
//! Thermal                    cold-to-warm, air temperatures      mu(T) (independent)
//! ```
//!
//! With `[fit] grip_correction` on (the default) Thermal moves to the front: every PAC2002 fit
//! then reads the sweeps brought to a reference tread temperature with the group's `mu(T)`
//! ([`grip::correct`]); without a `mu(T)` fit the sweeps are fitted as measured.
//!
//! A stage's result does not depend on which other stages were asked for: every step it
//! depends on runs, asked for or not, and only the stages asked for report their tables and
//! failures. `--stages pac2002` writes the full fit's PAC2002 and MF 6.1 models but for what the
//! relaxation stage writes into them, which is there only when relaxation was asked for: the
//! `PTY*`/`PTX*` laws (`USE_MODE` + 10) and MF 6.1's carcass stiffnesses and their pressure
//! terms (coefficient family `relaxation`). So other stage sets drop only what nothing they
//! report depends on:
//! - without de-lagging (or without relaxation segments) the first PAC2002 fit is the written
//!   one (every family, k-fold) and relaxation, when asked for, runs once with it;
//! - relaxation without PAC2002: every fit is forces only and none is written (the moment
//!   families cost the most and relaxation reads only `Fy` and `Fx`); without de-lagging it is
//!   one fit;
//! - PAC2002 without relaxation still runs relaxation for the de-lag lengths, not its final
//!   pass; spring rate not asked for still runs for `Cz`/`R0`, thermal not asked for still runs
//!   first for the grip-temperature correction (their tables and failures are then not
//!   reported).
//!
//! What a group loads is derived from the same plan ([`used_by`]: the segment kinds some step
//! reads), so the segments read and the steps run cannot disagree.
//!
//! A step whose input is missing (no model, no vertical stiffness) records why when its stage
//! was asked for; every other stage still runs.
//!
//! Deliberately not here: reading the store (`load`), tables and file text (`tables`, `tir`).

use std::collections::BTreeMap;
use std::time::Instant;

use tirebase_core::fit::mf61::{Mf61Sample, Mf61Sweep};
use tirebase_core::fit::pac2002::{
    self, FitConfig, FitInput, Pac2002Fit, RelaxationLengths, RelaxationTable, Sweep,
    grip::{self, GripLaw, GripReference},
};
use tirebase_core::fit::relaxation::{
    self, Direction, RelaxationConfig, RelaxationInput, RelaxationOutput,
};
use tirebase_core::fit::segment_data::{MeasuredSegment, SegmentKind, StageFailure, TireKey};
use tirebase_core::fit::spring_rate::{self, SpringRateConfig, SpringRateOutput, TirVertical};
use tirebase_core::fit::sweep_folds::OutOfSampleQuality;
use tirebase_core::fit::thermal::{self, ThermalConfig, ThermalOutput};
use tirebase_core::numerics::stats::finite_median;
use tirebase_core::tire_model::Coef;

use super::load::LoadedSegment;
use super::{FitFailure, StageSet};

/// The resolved configuration of every stage.
#[derive(Clone, Debug, PartialEq)]
pub struct StageConfigs {
    /// PAC2002.
    pub pac2002: FitConfig,
    /// Spring rate.
    pub spring_rate: SpringRateConfig,
    /// Thermal.
    pub thermal: ThermalConfig,
    /// Relaxation.
    pub relaxation: RelaxationConfig,
}

/// Everything one group produced.
#[derive(Debug)]
pub struct GroupResult {
    /// The group.
    pub key: TireKey,
    /// Spring-rate output (rows and the `.tir` vertical numbers); also present when the stage
    /// only ran for the PAC2002 fit's sake (its table is then not written).
    pub spring_rate: Option<SpringRateOutput>,
    /// The final PAC2002 fit.
    pub pac2002: Option<Pac2002Fit>,
    /// Relaxation output (with the final model).
    pub relaxation: Option<RelaxationOutput>,
    /// Thermal output; also present when the stage only ran for the grip-temperature
    /// correction's sake (its tables are then not written).
    pub thermal: Option<ThermalOutput>,
    /// The reference temperatures the PAC2002 sweeps were brought to by the grip-temperature
    /// correction (`None`: fitted as measured).
    pub grip: Option<GripReference>,
    /// Mean measured inflation pressure of the PAC2002 sweeps, kPa.
    pub pressure_kpa_mean: f64,
    /// The relaxation lengths the final PAC2002 fit de-lagged its sweeps with (`None`: not
    /// de-lagged); the MF 6.1 stage de-lags the same way.
    pub delag: Option<RelaxationLengths>,
    /// Force-clean segments the PAC2002 stage was given.
    pub n_pac2002_segments: usize,
    /// PAC2002 fits run (2 when the sweeps were refitted de-lagged).
    pub pac2002_fits: usize,
    /// Model evaluations of those fits.
    pub pac2002_evaluations: usize,
    /// Failures (fatal and partial).
    pub failures: Vec<FitFailure>,
    /// Wall time per stage, s.
    pub stage_seconds: BTreeMap<String, f64>,
}

impl GroupResult {
    /// An empty result of `key` (nothing run yet).
    pub fn new(key: &TireKey) -> GroupResult {
        GroupResult {
            key: key.clone(),
            spring_rate: None,
            pac2002: None,
            relaxation: None,
            thermal: None,
            grip: None,
            pressure_kpa_mean: f64::NAN,
            delag: None,
            n_pac2002_segments: 0,
            pac2002_fits: 0,
            pac2002_evaluations: 0,
            failures: Vec::new(),
            stage_seconds: BTreeMap::new(),
        }
    }

    fn fail(&mut self, stage: &str, scope: &str, fatal: bool, reason: impl Into<String>) {
        self.failures.push(FitFailure::new(
            &self.key,
            stage,
            scope,
            fatal,
            reason.into(),
        ));
    }

    fn partial(&mut self, stage: &str, failures: &[StageFailure]) {
        for f in failures {
            self.fail(stage, &f.scope, false, f.reason.clone());
        }
    }

    fn time(&mut self, stage: &str, started: Instant) {
        *self.stage_seconds.entry(stage.to_string()).or_default() +=
            started.elapsed().as_secs_f64();
    }
}

/// Which stage reads which segments.
fn pac2002_segment(s: &LoadedSegment) -> bool {
    s.row.forces_ok && s.segment.kind.is_matrix()
}

/// Kinds the spring-rate stage reads (holds, and the zero crossings of free-rolling sweeps).
fn spring_rate_kind(kind: SegmentKind) -> bool {
    matches!(
        kind,
        SegmentKind::SpringRateStatic
            | SegmentKind::SpringRateDynamic
            | SegmentKind::Cornering
            | SegmentKind::DriveBrake
            | SegmentKind::Conditioning
            | SegmentKind::SpeedSweep
    )
}

/// Kinds the relaxation stage reads for the measurement lag of one speed: the spring-rate
/// holds' load steps.
fn load_step_kind(kind: SegmentKind) -> bool {
    relaxation::load_steps::is_hold(kind)
}

/// Kinds the relaxation stage fits relaxation lengths to.
fn relaxation_kind(kind: SegmentKind) -> bool {
    matches!(
        kind,
        SegmentKind::Cornering
            | SegmentKind::ColdToWarm
            | SegmentKind::SpeedSweep
            | SegmentKind::StepSteer
            | SegmentKind::DriveBrake
    )
}

/// Kinds the thermal stage reads: the cold-to-warm tests, and the air temperature of every
/// classified segment (the mu(T) gain's cold reference).
fn thermal_kind(kind: SegmentKind) -> bool {
    kind != SegmentKind::Other
}

fn spring_rate_segment(s: &LoadedSegment) -> bool {
    s.row.forces_ok && spring_rate_kind(s.segment.kind)
}

/// Cold-to-warm segments are analysed; every other temperature-clean segment only gives the
/// thermal stage the air temperature (its cold reference).
fn thermal_segment(s: &LoadedSegment) -> bool {
    s.row.temperatures_ok
}

fn relaxation_segment(s: &LoadedSegment) -> bool {
    s.row.forces_ok && relaxation_kind(s.segment.kind)
}

impl Step {
    /// Whether the step reads segments of `kind` (before the QC filter of its stage).
    fn reads(self, kind: SegmentKind) -> bool {
        match self {
            Step::SpringRate | Step::SpringRateAtFittedFnomin => spring_rate_kind(kind),
            Step::Pac2002 { .. } | Step::Pac2002Delagged { .. } => kind.is_matrix(),
            Step::Relaxation | Step::RelaxationFinal => {
                relaxation_kind(kind) || load_step_kind(kind)
            }
            Step::Thermal => thermal_kind(kind),
            Step::Record => false,
        }
    }
}

/// Whether a group's fit reads segments of `kind` (what the store loads for it and what its
/// hash covers): some step of its [`plan`] reads them. Decided before the groups exist, so from
/// the plan of a group with relaxation segments, whose steps include those of the plan
/// without.
pub fn used_by(stages: &StageSet, cfg: &StageConfigs, kind: SegmentKind) -> bool {
    plan(stages, cfg.pac2002.delag, true, cfg.pac2002.grip_correction)
        .iter()
        .any(|step| step.reads(kind))
}

/// `FNOMIN` as the PAC2002 stage chooses it ([`pac2002::middle_nominal_load`]), from the
/// group's matrix segments before the stage collapses them (it may skip some sweeps, so the
/// fitted `FNOMIN` can still differ: see [`Step::SpringRateAtFittedFnomin`]).
pub fn middle_nominal_load(segments: &[&LoadedSegment]) -> Option<f64> {
    let loads_of = |cornering_only: bool| -> Vec<f64> {
        segments
            .iter()
            .filter(|s| pac2002_segment(s))
            .filter(|s| !cornering_only || s.segment.kind == SegmentKind::Cornering)
            .filter_map(|s| s.segment.nominal.fz_n.map(|f| f as f64))
            .collect()
    };
    pac2002::middle_nominal_load(&loads_of(true), &loads_of(false))
}

/// The PAC2002 stage's view of the group's force-clean matrix segments.
fn pac2002_input(
    key: &TireKey,
    segments: &[&LoadedSegment],
    vertical: Option<&TirVertical>,
) -> Option<FitInput> {
    let sweeps: Vec<Sweep> = segments
        .iter()
        .filter(|s| pac2002_segment(s))
        // a drive/brake or combined sweep without a measured or derived slip ratio has nothing
        // to fit
        .filter(|s| s.segment.kind == SegmentKind::Cornering || has_kappa(s))
        .filter_map(|s| sweep_of(s))
        .collect();
    let speed_kph = finite_median(
        segments
            .iter()
            .filter(|s| pac2002_segment(s))
            .map(|s| s.row.speed_kph_mean),
    )?;
    Some(FitInput {
        context: spring_rate::pac2002_context(key, speed_kph / 3.6, vertical),
        sweeps,
    })
}

/// The sweeps the MF 6.1 stage reads from one group: the PAC2002 stage's (force-clean cornering,
/// and drive/brake and combined sweeps with a slip ratio), cleaned as it cleans them (despiked,
/// de-lagged with the group's relaxation lengths when it de-lagged), each sample with its
/// measured inflation pressure.
pub fn mf61_sweeps(
    segments: &[LoadedSegment],
    result: &GroupResult,
    cfg: &StageConfigs,
) -> Vec<Mf61Sweep> {
    let delag = if cfg.pac2002.delag {
        result.delag.as_ref()
    } else {
        None
    };
    segments
        .iter()
        .filter(|s| pac2002_segment(s))
        .filter(|s| s.segment.kind == SegmentKind::Cornering || has_kappa(s))
        .filter_map(|s| {
            let sweep = sweep_of(s)?;
            let c = &s.segment.channels;
            // Cleaning keeps samples by time: their pressure is found by it.
            let pressure_at = |et: f64| {
                c.et_s
                    .binary_search_by(|t| t.total_cmp(&et))
                    .ok()
                    .and_then(|i| c.pressure_kpa.get(i))
                    .map_or(f64::NAN, |p| p * 1e3)
            };
            let samples = pac2002::cleaned_samples(&sweep, cfg.pac2002.despike_sigmas, delag);
            Some(Mf61Sweep {
                id: sweep.id,
                kind: sweep.kind,
                samples: samples
                    .iter()
                    .map(|x| Mf61Sample {
                        fz_n: x.fz_n,
                        kappa: x.kappa,
                        alpha_rad: x.alpha_rad,
                        gamma_rad: x.gamma_rad,
                        vx_mps: x.vx_mps,
                        p_pa: pressure_at(x.et_s),
                        fx_n: x.fx_n,
                        fy_n: x.fy_n,
                        mz_nm: x.mz_nm,
                        mx_nm: x.mx_nm,
                    })
                    .collect(),
            })
        })
        .collect()
}

/// The segment's kappa is a slip (measured SL, or derived from N and V), not an assumed zero.
fn has_kappa(s: &LoadedSegment) -> bool {
    s.kappa_measured || s.kappa_derived
}

fn sweep_of(s: &LoadedSegment) -> Option<Sweep> {
    Sweep::from_segment(&s.segment, Some(&s.mx_nm), s.row.forces_ok)
}

/// Relaxation lengths by nominal load from the relaxation rows, for de-lagging.
fn delag_lengths(rx: &RelaxationOutput) -> Option<RelaxationLengths> {
    let by_load = relaxation::sigma_by_load(&rx.rows);
    let law = |d: Direction| RelaxationTable {
        by_load: by_load
            .iter()
            .filter(|((dir, fz), s)| *dir == d && *fz > 0 && s.is_finite() && **s > 0.0)
            .map(|((_, fz), s)| (*fz as f64, *s))
            .collect(),
    };
    let lengths = RelaxationLengths {
        sigma_alpha: law(Direction::Lateral),
        sigma_kappa: law(Direction::Longitudinal),
        measurement_lag_s: rx.measurement_lags.first().map_or(0.0, |m| m.lag.lag_s),
    };
    (!lengths.sigma_alpha.by_load.is_empty() || !lengths.sigma_kappa.by_load.is_empty())
        .then_some(lengths)
}

/// One step of a group's fit plan (see the module doc for the orders [`plan`] builds).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Spring rate at the nominal load the PAC2002 fit is expected to choose: `Cz`, `R0` for
    /// the fit (relaxation reads them too) and the `.tir` vertical numbers.
    SpringRate,
    /// PAC2002 on the sweeps as measured. `forces_only`: the moment channels are left out (the
    /// model only feeds relaxation, which reads `Fy` and `Fx`). `written`: the model to write,
    /// with its out-of-sample (k-fold) refits.
    Pac2002 {
        /// Fit the force families only.
        forces_only: bool,
        /// The model to write (out-of-sample refits run).
        written: bool,
    },
    /// Relaxation with the model so far: its lengths are what the sweeps are de-lagged with,
    /// and (when the stage is asked for) its output is the relaxation table.
    Relaxation,
    /// PAC2002 again on the sweeps de-lagged with the relaxation lengths (as measured when
    /// relaxation gave none; skipped then when it would repeat the first fit).
    Pac2002Delagged {
        /// Fit the force families only.
        forces_only: bool,
        /// The model to write (out-of-sample refits run).
        written: bool,
    },
    /// Relaxation again with the de-lagged model, so the written `PTY*`/`PTX*` belong to the
    /// written steady state (only when the refit was de-lagged).
    RelaxationFinal,
    /// Keep the relaxation output (when asked for) and the PAC2002 model to write, with their
    /// notes as partial failures.
    Record,
    /// Spring rate again when the fit chose another `FNOMIN` (the RE law is normalised by it).
    SpringRateAtFittedFnomin,
    /// mu(T) from the cold-to-warm tests (independent of the other stages; first when the
    /// PAC2002 fits read it for the grip-temperature correction).
    Thermal,
}

/// The fit plan of one group: which steps run, in order, for the enabled `stages`, `[fit]
/// delag`, whether the group has segments relaxation reads and `[fit] grip_correction`.
pub fn plan(
    stages: &StageSet,
    delag: bool,
    has_relax_segments: bool,
    grip_correction: bool,
) -> Vec<Step> {
    let mut steps = Vec::new();
    // Relaxation needs the PAC2002 model; both need the spring rate's Cz and R0.
    let fits = stages.pac2002 || stages.relaxation;
    // The grip-temperature correction of the PAC2002 sweeps reads the thermal stage's mu(T):
    // it runs first, asked for or not, so that the models do not depend on the stage set.
    let thermal_first = fits && grip_correction;
    if thermal_first {
        steps.push(Step::Thermal);
    }
    if stages.spring_rate || fits {
        steps.push(Step::SpringRate);
    }
    if fits {
        // De-lagging needs the relaxation lengths, which need a first model: that one is then
        // a forces-only pass, and so is every fit when only relaxation is asked for.
        let refit = delag && has_relax_segments;
        let written = stages.pac2002 && !refit;
        steps.push(Step::Pac2002 {
            forces_only: !written,
            written,
        });
        if stages.relaxation || refit {
            steps.push(Step::Relaxation);
        }
        if refit {
            steps.push(Step::Pac2002Delagged {
                forces_only: !stages.pac2002,
                written: stages.pac2002,
            });
            if stages.relaxation {
                steps.push(Step::RelaxationFinal);
            }
        }
        steps.push(Step::Record);
    }
    if stages.pac2002 {
        steps.push(Step::SpringRateAtFittedFnomin);
    }
    if stages.thermal && !thermal_first {
        steps.push(Step::Thermal);
    }
    steps
}

/// Run the enabled stages on one group's segments: build the [`plan`] and walk it.
pub fn run(
    key: &TireKey,
    segments: &[LoadedSegment],
    stages: &StageSet,
    cfg: &StageConfigs,
) -> GroupResult {
    let all: Vec<&LoadedSegment> = segments.iter().collect();
    let has_relax_segments = all.iter().any(|s| relaxation_segment(s));
    let mut walk = Walk {
        out: GroupResult::new(key),
        fnomin_estimate: middle_nominal_load(&all),
        all,
        stages,
        cfg,
        input: None,
        model: None,
        relax_segments: Vec::new(),
        vertical_for_relaxation: None,
        relaxation: None,
    };
    let steps = plan(
        stages,
        cfg.pac2002.delag,
        has_relax_segments,
        cfg.pac2002.grip_correction,
    );
    for step in steps {
        match step {
            Step::SpringRate => walk.spring_rate(walk.fnomin_estimate),
            Step::Pac2002 {
                forces_only,
                written,
            } => walk.pac2002(forces_only, written),
            Step::Relaxation => walk.relaxation(),
            Step::Pac2002Delagged {
                forces_only,
                written,
            } => walk.pac2002_delagged(forces_only, written),
            Step::RelaxationFinal => walk.relaxation_final(),
            Step::Record => walk.record(),
            Step::SpringRateAtFittedFnomin => walk.spring_rate_at_fitted_fnomin(),
            Step::Thermal => walk.thermal(),
        }
    }
    walk.out
}

/// A PAC2002 fit of the walk and how it was run.
struct Model {
    fit: Pac2002Fit,
    forces_only: bool,
    written: bool,
    /// Fitted on de-lagged sweeps.
    delagged: bool,
}

/// The state a group's plan is walked with.
struct Walk<'a> {
    out: GroupResult,
    all: Vec<&'a LoadedSegment>,
    stages: &'a StageSet,
    cfg: &'a StageConfigs,
    /// `FNOMIN` as the PAC2002 fit is expected to choose it.
    fnomin_estimate: Option<f64>,
    /// The PAC2002 stage's input (built by the first PAC2002 step; `None`: none could be).
    input: Option<FitInput>,
    /// The latest successful PAC2002 fit.
    model: Option<Model>,
    /// The segments relaxation reads, spring-rate holds included (filled by the first
    /// relaxation).
    relax_segments: Vec<MeasuredSegment>,
    /// Unloaded radius, m, and vertical stiffness, N/m, relaxation runs with.
    vertical_for_relaxation: Option<(f64, f64)>,
    /// The latest relaxation output.
    relaxation: Option<RelaxationOutput>,
}

impl Walk<'_> {
    /// Spring rate at `fnomin` (replacing an earlier run's output and failures). When the stage
    /// was not asked for, it ran only for the fit's sake: its failures are not reported.
    fn spring_rate(&mut self, fnomin: Option<f64>) {
        let started = Instant::now();
        let out = &mut self.out;
        out.failures.retain(|f| f.stage != "spring_rate");
        let segs: Vec<MeasuredSegment> = self
            .all
            .iter()
            .filter(|s| spring_rate_segment(s))
            .map(|s| s.segment.clone())
            .collect();
        let fnomin_map: BTreeMap<TireKey, f64> =
            fnomin.map(|f| (out.key.clone(), f)).into_iter().collect();
        let sr = spring_rate::run(&segs, &fnomin_map, &self.cfg.spring_rate);
        out.partial("spring_rate", &sr.failures);
        if sr.vertical.is_empty() {
            out.fail(
                "spring_rate",
                "spring_rate",
                true,
                if segs.is_empty() {
                    "no force-clean spring-rate hold or free-rolling sweep".to_string()
                } else {
                    "no vertical stiffness and unloaded radius for the .tir".to_string()
                },
            );
        }
        if !self.stages.spring_rate {
            out.failures.retain(|f| f.stage != "spring_rate");
        }
        out.spring_rate = Some(sr);
        out.time("spring_rate", started);
    }

    /// The spring rate's `.tir` vertical numbers, when it ran and found them.
    fn vertical(&self) -> Option<TirVertical> {
        self.out
            .spring_rate
            .as_ref()
            .and_then(|s| s.vertical.first().cloned())
    }

    /// The first PAC2002 fit (building the stage's input).
    fn pac2002(&mut self, forces_only: bool, written: bool) {
        let started = Instant::now();
        let vertical = self.vertical();
        let Some(input) = pac2002_input(&self.out.key, &self.all, vertical.as_ref()) else {
            self.out.fail(
                "pac2002",
                "pac2002",
                true,
                "no force-clean cornering, drive/brake or combined segment",
            );
            self.out.time("pac2002", started);
            return;
        };
        self.out.n_pac2002_segments = input.sweeps.len();
        let law = grip_law(self.out.thermal.as_ref(), &self.out.key, self.cfg);
        let input = match law {
            Some(law) => {
                let r0 = vertical
                    .as_ref()
                    .map(|v| v.unloaded_radius_m)
                    .or(input.context.unloaded_radius_m)
                    .unwrap_or(f64::NAN);
                let (corrected, reference) = grip::correct(&input, &law, r0);
                // no sample with a tread temperature: nothing was corrected
                if reference.samples_corrected == 0 {
                    input
                } else {
                    self.out.grip = Some(reference);
                    corrected
                }
            }
            None => input,
        };
        record_unusable_sweeps(&mut self.out, &self.all);
        self.out.pressure_kpa_mean = finite_median(
            self.all
                .iter()
                .filter(|s| pac2002_segment(s))
                .flat_map(|s| s.segment.channels.pressure_kpa.iter().copied()),
        )
        .unwrap_or(f64::NAN);
        self.fit(&input, forces_only, written, false);
        self.input = Some(input);
    }

    /// Relaxation with the first model; when it cannot run and the stage was asked for, why.
    fn relaxation(&mut self) {
        let cannot = match &self.model {
            None => Some("needs the PAC2002 model".to_string()),
            Some(_) if !self.all.iter().any(|s| relaxation_segment(s)) => {
                Some("no force-clean sweep, speed sweep or step steer".to_string())
            }
            Some(model) => {
                let (r0, cz) = match self.vertical() {
                    Some(v) => (v.unloaded_radius_m, v.vertical_stiffness_n_per_m),
                    None => (
                        model.fit.model.coefs[Coef::UNLOADED_RADIUS],
                        model.fit.model.coefs[Coef::VERTICAL_STIFFNESS],
                    ),
                };
                if cz > 0.0 && r0 > 0.0 {
                    self.vertical_for_relaxation = Some((r0, cz));
                    None
                } else {
                    Some(format!(
                        "no vertical stiffness/unloaded radius (Cz {cz} N/m, R0 {r0} m)"
                    ))
                }
            }
        };
        if let Some(reason) = cannot {
            if self.stages.relaxation {
                self.out.fail("relaxation", "relaxation", true, reason);
            }
            return;
        }
        self.relax_segments = self
            .all
            .iter()
            .filter(|s| {
                relaxation_segment(s) || (s.row.forces_ok && load_step_kind(s.segment.kind))
            })
            .map(|s| s.segment.clone())
            .collect();
        self.relax();
    }

    /// Relaxation with the latest model (set up by [`Walk::relaxation`]).
    fn relax(&mut self) {
        let (Some(model), Some((r0, cz))) = (&self.model, self.vertical_for_relaxation) else {
            return;
        };
        let started = Instant::now();
        let input = RelaxationInput {
            key: self.out.key.clone(),
            model: &model.fit.model,
            unloaded_radius_m: r0,
            vertical_stiffness_n_per_m: cz,
            segments: &self.relax_segments,
        };
        self.relaxation = Some(relaxation::run(
            std::slice::from_ref(&input),
            &self.cfg.relaxation,
        ));
        self.out.time("relaxation", started);
    }

    /// PAC2002 again, on sweeps de-lagged with the relaxation lengths.
    fn pac2002_delagged(&mut self, forces_only: bool, written: bool) {
        let (Some(mut input), Some(first)) = (self.input.take(), &self.model) else {
            return;
        };
        let lengths = self.relaxation.as_ref().and_then(delag_lengths);
        // Nothing to de-lag with and the same fit as the first: keep the first.
        if lengths.is_none() && first.forces_only == forces_only && first.written == written {
            self.input = Some(input);
            return;
        }
        input.context.relaxation = lengths;
        self.out.delag = input.context.relaxation.clone();
        let delagged = self.out.delag.is_some();
        self.fit(&input, forces_only, written, delagged);
        self.input = Some(input);
    }

    /// Relaxation again when the model was refitted de-lagged.
    fn relaxation_final(&mut self) {
        if self.model.as_ref().is_some_and(|m| m.delagged) {
            self.relax();
        }
    }

    /// One PAC2002 fit of `input` (the moment channels left out when `forces_only`); on
    /// success it becomes the walk's model. A failed fit leaves the earlier model, which is
    /// then not written (only a forces-only first pass precedes a refit).
    fn fit(&mut self, input: &FitInput, forces_only: bool, written: bool, delagged: bool) {
        let fit = if forces_only {
            run_fit(&mut self.out, &only_forces(input), self.cfg, written)
        } else {
            run_fit(&mut self.out, input, self.cfg, written)
        };
        if let Some(fit) = fit {
            self.model = Some(Model {
                fit,
                forces_only,
                written,
                delagged,
            });
        }
    }

    /// The relaxation output (when asked for) and the model to write (when PAC2002 was asked
    /// for), with their notes.
    fn record(&mut self) {
        if self.stages.relaxation
            && let Some(rx) = self.relaxation.take()
        {
            let out = &mut self.out;
            out.partial("relaxation", &rx.failures);
            if rx.laws.is_empty() {
                out.fail(
                    "relaxation",
                    "relaxation",
                    true,
                    "no relaxation length law (PTY1/PTY2, PTX1..3)",
                );
            } else if rx
                .laws
                .iter()
                .all(|l| l.lateral.is_none() && l.longitudinal.is_none())
            {
                // e.g. a lag-free (ideal) round: every sigma at its lower search bound.
                let at_bound = rx.rows.iter().filter(|r| r.at_bound).count();
                out.fail(
                    "relaxation",
                    "PTY1/PTY2, PTX1..3",
                    false,
                    format!(
                        "no law: {at_bound} of {} relaxation lengths sit on a search bound (no measurable lag?)",
                        rx.rows.len()
                    ),
                );
            }
            out.relaxation = Some(rx);
        }
        if self.stages.pac2002
            && let Some(mut model) = self.model.take_if(|m| m.written)
        {
            if let Some(g) = &self.out.grip {
                model.fit.notes.push(grip_note(g));
            }
            record_fit_notes(&mut self.out, &model.fit, self.cfg.pac2002.oos_ratio_limit);
            self.out.pac2002 = Some(model.fit);
        }
    }

    fn spring_rate_at_fitted_fnomin(&mut self) {
        if let (Some(fit), Some(est)) = (&self.out.pac2002, self.fnomin_estimate) {
            let fnomin = fit.model.coefs[Coef::FNOMIN];
            if (fnomin - est).abs() > 1e-6 * fnomin.abs().max(1.0) {
                self.spring_rate(Some(fnomin));
            }
        }
    }

    /// The thermal stage. When it was not asked for, it ran only for the grip-temperature
    /// correction's sake: its failures are not reported (its tables are not written).
    fn thermal(&mut self) {
        let started = Instant::now();
        let report = self.stages.thermal;
        let out = &mut self.out;
        let failures_before = out.failures.len();
        let segs: Vec<MeasuredSegment> = self
            .all
            .iter()
            .filter(|s| thermal_segment(s))
            .map(|s| s.segment.clone())
            .collect();
        if !segs.iter().any(|s| s.kind == SegmentKind::ColdToWarm) {
            out.fail(
                "thermal",
                "thermal",
                false,
                "no force- and temperature-clean cold_to_warm segment: nothing to fit",
            );
        } else {
            let th = thermal::run(&segs, &self.cfg.thermal);
            out.partial("thermal", &th.failures);
            if th.fits.is_empty() {
                out.fail("thermal", "thermal", true, "no mu(T) fit");
            }
            out.thermal = Some(th);
        }
        if !report {
            out.failures.truncate(failures_before);
        }
        out.time("thermal", started);
    }
}

/// The group's `mu(T)` law for the grip-temperature correction: its thermal fit, when `[fit]
/// grip_correction` is on, the thermal step ran before the PAC2002 fit and the law rises by at
/// least `grip_min_gain` from cold to optimum (`None` otherwise).
fn grip_law(th: Option<&ThermalOutput>, key: &TireKey, cfg: &StageConfigs) -> Option<GripLaw> {
    if !cfg.pac2002.grip_correction {
        return None;
    }
    let f = th?
        .fits
        .iter()
        .find(|f| &f.key == key && f.gain_peak_over_cold >= cfg.pac2002.grip_min_gain)?;
    GripLaw::new(
        f.t_peak_c,
        f.k_cold_per_c2,
        f.hot_falloff,
        cfg.thermal.ir_phase_revolutions,
    )
}

/// The `.tir` comment of a grip-corrected fit: the temperatures the model describes.
fn grip_note(g: &GripReference) -> String {
    let t = |v: Option<f64>| v.map_or("as measured".to_string(), |t| format!("{t:.1} degC"));
    format!(
        "grip-temperature correction: the model describes the tire at a tread surface \
         temperature of {} (lateral: Fy, Mz, Mx) and {} (longitudinal: Fx), where the thermal \
         stage's mu(T) equals the |F|/Fz-weighted mean grip of those sweeps; {} samples scaled \
         by mu(T)/mu(T_ref) in {:.3}..{:.3}",
        t(g.lateral_t_ref_c),
        t(g.longitudinal_t_ref_c),
        g.samples_corrected,
        g.factor_range.0,
        g.factor_range.1
    )
}

/// Force-clean matrix segments the PAC2002 stage could not be given, as partial failures (one
/// row per reason).
fn record_unusable_sweeps(out: &mut GroupResult, all: &[&LoadedSegment]) {
    let mut by_reason: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for s in all.iter().filter(|s| pac2002_segment(s)) {
        let reason = if s.segment.kind != SegmentKind::Cornering && !has_kappa(s) {
            "no longitudinal slip (no SL channel, none derivable from N and V)"
        } else if sweep_of(s).is_none() {
            "no nominal load or inclination (off-nominal level)"
        } else {
            continue;
        };
        by_reason
            .entry(reason)
            .or_default()
            .push(&s.segment.segment_id);
    }
    for (reason, ids) in by_reason {
        out.fail(
            "pac2002",
            &format!("{} sweeps", ids.len()),
            false,
            format!("{reason}: {}", ids.join(", ")),
        );
    }
}

/// Sweeps the PAC2002 stage skipped, families it could not fit and families flagged out of
/// sample (`out_of_sample_limit`: [`FitConfig::oos_ratio_limit`]), as partial failures.
fn record_fit_notes(out: &mut GroupResult, fit: &Pac2002Fit, out_of_sample_limit: f64) {
    for s in &fit.skipped_sweeps {
        out.fail(
            "pac2002",
            &format!("sweep {}", s.id),
            false,
            s.reason.clone(),
        );
    }
    let limit = out_of_sample_limit;
    for f in &fit.families {
        if let Some(q) = f.quality.as_ref().filter(|q| q.oos_flagged(limit)) {
            out.fail(
                "pac2002",
                &crate::store::results::out_of_sample_scope(f.family.as_str()),
                false,
                super::out_of_sample_reason(q, limit, "by sweep"),
            );
        }
        if let pac2002::FamilyStatus::Failed { reason } = &f.status {
            out.fail(
                "pac2002",
                &format!("family {}", f.family.as_str()),
                false,
                reason.clone(),
            );
        }
    }
}

/// The input without the moment channels: the moment families then have no data and are
/// skipped (a fit of the force families only).
fn only_forces(input: &FitInput) -> FitInput {
    let mut input = input.clone();
    for sweep in &mut input.sweeps {
        for sample in &mut sweep.samples {
            sample.mz_nm = f64::NAN;
            sample.mx_nm = f64::NAN;
        }
    }
    input
}

/// One PAC2002 fit, timed and counted; an error is a fatal failure of the stage. Without
/// `cross_validate` the out-of-sample refits are skipped (a pass that is not written).
fn run_fit(
    out: &mut GroupResult,
    input: &FitInput,
    cfg: &StageConfigs,
    cross_validate: bool,
) -> Option<Pac2002Fit> {
    let started = Instant::now();
    let mut fit_cfg = cfg.pac2002;
    if !cross_validate {
        fit_cfg.kfold = 0;
    }
    let fit = pac2002::fit(input, &fit_cfg);
    out.time("pac2002", started);
    out.pac2002_fits += 1;
    match fit {
        Ok(f) => {
            out.pac2002_evaluations += f.evaluations;
            Some(f)
        }
        Err(e) => {
            out.fail("pac2002", "pac2002", true, e.to_string());
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Step::*;

    fn stages(list: &str) -> StageSet {
        StageSet::parse(list).unwrap()
    }

    const FORCES: Step = Pac2002 {
        forces_only: true,
        written: false,
    };
    const WRITTEN: Step = Pac2002 {
        forces_only: false,
        written: true,
    };
    const DELAGGED: Step = Pac2002Delagged {
        forces_only: false,
        written: true,
    };
    const DELAGGED_FORCES: Step = Pac2002Delagged {
        forces_only: true,
        written: false,
    };

    #[test]
    fn every_stage_with_delag_fits_forces_then_the_delagged_model() {
        assert_eq!(
            plan(&stages("all"), true, true, false),
            [
                SpringRate,
                FORCES,
                Relaxation,
                DELAGGED,
                RelaxationFinal,
                Record,
                SpringRateAtFittedFnomin,
                Thermal,
            ]
        );
    }

    #[test]
    fn grip_correction_runs_thermal_before_the_fits() {
        assert_eq!(
            plan(&stages("all"), true, true, true),
            [
                Thermal,
                SpringRate,
                FORCES,
                Relaxation,
                DELAGGED,
                RelaxationFinal,
                Record,
                SpringRateAtFittedFnomin,
            ]
        );
        // thermal not asked for still runs first: the law is the full fit's
        assert_eq!(
            plan(&stages("pac2002"), true, true, true),
            [
                Thermal,
                SpringRate,
                FORCES,
                Relaxation,
                DELAGGED,
                Record,
                SpringRateAtFittedFnomin,
            ]
        );
        assert_eq!(plan(&stages("thermal"), true, true, true), [Thermal]);
    }

    /// The steps up to and including the fit that is written.
    fn through_written_fit(p: &[Step]) -> &[Step] {
        let last = p.iter().rposition(|s| {
            matches!(
                s,
                Pac2002 { written: true, .. } | Pac2002Delagged { written: true, .. }
            )
        });
        &p[..=last.expect("a written fit")]
    }

    #[test]
    fn the_written_model_has_the_same_steps_whatever_else_was_asked_for() {
        for list in [
            "pac2002",
            "pac2002,thermal",
            "pac2002,relaxation",
            "pac2002,spring_rate",
        ] {
            for (delag, has_relax, grip) in (0..8).map(|k| (k & 1 == 1, k & 2 == 2, k & 4 == 4)) {
                assert_eq!(
                    through_written_fit(&plan(&stages(list), delag, has_relax, grip)),
                    through_written_fit(&plan(&stages("all"), delag, has_relax, grip)),
                    "{list} delag {delag} relaxation segments {has_relax} grip {grip}"
                );
            }
        }
    }

    fn configs(delag: bool, grip_correction: bool) -> StageConfigs {
        let mut cfg = crate::fit::stage_configs(&crate::config::Config::default());
        cfg.pac2002.delag = delag;
        cfg.pac2002.grip_correction = grip_correction;
        cfg
    }

    #[test]
    fn every_kind_a_step_reads_is_loaded() {
        for list in [
            "all",
            "pac2002",
            "relaxation",
            "thermal",
            "spring_rate",
            "pac2002,relaxation",
            "relaxation,spring_rate",
        ] {
            let s = stages(list);
            for (delag, has_relax, grip) in (0..8).map(|k| (k & 1 == 1, k & 2 == 2, k & 4 == 4)) {
                let cfg = configs(delag, grip);
                for step in plan(&s, delag, has_relax, grip) {
                    for kind in SegmentKind::ALL.into_iter().filter(|k| step.reads(*k)) {
                        assert!(
                            used_by(&s, &cfg, kind),
                            "{list} delag {delag} grip {grip}: {step:?} reads {kind} segments"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn pac2002_alone_loads_what_its_delag_and_grip_law_read() {
        let s = stages("pac2002");
        for kind in [SegmentKind::ColdToWarm, SegmentKind::StepSteer] {
            assert!(used_by(&s, &configs(true, false), kind), "{kind}");
        }
        // no de-lag relaxation, no grip law: no step reads step steers
        assert!(!used_by(&s, &configs(false, false), SegmentKind::StepSteer));
        assert!(used_by(&s, &configs(false, true), SegmentKind::IaSweep));
        // nothing reads unclassified segments
        assert!(!used_by(
            &stages("all"),
            &configs(true, true),
            SegmentKind::Other
        ));
    }

    #[test]
    fn without_delag_or_relaxation_segments_the_first_fit_is_written() {
        let once = [
            SpringRate,
            WRITTEN,
            Relaxation,
            Record,
            SpringRateAtFittedFnomin,
            Thermal,
        ];
        assert_eq!(plan(&stages("all"), false, true, false), once);
        // no relaxation segments: relaxation is still a step (it records why it cannot run)
        assert_eq!(plan(&stages("all"), true, false, false), once);
    }

    #[test]
    fn pac2002_alone_runs_relaxation_only_for_the_delag_lengths() {
        assert_eq!(
            plan(&stages("pac2002"), true, true, false),
            [
                SpringRate,
                FORCES,
                Relaxation,
                DELAGGED,
                Record,
                SpringRateAtFittedFnomin,
            ]
        );
        assert_eq!(
            plan(&stages("pac2002"), false, true, false),
            [SpringRate, WRITTEN, Record, SpringRateAtFittedFnomin]
        );
    }

    #[test]
    fn relaxation_alone_fits_forces_only_and_writes_no_model() {
        // without de-lagging the forces-only fit is the only one
        assert_eq!(
            plan(&stages("relaxation"), false, true, false),
            [SpringRate, FORCES, Relaxation, Record]
        );
        assert_eq!(
            plan(&stages("relaxation"), true, true, false),
            [
                SpringRate,
                FORCES,
                Relaxation,
                DELAGGED_FORCES,
                RelaxationFinal,
                Record,
            ]
        );
        assert_eq!(
            plan(&stages("relaxation"), true, false, false),
            [SpringRate, FORCES, Relaxation, Record]
        );
    }

    #[test]
    fn stages_without_a_model_fit_nothing() {
        assert_eq!(plan(&stages("thermal"), true, true, false), [Thermal]);
        assert_eq!(
            plan(&stages("spring_rate"), true, true, false),
            [SpringRate]
        );
        assert_eq!(
            plan(&stages("spring_rate,thermal"), false, false, false),
            [SpringRate, Thermal]
        );
    }

    #[test]
    fn every_plan_fits_at_most_twice_and_writes_at_most_one_model() {
        for list in [
            "all",
            "pac2002",
            "relaxation",
            "pac2002,relaxation",
            "pac2002,thermal",
            "relaxation,spring_rate",
        ] {
            for (delag, has_relax, grip) in (0..8).map(|k| (k & 1 == 1, k & 2 == 2, k & 4 == 4)) {
                {
                    let s = stages(list);
                    let p = plan(&s, delag, has_relax, grip);
                    let fits: Vec<bool> = p
                        .iter()
                        .filter_map(|step| match *step {
                            Pac2002 { written, .. } | Pac2002Delagged { written, .. } => {
                                Some(written)
                            }
                            _ => None,
                        })
                        .collect();
                    assert!(matches!(fits.len(), 1 | 2), "{list} {delag} {has_relax}");
                    // the written model is the last fit, and only when PAC2002 was asked for
                    let written = fits.iter().filter(|w| **w).count();
                    assert_eq!(
                        written,
                        usize::from(s.pac2002),
                        "{list} {delag} {has_relax}"
                    );
                    assert!(!s.pac2002 || fits[fits.len() - 1], "{list}");
                    // relaxation reads a model: it comes after the first fit
                    let first_fit = p.iter().position(|x| matches!(x, Pac2002 { .. }));
                    let relax = p.iter().position(|x| *x == Relaxation);
                    assert!(relax.is_none_or(|r| first_fit.is_some_and(|f| f < r)));
                    // the grip-temperature correction reads mu(T): thermal before every fit
                    let thermal = p.iter().position(|x| *x == Thermal);
                    if grip && s.thermal {
                        assert!(thermal.is_some_and(|t| first_fit.is_some_and(|f| t < f)));
                    }
                    // thermal runs once, when asked for or read by the grip correction
                    assert_eq!(
                        p.iter().filter(|x| **x == Thermal).count(),
                        usize::from(s.thermal || grip)
                    );
                }
            }
        }
    }
}
