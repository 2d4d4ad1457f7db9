//! The evaluator, fed through the `.tir` reader, against every MFeval 4.3.1 reference grid.
//!
//! In: the reference `.tir` files and CSVs under `tests/fixtures/reference/` (compiled in).
//! Out: assertions that every output column agrees to a relative error of 1e-9 (relative to
//! `max(|ref|, 1)`), and the measured maxima printed (`cargo test -- --nocapture`).
//! Deliberately not here: the CLI path (tests/tir.rs drives the binary on the same files).

use super::TirFile;
use crate::tire_model::{Evaluation, Mode, SlipInput};

const MFEVAL_TIR: &str = include_str!(
    "../../../../tests/fixtures/reference/mfeval-sample/MagicFormula52_Parameters.tir"
);
const MFEVAL_111: &str = include_str!(
    "../../../../tests/fixtures/reference/mfeval-sample/mfeval_pac2002_combined_mode111.csv"
);
const MFEVAL_211: &str = include_str!(
    "../../../../tests/fixtures/reference/mfeval-sample/mfeval_pac2002_combined_mode211.csv"
);
const MFEVAL_PURE_111: &str = include_str!(
    "../../../../tests/fixtures/reference/mfeval-sample/mfeval_pac2002_pure_mode111.csv"
);
const FSAE_TIR: &str =
    include_str!("../../../../tests/fixtures/reference/fsae-demo/fsae_demo_pac2002.tir");
const FSAE_COMBINED_111: &str = include_str!(
    "../../../../tests/fixtures/reference/fsae-demo/fsae_demo_pac2002_combined_mode111.csv"
);
const FSAE_PURE_111: &str = include_str!(
    "../../../../tests/fixtures/reference/fsae-demo/fsae_demo_pac2002_pure_mode111.csv"
);

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
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |n: &str| {
        header
            .iter()
            .position(|h| *h == n)
            .unwrap_or_else(|| panic!("{name}: no column {n}"))
    };
    let inputs = ["Fz_N", "kappa", "alpha_rad", "gamma_rad", "Vx_mps"].map(col);
    let outputs: Vec<usize> = OUTPUTS.iter().map(|(n, _)| col(n)).collect();
    let mut worst = vec![0.0_f64; OUTPUTS.len()];
    let mut rows = 0;
    for (i, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        let num = |j: usize| -> f64 { cells[j].parse().expect("number") };
        let input = SlipInput {
            fz_n: num(inputs[0]),
            kappa: num(inputs[1]),
            alpha_rad: num(inputs[2]),
            gamma_rad: num(inputs[3]),
            vx_mps: num(inputs[4]),
        };
        let eval = model.eval(&input, mode);
        for (k, (out_name, get)) in OUTPUTS.iter().enumerate() {
            let reference = num(outputs[k]);
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
        rows += 1;
    }
    assert!(rows > 100, "{name}: only {rows} rows");
    let report: Vec<(&str, f64)> = OUTPUTS.iter().map(|(n, _)| *n).zip(worst).collect();
    println!("{name} ({rows} rows) max relative error: {report:?}");
    report
}

#[test]
fn mfeval_sample_combined_limits_matches_usemode_111() {
    check("mfeval combined 111", MFEVAL_TIR, MFEVAL_111, Mode::Limits);
}

#[test]
fn mfeval_sample_combined_raw_matches_usemode_211() {
    check("mfeval combined 211", MFEVAL_TIR, MFEVAL_211, Mode::Raw);
}

#[test]
fn mfeval_sample_pure_limits_matches_usemode_111() {
    check("mfeval pure 111", MFEVAL_TIR, MFEVAL_PURE_111, Mode::Limits);
}

#[test]
fn fsae_demo_combined_limits_matches_usemode_111() {
    check(
        "fsae combined 111",
        FSAE_TIR,
        FSAE_COMBINED_111,
        Mode::Limits,
    );
}

#[test]
fn fsae_demo_pure_limits_matches_usemode_111() {
    check("fsae pure 111", FSAE_TIR, FSAE_PURE_111, Mode::Limits);
}

/// The raw mode really differs where the E clamp acts (so the 111/211 tests are not the same
/// test twice).
#[test]
fn limits_and_raw_differ_on_the_mfeval_sample() {
    let (file, _) = TirFile::parse(MFEVAL_TIR).unwrap();
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
    for tir in [MFEVAL_TIR, FSAE_TIR] {
        let (file, _) = TirFile::parse(tir).unwrap();
        let (again, _) = TirFile::parse(&file.render().unwrap()).unwrap();
        for (a, b) in file.coefs.0.iter().zip(again.coefs.0.iter()) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }
}
