//! The MF 6.1 fitting stage: one Magic Formula 6.1 model per (tire, rim) from every tested
//! inflation pressure, built on the per-pressure PAC2002 fits.
//!
//! In: an [`Mf61Input`]: per tested pressure its clean cornering, drive/brake and combined
//! sweeps (samples with the measured pressure), its PAC2002 fit and its spring-rate results.
//! Out: an [`Mf61Fit`]: the model (`NOMPRES` = [`Mf61Input::nominal_pa`], pressure range the
//! tested one), per-coefficient facts, per-pressure fit quality in sample and out of sample
//! (k-fold by sweep per family, `out_of_sample`, as the PAC2002 stage; with three or more
//! tested pressures also by leaving each pressure out: the whole fit, starting values included,
//! rerun without it, the left-out pressure predicted), per-family solver facts and notes.
//!
//! Method:
//! 1. [`data`]: every sweep collapsed onto a slip grid (up/down branch medians averaged), each
//!    point at its measured pressure, weighted so every sweep counts the same (in the joint `Mz`
//!    family also by its noise level).
//! 2. [`initial`]: the PAC2002 model nearest `NOMPRES` lifted into MF 6.1 (exact where the forms
//!    agree), the pressure terms from the trends of the PAC2002 coefficients across pressures.
//! 3. [`problem`]: each family refined jointly over all pressures (bounded Levenberg-Marquardt,
//!    Huber loss), in the PAC2002 stage's order: `Fy0` (cornering `Fy`), `Mz0` (cornering `Mz`),
//!    `Fx0` (drive/brake `Fx`), combined `Fx`, `Fy`, then `Mz` (every sweep: the `Mz0`
//!    coefficients again with the combined-slip arm `SSZ*`), then `Mx`; its free coefficients are
//!    the family's MF 6.1 coefficients and their pressure terms (linear terms with two pressures,
//!    quadratic ones with three), camber terms only where the data vary the camber (`QBZ5`, on
//!    `|gamma|`, only with inclinations of both signs), load terms only where they vary the
//!    load. `PKY4 = 2`, `PKY5 = PEY5 = 0`, `RBX3 = RBY4 = 0` are held:
//!    the PAC2002 fits they start from have no such terms. A family without data keeps its
//!    lifted values. Shape factors `PCX1`, `PCY1` and peak frictions `|PDX1|`, `|PDY1|` keep the
//!    PAC2002 stage's boxes (`C` in [1, 2.5], `|mu|` in [0.02, 4]). Every refinement (k-fold
//!    and left-out-pressure refits included) holds the PAC2002 stage's physical rules (`E <= 1`,
//!    `Bt > 0`, `Gxa, Gyk > 0`) in MF 6.1's equations over the data's envelope
//!    ([`problem::physical_penalties`]).
//! 4. After `Fx0` and `Fy0`: the peak friction evaluated over the tested envelope (loads,
//!    inclinations, pressures); above the lint's limit (4) the family is refined again with the
//!    friction's pressure terms, then also its load and camber terms, held at 0, and the first
//!    physical result is kept with a note (none physical: a note, and the lint flags the file).
//!
//! 5. Notes: among others, a tested pressure whose per-pressure friction or slip stiffness lies
//!    beyond both neighbouring pressures (`pressure_order_notes`): an optimum between the
//!    tested pressures or a block that differs by more than pressure, which no fit of the
//!    others predicts.
//!
//! Deliberately not here: reading the store, writing files or tables (the `tirebase` crate),
//! relaxation and spring-rate fitting (their per-pressure results are inputs; the relaxation
//! pressure term `PCFX3`/`PCFY3` and `PFZ1` come from their trends in [`initial`]).

pub mod data;
pub mod initial;
mod out_of_sample;
pub mod problem;

#[cfg(test)]
mod tests;
#[cfg(test)]
pub(crate) mod virtual_input;
#[cfg(test)]
mod virtual_round;

use std::collections::BTreeMap;
use std::time::Instant;

use rayon::prelude::*;

use crate::fit::noise_weights::{kind_levels, sweep_factors};
use crate::fit::output::Output;
use crate::fit::pac2002::{self, Family, Levels, SweepKind, combined_slip_box, unidentifiable};
use crate::fit::sweep_folds::OutOfSampleQuality;
use crate::numerics::nonlinear_least_squares::{
    Bounds, FitOutcome, Identifiability, Options, RobustLoss, Termination, minimize,
};
use crate::numerics::stats::count_levels;
use crate::tire_model::factors::slip_factors;
use crate::tire_model::pac2002::load_with;
use crate::tire_model::params::{Coef, Coef::*};
use crate::tire_model::tir::lint::MU_MAX;
use crate::tire_model::{Channel, Evaluation, MagicFormula, Pressures, SlipInput, Version};

pub use data::{CollapseConfig, Mf61Sample, Mf61Sweep, Point};
pub use initial::Pac2002AtPressure;
use problem::{FIT_MODE, FamilyData, Mf61FamilyProblem, Span};

/// One tested pressure.
#[derive(Clone, Debug, PartialEq)]
pub struct PressureGroup {
    /// Nominal pressure of the group, kPa (the key of its PAC2002 file).
    pub pressure_kpa_nom: i64,
    /// Its sweeps (clean: QC and force checks passed).
    pub sweeps: Vec<Mf61Sweep>,
    /// Its PAC2002 fit and spring-rate results (`None`: the group's PAC2002 fit failed; its
    /// sweeps still count).
    pub pac2002: Option<Pac2002AtPressure>,
}

/// Everything one MF 6.1 fit needs.
#[derive(Clone, Debug, PartialEq)]
pub struct Mf61Input {
    /// Tire name (for messages).
    pub tire: String,
    /// Rim width, in.
    pub rim_in: f64,
    /// `NOMPRES` of the model, Pa.
    pub nominal_pa: f64,
    /// The tested pressures, any order.
    pub groups: Vec<PressureGroup>,
}

impl Mf61Input {
    /// The nominal pressure a set of tested pressures (kPa) is referred to: the tested pressure
    /// nearest their mean (the higher on a tie), in Pa.
    pub fn nominal_for(pressures_kpa: &[i64]) -> f64 {
        if pressures_kpa.is_empty() {
            return f64::NAN;
        }
        let mut p: Vec<i64> = pressures_kpa.to_vec();
        p.sort_unstable();
        p.dedup();
        let mean = p.iter().sum::<i64>() as f64 / p.len() as f64;
        let best = p
            .iter()
            .copied()
            .min_by(|a, b| {
                let (da, db) = ((*a as f64 - mean).abs(), (*b as f64 - mean).abs());
                da.total_cmp(&db).then(b.cmp(a))
            })
            .unwrap_or(p[0]);
        best as f64 * 1e3
    }
}

/// Knobs of the stage.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Mf61Config {
    /// How sweeps are collapsed.
    pub collapse: CollapseConfig,
    /// Iteration budget per family refinement (per IRLS round).
    pub max_iterations: usize,
    /// A family refinement (each IRLS round) stops when an accepted step lowers its cost by
    /// less than this fraction. The joint `Mz` step crawls along a flat valley (33 coefficients
    /// over every sweep): a tighter value spends its whole budget on cost changes of 1e-7 and
    /// below, far under the sensor noise.
    pub ftol: f64,
    /// Robust loss of the refinements.
    pub loss: RobustLoss,
    /// Folds of the out-of-sample check (k-fold by sweep, per family: the headline); below 2
    /// it is skipped.
    pub kfold: usize,
    /// Iteration budget of each fold's refit (warm-started from the full fit, one robust-loss
    /// round).
    pub kfold_iterations: usize,
    /// A family whose out-of-sample RMSE exceeds this multiple of its in-sample RMSE (plus
    /// 0.1 % of the channel's peak) is flagged ([`OutOfSampleQuality::oos_flagged`]).
    pub oos_ratio_limit: f64,
    /// With three or more tested pressures, also refit with each pressure left out (the whole
    /// fit, starting values included) and report how well that pressure is predicted.
    pub leave_one_pressure_out: bool,
}

