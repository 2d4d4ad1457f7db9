//! Quirks of real rounds the virtual machine can imitate, each with its truth: older rounds'
//! files, test plans off the standard levels, de-identified data.
//!
//! In: a [`QuirksConfig`] (`[synth.quirks]`, everything off by default: the demo round stays
//! clean). Out: changes to the commanded programs ([`apply_to_program`]: scaled slip angles and
//! loads, loads off the standard list), to the machine (loose load control, 50 Hz), to the files
//! ([`apply_to_table`]: no SL, no NFX/NFY, radius channels in a wrong length unit; `.mat` without
//! a `channel` struct) and the truth of the unit errors ([`UnitErrorRow`],
//! `truth/unit_errors.csv`). The segments' truth follows the commanded (quirked) levels.
//!
//! - **Older round** (rounds 1-3): every file at 50 Hz; loose load control, FZ swinging by
//!   `load_swing_frac` around its set-point while the tire slips (a sine of a period between
//!   0.5 and 2 s per run: several swings within every sweep); Calspan's SR but no SL and no
//!   NFX/NFY; RL and RE written in inches where the file declares cm (and in cm where it
//!   declares inches); `.mat` files without the `channel` struct (no unit metadata at all).
//! - **Non-standard levels**: a 16 psi (110 kPa) pressure for every tire, and every load moved
//!   off the consortium's list (50/100/150/200/250/350 lb -> 75/125/175/225/275/400 lb).
//! - **De-identified** (as the consortium publishes example data): commanded slip angles and
//!   loads multiplied by `sa_scale` and `load_scale`.
//! - **Run-order drift** (`[synth.quirks.drift]`, [`super::drift`]): friction and slip stiffness
//!   that settle with the tire's history, so the pressure tested first differs from the others
//!   by more than pressure; the truth of each pressure is the tire as its block saw it.
//!
//! Deliberately not here: physics (the truth models are unchanged; the drift's law and the
//! truth under it are in [`super::drift`]), segmentation.

use serde::{Deserialize, Serialize};

use super::dat::{ChannelTable, Container, FileStyle, FileUnits};
use super::drift::RunOrderDrift;
use super::schedule::Program;
use super::tires::N_PER_LBF;

/// Quirks of real rounds to imitate (`[synth.quirks]`), all off by default: older-round files,
/// non-standard levels, de-identified scaling.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QuirksConfig {
    /// Older-round files: 50 Hz, loose load control, SR without SL or NFX/NFY, radius channels
    /// in a wrong length unit, `.mat` without a `channel` struct.
    pub older_round: bool,
    /// Loose load control of an older round: FZ swings by this fraction of its set-point while
    /// the tire slips, -.
    pub load_swing_frac: f64,
    /// A 16 psi pressure for every tire and loads off the standard list.
    pub nonstandard_levels: bool,
    /// De-identified data: commanded slip angles multiplied by this, -.
    pub sa_scale: f64,
    /// De-identified data: commanded loads multiplied by this, -.
    pub load_scale: f64,
    /// Run-order drift of friction and slip stiffness (off by default; not written to
    /// `round.toml` when off, so a round without it keeps its bytes).
    #[serde(skip_serializing_if = "RunOrderDrift::is_off")]
    pub drift: RunOrderDrift,
}

impl Default for QuirksConfig {
    fn default() -> Self {
        QuirksConfig {
            older_round: false,
            load_swing_frac: 0.2,
            nonstandard_levels: false,
            sa_scale: 1.0,
            load_scale: 1.0,
            drift: RunOrderDrift::default(),
        }
    }
}

impl QuirksConfig {
    /// Every quirk on, with the consortium's de-identification scales seen in published data
    /// (slip angles x 0.8125: +-12 deg -> +-9.75 deg) and loads x 1.15, and the typical
    /// run-order drift ([`RunOrderDrift::typical`]).
    pub fn all() -> QuirksConfig {
        QuirksConfig {
            older_round: true,
            load_swing_frac: 0.2,
            nonstandard_levels: true,
            sa_scale: 0.8125,
            load_scale: 1.15,
            drift: RunOrderDrift::typical(),
        }
    }

    /// The range problem of a value, if any: `(key, message)`.
    pub fn invalid(&self) -> Option<(&'static str, f64, &'static str)> {
        let in_range = |v: f64, lo: f64, hi: f64| v.is_finite() && (lo..=hi).contains(&v);
        if !in_range(self.load_swing_frac, 0.0, 0.5) {
            return Some((
                "quirks.load_swing_frac",
                self.load_swing_frac,
                "must be in 0..0.5",
            ));
        }
        if !in_range(self.sa_scale, 0.3, 2.0) {
            return Some(("quirks.sa_scale", self.sa_scale, "must be in 0.3..2"));
        }
        if !in_range(self.load_scale, 0.3, 3.0) {
            return Some(("quirks.load_scale", self.load_scale, "must be in 0.3..3"));
        }
        self.drift.invalid()
    }

    /// The sample rate of a file of `style`, Hz.
    pub fn rate_hz(&self, style: &FileStyle) -> f64 {
        if self.older_round {
            50.0
        } else {
            style.rate_hz()
        }
    }

