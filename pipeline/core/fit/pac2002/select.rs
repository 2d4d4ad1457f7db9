//! Holding weakly identified term groups at their neutral values when the family then predicts
//! sweeps it did not see better (issue 18).
//!
//! In: one fitted family (its sweeps, free coefficients, refinement outcome and quality, the
//! coefficient vector) and the stage's envelope and configuration. Out: the same family with
//! zero or more of its [`CANDIDATE_GROUPS`] held at their neutral values and the rest refitted,
//! the held coefficients' origins (`Fixed`, with the k-fold figures), a note per group tested,
//! and the family's k-fold figure for the model actually kept.
//!
//! Method, per candidate group of the family, in table order, each against the model kept so
//! far (greedy, no randomness, no dependence on the number of threads):
//! 1. Prefilter (no model evaluation): the group is tested only if some member is free and the
//!    refinement's covariance predicts that holding the free members costs little in sample
//!    ([`predicted_rise`], [`PREDICTION_MARGIN`]): the members are weakly identified jointly,
//!    their correlation with the other coefficients included.
//! 2. Refit with the group held (the family's own refinement, warm-started from the fit); the
//!    group is kept if the in-sample RMSE rises by more than [`MAX_IN_SAMPLE_RISE`].
//! 3. k-fold by sweep ([`super::quality::out_of_sample`] on the selection folds, the folds and
//!    refits the family's out-of-sample figure uses when nothing is held) of the current model
//!    and of the held one; the group is held if the held-out RMSE falls by at least
//!    [`MIN_HELD_OUT_GAIN`].
//!
//! When a group was held, the family's reported k-fold figure is the kept model's on the report
//! folds ([`Dealing::Report`]), a dealing that shares little with the selection folds: on the
//! selection folds the kept model's figure is the smallest of the figures compared, its fold
//! noise included, so it would flatter the kept model. One more k-fold per family that holds a
//! group; where no other dealing exists (a fold per sweep) the selection folds' figure is
//! reported. Both figures are in the family's notes.
//!
//! Deliberately not here: choosing the groups from the data (the table is fixed), any
//! per-file setting, and the `Mx` family (its extended form is chosen by `stage`).

use super::collapse::CollapsedSweep;
use super::family::{Family, held_value};
use super::quality::{Dealing, OutOfSample, out_of_sample};
use super::stage::{Envelope, data_points, neutral_prior, refine};
use super::{CoefficientOrigin, FitConfig, FitQuality};
use crate::numerics::nonlinear_least_squares::FitOutcome;
use crate::tire_model::{Coef, Coef::*, Coefs};
use nalgebra::{DMatrix, DVector};

/// A set of coefficients that is held at its neutral values, or freed, as one.
#[derive(Copy, Clone, Debug)]
pub struct TermGroup {
    /// The family whose coefficients they are.
    pub family: Family,
    /// What the group describes (used in notes and reasons).
    pub name: &'static str,
    /// Its coefficients.
    pub coefs: &'static [Coef],
}

const fn group(family: Family, name: &'static str, coefs: &'static [Coef]) -> TermGroup {
    TermGroup {
        family,
        name,
        coefs,
    }
}

