//! Quantitative tests of the virtual test machine across modules: the physics a fitter will see.
//!
//! In: generated runs (in memory). Out: pass/fail with the measured figures printed. Deliberately
//! not here: the file system and the CLI (see `tests/synth.rs`).

use super::machine::{Realism, RunSamples, simulate};
use super::noise::Rng;
use super::round::{RoundPlan, SynthConfig, plan_round};
use super::schedule::{Program, RunKind, SegmentKind};

fn plan() -> RoundPlan {
    plan_round(&SynthConfig::default()).unwrap()
}

/// Simulate run `index` of the demo plan with `realism`.
fn run_of(plan: &RoundPlan, index: usize, realism: &Realism) -> (Program, RunSamples) {
    let spec = &plan.runs[index];
    let program = plan.program(spec);
    let truth = plan.truth(spec.combo, spec.pressure_psi);
    let mut rng = Rng::for_stream(1, &[index as u64]);
    let s = simulate(
        &program,
        truth,
        &plan.thermal[spec.combo],
        realism,
        spec.style.rate_hz(),
        &mut rng,
    );
    (program, s)
}

/// Per half cycle of `seg` (a run of samples with one slip-angle sign): the sample of peak
/// grip `|Fy / Fz|` and the half cycle's length.
fn half_cycle_peaks(seg: &[usize], s: &RunSamples) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut k = 0;
    while k < seg.len() {
        let i0 = k;
        let sign = s.alpha_rad[seg[k]].signum();
        while k < seg.len() && s.alpha_rad[seg[k]].signum() == sign {
            k += 1;
        }
        let best = seg[i0..k]
            .iter()
            .copied()
            .max_by(|&a, &b| {
                (s.fy_n[a] / s.fz_n[a])
                    .abs()
                    .total_cmp(&(s.fy_n[b] / s.fz_n[b]).abs())
            })
            .unwrap();
        out.push((best, k - i0));
    }
    out
}

fn samples_of(program: &Program, s: &RunSamples, kind: SegmentKind) -> Vec<Vec<usize>> {
    program
        .segments
        .iter()
        .filter(|g| g.kind == kind)
        .map(|g| {
            (0..s.et_s.len())
                .filter(|&i| {
                    let p = s.piece[i] as usize;
                    p >= g.first_piece && p < g.end_piece
                })
                .collect()
        })
        .collect()
}

#[test]
#[ignore = "calibration printout"]
fn calibration_printout() {
    let plan = plan();
    for index in 0..plan.runs.len() {
        let spec = &plan.runs[index];
        let (program, s) = run_of(&plan, index, plan.realism());
        println!(
            "run {} {:?} {} psi, {} samples",
            spec.run,
            spec.kind,
            spec.pressure_psi,
            s.et_s.len()
        );
        let mut stats = Vec::new();
        for (kind, label) in [
            (SegmentKind::ColdToWarm, "c2w"),
            (SegmentKind::Cornering, "matrix"),
            (SegmentKind::DriveBrake, "db"),
            (SegmentKind::Combined, "comb"),
        ] {
            for seg in samples_of(&program, &s, kind) {
                let t: Vec<f64> = seg.iter().map(|&i| s.surface_true_c[i]).collect();
                let g: Vec<f64> = seg.iter().map(|&i| s.grip_scale[i]).collect();
                let min = t.iter().cloned().fold(f64::INFINITY, f64::min);
                let max = t.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                let gmin = g.iter().cloned().fold(f64::INFINITY, f64::min);
                let gmax = g.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                let fz = s.fz_n[seg[seg.len() / 2]];
                if std::env::var("CAL_VERBOSE").is_ok() || label == "c2w" {
                    println!(
                        "  {label:6} fz {fz:6.0} T {min:5.1}..{max:5.1} grip {gmin:.3}..{gmax:.3}"
                    );
                }
                stats.push((label, fz, min, max, gmin, gmax));
            }
        }
        for label in ["matrix", "db", "comb"] {
            let v: Vec<_> = stats.iter().filter(|x| x.0 == label).collect();
            if v.is_empty() {
                continue;
            }
            let tmin = v.iter().map(|x| x.2).fold(f64::INFINITY, f64::min);
            let tmax = v.iter().map(|x| x.3).fold(f64::NEG_INFINITY, f64::max);
            let gmin = v.iter().map(|x| x.4).fold(f64::INFINITY, f64::min);
            let gmax = v.iter().map(|x| x.5).fold(f64::NEG_INFINITY, f64::max);
            let heavy: Vec<_> = v
                .iter()
                .filter(|x| x.1 > 1300.0)
                .map(|x| format!("{:.0}-{:.0}", x.2, x.3))
                .collect();
            let light: Vec<_> = v
                .iter()
                .filter(|x| x.1 < 300.0)
                .map(|x| format!("{:.0}-{:.0}", x.2, x.3))
                .collect();
            println!(
                "  {label}: T {tmin:.1}..{tmax:.1} grip {gmin:.3}..{gmax:.3} heavy {heavy:?} light {light:?}"
            );
        }
        if spec.kind == RunKind::Cornering {
            // Cold-to-warm per half cycle peaks.
            for seg in samples_of(&program, &s, SegmentKind::ColdToWarm) {
                let mut line = String::from("  c2w peaks (T, mu):");
                for (best, _) in half_cycle_peaks(&seg, &s) {
                    line += &format!(
                        " ({:.0},{:.2})",
                        s.surface_true_c[best],
                        (s.fy_n[best] / s.fz_n[best]).abs()
                    );
                }
                println!("{line}");
            }
        }
    }
}

