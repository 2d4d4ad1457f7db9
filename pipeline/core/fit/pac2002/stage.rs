//! The stage itself: sweeps in, fitted model and facts out, family by family in dependency order.
//!
//! In: a [`FitInput`] and a [`FitConfig`]. Out: a [`Pac2002Fit`] or a [`Pac2002Error`] for input
//! that cannot be fitted at all. Order: check the context, sort and collapse the sweeps, set the
//! scalars (`FNOMIN` = middle nominal load of the matrix, `LONGVL`, radius, stiffness, ranges),
//! then `Fy0 -> Mz0 -> Fx0 -> Fx -> Fy -> Mz -> Mx`, each: data points and weights, held
//! (unidentifiable) coefficients, starting values, bounds and penalties, joint refinement,
//! quality, then the k-fold selection of weakly identified term groups (`select`); finally the
//! `My` placeholder and `USE_MODE`.
//!
//! Deterministic: sweeps are sorted by (kind, nominal slip angle, inclination, load, id) before
//! anything else, every container iterates in a fixed order, and no randomness is used; only
//! the `seconds` fields differ between runs.

use std::time::Instant;

use super::collapse::{CollapseSettings, CollapsedSweep, collapse};
use super::family::{Family, Levels, held_value, unidentifiable};
use super::initial::{self, NoSweepCurve, Setup};
use super::problem::{
    ConstrainedQuantity, DataPoint, FamilyProblem, Penalty, channel_value, ey_rules, trail_rules,
};
use super::quality;
use super::select::{FittedFamily, hold_weak_groups};
use super::{
    CoefficientOrigin, FamilyFit, FamilyStatus, FitConfig, FitInput, FitQuality, FittedCoefficient,
    MxForm, Pac2002Error, Pac2002Fit, SkippedSweep, SweepKind,
};
use crate::fit::noise_weights::{kind_levels, sweep_factors};
use crate::fit::output::Output;
use crate::numerics::nonlinear_least_squares::{
    Bounds, FitOutcome, Options, Termination, minimize,
};
use crate::numerics::stats::count_levels;
use crate::tire_model::{Coef, Coef::*, Coefs, Pac2002, SlipInput, Version};

/// The tested envelope: ranges of the data and the nominal load.
#[derive(Copy, Clone, Debug)]
pub(super) struct Envelope {
    fz0: f64,
    fz: (f64, f64),
    kappa: (f64, f64),
    alpha: (f64, f64),
    gamma: (f64, f64),
    vx: f64,
}

impl Envelope {
    fn dfz(&self, fz: f64) -> f64 {
        (fz - self.fz0) / self.fz0
    }

    /// Relative load changes spanning the envelope (ends, and points between for quadratics).
    fn dfz_grid(&self) -> [f64; 5] {
        let (a, b) = (self.dfz(self.fz.0), self.dfz(self.fz.1));
        [a, a + 0.25 * (b - a), 0.5 * (a + b), a + 0.75 * (b - a), b]
    }

    fn gamma_max_abs(&self) -> f64 {
        self.gamma.0.abs().max(self.gamma.1.abs())
    }
}

/// Why one family was not fitted (its [`FamilyStatus`] reason).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub(super) enum FamilyError {
    /// A family it builds on was not fitted.
    #[error("needs the {} family, which was not fitted", .0.as_str())]
    NeedsFamily(Family),
    /// None of the sweeps it is fitted to carries its channel.
    #[error("no {sweeps} with {} data", .output.name())]
    NoSweeps {
        /// The sweeps it needs (`cornering sweeps`, ...).
        sweeps: &'static str,
        /// Its channel.
        output: Output,
    },
    /// No starting values.
    #[error(transparent)]
    NoStart(#[from] NoSweepCurve),
    /// The starting values give non-finite residuals.
    #[error("the starting values give non-finite residuals")]
    NonFiniteStart,
}

