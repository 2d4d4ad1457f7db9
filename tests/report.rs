//! `tirebase report` end to end, checked in a real browser (issue 7: "a test opens it in
//! headless Chromium and checks that every plot rendered").
//!
//! Fixture: a demo virtual round (`synth round`) ingested into a store; the result directory holds
//! the round's truth `.tir` files (named like fitted ones) and small result tables built here from
//! the truth laws (spring rate, relaxation, mu(T)) plus a few fit-quality, lint, failure and
//! coefficient rows (every column of each table's schema, the ones not set here null). Until
//! `tirebase fit` exists this stands in for its output; the report reads both the same way.
//!
//! The browser check: each page is copied with a probe script appended (the report itself has
//! no script), loaded with `chromium --headless --dump-dom`, and the probe reports per
//! `<svg class="plot">` its laid-out size and, per data series, whether the browser computed a
//! non-empty bounding box that overlaps the plot frame. Every chart must have drawn every series.
//! Chromium is required: without it the test fails and says how to install it (`.ci/run`
//! installs it on CI).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use polars::prelude::*;

use crate::harness::{copy_tree, demo_published, demo_round, ingest, ok, tirebase};

/// The browser: $TIREBASE_CHROMIUM, else chromium or chromium-browser on PATH.
fn chromium() -> PathBuf {
    if let Some(p) = std::env::var_os("TIREBASE_CHROMIUM") {
        return PathBuf::from(p);
    }
    for name in ["chromium", "chromium-browser"] {
        if let Some(dir) = std::env::var_os("PATH")
            .iter()
            .flat_map(std::env::split_paths)
            .find(|d| d.join(name).is_file())
        {
            return dir.join(name);
        }
    }
    panic!(
        "headless Chromium is required by the report test and was not found on PATH: install it \
         with `apt-get install -y chromium` (Debian/Ubuntu; .ci/run does this) or point \
         TIREBASE_CHROMIUM at a Chromium/Chrome binary"
    );
}

const PROBE: &str = r#"<script>
(function () {
  const out = [];
  // Every state of the page's pressure selector (CSS radio tabs); a chart counts once, in the
  // first state that shows it.
  const radios = Array.from(document.querySelectorAll('input.psel'));
  const states = radios.length ? radios : [null];
  const seen = new Set();
  for (const radio of states) {
    if (radio) radio.checked = true;
    for (const svg of document.querySelectorAll('svg.plot')) {
      if (seen.has(svg.id) || svg.getClientRects().length === 0) continue;
      seen.add(svg.id);
      const r = svg.getBoundingClientRect();
      const f = svg.querySelector('rect.frame').getBBox();
      const series = svg.querySelectorAll('g.series');
      let drawn = 0, inside = 0, lines = 0;
      for (const g of series) {
        const b = g.getBBox();
        if (b.width > 0 || b.height > 0) drawn++;
        if (b.x <= f.x + f.width && b.x + b.width >= f.x &&
            b.y <= f.y + f.height && b.y + b.height >= f.y) inside++;
        if (g.querySelector('path:not(.markers)')) lines++;
      }
      out.push(['svg', svg.id, svg.dataset.kind, Math.round(r.width), Math.round(r.height),
                series.length, drawn, inside, lines, radio ? radio.id : '-'].join(' '));
    }
  }
  for (const svg of document.querySelectorAll('svg.plot')) {
    if (!seen.has(svg.id)) out.push(['hidden', svg.id, svg.dataset.kind].join(' '));
  }
  for (const d of document.querySelectorAll('.plot-missing')) {
    out.push(['missing', d.id, d.dataset.kind].join(' '));
  }
  const pre = document.createElement('pre');
  pre.id = 'probe';
  pre.textContent = 'PROBE' + '-BEGIN\n' + out.join('\n') + '\nPROBE' + '-END';
  document.body.appendChild(pre);
})();
</script>
"#;

/// What the browser saw on one page.
#[derive(Debug, Default)]
struct Rendered {
    /// kind -> number of charts drawn.
    drawn: BTreeMap<String, usize>,
    /// selector state (radio id, "-" without a selector) -> kinds of the charts it showed.
    by_state: BTreeMap<String, Vec<String>>,
    /// kind -> number of "no data" notes.
    missing: BTreeMap<String, usize>,
    /// kind -> charts with at least one line (model) series.
    with_lines: BTreeMap<String, usize>,
}

