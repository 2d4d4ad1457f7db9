//! `tirebase fit` end to end: `synth round` (demo) -> `ingest` -> `fit`, through the real binary.
//!
//! Checks, against the virtual machine's truth (`truth/tir/*.tir`, `truth/<tire>__<rim>in.toml`):
//! - issue 5: every written `.tir` reproduces its truth over the tested envelope (the nominal
//!   load, inclination and slip ranges of the store's force-clean cornering, drive/brake and
//!   combined segments): RMS error <= 0.1 % of peak (Fx, Fy, Mz) on an ideal round (no noise,
//!   lag or heat), <= 2 % (Fx, Fy) and <= 5 % (Mz) with the default realism;
//! - issue 6 through the command: vertical stiffness within 1 %, unloaded radius within 0.5 mm
//!   (table rows and the `.tir`), relaxation length within 5 % of the truth law at every tested
//!   load (rows, law and the `.tir`'s PTY/PTX), mu(T) peak temperature within 3 degC and gain
//!   within 3 %;
//! - `--jobs 1` and `--jobs 2` give identical tables (except wall time) and `.tir` bytes;
//! - a group whose force data are all QC-flagged fails (reported, exit code 1) while the other
//!   groups and that group's other stages are written.
//!
//! The rounds are built once per test binary (shared fixtures) to keep the runtime modest.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;

use polars::prelude::*;
use tirebase::core::naming::tir_file_name;
use tirebase::core::tire_model::tir::TirFile;
use tirebase::core::tire_model::{Coef, SlipInput};

use crate::harness::{
    ENVELOPE_COLUMNS, ENVELOPE_WHERE, copy_tree, demo_round, envelope_points, f64s, flag_segments,
    ingest, ok, p, strs, synth_round, tirebase,
};

/// A demo round, its store and one fit of it.
struct Fitted {
    _dir: tempfile::TempDir,
    round: PathBuf,
    store: PathBuf,
    out: PathBuf,
    fit: Output,
}

/// Ingest and fit a demo round: the harness's for no flags, else one made with `synth_flags`.
fn prepare(synth_flags: &[&str]) -> Fitted {
    prepare_with(synth_flags, &[])
}

/// [`prepare`] with `fit_flags` added to the fit's command line.
fn prepare_with(synth_flags: &[&str], fit_flags: &[&str]) -> Fitted {
    let dir = tempfile::tempdir().unwrap();
    let (store, out) = (dir.path().join("store"), dir.path().join("out"));
    let round = if synth_flags.is_empty() {
        demo_round().to_path_buf()
    } else {
        let round = dir.path().join("round");
        synth_round(&round, synth_flags);
        round
    };
    ingest(
        &round.join("raw"),
        &store,
        Some(&round.join("catalog.toml")),
    );
    let mut fit_args = vec!["fit", "--store", p(&store), "--out", p(&out), "--jobs", "2"];
    fit_args.extend_from_slice(fit_flags);
    let fit = tirebase(&fit_args);
    eprintln!("{}", String::from_utf8_lossy(&fit.stderr));
    Fitted {
        _dir: dir,
        round,
        store,
        out,
        fit,
    }
}

fn ideal() -> &'static Fitted {
    static F: OnceLock<Fitted> = OnceLock::new();
    F.get_or_init(|| prepare(&["--ideal"]))
}

fn realistic() -> &'static Fitted {
    static F: OnceLock<Fitted> = OnceLock::new();
    F.get_or_init(|| prepare(&[]))
}

/// A demo round with every quirk of real rounds on (`QuirksConfig::all`: older-round files at
/// 50 Hz with loose load control, SR only and radii in a wrong unit, no channel struct; 16 psi
/// and loads off the standard list; de-identified slip angles and loads; run-order drift: the
/// pressure tested first on a fresher, stiffer tire; the rig's slip-angle turnarounds with their
/// ringing), default realism. Under drift each pressure's truth `.tir` is the tire as that
/// pressure's block of runs saw it (`synth::drift`), which is what the per-pressure fits are
/// judged against.
fn quirked() -> &'static Fitted {
    static F: OnceLock<Fitted> = OnceLock::new();
    F.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("quirks.toml");
        std::fs::write(
            &config,
            "[synth.quirks]\nolder_round = true\nload_swing_frac = 0.2\n\
             nonstandard_levels = true\nsa_scale = 0.8125\nload_scale = 1.15\n\
             rig_turnaround = true\n\
             [synth.quirks.drift]\nmu_frac = 0.06\nstiffness_frac = 0.06\n",
        )
        .unwrap();
        prepare(&["--config", p(&config)])
    })
}

/// A demo round with the older-round quirk alone (standard levels): raw files whose many idle
/// free-rolling crossings at one light load must not set the effective-radius law of the
/// derived kappa.
fn older_round() -> &'static Fitted {
    static F: OnceLock<Fitted> = OnceLock::new();
    F.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("quirks.toml");
        std::fs::write(&config, "[synth.quirks]\nolder_round = true\n").unwrap();
        prepare(&["--config", p(&config)])
    })
}

fn read_table(out: &Path, name: &str) -> DataFrame {
    let path = out.join(format!("{name}.parquet"));
    let file = std::fs::File::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    ParquetReader::new(file).finish().unwrap()
}

fn model(path: &Path) -> TirFile {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    TirFile::parse(&text).unwrap().0
}

/// Group file name -> operating points of the tested envelope: every force-clean cornering,
/// drive/brake and combined segment at its nominal load, inclination (and held slip angle),
/// over the slip range it covered.
fn tested_envelope(store: &Path) -> BTreeMap<String, Vec<SlipInput>> {
    let sql = format!(
        "SELECT tire, rim_in, pressure_kpa_nom, {ENVELOPE_COLUMNS} FROM segments WHERE {ENVELOPE_WHERE}"
    );
    let o = tirebase(&["query", "--store", p(store), "--format", "csv", &sql]);
    ok(&o, "query");
    let mut reader = csv::Reader::from_reader(o.stdout.as_slice());
    let mut out: BTreeMap<String, Vec<SlipInput>> = BTreeMap::new();
    for rec in reader.records() {
        let r = rec.unwrap();
        let num = |i: usize| r[i].parse::<f64>().unwrap_or(f64::NAN);
        let name = tir_file_name(&r[0], num(1), num(2));
        out.entry(name).or_default().extend(envelope_points(&r, 3));
    }
    out
}

