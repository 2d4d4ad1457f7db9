//! How well a fitted family predicts what it did not see, and whether it stays with the data
//! between the points it was fitted to.
//!
//! In: a fitted family (its free coefficients, the final coefficient vector), its collapsed
//! sweeps, the stage's envelope and configuration. Out: [`OutOfSample`] (k-fold by sweep) and
//! [`TrendDeviation`] (dense grid along every sweep).
//!
//! - Out of sample: the sweeps are dealt into `k` folds by their nominal levels, diagonally:
//!   fold = (rank of the load + rank of the inclination + rank of the held slip angle) mod `k`
//!   (ranks among the family's distinct levels), so a fold on a load x inclination grid holds at
//!   most one sweep of a load at each inclination, never most of a load or inclination level
//!   (its prediction would be an extrapolation), and repeats of a condition are held out
//!   together. A family whose term selection (`select`) held a group reports the k-fold of
//!   another dealing ([`Dealing::Report`]), not the one the selection compared models on. For
//!   each
//!   fold the family's free coefficients are refitted on the other folds' sweeps, warm-started
//!   from the family's own stage (where its in-sample figure was measured; the combined `Mz`
//!   family later refits the `Mz0` coefficients on every sweep) with a short budget
//!   ([`super::FitConfig::kfold_iterations`], one robust-loss round), and the held-out sweeps'
//!   collapsed points are predicted (each by the mean of the model at its branch operating
//!   points, as in the fit). The RMSE over every held-out point is on the same points
//!   as the in-sample `rmse`. Families fitted earlier (e.g. `Fy0` under `Mz0`) keep their
//!   full-data values: a family's own coefficients are what is cross-validated.
//! - Trend deviation: between neighbouring collapsed points of every sweep the operating point
//!   is interpolated at [`TREND_SUBDIVISIONS`] steps (~0.5 mrad of slip angle on the default
//!   grid) and the model is compared with the data's local trend there (a least-squares
//!   quadratic through the six nearest collapsed points). A model that is good at the points
//!   and wild between them (a residual-torque spike) shows here and nowhere else.
//!
//! Deliberately not here: the full fit (`stage`), choosing what is flagged beyond the ratio.

use super::FitConfig;
use super::collapse::CollapsedSweep;
use super::family::Family;
use super::linear::lstsq;
use super::problem::{DataPoint, FIT_MODE, FamilyProblem};
use super::stage::{Envelope, bounds_of, data_points, output_of, penalties_of};
use crate::fit::output::Output;
use crate::fit::sweep_folds;
use crate::numerics::nonlinear_least_squares::{Identifiability, Options, refit};
use crate::tire_model::{Coef, Coefs, Evaluation, Pac2002, SlipInput};

/// Interpolation steps between neighbouring collapsed points of the trend check.
pub const TREND_SUBDIVISIONS: usize = 8;

/// k-fold-by-sweep quality of one family (units of its channel).
#[derive(Clone, Debug, PartialEq)]
pub struct OutOfSample {
    /// Folds used (`min(k, sweeps)`).
    pub folds: usize,
    /// Held-out collapsed points predicted (every point of every sweep, once).
    pub n: usize,
    /// RMSE of those predictions.
    pub rmse: f64,
    /// Solver evaluations of the refits.
    pub evaluations: usize,
    /// Folds whose training sweeps do not determine the family's coefficients
    /// ([`sweep_folds::fold_design`], judged at the refit's start): the held-out sweeps alone
    /// carried that information, and the warm start, not the data, set those coefficients, so
    /// the fold's error is optimistic.
    pub deficient_folds: usize,
}

/// The largest deviation of the model from the data's local trend along the sweeps.
#[derive(Clone, Debug, PartialEq)]
pub struct TrendDeviation {
    /// `|model - trend|`, N or N m.
    pub max: f64,
    /// Where: the sweep id.
    pub sweep: String,
    /// Where: the swept slip (rad or slip ratio).
    pub slip: f64,
    /// Points compared.
    pub n: usize,
}

/// How the sweeps are dealt into folds (both diagonal in the nominal levels, module docs).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Dealing {
    /// fold = (load rank + inclination rank + slip-angle rank) mod `k`: the family's reported
    /// figure when no term selection ran, and the folds the selection decides on.
    Selection,
    /// The report folds of a family whose term selection held a group: a dealing that shares
    /// little with [`Dealing::Selection`] (anti-diagonal, fold = (load rank minus inclination
    /// rank minus slip-angle rank) mod `k`; where that is the same partition, as with one
    /// varying level, diagonal in `k + 1` folds), so the kept model's figure is not the minimum
    /// the selection took over the same folds' noise. `None` from [`out_of_sample`] where no
    /// dealing differs (a fold per sweep).
    Report,
}

