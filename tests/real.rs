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
use std::process::Output;

use tirebase::core::naming::tir_file_name;

use crate::harness::{ok, p, tirebase};

/// The MF 6.1 fit's figures from `shared/real/README.md`: (pressure kPa, Fy RMSE N, Mz RMSE N m).
const MF61_README: [(i64, f64, f64); 3] = [(69, 177.0, 14.6), (83, 158.0, 13.7), (97, 162.0, 13.3)];

fn real_dir() -> Option<PathBuf> {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::env::var_os("TIREBASE_REAL_DIR")
        .map(PathBuf::from)
        .into_iter()
        .chain([
            manifest.join("../shared/real"),
            manifest.join("../../shared/real"),
        ])
        .find(|d| d.join("cornering.mat").is_file())
}

/// CSV rows (header dropped) of a command's stdout.
fn csv_rows(o: &Output) -> Vec<Vec<String>> {
    let mut r = csv::Reader::from_reader(o.stdout.as_slice());
    r.records()
        .map(|rec| rec.unwrap().iter().map(str::to_string).collect())
        .collect()
}

/// `(fy_rmse_n, mz_rmse_nm, fx_rmse_n, n_samples)` of `cornering.mat` at `pressure` from a
/// `tir score` output, or the error text.
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
        .find(|r| r[1] == "cornering.mat")
        .ok_or_else(|| "no cornering.mat row".to_string())?;
    let f = |i: usize| row[i].parse::<f64>().unwrap();
    Ok((f(5), f(6), f(4), row[3].parse().unwrap()))
}

#[test]
#[ignore = "needs the real files of shared/real/ (development only); run with --ignored"]
fn real_data_cornering_fit_against_mf61() {
    let Some(real) = real_dir() else {
        eprintln!("real-data check skipped: no shared/real/cornering.mat (set TIREBASE_REAL_DIR)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (store, out) = (dir.path().join("store"), dir.path().join("fit"));
    ok(
        &tirebase(&["ingest", p(&real), "--store", p(&store)]),
        "ingest",
    );
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