/// Load `page` (with the probe appended) in headless Chromium and check every chart drew.
fn render(page: &Path, scratch: &Path) -> Rendered {
    let html = std::fs::read_to_string(page).unwrap();
    assert!(
        !html.contains("<script"),
        "{}: the report must not contain scripts",
        page.display()
    );
    for bad in ["NaN", "inf\"", "http://", "https://"] {
        let allowed = bad == "http://"
            && html.matches(bad).count() == html.matches("http://www.w3.org/2000/svg").count();
        assert!(
            allowed || !html.contains(bad),
            "{}: contains {bad}",
            page.display()
        );
    }
    let probed = scratch.join(format!(
        "probe-{}",
        page.file_name().unwrap().to_string_lossy()
    ));
    std::fs::write(&probed, html.replace("</body>", &format!("{PROBE}</body>"))).unwrap();
    let profile = tempfile::tempdir().unwrap();
    let output = Command::new(chromium())
        .args([
            "--headless",
            "--disable-gpu",
            "--no-sandbox",
            "--no-first-run",
            "--window-size=1400,1000",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg("--dump-dom")
        .arg(format!("file://{}", probed.display()))
        .output()
        .expect("start chromium");
    let dom = String::from_utf8_lossy(&output.stdout);
    let probe = dom
        .split("PROBE-BEGIN")
        .nth(1)
        .and_then(|s| s.split("PROBE-END").next())
        .unwrap_or_else(|| {
            panic!(
                "{}: no probe output from chromium (exit {:?}); stderr: {}",
                page.display(),
                output.status,
                String::from_utf8_lossy(&output.stderr)
            )
        });
    let mut seen = Rendered::default();
    let svg_in_source = html.matches("<svg class=\"plot\"").count();
    let mut svg_in_browser = 0;
    for line in probe.lines().filter(|l| !l.trim().is_empty()) {
        let f: Vec<&str> = line.split_whitespace().collect();
        match f[0] {
            "svg" => {
                svg_in_browser += 1;
                let n = |i: usize| f[i].parse::<i64>().unwrap();
                let (w, h, series, drawn, inside, lines) = (n(3), n(4), n(5), n(6), n(7), n(8));
                assert!(
                    w > 100 && h > 100,
                    "{}: chart {} laid out {w}x{h}",
                    page.display(),
                    f[1]
                );
                assert!(
                    series > 0,
                    "{}: chart {} has no series",
                    page.display(),
                    f[1]
                );
                assert_eq!(
                    drawn,
                    series,
                    "{}: chart {}: {drawn}/{series} series drawn",
                    page.display(),
                    f[1]
                );
                assert_eq!(
                    inside,
                    series,
                    "{}: chart {}: {inside}/{series} series inside the frame",
                    page.display(),
                    f[1]
                );
                *seen.drawn.entry(f[2].to_string()).or_default() += 1;
                if lines > 0 {
                    *seen.with_lines.entry(f[2].to_string()).or_default() += 1;
                }
                seen.by_state
                    .entry(f[9].to_string())
                    .or_default()
                    .push(f[2].to_string());
            }
            "hidden" => panic!(
                "{}: chart {} ({}) is shown in no state of the page",
                page.display(),
                f[1],
                f[2]
            ),
            "missing" => *seen.missing.entry(f[2].to_string()).or_default() += 1,
            other => panic!("unexpected probe line {other}"),
        }
    }
    assert_eq!(
        svg_in_browser,
        svg_in_source,
        "{}: the browser saw {svg_in_browser} of {svg_in_source} charts",
        page.display()
    );
    seen
}

/// The front page's tire-selection charts, per pressure choice.
const SELECTION_KINDS: [&str; 4] = [
    "sel_peak_mu",
    "sel_cornering_stiffness",
    "sel_camber",
    "sel_thermal",
];

/// The front page shows the tire selection: every choice of its pressure selector ("best" and
/// each of the `pressures` tested) shows the four per-pressure charts with data and model
/// lines, the friction envelopes are drawn, no chart lacks data, and the ranked comparison
/// table follows.
fn check_front_page(seen: &Rendered, html: &str, pressures: usize) {
    assert!(
        seen.missing.is_empty(),
        "front page charts without data: {seen:?}"
    );
    let states: Vec<&String> = seen.by_state.keys().collect();
    assert_eq!(states.len(), 1 + pressures, "selector states: {states:?}");
    assert!(seen.by_state.contains_key("psel-best"), "{states:?}");
    for (state, kinds) in &seen.by_state {
        let mut kinds = kinds.clone();
        if state == "psel-best" {
            kinds.retain(|k| k != "sel_envelope");
        }
        kinds.sort();
        let mut want: Vec<String> = SELECTION_KINDS.iter().map(|k| k.to_string()).collect();
        want.sort();
        assert_eq!(kinds, want, "charts shown with {state}");
    }
    for kind in SELECTION_KINDS.iter().chain(&["sel_envelope"]) {
        assert_eq!(
            seen.with_lines.get(*kind),
            seen.drawn.get(*kind),
            "every {kind} chart draws model lines"
        );
    }
    assert_eq!(seen.drawn.get("sel_envelope"), Some(&1));
    let selection = html
        .split("id=\"selection\"")
        .nth(1)
        .expect("the front page opens with the tire selection");
    assert!(
        html.find("id=\"selection\"").unwrap() < html.find("id=\"fit_quality\"").unwrap(),
        "the selection comes before the fit-quality tables"
    );
    assert!(selection.contains("Comparison at the car's conditions"));
    assert!(selection.contains("lateral_mu") && selection.contains("mu_y_peak_fz700"));
}

/// Every kind of chart a tire page has.
const KINDS: [&str; 9] = [
    "fy_sa",
    "mz_sa",
    "fx_sl",
    "envelope",
    "peak_mu",
    "cornering_stiffness",
    "spring_rate",
    "mu_temperature",
    "relaxation",
];

/// Write a fixture table with every column of its schema: the columns the fixture does not set
/// are null (the report reads typed rows, and a table without a column counts as missing).
fn write_table(dir: &Path, name: &str, mut df: DataFrame) {
    let n = df.height();
    for c in tirebase::schema::table_named(name).unwrap().file_columns() {
        if df.column(&c.name).is_err() {
            df.with_column(Column::full_null(
                c.name.as_str().into(),
                n,
                &c.dtype.polars(),
            ))
            .unwrap();
        }
    }
    let file = std::fs::File::create(dir.join(format!("{name}.parquet"))).unwrap();
    ParquetWriter::new(file).finish(&mut df).unwrap();
}

/// Result tables built from the round's truth files (see the module doc); returns the number of
/// tire, rim and pressure groups (the fit-quality fixture's worst rows are `groups + 0.2`,
/// `+ 0.1` and `+ 0.0` % of peak).
fn write_fixture_tables(round: &Path, results: &Path) -> usize {
    let mut tires = Vec::new();
    let mut spring = (
        Vec::<String>::new(),
        Vec::<i64>::new(),
        Vec::<i64>::new(),
        Vec::<String>::new(),
        Vec::<f64>::new(),
    );
    let mut relax = (
        Vec::<String>::new(),
        Vec::<i64>::new(),
        Vec::<i64>::new(),
        Vec::<f64>::new(),
        Vec::<String>::new(),
        Vec::<f64>::new(),
    );
    let mut tfit = (
        Vec::<String>::new(),
        Vec::<i64>::new(),
        Vec::<f64>::new(),
        Vec::<f64>::new(),
        Vec::<f64>::new(),
        Vec::<f64>::new(),
    );
    let mut therm = (
        Vec::<String>::new(),
        Vec::<i64>::new(),
        Vec::<String>::new(),
        Vec::<f64>::new(),
        Vec::<f64>::new(),
    );
    let mut truths: Vec<PathBuf> = std::fs::read_dir(round.join("truth"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.extension().is_some_and(|x| x == "toml") && p.file_name().unwrap() != "round.toml"
        })
        .collect();
    truths.sort();
    // Rim of every row of each table, in push order.
    let (mut spring_rim, mut relax_rim, mut tfit_rim, mut therm_rim) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut tfit_gain = Vec::new();
    for path in truths {
        let truth: toml::Table = toml::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        let tire = truth["tire"].as_str().unwrap().to_string();
        let rim_in = truth["rim_in"].as_float().unwrap().round() as i64;
        let th = truth["thermal"].as_table().unwrap();
        let t_peak = th["t_peak_c"].as_float().unwrap();
        let t_cold = th["t_cold_c"].as_float().unwrap();
        let gain = th["gain_peak_over_cold"].as_float().unwrap();
        let k = (1.0 - 1.0 / (1.0 + gain)) / (t_peak - t_cold).powi(2);
        for p in truth["pressure"].as_array().unwrap() {
            let p = p.as_table().unwrap();
            let kpa = p["pressure_kpa_nom"].as_float().unwrap().round() as i64;
            tires.push((tire.clone(), rim_in, kpa));
            for cond in ["static", "dynamic"] {
                spring.0.push(tire.clone());
                spring_rim.push(rim_in);
                spring.1.push(kpa);
                spring.2.push(0);
                spring.3.push(cond.to_string());
                spring.4.push(
                    p[&format!("vertical_stiffness_{cond}_n_per_m")]
                        .as_float()
                        .unwrap(),
                );
            }
            for (dir, key) in [
                ("lateral", "sigma_alpha_m"),
                ("longitudinal", "sigma_kappa_m"),
            ] {
                for (load, sigma) in p[key].as_table().unwrap() {
                    relax.0.push(tire.clone());
                    relax_rim.push(rim_in);
                    relax.1.push(kpa);
                    relax.2.push(load.parse().unwrap());
                    relax.3.push(load.parse::<f64>().unwrap());
                    relax.4.push(dir.to_string());
                    relax.5.push(sigma.as_float().unwrap() * 1.03);
                }
            }
            tfit.0.push(tire.clone());
            tfit_rim.push(rim_in);
            tfit_gain.push(gain);
            tfit.1.push(kpa);
            tfit.2.push(t_peak);
            tfit.3.push(t_cold);
            tfit.4.push(k);
            tfit.5.push(2.4);
            for (q, level) in [
                ("increasing_positive", 2.45),
                ("increasing_negative", 2.4),
                ("decreasing_positive", 2.35),
                ("decreasing_negative", 2.38),
            ] {
                for t in [30.0, 38.0, 46.0, 54.0, 62.0, 70.0] {
                    therm.0.push(tire.clone());
                    therm_rim.push(rim_in);
                    therm.1.push(kpa);
                    therm.2.push(q.to_string());
                    therm.3.push(t);
                    therm
                        .4
                        .push(level * (1.0 - k * (t - t_peak) * (t - t_peak)));
                }
            }
        }
    }
    write_table(results, "spring_rate", df!("tire" => spring.0, "rim_in" => spring_rim, "pressure_kpa" => spring.1, "ia_cdeg_nom" => spring.2, "condition" => spring.3, "stiffness_n_per_m" => spring.4).unwrap());
    let n = relax.0.len();
    write_table(results, "relaxation", df!("tire" => relax.0, "rim_in" => relax_rim, "pressure_kpa" => relax.1, "fz_n_nom" => relax.2, "fz_n_mean" => relax.3, "direction" => relax.4, "method" => vec!["sweep"; n], "sigma_m" => relax.5, "converged" => vec![true; n]).unwrap());
    let n = tfit.0.len();
    write_table(results, "thermal_fit", df!("tire" => tfit.0, "rim_in" => tfit_rim, "pressure_kpa" => tfit.1, "t_peak_c" => tfit.2, "gain_peak_over_cold" => tfit_gain, "t_cold_c" => tfit.3, "k_cold_per_c2" => tfit.4, "hot_falloff" => vec![1.0; n], "mu_peak_mean" => tfit.5).unwrap());
    write_table(results, "thermal", df!("tire" => therm.0, "rim_in" => therm_rim, "pressure_kpa" => therm.1, "quadrant" => therm.2, "t_centre_peak_c" => therm.3, "mu_peak" => therm.4).unwrap());
    // Fit quality: three channels per group; one clearly worst row per tire group index.
    let (mut t, mut r, mut p, mut ch, mut pct) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (i, (tire, rim_in, kpa)) in tires.iter().enumerate() {
        for (j, c) in ["fx", "fy", "mz"].into_iter().enumerate() {
            t.push(tire.clone());
            r.push(*rim_in);
            p.push(*kpa);
            ch.push(c);
            pct.push(1.0 + i as f64 + 0.1 * j as f64);
        }
    }
    let n = t.len();
    let r2: Vec<f64> = pct.iter().map(|x| 1.0 - x / 100.0).collect();
    write_table(results, "fit_quality", df!("tire" => t.clone(), "rim_in" => r, "pressure_kpa" => p.clone(), "channel" => ch, "n" => vec![1000i64; n], "rmse" => pct.clone(), "rmse_pct_of_peak" => pct, "r2" => r2).unwrap());
    let (tire0, rim0, kpa0) = tires[0].clone();
    write_table(results, "lint", df!("tire" => [tire0.clone()], "rim_in" => [rim0], "pressure_kpa" => [kpa0], "severity" => ["warning"], "code" => ["fixture-lint"], "message" => ["fixture: E > 1 before clamping at Fz 1557 N"]).unwrap());
    write_table(results, "fit_failures", df!("tire" => [tire0.clone()], "rim_in" => [rim0], "pressure_kpa" => [kpa0], "stage" => ["relaxation"], "reason" => ["fixture: no step-steer segments"]).unwrap());
    write_table(results, "coefficients", df!("tire" => [tire0.clone(), tire0], "rim_in" => [rim0, rim0], "pressure_kpa" => [kpa0, kpa0], "model" => ["pac2002", "pac2002"], "family" => ["fy", "fy"], "name" => ["PEY1", "PDY1"], "value" => [1.0, 2.4], "std_error" => [0.01, 0.02], "at_bound" => [true, false]).unwrap());
    tires.len()
}

/// Every kind of tire-page chart drawn on `page`, none without data.
fn assert_every_chart_drawn(page: &Path, seen: &Rendered) {
    for kind in KINDS {
        assert!(
            seen.drawn.get(kind).copied().unwrap_or(0) > 0,
            "{}: no {kind} chart drawn: {seen:?}",
            page.display()
        );
    }
    assert!(
        seen.missing.is_empty(),
        "{}: charts without data: {:?}",
        page.display(),
        seen.missing
    );
}

fn report(store: &Path, results: &Path, out: &Path) -> (std::process::Output, f64) {
    let start = std::time::Instant::now();
    let output = tirebase(&[
        "report".as_ref(),
        "--store".as_ref(),
        store.as_os_str(),
        "--results".as_ref(),
        results.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    (output, start.elapsed().as_secs_f64())
}

fn pages(out: &Path) -> Vec<PathBuf> {
    let mut p: Vec<PathBuf> = std::fs::read_dir(out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "html"))
        .collect();
    p.sort();
    p
}

#[test]
fn report_renders_every_plot_in_headless_chromium() {
    let browser = chromium(); // fail early, with instructions, when it is missing
    let tmp = tempfile::tempdir().unwrap();
    let (round, store) = (demo_round(), tmp.path().join("store"));
    ingest(
        &round.join("raw"),
        &store,
        Some(&round.join("catalog.toml")),
    );

    // Full result directory: every chart must be drawn on every tire page.
    let results = tmp.path().join("results");
    copy_tree(&round.join("truth").join("tir"), &results.join("tir"));
    let groups = write_fixture_tables(round, &results);
    let out = tmp.path().join("report");
    let (output, seconds) = report(&store, &results, &out);
    ok(&output, "report");
    let bytes: u64 = pages(&out)
        .iter()
        .map(|p| std::fs::metadata(p).unwrap().len())
        .sum();
    eprintln!(
        "report of the demo round: {seconds:.2} s wall, {} pages, {} KiB (browser: {})",
        pages(&out).len(),
        bytes / 1024,
        browser.display()
    );
    assert!(bytes < 2 * 1024 * 1024, "report too large: {bytes} bytes");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert_eq!(stdout.trim(), out.join("index.html").display().to_string());

    let tire_pages: Vec<PathBuf> = pages(&out)
        .into_iter()
        .filter(|p| p.file_name().unwrap() != "index.html")
        .collect();
    assert_eq!(
        tire_pages.len(),
        3,
        "one page per demo tire (one of them on two rims)"
    );
    let index = std::fs::read_to_string(out.join("index.html")).unwrap();
    for p in &tire_pages {
        let name = p.file_name().unwrap().to_string_lossy();
        assert!(
            index.contains(&format!("href=\"{name}\"")),
            "index links {name}"
        );
    }
    // The fixture's three worst rows (groups + 0.2, + 0.1, + 0.0 % of peak) are listed first
    // and highlighted again in the full table.
    assert_eq!(index.matches("<tr class=\"worst\">").count(), 6);
    let worst = index
        .split("Worst fits")
        .nth(1)
        .unwrap()
        .split("<h2")
        .next()
        .unwrap();
    let pos = |v: &str| {
        worst
            .find(v)
            .unwrap_or_else(|| panic!("{v} not among the worst: {worst}"))
    };
    let pct = |x: f64| format!("{x:.4}");
    let n = groups as f64;
    assert!(pos(&pct(n + 0.2)) < pos(&pct(n + 0.1)) && pos(&pct(n + 0.1)) < pos(&pct(n)));
    assert!(!worst.contains(&pct(n - 0.8)));
    assert!(index.contains("fixture-lint") && index.contains("fixture: no step-steer segments"));
    let idx = render(&out.join("index.html"), tmp.path());
    check_front_page(&idx, &index, 2);
    for page in &tire_pages {
        let seen = render(page, tmp.path());
        assert_every_chart_drawn(page, &seen);
        for kind in [
            "fy_sa",
            "mz_sa",
            "fx_sl",
            "envelope",
            "peak_mu",
            "cornering_stiffness",
            "mu_temperature",
            "relaxation",
        ] {
            assert_eq!(
                seen.with_lines.get(kind),
                seen.drawn.get(kind),
                "{}: every {kind} chart shows the model",
                page.display()
            );
        }
        let html = std::fs::read_to_string(page).unwrap();
        assert!(html.contains("Coefficients at a bound"));
    }

    // Degraded result directory: no tables, one model missing, one unreadable.
    let sparse = tmp.path().join("sparse");
    copy_tree(&round.join("truth").join("tir"), &sparse.join("tir"));
    let mut tirs: Vec<PathBuf> = std::fs::read_dir(sparse.join("tir"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    tirs.sort();
    std::fs::remove_file(&tirs[0]).unwrap();
    std::fs::write(&tirs[1], b"[MODEL]\nFITTYP = oops\n\x00\x01binary").unwrap();
    let out2 = tmp.path().join("report2");
    let (output, _) = report(&store, &sparse, &out2);
    ok(&output, "report on a sparse result directory");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("note: spring_rate.parquet: not present"),
        "{stderr}"
    );
    let index = std::fs::read_to_string(out2.join("index.html")).unwrap();
    assert!(
        index.contains(&tirs[1].file_name().unwrap().to_string_lossy().to_string()),
        "the unreadable .tir is listed"
    );
    for page in pages(&out2)
        .into_iter()
        .filter(|p| p.file_name().unwrap() != "index.html")
    {
        let seen = render(&page, tmp.path());
        for kind in ["spring_rate", "mu_temperature", "relaxation"] {
            assert!(
                seen.missing.get(kind).copied().unwrap_or(0) > 0,
                "{}: {kind} should say no data: {seen:?}",
                page.display()
            );
            assert!(!seen.drawn.contains_key(kind));
        }
        for kind in ["fy_sa", "mz_sa", "fx_sl"] {
            assert!(
                seen.drawn.get(kind).copied().unwrap_or(0) > 0,
                "{}: {kind} data still drawn",
                page.display()
            );
        }
    }
}

#[test]
fn report_without_a_result_directory_is_a_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let missing = tmp.path().join("nope");
    let (output, _) = report(tmp.path(), &missing, &tmp.path().join("out"));
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("nope") && stderr.contains("result directory not found"),
        "{stderr}"
    );
}

/// Issue 22 "Done when", third line: the README's main command (`tirebase run` on the demo
/// round: the harness's first run of it; `run::readme_command_...` runs the command itself, in an
/// empty directory) publishes a version whose report opens with the tire
/// selection (every chart drawn with data in headless Chromium, in every state of the pressure
/// selector), has a page for every tire (every chart drawn with data), shows the rig-inertia
/// results, and publishes inertia.parquet.
#[test]
fn readme_main_command_publishes_the_selection_front_page_tire_pages_and_inertia() {
    chromium(); // fail early, with instructions, when it is missing
    let cwd = tempfile::tempdir().unwrap();
    let version = demo_published().join("store/versions/v000001");
    let inertia = tirebase::store::files::read_parquet(&version.join("inertia.parquet")).unwrap();
    assert!(inertia.height() > 0, "inertia.parquet is empty");

    let report = version.join("report");
    let index = std::fs::read_to_string(report.join("index.html")).unwrap();
    let front = render(&report.join("index.html"), cwd.path());
    check_front_page(&front, &index, 2);
    assert!(
        index.contains("id=\"inertia\"") && index.contains("demo car"),
        "the rig-inertia results are on the index"
    );
    let tire_pages: Vec<PathBuf> = pages(&report)
        .into_iter()
        .filter(|p| p.file_name().unwrap() != "index.html")
        .collect();
    assert_eq!(tire_pages.len(), 3, "a page per tire of the embedded round");
    for page in &tire_pages {
        let name = page.file_name().unwrap().to_string_lossy();
        assert!(
            index.contains(&format!("href=\"{name}\"")),
            "index links {name}"
        );
        let seen = render(page, cwd.path());
        assert_every_chart_drawn(page, &seen);
    }
}