/// The folds of `sweeps` dealt as `dealing` says (module docs, [`sweep_folds::diagonal`]),
/// `None` with fewer than two sweeps or `k < 2`, or for [`Dealing::Report`] when every other
/// dealing is the selection's partition.
fn folds(sweeps: &[&CollapsedSweep], k: usize, dealing: Dealing) -> Option<Vec<usize>> {
    let selection = diagonal_folds(sweeps, k, 1)?;
    if dealing == Dealing::Selection {
        return Some(selection);
    }
    [
        diagonal_folds(sweeps, k, k.min(sweeps.len()) - 1),
        diagonal_folds(sweeps, k + 1, 1),
    ]
    .into_iter()
    .flatten()
    .find(|f| !sweep_folds::same_partition(f, &selection))
}

/// Folds from the rank sum `load + w (inclination + slip angle)` (`w = k - 1`: anti-diagonal).
fn diagonal_folds(sweeps: &[&CollapsedSweep], k: usize, w: usize) -> Option<Vec<usize>> {
    let level = |f: fn(&CollapsedSweep) -> f64, resolution: f64| {
        sweep_folds::ranks(
            &sweeps.iter().map(|s| f(s)).collect::<Vec<f64>>(),
            resolution,
        )
    };
    let fz = level(|s| s.nominal.fz_n, 1.0);
    let gamma = level(|s| s.nominal.gamma_rad, 1e-4);
    let alpha = level(|s| s.nominal.alpha_rad, 1e-4);
    let sums: Vec<usize> = (0..sweeps.len())
        .map(|i| fz[i] + w * (gamma[i] + alpha[i]))
        .collect();
    sweep_folds::diagonal(&sums, k)
}

/// k-fold-by-sweep prediction error of `family` on the folds of `dealing` (see the module docs);
/// `None` with fewer than two sweeps.
#[allow(clippy::too_many_arguments)]
pub fn out_of_sample(
    family: Family,
    free: &[Coef],
    sweeps: &[&CollapsedSweep],
    env: &Envelope,
    cfg: &FitConfig,
    c: &Coefs<f64>,
    full: &Identifiability,
    dealing: Dealing,
) -> Option<OutOfSample> {
    let fold = folds(sweeps, cfg.kfold, dealing)?;
    let k = fold.iter().max()? + 1;
    let output = output_of(family);
    let penalties = penalties_of(family, free, env, cfg);
    let bounds = bounds_of(free, c, env);
    // Warm start from the full fit (`refit` clamps it into the box).
    let start: Vec<f64> = free.iter().map(|coef| c[*coef]).collect();
    let options = Options {
        scale_floor: 1e-5,
        ..Options::warm_refit(cfg.kfold_iterations, cfg.loss)
    };
    let (mut ss, mut n, mut evaluations, mut deficient) = (0.0, 0usize, 0usize, 0usize);
    for f in 0..k {
        let train: Vec<&CollapsedSweep> = sweeps
            .iter()
            .zip(&fold)
            .filter(|(_, g)| **g != f)
            .map(|(s, _)| *s)
            .collect();
        let points: Vec<DataPoint> = data_points(&train, family, cfg.kfold_points_per_sweep);
        let problem = FamilyProblem::new(c, free, family, &points, &penalties);
        let (is_deficient, at_start) = sweep_folds::fold_design(&problem, &start, &bounds, full);
        deficient += usize::from(is_deficient);
        // Only the refit's parameters are used: no statistics at its solution, and its first
        // Jacobian is the one just evaluated at the start.
        let outcome = refit(&problem, &start, &bounds, &options, Some(at_start));
        evaluations += outcome.evaluations + 1;
        let refitted = problem.coefs_at(&outcome.params);
        let held_out: Vec<_> = sweeps
            .iter()
            .zip(&fold)
            .filter(|(_, g)| **g == f)
            .flat_map(|(s, _)| s.points.iter())
            .filter(|p| p.output(output).is_finite())
            .collect();
        // Every held-out point's branch operating points, then their means.
        let mut inputs: Vec<SlipInput> = held_out
            .iter()
            .flat_map(|p| p.branches.as_slice().iter().copied())
            .collect();
        let values = channel_batch(family, &refitted, &mut inputs);
        let mut next = values.into_iter();
        for p in &held_out {
            let m = p.branches.mean_of(|_| next.next().unwrap_or(f64::NAN));
            let e = m - p.output(output);
            if e.is_finite() {
                ss += e * e;
                n += 1;
            }
        }
    }
    Some(OutOfSample {
        folds: k,
        n,
        rmse: if n > 0 {
            (ss / n as f64).sqrt()
        } else {
            f64::NAN
        },
        evaluations,
        deficient_folds: deficient,
    })
}

