//! One (tire, rim, nominal pressure) group through every fitting stage, in dependency order.
//!
//! In: the group's loaded segments, the resolved stage configurations and the stages to run.
//! Out: a [`GroupResult`]: each stage's output, the `.tir` coefficients (PAC2002 model with the
//! spring-rate and relaxation results written in), failures as data, wall time per stage.
//!
//! Order (issues 5 and 6): spring rate (holds + free-rolling sweep crossings) -> PAC2002 on the
//! force-clean cornering, drive/brake and combined segments, with `Cz`/`R0` from the spring-rate
//! stage (else the fit takes them from `RL` at low slip) -> relaxation with that model (sweeps,
//! cold-to-warm sweeps, speed sweeps, step steers) -> when `[fit] delag` is on and relaxation
//! gave lengths, PAC2002 again on de-lagged sweeps and relaxation again with the final model (so
//! the written `PTY*`/`PTX*` belong to the written steady state). With de-lagging the first
//! PAC2002 pass fits the force families only (relaxation reads `Fy`, `Fx`; `Mz`, `Mx` cost the
//! most and do not change the forces). Thermal (cold-to-warm) is independent. Every stage's
//! failure is recorded and the others still run.
//!
//! Deliberately not here: reading the store (`load`), tables and file text (`tables`, `tir`).

use std::collections::BTreeMap;
use std::time::Instant;

use tirebase_core::fit::mf61::{Mf61Sample, Mf61Sweep};
use tirebase_core::fit::pac2002::{
    self, FitConfig, FitInput, Pac2002Fit, RelaxationLengths, RelaxationTable, Sweep,
};
use tirebase_core::fit::relaxation::{
    self, Direction, RelaxationConfig, RelaxationInput, RelaxationOutput,
};
use tirebase_core::fit::segment_data::{MeasuredSegment, SegmentKind, StageFailure, TireKey};
use tirebase_core::fit::spring_rate::{self, SpringRateConfig, SpringRateOutput, TirVertical};
use tirebase_core::fit::sweep_folds::OutOfSampleQuality;
use tirebase_core::fit::thermal::{self, ThermalConfig, ThermalOutput};
use tirebase_core::numerics::stats::finite_median;

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
    /// Thermal output.
    pub thermal: Option<ThermalOutput>,
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

/// Kinds the relaxation stage reads.
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

/// The segment kinds any enabled stage reads (what a group's plan and hash cover).
pub fn used_by(stages: &StageSet, kind: SegmentKind) -> bool {
    let pac = kind.is_matrix();
    let spring = spring_rate_kind(kind);
    // The cold-to-warm tests, and the air temperature of every classified segment (the mu(T)
    // gain's cold reference): `--stages thermal` reads what the full fit reads.
    let thermal = kind != SegmentKind::Other;
    let relax = relaxation_kind(kind);
    // PAC2002 needs the spring-rate segments for Cz/R0 and relaxation needs the PAC2002 model.
    (stages.pac2002 && (pac || spring))
        || (stages.spring_rate && spring)
        || (stages.thermal && thermal)
        || (stages.relaxation && (relax || pac || spring))
}

