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

/// MFeval 4.3.1 on its sample tire, pure-slip grid, useMode 111.
pub const MFEVAL_SAMPLE_PURE_111: &str =
    include_str!("../../../tests/fixtures/reference/mfeval-sample/mfeval_pac2002_pure_mode111.csv");
/// MFeval 4.3.1 on the FSAE demo tire, pure-slip grid, useMode 111.
pub const FSAE_DEMO_PURE_111: &str =
    include_str!("../../../tests/fixtures/reference/fsae-demo/fsae_demo_pac2002_pure_mode111.csv");
/// MFeval on its MF 6.1 sample, per-row pressure, useMode 111.
pub const MF61_SAMPLE_111: &str = include_str!(
    "../../../tests/fixtures/reference/mfeval-mf6/MagicFormula61_Parameters_mode111.csv"
);
/// MFeval on its MF 6.1 sample, per-row pressure, useMode 211.
pub const MF61_SAMPLE_211: &str = include_str!(
    "../../../tests/fixtures/reference/mfeval-mf6/MagicFormula61_Parameters_mode211.csv"
);
/// MFeval's MF 6.2 sample tire.
pub const MF62_SAMPLE_TIR: &str =
    include_str!("../../../tests/fixtures/reference/mfeval-mf6/MagicFormula62_Parameters.tir");
/// MFeval on its MF 6.2 sample, per-row pressure, useMode 111.
pub const MF62_SAMPLE_111: &str = include_str!(
    "../../../tests/fixtures/reference/mfeval-mf6/MagicFormula62_Parameters_mode111.csv"
);
/// MFeval on its MF 6.2 sample, per-row pressure, useMode 211.
pub const MF62_SAMPLE_211: &str = include_str!(
    "../../../tests/fixtures/reference/mfeval-mf6/MagicFormula62_Parameters_mode211.csv"
);
/// MFeval on the book-values MF 6.1 file, per-row pressure, useMode 111.
pub const MF61_BOOK_111: &str =
    include_str!("../../../tests/fixtures/reference/mfeval-mf6/PacejkaBook_Defaults_mode111.csv");
/// MFeval on the book-values MF 6.1 file, per-row pressure, useMode 211.
pub const MF61_BOOK_211: &str =
    include_str!("../../../tests/fixtures/reference/mfeval-mf6/PacejkaBook_Defaults_mode211.csv");

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

/// A reference CSV read once: the header and every non-blank row's cells (numbers parsed when
/// read, so text columns such as `case` may be present).
#[derive(Clone, Debug)]
pub struct ReferenceGrid {
    header: Vec<String>,
    cells: Vec<Vec<String>>,
}

impl ReferenceGrid {
    /// Parse `csv` (comma separated, a header line, blank lines skipped).
    pub fn parse(csv: &str) -> ReferenceGrid {
        let split = |l: &str| l.split(',').map(|c| c.trim().to_string()).collect();
        let mut lines = csv.lines();
        let header = split(lines.next().expect("header"));
        let cells = lines.filter(|l| !l.trim().is_empty()).map(split).collect();
        ReferenceGrid { header, cells }
    }

    /// Number of rows.
    pub fn row_count(&self) -> usize {
        self.cells.len()
    }

    /// The index of column `name` (panics naming it when it is missing).
    pub fn column(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("column {name} missing"))
    }

    /// The number in row `row`, column `column`.
    pub fn value(&self, row: usize, column: usize) -> f64 {
        let cell = &self.cells[row][column];
        cell.parse()
            .unwrap_or_else(|_| panic!("row {row}, column {column}: not a number: {cell:?}"))
    }

    /// Column `name` of every row.
    pub fn values(&self, name: &str) -> Vec<f64> {
        let j = self.column(name);
        (0..self.row_count()).map(|i| self.value(i, j)).collect()
    }

    /// Every row's operating point (`Fz_N, kappa, alpha_rad, gamma_rad, Vx_mps`).
    pub fn inputs(&self) -> Vec<SlipInput> {
        let [fz, kappa, alpha, gamma, vx] =
            ["Fz_N", "kappa", "alpha_rad", "gamma_rad", "Vx_mps"].map(|n| self.column(n));
        (0..self.row_count())
            .map(|i| SlipInput {
                fz_n: self.value(i, fz),
                kappa: self.value(i, kappa),
                alpha_rad: self.value(i, alpha),
                gamma_rad: self.value(i, gamma),
                vx_mps: self.value(i, vx),
            })
            .collect()
    }
}

/// One reference row: the input point and MFeval's `[Fx, Fy, Mx, My, Mz]`.
#[derive(Copy, Clone, Debug)]
pub struct ReferenceRow {
    /// The operating point.
    pub input: SlipInput,
    /// MFeval's `Fx_N, Fy_N, Mx_Nm, My_Nm, Mz_Nm`.
    pub outputs: [f64; 5],
}

/// Parse a reference CSV into rows of the operating point and the five forces and moments.
pub fn reference_rows(csv: &str) -> Vec<ReferenceRow> {
    let grid = ReferenceGrid::parse(csv);
    let outputs = ["Fx_N", "Fy_N", "Mx_Nm", "My_Nm", "Mz_Nm"].map(|n| grid.column(n));
    grid.inputs()
        .into_iter()
        .enumerate()
        .map(|(i, input)| ReferenceRow {
            input,
            outputs: outputs.map(|j| grid.value(i, j)),
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
