//! Pass 6, QC: raw channels + final segments -> QC flags per segment.
//!
//! In: the raw [`RunSignals`], the [`Timeline`] (ET anomalies), the pressure dropouts found by
//! preparation, the segments' ranges and kinds. Out: one sorted, deduplicated flag list per
//! segment. A finding covering a stretch flags every segment the stretch overlaps.
//!
//! Rules: `zero_pressure` where P <= `qc.zero_pressure_max_kpa` for `qc.zero_min_s`;
//! `zeroed_channel:<name>` where a channel is exactly 0 for `qc.zero_min_s` and either carries
//! sensor noise elsewhere (a noisy measured channel never rests at exactly 0) or is clearly
//! non-zero on both sides (set-point channels and noise-free files: SA at a dwell or V at a static
//! hold are legitimately 0 and not flagged; nor are slip forces and moments at standstill);
//! `non_monotonic_et` / `duplicated_et` at ET
//! steps back / repeats; `too_short` for a classified segment under `qc.too_short_min_s`, a sweep
//! cycle with only one big excursion, or a sweep under `qc.too_short_frac` of its kind's median
//! length in the run; `load_drift` when the least-squares FZ trend across a held-load segment
//! (read at low tire force, where load control is not disturbed) exceeds `qc.load_drift` (a
//! persistent change, beyond the swing of loose load control);
//! `saturated_channel:<name>` when a live (noisy) force, temperature or extra channel sits
//! exactly at its run extreme for `qc.saturation_min_s`; `out_of_range:pressure_kpa` when the
//! segment's median pressure (dropouts left out) is outside [`crate::physical::PRESSURE_KPA`]
//! (a pressure read in the wrong unit). Off-nominal flags come from binning.
//! Deliberately not here: deciding what to do with flagged data (the fitting stages do).

use std::ops::Range;

use super::config::SegmentConfig;
use super::gaps::Timeline;
use super::output::{QcFlag, SegmentKind};
use super::prepare::{is_exact_zero, zero_runs};
use super::signals::RunSignals;
use crate::numerics::stats::median_high;

/// What QC needs to know about a segment.
pub(crate) struct Draft {
    pub samples: Range<usize>,
    pub kind: SegmentKind,
    /// Big excursions of a sweep cycle (2 = complete).
    pub parts: usize,
}

/// Samples on each side of a zero stretch used to judge whether the channel should be non-zero.
const NEIGHBOURS: usize = 3;

/// A channel whose consecutive samples repeat exactly in more than this fraction of steps is
/// too smooth (or too coarse) for "sitting exactly at its extreme" to mean clipping.
const SMOOTH_REPEAT_FRAC: f64 = 0.2;

/// Flags for every draft (same order).
pub(crate) fn flag(
    signals: &RunSignals,
    timeline: &Timeline,
    pressure_dropouts: &[Range<usize>],
    drafts: &[Draft],
    cfg: &SegmentConfig,
) -> Vec<Vec<QcFlag>> {
    let mut flags: Vec<Vec<QcFlag>> = vec![Vec::new(); drafts.len()];
    let starts: Vec<usize> = drafts.iter().map(|d| d.samples.start).collect();
    let mut mark = |range: Range<usize>, flag: &QcFlag| {
        let first = starts
            .partition_point(|&s| s <= range.start)
            .saturating_sub(1);
        for (k, d) in drafts.iter().enumerate().skip(first) {
            if d.samples.start >= range.end.max(range.start + 1) {
                break;
            }
            if d.samples.end > range.start {
                flags[k].push(flag.clone());
            }
        }
    };
    for &i in &timeline.non_monotonic {
        mark(i..i + 1, &QcFlag::NonMonotonicEt);
    }
    for &i in &timeline.duplicated {
        mark(i..i + 1, &QcFlag::DuplicatedEt);
    }
    for r in pressure_dropouts {
        mark(r.clone(), &QcFlag::ZeroPressure);
    }
    let min_zero = timeline.samples(cfg.qc.zero_min_s);
    for (name, x) in zero_checked(signals) {
        let set_point = matches!(name, "speed_kph" | "alpha_rad" | "gamma_rad" | "kappa");
        let live = || !set_point && is_live(x);
        let frac = cfg.qc.zeroed_neighbour_frac;
        // Slip forces and moments are legitimately 0 at standstill in noise-free files.
        let slip_force = !matches!(name, "fz_n" | "loaded_radius_m") && !name.starts_with("tread");
        let standstill = |r: &Range<usize>| {
            signals.speed_kph[r.clone()]
                .iter()
                .all(|v| v.abs() <= cfg.activity.rolling_min_kph)
        };
        for r in zeroed_stretches(x, min_zero, frac, live, &timeline.blocks) {
            if slip_force && !set_point && standstill(&r) {
                continue;
            }
            mark(r, &QcFlag::ZeroedChannel(name.to_string()));
        }
    }
    let min_sat = timeline.samples(cfg.qc.saturation_min_s);
    for (name, x) in saturation_checked(signals) {
        for r in saturated_stretches(x, min_sat) {
            mark(r, &QcFlag::SaturatedChannel(name.to_string()));
        }
    }
    for (k, d) in drafts.iter().enumerate() {
        if pressure_out_of_range(signals.pressure_kpa, d.samples.clone(), cfg) {
            flags[k].push(QcFlag::OutOfRange("pressure_kpa".to_string()));
        }
    }
    shape_flags(signals, timeline, drafts, cfg, &mut flags);
    for f in &mut flags {
        f.sort();
        f.dedup();
    }
    flags
}

