//! The spring-rate, thermal and relaxation stages against a virtual round's truth, through the raw
//! files: `synth` renders the demo round's run files, the TTC reader parses them, the truth
//! segment table (`truth/segments.csv` rows) cuts them into segments, the stages run, and their
//! results are compared with the truth models (issue 6 "Done when"). Test-only.

use std::collections::BTreeMap;

use super::relaxation::{self, Direction, RelaxationConfig, RelaxationInput};
use super::segment_data::{Channels, MeasuredSegment, NominalLevels, SegmentKind, TireKey};
use super::spring_rate::{self, Condition, SpringRateConfig};
use super::thermal::{self, ThermalConfig};
use crate::synth::round::{RoundPlan, SynthConfig, plan_round, render_run};
use crate::synth::tires::TruthModel;
use crate::tire_model::{Coef, Pac2002};
use crate::ttc::read_run;

/// The round's segments and what the truth says per tire/rim/pressure.
struct Round {
    plan: RoundPlan,
    segments: Vec<MeasuredSegment>,
}

fn key_of(tire: &str, rim_in: f64, pressure_kpa_nom: f64) -> TireKey {
    TireKey {
        tire: tire.to_string(),
        rim_in: rim_in.round() as i64,
        pressure_kpa_nom: pressure_kpa_nom.round() as i64,
    }
}

fn build(config: SynthConfig) -> Round {
    let plan = plan_round(&config).expect("plan");
    let mut segments = Vec::new();
    for index in 0..plan.runs.len() {
        let out = render_run(&plan, index).expect("render");
        let table = read_run(&out.file.bytes, &out.file.path).expect("read");
        for (k, row) in out.summary.segments.iter().enumerate() {
            let Some(kind) = SegmentKind::parse(row.kind.as_str()) else {
                continue;
            };
            let a = row.row_first - 1;
            let r = a..a + row.n_samples;
            segments.push(MeasuredSegment {
                segment_id: format!("{}-{k}", out.file.path),
                kind,
                source_file: out.file.path.clone(),
                segment_index: k as i64,
                key: key_of(&row.tire, row.rim_in, row.pressure_kpa_nom),
                nominal: NominalLevels {
                    pressure_kpa: Some(row.pressure_kpa_nom.round() as i64),
                    ia_cdeg: row.ia_deg_nom.map(crate::segment::ia_cdeg_label),
                    fz_n: row.fz_n_nom.map(|v| v.round() as i64),
                    alpha_deg: row.alpha_deg_nom.map(|v| v.round() as i64),
                    speed_kph: row.speed_kph_nom.map(|v| v.round() as i64),
                },
                channels: Channels::of_run(&table, r.clone()),
            });
        }
    }
    Round { plan, segments }
}

/// A row's inclination as printed: degrees (`1.6`), `swept` when not held.
fn ia_text(ia_cdeg: Option<i64>) -> String {
    ia_cdeg.map_or_else(|| "swept".to_string(), crate::segment::ia_cdeg_text)
}

fn truths(plan: &RoundPlan) -> BTreeMap<TireKey, &TruthModel> {
    plan.truths
        .iter()
        .map(|t| {
            let c = plan
                .combos
                .iter()
                .find(|c| c.tire_index == t.tire_index && (c.rim_in - t.rim_in).abs() < 1e-9)
                .unwrap();
            (key_of(c.tire(), t.rim_in, t.pressure_kpa()), t)
        })
        .collect()
}

#[test]
fn demo_round_meets_the_issue_6_tolerances() {
    check_round(&build(SynthConfig::default()));
}

#[test]
fn demo_round_through_the_segmenter_meets_the_issue_6_tolerances() {
    check_round(&build_segmented(SynthConfig::default()));
}

/// The full round (12 tire/rim combinations, 48 tire x pressure groups) through the segmenter,
/// as the pipeline sees it. Ignored by default: rendering the round takes about a minute.
#[test]
#[ignore = "renders the full round (~1 min at opt-level 3); run with --ignored"]
fn full_round_meets_the_issue_6_tolerances() {
    check_round(&build_segmented(SynthConfig {
        size: crate::synth::round::Size::Full,
        ..SynthConfig::default()
    }));
}

