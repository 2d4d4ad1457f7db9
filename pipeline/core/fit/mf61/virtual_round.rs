//! The MF 6.1 stage on a virtual round whose truth is one MF 6.1 model (`[synth] truth = "mf61"`),
//! through the raw files, the segmenter and the per-pressure PAC2002 fits
//! ([`super::virtual_input`]): the fitted model against the truth over each pressure's tested
//! envelope (issue 19). Test-only.

use super::tests::{model_only, print_families};
use super::virtual_input::{Prepared, prepare, prepare_config};
use super::*;
use crate::synth::drift::RunOrderDrift;
use crate::synth::quirks::QuirksConfig;
use crate::synth::round::SynthConfig;
use crate::synth::tires::TruthForm;
use crate::tire_model::{Mode, SlipInput};

fn show(e: [f64; 3]) -> String {
    format!("Fx {:.3} %, Fy {:.3} %, Mz {:.3} %", e[0], e[1], e[2])
}

/// Issue 19 "Done when" 2 on a virtual round with an MF 6.1 truth (Hoosier 16.0x7.5-10 R25B on a
/// 7 in rim, round-9 plan, 8 / 10 / 12 / 14 psi, default realism): the MF 6.1 model fitted on
/// all four pressures is within 1 % of peak (RMS over each pressure's tested envelope; Fx, Fy,
/// Mz) at every pressure, and fitted on three it predicts the fourth within 3 % (Fx, Fy) and 6 %
/// (Mz). Renders 8 run files and runs 4 PAC2002 fits and 5 MF 6.1 fits (~1 min at opt-level 3).
#[test]
fn mf61_truth_round_is_recovered_and_a_left_out_pressure_predicted() {
    let prep = prepare(1, 7.0);
    let pressures: Vec<i64> = prep.envelopes.keys().copied().collect();
    assert_eq!(pressures.len(), 4, "{pressures:?}");
    let cfg = model_only();
    let full = fit(&prep.input, &cfg).expect("fit");
    print_families(&full);
    for n in &full.notes {
        println!("note: {n}");
    }
    for c in [PPX1, PPX3, PPY1, PPY2, PPY3, PPY4, PPY5, PPZ1, PPZ2, PFZ1] {
        println!(
            "{}: fitted {:.4}, truth {:.4}",
            c.name(),
            full.model.coefs[c],
            prep.truth.coefs[c]
        );
    }
    let mut violations = Vec::new();
    for (k, (p_pa, points)) in &prep.envelopes {
        let e = prep
            .truth
            .rms_error_pct_of_peak(&full.model, points, Some(*p_pa));
        println!("{k} kPa, all pressures: {}", show(e));
        if e.iter().any(|x| x.is_nan() || *x > 1.0) {
            violations.push(format!("{k} kPa in sample: {}", show(e)));
        }
    }
    for left_out in &pressures {
        let mut input = prep.input.clone();
        input.groups.retain(|g| g.pressure_kpa_nom != *left_out);
        let mut held = fit(&input, &cfg).expect("fit without one pressure");
        // Evaluated at the left-out pressure, not clipped to the others' range.
        held.model.coefs[PRESMIN] = PRESMIN.default_value();
        held.model.coefs[PRESMAX] = PRESMAX.default_value();
        let (p_pa, points) = &prep.envelopes[left_out];
        let e = prep
            .truth
            .rms_error_pct_of_peak(&held.model, points, Some(*p_pa));
        println!("{left_out} kPa left out: {}", show(e));
        let limits = [3.0, 3.0, 6.0];
        if e.iter().zip(limits).any(|(x, l)| x.is_nan() || *x > l) {
            violations.push(format!("{left_out} kPa left out: {}", show(e)));
        }
    }
    assert!(violations.is_empty(), "{violations:#?}");
}