fn lerp_input(a: &SlipInput, b: &SlipInput, t: f64) -> SlipInput {
    let l = |x: f64, y: f64| x + t * (y - x);
    SlipInput {
        fz_n: l(a.fz_n, b.fz_n),
        kappa: l(a.kappa, b.kappa),
        alpha_rad: l(a.alpha_rad, b.alpha_rad),
        gamma_rad: l(a.gamma_rad, b.gamma_rad),
        vx_mps: l(a.vx_mps, b.vx_mps),
    }
}

/// Least-squares quadratic through `(x, y)`: `(centre, scale, [a, b, c])` with
/// `y = a + b u + c u^2`, `u = (x - centre)/scale` (`None` if singular).
fn local_quadratic(x: &[f64], y: &[f64]) -> Option<(f64, f64, [f64; 3])> {
    let centre = x.iter().sum::<f64>() / x.len() as f64;
    let scale = x.iter().map(|v| (v - centre).abs()).fold(0.0, f64::max);
    if scale <= 0.0 {
        return None;
    }
    let design: Vec<f64> = x
        .iter()
        .flat_map(|v| {
            let u = (v - centre) / scale;
            [1.0, u, u * u]
        })
        .collect();
    let b = lstsq(&design, 3, y)?;
    Some((centre, scale, [b[0], b[1], b[2]]))
}

fn quadratic_at(q: &(f64, f64, [f64; 3]), at: f64) -> f64 {
    let u = (at - q.0) / q.1;
    q.2[0] + q.2[1] * u + q.2[2] * u * u
}

/// The family's channel at many points through the batch evaluator (raw mode, as the fit
/// evaluates): the pure families with the other slip set to zero (`Gxa = Gyk = 1`, `SVyk = 0`
/// there) and, for `Mz0`, without the `s Fx` arm.
fn channel_batch(family: Family, c: &Coefs<f64>, inputs: &mut [SlipInput]) -> Vec<f64> {
    let mut coefs = c.clone();
    match family {
        Family::Fy0 | Family::Mz0 => inputs.iter_mut().for_each(|i| i.kappa = 0.0),
        Family::Fx0 => inputs.iter_mut().for_each(|i| i.alpha_rad = 0.0),
        _ => {}
    }
    if family == Family::Mz0 {
        for k in [Coef::SSZ1, Coef::SSZ2, Coef::SSZ3, Coef::SSZ4] {
            coefs[k] = 0.0;
        }
    }
    let model = Pac2002::new(coefs);
    let mut out = vec![Evaluation::default(); inputs.len()];
    model.eval_batch(inputs, FIT_MODE, &mut out);
    out.iter()
        .map(|e| match family {
            Family::Fx0 | Family::Fx => e.fx_n,
            Family::Fy0 | Family::Fy => e.fy_n,
            Family::Mz0 | Family::Mz => e.mz_nm,
            Family::Mx => e.mx_nm,
            Family::My => f64::NAN,
        })
        .collect()
}