/// Runs the PAC2002 fit of one (tire, rim, pressure). See the module docs of `fit::pac2002`.
pub fn fit(input: &FitInput, cfg: &FitConfig) -> Result<Pac2002Fit, Pac2002Error> {
    let started = Instant::now();
    let ctx = &input.context;
    let speed = ctx.test_speed_mps;
    if !(speed.is_finite() && speed > 0.0) {
        return Err(Pac2002Error::BadContext {
            tire: ctx.tire.clone(),
            field: "test_speed_mps",
            value: speed,
            expected: "finite and > 0",
        });
    }
    let mut notes = Vec::new();
    let (sweeps, skipped) = prepare_sweeps(input, cfg);
    if sweeps.is_empty() {
        return Err(Pac2002Error::NoUsableSweeps {
            tire: ctx.tire.clone(),
            skipped: skipped.len(),
        });
    }
    let mut origins: Vec<(Coef, Option<Family>, CoefficientOrigin)> = Vec::new();
    let mut c = Coefs::defaults();
    for coef in Family::FIT_ORDER
        .iter()
        .flat_map(|f| f.coefficients().iter())
    {
        c[*coef] = 0.0;
    }
    // MFeval's defaults for the extra Mx terms (they vanish with QSX7 = QSX8 = QSX10 = 0).
    for coef in [QSX4, QSX5, QSX6, QSX9, QSX11] {
        c[coef] = coef.default_value();
    }
    let env = set_scalars(input, &sweeps, &mut c, &mut origins, &mut notes)?;
    let spikes: usize = sweeps.iter().map(|s| s.spikes).sum();
    if spikes > 0 {
        notes.push(format!(
            "despiking replaced {spikes} sample values (running-median test) in {} sweeps",
            sweeps.len()
        ));
    }
    let mut families = Vec::new();
    let mut std_errors: Vec<(Coef, Option<f64>, bool)> = Vec::new();
    let mut evaluations = 0;
    let mut fitted: Vec<Family> = Vec::new();
    let mut free_lists: Vec<(Family, Vec<Coef>)> = Vec::new();
    // Every family's coefficients as its own stage left them (later families may refit some:
    // the combined Mz family refits the Mz0 coefficients on every sweep).
    let mut stage_coefs: Vec<(Family, Coefs<f64>)> = Vec::new();
    for family in Family::FIT_ORDER {
        if family == Family::My {
            families.push(rolling_placeholder(cfg, &mut c, &mut origins, &mut notes));
            continue;
        }
        let t0 = Instant::now();
        let data = family_sweeps(family, &sweeps, &fitted);
        let data = match data {
            Err(reason) => {
                families.push(FamilyFit {
                    family,
                    status: FamilyStatus::NoData {
                        reason: reason.to_string(),
                    },
                    quality: None,
                });
                continue;
            }
            Ok(data) => data,
        };
        let status = fit_family(
            family,
            &data,
            &env,
            cfg,
            &mut c,
            &mut origins,
            &free_lists,
            &mut notes,
        );
        match status {
            Ok((outcome, free, quality, extra_evals)) => {
                let mut kept = FittedFamily {
                    outcome,
                    free,
                    quality,
                };
                let selection_evals = hold_weak_groups(
                    family,
                    &data,
                    &env,
                    cfg,
                    &mut c,
                    &mut kept,
                    &mut origins,
                    &mut notes,
                );
                let FittedFamily {
                    outcome,
                    free,
                    mut quality,
                } = kept;
                quality.seconds = t0.elapsed().as_secs_f64();
                evaluations += quality.evaluations + extra_evals + selection_evals;
                for (k, coef) in free.iter().enumerate() {
                    std_errors.push((*coef, outcome.std_errors[k], outcome.at_bounds[k]));
                }
                free_lists.push((family, free));
                stage_coefs.push((family, c.clone()));
                fitted.push(family);
                families.push(FamilyFit {
                    family,
                    status: FamilyStatus::Fitted,
                    quality: Some(quality),
                });
            }
            Err(reason) => {
                for coef in family.coefficients() {
                    c[*coef] = if family == Family::Mx {
                        held_value(*coef)
                    } else {
                        0.0
                    };
                }
                origins.retain(|o| o.1 != Some(family));
                families.push(FamilyFit {
                    family,
                    status: FamilyStatus::Failed {
                        reason: reason.to_string(),
                    },
                    quality: None,
                });
            }
        }
    }
    evaluations += cross_validate(
        &mut families,
        &free_lists,
        &stage_coefs,
        &sweeps,
        &env,
        cfg,
        &c,
    );
    let has = |f: Family| fitted.contains(&f);
    let use_mode = match (has(Family::Fx0), has(Family::Fy0)) {
        (true, true) if has(Family::Fx) && has(Family::Fy) => 4,
        (true, true) => 3,
        (false, true) => 2,
        (true, false) => 1,
        (false, false) => 0,
    };
    let coefficients = coefficient_list(&c, &origins, &std_errors, &env);
    Ok(Pac2002Fit {
        model: Pac2002::new(c),
        use_mode,
        families,
        coefficients,
        skipped_sweeps: skipped,
        notes,
        evaluations,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// Out-of-sample and trend-deviation quality of every fitted family (see `quality`): the trend
/// of the final coefficients (the written model), the out-of-sample refits from the family's
/// own stage (`stage_coefs`), where its in-sample figure was measured; returns the refits'
/// evaluations.
fn cross_validate(
    families: &mut [FamilyFit],
    free_lists: &[(Family, Vec<Coef>)],
    stage_coefs: &[(Family, Coefs<f64>)],
    sweeps: &[CollapsedSweep],
    env: &Envelope,
    cfg: &FitConfig,
    c: &Coefs<f64>,
) -> usize {
    let fitted: Vec<Family> = free_lists.iter().map(|(f, _)| *f).collect();
    let mut evaluations = 0;
    for fam in families.iter_mut() {
        let (Some(q), Some((_, free))) = (
            fam.quality.as_mut(),
            free_lists.iter().find(|(f, _)| *f == fam.family),
        ) else {
            continue;
        };
        let Ok(data) = family_sweeps(fam.family, sweeps, &fitted) else {
            continue;
        };
        q.trend = quality::trend_deviation(fam.family, &data, c);
        // A family whose term selection measured the kept model's k-fold figure has it already.
        if cfg.kfold >= 2 && q.out_of_sample.is_none() {
            let at_stage = stage_coefs
                .iter()
                .find(|(f, _)| *f == fam.family)
                .map_or(c, |(_, s)| s);
            q.out_of_sample = quality::out_of_sample(
                fam.family,
                free,
                &data,
                env,
                cfg,
                at_stage,
                &q.identifiability,
                quality::Dealing::Selection,
            );
            evaluations += q.out_of_sample.as_ref().map_or(0, |o| o.evaluations);
        }
    }
    evaluations
}

/// Sorts, checks and collapses the sweeps; returns the usable ones and the skipped ones.
fn prepare_sweeps(input: &FitInput, cfg: &FitConfig) -> (Vec<CollapsedSweep>, Vec<SkippedSweep>) {
    let mut order: Vec<usize> = (0..input.sweeps.len()).collect();
    order.sort_by(|&a, &b| {
        let (x, y) = (&input.sweeps[a], &input.sweeps[b]);
        x.kind
            .cmp(&y.kind)
            .then(x.nominal.alpha_rad.total_cmp(&y.nominal.alpha_rad))
            .then(x.nominal.gamma_rad.total_cmp(&y.nominal.gamma_rad))
            .then(x.nominal.fz_n.total_cmp(&y.nominal.fz_n))
            .then(x.id.cmp(&y.id))
    });
    let relaxation = if cfg.delag {
        input.context.relaxation.as_ref()
    } else {
        None
    };
    let mut kept = Vec::new();
    let mut skipped = Vec::new();
    for i in order {
        let sweep = &input.sweeps[i];
        if !sweep.qc_ok {
            skipped.push(SkippedSweep {
                id: sweep.id.clone(),
                reason: "QC flagged".to_string(),
            });
            continue;
        }
        let settings = CollapseSettings {
            bin: match sweep.kind {
                SweepKind::Cornering => cfg.alpha_bin_rad,
                _ => cfg.kappa_bin,
            },
            despike_sigmas: cfg.despike_sigmas,
            relaxation,
        };
        let c = collapse(sweep, &settings);
        let swept: Vec<f64> = c.points.iter().map(|p| c.swept(p)).collect();
        let span = swept.last().unwrap_or(&0.0) - swept.first().unwrap_or(&0.0);
        let min_span = match sweep.kind {
            SweepKind::Cornering => 2.0_f64.to_radians(),
            _ => 0.02,
        };
        if c.points.len() < 8 || span < min_span {
            skipped.push(SkippedSweep {
                id: sweep.id.clone(),
                reason: format!(
                    "too short: {} collapsed points over a slip span of {span:.4}",
                    c.points.len()
                ),
            });
            continue;
        }
        kept.push(c);
    }
    (kept, skipped)
}

/// `FNOMIN` as the fit chooses it: the middle nominal load level of the cornering sweeps
/// (`cornering`), or of all sweeps (`all`) when there is no cornering sweep; levels closer
/// than 2 % are merged. Loads in N; `None` when there is none.
pub fn middle_nominal_load(cornering: &[f64], all: &[f64]) -> Option<f64> {
    let mut loads = if cornering.is_empty() {
        all.to_vec()
    } else {
        cornering.to_vec()
    };
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

/// `FNOMIN`, `LONGVL`, radius, stiffness and ranges; returns the envelope.
fn set_scalars(
    input: &FitInput,
    sweeps: &[CollapsedSweep],
    c: &mut Coefs<f64>,
    origins: &mut Vec<(Coef, Option<Family>, CoefficientOrigin)>,
    notes: &mut Vec<String>,
) -> Result<Envelope, Pac2002Error> {
    let ctx = &input.context;
    let loads = |cornering_only: bool| -> Vec<f64> {
        sweeps
            .iter()
            .filter(|s| !cornering_only || s.kind == SweepKind::Cornering)
            .map(|s| s.nominal.fz_n)
            .collect()
    };
    let fz0 = middle_nominal_load(&loads(true), &loads(false))
        .expect("fit() returns NoUsableSweeps before set_scalars when there is no sweep");
    c[FNOMIN] = fz0;
    c[LONGVL] = ctx.test_speed_mps;
    origins.push((FNOMIN, None, CoefficientOrigin::Data));
    origins.push((LONGVL, None, CoefficientOrigin::Context));
    let samples = || sweeps.iter().flat_map(|s| s.samples.iter());
    let range = |f: &dyn Fn(&super::Sample) -> f64| {
        samples()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            })
    };
    let kappa = range(&|s| s.kappa);
    let alpha = range(&|s| s.alpha_rad);
    let gamma = range(&|s| s.gamma_rad);
    let fz = range(&|s| s.fz_n);
    for (lo, hi, range, what) in [
        (KPUMIN, KPUMAX, kappa, "longitudinal slip"),
        (ALPMIN, ALPMAX, alpha, "slip angle"),
        (CAMMIN, CAMMAX, gamma, "inclination"),
        (FZMIN, FZMAX, fz, "load"),
    ] {
        if range.1 - range.0 > 1e-4 * range.1.abs().max(1.0) {
            c[lo] = range.0;
            c[hi] = range.1;
            origins.push((lo, None, CoefficientOrigin::Data));
            origins.push((hi, None, CoefficientOrigin::Data));
        } else {
            // A channel the data hold constant (a cornering-only file's slip ratio): no range.
            origins.push((lo, None, CoefficientOrigin::Placeholder));
            origins.push((hi, None, CoefficientOrigin::Placeholder));
            notes.push(format!(
                "{}/{} left at the PAC2002 defaults {}/{}: the data hold the {what} at {:.4}",
                lo.name(),
                hi.name(),
                c[lo],
                c[hi],
                range.0
            ));
        }
    }
    let rl = radius_from_rl(sweeps).and_then(|(r0, cz)| {
        use crate::physical::{RADIUS_M, VERTICAL_STIFFNESS_N_PER_M, within};
        if !within(r0, RADIUS_M) {
            notes.push(format!(
                "the loaded-radius line gives R0 = {r0:.4} m, outside a tire's {}..{} m: not used",
                RADIUS_M.0, RADIUS_M.1
            ));
            return None;
        }
        let cz = cz.filter(|cz| {
            let ok = within(*cz, VERTICAL_STIFFNESS_N_PER_M);
            if !ok {
                notes.push(format!(
                    "the loaded-radius line gives Cz = {cz:.0} N/m, outside a tire's {:.0}..{:.0} N/m: not used",
                    VERTICAL_STIFFNESS_N_PER_M.0, VERTICAL_STIFFNESS_N_PER_M.1
                ));
            }
            ok
        });
        Some((r0, cz))
    });
    match (ctx.unloaded_radius_m, rl) {
        (Some(r0), _) => {
            c[UNLOADED_RADIUS] = r0;
            origins.push((UNLOADED_RADIUS, None, CoefficientOrigin::Context));
        }
        (None, Some((r0, _))) => {
            c[UNLOADED_RADIUS] = r0;
            origins.push((UNLOADED_RADIUS, None, CoefficientOrigin::Data));
            notes.push(format!(
                "UNLOADED_RADIUS = {r0:.5} m from a line through the loaded radius at low slip \
                 (no spring-rate result)"
            ));
        }
        (None, None) => {
            return Err(Pac2002Error::NoUnloadedRadius {
                tire: ctx.tire.clone(),
            });
        }
    }
    match (ctx.vertical_stiffness_n_per_m, rl) {
        (Some(cz), _) => {
            c[VERTICAL_STIFFNESS] = cz;
            origins.push((VERTICAL_STIFFNESS, None, CoefficientOrigin::Context));
        }
        (None, Some((_, Some(cz)))) => {
            c[VERTICAL_STIFFNESS] = cz;
            origins.push((VERTICAL_STIFFNESS, None, CoefficientOrigin::Data));
            notes.push(format!(
                "VERTICAL_STIFFNESS = {cz:.0} N/m from the slope of the loaded radius against \
                 load (no spring-rate result)"
            ));
        }
        _ => notes.push("VERTICAL_STIFFNESS unknown: left at 0".to_string()),
    }
    let vx = samples().map(|s| s.vx_mps).sum::<f64>() / samples().count().max(1) as f64;
    Ok(Envelope {
        fz0,
        fz,
        kappa,
        alpha,
        gamma,
        vx,
    })
}

/// `(R0, Cz)` from a line `RL = R0 - Fz/Cz` through the near-zero-slip samples with a loaded
/// radius (`None` if fewer than 10 such samples).
fn radius_from_rl(sweeps: &[CollapsedSweep]) -> Option<(f64, Option<f64>)> {
    let pts: Vec<(f64, f64)> = sweeps
        .iter()
        .flat_map(|s| s.samples.iter())
        .filter(|s| s.alpha_rad.abs() < 1f64.to_radians() && s.kappa.abs() < 0.01)
        .filter_map(|s| s.loaded_radius_m.map(|r| (s.fz_n, r)))
        .filter(|(f, r)| f.is_finite() && r.is_finite())
        .collect();
    if pts.len() < 10 {
        return None;
    }
    let design: Vec<f64> = pts.iter().flat_map(|p| [1.0, p.0]).collect();
    let y: Vec<f64> = pts.iter().map(|p| p.1).collect();
    let b = super::linear::lstsq(&design, 2, &y)?;
    let cz = if b[1] < 0.0 { Some(-1.0 / b[1]) } else { None };
    Some((b[0], cz))
}

/// The sweeps a family is fitted to, or why it cannot be fitted.
fn family_sweeps<'a>(
    family: Family,
    sweeps: &'a [CollapsedSweep],
    fitted: &[Family],
) -> Result<Vec<&'a CollapsedSweep>, FamilyError> {
    let needs: &[Family] = match family {
        Family::Fy0 | Family::Fx0 | Family::My => &[],
        Family::Mz0 => &[Family::Fy0],
        Family::Fx => &[Family::Fx0],
        Family::Fy => &[Family::Fy0],
        Family::Mz => &[Family::Mz0, Family::Fx, Family::Fy],
        Family::Mx => &[Family::Fy0],
    };
    if let Some(missing) = needs.iter().find(|f| !fitted.contains(f)) {
        return Err(FamilyError::NeedsFamily(*missing));
    }
    let output = output_of(family);
    let combined_fy = fitted.contains(&Family::Fy);
    let selected: Vec<&CollapsedSweep> = sweeps
        .iter()
        .filter(|s| match family {
            Family::Fy0 | Family::Mz0 => s.kind == SweepKind::Cornering,
            Family::Fx0 => s.kind == SweepKind::DriveBrake,
            Family::Fx => s.kind == SweepKind::Combined,
            Family::Fy => s.kind != SweepKind::Cornering,
            // The cornering sweeps' Mz also carries the s Fx arm: the joint Mz refinement uses
            // every sweep.
            Family::Mz => true,
            Family::Mx => s.kind == SweepKind::Cornering || combined_fy,
            Family::My => false,
        })
        .filter(|s| s.points.iter().any(|p| p.output(output).is_finite()))
        .collect();
    let needs_combined = matches!(family, Family::Fx | Family::Fy | Family::Mz);
    if selected.is_empty()
        || (needs_combined && !selected.iter().any(|s| s.kind == SweepKind::Combined))
    {
        let what = match family {
            Family::Fy0 | Family::Mz0 => "cornering sweeps",
            Family::Fx0 => "drive/brake sweeps",
            Family::Fx | Family::Fy | Family::Mz => "combined-slip sweeps",
            _ => "sweeps",
        };
        return Err(FamilyError::NoSweeps {
            sweeps: what,
            output,
        });
    }
    Ok(selected)
}

