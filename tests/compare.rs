//! `tirebase compare` end to end (issue 22): the demo round through `synth round` -> `run` ->
//! `compare`, against the virtual machine's truth.
//!
//! The truth figures are computed here, independently of the fitted models and of the compare
//! module's searches: the truth `.tir` of every group (with the fitted file's tested slip and
//! camber ranges, so both are evaluated "at the same conditions") is evaluated on dense grids
//! through the batch evaluator (peaks on a 0.01 deg / 1e-5 slip grid refined tenfold, the design
//! camber on a 0.05 deg grid refined to 0.0005 deg, stiffnesses as least-squares slopes over
//! +-0.1 deg / +-5e-4, the friction envelope on a 201 x 201 grid instead of 41 x 41), plus the
//! truth's relaxation law, vertical stiffness and mu(T) law. Checked:
//! - every figure of every row within 2 % of its truth (the small derived figures, camber gain
//!   and load sensitivity, against a scale stated at their check);
//! - for each objective, every pair of rows whose truth differs by more than the rows' stated
//!   uncertainty is ranked in the truth's order (and such pairs exist);
//! - `--format csv` gives the same bytes twice and its header is the schema's;
//! - `--help` names units and axes.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use polars::prelude::*;
use tirebase::core::compare::envelope::{convex_hull, polygon_area};
use tirebase::core::naming::{tir_file_name, tire_rim_stem};
use tirebase::core::tire_model::tir::TirFile;
use tirebase::core::tire_model::{Coef, Evaluation, Mode, Pac2002, SlipInput};
use tirebase::schema::TableName;

use crate::harness::{bin, demo_published, f64s, ok, p, run, strs, synth_round, tirebase};

/// A demo round and its first published version.
struct Published {
    _dir: Option<tempfile::TempDir>,
    round: PathBuf,
    store: PathBuf,
}

/// The demo round without the heat model: noise and force relaxation as usual, grip independent
/// of temperature, so the truth `.tir` *is* the tire at every sample.
fn without_heat() -> &'static Published {
    static P: OnceLock<Published> = OnceLock::new();
    P.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let (round, store) = (dir.path().join("round"), dir.path().join("store"));
        synth_round(&round, &["--no-heat"]);
        ok(&run(&round, &store, &[]), "run");
        Published {
            _dir: Some(dir),
            round,
            store,
        }
    })
}

/// The default demo round (heat on: grip follows the tread temperature, and the truth `.tir`
/// describes the tire at the reference temperatures of its sweeps): the harness's.
fn default_round() -> &'static Published {
    static P: OnceLock<Published> = OnceLock::new();
    P.get_or_init(|| Published {
        _dir: None,
        round: demo_published().join("input"),
        store: demo_published().join("store"),
    })
}

fn compare_csv(store: &Path, extra: &[&str]) -> Vec<u8> {
    let mut args = vec!["compare", "--store", p(store), "--format", "csv"];
    args.extend_from_slice(extra);
    let o = tirebase(&args);
    ok(&o, "compare");
    o.stdout
}

fn frame(csv: &[u8]) -> DataFrame {
    CsvReadOptions::default()
        .with_has_header(true)
        .with_infer_schema_length(None)
        .into_reader_with_file_handle(std::io::Cursor::new(csv.to_vec()))
        .finish()
        .unwrap()
}

fn read_tir(path: &Path) -> TirFile {
    TirFile::parse_bytes(&std::fs::read(path).unwrap())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .0
}

/// The built-in car (config/car.toml), restated: the test must fail if it drifts.
const LOADS_N: [f64; 3] = [350.0, 700.0, 1050.0];
const NOMINAL_N: f64 = 700.0;
const SPEED_MPS: f64 = 40.0 / 3.6;
const CAMBER_DEG: (f64, f64) = (0.0, 4.0);

/// The truth model evaluated by brute force.
struct Truth {
    model: Pac2002,
}

impl Truth {
    /// The truth `.tir` with the fitted file's tested slip and camber ranges and no load clip.
    fn new(truth: &TirFile, fitted: &TirFile) -> Truth {
        let mut c = truth.coefs.clone();
        for k in [
            Coef::ALPMIN,
            Coef::ALPMAX,
            Coef::KPUMIN,
            Coef::KPUMAX,
            Coef::CAMMIN,
            Coef::CAMMAX,
        ] {
            c[k] = fitted.coefs[k];
        }
        c[Coef::FZMAX] = c[Coef::FZMAX].max(2.0 * NOMINAL_N);
        Truth {
            model: Pac2002::new(c),
        }
    }

