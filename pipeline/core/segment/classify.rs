//! Pass 4, classification: detections of the whole run -> a [`SegmentKind`] each, the run's main
//! speed and the run-level [`RunClass`].
//!
//! In: the detections of pass 3 in time order, their binned levels, optional centre tread
//! temperature, [`ClassifyConfig`]. Out: one kind per detection.
//!
//! The rules (no schedule needed; all thresholds in `[segment.classify]`):
//! - A *train* is a run of consecutive sweep cycles of one variable at one set-point (same
//!   nominal P, IA, FZ, V, and held SA for SL sweeps) with similar span and slip rate; any other
//!   detection (spring rate, step steer, IA sweep) in between ends a train.
//! - *Cold-to-warm*: the first train of at least `cold_to_warm_min_cycles` SA cycles swept at
//!   `cold_to_warm_min_rate_deg_s` or faster, whose centre tread (when given) warms by
//!   `cold_to_warm_min_temp_rise_c` from its first to its last cycle, if it comes before the matrix.
//!   At most one per run: a cold tire happens once.
//! - The *matrix train length* L is the most common train length among the other trains (1 in
//!   every TTC plan: each set-point once; when fewer than 3 trains, L = 1). The *matrix variable*
//!   is the one with most cycles in trains of length <= L; its *matrix rate* is their median
//!   slip rate. A train is *regular* when it has <= L cycles at a rate within `rate_tol_frac` of
//!   the matrix rate of its variable.
//! - The matrix starts at the first regular train of the matrix variable. *Conditioning*: every
//!   other train before that, and later trains that are repeated (> L cycles) at an off-matrix
//!   rate (a fast warm-up block between pressures). Without any regular train the run has no
//!   matrix and every train but the cold-to-warm one is conditioning (a warm-up run).
//! - Everything else is data: SA cycles `cornering`, SL cycles `drive_brake` at held SA 0 and
//!   `combined` otherwise; a data cycle at a nominal speed other than the main speed is
//!   `speed_sweep`. The main speed is `main_speed_kph` when any data cycle runs at it, else the
//!   speed of most data cycles.
//! - The cycles of one cold-to-warm or conditioning train that follow each other without a gap
//!   are then merged into one segment ([`merge_warm_up_blocks`]).
//! - Step steers, spring-rate staircases (static below `spring_rate.static_max_kph`) and IA
//!   ramps keep the kind their detector gave.
//!
//! Deliberately not here: binning and QC (passes 5 and 6).

use std::collections::BTreeMap;

use super::config::SegmentConfig;
use super::output::{NominalLevels, RunClass, SegmentKind, SweepVariable};
use super::sweep::{Detection, Motion};
use crate::numerics::stats::median_high;

/// A detection's classification.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(crate) struct Classified {
    pub kind: SegmentKind,
    pub sweep: Option<SweepVariable>,
    /// The train a cold-to-warm or conditioning cycle belongs to (blocks merge per train).
    pub train: Option<usize>,
}

/// The set-point key of a sweep cycle.
type Key = (
    SweepVariable,
    Option<i64>,
    Option<i64>,
    Option<i64>,
    Option<i64>,
    Option<i64>,
);

fn key(d: &Detection, bins: &NominalLevels) -> Option<Key> {
    let var = match d.motion {
        Motion::SaSweep => SweepVariable::SlipAngle,
        Motion::SlSweep => SweepVariable::LongitudinalSlip,
        _ => return None,
    };
    let alpha = (var == SweepVariable::LongitudinalSlip)
        .then_some(bins.alpha_deg)
        .flatten();
    Some((
        var,
        bins.pressure_kpa,
        bins.ia_cdeg,
        bins.fz_n,
        bins.speed_kph,
        alpha,
    ))
}

struct Train {
    key: Key,
    members: Vec<usize>,
    rate: f64,
}

fn ratio_ok(a: f64, b: f64, tol: f64) -> bool {
    b.abs() > 0.0 && ((a / b) - 1.0).abs() <= tol
}

