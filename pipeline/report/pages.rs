//! HTML pages of the report: the index (round overview, fit quality with the worst entries
//! highlighted, lint warnings, failures, unreadable inputs, links) and one page per tire (its
//! charts and tables).
//!
//! In: [`ReportData`]. Out: (file name, HTML) pairs, index first, plus chart counts. Pages are
//! plain HTML5 with one inline `<style>`; no script, no external resource.
//!
//! Deliberately not here: chart contents (plots.rs), SVG drawing (svg.rs), writing files.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use tirebase_core::naming::sanitize_tire;

use super::data::ReportData;
use super::plots;
use super::selection::SelectionSection;
use super::svg::{Plot, escape};
use crate::compare::Comparison;
use crate::schema::TableName;
use crate::store::results::{CoefficientRecord, FitFailure, LintRow, QualityRow};

/// Rows of fit quality highlighted as the worst of the round.
const WORST_FITS: usize = 3;

/// The pages and what they hold.
pub struct Built {
    /// (file name, HTML), index first.
    pub pages: Vec<(String, String)>,
    /// Charts drawn.
    pub plots: usize,
    /// Chart slots with a "no data" note.
    pub plots_without_data: usize,
}

const STYLE: &str = "body{font-family:sans-serif;margin:1.5em auto;max-width:1400px;color:#222}\
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ccc}\
table{border-collapse:collapse;font-size:.85em;margin:.5em 0}\
th,td{border:1px solid #ccc;padding:2px 6px;text-align:left}th{background:#f0f0f0}\
td.num{text-align:right;font-variant-numeric:tabular-nums}\
tr.worst td{background:#fde2e2;font-weight:bold}\
.plots{display:flex;flex-wrap:wrap;gap:10px}\
svg.plot{border:1px solid #ddd;background:#fafafa}\
.plot-missing{width:620px;height:120px;border:1px dashed #bbb;padding:4px 10px;color:#666}\
.plot-missing h4{margin:.3em 0}.note{color:#666;font-size:.9em}\
.warn{color:#a33}";

/// Build every page; the index opens with the tire selection of `comparison`.
pub fn build(data: &ReportData, comparison: &Comparison) -> Built {
    let names = page_names(&data.tires);
    let worst_order = worst_fit_rows(data);
    let worst: BTreeSet<usize> = worst_order.iter().copied().collect();
    let mut built = Built {
        pages: Vec::new(),
        plots: 0,
        plots_without_data: 0,
    };
    let mut tire_pages = Vec::new();
    for (tire, file) in data.tires.iter().zip(&names) {
        let (html, drawn, missing) = tire_page(data, tire, &worst);
        built.plots += drawn;
        built.plots_without_data += missing;
        tire_pages.push((file.clone(), html));
    }
    let selection = super::selection::section(data, comparison);
    built.plots += selection.drawn;
    built.plots_without_data += selection.missing;
    let index = index_page(
        data,
        &names,
        &worst_order,
        &selection,
        (built.plots, built.plots_without_data),
    );
    built.pages.push(("index.html".to_string(), index));
    built.pages.extend(tire_pages);
    built
}

/// `tire-<sanitised name>.html`, made unique with a counter if two names sanitise alike.
fn page_names(tires: &[String]) -> Vec<String> {
    let mut seen = BTreeSet::new();
    tires
        .iter()
        .map(|t| {
            let base = format!("tire-{}", sanitize_tire(t));
            let mut name = format!("{base}.html");
            let mut k = 2;
            while !seen.insert(name.clone()) {
                name = format!("{base}-{k}.html");
                k += 1;
            }
            name
        })
        .collect()
}

fn head(title: &str) -> String {
    head_with(title, "")
}

/// The page head with `css` appended to the shared style.
fn head_with(title: &str, css: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<style>{STYLE}{css}</style>\n</head>\n<body>\n",
        escape(title)
    )
}

