//! The report's front page: tire selection at the car's conditions (`crate::compare`).
//!
//! In: [`ReportData`] (the models and tables), a [`Comparison`] of its round and the car. Out:
//! one HTML section: a pressure selector (radio inputs and CSS, no script: "best tested
//! pressure" or one tested pressure), per pressure the charts of peak mu_y and cornering
//! stiffness against load (one line per tire and rim, at each tire's design camber; the car's
//! corner loads marked), peak mu_y against camber at the nominal load (the design camber
//! marked) and the thermal window (grip relative to its optimum against tread temperature);
//! the friction envelopes of the top tires at their best pressure overlaid; the ranked
//! comparison table. Model lines are drawn solid inside the tested load range and dashed where
//! the model extrapolates.
//!
//! Deliberately not here: computing the figures (`tirebase_core::compare`), the rest of the
//! index page (pages.rs).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use tirebase_core::compare::{
    LoadFigures, Pac2002Tire, SteadyStateTire, cornering_stiffness, envelope_outline, peak_fy,
};
use tirebase_core::fit::thermal::relative_grip;

use polars::prelude::{AnyValue, DataFrame};

use super::data::ReportData;
use super::pages::{Cell, grid_html};
use super::svg::{Axis, Plot, Series, Style, escape};
use crate::compare::{CompareRow, Comparison};

/// Tires whose envelopes are overlaid.
const TOP_ENVELOPES: usize = 4;
/// Points along a curve.
const CURVE_POINTS: usize = 41;

/// The section and its chart counts (drawn, without data), plus the CSS of its selector.
pub struct SelectionSection {
    /// HTML.
    pub html: String,
    /// Extra CSS for the page head.
    pub css: String,
    /// Charts drawn.
    pub drawn: usize,
    /// Chart slots with a "no data" note.
    pub missing: usize,
}

/// One choice of the pressure selector.
struct Choice {
    /// Element id suffix.
    id: String,
    /// Label.
    label: String,
    /// Indices into the comparison's rows shown under it (one per tire and rim).
    rows: Vec<usize>,
}

/// `(tire, rim)` label of a row for legends: rim first, so that a shortened legend keeps it,
/// and without the first word of the name when every tire of the comparison shares it (the
/// brand), so that the part that differs fits.
fn tire_label(c: &Comparison, r: &CompareRow) -> String {
    let first = |t: &str| t.split_once(' ').map(|(w, _)| w.to_string());
    let shared = first(&r.tire).filter(|w| {
        c.rows
            .iter()
            .all(|o| first(&o.tire).as_deref() == Some(w.as_str()))
    });
    let name = match shared {
        Some(w) => r.tire[w.len()..].trim_start(),
        None => r.tire.as_str(),
    };
    format!("{} in {name}", r.rim_in)
}

/// A row's model, ready to evaluate (None when its `.tir` is not loaded).
fn tire_of(data: &ReportData, r: &CompareRow, max_load: f64) -> Option<Pac2002Tire> {
    let key = (r.tire.clone(), r.rim_in, r.pressure_kpa);
    let file = data.tir_names.get(&key).cloned().unwrap_or_else(|| {
        tirebase_core::naming::tir_file_name(&r.tire, r.rim_in as f64, r.pressure_kpa as f64)
    });
    data.models
        .get(&file)
        .map(|m| Pac2002Tire::new(&m.model, m.use_mode, max_load))
}

/// The selector's choices: each (tire, rim) at its best tested pressure, then each pressure.
fn choices(c: &Comparison) -> Vec<Choice> {
    let mut best: BTreeMap<(String, i64), usize> = BTreeMap::new();
    let mut by_pressure: BTreeMap<i64, Vec<usize>> = BTreeMap::new();
    for (i, r) in c.rows.iter().enumerate() {
        if r.best_pressure {
            // Rows come in rank order: the first flagged row of a tire and rim is its best.
            best.entry((r.tire.clone(), r.rim_in)).or_insert(i);
        }
        by_pressure.entry(r.pressure_kpa).or_default().push(i);
    }
    let mut out = vec![Choice {
        id: "best".to_string(),
        label: "best tested pressure of each tire".to_string(),
        rows: best.into_values().collect(),
    }];
    for (p, rows) in by_pressure {
        out.push(Choice {
            id: format!("{p}kpa"),
            label: format!("{p} kPa"),
            rows,
        });
    }
    out
}