/// Group consecutive sweep cycles into trains.
fn trains(dets: &[Detection], bins: &[NominalLevels], cfg: &SegmentConfig) -> Vec<Train> {
    let c = &cfg.classify;
    let mut out: Vec<Train> = Vec::new();
    let mut open = false;
    for (i, d) in dets.iter().enumerate() {
        let Some(k) = key(d, &bins[i]) else {
            open = false;
            continue;
        };
        let rate = d.rate.unwrap_or(0.0);
        let width = d.span.1 - d.span.0;
        let joins = open
            && out.last().is_some_and(|t| {
                let last = &dets[*t.members.last().unwrap_or(&i)];
                t.key == k
                    && ratio_ok(rate, last.rate.unwrap_or(0.0), c.rate_tol_frac)
                    && ratio_ok(width, last.span.1 - last.span.0, c.span_tol_frac)
            });
        if joins {
            if let Some(t) = out.last_mut() {
                t.members.push(i);
            }
        } else {
            out.push(Train {
                key: k,
                members: vec![i],
                rate,
            });
        }
        open = true;
    }
    for t in &mut out {
        let mut rates: Vec<f64> = t.members.iter().filter_map(|&i| dets[i].rate).collect();
        t.rate = median_high(&mut rates).unwrap_or(0.0);
    }
    out
}

/// Mean of `x` over a detection's samples.
fn mean_over(x: &[f64], d: &Detection) -> f64 {
    let r = d.samples.clone();
    x[r.clone()].iter().sum::<f64>() / r.len().max(1) as f64
}

/// Classify every detection.
pub(crate) fn classify(
    dets: &[Detection],
    bins: &[NominalLevels],
    speed_means_kph: &[f64],
    centre_temp_c: Option<&[f64]>,
    main_speed_label: Option<i64>,
    cfg: &SegmentConfig,
) -> (Vec<Classified>, Option<i64>) {
    let c = &cfg.classify;
    let mut out: Vec<Classified> = dets
        .iter()
        .enumerate()
        .map(|(i, d)| Classified {
            kind: match d.motion {
                Motion::StepSteer => SegmentKind::StepSteer,
                Motion::IaRamp => SegmentKind::IaSweep,
                Motion::LoadSteps if speed_means_kph[i] <= cfg.spring_rate.static_max_kph => {
                    SegmentKind::SpringRateStatic
                }
                Motion::LoadSteps => SegmentKind::SpringRateDynamic,
                Motion::SaSweep | Motion::SlSweep => SegmentKind::Other,
            },
            sweep: Some(match d.motion {
                Motion::SaSweep | Motion::StepSteer => SweepVariable::SlipAngle,
                Motion::SlSweep => SweepVariable::LongitudinalSlip,
                Motion::LoadSteps => SweepVariable::Load,
                Motion::IaRamp => SweepVariable::Inclination,
            }),
            train: None,
        })
        .collect();

    let trains = trains(dets, bins, cfg);
    let warms = |t: &Train| match centre_temp_c {
        Some(temp) if c.cold_to_warm_min_temp_rise_c >= 0.0 => {
            let first = &dets[t.members[0]];
            let last = &dets[*t.members.last().unwrap_or(&t.members[0])];
            mean_over(temp, last) - mean_over(temp, first) >= c.cold_to_warm_min_temp_rise_c
        }
        _ => true,
    };
    let mut ctw = trains.iter().position(|t| {
        t.key.0 == SweepVariable::SlipAngle
            && t.members.len() >= c.cold_to_warm_min_cycles
            && t.rate >= c.cold_to_warm_min_rate_deg_s
            && warms(t)
    });

    let rest: Vec<usize> = (0..trains.len()).filter(|&k| Some(k) != ctw).collect();
    let matrix_len = matrix_train_length(&trains, &rest);
    let mut short_cycles: BTreeMap<SweepVariable, Vec<f64>> = BTreeMap::new();
    for &k in &rest {
        if trains[k].members.len() <= matrix_len {
            for &i in &trains[k].members {
                short_cycles
                    .entry(trains[k].key.0)
                    .or_default()
                    .push(dets[i].rate.unwrap_or(0.0));
            }
        }
    }
    let matrix_var = short_cycles
        .iter()
        .max_by(|a, b| a.1.len().cmp(&b.1.len()).then(b.0.cmp(a.0)))
        .map(|(v, _)| *v);
    let matrix_rate: BTreeMap<SweepVariable, f64> = short_cycles
        .into_iter()
        .filter_map(|(v, mut rates)| median_high(&mut rates).map(|m| (v, m)))
        .collect();
    let at_matrix_rate = |t: &Train| {
        matrix_rate
            .get(&t.key.0)
            .is_some_and(|m| ratio_ok(t.rate, *m, c.rate_tol_frac))
    };
    let regular = |t: &Train| t.members.len() <= matrix_len && at_matrix_rate(t);
    let matrix_start = rest
        .iter()
        .copied()
        .find(|&k| Some(trains[k].key.0) == matrix_var && regular(&trains[k]));
    if let (Some(w), Some(m)) = (ctw, matrix_start)
        && w > m
    {
        ctw = None;
    }

    for (k, t) in trains.iter().enumerate() {
        let before_matrix = matrix_start.is_none_or(|m| k < m);
        let kind = if Some(k) == ctw {
            SegmentKind::ColdToWarm
        } else if before_matrix || (t.members.len() > matrix_len && !at_matrix_rate(t)) {
            SegmentKind::Conditioning
        } else {
            match t.key.0 {
                SweepVariable::SlipAngle => SegmentKind::Cornering,
                _ if t.key.5 == Some(0) => SegmentKind::DriveBrake,
                _ => SegmentKind::Combined,
            }
        };
        let warm_up = matches!(kind, SegmentKind::ColdToWarm | SegmentKind::Conditioning);
        for &i in &t.members {
            out[i].kind = kind;
            out[i].train = warm_up.then_some(k);
        }
    }

    let main_speed = main_speed(&out, bins, main_speed_label);
    for (o, b) in out.iter_mut().zip(bins) {
        if o.kind.is_matrix() && b.speed_kph != main_speed {
            o.kind = SegmentKind::SpeedSweep;
        }
    }
    (out, main_speed)
}