impl Default for Mf61Config {
    fn default() -> Self {
        Mf61Config {
            collapse: CollapseConfig::default(),
            max_iterations: 100,
            ftol: 1e-6,
            loss: RobustLoss::Huber { k: 2.0 },
            kfold: 5,
            kfold_iterations: 20,
            oos_ratio_limit: 1.2,
            leave_one_pressure_out: true,
        }
    }
}

/// Relative cost change per accepted step below which a left-out-pressure refit stops: it is
/// a check, whose RMSE needs no more digits than its ratio to the model's (at 1e-6 the joint
/// `Mz` step crawls along a narrow valley: most of its iterations lower the cost by under
/// 0.1 % together).
const CHECK_FTOL: f64 = 1e-5;

/// The measured output `family` is fitted to on sweeps of `kind`, `None` for sweeps it does
/// not read. `Mz` reads every sweep: the `Mz0` coefficients (trail, residual torque, `PPZ*`)
/// and the arm `SSZ*` of combined slip are refined jointly.
fn reads(family: Family, kind: SweepKind) -> Option<Output> {
    use SweepKind::*;
    match (family, kind) {
        (Family::Fy0, Cornering) => Some(Output::Fy),
        (Family::Mz0, Cornering) => Some(Output::Mz),
        (Family::Fx0, DriveBrake) => Some(Output::Fx),
        (Family::Fx, Combined) => Some(Output::Fx),
        (Family::Fy, Combined) => Some(Output::Fy),
        (Family::Mz, _) => Some(Output::Mz),
        (Family::Mx, _) => Some(Output::Mx),
        _ => None,
    }
}

/// The pure-slip data each tested pressure carries, which the families fitted on top of them
/// need at that same pressure: combined `Fx` needs `Fx0` (drive/brake sweeps), combined `Fy`
/// and `Mx` on slip-ratio sweeps need `Fy0` (cornering sweeps), `Mz` on slip-ratio sweeps
/// needs both (its trail and residual torque come from `Fy0` / `Mz0`, its arm multiplies `Fx`).
/// A family reads a pressure's points only when that pressure carries what it needs (as the
/// PAC2002 stage leaves `Fy`, `Mz`, `Mx` out of a drive/brake-only group): fitted against another
/// family's unmeasured start, its coefficients would absorb that family's error instead of
/// describing their own effect.
#[derive(Clone, Debug, Default, PartialEq)]
struct PureData {
    /// Groups with cornering `Fy` points.
    lateral: std::collections::BTreeSet<usize>,
    /// Groups with drive/brake `Fx` points.
    longitudinal: std::collections::BTreeSet<usize>,
}

impl PureData {
    fn of(points: &[Point]) -> PureData {
        let mut d = PureData::default();
        for p in points {
            let has = |o: Output| p.values[o as usize].is_finite() && p.weights[o as usize] > 0.0;
            match p.kind {
                SweepKind::Cornering if has(Output::Fy) => {
                    d.lateral.insert(p.group);
                }
                SweepKind::DriveBrake if has(Output::Fx) => {
                    d.longitudinal.insert(p.group);
                }
                _ => {}
            }
        }
        d
    }

    /// Whether `family` may read the points of `group`'s sweeps of `kind`.
    fn allows(&self, family: Family, kind: SweepKind, group: usize) -> bool {
        let lat = self.lateral.contains(&group);
        let lon = self.longitudinal.contains(&group);
        match (family, kind) {
            (Family::Fy0 | Family::Mz0 | Family::Fx0, _) => true,
            (Family::Mz | Family::Mx, SweepKind::Cornering) => true,
            (Family::Fx, _) => lon,
            (Family::Fy | Family::Mx, _) => lat,
            (Family::Mz, _) => lat && lon,
            (Family::My, _) => false,
        }
    }

    /// What `family` needs at a pressure, for notes.
    fn need(family: Family) -> &'static str {
        match family {
            Family::Fy0 | Family::Mz0 | Family::Fx0 | Family::My => "",
            Family::Fx => "drive/brake sweeps (Fx0)",
            Family::Fy | Family::Mx => "cornering sweeps (Fy0)",
            Family::Mz => "cornering (Fy0, Mz0) and drive/brake (Fx0) sweeps",
        }
    }
}

/// What the data vary.
#[derive(Copy, Clone, Debug, PartialEq)]
struct Variation {
    pressures: usize,
    loads: bool,
    cambers: usize,
    /// Inclinations on both sides of zero (beyond the level tolerance): otherwise `|gamma|` is
    /// `gamma` (or `-gamma`) on every point and `QBZ5` cannot be told from `QBZ4`, the rule
    /// the PAC2002 stage applies (`pac2002::family::unidentifiable`).
    camber_both_signs: bool,
}

/// The free coefficients of a family given what the data vary.
fn free_coefficients(family: Family, v: Variation) -> Vec<Coef> {
    let camber = v.cambers >= 2;
    let camber2 = v.cambers >= 3;
    let lin = v.pressures >= 2;
    let quad = v.pressures >= 3;
    let mut out: Vec<Coef> = Vec::new();
    let mut add = |cs: &[Coef], when: bool| {
        if when {
            out.extend_from_slice(cs);
        }
    };
    match family {
        Family::Fy0 => {
            add(&[PCY1, PDY1, PEY1, PEY3, PKY1, PHY1, PVY1], true);
            add(&[PDY2, PEY2, PKY2, PHY2, PVY2], v.loads);
            add(&[PDY3, PEY4, PKY3, PVY3, PKY6], camber);
            add(&[PVY4, PKY7], camber && v.loads);
            add(&[PPY1, PPY3], lin);
            add(&[PPY2, PPY4], quad);
            add(&[PPY5], lin && camber);
        }
        Family::Mz0 => {
            add(
                &[QBZ1, QBZ9, QBZ10, QCZ1, QDZ1, QDZ6, QEZ1, QEZ4, QHZ1],
                true,
            );
            add(&[QBZ2, QBZ3, QDZ2, QDZ7, QEZ2, QEZ3, QHZ2], v.loads);
            add(&[QBZ4, QDZ3, QDZ4, QDZ8, QEZ5, QHZ3], camber);
            add(&[QBZ5], camber && v.camber_both_signs);
            add(&[QDZ9, QHZ4], camber && v.loads);
            add(&[QDZ10], camber2);
            add(&[QDZ11], camber2 && v.loads);
            add(&[PPZ1], lin);
            add(&[PPZ2], lin && camber);
        }
        Family::Fx0 => {
            add(&[PCX1, PDX1, PEX1, PEX4, PKX1, PHX1, PVX1], true);
            add(&[PDX2, PEX2, PEX3, PKX2, PKX3, PHX2, PVX2], v.loads);
            add(&[PDX3], camber);
            add(&[PPX1, PPX3], lin);
            add(&[PPX2, PPX4], quad);
        }
        Family::Fx => add(&[RBX1, RBX2, RCX1, REX1, RHX1], true),
        Family::Fy => {
            add(
                &[RBY1, RBY2, RBY3, RCY1, REY1, RHY1, RVY1, RVY4, RVY5, RVY6],
                true,
            );
            add(&[REY2, RHY2, RVY2], v.loads);
            add(&[RVY3], camber);
        }
        Family::Mz => {
            // The trail and residual-torque coefficients with the s Fx arm, on every sweep:
            // MF 6.x's combined-slip Mz takes its trail force at zero camber (Fy' = Gyk
            // Fy0(gamma = 0)) and its residual torque at an equivalent slip angle, so the Mz0
            // coefficients chosen on cornering sweeps alone need not carry over to slip-ratio
            // sweeps, and the arm alone cannot make up for them.
            add(&free_coefficients(Family::Mz0, v), true);
            add(&[SSZ1, SSZ2], true);
            add(&[SSZ3], camber);
            add(&[SSZ4], camber && v.loads);
        }
        Family::Mx => {
            add(&[QSX1, QSX3], true);
            add(&[QSX2], camber);
            add(&[PPMX1], lin && camber);
        }
        Family::My => {}
    }
    out
}

