//! End-to-end tests of `segment::run` on synthetic runs (see `synthetic.rs`): exact counts,
//! kinds and nominal levels against the scheduled truth, defects flagged, determinism.

use std::ops::Range;

use super::synthetic::{self, Rig, Truth};
use super::*;

/// How detected segments compare with the truth.
#[derive(Debug, Default)]
struct Score {
    total: usize,
    found: usize,
    spurious: Vec<String>,
    missed: Vec<String>,
}

fn overlap(a: &Range<usize>, b: &Range<usize>) -> usize {
    a.end.min(b.end).saturating_sub(a.start.max(b.start))
}

/// Overlap of at least half the shorter of the two.
fn matches_range(a: &Range<usize>, b: &Range<usize>) -> bool {
    2 * overlap(a, b) >= a.len().min(b.len()).max(1)
}

/// Levels agree where the truth states one (a detected extra level is fine).
fn levels_agree(truth: &NominalLevels, got: &NominalLevels) -> bool {
    let same = |t: Option<i64>, g: Option<i64>| t.is_none() || t == g;
    same(truth.pressure_kpa, got.pressure_kpa)
        && same(truth.ia_cdeg, got.ia_cdeg)
        && same(truth.fz_n, got.fz_n)
        && same(truth.alpha_deg, got.alpha_deg)
        && same(truth.speed_kph, got.speed_kph)
}

fn score(segments: &[Segment], truth: &[Truth]) -> Score {
    let mut s = Score {
        total: truth.len(),
        ..Score::default()
    };
    for t in truth {
        let hit = segments.iter().any(|g| {
            g.kind == t.kind
                && matches_range(&g.samples, &t.samples)
                && levels_agree(&t.nominal, &g.nominal)
        });
        if hit {
            s.found += 1;
        } else {
            let near: Vec<String> = segments
                .iter()
                .filter(|g| overlap(&g.samples, &t.samples) > 0)
                .map(|g| format!("{} {:?} {:?}", g.kind, g.samples, g.nominal))
                .collect();
            s.missed.push(format!(
                "{} {:?} {:?} <- {near:?}",
                t.kind, t.samples, t.nominal
            ));
        }
    }
    for g in segments.iter().filter(|g| g.kind.is_matrix()) {
        if !truth
            .iter()
            .any(|t| t.kind == g.kind && matches_range(&g.samples, &t.samples))
        {
            s.spurious
                .push(format!("{} {:?} {:?}", g.kind, g.samples, g.nominal));
        }
    }
    s
}

fn segment(rig: &Rig, has_kappa: bool) -> (Vec<Segment>, RunSegmentation) {
    run(&rig.cols.signals(has_kappa), &SegmentConfig::default()).expect("valid run")
}

fn assert_perfect(rig: &Rig, has_kappa: bool) -> (Vec<Segment>, RunSegmentation) {
    let (segments, report) = segment(rig, has_kappa);
    let s = score(&segments, &rig.truth);
    assert!(
        s.found == s.total && s.spurious.is_empty(),
        "found {}/{}\nmissed: {:#?}\nspurious: {:#?}",
        s.found,
        s.total,
        s.missed,
        s.spurious
    );
    assert_covers(&segments, rig.len());
    (segments, report)
}

fn assert_covers(segments: &[Segment], n: usize) {
    let mut cursor = 0;
    for (i, s) in segments.iter().enumerate() {
        assert_eq!(s.index, i);
        assert_eq!(
            s.samples.start,
            cursor,
            "segment {i} does not start where {} ended",
            i.max(1) - 1
        );
        assert!(s.samples.end > s.samples.start);
        assert_eq!(s.n_samples, s.samples.len());
        cursor = s.samples.end;
    }
    assert_eq!(cursor, n);
}

fn count(segments: &[Segment], kind: SegmentKind) -> usize {
    segments.iter().filter(|s| s.kind == kind).count()
}