/// Row indices of the fit-quality table flagged as the worst of the round, worst first: the
/// largest out-of-sample RMSE in percent of the channel's peak (the in-sample one where a row
/// has no out-of-sample figure), or the lowest R² when no row has either.
fn worst_fit_rows(data: &ReportData) -> Vec<usize> {
    let Some(rows) = &data.results.fit_quality else {
        return Vec::new();
    };
    let badness: Vec<f64> = if rows.iter().any(|q| q.headline_pct_of_peak().is_some()) {
        rows.iter()
            .map(|q| q.headline_pct_of_peak().unwrap_or(f64::NAN))
            .collect()
    } else {
        rows.iter()
            .map(|q| 1.0 - q.r2.unwrap_or(f64::NAN))
            .collect()
    };
    let mut order: Vec<usize> = (0..rows.len())
        .filter(|&i| badness[i].is_finite())
        .collect();
    order.sort_by(|&a, &b| badness[b].total_cmp(&badness[a]).then(a.cmp(&b)));
    order.truncate(WORST_FITS);
    order
}

/// The worst-fits table: each row's out-of-sample and in-sample RMSE in percent of the
/// channel's peak side by side, in the order of [`worst_fit_rows`] (out-of-sample first).
fn worst_fits_html(rows: &[QualityRow], worst: &[usize]) -> String {
    const COLUMNS: &[&str] = &[
        "tire",
        "rim_in",
        "pressure_kpa",
        "model",
        "channel",
        "oos_pct_of_peak",
        "rmse_pct_of_peak",
        "oos_ratio",
        "oos_folds",
        "ranked_by",
    ];
    let cells = worst.iter().map(|&i| {
        let q = &rows[i];
        let oos_pct = q.oos_pct_of_peak();
        let ranked_by = match (oos_pct, q.oos_folds) {
            (Some(_), Some(k)) if k > 0 => format!("out-of-sample ({k}-fold by sweep)"),
            (Some(_), _) => "out-of-sample".to_string(),
            (None, _) if q.rmse_pct_of_peak.is_some_and(f64::is_finite) => {
                "in-sample (no out-of-sample figure)".to_string()
            }
            (None, _) => "1 - r2".to_string(),
        };
        let row = vec![
            text(&q.tire),
            Cell::Int(q.rim_in),
            Cell::Int(q.pressure_kpa),
            text(&q.model),
            text(&q.channel),
            float(oos_pct),
            float(q.rmse_pct_of_peak),
            float(q.oos_ratio),
            int(q.oos_folds),
            Cell::Text(ranked_by),
        ];
        (true, row)
    });
    let mut out = String::from(
        "<p class=\"note\">ordered by the out-of-sample RMSE in percent of the channel's peak \
         (oos_pct_of_peak = rmse_pct_of_peak x oos_ratio, k-fold by sweep); the in-sample figure \
         where a row has no out-of-sample one</p>\n",
    );
    out.push_str(&grid_html(COLUMNS, cells));
    out
}

/// One cell of a result table as shown.
pub(super) enum Cell {
    Text(String),
    Int(i64),
    Float(f64),
    Bool(bool),
    Empty,
}

/// A typed result row shown as an HTML table row: its columns and its cells.
trait Tabular {
    /// Column headers, in order.
    fn columns() -> Vec<&'static str>;
    /// The row's tire.
    fn tire(&self) -> &str;
    /// One cell per column.
    fn cells(&self) -> Vec<Cell>;
}

fn text(s: &str) -> Cell {
    Cell::Text(s.to_string())
}

fn float(v: Option<f64>) -> Cell {
    v.map_or(Cell::Empty, Cell::Float)
}

fn int(v: Option<i64>) -> Cell {
    v.map_or(Cell::Empty, Cell::Int)
}

/// Fit-quality columns shown, the out-of-sample error and the deviation between the fitted
/// points first. `seconds` (wall time) is left out so the same results give the same report
/// bytes.
impl Tabular for QualityRow {
    fn columns() -> Vec<&'static str> {
        vec![
            "tire",
            "rim_in",
            "pressure_kpa",
            "model",
            "channel",
            "oos_rmse",
            "rmse",
            "oos_ratio",
            "oos_flag",
            "trend_dev_max",
            "trend_dev_pct_of_peak",
            "n_free",
            "jacobian_rank",
            "condition_number",
            "n",
            "rmse_pct_of_peak",
            "r2",
            "sample_rmse",
            "initial_rmse",
            "iterations",
            "termination",
        ]
    }
    fn tire(&self) -> &str {
        &self.tire
    }
    fn cells(&self) -> Vec<Cell> {
        vec![
            text(&self.tire),
            Cell::Int(self.rim_in),
            Cell::Int(self.pressure_kpa),
            text(&self.model),
            text(&self.channel),
            float(self.oos_rmse),
            float(self.rmse),
            float(self.oos_ratio),
            self.oos_flag.map_or(Cell::Empty, Cell::Bool),
            float(self.trend_dev_max),
            float(self.trend_dev_pct_of_peak),
            int(self.n_free),
            int(self.jacobian_rank),
            float(self.condition_number),
            int(self.n),
            float(self.rmse_pct_of_peak),
            float(self.r2),
            float(self.sample_rmse),
            float(self.initial_rmse),
            int(self.iterations),
            self.termination.as_deref().map_or(Cell::Empty, text),
        ]
    }
}