/// Check every written model against its truth; returns the worst (Fx, Fy, Mz) errors.
fn check_models(f: &Fitted, limits: [f64; 3]) -> [f64; 3] {
    let envelope = tested_envelope(&f.store);
    let truth_dir = f.round.join("truth/tir");
    let mut truths: Vec<String> = std::fs::read_dir(&truth_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    truths.sort();
    // 4 tire/rim combinations x 2 pressures.
    assert_eq!(truths.len(), 8, "{truths:?}");
    let mut worst = [0.0_f64; 3];
    let mut failures = Vec::new();
    for name in &truths {
        let fitted = f.out.join("tir").join(name);
        assert!(fitted.exists(), "no fitted {name}");
        let (t, m) = (model(&truth_dir.join(name)), model(&fitted));
        let points = &envelope[name];
        let e = t.model().rms_error_pct_of_peak(&m.model(), points, None);
        eprintln!(
            "{name}: USE_MODE {:?}, {} envelope points: Fx {:.4} %, Fy {:.4} %, Mz {:.4} % of peak",
            m.use_mode,
            points.len(),
            e[0],
            e[1],
            e[2]
        );
        for k in 0..3 {
            worst[k] = worst[k].max(e[k]);
            if e[k] > limits[k] {
                failures.push(format!(
                    "{name}: {} {:.4} % > {} %",
                    ["Fx", "Fy", "Mz"][k],
                    e[k],
                    limits[k]
                ));
            }
        }
    }
    eprintln!(
        "worst: Fx {:.4} %, Fy {:.4} %, Mz {:.4} %",
        worst[0], worst[1], worst[2]
    );
    assert!(failures.is_empty(), "{failures:#?}");
    worst
}

/// Issue 5, Done when 1: ideal round, 0.1 % of peak.
#[test]
fn ideal_round_reproduces_the_truth_models_issue_5() {
    let f = ideal();
    assert_eq!(f.fit.status.code(), Some(0), "fit exit code");
    check_models(f, [0.1, 0.1, 0.1]);
}

/// Issue 17: `tir score` on an ideal round: the truth model of one (tire, rim, pressure)
/// reproduces that rim's measured samples (RMSE under 1 % of the measured RMS), the truth of
/// another pressure does not, and asking for one pressure scores the same samples as the
/// whole-file run. `--rim-in` keeps the files of the tire's other rims (other models) out: the
/// demo round's first tire is tested on two rims.
#[test]
fn tir_score_separates_the_truth_from_another_pressures_model_issue_17() {
    let f = ideal();
    let truth_dir = f.round.join("truth/tir");
    let groups = tirebase(&[
        "query",
        "--store",
        p(&f.store),
        "--format",
        "csv",
        "SELECT DISTINCT tire, rim_in, pressure_kpa_nom FROM segments WHERE kind = 'cornering' \
         ORDER BY tire, rim_in, pressure_kpa_nom",
    ]);
    ok(&groups, "query");
    let mut reader = csv::Reader::from_reader(groups.stdout.as_slice());
    let groups: Vec<(String, i64, i64)> = reader
        .records()
        .map(|r| {
            let r = r.unwrap();
            (
                r[0].to_string(),
                r[1].parse().unwrap(),
                r[2].parse().unwrap(),
            )
        })
        .collect();
    let (tire, rim, pressure) = groups[0].clone();
    let other = groups
        .iter()
        .find(|g| g.0 == tire && g.1 == rim && g.2 != pressure)
        .expect("a second pressure of the same tire and rim")
        .2;
    let score = |model_pressure: i64, only: Option<i64>| -> Vec<Vec<String>> {
        let tir = truth_dir.join(tir_file_name(&tire, rim as f64, model_pressure as f64));
        let only = only.map(|p| p.to_string());
        let rim_arg = rim.to_string();
        let mut args = vec![
            "tir",
            "score",
            "--store",
            p(&f.store),
            "--tir",
            p(&tir),
            "--tire",
            &tire,
            "--rim-in",
            &rim_arg,
        ];
        if let Some(only) = &only {
            args.extend(["--pressure-kpa", only.as_str()]);
        }
        let o = tirebase(&args);
        ok(&o, "tir score");
        let mut r = csv::Reader::from_reader(o.stdout.as_slice());
        assert_eq!(
            r.headers().unwrap().iter().collect::<Vec<_>>(),
            [
                "tire",
                "rim_in",
                "source_file",
                "pressure_kpa_nom",
                "n_samples",
                "fx_rmse_n",
                "fy_rmse_n",
                "mz_rmse_nm",
                "fx_rms_n",
                "fy_rms_n",
                "mz_rms_nm"
            ]
        );
        r.records()
            .map(|rec| rec.unwrap().iter().map(str::to_string).collect())
            .collect()
    };
    let num = |row: &Vec<String>, i: usize| row[i].parse::<f64>().unwrap();
    let all = score(pressure, None);
    let own = score(pressure, Some(pressure));
    let wrong = score(other, Some(pressure));
    assert!(!own.is_empty());
    assert!(own.iter().all(|r| r[3] == pressure.to_string()));
    // Every row names the rim its samples were measured on.
    for rows in [&all, &own, &wrong] {
        assert!(rows.iter().all(|r| r[1] == rim.to_string()), "{rows:?}");
    }
    // The rows are the files of this tire on this rim, none of another rim.
    let files = tirebase(&[
        "query",
        "--store",
        p(&f.store),
        "--format",
        "csv",
        &format!(
            "SELECT DISTINCT source_file FROM samples WHERE tire = '{tire}' AND rim_in = {rim} \
             ORDER BY source_file"
        ),
    ]);
    ok(&files, "query");
    let mut reader = csv::Reader::from_reader(files.stdout.as_slice());
    let files: Vec<String> = reader
        .records()
        .map(|r| r.unwrap()[0].to_string())
        .collect();
    let mut scored: Vec<String> = all.iter().map(|r| r[2].clone()).collect();
    scored.dedup();
    assert_eq!(scored, files, "{tire} on {rim} in: the files scored");
    for row in &own {
        let same = all
            .iter()
            .find(|r| r[2] == row[2] && r[3] == row[3])
            .expect("the whole-file score has the row");
        assert_eq!(
            same, row,
            "one pressure or all: the same samples and errors"
        );
        let bad = wrong.iter().find(|r| r[2] == row[2]).expect("same row");
        eprintln!(
            "{} at {pressure} kPa: truth Fy RMSE {} N, {other} kPa truth {} N (RMS {} N, {} samples)",
            row[2], row[6], bad[6], row[9], row[4]
        );
        if num(row, 9) > 100.0 {
            assert!(num(row, 6) < 0.01 * num(row, 9), "{row:?}");
            assert!(num(bad, 6) > 2.0 * num(row, 6), "{bad:?} vs {row:?}");
        }
    }
}

/// Issue 5, Done when 2: default realism (noise, lag, heat): 2 % Fx/Fy, 5 % Mz.
#[test]
fn realistic_round_within_2_percent_forces_5_percent_mz_issue_5() {
    let f = realistic();
    assert_eq!(f.fit.status.code(), Some(0), "fit exit code");
    check_models(f, [2.0, 2.0, 5.0]);
    // Every written file lints without errors.
    let lint = read_table(&f.out, "lint");
    let errors: Vec<String> = strs(&lint, "severity")
        .into_iter()
        .zip(strs(&lint, "message"))
        .filter(|(s, _)| s == "error")
        .map(|(_, m)| m)
        .collect();
    assert!(errors.is_empty(), "{errors:#?}");
    // ... and so does `tirebase tir lint` on the files as written (exit 0: no errors).
    for entry in std::fs::read_dir(f.out.join("tir")).unwrap() {
        let path = entry.unwrap().path();
        let o = tirebase(&["tir", "lint", p(&path)]);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stdout)
        );
    }
    let q = read_table(&f.out, "fit_quality");
    let models = strs(&q, "model");
    let pac2002 = models.iter().filter(|m| *m == "pac2002").count();
    assert_eq!(pac2002, 8 * 7, "7 fitted channels per PAC2002 model: {q}");
    // One MF 6.1 model per tire and rim, its 7 families at each of the 2 tested pressures.
    let mf61 = models.iter().filter(|m| *m == "mf61").count();
    assert_eq!(mf61, 4 * 2 * 7, "{q}");
}

