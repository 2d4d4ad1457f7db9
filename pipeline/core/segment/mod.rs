//! Segmentation: one run's channels -> a list of classified segments covering every sample,
//! without any hand-typed test schedule.
//!
//! In: [`RunSignals`] (slices, ISO-W, SI-ish units, see there) and a [`SegmentConfig`].
//! Out: `Vec<`[`Segment`]`>` (sorted, contiguous, each sample in exactly one segment; `other`
//! for dwells and transitions) and a [`RunSegmentation`] report (counts by kind, run class,
//! warnings). Deliberately not here: reading files, units and frames (readers and
//! [`crate::frame`]), writing the store (the command layer), and anything that needs more than
//! one run.
//!
//! The passes, one module each, in order:
//! ```text
//! gaps      ET -> sample period, gap-free blocks, ET anomalies
//! prepare   channels -> smoothed working channels (deg, SL vs free rolling), dropouts bridged
//! plateau   (used by sweep) held levels of P, IA, FZ, V
//! sweep     slip activity -> set-point pieces -> SA/SL sweep cycles, step steers;
//!           quiet stretches -> spring-rate staircases, IA ramps
//! levels    the run's own set-point levels, clustered from the candidates' measured means
//! binning   measured means/std and learned nominal levels of every candidate
//! classify  whole-run rules: cold-to-warm, conditioning, matrix kinds, speed sweeps
//! qc        flags per segment
//! ```
//! `run` joins them and fills everything undetected with `other` segments (cut at ET gaps).

mod binning;
mod classify;
mod config;
mod gaps;
mod levels;
mod output;
mod plateau;
mod prepare;
mod qc;
mod signals;
mod sweep;

#[cfg(test)]
mod synthetic;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod truth_eval;

use std::collections::BTreeMap;
use std::ops::Range;

use levels::{HeldValues, RunLevels};

pub use config::{
    ActivityConfig, ClassifyConfig, GapConfig, IaSweepConfig, LevelConfig, PlateauConfig, QcConfig,
    SegmentConfig, SmoothingConfig, SpringRateHoldConfig, StepSteerConfig, SweepConfig, Tolerance,
};
pub use output::{
    ChannelStats, IA_LABEL_STEP_CDEG, Level, MeasuredLevels, NominalLevels, QcFlag, RunClass,
    RunSegmentation, Segment, SegmentKind, SweepVariable, ia_cdeg_label, ia_cdeg_text,
};
pub use signals::{RunSignals, TreadTemps};

/// Bad input or configuration; one line naming the channel, sample or key.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SegmentError {
    /// A channel's length differs from ET's.
    #[error("channel {channel}: {found} samples, expected {expected} (the length of et_s)")]
    LengthMismatch {
        channel: String,
        expected: usize,
        found: usize,
    },
    /// A NaN or infinity in a channel.
    #[error("channel {channel}: sample {index} is not a finite number")]
    NonFinite { channel: String, index: usize },
    /// A configuration value out of range.
    #[error("segment config key {key}: {reason}")]
    Config { key: &'static str, reason: String },
}