/// The same on other noise realizations of the full round (seed 20261122 once put one thermal
/// gain 5.8 % off, through the unresolved cold maxima now left out of `mu(T)`).
#[test]
#[ignore = "renders the full round twice (~2 min at opt-level 3); run with --ignored"]
fn full_rounds_of_other_seeds_meet_the_issue_6_tolerances() {
    for seed in [1, 20261122] {
        println!("seed {seed}");
        check_round(&build_segmented(SynthConfig {
            size: crate::synth::round::Size::Full,
            seed,
            ..SynthConfig::default()
        }));
    }
}

/// Like [`build`], but the segments come from the segmenter, not from the truth table.
fn build_segmented(config: SynthConfig) -> Round {
    build_segmented_runs(config, |_, _, _| true)
}

/// [`build_segmented`] over the runs `keep` accepts (its tire name, rim and pressure, psi).
fn build_segmented_runs(config: SynthConfig, keep: impl Fn(&str, f64, f64) -> bool) -> Round {
    use crate::segment::{self, RunSignals, SegmentConfig, TreadTemps};
    let plan = plan_round(&config).expect("plan");
    let mut segments = Vec::new();
    for index in 0..plan.runs.len() {
        let c = plan.combos[plan.runs[index].combo];
        if !keep(c.tire(), c.rim_in, plan.runs[index].pressure_psi) {
            continue;
        }
        let out = render_run(&plan, index).expect("render");
        let table = read_run(&out.file.bytes, &out.file.path).expect("read");
        let spec = &plan.runs[index];
        let combo = plan.combos[spec.combo];
        let empty: Vec<f64> = Vec::new();
        let rl = table.loaded_radius_m.as_ref().unwrap_or(&empty);
        let mut signals = RunSignals::from_iso_w(
            &table.tire,
            &table.et_s,
            &table.speed_kph,
            &table.pressure_kpa,
            rl,
        );
        if let (Some(i), Some(c), Some(o)) = (
            &table.tread_inner_temp_c,
            &table.tread_centre_temp_c,
            &table.tread_outer_temp_c,
        ) {
            signals.tread_temps = Some(TreadTemps {
                inner_c: i,
                centre_c: c,
                outer_c: o,
            });
        }
        let (segs, _) = segment::run(&signals, &SegmentConfig::default()).expect("segment");
        let key = key_of(
            combo.tire(),
            combo.rim_in,
            spec.pressure_psi * crate::synth::tires::KPA_PER_PSI,
        );
        for seg in segs {
            segments.push(MeasuredSegment::of_run(
                &table,
                &out.file.path,
                &seg,
                key.clone(),
            ));
        }
    }
    Round { plan, segments }
}