#[test]
fn round4_cornering_run_file_gives_its_25_matrix_sweeps_and_conditioning() {
    let rig = synthetic::round4_cornering(83.0, true, false, 1);
    let (segments, report) = assert_perfect(&rig, false);
    assert_eq!(count(&segments, SegmentKind::Cornering), 25);
    assert_eq!(
        count(&segments, SegmentKind::Conditioning),
        1,
        "one block of 3 cycles"
    );
    assert_eq!(
        count(&segments, SegmentKind::ColdToWarm),
        1,
        "one block of 8 cycles"
    );
    assert_eq!(count(&segments, SegmentKind::SpringRateStatic), 3);
    assert_eq!(count(&segments, SegmentKind::SpringRateDynamic), 7);
    assert_eq!(report.run_class, RunClass::Cornering);
    assert_eq!(report.main_speed_kph, Some(40));
    assert!(
        report.n_blocks >= 26,
        "dwells cut: {} blocks",
        report.n_blocks
    );
    let loads: Vec<i64> = segments
        .iter()
        .filter(|s| s.kind == SegmentKind::Cornering)
        .take(5)
        .filter_map(|s| s.nominal.fz_n)
        .collect();
    assert_eq!(loads, vec![1557, 667, 222, 1112, 445]);
    let clean = segments
        .iter()
        .filter(|s| s.kind != SegmentKind::Other)
        .all(|s| s.qc.is_empty());
    assert!(
        clean,
        "{:#?}",
        segments
            .iter()
            .filter(|s| !s.qc.is_empty())
            .collect::<Vec<_>>()
    );
}

#[test]
fn round4_cornering_without_cold_start_and_with_dwells_kept() {
    let rig = synthetic::round4_cornering(55.0, false, true, 2);
    let (segments, report) = assert_perfect(&rig, false);
    assert_eq!(count(&segments, SegmentKind::Cornering), 25);
    assert_eq!(count(&segments, SegmentKind::Conditioning), 1);
    assert_eq!(count(&segments, SegmentKind::ColdToWarm), 0);
    assert_eq!(report.n_blocks, 1);
    let p: Vec<Option<i64>> = segments.iter().map(|s| s.nominal.pressure_kpa).collect();
    assert!(p.iter().all(|p| *p == Some(55)));
}

#[test]
fn round4_drive_brake_gives_36_sweeps_at_sa_0_3_6() {
    let rig = synthetic::round4_drive_brake(97.0, false, 3);
    let (segments, report) = assert_perfect(&rig, true);
    assert_eq!(count(&segments, SegmentKind::DriveBrake), 12);
    assert_eq!(count(&segments, SegmentKind::Combined), 24);
    assert_eq!(
        count(&segments, SegmentKind::Conditioning),
        1,
        "two SL cycles, one block"
    );
    assert_eq!(report.run_class, RunClass::DriveBrake);
    let alphas: Vec<Option<i64>> = segments
        .iter()
        .filter(|s| s.kind.is_matrix())
        .take(3)
        .map(|s| s.nominal.alpha_deg)
        .collect();
    assert_eq!(alphas, vec![Some(0), Some(3), Some(6)]);
}

#[test]
fn round4_drive_brake_raw_with_dwells() {
    let rig = synthetic::round4_drive_brake(69.0, true, 4);
    let (segments, _) = assert_perfect(&rig, true);
    assert_eq!(
        count(&segments, SegmentKind::DriveBrake) + count(&segments, SegmentKind::Combined),
        36
    );
}

#[test]
fn round8_raw_cornering_with_pressures_ia_and_speed_sweeps() {
    let rig = synthetic::round8_cornering_raw(5);
    let (segments, report) = assert_perfect(&rig, false);
    assert_eq!(count(&segments, SegmentKind::ColdToWarm), 1);
    let warm = segments
        .iter()
        .find(|s| s.kind == SegmentKind::ColdToWarm)
        .unwrap();
    assert!((warm.sweep_rate.unwrap() - 8.0).abs() < 0.2);
    assert_eq!(count(&segments, SegmentKind::Cornering), 24);
    assert_eq!(count(&segments, SegmentKind::IaSweep), 2);
    assert_eq!(count(&segments, SegmentKind::SpeedSweep), 4);
    assert_eq!(count(&segments, SegmentKind::SpringRateStatic), 3);
    assert_eq!(report.run_class, RunClass::Cornering);
}

#[test]
fn round8_transient_run_gives_step_steers() {
    let rig = synthetic::round8_transient(6);
    let (segments, report) = assert_perfect(&rig, false);
    assert_eq!(count(&segments, SegmentKind::StepSteer), 9);
    assert_eq!(report.run_class, RunClass::Transient);
}

#[test]
fn round9_raw_drive_brake_with_speed_sweeps() {
    let rig = synthetic::round9_drive_brake_raw(7);
    let (segments, report) = assert_perfect(&rig, true);
    assert_eq!(count(&segments, SegmentKind::DriveBrake), 4);
    assert_eq!(count(&segments, SegmentKind::Combined), 8);
    assert_eq!(count(&segments, SegmentKind::SpeedSweep), 2);
    assert_eq!(report.run_class, RunClass::DriveBrake);
}