/// The groups that may be held at their neutral values. Each refines a law the family's main
/// coefficients already describe and is determined by a few inclination or load levels only, so
/// what differs from run to run of one condition (drift, wear, temperature, a re-mounted tire)
/// is shared by a whole level and a free group can follow it:
/// - `Fy0` camber of friction and curvature (`PDY3`, `PEY4`): the friction law's only camber
///   term is `gamma^2`, with no load x camber term; both curvatures of a few inclinations
///   bend to whatever the peak region of those sweeps did.
/// - `Fy0` curvature with load and its slip-angle asymmetry (`PEY2`, `PEY3`): curvature is the
///   least determined shape factor, its load slope and asymmetry the least of all.
/// - `Mz0` trail camber (`QBZ4`, `QDZ3`, `QDZ4`): three terms for the trail's change over the
///   few tested inclinations, beside the residual torque's own camber terms.
/// - `Mz0` residual torque camber (`QDZ8`, `QDZ9`): the residual torque is a small difference
///   of the measured moment and the trail's; its camber law is the smallest part of it.
/// - `Mz0` trail curvature with load and camber (`QEZ2`, `QEZ3`, `QEZ5`): curvature terms of a
///   curve whose shape beyond the peak the sweeps barely reach.
/// - `Fx0` friction camber (`PDX3`): as `PDY3`; drive/brake sweeps usually have fewer
///   inclinations than cornering ones.
/// - `Fx0` curvature with load (`PEX2`, `PEX3`): as `PEY2`, with a load-squared term.
/// - `Fx`, `Fy` weighting curvature with load (`REX1`, `REX2`; `REY1`, `REY2`): the combined
///   sweeps span a few slip angles, and the weighting's shape is fixed mostly by `RBX1`/`RCX1`.
/// - `Fy` kappa-induced side force with load and camber (`RVY2`, `RVY3`): a small force whose
///   load and camber laws rest on the few combined-slip levels.
/// - `Mz` arm camber (`SSZ3`, `SSZ4`): the `s Fx` arm is a small correction of the moment.
pub const CANDIDATE_GROUPS: &[TermGroup] = &[
    group(Family::Fy0, "friction and curvature camber", &[PDY3, PEY4]),
    group(Family::Fy0, "curvature load and asymmetry", &[PEY2, PEY3]),
    group(Family::Mz0, "trail camber", &[QBZ4, QDZ3, QDZ4]),
    group(Family::Mz0, "residual torque camber", &[QDZ8, QDZ9]),
    group(
        Family::Mz0,
        "trail curvature load and camber",
        &[QEZ2, QEZ3, QEZ5],
    ),
    group(Family::Fx0, "friction camber", &[PDX3]),
    group(Family::Fx0, "curvature load", &[PEX2, PEX3]),
    group(Family::Fx, "weighting curvature", &[REX1, REX2]),
    group(Family::Fy, "weighting curvature", &[REY1, REY2]),
    group(
        Family::Fy,
        "kappa-induced force load and camber",
        &[RVY2, RVY3],
    ),
    group(Family::Mz, "arm camber", &[SSZ3, SSZ4]),
];

/// Largest relative rise of the in-sample RMSE a held group may cause: less than the smallest
/// held-out gain that holds a group ([`MIN_HELD_OUT_GAIN`]), so a hold never gives up more fit
/// on the sweeps the family saw than it wins on those it did not; a group whose removal costs
/// more describes something the sweeps share.
pub const MAX_IN_SAMPLE_RISE: f64 = 0.02;

/// A group is refitted only when the first-order prediction of its in-sample cost
/// ([`predicted_rise`]) is at most this multiple of [`MAX_IN_SAMPLE_RISE`]: the prediction
/// holds the other coefficients' response linear and the robust weights fixed, so it may be off
/// by a factor; a group predicted to cost several times the limit (a determined camber or load
/// law) is not worth a refit.
pub const PREDICTION_MARGIN: f64 = 2.0;

/// Smallest relative fall of the k-fold held-out RMSE that holds a group. The fold refits are
/// short warm-started refinements, and holding a group changes where they start: differences
/// of a percent or two are within what the refits alone move. Three percent is a clear margin
/// above that and below the few percent that terms fitting run-to-run noise cost.
pub const MIN_HELD_OUT_GAIN: f64 = 0.03;

/// The value a candidate coefficient is held at: the centre of its neutral prior, else the
/// neutral value of an unidentifiable coefficient.
pub fn neutral_value(coef: Coef) -> f64 {
    neutral_prior(coef).map_or_else(|| held_value(coef), |(centre, _)| centre)
}

/// A fitted family as the selection reads and updates it.
pub(super) struct FittedFamily {
    /// The refinement of the kept model.
    pub outcome: FitOutcome,
    /// Its free coefficients (the outcome's parameters, in order).
    pub free: Vec<Coef>,
    /// Its in-sample quality (and, after [`hold_weak_groups`], the k-fold figure if one was
    /// computed).
    pub quality: FitQuality,
}