/// A demo round whose rig adds a 20 ms pure delay to the load cell's channels
/// (`[synth.realism] measurement_delay_s`), default realism otherwise.
fn rig_lagged() -> &'static Fitted {
    static F: OnceLock<Fitted> = OnceLock::new();
    F.get_or_init(|| {
        prepare_configured(&format!(
            "[synth.realism]\nmeasurement_delay_s = {RIG_LAG_S}\n"
        ))
    })
}

/// A demo round whose load cell's channels pass through a 20 ms first-order filter
/// (`[synth.realism] measurement_filter_s`), fitted with `measurement_lag_form = "first_order"`.
fn rig_filtered() -> &'static Fitted {
    static F: OnceLock<Fitted> = OnceLock::new();
    F.get_or_init(|| {
        prepare_configured(&format!(
            "[synth.realism]\nmeasurement_filter_s = {RIG_LAG_S}\n\
             [fit.relaxation]\nmeasurement_lag_form = \"first_order\"\n"
        ))
    })
}

/// A demo round made and fitted with the configuration `toml` (its `[synth]` tables shape the
/// round, its `[fit]` tables the fit).
fn prepare_configured(toml: &str) -> Fitted {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("round.toml");
    std::fs::write(&config, toml).unwrap();
    prepare_with(&["--config", p(&config)], &["--config", p(&config)])
}

/// The rig delay of [`rig_lagged`] and filter time constant of [`rig_filtered`], s.
const RIG_LAG_S: f64 = 0.02;

/// Issue 18, Done when 1 (rig lag): where a tire was swept at two or more speeds at one load
/// (the round-9 plan: 15, 25 and 45 mph at 250 lb) the relaxation stage separates the rig's
/// 20 ms delay from the tire's relaxation length by the speeds; where every sweep ran at one
/// speed (round 4: 25 mph) it takes the lag from the spring-rate holds' load steps. Either way
/// every row says the lag was separated (and how, in its note) and has the lag within 10 % and
/// sigma within 10 % of the truth. The steady-state fit, de-lagged with both, stays within 2 %
/// (Fx, Fy) and 5 % (Mz) of truth.
#[test]
fn rig_lag_is_separated_from_relaxation_with_two_speeds_issue_18() {
    check_rig_lag(rig_lagged(), "delay");
}

/// The same with a first-order filter in the load cell's chain and the stage's lag form set to
/// match: one-speed groups take the filter's time constant from the load steps.
#[test]
fn rig_filter_is_separated_from_relaxation_by_the_load_steps_issue_18() {
    check_rig_lag(rig_filtered(), "filter");
}

