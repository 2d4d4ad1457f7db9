//! The evaluator, fed through the `.tir` reader, against every MFeval 4.3.1 reference grid.
//!
//! In: the reference `.tir` files and CSVs under `tests/fixtures/reference/` (`test_support`).
//! Out: assertions that every output column agrees to a relative error of 1e-9 (relative to
//! `max(|ref|, 1)`), and the measured maxima printed (`cargo test -- --nocapture`).
//! Deliberately not here: the CLI path (tests/tir.rs drives the binary on the same files).

use super::TirFile;
use crate::tire_model::test_support::*;
use crate::tire_model::{Evaluation, Mode, SlipInput};

/// Relative error bound of issue 2 ("Done when").
const TOL: f64 = 1e-9;

/// Reads one output from an [`Evaluation`].
type Getter = fn(&Evaluation<f64>) -> f64;

/// Compared outputs: CSV column and how to get it from an [`Evaluation`].
const OUTPUTS: [(&str, Getter); 11] = [
    ("Fx_N", |e| e.fx_n),
    ("Fy_N", |e| e.fy_n),
    ("Mx_Nm", |e| e.mx_nm),
    ("My_Nm", |e| e.my_nm),
    ("Mz_Nm", |e| e.mz_nm),
    ("t_m", |e| e.trail_m),
    ("Mzr_Nm", |e| e.mzr_nm),
    ("mux", |e| e.mux),
    ("muy", |e| e.muy),
    ("Kya_Nprad", |e| e.kya_n_per_rad),
    ("Kxk_N", |e| e.kxk_n),
];

/// Evaluate every row of `csv` with the tire in `tir` and return the maximum relative error per
/// output column; panics with a readable diff at the first value beyond [`TOL`].
fn check(name: &str, tir: &str, csv: &str, mode: Mode) -> Vec<(&'static str, f64)> {
    let (file, _warnings) = TirFile::parse(tir).expect("reference .tir reads");
    let model = file.model();
    let grid = ReferenceGrid::parse(csv);
    let outputs: Vec<usize> = OUTPUTS.iter().map(|(n, _)| grid.column(n)).collect();
    let mut worst = vec![0.0_f64; OUTPUTS.len()];
    for (i, input) in grid.inputs().iter().enumerate() {
        let eval = model.eval(input, mode);
        for (k, (out_name, get)) in OUTPUTS.iter().enumerate() {
            let reference = grid.value(i, outputs[k]);
            let ours = get(&eval);
            let rel = (ours - reference).abs() / reference.abs().max(1.0);
            assert!(
                rel <= TOL,
                "{name} row {} ({input:?}): {out_name} ours {ours:.17e} reference {reference:.17e} \
                 relative error {rel:.3e} > {TOL:e}",
                i + 2
            );
            worst[k] = worst[k].max(rel);
        }
    }
    let rows = grid.row_count();
    assert!(rows > 100, "{name}: only {rows} rows");
    let report: Vec<(&str, f64)> = OUTPUTS.iter().map(|(n, _)| *n).zip(worst).collect();
    println!("{name} ({rows} rows) max relative error: {report:?}");
    report
}

#[test]
fn mfeval_sample_combined_limits_matches_usemode_111() {
    check(
        "mfeval combined 111",
        MFEVAL_SAMPLE_TIR,
        MFEVAL_SAMPLE_COMBINED_111,
        Mode::Limits,
    );
}

#[test]
fn mfeval_sample_combined_raw_matches_usemode_211() {
    check(
        "mfeval combined 211",
        MFEVAL_SAMPLE_TIR,
        MFEVAL_SAMPLE_COMBINED_211,
        Mode::Raw,
    );
}

#[test]
fn mfeval_sample_pure_limits_matches_usemode_111() {
    check(
        "mfeval pure 111",
        MFEVAL_SAMPLE_TIR,
        MFEVAL_SAMPLE_PURE_111,
        Mode::Limits,
    );
}

#[test]
fn fsae_demo_combined_limits_matches_usemode_111() {
    check(
        "fsae combined 111",
        FSAE_DEMO_TIR,
        FSAE_DEMO_COMBINED_111,
        Mode::Limits,
    );
}

#[test]
fn fsae_demo_pure_limits_matches_usemode_111() {
    check(
        "fsae pure 111",
        FSAE_DEMO_TIR,
        FSAE_DEMO_PURE_111,
        Mode::Limits,
    );
}

/// The raw mode really differs where the E clamp acts (so the 111/211 tests are not the same
/// test twice).
#[test]
fn limits_and_raw_differ_on_the_mfeval_sample() {
    let (file, _) = TirFile::parse(MFEVAL_SAMPLE_TIR).unwrap();
    let model = file.model();
    let input = SlipInput {
        fz_n: 2.0 * 9416.6,
        kappa: -0.2,
        alpha_rad: 0.0,
        gamma_rad: 0.0,
        vx_mps: 11.1,
    };
    let limits = model.eval(&input, Mode::Limits).fx_n;
    let raw = model.eval(&input, Mode::Raw).fx_n;
    assert!((limits - raw).abs() > 100.0, "limits {limits} raw {raw}");
}

/// Converting a reference file (render, then read) changes no output bit.
#[test]
fn converted_reference_files_evaluate_identically() {
    for tir in [MFEVAL_SAMPLE_TIR, FSAE_DEMO_TIR] {
        let (file, _) = TirFile::parse(tir).unwrap();
        let (again, _) = TirFile::parse(&file.render().unwrap()).unwrap();
        for (a, b) in file.coefs.0.iter().zip(again.coefs.0.iter()) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }
}