/// The largest deviation of `family`'s channel from the data's local trend (module docs).
pub fn trend_deviation(
    family: Family,
    sweeps: &[&CollapsedSweep],
    c: &Coefs<f64>,
) -> Option<TrendDeviation> {
    let output: Output = output_of(family);
    let mut best: Option<TrendDeviation> = None;
    let mut n = 0;
    for s in sweeps {
        let pts: Vec<_> = s
            .points
            .iter()
            .filter(|p| p.output(output).is_finite())
            .collect();
        if pts.len() < 6 {
            continue;
        }
        let x: Vec<f64> = pts.iter().map(|p| s.swept(p)).collect();
        let y: Vec<f64> = pts.iter().map(|p| p.output(output)).collect();
        let (mut inputs, mut at, mut trend) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..pts.len() - 1 {
            let lo = i.saturating_sub(2).min(pts.len() - 6);
            let Some(q) = local_quadratic(&x[lo..lo + 6], &y[lo..lo + 6]) else {
                continue;
            };
            for step in 0..TREND_SUBDIVISIONS {
                let t = step as f64 / TREND_SUBDIVISIONS as f64;
                let xi = x[i] + t * (x[i + 1] - x[i]);
                inputs.push(lerp_input(&pts[i].input, &pts[i + 1].input, t));
                at.push(xi);
                trend.push(quadratic_at(&q, xi));
            }
        }
        let model = channel_batch(family, c, &mut inputs);
        n += model.len();
        for ((m, t), xi) in model.iter().zip(&trend).zip(&at) {
            let d = (m - t).abs();
            if d.is_finite() && best.as_ref().is_none_or(|b| d > b.max) {
                best = Some(TrendDeviation {
                    max: d,
                    sweep: s.id.clone(),
                    slip: *xi,
                    n: 0,
                });
            }
        }
    }
    best.map(|b| TrendDeviation { n, ..b })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadratic_trend_is_exact_on_a_parabola() {
        let x = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5];
        let y: Vec<f64> = x.iter().map(|v| 3.0 - 2.0 * v + 5.0 * v * v).collect();
        let at = 0.25;
        let got = quadratic_at(&local_quadratic(&x, &y).unwrap(), at);
        assert!((got - (3.0 - 0.5 + 5.0 * 0.0625)).abs() < 1e-12, "{got}");
    }

    #[test]
    fn folds_are_fixed_and_never_empty() {
        let mk = |id: &str| CollapsedSweep {
            id: id.to_string(),
            kind: super::super::SweepKind::Cornering,
            nominal: super::super::SweepNominal {
                fz_n: 1000.0,
                gamma_rad: 0.0,
                alpha_rad: 0.0,
            },
            samples: Vec::new(),
            points: Vec::new(),
            spikes: 0,
            scatter: [None; 4],
        };
        let sweeps: Vec<CollapsedSweep> = (0..7).map(|i| mk(&format!("s-{i}"))).collect();
        let refs: Vec<&CollapsedSweep> = sweeps.iter().collect();
        let f = folds(&refs, 5, Dealing::Selection).unwrap();
        assert_eq!(f, folds(&refs, 5, Dealing::Selection).unwrap());
        for g in 0..5 {
            assert!(f.contains(&g), "{f:?}");
        }
        assert!(folds(&refs[..1], 5, Dealing::Selection).is_none());
        // A 5-load x 3-inclination grid in 5 folds: each fold holds one sweep of 3 different
        // loads at the 3 inclinations.
        let grid: Vec<CollapsedSweep> = (0..15)
            .map(|i| {
                let mut s = mk(&format!("g-{i}"));
                s.nominal.fz_n = 200.0 * (1 + i % 5) as f64;
                s.nominal.gamma_rad = (i / 5) as f64 * 0.02;
                s
            })
            .collect();
        let refs: Vec<&CollapsedSweep> = grid.iter().collect();
        let f = folds(&refs, 5, Dealing::Selection).unwrap();
        for g in 0..5 {
            let held: Vec<&&CollapsedSweep> = refs
                .iter()
                .zip(&f)
                .filter(|(_, x)| **x == g)
                .map(|(s, _)| s)
                .collect();
            assert_eq!(held.len(), 3, "{f:?}");
            let mut loads: Vec<i64> = held.iter().map(|s| s.nominal.fz_n as i64).collect();
            loads.dedup();
            assert_eq!(loads.len(), 3, "{f:?}");
        }
        assert_eq!(folds(&refs[..2], 5, Dealing::Selection).unwrap().len(), 2);
        // The report folds on that grid: again one sweep of 3 different loads at the 3
        // inclinations per fold, and no two sweeps held out together in both dealings.
        let r = folds(&refs, 5, Dealing::Report).unwrap();
        for g in 0..5 {
            let mut loads: Vec<i64> = (0..15)
                .filter(|i| r[*i] == g)
                .map(|i| refs[i].nominal.fz_n as i64)
                .collect();
            assert_eq!(loads.len(), 3, "{r:?}");
            loads.sort_unstable();
            loads.dedup();
            assert_eq!(loads.len(), 3, "{r:?}");
        }
        for i in 0..15 {
            for j in 0..i {
                assert!(f[i] != f[j] || r[i] != r[j], "{f:?} {r:?}");
            }
        }
        // One varying level (7 loads): the anti-diagonal is the same partition, so the report
        // folds are 6 diagonal ones; a fold per sweep leaves no other dealing.
        let loads: Vec<CollapsedSweep> = (0..7)
            .map(|i| {
                let mut s = mk(&format!("l-{i}"));
                s.nominal.fz_n = 200.0 * (1 + i) as f64;
                s
            })
            .collect();
        let refs: Vec<&CollapsedSweep> = loads.iter().collect();
        let r = folds(&refs, 5, Dealing::Report).unwrap();
        assert_eq!(r, [0, 1, 2, 3, 4, 5, 0]);
        assert!(folds(&refs[..4], 5, Dealing::Report).is_none());
    }
}
