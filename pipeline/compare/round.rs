//! One round's fitted results, as a comparison reads them: the result tables it needs and the
//! `.tir` models, from a published version (or any result directory laid out like one), plus
//! the per-group lookups: the fit's error estimate and the thermal window.
//!
//! In: a directory with `<table>.parquet` and `tir/*.tir`. Out: [`RoundResults`] (a missing or
//! unreadable table or model is a note, never an error: its figures are left empty), and for a
//! group its [`FitError`] and [`ThermalWindow`]. Deliberately not here: the figures, ranking.

use std::collections::BTreeMap;
use std::path::Path;

use polars::prelude::*;
use tirebase_core::tire_model::Pac2002;
use tirebase_core::tire_model::tir::TirFile;

/// Result tables a comparison reads.
pub const TABLES: [&str; 4] = ["fit_quality", "coefficients", "thermal_fit", "thermal"];

/// A fitted model and what its file declares about itself.
#[derive(Clone, Debug)]
pub struct TirModel {
    /// The model.
    pub model: Pac2002,
    /// `[MODEL] USE_MODE` of the file.
    pub use_mode: Option<i64>,
}

/// A round's tables (by name) and models (by `.tir` file name).
#[derive(Clone, Debug, Default)]
pub struct RoundResults {
    /// The round's label.
    pub label: String,
    /// Tables present and readable.
    pub tables: BTreeMap<String, DataFrame>,
    /// Models by file name.
    pub models: BTreeMap<String, TirModel>,
    /// What could not be read.
    pub notes: Vec<String>,
}

/// Read a model file; the reason when it cannot be read.
pub fn read_tir(path: &Path) -> Result<TirModel, String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let (tir, _) = TirFile::parse_bytes(&bytes).map_err(|e| e.to_string())?;
    Ok(TirModel {
        model: tir.model(),
        use_mode: tir.use_mode,
    })
}

/// Load the tables and models of `dir` as round `label`.
pub fn load(dir: &Path, label: &str) -> RoundResults {
    let mut round = RoundResults {
        label: label.to_string(),
        ..Default::default()
    };
    for name in TABLES {
        match crate::store::results::read_table(dir, name) {
            Ok(Some(df)) => {
                round.tables.insert(name.to_string(), df);
            }
            Ok(None) => round
                .notes
                .push(format!("{}: {name}.parquet not present", dir.display())),
            Err(e) => round.notes.push(format!("unreadable: {e}")),
        }
    }
    let tir_dir = dir.join("tir");
    let mut paths: Vec<_> = std::fs::read_dir(&tir_dir)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "tir"))
                .collect()
        })
        .unwrap_or_default();
    paths.sort();
    for path in paths {
        let name = path
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        match read_tir(&path) {
            Ok(m) => {
                round.models.insert(name, m);
            }
            Err(e) => round
                .notes
                .push(format!("{}: unreadable: {e}", path.display())),
        }
    }
    round
}

/// Column `name` of `df` as f64 values (NaN where null, missing or not numeric).
fn f64s(df: &DataFrame, name: &str) -> Vec<f64> {
    df.column(name)
        .ok()
        .and_then(|c| c.cast(&DataType::Float64).ok())
        .and_then(|c| {
            c.f64()
                .ok()
                .map(|v| v.iter().map(|x| x.unwrap_or(f64::NAN)).collect())
        })
        .unwrap_or_else(|| vec![f64::NAN; df.height()])
}

/// Column `name` of `df` as strings (None where null or missing).
fn strs(df: &DataFrame, name: &str) -> Vec<Option<String>> {
    df.column(name)
        .ok()
        .and_then(|c| {
            c.str()
                .ok()
                .map(|v| v.iter().map(|s| s.map(String::from)).collect())
        })
        .unwrap_or_else(|| vec![None; df.height()])
}

/// Column `name` of `df` as i64 values (None where null, missing or not integral).
fn i64s(df: &DataFrame, name: &str) -> Vec<Option<i64>> {
    df.column(name)
        .ok()
        .and_then(|c| c.cast(&DataType::Int64).ok())
        .and_then(|c| c.i64().ok().map(|v| v.iter().collect()))
        .unwrap_or_else(|| vec![None; df.height()])
}

/// A fit group: (tire, rim_in, pressure_kpa).
pub type GroupKey = (String, i64, i64);

/// Row indices of `df` per group.
fn rows_by_group(df: &DataFrame) -> BTreeMap<GroupKey, Vec<usize>> {
    let (t, r, p) = (
        strs(df, "tire"),
        i64s(df, "rim_in"),
        i64s(df, "pressure_kpa"),
    );
    let mut out: BTreeMap<GroupKey, Vec<usize>> = BTreeMap::new();
    for i in 0..df.height() {
        if let (Some(t), Some(r), Some(p)) = (&t[i], r[i], p[i]) {
            out.entry((t.clone(), r, p)).or_default().push(i);
        }
    }
    out
}