pub(super) fn output_of(family: Family) -> Output {
    match family {
        Family::Fy0 | Family::Fy => Output::Fy,
        Family::Fx0 | Family::Fx | Family::My => Output::Fx,
        Family::Mz0 | Family::Mz => Output::Mz,
        Family::Mx => Output::Mx,
    }
}

/// Distinct levels of the family's sweeps.
fn levels_of(sweeps: &[&CollapsedSweep]) -> Levels {
    let tol_angle = 0.25_f64.to_radians();
    let cambers = sweeps.iter().map(|s| s.nominal.gamma_rad);
    Levels {
        loads: count_levels(sweeps.iter().map(|s| s.nominal.fz_n), 10.0),
        cambers: count_levels(cambers.clone(), tol_angle),
        camber_both_signs: cambers.clone().any(|g| g > tol_angle)
            && cambers.clone().any(|g| g < -tol_angle),
        alphas: count_levels(
            sweeps
                .iter()
                .filter(|s| s.kind != SweepKind::Cornering)
                .map(|s| s.nominal.alpha_rad.abs()),
            tol_angle,
        ),
        alpha_both_signs: {
            let combined = || sweeps.iter().filter(|s| s.kind == SweepKind::Combined);
            combined().any(|s| s.nominal.alpha_rad > tol_angle)
                && combined().any(|s| s.nominal.alpha_rad < -tol_angle)
        },
    }
}

