//! Pass 3, sweep detection: prepared channels -> candidate segments ([`Detection`]s) with what
//! moves in them, before any judgement of their role in the test plan.
//!
//! In: [`Prepared`] channels and the gap-free blocks. Out: sorted, non-overlapping detections:
//! slip-angle sweep cycles, longitudinal-slip sweep cycles, step steers, spring-rate staircases and
//! inclination sweeps. Everything not detected is left for `other`.
//!
//! How, per gap-free block:
//! 1. Slip activity: samples with SA or SL (relative to free rolling) away from zero or moving;
//!    quiet gaps
//!    shorter than `activity.quiet_min_s` are bridged (a sweep crossing zero), so an episode is
//!    one sweep, one block of back-to-back sweeps, or one step-steer sequence. Dwells are quiet.
//! 2. Each episode is cut into pieces where P, IA and V all hold a level (pass 2). Not FZ: under
//!    loose load control FZ swings by +-20 % within a sweep (every sample carries its measured
//!    load), and a load set-point changes between sweeps, where the cycles are cut anyway.
//! 3. Each piece is: an SL sweep (SL spans `sweep.sl_min_span`; cut further where the held SA
//!    changes, one set-point per sweep), else a step-steer sequence (SA mostly held at levels
//!    reached in under `step_steer.max_rise_s`), else an SA sweep (SA spans `sweep.sa_min_span_deg`),
//!    else nothing. Sweeps are cut into cycles (one positive and one negative big excursion each).
//! 4. Quiet stretches are searched for load staircases (spring rates) and wide IA ramps.
//!
//! Deliberately not here: naming the role of a sweep (cold-to-warm, conditioning, matrix): that
//! needs the whole run and is pass 4 (`classify.rs`).

use std::ops::Range;

use super::config::{SegmentConfig, Tolerance};
use super::gaps::Timeline;
use super::plateau::{LevelRun, held_pieces, held_runs, level_runs, linear_change};
use super::prepare::Prepared;
use crate::numerics::stats::median_high;

/// What moves in a detection.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) enum Motion {
    /// One cycle of a slip-angle sweep.
    SaSweep,
    /// One cycle of a longitudinal-slip sweep.
    SlSweep,
    /// One step of the slip angle to a held level.
    StepSteer,
    /// A load staircase at zero slip.
    LoadSteps,
    /// A wide inclination ramp at zero slip.
    IaRamp,
}

/// A candidate segment.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Detection {
    /// Absolute sample range.
    pub samples: Range<usize>,
    pub motion: Motion,
    /// Big excursions in a sweep cycle (2 = complete), steps in a staircase, 1 otherwise.
    pub parts: usize,
    /// Median rate of the moving variable while it moves (deg/s, 1/s), if it has one.
    pub rate: Option<f64>,
    /// (min, max) of the moving variable (deg, -, N).
    pub span: (f64, f64),
    /// The held slip angle of a step, deg.
    pub held_sa_deg: Option<f64>,
}

/// Run every detector over every block; the result is sorted and non-overlapping.
pub(crate) fn detect(prep: &Prepared, timeline: &Timeline, cfg: &SegmentConfig) -> Vec<Detection> {
    let mut out = Vec::new();
    for block in &timeline.blocks {
        let episodes = activity_episodes(prep, block.clone(), timeline, cfg);
        for episode in &episodes {
            out.extend(detect_in_episode(prep, episode.clone(), timeline, cfg));
        }
        for quiet in complement(block.clone(), &episodes) {
            out.extend(detect_in_quiet(prep, quiet, timeline, cfg));
        }
    }
    out.sort_by_key(|d| (d.samples.start, d.samples.end));
    let mut kept: Vec<Detection> = Vec::with_capacity(out.len());
    for d in out {
        if kept.last().is_none_or(|k| k.samples.end <= d.samples.start) {
            kept.push(d);
        }
    }
    kept
}