/// True when the median pressure of `range` (dropouts to ~0 left out: they have their own flag)
/// lies outside the physical range of an inflation pressure.
fn pressure_out_of_range(p: &[f64], range: Range<usize>, cfg: &SegmentConfig) -> bool {
    let mut held: Vec<f64> = p[range]
        .iter()
        .copied()
        .filter(|v| *v > cfg.qc.zero_pressure_max_kpa)
        .collect();
    median_high(&mut held)
        .is_some_and(|m| !crate::physical::within(m, crate::physical::PRESSURE_KPA))
}

/// Channels checked for zeroed stretches (pressure has its own flag).
fn zero_checked<'a>(s: &RunSignals<'a>) -> Vec<(&'a str, &'a [f64])> {
    s.required()
        .into_iter()
        .filter(|(name, _)| !matches!(*name, "et_s" | "pressure_kpa"))
        .collect()
}

/// Channels checked for saturation: measured responses, not commanded set-points.
fn saturation_checked<'a>(s: &RunSignals<'a>) -> Vec<(&'a str, &'a [f64])> {
    let mut out: Vec<(&'a str, &'a [f64])> = vec![("fy_n", s.fy_n), ("fx_n", s.fx_n)];
    if let Some(t) = s.tread_temps {
        out.extend([
            ("tread_inner_c", t.inner_c),
            ("tread_centre_c", t.centre_c),
            ("tread_outer_c", t.outer_c),
        ]);
    }
    out.extend(s.extra.iter().copied());
    out
}

/// True when the channel carries sensor noise: outside exact zeros, consecutive samples repeat
/// in at most 20 % of steps. A noisy channel cannot sit at exactly 0 for a stretch by itself.
fn is_live(x: &[f64]) -> bool {
    let (mut steps, mut repeats) = (0usize, 0usize);
    for w in x
        .windows(2)
        .filter(|w| !is_exact_zero(w[0]) && !is_exact_zero(w[1]))
    {
        steps += 1;
        repeats += usize::from((w[1] - w[0]).abs() <= 0.0);
    }
    steps > 0 && (repeats as f64) <= SMOOTH_REPEAT_FRAC * steps as f64
}

