//! The report's charts: measured data from the store next to the fitted models and the stage
//! result tables, one function per kind of chart.
//!
//! In: [`ReportData`] and a tire name. Out: [`Plot`]s (drawn by `svg.rs`); a chart whose inputs
//! are missing comes back empty with a reason, which renders as a "no data" note. Display units:
//! slip angle deg, forces N, moments N m, stiffness kN/m, lengths mm, temperatures degC; ISO-W
//! signs throughout (positive slip angle gives negative Fy on a normal tire).
//!
//! Deliberately not here: HTML around the charts (pages.rs), reading files (data.rs).

use std::collections::BTreeMap;

use tirebase_core::compare::envelope::convex_hull;
use tirebase_core::fit::thermal::relative_grip;
use tirebase_core::naming::tir_file_name;
use tirebase_core::segment::{ia_cdeg_label, ia_cdeg_text};
use tirebase_core::tire_model::{Coef, Mode, Pac2002, SlipInput, pac2002::relaxation_lengths};

use super::data::{PlotSample, PlotSegment, ReportData, decimate};
use super::svg::{Axis, Plot, Series, Style};
use crate::store::tables::SegmentRecord;

/// Points along a model curve.
const CURVE_POINTS: usize = 81;
/// Measured points per (plot, load) series after pooling segments.
const MAX_POINTS_PER_SERIES: usize = 60;

/// Points by (rim, pressure) and then by a series label.
type PointsByGroup = BTreeMap<(i64, i64), BTreeMap<String, Vec<(f64, f64)>>>;

/// Which signal a slip chart shows.
#[derive(Clone, Copy)]
enum SlipChart {
    FySa,
    MzSa,
    FxSl,
}

impl SlipChart {
    fn kind(self) -> &'static str {
        match self {
            SlipChart::FySa => "fy_sa",
            SlipChart::MzSa => "mz_sa",
            SlipChart::FxSl => "fx_sl",
        }
    }

    fn segment_kind(self) -> &'static str {
        match self {
            SlipChart::FxSl => "drive_brake",
            _ => "cornering",
        }
    }

    /// (x, y) in display units of a sample.
    fn xy_sample(self, s: &PlotSample) -> (f64, f64) {
        match self {
            SlipChart::FySa => (s.alpha_rad.to_degrees(), s.fy_n),
            SlipChart::MzSa => (s.alpha_rad.to_degrees(), s.mz_nm),
            SlipChart::FxSl => (s.kappa, s.fx_n),
        }
    }

    fn axes(self) -> (Axis, Axis) {
        match self {
            SlipChart::FySa => (
                Axis::new("slip angle α (deg, ISO-W)"),
                Axis::from_zero("lateral force Fy (N)"),
            ),
            SlipChart::MzSa => (
                Axis::new("slip angle α (deg, ISO-W)"),
                Axis::from_zero("aligning moment Mz (N m)"),
            ),
            SlipChart::FxSl => (
                Axis::new("longitudinal slip κ (-)"),
                Axis::from_zero("longitudinal force Fx (N)"),
            ),
        }
    }

    fn label(self) -> &'static str {
        match self {
            SlipChart::FySa => "Fy vs slip angle",
            SlipChart::MzSa => "Mz vs slip angle",
            SlipChart::FxSl => "Fx vs longitudinal slip",
        }
    }
}

/// The model of a tire, rim and nominal pressure, if its `.tir` was loaded.
pub fn model_for<'a>(
    data: &'a ReportData,
    tire: &str,
    rim_in: i64,
    p_kpa: i64,
) -> Option<&'a Pac2002> {
    let name = data
        .tir_names
        .get(&(tire.to_string(), rim_in, p_kpa))
        .cloned()
        .unwrap_or_else(|| tir_file_name(tire, rim_in as f64, p_kpa as f64));
    data.models.get(&name).map(|m| &m.model)
}

/// Label of a nominal load (or its rounded mean when not held).
fn load_label(seg: &PlotSegment) -> i64 {
    seg.segment
        .fz_n_nom
        .filter(|&f| f > 0)
        .unwrap_or_else(|| (seg.segment.fz_n_mean / 10.0).round() as i64 * 10)
}

