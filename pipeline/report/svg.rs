//! A small, deterministic SVG plotter for the HTML report.
//!
//! In: a [`Plot`] (title, two [`Axis`] labels with units, several [`Series`] of points already in
//! display units). Out: one `<svg class="plot">` element as a string (inline, no external
//! fonts, styles or scripts), or, when no series has a finite point, a `<div class="plot-missing">`
//! note saying why. Every number written is finite and rounded to 0.1 px, so the same plot gives
//! the same bytes.
//!
//! Deliberately not here: reading data, choosing what to plot (see `report/pages.rs`), log axes,
//! interactivity.

use std::fmt::Write as _;

/// Canvas size, px.
const WIDTH: f64 = 640.0;
const HEIGHT: f64 = 400.0;
/// Plot-area margins, px (the right margin holds the legend).
const LEFT: f64 = 72.0;
const RIGHT: f64 = 182.0;
const TOP: f64 = 34.0;
const BOTTOM: f64 = 52.0;
/// Legend entries shown before "+ n more".
const MAX_LEGEND: usize = 16;

/// Colour cycle (Tableau 10), picked by [`Series::color`].
pub const PALETTE: [&str; 10] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf",
];

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    /// Points joined in the given order (a model curve).
    Line,
    /// Dashed line (a second model or a reference law).
    Dashed,
    /// Unjoined markers (measured data).
    Markers,
    /// Markers joined by a thin line (a table of results against one variable).
    LineMarkers,
}

/// One named set of points in display units.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text; an empty name keeps the series out of the legend.
    pub name: String,
    /// Index into [`PALETTE`] (taken modulo its length).
    pub color: usize,
    /// Drawing style.
    pub style: Style,
    /// (x, y) points; non-finite points are skipped (and break a line).
    pub points: Vec<(f64, f64)>,
}

impl Series {
    /// A series with the given name, colour and style.
    pub fn new(
        name: impl Into<String>,
        color: usize,
        style: Style,
        points: Vec<(f64, f64)>,
    ) -> Self {
        Series {
            name: name.into(),
            color,
            style,
            points,
        }
    }

    fn finite_points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
    }
}

/// An axis: its label including the unit, e.g. `"slip angle α (deg)"`.
#[derive(Clone, Debug)]
pub struct Axis {
    /// Label with unit.
    pub label: String,
    /// Force zero into the range (forces, stiffnesses).
    pub include_zero: bool,
}

impl Axis {
    /// An axis whose range follows the data.
    pub fn new(label: impl Into<String>) -> Self {
        Axis {
            label: label.into(),
            include_zero: false,
        }
    }

    /// An axis whose range always includes zero.
    pub fn from_zero(label: impl Into<String>) -> Self {
        Axis {
            label: label.into(),
            include_zero: true,
        }
    }
}

/// One chart.
#[derive(Clone, Debug)]
pub struct Plot {
    /// Stable id (also the element id; unique within a page).
    pub id: String,
    /// What the plot shows (`data-kind`, e.g. `fy_sa`): lets readers and tests find plots by kind.
    pub kind: String,
    /// Title line.
    pub title: String,
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
    /// Series in drawing order.
    pub series: Vec<Series>,
    /// Why there may be no data (shown instead of the chart when nothing is drawable).
    pub missing_reason: String,
}

impl Plot {
    /// An empty plot.
    pub fn new(
        id: impl Into<String>,
        kind: &str,
        title: impl Into<String>,
        x: Axis,
        y: Axis,
    ) -> Self {
        Plot {
            id: id.into(),
            kind: kind.to_string(),
            title: title.into(),
            x,
            y,
            series: Vec::new(),
            missing_reason: "no data".to_string(),
        }
    }

    /// True when at least one series has a finite point.
    pub fn has_data(&self) -> bool {
        self.series
            .iter()
            .any(|s| s.finite_points().next().is_some())
    }