/// The sample range of the `k`-th truth segment of `kind`.
fn truth_range(rig: &Rig, kind: SegmentKind, k: usize) -> Range<usize> {
    rig.truth
        .iter()
        .filter(|t| t.kind == kind)
        .nth(k)
        .expect("truth")
        .samples
        .clone()
}

fn flags_over(segments: &[Segment], r: &Range<usize>) -> Vec<String> {
    segments
        .iter()
        .filter(|s| overlap(&s.samples, r) > 0)
        .flat_map(|s| s.qc.iter().map(ToString::to_string))
        .collect()
}

#[test]
fn injected_defects_are_flagged_and_do_not_break_the_count() {
    let mut rig = synthetic::round4_cornering(83.0, false, false, 8);
    let sweep = truth_range(&rig, SegmentKind::Cornering, 3);
    let mid = (sweep.start + sweep.end) / 2;
    rig.cols.pressure_kpa[mid..mid + 40]
        .iter_mut()
        .for_each(|v| *v = 0.0);
    let sweep7 = truth_range(&rig, SegmentKind::Cornering, 7);
    let m7 = (sweep7.start + sweep7.end) / 2;
    rig.cols.fy_n[m7..m7 + 60].iter_mut().for_each(|v| *v = 0.0);
    let sweep12 = truth_range(&rig, SegmentKind::Cornering, 12);
    let m12 = sweep12.start + 100;
    rig.cols.et_s[m12] = rig.cols.et_s[m12 - 1];
    let sweep15 = truth_range(&rig, SegmentKind::Cornering, 15);
    let m15 = sweep15.start + 200;
    rig.cols.et_s[m15] = rig.cols.et_s[m15 - 1] - 0.01;
    let sweep20 = truth_range(&rig, SegmentKind::Cornering, 20);
    let m20 = sweep20.start + 150;
    rig.cols.alpha_rad[m20..m20 + 30]
        .iter_mut()
        .for_each(|v| *v = 0.0);

    let (segments, _) = assert_perfect(&rig, false);
    assert_eq!(count(&segments, SegmentKind::Cornering), 25);
    assert!(flags_over(&segments, &(mid..mid + 40)).contains(&"zero_pressure".to_string()));
    assert!(flags_over(&segments, &(m7..m7 + 60)).contains(&"zeroed_channel:fy_n".to_string()));
    assert!(flags_over(&segments, &(m12..m12 + 1)).contains(&"duplicated_et".to_string()));
    assert!(flags_over(&segments, &(m15..m15 + 1)).contains(&"non_monotonic_et".to_string()));
    assert!(
        flags_over(&segments, &(m20..m20 + 30)).contains(&"zeroed_channel:alpha_rad".to_string())
    );
    let flagged = segments.iter().filter(|s| !s.qc.is_empty()).count();
    assert_eq!(flagged, 5, "only the defective sweeps are flagged");
}

#[test]
fn load_drift_saturation_and_truncation_are_flagged() {
    let mut rig = synthetic::round4_cornering(83.0, false, false, 9);
    let s2 = truth_range(&rig, SegmentKind::Cornering, 2);
    let n = s2.len() as f64;
    for (k, i) in s2.clone().enumerate() {
        rig.cols.fz_n[i] += 400.0 * k as f64 / n;
    }
    let s5 = truth_range(&rig, SegmentKind::Cornering, 5);
    let cap = rig.cols.fy_n[s5.clone()]
        .iter()
        .cloned()
        .fold(f64::NEG_INFINITY, f64::max)
        - 150.0;
    rig.cols.fy_n.iter_mut().for_each(|v| *v = v.min(cap));
    let (segments, _) = segment(&rig, false);
    assert!(flags_over(&segments, &s2).contains(&"load_drift".to_string()));
    assert!(
        flags_over(&segments, &s5)
            .iter()
            .any(|f| f == "saturated_channel:fy_n")
    );

    let last = truth_range(&rig, SegmentKind::Cornering, 24);
    let cut = last.start + last.len() / 3;
    let cols = truncate(&rig.cols, cut);
    let (segments, _) = run(&cols.signals(false), &SegmentConfig::default()).unwrap();
    let tail = segments
        .iter()
        .rev()
        .find(|s| s.kind != SegmentKind::Other)
        .unwrap();
    assert!(tail.qc.contains(&QcFlag::TooShort), "{tail:#?}");
}