/// Cold-to-warm and conditioning cycles of one train that follow each other without a gap
/// (adjacent samples, no ET gap between them: a "run" file's cut dwell separates procedures)
/// become one segment: a warm-up block is one procedure (the thesis keeps it as one structure,
/// the virtual machine's truth as one segment); the thermal stage splits it by zero crossings.
/// Each merged segment keeps the levels (`bins`) of its first cycle (one train, one key).
pub(crate) fn merge_warm_up_blocks(
    dets: Vec<Detection>,
    classes: Vec<Classified>,
    bins: Vec<NominalLevels>,
    blocks: &[std::ops::Range<usize>],
) -> (Vec<Detection>, Vec<Classified>, Vec<NominalLevels>) {
    let block_of = |i: usize| blocks.partition_point(|b| b.end <= i);
    let mut out_d: Vec<Detection> = Vec::with_capacity(dets.len());
    let mut out_c: Vec<Classified> = Vec::with_capacity(classes.len());
    let mut out_b: Vec<NominalLevels> = Vec::with_capacity(bins.len());
    let mut members = 1usize;
    for ((d, c), b) in dets.into_iter().zip(classes).zip(bins) {
        if let (Some(last_d), Some(last_c)) = (out_d.last_mut(), out_c.last())
            && c.train.is_some()
            && last_c.train == c.train
            && last_d.samples.end == d.samples.start
            && block_of(last_d.samples.start) == block_of(d.samples.start)
        {
            let (a, b) = (members as f64, 1.0);
            last_d.rate = match (last_d.rate, d.rate) {
                (Some(x), Some(y)) => Some((x * a + y * b) / (a + b)),
                (x, y) => x.or(y),
            };
            last_d.samples.end = d.samples.end;
            last_d.parts += d.parts;
            last_d.span = (last_d.span.0.min(d.span.0), last_d.span.1.max(d.span.1));
            members += 1;
            continue;
        }
        members = 1;
        out_d.push(d);
        out_c.push(c);
        out_b.push(b);
    }
    (out_d, out_c, out_b)
}

/// Most common train length among `rest` (ties to the shortest), 1 with fewer than 3 trains.
fn matrix_train_length(trains: &[Train], rest: &[usize]) -> usize {
    if rest.len() < 3 {
        return 1;
    }
    let mut counts: BTreeMap<usize, usize> = BTreeMap::new();
    for &k in rest {
        *counts.entry(trains[k].members.len()).or_default() += 1;
    }
    counts
        .iter()
        .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0)))
        .map_or(1, |(len, _)| *len)
}

/// The configured main speed (`main`: its label among the run's speed levels) if any data cycle
/// runs at it, else the most common data speed.
fn main_speed(out: &[Classified], bins: &[NominalLevels], main: Option<i64>) -> Option<i64> {
    let mut counts: BTreeMap<Option<i64>, usize> = BTreeMap::new();
    for (o, b) in out.iter().zip(bins) {
        if o.kind.is_matrix() {
            *counts.entry(b.speed_kph).or_default() += 1;
        }
    }
    if counts.is_empty() {
        return main;
    }
    if main.is_some() && counts.contains_key(&main) {
        return main;
    }
    counts
        .iter()
        .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0)))
        .and_then(|(speed, _)| *speed)
}