/// Diagnosis of the combined-slip `Mz` gap on a PAC2002-truth round (not an assertion; prints
/// the figures): per pressure, on the combined sweeps' collapsed points, the RMSE of `Mz`, `Fx`,
/// `Fy` for the MF 6.1 fit, the per-pressure PAC2002 fit and the truth, then the `Mz` family
/// refitted with larger free sets, and the MF 6.1 fit of the noise-free truth values.
#[test]
#[ignore = "diagnostic: cargo test -p tirebase-core --lib combined_mz_diagnostic -- --ignored --nocapture"]
fn combined_mz_diagnostic() {
    use crate::synth::tires::TruthForm;
    let prep = super::virtual_input::prepare_with(1, 7.0, TruthForm::Pac2002);
    let cfg = model_only();
    let full = fit(&prep.input, &cfg).expect("fit");
    for f in &full.families {
        println!(
            "{}: free {:?} rmse {:.4} (start {:.4})",
            f.family.as_str(),
            f.free.iter().map(|c| c.name()).collect::<Vec<_>>(),
            f.rmse,
            f.initial_rmse
        );
    }
    let mut all = FamilyData::default();
    let mut all_truth = FamilyData::default();
    for g in &prep.input.groups {
        let mut pts = collapse_group(&g.sweeps, &cfg.collapse);
        for p in &mut pts {
            p.group = 0;
        }
        let pure = PureData::of(&pts);
        let truth = &prep.pressure_truths[&g.pressure_kpa_nom];
        let pac = &g.pac2002.as_ref().unwrap().model;
        let mut line = format!("{} kPa:", g.pressure_kpa_nom);
        for (family, ch) in [
            (Family::Mz, Channel::Mz),
            (Family::Fx, Channel::Fx),
            (Family::Fy, Channel::Fy),
        ] {
            let combined: Vec<Point> = pts
                .iter()
                .filter(|p| p.kind == SweepKind::Combined)
                .copied()
                .collect();
            let d = family_data(&combined, family, &pure);
            let peak = d.measured.iter().fold(0.0_f64, |m, y| m.max(y.abs()));
            let pct = |m: &MagicFormula| 100.0 * rmse_of(m, ch, &d) / peak;
            line += &format!(
                " {}: mf61 {:.3} % pac2002 {:.3} % truth {:.3} % (n {}, peak {:.1});",
                family.as_str(),
                pct(&full.model),
                pct(pac),
                pct(truth),
                d.len(),
                peak
            );
            if family == Family::Mz {
                let mut t = d.clone();
                truth.channel_into_at(
                    Channel::Mz,
                    &d.inputs,
                    Pressures::PerPoint(&d.pressures),
                    FIT_MODE,
                    &mut t.measured,
                );
                all.inputs.extend(&d.inputs);
                all.pressures.extend(&d.pressures);
                all.measured.extend(&d.measured);
                all.weights.extend(&d.weights);
                all_truth.inputs.extend(&t.inputs);
                all_truth.pressures.extend(&t.pressures);
                all_truth.measured.extend(&t.measured);
                all_truth.weights.extend(&t.weights);
            }
        }
        println!("{line}");
    }
    // Against the truth of each pressure over its tested envelope: Mz RMS in % of the truth's
    // peak Mz over the whole envelope, by sweep kind and inclination.
    for (kpa, (p_pa, env)) in &prep.envelopes {
        let truth = &prep.pressure_truths[kpa];
        let pac = &prep
            .input
            .groups
            .iter()
            .find(|g| g.pressure_kpa_nom == *kpa)
            .unwrap()
            .pac2002
            .as_ref()
            .unwrap()
            .model;
        let vx = truth.coefs[LONGVL];
        let eval = |m: &MagicFormula, x: &SlipInput| {
            m.eval_at(&SlipInput { vx_mps: vx, ..*x }, *p_pa, Mode::Limits)
                .mz_nm
        };
        let peak = env.iter().fold(0.0_f64, |a, x| a.max(eval(truth, x).abs()));
        let mut line = format!("{kpa} kPa vs truth, Mz % of peak {peak:.1} N m:");
        for kind in ["cornering", "drive/brake", "combined"] {
            for ia in [0.0_f64, 2.0, 4.0] {
                let pts: Vec<&SlipInput> = env
                    .iter()
                    .filter(|x| {
                        let k = if x.kappa == 0.0 {
                            "cornering"
                        } else if x.alpha_rad == 0.0 {
                            "drive/brake"
                        } else {
                            "combined"
                        };
                        k == kind && (x.gamma_rad - ia.to_radians()).abs() < 1e-6
                    })
                    .collect();
                if pts.is_empty() {
                    continue;
                }
                let rms = |m: &MagicFormula| {
                    100.0
                        * (pts
                            .iter()
                            .map(|x| (eval(m, x) - eval(truth, x)).powi(2))
                            .sum::<f64>()
                            / pts.len() as f64)
                            .sqrt()
                        / peak
                };
                line += &format!(
                    " {kind} IA {ia}: mf61 {:.2} pac2002 {:.2};",
                    rms(&full.model),
                    rms(pac)
                );
            }
        }
        println!("{line}");
    }
    let variants: [(&str, &[Coef]); 5] = [
        ("SSZ1-4", &[SSZ1, SSZ2, SSZ3, SSZ4]),
        (
            "SSZ + Mzr camber (QDZ8-11)",
            &[SSZ1, SSZ2, SSZ3, SSZ4, QDZ8, QDZ9, QDZ10, QDZ11],
        ),
        (
            "SSZ + Mzr (QDZ6-11, QBZ9-10)",
            &[
                SSZ1, SSZ2, SSZ3, SSZ4, QDZ6, QDZ7, QDZ8, QDZ9, QDZ10, QDZ11, QBZ9, QBZ10,
            ],
        ),
        (
            "SSZ + trail (QBZ1-5, QDZ1-4, QEZ1-5, QHZ1-4)",
            &[
                SSZ1, SSZ2, SSZ3, SSZ4, QBZ1, QBZ2, QBZ3, QBZ4, QBZ5, QDZ1, QDZ2, QDZ3, QDZ4, QEZ1,
                QEZ2, QEZ3, QEZ4, QEZ5, QHZ1, QHZ2, QHZ3, QHZ4,
            ],
        ),
        (
            "SSZ + trail + Mzr",
            &[
                SSZ1, SSZ2, SSZ3, SSZ4, QBZ1, QBZ2, QBZ3, QBZ4, QBZ5, QDZ1, QDZ2, QDZ3, QDZ4, QEZ1,
                QEZ2, QEZ3, QEZ4, QEZ5, QHZ1, QHZ2, QHZ3, QHZ4, QDZ6, QDZ7, QDZ8, QDZ9, QDZ10,
                QDZ11, QBZ9, QBZ10,
            ],
        ),
    ];
    let peak = all.measured.iter().fold(0.0_f64, |m, y| m.max(y.abs()));
    for (label, data) in [("measured", &all), ("noise-free truth", &all_truth)] {
        println!(
            "{label}: start {:.3} % of peak",
            100.0 * rmse_of(&full.model, Channel::Mz, data) / peak
        );
        for (name, free) in variants {
            let problem = Mf61FamilyProblem::new(&full.model, free, Channel::Mz, data);
            let bounds = Bounds {
                lower: vec![f64::NEG_INFINITY; free.len()],
                upper: vec![f64::INFINITY; free.len()],
            };
            let start: Vec<f64> = free.iter().map(|c| full.model.coefs[*c]).collect();
            let out = minimize(&problem, &start, &bounds, &Options::default());
            let m = problem.model_at(&out.params);
            println!(
                "  {label}, {name}: Mz {:.3} % of peak ({:?})",
                100.0 * rmse_of(&m, Channel::Mz, data) / peak,
                out.termination
            );
        }
    }
}