/// The groups the round's result tables name (fit_quality and coefficients).
pub fn groups(tables: &BTreeMap<String, DataFrame>) -> Vec<GroupKey> {
    let mut all: Vec<GroupKey> = ["fit_quality", "coefficients"]
        .iter()
        .filter_map(|t| tables.get(*t))
        .flat_map(|df| rows_by_group(df).into_keys())
        .collect();
    all.sort();
    all.dedup();
    all
}

/// The fit's relative error behind an objective.
#[derive(Clone, Debug, PartialEq)]
pub struct FitError {
    /// Relative standard error of the objective (NaN when unknown).
    pub relative: f64,
    /// Where it comes from.
    pub source: String,
}

/// The relative error of a figure built from `channels` of the group's fit (their errors
/// combined in quadrature: a product of forces, like an envelope area, adds relative errors
/// so). Each channel's error is its out-of-sample RMSE in percent of its peak
/// (`rmse_pct_of_peak x oos_ratio`: k-fold by sweep, what the fit does on sweeps it did not
/// see) where `fit_quality` has it, else the in-sample `rmse_pct_of_peak` (the error on the
/// points it was fitted to, noise included); the source says which.
pub fn fit_error(
    tables: &BTreeMap<String, DataFrame>,
    key: &GroupKey,
    channels: &[&str],
) -> FitError {
    let unknown = |why: &str| FitError {
        relative: f64::NAN,
        source: why.to_string(),
    };
    let Some(df) = tables.get("fit_quality") else {
        return unknown("unknown: no fit_quality table");
    };
    if df.column("rmse_pct_of_peak").is_err() {
        return unknown("unknown: fit_quality has no error column");
    }
    let rows = rows_by_group(df).remove(key).unwrap_or_default();
    let chan = strs(df, "channel");
    let pct = f64s(df, "rmse_pct_of_peak");
    let ratio = if df.column("oos_ratio").is_ok() {
        f64s(df, "oos_ratio")
    } else {
        vec![f64::NAN; df.height()]
    };
    let (mut sum_sq, mut in_sample) = (0.0, Vec::new());
    for want in channels {
        let Some(&i) = rows.iter().find(|&&i| chan[i].as_deref() == Some(*want)) else {
            return unknown(&format!(
                "unknown: no fit_quality rmse_pct_of_peak of channel {want}"
            ));
        };
        let v = if ratio[i].is_finite() && ratio[i] > 0.0 {
            pct[i] * ratio[i]
        } else {
            in_sample.push(*want);
            pct[i]
        };
        if !(v.is_finite() && v >= 0.0) {
            return unknown(&format!(
                "unknown: no fit_quality rmse_pct_of_peak of channel {want}"
            ));
        }
        sum_sq += (v / 100.0).powi(2);
    }
    FitError {
        relative: sum_sq.sqrt(),
        source: if in_sample.is_empty() {
            format!(
                "fit_quality.rmse_pct_of_peak x oos_ratio of {} (out-of-sample)",
                channels.join(" and ")
            )
        } else {
            format!(
                "fit_quality.rmse_pct_of_peak of {} (in-sample for {}: no out-of-sample error)",
                channels.join(" and "),
                in_sample.join(" and ")
            )
        },
    }
}

/// The measured thermal window of a group.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ThermalWindow {
    /// Temperature of peak grip, degC.
    pub t_opt_c: Option<f64>,
    /// Relative gain of peak grip over the cold reference.
    pub gain_over_cold: Option<f64>,
    /// Net warm-up rate on the cold-to-warm test, degC/s.
    pub warmup_rate_c_per_s: Option<f64>,
    /// Time from the cold reference to the optimum at that rate, s.
    pub warmup_time_s: Option<f64>,
}