    fn range(&self, lo: Coef, hi: Coef) -> (f64, f64) {
        (self.model.coefs[lo], self.model.coefs[hi])
    }

    fn batch(&self, inputs: &[SlipInput]) -> Vec<Evaluation<f64>> {
        let mut out = vec![Evaluation::default(); inputs.len()];
        self.model.eval_batch(inputs, Mode::Limits, &mut out);
        out
    }

    /// max of |F| over a grid of `n` points over [lo, hi], then a tenfold finer grid around
    /// the best point.
    fn peak(&self, lo: f64, hi: f64, n: usize, at: &dyn Fn(f64) -> SlipInput, fx: bool) -> f64 {
        let pick = |e: &Evaluation<f64>| if fx { e.fx_n.abs() } else { e.fy_n.abs() };
        let grid = |lo: f64, hi: f64| -> (f64, f64) {
            let xs: Vec<f64> = (0..n)
                .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
                .collect();
            let inputs: Vec<SlipInput> = xs.iter().map(|&x| at(x)).collect();
            self.batch(&inputs)
                .iter()
                .zip(&xs)
                .map(|(e, &x)| (x, pick(e)))
                .fold(
                    (lo, f64::NEG_INFINITY),
                    |a, b| if b.1 > a.1 { b } else { a },
                )
        };
        let step = (hi - lo) / (n - 1) as f64;
        let (x, _) = grid(lo, hi);
        grid((x - step).max(lo), (x + step).min(hi)).1
    }

    fn peak_fy(&self, fz: f64, gamma: f64) -> f64 {
        let (lo, hi) = self.range(Coef::ALPMIN, Coef::ALPMAX);
        let n = ((hi - lo).to_degrees() / 0.01).round() as usize + 1;
        self.peak(lo, hi, n, &|a| input(fz, a, 0.0, gamma), false)
    }

    fn peak_fx(&self, fz: f64, gamma: f64) -> f64 {
        let (lo, hi) = self.range(Coef::KPUMIN, Coef::KPUMAX);
        let n = ((hi - lo) / 1e-5).round() as usize + 1;
        self.peak(lo, hi, n, &|k| input(fz, 0.0, k, gamma), true)
    }

    /// The design camber: grid of 0.05 deg over the car's range within the tested one, then
    /// 0.0005 deg around the best point.
    fn camber(&self) -> f64 {
        let (m_lo, m_hi) = self.range(Coef::CAMMIN, Coef::CAMMAX);
        let lo = CAMBER_DEG.0.to_radians().clamp(m_lo, m_hi);
        let hi = CAMBER_DEG.1.to_radians().clamp(m_lo, m_hi);
        let best = |lo: f64, hi: f64, step: f64| {
            let n = ((hi - lo) / step).round().max(1.0) as usize + 1;
            (0..n)
                .map(|i| lo + (hi - lo) * i as f64 / (n - 1) as f64)
                .map(|g| (g, self.peak_fy(NOMINAL_N, g)))
                .fold(
                    (lo, f64::NEG_INFINITY),
                    |a, b| if b.1 > a.1 { b } else { a },
                )
                .0
        };
        let coarse = 0.05f64.to_radians();
        let g = best(lo, hi, coarse);
        best(
            (g - coarse).max(lo),
            (g + coarse).min(hi),
            0.0005f64.to_radians(),
        )
    }

    /// Least-squares slope of |F| against the slip over +-`half` around zero (41 points).
    fn slope(&self, half: f64, at: &dyn Fn(f64) -> SlipInput, fx: bool) -> f64 {
        let xs: Vec<f64> = (0..41).map(|i| -half + half * i as f64 / 20.0).collect();
        let inputs: Vec<SlipInput> = xs.iter().map(|&x| at(x)).collect();
        let ys: Vec<f64> = self
            .batch(&inputs)
            .iter()
            .map(|e| if fx { e.fx_n } else { e.fy_n })
            .collect();
        let mx = xs.iter().sum::<f64>() / 41.0;
        let my = ys.iter().sum::<f64>() / 41.0;
        let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
        let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
        (sxy / sxx).abs()
    }