    /// The chart as an inline `<svg class="plot">`, or a `<div class="plot-missing">` note.
    pub fn render(&self) -> String {
        if !self.has_data() {
            return format!(
                "<div class=\"plot-missing\" id=\"{}\" data-kind=\"{}\"><h4>{}</h4><p>{}</p></div>\n",
                escape(&self.id),
                escape(&self.kind),
                escape(&self.title),
                escape(&self.missing_reason)
            );
        }
        let (x_range, y_range) = self.ranges();
        let frame = Frame::new(x_range, y_range);
        let mut out = String::with_capacity(16 * 1024);
        let _ = write!(
            out,
            "<svg class=\"plot\" id=\"{id}\" data-kind=\"{kind}\" xmlns=\"http://www.w3.org/2000/svg\" \
             width=\"{WIDTH}\" height=\"{HEIGHT}\" viewBox=\"0 0 {WIDTH} {HEIGHT}\" role=\"img\" \
             font-family=\"sans-serif\" font-size=\"11\">\n<title>{title}</title>\n",
            id = escape(&self.id),
            kind = escape(&self.kind),
            title = escape(&self.title),
        );
        let clip = format!("clip-{}", self.id);
        let _ = writeln!(
            out,
            "<defs><clipPath id=\"{}\"><rect x=\"{LEFT}\" y=\"{TOP}\" width=\"{:.1}\" height=\"{:.1}\"/></clipPath></defs>",
            escape(&clip),
            frame.w,
            frame.h
        );
        self.render_axes(&mut out, &frame);
        let _ = writeln!(out, "<g clip-path=\"url(#{})\">", escape(&clip));
        for s in &self.series {
            render_series(&mut out, &frame, s);
        }
        out.push_str("</g>\n");
        self.render_legend(&mut out);
        out.push_str("</svg>\n");
        out
    }

    /// Data ranges with a 4 % pad, widened to something drawable when degenerate.
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let pts: Vec<(f64, f64)> = self.series.iter().flat_map(|s| s.finite_points()).collect();
        let xs = pts.iter().map(|p| p.0);
        let ys = pts.iter().map(|p| p.1);
        (
            padded_range(xs, self.x.include_zero),
            padded_range(ys, self.y.include_zero),
        )
    }

    fn render_axes(&self, out: &mut String, f: &Frame) {
        let _ = writeln!(
            out,
            "<rect class=\"frame\" x=\"{LEFT}\" y=\"{TOP}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"#fff\" stroke=\"#444\"/>",
            f.w, f.h
        );
        let _ = writeln!(
            out,
            "<text x=\"{:.1}\" y=\"20\" text-anchor=\"middle\" font-size=\"13\" font-weight=\"bold\">{}</text>",
            LEFT + f.w / 2.0,
            escape(&self.title)
        );
        let xt = nice_ticks(f.x0, f.x1);
        let yt = nice_ticks(f.y0, f.y1);
        out.push_str("<g class=\"grid\" stroke=\"#e4e4e4\" stroke-width=\"1\">\n");
        for &t in &xt.values {
            let px = f.px(t);
            let _ = writeln!(
                out,
                "<line x1=\"{px:.1}\" y1=\"{TOP}\" x2=\"{px:.1}\" y2=\"{:.1}\"/>",
                TOP + f.h
            );
        }
        for &t in &yt.values {
            let py = f.py(t);
            let _ = writeln!(
                out,
                "<line x1=\"{LEFT}\" y1=\"{py:.1}\" x2=\"{:.1}\" y2=\"{py:.1}\"/>",
                LEFT + f.w
            );
        }
        out.push_str("</g>\n<g class=\"ticks\" fill=\"#222\">\n");
        for &t in &xt.values {
            let _ = writeln!(
                out,
                "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
                f.px(t),
                TOP + f.h + 15.0,
                xt.label(t)
            );
        }
        for &t in &yt.values {
            let _ = writeln!(
                out,
                "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
                LEFT - 5.0,
                f.py(t) + 4.0,
                yt.label(t)
            );
        }
        let _ = writeln!(
            out,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
            LEFT + f.w / 2.0,
            HEIGHT - 12.0,
            escape(&self.x.label)
        );
        let ymid = TOP + f.h / 2.0;
        let _ = writeln!(
            out,
            "<text x=\"16\" y=\"{ymid:.1}\" text-anchor=\"middle\" transform=\"rotate(-90 16 {ymid:.1})\">{}</text>",
            escape(&self.y.label)
        );
        out.push_str("</g>\n");
    }

    fn render_legend(&self, out: &mut String) {
        let named: Vec<&Series> = self.series.iter().filter(|s| !s.name.is_empty()).collect();
        if named.is_empty() {
            return;
        }
        let x = WIDTH - RIGHT + 12.0;
        out.push_str("<g class=\"legend\">\n");
        for (i, s) in named.iter().take(MAX_LEGEND).enumerate() {
            let y = TOP + 8.0 + 18.0 * i as f64;
            let color = PALETTE[s.color % PALETTE.len()];
            match s.style {
                Style::Markers => {
                    let _ = writeln!(
                        out,
                        "<circle cx=\"{:.1}\" cy=\"{y:.1}\" r=\"3\" fill=\"{color}\"/>",
                        x + 9.0
                    );
                }
                Style::Line | Style::Dashed | Style::LineMarkers => {
                    let dash = if s.style == Style::Dashed {
                        " stroke-dasharray=\"5 3\""
                    } else {
                        ""
                    };
                    let _ = writeln!(
                        out,
                        "<line x1=\"{x:.1}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"{color}\" stroke-width=\"2\"{dash}/>",
                        x + 18.0
                    );
                }
            }
            let _ = writeln!(
                out,
                "<text x=\"{:.1}\" y=\"{:.1}\">{}</text>",
                x + 24.0,
                y + 4.0,
                escape(&shorten(&s.name, 26))
            );
        }
        if named.len() > MAX_LEGEND {
            let y = TOP + 8.0 + 18.0 * MAX_LEGEND as f64;
            let _ = writeln!(
                out,
                "<text x=\"{x:.1}\" y=\"{:.1}\">+ {} more</text>",
                y + 4.0,
                named.len() - MAX_LEGEND
            );
        }
        out.push_str("</g>\n");
    }
}