/// A row of a table the report shows whole: its columns are the schema's, in the schema's order
/// (`schemas/<table>.toml`, the one definition of them), each cell looked up by column name.
trait SchemaRow {
    /// The table.
    const TABLE: TableName;
    /// The row's tire.
    fn row_tire(&self) -> &str;
    /// The cell of `column` (`Cell::Empty` for a column the row does not know).
    fn cell(&self, column: &str) -> Cell;
}

impl<T: SchemaRow> Tabular for T {
    fn columns() -> Vec<&'static str> {
        crate::schema::table(T::TABLE)
            .columns
            .iter()
            .map(|c| c.name.as_str())
            .collect()
    }
    fn tire(&self) -> &str {
        self.row_tire()
    }
    fn cells(&self) -> Vec<Cell> {
        Self::columns().into_iter().map(|c| self.cell(c)).collect()
    }
}

/// The cell of a group column (`tire`, `rim_in`, `pressure_kpa`: every result table has them),
/// `Cell::Empty` for any other.
fn group_cell(tire: &str, rim_in: i64, pressure_kpa: i64, column: &str) -> Cell {
    match column {
        "tire" => text(tire),
        "rim_in" => Cell::Int(rim_in),
        "pressure_kpa" => Cell::Int(pressure_kpa),
        _ => Cell::Empty,
    }
}

impl SchemaRow for LintRow {
    const TABLE: TableName = TableName::Lint;
    fn row_tire(&self) -> &str {
        &self.tire
    }
    fn cell(&self, column: &str) -> Cell {
        match column {
            "model" => text(&self.model),
            "file" => text(&self.file),
            "severity" => text(&self.severity),
            "code" => text(&self.code),
            "message" => text(&self.message),
            _ => group_cell(&self.tire, self.rim_in, self.pressure_kpa, column),
        }
    }
}

impl SchemaRow for FitFailure {
    const TABLE: TableName = TableName::FitFailures;
    fn row_tire(&self) -> &str {
        &self.tire
    }
    fn cell(&self, column: &str) -> Cell {
        match column {
            "stage" => text(&self.stage),
            "scope" => text(&self.scope),
            "fatal" => Cell::Bool(self.fatal),
            "reason" => text(&self.reason),
            _ => group_cell(&self.tire, self.rim_in, self.pressure_kpa, column),
        }
    }
}

/// A coefficient at a bound, shown on its tire's page (the tire is the page's).
impl Tabular for CoefficientRecord {
    fn columns() -> Vec<&'static str> {
        vec![
            "rim_in",
            "pressure_kpa",
            "model",
            "family",
            "name",
            "value",
            "std_error",
        ]
    }
    fn tire(&self) -> &str {
        &self.tire
    }
    fn cells(&self) -> Vec<Cell> {
        vec![
            Cell::Int(self.rim_in),
            Cell::Int(self.pressure_kpa),
            text(&self.model),
            text(&self.family),
            text(&self.name),
            Cell::Float(self.value),
            float(self.std_error),
        ]
    }
}

/// Rows of a result table (by index) as HTML; `worst` rows highlighted.
fn table_html<T: Tabular>(rows: &[T], show: &[usize], worst: &BTreeSet<usize>) -> String {
    grid_html(
        &T::columns(),
        show.iter().map(|&i| (worst.contains(&i), rows[i].cells())),
    )
}