/// Tests the family's candidate groups (module docs) and holds those that predict unseen sweeps
/// better; updates `c`, `fitted`, `origins` and `notes`; returns the solver evaluations spent.
#[allow(clippy::too_many_arguments)]
pub(super) fn hold_weak_groups(
    family: Family,
    sweeps: &[&CollapsedSweep],
    env: &Envelope,
    cfg: &FitConfig,
    c: &mut Coefs<f64>,
    fitted: &mut FittedFamily,
    origins: &mut Vec<(Coef, Option<Family>, CoefficientOrigin)>,
    notes: &mut Vec<String>,
) -> usize {
    let groups = CANDIDATE_GROUPS.iter().filter(|g| g.family == family);
    if cfg.kfold < 2 || sweeps.len() < 2 || groups.clone().next().is_none() {
        return 0;
    }
    let points = data_points(sweeps, family, cfg.max_points_per_sweep);
    let unit = match family {
        Family::Mz0 | Family::Mz | Family::Mx => "N m",
        _ => "N",
    };
    // The family's k-fold figure of one model: its free set, coefficients and in-sample quality.
    let k_fold = |free: &[Coef], coefs: &Coefs<f64>, quality: &FitQuality, dealing: Dealing| {
        out_of_sample(
            family,
            free,
            sweeps,
            env,
            cfg,
            coefs,
            &quality.identifiability,
            dealing,
        )
    };
    let mut evaluations = 0;
    let mut current: Option<OutOfSample> = None;
    let mut held_any = false;
    for g in groups {
        let members: Vec<Coef> = g
            .coefs
            .iter()
            .copied()
            .filter(|m| fitted.free.contains(m))
            .collect();
        let weak = predicted_rise(&members, fitted, c)
            .is_some_and(|r| r <= PREDICTION_MARGIN * MAX_IN_SAMPLE_RISE);
        if members.is_empty() || !weak {
            continue;
        }
        let names = members
            .iter()
            .map(|m| m.name())
            .collect::<Vec<_>>()
            .join(", ");
        let label = format!("{}: {} ({names})", family.as_str(), g.name);
        let free: Vec<Coef> = fitted
            .free
            .iter()
            .copied()
            .filter(|f| !members.contains(f))
            .collect();
        let mut trial = c.clone();
        for m in &members {
            trial[*m] = neutral_value(*m);
        }
        let Ok((outcome, mut quality)) =
            refine(family, &free, &points, sweeps, env, cfg, &mut trial)
        else {
            continue;
        };
        evaluations += outcome.evaluations;
        let (before, after) = (fitted.quality.rmse, quality.rmse);
        let in_sample = format!(
            "in-sample {before:.4} -> {after:.4} {unit} ({:+.1} %)",
            100.0 * (after / before - 1.0)
        );
        // A NaN RMSE fails the test: the group stays free.
        let in_sample_ok = after <= (1.0 + MAX_IN_SAMPLE_RISE) * before;
        if !in_sample_ok {
            notes.push(format!("{label} kept free: held, {in_sample}"));
            continue;
        }
        if current.is_none() {
            current = k_fold(&fitted.free, c, &fitted.quality, Dealing::Selection);
            evaluations += current.as_ref().map_or(0, |o| o.evaluations);
        }
        let (Some(base), Some(held)) = (
            current.as_ref(),
            k_fold(&free, &trial, &quality, Dealing::Selection),
        ) else {
            continue;
        };
        evaluations += held.evaluations;
        let kfold = format!(
            "k-fold RMSE {:.4} -> {:.4} {unit} ({:+.1} %)",
            base.rmse,
            held.rmse,
            100.0 * (held.rmse / base.rmse - 1.0)
        );
        if held.rmse <= (1.0 - MIN_HELD_OUT_GAIN) * base.rmse {
            let reason = format!("{} held at neutral: {kfold}, {in_sample}", g.name);
            for m in &members {
                origins.push((
                    *m,
                    Some(family),
                    CoefficientOrigin::Fixed {
                        reason: reason.clone(),
                    },
                ));
            }
            notes.push(format!("{label} held at neutral: {kfold}, {in_sample}"));
            quality.evaluations += fitted.quality.evaluations;
            *c = trial;
            *fitted = FittedFamily {
                outcome,
                free,
                quality,
            };
            current = Some(held);
            held_any = true;
        } else {
            notes.push(format!("{label} kept free: held, {kfold}, {in_sample}"));
        }
    }
    if !held_any {
        fitted.quality.out_of_sample = current;
        return evaluations;
    }
    match k_fold(&fitted.free, c, &fitted.quality, Dealing::Report) {
        Some(r) => {
            evaluations += r.evaluations;
            if let Some(sel) = &current {
                notes.push(format!(
                    "{}: k-fold RMSE of the kept model {:.4} {unit} on report folds, {:.4} {unit} \
                     on the selection folds",
                    family.as_str(),
                    r.rmse,
                    sel.rmse
                ));
            }
            fitted.quality.out_of_sample = Some(r);
        }
        None => fitted.quality.out_of_sample = current,
    }
    evaluations
}