/// Data points of a family, weighted so every sweep counts the same: residuals are relative to
/// the sweep's peak (floored at 5 % of the largest peak) and divided by the square root of the
/// sweep's point count and of the number of sweeps.
///
/// The joint `Mz` family's sweeps are also weighed by their kind's noise ([`sweep_factors`] of
/// [`kind_levels`] of each sweep's Mz scatter): on a real TTC round the drive/brake and
/// combined sweeps carry ten times the high-frequency Mz scatter of the cornering sweeps, and
/// weighed alike they pull the trail and residual torque away from the cornering data for no
/// gain on their own, noise-dominated, Mz. Kinds of equal noise keep the weights above.
///
/// A sweep with more than `max_per_sweep` points contributes that many, evenly spaced along the
/// curve (a deterministic thinning: the collapsed curves are oversampled for fitting purposes).
pub(super) fn data_points(
    sweeps: &[&CollapsedSweep],
    family: Family,
    max_per_sweep: usize,
) -> Vec<DataPoint> {
    let output = output_of(family);
    let max_peak = sweeps.iter().map(|s| s.peak(output)).fold(0.0, f64::max);
    let noise = if family == Family::Mz {
        let levels: Vec<(SweepKind, Option<f64>)> =
            sweeps.iter().map(|s| (s.kind, s.scatter(output))).collect();
        sweep_factors(&kind_levels(&levels), max_peak)
    } else {
        vec![1.0; sweeps.len()]
    };
    let mut out = Vec::new();
    for (sweep, s) in sweeps.iter().enumerate() {
        let valid: Vec<_> = s
            .points
            .iter()
            .filter(|p| p.output(output).is_finite())
            .collect();
        let n = valid.len();
        if n == 0 {
            continue;
        }
        let m = n.min(max_per_sweep.max(2));
        let peak = s.peak(output).max(0.05 * max_peak).max(1e-9);
        let w = noise[sweep] / (peak * ((m * sweeps.len()) as f64).sqrt());
        out.extend((0..m).map(|k| {
            let i = if m == n {
                k
            } else {
                ((k * (n - 1)) as f64 / (m - 1) as f64).round() as usize
            };
            DataPoint {
                input: valid[i].input,
                branches: valid[i].branches,
                value: valid[i].output(output),
                weight: w,
                sweep,
            }
        }));
    }
    out
}

type FamilyResult = Result<(FitOutcome, Vec<Coef>, FitQuality, usize), FamilyError>;