/// Inclination level of a segment, hundredths of a degree: its nominal level (negative camber
/// included), else its measured mean labelled the same way.
fn ia_label(seg: &PlotSegment) -> i64 {
    seg.segment
        .ia_cdeg_nom
        .unwrap_or_else(|| ia_cdeg_label(seg.segment.ia_deg_mean))
}

/// How far from zero (hundredths of a degree) a level still counts as upright ("IA 0").
const UPRIGHT_CDEG: i64 = 50;

/// The tire's segments of one kind by (rim, nominal pressure, inclination label), then by load
/// label (segments without a held pressure belong to no group).
type ByGroupAndLoad<'a> = BTreeMap<(i64, i64, i64), BTreeMap<i64, Vec<&'a PlotSegment>>>;

fn by_group_and_load<'a>(data: &'a ReportData, tire: &str, kind: &str) -> ByGroupAndLoad<'a> {
    let mut groups = ByGroupAndLoad::new();
    for seg in data
        .segments
        .iter()
        .filter(|s| s.segment.tire == tire && s.segment.kind == kind)
    {
        let Some(p) = seg.segment.pressure_kpa_nom else {
            continue;
        };
        groups
            .entry((seg.segment.rim_in, p, ia_label(seg)))
            .or_default()
            .entry(load_label(seg))
            .or_default()
            .push(seg);
    }
    groups
}

fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for v in values.filter(|v| v.is_finite()) {
        sum += v;
        n += 1;
    }
    if n == 0 { f64::NAN } else { sum / n as f64 }
}

fn linspace(lo: f64, hi: f64, n: usize) -> impl Iterator<Item = f64> {
    (0..n).map(move |i| lo + (hi - lo) * i as f64 / (n - 1).max(1) as f64)
}

/// Fy-SA, Mz-SA or Fx-SL charts: one per (rim, pressure, inclination), one colour per load,
/// markers = measured (pooled, decimated), lines = the model at the group's mean load and
/// inclination over the swept range.
fn slip_charts(data: &ReportData, tire: &str, chart: SlipChart) -> Vec<Plot> {
    let groups = by_group_and_load(data, tire, chart.segment_kind());
    let mut plots = Vec::new();
    for ((rim, p, ia), loads) in &groups {
        let (x, y) = chart.axes();
        let model = model_for(data, tire, *rim, *p);
        let title = format!(
            "{} · {rim} in · {p} kPa · IA {}°",
            chart.label(),
            ia_cdeg_text(*ia)
        );
        let mut plot = Plot::new(String::new(), chart.kind(), title, x, y);
        for (color, (load, segs)) in loads.iter().enumerate() {
            plot.series
                .push(measured_series(segs, *load, color, |x| chart.xy_sample(x)));
            if let Some(model) = model {
                let curve = slip_model_curve(model, segs, chart);
                plot.series.push(Series::new("", color, Style::Line, curve));
            }
        }
        if model.is_none() {
            plot.title.push_str(" (no model)");
        }
        plots.push(plot);
    }
    if plots.is_empty() {
        let (x, y) = chart.axes();
        let mut plot = Plot::new(String::new(), chart.kind(), chart.label(), x, y);
        plot.missing_reason = format!("no QC-clean {} segments in the store", chart.segment_kind());
        plots.push(plot);
    }
    plots
}

/// The pooled segments' samples as measured markers (decimated), labelled by their load.
fn measured_series(
    segs: &[&PlotSegment],
    load: i64,
    color: usize,
    xy: impl Fn(&PlotSample) -> (f64, f64),
) -> Series {
    let pooled: Vec<(f64, f64)> = segs
        .iter()
        .flat_map(|s| s.samples.iter().map(&xy))
        .collect();
    let points = decimate(&pooled, MAX_POINTS_PER_SERIES);
    Series::new(format!("Fz {load} N"), color, Style::Markers, points)
}

/// The smallest low and the largest high end of a range the segments each record.
fn span(segs: &[&PlotSegment], range: impl Fn(&SegmentRecord) -> (f64, f64)) -> (f64, f64) {
    segs.iter()
        .map(|s| range(&s.segment))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (a, b)| {
            (lo.min(a), hi.max(b))
        })
}