/// Segment one run. Deterministic: same input, same output.
pub fn run(
    signals: &RunSignals,
    cfg: &SegmentConfig,
) -> Result<(Vec<Segment>, RunSegmentation), SegmentError> {
    cfg.validate()?;
    signals.validate()?;
    let timeline = gaps::split_gaps(signals.et_s, &cfg.gaps);
    let prep = prepare::prepare(signals, &timeline, cfg);
    let detections = sweep::detect(&prep, &timeline, cfg);

    let source = binning::StatsSource::new(signals, &prep.dropouts);
    let measured: Vec<MeasuredLevels> = detections
        .iter()
        .map(|d| source.measure(d.samples.clone()))
        .collect();
    let inputs = level_inputs(&detections, &measured, &timeline.blocks, cfg);
    let levels = RunLevels::learn(&held_values(&detections, &inputs), &cfg.levels);
    let bins: Vec<NominalLevels> = inputs.iter().map(|m| levels.bin_all(m)).collect();
    let speeds: Vec<f64> = measured.iter().map(|m| m.speed_kph.mean).collect();
    let centre = signals.tread_temps.map(|t| t.centre_c);
    let main_label = levels.speed_kph.label_of(cfg.classify.main_speed_kph);
    let (classes, main_speed) =
        classify::classify(&detections, &bins, &speeds, centre, main_label, cfg);
    let (detections, classes, bins) =
        classify::merge_warm_up_blocks(detections, classes, bins, &timeline.blocks);
    let measured: Vec<MeasuredLevels> = detections
        .iter()
        .map(|d| source.measure(d.samples.clone()))
        .collect();

    let mut segments = Vec::new();
    let mut extras: Vec<Extra> = Vec::new();
    let mut cursor = 0;
    let push_other = |segments: &mut Vec<Segment>, extras: &mut Vec<_>, range: Range<usize>| {
        for block in &timeline.blocks {
            let r = range.start.max(block.start)..range.end.min(block.end);
            if r.start < r.end {
                segments.push(draft(r, SegmentKind::Other, None));
                extras.push(Extra::default());
            }
        }
    };
    for (((d, c), m), b) in detections.iter().zip(&classes).zip(&measured).zip(&bins) {
        if d.samples.start > cursor {
            push_other(&mut segments, &mut extras, cursor..d.samples.start);
        }
        let mut s = draft(d.samples.clone(), c.kind, c.sweep);
        s.measured = *m;
        segments.push(s);
        extras.push(Extra {
            parts: d.parts,
            rate: d.rate,
            held_sa_deg: d.held_sa_deg,
            bins: Some(*b),
        });
        cursor = d.samples.end;
    }
    if cursor < signals.len() {
        push_other(&mut segments, &mut extras, cursor..signals.len());
    }

    let drafts: Vec<qc::Draft> = segments
        .iter()
        .zip(&extras)
        .map(|(s, e)| qc::Draft {
            samples: s.samples.clone(),
            kind: s.kind,
            parts: e.parts,
        })
        .collect();
    let flags = qc::flag(signals, &timeline, &prep.dropouts.p, &drafts, cfg);
    for (index, ((s, e), f)) in segments.iter_mut().zip(&extras).zip(flags).enumerate() {
        finish(s, index, e, f, signals, &source, &levels);
    }

    let mut counts: BTreeMap<SegmentKind, usize> =
        SegmentKind::ALL.iter().map(|k| (*k, 0)).collect();
    for s in &segments {
        *counts.entry(s.kind).or_default() += 1;
    }
    let report = RunSegmentation {
        run_class: classify::run_class(&counts),
        counts,
        sample_period_s: timeline.period_s,
        n_blocks: timeline.blocks.len(),
        main_speed_kph: main_speed,
        warnings: warnings(signals, &timeline, &segments)
            .into_iter()
            .chain(levels.warnings())
            .collect(),
    };
    Ok((segments, report))
}

/// The means a detection's levels are read from: its measured means, except the load of a sweep
/// cycle, which is the pooled mean load of the run of adjacent cycles (same motion, no gap, no
/// ET gap between them: a "run" file's cut dwell separates set-points) whose
/// own means agree within `plateau.fz_swing` of it: under loose load control the load swings
/// within and between the cycles of one set-point (a cycle of a slow swing can sit 10 % off),
/// while the block of cycles averages it out.
fn level_inputs(
    detections: &[sweep::Detection],
    measured: &[MeasuredLevels],
    blocks: &[Range<usize>],
    cfg: &SegmentConfig,
) -> Vec<MeasuredLevels> {
    use sweep::Motion;
    let block_of = |i: usize| blocks.partition_point(|b| b.end <= i);
    let mut out = measured.to_vec();
    let sweep = |d: &sweep::Detection| matches!(d.motion, Motion::SaSweep | Motion::SlSweep);
    let mut k = 0;
    while k < detections.len() {
        if !sweep(&detections[k]) {
            k += 1;
            continue;
        }
        let (mut sum, mut n) = (0.0, 0.0);
        let mut end = k;
        while end < detections.len() {
            let d = &detections[end];
            let fits = end == k
                || (sweep(d)
                    && d.motion == detections[end - 1].motion
                    && detections[end - 1].samples.end == d.samples.start
                    && block_of(d.samples.start) == block_of(detections[k].samples.start)
                    && (measured[end].fz_n.mean - sum / n).abs()
                        <= cfg.plateau.fz_swing.at(sum / n));
            if !fits {
                break;
            }
            let w = d.samples.len() as f64;
            sum += measured[end].fz_n.mean * w;
            n += w;
            end += 1;
        }
        for m in &mut out[k..end] {
            m.fz_n.mean = sum / n;
        }
        k = end;
    }
    out
}