    /// Friction-envelope area at the nominal load on a 201 x 201 grid, N^2.
    fn envelope(&self, gamma: f64) -> f64 {
        let (a_lo, a_hi) = self.range(Coef::ALPMIN, Coef::ALPMAX);
        let (k_lo, k_hi) = self.range(Coef::KPUMIN, Coef::KPUMAX);
        let n = 201;
        let lin = |lo: f64, hi: f64, i: usize| lo + (hi - lo) * i as f64 / (n - 1) as f64;
        let inputs: Vec<SlipInput> = (0..n)
            .flat_map(|i| {
                (0..n).map(move |j| input(NOMINAL_N, lin(a_lo, a_hi, i), lin(k_lo, k_hi, j), gamma))
            })
            .collect();
        let pts: Vec<(f64, f64)> = self
            .batch(&inputs)
            .iter()
            .map(|e| (e.fx_n, e.fy_n))
            .collect();
        polygon_area(&convex_hull(pts))
    }
}

fn input(fz_n: f64, alpha_rad: f64, kappa: f64, gamma_rad: f64) -> SlipInput {
    SlipInput {
        fz_n,
        kappa,
        alpha_rad,
        gamma_rad,
        vx_mps: SPEED_MPS,
    }
}

/// Every figure of the truth at the car's conditions, by the compare table's column names.
fn truth_figures(t: &Truth, truth_toml: &toml::Table) -> BTreeMap<String, f64> {
    let mut f = BTreeMap::new();
    let g = t.camber();
    f.insert("camber_deg".to_string(), g.to_degrees());
    let fy_nom = t.peak_fy(NOMINAL_N, g);
    f.insert(
        "camber_gain_pct".to_string(),
        100.0 * (fy_nom / t.peak_fy(NOMINAL_N, 0.0) - 1.0),
    );
    let (mut sum_fy, mut sum_fx, mut mu_y, mut mu_x) = (0.0, 0.0, Vec::new(), Vec::new());
    for fz in LOADS_N {
        let (fy, fx) = (t.peak_fy(fz, g), t.peak_fx(fz, g));
        sum_fy += fy;
        sum_fx += fx;
        mu_y.push(fy / fz);
        mu_x.push(fx / fz);
        let l = fz as i64;
        f.insert(format!("fy_peak_n_fz{l}"), fy);
        f.insert(format!("mu_y_peak_fz{l}"), fy / fz);
        f.insert(format!("fx_peak_n_fz{l}"), fx);
        f.insert(format!("mu_x_peak_fz{l}"), fx / fz);
        f.insert(
            format!("cornering_stiffness_n_per_rad_fz{l}"),
            t.slope(0.1f64.to_radians(), &|a| input(fz, a, 0.0, g), false),
        );
    }
    let fz_sum: f64 = LOADS_N.iter().sum();
    f.insert("lateral_mu".to_string(), sum_fy / fz_sum);
    f.insert("longitudinal_mu".to_string(), sum_fx / fz_sum);
    let span_kn = (LOADS_N[2] - LOADS_N[0]) / 1000.0;
    f.insert(
        "mu_y_load_sensitivity_per_kn".to_string(),
        (mu_y[2] - mu_y[0]) / span_kn,
    );
    f.insert(
        "mu_x_load_sensitivity_per_kn".to_string(),
        (mu_x[2] - mu_x[0]) / span_kn,
    );
    f.insert(
        "cornering_stiffness_n_per_rad".to_string(),
        t.slope(0.1f64.to_radians(), &|a| input(NOMINAL_N, a, 0.0, g), false),
    );
    f.insert(
        "longitudinal_stiffness_n".to_string(),
        t.slope(5e-4, &|k| input(NOMINAL_N, 0.0, k, g), true),
    );
    f.insert("envelope_area_kn2".to_string(), t.envelope(g) * 1e-6);
    let (sk, sa) = t.model.relaxation_lengths(NOMINAL_N, g);
    f.insert("relaxation_length_lateral_m".to_string(), sa);
    f.insert("relaxation_length_longitudinal_m".to_string(), sk);
    f.insert(
        "vertical_stiffness_n_per_m".to_string(),
        t.model.coefs[Coef::VERTICAL_STIFFNESS],
    );
    let th = truth_toml["thermal"].as_table().unwrap();
    f.insert("t_opt_c".to_string(), th["t_peak_c"].as_float().unwrap());
    f.insert(
        "thermal_gain_pct".to_string(),
        100.0 * th["gain_peak_over_cold"].as_float().unwrap(),
    );
    f
}