/// The pressure terms of a family.
fn pressure_terms(family: Family) -> &'static [Coef] {
    match family {
        Family::Fy0 => &[PPY1, PPY2, PPY3, PPY4, PPY5],
        Family::Mz0 | Family::Mz => &[PPZ1, PPZ2],
        Family::Fx0 => &[PPX1, PPX2, PPX3, PPX4],
        Family::Mx => &[PPMX1],
        Family::Fx | Family::Fy | Family::My => &[],
    }
}

/// Box bounds of a coefficient in the refinement. `reference` (the start's value, or the fitted
/// value, which keeps that sign) orients the signed boxes of the friction coefficients.
///
/// The shape and friction boxes are the PAC2002 stage's: below `C = 1` the curve never reaches
/// `D` (at `C` it tends to `D sin(C pi / 2)`), so a refinement on sweeps that do not reach the
/// friction peak trades `C` down against `D` up without bound, and `D` stops being the peak
/// friction the file claims. The combined-slip weighting terms have the PAC2002 stage's boxes
/// too (`pac2002::combined_slip_box`).
fn bounds_of(c: Coef, reference: f64) -> (f64, f64) {
    if let Some((lo, hi, _)) = combined_slip_box(c) {
        return (lo, hi);
    }
    let signed = |lo: f64, hi: f64| {
        if reference < 0.0 {
            (-hi, -lo)
        } else {
            (lo, hi)
        }
    };
    match c {
        PCY1 | PCX1 => (1.0, 2.5),
        QCZ1 => (0.3, 4.0),
        PDY1 | PDX1 => signed(MU_MIN, MU_MAX),
        PPX1 | PPX2 | PPX3 | PPX4 | PPY1 | PPY2 | PPY3 | PPY4 | PPY5 | PPZ1 | PPZ2 | PPMX1 => {
            (-5.0, 5.0)
        }
        _ => (f64::NEG_INFINITY, f64::INFINITY),
    }
}

/// Smallest `|PDX1|`, `|PDY1|` of the refinement: a tire without grip is no tire.
const MU_MIN: f64 = 0.02;

/// Why a fitted coefficient sits on its bound of the refinement (`bounds_of`) and what that
/// bound means; `None` for a coefficient without bounds.
pub fn bound_note(c: Coef, value: f64) -> Option<String> {
    let (lo, hi) = bounds_of(c, value);
    let why = match c {
        _ if combined_slip_box(c).is_some() => combined_slip_box(c)?.2,
        PCY1 | PCX1 => {
            "shape factor C in [1, 2.5]; at 1 the sweeps do not reach the friction peak and D \
             is the force's asymptote (below 1 the peak factor would grow without bound); at \
             2.5 the force reverses after its peak"
        }
        QCZ1 => "shape factor in [0.3, 4], the refinement's box",
        PDY1 | PDX1 => {
            "peak friction |mu| at FNOMIN and NOMPRES in [0.02, 4]: beyond 4 not physical (the \
             lint's limit)"
        }
        PPX1 | PPX2 | PPX3 | PPX4 | PPY1 | PPY2 | PPY3 | PPY4 | PPY5 | PPZ1 | PPZ2 | PPMX1 => {
            "pressure term within 5 per unit of dpi = (P - NOMPRES) / NOMPRES: steeper would \
             change its factor by more than 100 % over a 20 % pressure change"
        }
        _ => return None,
    };
    Some(pac2002::bound_note(c, value, (lo, hi, why)))
}

/// Solver facts of one family.
#[derive(Clone, Debug, PartialEq)]
pub struct FamilyOutcome {
    /// The family.
    pub family: Family,
    /// Points it was refined on.
    pub n: usize,
    /// Free coefficients.
    pub free: Vec<Coef>,
    /// RMSE of the starting values on those points (N or N m).
    pub initial_rmse: f64,
    /// RMSE after the refinement.
    pub rmse: f64,
    /// Solver trial steps.
    pub iterations: usize,
    /// Why the solver stopped.
    pub termination: Termination,
    /// Model evaluations.
    pub evaluations: usize,
    /// Wall time, s.
    pub seconds: f64,
    /// Rank and condition of the data Jacobian at the refinement's solution.
    pub identifiability: Identifiability,
    /// The refinement was kept (not worse than its start).
    pub accepted: bool,
}

/// One coefficient of the written model.
#[derive(Clone, Debug, PartialEq)]
pub struct Mf61Coefficient {
    /// The coefficient.
    pub coef: Coef,
    /// Its family (`None` for scalars, pressures, vertical and relaxation keys).
    pub family: Option<Family>,
    /// Value, SI.
    pub value: f64,
    /// Standard error from the joint refinement (`None` unless fitted and off its bounds).
    pub std_error: Option<f64>,
    /// On a bound of the refinement.
    pub at_bound: bool,
    /// `fitted`, `fixed` (the tested levels cannot determine it: held at its start, `note`
    /// says why), `start` (from the PAC2002 fits: lifted or their pressure trend, not
    /// refined), `placeholder` (the rolling resistance terms `QSY1..QSY8`: TTC records no
    /// `My`).
    pub origin: &'static str,
    /// Why a `fixed` coefficient is held.
    pub note: Option<String>,
}

/// Fit quality at one tested pressure and output.
#[derive(Clone, Debug, PartialEq)]
pub struct PressureQuality {
    /// The tested pressure, kPa.
    pub pressure_kpa_nom: i64,
    /// The output.
    pub output: Output,
    /// Collapsed points.
    pub n: usize,
    /// In-sample RMSE (N or N m).
    pub rmse: f64,
    /// `rmse` relative to the largest `|value|` among the points, %.
    pub rmse_pct_of_peak: f64,
    /// Coefficient of determination.
    pub r2: f64,
    /// RMSE of the model fitted without this pressure (`None` with fewer than three tested
    /// pressures or without the check).
    pub lopo_rmse: Option<f64>,
    /// `lopo_rmse` relative to the same peak, %.
    pub lopo_rmse_pct_of_peak: Option<f64>,
}

/// Fit quality of one family at one tested pressure: the family's channel evaluated on the
/// collapsed points of that pressure's sweeps the family reads (cornering sweeps for `Fy0` and
/// `Mz0`, drive/brake for `Fx0`, combined for `Fx`, `Fy`, all for `Mz` and `Mx`; slip-ratio
/// sweeps only at pressures that also carry the pure-slip data the family needs), so a row
/// compares with the PAC2002 fit of that pressure.
#[derive(Clone, Debug, PartialEq)]
pub struct FamilyQuality {
    /// The tested pressure, kPa.
    pub pressure_kpa_nom: i64,
    /// The family.
    pub family: Family,
    /// Collapsed points.
    pub n: usize,
    /// In-sample RMSE (N or N m).
    pub rmse: f64,
    /// `rmse` relative to the largest `|value|` among the points, %.
    pub rmse_pct_of_peak: f64,
    /// Coefficient of determination.
    pub r2: f64,
    /// RMSE of this pressure's points predicted k-fold by sweep (each by the family refitted
    /// without its sweep; `None` for a family not refined, with fewer than two sweeps or
    /// `kfold < 2`).
    pub oos_rmse: Option<f64>,
    /// Folds of `oos_rmse` (0 without it).
    pub oos_folds: usize,
    /// Points of this pressure `oos_rmse` is over (0 without it).
    pub oos_n: usize,
    /// Folds whose training sweeps could not determine the family's coefficients.
    pub oos_deficient_folds: usize,
    /// RMSE of the model fitted without this pressure (`None` with fewer than three tested
    /// pressures or without the check).
    pub lopo_rmse: Option<f64>,
}