/// Compare every stage with the truth; every violation is collected and printed before the one
/// assertion, so a run shows the whole picture.
fn check_round(round: &Round) {
    let mut violations: Vec<String> = Vec::new();
    let truth = truths(&round.plan);
    let fnomin: BTreeMap<TireKey, f64> = truth
        .iter()
        .map(|(k, t)| (k.clone(), t.model.coefs[Coef::FNOMIN]))
        .collect();

    // Spring rate: every static/dynamic row within 1 % and 0.5 mm.
    let sr = spring_rate::run(&round.segments, &fnomin, &SpringRateConfig::default());
    // Speed sweeps run at one load only: no stiffness from them, said so.
    let unexpected: Vec<_> = sr
        .failures
        .iter()
        .filter(|f| !(f.scope.starts_with("sweep") && f.reason.contains("load span")))
        .collect();
    if !unexpected.is_empty() {
        violations.push(format!("spring-rate failures: {unexpected:?}"));
    }
    let mut worst = (0.0_f64, 0.0_f64);
    for r in &sr.rows {
        let t = truth[&r.key];
        let (cz, r0) = match r.condition {
            Condition::Static => (t.vertical.cz_static_n_per_m, t.vertical.r0_static_m),
            _ => (
                t.vertical.cz_at(r.speed_kph / 3.6),
                t.vertical.r0_at(r.speed_kph / 3.6),
            ),
        };
        let (e_cz, e_r0) = (r.stiffness_n_per_m / cz - 1.0, r.unloaded_radius_m - r0);
        println!(
            "spring {} {:>7} ia {:>5}: Cz {:+.4} %, R0 {:+.4} mm (n {})",
            r.key,
            r.condition.as_str(),
            ia_text(r.ia_cdeg_nom),
            100.0 * e_cz,
            1e3 * e_r0,
            r.n
        );
        worst = (worst.0.max(e_cz.abs()), worst.1.max(e_r0.abs()));
        if !(e_cz.abs() < 0.01 && e_r0.abs() < 0.5e-3) {
            violations.push(format!(
                "spring {} {} ia {}: Cz {:+.3} %, R0 {:+.3} mm",
                r.key,
                r.condition.as_str(),
                ia_text(r.ia_cdeg_nom),
                100.0 * e_cz,
                1e3 * e_r0
            ));
        }
    }
    println!(
        "spring worst: Cz {:.3} %, R0 {:.3} mm",
        100.0 * worst.0,
        1e3 * worst.1
    );
    for v in &sr.vertical {
        let t = truth[&v.key];
        let law = v.effective_radius.as_ref().expect("RE law");
        let mut worst_re = 0.0_f64;
        for fz in [222.0, 445.0, 667.0, 1112.0, 1557.0] {
            let re = spring_rate::effective_radius_m(
                law,
                v.unloaded_radius_m,
                v.vertical_stiffness_n_per_m,
                fz,
            );
            worst_re = worst_re.max((re - t.effective_radius(fz, v.speed_kph / 3.6)).abs());
        }
        println!(
            "RE law {}: BREFF {:.3} DREFF {:.4} FREFF {:.4}, worst RE error {:.4} mm",
            v.key,
            law.breff,
            law.dreff,
            law.freff,
            1e3 * worst_re
        );
        if worst_re >= 0.1e-3 {
            violations.push(format!("RE law {}: worst {:.4} mm", v.key, 1e3 * worst_re));
        }
    }

    // Relaxation with the truth model as the "fitted" steady state.
    let mut inputs = Vec::new();
    let models: BTreeMap<TireKey, Pac2002> = truth
        .iter()
        .map(|(k, t)| (k.clone(), t.model.clone()))
        .collect();
    let mut per_key: BTreeMap<TireKey, Vec<MeasuredSegment>> = BTreeMap::new();
    for s in &round.segments {
        per_key.entry(s.key.clone()).or_default().push(s.clone());
    }
    for (k, segs) in &per_key {
        let t = truth[k];
        inputs.push(RelaxationInput {
            key: k.clone(),
            model: &models[k],
            unloaded_radius_m: t.vertical.r0_dynamic_m,
            vertical_stiffness_n_per_m: t.vertical.cz_dynamic_n_per_m,
            segments: segs,
        });
    }
    let rx = relaxation::run(&inputs, &RelaxationConfig::default());
    println!("relaxation failures: {:?}", rx.failures);
    // The default realism has no measurement lag: neither the speeds nor the load steps of the
    // spring-rate holds may find one.
    for m in &rx.measurement_lags {
        println!(
            "measurement lag {}: {:.5} s: {}",
            m.key, m.lag.lag_s, m.note
        );
        let steps_supported = m.load_steps.as_ref().is_none_or(|s| s.supported);
        if m.identified || m.lag.lag_s != 0.0 || steps_supported {
            violations.push(format!("measurement lag {}: {}", m.key, m.note));
        }
    }
    let mut worst = BTreeMap::new();
    for r in &rx.rows {
        let (sk, sa) = models[&r.key].relaxation_lengths(r.fz_n_mean, 0.0);
        let t = if r.direction == Direction::Lateral {
            sa
        } else {
            sk
        };
        let e = r.sigma_m / t - 1.0;
        let el = r.sigma_law_m / t - 1.0;
        println!(
            "relax {} {} {} Fz {:>7} rate {:.3}: sigma {:.4} truth {:.4} ({:+.2} %), own {:+.2} %, prior {:+.2} %, weight {:.2}, law {:+.2} %, spread {:.4}, se {:.4} ({:+.1} se), a {:.4}, c {:.0}, n_seg {}",
            r.key,
            r.direction.as_str(),
            r.method.as_str(),
            super::relaxation::load_text(r.fz_n_nom),
            r.slip_rate,
            r.sigma_m,
            t,
            100.0 * e,
            100.0 * (r.sigma_row_m / t - 1.0),
            100.0 * (r.sigma_prior_m / t - 1.0),
            r.pool_weight,
            100.0 * el,
            r.sigma_spread_m,
            r.sigma_se_m,
            (r.sigma_row_m - t) / r.sigma_se_m,
            r.contact_half_length_m,
            r.carcass_stiffness_n_per_m,
            r.n_segments
        );
        let w = worst
            .entry(r.direction.as_str())
            .or_insert((0.0_f64, 0.0_f64));
        *w = (w.0.max(e.abs()), w.1.max(el.abs()));
        // Issue 6: within 5 % of the truth law at every tested load. The lowest load (222 N)
        // carries ~2-3 % statistical scatter from the force noise (see relaxation's docs), so
        // this margin is real but not wide.
        if !(e.abs() < 0.05 && el.abs() < 0.05) {
            violations.push(format!(
                "relax {} {} {} Fz {} rate {:.3}: row {:+.2} %, law {:+.2} %",
                r.key,
                r.direction.as_str(),
                r.method.as_str(),
                super::relaxation::load_text(r.fz_n_nom),
                r.slip_rate,
                100.0 * e,
                100.0 * el
            ));
        }
    }
    println!("relaxation worst |error| (row, law): {worst:?}");
    check_per_tire(
        &mut violations,
        "relaxation",
        &rx.failures,
        "relaxation laws",
        rx.laws.len(),
        truth.len(),
    );

    // Thermal.
    let th = thermal::run(&round.segments, &ThermalConfig::default());
    check_per_tire(
        &mut violations,
        "thermal",
        &th.failures,
        "thermal fits",
        th.fits.len(),
        truth.len(),
    );
    let mut worst_th = (0.0_f64, 0.0_f64);
    for f in &th.fits {
        let ci = round
            .plan
            .combos
            .iter()
            .position(|c| c.tire() == f.key.tire && (c.rim_in.round() as i64) == f.key.rim_in)
            .unwrap();
        let tt = round.plan.thermal[ci];
        println!(
            "thermal {}: T_peak {:.2} vs {:.2} ({:+.2} degC), gain {:.4} vs {:.4} ({:+.2} %), T_cold {:.2} vs {:.2}, falloff {:.3} (obs {}), n {}, rmse {:.4}",
            f.key,
            f.t_peak_c,
            tt.t_peak_c,
            f.t_peak_c - tt.t_peak_c,
            f.gain_peak_over_cold,
            tt.gain_peak_over_cold,
            100.0 * (f.gain_peak_over_cold / tt.gain_peak_over_cold - 1.0),
            f.t_cold_c,
            tt.t_cold_c,
            f.hot_falloff,
            f.hot_side_observed,
            f.n,
            f.rmse
        );
        // Issue 6: peak temperature within 3 degC, peak gain within 3 % (relative).
        let (e_t, e_g) = (
            f.t_peak_c - tt.t_peak_c,
            f.gain_peak_over_cold / tt.gain_peak_over_cold - 1.0,
        );
        worst_th = (worst_th.0.max(e_t.abs()), worst_th.1.max(e_g.abs()));
        if !(e_t.abs() < 3.0 && e_g.abs() < 0.03) {
            violations.push(format!(
                "thermal {}: T_peak {:+.2} degC, gain {:+.2} %",
                f.key,
                e_t,
                100.0 * e_g
            ));
        }
    }
    println!(
        "thermal worst |error|: T_peak {:.2} degC, gain {:.2} %",
        worst_th.0,
        100.0 * worst_th.1
    );
    for v in &violations {
        println!("VIOLATION {v}");
    }
    assert!(
        violations.is_empty(),
        "{} violations of issue 6's tolerances (listed above)",
        violations.len()
    );
}