/// Least-squares slope of `y` against `x` (None with fewer than 3 points or no spread).
fn slope(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The thermal window of a group from `thermal_fit` (optimum, gain, cold reference) and
/// `thermal` (the sweep peaks: centre temperature against time, per cold-to-warm test).
pub fn thermal_window(tables: &BTreeMap<String, DataFrame>, key: &GroupKey) -> ThermalWindow {
    let finite = |v: f64| v.is_finite().then_some(v);
    let mut w = ThermalWindow::default();
    let mut t_cold = None;
    if let Some(df) = tables.get("thermal_fit")
        && let Some(&i) = rows_by_group(df).get(key).and_then(|r| r.first())
    {
        w.t_opt_c = finite(f64s(df, "t_peak_c")[i]);
        w.gain_over_cold = finite(f64s(df, "gain_peak_over_cold")[i]);
        t_cold = finite(f64s(df, "t_cold_c")[i]);
    }
    let Some(t_opt) = w.t_opt_c else {
        return w;
    };
    if let Some(df) = tables.get("thermal") {
        let rows = rows_by_group(df).remove(key).unwrap_or_default();
        let (seg, et, t) = (
            strs(df, "segment_id"),
            f64s(df, "et_peak_s"),
            f64s(df, "t_centre_peak_c"),
        );
        let mut by_test: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for i in rows {
            if et[i].is_finite() && t[i].is_finite() && t[i] < t_opt {
                by_test
                    .entry(seg[i].clone().unwrap_or_default())
                    .or_default()
                    .push((et[i], t[i]));
            }
        }
        let slopes: Vec<f64> = by_test
            .values()
            .filter_map(|p| slope(p))
            .filter(|s| s.is_finite() && *s > 0.0)
            .collect();
        if !slopes.is_empty() {
            let rate = slopes.iter().sum::<f64>() / slopes.len() as f64;
            w.warmup_rate_c_per_s = Some(rate);
            w.warmup_time_s = t_cold.map(|c| (t_opt - c) / rate).filter(|s| *s >= 0.0);
        }
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tables() -> BTreeMap<String, DataFrame> {
        let mut t = BTreeMap::new();
        t.insert(
            "fit_quality".to_string(),
            df!(
                "tire" => ["A", "A", "A", "B"],
                "rim_in" => [7i64, 7, 7, 7],
                "pressure_kpa" => [83i64, 83, 83, 83],
                "channel" => ["Fy0", "Fx", "Fy", "Fy0"],
                "rmse_pct_of_peak" => [0.3, 0.4, 0.3, f64::NAN],
            )
            .unwrap(),
        );
        t.insert(
            "thermal_fit".to_string(),
            df!(
                "tire" => ["A"], "rim_in" => [7i64], "pressure_kpa" => [83i64],
                "t_peak_c" => [55.0], "gain_peak_over_cold" => [0.35], "t_cold_c" => [25.0],
            )
            .unwrap(),
        );
        // Two tests warming at 0.5 and 0.7 degC/s; peaks above t_opt are left out.
        let mut et = Vec::new();
        let mut tc = Vec::new();
        let mut seg = Vec::new();
        for (s, rate) in [("s1", 0.5), ("s2", 0.7)] {
            for k in 0..8 {
                let time = 100.0 + 5.0 * k as f64;
                et.push(time);
                tc.push((30.0 + rate * (time - 100.0)).min(80.0) + if k > 5 { 30.0 } else { 0.0 });
                seg.push(s);
            }
        }
        let n = et.len();
        t.insert(
            "thermal".to_string(),
            df!(
                "tire" => vec!["A"; n], "rim_in" => vec![7i64; n], "pressure_kpa" => vec![83i64; n],
                "segment_id" => seg, "et_peak_s" => et, "t_centre_peak_c" => tc,
            )
            .unwrap(),
        );
        t
    }

    #[test]
    fn errors_combine_channels_and_say_where_they_come_from() {
        let t = tables();
        let a = ("A".to_string(), 7, 83);
        let e = fit_error(&t, &a, &["Fy0"]);
        assert!((e.relative - 0.003).abs() < 1e-12);
        assert!(e.source.contains("rmse_pct_of_peak") && e.source.contains("in-sample"));
        let e = fit_error(&t, &a, &["Fx", "Fy"]);
        assert!((e.relative - 0.005).abs() < 1e-12);
        let b = ("B".to_string(), 7, 83);
        assert!(fit_error(&t, &b, &["Fy0"]).relative.is_nan());
        assert!(fit_error(&t, &a, &["Mx"]).source.starts_with("unknown"));
        assert_eq!(groups(&t), vec![a.clone(), b]);
        // With the out-of-sample ratio, the out-of-sample error where a row has one.
        let mut t = t;
        t.insert(
            "fit_quality".to_string(),
            df!(
                "tire" => ["A", "A", "A"],
                "rim_in" => [7i64, 7, 7],
                "pressure_kpa" => [83i64, 83, 83],
                "channel" => ["Fy0", "Fx", "Fy"],
                "rmse_pct_of_peak" => [0.3, 0.4, 0.3],
                "oos_ratio" => [2.0, f64::NAN, 1.0],
            )
            .unwrap(),
        );
        let e = fit_error(&t, &a, &["Fy0"]);
        assert!((e.relative - 0.006).abs() < 1e-12, "{e:?}");
        assert!(e.source.contains("out-of-sample"), "{e:?}");
        let e = fit_error(&t, &a, &["Fx", "Fy"]);
        assert!((e.relative - 0.005).abs() < 1e-12, "{e:?}");
        assert!(e.source.contains("in-sample for Fx"), "{e:?}");
    }

    #[test]
    fn the_thermal_window_uses_the_warming_peaks() {
        let t = tables();
        let w = thermal_window(&t, &("A".to_string(), 7, 83));
        assert_eq!(w.t_opt_c, Some(55.0));
        assert_eq!(w.gain_over_cold, Some(0.35));
        let rate = w.warmup_rate_c_per_s.unwrap();
        assert!((rate - 0.6).abs() < 1e-9, "{rate}");
        assert!((w.warmup_time_s.unwrap() - 30.0 / 0.6).abs() < 1e-6);
        let none = thermal_window(&t, &("B".to_string(), 7, 83));
        assert_eq!(none, ThermalWindow::default());
    }
}
