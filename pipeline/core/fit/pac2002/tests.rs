//! Validation of the PAC2002 fitting stage on rounds generated from known truths (issue 5).
//!
//! Truths: the `fsae-demo` reference tire and perturbed variants (one with the lateral signs
//! mirrored). Rounds: TTC layout from [`super::synthetic`]. Accuracy: RMS error of the fitted
//! model against the truth over the tested envelope, % of the truth's peak per channel.

use super::synthetic::{
    EnvelopeErrors, RoundSpec, envelope_errors, fsae_demo, truth_relaxation, ttc_round,
};
use super::*;
use crate::numerics::cpu_clock::thread_cpu_seconds;
use crate::tire_model::{Coef::*, Coefs, Real};

fn report(name: &str, fit: &Pac2002Fit, e: &EnvelopeErrors) {
    eprintln!(
        "== {name}: USE_MODE {}, {} evaluations, {:.3} s",
        fit.use_mode, fit.evaluations, fit.seconds
    );
    for f in &fit.families {
        match &f.quality {
            Some(q) => eprintln!(
                "  {:4} n {:5} rmse {:10.4} ({:7.4} % of peak) r2 {:.6} samples {:6} \
                 sample_rmse {:9.3} init_rmse {:9.3} it {:4} {:>18} evals {:4} {:.3} s",
                f.family.as_str(),
                q.n,
                q.rmse,
                q.rmse_pct_of_peak,
                q.r2,
                q.n_samples,
                q.sample_rmse,
                q.initial_rmse,
                q.iterations,
                q.termination.as_str(),
                q.evaluations,
                q.seconds
            ),
            None => eprintln!("  {:4} {:?}", f.family.as_str(), f.status),
        }
        if let Some(q) = &f.quality {
            eprintln!(
                "       oos {:?} ratio {:.3} trend {:?} ident {:?}",
                q.out_of_sample
                    .as_ref()
                    .map(|o| (o.folds, o.n, o.rmse, o.evaluations)),
                q.oos_ratio(),
                q.trend
                    .as_ref()
                    .map(|t| (t.max, 100.0 * t.max / q.peak(), t.slip)),
                q.identifiability
            );
        }
    }
    for n in &fit.notes {
        eprintln!("  note: {n}");
    }
    let fmt = |v: [f64; 4]| {
        format!(
            "Fx {:.4} Fy {:.4} Mz {:.4} Mx {:.4}",
            v[0], v[1], v[2], v[3]
        )
    };
    eprintln!("  envelope % of peak: cornering   {}", fmt(e.cornering));
    eprintln!("  envelope % of peak: drive/brake {}", fmt(e.drive_brake));
    eprintln!("  envelope % of peak: combined    {}", fmt(e.combined));
    eprintln!("  envelope % of peak: all         {}", fmt(e.all));
}

/// A variant of the reference tire: every fitted coefficient scaled by `1 + 0.15 u`, `u` uniform
/// in [-1, 1] (seeded), shifts and camber terms included.
fn perturbed(seed: u64) -> Coefs<f64> {
    let mut c = fsae_demo();
    let mut rng = crate::numerics::random::SplitMix64::new(seed);
    for family in Family::FIT_ORDER {
        if family == Family::My || family == Family::Mx {
            continue;
        }
        for coef in family.coefficients() {
            c[*coef] *= 1.0 + 0.15 * (2.0 * rng.uniform() - 1.0);
        }
    }
    c
}

/// The reference tire with its lateral behaviour mirrored in sign conventions: `PDY1 > 0` and
/// `PKY1 > 0` (a tire whose data would come out with a positive cornering stiffness).
fn mirrored_lateral() -> Coefs<f64> {
    let mut c = fsae_demo();
    c[PDY1] = -c[PDY1];
    c[PKY1] = -c[PKY1];
    c
}

fn truths() -> Vec<(&'static str, Coefs<f64>)> {
    vec![
        ("fsae-demo", fsae_demo()),
        ("perturbed-1", perturbed(11)),
        ("perturbed-2", perturbed(29)),
        ("mirrored-lateral", mirrored_lateral()),
    ]
}