/// A stable colour per (tire, rim) across every chart.
fn colours(c: &Comparison) -> BTreeMap<(String, i64), usize> {
    let mut keys: Vec<(String, i64)> = c.rows.iter().map(|r| (r.tire.clone(), r.rim_in)).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter().enumerate().map(|(i, k)| (k, i)).collect()
}

fn linspace(lo: f64, hi: f64, n: usize) -> impl Iterator<Item = f64> {
    (0..n).map(move |i| lo + (hi - lo) * i as f64 / (n - 1).max(1) as f64)
}

/// Push a model curve split into its tested part (solid, named) and its extrapolated part
/// (dashed, unnamed).
fn push_curve(
    plot: &mut Plot,
    name: String,
    color: usize,
    points: Vec<(f64, f64)>,
    tested: impl Fn(f64) -> bool,
) {
    let inside: Vec<(f64, f64)> = points.iter().copied().filter(|p| tested(p.0)).collect();
    let extrapolated = inside.len() < points.len();
    plot.series
        .push(Series::new(name, color, Style::Line, inside));
    if extrapolated {
        // Keep the dashed part joined to the solid one (a NaN point breaks the line between
        // the low and the high extrapolated ends).
        let mut dashed = Vec::new();
        for w in points.windows(2) {
            let (a, b) = (w[0], w[1]);
            if !tested(a.0) || !tested(b.0) {
                if dashed.last() != Some(&a) {
                    if !dashed.is_empty() {
                        dashed.push((f64::NAN, f64::NAN));
                    }
                    dashed.push(a);
                }
                dashed.push(b);
            }
        }
        plot.series
            .push(Series::new("", color, Style::Dashed, dashed));
    }
}