/// Episodes of slip activity inside `block` (absolute ranges).
fn activity_episodes(
    prep: &Prepared,
    block: Range<usize>,
    timeline: &Timeline,
    cfg: &SegmentConfig,
) -> Vec<Range<usize>> {
    let a = &cfg.activity;
    let active = |i: usize| {
        let sa = prep.sa_deg[i].abs() > a.sa_active_deg
            || prep.sa_rate[i].abs() > a.sa_rate_active_deg_s;
        let sl = prep.has_sl
            && prep.v_kph[i] > a.rolling_min_kph
            && (prep.sl[i].abs() > a.sl_active || prep.sl_rate[i].abs() > a.sl_rate_active_per_s);
        sa || sl
    };
    let raw = mask_runs(block, active);
    let quiet_min = timeline.samples(a.quiet_min_s);
    let mut merged: Vec<Range<usize>> = Vec::new();
    for r in raw {
        match merged.last_mut() {
            Some(last) if r.start - last.end < quiet_min => last.end = r.end,
            _ => merged.push(r),
        }
    }
    let active_min = timeline.samples(a.active_min_s);
    merged.retain(|r| r.len() >= active_min);
    merged
}

/// Maximal runs of `range` where `pred` holds.
fn mask_runs(range: Range<usize>, pred: impl Fn(usize) -> bool) -> Vec<Range<usize>> {
    let mut runs = Vec::new();
    let mut start = None;
    for i in range.clone() {
        match (pred(i), start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                runs.push(s..i);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        runs.push(s..range.end);
    }
    runs
}

/// The parts of `block` outside the sorted, disjoint `inside` ranges.
fn complement(block: Range<usize>, inside: &[Range<usize>]) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut cursor = block.start;
    for r in inside {
        if r.start > cursor {
            out.push(cursor..r.start);
        }
        cursor = r.end;
    }
    if cursor < block.end {
        out.push(cursor..block.end);
    }
    out
}

/// Offset relative runs to absolute ranges.
fn shift(r: Range<usize>, by: usize) -> Range<usize> {
    r.start + by..r.end + by
}

/// Set-point pieces of an episode, then what moves in each.
fn detect_in_episode(
    prep: &Prepared,
    episode: Range<usize>,
    timeline: &Timeline,
    cfg: &SegmentConfig,
) -> Vec<Detection> {
    let p = &cfg.plateau;
    let hold = timeline.samples(p.hold_min_s);
    let blip = timeline.samples(p.blip_max_s);
    let e = episode.clone();
    let runs: Vec<Vec<LevelRun>> = [
        (&prep.p_kpa, p.pressure_kpa),
        (&prep.ia_deg, p.ia_deg),
        (&prep.v_kph, p.speed_kph),
    ]
    .into_iter()
    .map(|(x, tol)| held_runs(&x[e.clone()], tol, hold, blip))
    .collect();
    let mut out = Vec::new();
    for piece in held_pieces(e.len(), &runs, hold) {
        out.extend(detect_in_piece(prep, shift(piece, e.start), timeline, cfg));
    }
    out
}