/// Issue 5 "Done when" 1: noise-free, lag-free sweeps: every fitted model reproduces its truth
/// within 0.1 % of peak (RMS over the tested envelope) for Fx, Fy and Mz.
#[test]
fn fit_noise_free_reproduces_truth_within_0_1_percent() {
    for (name, truth) in truths() {
        let input = ttc_round(&truth, &RoundSpec::ideal());
        let fit = fit(&input, &FitConfig::default()).expect("fit");
        let e = envelope_errors(&truth, &fit.model);
        report(name, &fit, &e);
        assert_eq!(fit.use_mode, 4, "{name}");
        for (k, channel) in ["Fx", "Fy", "Mz"].iter().enumerate() {
            assert!(
                e.all[k] <= 0.1,
                "{name}: {channel} RMS error {:.4} % of peak > 0.1 %",
                e.all[k]
            );
        }
    }
}

/// Issue 5 "Done when" 2 (on generated data until the virtual machine lands): ~1 % of peak
/// Gaussian noise, spikes, input noise and a first-order lag (sigma 0.2..0.45 m at 11 m/s) on
/// up/down sweeps: RMS force error against the truth <= 2 % of peak for Fx and Fy, <= 5 % for
/// Mz, fitted without relaxation lengths (up/down averaging only) and with them (de-lagging).
#[test]
fn fit_noisy_lagged_within_2_percent_forces_5_percent_mz() {
    for (name, truth) in truths() {
        for delag in [false, true] {
            let mut input = ttc_round(&truth, &RoundSpec::realistic(7));
            if delag {
                input.context.relaxation = Some(truth_relaxation());
            }
            let fit = fit(&input, &FitConfig::default()).expect("fit");
            let e = envelope_errors(&truth, &fit.model);
            let label = format!("{name} noisy, de-lag {delag}");
            report(&label, &fit, &e);
            for (k, (channel, limit)) in [("Fx", 2.0), ("Fy", 2.0), ("Mz", 5.0)].iter().enumerate()
            {
                assert!(
                    e.all[k] <= *limit,
                    "{label}: {channel} RMS error {:.3} % of peak > {limit} %",
                    e.all[k]
                );
            }
            // Issue 18: out of sample (5-fold by sweep) within 20 % of in sample, every family.
            for f in &fit.families {
                let Some(q) = &f.quality else { continue };
                let ratio = q.oos_ratio();
                assert!(
                    ratio <= 1.2 && !q.oos_flagged(1.2),
                    "{label}: {} out-of-sample RMSE {:.4} is {ratio:.3}x in-sample {:.4}",
                    f.family.as_str(),
                    q.out_of_sample.as_ref().map_or(f64::NAN, |o| o.rmse),
                    q.rmse
                );
            }
        }
    }
}

