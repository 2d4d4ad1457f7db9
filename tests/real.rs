//! Opt-in real-data check (issue 17): ingest and fit the two real, de-identified TTC files of
//! `shared/real/` through the real binary, then score the fitted PAC2002 models on the measured
//! samples of `cornering.mat` with `tirebase tir score` (the README's selection: |alpha| <=
//! 12.5 deg, Fz > 100 N, V > 5 km/h, every 5th sample) and print, per pressure, tirebase's Fy
//! and Mz RMSE beside those of the file author's MF 6.1 fit (`obfuscated_mf61.tir`).
//!
//! Ignored by default: the files are GPL, development only, and never copied into the project;
//! they are read where they lie. Run it with
//! `cargo test --test integration real_data -- --ignored --nocapture`
//! (`TIREBASE_REAL_DIR` overrides where the files are looked for; default `../shared/real` and
//! `../../shared/real` beside the checkout). Asserts what issue 17 asks: no sweep of
//! `cornering.mat` rejected as off-nominal, and at each pressure tirebase's Fy and Mz RMSE no
//! larger than the MF 6.1 fit's.

use std::path::{Path, PathBuf};

use tirebase::core::naming::tir_file_name;

use crate::harness::{csv_rows, ingest, ok, p, tirebase};

/// The MF 6.1 fit's figures from `shared/real/README.md`: (pressure kPa, Fy RMSE N, Mz RMSE N m).
const MF61_README: [(i64, f64, f64); 3] = [(69, 177.0, 14.6), (83, 158.0, 13.7), (97, 162.0, 13.3)];

/// The directory of the real files (`TIREBASE_REAL_DIR`, else `shared/real` beside or above the
/// checkout); `None`, with a note on stderr, when there is none and the check is skipped.
pub(crate) fn real_dir() -> Option<PathBuf> {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let found = std::env::var_os("TIREBASE_REAL_DIR")
        .map(PathBuf::from)
        .into_iter()
        .chain([
            manifest.join("../shared/real"),
            manifest.join("../../shared/real"),
        ])
        .find(|d| d.join("cornering.mat").is_file());
    if found.is_none() {
        eprintln!("real-data check skipped: no shared/real/cornering.mat (set TIREBASE_REAL_DIR)");
    }
    found
}

/// `(fy_rmse_n, mz_rmse_nm, fx_rmse_n, n_samples)` of `cornering.mat` at `pressure` from a
/// `tir score` output (NaN for a channel the model lacks), or the error text.
fn score(
    store: &Path,
    tir: &Path,
    tire: &str,
    pressure: i64,
) -> Result<(f64, f64, f64, usize), String> {
    let pressure_arg = pressure.to_string();
    let o = tirebase(&[
        "tir",
        "score",
        "--store",
        p(store),
        "--tir",
        p(tir),
        "--tire",
        tire,
        "--pressure-kpa",
        &pressure_arg,
    ]);
    if !o.status.success() {
        return Err(String::from_utf8_lossy(&o.stderr).trim().to_string());
    }
    let row = csv_rows(&o)
        .into_iter()
        .find(|r| r[2] == "cornering.mat")
        .ok_or_else(|| "no cornering.mat row".to_string())?;
    // an empty cell: a channel the model does not carry (NaN)
    let f = |i: usize| match row[i].as_str() {
        "" => f64::NAN,
        v => v.parse::<f64>().unwrap(),
    };
    Ok((f(6), f(7), f(5), row[4].parse().unwrap()))
}

