//! One round's fitted results, as a comparison reads them: the typed result tables and the
//! `.tir` models of a published version (or any result directory laid out like one), read
//! through `store::results`, plus the per-group lookups: the fit's error estimate and the
//! thermal window.
//!
//! In: a directory with `<table>.parquet` and `tir/*.tir`, or typed [`Results`] and models
//! already in memory (the report). Out: [`RoundResults`] (a missing or unreadable table or
//! model is a note, never an error: its figures are left empty), and for a group its model (by
//! the version's `.tir` name), [`FitUncertainty`] and [`ThermalWindow`]. Deliberately not here: the
//! figures, ranking.

use std::collections::BTreeMap;
use std::path::Path;

use crate::schema::TableName;
pub use crate::store::results::{GroupKey, TirModel};
use crate::store::results::{
    QualityRow, Results, ThermalFitRecord, ThermalRow, read_tir_models, tir_names,
};

/// Result tables a comparison reads (notes about the others are left out).
pub const TABLES: [TableName; 4] = [
    TableName::FitQuality,
    TableName::Coefficients,
    TableName::ThermalFit,
    TableName::Thermal,
];

/// A round's typed result tables and models.
#[derive(Clone, Debug, Default)]
pub struct RoundResults {
    /// The round's label.
    pub label: String,
    /// The result tables.
    pub results: Results,
    /// Models by `.tir` file name.
    pub models: BTreeMap<String, TirModel>,
    /// The `.tir` file name of each group with a model (`store::results::tir_names`).
    pub tir_names: BTreeMap<GroupKey, String>,
    /// What could not be read.
    pub notes: Vec<String>,
}

impl RoundResults {
    /// A round of `results` and its `models` (by `.tir` file name).
    pub fn new(label: &str, results: Results, models: BTreeMap<String, TirModel>) -> RoundResults {
        // The selection ranks per-pressure PAC2002 models; MF 6.1 rows are not its channels.
        let mut results = results;
        results.fit_quality = results.pac2002_quality();
        RoundResults {
            label: label.to_string(),
            tir_names: tir_names(&results.model_groups()).0,
            results,
            models,
            notes: Vec::new(),
        }
    }

    /// The groups the round's fit_quality and coefficients name, sorted.
    pub fn groups(&self) -> Vec<GroupKey> {
        let r = &self.results;
        let mut all: Vec<GroupKey> = r
            .fit_quality
            .iter()
            .flatten()
            .map(|q| (q.tire.clone(), q.rim_in, q.pressure_kpa))
            .chain(r.model_groups())
            .collect();
        all.sort();
        all.dedup();
        all
    }

    /// The model of a group, or the file it would be in when the round has no readable model.
    pub fn model(&self, key: &GroupKey) -> Result<&TirModel, NoModel> {
        let file = self.tir_names.get(key).cloned().unwrap_or_else(|| {
            tirebase_core::naming::tir_file_name(&key.0, key.1 as f64, key.2 as f64)
        });
        self.models.get(&file).ok_or(NoModel { file })
    }
}

/// A group of a round without a readable model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("no model tir/{file}")]
pub struct NoModel {
    /// The `.tir` file name the model would have.
    pub file: String,
}

/// Load the tables and models of `dir` as round `label`.
pub fn load(dir: &Path, label: &str) -> RoundResults {
    let results = Results::read(dir);
    let (models, model_notes) = read_tir_models(&dir.join("tir"));
    let table_notes: Vec<String> = results
        .notes
        .iter()
        .filter(|n| {
            TABLES
                .iter()
                .any(|t| n.starts_with(&format!("{t}.parquet:")))
        })
        .cloned()
        .collect();
    let mut round = RoundResults::new(label, results, models);
    round.notes = table_notes
        .into_iter()
        .chain(model_notes)
        .map(|n| format!("{}: {n}", dir.display()))
        .collect();
    round
}

/// Rows of a typed table belonging to a group.
fn of_group<'a, T>(
    rows: &'a Option<Vec<T>>,
    key: &'a GroupKey,
    group: impl Fn(&T) -> (&str, i64, i64) + 'a,
) -> impl Iterator<Item = &'a T> + 'a {
    rows.iter()
        .flatten()
        .filter(move |r| group(r) == (key.0.as_str(), key.1, key.2))
}

/// The fit's relative error behind an objective.
#[derive(Clone, Debug, PartialEq)]
pub struct FitUncertainty {
    /// Relative standard error of the objective (NaN when unknown).
    pub relative: f64,
    /// Where it comes from.
    pub source: String,
}

/// The fit_quality measure used as a channel's relative error, in percent of the channel's
/// peak, and whether it is out-of-sample: `rmse_pct_of_peak x oos_ratio` (k-fold by sweep, what
/// the fit does on sweeps it did not see) where the row has an out-of-sample ratio, else the
/// in-sample `rmse_pct_of_peak` (the error on the points it was fitted to, noise included).
fn error_measure(row: &QualityRow) -> (bool, Option<f64>) {
    let oos = row.oos_ratio.is_some_and(|r| r.is_finite() && r > 0.0);
    (oos, row.headline_pct_of_peak())
}