/// Issue 5 physical rules on every fitted model, over the tested envelope: shape factors
/// `C > 0`, curvature factors `E <= 1` before clamping, `Gxa` and `Gyk` positive (no sign flip),
/// `|RHX1|` small.
#[test]
fn fitted_models_pass_the_physical_rules() {
    use crate::tire_model::pac2002::{gxa, load, weighting};
    for (name, truth) in truths() {
        let input = ttc_round(&truth, &RoundSpec::realistic(3));
        let fit = fit(&input, &FitConfig::default()).expect("fit");
        let c = &fit.model.coefs;
        for coef in [PCX1, PCY1, QCZ1, RCX1, RCY1] {
            assert!(c[coef] > 0.0, "{name}: {} = {}", coef.name(), c[coef]);
        }
        assert!(c[RHX1].abs() <= 0.02, "{name}: RHX1 = {}", c[RHX1]);
        let fz0 = c[FNOMIN];
        let mut worst_e = f64::NEG_INFINITY;
        let mut worst_g = f64::INFINITY;
        for i in 0..=10 {
            let fz = c[FZMIN] + (c[FZMAX] - c[FZMIN]) * i as f64 / 10.0;
            let dfz = (fz - fz0) / fz0;
            for j in 0..=4 {
                let g = c[CAMMIN] + (c[CAMMAX] - c[CAMMIN]) * j as f64 / 4.0;
                for s in [-1.0, 1.0] {
                    let ey = (c[PEY1] + c[PEY2] * dfz) * (1.0 - (c[PEY3] + c[PEY4] * g) * s);
                    let ex = (c[PEX1] + c[PEX2] * dfz + c[PEX3] * dfz * dfz) * (1.0 - c[PEX4] * s);
                    let et = (c[QEZ1] + c[QEZ2] * dfz + c[QEZ3] * dfz * dfz)
                        * (1.0 + (c[QEZ4] + c[QEZ5] * g) * s);
                    worst_e = worst_e.max(ey).max(ex).max(et);
                }
                worst_e = worst_e
                    .max(c[REX1] + c[REX2] * dfz)
                    .max(c[REY1] + c[REY2] * dfz);
                for a in 0..=12 {
                    let alpha = c[ALPMIN] + (c[ALPMAX] - c[ALPMIN]) * a as f64 / 12.0;
                    for k in 0..=8 {
                        let kappa = c[KPUMIN] + (c[KPUMAX] - c[KPUMIN]) * k as f64 / 8.0;
                        let input = crate::tire_model::SlipInput {
                            fz_n: fz,
                            kappa,
                            alpha_rad: alpha,
                            gamma_rad: g,
                            vx_mps: 11.176,
                        };
                        let l = load(c, &input, crate::tire_model::Mode::Raw);
                        let byk = c[RBY1] * (c[RBY2] * (alpha - c[RBY3])).cos_atan();
                        let eyk = c[REY1] + c[REY2] * dfz;
                        let shyk = c[RHY1] + c[RHY2] * dfz;
                        let gyk = weighting(byk, c[RCY1], eyk, kappa + shyk)
                            / weighting(byk, c[RCY1], eyk, shyk);
                        worst_g = worst_g.min(gxa(c, &l)).min(gyk);
                    }
                }
            }
        }
        eprintln!("{name}: largest E {worst_e:.4}, smallest G {worst_g:.4}");
        assert!(worst_e <= 1.0 + 1e-9, "{name}: E = {worst_e} > 1");
        assert!(worst_g > 0.0, "{name}: G = {worst_g} <= 0");
        // The `.tir` lint (tire_model::tir::lint) finds no error the truth itself does not have
        // (the mirrored-lateral truth has Ky_alpha > 0, which the lint calls SAE-signed).
        let lint_codes = |coefs: &Coefs<f64>, use_mode: i64| {
            let mut file = crate::tire_model::tir::TirFile::from_coefs(coefs.clone());
            file.use_mode = Some(use_mode);
            let report = crate::tire_model::tir::lint::lint(&file);
            for f in &report.findings {
                eprintln!("{name}: lint {f}");
            }
            report
                .findings
                .iter()
                .filter(|f| f.severity == crate::tire_model::tir::lint::Severity::Error)
                .map(|f| f.code)
                .collect::<Vec<_>>()
        };
        let truth_errors = lint_codes(&truth, 4);
        let fitted_errors = lint_codes(c, i64::from(fit.use_mode));
        for code in &fitted_errors {
            assert!(
                truth_errors.contains(code),
                "{name}: lint error {code} on the fitted model"
            );
        }
    }
}

