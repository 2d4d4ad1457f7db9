//! k-fold by sweep: which fold each sweep of a family is held out in, shared by the PAC2002 and
//! MF 6.1 out-of-sample checks.
//!
//! In: per sweep its rank at each of its nominal levels (load, inclination, held slip angle, and
//! for a model across pressures the tested pressure), and the number of folds `k`. Out: the fold
//! of every sweep, dealt diagonally: fold = (sum of the sweep's level ranks) mod `k`, so a fold
//! on a load x inclination (x pressure) grid holds at most one sweep of a load at each other
//! level, never most of a load, inclination or pressure (its prediction would be an
//! extrapolation), and repeats of a condition are held out together. An empty fold takes a sweep
//! from the largest one. [`fold_design`]: whether a fold's training sweeps determine the
//! family's coefficients (a deficient fold), judged where both models' fold refits start.
//! [`OutOfSampleQuality`]: the ratio and the flag rule read from a family's in-sample and
//! out-of-sample errors, the same for both models.
//!
//! Deliberately not here: the refits and predictions (each stage's own quality module), where
//! the levels come from (nominal levels of a segment, or clustered sweep means).

use crate::numerics::nonlinear_least_squares::{
    Bounds, Evaluated, Identifiability, LeastSquaresProblem,
};

/// A fold whose training data are this many times worse conditioned than the full fit's is
/// deficient: its training sweeps do not determine the family's coefficients.
pub const DEFICIENT_CONDITION: f64 = 1e3;

/// Whether a fold's training data leave the family's coefficients undetermined, judged at the
/// fold refit's start `at` (the full fit's coefficients, clamped into `bounds`): their data
/// Jacobian there, over the coefficients off their bounds, is rank-deficient or
/// [`DEFICIENT_CONDITION`] times worse conditioned than the full fit's (`full`, measured at the
/// same coefficients). Judged at the start, not where the fold's refit ends: the comparison then
/// sees only what leaving the held-out sweeps out does to the design, not where a short warm
/// refit wandered (its end can be far worse conditioned while its training sweeps hold every
/// level), and a coefficient the training sweeps do not fix, which a refit tends to run onto a
/// bound, would leave the end point's off-bound set and go unjudged. Also returns the evaluation
/// at the start, which the refit takes as its first Jacobian.
pub fn fold_design(
    problem: &impl LeastSquaresProblem,
    at: &[f64],
    bounds: &Bounds,
    full: &Identifiability,
) -> (bool, Evaluated) {
    let (m, n) = (problem.n_residuals(), problem.n_params());
    let at: Vec<f64> = (0..n)
        .map(|j| at[j].max(bounds.lower[j]).min(bounds.upper[j]))
        .collect();
    let (mut r, mut jac) = (vec![0.0; m], vec![0.0; m * n]);
    problem.residuals_and_jacobian(&at, &mut r, &mut jac);
    let off: Vec<usize> = (0..n)
        .filter(|&j| at[j] > bounds.lower[j] && at[j] < bounds.upper[j])
        .collect();
    let id = Identifiability::of(&jac, n, problem.n_data(), &off);
    let deficient = id.rank < id.n_free || id.condition > DEFICIENT_CONDITION * full.condition;
    (deficient, Evaluated { at, r, jac })
}

/// Rank of every value among the distinct values, values equal to `resolution` being one level
/// (for nominal levels, which repeat exactly).
pub fn ranks(values: &[f64], resolution: f64) -> Vec<usize> {
    let keys: Vec<i64> = values
        .iter()
        .map(|v| (v / resolution).round() as i64)
        .collect();
    let mut levels = keys.clone();
    levels.sort_unstable();
    levels.dedup();
    keys.iter()
        .map(|k| levels.binary_search(k).unwrap_or(0))
        .collect()
}

/// Rank of every value among levels formed by sorting the values and starting a new level
/// wherever two neighbours are more than `tolerance` apart (for measured means of a sweep,
/// which wander around their nominal level). Non-finite values take rank 0.
pub fn clustered_ranks(values: &[f64], tolerance: f64) -> Vec<usize> {
    let mut order: Vec<usize> = (0..values.len())
        .filter(|i| values[*i].is_finite())
        .collect();
    order.sort_by(|a, b| values[*a].total_cmp(&values[*b]));
    let mut out = vec![0; values.len()];
    let mut level = 0;
    for (j, i) in order.iter().enumerate() {
        if j > 0 && values[*i] - values[order[j - 1]] > tolerance {
            level += 1;
        }
        out[*i] = level;
    }
    out
}

/// The fold of every sweep from the sum of its level ranks (module docs), every fold non-empty;
/// `None` with fewer than two sweeps or `k < 2`. Folds used: `min(k, sweeps)`.
pub fn diagonal(rank_sums: &[usize], k: usize) -> Option<Vec<usize>> {
    let k = k.min(rank_sums.len());
    if k < 2 {
        return None;
    }
    let mut fold: Vec<usize> = rank_sums.iter().map(|r| r % k).collect();
    for f in 0..k {
        if fold.contains(&f) {
            continue;
        }
        let count = |g: usize, fold: &[usize]| fold.iter().filter(|x| **x == g).count();
        let largest = (0..k).max_by_key(|g| (count(*g, &fold), *g))?;
        let i = fold.iter().rposition(|x| *x == largest)?;
        fold[i] = f;
    }
    Some(fold)
}

/// Whether two fold assignments split the sweeps into the same groups (fold labels aside).
pub fn same_partition(a: &[usize], b: &[usize]) -> bool {
    a.len() == b.len() && (0..a.len()).all(|i| (0..i).all(|j| (a[i] == a[j]) == (b[i] == b[j])))
}