/// The charts of one choice: peak mu_y and cornering stiffness against load, mu_y against
/// camber, thermal window.
fn choice_charts(
    data: &ReportData,
    c: &Comparison,
    choice: &Choice,
    colour: &BTreeMap<(String, i64), usize>,
) -> Vec<Plot> {
    let cond = &c.car.conditions;
    let loads = &cond.loads_n;
    let (lo, hi) = (0.5 * loads[0], 1.25 * loads[loads.len() - 1]);
    // `sel-<id>-<choice>`, the title ending with the choice's label
    let plot = |id: &str, kind: &str, title: String, x: Axis, y: Axis| {
        let title = format!("{title} · {}", choice.label);
        Plot::new(format!("sel-{id}-{}", choice.id), kind, title, x, y)
    };
    let load_axis = || Axis::from_zero("vertical load Fz (N)");
    let mu_axis = || Axis::new("peak μy = |Fy|/Fz (-)");
    let mut mu = plot(
        "mu",
        "sel_peak_mu",
        "Peak μy vs load at the design camber".into(),
        load_axis(),
        mu_axis(),
    );
    let mut ky = plot(
        "ky",
        "sel_cornering_stiffness",
        "Cornering stiffness vs load".into(),
        load_axis(),
        Axis::from_zero("cornering stiffness |dFy/dα| (kN/rad)"),
    );
    let mut camber = plot(
        "camber",
        "sel_camber",
        format!("Peak μy vs camber at Fz = {:.0} N", cond.nominal_load_n),
        Axis::from_zero("inclination, leaning into the turn (deg)"),
        mu_axis(),
    );
    let max_load = hi.max(cond.nominal_load_n);
    for &i in &choice.rows {
        let r = &c.rows[i];
        // every chart here is lateral: a model without Fy (USE_MODE 1) has no curve
        let Some(tire) = tire_of(data, r, max_load).filter(|t| t.has_lateral()) else {
            continue;
        };
        let color = colour[&(r.tire.clone(), r.rim_in)];
        let label = tire_label(c, r);
        let g = r.figures.camber_rad;
        let (f_lo, f_hi) = tire.ranges().fz_n;
        let tested = |f: f64| f >= f_lo * (1.0 - 1e-9) && f <= f_hi * (1.0 + 1e-9);
        // the model over the load span (extrapolation dashed), and the row's figure per load
        let vs_load =
            |plot: &mut Plot, model: &dyn Fn(f64) -> f64, figure: fn(&LoadFigures) -> f64| {
                let curve = linspace(lo, hi, CURVE_POINTS)
                    .map(|f| (f, model(f)))
                    .collect();
                push_curve(plot, label.clone(), color, curve, tested);
                let markers = r
                    .figures
                    .loads
                    .iter()
                    .map(|l| (l.fz_n, figure(l)))
                    .collect();
                plot.series
                    .push(Series::new("", color, Style::Markers, markers));
            };
        vs_load(&mut mu, &|f| peak_fy(&tire, cond, f, g) / f, |l| {
            l.mu_y_peak
        });
        vs_load(
            &mut ky,
            &|f| cornering_stiffness(&tire, cond, f, g) / 1000.0,
            |l| l.cornering_stiffness_n_per_rad / 1000.0,
        );
        let (g_lo, g_hi) = tire.ranges().gamma_rad;
        let g_lo = g_lo.max(0.0);
        let curve: Vec<(f64, f64)> = linspace(g_lo, g_hi.max(g_lo), CURVE_POINTS)
            .map(|x| {
                (
                    x.to_degrees(),
                    peak_fy(&tire, cond, cond.nominal_load_n, x) / cond.nominal_load_n,
                )
            })
            .collect();
        camber
            .series
            .push(Series::new(label, color, Style::Line, curve));
        camber.series.push(Series::new(
            "",
            color,
            Style::Markers,
            vec![(
                g.to_degrees(),
                r.figures.fy_peak_nominal_n / cond.nominal_load_n,
            )],
        ));
    }
    for p in [&mut mu, &mut ky, &mut camber] {
        p.missing_reason = "no fitted model at this pressure".to_string();
    }
    vec![mu, ky, camber, thermal_chart(data, c, choice, colour)]
}

/// Grip relative to its optimum against tread temperature, per tire and rim whose thermal
/// window was measured (thermal_fit: `1 - k (T - t_opt)^2`, `k` below and `hot_falloff k`
/// above the optimum, from the cold reference to 25 degC past the optimum).
fn thermal_chart(
    data: &ReportData,
    c: &Comparison,
    choice: &Choice,
    colour: &BTreeMap<(String, i64), usize>,
) -> Plot {
    let mut plot = Plot::new(
        format!("sel-thermal-{}", choice.id),
        "sel_thermal",
        format!("Thermal window · {}", choice.label),
        Axis::new("centre tread temperature (°C)"),
        Axis::new("peak grip / grip at the optimum (-)"),
    );
    plot.missing_reason =
        "no thermal window measured (no converged mu(T) fit with an optimum)".to_string();
    let Some(fits) = &data.results.thermal_fit else {
        return plot;
    };
    for &i in &choice.rows {
        let r = &c.rows[i];
        let Some(t_opt) = r.thermal.t_opt_c else {
            continue;
        };
        let Some(fit) = fits
            .iter()
            .find(|f| f.tire == r.tire && f.rim_in == r.rim_in && f.pressure_kpa == r.pressure_kpa)
        else {
            continue;
        };
        let k = fit.k_cold_per_c2;
        let hot_k = if fit.hot_falloff.is_finite() {
            fit.hot_falloff
        } else {
            1.0
        } * k;
        let from = if fit.t_cold_c.is_finite() {
            fit.t_cold_c
        } else {
            t_opt - 30.0
        };
        let curve: Vec<(f64, f64)> = linspace(from, t_opt + 25.0, CURVE_POINTS)
            .map(|t| (t, relative_grip(t, t_opt, k, hot_k)))
            .collect();
        let color = colour[&(r.tire.clone(), r.rim_in)];
        plot.series
            .push(Series::new(tire_label(c, r), color, Style::Line, curve));
        plot.series
            .push(Series::new("", color, Style::Markers, vec![(t_opt, 1.0)]));
    }
    plot
}