/// Same input, bit-identical coefficients, quality and reports (except wall-clock seconds).
#[test]
fn fit_is_deterministic() {
    let input = ttc_round(&perturbed(5), &RoundSpec::realistic(9));
    let mut a = fit(&input, &FitConfig::default()).expect("fit");
    let mut b = fit(&input, &FitConfig::default()).expect("fit");
    for r in [&mut a, &mut b] {
        r.seconds = 0.0;
        for f in &mut r.families {
            if let Some(q) = &mut f.quality {
                q.seconds = 0.0;
            }
        }
    }
    assert!(a == b, "two fits of the same input differ");
    for (x, y) in a.model.coefs.0.iter().zip(&b.model.coefs.0) {
        assert_eq!(x.to_bits(), y.to_bits());
    }
    // The order of the sweeps in the input does not matter either.
    let mut reversed = input.clone();
    reversed.sweeps.reverse();
    let c = fit(&reversed, &FitConfig::default()).expect("fit");
    for (x, y) in a.model.coefs.0.iter().zip(&c.model.coefs.0) {
        assert_eq!(x.to_bits(), y.to_bits());
    }
}

/// Issue 5 speed target: a full fit (all families) of one tire and pressure under 2 s on one
/// core, measured as the CPU time of the fitting thread in the test profile (the core crate is
/// built at opt-level 3 in every profile). `cargo bench -p tirebase-core --bench fit_pac2002`
/// gives the release wall-clock figure. A timing, not a check of behaviour: it runs on request
/// (`--ignored`), since a loaded or slower machine fails it with correct code (the speed target
/// lives in that bench).
#[test]
#[ignore = "timing: cargo test -p tirebase-core --lib full_fit_takes -- --ignored --nocapture"]
fn full_fit_takes_under_two_seconds() {
    let input = ttc_round(&fsae_demo(), &RoundSpec::realistic(13));
    let samples: usize = input.sweeps.iter().map(|s| s.samples.len()).sum();
    let mut best = (f64::INFINITY, f64::INFINITY, 0);
    for _ in 0..2 {
        let cpu0 = thread_cpu_seconds();
        let t = std::time::Instant::now();
        let fit = fit(&input, &FitConfig::default()).expect("fit");
        let wall = t.elapsed().as_secs_f64();
        let cpu = match (cpu0, thread_cpu_seconds()) {
            (Some(a), Some(b)) => b - a,
            _ => wall,
        };
        if cpu < best.0 {
            best = (cpu, wall, fit.evaluations);
        }
    }
    eprintln!(
        "full fit: {:.3} s CPU ({:.3} s wall), {} solver evaluations, {} sweeps, {samples} samples",
        best.0,
        best.1,
        best.2,
        input.sweeps.len()
    );
    assert!(best.0 < 2.0, "full fit took {:.3} s of CPU", best.0);
}

/// Families without data are left out and USE_MODE says so; a QC-flagged sweep is skipped.
#[test]
fn cornering_only_round_gives_use_mode_2() {
    let mut input = ttc_round(&fsae_demo(), &RoundSpec::ideal());
    input.sweeps.retain(|s| s.kind == SweepKind::Cornering);
    input.sweeps[3].qc_ok = false;
    let fit = fit(&input, &FitConfig::default()).expect("fit");
    assert_eq!(fit.use_mode, 2);
    assert_eq!(fit.skipped_sweeps.len(), 1);
    let status = |f: Family| {
        fit.families
            .iter()
            .find(|x| x.family == f)
            .map(|x| x.status.as_str())
            .unwrap()
    };
    assert_eq!(status(Family::Fy0), "fitted");
    assert_eq!(status(Family::Mz0), "fitted");
    assert_eq!(status(Family::Fx0), "no_data");
    assert_eq!(status(Family::Fx), "no_data");
    assert_eq!(status(Family::Mz), "no_data");
    assert_eq!(status(Family::Mx), "fitted");
    assert_eq!(status(Family::My), "placeholder");
    assert_eq!(fit.model.coefs[PDX1], 0.0);
    assert!((fit.model.coefs[FNOMIN] - 667.0).abs() < 1e-9);
    assert!((fit.model.coefs[LONGVL] - super::synthetic::SPEED_MPS).abs() < 1e-12);
}