/// `FNOMIN` as the PAC2002 stage chooses it: the middle nominal load of the cornering matrix
/// (else of all matrix sweeps), levels closer than 2 % merged.
pub fn middle_nominal_load(segments: &[&LoadedSegment]) -> Option<f64> {
    let loads_of = |cornering_only: bool| -> Vec<f64> {
        segments
            .iter()
            .filter(|s| pac2002_segment(s))
            .filter(|s| !cornering_only || s.segment.kind == SegmentKind::Cornering)
            .filter_map(|s| s.segment.nominal.fz_n.map(|f| f as f64))
            .collect()
    };
    let mut loads = loads_of(true);
    if loads.is_empty() {
        loads = loads_of(false);
    }
    loads.sort_by(f64::total_cmp);
    let mut levels: Vec<f64> = Vec::new();
    for l in loads {
        if levels
            .last()
            .is_none_or(|last| l - last > 0.02 * last.abs().max(1.0))
        {
            levels.push(l);
        }
    }
    (!levels.is_empty()).then(|| levels[(levels.len() - 1) / 2])
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

/// Run the enabled stages on one group's segments.
pub fn run(
    key: &TireKey,
    segments: &[LoadedSegment],
    stages: &StageSet,
    cfg: &StageConfigs,
) -> GroupResult {
    let mut out = GroupResult::new(key);
    let all: Vec<&LoadedSegment> = segments.iter().collect();

    // Spring rate: needed by the PAC2002 fit (Cz, R0) and by relaxation (Cz, R0).
    let needs_vertical = stages.spring_rate || stages.pac2002 || stages.relaxation;
    let fnomin_estimate = middle_nominal_load(&all);
    if needs_vertical {
        run_spring_rate(&mut out, &all, fnomin_estimate, cfg);
    }
    let vertical = out
        .spring_rate
        .as_ref()
        .and_then(|s| s.vertical.first().cloned());

    if stages.pac2002 || stages.relaxation {
        run_pac2002_and_relaxation(&mut out, key, &all, vertical.as_ref(), stages, cfg);
    }
    // The RE law is normalised by FNOMIN: redo it if the fit chose another nominal load.
    if let (Some(fit), Some(est)) = (&out.pac2002, fnomin_estimate) {
        let fnomin = fit.model.coefs[tirebase_core::tire_model::Coef::FNOMIN];
        if (fnomin - est).abs() > 1e-6 * fnomin.abs().max(1.0) {
            run_spring_rate(&mut out, &all, Some(fnomin), cfg);
        }
    }
    if !stages.spring_rate {
        // used for Cz, R0 and the RE law of the .tir, but not asked for: not reported.
        out.failures.retain(|f| f.stage != "spring_rate");
    }

    if stages.thermal {
        let started = Instant::now();
        let segs: Vec<MeasuredSegment> = all
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
            let th = thermal::run(&segs, &cfg.thermal);
            out.partial("thermal", &th.failures);
            if th.fits.is_empty() {
                out.fail("thermal", "thermal", true, "no mu(T) fit");
            }
            out.thermal = Some(th);
        }
        out.time("thermal", started);
    }
    out
}

fn run_spring_rate(
    out: &mut GroupResult,
    all: &[&LoadedSegment],
    fnomin: Option<f64>,
    cfg: &StageConfigs,
) {
    let started = Instant::now();
    out.failures.retain(|f| f.stage != "spring_rate");
    let segs: Vec<MeasuredSegment> = all
        .iter()
        .filter(|s| spring_rate_segment(s))
        .map(|s| s.segment.clone())
        .collect();
    let fnomin_map: BTreeMap<TireKey, f64> =
        fnomin.map(|f| (out.key.clone(), f)).into_iter().collect();
    let sr = spring_rate::run(&segs, &fnomin_map, &cfg.spring_rate);
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
    out.spring_rate = Some(sr);
    out.time("spring_rate", started);
}