/// A table of `headers` and rows of cells (each flagged when highlighted as worst) as HTML.
pub(super) fn grid_html<H: AsRef<str>>(
    headers: &[H],
    rows: impl Iterator<Item = (bool, Vec<Cell>)>,
) -> String {
    let mut out = String::from("<table>\n<tr>");
    for c in headers {
        let _ = write!(out, "<th>{}</th>", escape(c.as_ref()));
    }
    out.push_str("</tr>\n");
    for (is_worst, cells) in rows {
        let class = if is_worst { " class=\"worst\"" } else { "" };
        let _ = write!(out, "<tr{class}>");
        for cell in cells {
            let (text, num) = match cell {
                Cell::Float(x) => (format_sig(x), true),
                Cell::Int(x) => (x.to_string(), true),
                Cell::Empty => (String::new(), false),
                Cell::Text(s) => (s, false),
                Cell::Bool(b) => (b.to_string(), false),
            };
            let class = if num { " class=\"num\"" } else { "" };
            let _ = write!(out, "<td{class}>{}</td>", escape(&text));
        }
        out.push_str("</tr>\n");
    }
    out.push_str("</table>\n");
    out
}

/// Up to 5 significant digits, plain notation for moderate magnitudes.
fn format_sig(x: f64) -> String {
    if !x.is_finite() {
        return x.to_string();
    }
    let a = x.abs();
    if a != 0.0 && !(1e-3..1e6).contains(&a) {
        format!("{x:.4e}")
    } else {
        let digits = if a == 0.0 {
            0
        } else {
            (4 - a.log10().floor() as i64).max(0) as usize
        };
        format!("{x:.digits$}")
    }
}

/// A section showing a result table's rows for one tire (or all rows when `tire` is None).
fn table_section<T: Tabular>(
    rows: Option<&[T]>,
    table: &str,
    title: &str,
    tire: Option<&str>,
    worst: &BTreeSet<usize>,
) -> String {
    let mut out = format!("<h2 id=\"{}\">{}</h2>\n", escape(table), escape(title));
    let Some(rows) = rows else {
        let _ = writeln!(
            out,
            "<p class=\"note\">no data: {table}.parquet not present</p>"
        );
        return out;
    };
    let show: Vec<usize> = (0..rows.len())
        .filter(|&i| tire.is_none_or(|t| rows[i].tire() == t))
        .collect();
    if show.is_empty() {
        let _ = writeln!(out, "<p class=\"note\">none</p>");
        return out;
    }
    out.push_str(&table_html(rows, &show, worst));
    out
}

/// One tire's page and its (drawn, missing) chart counts.
fn tire_page(data: &ReportData, tire: &str, worst: &BTreeSet<usize>) -> (String, usize, usize) {
    let mut out = head(&format!("{tire}: tirebase report"));
    let _ = writeln!(
        out,
        "<p><a href=\"index.html\">← round overview</a></p>\n<h1>{}</h1>\n<p class=\"note\">Markers: \
         measured samples (QC-clean segments, decimated); lines: the fitted PAC2002 model (.tir) \
         evaluated at the segments' mean load and inclination. SI units, ISO-W axes (x forward, y \
         left, z up; positive slip angle gives negative Fy).</p>",
        escape(tire)
    );
    let mut groups = group_summary(data, tire);
    if groups.is_empty() {
        groups = "<p class=\"note\">no segments or results</p>\n".to_string();
    }
    out.push_str(&groups);
    let sections: [(&str, &str, Vec<Plot>); 8] = [
        (
            "fy",
            "Lateral force vs slip angle (per load and IA)",
            plots::fy_sa(data, tire),
        ),
        (
            "mz",
            "Aligning moment vs slip angle (per load and IA)",
            plots::mz_sa(data, tire),
        ),
        (
            "fx",
            "Longitudinal force vs slip (per load)",
            plots::fx_sl(data, tire),
        ),
        ("envelope", "Friction envelope", plots::envelope(data, tire)),
        (
            "peak",
            "Peak friction and cornering stiffness vs load",
            plots::peak_mu_and_stiffness(data, tire),
        ),
        (
            "spring",
            "Vertical stiffness",
            plots::spring_rate(data, tire),
        ),
        (
            "thermal",
            "Grip vs tread temperature",
            plots::mu_temperature(data, tire),
        ),
        (
            "relaxation",
            "Relaxation length",
            plots::relaxation(data, tire),
        ),
    ];
    let (mut drawn, mut missing) = (0, 0);
    for (id, title, mut charts) in sections {
        let _ = writeln!(
            out,
            "<h2 id=\"{id}\">{}</h2>\n<div class=\"plots\">",
            escape(title)
        );
        for (k, chart) in charts.iter_mut().enumerate() {
            chart.id = format!("{id}-{}", k + 1);
            if chart.has_data() {
                drawn += 1;
            } else {
                missing += 1;
            }
            out.push_str(&chart.render());
        }
        out.push_str("</div>\n");
    }
    let r = &data.results;
    out.push_str(&table_section(
        r.fit_quality.as_deref(),
        "fit_quality",
        "Fit quality",
        Some(tire),
        worst,
    ));
    out.push_str(&at_bound_section(data, tire));
    out.push_str(&table_section(
        r.lint.as_deref(),
        "lint",
        "Lint warnings",
        Some(tire),
        &BTreeSet::new(),
    ));
    out.push_str(&table_section(
        r.fit_failures.as_deref(),
        "fit_failures",
        "Failures",
        Some(tire),
        &BTreeSet::new(),
    ));
    out.push_str("</body>\n</html>\n");
    (out, drawn, missing)
}