use super::round::{RealismConfig, Size, render_run};
use super::tires::{CATALOGUE, TruthModel};
use crate::tire_model::{Mode, SlipInput};

fn realism_with(noise: f64, lag: bool, heat: bool, plan: &RoundPlan) -> Realism {
    Realism {
        noise_scale: noise,
        lag,
        heat,
        ..*plan.realism()
    }
}

fn first_run(plan: &RoundPlan, combo: usize, kind: RunKind) -> usize {
    plan.runs
        .iter()
        .position(|r| r.combo == combo && r.kind == kind)
        .unwrap()
}

/// Pooled RMS over segments of (simulated - truth)/segment peak, for Fx and Fy.
fn grip_error_vs_truth(
    truth: &TruthModel,
    program: &Program,
    s: &RunSamples,
    kinds: &[SegmentKind],
) -> (f64, f64) {
    let (mut sx, mut nx, mut sy, mut ny) = (0.0, 0usize, 0.0, 0usize);
    for kind in kinds {
        for seg in samples_of(program, s, *kind) {
            let t: Vec<(f64, f64)> = seg
                .iter()
                .map(|&i| {
                    let e = truth.model.eval(
                        &SlipInput {
                            fz_n: s.fz_n[i],
                            kappa: s.sl[i],
                            alpha_rad: s.alpha_rad[i],
                            gamma_rad: s.gamma_rad[i],
                            vx_mps: s.v_mps[i],
                        },
                        Mode::Limits,
                    );
                    (e.fx_n, e.fy_n)
                })
                .collect();
            let px = t.iter().map(|x| x.0.abs()).fold(0.0, f64::max);
            let py = t.iter().map(|x| x.1.abs()).fold(0.0, f64::max);
            for (k, &i) in seg.iter().enumerate() {
                if px > 100.0 {
                    sx += ((s.fx_n[i] - t[k].0) / px).powi(2);
                    nx += 1;
                }
                if py > 100.0 {
                    sy += ((s.fy_n[i] - t[k].1) / py).powi(2);
                    ny += 1;
                }
            }
        }
    }
    (
        (sx / nx.max(1) as f64).sqrt(),
        (sy / ny.max(1) as f64).sqrt(),
    )
}

/// How far the tread temperatures of the fitted sweeps push grip away from the truth `.tir`
/// (noise and lag off, heat on): the fit stage's 2 % budget must not be eaten by heat.
#[test]
fn heat_moves_fitted_sweeps_less_than_1_5_pct_from_truth() {
    let plan = plan();
    for combo in 0..plan.combos.len() {
        for (kind, kinds) in [
            (RunKind::Cornering, vec![SegmentKind::Cornering]),
            (
                RunKind::DriveBrake,
                vec![SegmentKind::DriveBrake, SegmentKind::Combined],
            ),
        ] {
            let index = first_run(&plan, combo, kind);
            let spec = &plan.runs[index];
            let (program, s) = run_of(&plan, index, &realism_with(0.0, false, true, &plan));
            let truth = plan.truth(spec.combo, spec.pressure_psi);
            let (ex, ey) = grip_error_vs_truth(truth, &program, &s, &kinds);
            let th = &plan.thermal[combo];
            println!(
                "{} {:?}: RMS (heat - truth)/peak Fx {:.2} %, Fy {:.2} % (t_peak {:.1}, t_ref {:.1})",
                CATALOGUE[plan.combos[combo].tire_index].name,
                kind,
                100.0 * ex,
                100.0 * ey,
                th.t_peak_c,
                th.t_matrix_ref_c
            );
            let e = if kind == RunKind::Cornering { ey } else { ex };
            assert!(e < 0.015, "{kind:?}: {e}");
        }
    }
}

