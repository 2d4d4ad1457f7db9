//! Opt-in real-data check of issue 18: tirebase's fits of the two real, de-identified TTC files
//! of `shared/real/` in sample and out of sample on the measured samples, against the file
//! author's MF 5.2 and MF 6.1 fits (`obfuscated_mf52.tir`, `obfuscated_mf61.tir`, which saw
//! every sample).
//!
//! Through the real binary: ingest both files, fit (in sample); then out of sample two ways, each
//! fold a copy of the store with the fold's segments held out (an unknown QC flag, which the fit
//! treats as spoiling the forces), fitted, its models predicting the held-out segments' samples:
//! - 5-fold by sweep (the headline): the force segments of every tire/pressure/kind dealt
//!   diagonally over their nominal load, inclination and slip angle
//!   ([`tirebase::core::fit::sweep_folds::diagonal`], the rule of `fit_quality`'s k-fold): a
//!   fold holds at most one sweep of a load at each inclination, so each held-out sweep is
//!   predicted from sweeps at its load and at its inclination (interpolation over load and
//!   camber); repeats of a condition are held out together.
//! - Load level held out: fold `i` holds every sweep at the `i`-th nominal load of its group, so
//!   that load is predicted from the other loads alone (the end loads are extrapolations). The
//!   cornering test plan cycles five loads per inclination, so a fold dealt by file order
//!   (index mod 5) is nearly this rule.
//!
//! Both files are one tire (the author's fits are one model of both): `drivebrake.mat` names no
//! tire, so the check ingests it through a catalog in the temp dir as the Hoosier 43075
//! 16x7.5-10 LCO on its 7 in rim, the tire `cornering.mat`'s `tireid` names. Each pressure's group
//! then holds cornering, drive/brake and combined sweeps, and the fit fits combined Fx and Fy on
//! them (Fy0 from the cornering sweeps).
//!
//! Every figure is an RMSE on the measured samples of the sweeps (the README's selection:
//! |alpha| <= 12.5 deg, Fz > 100 N, V > 5 km/h), per pressure and channel, a sample's channels
//! chosen by its segment's kind: pure Fy and pure Mz of the cornering sweeps, pure Fx of the
//! drive/brake sweeps, combined Fx and combined Fy (and, printed only, combined Mz) of the
//! combined sweeps; the same samples for every model. Columns: tirebase in sample, out of sample
//! by sweep, load level held out, the author's MF 5.2 fit and the author's MF 6.1 fit
//! (`obfuscated_mf61.tir`, one model of every pressure, evaluated at each sample's measured
//! inflation pressure as `tirebase tir score` does). Also printed: the relaxation rows (speeds,
//! lag identifiability) beside the thesis's Table 15.
//!
//! Also: no `.tir` the fit writes (per pressure, MF 6.1) has a lint error (printed: every
//! finding, and the MF 6.1 rows' 5-fold and left-out-pressure ratios).
//!
//! Ignored by default (GPL data, development only, read where it lies):
//! `cargo test --test integration real_data_out_of_sample -- --ignored --nocapture`
//! (`TIREBASE_REAL_DIR` overrides where the files are looked for). Asserts issue 18's target:
//! on every asserted channel (all but combined Mz) and pressure, tirebase's RMSE in sample and
//! out of sample by sweep no larger than the MF 5.2 fit's or the MF 6.1 fit's (both saw every
//! sample), and with a load level held out no larger than the MF 5.2 fit's. The load-level
//! column against the MF 6.1 fit is printed: it asks tirebase to extrapolate to a load it did
//! not see against a model that saw it, more than the issue's "repeat runs neither fit saw".

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use polars::prelude::*;
use tirebase::core::fit::sweep_folds;
use tirebase::core::naming::tir_file_name;
use tirebase::core::tire_model::tir::TirFile;
use tirebase::core::tire_model::{Evaluation, Mode, Pressures, SlipInput};

use crate::harness::{copy_tree, csv_rows, flag_segments, ingest, ok, p, strs, tirebase};
use crate::real::real_dir;

/// Folds of the out-of-sample check by sweep.
const FOLDS: usize = 5;
/// Accumulator columns: in sample, out of sample by sweep, load level held out, MF 5.2, MF 6.1.
const COLUMNS: usize = 5;
/// The tire both files hold (`cornering.mat`'s `tireid`; `drivebrake.mat` names none).
const TIRE: &str = "Hoosier 43075 16x7.5-10 LCO";
/// Its rim width, inches.
const RIM_IN: i64 = 7;