/// Fits one family: held coefficients, starting values, bounds and penalties, refinement.
#[allow(clippy::too_many_arguments)]
fn fit_family(
    family: Family,
    sweeps: &[&CollapsedSweep],
    env: &Envelope,
    cfg: &FitConfig,
    c: &mut Coefs<f64>,
    origins: &mut Vec<(Coef, Option<Family>, CoefficientOrigin)>,
    previous: &[(Family, Vec<Coef>)],
    notes: &mut Vec<String>,
) -> FamilyResult {
    let levels = levels_of(sweeps);
    let mut coefs: Vec<Coef> = family.coefficients().to_vec();
    if family == Family::Mx {
        coefs.truncate(3);
    }
    let mut free: Vec<Coef> = Vec::new();
    for coef in &coefs {
        match unidentifiable(*coef, &levels) {
            Some(reason) => {
                c[*coef] = held_value(*coef);
                origins.push((*coef, Some(family), CoefficientOrigin::Fixed { reason }));
            }
            None => free.push(*coef),
        }
    }
    let setup = Setup {
        free: &free,
        fz0: env.fz0,
        r0: c[UNLOADED_RADIUS],
    };
    match family {
        Family::Fy0 => initial::pure_lateral(sweeps, &setup, c)?,
        Family::Mz0 => initial::pure_aligning(sweeps, &setup, c)?,
        Family::Fx0 => initial::pure_longitudinal(sweeps, &setup, c)?,
        Family::Fx => initial::combined_longitudinal(sweeps, &setup, c),
        Family::Fy => initial::combined_lateral(sweeps, &setup, c),
        Family::Mz => {}
        Family::Mx => initial::overturning(sweeps, &setup, c),
        Family::My => unreachable!("My is a placeholder"),
    }
    let mut evals = 0;
    if family == Family::Mz {
        // The s Fx arm alone on the slip-ratio sweeps, then jointly with the Mz0 coefficients
        // on every sweep's Mz.
        let slip: Vec<&CollapsedSweep> = sweeps
            .iter()
            .copied()
            .filter(|s| s.kind != SweepKind::Cornering)
            .collect();
        let points = data_points(&slip, family, cfg.max_points_per_sweep);
        let (_, q) = refine(family, &free, &points, &slip, env, cfg, c)?;
        evals += q.evaluations;
        let mz0: &[Coef] = previous
            .iter()
            .find(|(f, _)| *f == Family::Mz0)
            .map_or(&[], |(_, v)| v.as_slice());
        free = mz0.iter().chain(free.iter()).copied().collect();
    }
    let points = data_points(sweeps, family, cfg.max_points_per_sweep);
    let (outcome, mut quality) = refine(family, &free, &points, sweeps, env, cfg, c)?;
    let mut outcome = outcome;
    if family == Family::Mx && cfg.mx_form == MxForm::Auto {
        let (ext, q) = extended_mx(&points, sweeps, env, cfg, c, &levels, &quality);
        evals += q.evaluations;
        let kept = ext.is_some();
        notes.push(format!(
            "Mx: core form RMSE {:.4} N m, with QSX4..QSX11 {:.4} N m: {} form kept",
            quality.rmse,
            q.rmse,
            if kept { "extended" } else { "core" }
        ));
        if let Some((ext_outcome, ext_free, ext_quality)) = ext {
            outcome = ext_outcome;
            quality = ext_quality;
            free = ext_free;
        }
    }
    for coef in free
        .iter()
        .filter(|coef| family.coefficients().contains(coef))
    {
        origins.push((*coef, Some(family), CoefficientOrigin::Fitted));
    }
    Ok((outcome, free, quality, evals))
}

/// The box of one coefficient and what its edges mean: `(lower, upper, why)`; some bounds
/// depend on the sign found by the starting values and on the envelope. `why` is what a value
/// on the bound says about the data (the `note` of its coefficient row).
pub(super) fn bound_of(coef: Coef, c: &Coefs<f64>, env: &Envelope) -> (f64, f64, &'static str) {
    if let Some(combined) = combined_slip_box(coef) {
        return combined;
    }
    let inf = f64::INFINITY;
    let g = env.gamma_max_abs().max(1e-3);
    let signed = |v: f64, lo: f64, hi: f64| if v < 0.0 { (-hi, -lo) } else { (lo, hi) };
    let with = |(lo, hi): (f64, f64), why| (lo, hi, why);
    match coef {
        PCY1 | PCX1 => with(
            (1.0, 2.5),
            "shape factor C in [1, 2.5]; at 1 the sweeps do not reach the friction peak and D \
             is the force's asymptote (below 1 mu would be unbounded); at 2.5 the force reverses \
             after its peak",
        ),
        QCZ1 => with((0.3, 2.5), "trail shape factor Ct in [0.3, 2.5]"),
        PDY1 | PDX1 => with(
            signed(c[coef], 0.02, MU_MAX),
            "peak friction |mu| at FNOMIN in [0.02, 4]: beyond 4 not physical (the lint's limit)",
        ),
        PKY1 | PKX1 => with(
            signed(c[coef], 0.05, 2000.0),
            "slip stiffness per load in [0.05, 2000]",
        ),
        PKY2 => with(
            (0.05, 50.0),
            "load of peak cornering stiffness in [0.05, 50] FNOMIN",
        ),
        PKY3 => with(
            (-50.0, 0.9 / g),
            "camber reduction of Ky below 90 % over the tested inclination",
        ),
        PDY3 | PDX3 => with(
            (-50.0, 0.9 / (g * g)),
            "camber reduction of mu below 90 % over the tested inclination",
        ),
        PKX3 => with((-10.0, 10.0), "exponent of Kx/Fz with load in [-10, 10]"),
        QBZ1 => with((0.05, 200.0), "trail slope factor Bt in [0.05, 200]"),
        QBZ9 => with((0.0, 200.0), "residual torque slope QBZ9 in [0, 200]"),
        QBZ10 => with(
            (-20.0, 20.0),
            "residual torque slope QBZ10 By Cy within 20 By Cy: steeper makes Mzr a spike \
             narrower than the sweeps' slip grid",
        ),
        QDZ6 | QDZ7 => with(
            (-0.2, 0.2),
            "residual torque peak within 0.2 Fz R0 (a real tire's is ~0.01)",
        ),
        QEZ1 => with((-20.0, 1.0), "trail curvature Et at FNOMIN in [-20, 1]"),
        QSX5 | QSX6 | QSX9 | QSX11 => with((0.0, 100.0), "Mx shape term in [0, 100]"),
        _ => (-inf, inf, "unbounded"),
    }
}

/// The box of a combined-slip weighting coefficient and what its edges mean, `(lower, upper,
/// why)`; `None` for other coefficients. PAC2002 and MF 6.x share the weighting functions
/// (`Gxa`, `Gyk`, `SVyk`), so both fits use these boxes. The shape terms inside `cos(atan(.))`
/// (`RBX2`, `RBY2`, `RVY4`) act through their magnitude only and have no slope at 0: a start
/// there stays there unless the box holds it as a bound (then it counts as determined by the
/// data, not as a free direction of the Jacobian).
pub(crate) fn combined_slip_box(coef: Coef) -> Option<(f64, f64, &'static str)> {
    Some(match coef {
        RBX1 | RBY1 => (
            0.0,
            100.0,
            "combined-slip weighting slope within 100: steeper drops the force to zero within \
             0.01 of the other slip",
        ),
        RBX2 | RBY2 | RVY4 | RVY6 => (0.0, 500.0, "combined-slip shape term in [0, 500]"),
        RCX1 | RCY1 => (0.3, 2.0, "combined-slip weighting shape in [0.3, 2]"),
        RHX1 | RBY3 => (-0.1, 0.1, "combined-slip shift within 0.1 rad"),
        RHY1 | RHY2 => (-0.3, 0.3, "combined-slip shift within 0.3"),
        RVY5 => (0.0, 3.0, "kappa-induced side force shape in [0, 3]"),
        _ => return None,
    })
}