/// Up and down branches of a lagged sweep differ at alpha = 0 by `2 K alpha_dot sigma / V`, with
/// the truth sigma_alpha: recover sigma from the generated sweep within 2 %.
#[test]
fn fy_hysteresis_gives_back_the_truth_relaxation_length() {
    let plan = plan();
    let index = first_run(&plan, 0, RunKind::Cornering);
    let spec = &plan.runs[index];
    let truth = plan.truth(spec.combo, spec.pressure_psi);
    let (program, s) = run_of(&plan, index, &realism_with(0.0, true, false, &plan));
    let mut checked = 0;
    for (g, seg) in program
        .segments
        .iter()
        .filter(|g| g.kind == SegmentKind::Cornering)
        .zip(samples_of(&program, &s, SegmentKind::Cornering))
    {
        if g.nominal.ia_deg != Some(0.0) {
            continue;
        }
        // Fy at alpha = 0 on the rising and on the falling branch (linear interpolation).
        let (mut up, mut down) = (None, None);
        for w in seg.windows(2) {
            let (a0, a1) = (s.alpha_rad[w[0]], s.alpha_rad[w[1]]);
            if a0 < 0.0 && a1 >= 0.0 || a0 > 0.0 && a1 <= 0.0 {
                let f = a0 / (a0 - a1);
                let fy = s.fy_n[w[0]] + f * (s.fy_n[w[1]] - s.fy_n[w[0]]);
                if a1 > a0 {
                    up = Some(fy);
                } else {
                    down = Some(fy);
                }
            }
        }
        let (Some(up), Some(down)) = (up, down) else {
            continue;
        };
        let fz = g.nominal.fz_n.unwrap();
        let e = truth.model.eval(
            &SlipInput {
                fz_n: fz,
                vx_mps: s.v_mps[seg[0]],
                ..Default::default()
            },
            Mode::Limits,
        );
        let rate = plan.config.schedule.sweep_rate_deg_s.to_radians();
        let v = s.v_mps[seg[0]];
        let sigma_est = (up - down).abs() / (2.0 * e.kya_n_per_rad.abs() * rate) * v;
        let (_, sigma) = truth.model.relaxation_lengths(fz, 0.0);
        let rel = sigma_est / sigma - 1.0;
        println!(
            "Fz {fz:.0} N: sigma truth {sigma:.4} m, from hysteresis {sigma_est:.4} m ({:+.2} %)",
            100.0 * rel
        );
        assert!(rel.abs() < 0.02, "Fz {fz}: {rel}");
        checked += 1;
    }
    assert_eq!(checked, 5);
}

/// Cold-to-warm (12 sweeps, round-9 plan): peak |FY/FZ| per half sweep against the centre tread
/// temperature rises by more than 15 %, peaks within 4 degC of the truth t_peak, then falls.
#[test]
fn cold_to_warm_peak_mu_rises_then_falls() {
    let plan = plan();
    let combo = 1;
    assert_eq!(
        CATALOGUE[plan.combos[combo].tire_index].plan,
        super::tires::TestPlan::Round9
    );
    let index = first_run(&plan, combo, RunKind::Cornering);
    let (program, s) = run_of(&plan, index, plan.realism());
    let seg = &samples_of(&program, &s, SegmentKind::ColdToWarm)[0];
    let peaks: Vec<(f64, f64)> = half_cycle_peaks(seg, &s)
        .into_iter()
        .filter(|&(_, len)| len > 20)
        .map(|(best, _)| (s.tread_centre_c[best], (s.fy_n[best] / s.fz_n[best]).abs()))
        .collect();
    let (imax, &(t_at_max, mu_max)) = peaks
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.1.total_cmp(&b.1.1))
        .unwrap();
    let first = peaks[0].1;
    let last = peaks.last().unwrap().1;
    let th = &plan.thermal[combo];
    println!("peaks (T, mu): {peaks:.2?}");
    println!(
        "rise {:.1} %, max at {t_at_max:.1} degC (truth t_peak {:.1}), fall after max {:.1} %",
        100.0 * (mu_max / first - 1.0),
        th.t_peak_c,
        100.0 * (1.0 - last / mu_max)
    );
    assert!(mu_max / first - 1.0 > 0.15);
    assert!((t_at_max - th.t_peak_c).abs() < 4.0);
    assert!(imax + 2 < peaks.len() && last < mu_max * 0.99);
}