impl FamilyQuality {
    /// `lopo_rmse / rmse` (NaN without the check).
    pub fn lopo_ratio(&self) -> f64 {
        self.lopo_rmse.map_or(f64::NAN, |o| o / self.rmse)
    }
}

impl OutOfSampleQuality for FamilyQuality {
    fn rmse(&self) -> f64 {
        self.rmse
    }
    fn rmse_pct_of_peak(&self) -> f64 {
        self.rmse_pct_of_peak
    }
    fn oos_rmse(&self) -> Option<f64> {
        self.oos_rmse
    }
    fn oos_folds(&self) -> usize {
        self.oos_folds
    }
    fn oos_deficient_folds(&self) -> usize {
        self.oos_deficient_folds
    }
}

/// The stage's result.
#[derive(Clone, Debug, PartialEq)]
pub struct Mf61Fit {
    /// The fitted MF 6.1 model (SI).
    pub model: MagicFormula,
    /// Every coefficient of the model.
    pub coefficients: Vec<Mf61Coefficient>,
    /// Per tested pressure and output.
    pub quality: Vec<PressureQuality>,
    /// Per tested pressure and family (in pressure, then fit order).
    pub family_quality: Vec<FamilyQuality>,
    /// Per family, in fit order.
    pub families: Vec<FamilyOutcome>,
    /// What the model could not carry, what was held.
    pub notes: Vec<String>,
    /// Model evaluations over all families (the full fit, not the out-of-sample refits).
    pub evaluations: usize,
    /// Model evaluations of the k-fold refits.
    pub kfold_evaluations: usize,
    /// Wall time of the k-fold refits, s.
    pub kfold_seconds: f64,
    /// Wall time of the whole stage including the out-of-sample refits, s.
    pub seconds: f64,
    /// The tested pressure (kPa) whose PAC2002 model the start was lifted from
    /// ([`initial::reference`]): what a coefficient of origin `start` without a pressure trend
    /// (`BREFF`, `DREFF`, `FREFF`, ..) holds is that model's value.
    pub start_reference_kpa: i64,
}

/// Bad input.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Mf61Error {
    /// No group has a PAC2002 fit to start from.
    #[error("{tire} on {rim_in} in rim: no tested pressure has a PAC2002 fit to start from")]
    NoStart {
        /// Tire.
        tire: String,
        /// Rim, in.
        rim_in: f64,
    },
    /// The nominal pressure is not positive.
    #[error("{tire}: nominal pressure {value} Pa is not positive")]
    BadNominal {
        /// Tire.
        tire: String,
        /// The value.
        value: f64,
    },
}

/// The fit of one data set (no quality): start, then every family.
struct Fitted {
    model: MagicFormula,
    families: Vec<FamilyOutcome>,
    std_errors: Vec<(Coef, Option<f64>, bool, Family)>,
    /// Coefficients the data's levels cannot determine, held at their start: why.
    held: Vec<(Coef, Family, String)>,
    notes: Vec<String>,
}

fn family_data(points: &[Point], family: Family, pure: &PureData) -> FamilyData {
    family_data_scaled(points, family, pure, |_| 1.0)
}

/// The `Mz` family's data with cornering and slip-ratio sweeps weighing the same in total (each
/// sweep already weighs the same relative to its peak; there are more slip-ratio sweeps than
/// cornering ones, which would otherwise pull the trail and residual torque away from the
/// cornering sweeps that `Mz0` was fitted on), and each sweep weighed by its noise
/// ([`sweep_factors`] of [`kind_levels`] of its Mz scatter: the drive/brake and combined
/// sweeps of a real round can carry ten times the cornering sweeps' scatter; kinds of equal
/// noise keep factor 1).
fn mz_data(points: &[Point], pure: &PureData) -> FamilyData {
    let family = Family::Mz;
    let mz = Output::Mz as usize;
    let mut sweeps = [
        std::collections::BTreeSet::new(),
        std::collections::BTreeSet::new(),
    ];
    // Per sweep: its kind and Mz scatter.
    let mut levels: BTreeMap<usize, (SweepKind, Option<f64>)> = Default::default();
    let mut peak = 0.0f64;
    for p in points {
        if p.value(Output::Mz).is_finite() && pure.allows(family, p.kind, p.group) {
            sweeps[usize::from(p.kind != SweepKind::Cornering)].insert(p.sweep);
            levels.insert(
                p.sweep,
                (p.kind, Some(p.scatter[mz]).filter(|v| v.is_finite())),
            );
            peak = peak.max(p.value(Output::Mz).abs());
        }
    }
    let (cornering, slip_ratio) = (sweeps[0].len() as f64, sweeps[1].len() as f64);
    let scale = if cornering > 0.0 && slip_ratio > 0.0 {
        (slip_ratio / cornering).sqrt()
    } else {
        1.0
    };
    let level_list: Vec<(SweepKind, Option<f64>)> = levels.values().copied().collect();
    let noise: BTreeMap<usize, f64> = levels
        .keys()
        .copied()
        .zip(sweep_factors(&kind_levels(&level_list), peak))
        .collect();
    family_data_scaled(points, family, pure, |p| {
        let kind = if p.kind == SweepKind::Cornering {
            scale
        } else {
            1.0
        };
        kind * noise.get(&p.sweep).copied().unwrap_or(1.0)
    })
}

fn family_data_scaled(
    points: &[Point],
    family: Family,
    pure: &PureData,
    scale: impl Fn(&Point) -> f64,
) -> FamilyData {
    let mut d = FamilyData::default();
    for p in points {
        let Some(out) = reads(family, p.kind) else {
            continue;
        };
        if !pure.allows(family, p.kind, p.group) {
            continue;
        }
        d.push_output(p, out, p.weights[out as usize] * scale(p));
    }
    d
}

/// Root mean square of `model`'s `channel` minus the measured values of `d` (unweighted; NaN
/// without points).
pub fn rmse_of(model: &MagicFormula, channel: Channel, d: &FamilyData) -> f64 {
    if d.is_empty() {
        return f64::NAN;
    }
    let mut v = vec![0.0; d.len()];
    model.channel_into_at(
        channel,
        &d.inputs,
        Pressures::PerPoint(&d.pressures),
        FIT_MODE,
        &mut v,
    );
    (v.iter()
        .zip(&d.measured)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        / d.len() as f64)
        .sqrt()
}

/// The refinement's box ([`bounds_of`]) of each of `free`, oriented by `model`'s values.
fn refinement_bounds(model: &MagicFormula, free: &[Coef]) -> Bounds {
    let (lower, upper) = free.iter().map(|c| bounds_of(*c, model.coefs[*c])).unzip();
    Bounds { lower, upper }
}

/// One family's bounded refinement of `free` from `model`: the solver's outcome and the model
/// at its solution.
fn refine(
    model: &MagicFormula,
    free: &[Coef],
    channel: Channel,
    data: &FamilyData,
    cfg: &Mf61Config,
) -> (FitOutcome, MagicFormula) {
    let problem = Mf61FamilyProblem::new(model, free, channel, data);
    let bounds = refinement_bounds(model, free);
    let start: Vec<f64> = free.iter().map(|c| model.coefs[*c]).collect();
    let options = Options {
        max_iterations: cfg.max_iterations,
        ftol: cfg.ftol,
        loss: cfg.loss,
        ..Options::default()
    };
    let outcome = minimize(&problem, &start, &bounds, &options);
    let candidate = problem.model_at(&outcome.params);
    (outcome, candidate)
}

/// The friction terms a repair holds at their neutral value 0, in the order tried (each set
/// includes the previous): the pressure terms of the peak friction, then its load and camber
/// terms too.
fn neutral_friction_terms(family: Family) -> [&'static [Coef]; 2] {
    match family {
        Family::Fx0 => [&[PPX3, PPX4], &[PPX3, PPX4, PDX2, PDX3]],
        Family::Fy0 => [&[PPY3, PPY4], &[PPY3, PPY4, PDY2, PDY3]],
        _ => [&[], &[]],
    }
}