/// The model over the pooled segments' swept range at their mean load, inclination and speed.
fn slip_model_curve(model: &Pac2002, segs: &[&PlotSegment], chart: SlipChart) -> Vec<(f64, f64)> {
    let fz_n = mean(segs.iter().map(|s| s.segment.fz_n_mean));
    let gamma_rad = mean(segs.iter().map(|s| s.segment.ia_deg_mean)).to_radians();
    let vx_mps = mean(segs.iter().map(|s| s.segment.speed_kph_mean)) / 3.6;
    let vx_mps = if vx_mps.is_finite() && vx_mps > 1.0 {
        vx_mps
    } else {
        11.1
    };
    let gamma_rad = if gamma_rad.is_finite() {
        gamma_rad
    } else {
        0.0
    };
    if !fz_n.is_finite() {
        return Vec::new();
    }
    let (lo, hi) = match chart {
        SlipChart::FxSl => span(segs, |s| (s.kappa_min, s.kappa_max)),
        _ => span(segs, |s| (s.alpha_deg_min, s.alpha_deg_max)),
    };
    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return Vec::new();
    }
    let alpha_held = mean(segs.iter().map(|s| s.segment.alpha_deg_mean)).to_radians();
    linspace(lo, hi, CURVE_POINTS)
        .map(|x| {
            let input = match chart {
                SlipChart::FxSl => SlipInput {
                    fz_n,
                    kappa: x,
                    alpha_rad: if alpha_held.is_finite() {
                        alpha_held
                    } else {
                        0.0
                    },
                    gamma_rad,
                    vx_mps,
                },
                _ => SlipInput {
                    fz_n,
                    kappa: 0.0,
                    alpha_rad: x.to_radians(),
                    gamma_rad,
                    vx_mps,
                },
            };
            let e = model.eval(&input, Mode::Limits);
            let y = match chart {
                SlipChart::FySa => e.fy_n,
                SlipChart::MzSa => e.mz_nm,
                SlipChart::FxSl => e.fx_n,
            };
            (x, y)
        })
        .collect()
}

/// Fy vs slip angle charts.
pub fn fy_sa(data: &ReportData, tire: &str) -> Vec<Plot> {
    slip_charts(data, tire, SlipChart::FySa)
}

/// Mz vs slip angle charts.
pub fn mz_sa(data: &ReportData, tire: &str) -> Vec<Plot> {
    slip_charts(data, tire, SlipChart::MzSa)
}

/// Fx vs longitudinal slip charts.
pub fn fx_sl(data: &ReportData, tire: &str) -> Vec<Plot> {
    slip_charts(data, tire, SlipChart::FxSl)
}