/// Spring-rate holds: RL against FZ is a line with the truth slope (stiffness within 1 %) and
/// intercept (unloaded radius within 0.2 mm), static and dynamic, with default noise.
#[test]
fn spring_rate_holds_give_the_truth_stiffness() {
    let plan = plan();
    let index = first_run(&plan, 0, RunKind::Cornering);
    let spec = &plan.runs[index];
    let truth = plan.truth(spec.combo, spec.pressure_psi);
    let (program, s) = run_of(&plan, index, plan.realism());
    for (kind, cz, r0) in [
        (
            SegmentKind::SpringRateStatic,
            truth.vertical.cz_static_n_per_m,
            truth.vertical.r0_static_m,
        ),
        (
            SegmentKind::SpringRateDynamic,
            truth.vertical.cz_dynamic_n_per_m,
            truth.vertical.r0_dynamic_m,
        ),
    ] {
        for seg in samples_of(&program, &s, kind) {
            let n = seg.len() as f64;
            let (mx, my) = seg
                .iter()
                .fold((0.0, 0.0), |a, &i| (a.0 + s.fz_n[i], a.1 + s.rl_m[i]));
            let (mx, my) = (mx / n, my / n);
            let (sxy, sxx) = seg.iter().fold((0.0, 0.0), |a, &i| {
                (
                    a.0 + (s.fz_n[i] - mx) * (s.rl_m[i] - my),
                    a.1 + (s.fz_n[i] - mx).powi(2),
                )
            });
            let slope = sxy / sxx;
            let stiffness = -1.0 / slope;
            let intercept = my - slope * mx;
            assert!(
                (stiffness / cz - 1.0).abs() < 0.01,
                "{kind:?}: {stiffness} vs {cz}"
            );
            assert!(
                (intercept - r0).abs() < 0.0002,
                "{kind:?}: {intercept} vs {r0}"
            );
        }
    }
}

/// Same seed -> same bytes (each run's stream is its own).
#[test]
fn same_seed_same_bytes_different_seed_different_bytes() {
    let cfg = SynthConfig::default();
    let a = plan_round(&cfg).unwrap();
    let b = plan_round(&cfg).unwrap();
    let c = plan_round(&SynthConfig { seed: 7, ..cfg }).unwrap();
    for i in [0, 2, 5] {
        let x = render_run(&a, i).unwrap();
        assert_eq!(x, render_run(&b, i).unwrap());
        assert_ne!(x.file.bytes, render_run(&c, i).unwrap().file.bytes);
    }
}