#[test]
#[ignore = "needs the real files of shared/real/ (development only); run with --ignored"]
fn real_data_cornering_fit_against_mf61() {
    let Some(real) = real_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (store, out) = (dir.path().join("store"), dir.path().join("fit"));
    ingest(&real, &store, None);
    let fit = tirebase(&["fit", "--store", p(&store), "--out", p(&out)]);
    let fit_log = String::from_utf8_lossy(&fit.stderr).into_owned();
    let kinds = tirebase(&[
        "query",
        "--store",
        p(&store),
        "--format",
        "csv",
        "SELECT source_file, tire, rim_in, kind, COUNT(*) AS n FROM segments \
         GROUP BY source_file, tire, rim_in, kind ORDER BY source_file, kind",
    ]);
    ok(&kinds, "query segments");
    eprintln!("segments:\n{}", String::from_utf8_lossy(&kinds.stdout));
    let groups = tirebase(&[
        "query",
        "--store",
        p(&store),
        "--format",
        "csv",
        "SELECT DISTINCT tire, rim_in, pressure_kpa_nom FROM segments \
         WHERE source_file = 'cornering.mat' AND kind = 'cornering' ORDER BY pressure_kpa_nom",
    ]);
    ok(&groups, "query groups");
    let groups = csv_rows(&groups);
    assert!(!groups.is_empty(), "no cornering segment in cornering.mat");
    let rejected: Vec<&str> = fit_log
        .lines()
        .filter(|l| l.contains("cornering.mat") || l.contains("cornering_mat"))
        .filter(|l| l.contains("off-nominal"))
        .collect();
    let mf61 = real.join("obfuscated_mf61.tir");

    eprintln!(
        "pressure | tirebase PAC2002 Fy RMSE | MF 6.1 (README) | MF 6.1 (evaluated) | \
         tirebase Mz RMSE | MF 6.1 (README) | MF 6.1 (evaluated) | samples"
    );
    let mut misses = Vec::new();
    for g in &groups {
        let (tire, rim, pressure): (&str, f64, i64) =
            (&g[0], g[1].parse().unwrap(), g[2].parse().unwrap());
        let tir = out
            .join("tir")
            .join(tir_file_name(tire, rim, pressure as f64));
        let ours = score(&store, &tir, tire, pressure);
        let theirs = score(&store, &mf61, tire, pressure);
        let readme = MF61_README.iter().find(|r| r.0 == pressure);
        let shown =
            |v: Option<f64>, unit: &str| v.map_or("-".to_string(), |v| format!("{v:.1} {unit}"));
        let (fy, mz, n) = match &ours {
            Ok((fy, mz, _, n)) => (Some(*fy), Some(*mz), n.to_string()),
            Err(e) => {
                eprintln!("  {pressure} kPa: no tirebase score: {e}");
                (None, None, "-".to_string())
            }
        };
        let (fy61, mz61) = match &theirs {
            Ok((fy, mz, _, _)) => (Some(*fy), Some(*mz)),
            Err(_) => (None, None),
        };
        eprintln!(
            "{pressure:>4} kPa | {} | {} | {} | {} | {} | {} | {n}",
            shown(fy, "N"),
            shown(readme.map(|r| r.1), "N"),
            shown(fy61, "N"),
            shown(mz, "N m"),
            shown(readme.map(|r| r.2), "N m"),
            shown(mz61, "N m"),
        );
        let Some(&(_, fy_target, mz_target)) = readme else {
            misses.push(format!(
                "{pressure} kPa: no MF 6.1 figure for this pressure"
            ));
            continue;
        };
        match (fy, mz) {
            (Some(fy), Some(mz)) => {
                if fy > fy_target {
                    misses.push(format!("{pressure} kPa: Fy RMSE {fy:.1} N > {fy_target} N"));
                }
                if mz > mz_target {
                    misses.push(format!(
                        "{pressure} kPa: Mz RMSE {mz:.2} N m > {mz_target} N m"
                    ));
                }
            }
            _ => misses.push(format!("{pressure} kPa: no fitted model scored")),
        }
    }
    if let Err(e) = score(&store, &mf61, &groups[0][0], groups[0][2].parse().unwrap()) {
        eprintln!("(MF 6.1 not evaluated by tirebase: {e})");
    }
    for line in &rejected {
        misses.push(format!("off-nominal rejection: {line}"));
    }
    assert!(
        misses.is_empty(),
        "issue 17 real-data targets missed:\n{}",
        misses.join("\n")
    );
}