/// A stage that fits one result per tire: any failure, and a count of results (`what`) other
/// than one per tire, is a violation.
fn check_per_tire<F: std::fmt::Debug>(
    violations: &mut Vec<String>,
    stage: &str,
    failures: &[F],
    what: &str,
    results: usize,
    tires: usize,
) {
    if !failures.is_empty() {
        violations.push(format!("{stage} failures: {failures:?}"));
    }
    if results != tires {
        violations.push(format!("{results} {what} for {tires} tires"));
    }
}

/// The sweeps of one tire as the PAC2002 stage wants them.
fn pac2002_input(
    key: &TireKey,
    segs: &[MeasuredSegment],
    cz: f64,
    r0: f64,
) -> super::pac2002::FitInput {
    use super::pac2002::{FitContext, FitInput, Sweep};
    let sweeps = segs
        .iter()
        .filter_map(|s| Sweep::from_segment(s, None, true))
        .collect();
    FitInput {
        context: FitContext {
            tire: key.tire.clone(),
            rim_in: key.rim_in as f64,
            pressure_kpa_nom: key.pressure_kpa_nom as f64,
            test_speed_mps: crate::synth::tires::V_REF_MPS,
            vertical_stiffness_n_per_m: Some(cz),
            unloaded_radius_m: Some(r0),
            relaxation: None,
        },
        sweeps,
    }
}