/// Every rendered file reads back with the TTC readers: 3-line layout, SI values matching the
/// simulation, FZ negative in the file, the `.mat` variable set complete.
#[test]
fn every_demo_file_reads_back() {
    let plan = plan();
    for i in 0..plan.runs.len() {
        let out = render_run(&plan, i).unwrap();
        let name = &out.summary.spec.file;
        let table = if name.ends_with(".dat") {
            let text = std::str::from_utf8(&out.file.bytes).unwrap();
            let lines: Vec<&str> = text.lines().take(4).collect();
            assert!(
                lines[0].starts_with("TIRF Data File: Project 2410; Run "),
                "{name}"
            );
            let n_names = lines[1].split('\t').count();
            assert_eq!(lines[2].split('\t').count(), n_names, "{name}");
            assert_eq!(lines[3].split('\t').count(), n_names, "{name}");
            let fz_col = lines[1].split('\t').position(|c| c == "FZ").unwrap();
            let fz_neg = text
                .lines()
                .skip(3)
                .filter(|l| l.split('\t').nth(fz_col).unwrap().starts_with('-'))
                .count();
            assert!(
                fz_neg as f64 > 0.99 * out.summary.rows as f64,
                "{name}: FZ not negative"
            );
            crate::ttc::read_dat(&out.file.bytes, name).unwrap()
        } else {
            let t = crate::ttc::read_mat(&out.file.bytes, name).unwrap();
            assert_eq!(
                t.meta.testid.as_deref(),
                Some(out.summary.spec.kind.test_id())
            );
            assert!(t.meta.tireid.as_deref().unwrap().contains(" inch rim"));
            assert!(t.meta.source.is_some());
            t
        };
        assert_eq!(table.et_s.len(), out.summary.rows, "{name}");
        assert_eq!(table.meta.run, Some(out.summary.spec.run), "{name}");
        let fz_mean = table.tire.fz_n.iter().sum::<f64>() / table.et_s.len() as f64;
        assert!(
            (300.0..1500.0).contains(&fz_mean),
            "{name}: mean Fz {fz_mean}"
        );
        assert!(
            table.meta.warnings.is_empty(),
            "{name}: {:?}",
            table.meta.warnings
        );
    }
}

/// With defects on, every kind is injected once, recorded, and visible in the file.
#[test]
fn every_defect_kind_is_injected_and_recorded() {
    use super::defects::DefectKind;
    let plan = plan_round(&SynthConfig {
        defects: true,
        ..SynthConfig::default()
    })
    .unwrap();
    let mut seen = Vec::new();
    for i in 0..plan.runs.len() {
        if plan.runs[i].defects.is_empty() {
            continue;
        }
        let out = render_run(&plan, i).unwrap();
        let text = String::from_utf8(out.file.bytes.clone()).unwrap();
        let rows: Vec<&str> = text.lines().skip(3).collect();
        let cols: Vec<&str> = text.lines().nth(1).unwrap().split('\t').collect();
        let col = |name: &str| cols.iter().position(|c| *c == name).unwrap();
        let cell = |r: usize, c: usize| -> f64 {
            rows[r - 1].split('\t').nth(c).unwrap().parse().unwrap()
        };
        for d in &out.summary.defects {
            match d.kind {
                DefectKind::DuplicatedEt => {
                    assert_eq!(cell(d.row_first, 0), cell(d.row_first - 1, 0));
                }
                DefectKind::NonMonotonicEt => {
                    assert!(cell(d.row_first, 0) < cell(d.row_first - 1, 0));
                }
                DefectKind::ZeroPressure => {
                    for r in d.row_first..=d.row_last {
                        assert_eq!(cell(r, col("P")), 0.0);
                    }
                }
                DefectKind::ZeroedChannel => {
                    for r in d.row_first..=d.row_last {
                        assert_eq!(cell(r, col(&d.channel)), 0.0);
                    }
                }
                DefectKind::TruncatedLastLine => {
                    assert!(!text.ends_with('\n'));
                    assert!(rows.last().unwrap().split('\t').count() < cols.len());
                }
                DefectKind::SpreadsheetResaved => {
                    assert!(text.lines().next().unwrap().ends_with('\t'));
                    assert!(rows.iter().any(|r| r.split('\t').any(|c| c == "0")));
                }
            }
            seen.push(d.kind);
        }
    }
    seen.sort();
    assert_eq!(seen, DefectKind::ALL.to_vec());
}

#[test]
fn ideal_realism_holds_the_truth_model() {
    let plan = plan_round(&SynthConfig {
        realism: RealismConfig::ideal(),
        ..SynthConfig::default()
    })
    .unwrap();
    let index = first_run(&plan, 0, RunKind::Cornering);
    let spec = &plan.runs[index];
    let (program, s) = run_of(&plan, index, plan.realism());
    let truth = plan.truth(spec.combo, spec.pressure_psi);
    let (_, ey) = grip_error_vs_truth(truth, &program, &s, &[SegmentKind::Cornering]);
    assert!(ey < 1e-12, "{ey}");
    assert_eq!(plan.config.size, Size::Demo);
}

