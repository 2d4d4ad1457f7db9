//! How well the MF 6.1 model predicts sweeps it did not see: k-fold by sweep, per family, as the
//! PAC2002 stage checks its families.
//!
//! In: the full fit's model, every collapsed point (all tested pressures), one refined family's
//! outcome (its free coefficients and the full fit's identifiability) and the stage's
//! configuration. Out: a [`KFold`]: per tested pressure the squared prediction errors of the
//! held-out points, the folds used and the folds whose training sweeps could not determine the
//! family's coefficients.
//!
//! - Folds: the family's sweeps dealt diagonally ([`crate::fit::sweep_folds::diagonal`]) in
//!   their load, inclination, held slip angle and tested pressure (load, inclination and slip
//!   angle are the sweep's mean over its points, grouped into levels within 10 % of `FNOMIN`,
//!   0.25 deg and 0.5 deg), so every fold keeps sweeps of every tested pressure in training and
//!   the pressure terms stay identified (holding out a whole pressure of two would leave one
//!   pressure to fit them from).
//! - Refit: as the PAC2002 folds refit, the family's free coefficients only, refined on the
//!   other folds' sweeps from the full fit's values with a short budget
//!   ([`super::Mf61Config::kfold_iterations`], one robust-loss round; the solver's
//!   [`crate::numerics::nonlinear_least_squares::refit`], parameters only); every other
//!   coefficient keeps its full-fit value. The refit is used whatever its plain RMSE on the
//!   training sweeps (the solver minimises the weighted robust cost, which from the full fit's
//!   values may raise the plain RMSE a little; falling back to the full fit would predict
//!   held-out sweeps with a model that saw them), unless it is not finite. A fold is deficient
//!   when its training data leave the coefficients undetermined at the refit's start, the full
//!   fit's coefficients ([`sweep_folds::fold_design`], the PAC2002 rule and point).
//! - Prediction: the held-out sweeps' points (those [`super::group_family_quality`] scores in
//!   sample), so `oos_rmse` and `rmse` are on the same points. The `Mz0` row is scored by the
//!   joint `Mz` step's refits when that step was kept (it sets the written `Mz0` coefficients
//!   last, on every sweep; refitting them on the cornering sweeps alone would cross-validate a
//!   model that is not the written one): its cornering points are predicted by the `Mz` refit
//!   that did not see their sweep.
//!
//! Deliberately not here: leaving a whole pressure out (`super::fit_collapsed`, a separate
//! figure with three or more tested pressures), flagging (the `tirebase` crate).

use std::collections::BTreeMap;

use super::problem::{FIT_MODE, FamilyData, Mf61FamilyProblem};
use super::{
    Family, FamilyOutcome, Mf61Config, Point, PureData, family_data, mz_data, refinement_bounds,
    rmse_of,
};
use crate::fit::sweep_folds;
use crate::numerics::nonlinear_least_squares::{Options, refit};
use crate::tire_model::params::Coef::FNOMIN;
use crate::tire_model::{MagicFormula, Pressures};

/// k-fold-by-sweep result of one family.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct KFold {
    /// Folds used (`min(kfold, sweeps)`).
    pub folds: usize,
    /// Folds whose training sweeps did not determine the family's coefficients (see the module
    /// docs), or too few training points to refit (the full fit predicted them).
    pub deficient_folds: usize,
    /// Solver evaluations of the refits.
    pub evaluations: usize,
    /// Per scored family and tested-pressure group: (sum of squared held-out errors, held-out
    /// points).
    pub by_group: BTreeMap<(Family, usize), (f64, usize)>,
}

impl KFold {
    /// RMSE of `family`'s held-out predictions at `group` (`None` without points there).
    pub fn rmse_at(&self, family: Family, group: usize) -> Option<(f64, usize)> {
        self.by_group
            .get(&(family, group))
            .filter(|(_, n)| *n > 0)
            .map(|(ss, n)| ((ss / *n as f64).sqrt(), *n))
    }
}