/// Exact-zero stretches that are dropouts: every one in a `live` (noisy) channel; otherwise
/// those whose neighbours on both sides (the one side at a run end) exceed `frac` of the
/// channel's 95th percentile |x| (neighbours across an ET gap do not count): a signal that
/// drops to zero, not a quiet or noise-free channel
/// resting at zero (speed at a static hold, slip angle at a dwell, SL of a cornering run).
pub(crate) fn zeroed_stretches(
    x: &[f64],
    min_len: usize,
    frac: f64,
    live: impl FnOnce() -> bool,
    blocks: &[Range<usize>],
) -> Vec<Range<usize>> {
    let runs = zero_runs(x, min_len, is_exact_zero);
    if runs.is_empty() || live() {
        return runs;
    }
    // Every 7th sample is plenty for a threshold (and keeps this pass cheap on long runs).
    let mut mags: Vec<f64> = x.iter().step_by(7).map(|v| v.abs()).collect();
    let k = (mags.len() * 95 / 100).min(mags.len() - 1);
    let (_, p95, _) = mags.select_nth_unstable_by(k, f64::total_cmp);
    let floor = frac * *p95;
    if floor <= 0.0 {
        return Vec::new();
    }
    let side = |r: Range<usize>| {
        let mut v: Vec<f64> = x[r].iter().map(|v| v.abs()).collect();
        median_high(&mut v).unwrap_or(0.0)
    };
    let block_of = |i: usize| {
        let k = blocks.partition_point(|b| b.end <= i);
        blocks.get(k).cloned().unwrap_or(0..x.len())
    };
    runs.into_iter()
        .filter(|r| {
            // Neighbours across an ET gap (a cut dwell) say nothing about this stretch.
            let (first, last) = (block_of(r.start), block_of(r.end - 1));
            let left = (r.start > first.start)
                .then(|| side(r.start.saturating_sub(NEIGHBOURS).max(first.start)..r.start));
            let right = (r.end < last.end).then(|| side(r.end..(r.end + NEIGHBOURS).min(last.end)));
            match (left, right) {
                (Some(l), Some(r)) => l.min(r) > floor,
                (Some(one), None) | (None, Some(one)) => one > floor,
                (None, None) => false,
            }
        })
        .collect()
}

/// Stretches of at least `min_len` samples exactly at the channel's run maximum or minimum.
/// Only for channels that are live sample to sample (noise): a smooth or coarse channel (exact
/// repeats in over 20 % of steps) naturally lingers at its extreme, and a zero extreme is the
/// zeroed-channel check's business.
fn saturated_stretches(x: &[f64], min_len: usize) -> Vec<Range<usize>> {
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if hi <= lo {
        return Vec::new();
    }
    let pinned_count = x.iter().filter(|&&v| v >= hi || v <= lo).count();
    if pinned_count < min_len {
        return Vec::new();
    }
    let at_extreme = |v: f64| {
        let near = |e: f64| !is_exact_zero(e) && (v - e).abs() <= 1e-9 * e.abs().max(1.0);
        near(hi) || near(lo)
    };
    let (mut steps, mut repeats) = (0usize, 0usize);
    let mut runs = Vec::new();
    let mut start: Option<usize> = None;
    for (i, &v) in x.iter().enumerate() {
        if i > 0 && v > lo && v < hi && x[i - 1] > lo && x[i - 1] < hi {
            steps += 1;
            repeats += usize::from((v - x[i - 1]).abs() <= 0.0);
        }
        let pinned = at_extreme(v) && start.is_none_or(|s| (x[s] - v).abs() <= 0.0);
        match (pinned, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                if i - s >= min_len {
                    runs.push(s..i);
                }
                start = at_extreme(v).then_some(i);
            }
            _ => {}
        }
    }
    if let Some(s) = start
        && x.len() - s >= min_len
    {
        runs.push(s..x.len());
    }
    if repeats as f64 > SMOOTH_REPEAT_FRAC * steps as f64 {
        return Vec::new();
    }
    runs
}

fn is_sweep(kind: SegmentKind) -> bool {
    matches!(
        kind,
        SegmentKind::ColdToWarm
            | SegmentKind::Conditioning
            | SegmentKind::Cornering
            | SegmentKind::DriveBrake
            | SegmentKind::Combined
            | SegmentKind::SpeedSweep
    )
}

fn holds_load(kind: SegmentKind) -> bool {
    !matches!(
        kind,
        SegmentKind::Other | SegmentKind::SpringRateStatic | SegmentKind::SpringRateDynamic
    )
}

/// `too_short` and `load_drift`.
fn shape_flags(
    signals: &RunSignals,
    timeline: &Timeline,
    drafts: &[Draft],
    cfg: &SegmentConfig,
    flags: &mut [Vec<QcFlag>],
) {
    let q = &cfg.qc;
    let min_len = timeline.samples(q.too_short_min_s);
    let typical = |kind: SegmentKind| {
        let mut lens: Vec<f64> = drafts
            .iter()
            .filter(|d| d.kind == kind)
            .map(|d| d.samples.len() as f64)
            .collect();
        median_high(&mut lens).unwrap_or(0.0)
    };
    for (d, f) in drafts.iter().zip(flags.iter_mut()) {
        if d.kind == SegmentKind::Other {
            continue;
        }
        let n = d.samples.len();
        let short = n < min_len
            || (is_sweep(d.kind)
                && (d.parts < 2 || (n as f64) < q.too_short_frac * typical(d.kind)));
        if short {
            f.push(QcFlag::TooShort);
        }
        if holds_load(d.kind) {
            let (drift, mean) = trend(&low_force_load(signals, d.samples.clone()));
            if drift.abs() > q.load_drift.at(mean) {
                f.push(QcFlag::LoadDrift);
            }
        }
    }
}