/// One scored channel: the segment kind whose samples it is scored on, which measured value
/// (0 Fx, 1 Fy, 2 Mz), its printed name, and whether issue 18's target is asserted on it.
struct Channel {
    kind: &'static str,
    value: usize,
    name: &'static str,
    asserted: bool,
}

/// The channels of issue 18's done-when, in printed order (combined Mz printed only).
const CHANNELS: [Channel; 6] = [
    Channel {
        kind: "cornering",
        value: 1,
        name: "pure Fy, N",
        asserted: true,
    },
    Channel {
        kind: "cornering",
        value: 2,
        name: "pure Mz, N m",
        asserted: true,
    },
    Channel {
        kind: "drive_brake",
        value: 0,
        name: "pure Fx, N",
        asserted: true,
    },
    Channel {
        kind: "combined",
        value: 0,
        name: "combined Fx, N",
        asserted: true,
    },
    Channel {
        kind: "combined",
        value: 1,
        name: "combined Fy, N",
        asserted: true,
    },
    Channel {
        kind: "combined",
        value: 2,
        name: "combined Mz, N m",
        asserted: false,
    },
];

/// Squared-error sums and counts, one per [`CHANNELS`] entry.
type ChannelErrors = [(f64, usize); CHANNELS.len()];
/// Held-out marker written into `qc_flags` (unknown flags spoil the forces for the fit).
const HELD_OUT: &str = "held_out_by_test";

/// CSV rows (header dropped) of a `query --format csv`.
fn query(store: &Path, sql: &str) -> Vec<Vec<String>> {
    let o = tirebase(&["query", "--store", p(store), "--format", "csv", sql]);
    ok(&o, sql);
    csv_rows(&o)
}

/// Mark the segments `ids` of the store as held out; returns how many were marked.
fn hold_out(store: &Path, ids: &BTreeSet<String>) -> usize {
    flag_segments(store, HELD_OUT, |df| {
        strs(df, "segment_id")
            .iter()
            .map(|s| ids.contains(s))
            .collect()
    })
}

/// One measured sweep sample (ISO-W, SI) and where it belongs.
struct Sample {
    segment: String,
    /// Its segment's kind (`segments.kind`): which channels it is scored on.
    kind: String,
    /// (tire, nominal pressure kPa).
    group: (String, i64),
    rim_in: f64,
    point: SlipInput,
    /// Measured inflation pressure, kPa (an MF 6.1 model is evaluated at it).
    pressure_kpa: f64,
    /// Measured Fx, Fy, Mz.
    measured: [f64; 3],
}

/// The sweep samples of the force segments `kinds` (segment id -> kind), with the README's
/// selection.
fn sweep_samples(store: &Path, kinds: &BTreeMap<String, String>) -> Vec<Sample> {
    let rows = query(
        store,
        "SELECT segment_id, tire, pressure_kpa_nom, rim_in, fz_n, kappa, alpha_rad, gamma_rad, \
         speed_kph, pressure_kpa, fx_n, fy_n, mz_nm FROM samples \
         WHERE fz_n > 100 AND speed_kph > 5 AND abs(alpha_rad) <= 0.2181661564992912 \
         AND segment_id IS NOT NULL",
    );
    rows.into_iter()
        .filter_map(|r| {
            let kind = kinds.get(&r[0])?.clone();
            let f = |i: usize| r[i].parse::<f64>().unwrap_or(f64::NAN);
            Some(Sample {
                segment: r[0].clone(),
                kind,
                group: (r[1].clone(), r[2].parse().unwrap()),
                rim_in: f(3),
                point: SlipInput {
                    fz_n: f(4),
                    kappa: f(5),
                    alpha_rad: f(6),
                    gamma_rad: f(7),
                    vx_mps: f(8) / 3.6,
                },
                pressure_kpa: f(9),
                measured: [f(10), f(11), f(12)],
            })
        })
        .collect()
}

fn model_of(path: &Path) -> TirFile {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    TirFile::parse(&text)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .0
}

