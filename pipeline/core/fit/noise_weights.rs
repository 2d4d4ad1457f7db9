//! Per-sweep noise levels and the factors that weigh a family's sweeps by them.
//!
//! In: one channel's samples of one sweep in time order (for its noise level), or the noise
//! levels of a family's sweeps (for their factors). Out: a robust standard deviation of the
//! channel's high-frequency scatter ([`high_frequency_scatter`]), and one weight factor in
//! `(0, 1]` per sweep ([`sweep_factors`]).
//!
//! Scatter: second differences of consecutive samples cancel the curve's level and slope (a
//! sweep's curvature over two sample steps is far below sensor noise) and leave `sqrt(6)` times
//! the white part of the noise; 1.4826 times their median absolute deviation is a standard
//! deviation that spikes and turnarounds cannot move.
//!
//! Factors (generalised least squares with a tolerance): the reference level is the lower
//! quartile of the family's levels, each level first floored at 5 % of their median and at
//! 0.1 % of the family's largest `|value|` (a noise-free virtual sweep would otherwise set a
//! reference of ~0 and weigh every other sweep down to nothing). A sweep within
//! [`TOLERANCE`] times the reference counts fully (factor 1): the levels of equally noisy sweeps
//! differ by their estimation error, and the fit of such a set must not depend on it. A noisier
//! sweep's residuals are divided by its level: factor `TOLERANCE * reference / level` (a sweep
//! with ten times the reference's scatter weighs 1/8).
//!
//! Levels are compared between kinds of sweep, not between sweeps ([`kind_levels`]: each
//! sweep takes its kind's median level). Sweeps of a kind share the rig's configuration (a
//! drive/brake run turns the wheel through a driveline, whose vibration a real rig's Mz picks
//! up); within a kind a sweep's scatter also grows with its load, and weighing the heavy sweeps
//! down would undo the stages' rule that every sweep counts the same relative to its peak.
//!
//! Deliberately not here: which families use the factors (the stages decide), the sweeps'
//! other weights (relative to their peak, per point count).

use crate::numerics::stats::median;

/// Levels within this multiple of the reference count as equally noisy: the estimates of
/// equally noisy sweeps (each from hundreds of second differences) scatter by a few per cent
/// (+-6 % from the 10th to the 90th percentile over the cornering sweeps of a real TTC round).
pub const TOLERANCE: f64 = 1.25;

/// Fewest second differences a level is estimated from.
const MIN_DIFFERENCES: usize = 8;

/// Robust standard deviation of the high-frequency scatter of `values` (samples in time order;
/// non-finite values are skipped with their neighbours): `1.4826 MAD / sqrt(6)` of the second
/// differences of consecutive finite triples; `None` with fewer than 8 of them.
pub fn high_frequency_scatter(values: &[f64]) -> Option<f64> {
    let mut d2: Vec<f64> = values
        .windows(3)
        .filter(|w| w.iter().all(|v| v.is_finite()))
        .map(|w| w[0] - 2.0 * w[1] + w[2])
        .collect();
    if d2.len() < MIN_DIFFERENCES {
        return None;
    }
    let centre = median(&mut d2)?;
    let mut dev: Vec<f64> = d2.iter().map(|d| (d - centre).abs()).collect();
    Some(1.4826 * median(&mut dev)? / 6f64.sqrt())
}

/// Each sweep's level replaced by the median of its kind's known levels (`None` where its
/// kind has none); sweeps are `(kind, level)`.
pub fn kind_levels<K: Ord + Copy>(sweeps: &[(K, Option<f64>)]) -> Vec<Option<f64>> {
    let mut by_kind: std::collections::BTreeMap<K, Vec<f64>> = Default::default();
    for (kind, level) in sweeps {
        if let Some(v) = level {
            by_kind.entry(*kind).or_default().push(*v);
        }
    }
    let medians: std::collections::BTreeMap<K, f64> = by_kind
        .into_iter()
        .filter_map(|(k, mut v)| median(&mut v).map(|m| (k, m)))
        .collect();
    sweeps
        .iter()
        .map(|(k, _)| medians.get(k).copied())
        .collect()
}