/// Friction envelope (seed figure 22): Fx against Fy, one chart per (rim, pressure,
/// inclination) of the combined-slip tests (or of the cornering tests when there are none), one
/// colour per load: markers = combined-slip data, closed line = outline (convex hull) of the
/// model over slip angle ±(largest tested |α|) × the tested κ range.
pub fn envelope(data: &ReportData, tire: &str) -> Vec<Plot> {
    let source = if data
        .segments
        .iter()
        .any(|s| s.segment.tire == tire && s.segment.kind == "combined")
    {
        "combined"
    } else {
        "cornering"
    };
    let groups = by_group_and_load(data, tire, source);
    let mut plots = Vec::new();
    for ((rim, p, ia), loads) in &groups {
        let model = model_for(data, tire, *rim, *p);
        let mut plot = Plot::new(
            String::new(),
            "envelope",
            format!(
                "Friction envelope · {rim} in · {p} kPa · IA {}°",
                ia_cdeg_text(*ia)
            ),
            Axis::from_zero("lateral force Fy (N)"),
            Axis::from_zero("longitudinal force Fx (N)"),
        );
        let alpha_max_deg = data
            .segments
            .iter()
            .filter(|s| {
                s.segment.tire == tire
                    && s.segment.rim_in == *rim
                    && s.segment.pressure_kpa_nom == Some(*p)
            })
            .flat_map(|s| [s.segment.alpha_deg_min.abs(), s.segment.alpha_deg_max.abs()])
            .filter(|a| a.is_finite())
            .fold(0.0, f64::max);
        let alpha_max_deg = if alpha_max_deg > 1.0 {
            alpha_max_deg
        } else {
            12.0
        };
        for (color, (load, segs)) in loads.iter().enumerate() {
            if source == "combined" {
                plot.series
                    .push(measured_series(segs, *load, color, |x| (x.fy_n, x.fx_n)));
            }
            if let Some(model) = model {
                let (k_lo, k_hi) = if source == "combined" {
                    span(segs, |s| (s.kappa_min, s.kappa_max))
                } else {
                    (-0.2, 0.2)
                };
                let (k_lo, k_hi) = if k_lo.is_finite() && k_hi > k_lo {
                    (k_lo, k_hi)
                } else {
                    (-0.2, 0.2)
                };
                let fz_n = mean(segs.iter().map(|s| s.segment.fz_n_mean));
                let gamma = mean(segs.iter().map(|s| s.segment.ia_deg_mean)).to_radians();
                let hull =
                    model_envelope(model, fz_n, gamma, alpha_max_deg.to_radians(), (k_lo, k_hi));
                let name = if source == "combined" {
                    String::new()
                } else {
                    format!("Fz {load} N (model)")
                };
                plot.series
                    .push(Series::new(name, color, Style::Line, hull));
            }
        }
        plot.missing_reason = "no combined-slip data and no model".to_string();
        plots.push(plot);
    }
    if plots.is_empty() {
        let mut plot = Plot::new(
            String::new(),
            "envelope",
            "Friction envelope",
            Axis::from_zero("lateral force Fy (N)"),
            Axis::from_zero("longitudinal force Fx (N)"),
        );
        plot.missing_reason = "no QC-clean combined or cornering segments in the store".to_string();
        plots.push(plot);
    }
    plots
}

/// Closed convex outline of the model's (Fy, Fx) over a slip-angle × slip grid.
fn model_envelope(
    model: &Pac2002,
    fz_n: f64,
    gamma_rad: f64,
    alpha_max: f64,
    kappa: (f64, f64),
) -> Vec<(f64, f64)> {
    if !fz_n.is_finite() {
        return Vec::new();
    }
    let gamma_rad = if gamma_rad.is_finite() {
        gamma_rad
    } else {
        0.0
    };
    let mut points = Vec::new();
    for alpha in linspace(-alpha_max, alpha_max, 31) {
        for k in linspace(kappa.0, kappa.1, 31) {
            let e = model.eval(
                &SlipInput {
                    fz_n,
                    kappa: k,
                    alpha_rad: alpha,
                    gamma_rad,
                    vx_mps: 11.1,
                },
                Mode::Limits,
            );
            if e.fx_n.is_finite() && e.fy_n.is_finite() {
                points.push((e.fy_n, e.fx_n));
            }
        }
    }
    let mut hull = convex_hull(points);
    if let Some(&first) = hull.first() {
        hull.push(first);
    }
    hull
}