/// Draw one series inside the clipped plot area.
fn render_series(out: &mut String, f: &Frame, s: &Series) {
    let color = PALETTE[s.color % PALETTE.len()];
    let _ = writeln!(
        out,
        "<g class=\"series\" data-name=\"{}\">",
        escape(&s.name)
    );
    if matches!(s.style, Style::Line | Style::Dashed | Style::LineMarkers) {
        let (width, dash) = match s.style {
            Style::Dashed => ("1.8", " stroke-dasharray=\"5 3\""),
            Style::LineMarkers => ("1.2", ""),
            _ => ("1.8", ""),
        };
        let mut d = String::new();
        let mut pen_down = false;
        for &(x, y) in &s.points {
            if !(x.is_finite() && y.is_finite()) {
                pen_down = false;
                continue;
            }
            let _ = write!(
                d,
                "{}{:.1} {:.1}",
                if pen_down { "L" } else { "M" },
                f.px(x),
                f.py(y)
            );
            pen_down = true;
        }
        let _ = writeln!(
            out,
            "<path d=\"{d}\" fill=\"none\" stroke=\"{color}\" stroke-width=\"{width}\" stroke-linejoin=\"round\"{dash}/>"
        );
    }
    if matches!(s.style, Style::Markers | Style::LineMarkers) {
        // Each marker is a 0.1 px stroke with round caps (a dot of the stroke width): a third
        // of the bytes of a <circle>, and still a non-empty geometry for a lone point.
        let mut d = String::new();
        for (x, y) in s.finite_points() {
            let _ = write!(d, "M{:.1} {:.1}h.1", f.px(x), f.py(y));
        }
        let _ = writeln!(
            out,
            "<path class=\"markers\" d=\"{d}\" fill=\"none\" stroke=\"{color}\" stroke-opacity=\"0.75\" stroke-width=\"4.4\" stroke-linecap=\"round\"/>"
        );
    }
    out.push_str("</g>\n");
}

/// Data-to-pixel mapping of the plot area.
struct Frame {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    w: f64,
    h: f64,
}

impl Frame {
    fn new((x0, x1): (f64, f64), (y0, y1): (f64, f64)) -> Self {
        Frame {
            x0,
            x1,
            y0,
            y1,
            w: WIDTH - LEFT - RIGHT,
            h: HEIGHT - TOP - BOTTOM,
        }
    }

    fn px(&self, x: f64) -> f64 {
        LEFT + (x - self.x0) / (self.x1 - self.x0) * self.w
    }

    fn py(&self, y: f64) -> f64 {
        TOP + self.h - (y - self.y0) / (self.y1 - self.y0) * self.h
    }
}