    /// The pressures a tire is tested at, psi.
    pub fn pressures_psi(&self, planned: &[f64]) -> Vec<f64> {
        let mut p = planned.to_vec();
        if self.nonstandard_levels {
            match p.len() {
                0 | 1 => p.push(NONSTANDARD_PSI),
                n => p[n - 1] = NONSTANDARD_PSI,
            }
        }
        p
    }

    /// Whether any quirk changes the commanded levels.
    fn moves_levels(&self) -> bool {
        self.nonstandard_levels || self.sa_scale != 1.0 || self.load_scale != 1.0
    }

    /// A commanded load after the level quirks, N.
    pub fn load_n(&self, fz_n: f64) -> f64 {
        let lb = fz_n / N_PER_LBF;
        let lb = if self.nonstandard_levels {
            off_list_lb(lb)
        } else {
            lb
        };
        lb * N_PER_LBF * self.load_scale
    }
}

/// The pressure a non-standard round adds, psi (round 3 tested 10/12/14/16 psi).
pub const NONSTANDARD_PSI: f64 = 16.0;

/// Standard loads and where a non-standard plan puts them, lb (linear in between and beyond).
const OFF_LIST_LB: [(f64, f64); 7] = [
    (0.0, 0.0),
    (50.0, 75.0),
    (100.0, 125.0),
    (150.0, 175.0),
    (200.0, 225.0),
    (250.0, 275.0),
    (350.0, 400.0),
];

fn off_list_lb(lb: f64) -> f64 {
    let k = OFF_LIST_LB
        .iter()
        .position(|p| p.0 >= lb)
        .unwrap_or(OFF_LIST_LB.len() - 1)
        .max(1);
    let ((x0, y0), (x1, y1)) = (OFF_LIST_LB[k - 1], OFF_LIST_LB[k]);
    y0 + (lb - x0) * (y1 - y0) / (x1 - x0)
}

/// Scale and move the commanded slip angles and loads of a program, and its segments' nominal
/// levels with them (the truth is what was commanded).
pub fn apply_to_program(program: &mut Program, q: &QuirksConfig) {
    if !q.moves_levels() {
        return;
    }
    for piece in &mut program.pieces {
        for c in [&mut piece.from, &mut piece.to] {
            c.alpha_rad *= q.sa_scale;
            c.fz_n = q.load_n(c.fz_n);
        }
    }
    for seg in &mut program.segments {
        seg.nominal.alpha_deg = seg.nominal.alpha_deg.map(|a| a * q.sa_scale);
        seg.nominal.fz_n = seg.nominal.fz_n.map(|f| q.load_n(f).round());
    }
}

/// One radius channel written in a wrong unit (a row of `truth/unit_errors.csv`).
#[derive(Clone, Debug, PartialEq)]
pub struct UnitErrorRow {
    pub file: String,
    pub channel: &'static str,
    /// The unit the file declares (or, without unit metadata, the reader's SI default).
    pub declared: &'static str,
    /// The unit the values are really in.
    pub actual: &'static str,
    /// What the values must be multiplied by to be in the declared unit.
    pub factor: f64,
}

/// Older-round file contents: no SL, NFX, NFY; RL and RE in the other length unit. Returns the
/// unit errors injected.
pub fn apply_to_table(
    table: &mut ChannelTable,
    style: &FileStyle,
    file: &str,
    q: &QuirksConfig,
) -> Vec<UnitErrorRow> {
    if !q.older_round {
        return Vec::new();
    }
    table
        .columns
        .retain(|c| !matches!(c.name.as_str(), "SL" | "NFX" | "NFY"));
    let declared_in = style.units == FileUnits::UsCustomary && style.container == Container::Dat;
    let (declared, actual, values_per_declared) = if declared_in {
        ("in", "cm", 2.54)
    } else {
        ("cm", "in", 1.0 / 2.54)
    };
    let mut out = Vec::new();
    for name in ["RL", "RE"] {
        if let Some(c) = table.column_mut(name) {
            c.values.iter_mut().for_each(|v| *v *= values_per_declared);
            out.push(UnitErrorRow {
                file: file.to_string(),
                channel: name,
                declared,
                actual,
                factor: 1.0 / values_per_declared,
            });
        }
    }
    out
}

/// `truth/unit_errors.csv`.
pub fn unit_errors_csv(rows: &[UnitErrorRow]) -> String {
    let mut s = String::from("file,channel,declared_unit,actual_unit,factor\n");
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{}\n",
            r.file, r.channel, r.declared, r.actual, r.factor
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_loads_move_off_the_list_and_scale() {
        let q = QuirksConfig {
            nonstandard_levels: true,
            ..QuirksConfig::default()
        };
        for (lb, want) in [(50.0, 75.0), (250.0, 275.0), (350.0, 400.0), (300.0, 337.5)] {
            assert!(
                (q.load_n(lb * N_PER_LBF) / N_PER_LBF - want).abs() < 1e-9,
                "{lb}"
            );
        }
        let d = QuirksConfig {
            load_scale: 1.15,
            ..QuirksConfig::default()
        };
        assert!((d.load_n(1000.0) - 1150.0).abs() < 1e-9);
        assert_eq!(q.pressures_psi(&[12.0, 10.0]), vec![12.0, 16.0]);
        assert!(QuirksConfig::default().invalid().is_none());
        assert!(QuirksConfig::all().invalid().is_none());
    }
}