/// One fitted family's in-sample error and k-fold-by-sweep check, and the rules read from them,
/// shared by the PAC2002 and MF 6.1 quality rows (which differ otherwise).
pub trait OutOfSampleQuality {
    /// In-sample RMSE (N or N m).
    fn rmse(&self) -> f64;
    /// `rmse` relative to the largest `|value|` among the points, %.
    fn rmse_pct_of_peak(&self) -> f64;
    /// RMSE of the points predicted k-fold by sweep (`None` without the check).
    fn oos_rmse(&self) -> Option<f64>;
    /// Folds of the check (0 without it).
    fn oos_folds(&self) -> usize;
    /// Folds whose training sweeps could not determine the family's coefficients (some
    /// coefficient rests on the held-out sweeps alone).
    fn oos_deficient_folds(&self) -> usize;

    /// Largest `|value|` among the points (from `rmse` and `rmse_pct_of_peak`; NaN when 0).
    fn peak(&self) -> f64 {
        if self.rmse_pct_of_peak() > 0.0 {
            100.0 * self.rmse() / self.rmse_pct_of_peak()
        } else {
            f64::NAN
        }
    }

    /// Out-of-sample RMSE over in-sample RMSE (NaN without the check).
    fn oos_ratio(&self) -> f64 {
        self.oos_rmse().map_or(f64::NAN, |o| o / self.rmse())
    }

    /// Good in sample, bad out of sample by the error alone: the out-of-sample RMSE exceeds
    /// `limit` times the in-sample RMSE plus 0.1 % of the channel's peak (a floor for
    /// noise-free data).
    fn oos_ratio_over(&self, limit: f64) -> bool {
        let floor = 1e-3 * self.peak();
        self.oos_rmse()
            .is_some_and(|o| o > limit * self.rmse() + floor.max(0.0))
    }

    /// Flagged out of sample: the error is over the limit ([`Self::oos_ratio_over`]), or some
    /// fold's training sweeps could not determine the coefficients (its error is optimistic).
    fn oos_flagged(&self, limit: f64) -> bool {
        self.oos_rmse().is_some() && (self.oos_ratio_over(limit) || self.oos_deficient_folds() > 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clustered_ranks_group_values_within_the_tolerance() {
        let v = [1005.0, 2210.0, 998.0, 1560.0, 2190.0, f64::NAN];
        assert_eq!(clustered_ranks(&v, 100.0), [0, 2, 0, 1, 2, 0]);
        assert_eq!(ranks(&[0.5, 0.0, 0.5], 1e-4), [1, 0, 1]);
    }

    #[test]
    fn diagonal_folds_cover_every_fold() {
        assert_eq!(diagonal(&[0, 0, 0, 0], 3).unwrap(), [0, 0, 2, 1]);
        assert_eq!(
            diagonal(&[0, 1, 2, 3, 4, 5], 5).unwrap(),
            [0, 1, 2, 3, 4, 0]
        );
        assert!(diagonal(&[0], 5).is_none());
        assert!(diagonal(&[0, 1, 2], 1).is_none());
    }

    /// `y = a + b x` at the points `x`.
    struct Line(Vec<f64>);

    impl LeastSquaresProblem for Line {
        fn n_params(&self) -> usize {
            2
        }
        fn n_residuals(&self) -> usize {
            self.0.len()
        }
        fn residuals(&self, p: &[f64], r: &mut [f64]) {
            for (r, x) in r.iter_mut().zip(&self.0) {
                *r = p[0] + p[1] * x;
            }
        }
        fn residuals_and_jacobian(&self, p: &[f64], r: &mut [f64], jac: &mut [f64]) {
            self.residuals(p, r);
            for (i, x) in self.0.iter().enumerate() {
                jac[2 * i] = 1.0;
                jac[2 * i + 1] = *x;
            }
        }
    }

    #[test]
    fn a_fold_is_deficient_when_its_design_does_not_fix_the_coefficients() {
        let full = Identifiability {
            n_free: 2,
            rank: 2,
            condition: 3.0,
        };
        let bounds = Bounds {
            lower: vec![-10.0, -10.0],
            upper: vec![10.0, 10.0],
        };
        let at = [1.0, 2.0];
        // Two distinct x fix both coefficients; the evaluation is at the (clamped) start.
        let (deficient, e) = fold_design(&Line(vec![0.0, 1.0, 2.0]), &at, &bounds, &full);
        assert!(!deficient);
        assert_eq!(e.at, at);
        assert_eq!(e.r, [1.0, 3.0, 5.0]);
        // One x: the slope rests on the held-out points alone.
        assert!(fold_design(&Line(vec![1.0, 1.0]), &at, &bounds, &full).0);
        // Nearly one x: determined, but far worse conditioned than the full fit.
        assert!(fold_design(&Line(vec![1.0, 1.0 + 1e-6]), &at, &bounds, &full).0);
        // A start outside the box is judged where the refit starts, on the bound, and a
        // coefficient on its bound is not judged (one x then fixes the intercept).
        let (deficient, e) = fold_design(&Line(vec![1.0, 1.0]), &[1.0, 12.0], &bounds, &full);
        assert!(!deficient);
        assert_eq!(e.at, [1.0, 10.0]);
    }

    #[test]
    fn same_partition_ignores_fold_labels() {
        assert!(same_partition(&[0, 1, 0, 2], &[2, 0, 2, 1]));
        assert!(!same_partition(&[0, 1, 0, 2], &[0, 1, 1, 2]));
        assert!(!same_partition(&[0, 1], &[0, 1, 1]));
    }
}