/// Per (rim, pressure): segments by kind and whether a model exists (segments without a held
/// pressure belong to no group).
fn group_summary(data: &ReportData, tire: &str) -> String {
    let mut counts: BTreeMap<(i64, i64), BTreeMap<String, usize>> = BTreeMap::new();
    for s in data.segments.iter().filter(|s| s.segment.tire == tire) {
        let Some(p) = s.segment.pressure_kpa_nom else {
            continue;
        };
        *counts
            .entry((s.segment.rim_in, p))
            .or_default()
            .entry(s.segment.kind.clone())
            .or_default() += 1;
    }
    for &key in data.result_groups.get(tire).into_iter().flatten() {
        counts.entry(key).or_default();
    }
    if counts.is_empty() {
        return String::new();
    }
    let mut out = String::from(
        "<table>\n<tr><th>rim (in)</th><th>pressure (kPa)</th><th>cornering segments</th>\
         <th>drive/brake segments</th><th>combined segments</th><th>model (.tir)</th></tr>\n",
    );
    for ((rim, p), kinds) in &counts {
        let n = |k: &str| kinds.get(k).copied().unwrap_or(0);
        let model = if plots::model_for(data, tire, *rim, *p).is_some() {
            "yes"
        } else {
            "<span class=\"warn\">missing</span>"
        };
        let _ = writeln!(
            out,
            "<tr><td class=\"num\">{rim}</td><td class=\"num\">{p}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td>{model}</td></tr>",
            n("cornering"),
            n("drive_brake"),
            n("combined")
        );
    }
    out.push_str("</table>\n");
    out
}

/// Coefficients that ended on a bound of their search interval.
fn at_bound_section(data: &ReportData, tire: &str) -> String {
    let mut out = String::from("<h2 id=\"at-bound\">Coefficients at a bound</h2>\n");
    let Some(rows) = &data.results.coefficients else {
        out.push_str("<p class=\"note\">no data: coefficients.parquet not present</p>\n");
        return out;
    };
    let show: Vec<usize> = (0..rows.len())
        .filter(|&i| rows[i].tire == tire && rows[i].at_bound)
        .collect();
    if show.is_empty() {
        out.push_str("<p class=\"note\">none</p>\n");
        return out;
    }
    out.push_str(&table_html(rows, &show, &BTreeSet::new()));
    out
}