// MF 6.1 / 6.2: MFeval's samples and the book defaults, per-row inflation pressure, both modes.

/// Every row of an MF 6.x grid (inputs with `P_Pa`), scalar and batch paths, against MFeval's
/// five outputs; returns the worst relative error per output (scalar, batch).
fn check_mf6(name: &str, tir: &str, csv: &str, mode: Mode) -> [f64; 5] {
    use crate::tire_model::{Pressures, Version};
    let (file, _warnings) = TirFile::parse(tir).expect("reference .tir reads");
    assert!(file.version.is_mf6(), "{name}: read as {}", file.version);
    assert_ne!(file.version, Version::Pac2002);
    let model = file.model();
    let rows = reference_rows(csv);
    let points: Vec<SlipInput> = rows.iter().map(|r| r.input).collect();
    let reference: Vec<[f64; 5]> = rows.iter().map(|r| r.outputs).collect();
    let pressures = ReferenceGrid::parse(csv).values("P_Pa");
    assert!(points.len() >= 400, "{name}: only {} rows", points.len());
    let mut batch = vec![Evaluation::default(); points.len()];
    model.eval_batch_at(&points, Pressures::PerPoint(&pressures), mode, &mut batch);
    let mut worst = [0.0_f64; 5];
    for (i, ((p, pa), r)) in points.iter().zip(&pressures).zip(&reference).enumerate() {
        let s = model.eval_at(p, *pa, mode);
        let b = &batch[i];
        let ours = [
            [s.fx_n, s.fy_n, s.mx_nm, s.my_nm, s.mz_nm],
            [b.fx_n, b.fy_n, b.mx_nm, b.my_nm, b.mz_nm],
        ];
        for path in ours {
            for (k, (o, rf)) in path.iter().zip(r).enumerate() {
                let rel = (o - rf).abs() / rf.abs().max(1.0);
                assert!(
                    rel <= TOL,
                    "{name} row {} ({p:?}, {pa} Pa): {} ours {o:.17e} reference {rf:.17e} \
                     relative error {rel:.3e} > {TOL:e}",
                    i + 2,
                    ["Fx", "Fy", "Mx", "My", "Mz"][k]
                );
                worst[k] = worst[k].max(rel);
            }
        }
    }
    let shown: Vec<String> = worst.iter().map(|w| format!("{w:.1e}")).collect();
    println!(
        "{name} ({} rows) max relative error Fx, Fy, Mx, My, Mz: {shown:?}",
        points.len()
    );
    worst
}

/// Issue 19: MF 6.1 (MFeval's sample), limits mode (pressure clipped to PRESMIN).
#[test]
fn mf61_sample_matches_usemode_111() {
    check_mf6("mf61 111", MF61_SAMPLE_TIR, MF61_SAMPLE_111, Mode::Limits);
}

#[test]
fn mf61_sample_matches_usemode_211() {
    check_mf6("mf61 211", MF61_SAMPLE_TIR, MF61_SAMPLE_211, Mode::Raw);
}

#[test]
fn mf62_sample_matches_usemode_111() {
    check_mf6("mf62 111", MF62_SAMPLE_TIR, MF62_SAMPLE_111, Mode::Limits);
}

#[test]
fn mf62_sample_matches_usemode_211() {
    check_mf6("mf62 211", MF62_SAMPLE_TIR, MF62_SAMPLE_211, Mode::Raw);
}

#[test]
fn pacejka_book_defaults_match_usemode_111() {
    check_mf6("book 111", MF61_BOOK_TIR, MF61_BOOK_111, Mode::Limits);
}

#[test]
fn pacejka_book_defaults_match_usemode_211() {
    check_mf6("book 211", MF61_BOOK_TIR, MF61_BOOK_211, Mode::Raw);
}

/// The pressure really acts (so the grids test the pressure terms), and limits mode clips it.
#[test]
fn mf61_pressure_changes_forces_and_is_clipped_in_limits_mode() {
    let (file, _) = TirFile::parse(MF61_SAMPLE_TIR).unwrap();
    let model = file.model();
    let input = SlipInput {
        fz_n: 6752.0,
        kappa: 0.05,
        alpha_rad: 0.08,
        gamma_rad: 0.02,
        vx_mps: 16.6,
    };
    let at = |p: f64, mode| model.eval_at(&input, p, mode);
    let (lo, hi) = (at(200e3, Mode::Raw), at(320e3, Mode::Raw));
    assert!(
        (lo.fy_n - hi.fy_n).abs() > 10.0,
        "{} vs {}",
        lo.fy_n,
        hi.fy_n
    );
    assert!(
        (lo.fx_n - hi.fx_n).abs() > 10.0,
        "{} vs {}",
        lo.fx_n,
        hi.fx_n
    );
    // PRESMIN = 200 kPa: 150 kPa evaluates as 200 kPa in limits mode, not in raw mode.
    assert_eq!(at(150e3, Mode::Limits), at(200e3, Mode::Limits));
    assert_ne!(at(150e3, Mode::Raw), at(200e3, Mode::Raw));
    // The default pressure is INFLPRES.
    assert_eq!(model.eval(&input, Mode::Raw), at(260e3, Mode::Raw));
}