/// Min/max of finite values, optionally including zero, padded by 4 %; a single value `v`
/// becomes `v ± max(|v| 5 %, 1)`.
fn padded_range(values: impl Iterator<Item = f64>, include_zero: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if include_zero {
        lo = lo.min(0.0);
        hi = hi.max(0.0);
    }
    let span = hi - lo;
    if !span.is_finite() {
        return (0.0, 1.0);
    }
    if span <= 1e-12 * hi.abs().max(lo.abs()).max(1e-300) {
        let half = (0.05 * hi.abs()).max(1.0);
        return (lo - half, hi + half);
    }
    (lo - 0.04 * span, hi + 0.04 * span)
}

/// Tick positions inside a range and the decimals their labels need.
struct Ticks {
    values: Vec<f64>,
    decimals: usize,
}

impl Ticks {
    fn label(&self, v: f64) -> String {
        let v = if v.abs() < 1e-12 { 0.0 } else { v };
        format!("{v:.*}", self.decimals)
    }
}

/// 4 to 8 ticks at 1, 2 or 5 times a power of ten.
fn nice_ticks(lo: f64, hi: f64) -> Ticks {
    let raw = (hi - lo) / 6.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| (hi - lo) / s <= 8.0)
        .unwrap_or(10.0 * mag);
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    let values = (first..=last).map(|k| k as f64 * step).collect();
    Ticks { values, decimals }
}

/// Escape text for HTML/SVG content and attribute values.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

fn shorten(s: &str, max: usize) -> String {
    if s.chars().count() <= max {
        s.to_string()
    } else {
        let mut t: String = s.chars().take(max - 1).collect();
        t.push('…');
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plot_with(points: Vec<(f64, f64)>) -> Plot {
        let mut p = Plot::new(
            "p1",
            "test",
            "Test <plot>",
            Axis::new("x (m)"),
            Axis::new("y (N)"),
        );
        p.series
            .push(Series::new("a & b", 0, Style::LineMarkers, points));
        p
    }

    #[test]
    fn ticks_are_round_numbers_inside_the_range() {
        let t = nice_ticks(-0.27, 0.21);
        assert_eq!(t.decimals, 1);
        assert!(t.values.len() >= 4 && t.values.len() <= 8, "{:?}", t.values);
        for v in &t.values {
            assert!((-0.27..=0.21).contains(v));
            assert!(((v * 10.0).round() - v * 10.0).abs() < 1e-9);
        }
        let t = nice_ticks(0.0, 3400.0);
        assert_eq!(t.values.first().copied(), Some(0.0));
        assert_eq!(t.decimals, 0);
    }

    #[test]
    fn empty_or_non_finite_series_render_a_note_not_an_svg() {
        let html = plot_with(vec![(f64::NAN, 1.0), (2.0, f64::INFINITY)]).render();
        assert!(html.starts_with("<div class=\"plot-missing\""), "{html}");
        assert!(html.contains("no data"));
    }

    #[test]
    fn a_plot_is_escaped_finite_and_deterministic() {
        let p = plot_with(vec![(0.0, 1.0), (1.0, f64::NAN), (2.0, 3.0), (3.0, 2.5)]);
        let a = p.render();
        assert_eq!(a, p.render());
        assert!(a.starts_with("<svg class=\"plot\" id=\"p1\""));
        assert!(a.contains("Test &lt;plot&gt;") && a.contains("a &amp; b"));
        assert!(!a.contains("NaN") && !a.contains("inf"));
        // The NaN breaks the line: two move-tos.
        let path = a.lines().find(|l| l.starts_with("<path")).unwrap();
        assert_eq!(path.matches('M').count(), 2, "{path}");
        let markers = a.lines().find(|l| l.contains("class=\"markers\"")).unwrap();
        assert_eq!(markers.matches('M').count(), 3, "{markers}");
    }

    #[test]
    fn a_single_point_gets_a_drawable_range() {
        let (lo, hi) = padded_range([5.0].into_iter(), false);
        assert!(lo < 5.0 && hi > 5.0);
        let (lo, hi) = padded_range([2.0, 4.0].into_iter(), true);
        assert!(lo < 0.0 && hi > 4.0);
    }
}