/// Where the peak friction of `family` (`mu_x` for `Fx0`, `mu_y` for `Fy0`) exceeds the lint's
/// [`MU_MAX`] over the envelope the family's data span ([`Span`]: loads, inclinations and
/// measured pressures widened to the model's declared ranges, as the lint samples them;
/// 9 x 3 x 3 points, corners included): the worst, described; `None` when it stays within it
/// or for other families.
fn friction_above_limit(model: &MagicFormula, family: Family, data: &FamilyData) -> Option<String> {
    if !matches!(family, Family::Fx0 | Family::Fy0) {
        return None;
    }
    let span = Span::of(model, data)?;
    let (fz, gamma, p) = (span.fz, span.gamma, span.p);
    let at = |r: (f64, f64), i: usize, n: usize| r.0 + (r.1 - r.0) * i as f64 / (n - 1) as f64;
    let mut worst: Option<(f64, f64, f64, f64)> = None;
    for i in 0..9 {
        for j in 0..3 {
            for k in 0..3 {
                let input = SlipInput {
                    fz_n: at(fz, i, 9),
                    kappa: 0.0,
                    alpha_rad: 0.0,
                    gamma_rad: at(gamma, j, 3),
                    vx_mps: span.vx,
                };
                let p_pa = at(p, k, 3);
                let l = load_with(&model.coefs, &input, FIT_MODE, Version::Mf61, p_pa);
                let f = slip_factors(&model.coefs, &l);
                let mu = if family == Family::Fx0 { f.mux } else { f.muy };
                if !mu.is_finite() || mu.abs() > MU_MAX {
                    let m = if mu.is_finite() {
                        mu.abs()
                    } else {
                        f64::INFINITY
                    };
                    if worst.is_none_or(|w| m > w.0) {
                        worst = Some((m, input.fz_n, input.gamma_rad, p_pa));
                    }
                }
            }
        }
    }
    worst.map(|(mu, fz, gamma, p)| {
        format!(
            "|mu_{}| {mu:.2} > {MU_MAX} at Fz {fz:.0} N, inclination {:.2} deg, {:.1} kPa",
            if family == Family::Fx0 { "x" } else { "y" },
            gamma.to_degrees(),
            p / 1e3
        )
    })
}

fn fit_points(
    models: &[Pac2002AtPressure],
    points: &[Point],
    nominal_pa: f64,
    pressures_pa: (f64, f64),
    cfg: &Mf61Config,
) -> Fitted {
    let start = initial::start(models, nominal_pa);
    let mut model = MagicFormula::with_version(start.coefs, Version::Mf61);
    model.coefs[PRESMIN] = pressures_pa.0;
    model.coefs[PRESMAX] = pressures_pa.1;
    let mut notes = start.notes;
    let mut families = Vec::new();
    let mut std_errors = Vec::new();
    let mut held = Vec::new();
    let pure = PureData::of(points);
    // `My` is not refined: TTC records no rolling resistance moment, so its coefficients keep
    // their lifted values.
    for family in Family::MEASURED {
        let started = Instant::now();
        let data = if family == Family::Mz {
            mz_data(points, &pure)
        } else {
            family_data(points, family, &pure)
        };
        let mut left_out: Vec<usize> = points
            .iter()
            .filter(|p| {
                reads(family, p.kind).is_some_and(|o| {
                    p.values[o as usize].is_finite() && p.weights[o as usize] > 0.0
                }) && !pure.allows(family, p.kind, p.group)
            })
            .map(|p| p.group)
            .collect();
        left_out.sort_unstable();
        left_out.dedup();
        if !left_out.is_empty() {
            let kpa: Vec<String> = left_out
                .iter()
                .filter_map(|g| {
                    points
                        .iter()
                        .find(|p| p.group == *g)
                        .map(|p| format!("{:.0}", p.p_pa / 1e3))
                })
                .collect();
            notes.push(format!(
                "{}: {} at {} kPa (measured) not fitted: the family needs {} at the same \
                 pressure{}",
                family.as_str(),
                match family {
                    Family::Mz | Family::Mx => "the slip-ratio sweeps",
                    _ => "the combined sweeps",
                },
                kpa.join(" / "),
                PureData::need(family),
                if data.len() < 8 {
                    "; not refined (its coefficients keep the values lifted from the PAC2002 fits)"
                } else {
                    ""
                }
            ));
        }
        if data.len() < 8 {
            continue;
        }
        // Without slip-ratio sweeps the joint Mz refinement would only repeat Mz0 (the arm
        // SSZ* multiplies Fx, which is zero there).
        if family == Family::Mz
            && !points.iter().any(|p| {
                p.kind != SweepKind::Cornering
                    && p.value(Output::Mz).is_finite()
                    && pure.allows(family, p.kind, p.group)
            })
        {
            continue;
        }
        // Pressure levels are the tested pressures (groups), not the measured values: a group's
        // measured pressure wanders by a few kPa, which would otherwise count as extra levels
        // and free the quadratic pressure terms on two tested pressures.
        // The points the family is fitted on.
        let fitted_on = |p: &&Point| {
            pure.allows(family, p.kind, p.group)
                && reads(family, p.kind).is_some_and(|o| {
                    p.values[o as usize].is_finite() && p.weights[o as usize] > 0.0
                })
        };
        let levels: std::collections::BTreeSet<usize> =
            points.iter().filter(fitted_on).map(|p| p.group).collect();
        let camber_tol = 0.25_f64.to_radians();
        let variation = Variation {
            pressures: levels.len(),
            loads: count_levels(
                data.inputs.iter().map(|p| p.fz_n),
                0.1 * model.coefs[FNOMIN],
            ) >= 2,
            cambers: count_levels(data.inputs.iter().map(|p| p.gamma_rad), camber_tol),
            camber_both_signs: data.inputs.iter().any(|p| p.gamma_rad > camber_tol)
                && data.inputs.iter().any(|p| p.gamma_rad < -camber_tol),
        };
        let mut free = free_coefficients(family, variation);
        // The PAC2002 stage's rule on what the tested levels cannot determine (a shift of the
        // combined-slip weighting with slip angles of one sign only, a load curvature from two
        // loads, ...): such a coefficient keeps its start value, and its row says why.
        let tested = levels_of(
            points.iter().filter(fitted_on),
            points.iter().filter(|p| p.kind != SweepKind::Cornering),
            0.1 * model.coefs[FNOMIN],
        );
        free.retain(|c| match unidentifiable(*c, &tested) {
            Some(why) => {
                // Fitted on an earlier family's data, it keeps that fit's value and row.
                if !std_errors.iter().any(|s: &(Coef, _, _, _)| s.0 == *c)
                    && !held.iter().any(|h: &(Coef, _, _)| h.0 == *c)
                {
                    held.push((*c, family, why));
                }
                false
            }
            None => true,
        });
        // A pressure term the family's data cannot determine (its sweeps at fewer tested
        // pressures than the term needs) is 0, not the start's trend: that trend may come from
        // a pressure whose PAC2002 fit had no data for the family (its defaults).
        for term in pressure_terms(family) {
            if !free.contains(term) && model.coefs[*term] != 0.0 {
                notes.push(format!(
                    "{}: {} = 0 ({} tested pressure(s) with data for the family)",
                    family.as_str(),
                    term.name(),
                    variation.pressures
                ));
                model.coefs[*term] = 0.0;
            }
        }
        let channel = family.channel();
        let initial_rmse = rmse_of(&model, channel, &data);
        let (mut outcome, mut candidate) = refine(&model, &free, channel, &data, cfg);
        let mut rmse = rmse_of(&candidate, channel, &data);
        // A peak friction above the lint's limit inside the tested envelope: the friction's
        // load, camber and pressure terms were pulled beyond what the data hold (typically
        // sweeps that stop short of the friction peak, where D is an asymptote). Refine again
        // with those terms held neutral, the pressure terms first, and keep the first physical
        // result; otherwise keep the refinement and say so (the written file's lint flags it).
        let mut repaired_friction = false;
        if let Some(worst) = friction_above_limit(&candidate, family, &data) {
            let mut repaired = None;
            for held in neutral_friction_terms(family) {
                let held: Vec<Coef> = held.iter().copied().filter(|c| free.contains(c)).collect();
                if held.is_empty() {
                    continue;
                }
                let mut base = model.clone();
                held.iter().for_each(|c| base.coefs[*c] = 0.0);
                let kept: Vec<Coef> = free.iter().copied().filter(|c| !held.contains(c)).collect();
                let (o, m) = refine(&base, &kept, channel, &data, cfg);
                let r = rmse_of(&m, channel, &data);
                if r.is_finite() && friction_above_limit(&m, family, &data).is_none() {
                    repaired = Some((o, m, r, kept, held));
                    break;
                }
            }
            match repaired {
                Some((o, m, r, kept, held)) => {
                    notes.push(format!(
                        "{}: peak friction {worst} within the tested envelope; refined again with \
                         {} held at 0: RMSE {rmse:.2} -> {r:.2}",
                        family.as_str(),
                        held.iter().map(|c| c.name()).collect::<Vec<_>>().join(", ")
                    ));
                    (outcome, candidate, rmse, free) = (o, m, r, kept);
                    repaired_friction = true;
                }
                None => notes.push(format!(
                    "{}: peak friction {worst} within the tested envelope, also with its load, \
                     camber and pressure terms held at 0",
                    family.as_str()
                )),
            }
        }
        // Keep the refinement only if it did not make the family worse (a diverged or
        // non-finite start keeps the lifted values), or if it repaired a friction above the
        // limit that the start has too (the start's lower RMSE is then no reason to keep it).
        let accepted = rmse.is_finite()
            && (initial_rmse.is_nan()
                || rmse <= initial_rmse
                || (repaired_friction && friction_above_limit(&model, family, &data).is_some()));
        if accepted {
            model = candidate;
            for (j, c) in free.iter().enumerate() {
                std_errors.push((*c, outcome.std_errors[j], outcome.at_bounds[j], family));
            }
            held.retain(|h| !free.contains(&h.0));
        } else {
            notes.push(format!(
                "{}: refinement rejected (RMSE {rmse:.4} vs start {initial_rmse:.4}); the values \
                 lifted from the PAC2002 fits are kept",
                family.as_str()
            ));
        }
        families.push(FamilyOutcome {
            family,
            n: data.len(),
            free,
            initial_rmse,
            rmse: if accepted { rmse } else { initial_rmse },
            iterations: outcome.iterations,
            termination: outcome.termination,
            evaluations: outcome.evaluations,
            seconds: started.elapsed().as_secs_f64(),
            identifiability: outcome.identifiability,
            accepted,
        });
    }
    Fitted {
        model,
        families,
        std_errors,
        held,
        notes,
    }
}