fn truncate(c: &synthetic::Columns, n: usize) -> synthetic::Columns {
    let t = |v: &Vec<f64>| v[..n].to_vec();
    synthetic::Columns {
        et_s: t(&c.et_s),
        speed_kph: t(&c.speed_kph),
        pressure_kpa: t(&c.pressure_kpa),
        fz_n: t(&c.fz_n),
        alpha_rad: t(&c.alpha_rad),
        gamma_rad: t(&c.gamma_rad),
        kappa: t(&c.kappa),
        fy_n: t(&c.fy_n),
        fx_n: t(&c.fx_n),
        loaded_radius_m: t(&c.loaded_radius_m),
        t_inner_c: t(&c.t_inner_c),
        t_centre_c: t(&c.t_centre_c),
        t_outer_c: t(&c.t_outer_c),
        mz_nm: t(&c.mz_nm),
    }
}

/// Issue 17: a load off the standard list is a level of its own, not an off-nominal sweep.
#[test]
fn a_load_off_the_standard_list_is_its_own_level_issue_17() {
    let mut rig = synthetic::round4_cornering(83.0, false, false, 10);
    let s = truth_range(&rig, SegmentKind::Cornering, 0);
    // The load set-point changes in the dwells around the sweep.
    let pad = s.len() / 4;
    rig.cols.fz_n[s.start - pad..s.end + pad]
        .iter_mut()
        .for_each(|v| *v -= 350.0);
    let (segments, _) = segment(&rig, false);
    let hit = segments
        .iter()
        .find(|g| g.kind == SegmentKind::Cornering && matches_range(&g.samples, &s))
        .expect("still a cornering sweep");
    let level = hit.nominal.fz_n.expect("a learned load level");
    assert!(
        (level as f64 - hit.measured.fz_n.mean).abs() < 1.0,
        "labelled with its own centre: {level} vs {}",
        hit.measured.fz_n.mean
    );
    assert!((hit.measured.fz_n.mean - 1207.0).abs() < 30.0);
    assert!(hit.qc.is_empty(), "{:?}", hit.qc);
}

/// Issue 17: under loose load control (FZ swinging by +-20 % around its set-point, slowly or
/// fast) every sweep is still one segment with its nominal load, and no sweep is flagged.
#[test]
fn sweeps_stay_whole_under_loose_load_control_issue_17() {
    for period_s in [1.3, 4.0, 11.0] {
        let mut rig = synthetic::round4_cornering(83.0, true, false, 3);
        for (f, t) in rig.cols.fz_n.iter_mut().zip(&rig.cols.et_s) {
            *f *= 1.0 + 0.2 * (std::f64::consts::TAU * t / period_s).sin();
        }
        let (segments, _) = assert_perfect(&rig, false);
        let matrix: Vec<&Segment> = segments
            .iter()
            .filter(|s| s.kind == SegmentKind::Cornering)
            .collect();
        assert_eq!(matrix.len(), 25, "period {period_s} s");
        for s in matrix {
            assert!(
                s.qc.is_empty(),
                "period {period_s} s: {:?} {:?}",
                s.samples,
                s.qc
            );
        }
    }
}

#[test]
fn same_input_same_output() {
    let rig = synthetic::round8_cornering_raw(11);
    assert_eq!(segment(&rig, false), segment(&rig, false));
}

#[test]
fn bad_input_is_an_error_naming_the_channel() {
    let rig = synthetic::round8_transient(12);
    let mut cols = rig.cols.clone();
    cols.fz_n.pop();
    let err = run(&cols.signals(false), &SegmentConfig::default()).unwrap_err();
    assert!(err.to_string().contains("fz_n"), "{err}");
    let mut cols = rig.cols.clone();
    cols.fy_n[7] = f64::NAN;
    let err = run(&cols.signals(false), &SegmentConfig::default()).unwrap_err();
    assert_eq!(
        err.to_string(),
        "channel fy_n: sample 7 is not a finite number"
    );
}

#[test]
fn an_empty_run_gives_no_segments_and_a_warning() {
    let cols = synthetic::Columns::default();
    let (segments, report) = run(&cols.signals(false), &SegmentConfig::default()).unwrap();
    assert!(segments.is_empty());
    assert_eq!(report.run_class, RunClass::Unknown);
    assert_eq!(report.warnings, vec!["run has no samples".to_string()]);
}

/// Print a compact table of a run's segments (debugging aid: `cargo test -- --nocapture`).
#[allow(dead_code)]
fn dump(segments: &[Segment]) {
    for s in segments {
        eprintln!(
            "{:>3} {:>6}..{:<6} {:<20} p={:?} ia={:?} fz={:?} a={:?} v={:?} rate={:?} fzm={:.0} {}",
            s.index,
            s.samples.start,
            s.samples.end,
            s.kind.as_str(),
            s.nominal.pressure_kpa,
            s.nominal.ia_cdeg,
            s.nominal.fz_n,
            s.nominal.alpha_deg,
            s.nominal.speed_kph,
            s.sweep_rate.map(|r| (r * 100.0).round() / 100.0),
            s.measured.fz_n.mean,
            s.qc_string()
        );
    }
}