fn check_rig_lag(f: &Fitted, what: &str) {
    assert_eq!(f.fit.status.code(), Some(0), "fit exit code");
    let rx = read_table(&f.out, "relaxation");
    let (rt, rr, rp, dir, method) = (
        strs(&rx, "tire"),
        f64s(&rx, "rim_in"),
        f64s(&rx, "pressure_kpa"),
        strs(&rx, "direction"),
        strs(&rx, "method"),
    );
    let (fz, fz_nom, sigma, v) = (
        f64s(&rx, "fz_n_mean"),
        f64s(&rx, "fz_n_nom"),
        f64s(&rx, "sigma_m"),
        f64s(&rx, "speed_kph"),
    );
    let (lag, note) = (f64s(&rx, "measurement_lag_s"), strs(&rx, "lag_note"));
    let separated: Vec<bool> = rx
        .column("lag_separated")
        .unwrap()
        .bool()
        .unwrap()
        .iter()
        .map(|b| b.unwrap())
        .collect();
    let group = |k: usize| tir_file_name(&rt[k], rr[k], rp[k]);
    // The groups with sweeps of one direction and load at two or more speeds (4 km/h bins).
    let mut speeds: BTreeMap<(String, String, i64), Vec<i64>> = BTreeMap::new();
    for k in (0..rx.height()).filter(|&k| method[k] == "sweep") {
        let bin = (v[k] / 4.0).round() as i64;
        let e = speeds
            .entry((group(k), dir[k].clone(), fz_nom[k] as i64))
            .or_default();
        if !e.contains(&bin) {
            e.push(bin);
        }
    }
    let two_speeds: std::collections::BTreeSet<String> = speeds
        .iter()
        .filter(|(_, s)| s.len() >= 2)
        .map(|(key, _)| key.0.clone())
        .collect();
    let mut worst = BTreeMap::new();
    let mut failures = Vec::new();
    for k in 0..rx.height() {
        let name = group(k);
        let truth = model(&f.round.join("truth/tir").join(&name)).model();
        let (sk, sa) = truth.relaxation_lengths(fz[k], 0.0);
        let t = if dir[k] == "lateral" { sa } else { sk };
        let e = sigma[k] / t - 1.0;
        let e_lag = lag[k] / RIG_LAG_S - 1.0;
        let row = format!(
            "{name} {} {} at {:.0} N, {:.0} km/h: lag {:.4} s ({:+.2} %), sigma {:.4} m \
             (truth {:.4} m, {:+.2} %): {}",
            dir[k],
            method[k],
            fz[k],
            v[k],
            lag[k],
            100.0 * e_lag,
            sigma[k],
            t,
            100.0 * e,
            note[k]
        );
        let by = if two_speeds.contains(&name) {
            "speeds"
        } else {
            "load steps"
        };
        let from_steps = note[k].starts_with("identified from the load steps");
        if !separated[k] || from_steps == (by == "speeds") {
            failures.push(format!(
                "separated {} (expected by {by}): {row}",
                separated[k]
            ));
        }
        let w = worst.entry(by).or_insert((0usize, 0.0_f64, 0.0_f64));
        *w = (w.0 + 1, w.1.max(e_lag.abs()), w.2.max(e.abs()));
        if e_lag.abs() >= 0.1 || e.abs() >= 0.1 {
            failures.push(row);
        }
    }
    eprintln!(
        "rig {what}: {} rows; by separation method (rows, worst lag error, worst sigma error): \
         {worst:?}",
        rx.height()
    );
    assert!(failures.is_empty(), "{failures:#?}");
    assert!(
        worst.contains_key("speeds") && worst.contains_key("load steps"),
        "both methods exercised: {worst:?}"
    );
    check_models(f, [2.0, 2.0, 5.0]);
}

/// Issue 17, Done when 1: with every quirk of real rounds on, the fitted models are within 2 %
/// (Fx, Fy) and 5 % (Mz) of truth over the tested envelope, as on the clean round.
#[test]
fn quirked_round_within_2_percent_forces_5_percent_mz_issue_17() {
    let f = quirked();
    assert_eq!(f.fit.status.code(), Some(0), "fit exit code");
    check_models(f, [2.0, 2.0, 5.0]);
}