/// The tested levels (`pac2002::Levels`) of a family's points, one level per sweep (its mean
/// load, inclination and slip angle): loads within `load_tol` N and angles within 0.25 deg are
/// one level. Slip-angle levels count the slip-ratio sweeps `slip_ratio` (0 included).
fn levels_of<'a>(
    family: impl Iterator<Item = &'a Point>,
    slip_ratio: impl Iterator<Item = &'a Point>,
    load_tol: f64,
) -> Levels {
    let angle_tol = 0.25_f64.to_radians();
    let own = sweep_means(family);
    let slips = sweep_means(slip_ratio);
    let gammas = || own.iter().map(|s| s.1[1]);
    let combined = || {
        slips
            .iter()
            .filter(|s| s.0 == SweepKind::Combined)
            .map(|s| s.1[2])
    };
    Levels {
        loads: count_levels(own.iter().map(|s| s.1[0]), load_tol),
        cambers: count_levels(gammas(), angle_tol),
        camber_both_signs: gammas().any(|g| g > angle_tol) && gammas().any(|g| g < -angle_tol),
        alphas: count_levels(slips.iter().map(|s| s.1[2].abs()), angle_tol),
        alpha_both_signs: combined().any(|a| a > angle_tol) && combined().any(|a| a < -angle_tol),
    }
}

/// Per sweep of `points`: its kind and mean `(Fz, gamma, alpha)`.
fn sweep_means<'a>(points: impl Iterator<Item = &'a Point>) -> Vec<(SweepKind, [f64; 3])> {
    let mut sums: BTreeMap<usize, (SweepKind, [f64; 3], f64)> = BTreeMap::new();
    for p in points {
        let e = sums.entry(p.sweep).or_insert((p.kind, [0.0; 3], 0.0));
        e.1[0] += p.input.fz_n;
        e.1[1] += p.input.gamma_rad;
        e.1[2] += p.input.alpha_rad;
        e.2 += 1.0;
    }
    sums.into_values()
        .map(|(kind, s, n)| (kind, s.map(|v| v / n)))
        .collect()
}

/// Per output at one group: (n, rmse, peak, r2).
fn group_quality(
    model: &MagicFormula,
    points: &[Point],
    group: usize,
) -> Vec<(Output, usize, f64, f64, f64)> {
    let pts: Vec<&Point> = points.iter().filter(|p| p.group == group).collect();
    if pts.is_empty() {
        return Vec::new();
    }
    let inputs: Vec<_> = pts.iter().map(|p| p.input).collect();
    let pressures: Vec<f64> = pts.iter().map(|p| p.p_pa).collect();
    let mut evals = vec![Evaluation::default(); pts.len()];
    model.eval_batch_at(
        &inputs,
        Pressures::PerPoint(&pressures),
        FIT_MODE,
        &mut evals,
    );
    let mut out = Vec::new();
    for o in Output::ALL {
        let k = o as usize;
        let pairs: Vec<(f64, f64)> = pts
            .iter()
            .zip(&evals)
            .filter(|(p, _)| p.values[k].is_finite())
            .map(|(p, e)| {
                let m = match o {
                    Output::Fx => e.fx_n,
                    Output::Fy => e.fy_n,
                    Output::Mz => e.mz_nm,
                    Output::Mx => e.mx_nm,
                };
                (m, p.values[k])
            })
            .collect();
        if pairs.is_empty() {
            continue;
        }
        let (n, rmse, peak, r2) = agreement(pairs.iter().copied());
        out.push((o, n, rmse, peak, r2));
    }
    out
}

/// Per family at one group: (family, n, rmse, peak, r2).
fn group_family_quality(
    model: &MagicFormula,
    points: &[Point],
    group: usize,
) -> Vec<(Family, usize, f64, f64, f64)> {
    let pts: Vec<Point> = points
        .iter()
        .filter(|p| p.group == group)
        .copied()
        .collect();
    let pure = PureData::of(&pts);
    let mut out = Vec::new();
    for family in Family::MEASURED {
        let d = family_data(&pts, family, &pure);
        if d.is_empty() {
            continue;
        }
        let mut v = vec![0.0; d.len()];
        model.channel_into_at(
            family.channel(),
            &d.inputs,
            Pressures::PerPoint(&d.pressures),
            FIT_MODE,
            &mut v,
        );
        let (n, rmse, peak, r2) = agreement(v.iter().copied().zip(d.measured.iter().copied()));
        out.push((family, n, rmse, peak, r2));
    }
    out
}

