//! Pass 1, gap split: ET -> sample period, gap-free blocks and ET anomalies.
//!
//! In: the ET column. Out: [`Timeline`]: the median sample period, the blocks between ET jumps
//! (a "run" file drops dwells, so ET jumps there) and the indices where ET repeats or steps back.
//! Deliberately not here: anything about the other channels; anomalies are reported, not fixed
//! (a backwards step does not split the run, it is flagged by QC).

use std::ops::Range;

use super::config::GapConfig;
use crate::numerics::stats::median_high;

/// Fallback sample period when ET gives none (fewer than two distinct times), s.
const FALLBACK_PERIOD_S: f64 = 0.01;

/// Two ET values closer than this are "the same time", s (files carry 3 decimals).
const SAME_TIME_S: f64 = 1e-9;

/// The time structure of a run.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Timeline {
    /// Median of the positive ET steps, s.
    pub period_s: f64,
    /// Gap-free blocks, sorted, covering every sample.
    pub blocks: Vec<Range<usize>>,
    /// Indices `i` where `et[i] < et[i - 1]`.
    pub non_monotonic: Vec<usize>,
    /// Indices `i` where `et[i] == et[i - 1]` (within 1e-9 s).
    pub duplicated: Vec<usize>,
}

impl Timeline {
    /// Number of samples spanning `seconds` at the run's sample period (at least 1).
    pub fn samples(&self, seconds: f64) -> usize {
        ((seconds / self.period_s).round() as usize).max(1)
    }
}

/// Split the run at ET gaps and collect ET anomalies.
pub(crate) fn split_gaps(et_s: &[f64], cfg: &GapConfig) -> Timeline {
    let period_s = median_positive_step(et_s).unwrap_or(FALLBACK_PERIOD_S);
    let gap_s = cfg.min_gap_s.max(cfg.gap_factor * period_s);
    let mut blocks = Vec::new();
    let mut non_monotonic = Vec::new();
    let mut duplicated = Vec::new();
    let mut start = 0;
    for i in 1..et_s.len() {
        let dt = et_s[i] - et_s[i - 1];
        if dt > gap_s {
            blocks.push(start..i);
            start = i;
        } else if dt.abs() <= SAME_TIME_S {
            duplicated.push(i);
        } else if dt < 0.0 {
            non_monotonic.push(i);
        }
    }
    if !et_s.is_empty() {
        blocks.push(start..et_s.len());
    }
    Timeline {
        period_s,
        blocks,
        non_monotonic,
        duplicated,
    }
}

fn median_positive_step(et_s: &[f64]) -> Option<f64> {
    let mut steps: Vec<f64> = et_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|dt| *dt > SAME_TIME_S)
        .collect();
    median_high(&mut steps)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn et(n: usize, dt: f64) -> Vec<f64> {
        (0..n).map(|i| i as f64 * dt).collect()
    }

    #[test]
    fn a_dwell_cut_splits_the_run() {
        let mut t = et(100, 0.02);
        t.extend(et(50, 0.02).iter().map(|x| x + 30.0));
        let timeline = split_gaps(&t, &GapConfig::default());
        assert!((timeline.period_s - 0.02).abs() < 1e-12);
        assert_eq!(timeline.blocks, vec![0..100, 100..150]);
        assert!(timeline.non_monotonic.is_empty() && timeline.duplicated.is_empty());
    }

    #[test]
    fn repeats_and_backward_steps_are_reported_not_split() {
        let mut t = et(20, 0.01);
        t[5] = t[4];
        t[12] = t[11] - 0.005;
        let timeline = split_gaps(&t, &GapConfig::default());
        assert_eq!(timeline.blocks, vec![0..20]);
        assert_eq!(timeline.duplicated, vec![5]);
        assert_eq!(timeline.non_monotonic, vec![12]);
    }

    #[test]
    fn tiny_or_empty_runs_do_not_panic() {
        assert!(split_gaps(&[], &GapConfig::default()).blocks.is_empty());
        let one = split_gaps(&[3.0], &GapConfig::default());
        assert_eq!(one.blocks, vec![0..1]);
        assert_eq!(one.period_s, FALLBACK_PERIOD_S);
    }
}