fn index_page(
    data: &ReportData,
    names: &[String],
    worst: &[usize],
    selection: &SelectionSection,
    (drawn, missing): (usize, usize),
) -> String {
    let mut out = head_with("tirebase report", &selection.css);
    let _ = writeln!(
        out,
        "<h1>tirebase round report</h1>\n<p class=\"note\">{} tires · {} models · \
         {} slip-test segments · {drawn} charts drawn, {missing} without data</p>",
        data.tires.len(),
        data.models.len(),
        data.segments.len()
    );
    out.push_str(&selection.html);
    out.push_str("<h2 id=\"tires\">Tires</h2>\n");
    if data.tires.is_empty() {
        out.push_str("<p class=\"note\">no tires in the store or the results</p>\n");
    } else {
        out.push_str("<table>\n<tr><th>tire</th><th>rims (in)</th><th>pressures (kPa)</th><th>segments</th><th>models</th></tr>\n");
        for (tire, file) in data.tires.iter().zip(names) {
            let (rims, pressures) = tire_levels(data, tire);
            let segs = data
                .segments
                .iter()
                .filter(|s| &s.segment.tire == tire)
                .count();
            let models = data
                .tir_names
                .iter()
                .filter(|((t, _, _), file)| t == tire && data.models.contains_key(*file))
                .count();
            let _ = writeln!(
                out,
                "<tr><td><a href=\"{}\">{}</a></td><td>{}</td><td>{}</td><td class=\"num\">{segs}</td><td class=\"num\">{models}</td></tr>",
                escape(file),
                escape(tire),
                join(&rims),
                join(&pressures)
            );
        }
        out.push_str("</table>\n");
    }
    out.push_str(&inertia_section(data));
    let worst_set: BTreeSet<usize> = worst.iter().copied().collect();
    let r = &data.results;
    if let Some(rows) = &r.fit_quality
        && !worst.is_empty()
    {
        out.push_str("<h2 id=\"worst-fits\">Worst fits</h2>\n");
        out.push_str(&worst_fits_html(rows, worst));
    }
    out.push_str(&table_section(
        r.fit_quality.as_deref(),
        "fit_quality",
        "Fit quality (worst highlighted)",
        None,
        &worst_set,
    ));
    out.push_str(&table_section(
        r.lint.as_deref(),
        "lint",
        "Lint warnings",
        None,
        &BTreeSet::new(),
    ));
    out.push_str(&table_section(
        r.fit_failures.as_deref(),
        "fit_failures",
        "Failures",
        None,
        &BTreeSet::new(),
    ));
    out.push_str("<h2 id=\"inputs\">Inputs not available</h2>\n");
    if data.notes.is_empty() {
        out.push_str("<p class=\"note\">none</p>\n");
    } else {
        out.push_str("<ul>\n");
        for n in &data.notes {
            let _ = writeln!(out, "<li>{}</li>", escape(n));
        }
        out.push_str("</ul>\n");
    }
    out.push_str("</body>\n</html>\n");
    out
}

/// Quantities of the rig-inertia results shown on the index (the rest stays in the table).
const INERTIA_QUANTITIES: [&str; 5] = [
    "inertia",
    "inertia_cg",
    "cg_height",
    "cg_offset_x",
    "aero_drag_coefficient",
];

/// Rig objects that are part of the rig, not of the car (tare and calibration runs).
const RIG_OBJECTS: [&str; 2] = ["platform", "table"];

/// The rig-inertia results of the measured objects (inertia.parquet), when present.
fn inertia_section(data: &ReportData) -> String {
    let mut out = String::from("<h2 id=\"inertia\">Rig inertia</h2>\n");
    let Some(all) = &data.results.inertia else {
        out.push_str(
            "<p class=\"note\">no rig-inertia sessions (inertia.parquet not present)</p>\n",
        );
        return out;
    };
    let rows: Vec<usize> = (0..all.len())
        .filter(|&i| {
            INERTIA_QUANTITIES.contains(&all[i].quantity.as_str())
                && !RIG_OBJECTS.contains(&all[i].object.as_str())
        })
        .collect();
    let _ = writeln!(
        out,
        "<p class=\"note\">Inertias about the stated axis (yaw vertical, pitch, roll) and CG \
         position of the measured objects, each with its standard uncertainty (k = 1); {} of \
         inertia.parquet's {} rows (the rig's own tare and calibration results, periods and \
         first moments are in the table).</p>",
        rows.len(),
        all.len()
    );
    if rows.is_empty() {
        out.push_str("<p class=\"note\">none</p>\n");
        return out;
    }
    let columns = [
        "session",
        "object",
        "axis",
        "quantity",
        "method",
        "value",
        "uncertainty",
        "units",
    ];
    out.push_str(&grid_html(
        &columns,
        rows.iter().map(|&i| {
            let r = &all[i];
            let cells = vec![
                text(&r.session),
                text(&r.object),
                text(&r.axis),
                text(&r.quantity),
                text(&r.method),
                Cell::Float(r.value),
                Cell::Float(r.uncertainty),
                text(&r.units),
            ];
            (false, cells)
        }),
    ));
    out
}

/// Rims and nominal pressures a tire appears with (segments and result tables).
fn tire_levels(data: &ReportData, tire: &str) -> (BTreeSet<i64>, BTreeSet<i64>) {
    let mut rims = BTreeSet::new();
    let mut pressures = BTreeSet::new();
    for s in data.segments.iter().filter(|s| s.segment.tire == tire) {
        rims.insert(s.segment.rim_in);
        pressures.extend(s.segment.pressure_kpa_nom);
    }
    for &(r, p) in data.result_groups.get(tire).into_iter().flatten() {
        rims.insert(r);
        pressures.insert(p);
    }
    (rims, pressures)
}