/// The truth TOML of a tire and rim.
fn truth_toml(round: &Path, tire: &str, rim_in: i64) -> toml::Table {
    let stem = tire_rim_stem(tire, rim_in as f64);
    let path = round.join("truth").join(format!("{stem}.toml"));
    toml::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap()
}

/// The scale a figure's error is measured against: its own value, except for the figures that
/// are small differences of larger ones (stated per figure).
fn scale(column: &str, truth: f64, figures: &BTreeMap<String, f64>) -> (f64, &'static str) {
    match column {
        // The gain is the difference of two peak forces in % of the peak: judged in % of the peak.
        "camber_gain_pct" => (100.0, "in % of the peak force"),
        // d mu/d Fz over the car's loads is the difference of two friction coefficients: judged
        // as that difference against the mean mu over the span of loads.
        "mu_y_load_sensitivity_per_kn" => (
            figures["lateral_mu"] / ((LOADS_N[2] - LOADS_N[0]) / 1000.0),
            "in mu per kN of load span (the mu change over the span relative to mu)",
        ),
        "mu_x_load_sensitivity_per_kn" => (
            figures["longitudinal_mu"] / ((LOADS_N[2] - LOADS_N[0]) / 1000.0),
            "in mu per kN of load span (the mu change over the span relative to mu)",
        ),
        _ => (truth.abs(), "relative"),
    }
}

/// Every row's figures against the truth: the worst error per figure is printed; figures for
/// which `asserted` holds must be within 2 %, the others are only measured. Returns the truth
/// figures per row (in CSV row order) and the compare table.
fn figures_against_truth(
    pubd: &Published,
    asserted: &dyn Fn(&str) -> bool,
) -> (Vec<BTreeMap<String, f64>>, DataFrame) {
    let csv = compare_csv(&pubd.store, &[]);
    assert_eq!(
        csv,
        compare_csv(&pubd.store, &[]),
        "compare --format csv must be byte-stable"
    );
    let one_thread = bin()
        .args(["compare", "--store", p(&pubd.store), "--format", "csv"])
        .env("RAYON_NUM_THREADS", "1")
        .output()
        .unwrap();
    ok(&one_thread, "compare on one thread");
    assert_eq!(csv, one_thread.stdout, "the same bytes on one thread");
    let df = frame(&csv);
    let header: Vec<String> = df
        .get_column_names()
        .iter()
        .map(|s| s.to_string())
        .collect();
    let schema = tirebase::schema::table(TableName::Compare).for_loads(&[350, 700, 1050]);
    let expected: Vec<String> = schema.columns.iter().map(|c| c.name.clone()).collect();
    assert_eq!(header, expected, "CSV header = schemas/compare.toml");
    let version = pubd.store.join("versions/v000001");
    let (tires, rims, pressures) = (
        strs(&df, "tire"),
        f64s(&df, "rim_in"),
        f64s(&df, "pressure_kpa"),
    );
    assert!(df.height() >= 8, "every demo group: {}", df.height());
    let mut truths = Vec::new();
    let mut worst: BTreeMap<String, (f64, String)> = BTreeMap::new();
    let mut failures = Vec::new();
    for i in 0..df.height() {
        let (tire, rim, kpa) = (&tires[i], rims[i] as i64, pressures[i] as i64);
        let file = tir_file_name(tire, rim as f64, kpa as f64);
        let truth = Truth::new(
            &read_tir(&pubd.round.join("truth/tir").join(&file)),
            &read_tir(&version.join("tir").join(&file)),
        );
        let figures = truth_figures(&truth, &truth_toml(&pubd.round, tire, rim));
        for (column, &t) in &figures {
            let got = f64s(&df, column)[i];
            let (s, how) = scale(column, t, &figures);
            let err = (got - t).abs() / s;
            let label = format!("{tire} {rim}in/{kpa}kPa: got {got:.6}, truth {t:.6}");
            let checked = if asserted(column) { "" } else { " [measured]" };
            let w = worst
                .entry(format!("{column} ({how}){checked}"))
                .or_default();
            if err > w.0 || err.is_nan() {
                *w = (err, label.clone());
            }
            if asserted(column) && (err > 0.02 || err.is_nan()) {
                failures.push(format!("{column}: {label}: {:.2} % ({how})", 100.0 * err));
            }
        }
        truths.push(figures);
    }
    println!("worst error per figure over {} rows:", df.height());
    for (column, (err, label)) in &worst {
        println!("  {column:70} {:7.3} %  {label}", 100.0 * err);
    }
    assert!(
        failures.is_empty(),
        "figures off the truth by more than 2 %:\n{}",
        failures.join("\n")
    );
    (truths, df)
}