/// Peak mu_y (seed figure 23) and cornering stiffness (figure 24) against load, one colour per
/// (rim, pressure): lines = model (pure lateral slip, IA 0) over the tested loads, markers =
/// per-segment values measured on the cornering data at IA 0.
pub fn peak_mu_and_stiffness(data: &ReportData, tire: &str) -> Vec<Plot> {
    let mut mu = Plot::new(
        String::new(),
        "peak_mu",
        "Peak lateral friction μy vs load (IA 0°)",
        Axis::from_zero("vertical load Fz (N)"),
        Axis::new("peak μy = |Fy|/Fz (-)"),
    );
    let mut ky = Plot::new(
        String::new(),
        "cornering_stiffness",
        "Cornering stiffness Kyα vs load (IA 0°)",
        Axis::from_zero("vertical load Fz (N)"),
        Axis::from_zero("cornering stiffness Kyα (N/rad, ISO-W)"),
    );
    let mut groups: BTreeMap<(i64, i64), Vec<&PlotSegment>> = BTreeMap::new();
    for seg in data
        .segments
        .iter()
        .filter(|s| s.segment.tire == tire && s.segment.kind == "cornering")
    {
        if let Some(p) = seg.segment.pressure_kpa_nom {
            groups.entry((seg.segment.rim_in, p)).or_default().push(seg);
        }
    }
    // Models without data still get their curves (at 25 % to 175 % of FNOMIN).
    for &(rim, p) in data.result_groups.get(tire).into_iter().flatten() {
        if model_for(data, tire, rim, p).is_some() {
            groups.entry((rim, p)).or_default();
        }
    }
    for (color, ((rim, p), segs)) in groups.iter().enumerate() {
        let label = format!("{p} kPa · {rim} in");
        let flat: Vec<&&PlotSegment> = segs
            .iter()
            .filter(|s| ia_label(s).abs() <= UPRIGHT_CDEG)
            .collect();
        let mu_pts: Vec<(f64, f64)> = flat
            .iter()
            .map(|s| (s.segment.fz_n_mean, s.stats.mu_y_peak))
            .collect();
        let ky_pts: Vec<(f64, f64)> = flat
            .iter()
            .map(|s| (s.segment.fz_n_mean, s.stats.cornering_stiffness_n_per_rad))
            .collect();
        mu.series.push(Series::new(
            format!("{label} data"),
            color,
            Style::Markers,
            mu_pts,
        ));
        ky.series.push(Series::new(
            format!("{label} data"),
            color,
            Style::Markers,
            ky_pts,
        ));
        if let Some(model) = model_for(data, tire, *rim, *p) {
            let fz0 = model.coefs[Coef::FNOMIN];
            let (lo, hi) = if segs.is_empty() {
                (0.25 * fz0, 1.75 * fz0)
            } else {
                (
                    segs.iter()
                        .map(|s| s.segment.fz_n_mean)
                        .fold(f64::INFINITY, f64::min),
                    segs.iter()
                        .map(|s| s.segment.fz_n_mean)
                        .fold(f64::NEG_INFINITY, f64::max),
                )
            };
            let (lo, hi) = if lo.is_finite() && hi > lo {
                (lo, hi)
            } else {
                (0.25 * fz0, 1.75 * fz0)
            };
            let (mut mu_line, mut ky_line) = (Vec::new(), Vec::new());
            for fz_n in linspace(lo, hi, 41) {
                let e = model.eval(
                    &SlipInput {
                        fz_n,
                        vx_mps: 11.1,
                        ..Default::default()
                    },
                    Mode::Limits,
                );
                mu_line.push((fz_n, e.muy));
                ky_line.push((fz_n, e.kya_n_per_rad));
            }
            mu.series.push(Series::new(
                format!("{label} model"),
                color,
                Style::Line,
                mu_line,
            ));
            ky.series.push(Series::new(
                format!("{label} model"),
                color,
                Style::Line,
                ky_line,
            ));
        }
    }
    mu.missing_reason = "no cornering data at IA 0 and no model".to_string();
    ky.missing_reason = mu.missing_reason.clone();
    vec![mu, ky]
}

/// Vertical stiffness against pressure: one series per (rim, condition, inclination).
pub fn spring_rate(data: &ReportData, tire: &str) -> Vec<Plot> {
    let mut plot = Plot::new(
        String::new(),
        "spring_rate",
        "Vertical stiffness vs pressure and IA",
        Axis::new("inflation pressure (kPa, nominal)"),
        Axis::from_zero("vertical stiffness Cz (kN/m)"),
    );
    let Some(rows) = &data.results.spring_rate else {
        plot.missing_reason = "spring_rate table not present".to_string();
        return vec![plot];
    };
    // (rim, condition, held inclination in hundredths of a degree: None when swept) -> points.
    type SeriesKey = (i64, String, Option<i64>);
    let mut series: BTreeMap<SeriesKey, Vec<(f64, f64)>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.tire == tire) {
        let key = (r.rim_in, r.condition.clone(), r.ia_cdeg_nom);
        series
            .entry(key)
            .or_default()
            .push((r.pressure_kpa as f64, r.stiffness_n_per_m / 1000.0));
    }
    for (color, ((rim, cond, ia), mut pts)) in series.into_iter().enumerate() {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let ia = match ia {
            None => "IA swept".to_string(),
            Some(ia) => format!("IA {}°", ia_cdeg_text(ia)),
        };
        plot.series.push(Series::new(
            format!("{cond} · {ia} · {rim} in"),
            color,
            Style::LineMarkers,
            pts,
        ));
    }
    plot.missing_reason =
        "no spring_rate rows for this tire with pressure_kpa and stiffness_n_per_m".to_string();
    vec![plot]
}