/// The fold of every sweep of `data` (diagonal in its levels, module docs), keyed by sweep index;
/// `None` with fewer than two sweeps or `k < 2`.
fn folds(data: &FamilyData, fnomin: f64, k: usize) -> Option<BTreeMap<usize, usize>> {
    // Per sweep: sums of fz, gamma, alpha, count, and its group.
    let mut acc: BTreeMap<usize, ([f64; 3], usize, usize)> = BTreeMap::new();
    for (i, s) in data.sweeps.iter().enumerate() {
        let e = acc.entry(*s).or_insert(([0.0; 3], 0, data.groups[i]));
        let x = &data.inputs[i];
        e.0[0] += x.fz_n;
        e.0[1] += x.gamma_rad;
        e.0[2] += x.alpha_rad;
        e.1 += 1;
    }
    let mean =
        |j: usize| -> Vec<f64> { acc.values().map(|(sum, n, _)| sum[j] / *n as f64).collect() };
    let tolerance = if fnomin.is_finite() && fnomin > 0.0 {
        0.1 * fnomin
    } else {
        100.0
    };
    let fz = sweep_folds::clustered_ranks(&mean(0), tolerance);
    let gamma = sweep_folds::clustered_ranks(&mean(1), 0.25_f64.to_radians());
    let alpha = sweep_folds::clustered_ranks(&mean(2), 0.5_f64.to_radians());
    let groups: Vec<f64> = acc.values().map(|(_, _, g)| *g as f64).collect();
    let pressure = sweep_folds::ranks(&groups, 1.0);
    let sums: Vec<usize> = (0..acc.len())
        .map(|i| fz[i] + gamma[i] + alpha[i] + pressure[i])
        .collect();
    let fold = sweep_folds::diagonal(&sums, k)?;
    Some(acc.keys().copied().zip(fold).collect())
}

/// The points of `data` whose sweep is (`held = true`) or is not in fold `f`.
fn subset(data: &FamilyData, fold_of: &BTreeMap<usize, usize>, f: usize, held: bool) -> FamilyData {
    let mut d = FamilyData::default();
    for i in 0..data.len() {
        if (fold_of.get(&data.sweeps[i]) == Some(&f)) != held {
            continue;
        }
        d.inputs.push(data.inputs[i]);
        d.pressures.push(data.pressures[i]);
        d.measured.push(data.measured[i]);
        d.weights.push(data.weights[i]);
        d.sweeps.push(data.sweeps[i]);
        d.groups.push(data.groups[i]);
    }
    d
}

/// k-fold-by-sweep prediction error of one refined family of `model` (module docs), scored on
/// the points of the family itself and of `also` (families whose written coefficients this
/// family's refinement set last: `Mz0` for the joint `Mz` step; their points must lie in this
/// family's sweeps); `None` with fewer than two sweeps or `kfold < 2`.
pub fn k_fold(
    model: &MagicFormula,
    points: &[Point],
    outcome: &FamilyOutcome,
    also: &[Family],
    cfg: &Mf61Config,
) -> Option<KFold> {
    let family = outcome.family;
    let pure = PureData::of(points);
    // The weights of the full fit (the Mz family's balance of cornering and slip-ratio sweeps
    // included) for the training sweeps; the held-out points are the in-sample quality's.
    let weighted = if family == Family::Mz {
        mz_data(points, &pure)
    } else {
        family_data(points, family, &pure)
    };
    let scored = family_data(points, family, &pure);
    let fold_of = folds(&scored, model.coefs[FNOMIN], cfg.kfold)?;
    let mut scored_families = vec![(family, scored)];
    for f in also {
        scored_families.push((*f, family_data(points, *f, &pure)));
    }
    let k = fold_of.values().max()? + 1;
    let free = &outcome.free;
    let bounds = refinement_bounds(model, free);
    // Warm start from the full fit (`refit` clamps it into the box).
    let start: Vec<f64> = free.iter().map(|c| model.coefs[*c]).collect();
    let options = Options::warm_refit(cfg.kfold_iterations, cfg.loss);
    let channel = family.channel();
    let full = &outcome.identifiability;
    let mut out = KFold {
        folds: k,
        ..KFold::default()
    };
    for f in 0..k {
        let train = subset(&weighted, &fold_of, f, false);
        let refit = if train.len() < 8 {
            out.deficient_folds += 1;
            model.clone()
        } else {
            let problem = Mf61FamilyProblem::new(model, free, channel, &train);
            let (deficient, at_start) = sweep_folds::fold_design(&problem, &start, &bounds, full);
            out.deficient_folds += usize::from(deficient);
            // Only the refit's parameters are used; its first Jacobian is the one just
            // evaluated at the start.
            let o = refit(&problem, &start, &bounds, &options, Some(at_start));
            out.evaluations += o.evaluations + 1;
            let candidate = problem.model_at(&o.params);
            if rmse_of(&candidate, channel, &train).is_finite() {
                candidate
            } else {
                model.clone()
            }
        };
        for (scored_family, scored) in &scored_families {
            let held = subset(scored, &fold_of, f, true);
            let mut predicted = vec![0.0; held.len()];
            refit.channel_into_at(
                scored_family.channel(),
                &held.inputs,
                Pressures::PerPoint(&held.pressures),
                FIT_MODE,
                &mut predicted,
            );
            for ((m, y), g) in predicted.iter().zip(&held.measured).zip(&held.groups) {
                let e = m - y;
                if e.is_finite() {
                    let slot = out.by_group.entry((*scored_family, *g)).or_insert((0.0, 0));
                    slot.0 += e * e;
                    slot.1 += 1;
                }
            }
        }
    }
    Some(out)
}