#[test]
fn demo_round_relaxation_with_the_fitted_pac2002_model() {
    // The pipeline's order: spring rate -> PAC2002 fit -> relaxation with the fitted model.
    let round = build(SynthConfig::default());
    let truth = truths(&round.plan);
    let sr = spring_rate::run(
        &round.segments,
        &BTreeMap::new(),
        &SpringRateConfig::default(),
    );
    let mut per_key: BTreeMap<TireKey, Vec<MeasuredSegment>> = BTreeMap::new();
    for s in &round.segments {
        per_key.entry(s.key.clone()).or_default().push(s.clone());
    }
    let mut fitted = BTreeMap::new();
    for (k, segs) in &per_key {
        let v = sr.vertical.iter().find(|v| &v.key == k).expect("vertical");
        let input = pac2002_input(k, segs, v.vertical_stiffness_n_per_m, v.unloaded_radius_m);
        let fit = super::pac2002::fit(&input, &super::pac2002::FitConfig::default()).expect("fit");
        fitted.insert(
            k.clone(),
            (fit.model, v.vertical_stiffness_n_per_m, v.unloaded_radius_m),
        );
    }
    let inputs: Vec<RelaxationInput> = per_key
        .iter()
        .map(|(k, segs)| RelaxationInput {
            key: k.clone(),
            model: &fitted[k].0,
            unloaded_radius_m: fitted[k].2,
            vertical_stiffness_n_per_m: fitted[k].1,
            segments: segs,
        })
        .collect();
    let rx = relaxation::run(&inputs, &RelaxationConfig::default());
    assert!(rx.failures.is_empty(), "{:?}", rx.failures);
    let mut worst = (0.0_f64, 0.0_f64);
    for r in &rx.rows {
        let (sk, sa) = truth[&r.key].model.relaxation_lengths(r.fz_n_mean, 0.0);
        let t = if r.direction == Direction::Lateral {
            sa
        } else {
            sk
        };
        let (e, el) = (r.sigma_m / t - 1.0, r.sigma_law_m / t - 1.0);
        println!(
            "fitted-model relax {} {} {} Fz {:>7}: sigma {:+.2} %, law {:+.2} %, scale {:.3}",
            r.key,
            r.direction.as_str(),
            r.method.as_str(),
            super::relaxation::load_text(r.fz_n_nom),
            100.0 * e,
            100.0 * el,
            r.model_scale
        );
        worst = (worst.0.max(e.abs()), worst.1.max(el.abs()));
    }
    println!("fitted-model relaxation worst |error| (row, law): {worst:?}");
    assert!(worst.0 < 0.05 && worst.1 < 0.05, "{worst:?}");
}