/// One tire's sweeps and per-pressure PAC2002 fits read from `cornering.mat` in process, through
/// the code ingest and `fit` call: the TTC reader, the segmenter (default `[segment]`; segments
/// whose QC flags spoil the forces left out), the spring-rate stage and the PAC2002 stage
/// (default configuration, no de-lagging) per nominal pressure. Not the store: ingest's Parquet
/// round trip and catalog are not exercised.
fn cornering_mf61_groups(
    real: &Path,
) -> (String, f64, Vec<tirebase::core::fit::mf61::PressureGroup>) {
    let (tire, rim, groups, _) = mf61_groups(real, "cornering.mat");
    (tire, rim, groups)
}

/// [`cornering_mf61_groups`] for any file of `shared/real/`, also with the segments each tested
/// pressure's sweeps came from (nominal pressure, kPa -> segments, in file order).
pub(crate) fn mf61_groups(
    real: &Path,
    file: &str,
) -> (
    String,
    f64,
    Vec<tirebase::core::fit::mf61::PressureGroup>,
    std::collections::BTreeMap<i64, Vec<tirebase::core::fit::segment_data::MeasuredSegment>>,
) {
    use std::collections::BTreeMap;
    use tirebase::core::fit::mf61::{Mf61Sweep, Pac2002AtPressure, PressureGroup};
    use tirebase::core::fit::pac2002::{self, FitConfig, FitInput, Sweep};
    use tirebase::core::fit::segment_data::{MeasuredSegment, TireKey};
    use tirebase::core::fit::spring_rate::{self, SpringRateConfig};
    use tirebase::core::segment::{self, RunSignals, SegmentConfig};

    let path = real.join(file);
    let bytes = std::fs::read(&path).unwrap();
    let table = tirebase::core::ttc::read_run(&bytes, file).expect("read");
    let empty: Vec<f64> = Vec::new();
    let signals = RunSignals::from_iso_w(
        &table.tire,
        &table.et_s,
        &table.speed_kph,
        &table.pressure_kpa,
        table.loaded_radius_m.as_ref().unwrap_or(&empty),
    );
    let (segs, _) = segment::run(&signals, &SegmentConfig::default()).expect("segment");
    let (tire, rim) = (file.trim_end_matches(".mat").to_string(), 7.0);
    let mut by_pressure: BTreeMap<i64, Vec<MeasuredSegment>> = BTreeMap::new();
    for seg in segs {
        let Some(p) = seg.nominal.pressure_kpa else {
            continue;
        };
        if seg.qc.iter().any(|f| f.spoils_forces()) {
            continue;
        }
        let key = TireKey {
            tire: tire.clone(),
            rim_in: rim as i64,
            pressure_kpa_nom: p,
        };
        by_pressure
            .entry(p)
            .or_default()
            .push(MeasuredSegment::of_run(&table, file, &seg, key));
    }
    let median = |mut v: Vec<f64>| {
        v.retain(|x| x.is_finite());
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let mut groups = Vec::new();
    for (p, segs) in &by_pressure {
        let key = TireKey {
            tire: tire.clone(),
            rim_in: rim as i64,
            pressure_kpa_nom: *p,
        };
        let sr = spring_rate::run(segs, &BTreeMap::new(), &SpringRateConfig::default());
        let vertical = sr.vertical.first();
        let sweeps: Vec<&MeasuredSegment> = segs
            .iter()
            .filter(|s| Sweep::from_segment(s, None, true).is_some())
            .collect();
        if sweeps.is_empty() {
            continue;
        }
        let speed_kph = median(
            sweeps
                .iter()
                .flat_map(|s| s.channels.speed_kph.clone())
                .collect(),
        );
        let input = FitInput {
            context: spring_rate::pac2002_context(&key, speed_kph / 3.6, vertical),
            sweeps: sweeps
                .iter()
                .filter_map(|s| Sweep::from_segment(s, None, true))
                .collect(),
        };
        let pac = pac2002::fit(&input, &FitConfig::default());
        if let Err(e) = &pac {
            eprintln!("  {p} kPa: PAC2002 fit failed: {e}");
        }
        let p_pa = 1e3
            * median(
                sweeps
                    .iter()
                    .flat_map(|s| s.channels.pressure_kpa.clone())
                    .collect(),
            );
        eprintln!(
            "  {p} kPa: {} sweeps, measured {:.1} kPa, Cz {:?}, R0 {:?}",
            sweeps.len(),
            p_pa / 1e3,
            vertical.map(|v| v.vertical_stiffness_n_per_m),
            vertical.map(|v| v.unloaded_radius_m)
        );
        groups.push(PressureGroup {
            pressure_kpa_nom: *p,
            sweeps: sweeps
                .iter()
                .filter_map(|s| Mf61Sweep::from_segment(s, None))
                .collect(),
            pac2002: pac.ok().map(|f| Pac2002AtPressure {
                p_pa,
                model: f.model,
                vertical_stiffness_n_per_m: vertical.map(|v| v.vertical_stiffness_n_per_m),
                unloaded_radius_m: vertical.map(|v| v.unloaded_radius_m),
            }),
        });
    }
    (tire, rim, groups, by_pressure)
}

/// Issue 19 opt-in real-data check: one MF 6.1 model fitted by `fit::mf61` on every pressure of
/// `cornering.mat` ([`cornering_mf61_groups`]), scored with `tirebase tir score` on the measured
/// samples (the README's selection, each sample at its measured pressure) per pressure beside the
/// file author's MF 6.1 fit (`obfuscated_mf61.tir`); the same for the MF 6.1 model `tirebase fit`
/// writes (the pipeline's sweeps: QC, despiked, de-lagged); then `fit::mf61` fitted on 69 and
/// 97 kPa only and scored on the 83 kPa samples. Asserts the target: every figure no
/// larger than the author's.
/// Run: `cargo test --test integration real_data_mf61 -- --ignored --nocapture`.
#[test]
#[ignore = "needs the real files of shared/real/ (development only); run with --ignored"]
fn real_data_mf61_fit_against_the_authors_mf61() {
    use tirebase::core::fit::mf61::{Mf61Config, Mf61Input, fit};
    use tirebase::core::tire_model::Version;
    use tirebase::core::tire_model::tir::TirFile;

    let Some(real) = real_dir() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("store");
    ingest(&real.join("cornering.mat"), &store, None);
    let stored = tirebase(&[
        "query",
        "--store",
        p(&store),
        "--format",
        "csv",
        "SELECT DISTINCT tire FROM segments WHERE source_file = 'cornering.mat'",
    ]);
    ok(&stored, "query tire");
    let store_tire = csv_rows(&stored)[0][0].clone();

    let (tire, rim, groups) = cornering_mf61_groups(&real);
    let pressures: Vec<i64> = groups.iter().map(|g| g.pressure_kpa_nom).collect();
    eprintln!("tested pressures {pressures:?}");
    let cfg = Mf61Config::default();
    let write = |name: &str, input: &Mf61Input| {
        let f = fit(input, &cfg).expect("MF 6.1 fit");
        for fam in &f.families {
            eprintln!(
                "  {name} {}: n {} free {} rmse {:.2} (start {:.2}) {:?}",
                fam.family.as_str(),
                fam.n,
                fam.free.len(),
                fam.rmse,
                fam.initial_rmse,
                fam.termination
            );
        }
        for n in &f.notes {
            eprintln!("  {name} note: {n}");
        }
        let path = dir.path().join(format!("{name}.tir"));
        let text = TirFile::from_coefs_as(f.model.coefs.clone(), Version::Mf61)
            .render()
            .unwrap();
        std::fs::write(&path, text).unwrap();
        (path, f.seconds)
    };
    let all = Mf61Input {
        tire: tire.clone(),
        rim_in: rim,
        nominal_pa: Mf61Input::nominal_for(&pressures),
        groups: groups.clone(),
    };
    let (all_tir, secs) = write("all", &all);
    eprintln!("MF 6.1 fit on every pressure: {secs:.1} s (with leave-one-pressure-out refits)");
    let outer: Vec<i64> = pressures
        .iter()
        .copied()
        .filter(|p| *p == pressures[0] || *p == pressures[pressures.len() - 1])
        .collect();
    let held = Mf61Input {
        groups: groups
            .iter()
            .filter(|g| outer.contains(&g.pressure_kpa_nom))
            .cloned()
            .collect(),
        nominal_pa: Mf61Input::nominal_for(&outer),
        ..all.clone()
    };
    let (held_tir, _) = write("outer", &held);
    let mf61 = real.join("obfuscated_mf61.tir");
    // The pipeline's own MF 6.1 model (`tirebase fit`, default `[fit] models`), scored too.
    let out = dir.path().join("fit");
    let fitted = tirebase(&["fit", "--store", p(&store), "--out", p(&out)]);
    let pipeline_tir = std::fs::read_dir(out.join("tir")).ok().and_then(|d| {
        d.filter_map(|e| e.ok().map(|e| e.path()))
            .find(|f| f.to_string_lossy().ends_with("__mf61.tir"))
    });
    if pipeline_tir.is_none() {
        eprintln!(
            "tirebase fit wrote no MF 6.1 model: {}",
            String::from_utf8_lossy(&fitted.stderr)
        );
    }

    eprintln!(
        "pressure | MF 6.1 (tirebase) Fy RMSE | author's (README / evaluated) | Mz RMSE | author's | samples"
    );
    let mut misses = Vec::new();
    let show = |r: &Result<(f64, f64, f64, usize), String>, k: usize| match r {
        Ok(v) => format!("{:.1}", [v.0, v.1][k]),
        Err(e) => format!("({e})"),
    };
    let mut row = |label: &str, pressure: i64, tir: &Path| {
        let ours = score(&store, tir, &store_tire, pressure);
        let theirs = score(&store, &mf61, &store_tire, pressure);
        let readme = MF61_README.iter().find(|r| r.0 == pressure);
        eprintln!(
            "{pressure:>4} kPa {label} | {} N | {} / {} N | {} N m | {} / {} N m | {}",
            show(&ours, 0),
            readme.map_or("-".into(), |r| format!("{}", r.1)),
            show(&theirs, 0),
            show(&ours, 1),
            readme.map_or("-".into(), |r| format!("{}", r.2)),
            show(&theirs, 1),
            ours.as_ref().map_or(0, |v| v.3)
        );
        match (ours, readme) {
            (Ok((fy, mz, _, _)), Some(&(_, fy_t, mz_t))) => {
                if fy > fy_t {
                    misses.push(format!(
                        "{pressure} kPa {label}: Fy RMSE {fy:.1} N > {fy_t} N"
                    ));
                }
                if mz > mz_t {
                    misses.push(format!(
                        "{pressure} kPa {label}: Mz RMSE {mz:.2} N m > {mz_t} N m"
                    ));
                }
            }
            (Err(e), _) => misses.push(format!("{pressure} kPa {label}: not scored: {e}")),
            (_, None) => misses.push(format!("{pressure} kPa: no author's figure")),
        }
    };
    for &pressure in &pressures {
        row("all pressures", pressure, &all_tir);
    }
    if let Some(tir) = &pipeline_tir {
        for &pressure in &pressures {
            row("tirebase fit", pressure, tir);
        }
    }
    for &pressure in pressures.iter().filter(|p| !outer.contains(p)) {
        row("fitted on the others", pressure, &held_tir);
    }
    if pipeline_tir.is_none() {
        misses.push("tirebase fit wrote no MF 6.1 model".to_string());
    }
    assert!(
        misses.is_empty(),
        "issue 19 real-data targets missed:\n{}",
        misses.join("\n")
    );
}
