//! Signal preparation: raw run channels -> smoothed working channels in segmentation units.
//!
//! In: [`RunSignals`], the [`Timeline`] of pass 1. Out: [`Prepared`]: slip angle and inclination
//! in degrees, SL relative to free rolling, every channel smoothed by a centred moving average
//! *within* each gap-free block (never across a gap), sweep rates, and dropout stretches
//! (exact zeros, P ~ 0) bridged by linear interpolation so a sensor dropout does not break a
//! plateau or a sweep. Deliberately not here: deciding anything; QC reads the raw channels.

use std::ops::Range;

use super::config::SegmentConfig;
use super::gaps::Timeline;
use super::signals::RunSignals;
use crate::numerics::stats::median_high;

/// Working channels of one run (same length as the run).
#[derive(Clone, Debug)]
pub(crate) struct Prepared {
    /// Slip angle, deg, ISO-W, smoothed.
    pub sa_deg: Vec<f64>,
    /// Longitudinal slip minus its free-rolling value, smoothed (zeros without kappa).
    pub sl: Vec<f64>,
    /// Inclination, deg, smoothed.
    pub ia_deg: Vec<f64>,
    /// Load, N, smoothed.
    pub fz_n: Vec<f64>,
    /// Pressure, kPa, smoothed (P ~ 0 dropouts bridged).
    pub p_kpa: Vec<f64>,
    /// Road speed, km/h, smoothed.
    pub v_kph: Vec<f64>,
    /// dSA/dt, deg/s.
    pub sa_rate: Vec<f64>,
    /// dSL/dt, 1/s.
    pub sl_rate: Vec<f64>,
    /// dIA/dt over the slow window, deg/s.
    pub ia_rate: Vec<f64>,
    /// Whether SL carries a signal.
    pub has_sl: bool,
    /// Bridged dropout stretches per set-point channel (excluded from measured statistics).
    pub dropouts: Dropouts,
}

/// Dropout stretches (exact zeros; P at or below the zero-pressure threshold) that were bridged.
#[derive(Clone, Debug, Default)]
pub(crate) struct Dropouts {
    pub sa: Vec<Range<usize>>,
    pub ia: Vec<Range<usize>>,
    pub fz: Vec<Range<usize>>,
    pub p: Vec<Range<usize>>,
    pub v: Vec<Range<usize>>,
}

/// Exact-zero test: converted zeros stay exact, a live signal is never this small.
pub(crate) fn is_exact_zero(x: f64) -> bool {
    x.abs() < 1e-12
}

/// Build the working channels.
pub(crate) fn prepare(signals: &RunSignals, timeline: &Timeline, cfg: &SegmentConfig) -> Prepared {
    let min_zero = timeline.samples(cfg.qc.zero_min_s);
    let p_floor = cfg.qc.zero_pressure_max_kpa;
    let half = timeline.samples(cfg.smoothing.window_s) / 2;
    let blocks = &timeline.blocks;
    let deg = 1f64.to_degrees();
    let mut dropouts = Dropouts::default();
    let sa_deg = working_set_point(
        signals.alpha_rad,
        min_zero,
        blocks,
        half,
        deg,
        &mut dropouts.sa,
        cfg.qc.zeroed_neighbour_frac,
    );
    let ia_deg = working_set_point(
        signals.gamma_rad,
        min_zero,
        blocks,
        half,
        deg,
        &mut dropouts.ia,
        cfg.qc.zeroed_neighbour_frac,
    );
    let fz_n = working(
        signals.fz_n,
        min_zero,
        is_exact_zero,
        blocks,
        half,
        1.0,
        &mut dropouts.fz,
    );
    let p_kpa = working(
        signals.pressure_kpa,
        min_zero,
        |x| x.abs() <= p_floor,
        blocks,
        half,
        1.0,
        &mut dropouts.p,
    );
    let v_kph = working_set_point(
        signals.speed_kph,
        min_zero,
        blocks,
        half,
        1.0,
        &mut dropouts.v,
        cfg.qc.zeroed_neighbour_frac,
    );
    let has_sl = signals.has_kappa && !signals.kappa.is_empty();
    let sl = if has_sl {
        let mut sl = working(
            signals.kappa,
            min_zero,
            is_exact_zero,
            blocks,
            half,
            1.0,
            &mut Vec::new(),
        );
        let reference = free_rolling_slip(&sl, &sa_deg, &v_kph, cfg);
        sl.iter_mut().for_each(|k| *k -= reference);
        sl
    } else {
        vec![0.0; signals.len()]
    };
    let rate_half = (timeline.samples(cfg.smoothing.rate_window_s) / 2).max(1);
    let ia_rate_half = (timeline.samples(cfg.smoothing.ia_rate_window_s) / 2).max(1);
    let period = timeline.period_s;
    Prepared {
        sa_rate: rate_blocks(&sa_deg, blocks, rate_half, period),
        sl_rate: rate_blocks(&sl, blocks, rate_half, period),
        ia_rate: rate_blocks(&ia_deg, blocks, ia_rate_half, period),
        sa_deg,
        sl,
        ia_deg,
        fz_n,
        p_kpa,
        v_kph,
        has_sl,
        dropouts,
    }
}