/// Peak mu against centre tread temperature (seed figure 29), one chart per (rim, pressure):
/// markers = the thermal table's peaks by quadrant, line = the thermal_fit mu(T) curve.
pub fn mu_temperature(data: &ReportData, tire: &str) -> Vec<Plot> {
    let mut groups: BTreeMap<(i64, i64), Plot> = BTreeMap::new();
    let new_plot = |rim: i64, p: i64| {
        let mut plot = Plot::new(
            String::new(),
            "mu_temperature",
            format!("Peak μy vs centre tread temperature · {rim} in · {p} kPa"),
            Axis::new("centre tread temperature (°C)"),
            Axis::new("peak |Fy|/Fz (-)"),
        );
        plot.missing_reason =
            "no finite t_centre_peak_c/mu_peak (thermal) or mu(T) curve (thermal_fit)".to_string();
        plot
    };
    let mut ranges: BTreeMap<(i64, i64), (f64, f64)> = BTreeMap::new();
    let results = &data.results;
    if let Some(rows) = &results.thermal {
        let mut by_quad: PointsByGroup = BTreeMap::new();
        for row in rows.iter().filter(|r| r.tire == tire) {
            let key = (row.rim_in, row.pressure_kpa);
            let t = row.t_centre_peak_c;
            by_quad
                .entry(key)
                .or_default()
                .entry(row.quadrant.clone())
                .or_default()
                .push((t, row.mu_peak));
            if t.is_finite() {
                let r = ranges
                    .entry(key)
                    .or_insert((f64::INFINITY, f64::NEG_INFINITY));
                *r = (r.0.min(t), r.1.max(t));
            }
        }
        for (key, quads) in by_quad {
            let plot = groups.entry(key).or_insert_with(|| new_plot(key.0, key.1));
            for (color, (q, pts)) in quads.into_iter().enumerate() {
                plot.series
                    .push(Series::new(q.replace('_', " "), color, Style::Markers, pts));
            }
        }
    }
    if let Some(rows) = &results.thermal_fit {
        for row in rows.iter().filter(|r| r.tire == tire) {
            let key = (row.rim_in, row.pressure_kpa);
            let (t_peak, k) = (row.t_peak_c, row.k_cold_per_c2);
            let (lo, hi) = match ranges.get(&key) {
                Some(&(lo, hi)) if hi > lo => (lo, hi),
                _ => (row.t_cold_c, t_peak + 20.0),
            };
            let hot = row.hot_falloff;
            let hot_k = if hot.is_finite() { hot } else { 1.0 } * k;
            let curve: Vec<(f64, f64)> = linspace(lo, hi, CURVE_POINTS)
                .map(|t| (t, row.mu_peak_mean * relative_grip(t, t_peak, k, hot_k)))
                .collect();
            let plot = groups.entry(key).or_insert_with(|| new_plot(key.0, key.1));
            plot.series
                .push(Series::new("μ(T) fit (mean level)", 4, Style::Line, curve));
        }
    }
    if groups.is_empty() {
        let mut plot = new_plot(0, 0);
        plot.title = "Peak μy vs centre tread temperature".to_string();
        plot.missing_reason = match (results.thermal.is_some(), results.thermal_fit.is_some()) {
            (false, false) => "thermal and thermal_fit tables not present".to_string(),
            _ => "no thermal rows for this tire".to_string(),
        };
        return vec![plot];
    }
    groups.into_values().collect()
}