/// FZ over a segment with the samples of high tire force set to exact zero (skipped by
/// [`trend`]): load control wanders with the force, so the baseline is read where the force is
/// low (|FX| + |FY| within a quarter of its segment maximum), e.g. at every zero crossing of a
/// sweep. Falls back to every sample when fewer than 10 qualify.
fn low_force_load(signals: &RunSignals, r: Range<usize>) -> Vec<f64> {
    let force: Vec<f64> = r
        .clone()
        .map(|i| signals.fx_n[i].abs() + signals.fy_n[i].abs())
        .collect();
    let limit = 0.25 * force.iter().cloned().fold(0.0, f64::max);
    let fz = &signals.fz_n[r];
    if force.iter().filter(|f| **f <= limit).count() < 10 {
        return fz.to_vec();
    }
    fz.iter()
        .zip(&force)
        .map(|(z, f)| if *f <= limit { *z } else { 0.0 })
        .collect()
}

/// Least-squares change across the slice (slope times length) and the mean, exact zeros skipped.
fn trend(x: &[f64]) -> (f64, f64) {
    let pts: Vec<(f64, f64)> = x
        .iter()
        .enumerate()
        .filter(|(_, v)| !is_exact_zero(**v))
        .map(|(i, v)| (i as f64, *v))
        .collect();
    let n = pts.len() as f64;
    if pts.len() < 3 {
        return (0.0, pts.first().map_or(0.0, |p| p.1));
    }
    let (mt, mx) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), (t, v)| (a + t / n, b + v / n));
    let (sxy, sxx) = pts.iter().fold((0.0, 0.0), |(a, b), (t, v)| {
        (a + (t - mt) * (v - mx), b + (t - mt) * (t - mt))
    });
    let span = pts[pts.len() - 1].0 - pts[0].0;
    ((sxy / sxx) * span, mx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zeros_inside_a_live_signal_are_flagged_zeros_at_rest_are_not() {
        let mut fy: Vec<f64> = (0..200).map(|i| 1000.0 * (i as f64 * 0.05).sin()).collect();
        for v in &mut fy[50..80] {
            *v = 0.0;
        }
        assert_eq!(zeroed_stretches(&fy, 10, 0.05, || false, &[]), vec![50..80]);
        let mut v: Vec<f64> = (0..100).map(|i| 40.0 * (1.0 - i as f64 / 100.0)).collect();
        v.extend(std::iter::repeat_n(0.0, 100));
        assert!(
            zeroed_stretches(&v, 10, 0.05, || false, &[]).is_empty(),
            "speed at a static hold"
        );
        let quiet_mz: Vec<f64> = (0..200)
            .map(|i| {
                if (60..90).contains(&i) {
                    0.0
                } else {
                    0.5 + 0.13 * ((i * 7) % 5) as f64
                }
            })
            .collect();
        assert!(is_live(&quiet_mz));
        assert_eq!(
            zeroed_stretches(&quiet_mz, 10, 0.5, || true, &[]),
            vec![60..90],
            "small but noisy"
        );
    }

    #[test]
    fn a_clipped_channel_is_saturated() {
        let noisy: Vec<f64> = (0..100)
            .map(|i| 40.0 + i as f64 * 0.3 + if i % 2 == 0 { 0.05 } else { -0.05 })
            .collect();
        let x: Vec<f64> = noisy.iter().map(|v| v.min(60.0)).collect();
        assert_eq!(saturated_stretches(&x, 10), vec![67..100]);
        assert!(saturated_stretches(&[5.0; 50], 10).is_empty());
        let smooth: Vec<f64> = (0..100)
            .map(|i| (40.0 + (i as f64 * 0.03).sin() * 5.0).round())
            .collect();
        assert!(
            saturated_stretches(&smooth, 10).is_empty(),
            "a slow peak is not clipping"
        );
    }

    #[test]
    fn trend_measures_drift() {
        let x: Vec<f64> = (0..101).map(|i| 1000.0 + i as f64).collect();
        let (drift, mean) = trend(&x);
        assert!((drift - 100.0).abs() < 1e-6 && (mean - 1050.0).abs() < 1e-6);
    }
}