/// The relative error of a figure built from `channels` of the group's fit (their errors
/// combined in quadrature: a product of forces, like an envelope area, adds relative errors
/// so); the source names the measure and the channels that had only an in-sample one.
pub fn fit_error(results: &Results, key: &GroupKey, channels: &[&str]) -> FitUncertainty {
    let unknown = |why: &str| FitUncertainty {
        relative: f64::NAN,
        source: why.to_string(),
    };
    if results.fit_quality.is_none() {
        return unknown("unknown: no fit_quality table");
    }
    let rows: Vec<&QualityRow> = of_group(&results.fit_quality, key, |q| {
        (q.tire.as_str(), q.rim_in, q.pressure_kpa)
    })
    .collect();
    let mut sum_sq = 0.0;
    let mut in_sample = Vec::new();
    for want in channels {
        let measure = rows
            .iter()
            .find(|q| q.channel == *want)
            .map(|q| error_measure(q));
        match measure {
            Some((oos, Some(v))) if v.is_finite() && v >= 0.0 => {
                sum_sq += (v / 100.0).powi(2);
                if !oos {
                    in_sample.push(*want);
                }
            }
            _ => {
                return unknown(&format!(
                    "unknown: no fit_quality rmse_pct_of_peak of channel {want}"
                ));
            }
        }
    }
    FitUncertainty {
        relative: sum_sq.sqrt(),
        source: if in_sample.is_empty() {
            format!(
                "fit_quality.rmse_pct_of_peak x oos_ratio {} (out-of-sample)",
                channels.join("+")
            )
        } else {
            format!(
                "fit_quality.rmse_pct_of_peak {} (in-sample for {}: no out-of-sample error)",
                channels.join("+"),
                in_sample.join("+")
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

/// Smallest gain of peak grip over cold for a temperature optimum to mean anything: below it
/// the fitted parabola is flat and its vertex is noise.
pub const MIN_THERMAL_GAIN: f64 = 0.01;

/// The thermal window of a group from `thermal_fit` (optimum, gain, cold reference) and
/// `thermal` (the sweep peaks: centre temperature against time, per cold-to-warm test).
///
/// Reported only where measured: nothing when the mu(T) fit did not converge; the gain alone
/// when grip rises by less than [`MIN_THERMAL_GAIN`] or the optimum lies outside the measured
/// peak temperatures (an extrapolated vertex).
pub fn thermal_window(results: &Results, key: &GroupKey) -> ThermalWindow {
    let finite = |v: f64| v.is_finite().then_some(v);
    let mut w = ThermalWindow::default();
    let Some(fit): Option<&ThermalFitRecord> = of_group(&results.thermal_fit, key, |f| {
        (f.tire.as_str(), f.rim_in, f.pressure_kpa)
    })
    .next() else {
        return w;
    };
    if !fit.converged {
        return w;
    }
    w.gain_over_cold = finite(fit.gain_peak_over_cold);
    let t_cold = finite(fit.t_cold_c);
    let peaks = peak_temperatures(results, key);
    let (lo, hi) = peaks
        .values()
        .flatten()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.1), hi.max(p.1))
        });
    let Some(t_opt) = finite(fit.t_peak_c)
        .filter(|&t| w.gain_over_cold.is_some_and(|g| g >= MIN_THERMAL_GAIN) && lo <= t && t <= hi)
    else {
        return w;
    };
    w.t_opt_c = Some(t_opt);
    let slopes: Vec<f64> = peaks
        .values()
        .map(|p| {
            p.iter()
                .copied()
                .filter(|x| x.0.is_finite() && x.1 < t_opt)
                .collect::<Vec<_>>()
        })
        .filter_map(|p| slope(&p))
        .filter(|s| s.is_finite() && *s > 0.0)
        .collect();
    if !slopes.is_empty() {
        let rate = slopes.iter().sum::<f64>() / slopes.len() as f64;
        w.warmup_rate_c_per_s = Some(rate);
        w.warmup_time_s = t_cold.map(|c| (t_opt - c) / rate).filter(|s| *s >= 0.0);
    }
    w
}