/// Bad input is an error naming the tire.
#[test]
fn bad_input_is_an_error() {
    let mut input = ttc_round(&fsae_demo(), &RoundSpec::ideal());
    input.context.test_speed_mps = 0.0;
    let err = fit(&input, &FitConfig::default()).unwrap_err();
    assert!(err.to_string().contains("synthetic"), "{err}");
    let mut input = ttc_round(&fsae_demo(), &RoundSpec::ideal());
    input.sweeps.clear();
    assert!(matches!(
        fit(&input, &FitConfig::default()),
        Err(Pac2002Error::NoUsableSweeps { .. })
    ));
    let mut input = ttc_round(&fsae_demo(), &RoundSpec::ideal());
    input.context.unloaded_radius_m = None;
    assert!(matches!(
        fit(&input, &FitConfig::default()),
        Err(Pac2002Error::NoUnloadedRadius { .. })
    ));
}

/// Issue 18: a degenerate residual torque (the QBZ10 = 3.1e5, QDZ6 = -218) sits between
/// the fitted points, where the in-sample RMSE cannot see it; the trend deviation on the dense
/// grid between the points does.
#[test]
fn trend_deviation_sees_a_spike_between_the_points() {
    let input = ttc_round(&fsae_demo(), &RoundSpec::realistic(5));
    let fit = fit(&input, &FitConfig::default()).expect("fit");
    let quality = |f: &Pac2002Fit, family: Family| {
        f.families
            .iter()
            .find(|x| x.family == family)
            .and_then(|x| x.quality.clone())
            .unwrap()
    };
    let good = quality(&fit, Family::Mz0);
    let t = good.trend.clone().unwrap();
    assert!(t.max < 0.05 * good.peak(), "{t:?}, peak {}", good.peak());
    let sweeps = prepare_for_test(&input);
    let refs: Vec<&super::collapse::CollapsedSweep> = sweeps
        .iter()
        .filter(|s| s.kind == SweepKind::Cornering)
        .collect();
    let mut spiky = fit.model.coefs.clone();
    spiky[QBZ10] = 3.1e5;
    spiky[QDZ6] = -218.0;
    let bad = super::quality::trend_deviation(Family::Mz0, &refs, &spiky).unwrap();
    eprintln!("good {t:?}\nspiky {bad:?}");
    assert!(bad.max > 20.0 * t.max.max(1.0), "{bad:?}");
}

fn prepare_for_test(input: &FitInput) -> Vec<super::collapse::CollapsedSweep> {
    use super::collapse::{CollapseSettings, collapse};
    let cfg = FitConfig::default();
    input
        .sweeps
        .iter()
        .map(|s| {
            collapse(
                s,
                &CollapseSettings {
                    bin: if s.kind == SweepKind::Cornering {
                        cfg.alpha_bin_rad
                    } else {
                        cfg.kappa_bin
                    },
                    despike_sigmas: cfg.despike_sigmas,
                    relaxation: None,
                },
            )
        })
        .collect()
}

/// Issue 18: a fit that rests on one sweep is flagged out of sample. Only one of the
/// cornering sweeps at zero inclination goes past the friction peak; the others stop at 2.5 deg.
/// In sample the model is fine; the fold that holds the wide sweep out cannot determine the
/// peak.
#[test]
fn fit_resting_on_one_sweep_is_flagged_out_of_sample() {
    let mut input = ttc_round(&perturbed(3), &RoundSpec::realistic(21));
    input
        .sweeps
        .retain(|s| s.kind == SweepKind::Cornering && s.nominal.gamma_rad.abs() < 1e-3);
    let wide = input.sweeps.len() / 2;
    for (i, s) in input.sweeps.iter_mut().enumerate() {
        if i != wide {
            s.samples
                .retain(|p| p.alpha_rad.abs() < 2.5_f64.to_radians());
        }
    }
    let fit = fit(&input, &FitConfig::default()).expect("fit");
    let q = fit
        .families
        .iter()
        .find(|f| f.family == Family::Fy0)
        .and_then(|f| f.quality.clone())
        .unwrap();
    eprintln!(
        "{} sweeps: in sample {:.2} N {:?}, out of sample {:?}",
        input.sweeps.len(),
        q.rmse,
        q.identifiability,
        q.out_of_sample
    );
    assert!(q.oos_flagged(1.2), "{q:?}");
    // The same round with every sweep wide is not flagged.
    let full = ttc_round(&perturbed(3), &RoundSpec::realistic(21));
    let mut all = full.clone();
    all.sweeps
        .retain(|s| s.kind == SweepKind::Cornering && s.nominal.gamma_rad.abs() < 1e-3);
    let fit = super::fit(&all, &FitConfig::default()).expect("fit");
    let q = fit.families[0].quality.clone().unwrap();
    assert!(!q.oos_flagged(1.2), "{q:?}");
}

