//! Test and benchmark support: the bundled reference tires and MFeval reference grids.
//!
//! In: the `.tir` and CSV files under `tests/fixtures/reference/` (compiled in with
//! `include_str!`). Out: coefficient vectors (through the real `.tir` reader) and reference
//! rows, plus a seeded point generator.
//!
//! Compiled only for tests (`#[cfg(test)]` in `tire_model/mod.rs`) and included by path into the
//! benchmarks, so nothing here is public API.

#![allow(dead_code)]

// `super` is `tire_model` in the library and the benchmark's crate root in the benches; both
// have these names in scope.
use super::{Coefs, SlipInput, SplitMix64, tir::TirFile};

/// The FSAE-size PAC2002 demo tire (`PDY1 < 0`, `QSX4..11` set).
pub const FSAE_DEMO_TIR: &str =
    include_str!("../../../tests/fixtures/reference/fsae-demo/fsae_demo_pac2002.tir");
/// MFeval 4.3.1 on the FSAE demo tire, combined-slip grid, useMode 111.
pub const FSAE_DEMO_COMBINED_111: &str = include_str!(
    "../../../tests/fixtures/reference/fsae-demo/fsae_demo_pac2002_combined_mode111.csv"
);
/// MFeval's MF 5.2 sample tire.
pub const MFEVAL_SAMPLE_TIR: &str =
    include_str!("../../../tests/fixtures/reference/mfeval-sample/MagicFormula52_Parameters.tir");
/// MFeval 4.3.1 on its sample tire, combined-slip grid, useMode 111 (E clamp active).
pub const MFEVAL_SAMPLE_COMBINED_111: &str = include_str!(
    "../../../tests/fixtures/reference/mfeval-sample/mfeval_pac2002_combined_mode111.csv"
);
/// MFeval 4.3.1 on its sample tire, combined-slip grid, useMode 211 (no limits).
pub const MFEVAL_SAMPLE_COMBINED_211: &str = include_str!(
    "../../../tests/fixtures/reference/mfeval-sample/mfeval_pac2002_combined_mode211.csv"
);

/// MFeval's MF 6.1 sample tire (passenger-car size, NOMPRES 260 kPa).
pub const MF61_SAMPLE_TIR: &str =
    include_str!("../../../tests/fixtures/reference/mfeval-mf6/MagicFormula61_Parameters.tir");
/// MFeval's MF 6.1 file with the coefficient values of Pacejka's book.
pub const MF61_BOOK_TIR: &str =
    include_str!("../../../tests/fixtures/reference/mfeval-mf6/PacejkaBook_Defaults.tir");

/// The coefficients of a bundled `.tir` file (panics if it cannot be read: fixtures are fixed).
pub fn coefs_from_tir(text: &str) -> Coefs<f64> {
    TirFile::parse(text).expect("bundled .tir reads").0.coefs
}

/// The model of a bundled `.tir` file, its own version.
pub fn model_from_tir(text: &str) -> super::MagicFormula {
    TirFile::parse(text).expect("bundled .tir reads").0.model()
}

/// `n` pressures drawn uniformly in `[lo, hi]` times `nominal_pa`.
pub fn random_pressures(n: usize, seed: u64, nominal_pa: f64, lo: f64, hi: f64) -> Vec<f64> {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| rng.uniform_in(lo, hi) * nominal_pa)
        .collect()
}

/// One reference row: the input point and MFeval's `[Fx, Fy, Mx, My, Mz]`.
#[derive(Copy, Clone, Debug)]
pub struct ReferenceRow {
    /// The operating point.
    pub input: SlipInput,
    /// MFeval's `Fx_N, Fy_N, Mx_Nm, My_Nm, Mz_Nm`.
    pub outputs: [f64; 5],
}

/// Parse a reference CSV (columns found by header name).
pub fn reference_rows(csv: &str) -> Vec<ReferenceRow> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| *h == name)
            .unwrap_or_else(|| panic!("column {name} missing"))
    };
    let idx_in = [
        col("Fz_N"),
        col("kappa"),
        col("alpha_rad"),
        col("gamma_rad"),
        col("Vx_mps"),
    ];
    let idx_out = [
        col("Fx_N"),
        col("Fy_N"),
        col("Mx_Nm"),
        col("My_Nm"),
        col("Mz_Nm"),
    ];
    lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let num = |i: usize| f[i].trim().parse::<f64>().expect("number");
            ReferenceRow {
                input: SlipInput {
                    fz_n: num(idx_in[0]),
                    kappa: num(idx_in[1]),
                    alpha_rad: num(idx_in[2]),
                    gamma_rad: num(idx_in[3]),
                    vx_mps: num(idx_in[4]),
                },
                outputs: idx_out.map(num),
            }
        })
        .collect()
}

/// The two reference tires, by name.
pub fn reference_tires() -> [(&'static str, Coefs<f64>); 2] {
    [
        ("fsae-demo", coefs_from_tir(FSAE_DEMO_TIR)),
        ("mfeval-sample", coefs_from_tir(MFEVAL_SAMPLE_TIR)),
    ]
}

/// `n` operating points drawn uniformly over an FSAE test envelope scaled to `fnomin_n`:
/// `Fz` in `[0.15, 2] FNOMIN` (a continuous load, as measured data has), `kappa` in
/// `[-0.2, 0.2]`, `alpha` in `[-12, 12]` deg, `gamma` in `[-1, 4]` deg, `Vx` 11.176 m/s.
pub fn random_points(n: usize, seed: u64, fnomin_n: f64) -> Vec<SlipInput> {
    let mut rng = SplitMix64::new(seed);
    let deg = std::f64::consts::PI / 180.0;
    (0..n)
        .map(|_| SlipInput {
            fz_n: rng.uniform_in(0.15, 2.0) * fnomin_n,
            kappa: rng.uniform_in(-0.2, 0.2),
            alpha_rad: rng.uniform_in(-12.0, 12.0) * deg,
            gamma_rad: rng.uniform_in(-1.0, 4.0) * deg,
            vx_mps: 11.176,
        })
        .collect()
}
