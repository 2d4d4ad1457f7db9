//! k-fold by sweep: which fold each sweep of a family is held out in, shared by the PAC2002 and
//! MF 6.1 out-of-sample checks.
//!
//! In: per sweep its rank at each of its nominal levels (load, inclination, held slip angle, and
//! for a model across pressures the tested pressure), and the number of folds `k`. Out: the fold
//! of every sweep, dealt diagonally: fold = (sum of the sweep's level ranks) mod `k`, so a fold
//! on a load x inclination (x pressure) grid holds at most one sweep of a load at each other
//! level, never most of a load, inclination or pressure (its prediction would be an
//! extrapolation), and repeats of a condition are held out together. An empty fold takes a sweep
//! from the largest one. [`OutOfSampleQuality`]: the ratio and the flag rule read from a
//! family's in-sample and out-of-sample errors, the same for both models.
//!
//! Deliberately not here: the refits and predictions (each stage's own quality module), where
//! the levels come from (nominal levels of a segment, or clustered sweep means).

/// A fold whose training data are this many times worse conditioned than the full fit's is
/// deficient: its training sweeps do not determine the family's coefficients.
pub const DEFICIENT_CONDITION: f64 = 1e3;

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

    /// Good in sample, bad out of sample: the out-of-sample RMSE exceeds `limit` times the
    /// in-sample RMSE plus 0.1 % of the channel's peak (a floor for noise-free data), or some
    /// fold's training sweeps could not determine the coefficients.
    fn oos_flagged(&self, limit: f64) -> bool {
        let floor = 1e-3 * self.peak();
        self.oos_rmse().is_some_and(|o| {
            o > limit * self.rmse() + floor.max(0.0) || self.oos_deficient_folds() > 0
        })
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

    #[test]
    fn same_partition_ignores_fold_labels() {
        assert!(same_partition(&[0, 1, 0, 2], &[2, 0, 2, 1]));
        assert!(!same_partition(&[0, 1, 0, 2], &[0, 1, 1, 2]));
        assert!(!same_partition(&[0, 1], &[0, 1, 1]));
    }
}