/// The note of a coefficient at `value` on a bound of its box `(lower, upper, why)`.
pub(crate) fn bound_note(coef: Coef, value: f64, (lo, hi, why): (f64, f64, &str)) -> String {
    let lower = (value - lo).abs() <= (hi - value).abs();
    if lower && lo == 0.0 && matches!(coef, RBX2 | RBY2 | RVY4) {
        // Even in the coefficient and flat at 0: the data do not push it past 0.
        return format!(
            "on its lower bound 0, where it stops acting (it enters as cos(atan({} x)), flat at \
             0: the data show no change of the weighting's width with the other slip): {why}",
            coef.name()
        );
    }
    let (side, bound) = if lower { ("lower", lo) } else { ("upper", hi) };
    format!("on its {side} bound {bound} (the data pull it further): {why}")
}

/// Bounds of the free coefficients ([`bound_of`]).
pub(super) fn bounds_of(free: &[Coef], c: &Coefs<f64>, env: &Envelope) -> Bounds {
    let (lower, upper) = free
        .iter()
        .map(|coef| {
            let (lo, hi, _) = bound_of(*coef, c, env);
            (lo, hi)
        })
        .unzip();
    Bounds { lower, upper }
}

/// Largest peak friction a fit may reach, `|mu|`.
const MU_MAX: f64 = 4.0;

/// Physical-constraint penalties and asymmetry priors of a family.
pub(super) fn penalties_of(
    family: Family,
    free: &[Coef],
    env: &Envelope,
    cfg: &FitConfig,
) -> Vec<Penalty> {
    let w = cfg.constraint_weight;
    let at_most = |quantity, limit| Penalty::AtMost {
        quantity,
        limit,
        weight: w,
    };
    let gammas = [env.gamma.0, env.gamma.1];
    let mut out = Vec::new();
    match family {
        Family::Fy0 => {
            let rules = ey_rules(&env.dfz_grid(), &gammas, Version::Pac2002);
            out.extend(rules.into_iter().map(|(q, limit)| at_most(q, limit)));
        }
        Family::Fx0 => {
            for dfz in env.dfz_grid() {
                for sign in [-1.0, 1.0] {
                    out.push(at_most(ConstrainedQuantity::Ex { dfz, sign }, 1.0));
                }
            }
            let (lo, hi) = (env.dfz(env.fz.0), env.dfz(env.fz.1));
            for sign in [-1.0, 1.0] {
                out.push(at_most(ConstrainedQuantity::ExPeak { lo, hi, sign }, 1.0));
            }
        }
        Family::Mz0 | Family::Mz if free.iter().any(|c| Family::Mz0.coefficients().contains(c)) => {
            let rules = trail_rules(&env.dfz_grid(), &gammas);
            out.extend(rules.into_iter().map(|(q, limit)| at_most(q, limit)));
        }
        Family::Fx | Family::Fy => {
            for dfz in env.dfz_grid() {
                let q = if family == Family::Fx {
                    ConstrainedQuantity::Exa { dfz }
                } else {
                    ConstrainedQuantity::Eyk { dfz }
                };
                out.push(at_most(q, 1.0));
            }
            for input in envelope_grid(env) {
                let q = if family == Family::Fx {
                    ConstrainedQuantity::NegGxa {
                        input,
                        version: Version::Pac2002,
                    }
                } else {
                    ConstrainedQuantity::NegGyk {
                        input,
                        version: Version::Pac2002,
                    }
                };
                out.push(at_most(q, -0.01));
            }
            let prior = |coef| Penalty::Prior {
                coef,
                centre: 0.0,
                weight: cfg.asymmetry_weight / 0.01,
            };
            for coef in [RHX1, RBY3] {
                if free.contains(&coef) {
                    out.push(prior(coef));
                }
            }
        }
        Family::Mz0 | Family::Mz | Family::Mx | Family::My => {}
    }
    if cfg.regularisation_weight > 0.0 {
        for coef in free {
            if let Some((centre, scale)) = neutral_prior(*coef) {
                out.push(Penalty::Prior {
                    coef: *coef,
                    centre,
                    weight: cfg.regularisation_weight / scale,
                });
            }
        }
    }
    out
}

/// The neutral value of a weakly identified coefficient and the scale of a typical departure
/// from it: `(centre, scale)`. A prior `regularisation_weight (c - centre)/scale` settles what
/// the data leave undetermined (a flat direction of the cost) at the neutral value and moves a
/// well-determined coefficient by a negligible amount: one scale away costs as much as 0.1 % of
/// relative RMS error at the default weight. Terms: residual torque, trail curvature (both with
/// their camber terms), the curvature asymmetry, load curvature terms and the combined-slip
/// shape terms; the main peak, stiffness and shape factors have none.
///
/// The other camber terms have none either: each is free only when the family's data have the
/// inclination levels that identify it ([`super::family::unidentifiable`]: two inclinations,
/// three for `QDZ4`'s `gamma^2`, both signs for `QBZ5`'s `|gamma|`, two loads as well for the
/// `dfz gamma` terms) and is held at its neutral value otherwise (one inclination tested), so
/// a prior would only pull a determined camber law toward zero.
pub(super) fn neutral_prior(coef: Coef) -> Option<(f64, f64)> {
    Some(match coef {
        // Residual torque.
        QBZ10 => (0.0, 2.0),
        QDZ6 | QDZ7 => (0.0, 0.05),
        QDZ8 | QDZ9 => (0.0, 0.2),
        // Trail curvature and its load and camber terms.
        QEZ1 | QEZ2 | QEZ3 | QEZ4 | QEZ5 => (0.0, 2.0),
        // Asymmetry of the lateral curvature in slip angle.
        PEY3 => (0.0, 1.0),
        // Load curvature.
        PEX3 | QBZ3 => (0.0, 2.0),
        // Combined-slip shape.
        RCX1 | RCY1 => (1.0, 0.5),
        REX1 | REX2 | REY1 | REY2 => (0.0, 1.0),
        RBX2 | RBY2 | RVY4 => (0.0, 20.0),
        RHY1 | RHY2 => (0.0, 0.05),
        RVY1 | RVY2 => (0.0, 0.1),
        _ => return None,
    })
}

/// Operating points spanning the envelope (for the weighting-function sign constraints).
fn envelope_grid(env: &Envelope) -> Vec<SlipInput> {
    let mut out = Vec::new();
    for fz in [env.fz.0, env.fz.1] {
        for i in 0..9 {
            let alpha = env.alpha.0 + (env.alpha.1 - env.alpha.0) * i as f64 / 8.0;
            for j in 0..5 {
                let kappa = env.kappa.0 + (env.kappa.1 - env.kappa.0) * j as f64 / 4.0;
                out.push(SlipInput {
                    fz_n: fz,
                    kappa,
                    alpha_rad: alpha,
                    gamma_rad: 0.0,
                    vx_mps: env.vx,
                });
            }
        }
    }
    out
}

/// Relative cost change that ends an `Mx` refinement.
const MX_FTOL: f64 = 1e-6;