/// The quirked tire of [`run_order_drift_puts_the_first_block_out_of_pressure_order`]: the
/// Hoosier 16.0x7.5-10 R25B on a 7 in rim with an MF 6.1 truth, non-standard levels (tested
/// 12 / 10 / 14 / 16 psi in that order: 83 / 69 / 97 / 110 kPa), with `drift`.
fn quirked_tire(drift: RunOrderDrift) -> Prepared {
    prepare_config(
        1,
        7.0,
        SynthConfig {
            truth: TruthForm::Mf61,
            quirks: QuirksConfig {
                nonstandard_levels: true,
                drift,
                ..QuirksConfig::default()
            },
            ..SynthConfig::default()
        },
    )
}

/// Run-order drift on the virtual machine (`[synth.quirks.drift]`, the every-quirk round's
/// typical law): the pressure tested first (83 kPa, between 69 and 97 kPa, as on the real
/// drive/brake round) sees a fresher, stiffer tire than the later blocks. Per pressure the
/// PAC2002 fit is judged against that block's truth (the tire as its runs saw it), the MF 6.1 fit
/// against the block's and the settled tire; the left-out-pressure figures and the
/// out-of-pressure-order notes are printed. Checked: without drift no pressure is noted and every
/// `Fx0`/`Fy0` left-out-pressure ratio stays below 1.5x; with drift the per-pressure PAC2002 fits
/// still reproduce their blocks within 1 % of peak, and the end pressures, extrapolated through
/// the first-tested block, are predicted at least 3x worse than in sample (the real round's
/// 5.4x / 5.7x pattern).
#[test]
fn run_order_drift_puts_the_first_block_out_of_pressure_order() {
    let cfg = Mf61Config {
        kfold: 0,
        ..Mf61Config::default()
    };
    // Per drift setting: the worst Fx0/Fy0 left-out ratio per pressure (69, 83, 97, 110 kPa),
    // the notes, the worst PAC2002 error against its block (% of peak).
    let mut lopo: Vec<Vec<f64>> = Vec::new();
    let mut out_of_order = Vec::new();
    let mut pac_worst = Vec::new();
    for drift in [RunOrderDrift::default(), RunOrderDrift::typical()] {
        let on = !drift.is_off();
        let prep = quirked_tire(drift);
        let fit = fit(&prep.input, &cfg).expect("fit");
        println!("drift {}:", if on { "on" } else { "off" });
        let mut worst = 0.0_f64;
        for g in &prep.input.groups {
            let k = g.pressure_kpa_nom;
            let (p_pa, points) = &prep.envelopes[&k];
            let block = &prep.pressure_truths[&k];
            let pac = g.pac2002.as_ref().map_or([f64::NAN; 3], |pac| {
                block.rms_error_pct_of_peak(&pac.model, points, Some(*p_pa))
            });
            worst = pac.iter().fold(worst, |w, e| w.max(*e));
            let mf_block = block.rms_error_pct_of_peak(&fit.model, points, Some(*p_pa));
            let mf_settled = prep
                .truth
                .rms_error_pct_of_peak(&fit.model, points, Some(*p_pa));
            println!(
                "  {k} kPa (block LMUX {:.4} LKX {:.4} LMUY {:.4} LKY {:.4}): PAC2002 vs block \
                 {}; MF 6.1 vs block {}, vs settled {}",
                block.coefs[LMUX],
                block.coefs[LKX],
                block.coefs[LMUY],
                block.coefs[LKY],
                show(pac),
                show(mf_block),
                show(mf_settled)
            );
        }
        for q in fit
            .family_quality
            .iter()
            .filter(|q| matches!(q.family, Family::Fx0 | Family::Fy0))
        {
            println!(
                "  {} kPa {}: in-sample RMSE {:.2}, left out {:.2} ({:.2}x)",
                q.pressure_kpa_nom,
                q.family.as_str(),
                q.rmse,
                q.lopo_rmse.unwrap_or(f64::NAN),
                q.lopo_ratio()
            );
        }
        let notes: Vec<&String> = fit
            .notes
            .iter()
            .filter(|n| n.contains("not in pressure order"))
            .collect();
        for n in &notes {
            println!("  note: {n}");
        }
        out_of_order.push(notes.iter().map(|n| n.to_string()).collect::<Vec<_>>());
        pac_worst.push(worst);
        lopo.push(
            prep.input
                .groups
                .iter()
                .map(|g| {
                    fit.family_quality
                        .iter()
                        .filter(|q| q.pressure_kpa_nom == g.pressure_kpa_nom)
                        .filter(|q| matches!(q.family, Family::Fx0 | Family::Fy0))
                        .map(|q| q.lopo_ratio())
                        .fold(0.0, f64::max)
                })
                .collect(),
        );
    }
    assert!(out_of_order[0].is_empty(), "{:?}", out_of_order[0]);
    assert!(lopo[0].iter().all(|r| *r < 1.5), "{lopo:?}");
    assert!(lopo[1][0] > 3.0 && lopo[1][3] > 3.0, "{lopo:?}");
    assert!(pac_worst[1] < 1.0, "{pac_worst:?}");
}