/// For each objective, with `u` the uncertainty compare states for a pair (`sqrt(e_i^2 +
/// e_j^2)` of its objective_error): no pair whose truth differs by more than `u` is ranked
/// against the truth's order, and every pair whose truth differs by more than `2 u` is ranked
/// in it (strictly). Between `u` and `2 u` a tie is allowed: the fitted difference of a pair
/// whose true difference is just above the threshold falls below it about half the time, so
/// no threshold rule can order every such pair; a tie there says "cannot tell", never the wrong
/// thing. Returns the number of pairs beyond `u`.
fn ranking_against_truth(
    pubd: &Published,
    truths: &[BTreeMap<String, f64>],
    df: &DataFrame,
    objectives: &[(&str, &str)],
) -> usize {
    let key = |df: &DataFrame, i: usize| {
        (
            strs(df, "tire")[i].clone(),
            f64s(df, "rim_in")[i] as i64,
            f64s(df, "pressure_kpa")[i] as i64,
        )
    };
    let mut checked = 0;
    for &(objective, column) in objectives {
        let ranked = frame(&compare_csv(&pubd.store, &["--rank", objective]));
        let truth_of: BTreeMap<_, f64> = (0..df.height())
            .map(|i| (key(df, i), truths[i][column]))
            .collect();
        let (rank, err) = (f64s(&ranked, "rank"), f64s(&ranked, "objective_error"));
        assert!(err.iter().all(|e| e.is_finite() && *e > 0.0), "{err:?}");
        let (mut pairs, mut ordered, mut clear, mut within) = (0, 0, 0, 0);
        for i in 0..ranked.height() {
            for j in 0..ranked.height() {
                let (ti, tj) = (truth_of[&key(&ranked, i)], truth_of[&key(&ranked, j)]);
                let u = err[i].hypot(err[j]);
                let what = || {
                    format!(
                        "{objective}: {:?} (truth {ti}, rank {}) vs {:?} (truth {tj}, rank {}), u = {u}",
                        key(&ranked, i),
                        rank[i],
                        key(&ranked, j),
                        rank[j]
                    )
                };
                if ti - tj > u {
                    pairs += 1;
                    assert!(rank[i] <= rank[j], "ranked against the truth: {}", what());
                    if rank[i] < rank[j] {
                        ordered += 1;
                    }
                    if ti - tj > 2.0 * u {
                        clear += 1;
                        assert!(rank[i] < rank[j], "not ranked ahead: {}", what());
                    }
                } else if i < j && (ti - tj).abs() <= u {
                    within += 1;
                }
            }
        }
        println!(
            "{objective} ({} rows): {pairs} pairs differ beyond the stated uncertainty u in the truth: {ordered} ranked in its order, {} shown as ties, none against it; all {clear} beyond 2u ranked in order; {within} pairs within u",
            ranked.height(),
            pairs - ordered
        );
        checked += pairs;
    }
    checked
}

const OBJECTIVES: [(&str, &str); 3] = [
    ("lateral", "lateral_mu"),
    ("longitudinal", "longitudinal_mu"),
    ("envelope", "envelope_area_kn2"),
];

/// Issue 22 "Done when", first line: a virtual round whose truth models are known exactly
/// (no heat: the truth `.tir` is the tire at every sample, with noise and force lag as usual).
#[test]
fn compare_matches_the_truth_within_2_percent_and_ranks_in_its_order() {
    let pubd = without_heat();
    let (truths, df) = figures_against_truth(pubd, &|c| c != "t_opt_c" && c != "thermal_gain_pct");
    // Grip does not depend on temperature here: no thermal optimum may be reported.
    for column in ["t_opt_c", "warmup_rate_c_per_s", "warmup_time_s"] {
        assert!(
            f64s(&df, column).iter().all(|v| v.is_nan()),
            "{column}: a thermal optimum reported for a tire without one"
        );
    }
    let pairs = ranking_against_truth(pubd, &truths, &df, &OBJECTIVES);
    assert!(
        pairs >= 10,
        "too few decidable pairs ({pairs}) to test the ranking"
    );
}