/// Issue 18, Done when 1 (out of sample) on the every-quirk round: every `fit_quality` row, of
/// both models, predicts its held-out sweeps within 20 % of its in-sample RMSE
/// (`oos_ratio <= 1.2`) and none is flagged. The loose load control's swing puts the up and down
/// passes of a sweep at different loads; the fit predicts each collapsed point by the mean of the
/// model at the two passes' operating points (`fit::pac2002::collapse::BranchInputs`). An MF 6.1
/// row is one (tire, rim, tested pressure, family) of the joint fit over the pressures, its folds
/// by sweep across them.
#[test]
fn quirked_round_out_of_sample_within_20_percent_issue_18() {
    let f = quirked();
    assert_eq!(f.fit.status.code(), Some(0), "fit exit code");
    let q = read_table(&f.out, "fit_quality");
    let (model, tire, rim, pressure, channel) = (
        strs(&q, "model"),
        strs(&q, "tire"),
        f64s(&q, "rim_in"),
        f64s(&q, "pressure_kpa"),
        strs(&q, "channel"),
    );
    let (ratio, flag) = (f64s(&q, "oos_ratio"), strs(&q, "oos_flag"));
    let mut rows: BTreeMap<&str, usize> = BTreeMap::new();
    let mut failures = Vec::new();
    for i in 0..model.len() {
        *rows.entry(model[i].as_str()).or_default() += 1;
        let what = format!(
            "{} {} on {} in rim {} kPa {}: oos_ratio {:.4}, oos_flag {}",
            model[i], tire[i], rim[i], pressure[i], channel[i], ratio[i], flag[i]
        );
        eprintln!("{what}");
        if !(ratio[i].is_finite() && ratio[i] <= 1.2) || flag[i] != "false" {
            failures.push(what);
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
    // 4 (tire, rim) x 2 pressures x 7 families, for each model.
    let expected = BTreeMap::from([("mf61", 4 * 2 * 7), ("pac2002", 4 * 2 * 7)]);
    assert_eq!(rows, expected, "{q}");
}

/// The same with the older-round quirk alone (SR only, 50 Hz, loose load control, radii in a
/// wrong unit, at the standard levels).
#[test]
fn older_round_within_2_percent_forces_5_percent_mz_issue_17() {
    let f = older_round();
    assert_eq!(f.fit.status.code(), Some(0), "fit exit code");
    check_models(f, [2.0, 2.0, 5.0]);
}

/// The truth TOML of a tire/rim: (pressure_kpa_nom -> table) and the thermal table.
fn truth_toml(round: &Path, tire: &str, rim_in: i64) -> toml::Table {
    let stem = tirebase::core::naming::tire_rim_stem(tire, rim_in as f64);
    let text = std::fs::read_to_string(round.join(format!("truth/{stem}.toml"))).unwrap();
    toml::from_str(&text).unwrap()
}

fn pressure_table(t: &toml::Table, pressure_kpa: i64) -> toml::Table {
    t["pressure"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_table().unwrap().clone())
        .find(|p| (p["pressure_kpa_nom"].as_float().unwrap() - pressure_kpa as f64).abs() < 0.5)
        .unwrap()
}

fn num(t: &toml::Table, key: &str) -> f64 {
    t[key]
        .as_float()
        .or_else(|| t[key].as_integer().map(|i| i as f64))
        .unwrap()
}

/// Issue 6 tolerances through the command (the stage math is checked in tirebase-core).
#[test]
fn realistic_round_meets_the_issue_6_tolerances() {
    let f = realistic();
    let round = &f.round;
    let reference_mps = 11.176;

    // Spring rate: every row within 1 % / 0.5 mm of the truth at its speed.
    let sr = read_table(&f.out, "spring_rate");
    assert!(sr.height() >= 4 * 3, "{sr}");
    let (tires, rims, ps) = (
        strs(&sr, "tire"),
        f64s(&sr, "rim_in"),
        f64s(&sr, "pressure_kpa"),
    );
    let (cond, cz, r0, v) = (
        strs(&sr, "condition"),
        f64s(&sr, "stiffness_n_per_m"),
        f64s(&sr, "unloaded_radius_m"),
        f64s(&sr, "speed_kph"),
    );
    let mut worst = (0.0_f64, 0.0_f64);
    for k in 0..sr.height() {
        let t = pressure_table(&truth_toml(round, &tires[k], rims[k] as i64), ps[k] as i64);
        let u = if cond[k] == "static" {
            0.0
        } else {
            v[k] / 3.6 / reference_mps
        };
        let cz_s = num(&t, "vertical_stiffness_static_n_per_m");
        let cz_t = cz_s + (num(&t, "vertical_stiffness_dynamic_n_per_m") - cz_s) * u;
        let r0_s = num(&t, "unloaded_radius_static_m");
        let r0_t = r0_s + (num(&t, "unloaded_radius_dynamic_m") - r0_s) * u * u;
        let (e_cz, e_r0) = (cz[k] / cz_t - 1.0, r0[k] - r0_t);
        worst = (worst.0.max(e_cz.abs()), worst.1.max(e_r0.abs()));
        assert!(
            e_cz.abs() < 0.01 && e_r0.abs() < 0.5e-3,
            "{} {} kPa {}: Cz {:+.3} %, R0 {:+.3} mm",
            tires[k],
            ps[k],
            cond[k],
            100.0 * e_cz,
            1e3 * e_r0
        );
    }
    eprintln!(
        "spring rate worst: Cz {:.3} %, R0 {:.3} mm over {} rows",
        100.0 * worst.0,
        1e3 * worst.1,
        sr.height()
    );

    // The .tir carries the dynamic Cz and R0 and relaxation laws within 5 % at tested loads.
    let rx = read_table(&f.out, "relaxation");
    assert!(rx.height() > 0);
    let (rt, rr, rp, dir) = (
        strs(&rx, "tire"),
        f64s(&rx, "rim_in"),
        f64s(&rx, "pressure_kpa"),
        strs(&rx, "direction"),
    );
    let (fz, sigma, sigma_law) = (
        f64s(&rx, "fz_n_mean"),
        f64s(&rx, "sigma_m"),
        f64s(&rx, "sigma_law_m"),
    );
    let mut worst_sigma = 0.0_f64;
    for k in 0..rx.height() {
        let name = tir_file_name(&rt[k], rr[k], rp[k]);
        let truth = model(&round.join("truth/tir").join(&name)).model();
        let fitted = model(&f.out.join("tir").join(&name)).model();
        let pick = |(sk, sa): (f64, f64)| if dir[k] == "lateral" { sa } else { sk };
        let t = pick(truth.relaxation_lengths(fz[k], 0.0));
        let in_tir = pick(fitted.relaxation_lengths(fz[k], 0.0));
        let errs = [sigma[k] / t - 1.0, sigma_law[k] / t - 1.0, in_tir / t - 1.0];
        for e in errs {
            worst_sigma = worst_sigma.max(e.abs());
        }
        assert!(
            errs.iter().all(|e| e.abs() < 0.05),
            "{name} {} at {:.0} N: sigma {:+.2} %, law {:+.2} %, .tir {:+.2} %",
            dir[k],
            fz[k],
            100.0 * errs[0],
            100.0 * errs[1],
            100.0 * errs[2]
        );
    }
    eprintln!(
        "relaxation worst |error| (rows, law, .tir): {:.2} % over {} rows",
        100.0 * worst_sigma,
        rx.height()
    );
    for entry in std::fs::read_dir(f.out.join("tir")).unwrap() {
        let path = entry.unwrap().path();
        if path.to_string_lossy().ends_with("__mf61.tir") {
            continue; // the truth is per pressure
        }
        let m = model(&path);
        let truth = model(&round.join("truth/tir").join(path.file_name().unwrap()));
        let (cz, r0) = (
            m.coefs[Coef::VERTICAL_STIFFNESS],
            m.coefs[Coef::UNLOADED_RADIUS],
        );
        let (cz_t, r0_t) = (
            truth.coefs[Coef::VERTICAL_STIFFNESS],
            truth.coefs[Coef::UNLOADED_RADIUS],
        );
        assert!(
            (cz / cz_t - 1.0).abs() < 0.01 && (r0 - r0_t).abs() < 0.5e-3,
            "{}: Cz {cz} vs {cz_t}, R0 {r0} vs {r0_t}",
            path.display()
        );
        assert_eq!(m.use_mode, Some(14), "{}", path.display());
        let ip_nom = m.pressure.nominal_pa.unwrap();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            name.contains(&format!("__{:.0}kPa", ip_nom / 1e3)),
            "{name}"
        );
    }

    // Thermal: mu(T) peak temperature within 3 degC and gain within 3 %.
    let th = read_table(&f.out, "thermal_fit");
    assert_eq!(th.height(), 8, "{th}");
    let (tt, tr) = (strs(&th, "tire"), f64s(&th, "rim_in"));
    let (t_peak, gain) = (f64s(&th, "t_peak_c"), f64s(&th, "gain_peak_over_cold"));
    for k in 0..th.height() {
        let truth = truth_toml(round, &tt[k], tr[k] as i64);
        let thermal = truth["thermal"].as_table().unwrap();
        let (tp, g) = (
            num(thermal, "t_peak_c"),
            num(thermal, "gain_peak_over_cold"),
        );
        eprintln!(
            "thermal {}: T_peak {:.2} vs {tp} degC, gain {:.4} vs {g} ({:+.2} %)",
            tt[k],
            t_peak[k],
            gain[k],
            100.0 * (gain[k] / g - 1.0)
        );
        assert!(
            (t_peak[k] - tp).abs() < 3.0,
            "{}: T_peak {}",
            tt[k],
            t_peak[k]
        );
        assert!(
            (gain[k] / g - 1.0).abs() < 0.03,
            "{}: gain {}",
            tt[k],
            gain[k]
        );
    }
}

/// Every table except the wall-time column, and the `.tir` bytes.
fn outputs(out: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut files = BTreeMap::new();
    for entry in std::fs::read_dir(out).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        if let Some(table) = name.strip_suffix(".parquet") {
            let mut df = read_table(out, table);
            if table == "fit_quality" {
                df = df.drop("seconds").unwrap();
            }
            let mut bytes = Vec::new();
            CsvWriter::new(&mut bytes).finish(&mut df).unwrap();
            files.insert(name, bytes);
        }
    }
    // No tir/ when the PAC2002 stage did not run.
    for entry in std::fs::read_dir(out.join("tir")).into_iter().flatten() {
        let path = entry.unwrap().path();
        files.insert(
            format!("tir/{}", path.file_name().unwrap().to_string_lossy()),
            std::fs::read(&path).unwrap(),
        );
    }
    files
}