/// Joint refinement of `free` from the current values in `c` (updated in place).
pub(super) fn refine(
    family: Family,
    free: &[Coef],
    points: &[DataPoint],
    sweeps: &[&CollapsedSweep],
    env: &Envelope,
    cfg: &FitConfig,
    c: &mut Coefs<f64>,
) -> Result<(FitOutcome, FitQuality), FamilyError> {
    let bounds = bounds_of(free, c, env);
    let penalties = penalties_of(family, free, env, cfg);
    let start: Vec<f64> = free.iter().map(|coef| c[*coef]).collect();
    let output = output_of(family);
    let all_points = data_points(sweeps, family, usize::MAX);
    let initial_rmse = rmse_on_points(&all_points, c, family);
    let problem = FamilyProblem::new(c, free, family, points, &penalties);
    let options = Options {
        max_iterations: cfg.max_iterations,
        xtol: 1e-10,
        // Mx's extended form (QSX4..QSX11, atan/cos terms) creeps: at 1e-12 it ran out of
        // iterations (4 x 300) on a quarter of the full round's groups, 2.8 s of a 4.9 s group,
        // for RMSE changes far below the sensor noise. At 1e-6 the full round's Mx RMSE moves
        // by 0.002 % (mean 0.46609 -> 0.46610 N m) and its slowest PAC2002 fit is 1.9 s.
        ftol: if family == Family::Mx { MX_FTOL } else { 1e-12 },
        gtol: 1e-9,
        loss: cfg.loss,
        irls_rounds: 3,
        scale_floor: 1e-5 / (points.len().max(1) as f64).sqrt(),
    };
    let outcome = minimize(&problem, &start, &bounds, &options);
    if outcome.termination == Termination::NonFiniteStart {
        return Err(FamilyError::NonFiniteStart);
    }
    let fitted = problem.coefs_at(&outcome.params);
    *c = fitted;
    let quality = quality_of(
        family,
        output,
        &all_points,
        sweeps,
        c,
        &outcome,
        initial_rmse,
    );
    Ok((outcome, quality))
}

fn rmse_on_points(points: &[DataPoint], c: &Coefs<f64>, family: Family) -> f64 {
    let ss: f64 = points
        .iter()
        .map(|p| (p.branches.mean_of(|x| channel_value(c, x, family)) - p.value).powi(2))
        .sum();
    (ss / points.len().max(1) as f64).sqrt()
}

fn quality_of(
    family: Family,
    output: Output,
    points: &[DataPoint],
    sweeps: &[&CollapsedSweep],
    c: &Coefs<f64>,
    outcome: &FitOutcome,
    initial_rmse: f64,
) -> FitQuality {
    let n = points.len();
    let rmse = rmse_on_points(points, c, family);
    let peak = points.iter().map(|p| p.value.abs()).fold(0.0, f64::max);
    let mean = points.iter().map(|p| p.value).sum::<f64>() / n.max(1) as f64;
    let ss_tot: f64 = points.iter().map(|p| (p.value - mean).powi(2)).sum();
    let r2 = if ss_tot > 0.0 {
        1.0 - rmse * rmse * n as f64 / ss_tot
    } else {
        f64::NAN
    };
    let (mut ss, mut n_samples) = (0.0, 0usize);
    for s in sweeps {
        for sample in &s.samples {
            let y = sample.output(output);
            if !y.is_finite() {
                continue;
            }
            let input = SlipInput {
                fz_n: sample.fz_n,
                kappa: sample.kappa,
                alpha_rad: sample.alpha_rad,
                gamma_rad: sample.gamma_rad,
                vx_mps: sample.vx_mps,
            };
            ss += (channel_value(c, &input, family) - y).powi(2);
            n_samples += 1;
        }
    }
    FitQuality {
        n,
        rmse,
        rmse_pct_of_peak: if peak > 0.0 {
            100.0 * rmse / peak
        } else {
            f64::NAN
        },
        r2,
        n_samples,
        sample_rmse: (ss / n_samples.max(1) as f64).sqrt(),
        initial_rmse,
        iterations: outcome.iterations,
        termination: outcome.termination,
        evaluations: outcome.evaluations,
        seconds: 0.0,
        identifiability: outcome.identifiability,
        out_of_sample: None,
        trend: None,
    }
}

type Extended = (Option<(FitOutcome, Vec<Coef>, FitQuality)>, FitQuality);

/// Tries the `Mx` form with `QSX4..QSX11`; returns it when it lowers the RMSE by >= 10 %.
fn extended_mx(
    points: &[DataPoint],
    sweeps: &[&CollapsedSweep],
    env: &Envelope,
    cfg: &FitConfig,
    c: &mut Coefs<f64>,
    levels: &Levels,
    core: &FitQuality,
) -> Extended {
    let mut trial = c.clone();
    for (coef, v) in [
        (QSX4, 0.1),
        (QSX5, 1.0),
        (QSX6, 1.0),
        (QSX7, 0.0),
        (QSX8, 0.0),
        (QSX9, 0.5),
        (QSX10, 0.0),
        (QSX11, 1.0),
    ] {
        trial[coef] = v;
    }
    let free: Vec<Coef> = Family::Mx
        .coefficients()
        .iter()
        .copied()
        .filter(|coef| unidentifiable(*coef, levels).is_none())
        .collect();
    match refine(Family::Mx, &free, points, sweeps, env, cfg, &mut trial) {
        Ok((outcome, quality)) => {
            let q = quality.clone();
            if quality.rmse <= 0.9 * core.rmse {
                *c = trial;
                (Some((outcome, free, quality)), q)
            } else {
                (None, q)
            }
        }
        Err(_) => (None, core.clone()),
    }
}

/// `My`: TTC records no rolling resistance moment; `QSY1` is set to
/// [`FitConfig::rolling_resistance_placeholder`] (0 by default: `My` = 0, no moment claimed),
/// `QSY2..QSY4` to 0, and the family and its coefficients are flagged as placeholders.
fn rolling_placeholder(
    cfg: &FitConfig,
    c: &mut Coefs<f64>,
    origins: &mut Vec<(Coef, Option<Family>, CoefficientOrigin)>,
    notes: &mut Vec<String>,
) -> FamilyFit {
    let qsy1 = cfg.rolling_resistance_placeholder;
    c[QSY1] = qsy1;
    for coef in [QSY2, QSY3, QSY4] {
        c[coef] = 0.0;
    }
    for coef in Family::My.coefficients() {
        origins.push((*coef, Some(Family::My), CoefficientOrigin::Placeholder));
    }
    let reason = if qsy1 == 0.0 {
        "no My channel in the data: QSY1..QSY4 = 0, so the model's My is 0 (no rolling \
         resistance moment is claimed)"
            .to_string()
    } else {
        format!(
            "no My channel in the data: QSY1 = {qsy1} ([fit] rolling_resistance_placeholder, a \
             constant rolling resistance coefficient, not measured), QSY2..QSY4 = 0"
        )
    };
    notes.push(format!("My not fitted: {reason}"));
    FamilyFit {
        family: Family::My,
        status: FamilyStatus::Placeholder { reason },
        quality: None,
    }
}