/// `truth = "mf61"`: every pressure of a tire is the same MF 6.1 model (only `INFLPRES` differs),
/// the machine's forces are that model at the sample's pressure (ideal realism: exactly the
/// commanded one), the model equals the PAC2002 truth at the reference pressure and zero camber
/// (the lift is exact there), its pressure terms change the tire, and the truth files read back
/// as the same model.
#[test]
fn mf61_truth_is_one_mf61_model_across_pressures() {
    use super::round::{mf61_tir_file_name, render_truth};
    use super::tires::{P_REF_PSI, TruthForm, truth_model};
    use crate::tire_model::tir::TirFile;
    use crate::tire_model::{Coef, Version};
    let plan = plan_round(&SynthConfig {
        realism: RealismConfig::ideal(),
        truth: TruthForm::Mf61,
        ..SynthConfig::default()
    })
    .unwrap();
    let (lo, hi) = (&plan.truths[0], &plan.truths[1]);
    assert_eq!(lo.model.version, Version::Mf61);
    assert!(lo.pressure_psi < hi.pressure_psi);
    for c in Coef::ALL {
        if *c != Coef::INFLPRES {
            assert_eq!(lo.model.coefs[*c], hi.model.coefs[*c], "{}", c.name());
        }
    }
    assert_eq!(lo.model.coefs[Coef::INFLPRES], lo.pressure_kpa() * 1e3);
    assert!(lo.model.coefs[Coef::PPY1] != 0.0 && lo.model.coefs[Coef::PFZ1] != 0.0);

    // The machine evaluates the model at the run's pressure.
    for index in [
        first_run(&plan, 0, RunKind::Cornering),
        first_run(&plan, 1, RunKind::DriveBrake),
    ] {
        let spec = &plan.runs[index];
        let (program, s) = run_of(&plan, index, plan.realism());
        let truth = plan.truth(spec.combo, spec.pressure_psi);
        let (ex, ey) = grip_error_vs_truth(
            truth,
            &program,
            &s,
            &[SegmentKind::Cornering, SegmentKind::DriveBrake],
        );
        assert!(ex < 1e-12 && ey < 1e-12, "{ex} {ey}");
    }

    // At the reference pressure and zero camber it is the PAC2002 truth.
    let base = super::tires::base_coefs().unwrap();
    let pac = truth_model(&base, 0, 7.0, P_REF_PSI);
    let mf = &lo.model;
    let p_ref = mf.coefs[Coef::NOMPRES];
    let mut worst = [0.0_f64; 3];
    for fz in [300.0, 700.0, 1100.0, 1500.0] {
        for i in -12..=12 {
            for kappa in [-0.1, 0.0, 0.05] {
                let input = SlipInput {
                    fz_n: fz,
                    kappa,
                    alpha_rad: f64::to_radians(i as f64),
                    gamma_rad: 0.0,
                    vx_mps: super::tires::V_REF_MPS,
                };
                let a = mf.eval_at(&input, p_ref, Mode::Limits);
                let b = pac.model.eval(&input, Mode::Limits);
                for (w, (x, y)) in
                    worst
                        .iter_mut()
                        .zip([(a.fx_n, b.fx_n), (a.fy_n, b.fy_n), (a.mz_nm, b.mz_nm)])
                {
                    *w = w.max((x - y).abs() / y.abs().max(1.0));
                }
            }
        }
    }
    println!("MF 6.1 truth at NOMPRES vs PAC2002 truth, zero camber: {worst:?}");
    assert!(worst.iter().all(|w| *w < 1e-9), "{worst:?}");
    let at = |p_kpa: f64| {
        let input = SlipInput {
            fz_n: 1100.0,
            alpha_rad: 0.5_f64.to_radians(),
            vx_mps: super::tires::V_REF_MPS,
            ..SlipInput::default()
        };
        mf.eval_at(&input, p_kpa * 1e3, Mode::Limits).fy_n
    };
    assert!(
        at(97.0) / at(69.0) > 1.1,
        "cornering stiffness rises with pressure"
    );

    // The truth files: one per pressure and one for every pressure, reading back as the model.
    let files = render_truth(&plan, &[]).unwrap();
    let name = mf61_tir_file_name(plan.combos[0].tire(), plan.combos[0].rim_in);
    let file = files
        .iter()
        .find(|f| f.path == format!("truth/tir/{name}"))
        .expect("the MF 6.1 truth file");
    let (read, _) = TirFile::parse(std::str::from_utf8(&file.bytes).unwrap()).unwrap();
    assert_eq!(read.version, Version::Mf61);
    assert_eq!(read.coefs[Coef::INFLPRES], read.coefs[Coef::NOMPRES]);
    for c in Coef::ALL.iter().filter(|c| c.carried_by(Version::Mf61)) {
        if *c != Coef::INFLPRES {
            assert_eq!(read.coefs[*c], mf.coefs[*c], "{}", c.name());
        }
    }
    let per_pressure = files.iter().filter(|f| f.path.ends_with("kPa.tir")).count();
    assert_eq!(per_pressure, plan.truths.len());
    let toml = files
        .iter()
        .find(|f| f.path.ends_with("in.toml"))
        .map(|f| String::from_utf8_lossy(&f.bytes).into_owned())
        .unwrap();
    assert!(
        toml.contains("truth = \"mf61\"") && toml.contains("__mf61.tir"),
        "{toml}"
    );
    assert!(!toml.contains("pty1"), "{toml}");
}