/// Relaxation length against load, lateral and longitudinal: markers = the relaxation table
/// (one colour per rim, pressure and method), lines = the model's PTY/PTX law at IA 0.
pub fn relaxation(data: &ReportData, tire: &str) -> Vec<Plot> {
    let mut plots = Vec::new();
    for direction in ["lateral", "longitudinal"] {
        let symbol = if direction == "lateral" {
            "σα"
        } else {
            "σκ"
        };
        let mut plot = Plot::new(
            String::new(),
            "relaxation",
            format!(
                "{} relaxation length {symbol} vs load",
                capitalise(direction)
            ),
            Axis::from_zero("vertical load Fz (N)"),
            Axis::from_zero(format!("relaxation length {symbol} (mm)")),
        );
        let Some(rows) = &data.results.relaxation else {
            plot.missing_reason = "relaxation table not present".to_string();
            plots.push(plot);
            continue;
        };
        let mut series: PointsByGroup = BTreeMap::new();
        for r in rows.iter().filter(|r| {
            r.tire == tire && r.direction == direction && r.converged && r.sigma_m.is_finite()
        }) {
            series
                .entry((r.rim_in, r.pressure_kpa))
                .or_default()
                .entry(r.method.clone())
                .or_default()
                .push((r.fz_n_mean, r.sigma_m * 1000.0));
        }
        for (color, ((rim, p), by_method)) in series.into_iter().enumerate() {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for (method, pts) in by_method {
                for &(f, _) in pts.iter().filter(|(f, _)| f.is_finite()) {
                    lo = lo.min(f);
                    hi = hi.max(f);
                }
                plot.series.push(Series::new(
                    format!("{p} kPa · {rim} in · {method}"),
                    color,
                    Style::Markers,
                    pts,
                ));
            }
            if let Some(model) = model_for(data, tire, rim, p).filter(|_| hi > lo) {
                let law: Vec<(f64, f64)> = linspace(lo, hi, 41)
                    .map(|f| {
                        let (sk, sa) = relaxation_lengths(&model.coefs, f, 0.0);
                        (f, 1000.0 * if direction == "lateral" { sa } else { sk })
                    })
                    .collect();
                plot.series.push(Series::new("", color, Style::Line, law));
            }
        }
        plot.missing_reason = format!(
            "no converged {direction} relaxation rows for this tire with fz_n_mean and sigma_m"
        );
        plots.push(plot);
    }
    plots
}

fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_with_unexpected_columns_give_notes_not_panics() {
        use crate::store::results::{RESULT_TABLES, Results};
        let mut frames = BTreeMap::new();
        for name in RESULT_TABLES {
            let df = polars::prelude::df!("tire" => ["X", "X"], "something" => [1.0, 2.0]).unwrap();
            frames.insert(name.to_string(), df);
        }
        let empty = polars::prelude::df!("tire" => Vec::<String>::new()).unwrap();
        frames.insert("relaxation".to_string(), empty);
        let data = ReportData {
            results: Results::from_frames(&frames),
            ..ReportData::default()
        };
        assert_eq!(data.results.notes.len(), RESULT_TABLES.len());
        assert!(
            data.results
                .notes
                .iter()
                .all(|n| n.contains("unreadable") && n.contains("required column rim_in")),
            "{:?}",
            data.results.notes
        );
        for plots in [
            spring_rate(&data, "X"),
            mu_temperature(&data, "X"),
            relaxation(&data, "X"),
        ] {
            for p in plots {
                assert!(!p.has_data(), "{}", p.title);
                assert!(p.render().contains("plot-missing"));
            }
        }
    }

    #[test]
    fn charts_without_inputs_explain_what_is_missing() {
        let data = ReportData::default();
        for plots in [
            fy_sa(&data, "X"),
            fx_sl(&data, "X"),
            envelope(&data, "X"),
            spring_rate(&data, "X"),
            mu_temperature(&data, "X"),
            relaxation(&data, "X"),
            peak_mu_and_stiffness(&data, "X"),
        ] {
            assert!(!plots.is_empty());
            for p in plots {
                assert!(!p.has_data(), "{}", p.title);
                assert!(!p.missing_reason.is_empty());
            }
        }
    }
}