/// Squared-error sums and counts of `model` on `samples`, per [`CHANNELS`] entry (a sample
/// counts in the channels of its segment's kind). Evaluated as `tirebase tir score` evaluates:
/// each sample at its measured inflation pressure (MF 6.x; the model's default pressure where
/// none was measured; PAC2002 has no pressure terms), limits mode.
fn errors(model: &TirFile, samples: &[&Sample]) -> ChannelErrors {
    let model = model.model();
    let points: Vec<SlipInput> = samples.iter().map(|s| s.point).collect();
    let fallback = model.default_pressure_pa();
    let pressures_pa: Vec<f64> = samples
        .iter()
        .map(|s| match s.pressure_kpa {
            p if p.is_finite() && p > 0.0 => p * 1e3,
            _ => fallback,
        })
        .collect();
    let mut out = vec![Evaluation::default(); points.len()];
    model.eval_batch_at(
        &points,
        Pressures::PerPoint(&pressures_pa),
        Mode::Limits,
        &mut out,
    );
    let mut acc = [(0.0, 0usize); CHANNELS.len()];
    for (s, e) in samples.iter().zip(&out) {
        let predicted = [e.fx_n, e.fy_n, e.mz_nm];
        for (c, channel) in CHANNELS.iter().enumerate() {
            let d = predicted[channel.value] - s.measured[channel.value];
            if channel.kind == s.kind && d.is_finite() {
                acc[c].0 += d * d;
                acc[c].1 += 1;
            }
        }
    }
    acc
}

fn rmse(acc: (f64, usize)) -> f64 {
    if acc.1 == 0 {
        f64::NAN
    } else {
        (acc.0 / acc.1 as f64).sqrt()
    }
}