/// How a model agrees with measurements, from (model, measured) pairs (at least one): the count,
/// the RMSE, the peak `|measured|` and `R^2` (NaN when the measurements do not vary).
fn agreement(pairs: impl Iterator<Item = (f64, f64)> + Clone) -> (usize, f64, f64, f64) {
    let n = pairs.clone().count();
    let sse: f64 = pairs.clone().map(|(m, y)| (m - y) * (m - y)).sum();
    let mean_y = pairs.clone().map(|(_, y)| y).sum::<f64>() / n as f64;
    let sst: f64 = pairs
        .clone()
        .map(|(_, y)| (y - mean_y) * (y - mean_y))
        .sum();
    let peak = pairs.fold(0.0_f64, |m, (_, y)| m.max(y.abs()));
    let r2 = if sst > 0.0 { 1.0 - sse / sst } else { f64::NAN };
    (n, (sse / n as f64).sqrt(), peak, r2)
}

/// One tested pressure's sweeps, already collapsed ([`collapse_group`]): what a caller keeps in
/// memory between the per-pressure fits and the MF 6.1 fit instead of every sample.
#[derive(Clone, Debug, PartialEq)]
pub struct CollapsedGroup {
    /// Nominal pressure of the group, kPa.
    pub pressure_kpa_nom: i64,
    /// Its collapsed points.
    pub points: Vec<Point>,
    /// Its PAC2002 fit and spring-rate results (`None`: the group's PAC2002 fit failed).
    pub pac2002: Option<Pac2002AtPressure>,
}

/// Collapse one tested pressure's sweeps (as [`fit`] does).
pub fn collapse_group(sweeps: &[Mf61Sweep], cfg: &CollapseConfig) -> Vec<Point> {
    data::collapse(&[sweeps], cfg)
}

/// Fit one (tire, rim) from its sweeps.
pub fn fit(input: &Mf61Input, cfg: &Mf61Config) -> Result<Mf61Fit, Mf61Error> {
    let groups: Vec<CollapsedGroup> = input
        .groups
        .iter()
        .map(|g| CollapsedGroup {
            pressure_kpa_nom: g.pressure_kpa_nom,
            points: collapse_group(&g.sweeps, &cfg.collapse),
            pac2002: g.pac2002.clone(),
        })
        .collect();
    fit_collapsed(&input.tire, input.rim_in, input.nominal_pa, &groups, cfg)
}

/// Fit one (tire, rim) from its tested pressures' collapsed points.
pub fn fit_collapsed(
    tire: &str,
    rim_in: f64,
    nominal_pa: f64,
    collapsed: &[CollapsedGroup],
    cfg: &Mf61Config,
) -> Result<Mf61Fit, Mf61Error> {
    let started = Instant::now();
    if !(nominal_pa.is_finite() && nominal_pa > 0.0) {
        return Err(Mf61Error::BadNominal {
            tire: tire.to_string(),
            value: nominal_pa,
        });
    }
    let mut groups: Vec<&CollapsedGroup> = collapsed.iter().collect();
    groups.sort_by_key(|g| g.pressure_kpa_nom);
    if groups.iter().all(|g| g.pac2002.is_none()) {
        return Err(Mf61Error::NoStart {
            tire: tire.to_string(),
            rim_in,
        });
    }
    let mut points = Vec::new();
    let mut sweep_offset = 0;
    for (g, group) in groups.iter().enumerate() {
        let n_sweeps = group.points.iter().map(|p| p.sweep + 1).max().unwrap_or(0);
        points.extend(group.points.iter().map(|p| Point {
            group: g,
            sweep: p.sweep + sweep_offset,
            ..*p
        }));
        sweep_offset += n_sweeps;
    }
    let range_of = |gs: &[usize]| {
        let ps: Vec<f64> = points
            .iter()
            .filter(|p| gs.contains(&p.group))
            .map(|p| p.p_pa)
            .collect();
        let lo = ps.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ps.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if lo.is_finite() && hi.is_finite() {
            (lo, hi)
        } else {
            (PRESMIN.default_value(), PRESMAX.default_value())
        }
    };
    let models_of = |skip: Option<usize>| -> Vec<Pac2002AtPressure> {
        groups
            .iter()
            .enumerate()
            .filter(|(g, _)| Some(*g) != skip)
            .filter_map(|(_, g)| g.pac2002.clone())
            .collect()
    };
    let all: Vec<usize> = (0..groups.len()).collect();
    let with_start: Vec<&CollapsedGroup> = groups
        .iter()
        .copied()
        .filter(|g| g.pac2002.is_some())
        .collect();
    let start_reference_kpa =
        with_start[initial::reference(&models_of(None), nominal_pa)].pressure_kpa_nom;
    let full = fit_points(&models_of(None), &points, nominal_pa, range_of(&all), cfg);
    let mut quality = Vec::new();
    for (g, group) in groups.iter().enumerate() {
        for (o, n, rmse, peak, r2) in group_quality(&full.model, &points, g) {
            quality.push(PressureQuality {
                pressure_kpa_nom: group.pressure_kpa_nom,
                output: o,
                n,
                rmse,
                rmse_pct_of_peak: 100.0 * rmse / peak.max(1e-9),
                r2,
                lopo_rmse: None,
                lopo_rmse_pct_of_peak: None,
            });
        }
    }
    let mut family_quality = Vec::new();
    for (g, group) in groups.iter().enumerate() {
        for (family, n, rmse, peak, r2) in group_family_quality(&full.model, &points, g) {
            family_quality.push(FamilyQuality {
                pressure_kpa_nom: group.pressure_kpa_nom,
                family,
                n,
                rmse,
                rmse_pct_of_peak: 100.0 * rmse / peak.max(1e-9),
                r2,
                oos_rmse: None,
                oos_folds: 0,
                oos_n: 0,
                oos_deficient_folds: 0,
                lopo_rmse: None,
            });
        }
    }
    let kfold_started = Instant::now();
    let mut kfold_evaluations = 0;
    if cfg.kfold >= 2 {
        // The written Mz0 coefficients are the joint Mz step's when it was kept.
        let mz_sets_mz0 = full
            .families
            .iter()
            .any(|f| f.family == Family::Mz && f.accepted);
        // The families' checks are independent: run them on the pool, merge in family order.
        let checks: Vec<(Family, &[Family], out_of_sample::KFold)> = full
            .families
            .par_iter()
            .filter_map(|outcome| {
                let also: &[Family] = match outcome.family {
                    Family::Mz0 if mz_sets_mz0 => return None,
                    Family::Mz => &[Family::Mz0],
                    _ => &[],
                };
                out_of_sample::k_fold(&full.model, &points, outcome, also, cfg)
                    .map(|kf| (outcome.family, also, kf))
            })
            .collect();
        for (scored, also, kf) in checks {
            kfold_evaluations += kf.evaluations;
            for ((family, g), group) in [scored]
                .iter()
                .chain(also)
                .flat_map(|f| groups.iter().enumerate().map(move |(g, x)| ((*f, g), x)))
            {
                let Some((rmse, n)) = kf.rmse_at(family, g) else {
                    continue;
                };
                if let Some(q) = family_quality
                    .iter_mut()
                    .find(|q| q.pressure_kpa_nom == group.pressure_kpa_nom && q.family == family)
                {
                    q.oos_rmse = Some(rmse);
                    q.oos_folds = kf.folds;
                    q.oos_n = n;
                    q.oos_deficient_folds = kf.deficient_folds;
                }
            }
        }
    }
    let kfold_seconds = kfold_started.elapsed().as_secs_f64();
    let mut notes = full.notes.clone();
    notes.extend(pressure_order_notes(&groups, &points, &full.model));
    notes.push(format!(
        "My not fitted: TTC records no rolling resistance moment; QSY1..QSY8 are the PAC2002 \
         start's placeholder (QSY1 = {}{})",
        full.model.coefs[QSY1],
        if full.model.coefs[QSY1] == 0.0 {
            ": My = 0, no moment claimed"
        } else {
            ", not measured"
        }
    ));
    // Leaving one of two pressures out would fit the pressure terms from one pressure: not a
    // test of the model, so only with three or more.
    if cfg.leave_one_pressure_out && groups.len() >= 3 {
        // Each left-out pressure is a whole fit of its own: run them on the pool, apply in
        // pressure order.
        let check = Mf61Config {
            ftol: cfg.ftol.max(CHECK_FTOL),
            ..*cfg
        };
        let held_out: Vec<(usize, Fitted)> = (0..groups.len())
            .into_par_iter()
            .filter_map(|g| {
                let models = models_of(Some(g));
                if models.is_empty() {
                    return None;
                }
                let training: Vec<Point> =
                    points.iter().filter(|p| p.group != g).copied().collect();
                let rest: Vec<usize> = all.iter().copied().filter(|x| *x != g).collect();
                // The left-out pressure must be evaluated as such, not clipped to the others'
                // range.
                let mut held = fit_points(&models, &training, nominal_pa, range_of(&rest), &check);
                held.model.coefs[PRESMIN] = PRESMIN.default_value();
                held.model.coefs[PRESMAX] = PRESMAX.default_value();
                Some((g, held))
            })
            .collect();
        for (g, held) in held_out {
            let group = groups[g];
            for (o, _, rmse, peak, _) in group_quality(&held.model, &points, g) {
                if let Some(q) = quality
                    .iter_mut()
                    .find(|q| q.pressure_kpa_nom == group.pressure_kpa_nom && q.output == o)
                {
                    q.lopo_rmse = Some(rmse);
                    q.lopo_rmse_pct_of_peak = Some(100.0 * rmse / peak.max(1e-9));
                }
            }
            for (family, _, rmse, _, _) in group_family_quality(&held.model, &points, g) {
                if let Some(q) = family_quality
                    .iter_mut()
                    .find(|q| q.pressure_kpa_nom == group.pressure_kpa_nom && q.family == family)
                {
                    q.lopo_rmse = Some(rmse);
                }
            }
        }
    } else if groups.len() < 2 {
        notes.push(
            "one tested pressure: no pressure terms (all 0) and no leave-one-pressure-out check"
                .to_string(),
        );
    }
    let coefficients = coefficient_list(&full);
    Ok(Mf61Fit {
        evaluations: full.families.iter().map(|f| f.evaluations).sum(),
        kfold_evaluations,
        kfold_seconds,
        model: full.model,
        coefficients,
        quality,
        family_quality,
        families: full.families,
        notes,
        seconds: started.elapsed().as_secs_f64(),
        start_reference_kpa,
    })
}