/// A set-point channel (SA, IA, V) may rest at exactly 0 (noise-free files, standstill): only
/// zero stretches that are dropouts by the QC rule (clearly non-zero on both sides inside their
/// gap-free block) are bridged, never a legitimate zero.
#[allow(clippy::too_many_arguments)]
fn working_set_point(
    x: &[f64],
    min_zero: usize,
    blocks: &[Range<usize>],
    half: usize,
    scale: f64,
    dropouts: &mut Vec<Range<usize>>,
    frac: f64,
) -> Vec<f64> {
    *dropouts = super::qc::zeroed_stretches(x, min_zero, frac, || false, blocks);
    smooth_bridged(x, dropouts, blocks, half, scale)
}

/// One working channel: dropout stretches (`is_zero` for `min_zero` samples) found and bridged
/// (copied only when there are any), smoothed per block, scaled (rad -> deg).
#[allow(clippy::too_many_arguments)]
fn working(
    x: &[f64],
    min_zero: usize,
    is_zero: impl Fn(f64) -> bool,
    blocks: &[Range<usize>],
    half: usize,
    scale: f64,
    dropouts: &mut Vec<Range<usize>>,
) -> Vec<f64> {
    *dropouts = zero_runs(x, min_zero, is_zero);
    smooth_bridged(x, dropouts, blocks, half, scale)
}

/// `x` with `dropouts` bridged, smoothed per block, scaled.
fn smooth_bridged(
    x: &[f64],
    dropouts: &[Range<usize>],
    blocks: &[Range<usize>],
    half: usize,
    scale: f64,
) -> Vec<f64> {
    let bridged;
    let source = if dropouts.is_empty() {
        x
    } else {
        bridged = bridge(x, dropouts);
        &bridged[..]
    };
    let mut out = Vec::with_capacity(x.len());
    let mut prefix = Vec::with_capacity(x.len() + 1);
    for block in blocks {
        moving_average_into(&source[block.clone()], half, scale, &mut prefix, &mut out);
    }
    out
}

/// Centred differences (`centred_rate_into`) per block, into one vector.
fn rate_blocks(x: &[f64], blocks: &[Range<usize>], half: usize, period_s: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(x.len());
    for block in blocks {
        centred_rate_into(&x[block.clone()], half, period_s, &mut out);
    }
    out
}

/// Median SL while rolling free (rolling, SA quiet): the offset of Calspan's SR, ~0 for SL.
fn free_rolling_slip(sl: &[f64], sa_deg: &[f64], v_kph: &[f64], cfg: &SegmentConfig) -> f64 {
    let rolling = |i: &usize| v_kph[*i] > cfg.activity.rolling_min_kph;
    let mut free: Vec<f64> = (0..sl.len())
        .filter(rolling)
        .filter(|&i| sa_deg[i].abs() < cfg.activity.sa_active_deg)
        .map(|i| sl[i])
        .collect();
    if free.is_empty() {
        free = (0..sl.len()).filter(rolling).map(|i| sl[i]).collect();
    }
    median_high(&mut free).unwrap_or(0.0)
}

/// Centred moving average over `2 * half + 1` samples, shrinking at the ends.
#[cfg(test)]
fn moving_average(x: &[f64], half: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(x.len());
    moving_average_into(x, half, 1.0, &mut Vec::new(), &mut out);
    out
}