#[test]
#[ignore = "needs the real files of shared/real/ (development only); run with --ignored"]
fn real_data_out_of_sample_against_the_authors_fits_issue_18() {
    let Some(real) = real_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (store, out) = (dir.path().join("store"), dir.path().join("fit"));
    let catalog = dir.path().join("catalog.toml");
    std::fs::write(
        &catalog,
        format!("[[run]]\nfile = \"drivebrake.mat\"\ntire = \"{TIRE}\"\nrim_in = {RIM_IN}\n"),
    )
    .unwrap();
    ingest(&real, &store, Some(&catalog));
    let identities = query(
        &store,
        "SELECT DISTINCT source_file, tire, rim_in FROM segments ORDER BY source_file",
    );
    let expected: Vec<Vec<String>> = ["cornering.mat", "drivebrake.mat"]
        .iter()
        .map(|f| vec![f.to_string(), TIRE.to_string(), RIM_IN.to_string()])
        .collect();
    assert_eq!(identities, expected, "both files one tire on one rim");
    let fit = tirebase(&["fit", "--store", p(&store), "--out", p(&out), "--jobs", "2"]);
    eprintln!("{}", String::from_utf8_lossy(&fit.stderr));
    let lint_errors = lint_errors(&out);
    let mf61 = table(&out, "fit_quality");
    eprintln!(
        "MF 6.1 rows (tire | pressure | family | rmse | 5-fold ratio | left-out-pressure ratio):"
    );
    for i in 0..mf61.height() {
        let get = |c: &str| mf61.column(c).unwrap().get(i).unwrap().to_string();
        if get("model").contains("mf61") {
            eprintln!(
                "  {} | {} | {} | {} | {} | {}",
                get("tire"),
                get("pressure_kpa"),
                get("channel"),
                get("rmse"),
                get("oos_ratio"),
                get("lopo_ratio")
            );
        }
    }

    // The force segments of every tire/pressure/kind, dealt into folds two ways (module docs).
    let segs = query(
        &store,
        "SELECT segment_id, tire, pressure_kpa_nom, kind, fz_n_nom, ia_cdeg_nom, \
         coalesce(alpha_deg_nom, 0) FROM segments \
         WHERE qc_ok AND kind IN ('cornering', 'drive_brake', 'combined') \
         AND pressure_kpa_nom IS NOT NULL ORDER BY source_file, segment_index",
    );
    let mut groups: BTreeMap<(String, String, String), Vec<&Vec<String>>> = BTreeMap::new();
    for r in &segs {
        groups
            .entry((r[1].clone(), r[2].clone(), r[3].clone()))
            .or_default()
            .push(r);
    }
    // Per segment: (fold by sweep, held-out load level).
    let mut fold_of: BTreeMap<String, (usize, usize)> = BTreeMap::new();
    for rows in groups.values() {
        let level = |col: usize, resolution: f64| {
            let v: Vec<f64> = rows
                .iter()
                .map(|r| r[col].parse::<f64>().unwrap_or(0.0))
                .collect();
            sweep_folds::ranks(&v, resolution)
        };
        let (fz, ia, alpha) = (level(4, 1.0), level(5, 1e-3), level(6, 1e-3));
        let sums: Vec<usize> = (0..rows.len()).map(|i| fz[i] + ia[i] + alpha[i]).collect();
        let diagonal = sweep_folds::diagonal(&sums, FOLDS).unwrap_or_else(|| vec![0; rows.len()]);
        for (i, r) in rows.iter().enumerate() {
            fold_of.insert(r[0].clone(), (diagonal[i], fz[i]));
        }
    }
    let load_levels = fold_of.values().map(|f| f.1 + 1).max().unwrap_or(0);
    let kinds: BTreeMap<String, String> =
        segs.iter().map(|r| (r[0].clone(), r[3].clone())).collect();
    let samples = sweep_samples(&store, &kinds);
    eprintln!(
        "{} force segments, {} sweep samples",
        kinds.len(),
        samples.len()
    );

    // Per (tire, pressure): [in sample, out of sample by sweep, load level held out, MF 5.2,
    // MF 6.1] x CHANNELS.
    type Acc = [ChannelErrors; COLUMNS];
    let mut acc: BTreeMap<(String, i64), Acc> = BTreeMap::new();
    let mf52 = model_of(&real.join("obfuscated_mf52.tir"));
    let mf61 = model_of(&real.join("obfuscated_mf61.tir"));
    let add = |acc: &mut BTreeMap<(String, i64), Acc>,
               which: usize,
               model: &TirFile,
               group: &[&Sample]| {
        let e = errors(model, group);
        let a = acc.entry(group[0].group.clone()).or_default();
        for (c, (sum, n)) in e.into_iter().enumerate() {
            a[which][c].0 += sum;
            a[which][c].1 += n;
        }
    };
    let mut by_group: BTreeMap<(String, i64), Vec<&Sample>> = BTreeMap::new();
    for s in &samples {
        by_group.entry(s.group.clone()).or_default().push(s);
    }
    let tir_of = |fit_out: &Path, g: &(String, i64), rim: f64| {
        fit_out
            .join("tir")
            .join(tir_file_name(&g.0, rim, g.1 as f64))
    };
    for (g, group) in &by_group {
        let ours = tir_of(&out, g, group[0].rim_in);
        assert!(ours.exists(), "no model {}", ours.display());
        add(&mut acc, 0, &model_of(&ours), group);
        add(&mut acc, 3, &mf52, group);
        add(&mut acc, 4, &mf61, group);
    }
    let runs = (0..FOLDS)
        .map(|f| (1, f))
        .chain((0..load_levels).map(|f| (2, f)));
    for (column, fold) in runs {
        let held: BTreeSet<String> = fold_of
            .iter()
            .filter(|(_, f)| (if column == 1 { f.0 } else { f.1 }) == fold)
            .map(|(id, _)| id.clone())
            .collect();
        let fold_store = dir.path().join(format!("store_{column}_{fold}"));
        let fold_out = dir.path().join(format!("fit_{column}_{fold}"));
        copy_tree(&store, &fold_store);
        assert_eq!(hold_out(&fold_store, &held), held.len());
        let o = tirebase(&[
            "fit",
            "--store",
            p(&fold_store),
            "--out",
            p(&fold_out),
            "--jobs",
            "2",
        ]);
        assert_ne!(o.status.code(), Some(2), "fold {column}/{fold}");
        for (g, group) in &by_group {
            let held_out: Vec<&Sample> = group
                .iter()
                .copied()
                .filter(|s| held.contains(&s.segment))
                .collect();
            if held_out.is_empty() {
                continue;
            }
            let model = tir_of(&fold_out, g, group[0].rim_in);
            assert!(
                model.exists(),
                "fold {column}/{fold}: no model {}",
                model.display()
            );
            add(&mut acc, column, &model_of(&model), &held_out);
        }
        std::fs::remove_dir_all(&fold_store).ok();
    }

    let misses = print_and_check(&acc);

    // Relaxation: speeds and whether the rig lag could be separated (thesis Table 15:
    // 0.335 m at 667 N, 0.475 m at 1557 N, round 4).
    let rx = ParquetReader::new(std::fs::File::open(out.join("relaxation.parquet")).unwrap())
        .finish()
        .unwrap();
    let cols = [
        "tire",
        "pressure_kpa",
        "direction",
        "fz_n_nom",
        "speed_kph",
        "sigma_m",
        "at_bound",
        "scale_drift",
        "apparent_lag_s",
        "measurement_lag_s",
        "lag_separated",
    ];
    eprintln!("relaxation rows ({}):", cols.join(", "));
    for i in 0..rx.height() {
        let row: Vec<String> = cols
            .iter()
            .map(|c| rx.column(c).unwrap().get(i).unwrap().to_string())
            .collect();
        eprintln!("  {}", row.join(" | "));
    }
    assert!(
        misses.is_empty(),
        "issue 18 real-data targets missed:\n{}",
        misses.join("\n")
    );
    assert!(
        lint_errors.is_empty(),
        "issue 18: written .tir files with lint errors:\n{}",
        lint_errors.join("\n")
    );
}