/// The friction envelopes of the top tires (by rank, one row per tire and rim, at its best
/// pressure) at the nominal load, overlaid.
fn envelope_chart(
    data: &ReportData,
    c: &Comparison,
    colour: &BTreeMap<(String, i64), usize>,
) -> Plot {
    let cond = &c.car.conditions;
    let mut plot = Plot::new(
        "sel-envelope",
        "sel_envelope",
        format!(
            "Friction envelope at Fz = {:.0} N, top {TOP_ENVELOPES} at their best pressure",
            cond.nominal_load_n
        ),
        Axis::from_zero("lateral force Fy (N)"),
        Axis::from_zero("longitudinal force Fx (N)"),
    );
    plot.missing_reason = "no model with a fitted combined-slip part".to_string();
    let mut seen = Vec::new();
    for r in c.rows.iter().filter(|r| r.best_pressure) {
        let key = (r.tire.clone(), r.rim_in);
        if seen.contains(&key) || seen.len() >= TOP_ENVELOPES {
            continue;
        }
        let Some(tire) = tire_of(data, r, cond.nominal_load_n) else {
            continue;
        };
        if !tire.has_combined_slip() {
            continue;
        }
        let outline: Vec<(f64, f64)> =
            envelope_outline(&tire, cond, cond.nominal_load_n, r.figures.camber_rad)
                .into_iter()
                .map(|(fx, fy)| (fy, fx))
                .collect();
        plot.series.push(Series::new(
            format!("{} {}kPa", tire_label(c, r), r.pressure_kpa),
            colour[&key],
            Style::Line,
            outline,
        ));
        seen.push(key);
    }
    plot
}