/// The relative rise of the in-sample RMSE that holding `members` at their neutral values would
/// cause to first order, from the refinement's classical covariance `S = s^2 (J^T J)^-1` (`s^2`
/// the weighted residual variance; the cost's curvature, not the cluster-robust covariance of
/// the standard errors): with `d` the members' departures from neutral, the constrained fit's
/// residual sum of squares grows by `s^2 d^T S_gg^-1 d` (the Wald statistic; the block of the
/// covariance carries the members' correlation with every other free coefficient), relative to
/// the fit's `s^2 (n_data - n_free)`. `None` when a member sits on a bound or the block is not a
/// finite positive-definite matrix (no linear prediction).
fn predicted_rise(members: &[Coef], fitted: &FittedFamily, c: &Coefs<f64>) -> Option<f64> {
    let idx: Vec<usize> = members
        .iter()
        .map(|m| fitted.free.iter().position(|f| f == m))
        .collect::<Option<_>>()?;
    let cov = &fitted.outcome.classical_covariance;
    let k = idx.len();
    let block = DMatrix::from_fn(k, k, |x, y| cov[(idx[x], idx[y])]);
    if block.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let d = DVector::from_iterator(k, members.iter().map(|m| c[*m] - neutral_value(*m)));
    let wald = d.dot(&block.cholesky()?.solve(&d));
    let n_data = fitted.outcome.robust_weights.len();
    let n_free = fitted.outcome.identifiability.n_free;
    (n_data > n_free && wald.is_finite())
        .then(|| (1.0 + wald / (n_data - n_free) as f64).sqrt() - 1.0)
}

#[cfg(test)]
mod tests {
    use super::super::synthetic::{RoundSpec, fsae_demo, ttc_round};
    use super::super::{FitInput, SweepKind, fit};
    use super::*;
    use crate::numerics::random::SplitMix64;

    /// A realistic round of `truth` whose cornering sweeps also carry a run-to-run error of the
    /// aligning moment: each sweep's `Mz` scaled by its own `1 + 0.05 u`, `u` standard normal
    /// (seeded), as a re-mounted or re-warmed tire would differ between runs.
    fn round_with_run_errors(truth: &Coefs<f64>, seed: u64) -> FitInput {
        let mut input = ttc_round(truth, &RoundSpec::realistic(seed));
        let mut rng = SplitMix64::new(seed ^ 0x5eed);
        for s in input
            .sweeps
            .iter_mut()
            .filter(|s| s.kind == SweepKind::Cornering)
        {
            let gain = 1.0 + 0.05 * rng.gaussian();
            s.samples.iter_mut().for_each(|x| x.mz_nm *= gain);
        }
        input
    }

    fn trail_camber_origins(input: &FitInput) -> Vec<(Coef, String)> {
        let fit = fit(input, &FitConfig::default()).expect("fit");
        for n in &fit.notes {
            eprintln!("note: {n}");
        }
        fit.coefficients
            .iter()
            .filter(|c| [QBZ4, QDZ3, QDZ4].contains(&c.coef))
            .map(|c| {
                let why = match &c.origin {
                    CoefficientOrigin::Fixed { reason } => reason.clone(),
                    o => o.as_str().to_string(),
                };
                (c.coef, why)
            })
            .collect()
    }

    /// A trail with no camber law in the truth (`QBZ4`, `QBZ5`, `QDZ3`, `QDZ4` zero; `QBZ5` too,
    /// since with inclinations of one sign `QBZ4` stands for it), measured with run-to-run errors
    /// of the aligning moment, has its camber group held at neutral.
    #[test]
    fn selection_holds_an_absent_trail_camber_law() {
        let mut truth = fsae_demo();
        for k in [QBZ4, QBZ5, QDZ3, QDZ4] {
            truth[k] = 0.0;
        }
        let origins = trail_camber_origins(&round_with_run_errors(&truth, 3));
        assert_eq!(origins.len(), 3, "{origins:?}");
        for (coef, why) in &origins {
            assert!(why.contains("held at neutral"), "{coef:?}: {why}");
        }
    }

    /// Issue 18: a trail with a camber law (the reference tire's), measured with run-to-run
    /// errors, keeps the law free: the selection does not hold a term the data determine.
    #[test]
    fn selection_keeps_a_real_trail_camber_law() {
        let origins = trail_camber_origins(&round_with_run_errors(&fsae_demo(), 3));
        assert_eq!(origins.len(), 3, "{origins:?}");
        for (coef, why) in &origins {
            assert_eq!(why, "fitted", "{coef:?}");
        }
    }
}