/// Centred moving average over `2 * half + 1` samples (shrinking at the ends) times `scale`,
/// appended to `out` (`prefix` is scratch space).
fn moving_average_into(
    x: &[f64],
    half: usize,
    scale: f64,
    prefix: &mut Vec<f64>,
    out: &mut Vec<f64>,
) {
    let n = x.len();
    prefix.clear();
    prefix.push(0.0);
    let mut sum = 0.0;
    for v in x {
        sum += v;
        prefix.push(sum);
    }
    out.extend((0..n).map(|i| {
        let lo = i.saturating_sub(half);
        let hi = (i + half + 1).min(n);
        scale * (prefix[hi] - prefix[lo]) / (hi - lo) as f64
    }));
}

/// Centred difference `(x[i+h] - x[i-h]) / (2 h period)`, one-sided at the ends, per second.
#[cfg(test)]
fn centred_rate(x: &[f64], half: usize, period_s: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(x.len());
    centred_rate_into(x, half, period_s, &mut out);
    out
}

/// Centred difference `(x[i+h] - x[i-h]) / (2 h period)`, one-sided at the ends, per second,
/// appended to `out`.
fn centred_rate_into(x: &[f64], half: usize, period_s: f64, out: &mut Vec<f64>) {
    let n = x.len();
    out.extend((0..n).map(|i| {
        let lo = i.saturating_sub(half);
        let hi = (i + half).min(n.saturating_sub(1));
        if hi > lo {
            (x[hi] - x[lo]) / ((hi - lo) as f64 * period_s)
        } else {
            0.0
        }
    }));
}

/// Maximal stretches of at least `min_len` samples where `is_zero` holds.
pub(crate) fn zero_runs(
    x: &[f64],
    min_len: usize,
    is_zero: impl Fn(f64) -> bool,
) -> Vec<Range<usize>> {
    let mut runs = Vec::new();
    let mut start = None;
    for (i, v) in x.iter().enumerate() {
        match (is_zero(*v), start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                if i - s >= min_len {
                    runs.push(s..i);
                }
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start
        && x.len() - s >= min_len
    {
        runs.push(s..x.len());
    }
    runs
}

/// Copy of `x` with every run replaced by a straight line between its neighbours (held flat
/// at a run touching an end; left as is when the run is the whole signal).
pub(crate) fn bridge(x: &[f64], runs: &[Range<usize>]) -> Vec<f64> {
    let mut out = x.to_vec();
    for run in runs {
        let left = run.start.checked_sub(1).map(|i| x[i]);
        let right = x.get(run.end).copied();
        let (a, b) = match (left, right) {
            (Some(a), Some(b)) => (a, b),
            (Some(a), None) => (a, a),
            (None, Some(b)) => (b, b),
            (None, None) => continue,
        };
        let span = (run.len() + 1) as f64;
        for (k, i) in run.clone().enumerate() {
            out[i] = a + (b - a) * (k + 1) as f64 / span;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moving_average_keeps_a_line_and_shrinks_at_the_ends() {
        let x: Vec<f64> = (0..10).map(f64::from).collect();
        let y = moving_average(&x, 2);
        for (a, b) in x.iter().zip(&y).skip(2).take(6) {
            assert!((a - b).abs() < 1e-12);
        }
        assert!((y[0] - 1.0).abs() < 1e-12, "mean of 0,1,2");
    }

    #[test]
    fn centred_rate_of_a_ramp_is_its_slope() {
        let x: Vec<f64> = (0..50).map(|i| 4.0 * i as f64 * 0.02).collect();
        let r = centred_rate(&x, 5, 0.02);
        assert!(r.iter().all(|v| (v - 4.0).abs() < 1e-9));
    }

    #[test]
    fn dropouts_are_found_and_bridged() {
        let mut x: Vec<f64> = (0..20).map(|i| 100.0 + i as f64).collect();
        for v in &mut x[5..10] {
            *v = 0.0;
        }
        let runs = zero_runs(&x, 3, is_exact_zero);
        assert_eq!(runs, vec![5..10]);
        let y = bridge(&x, &runs);
        for (i, v) in y.iter().enumerate() {
            assert!((v - (100.0 + i as f64)).abs() < 1e-9, "sample {i}: {v}");
        }
        assert!(zero_runs(&x, 6, is_exact_zero).is_empty());
    }
}