/// What each detection tells about the run's set-points: the measured mean of every channel
/// its motion holds (a sweep holds P, IA, FZ and V; a load staircase P, IA, V and SA = 0; an IA
/// ramp P, FZ, V and SA = 0; an SL sweep and a step steer also a slip angle), weighted by its
/// sample count.
fn held_values(detections: &[sweep::Detection], measured: &[MeasuredLevels]) -> HeldValues {
    use sweep::Motion;
    let mut held = HeldValues::default();
    for (d, m) in detections.iter().zip(measured) {
        let w = d.samples.len() as f64;
        let (ia, fz, alpha) = match d.motion {
            Motion::SaSweep => (true, true, None),
            Motion::SlSweep => (true, true, Some(m.alpha_deg.mean)),
            Motion::StepSteer => (true, true, d.held_sa_deg),
            Motion::LoadSteps => (true, false, Some(m.alpha_deg.mean)),
            Motion::IaRamp => (false, true, Some(m.alpha_deg.mean)),
        };
        held.pressure_kpa.push((m.pressure_kpa.mean, w));
        held.speed_kph.push((m.speed_kph.mean, w));
        if ia {
            held.ia_deg.push((m.ia_deg.mean, w));
        }
        if fz {
            held.fz_n.push((m.fz_n.mean, w));
        }
        if let Some(a) = alpha {
            held.alpha_deg.push((a, w));
        }
    }
    held
}

/// A segment with its range and kind; levels, ET and flags are filled by [`finish`].
fn draft(samples: Range<usize>, kind: SegmentKind, sweep: Option<SweepVariable>) -> Segment {
    Segment {
        index: 0,
        n_samples: samples.len(),
        samples,
        kind,
        sweep,
        nominal: NominalLevels::default(),
        measured: MeasuredLevels::default(),
        et_start_s: 0.0,
        et_end_s: 0.0,
        sweep_rate: None,
        qc: Vec::new(),
    }
}

/// What a detected segment carries from detection to [`finish`].
#[derive(Clone, Debug, Default)]
struct Extra {
    /// Big excursions of a sweep cycle, steps of a staircase.
    parts: usize,
    /// Median sweep rate.
    rate: Option<f64>,
    /// Held slip angle of a step steer, deg.
    held_sa_deg: Option<f64>,
    /// The detection's levels (from its level inputs); `None` for `other` stretches.
    bins: Option<NominalLevels>,
}

/// Fill ET range, levels and flags of a drafted segment.
fn finish(
    s: &mut Segment,
    index: usize,
    extra: &Extra,
    mut flags: Vec<QcFlag>,
    signals: &RunSignals,
    source: &binning::StatsSource,
    levels: &RunLevels,
) {
    s.index = index;
    s.et_start_s = signals.et_s[s.samples.start];
    s.et_end_s = signals.et_s[s.samples.end - 1];
    if s.kind == SegmentKind::Other {
        s.measured = source.measure(s.samples.clone());
    }
    let bins = extra.bins.unwrap_or_else(|| levels.bin_all(&s.measured));
    let rate = extra.rate;
    let held = extra.held_sa_deg.map(|a| levels.alpha_deg.label_of(a));
    let (nominal, off) = binning::nominal_for(s.kind, s.sweep, &bins, held);
    s.nominal = nominal;
    s.sweep_rate = rate;
    flags.extend(off.into_iter().map(QcFlag::OffNominal));
    flags.sort();
    flags.dedup();
    s.qc = flags;
}

/// Run-level warnings: empty run, no detection at all, channels zero throughout.
fn warnings(signals: &RunSignals, timeline: &gaps::Timeline, segments: &[Segment]) -> Vec<String> {
    let mut out = Vec::new();
    if signals.is_empty() {
        out.push("run has no samples".to_string());
        return out;
    }
    if segments.iter().all(|s| s.kind == SegmentKind::Other) {
        out.push("no sweep, step steer, spring rate or IA sweep detected".to_string());
    }
    for (name, x) in [
        ("pressure_kpa", signals.pressure_kpa),
        ("fz_n", signals.fz_n),
        ("fy_n", signals.fy_n),
        ("speed_kph", signals.speed_kph),
    ] {
        if x.iter().all(|v| prepare::is_exact_zero(*v)) {
            out.push(format!("channel {name} is zero throughout the run"));
        }
    }
    if !timeline.non_monotonic.is_empty() {
        out.push(format!(
            "ET steps back {} time(s), first at sample {}",
            timeline.non_monotonic.len(),
            timeline.non_monotonic[0]
        ));
    }
    if !timeline.duplicated.is_empty() {
        out.push(format!(
            "ET repeats {} time(s), first at sample {}",
            timeline.duplicated.len(),
            timeline.duplicated[0]
        ));
    }
    out
}