/// Issue 18: no coefficient is left on a bound without a row saying why. A tire whose data
/// say mu_y = 5 (beyond the fit's |mu| <= 4, the lint's limit) leaves PDY1 on its bound; the
/// coefficient row says which bound and what it means, and every held coefficient says why.
#[test]
fn a_coefficient_on_a_bound_says_why() {
    let mut truth = fsae_demo();
    truth[PDY1] = -5.0;
    let input = ttc_round(&truth, &RoundSpec::realistic(7));
    let fit = fit(&input, &FitConfig::default()).expect("fit");
    let on_bound: Vec<&FittedCoefficient> =
        fit.coefficients.iter().filter(|c| c.at_bound).collect();
    for c in &on_bound {
        eprintln!("{}: {} ({:?})", c.coef.name(), c.value, c.note);
    }
    let pdy1 = fit.coefficients.iter().find(|c| c.coef == PDY1).unwrap();
    assert!(pdy1.at_bound, "{pdy1:?}");
    assert_eq!(pdy1.value, -4.0);
    assert!(pdy1.std_error.is_none(), "{pdy1:?}");
    let note = pdy1.note.as_deref().unwrap_or_default();
    assert!(
        note.starts_with("on its lower bound -4 ") && note.contains("not physical"),
        "{note}"
    );
    for c in &fit.coefficients {
        if c.at_bound {
            assert!(
                c.note.as_deref().is_some_and(|n| n.starts_with("on its ")),
                "{c:?}"
            );
        }
        if matches!(c.origin, CoefficientOrigin::Fixed { .. }) {
            assert!(
                c.note.as_deref().is_some_and(|n| n.starts_with("held: ")),
                "{c:?}"
            );
        }
    }
}

/// A round whose slip-ratio sweeps carry ten times the aligning-moment noise of its cornering
/// sweeps (a real rig's drive/brake runs, whose driveline vibration its Mz picks up): the joint
/// `Mz` step weighs those sweeps by their kind's noise, so the pure Mz it refits stays within
/// 20 % of its error when every sweep is equally noisy (0.82x measured; weighed alike, 1.44x).
#[test]
fn noisy_slip_ratio_sweeps_do_not_spoil_pure_mz() {
    let truth = fsae_demo();
    let clean = ttc_round(&truth, &RoundSpec::realistic(7));
    let mut noisy = clean.clone();
    let mut rng = crate::numerics::random::SplitMix64::new(11);
    for sweep in noisy
        .sweeps
        .iter_mut()
        .filter(|s| s.kind != SweepKind::Cornering)
    {
        let peak = sweep
            .samples
            .iter()
            .map(|s| s.mz_nm.abs())
            .fold(0.0, f64::max);
        for s in &mut sweep.samples {
            s.mz_nm += 0.1 * peak * rng.gaussian();
        }
    }
    let cornering_mz = |input: &FitInput| {
        let fit = fit(input, &FitConfig::default()).expect("fit");
        envelope_errors(&truth, &fit.model).cornering[2]
    };
    let (base, with_noise) = (cornering_mz(&clean), cornering_mz(&noisy));
    eprintln!("cornering Mz error, % of peak: {base:.4} equal noise, {with_noise:.4} noisy slip");
    assert!(
        with_noise <= 1.2 * base,
        "pure Mz {with_noise:.4} % of peak with noisy slip-ratio sweeps, {base:.4} % without"
    );
}