/// The note of every `My` coefficient: TTC records no rolling resistance moment.
pub const MY_PLACEHOLDER_NOTE: &str = "placeholder, not fitted: TTC records no rolling resistance \
     moment (My); [fit] rolling_resistance_placeholder sets QSY1 (0 by default: My = 0)";

/// Every coefficient the stage set, in catalogue order.
fn coefficient_list(
    c: &Coefs<f64>,
    origins: &[(Coef, Option<Family>, CoefficientOrigin)],
    std_errors: &[(Coef, Option<f64>, bool)],
    env: &Envelope,
) -> Vec<FittedCoefficient> {
    Coef::ALL
        .iter()
        .filter_map(|coef| {
            let (_, family, origin) = origins.iter().rev().find(|o| o.0 == *coef)?;
            let (std_error, at_bound) = match origin {
                CoefficientOrigin::Fitted => std_errors
                    .iter()
                    .rev()
                    .find(|s| s.0 == *coef)
                    .map_or((None, false), |s| (s.1, s.2)),
                _ => (None, false),
            };
            let note = match origin {
                CoefficientOrigin::Fixed { reason } => Some(format!("held: {reason}")),
                CoefficientOrigin::Placeholder if *family == Some(Family::My) => {
                    Some(MY_PLACEHOLDER_NOTE.to_string())
                }
                _ if at_bound => Some(bound_note(*coef, c[*coef], bound_of(*coef, c, env))),
                _ => None,
            };
            Some(FittedCoefficient {
                coef: *coef,
                family: *family,
                value: c[*coef],
                std_error,
                at_bound,
                origin: origin.clone(),
                note,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::family::is_camber_term;
    use super::super::problem::penalty_rows;
    use super::*;

    /// The `Fx0` rule `Ex <= 1` holds between its grid loads too: with `Ex` concave in load and
    /// peaked (1.03) midway between the second and third of the five grid loads, below 1 at
    /// each of them, only the rows at the quadratic's interior maximum are active.
    #[test]
    fn fx0_penalties_see_a_curvature_peak_between_grid_loads() {
        let env = Envelope {
            fz0: 1100.0,
            fz: (222.0, 1557.0),
            kappa: (-0.2, 0.2),
            alpha: (0.0, 0.0),
            gamma: (0.0, 0.0),
            vx: 11.176,
        };
        let grid = env.dfz_grid();
        let vertex = 0.5 * (grid[1] + grid[2]);
        let mut c = Coefs::<f64>::defaults();
        c[PEX3] = -1.5;
        c[PEX2] = 3.0 * vertex;
        c[PEX1] = 1.03 - 1.5 * vertex * vertex;
        c[PEX4] = 0.0;
        c[LEX] = 1.0;
        let free = [PEX1, PEX2, PEX3, PEX4];
        let penalties = penalties_of(Family::Fx0, &free, &env, &FitConfig::default());
        let mut r = vec![0.0; penalties.len()];
        penalty_rows(&penalties, &c, &free, &mut r, None);
        let active: Vec<_> = penalties
            .iter()
            .zip(&r)
            .filter(|(_, r)| **r > 0.0)
            .map(|(p, _)| p)
            .collect();
        assert_eq!(active.len(), 2, "{active:?}");
        for p in active {
            assert!(
                matches!(
                    p,
                    Penalty::AtMost {
                        quantity: ConstrainedQuantity::ExPeak { .. },
                        ..
                    }
                ),
                "{p:?}"
            );
        }
    }

    /// With the default configuration the `My` placeholder makes the model's rolling resistance
    /// moment 0 whatever `QSY1` held before (TTC records no `My`, so the model claims no moment
    /// it was not fitted to), and the note says so.
    #[test]
    fn the_my_placeholder_claims_no_rolling_resistance_moment() {
        use crate::tire_model::{MagicFormula, Mode, Version};
        let mut c = Coefs::<f64>::defaults();
        c[UNLOADED_RADIUS] = 0.26;
        c[FNOMIN] = 1100.0;
        c[LONGVL] = 11.0;
        c[QSY1] = 0.012;
        let (mut origins, mut notes) = (Vec::new(), Vec::new());
        let fit = rolling_placeholder(&FitConfig::default(), &mut c, &mut origins, &mut notes);
        assert_eq!(fit.status.as_str(), "placeholder");
        assert!(
            origins
                .iter()
                .all(|o| o.2 == CoefficientOrigin::Placeholder)
        );
        let model = MagicFormula::with_version(c.clone(), Version::Pac2002);
        let input = SlipInput {
            fz_n: 1250.0,
            kappa: 0.0,
            alpha_rad: 0.0,
            gamma_rad: 0.0,
            vx_mps: 11.0,
        };
        let my = model.eval(&input, Mode::Limits).my_nm;
        assert!(my.abs() < 1e-12, "My {my} N m");
        assert!(notes[0].contains("My is 0"), "{notes:?}");
        // a configured constant is written, and named as the placeholder it is
        let cfg = FitConfig {
            rolling_resistance_placeholder: 0.0165,
            ..FitConfig::default()
        };
        let mut notes = Vec::new();
        rolling_placeholder(&cfg, &mut c, &mut Vec::new(), &mut notes);
        assert_eq!(c[QSY1], 0.0165);
        assert!(notes[0].contains("not measured"), "{notes:?}");
    }

    /// Camber terms are held when one inclination was tested and carry no prior when the
    /// inclination levels identify them; those of residual torque and trail curvature keep it.
    #[test]
    fn identified_camber_terms_carry_no_prior() {
        let one_ia = Levels {
            loads: 5,
            cambers: 1,
            camber_both_signs: false,
            alphas: 3,
            alpha_both_signs: true,
        };
        let tested = Levels {
            cambers: 5,
            camber_both_signs: true,
            ..one_ia.clone()
        };
        let mut n = 0;
        for family in Family::FIT_ORDER {
            for &c in family.coefficients() {
                if !is_camber_term(c) {
                    continue;
                }
                n += 1;
                assert!(
                    unidentifiable(c, &one_ia).is_some(),
                    "{c:?} free with one IA"
                );
                assert!(unidentifiable(c, &tested).is_none(), "{c:?}");
                let kept = matches!(c, QDZ8 | QDZ9 | QEZ5);
                assert_eq!(neutral_prior(c).is_some(), kept, "{c:?}");
            }
        }
        assert!(n >= 19, "{n} camber terms");
    }
}