/// `fit FLAGS` of `f`'s store again, into a new temp directory, asserted to succeed: the
/// directory (the caller keeps it alive) and the output directory in it.
fn refit(f: &Fitted, flags: &[&str]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut args = vec!["fit", "--store", p(&f.store), "--out", p(&out)];
    args.extend_from_slice(flags);
    ok(&tirebase(&args), &format!("fit {}", flags.join(" ")));
    (dir, out)
}

#[test]
fn jobs_1_and_jobs_2_give_identical_outputs() {
    let f = ideal();
    let (_dir, out1) = refit(f, &["--jobs", "1"]);
    let (a, b) = (outputs(&out1), outputs(&f.out));
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    assert_eq!(
        a.len(),
        8 + 8 + 4,
        "8 tables, 8 PAC2002 and 4 MF 6.1 .tir files: {:?}",
        a.keys()
    );
    for (name, bytes) in &a {
        assert!(bytes == &b[name], "{name} differs between --jobs 1 and 2");
    }
}

/// `--stages thermal` reads what the full fit reads for the thermal stage (the cold-to-warm
/// tests and the air temperature of every classified segment, the gain's cold reference), so
/// its tables are the full fit's.
#[test]
fn thermal_alone_writes_the_full_fits_thermal_tables() {
    let f = realistic();
    let (_dir, out) = refit(f, &["--stages", "thermal"]);
    let (alone, full) = (outputs(&out), outputs(&f.out));
    for table in ["thermal.parquet", "thermal_fit.parquet"] {
        assert!(
            alone[table] == full[table],
            "{table} differs from the full fit's"
        );
    }
}

/// A stage's result does not depend on which other stages were asked for: `--stages pac2002`
/// runs what its model depends on (spring rate for Cz/R0, relaxation for the de-lag lengths,
/// thermal for the grip-temperature correction, each on the segments the full fit gives it), so
/// its PAC2002 and MF 6.1 models are the full fit's but for what the relaxation stage writes
/// into them (the coefficients of family `relaxation`, and the `USE_MODE` that counts its laws).
#[test]
fn pac2002_alone_writes_the_full_fits_models() {
    let f = realistic();
    let (_dir, out) = refit(f, &["--stages", "pac2002"]);
    let full_coefficients = read_table(&f.out, "coefficients");
    let mut relaxation_names: Vec<String> = strs(&full_coefficients, "family")
        .into_iter()
        .zip(strs(&full_coefficients, "name"))
        .filter(|(family, _)| family == "relaxation")
        .map(|(_, name)| name)
        .collect();
    relaxation_names.extend(["USE_MODE".to_string()]);
    assert!(relaxation_names.iter().any(|n| n == "PTY1"));
    // The coefficients table without the relaxation family, as CSV rows.
    let rows = |out: &Path| -> Vec<String> {
        let mut df = read_table(out, "coefficients");
        let keep = df
            .column("family")
            .unwrap()
            .str()
            .unwrap()
            .not_equal("relaxation");
        df = df.filter(&keep).unwrap();
        let mut bytes = Vec::new();
        CsvWriter::new(&mut bytes).finish(&mut df).unwrap();
        String::from_utf8(bytes)
            .unwrap()
            .lines()
            .map(str::to_string)
            .collect()
    };
    assert_eq!(rows(&out), rows(&f.out), "coefficients");
    let without_relaxation = |bytes: &[u8]| -> Vec<String> {
        String::from_utf8_lossy(bytes)
            .lines()
            .filter(|l| {
                let key = l.split_whitespace().next().unwrap_or("");
                !relaxation_names.iter().any(|n| n == key)
            })
            .map(str::to_string)
            .collect()
    };
    let (alone, full) = (outputs(&out), outputs(&f.out));
    let tirs: Vec<&String> = full.keys().filter(|k| k.starts_with("tir/")).collect();
    assert_eq!(
        alone
            .keys()
            .filter(|k| k.starts_with("tir/"))
            .collect::<Vec<_>>(),
        tirs
    );
    for name in tirs {
        let (a, b) = (
            without_relaxation(&alone[name]),
            without_relaxation(&full[name]),
        );
        assert_eq!(a.len(), b.len(), "{name}: line count");
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x, y, "{name} differs from the full fit's");
        }
    }
    assert!(
        alone["fit_quality.parquet"] == full["fit_quality.parquet"],
        "fit_quality differs from the full fit's"
    );
}