#[test]
#[ignore]
fn debug_dump() {
    let which = std::env::var("DUMP").unwrap_or_default();
    let (rig, kappa) = match which.as_str() {
        "r4c" => (synthetic::round4_cornering(83.0, true, false, 1), false),
        "r4craw" => (synthetic::round4_cornering(55.0, false, true, 2), false),
        "r4db" => (synthetic::round4_drive_brake(97.0, false, 3), true),
        "r4dbraw" => (synthetic::round4_drive_brake(69.0, true, 4), true),
        "r8c" => (synthetic::round8_cornering_raw(5), false),
        "r8t" => (synthetic::round8_transient(6), false),
        _ => (synthetic::round9_drive_brake_raw(7), true),
    };
    let (segments, report) = segment(&rig, kappa);
    dump(&segments);
    eprintln!("{report:?}");
    for t in &rig.truth {
        eprintln!("truth {:?} {}", t.samples, t.kind);
    }
}

#[test]
#[ignore]
fn debug_zero_runs() {
    let rig = synthetic::round4_cornering(83.0, true, false, 1);
    let runs = super::prepare::zero_runs(&rig.cols.mz_nm, 5, super::prepare::is_exact_zero);
    eprintln!(
        "{} runs, first {:?}",
        runs.len(),
        &runs[..runs.len().min(10)]
    );
    for r in runs.iter().take(5) {
        eprintln!(
            "{:?} left {:?} right {:?}",
            r,
            &rig.cols.mz_nm[r.start.saturating_sub(10)..r.start],
            &rig.cols.mz_nm[r.end..(r.end + 10).min(rig.len())]
        );
    }
}

#[test]
#[ignore]
fn debug_staircase() {
    let rig = synthetic::round4_cornering(83.0, true, false, 1);
    let sig = rig.cols.signals(false);
    let cfg = SegmentConfig::default();
    let tl = super::gaps::split_gaps(sig.et_s, &cfg.gaps);
    let prep = super::prepare::prepare(&sig, &tl, &cfg);
    for r in super::plateau::level_runs(&prep.fz_n[2900..3350], cfg.spring_rate.fz_n) {
        let ia = prep.ia_deg[2900 + r.start..2900 + r.end]
            .iter()
            .sum::<f64>()
            / r.len() as f64;
        eprintln!(
            "{:?} {:.1} ia {:.2}",
            (r.start + 2900)..(r.end + 2900),
            r.mean,
            ia
        );
    }
}

/// Timing on a long raw run (run with `--release -- --ignored --nocapture`; prints ms per run).
#[test]
#[ignore]
fn timing_of_a_long_raw_run() {
    let rig = synthetic::round8_cornering_raw(13);
    let signals = rig.cols.signals(false);
    let cfg = SegmentConfig::default();
    let n: u32 = std::env::var("SEGMENT_TIMING_N")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20);
    let t0 = std::time::Instant::now();
    for _ in 0..n {
        std::hint::black_box(run(&signals, &cfg).unwrap());
    }
    let ms = t0.elapsed().as_secs_f64() * 1e3 / f64::from(n.max(1));
    eprintln!("{} samples: {ms:.2} ms per run", rig.len());
}

/// A pressure in psi read as kPa (12 "kPa") is outside the physical range of an inflation
/// pressure: every segment says so (`out_of_range:pressure_kpa`, which spoils forces: the group
/// would be the wrong pressure), and the same run in kPa has no such flag.
#[test]
fn a_pressure_outside_its_physical_range_flags_every_segment() {
    let rig = synthetic::round4_cornering(83.0, false, false, 8);
    let (clean, _) = segment(&rig, false);
    assert!(clean.iter().all(|s| s.qc.is_empty()));
    let mut psi = synthetic::round4_cornering(83.0, false, false, 8);
    psi.cols
        .pressure_kpa
        .iter_mut()
        .for_each(|v| *v /= 6.894_757);
    let (segments, _) = segment(&psi, false);
    let flag = QcFlag::OutOfRange("pressure_kpa".into());
    assert_eq!(segments.len(), clean.len());
    assert!(
        segments.iter().all(|s| s.qc == [flag.clone()]),
        "{:?}",
        segments.iter().map(|s| s.qc_string()).collect::<Vec<_>>()
    );
    assert!(flag.spoils_forces());
}