fn run_pac2002_and_relaxation(
    out: &mut GroupResult,
    key: &TireKey,
    all: &[&LoadedSegment],
    vertical: Option<&TirVertical>,
    stages: &StageSet,
    cfg: &StageConfigs,
) {
    let started = Instant::now();
    let Some(mut input) = pac2002_input(key, all, vertical) else {
        out.fail(
            "pac2002",
            "pac2002",
            true,
            "no force-clean cornering, drive/brake or combined segment",
        );
        if stages.relaxation {
            out.fail("relaxation", "relaxation", true, "needs the PAC2002 model");
        }
        out.time("pac2002", started);
        return;
    };
    out.n_pac2002_segments = input.sweeps.len();
    record_unusable_sweeps(out, all);
    out.pressure_kpa_mean = finite_median(
        all.iter()
            .filter(|s| pac2002_segment(s))
            .flat_map(|s| s.segment.channels.pressure_kpa.iter().copied()),
    )
    .unwrap_or(f64::NAN);
    let relax_segments: Vec<MeasuredSegment> = all
        .iter()
        .filter(|s| relaxation_segment(s))
        .map(|s| s.segment.clone())
        .collect();
    // Relaxation lengths: always when de-lagging, else only when asked for.
    let wants_relaxation = (stages.relaxation || cfg.pac2002.delag) && !relax_segments.is_empty();
    // The relaxation stage reads only Fy and Fx of the model. When a second PAC2002 fit follows
    // anyway (de-lagging) or the model is not written (relaxation alone), the first fit leaves
    // the moments out: the force families do not depend on them, so the relaxation lengths are
    // the same and the first pass costs a fraction (Mz and Mx are the expensive families).
    let forces_first = wants_relaxation && (cfg.pac2002.delag || !stages.pac2002);
    let first_input = if forces_first {
        forces_only(&input)
    } else {
        input.clone()
    };
    // The forces-only pass is never written: no out-of-sample refits for it.
    let first = match run_fit(out, &first_input, cfg, !forces_first) {
        Some(f) => f,
        None => {
            if stages.relaxation {
                out.fail("relaxation", "relaxation", true, "needs the PAC2002 model");
            }
            return;
        }
    };
    let (r0, cz) = match vertical {
        Some(v) => (v.unloaded_radius_m, v.vertical_stiffness_n_per_m),
        None => (
            first.model.coefs[tirebase_core::tire_model::Coef::UNLOADED_RADIUS],
            first.model.coefs[tirebase_core::tire_model::Coef::VERTICAL_STIFFNESS],
        ),
    };
    let relax = |model: &Pac2002Fit| {
        let input = RelaxationInput {
            key: key.clone(),
            model: &model.model,
            unloaded_radius_m: r0,
            vertical_stiffness_n_per_m: cz,
            segments: &relax_segments,
        };
        relaxation::run(std::slice::from_ref(&input), &cfg.relaxation)
    };
    let can_relax = cz > 0.0 && r0 > 0.0;
    if !wants_relaxation || !can_relax {
        if stages.relaxation {
            out.fail(
                "relaxation",
                "relaxation",
                true,
                if relax_segments.is_empty() {
                    "no force-clean sweep, speed sweep or step steer".to_string()
                } else {
                    format!("no vertical stiffness/unloaded radius (Cz {cz} N/m, R0 {r0} m)")
                },
            );
        }
        if !stages.pac2002 {
            return;
        }
        let fit = if forces_first {
            match run_fit(out, &input, cfg, true) {
                Some(f) => f,
                None => return,
            }
        } else {
            first
        };
        record_fit_notes(out, &fit, cfg.pac2002.oos_ratio_limit);
        out.pac2002 = Some(fit);
        return;
    }
    let started = Instant::now();
    let mut rx = relax(&first);
    out.time("relaxation", started);
    let lengths = if cfg.pac2002.delag {
        delag_lengths(&rx)
    } else {
        None
    };
    let refit = lengths.is_some();
    let fit = if forces_first || refit {
        input.context.relaxation = lengths;
        out.delag = input.context.relaxation.clone();
        let second_input = if stages.pac2002 {
            input
        } else {
            forces_only(&input)
        };
        match run_fit(out, &second_input, cfg, stages.pac2002) {
            Some(second) => {
                if refit {
                    let started = Instant::now();
                    rx = relax(&second);
                    out.time("relaxation", started);
                }
                Some(second)
            }
            // the forces-only first pass is not a model to write
            None if forces_first => None,
            None => {
                // the first (not de-lagged) fit is written
                out.delag = None;
                Some(first)
            }
        }
    } else {
        Some(first)
    };
    if stages.relaxation {
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
    if !stages.pac2002 {
        // relaxation alone still needed the steady-state model; it is not written.
        return;
    }
    if let Some(fit) = fit {
        record_fit_notes(out, &fit, cfg.pac2002.oos_ratio_limit);
        out.pac2002 = Some(fit);
    }
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
        if let Some(q) = f.quality.as_ref().filter(|q| q.oos_flagged(limit))
            && let Some(o) = &q.out_of_sample
        {
            out.fail(
                "pac2002",
                &format!("family {} out of sample", f.family.as_str()),
                false,
                format!(
                    "good in sample, bad out of sample: held-out sweeps RMSE {:.4} vs {:.4} in \
                     sample ({:.2}x, limit {limit}x; {}-fold by sweep); {} of the folds could not \
                     determine the coefficients without their held-out sweeps",
                    o.rmse,
                    q.rmse,
                    o.rmse / q.rmse,
                    o.folds,
                    o.deficient_folds
                ),
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
fn forces_only(input: &FitInput) -> FitInput {
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