fn join(set: &BTreeSet<i64>) -> String {
    set.iter()
        .map(|v| v.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digit_formatting() {
        assert_eq!(format_sig(1234.5678), "1234.6");
        assert_eq!(format_sig(0.012345), "0.012345");
        assert_eq!(format_sig(0.0), "0");
        assert_eq!(format_sig(2.5e7), "2.5000e7");
    }

    #[test]
    fn page_names_are_unique() {
        let names = page_names(&["A b".to_string(), "a_b".to_string()]);
        assert_eq!(names, vec!["tire-a_b.html", "tire-a_b-2.html"]);
    }

    /// A fit-quality row with an in-sample error and (where given) an out-of-sample ratio.
    fn quality(tire: &str, pct: f64, oos_ratio: Option<f64>) -> QualityRow {
        QualityRow {
            oos_ratio,
            oos_folds: oos_ratio.map(|_| 5),
            ..QualityRow::pct_of_peak_only(tire, 83, "fy", pct)
        }
    }

    #[test]
    fn worst_fits_rank_by_out_of_sample_error_and_show_both() {
        let data = ReportData {
            results: crate::store::results::Results {
                fit_quality: Some(vec![
                    // in-sample worst, generalises well: 2.0 % -> 2.2 % out of sample
                    quality("a", 2.0, Some(1.1)),
                    // in-sample best, worst out of sample: 1.0 % -> 4.0 %
                    quality("b", 1.0, Some(4.0)),
                    // no out-of-sample figure: ranked by its in-sample 1.5 %
                    quality("c", 1.5, None),
                    quality("d", 1.2, Some(2.0)),
                ]),
                ..Default::default()
            },
            ..ReportData::default()
        };
        assert_eq!(worst_fit_rows(&data), vec![1, 3, 0]);
        let rows = data.results.fit_quality.as_deref().unwrap();
        let html = worst_fits_html(rows, &worst_fit_rows(&data));
        assert!(html.contains("<th>oos_pct_of_peak</th><th>rmse_pct_of_peak</th>"));
        // row b: out-of-sample 4 %, in-sample 1 %
        assert!(
            html.contains("<td class=\"num\">4.0000</td><td class=\"num\">1.0000</td>"),
            "{html}"
        );
        assert!(html.contains("out-of-sample (5-fold by sweep)"));
    }

    /// The lint and failure tables show every column of their schema, each with its value:
    /// a column added to `schemas/` without a cell here shows as empty and fails this test.
    #[test]
    fn tables_shown_whole_follow_their_schema() {
        let failure = FitFailure {
            tire: "T".into(),
            rim_in: 7,
            pressure_kpa: 83,
            stage: "pac2002".into(),
            scope: "sweep 4".into(),
            fatal: false,
            reason: "r".into(),
        };
        let lint = LintRow {
            tire: "T".into(),
            rim_in: 7,
            pressure_kpa: 83,
            model: "pac2002".into(),
            file: "t.tir".into(),
            severity: "error".into(),
            code: "c".into(),
            message: "m".into(),
        };
        for (table, columns, cells) in [
            (
                TableName::FitFailures,
                FitFailure::columns(),
                failure.cells(),
            ),
            (TableName::Lint, LintRow::columns(), lint.cells()),
        ] {
            let schema: Vec<&str> = crate::schema::table(table)
                .columns
                .iter()
                .map(|c| c.name.as_str())
                .collect();
            assert_eq!(columns, schema);
            assert_eq!(cells.len(), columns.len());
            for (c, cell) in columns.iter().zip(&cells) {
                assert!(!matches!(cell, Cell::Empty), "{table:?}.{c} has no cell");
            }
        }
    }

    #[test]
    fn an_empty_round_still_gives_an_index() {
        let data = ReportData::default();
        let comparison = crate::compare::compare(
            &[],
            &crate::compare::car::Car::builtin(),
            tirebase_core::compare::Objective::Lateral,
            &Default::default(),
        );
        let built = build(&data, &comparison);
        assert_eq!(built.pages.len(), 1);
        assert!(built.pages[0].1.contains("no tires"));
    }
}