fn span_of(x: &[f64]) -> (f64, f64) {
    x.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

/// One set-point piece of an episode: SL sweep, step steers, SA sweep or nothing.
fn detect_in_piece(
    prep: &Prepared,
    piece: Range<usize>,
    timeline: &Timeline,
    cfg: &SegmentConfig,
) -> Vec<Detection> {
    let s = &cfg.sweep;
    let (sl_lo, sl_hi) = span_of(&prep.sl[piece.clone()]);
    if prep.has_sl && sl_hi - sl_lo >= s.sl_min_span {
        return sl_sweeps(prep, piece, timeline, cfg);
    }
    if let Some(steps) = step_steers(prep, piece.clone(), timeline, cfg) {
        return steps;
    }
    let (lo, hi) = span_of(&prep.sa_deg[piece.clone()]);
    if hi - lo >= s.sa_min_span_deg {
        let thr = s.sa_peak_min_deg.max(s.peak_frac * lo.abs().max(hi.abs()));
        return cycles(
            &prep.sa_deg,
            &prep.sa_rate,
            piece,
            thr,
            s.sa_rate_floor_deg_s,
            Motion::SaSweep,
        );
    }
    Vec::new()
}

/// SL sweeps of a piece, one set-point (held SA) at a time.
fn sl_sweeps(
    prep: &Prepared,
    piece: Range<usize>,
    timeline: &Timeline,
    cfg: &SegmentConfig,
) -> Vec<Detection> {
    let s = &cfg.sweep;
    let hold = timeline.samples(cfg.plateau.hold_min_s);
    let blip = timeline.samples(cfg.plateau.blip_max_s);
    let sa_tol = Tolerance::fixed(s.combined_sa_tol_deg);
    let mut out = Vec::new();
    for run in held_runs(&prep.sa_deg[piece.clone()], sa_tol, hold, blip) {
        let sub = shift(run.range(), piece.start);
        let (lo, hi) = span_of(&prep.sl[sub.clone()]);
        if hi - lo < s.sl_min_span {
            continue;
        }
        let thr = s.sl_peak_min.max(s.peak_frac * lo.abs().max(hi.abs()));
        out.extend(cycles(
            &prep.sl,
            &prep.sl_rate,
            sub,
            thr,
            s.sl_rate_floor_per_s,
            Motion::SlSweep,
        ));
    }
    out
}

/// Cut `range` of the swept variable `x` into cycles (see [`cycle_bounds`]) and describe each.
fn cycles(
    x: &[f64],
    rate: &[f64],
    range: Range<usize>,
    thr: f64,
    rate_floor: f64,
    motion: Motion,
) -> Vec<Detection> {
    cycle_bounds(&x[range.clone()], thr, motion == Motion::SlSweep)
        .into_iter()
        .map(|(r, parts)| {
            let r = shift(r, range.start);
            let mut moving: Vec<f64> = rate[r.clone()]
                .iter()
                .map(|v| v.abs())
                .filter(|v| *v > rate_floor)
                .collect();
            Detection {
                span: span_of(&x[r.clone()]),
                rate: median_high(&mut moving),
                samples: r,
                motion,
                parts,
                held_sa_deg: None,
            }
        })
        .collect()
}

/// Cycles of an oscillating signal: the big excursions (|x| > thr) in order; a cycle holds one
/// positive and one negative excursion, cut at the sample nearest zero between cycles. With
/// `three_is_one` (the SL sweep shape +0.2 -> -0.2 -> +0.2), a third excursion of the first's
/// sign joins the cycle when the signal then returns to zero (the next excursion has the same
/// sign again, or there is none). Returns relative ranges covering `x` and the number of
/// excursions in each (1 = incomplete). A trailing lone excursion after a complete cycle joins
/// it (a continuous train ends with a half excursion back to zero).
pub(crate) fn cycle_bounds(x: &[f64], thr: f64, three_is_one: bool) -> Vec<(Range<usize>, usize)> {
    let excursions = excursions(x, thr);
    if excursions.is_empty() {
        return vec![(0..x.len(), 0)];
    }
    let mut groups: Vec<Vec<(usize, usize, i8)>> = Vec::new();
    for (k, &e) in excursions.iter().enumerate() {
        let next_sign = excursions.get(k + 1).map(|n| n.2);
        match groups.last_mut() {
            Some(g) if g.len() == 1 && g[0].2 != e.2 => g.push(e),
            Some(g)
                if three_is_one
                    && g.len() == 2
                    && g[0].2 == e.2
                    && next_sign.is_none_or(|s| s == e.2) =>
            {
                g.push(e)
            }
            _ => groups.push(vec![e]),
        }
    }
    // The half excursion a continuous sweep train ends with (..., -12, +12 -> 0) finishes the
    // last cycle; a lone excursion with nothing before it stays an incomplete cycle.
    if groups.len() >= 2
        && groups[groups.len() - 1].len() == 1
        && groups[groups.len() - 2].len() >= 2
    {
        let tail = groups.pop().unwrap_or_default();
        if let Some(last) = groups.last_mut() {
            last.extend(tail);
        }
    }
    let mut out = Vec::with_capacity(groups.len());
    let mut start = 0;
    for pair in groups.windows(2) {
        let end_prev = pair[0].last().map_or(start, |e| e.1);
        let start_next = pair[1][0].0;
        let cut = (end_prev..start_next)
            .min_by(|&a, &b| x[a].abs().total_cmp(&x[b].abs()))
            .unwrap_or(start_next);
        out.push((start..cut, pair[0].len()));
        start = cut;
    }
    out.push((start..x.len(), groups.last().map_or(0, Vec::len)));
    out
}

/// Maximal stretches with |x| > thr: (start, end, sign).
fn excursions(x: &[f64], thr: f64) -> Vec<(usize, usize, i8)> {
    let sign = |v: f64| -> i8 {
        if v > thr {
            1
        } else if v < -thr {
            -1
        } else {
            0
        }
    };
    let mut out = Vec::new();
    let mut current: Option<(usize, i8)> = None;
    for (i, &v) in x.iter().enumerate() {
        let s = sign(v);
        match current {
            Some((start, cs)) if cs != s => {
                out.push((start, i, cs));
                current = (s != 0).then_some((i, s));
            }
            None if s != 0 => current = Some((i, s)),
            _ => {}
        }
    }
    if let Some((start, cs)) = current {
        out.push((start, x.len(), cs));
    }
    out
}

/// Step steers of a piece, when SA mostly holds at levels it jumped to; `None` otherwise.
fn step_steers(
    prep: &Prepared,
    piece: Range<usize>,
    timeline: &Timeline,
    cfg: &SegmentConfig,
) -> Option<Vec<Detection>> {
    let c = &cfg.step_steer;
    let sa = &prep.sa_deg[piece.clone()];
    let hold = timeline.samples(c.hold_min_s);
    let max_rise = timeline.samples(c.max_rise_s);
    let mut steps = Vec::new();
    let mut prev_end = 0;
    for run in held_runs(sa, Tolerance::fixed(c.hold_tol_deg), hold, 0) {
        let rise = run.start - prev_end;
        if run.mean.abs() >= c.min_level_deg && rise <= max_rise {
            steps.push((prev_end..run.end, run));
        }
        prev_end = run.end;
    }
    let held: usize = steps.iter().map(|(_, r)| r.len()).sum();
    if steps.is_empty() || (held as f64) < c.min_hold_fraction * sa.len() as f64 {
        return None;
    }
    Some(
        steps
            .into_iter()
            .map(|(r, run)| {
                let r = shift(r, piece.start);
                Detection {
                    span: span_of(&prep.sa_deg[r.clone()]),
                    samples: r,
                    motion: Motion::StepSteer,
                    parts: 1,
                    rate: None,
                    held_sa_deg: Some(run.mean),
                }
            })
            .collect(),
    )
}

/// Spring-rate staircases and IA ramps in a quiet stretch.
fn detect_in_quiet(
    prep: &Prepared,
    quiet: Range<usize>,
    timeline: &Timeline,
    cfg: &SegmentConfig,
) -> Vec<Detection> {
    let mut out = load_staircases(prep, quiet.clone(), timeline, cfg);
    for ramp in ia_ramps(prep, quiet, timeline, cfg) {
        if out
            .iter()
            .all(|d| d.samples.end <= ramp.samples.start || ramp.samples.end <= d.samples.start)
        {
            out.push(ramp);
        }
    }
    out
}

/// Chains of short load steps at one IA and speed. A step is a flat level run: the least-squares
/// change over its middle 60 % is within the step tolerance (a level run may start on the
/// tail of the ramp into it, but a slow load ramp cut into bands keeps rising in the middle);
/// consecutive flat runs closer than `step_min_n` are one step.
fn load_staircases(
    prep: &Prepared,
    quiet: Range<usize>,
    timeline: &Timeline,
    cfg: &SegmentConfig,
) -> Vec<Detection> {
    let c = &cfg.spring_rate;
    let (step_min, step_max) = (
        timeline.samples(c.step_min_s),
        timeline.samples(c.step_max_s),
    );
    let transition_max = timeline.samples(c.transition_max_s);
    let mean = |x: &[f64], r: Range<usize>| x[r.clone()].iter().sum::<f64>() / r.len() as f64;
    let mut levels: Vec<LevelRun> = Vec::new();
    for r in level_runs(&prep.fz_n[quiet.clone()], c.fz_n) {
        let flat = || {
            let x = &prep.fz_n[shift(r.range(), quiet.start)];
            let edge = x.len() / 5;
            linear_change(&x[edge..x.len() - edge]).abs() <= c.fz_n.at(r.mean)
        };
        if r.len() < step_min || r.mean < c.loaded_min_n || !flat() {
            continue;
        }
        match levels.last_mut() {
            // A step the greedy band cut in two (its ramp-in tail and its level): one step.
            Some(last)
                if r.start - last.end <= transition_max
                    && (r.mean - last.mean).abs() < c.step_min_n =>
            {
                let (a, b) = (last.len() as f64, r.len() as f64);
                last.mean = (last.mean * a + r.mean * b) / (a + b);
                last.end = r.end;
            }
            _ => levels.push(r),
        }
    }
    let steps: Vec<(Range<usize>, f64, f64, f64)> = levels
        .into_iter()
        .filter(|r| r.len() <= step_max)
        .map(|r| {
            let abs = shift(r.range(), quiet.start);
            let ia = mean(&prep.ia_deg, abs.clone());
            let v = mean(&prep.v_kph, abs.clone());
            (abs, r.mean, ia, v)
        })
        .collect();
    let same_chain = |a: &(Range<usize>, f64, f64, f64), b: &(Range<usize>, f64, f64, f64)| {
        b.0.start - a.0.end <= transition_max
            && (b.1 - a.1).abs() >= c.step_min_n
            && (b.2 - a.2).abs() <= cfg.plateau.ia_deg.at(a.2)
            && (b.3 - a.3).abs() <= cfg.plateau.speed_kph.at(a.3)
    };
    let mut out = Vec::new();
    let mut chain: Vec<&(Range<usize>, f64, f64, f64)> = Vec::new();
    let flush = |chain: &mut Vec<&(Range<usize>, f64, f64, f64)>, out: &mut Vec<Detection>| {
        if chain.len() >= c.min_steps {
            let r = chain[0].0.start..chain[chain.len() - 1].0.end;
            out.push(Detection {
                span: span_of(&prep.fz_n[r.clone()]),
                samples: r,
                motion: Motion::LoadSteps,
                parts: chain.len(),
                rate: None,
                held_sa_deg: None,
            });
        }
        chain.clear();
    };
    for step in &steps {
        if chain.last().is_some_and(|last| !same_chain(last, step)) {
            flush(&mut chain, &mut out);
        }
        chain.push(step);
    }
    flush(&mut chain, &mut out);
    out
}

/// Monotonic IA ramps spanning at least `ia_sweep.min_span_deg` over at least
/// `ia_sweep.min_duration_s`, rolling, loaded and at a held load.
fn ia_ramps(
    prep: &Prepared,
    quiet: Range<usize>,
    timeline: &Timeline,
    cfg: &SegmentConfig,
) -> Vec<Detection> {
    let c = &cfg.ia_sweep;
    let pause_max = timeline.samples(c.pause_max_s);
    let min_len = timeline.samples(c.min_duration_s);
    let mut out = Vec::new();
    for sign in [1.0, -1.0] {
        let raw = mask_runs(quiet.clone(), |i| sign * prep.ia_rate[i] > c.rate_min_deg_s);
        let mut merged: Vec<Range<usize>> = Vec::new();
        for r in raw {
            match merged.last_mut() {
                Some(last) if r.start - last.end <= pause_max => last.end = r.end,
                _ => merged.push(r),
            }
        }
        for r in merged {
            let ia = &prep.ia_deg[r.clone()];
            let (lo, hi) = span_of(ia);
            let n = r.len() as f64;
            let v = prep.v_kph[r.clone()].iter().sum::<f64>() / n;
            let fz = prep.fz_n[r.clone()].iter().sum::<f64>() / n;
            let (fz_lo, fz_hi) = span_of(&prep.fz_n[r.clone()]);
            if hi - lo >= c.min_span_deg
                && r.len() >= min_len
                && v > cfg.activity.rolling_min_kph
                && fz >= c.loaded_min_n
                && fz_hi - fz_lo <= 2.0 * cfg.plateau.fz_n.at(fz)
            {
                let mut moving: Vec<f64> =
                    prep.ia_rate[r.clone()].iter().map(|v| v.abs()).collect();
                out.push(Detection {
                    span: (lo, hi),
                    rate: median_high(&mut moving),
                    samples: r,
                    motion: Motion::IaRamp,
                    parts: 1,
                    held_sa_deg: None,
                });
            }
        }
    }
    out.sort_by_key(|d| d.samples.start);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle(points: &[f64], per_unit: usize) -> Vec<f64> {
        let mut x = Vec::new();
        for w in points.windows(2) {
            let n = ((w[1] - w[0]).abs() * per_unit as f64).round().max(1.0) as usize;
            for k in 0..n {
                x.push(w[0] + (w[1] - w[0]) * k as f64 / n as f64);
            }
        }
        x.push(*points.last().unwrap());
        x
    }

    #[test]
    fn a_round4_sweep_is_one_cycle() {
        let x = triangle(&[0.0, -4.0, 12.0, -12.0, 3.0, 0.0], 10);
        let c = cycle_bounds(&x, 6.0, false);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0], (0..x.len(), 2));
    }

    #[test]
    fn back_to_back_sweeps_are_cut_near_zero() {
        let mut pts = vec![0.0];
        for _ in 0..8 {
            pts.extend([12.0, -12.0, 0.0]);
        }
        let x = triangle(&pts, 10);
        let c = cycle_bounds(&x, 6.0, false);
        assert_eq!(c.len(), 8);
        assert!(c.iter().all(|(_, parts)| *parts == 2));
        for (r, _) in &c[1..] {
            assert!(x[r.start].abs() < 0.2, "cut at {}", x[r.start]);
        }
        let covered: usize = c.iter().map(|(r, _)| r.len()).sum();
        assert_eq!(covered, x.len());
    }

    #[test]
    fn sl_up_down_up_is_one_cycle_and_a_lone_excursion_is_incomplete() {
        let x = triangle(&[0.0, 0.2, -0.2, 0.2, 0.0], 500);
        assert_eq!(cycle_bounds(&x, 0.1, true).len(), 1);
        let tail = triangle(&[0.0, 12.0, -12.0, 0.0, 12.0, 0.0], 10);
        assert_eq!(
            cycle_bounds(&tail, 6.0, false).len(),
            1,
            "a tail joins its cycle"
        );
        let lone = triangle(&[0.0, 12.0, 0.0], 10);
        assert_eq!(cycle_bounds(&lone, 6.0, false), vec![(0..lone.len(), 1)]);
    }

    #[test]
    fn back_to_back_sl_sweeps_are_two_cycles() {
        let x = triangle(&[0.0, 0.2, -0.2, 0.2, 0.0, 0.2, -0.2, 0.2, 0.0], 500);
        let c = cycle_bounds(&x, 0.1, true);
        assert_eq!(c.iter().map(|(_, p)| *p).collect::<Vec<_>>(), vec![3, 3]);
    }

    #[test]
    fn complement_fills_between_episodes() {
        assert_eq!(complement(0..10, &[2..4, 6..7]), vec![0..2, 4..6, 7..10]);
        let all = std::iter::once(0..10).collect::<Vec<_>>();
        assert!(complement(0..10, &all).is_empty());
    }
}