/// Issue 18 on the demo round with a 20 ms pure delay (and, second, a 20 ms first-order filter)
/// in the load cell's chain: every tire/rim/pressure swept at one speed only takes the lag from
/// its spring-rate load steps, within 10 % of the truth, and its relaxation lengths (the truth
/// model's steady state, so only the lag is under test) land within 10 % of the truth.
#[test]
fn demo_round_one_speed_lag_from_the_load_steps() {
    use super::relaxation::LagForm;
    for (form, delay_s, filter_s) in [
        (LagForm::Delay, 0.02, 0.0),
        (LagForm::FirstOrder, 0.0, 0.02),
    ] {
        let mut config = SynthConfig::default();
        config.realism.measurement_delay_s = delay_s;
        config.realism.measurement_filter_s = filter_s;
        let round = build(config);
        let truth = truths(&round.plan);
        let mut per_key: BTreeMap<TireKey, Vec<MeasuredSegment>> = BTreeMap::new();
        for s in &round.segments {
            per_key.entry(s.key.clone()).or_default().push(s.clone());
        }
        let models: BTreeMap<TireKey, Pac2002> = truth
            .iter()
            .map(|(k, t)| (k.clone(), t.model.clone()))
            .collect();
        let inputs: Vec<RelaxationInput> = per_key
            .iter()
            .map(|(k, segs)| RelaxationInput {
                key: k.clone(),
                model: &models[k],
                unloaded_radius_m: truth[k].vertical.r0_dynamic_m,
                vertical_stiffness_n_per_m: truth[k].vertical.cz_dynamic_n_per_m,
                segments: segs,
            })
            .collect();
        let cfg = RelaxationConfig {
            measurement_lag_form: form,
            ..RelaxationConfig::default()
        };
        let rx = relaxation::run(&inputs, &cfg);
        let mut failures = Vec::new();
        let (mut worst_lag, mut worst_sigma, mut one_speed) = (0.0_f64, 0.0_f64, 0);
        for m in &rx.measurement_lags {
            let by_steps = m.speeds_kph.is_empty();
            println!("{form:?} {}: {:.5} s: {}", m.key, m.lag.lag_s, m.note);
            let e = m.lag.lag_s / 0.02 - 1.0;
            if !m.identified || e.abs() >= 0.1 {
                failures.push(format!("{}: {}", m.key, m.note));
            }
            if !by_steps {
                continue;
            }
            one_speed += 1;
            worst_lag = worst_lag.max(e.abs());
            for r in rx.rows.iter().filter(|r| r.key == m.key) {
                let (sk, sa) = models[&r.key].relaxation_lengths(r.fz_n_mean, 0.0);
                let t = if r.direction == Direction::Lateral {
                    sa
                } else {
                    sk
                };
                let es = r.sigma_m / t - 1.0;
                worst_sigma = worst_sigma.max(es.abs());
                if es.abs() >= 0.1 || r.measurement_lag_s != m.lag.lag_s || !r.lag_separated {
                    failures.push(format!(
                        "{} {} at {:.0} N: sigma {:.4} truth {t:.4} ({:+.2} %)",
                        r.key,
                        r.direction.as_str(),
                        r.fz_n_mean,
                        r.sigma_m,
                        100.0 * es
                    ));
                }
            }
        }
        println!(
            "{form:?}: {one_speed} one-speed inputs, worst lag error {:.2} %, worst sigma error \
             {:.2} %",
            100.0 * worst_lag,
            100.0 * worst_sigma
        );
        assert!(one_speed > 0, "no one-speed input");
        assert!(failures.is_empty(), "{form:?}: {failures:#?}");
    }
}