/// `--stages relaxation` runs the fits and the grip law its lengths depend on: its table is the
/// full fit's.
#[test]
fn relaxation_alone_writes_the_full_fits_relaxation_table() {
    let f = realistic();
    let (_dir, out) = refit(f, &["--stages", "relaxation"]);
    assert!(
        outputs(&out)["relaxation.parquet"] == outputs(&f.out)["relaxation.parquet"],
        "relaxation.parquet differs from the full fit's"
    );
}

/// Flag every force segment of one tire, rim and pressure with a zeroed lateral force (a QC
/// flag that spoils forces), as a segmenter would for a bad test; returns how many were flagged.
fn flag_force_segments(store: &Path, tire: &str, rim_in: i64, pressure_kpa: i64) -> usize {
    flag_segments(store, "zeroed_channel:fy_n", |df| {
        (0..df.height())
            .map(|i| {
                let s = |c: &str| df.column(c).unwrap().get(i).unwrap().to_string();
                s("tire").trim_matches('"') == tire
                    && s("rim_in") == rim_in.to_string()
                    && s("pressure_kpa_nom") == pressure_kpa.to_string()
                    && ["cornering", "drive_brake", "combined"]
                        .contains(&s("kind").trim_matches('"'))
            })
            .collect()
    })
}

#[test]
fn a_failed_group_is_reported_and_the_others_are_written() {
    let f = ideal();
    let dir = tempfile::tempdir().unwrap();
    let (store, out) = (dir.path().join("store"), dir.path().join("out"));
    copy_tree(&f.store, &store);
    let tire = "Hoosier 16.0x7.5-10 R25B";
    let n = flag_force_segments(&store, tire, 7, 69);
    assert!(n > 20, "flagged {n}");
    let o = tirebase(&["fit", "--store", p(&store), "--out", p(&out), "--jobs", "2"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains(&format!("failed: {tire} on 7 in rim at 69 kPa: pac2002")),
        "{stderr}"
    );
    let failures = read_table(&out, "fit_failures");
    let group = |df: &DataFrame| -> Vec<String> {
        strs(df, "tire")
            .into_iter()
            .zip(strs(df, "rim_in"))
            .zip(strs(df, "pressure_kpa"))
            .map(|((t, r), p)| format!("{t} {r} {p}"))
            .collect()
    };
    let failed = format!("{tire} 7 69");
    let fatal: Vec<(String, String)> = group(&failures)
        .into_iter()
        .zip(strs(&failures, "stage"))
        .zip(strs(&failures, "fatal"))
        .filter(|(_, fatal)| fatal == "true")
        .map(|((g, s), _)| (g, s))
        .collect();
    assert!(
        fatal.contains(&(failed.clone(), "pac2002".to_string())),
        "{fatal:?}"
    );
    assert!(fatal.iter().all(|(g, _)| g == &failed), "{fatal:?}");
    let mut tirs: Vec<String> = std::fs::read_dir(out.join("tir"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with("kPa.tir"))
        .collect();
    tirs.sort();
    assert_eq!(tirs.len(), 7, "{tirs:?}");
    assert!(!tirs.contains(&tir_file_name(tire, 7.0, 69.0)));
    // The failed group's other stages still ran: its spring-rate holds and thermal test.
    for table in ["spring_rate", "thermal_fit"] {
        let groups = group(&read_table(&out, table));
        assert!(groups.contains(&failed), "{table}: {groups:?}");
    }
    let groups: std::collections::BTreeSet<String> = group(&read_table(&out, "coefficients"))
        .into_iter()
        .collect();
    assert_eq!(groups.len(), 7, "{groups:?}");
    assert!(!groups.contains(&failed));
}

#[test]
fn bad_stage_names_and_empty_stores_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("store");
    let out = dir.path().join("out");
    let o = tirebase(&[
        "fit",
        "--store",
        p(&store),
        "--out",
        p(&out),
        "--stages",
        "pac",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown stage 'pac'"));
    let o = tirebase(&["fit", "--store", p(&store), "--out", p(&out)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("not a tirebase store"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Issue 5: families without data are left out and USE_MODE says so (a tire tested on
/// drive/brake only: pure and combined Fx, USE_MODE 1), and that is not a failure.
#[test]
fn drive_brake_only_group_is_written_with_use_mode_1() {
    let f = ideal();
    let dir = tempfile::tempdir().unwrap();
    let (raw, store, out) = (
        dir.path().join("raw"),
        dir.path().join("store"),
        dir.path().join("out"),
    );
    std::fs::create_dir_all(&raw).unwrap();
    // B2410run2.dat: the 20.5 in tire at 83 kPa, drive/brake and combined sweeps.
    std::fs::copy(f.round.join("raw/B2410run2.dat"), raw.join("B2410run2.dat")).unwrap();
    ingest(&raw, &store, Some(&f.round.join("catalog.toml")));
    let o = tirebase(&["fit", "--store", p(&store), "--out", p(&out), "--jobs", "1"]);
    ok(&o, "fit");
    let name = tir_file_name("Hoosier 20.5x7.0-13 R25B", 7.0, 83.0);
    let m = model(&out.join("tir").join(&name));
    assert_eq!(m.use_mode, Some(1), "{name}");
    let q = read_table(&out, "fit_quality");
    let channels = |model: &str| -> Vec<String> {
        strs(&q, "channel")
            .into_iter()
            .zip(strs(&q, "model"))
            .filter(|(_, m)| m == model)
            .map(|(c, _)| c)
            .collect()
    };
    assert_eq!(channels("pac2002"), ["Fx0", "Fx"], "{q}");
    // MF 6.1 refines what the data identify: without cornering sweeps neither the pure lateral
    // families nor those built on Fy0 (combined Fy, Mz, Mx).
    assert_eq!(channels("mf61"), ["Fx0", "Fx"], "{q}");
}

/// Issue 18: the geometry a `.tir` states is known or left out, never 0, and no coefficient
/// sits on a bound without a row saying why. Every model of the demo round (tire sizes in the
/// names: WIDTH, ASPECT_RATIO and RIM_RADIUS from the size, RIM_WIDTH from the rim) and one of a
/// tire whose name states no size (those three left out) are checked; every coefficient row at
/// a bound has a note naming the bound and its meaning, every held one a note saying why.
#[test]
fn geometry_is_known_or_left_out_and_every_bound_is_explained_issue_18() {
    let f = realistic();
    let geometry = [
        Coef::WIDTH,
        Coef::ASPECT_RATIO,
        Coef::RIM_RADIUS,
        Coef::RIM_WIDTH,
    ];
    let (mut files, mut mf61_files) = (0, 0);
    for entry in std::fs::read_dir(f.out.join("tir")).unwrap() {
        let path = entry.unwrap().path();
        if path.to_string_lossy().ends_with("__mf61.tir") {
            mf61_files += 1;
        }
        let m = model(&path);
        for coef in geometry {
            assert!(m.present[coef], "{}: no {}", path.display(), coef.name());
            assert!(
                m.coefs[coef] > 0.0,
                "{}: {} = {}",
                path.display(),
                coef.name(),
                m.coefs[coef]
            );
        }
        let text = std::fs::read_to_string(&path).unwrap();
        for coef in geometry {
            let line = text
                .lines()
                .find(|l| l.split('=').next().map(str::trim) == Some(coef.name()))
                .unwrap();
            let value: f64 = line
                .split('=')
                .nth(1)
                .unwrap()
                .split('$')
                .next()
                .unwrap()
                .trim()
                .parse()
                .unwrap();
            assert!(value > 0.0, "{}: {line}", path.display());
        }
        files += 1;
    }
    assert_eq!(
        (files - mf61_files, mf61_files),
        (8, 4),
        "8 PAC2002 and 4 MF 6.1 .tir files"
    );
    let check_notes = |out: &Path| -> (usize, usize) {
        let c = read_table(out, "coefficients");
        let (names, origins, notes) = (strs(&c, "name"), strs(&c, "origin"), strs(&c, "note"));
        let at_bound: Vec<bool> = c
            .column("at_bound")
            .unwrap()
            .bool()
            .unwrap()
            .iter()
            .map(|b| b.unwrap())
            .collect();
        let (mut on_bound, mut held) = (0, 0);
        for k in 0..c.height() {
            if at_bound[k] {
                on_bound += 1;
                assert!(
                    notes[k].starts_with("on its ") && notes[k].contains(": "),
                    "{} on a bound without a reason: {:?}",
                    names[k],
                    notes[k]
                );
                eprintln!("{}: {}", names[k], notes[k]);
            }
            if origins[k] == "fixed" {
                held += 1;
                assert!(
                    notes[k].starts_with("held: "),
                    "{}: {:?}",
                    names[k],
                    notes[k]
                );
            }
        }
        (on_bound, held)
    };
    let (on_bound, held) = check_notes(&f.out);
    eprintln!("demo round: {on_bound} coefficients on a bound, {held} held, all explained");

    // A tire whose name states no size: WIDTH, ASPECT_RATIO, RIM_RADIUS left out, not 0.
    let dir = tempfile::tempdir().unwrap();
    let (raw, store, out) = (
        dir.path().join("raw"),
        dir.path().join("store"),
        dir.path().join("out"),
    );
    std::fs::create_dir_all(&raw).unwrap();
    std::fs::copy(f.round.join("raw/B2410run2.dat"), raw.join("B2410run2.dat")).unwrap();
    let catalog = std::fs::read_to_string(f.round.join("catalog.toml"))
        .unwrap()
        .replace("Hoosier 20.5x7.0-13 R25B", "Team test tire B");
    let catalog_path = dir.path().join("catalog.toml");
    std::fs::write(&catalog_path, catalog).unwrap();
    ingest(&raw, &store, Some(&catalog_path));
    let o = tirebase(&["fit", "--store", p(&store), "--out", p(&out), "--jobs", "1"]);
    ok(&o, "fit");
    let path = out
        .join("tir")
        .join(tir_file_name("Team test tire B", 7.0, 83.0));
    let m = model(&path);
    let text = std::fs::read_to_string(&path).unwrap();
    for coef in [Coef::WIDTH, Coef::ASPECT_RATIO, Coef::RIM_RADIUS] {
        assert!(
            !m.present[coef],
            "{}: {} written",
            path.display(),
            coef.name()
        );
        assert!(
            !text
                .lines()
                .any(|l| l.split('=').next().map(str::trim) == Some(coef.name())),
            "{}",
            coef.name()
        );
    }
    assert!((m.coefs[Coef::RIM_WIDTH] - 7.0 * 0.0254).abs() < 1e-9);
    check_notes(&out);
}