/// `[synth] tires` / `rims_in` keep one tire on one rim of the full round (every planned
/// pressure, cornering and drive/brake each), and a name not in the catalogue or a filter that
/// keeps nothing is an error naming the key.
#[test]
fn tires_and_rims_narrow_the_round() {
    use super::round::RoundError;
    let tire = CATALOGUE[1].name.to_string();
    let plan = plan_round(&SynthConfig {
        size: Size::Full,
        tires: vec![tire.clone()],
        rims_in: vec![7.0],
        realism: RealismConfig::ideal(),
        ..SynthConfig::default()
    })
    .unwrap();
    assert_eq!(plan.combos.len(), 1);
    assert_eq!(
        (plan.combos[0].tire(), plan.combos[0].rim_in),
        (tire.as_str(), 7.0)
    );
    assert_eq!(
        plan.runs.len(),
        2 * CATALOGUE[1].pressures_psi.len(),
        "every planned pressure, two runs each"
    );
    let err = |cfg: SynthConfig| match plan_round(&cfg) {
        Err(RoundError::Config { key, .. }) => key,
        other => panic!("{:?}", other.map(|p| p.combos.len())),
    };
    assert_eq!(
        err(SynthConfig {
            tires: vec!["No Such Tire".to_string()],
            ..SynthConfig::default()
        }),
        "tires"
    );
    assert_eq!(
        err(SynthConfig {
            rims_in: vec![11.0],
            ..SynthConfig::default()
        }),
        "tires"
    );
    assert_eq!(
        err(SynthConfig {
            rims_in: vec![-1.0],
            ..SynthConfig::default()
        }),
        "rims_in"
    );
}

/// Run-order drift: every run starts from the history its tire's earlier runs left (first run
/// fresh, then growing in run order), the plan tests the middle pressure first, and the first
/// block's friction and slip stiffness scalings lie above every later block's.
#[test]
fn run_order_drift_histories_follow_the_run_order() {
    let cfg = SynthConfig {
        size: Size::Full,
        tires: vec![CATALOGUE[1].name.to_string()],
        rims_in: vec![7.0],
        quirks: super::quirks::QuirksConfig {
            nonstandard_levels: true,
            drift: super::drift::RunOrderDrift::typical(),
            ..Default::default()
        },
        ..SynthConfig::default()
    };
    let plan = plan_round(&cfg).unwrap();
    let d = cfg.quirks.drift;
    let mut last = -1.0;
    for r in &plan.runs {
        let (mu, k) = d.scales(&r.history);
        println!(
            "run {} {:?} {:.0} psi: {:.0} kJ, {:.2} km before: mu x {:.4}, K x {:.4}",
            r.run,
            r.kind,
            r.pressure_psi,
            r.history.slip_energy_j / 1e3,
            r.history.distance_m / 1e3,
            mu,
            k
        );
        assert!(r.history.slip_energy_j > last, "{:?}", r.history);
        last = r.history.slip_energy_j;
    }
    assert_eq!(plan.runs[0].history, Default::default());
    let order: Vec<f64> = plan.runs.iter().map(|r| r.pressure_psi).collect();
    let (lo, hi) = order
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(*p), b.max(*p))
        });
    assert!(order[0] > lo && order[0] < hi, "{order:?}");
}