/// How far beyond both neighbouring tested pressures a pressure's friction or slip stiffness
/// must lie to be noted: a margin for the per-pressure fits' own uncertainty.
pub const PRESSURE_ORDER_MARGIN: f64 = 0.03;

/// Notes on tested pressures whose per-pressure (PAC2002) peak friction or slip stiffness,
/// evaluated at `model`'s `FNOMIN` and zero inclination, lies more than
/// [`PRESSURE_ORDER_MARGIN`] above or below both neighbouring tested pressures (`Fx0`: `mu_x`,
/// `Kxk`; `Fy0`: `mu_y`, `Kya`; only pressures with the family's sweeps). Such a pressure is
/// either an optimum of the tire between the tested pressures or a block of sweeps that differs
/// from the others by more than pressure (run order, tread temperature, wear): the tested
/// pressures cannot tell these apart, the quadratic pressure terms bend through it, and a fit
/// without it (the leave-one-pressure-out check) cannot predict it.
fn pressure_order_notes(
    groups: &[&CollapsedGroup],
    points: &[Point],
    model: &MagicFormula,
) -> Vec<String> {
    let pure = PureData::of(points);
    let mut notes = Vec::new();
    for family in [Family::Fx0, Family::Fy0] {
        let with_data = if family == Family::Fx0 {
            &pure.longitudinal
        } else {
            &pure.lateral
        };
        // (kPa, |mu|, |K|) per pressure with the family's data and a PAC2002 fit, in order.
        let levels: Vec<(i64, f64, f64)> = groups
            .iter()
            .enumerate()
            .filter(|(g, _)| with_data.contains(g))
            .filter_map(|(_, g)| {
                let pac = g.pac2002.as_ref()?;
                let input = SlipInput {
                    fz_n: model.coefs[FNOMIN],
                    kappa: 0.0,
                    alpha_rad: 0.0,
                    gamma_rad: 0.0,
                    vx_mps: model.coefs[LONGVL],
                };
                let l = load_with(
                    &pac.model.coefs,
                    &input,
                    FIT_MODE,
                    pac.model.version,
                    pac.p_pa,
                );
                let f = slip_factors(&pac.model.coefs, &l);
                let (mu, k) = if family == Family::Fx0 {
                    (f.mux, f.kxk_n)
                } else {
                    (f.muy, f.kya_n_per_rad)
                };
                (mu.is_finite() && k.is_finite()).then_some((g.pressure_kpa_nom, mu.abs(), k.abs()))
            })
            .collect();
        for w in levels.windows(3) {
            let [lo, mid, hi] = [w[0], w[1], w[2]];
            let out_of_order = |v: fn(&(i64, f64, f64)) -> f64| {
                let (a, b, m) = (v(&lo), v(&hi), v(&mid));
                if m > a.max(b) * (1.0 + PRESSURE_ORDER_MARGIN) {
                    Some("above")
                } else if m < a.min(b) * (1.0 - PRESSURE_ORDER_MARGIN) {
                    Some("below")
                } else {
                    None
                }
            };
            let (mu_name, k_name) = if family == Family::Fx0 {
                ("mu_x", "Kxk")
            } else {
                ("mu_y", "Kya")
            };
            let found: Vec<String> = [
                (mu_name, out_of_order(|x| x.1), lo.1, mid.1, hi.1),
                (k_name, out_of_order(|x| x.2), lo.2, mid.2, hi.2),
            ]
            .iter()
            .filter_map(|(name, side, a, m, b)| {
                let v = |x: &f64| {
                    if *x < 100.0 {
                        format!("{x:.3}")
                    } else {
                        format!("{x:.0}")
                    }
                };
                side.map(|side| format!("{name} {} {side} {} / {}", v(m), v(a), v(b)))
            })
            .collect();
            if !found.is_empty() {
                notes.push(format!(
                    "{}: at {} kPa the per-pressure fit's {} at {} / {} kPa (at FNOMIN, zero \
                     inclination): not in pressure order. Either the tire peaks between the \
                     tested pressures or that pressure's sweeps differ from the others by more \
                     than pressure (run order, tread temperature, wear); the tested pressures \
                     cannot tell these apart, the pressure terms bend through it, and a fit \
                     without it cannot predict it",
                    family.as_str(),
                    mid.0,
                    found.join(", "),
                    lo.0,
                    hi.0
                ));
            }
        }
    }
    notes
}

/// The rolling resistance terms: never refined (TTC records no `My`), placeholders.
const ROLLING: [Coef; 8] = [QSY1, QSY2, QSY3, QSY4, QSY5, QSY6, QSY7, QSY8];

/// Every MF 6.1 coefficient with its origin.
fn coefficient_list(f: &Fitted) -> Vec<Mf61Coefficient> {
    Coef::ALL
        .iter()
        .filter(|c| c.carried_by(Version::Mf61))
        .map(|c| {
            let fitted = f.std_errors.iter().rev().find(|s| s.0 == *c);
            let held = f.held.iter().find(|h| h.0 == *c);
            Mf61Coefficient {
                coef: *c,
                family: fitted.map(|s| s.3).or(held.map(|h| h.1)),
                value: f.model.coefs[*c],
                std_error: fitted.and_then(|s| if s.2 { None } else { s.1 }),
                at_bound: fitted.is_some_and(|s| s.2),
                origin: match (fitted, held) {
                    (_, Some(_)) => "fixed",
                    (Some(_), None) => "fitted",
                    (None, None) if ROLLING.contains(c) => "placeholder",
                    (None, None) => "start",
                },
                note: held.map(|h| format!("held: {}", h.2)),
            }
        })
        .collect()
}