/// The default demo round (heat on). Grip-limited longitudinal figures are measured, not
/// asserted: the truth `.tir`'s longitudinal grip is the tire at the |F|/Fz-weighted mean
/// temperature of its drive/brake and combined sweeps, and the low-load sweeps run cooler, so
/// the fitted peaks there sit below it (see the README's tire-selection section).
#[test]
fn on_the_default_round_lateral_thermal_and_stiffness_figures_match_the_truth() {
    let pubd = default_round();
    let grip_limited_longitudinal = |c: &str| {
        c.starts_with("fx_peak_n")
            || c.starts_with("mu_x_peak")
            || c == "longitudinal_mu"
            || c == "envelope_area_kn2"
    };
    let (truths, df) = figures_against_truth(pubd, &|c| !grip_limited_longitudinal(c));
    let warm = f64s(&df, "warmup_rate_c_per_s");
    assert!(warm.iter().all(|w| w.is_finite() && *w > 0.0), "{warm:?}");
    println!(
        "  warmup_rate_c_per_s: no truth (the machine's heat model has no warm-up law); measured {:.3}..{:.3} degC/s",
        warm.iter().copied().fold(f64::INFINITY, f64::min),
        warm.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    );
    let pairs = ranking_against_truth(pubd, &truths, &df, &OBJECTIVES[..1]);
    assert!(
        pairs >= 5,
        "too few decidable pairs ({pairs}) to test the ranking"
    );
}

/// Two rounds of the same tires (the two fixtures: the same plan with and without the heat
/// model, standing in for a tire tested in two rounds): every row is matched across them, the
/// spread between the rounds is reported, and it is added to the uncertainty of every
/// cross-round pair (the same tire, rim and pressure in both rounds always ties).
#[test]
fn across_rounds_the_same_tire_is_matched_and_the_spread_is_shown() {
    let (a, b) = (without_heat(), default_round());
    let o = tirebase(&[
        "compare",
        "--store",
        p(&a.store),
        "--store",
        p(&b.store),
        "--format",
        "csv",
    ]);
    ok(&o, "compare over two rounds");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("cross-round pairs add"), "{stderr}");
    let df = frame(&o.stdout);
    assert_eq!(df.height(), 16, "8 groups in each round");
    let rounds = strs(&df, "round");
    let labels: std::collections::BTreeSet<&String> = rounds.iter().collect();
    assert_eq!(labels.len(), 2, "{labels:?}");
    let (tested, spread, value) = (
        f64s(&df, "rounds_tested"),
        f64s(&df, "objective_spread"),
        f64s(&df, "lateral_mu"),
    );
    let key = |i: usize| {
        (
            strs(&df, "tire")[i].clone(),
            f64s(&df, "rim_in")[i] as i64,
            f64s(&df, "pressure_kpa")[i] as i64,
        )
    };
    let tied = strs(&df, "tied_with");
    for i in 0..df.height() {
        assert_eq!(tested[i], 2.0);
        let twin = (0..df.height())
            .find(|&j| j != i && key(j) == key(i))
            .expect("the same tire in the other round");
        assert!(
            (spread[i] - (value[i] - value[twin]).abs()).abs() < 1e-12,
            "spread of {:?}",
            key(i)
        );
        let (tire, rim, kpa) = key(i);
        assert!(
            tied[i].contains(&format!("{tire} {rim}in/{kpa}kPa [{}]", rounds[twin])),
            "{:?} is tied with its twin: {}",
            key(i),
            tied[i]
        );
    }
}

#[test]
fn help_documents_units_and_axes_and_bad_input_is_a_clear_error() {
    let o = tirebase(&["compare", "--help"]);
    ok(&o, "compare --help");
    let help = String::from_utf8_lossy(&o.stdout);
    for needle in [
        "ISO-W",
        "N/rad",
        "kN^2",
        "degC",
        "1/kN",
        "camber",
        "tied_with",
    ] {
        assert!(help.contains(needle), "--help lacks {needle}");
    }
    let tmp = tempfile::tempdir().unwrap();
    let o = tirebase(&["compare", "--store", p(tmp.path())]);
    assert_eq!(o.status.code(), Some(2));
    let car = tmp.path().join("car.toml");
    std::fs::write(&car, "[car]\nname = \"x\"\nloads_n = [1.0]\n").unwrap();
    let o = tirebase(&[
        "compare",
        "--store",
        p(&default_round().store),
        "--car",
        p(&car),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("car.toml") && err.contains("missing field"),
        "{err}"
    );
}