/// The group's sweep peaks `(time s, centre temperature degC)` per cold-to-warm test (the time
/// NaN when not recorded).
fn peak_temperatures(results: &Results, key: &GroupKey) -> BTreeMap<String, Vec<(f64, f64)>> {
    let mut by_test: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let rows = of_group(&results.thermal, key, |t: &ThermalRow| {
        (t.tire.as_str(), t.rim_in, t.pressure_kpa)
    });
    for r in rows.filter(|r| r.t_centre_peak_c.is_finite()) {
        by_test
            .entry(r.segment_id.clone())
            .or_default()
            .push((r.et_peak_s, r.t_centre_peak_c));
    }
    by_test
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quality(tire: &str, channel: &str, pct: f64) -> QualityRow {
        QualityRow::pct_of_peak_only(tire, 83, channel, pct)
    }

    fn thermal_fit(t_peak: f64, gain: f64, converged: bool) -> ThermalFitRecord {
        ThermalFitRecord {
            tire: "A".into(),
            rim_in: 7,
            pressure_kpa: 83,
            t_peak_c: t_peak,
            gain_peak_over_cold: gain,
            t_cold_c: 25.0,
            k_cold_per_c2: 1e-4,
            hot_falloff: f64::NAN,
            mu_peak_mean: 1.6,
            converged,
        }
    }

    fn results() -> Results {
        // Two tests warming at 0.5 and 0.7 degC/s; peaks above t_opt are left out.
        let mut thermal = Vec::new();
        for (s, rate) in [("s1", 0.5), ("s2", 0.7)] {
            for k in 0..8 {
                let time = 100.0 + 5.0 * k as f64;
                let t = (30.0 + rate * (time - 100.0)).min(80.0) + if k > 5 { 30.0 } else { 0.0 };
                thermal.push(ThermalRow {
                    tire: "A".into(),
                    rim_in: 7,
                    pressure_kpa: 83,
                    segment_id: s.into(),
                    quadrant: "q".into(),
                    et_peak_s: time,
                    t_centre_peak_c: t,
                    mu_peak: 1.5,
                });
            }
        }
        Results {
            fit_quality: Some(vec![
                quality("A", "Fy0", 0.3),
                quality("A", "Fx", 0.4),
                quality("A", "Fy", 0.3),
                quality("B", "Fy0", f64::NAN),
            ]),
            thermal_fit: Some(vec![thermal_fit(55.0, 0.35, true)]),
            thermal: Some(thermal),
            ..Results::default()
        }
    }

    #[test]
    fn errors_combine_channels_and_say_where_they_come_from() {
        let r = results();
        let a = ("A".to_string(), 7, 83);
        let e = fit_error(&r, &a, &["Fy0"]);
        assert!((e.relative - 0.003).abs() < 1e-12);
        assert!(e.source.contains("rmse_pct_of_peak") && e.source.contains("in-sample"));
        let e = fit_error(&r, &a, &["Fx", "Fy"]);
        assert!((e.relative - 0.005).abs() < 1e-12);
        let b = ("B".to_string(), 7, 83);
        assert!(fit_error(&r, &b, &["Fy0"]).relative.is_nan());
        assert!(fit_error(&r, &a, &["Mx"]).source.starts_with("unknown"));
        assert!(
            fit_error(&Results::default(), &a, &["Fy0"])
                .source
                .contains("no fit_quality table")
        );
        let round = RoundResults::new("r", r, BTreeMap::new());
        assert_eq!(round.groups(), vec![a.clone(), b]);
        assert_eq!(
            round.model(&a).err().map(|e| e.file).as_deref(),
            Some("a__7in__83kPa.tir")
        );
        // With the out-of-sample ratio, the out-of-sample error where a row has one.
        let mut r = results();
        for q in r.fit_quality.iter_mut().flatten() {
            q.oos_ratio = match q.channel.as_str() {
                "Fy0" => Some(2.0),
                "Fy" => Some(1.0),
                _ => None,
            };
        }
        let e = fit_error(&r, &a, &["Fy0"]);
        assert!((e.relative - 0.006).abs() < 1e-12, "{e:?}");
        assert!(e.source.contains("(out-of-sample)"), "{e:?}");
        let e = fit_error(&r, &a, &["Fx", "Fy"]);
        assert!((e.relative - 0.005).abs() < 1e-12, "{e:?}");
        assert!(e.source.contains("in-sample for Fx"), "{e:?}");
    }

    #[test]
    fn the_thermal_window_uses_the_warming_peaks() {
        let r = results();
        let w = thermal_window(&r, &("A".to_string(), 7, 83));
        assert_eq!(w.t_opt_c, Some(55.0));
        assert_eq!(w.gain_over_cold, Some(0.35));
        let rate = w.warmup_rate_c_per_s.unwrap();
        assert!((rate - 0.6).abs() < 1e-9, "{rate}");
        assert!((w.warmup_time_s.unwrap() - 30.0 / 0.6).abs() < 1e-6);
        let none = thermal_window(&r, &("B".to_string(), 7, 83));
        assert_eq!(none, ThermalWindow::default());
    }

    #[test]
    fn an_unresolved_optimum_is_not_reported() {
        let mut r = results();
        let a = ("A".to_string(), 7, 83);
        // No measurable rise of grip with temperature: the vertex means nothing.
        r.thermal_fit = Some(vec![thermal_fit(55.0, 0.002, true)]);
        let w = thermal_window(&r, &a);
        assert_eq!((w.t_opt_c, w.gain_over_cold), (None, Some(0.002)));
        // An optimum hotter than any measured peak is an extrapolation.
        r.thermal_fit = Some(vec![thermal_fit(300.0, 0.3, true)]);
        assert_eq!(thermal_window(&r, &a).t_opt_c, None);
        r.thermal_fit = Some(vec![thermal_fit(55.0, 0.3, false)]);
        assert_eq!(thermal_window(&r, &a), ThermalWindow::default());
    }
}