/// The run-level class from the segment counts.
pub(crate) fn run_class(counts: &BTreeMap<SegmentKind, usize>) -> RunClass {
    let n = |k: SegmentKind| counts.get(&k).copied().unwrap_or(0);
    let cornering = n(SegmentKind::Cornering);
    let longitudinal = n(SegmentKind::DriveBrake) + n(SegmentKind::Combined);
    let steps = n(SegmentKind::StepSteer);
    let warm = n(SegmentKind::ColdToWarm)
        + n(SegmentKind::Conditioning)
        + n(SegmentKind::SpringRateStatic)
        + n(SegmentKind::SpringRateDynamic);
    if steps > 0 && steps >= cornering + longitudinal {
        RunClass::Transient
    } else if longitudinal > 0 && longitudinal >= cornering {
        RunClass::DriveBrake
    } else if cornering > 0 {
        RunClass::Cornering
    } else if warm > 0 {
        RunClass::WarmUp
    } else {
        RunClass::Unknown
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sweep(start: usize, rate: f64, load: i64) -> (Detection, NominalLevels) {
        (
            Detection {
                samples: start..start + 100,
                motion: Motion::SaSweep,
                parts: 2,
                rate: Some(rate),
                span: (-12.0, 12.0),
                held_sa_deg: None,
            },
            NominalLevels {
                pressure_kpa: Some(83),
                ia_cdeg: Some(0),
                fz_n: Some(load),
                alpha_deg: None,
                speed_kph: Some(40),
            },
        )
    }

    fn kinds(plan: Vec<(Detection, NominalLevels)>) -> Vec<SegmentKind> {
        let (dets, bins): (Vec<_>, Vec<_>) = plan.into_iter().unzip();
        let speeds = vec![40.0; dets.len()];
        let (out, _) = classify(
            &dets,
            &bins,
            &speeds,
            None,
            Some(40),
            &SegmentConfig::default(),
        );
        out.into_iter().map(|c| c.kind).collect()
    }

    #[test]
    fn warm_up_then_conditioning_then_matrix() {
        let mut plan = Vec::new();
        let mut t = 0;
        for _ in 0..8 {
            plan.push(sweep(t, 8.0, 1112));
            t += 100;
        }
        for _ in 0..3 {
            plan.push(sweep(t, 8.0, 667));
            t += 100;
        }
        for load in [1557, 667, 222, 1112, 445] {
            plan.push(sweep(t, 4.0, load));
            t += 100;
        }
        let k = kinds(plan);
        assert!(k[..8].iter().all(|k| *k == SegmentKind::ColdToWarm));
        assert!(k[8..11].iter().all(|k| *k == SegmentKind::Conditioning));
        assert!(k[11..].iter().all(|k| *k == SegmentKind::Cornering));
    }

    #[test]
    fn a_single_fast_sweep_before_the_matrix_is_conditioning() {
        let mut plan = vec![sweep(0, 8.0, 1112)];
        for (i, load) in [1557, 667, 222, 1112].into_iter().enumerate() {
            plan.push(sweep(100 * (i + 1), 4.0, load));
        }
        let k = kinds(plan);
        assert_eq!(k[0], SegmentKind::Conditioning);
        assert!(k[1..].iter().all(|k| *k == SegmentKind::Cornering));
    }

    #[test]
    fn repeats_only_are_a_warm_up_run() {
        let plan: Vec<_> = (0..12).map(|i| sweep(100 * i, 8.0, 1112)).collect();
        assert!(kinds(plan).iter().all(|k| *k == SegmentKind::ColdToWarm));
    }

    #[test]
    fn run_class_follows_the_majority() {
        let mut counts = BTreeMap::new();
        counts.insert(SegmentKind::Cornering, 25);
        counts.insert(SegmentKind::Conditioning, 3);
        assert_eq!(run_class(&counts), RunClass::Cornering);
        counts.insert(SegmentKind::DriveBrake, 36);
        assert_eq!(run_class(&counts), RunClass::DriveBrake);
        let mut warm = BTreeMap::new();
        warm.insert(SegmentKind::SpringRateStatic, 3);
        assert_eq!(run_class(&warm), RunClass::WarmUp);
    }
}