/// One factor per sweep from the sweeps' noise levels (`None`: unknown, factor 1) and the
/// family's largest `|value|` (`peak`); see the module docs.
pub fn sweep_factors(levels: &[Option<f64>], peak: f64) -> Vec<f64> {
    let mut known: Vec<f64> = levels.iter().flatten().copied().collect();
    let Some(mid) = median(&mut known.clone()) else {
        return vec![1.0; levels.len()];
    };
    let floor = (0.05 * mid).max(1e-3 * peak.abs());
    for v in &mut known {
        *v = v.max(floor);
    }
    known.sort_by(f64::total_cmp);
    let reference = known[(known.len() - 1) / 4];
    levels
        .iter()
        .map(|level| match level {
            Some(v) if reference > 0.0 => (TOLERANCE * reference / v.max(floor)).min(1.0),
            _ => 1.0,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::random::SplitMix64;

    /// Deterministic white noise of unit standard deviation.
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = SplitMix64::new(seed);
        (0..n).map(|_| rng.gaussian()).collect()
    }

    /// On a curve with a slope and turnarounds plus white noise, the scatter is the noise's
    /// standard deviation, not the curve's; a spike does not move it.
    #[test]
    fn scatter_measures_noise_not_curve() {
        let e = noise(2000, 7);
        let mut y: Vec<f64> = (0..2000)
            .map(|i| {
                let t = i as f64 * 0.01;
                60.0 * (0.5 * t).sin() + 3.0 * e[i]
            })
            .collect();
        y[500] += 1e4;
        y[900] = f64::NAN;
        let s = high_frequency_scatter(&y).unwrap();
        assert!((s - 3.0).abs() < 0.3, "scatter {s}");
        let clean: Vec<f64> = (0..2000).map(|i| 60.0 * (0.005 * i as f64).sin()).collect();
        assert!(high_frequency_scatter(&clean).unwrap() < 1e-3);
        assert!(high_frequency_scatter(&y[..5]).is_none());
    }

    /// A sweep takes its kind's median level; a kind without levels has none.
    #[test]
    fn kinds_share_their_median_level() {
        let sweeps = [
            (0, Some(1.0)),
            (1, Some(10.0)),
            (0, Some(3.0)),
            (0, Some(2.0)),
            (2, None),
        ];
        assert_eq!(
            kind_levels(&sweeps),
            vec![Some(2.0), Some(10.0), Some(2.0), Some(2.0), None]
        );
    }

    /// Equally noisy sweeps keep factor 1; a ten times noisier one is weighed down by the
    /// ratio over the tolerance; a noise-free sweep neither gets more than 1 nor weighs the
    /// others down.
    #[test]
    fn factors_weigh_noisy_sweeps_down_only() {
        let similar = [Some(1.0), Some(1.1), Some(0.9), Some(1.12), None];
        assert_eq!(sweep_factors(&similar, 100.0), vec![1.0; 5]);
        let mixed = [Some(1.0), Some(1.1), Some(0.9), Some(10.0), Some(12.0)];
        let f = sweep_factors(&mixed, 100.0);
        assert_eq!(&f[..3], &[1.0; 3]);
        // the reference is the lower quartile, 1.0: 1.25 * 1.0 / 10
        assert!((f[3] - 0.125).abs() < 1e-12, "{f:?}");
        assert!((f[4] - 1.25 / 12.0).abs() < 1e-12, "{f:?}");
        let with_clean = [Some(0.0), Some(1.0), Some(1.1), Some(0.95), Some(1.05)];
        let f = sweep_factors(&with_clean, 100.0);
        assert!(f.iter().all(|v| *v == 1.0), "{f:?}");
    }
}