/// Columns of the comparison table on the front page (those present).
fn table_columns(c: &Comparison) -> Vec<String> {
    let mut cols: Vec<String> = [
        "rank",
        "tied_with",
        "tire",
        "rim_in",
        "pressure_kpa",
        "best_pressure",
        "lateral_mu",
        "objective_error",
        "longitudinal_mu",
        "camber_deg",
        "camber_gain_pct",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for fz in c.car.loads_whole_n() {
        cols.push(format!("mu_y_peak_fz{fz}"));
    }
    cols.extend(
        [
            "mu_y_load_sensitivity_per_kn",
            "cornering_stiffness_n_per_rad",
            "longitudinal_stiffness_n",
            "envelope_area_kn2",
            "relaxation_length_lateral_m",
            "relaxation_length_longitudinal_m",
            "vertical_stiffness_n_per_m",
            "t_opt_c",
            "thermal_gain_pct",
            "warmup_rate_c_per_s",
            "extrapolated_loads_n",
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    cols
}

/// The columns of the comparison frame named in `columns` (those present) as an HTML table.
fn frame_html(df: &DataFrame, columns: &[String]) -> String {
    let cols: Vec<&String> = columns
        .iter()
        .filter(|c| df.column(c.as_str()).is_ok())
        .collect();
    let cell = |c: &str, i: usize| match df.column(c).ok().and_then(|col| col.get(i).ok()) {
        Some(AnyValue::Float64(x)) => Cell::Float(x),
        Some(AnyValue::Int64(x)) => Cell::Int(x),
        Some(AnyValue::Boolean(b)) => Cell::Bool(b),
        Some(AnyValue::String(s)) => Cell::Text(s.to_string()),
        Some(AnyValue::StringOwned(s)) => Cell::Text(s.to_string()),
        Some(AnyValue::Null) | None => Cell::Empty,
        Some(other) => Cell::Text(other.to_string()),
    };
    grid_html(
        &cols,
        (0..df.height()).map(|i| (false, cols.iter().map(|c| cell(c, i)).collect())),
    )
}

/// The whole section.
pub fn section(data: &ReportData, c: &Comparison) -> SelectionSection {
    let mut out = String::from("<h2 id=\"selection\">Tire selection</h2>\n");
    let _ = writeln!(
        out,
        "<p class=\"note\">Every tire, rim and tested pressure evaluated from its fitted model at \
         the car's conditions: {}. Lines: the model at each tire's design camber (dashed where the \
         load is outside its tested range); markers: the car's corner loads, the design camber, \
         the optimum temperature. Ranked by lateral capacity (sum of peak |Fy| over the corner \
         loads / sum of the loads); differences within the fit's own error are ties. The same \
         table: <code>tirebase compare --store STORE</code>.</p>",
        escape(&c.car.describe())
    );
    let mut css = String::from(".psel{margin-left:1em}.ppanel{display:none}");
    if c.rows.is_empty() {
        out.push_str("<p class=\"note\">no fitted tire, rim and pressure to compare</p>\n");
        return SelectionSection {
            html: out,
            css,
            drawn: 0,
            missing: 0,
        };
    }
    let colour = colours(c);
    let choices = choices(c);
    let (mut drawn, mut missing) = (0, 0);
    let mut count = |p: &Plot| {
        if p.has_data() {
            drawn += 1;
        } else {
            missing += 1;
        }
    };
    // The radio inputs are siblings of the panels' container, so `:checked ~` reaches it.
    out.push_str("<div class=\"selector\">\n<span>Pressure:</span>");
    for (k, ch) in choices.iter().enumerate() {
        let checked = if k == 0 { " checked" } else { "" };
        let _ = write!(
            out,
            "\n<input type=\"radio\" class=\"psel\" name=\"psel\" id=\"psel-{id}\"{checked}>\
             <label for=\"psel-{id}\">{}</label>",
            escape(&ch.label),
            id = ch.id
        );
        let _ = write!(
            css,
            "#psel-{id}:checked~.ppanels #ppanel-{id}{{display:flex;flex-wrap:wrap;gap:10px}}",
            id = ch.id
        );
    }
    out.push_str("\n<div class=\"ppanels\">\n");
    for ch in &choices {
        let _ = writeln!(out, "<div class=\"ppanel\" id=\"ppanel-{}\">", ch.id);
        for plot in choice_charts(data, c, ch, &colour) {
            count(&plot);
            out.push_str(&plot.render());
        }
        out.push_str("</div>\n");
    }
    out.push_str("</div>\n</div>\n");
    let envelope = envelope_chart(data, c, &colour);
    count(&envelope);
    out.push_str("<div class=\"plots\">\n");
    out.push_str(&envelope.render());
    out.push_str("</div>\n");
    out.push_str("<h3 id=\"comparison\">Comparison at the car's conditions</h3>\n");
    match crate::compare::table::to_frame(c) {
        Ok(df) => out.push_str(&frame_html(&df, &table_columns(c))),
        Err(e) => {
            let _ = writeln!(
                out,
                "<p class=\"warn\">comparison table unavailable: {}</p>",
                escape(&e.to_string())
            );
        }
    }
    if !c.notes.is_empty() {
        out.push_str("<ul class=\"note\">\n");
        for n in &c.notes {
            let _ = writeln!(out, "<li>{}</li>", escape(n));
        }
        out.push_str("</ul>\n");
    }
    SelectionSection {
        html: out,
        css,
        drawn,
        missing,
    }
}