/// Print the table of figures (per channel and pressure) and return the asserted channels'
/// misses: tirebase's RMSE in sample or out of sample by sweep above the MF 5.2 or the MF 6.1
/// fit's, with a load level held out above the MF 5.2 fit's, or not computed. Every sample is
/// predicted once by every column (asserted).
fn print_and_check(acc: &BTreeMap<(String, i64), [ChannelErrors; COLUMNS]>) -> Vec<String> {
    eprintln!(
        "channel | pressure | samples | tirebase in sample | tirebase out of sample \
         ({FOLDS}-fold by sweep) | load level held out | MF 5.2 (saw every sample) | \
         MF 6.1 (saw every sample)"
    );
    let mut misses = Vec::new();
    for (c, channel) in CHANNELS.iter().enumerate() {
        for ((tire, pressure), a) in acc {
            let n = a[0][c].1;
            for (column, what) in [
                (1, "out of sample by sweep"),
                (2, "load level held out"),
                (3, "MF 5.2"),
                (4, "MF 6.1"),
            ] {
                assert_eq!(
                    a[column][c].1, n,
                    "{tire} {pressure} kPa {}: every sample predicted once ({what})",
                    channel.name
                );
            }
            let [is, oos, lolo, mf52, mf61] = [0, 1, 2, 3, 4].map(|column| rmse(a[column][c]));
            let mark = if channel.asserted {
                ""
            } else {
                " (not asserted)"
            };
            eprintln!(
                "{}{mark} | {pressure} kPa | {n} | {is:.1} | {oos:.1} ({:.2}x) | {lolo:.1} \
                 ({:.2}x) | {mf52:.1} | {mf61:.1}",
                channel.name,
                oos / is,
                lolo / is
            );
            if !channel.asserted {
                continue;
            }
            // Issue 18's target: in sample and on sweeps tirebase did not see (by sweep)
            // against both of the author's fits, which saw every sample; a load level tirebase
            // did not see against the MF 5.2 fit (the supplier's PAC2002 form) only: against
            // the MF 6.1 fit it is printed, not asserted.
            let both = [(mf52, "MF 5.2"), (mf61, "MF 6.1")];
            // (figure, what it is, how many of `both` it is asked against)
            let compared = [
                (is, "in sample", 2),
                (oos, "out of sample by sweep", 2),
                (lolo, "load level held out", 1),
            ];
            for (e, what, against) in compared {
                for &(theirs, whose) in &both[..against] {
                    if e.is_nan() || theirs.is_nan() || e > theirs {
                        misses.push(format!(
                            "{pressure} kPa {}: {what} {e:.1} > {whose} {theirs:.1}",
                            channel.name
                        ));
                    }
                }
            }
        }
    }
    misses
}

/// A result table of a fit's output directory.
fn table(out: &Path, name: &str) -> DataFrame {
    ParquetReader::new(std::fs::File::open(out.join(format!("{name}.parquet"))).unwrap())
        .finish()
        .unwrap()
}

/// The lint findings of every written `.tir` (printed), and the errors among them.
fn lint_errors(out: &Path) -> Vec<String> {
    let lint = table(out, "lint");
    let mut errors = Vec::new();
    eprintln!("lint findings of the written .tir files: {}", lint.height());
    for i in 0..lint.height() {
        let get = |c: &str| lint.column(c).unwrap().get(i).unwrap().to_string();
        let line = format!("{} {}: {}", get("file"), get("code"), get("message"));
        eprintln!("  {} {line}", get("severity"));
        if get("severity").contains("error") {
            errors.push(line);
        }
    }
    errors
}
